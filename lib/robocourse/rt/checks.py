"""Graded checks of chapter 1 (real-time basics), as probe + judge. Registered as ``ch01.*``.

The probes call the student's functions on fresh inputs (new latency buffers, a FakeClock with
a new seed and new overrun positions each run) and hand back what came out; the judges
compare with robocourse.rt's own statistics and with the absolute-deadline grid, and name the
usual mistake. Timing never decides a grade: loops run on a deterministic :class:`FakeClock`.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import call, number, plain

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


def _stats_inputs(rng):
    n = int(rng.integers(2000, 4000))
    lat = rng.gamma(2.0, 8000.0, n).astype(np.int64)
    lat[rng.integers(0, n, 5)] = int(rng.integers(1_000_000, 3_000_000))
    small = rng.integers(1000, 50_000, 4)
    return [
        [small.tolist(), [3, 0, 0, 1], [0, 0, 1, 0]],
        [[-500, 0, int(rng.integers(100, 900))], [0, 0, 0], [0, 0, 0]],
        [[int(rng.integers(100, 5000))], [7], [2]],
        [lat.tolist(), rng.poisson(0.01, n).tolist(), rng.poisson(0.001, n).tolist()],
    ]


def _stats_probe(inputs, rttest_statistics):
    return [call(rttest_statistics, *(np.asarray(a, dtype=np.int64) for a in case)) for case in inputs]


@register("ch01.rttest_stats", weight=2, time_limit=10, uses=("rttest_statistics",), probe=_stats_probe,
          inputs=_stats_inputs, references=("robocourse.rt.stats:compute_stats",))
def check_rttest_stats(inputs, outputs):
    """rttest_statistics(latency_ns, minor, major) returns rttest's six numbers."""
    f = Failures()
    for (lat, minor, major), got in zip(inputs, outputs, strict=True):
        lat = np.asarray(lat, dtype=np.int64)
        where = f"(for {len(lat)} samples starting {list(lat[:3])})"
        if "raised" in got:
            f.add(f"raised {got['raised']}: {got['message']} {where}")
            continue
        value = got["value"]
        if not isinstance(value, dict):
            f.add(f"return a dict with keys {', '.join(STAT_KEYS)}; got {got.get('type')}")
            continue
        missing = [k for k in STAT_KEYS if k not in value]
        if missing:
            f.add(f"the dict lacks {', '.join(missing)}; rttest reports exactly {', '.join(STAT_KEYS)}")
            continue
        ref = compute_stats(lat, np.asarray(minor), np.asarray(major))
        for key in ("min_latency", "max_latency", "minor_pagefaults", "major_pagefaults"):
            if number(value[key]) != getattr(ref, key):
                hint = " Page faults are per-iteration deltas: rttest sums them." if "pagefaults" in key else ""
                f.add(f"{key} is {value[key]}, expected {getattr(ref, key)} {where}.{hint}")
        if not np.isclose(number(value["mean_latency"]), ref.mean_latency, rtol=1e-9, atol=1e-6):
            f.add(f"mean_latency is {value['mean_latency']}, expected {ref.mean_latency:.6f} {where}")
        sd = number(value["latency_stddev"])
        if not np.isclose(sd, ref.latency_stddev, rtol=1e-9, atol=1e-6):
            if len(lat) > 1 and np.isclose(sd, float(np.std(lat, ddof=1)), rtol=1e-9):
                f.add("latency_stddev is the *sample* standard deviation (divides by n-1); rttest uses the "
                      "population one (divides by n): np.std(x) with the default ddof=0")
            else:
                f.add(f"latency_stddev is {sd}, expected {ref.latency_stddev:.6f} {where}")
    return f.done(f"matches rttest on {len(inputs)} buffers, including a single sample and negative latencies")


class _Recorder:
    """The callback the probe passes: records when it was entered and left, and spends work."""

    def __init__(self, clock: FakeClock, work: list[int]):
        self.clock, self.work, self.entered, self.left = clock, work, [], []

    def __call__(self, k=None):
        self.entered.append(self.clock.t)
        self.clock.work(int(self.work[min(len(self.entered), len(self.work)) - 1]))
        self.left.append(self.clock.t)


