"""Shared test fixtures, the per-notebook time budget, and how the suite runs in parallel.

Parallel runs (``make test`` runs pytest-xdist: ``-n $(TEST_JOBS) --dist loadgroup
--no-loadscope-reorder``; give the same two options to a ``pytest -n N`` of your own):

- Every test module (and every notebook) is one unit of work, kept on one worker, so a
  module-scoped fixture (a class graded once, a box started once) runs once. A test with its own
  ``@pytest.mark.xdist_group(name)`` is a unit of its own (for long, independent cases of one
  module that can spread over the workers).
- Units start longest first (the seconds each took in the last run, kept in pytest's cache;
  before any run, notebooks and modules marked ``slow`` first), so no long unit starts last.
- ``@pytest.mark.serial`` (or ``pytestmark = pytest.mark.serial`` for a whole module) runs a
  test alone: no other test of this run is running while it runs. Use it for a test that is
  timing-sensitive by nature (a 1 kHz loop with a success-rate threshold, a jitter comparison),
  one that loads the CPU on purpose (CpuLoad), or one that holds a machine-wide resource (a
  network namespace, a fixed port). Serial tests run last, one after another, on one worker; a
  reader/writer lock in this run's temporary folder makes the others wait. A notebook that
  starts chapter 1's ``CpuLoad`` is serial without a marker.

Serial is not a licence for a wall-clock assertion: every test must still pass with two busy
processes beside the suite (timings belong in benchmarks/).
"""

from __future__ import annotations

import fcntl
import os
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
_CACHE_KEY = "robocourse/unit_seconds"
# a notebook that starts chapter 1's CPU load runs alone (it loads the machine on purpose)
_SERIAL_NOTEBOOK_TEXT = "CpuLoad("


@pytest.fixture
def root() -> Path:
    return ROOT


def _unit(nodeid: str) -> str:
    """The unit of work a test belongs to: its xdist group when the id carries one (``...@group``,
    as a worker reports it), else its module or notebook."""
    tail = nodeid.split("::", 1)[-1]
    if "@" in tail and tail.rfind("@") > tail.rfind("]"):
        return tail.rsplit("@", 1)[1]
    return nodeid.split("::")[0]


def _item_unit(item) -> str:
    """An explicit ``@pytest.mark.xdist_group(name)`` makes its own unit (tests of one module that
    share no module fixture and may run on different workers); otherwise the module."""
    mark = item.get_closest_marker("xdist_group")
    if mark is not None:
        return str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
    return _unit(item.nodeid)


def _notebook_is_serial(path: Path, seen: dict = {}) -> bool:  # noqa: B006 - a per-process cache
    if path not in seen:
        try:
            seen[path] = _SERIAL_NOTEBOOK_TEXT in path.read_text(encoding="utf-8")
        except OSError:
            seen[path] = False
    return seen[path]


def pytest_itemcollected(item):
    """Notebook time limit, serial marks, one xdist group per module: set as each item is
    collected, so xdist's own collection hook (which turns groups into ids) sees them."""
    path = Path(str(getattr(item, "path", "")))
    if path.suffix == ".ipynb":
        # the safety-net limit for the whole notebook (nbmake's own is per cell)
        item.add_marker(pytest.mark.timeout(NOTEBOOK_TIMEOUT_S))
        if _notebook_is_serial(path):
            item.add_marker(pytest.mark.serial)
    if item.get_closest_marker("serial") is not None:
        # serial wins over any group of its own: one group runs every serial test
        item.own_markers[:] = [m for m in item.own_markers if m.name != "xdist_group"]
        item.add_marker(pytest.mark.xdist_group(SERIAL_GROUP))
    elif item.get_closest_marker("xdist_group") is None:
        item.add_marker(pytest.mark.xdist_group(_unit(item.nodeid)))


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Longest units first, serial tests last."""
    cache = getattr(config, "cache", None)
    seconds = cache.get(_CACHE_KEY, {}) if cache is not None else {}

    def guess(item) -> float:
        if str(getattr(item, "path", "")).endswith(".ipynb"):
            return 20.0
        return 10.0 if item.get_closest_marker("slow") else 1.0

    cost: dict[str, float] = {}
    first_seen: dict[str, int] = {}
    units = {}
    for i, item in enumerate(items):
        unit = units[item] = _item_unit(item)
        cost.setdefault(unit, seconds.get(unit, guess(item)))
        first_seen.setdefault(unit, i)
    # serial tests last; the rest by unit, longest first; order inside a unit kept
    items.sort(key=lambda it: (it.get_closest_marker("serial") is not None, -cost[units[it]],
                               first_seen[units[it]]))


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
        folder = Path(tempfile.gettempdir()) / f"robocourse-pytest-{workerinput['testrunuid']}"
        config._robocourse_lock = _RunLock(folder)
    config._robocourse_seconds = defaultdict(float)


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
        config._robocourse_seconds[_unit(report.nodeid)] += report.duration


def pytest_sessionfinish(session, exitstatus):
    """Remember how long each unit took (the next run starts the longest first)."""
    config = session.config
    if getattr(config, "workerinput", None) is not None or getattr(config, "cache", None) is None:
        return
    measured = config._robocourse_seconds
    if not measured:
        return
    known = dict(config.cache.get(_CACHE_KEY, {}))
    known.update({unit: round(s, 2) for unit, s in measured.items()})
    config.cache.set(_CACHE_KEY, known)
