"""Shared test fixtures, the per-notebook time budget, and how the suite runs in parallel.

Parallel runs (``make test`` runs pytest-xdist: ``-n $(TEST_JOBS) --dist loadgroup``; a
``pytest -n N`` of your own is scheduled the same way, with or without ``--dist loadgroup``):

- Every test module (and every notebook) is one unit of work, kept on one worker, so a
  module-scoped fixture (a class graded once, a box started once) is built once. A test with its
  own ``@pytest.mark.xdist_group(name)`` is a unit of its own (for long, independent cases of one
  module that can spread over the workers).
- Units start longest first (the seconds their tests took in earlier runs here, kept in
  pytest's cache; in a clean clone, as CI's, the seconds of a full run committed in
  tests/unit_seconds.json; for tests never timed, notebooks and ``slow`` tests first), so no
  long unit starts last.
- ``@pytest.mark.early`` starts a test's unit before every unit without it (longest first among
  them): units that share something costly while they run go side by side. The loaded chapters
  share one ``CpuLoad`` (tests/test_chapters_under_load.py): run together at the start, its busy
  processes spin for about a third of the chapters' summed time, not for most of the run.
- ``@pytest.mark.serial`` (or ``pytestmark = pytest.mark.serial`` for a whole module) runs a
  test alone: no other test of this run is running while it runs. Use it for a test that is
  timing-sensitive by nature (a 1 kHz loop with a success-rate threshold, a jitter comparison),
  one that loads the CPU on purpose (CpuLoad), or one that holds a machine-wide resource (a
  network namespace, a fixed port). Serial tests form one unit that runs last, on one worker; a
  reader/writer lock in this run's temporary folder makes the others wait. A notebook that
  starts chapter 1's ``CpuLoad`` is serial without a marker. Mark a whole module serial rather
  than some of its tests when they share a module fixture (the serial unit would build it again).

How: the units are decided on the workers, where the markers are (``pytest_collection_finish``
writes ``{nodeid: unit}`` to this run's folder before the worker reports its collection), and a
scheduler of our own (``pytest_xdist_make_scheduler``, a LoadScopeScheduling keyed by that map)
hands out whole units. xdist's own ``loadgroup`` is not used: it appends ``@group`` to
``item._nodeid``, which pytest 9.2 no longer reads (node ids became structured), so every group
silently fell apart (pytest-xdist issue 1386, pytest 9.2 with xdist 3.8). ``--dist loadscope``,
``loadfile``, ``each`` and ``worksteal`` are left to xdist; the serial lock holds under every mode.

Serial is not a licence for a wall-clock assertion: every test must still pass with two busy
processes beside the suite (timings belong in benchmarks/).
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import tempfile
from collections import defaultdict
from contextlib import contextmanager
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: A notebook executed by nbmake is stopped after this long. A safety net, not the budget: the goal
#: is 60 s headless on a quiet machine, measured by benchmarks/notebook_times.py (issue 25: a
#: loaded machine made a 60 s test timeout fail a clean clone's CI for no fault of the course).
NOTEBOOK_TIMEOUT_S = 240

SERIAL_GROUP = "serial"
#: pytest's cache: {test id: [unit, seconds]} of every test that ran here (a partial run updates
#: only the tests it ran), and {unit: seconds} summed from it
_CACHE_KEY, _CACHE_UNITS = "robocourse/test_seconds", "robocourse/unit_seconds"
#: a clean clone's schedule (CI): {unit: seconds} of a full run, committed; refresh it after the
#: suite changed a lot with ``cp .pytest_cache/v/robocourse/unit_seconds tests/unit_seconds.json``
_FALLBACK = Path(__file__).resolve().parent / "unit_seconds.json"
# a notebook that starts chapter 1's CPU load runs alone (it loads the machine on purpose)
_SERIAL_NOTEBOOK_TEXT = "CpuLoad("
# the dist modes our scheduler takes over (xdist's default for -n N is "load")
_OUR_DIST_MODES = ("load", "loadgroup")
#: {nodeid: unit} of this run, as far as this process knows it (collection or the workers' maps)
_UNITS: dict[str, str] = {}


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture(autouse=True)
def _scheduling_given_back():
    """Every test leaves this worker's scheduling as it found it. libfranka's Robot() (pylibfranka)
    raises the constructing thread to SCHED_FIFO 99 as root and keeps it there (upstream
    behaviour, tests/test_drivers_scheduling.py); a worker left at 99 would run every later test
    ahead of the boxes and the kernel's own threads on its CPU."""
    from robocourse.rt import settings

    with settings.scheduling_kept():
        yield


def _run_folder(testrunuid: str) -> Path:
    """This run's shared folder: the serial lock and each worker's unit map."""
    return Path(tempfile.gettempdir()) / f"robocourse-pytest-{testrunuid}"


