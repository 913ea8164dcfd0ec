"""The ch00 checks: right answers pass on fresh inputs, the usual mistakes fail with a message naming them."""

from __future__ import annotations

import re
from decimal import Decimal

import numpy as np
import pytest

from robocourse.grading.checks import get, run_check
from robocourse.setup_check.checks import expected_ns

UNITS = {"ns": 1, "us": 1_000, "ms": 1_000_000, "s": 1_000_000_000, "": 1_000}


def to_ns(text, *, scale=round, bare="us", strict=True):
    m = re.fullmatch(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*(ns|us|ms|s|)\s*", str(text))
    if not m:
        raise ValueError(f"bad duration {text!r}")
    value = scale(float(m.group(1)) * UNITS[m.group(2) or bare])
    if strict and value <= 0:
        raise ValueError(f"{text!r} is not positive")
    return value


def budget(period, fraction=0.05):
    if period <= 0:
        raise ValueError("period must be positive")
    return round(period * fraction)


def limits(user, rtprio=98, memlock_kb=-1):
    if not 1 <= rtprio <= 98:
        raise ValueError("rtprio 1..98")
    return [f"{user} - rtprio {rtprio}", f"{user} - memlock {memlock_kb}"]


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_right_answers_pass_on_fresh_inputs(seed):
    assert run("ch00.to_ns", to_ns, seed=seed).points == 2
    assert run("ch00.budget", budget, seed=seed).points == 1
    assert run("ch00.limits_conf", limits, seed=seed).points == 2


@pytest.mark.parametrize("name, attempt, fragments", [
    ("ch00.to_ns", lambda t: to_ns(t, bare="ns"), ["to_ns('500') returned 500, expected 500000", "microseconds"]),
    ("ch00.to_ns", lambda t: to_ns(t, strict=False), ["to_ns('0') returned 0", "raise ValueError"]),
    ("ch00.to_ns", lambda t: to_ns(t, scale=float), ["should return an int"]),
    ("ch00.to_ns", lambda t: to_ns(t, scale=int), ["int() truncates"]),
    ("ch00.budget", lambda p, fraction=0.05: p * fraction, ["latency_budget_ns(0) should raise ValueError"]),
    ("ch00.budget", lambda p, fraction=0.05: round(abs(p) * fraction), ["latency_budget_ns(-1000000) should raise"]),
    ("ch00.budget", lambda p, fraction=0.05: budget(p, 0.05), ["fraction=", "expected"]),
    ("ch00.limits_conf", lambda u, rtprio=98, memlock_kb=-1: [f"{u} - rtprio {rtprio}", f"{u} - memlock {memlock_kb}"],
     ["rtprio=99 should raise ValueError"]),
    ("ch00.limits_conf", lambda u, rtprio=99, memlock_kb=-1: limits(u, min(rtprio, 98), memlock_kb)[:1],
     ["should return a list of 2 lines"]),
    ("ch00.limits_conf", lambda u, rtprio=98, memlock_kb=-1: [f"{u} rtprio {rtprio}", f"{u} memlock {memlock_kb}"]
     if 1 <= rtprio <= 98 else limits(u, rtprio), ["'<user> - <item> <value>'"]),
])
def test_wrong_attempts_fail_with_their_reason(name, attempt, fragments):
    r = run(name, attempt, seed=5)
    assert not r.passed and r.points == 0
    for fragment in fragments:
        assert fragment in r.message, r.message


def test_all_failures_are_listed():
    """A to_ns with no validation and a ns default fails several inputs: each is named."""
    r = run("ch00.to_ns", lambda t: to_ns(t, bare="ns", strict=False), seed=3)
    lines = r.message.splitlines()
    assert any("'500'" in m for m in lines) and any("'0'" in m for m in lines) and len(lines) >= 3


def test_expected_ns_is_exact_decimal():
    assert expected_ns("12.3ms") == 12_300_000 and expected_ns("0.5s") == 500_000_000
    assert expected_ns("1.5ns") is None and expected_ns("-1ms") is None and expected_ns("0") is None
    assert Decimal("12.3") * 1_000_000 == 12_300_000
