"""Graded checks of chapter 1 (real-time basics). Registered as ``ch01.*``.

Each check compares the student's function with robocourse.rt's own implementation on
crafted inputs and says, in the failure message, what was expected and the usual mistake.
Timing never decides a grade: loops are checked on a deterministic :class:`FakeClock`.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading import CheckFailed, register

from .clock import FakeClock
from .stats import compute_stats

STAT_KEYS = ("min_latency", "max_latency", "mean_latency", "latency_stddev", "minor_pagefaults", "major_pagefaults")

#: The causes of a latency tail met in chapter 1, and the knob that removes each one.
TAILS = ("timer slack oversleep", "page faults in the loop", "other processes on the same core", "gc pause")
KNOBS = ("hybrid wait", "mlockall + prefault", "SCHED_FIFO priority", "gc.freeze()", "more iterations")
_RIGHT_KNOB = {
    "timer slack oversleep": {"hybrid wait", "SCHED_FIFO priority"},
    "page faults in the loop": {"mlockall + prefault"},
    "other processes on the same core": {"SCHED_FIFO priority"},
    "gc pause": {"gc.freeze()"},
}
_WHY = {
    "timer slack oversleep": "SCHED_OTHER threads get 50 us of timer slack; a real-time policy sets it to 0 and a "
                             "hybrid wait spins through it",
    "page faults in the loop": "first touches of memory fault; mlockall + prefault take them before the loop",
    "other processes on the same core": "under SCHED_OTHER the scheduler shares the core fairly; SCHED_FIFO "
                                        "preempts every SCHED_OTHER task",
    "gc pause": "a full collection walks every live object; gc.freeze() moves them out of its reach",
}


def _cases():
    rng = np.random.default_rng(101)
    yield np.array([2414, 45949, 8712, 3000]), np.array([3, 0, 0, 1]), np.array([0, 0, 1, 0])
    yield np.array([-500, 0, 700]), np.zeros(3, int), np.zeros(3, int)
    yield np.array([1234]), np.array([7]), np.array([2])
    n = 5000
    lat = rng.gamma(2.0, 8000.0, n).astype(np.int64)
    lat[rng.integers(0, n, 5)] = 2_750_000
    yield lat, rng.poisson(0.01, n), rng.poisson(0.001, n)


@register("ch01.rttest_stats", weight=2, time_limit=10)
def check_rttest_stats(rttest_statistics):
    """rttest_statistics(latency_ns, minor, major) returns rttest's six numbers."""
    for lat, minor, major in _cases():
        got = rttest_statistics(lat.copy(), minor.copy(), major.copy())
        if not isinstance(got, dict):
            raise CheckFailed(f"return a dict with keys {', '.join(STAT_KEYS)}; got {type(got).__name__}")
        missing = [k for k in STAT_KEYS if k not in got]
        if missing:
            raise CheckFailed(f"the dict lacks {', '.join(missing)}; rttest reports exactly {', '.join(STAT_KEYS)}")
        ref = compute_stats(lat, minor, major)
        where = f"(for {len(lat)} samples starting {list(lat[:3])})"
        for key in ("min_latency", "max_latency", "minor_pagefaults", "major_pagefaults"):
            if int(got[key]) != getattr(ref, key):
                hint = " Page faults are per-iteration deltas: rttest sums them." if "pagefaults" in key else ""
                raise CheckFailed(f"{key} is {got[key]}, expected {getattr(ref, key)} {where}.{hint}")
        if not np.isclose(float(got["mean_latency"]), ref.mean_latency, rtol=1e-9, atol=1e-6):
            raise CheckFailed(f"mean_latency is {got['mean_latency']}, expected {ref.mean_latency:.6f} {where}")
        sd = float(got["latency_stddev"])
        if not np.isclose(sd, ref.latency_stddev, rtol=1e-9, atol=1e-6):
            if len(lat) > 1 and np.isclose(sd, float(np.std(lat, ddof=1)), rtol=1e-9):
                raise CheckFailed("latency_stddev is the *sample* standard deviation (divides by n-1); rttest "
                                  "uses the population one (divides by n): np.std(x) with the default ddof=0")
            raise CheckFailed(f"latency_stddev is {sd}, expected {ref.latency_stddev:.6f} {where}")
    return "matches rttest on 4 buffers, including a single sample and negative latencies"


class _Recorder:
    """The callback the check passes: records when it was entered and left, and spends work."""

    def __init__(self, clock: FakeClock, work: np.ndarray):
        self.clock, self.work, self.entered, self.left = clock, work, [], []

    def __call__(self, k=None):
        self.entered.append(self.clock.t)
        self.clock.work(int(self.work[len(self.entered) - 1]))
        self.left.append(self.clock.t)


def _steady(times: np.ndarray, period: int, tol: int = 1_000) -> bool:
    return bool(np.all(np.abs(np.diff(times) - period) <= tol))