@pytest.fixture(scope="session")
def run_folder(request, tmp_path_factory) -> Path:
    """A folder every xdist worker of this run shares (the controller removes it at the end); in a run
    without workers, one of this process's own."""
    workerinput = getattr(request.config, "workerinput", None)
    if workerinput is None:
        return tmp_path_factory.mktemp("run")
    folder = _run_folder(workerinput["testrunuid"])
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _unit(nodeid: str) -> str:
    """The unit of a test id: the one its collection decided, else its module or notebook (or the
    ``@group`` suffix an older xdist ``loadgroup`` puts on the id)."""
    known = _UNITS.get(nodeid)
    if known is not None:
        return known
    tail = nodeid.split("::", 1)[-1]
    if "@" in tail and tail.rfind("@") > tail.rfind("]"):
        return tail.rsplit("@", 1)[1]
    return nodeid.split("::")[0]


def _item_unit(item) -> str:
    """Serial tests share one unit; an explicit ``@pytest.mark.xdist_group(name)`` makes its own
    unit (tests of one module that share no module fixture and may run on different workers);
    otherwise the module or notebook."""
    if item.get_closest_marker("serial") is not None:
        return SERIAL_GROUP
    mark = item.get_closest_marker("xdist_group")
    if mark is not None:
        return str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
    return item.nodeid.split("::")[0]


def _notebook_is_serial(path: Path, seen: dict = {}) -> bool:  # noqa: B006 - a per-process cache
    if path not in seen:
        try:
            seen[path] = _SERIAL_NOTEBOOK_TEXT in path.read_text(encoding="utf-8")
        except OSError:
            seen[path] = False
    return seen[path]


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Notebook time limit and serial marks (here, not in ``pytest_itemcollected``: that hook only
    reaches this conftest for items under tests/, and the notebooks of testpaths live elsewhere);
    then longest units first, serial tests last."""
    for item in items:
        path = Path(str(getattr(item, "path", "")))
        if path.suffix == ".ipynb":
            # the safety-net limit for the whole notebook (nbmake's own is per cell)
            item.add_marker(pytest.mark.timeout(NOTEBOOK_TIMEOUT_S))
            if _notebook_is_serial(path):
                item.add_marker(pytest.mark.serial)

    cache = getattr(config, "cache", None)
    seconds = cache.get(_CACHE_KEY, {}) if cache is not None else {}
    try:
        fallback = json.loads(_FALLBACK.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        fallback = {}

    def guess(item) -> float:
        if str(getattr(item, "path", "")).endswith(".ipynb"):
            return 20.0
        return 10.0 if item.get_closest_marker("slow") else 0.5

    # a unit costs what its tests took here (a guess for the ones never run here); a unit none
    # of whose tests ran here yet costs what the committed fallback says, else the guesses
    known: dict[str, float] = defaultdict(float)
    guessed: dict[str, float] = defaultdict(float)
    first_seen: dict[str, int] = {}
    early: set[str] = set()
    units = {}
    for i, item in enumerate(items):
        unit = units[item] = _item_unit(item)
        first_seen.setdefault(unit, i)
        if item.get_closest_marker("early") is not None:
            early.add(unit)
        entry = seconds.get(item.nodeid)
        if isinstance(entry, list) and len(entry) == 2:
            known[unit] += float(entry[1])
        else:
            guessed[unit] += guess(item)
    cost = {unit: known[unit] + guessed[unit] if unit in known else fallback.get(unit, guessed[unit])
            for unit in first_seen}
    # serial tests last; the early units first; the rest by unit, longest first; order inside a unit kept
    items.sort(key=lambda it: (units[it] == SERIAL_GROUP, units[it] not in early, -cost[units[it]],
                               first_seen[units[it]]))


@pytest.hookimpl(tryfirst=True)
def pytest_collection_finish(session):
    """Record each test's unit (ids final now); a worker writes its map for the scheduler before
    it reports its collection (xdist sends that report from its own, later, implementation)."""
    units = {item.nodeid: _item_unit(item) for item in session.items}
    _UNITS.update(units)
    workerinput = getattr(session.config, "workerinput", None)
    if workerinput is None:
        return
    folder = _run_folder(workerinput["testrunuid"])
    folder.mkdir(parents=True, exist_ok=True)
    final = folder / f"units-{workerinput['workerid']}.json"
    partial = final.with_suffix(".part")
    partial.write_text(json.dumps(units), encoding="utf-8")
    os.replace(partial, final)


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_make_scheduler(config, log):
    """Whole units to one worker each, in collection order (longest first, serial last)."""
    if config.getvalue("dist") not in _OUR_DIST_MODES:
        return None
    from xdist.scheduler import LoadScopeScheduling

    class UnitScheduling(LoadScopeScheduling):
        """xdist's LoadScopeScheduling with the scope of a test read from the workers' unit maps."""

        def __init__(self, config, log=None):
            super().__init__(config, log)
            # our collection order is the schedule; xdist's reorder (most tests first) would undo it
            config.option.loadscopereorder = False

        def add_node_collection(self, node, collection):
            folder = _run_folder(node.workerinput["testrunuid"])
            config._robocourse_run_folder = folder
            path = folder / f"units-{node.workerinput['workerid']}.json"
            try:
                _UNITS.update(json.loads(path.read_text(encoding="utf-8")))
            except (OSError, ValueError) as exc:
                # the module stays the unit (_unit's fallback); say why serial tests may spread
                self.log(f"no unit map from {node.gateway.id} ({exc}); modules are the units")
            super().add_node_collection(node, collection)

        def _split_scope(self, nodeid: str) -> str:
            return _unit(nodeid)

    return UnitScheduling(config, log)


# -- the serial group: a reader/writer lock shared by this run's workers ---------------------------

class _RunLock:
    """Readers (ordinary tests) share it; a writer (a serial test) has it alone.

    A writer first takes the gate, so no new reader starts while it waits for the running ones
    (writer preference: a serial test is never starved by a stream of short ones).
    """

    def __init__(self, folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        self._gate = os.open(folder / "gate.lock", os.O_RDWR | os.O_CREAT, 0o600)
        self._run = os.open(folder / "run.lock", os.O_RDWR | os.O_CREAT, 0o600)

    @contextmanager
    def hold(self, exclusive: bool):
        fcntl.flock(self._gate, fcntl.LOCK_EX)
        try:
            fcntl.flock(self._run, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        finally:
            if not exclusive:
                fcntl.flock(self._gate, fcntl.LOCK_UN)
        try:
            yield
        finally:
            fcntl.flock(self._run, fcntl.LOCK_UN)
            if exclusive:
                fcntl.flock(self._gate, fcntl.LOCK_UN)


def pytest_configure(config):
    workerinput = getattr(config, "workerinput", None)
    config._robocourse_lock = None
    if workerinput is not None:      # an xdist worker: share a lock with this run's other workers
        config._robocourse_lock = _RunLock(_run_folder(workerinput["testrunuid"]))
    config._robocourse_seconds = defaultdict(float)
    config._robocourse_run_folder = None


def pytest_unconfigure(config):
    """The controller removes this run's folder (locks and unit maps) once its workers are gone."""
    folder = getattr(config, "_robocourse_run_folder", None)
    if folder is not None and getattr(config, "workerinput", None) is None:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_runtest_protocol(item, nextitem):
    """Outermost wrapper (around setup, call, teardown and pytest-timeout's timer): wait for the lock."""
    lock = item.config._robocourse_lock
    if lock is None:
        yield
        return
    with lock.hold(exclusive=item.get_closest_marker("serial") is not None):
        yield


