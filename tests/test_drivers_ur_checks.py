"""Chapter 5's UR exercise check (ch05.ur_servo_loop) against a UR-style box through ur_rtde: the
solution and a differently written correct loop score full; a bank of plausible wrong answers,
one per stated property, scores zero; no box process is left behind.

The 20-run stability figures (reference under chapter 1's CPU load, stalled loop) come from
``benchmarks/ur_exercise_stability.py`` (too slow for every CI run)."""

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


@pytest.fixture(scope="module")
def solution():
    discover()
    ns: dict = {}
    cell = next(c for c in nbformat.read(SOL, as_version=4).cells if "def follow_path" in c.source)
    exec(cell.source, ns)
    return ns["follow_path"]


def run(fn, seed=0):
    before = {p.pid for p in psutil.Process().children(recursive=True)}
    r = run_check(get("ch05.ur_servo_loop"), fn, rng=np.random.default_rng(seed))
    time.sleep(0.2)
    left = [p for p in psutil.Process().children(recursive=True) if p.pid not in before and p.is_running()
            and p.status() != psutil.STATUS_ZOMBIE]
    assert left == [], f"processes left behind: {left}"
    return r


def loop(watchdog=5.0, clock="wall", lookahead=0.03, pace=True, period=0.002, check_result=True, stop=True,
         stall_after=None):
    """A follow_path built from choices: the solution is loop(); each wrong answer changes one."""

    def follow_path(rtde_c, rtde_r, path, duration):
        if watchdog:
            rtde_c.setWatchdog(watchdog)
        t0 = time.monotonic()
        k = 0
        while True:
            t_cycle = rtde_c.initPeriod()
            t = time.monotonic() - t0 if clock == "wall" else k * period
            if t >= duration:
                break
            if stall_after is not None and t > stall_after:
                time.sleep(duration - t)          # the loop stops sending and waits the run out
                break
            ok = rtde_c.servoJ(list(path(t)), 0.0, 0.0, period, lookahead, 300)
            if check_result and not ok:
                return False
            k += 1
            if pace:
                if period == 0.002:
                    rtde_c.waitPeriod(t_cycle)
                else:
                    time.sleep(max(0.0, period - (time.monotonic() - t0 - t)))
        if stop:
            rtde_c.servoStop()
        return True

    return follow_path


def test_the_solution_scores_full_marks(solution):
    r = run(solution)
    assert r.passed and r.points == r.weight == 5, r.message
    assert "the 600 ms stall stopped the robot (watchdog) and follow_path returned False" in r.message


def test_a_differently_written_loop_scores_full_marks():
    """Absolute deadlines with time.sleep instead of initPeriod/waitPeriod, a class, other servo settings.
    (Not kickWatchdog after each servoJ: it overwrites the command register before the robot's cycle reads
    it, so the robot misses targets, on a real UR as on the box; servoJ itself feeds the watchdog.)"""

    class Streamer:
        def __init__(self, c, period=0.002):
            self.c, self.period = c, period

        def __call__(self, path, duration):
            self.c.setWatchdog(5.0)
            start = next_t = time.perf_counter()
            while (elapsed := time.perf_counter() - start) < duration:
                if not self.c.servoJ(path(elapsed), 0, 0, self.period, 0.05, 500):
                    return False
                next_t += self.period
                while (late := time.perf_counter() - next_t) > 0:    # behind: skip the missed ticks
                    next_t += self.period * (late // self.period + 1)
                time.sleep(next_t - time.perf_counter())
            return self.c.servoStop(8.0)

    r = run(lambda c, rr, path, duration: Streamer(c)(path, duration))
    assert r.passed and r.points == 5, r.message


BANK = {
    "no watchdog: the stall does not stop the robot": (dict(watchdog=0), "setWatchdog"),
    "a 1 Hz watchdog: too slow for the stall": (dict(watchdog=1.0), "the watchdog was set to 1 Hz"),
    "path sampled at k * dt: falls behind at every pause": (dict(clock="count"), "ms late"),
    "a long lookahead_time: the arm lags the path": (dict(lookahead=0.2), "ms late"),
    "no waitPeriod: thousands of servoJ per second": (dict(pace=False), "per s"),
    "a 125 Hz loop": (dict(period=0.008), "per s"),
    "servoJ's False ignored: the loop runs on after the stop": (dict(check_result=False), "returned True"),
    "no servoStop at the end": (dict(stop=False), "servoStop"),
    "a stalled loop: stops sending after 0.3 s": (dict(stall_after=0.3), "ms late"),
}


@pytest.mark.parametrize("name", list(BANK))
def test_a_wrong_answer_scores_zero(name):
    kwargs, why = BANK[name]
    r = run(loop(**kwargs))
    assert not r.passed and r.points == 0, r.message
    assert why in r.message, r.message


def test_a_loop_that_raises_fails_cleanly_and_stops_the_box():
    def broken(rtde_c, rtde_r, path, duration):
        raise OSError("cable pulled")

    r = run(broken)
    assert not r.passed and r.points == 0 and "OSError: cable pulled" in r.message
