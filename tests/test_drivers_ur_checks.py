"""Chapter 5's UR exercise check (ch05.ur_servo_loop), in-process: the reference earns every
sub-test, an answer that raises fails cleanly, and no box process is left behind either way.
The answer bank (wrong answers, one per stated property; another correct loop) is
tests/banks/ch05_ur.py, graded through the sandbox by tests/test_banks.py; the 20-run figures
come from benchmarks/ur_exercise_stability.py."""

from __future__ import annotations

import time
from pathlib import Path

import nbformat
import numpy as np
import psutil
import pytest

pytest.importorskip("rtde_control", reason="ur-rtde (Linux x86_64, CPython <= 3.12) is not installed")

from robocourse.grading import discover  # noqa: E402
from robocourse.grading.checks import get, run_check  # noqa: E402

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]
SOL = Path(__file__).resolve().parents[1] / "solutions/05_hardware_drivers_exercises.ipynb"


def run(fn, seed=0):
    discover()
    before = {p.pid for p in psutil.Process().children(recursive=True)}
    r = run_check(get("ch05.ur_servo_loop"), fn, rng=np.random.default_rng(seed))
    time.sleep(0.2)
    left = [p for p in psutil.Process().children(recursive=True) if p.pid not in before and p.is_running()
            and p.status() != psutil.STATUS_ZOMBIE]
    assert left == [], f"processes left behind: {left}"
    return r


def test_the_solution_earns_every_sub_test_and_leaves_nothing_running():
    ns: dict = {}
    exec(next(c for c in nbformat.read(SOL, as_version=4).cells if "def follow_path" in c.source).source, ns)
    r = run(ns["follow_path"])
    assert r.passed and r.points == r.weight == 5, r.message
    assert [s["points"] for s in r.subtests] == [1.5, 1.0, 0.5, 2.0]
    assert "the 1200 ms stall stopped the robot (watchdog, 2 Hz) and follow_path returned False" in r.message


def test_a_loop_that_raises_fails_cleanly_and_stops_the_box():
    def broken(rtde_c, rtde_r, path, duration):
        raise OSError("cable pulled")

    r = run(broken)
    assert not r.passed and r.points == 0 and "OSError: cable pulled" in r.message
