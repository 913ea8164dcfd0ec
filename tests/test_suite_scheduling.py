"""How the suite runs in parallel (tests/conftest.py), checked on a small scratch suite.

A scratch project gets a copy of tests/conftest.py and modules that log each module fixture's
set-up and the worker each test ran on, then runs under ``pytest -n 2 --dist loadgroup`` (what
``make test`` runs) and under plain pytest without xdist. The properties are the ones the suite
relies on: a module fixture is built once per run, every explicit ``xdist_group`` stays on one
worker, and a serial test never runs beside another test. (pytest 9.2 with pytest-xdist 3.8
broke xdist's own loadgroup silently: every property here failed, and nothing else noticed.)
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

HERE = Path(__file__).resolve().parent

_INI = """[pytest]
testpaths = tests
markers =
    early: first
    serial: alone
    slow: slow
    xdist_group(name): group
"""

# each test logs "<worker> <what> <name>"; a running test leaves a file in running/ so the serial
# tests can see who else is running (the lock must make that set empty around them)
_COMMON = '''
import os, time
from pathlib import Path
import pytest
LOG = Path(os.environ["SCHED_LOG"])
RUNNING = Path(os.environ["SCHED_RUNNING"])
WORKER = os.environ.get("PYTEST_XDIST_WORKER", "main")

def log(what, name):
    with LOG.open("a") as f:
        f.write(f"{WORKER} {what} {name}\\n")

def run(kind, name, seconds):
    mine = RUNNING / f"{kind}-{WORKER}-{name}"
    mine.touch()
    try:
        others = sorted(p.name for p in RUNNING.iterdir() if p != mine)
        time.sleep(seconds)
        others += sorted(p.name for p in RUNNING.iterdir() if p != mine)
    finally:
        mine.unlink()
    log(kind, name)
    if kind == "serial":
        assert not others, f"serial test {name} ran beside {others}"
    else:
        assert not [o for o in others if o.startswith("serial-")], f"{name} ran beside {others}"
'''

_MODULE = '''
@pytest.fixture(scope="module")
def costly():
    log("fixture", "{name}")

@pytest.mark.parametrize("i", range(4))
def test_unit(costly, i):
    run("parallel", "{name}-" + str(i), 0.05)
'''

_SERIAL = _COMMON + '''
pytestmark = pytest.mark.serial

@pytest.fixture(scope="module")
def costly():
    log("fixture", "serial")

@pytest.mark.parametrize("i", range(3))
def test_alone(costly, i):
    run("serial", "s-" + str(i), 0.2)
'''

_GROUPS = _COMMON + '''
@pytest.mark.parametrize("g", [pytest.param(g, marks=pytest.mark.xdist_group(g)) for g in ("g1", "g2")])
@pytest.mark.parametrize("i", range(3))
def test_grouped(g, i):
    run("parallel", g + "-" + str(i), 0.05)
    log("group", g)
'''


def _run_scratch(tmp_path: Path, *args: str) -> list[list[str]]:
    project = tmp_path / "scratch"
    (project / "tests").mkdir(parents=True)
    (project / "pytest.ini").write_text(_INI)
    shutil.copy(HERE / "conftest.py", project / "tests" / "conftest.py")
    for name in "abc":
        (project / "tests" / f"test_mod_{name}.py").write_text(_COMMON + _MODULE.replace("{name}", name))
    (project / "tests" / "test_serial.py").write_text(_SERIAL)
    (project / "tests" / "test_groups.py").write_text(_GROUPS)
    running = tmp_path / "running"
    running.mkdir()
    log = tmp_path / "log.txt"
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTEST_XDIST_", "PYTEST_CURRENT_TEST", "PYTEST_ADDOPTS"))}
    # only the plugin under test: the suite's others (nbmake's imports alone take seconds per
    # process, and an xdist run starts three) are not what this checks
    env.update(SCHED_LOG=str(log), SCHED_RUNNING=str(running), PYTEST_DISABLE_PLUGIN_AUTOLOAD="1")
    plugins = ["-p", "xdist.plugin", "-p", "xdist.looponfail"] if "-n" in args else []
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *plugins, *args],
                          cwd=project, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "21 passed" in done.stdout, done.stdout[-2000:]
    return [line.split() for line in log.read_text().splitlines()]


def _check(rows: list[list[str]]) -> None:
    fixtures = Counter(name for _, what, name in rows if what == "fixture")
    assert fixtures == {"a": 1, "b": 1, "c": 1, "serial": 1}
    workers = defaultdict(set)
    for worker, what, name in rows:
        if what == "group":
            workers[name].add(worker)
        elif what == "serial":
            workers["serial"].add(worker)
    assert {g: len(w) for g, w in workers.items()} == {"g1": 1, "g2": 1, "serial": 1}


def test_two_workers_build_each_module_fixture_once_and_run_serial_tests_alone(tmp_path):
    rows = _run_scratch(tmp_path, "-n", "2", "--dist", "loadgroup")
    _check(rows)
    # both workers got work (a scheduler that put everything on one worker would pass _check)
    assert len({worker for worker, what, _ in rows if what == "parallel"}) == 2


def test_plain_pytest_without_xdist_runs_the_same_suite(tmp_path):
    _check(_run_scratch(tmp_path, "-p", "no:xdist"))


def test_a_clean_clone_orders_units_by_the_committed_seconds_and_the_cache_wins_after_a_run(tmp_path):
    """Without pytest's cache (a clean clone, CI) the committed tests/unit_seconds.json sets the
    order, longest unit first, serial tests last; after a run the seconds measured here win."""
    project = tmp_path / "scratch"
    (project / "tests").mkdir(parents=True)
    (project / "pytest.ini").write_text(_INI)
    shutil.copy(HERE / "conftest.py", project / "tests" / "conftest.py")
    for name in "bc":
        (project / "tests" / f"test_mod_{name}.py").write_text("def test_one():\n    pass\n")
    # a takes longer than c and b together, whatever the load (a no-op took more than a fixed 0.3 s once on a
    # loaded machine): its module is imported at collection, before any test runs, and its test sleeps at least
    # as long as everything since then (c and b run first, in the committed order)
    (project / "tests" / "test_mod_a.py").write_text(
        "import time\n\nCOLLECTED = time.monotonic()\n\n\ndef test_one():\n"
        "    time.sleep(max(0.3, 2 * (time.monotonic() - COLLECTED)))\n")
    (project / "tests" / "test_serial.py").write_text(
        "import pytest\npytestmark = pytest.mark.serial\n\ndef test_alone():\n    pass\n")
    (project / "tests" / "unit_seconds.json").write_text(
        '{"tests/test_mod_a.py": 1, "tests/test_mod_b.py": 5, "tests/test_mod_c.py": 30, "serial": 99}')
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTEST_XDIST_", "PYTEST_CURRENT_TEST", "PYTEST_ADDOPTS"))}
    env["PYTEST_DISABLE_PLUGIN_AUTOLOAD"] = "1"

    def order(*args):
        done = subprocess.run([sys.executable, "-m", "pytest", "-q", *args], cwd=project, env=env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        return [line.split("::")[0].rsplit("/", 1)[-1] for line in done.stdout.splitlines() if "::" in line]

    first = ["test_mod_c.py", "test_mod_b.py", "test_mod_a.py", "test_serial.py"]
    assert order("--collect-only") == first
    order()                                     # a run: a took longer than b and c here
    after = order("--collect-only")
    assert after[0] == "test_mod_a.py" and after[-1] == "test_serial.py", after


def test_early_units_start_first_longest_first_among_them_and_serial_tests_stay_last(tmp_path):
    project = tmp_path / "scratch"
    (project / "tests").mkdir(parents=True)
    (project / "pytest.ini").write_text(_INI)
    shutil.copy(HERE / "conftest.py", project / "tests" / "conftest.py")
    for name, mark in (("a", ""), ("c", ""), ("e1", "early"), ("e2", "early"), ("s", "serial")):
        head = f"import pytest\npytestmark = pytest.mark.{mark}\n\n" if mark else ""
        (project / "tests" / f"test_mod_{name}.py").write_text(head + "def test_one():\n    pass\n")
    (project / "tests" / "unit_seconds.json").write_text(
        '{"tests/test_mod_a.py": 1, "tests/test_mod_c.py": 30, "tests/test_mod_e1.py": 0.5, '
        '"tests/test_mod_e2.py": 2, "serial": 99}')
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTEST_XDIST_", "PYTEST_CURRENT_TEST", "PYTEST_ADDOPTS"))}
    env["PYTEST_DISABLE_PLUGIN_AUTOLOAD"] = "1"
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--collect-only"],
                          cwd=project, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    order = [line.split("::")[0].rsplit("/", 1)[-1] for line in done.stdout.splitlines() if "::" in line]
    assert order == ["test_mod_e2.py", "test_mod_e1.py", "test_mod_c.py", "test_mod_a.py", "test_mod_s.py"], order
