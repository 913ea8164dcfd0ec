"""The student-side half of chapter 0's checks: the probes that call the exercise's functions.

They run where the student's code runs (their kernel, or the grading sandbox) and return only
what came out; the expected answers and the judges are in :mod:`robocourse.setup_check.checks`,
which the grading sandbox hides.
"""

from __future__ import annotations

from robocourse.grading.probes import call


def to_ns_probe(inputs, to_ns):
    """ch00.to_ns: every duration the grader drew, good and bad."""
    return {"good": [call(to_ns, t) for t in inputs["good"]], "bad": [call(to_ns, t) for t in inputs["bad"]]}


def budget_probe(inputs, latency_budget_ns):
    """ch00.budget: the default 5 %, other fractions, and periods that are not positive."""
    return {"default": [call(latency_budget_ns, p) for p in inputs["periods"]],
            "fraction": [call(latency_budget_ns, p, fraction=x) for p, x in inputs["fractions"]],
            "bad": [call(latency_budget_ns, p) for p in inputs["bad"]]}


def limits_probe(inputs, limits_conf_lines):
    """ch00.limits_conf: the defaults, given values (the edges 1 and 98 included), and bad priorities."""
    return {"default": call(limits_conf_lines, inputs["default_user"]),
            "custom": [call(limits_conf_lines, user, rtprio=prio, memlock_kb=mem) for user, prio, mem in inputs["custom"]],
            "bad": [call(limits_conf_lines, inputs["default_user"], rtprio=p) for p in inputs["bad"]]}