def _loop_inputs(rng):
    period = int(rng.choice([500_000, 1_000_000, 2_000_000]))
    n = 1500
    work = rng.integers(0, period // 2, n)
    late = rng.choice(np.arange(50, n - 50), 2, replace=False)
    work[late] = int(2.6 * period)  # two callbacks overrun by more than two periods
    return {"period": period, "n": n, "start_ns": int(rng.integers(1, 10)) * 1_000_000_000 + int(rng.integers(0, 10**6)),
            "oversleep_ns": 60_000, "read_cost_ns": 50, "seed": int(rng.integers(0, 2**31)),
            "work": work.tolist(), "late": sorted(int(k) for k in late)}


def _loop_probe(inputs, absolute_loop):
    clock = FakeClock(start_ns=inputs["start_ns"], oversleep_ns=inputs["oversleep_ns"],
                      read_cost_ns=inputs["read_cost_ns"], seed=inputs["seed"])
    rec = _Recorder(clock, inputs["work"])
    lat = absolute_loop(clock, inputs["period"], inputs["n"], rec)
    return {"latencies": None if lat is None else plain(np.asarray(lat).ravel()),
            "entered": rec.entered, "left": rec.left, "sleep_targets": clock.sleep_targets,
            "relative_sleeps": clock.relative_sleeps}


def _ints(values, what) -> np.ndarray:
    if not isinstance(values, list):
        raise TypeError(f"{what} is not a list")
    return np.array([number(v) for v in values], dtype=np.float64).astype(np.int64)


@register("ch01.drift_free_loop", weight=3, time_limit=20, uses=("absolute_loop",), probe=_loop_probe,
          inputs=_loop_inputs)
def check_drift_free_loop(inputs, outputs):
    """absolute_loop(clock, period_ns, iterations, callback) keeps absolute deadlines one period apart."""
    period, n, start = inputs["period"], inputs["n"], inputs["start_ns"]
    if outputs["latencies"] is None:
        raise CheckFailed("return the latencies (a list or array of wake - deadline in ns), one per iteration")
    lat = _ints(outputs["latencies"], "latencies")
    entered, left = _ints(outputs["entered"], "entered"), _ints(outputs["left"], "left")
    f = Failures()
    if len(entered) != n or len(lat) != n:
        f.add(f"asked for {n} iterations: the callback ran {len(entered)} times and {len(lat)} latencies came back")
        return f.done("")
    if outputs["relative_sleeps"]:
        f.add("you called clock.sleep_ns (a relative sleep): every small lateness then adds up. "
              "Compute each deadline as start + (k + 1) * period and use clock.sleep_until_ns(deadline)")
    targets = _ints(outputs["sleep_targets"], "sleep targets")
    if len(targets) == 0 and not outputs["relative_sleeps"]:
        f.add("the loop never slept: wait with clock.sleep_until_ns(deadline)")
    # rttest's grid: t0 is the clock read before the loop, deadline_k = t0 + (k + 1) * period
    reads = start + inputs["read_cost_ns"] * np.arange(1, 6)
    first_ok = [t0 + period for t0 in reads]
    grid = None
    if len(targets):
        t_first = int(targets[0])
        if t_first in first_ok:
            grid = t_first + period * np.arange(n, dtype=np.int64)
        elif t_first in reads:
            f.add(f"your first deadline is the loop's start time ({t_first}): off by one period. The k-th wake-up "
                  "(k = 0, 1, ...) belongs to start + (k + 1) * period, so the first one is a full period after start")
        elif t_first - period in first_ok:
            f.add("your first deadline is two periods after the start: off by one period; deadline_k = "
                  "start + (k + 1) * period with k counting from 0")
        else:
            f.add(f"your first deadline {t_first} is {t_first - start} ns after the clock's start {start}; "
                  f"expected start + 1 * period = {start + inputs['read_cost_ns']} + {period}")
        off = (targets - targets[0]) % period
        if np.any(off != 0):
            bad = int(targets[np.argmax(off != 0)])
            f.add(f"you slept until {bad}, which is {int(off[off != 0][0])} ns away from the grid start + k * period. "
                  f"Deadlines must never be 'now + period': after a late iteration (iterations {inputs['late']} "
                  "take 2.6 periods here) they must not move")
    if grid is not None and not np.any((targets - targets[0]) % period):
        before = np.abs(entered - lat - grid) <= 1_000
        if not np.all(before):
            if np.all(np.abs(left - lat - grid) <= 1_000):
                f.add("the latency must be sampled *before* the callback runs (rttest's rule); yours includes the "
                      "callback's own time")
            else:
                k = int(np.argmax(~before))
                f.add(f"the latency of iteration {k} is not (clock read right after waking) - (start + (k + 1) * "
                      f"period): expected about {int(entered[k] - grid[k])} ns, got {int(lat[k])}")
        if not set(targets.tolist()) <= set(grid.tolist()):
            f.add("some sleeps went to a time that is not one of the loop's deadlines start + (k + 1) * period")
    if np.any(lat < 0):
        f.add("a latency is negative, but sleep_until_ns never wakes early: latency = wake - deadline")
    return f.done(f"{n} iterations, deadlines exactly start + (k + 1) * period even after 2 overruns")


def _drift_inputs(rng):
    start, period = int(rng.integers(1_000, 100_000)), int(rng.choice([1_000, 2_000, 500]))
    k = np.arange(1, 7)
    wake = start + k * period + rng.integers(0, period // 3, len(k))
    return {"start": start, "period": period, "wake": wake.tolist()}


def _drift_probe(inputs, drift_ns):
    return call(drift_ns, np.asarray(inputs["wake"], dtype=np.int64), inputs["start"], inputs["period"])


@register("ch01.relative_drift", weight=1, time_limit=10, uses=("drift_ns",), probe=_drift_probe,
          inputs=_drift_inputs)
def check_relative_drift(inputs, outputs):
    """drift_ns(wake_ns, start_ns, period_ns): how far each wake-up is from its absolute deadline."""
    wake, start, period = np.asarray(inputs["wake"]), inputs["start"], inputs["period"]
    if "raised" in outputs:
        raise CheckFailed(f"drift_ns raised {outputs['raised']}: {outputs['message']}")
    got = outputs["value"]
    expected = wake - (start + np.arange(1, len(wake) + 1) * period)
    if not isinstance(got, list) or len(got) != len(expected):
        raise CheckFailed(f"return one drift per wake-up: expected {len(expected)} numbers, got {str(got)[:80]}")
    got = np.array([number(v) for v in got])
    if np.array_equal(got, wake - (start + np.arange(0, len(wake)) * period)):
        raise CheckFailed("off by one period: the first wake-up (k = 0) belongs to deadline start + 1 * period")
    if not np.array_equal(got, expected):
        raise CheckFailed(f"for wake {list(wake)}, start {start}, period {period} expected {list(expected)}, "
                     f"got {[int(v) if float(v).is_integer() else v for v in got]}")
    return "drift = wake_k - (start + (k + 1) * period)"


def _budget_inputs(rng):
    lat = rng.gamma(2.0, float(rng.uniform(5_000, 15_000)), 5_000).astype(np.int64)
    period = 1_000_000
    cap = int(0.05 * period)
    below = int(rng.integers(0, cap))
    return {"period": period, "latency": lat.tolist(), "percentiles": [99.0, 99.9, round(float(rng.uniform(90, 99)), 2)],
            "late": [2_000_000, 1_500_000],
            "meets": [[[below, cap], True], [[below, cap + 1], False], [[-300, 10_000], True],
                      [[1_000] * 99 + [cap + 5_000], False]]}


def _budget_probe(inputs, controller_budget_ns, meets_5_percent):
    lat = np.asarray(inputs["latency"], dtype=np.int64)
    return {"budget": [call(controller_budget_ns, inputs["period"], lat, q) for q in inputs["percentiles"]],
            "late": call(controller_budget_ns, inputs["period"], np.asarray(inputs["late"]), 99.0),
            "meets": [call(meets_5_percent, np.asarray(s), inputs["period"]) for s, _ in inputs["meets"]]}


@register("ch01.budget", weight=2, time_limit=10, uses=("controller_budget_ns", "meets_5_percent"),
          probe=_budget_probe, inputs=_budget_inputs)
def check_budget(inputs, outputs):
    """controller_budget_ns(period, latency, percentile) and meets_5_percent(latency, period)."""
    lat, period = np.asarray(inputs["latency"]), inputs["period"]
    f = Failures()
    for q, got in zip(inputs["percentiles"], outputs["budget"], strict=True):
        expected = max(0.0, period - float(np.percentile(lat, q)))
        if "raised" in got:
            f.add(f"controller_budget_ns(1 ms, latencies, {q:g}) raised {got['raised']}: {got['message']}")
            continue
        value = number(got["value"])
        if not np.isclose(value, expected, rtol=1e-9, atol=1.0):
            if np.isclose(value, period - float(lat.mean()), atol=1.0):
                f.add("you subtracted the *mean* latency: the controller must fit after the tail, "
                      f"so subtract the p{q:g} latency (np.percentile)")
            else:
                f.add(f"at percentile {q:g} expected {expected:.1f} ns left of the 1 ms period, got {value:.1f}")
    late = outputs["late"]
    if "raised" in late or number(late["value"]) != 0:
        f.add("when the tail latency exceeds the whole period no budget is left: return 0, not a negative number")
    for (samples, ok), got in zip(inputs["meets"], outputs["meets"], strict=True):
        if "raised" in got or bool(got["value"]) != ok:
            shown = samples if len(samples) < 5 else f"[{samples[0]}, ... {len(samples)} samples, max {max(samples)}]"
            f.add(f"meets_5_percent({shown}, 1 ms) should be {ok}: the seed's rule is max latency <= 5 % of the "
                  "period (50 000 ns at 1 kHz), judged on the max, not the mean")
    return f.done("budget = period - tail latency; 5 % rule judged on the maximum")


def _knob_probe(inputs, which_knob):
    return plain(which_knob() if callable(which_knob) else which_knob)


@register("ch01.which_knob", weight=1, time_limit=5, uses=("which_knob",), probe=_knob_probe)
def check_which_knob(inputs, knob_for):
    """which_knob: dict tail cause -> the knob that removes it (from KNOBS), or a function returning it."""
    if not isinstance(knob_for, dict):
        raise CheckFailed("which_knob() must return a dict {tail cause: knob}")
    f = Failures()
    missing = [t for t in TAILS if t not in knob_for]
    if missing:
        f.add(f"answer for every cause; missing: {', '.join(missing)}")
    for tail in TAILS:
        if tail not in knob_for:
            continue
        answer = knob_for[tail]
        if answer not in KNOBS:
            f.add(f"{tail!r}: {answer!r} is not one of the knobs {list(KNOBS)}")
        elif answer not in _RIGHT_KNOB[tail]:
            f.add(f"{tail!r}: {answer!r} does not remove it. Hint: {_WHY[tail]}")
    return f.done("every tail matched with the knob that removes it")