@register("ch01.drift_free_loop", weight=3, time_limit=20)
def check_drift_free_loop(absolute_loop):
    """absolute_loop(clock, period_ns, iterations, callback) keeps absolute deadlines."""
    period, n = 1_000_000, 3000
    clock = FakeClock(start_ns=7_000_000_000, oversleep_ns=60_000, read_cost_ns=50, seed=5)
    rng = np.random.default_rng(6)
    work = rng.integers(0, 500_000, n)
    work[[100, 2000]] = 2_600_000  # two callbacks overrun by more than two periods
    rec = _Recorder(clock, work)
    lat = absolute_loop(clock, period, n, rec)
    if lat is None:
        raise CheckFailed("return the latencies (a list or array of wake - deadline in ns), one per iteration")
    lat = np.asarray(lat, dtype=np.int64)
    if len(rec.entered) != n or len(lat) != n:
        raise CheckFailed(f"asked for {n} iterations: the callback ran {len(rec.entered)} times and "
                          f"{len(lat)} latencies came back")
    if clock.relative_sleeps:
        raise CheckFailed("you called clock.sleep_ns (a relative sleep): every small lateness then adds up. "
                          "Compute each deadline as start + k * period and use clock.sleep_until_ns(deadline)")
    targets = np.unique(np.array(clock.sleep_targets, dtype=np.int64))
    if len(targets) == 0:
        raise CheckFailed("the loop never slept: wait with clock.sleep_until_ns(deadline)")
    off = (targets - targets[0]) % period
    if np.any(off != 0):
        bad = int(targets[np.argmax(off != 0)])
        raise CheckFailed(f"you slept until {bad}, which is {int(off[off != 0][0])} ns away from the grid "
                          "start + k * period. Deadlines must never be 'now + period': after a late iteration "
                          "(iteration 100 here takes 2.6 periods) they must not move")
    entered, left = np.array(rec.entered, dtype=np.int64), np.array(rec.left, dtype=np.int64)
    if not _steady(entered - lat, period):
        if _steady(left - lat, period):
            raise CheckFailed("the latency must be sampled *before* the callback runs (rttest's rule); "
                              "yours includes the callback's own time")
        k = int(np.argmax(np.abs(np.diff(entered - lat) - period) > 1_000)) + 1
        raise CheckFailed(f"the latency of iteration {k} does not match a deadline one period after the previous "
                          "one: latency = (clock read right after waking) - (start + (k + 1) * period)")
    if np.any(lat < 0):
        raise CheckFailed("a latency is negative, but sleep_until_ns never wakes early: latency = wake - deadline")
    return f"{n} iterations, deadlines exactly one period apart even after 2 overruns"


@register("ch01.relative_drift", weight=1, time_limit=10)
def check_relative_drift(drift_ns):
    """drift_ns(wake_ns, start_ns, period_ns): how far each wake-up is from its absolute deadline."""
    start, period = 5_000, 1_000
    wake = np.array([6_060, 7_130, 8_190, 9_260])
    got = np.asarray(drift_ns(wake, start, period))
    expected = wake - (start + np.arange(1, 5) * period)
    if got.shape != expected.shape:
        raise CheckFailed(f"return one drift per wake-up: expected shape {expected.shape}, got {got.shape}")
    if np.array_equal(got, wake - (start + np.arange(0, 4) * period)):
        raise CheckFailed("off by one period: the first wake-up (k = 0) belongs to deadline start + 1 * period")
    if not np.array_equal(got, expected):
        raise CheckFailed(f"for wake {list(wake)}, start {start}, period {period} expected {list(expected)}, "
                          f"got {list(got)}")
    return "drift = wake_k - (start + (k + 1) * period)"


@register("ch01.budget", weight=2, time_limit=10)
def check_budget(controller_budget_ns, meets_5_percent):
    """controller_budget_ns(period, latency, percentile) and meets_5_percent(latency, period)."""
    rng = np.random.default_rng(8)
    lat = rng.gamma(2.0, 10_000.0, 20_000).astype(np.int64)
    for q in (99.0, 99.9):
        expected = max(0.0, 1_000_000 - float(np.percentile(lat, q)))
        got = float(controller_budget_ns(1_000_000, lat, q))
        if not np.isclose(got, expected, rtol=1e-9, atol=1.0):
            mean_based = 1_000_000 - float(lat.mean())
            if np.isclose(got, mean_based, atol=1.0):
                raise CheckFailed("you subtracted the *mean* latency: the controller must fit after the tail, "
                                  f"so subtract the p{q:g} latency (np.percentile)")
            raise CheckFailed(f"at percentile {q:g} expected {expected:.1f} ns left of the 1 ms period, got {got:.1f}")
    late = np.array([2_000_000, 1_500_000])
    if float(controller_budget_ns(1_000_000, late, 99.0)) != 0:
        raise CheckFailed("when the tail latency exceeds the whole period no budget is left: return 0, not a negative number")
    for samples, ok in (([1_000, 50_000], True), ([1_000, 50_001], False), ([-300, 10_000], True)):
        got = meets_5_percent(np.array(samples), 1_000_000)
        if bool(got) != ok:
            raise CheckFailed(f"meets_5_percent({samples}, 1 ms) should be {ok}: the seed's rule is "
                              "max latency <= 5 % of the period (50 000 ns at 1 kHz), judged on the max, not the mean")
    return "budget = period - tail latency; 5 % rule judged on the maximum"


@register("ch01.which_knob", weight=1, time_limit=5)
def check_which_knob(knob_for):
    """knob_for: dict tail cause -> the knob that removes it (from KNOBS)."""
    if not isinstance(knob_for, dict):
        raise CheckFailed("knob_for must be a dict {tail cause: knob}")
    missing = [t for t in TAILS if t not in knob_for]
    if missing:
        raise CheckFailed(f"answer for every cause; missing: {', '.join(missing)}")
    for tail in TAILS:
        answer = knob_for[tail]
        if answer not in KNOBS:
            raise CheckFailed(f"{tail!r}: {answer!r} is not one of the knobs {list(KNOBS)}")
        if answer not in _RIGHT_KNOB[tail]:
            raise CheckFailed(f"{tail!r}: {answer!r} does not remove it. Hint: {_WHY[tail]}")
    return "every tail matched with the knob that removes it"
