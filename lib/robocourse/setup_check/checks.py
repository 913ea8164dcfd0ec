"""Checks for the chapter 0 exercise (solutions/00_setup_exercises.ipynb)."""

from __future__ import annotations

from ..grading import CheckFailed, register

NS_TABLE = {"1ms": 1_000_000, "250us": 250_000, "500": 500_000, "2s": 2_000_000_000, "100ns": 100,
            "1.5ms": 1_500_000, "0.5s": 500_000_000}
BAD_DURATIONS = ["", "abc", "-1ms", "1 minute", "ms", "1kHz", "0", "0us"]


@register("ch00.to_ns", weight=2, time_limit=5)
def check_to_ns(to_ns):
    """to_ns parses rttest's -u durations (bare number = microseconds)."""
    for text, want in NS_TABLE.items():
        got = to_ns(text)
        if not isinstance(got, int) or isinstance(got, bool):
            raise CheckFailed(f"to_ns({text!r}) should return an int number of nanoseconds, got {type(got).__name__} {got!r}")
        if got != want:
            hint = " (a bare number means microseconds, as in rttest -u)" if text == "500" else ""
            raise CheckFailed(f"to_ns({text!r}) returned {got}, expected {want}{hint}")
    for text in BAD_DURATIONS:
        try:
            got = to_ns(text)
        except ValueError:
            continue
        raise CheckFailed(f"to_ns({text!r}) returned {got!r}; a period must be a positive duration, "
                          "so raise ValueError with a message naming the value and the accepted suffixes")
    return f"all {len(NS_TABLE)} durations parsed and {len(BAD_DURATIONS)} bad ones rejected"


@register("ch00.budget", weight=1, time_limit=5)
def check_budget(latency_budget_ns):
    """latency_budget_ns gives the 5 % latency budget of a period."""
    cases = {1_000_000: 50_000, 500_000: 25_000, 10_000_000: 500_000}
    for period, want in cases.items():
        got = latency_budget_ns(period)
        if got != want:
            raise CheckFailed(f"latency_budget_ns({period}) returned {got!r}; 5 % of {period} ns is {want} ns")
    got = latency_budget_ns(1_000_000, fraction=0.10)
    if got != 100_000:
        raise CheckFailed(f"latency_budget_ns(1_000_000, fraction=0.10) returned {got!r}, expected 100000")
    for bad in (0, -1_000_000):
        try:
            latency_budget_ns(bad)
        except ValueError:
            continue
        raise CheckFailed(f"latency_budget_ns({bad}) should raise ValueError: a period must be positive")
    return "the 1 kHz budget is 50 us"


@register("ch00.limits_conf", weight=2, time_limit=5)
def check_limits_conf(limits_conf_lines):
    """limits_conf_lines writes the two /etc/security/limits.conf lines real-time work needs."""
    lines = limits_conf_lines("alice")
    if not isinstance(lines, list) or len(lines) != 2:
        raise CheckFailed(f"limits_conf_lines('alice') should return a list of 2 lines, got {lines!r}")
    norm = sorted(" ".join(str(line).split()) for line in lines)
    want = sorted(["alice - rtprio 98", "alice - memlock -1"])
    if norm != want:
        raise CheckFailed(f"limits_conf_lines('alice') returned {lines!r}; each line is '<user> - <item> <value>', "
                          f"expected {want}")
    lines = limits_conf_lines("bob", rtprio=80, memlock_kb=1048576)
    norm = sorted(" ".join(str(line).split()) for line in lines)
    if norm != sorted(["bob - rtprio 80", "bob - memlock 1048576"]):
        raise CheckFailed(f"limits_conf_lines('bob', rtprio=80, memlock_kb=1048576) returned {lines!r}")
    for bad in (99, 0, 100):
        try:
            limits_conf_lines("alice", rtprio=bad)
        except ValueError:
            continue
        raise CheckFailed(f"rtprio={bad} should raise ValueError: use 1..98 (99 belongs to the kernel's watchdog threads)")
    return "both lines right, and priority 99 refused"
