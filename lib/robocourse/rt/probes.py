"""The student-side half of chapter 1's checks: the probes, and what the exercises hand out.

A probe runs where the student's code runs (their kernel, or the grading sandbox): it calls the
student's functions on the grader's inputs and returns what came out as plain data. The
judges, their answer keys and expected values live in :mod:`robocourse.rt.checks`, which the
grading sandbox hides. ``TAILS`` and ``KNOBS`` are the menu of exercise 5 (the notebook prints
them); which knob fixes which tail is the judge's secret.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading.probes import call, plain

from .clock import FakeClock

#: The causes of a latency tail met in chapter 1 (exercise 5's keys) ...
TAILS = ("timer slack oversleep", "page faults in the loop", "other processes on the same core", "gc pause")
#: ... and the knobs to choose from (exercise 5's values).
KNOBS = ("hybrid wait", "mlockall + prefault", "SCHED_FIFO priority", "gc.freeze()", "more iterations")


def stats_probe(inputs, rttest_statistics):
    """ch01.rttest_stats: one call per latency buffer, each with its page-fault deltas."""
    return {"cases": [call(rttest_statistics, *(np.asarray(a, dtype=np.int64) for a in case))
                      for case in inputs["cases"]]}


class Recorder:
    """The callback the loop probe passes: records ``k``, when it was entered and left, and
    spends the iteration's simulated work on the FakeClock."""

    def __init__(self, clock: FakeClock, work: list[int]):
        self.clock, self.work, self.entered, self.left, self.ks = clock, work, [], [], []

    def __call__(self, *args, **kwargs):
        self.ks.append(args[0] if len(args) == 1 and not kwargs else [list(args), sorted(kwargs)])
        self.entered.append(self.clock.t)
        self.clock.work(int(self.work[min(len(self.entered), len(self.work)) - 1]))
        self.left.append(self.clock.t)


class WakeClock(FakeClock):
    """A FakeClock that also notes the time each absolute sleep returned at (``woke``)."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.woke: list[int] = []

    def sleep_until_ns(self, deadline_ns: int) -> None:
        super().sleep_until_ns(deadline_ns)
        self.woke.append(self.t)


def loop_probe(inputs, absolute_loop):
    """ch01.drift_free_loop: the student's loop on a FakeClock, with two overrunning callbacks."""
    clock = WakeClock(start_ns=inputs["start_ns"], oversleep_ns=inputs["oversleep_ns"],
                      read_cost_ns=inputs["read_cost_ns"], seed=inputs["seed"])
    rec = Recorder(clock, inputs["work"])
    lat = absolute_loop(clock, inputs["period"], inputs["n"], rec)
    if lat is None:
        returned = None
    else:
        try:
            returned = plain(np.asarray(lat).ravel())
        except (TypeError, ValueError):
            returned = plain(lat)
    return {"latencies": returned, "entered": rec.entered, "left": rec.left, "ks": plain(rec.ks),
            "sleep_targets": clock.sleep_targets, "woke": clock.woke, "relative_sleeps": clock.relative_sleeps}


def drift_probe(inputs, drift_ns):
    """ch01.relative_drift: one call per wake-up series."""
    return {"cases": [call(drift_ns, np.asarray(c["wake"], dtype=np.int64), c["start"], c["period"])
                      for c in inputs["cases"]]}


def budget_probe(inputs, controller_budget_ns, meets_5_percent):
    """ch01.budget: the budget at several percentiles, with a tail past the period, and the 5 % rule."""
    lat = np.asarray(inputs["latency"], dtype=np.int64)
    return {"budget": [call(controller_budget_ns, inputs["period"], lat, q) for q in inputs["percentiles"]],
            "late": call(controller_budget_ns, inputs["period"], np.asarray(inputs["late"]), 99.0),
            "meets": [call(meets_5_percent, np.asarray(s), inputs["period"]) for s in inputs["meets"]]}


def knob_probe(inputs, which_knob):
    """ch01.which_knob: the student's dict (or what their function returns)."""
    return call(which_knob) if callable(which_knob) else {"value": plain(which_knob), "type": type(which_knob).__name__}