_CONFIG: dict = {}


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    _CONFIG["config"] = session.config


def pytest_runtest_logreport(report):
    """Add up the seconds of each unit (under xdist the controller sees every worker's reports)."""
    config = _CONFIG.get("config")
    if config is not None:
        config._robocourse_seconds[report.nodeid] += report.duration


def pytest_sessionfinish(session, exitstatus):
    """Remember how long each test took (the next run starts the longest units first)."""
    config = session.config
    if getattr(config, "workerinput", None) is not None or getattr(config, "cache", None) is None:
        return
    measured = config._robocourse_seconds
    if not measured:
        return
    known = {k: v for k, v in config.cache.get(_CACHE_KEY, {}).items() if isinstance(v, list)}
    known.update({nodeid: [_unit(nodeid), round(s, 3)] for nodeid, s in measured.items()})
    config.cache.set(_CACHE_KEY, known)
    per_unit: dict[str, float] = defaultdict(float)
    for unit, s in known.values():
        per_unit[unit] += s
    config.cache.set(_CACHE_UNITS, {unit: round(s, 1) for unit, s in sorted(per_unit.items())})


@pytest.fixture
def progress_updates(monkeypatch):
    """What ``robocourse.notebook.progress`` draws in a kernel: each object it updates its line with, in order."""
    import IPython.display

    from robocourse.notebook import progress_line

    updates = []

    class Handle:
        def update(self, obj, raw=False):
            updates.append(obj)

    monkeypatch.setattr(progress_line, "_in_kernel", lambda: True)
    monkeypatch.setattr(IPython.display, "display", lambda obj, raw=False, display_id=False: Handle())
    return updates


@pytest.fixture
def zenoh_pair():
    """Two zenoh contexts (two sessions, as two processes would have) joined by a zenoh router
    on a free loopback port; shut down after the test."""
    from robocourse.bus.context import Context
    from robocourse.bus.zenoh.processes import free_router

    r, ep = free_router()
    a = Context(transport="zenoh", connect=[ep])
    b = Context(transport="zenoh", connect=[ep])
    yield a, b
    a.try_shutdown()
    b.try_shutdown()
    r.close()
