"""Graded checks of chapter 1 (real-time basics): inputs, schemas, sub-tests. Registered as ``ch01.*``.

The judge side only: the grading sandbox hides this module (the knob key and the expected
values are here); the probes that run the student's code live in :mod:`robocourse.rt.probes`.
Each check is split into sub-tests, one per property the exercise states, with its share of
the points; every record is validated against the check's schema before a sub-test reads it.
Timing never decides a grade: loops run on a deterministic :class:`FakeClock`, and the judges
compare with robocourse.rt's own statistics and with the absolute-deadline grid.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Any, Array, Bool, Call, Dict, List, Map, Number, Opt, Str

from . import probes
from .probes import KNOBS, TAILS
from .stats import compute_stats

STAT_KEYS = ("min_latency", "max_latency", "mean_latency", "latency_stddev", "minor_pagefaults", "major_pagefaults")

#: which knob removes which tail (the key of exercise 5; never shipped into a sandbox)
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


# --- ch01.rttest_stats ---------------------------------------------------------------------------

def _stats_inputs(rng):
    n = int(rng.integers(2000, 4000))
    lat = rng.gamma(2.0, 8000.0, n).astype(np.int64)
    lat[rng.integers(0, n, 5)] = int(rng.integers(1_000_000, 3_000_000))
    small = rng.integers(1000, 50_000, 4)
    return {"cases": [
        [small.tolist(), [3, 0, 0, 1], [0, 0, 1, 0]],
        [[-500, 0, int(rng.integers(100, 900))], [0, 0, 0], [0, 0, 0]],
        [[int(rng.integers(100, 5000))], [7], [2]],
        [lat.tolist(), rng.poisson(0.01, n).tolist(), rng.poisson(0.001, n).tolist()],
    ]}


def _stats_cases(inputs, outputs):
    """(latencies, reference stats, the student's dict or None, where) per case; a raise is listed."""
    f = Failures()
    cases = []
    for (lat, minor, major), got in zip(inputs["cases"], outputs["cases"], strict=True):
        lat = np.asarray(lat, dtype=np.int64)
        where = f"(for {len(lat)} samples starting {lat[:3].tolist()})"
        if "raised" in got:
            f.add(f"raised {got['raised']}: {got['message']} {where}")
            continue
        cases.append((lat, compute_stats(lat, np.asarray(minor), np.asarray(major)), got["value"], where))
    return f, cases


def _has(f: Failures, value: dict, keys, where) -> bool:
    missing = [k for k in keys if k not in value]
    if missing:
        f.add(f"the dict lacks {', '.join(missing)} {where}; rttest reports exactly {', '.join(STAT_KEYS)}")
    return not missing


def _stats_extremes(inputs, outputs):
    f, cases = _stats_cases(inputs, outputs)
    for _lat, ref, value, where in cases:
        if not _has(f, value, ("min_latency", "max_latency"), where):
            continue
        for key in ("min_latency", "max_latency"):
            got = value[key]
            if not isinstance(got, int):
                f.add(f"{key} is {got!r}, a {type(got).__name__}; rttest reports it as an int")
            elif got != getattr(ref, key):
                f.add(f"{key} is {got}, expected {getattr(ref, key)} {where}: over every sample, negative ones too")
    return f.done("min and max are ints over every sample")


def _stats_mean(inputs, outputs):
    f, cases = _stats_cases(inputs, outputs)
    for _lat, ref, value, where in cases:
        if _has(f, value, ("mean_latency",), where) and \
                not np.isclose(value["mean_latency"], ref.mean_latency, rtol=1e-9, atol=1e-6):
            f.add(f"mean_latency is {value['mean_latency']!r}, expected {ref.mean_latency:.6f} {where}: the sum of "
                  "every sample over their count, as a float")
    return f.done("the mean over all samples")


def _stats_stddev(inputs, outputs):
    f, cases = _stats_cases(inputs, outputs)
    for lat, ref, value, where in cases:
        if not _has(f, value, ("latency_stddev",), where):
            continue
        sd = value["latency_stddev"]
        if not np.isclose(sd, ref.latency_stddev, rtol=1e-9, atol=1e-6):
            if len(lat) > 1 and np.isclose(sd, float(np.std(lat, ddof=1)), rtol=1e-9):
                f.add("latency_stddev is the *sample* standard deviation (divides by n-1); rttest uses the "
                      "population one (divides by n): np.std(x) with the default ddof=0")
            else:
                f.add(f"latency_stddev is {sd!r}, expected {ref.latency_stddev:.6f} {where}")
    return f.done("the population standard deviation")


def _stats_faults(inputs, outputs):
    f, cases = _stats_cases(inputs, outputs)
    for _lat, ref, value, where in cases:
        if not _has(f, value, ("minor_pagefaults", "major_pagefaults"), where):
            continue
        for key in ("minor_pagefaults", "major_pagefaults"):
            if value[key] != getattr(ref, key):
                f.add(f"{key} is {value[key]!r}, expected {getattr(ref, key)} {where}. Page faults are "
                      "per-iteration deltas: rttest sums them.")
    return f.done("page faults summed over the run")


register("ch01.rttest_stats", uses=("rttest_statistics",), probe=probes.stats_probe, inputs=_stats_inputs,
         time_limit=10, references=("robocourse.rt.stats:compute_stats", "robocourse.rt.stats:RunningStats"),
         schema=Dict(cases=List(Call(Map(Number(finite=False), max_items=50)), length="cases")),
         subtests=[SubTest("min and max, as ints over every sample", 0.5, _stats_extremes),
                   SubTest("the mean over all samples", 0.5, _stats_mean),
                   SubTest("the population standard deviation (divide by n)", 0.5, _stats_stddev),
                   SubTest("the total page faults (sum of the deltas)", 0.5, _stats_faults)])


# --- ch01.drift_free_loop ------------------------------------------------------------------------

def _loop_inputs(rng):
    period = int(rng.choice([500_000, 1_000_000, 2_000_000]))
    n = 1500
    work = rng.integers(0, period // 2, n)
    late = rng.choice(np.arange(50, n - 50), 2, replace=False)
    work[late] = int(2.6 * period)  # two callbacks overrun by more than two periods
    return {"period": period, "n": n, "start_ns": int(rng.integers(1, 10)) * 1_000_000_000 + int(rng.integers(0, 10**6)),
            "oversleep_ns": 60_000, "read_cost_ns": 50, "seed": int(rng.integers(0, 2**31)),
            "work": work.tolist(), "late": sorted(int(k) for k in late)}


_INTS = Array((None,), integer=True, max_items=200_000)
_LOOP_SCHEMA = Dict(latencies=Opt(Array((None,), finite=False, max_items=200_000), label="the latencies returned"),
                    entered=_INTS, left=_INTS, ks=List(Any(max_items=100), max_len=200_000), sleep_targets=_INTS,
                    woke=_INTS, relative_sleeps=_INTS)


def _grid(inputs, targets):
    """The deadlines start + (k + 1) * period for the start the loop read first (rttest's t0),
    or None with the problem when the first deadline is not one period after a start read."""
    period, n, start = inputs["period"], inputs["n"], inputs["start_ns"]
    reads = start + inputs["read_cost_ns"] * np.arange(1, 6)
    if not len(targets):
        return None, "the loop never slept until a deadline: wait with clock.sleep_until_ns(deadline)"
    t_first = int(targets[0])
    if t_first in reads + period:
        return t_first + period * np.arange(n, dtype=np.int64), ""
    if t_first in reads:
        return None, (f"your first deadline is the loop's start time ({t_first}): off by one period. The k-th wake-up "
                      "(k = 0, 1, ...) belongs to start + (k + 1) * period, so the first one is a full period after start")
    if t_first - period in reads + period:
        return None, ("your first deadline is two periods after the start: off by one period; deadline_k = "
                      "start + (k + 1) * period with k counting from 0")
    return None, (f"your first deadline {t_first} is {t_first - start} ns after the clock's start {start}; expected "
                  f"start + 1 * period = {start + inputs['read_cost_ns']} + {period}")


def _loop_deadlines(inputs, out):
    period, n = inputs["period"], inputs["n"]
    targets = out["sleep_targets"]
    if len(out["relative_sleeps"]):
        raise CheckFailed("you called clock.sleep_ns (a relative sleep): every small lateness then adds up. Compute "
                          "each deadline as start + (k + 1) * period and use clock.sleep_until_ns(deadline)")
    grid, problem = _grid(inputs, targets)
    f = Failures()
    if grid is None:
        f.add(problem)
    off = (targets - targets[0]) % period if len(targets) else targets
    if np.any(off != 0):
        bad = int(targets[np.argmax(off != 0)])
        f.add(f"you slept until {bad}, which is {int(off[off != 0][0])} ns away from the grid start + k * period. "
              f"Deadlines must never be 'now + period': after a late iteration (iterations {inputs['late']} take "
              "2.6 periods here) they must not move")
    elif grid is not None and (len(targets) != n or np.any(targets != grid)):
        k = next((k for k in range(min(n, len(targets))) if targets[k] != grid[k]), min(n, len(targets)))
        f.add(f"{len(targets)} sleeps for {n} iterations; iteration {k} should sleep until start + ({k} + 1) * period "
              f"= {int(grid[k]) if k < n else 'nothing more'}, got {int(targets[k]) if k < len(targets) else 'no sleep'}")
    return f.done(f"{n} sleeps, each until start + (k + 1) * period, even after 2 overruns")


def _loop_latency(inputs, out):
    n = inputs["n"]
    lat, targets, left = out["latencies"], out["sleep_targets"], out["left"]
    if lat is None:
        raise CheckFailed("return the latencies (a list or array of wake - deadline in ns), one per iteration")
    if len(lat) != n:
        raise CheckFailed(f"asked for {n} iterations: {len(lat)} latencies came back")
    if len(targets) != n or len(out["relative_sleeps"]):
        raise CheckFailed("the latency is wake - deadline for each iteration's sleep_until_ns(deadline): one absolute "
                          f"sleep per iteration is needed to judge it ({len(targets)} sleeps for {n} iterations)")
    f = Failures()
    # measured from each iteration's own deadline: this sub-test judges when and how the latency is read
    first_read = out["woke"] + inputs["read_cost_ns"]
    right = np.abs(lat - (first_read - targets)) <= 1_000
    if not np.all(right):
        k = int(np.argmax(~right))
        if len(left) == n and (np.all(np.abs(left - lat - targets) <= 1_000) or
                               np.all(np.abs(left + inputs["read_cost_ns"] - lat - targets) <= 1_000)):
            f.add("the latency must be sampled *before* the callback runs (rttest's rule); yours includes the "
                  "callback's own time")
        else:
            f.add(f"the latency of iteration {k} is not (clock read right after waking) - (its deadline): expected "
                  f"{int(first_read[k] - targets[k])} ns, got {lat[k]:g}")
    if np.any(lat < 0):
        f.add("a latency is negative, but sleep_until_ns never wakes early: latency = wake - deadline")
    return f.done("latency = clock read right after waking - deadline, before the callback")


def _loop_callback(inputs, out):
    n = inputs["n"]
    ks, entered, targets = out["ks"], out["entered"], out["sleep_targets"]
    if len(entered) != n:
        raise CheckFailed(f"asked for {n} iterations: the callback ran {len(entered)} times")
    if ks != list(range(n)):
        k = next(i for i, v in enumerate(ks) if v != i)
        raise CheckFailed(f"call callback(k) with the iteration number: call {k} got {str(ks[k])[:60]}, expected {k}")
    if len(targets) >= n and np.any(entered < targets[:n]):
        k = int(np.argmax(entered < targets[:n]))
        raise CheckFailed(f"iteration {k} ran the callback before its deadline: sleep first, read the clock, record, "
                          "and only then call callback(k)")
    return "callback(k) once per iteration, after waking"


register("ch01.drift_free_loop", uses=("absolute_loop",), probe=probes.loop_probe, inputs=_loop_inputs, time_limit=20,
         max_bytes=4_000_000, references=("robocourse.rt.loop:PeriodicLoop", "robocourse.rt.loop:run_loop"),
         schema=_LOOP_SCHEMA,
         subtests=[SubTest("sleeps until absolute deadlines start + (k + 1) * period", 1.5, _loop_deadlines,
                           reads=("sleep_targets", "relative_sleeps")),
                   SubTest("records wake - deadline right after waking, before the callback", 1.0, _loop_latency),
                   SubTest("calls callback(k) once per iteration, after waking", 0.5, _loop_callback,
                           reads=("ks", "entered", "sleep_targets"))])


# --- ch01.relative_drift -------------------------------------------------------------------------

def _drift_inputs(rng):
    cases = []
    for start in (int(rng.integers(1_000, 100_000)), int(rng.integers(10**12, 10**15))):  # a fresh clock; hours up
        period = int(rng.choice([1_000, 2_000, 500, 1_000_000]))
        k = np.arange(1, int(rng.integers(5, 9)))
        wake = start + k * period + rng.integers(0, period // 3, len(k)) + np.cumsum(rng.integers(0, period // 4, len(k)))
        cases.append({"start": start, "period": period, "wake": wake.tolist()})
    return {"cases": cases}


def _drift_values(inputs, outputs):
    f = Failures()
    for case, got in zip(inputs["cases"], outputs["cases"], strict=True):
        wake, start, period = np.asarray(case["wake"], dtype=np.int64), case["start"], case["period"]
        if "raised" in got:
            f.add(f"drift_ns(wake, {start}, {period}) raised {got['raised']}: {got['message']}")
            continue
        value = got["value"]
        expected = wake - (start + np.arange(1, len(wake) + 1) * period)
        if not isinstance(value, list) or len(value) != len(expected):
            f.add(f"return one drift per wake-up: expected {len(expected)} numbers, got {str(value)[:80]}")
            continue
        value = np.array([v if isinstance(v, (int, float)) and not isinstance(v, bool) else np.nan for v in value],
                         dtype=np.float64)
        if np.array_equal(value, wake - (start + np.arange(0, len(wake)) * period)):
            f.add("off by one period: the first wake-up (k = 0) belongs to deadline start + 1 * period")
        elif not np.array_equal(value, expected.astype(np.float64)):
            shown = [int(v) if np.isfinite(v) and float(v).is_integer() else v for v in value]
            f.add(f"for wake {list(wake)}, start {start}, period {period} expected {list(expected)}, got {shown}")
    return f.done("drift = wake_k - (start + (k + 1) * period)")


def _drift_type(inputs, outputs):
    f = Failures()
    for got in outputs["cases"]:
        if "raised" in got:
            f.add(f"drift_ns raised {got['raised']}")
        elif got["type"] != "ndarray":
            f.add(f"drift_ns returned a {got['type']}; the exercise asks for a numpy array (one drift per wake-up)")
    return f.done("a numpy array")


register("ch01.relative_drift", uses=("drift_ns",), probe=probes.drift_probe, inputs=_drift_inputs, time_limit=10,
         schema=Dict(cases=List(Call(Any(max_items=1000)), length="cases")),
         subtests=[SubTest("the drift of each wake-up from start + (k + 1) * period", 0.75, _drift_values),
                   SubTest("returned as a numpy array", 0.25, _drift_type)])


# --- ch01.budget ---------------------------------------------------------------------------------

def _budget_inputs(rng):
    lat = rng.gamma(2.0, float(rng.uniform(5_000, 15_000)), 5_000).astype(np.int64)
    period = 1_000_000
    cap = int(0.05 * period)
    below = int(rng.integers(0, cap))
    return {"period": period, "latency": lat.tolist(), "percentiles": [99.0, 99.9, round(float(rng.uniform(90, 99)), 2)],
            "late": [2_000_000, 1_500_000],
            "meets": [[below, cap], [below, cap + 1], [-300, 10_000], [1_000] * 99 + [cap + 5_000]]}


def _budget_values(inputs, outputs):
    lat, period = np.asarray(inputs["latency"]), inputs["period"]
    f = Failures()
    for q, got in zip(inputs["percentiles"], outputs["budget"], strict=True):
        expected = max(0.0, period - float(np.percentile(lat, q)))
        if "raised" in got:
            f.add(f"controller_budget_ns(1 ms, latencies, {q:g}) raised {got['raised']}: {got['message']}")
            continue
        value = got["value"]
        if not np.isclose(value, expected, rtol=1e-9, atol=1.0):
            if np.isclose(value, period - float(lat.mean()), atol=1.0):
                f.add("you subtracted the *mean* latency: the controller must fit after the tail, "
                      f"so subtract the p{q:g} latency (np.percentile)")
            elif np.isclose(value, period - float(lat.max()), atol=1.0):
                f.add(f"you subtracted the *maximum* latency; the exercise asks for the p{q:g} latency (np.percentile)")
            else:
                f.add(f"at percentile {q:g} expected {expected:.1f} ns left of the 1 ms period, got {value!r}")
    return f.done("budget = period - the percentile's latency")


def _budget_floor(inputs, outputs):
    late = outputs["late"]
    if "raised" in late:
        raise CheckFailed(f"controller_budget_ns with every latency past the period raised {late['raised']}: "
                          f"{late['message']}; return 0")
    if late["value"] != 0:
        raise CheckFailed(f"with latencies {inputs['late']} ns in a 1 ms period the budget came back "
                          f"{late['value']!r}: when the tail latency exceeds the whole period no budget is left: "
                          "return 0, not a negative number")
    return "0 when the tail exceeds the period"


def _budget_rule(inputs, outputs):
    period = inputs["period"]
    f = Failures()
    for samples, got in zip(inputs["meets"], outputs["meets"], strict=True):
        ok = max(samples) <= 0.05 * period
        shown = samples if len(samples) < 5 else f"[{samples[0]}, ... {len(samples)} samples, max {max(samples)}]"
        if "raised" in got:
            f.add(f"meets_5_percent({shown}, 1 ms) raised {got['raised']}: {got['message']}")
        elif got["value"] is not ok:
            f.add(f"meets_5_percent({shown}, 1 ms) returned {got['value']!r}, expected {ok}: the seed's rule is max "
                  "latency <= 5 % of the period (50 000 ns at 1 kHz, inclusive), judged on the max, not the mean")
    return f.done("5 % rule judged on the maximum, inclusive")


register("ch01.budget", uses=("controller_budget_ns", "meets_5_percent"), probe=probes.budget_probe,
         inputs=_budget_inputs, time_limit=10,
         schema=Dict(budget=List(Call(Number(finite=False)), length="percentiles"), late=Call(Number(finite=False)),
                     meets=List(Call(Bool()), length="meets")),
         subtests=[SubTest("budget = period - the percentile's latency", 0.75, _budget_values, reads="budget"),
                   SubTest("never negative: 0 when the tail exceeds the period", 0.5, _budget_floor, reads="late"),
                   SubTest("the 5 % rule on the maximum latency, inclusive", 0.75, _budget_rule, reads="meets")])


# --- ch01.which_knob -----------------------------------------------------------------------------

def _knob_subtest(tail):
    def judge(inputs, outputs):
        if "raised" in outputs:
            raise CheckFailed(f"which_knob() raised {outputs['raised']}: {outputs['message']}")
        knob_for = outputs["value"]
        if tail not in knob_for:
            raise CheckFailed(f"no answer for {tail!r}: the dict needs one entry per cause in TAILS")
        answer = knob_for[tail]
        if answer not in KNOBS:
            raise CheckFailed(f"{tail!r}: {answer!r} is not one of the knobs {list(KNOBS)}")
        if answer not in _RIGHT_KNOB[tail]:
            raise CheckFailed(f"{tail!r}: {answer!r} does not remove it. Hint: {_WHY[tail]}")
        return f"{answer} removes it"

    return judge


register("ch01.which_knob", uses=("which_knob",), probe=probes.knob_probe, time_limit=5,
         schema=Call(Map(Str(max_len=200), max_items=50, label="which_knob()'s dict"), label="which_knob()"),
         subtests=[SubTest(tail, 0.25, _knob_subtest(tail)) for tail in TAILS])
