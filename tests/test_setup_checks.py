"""The ch00 checks in the student's kernel: right answers pass on fresh inputs, mistakes are listed.

The plausible wrong answers, one per stated property, are the bank's (tests/banks/ch00.py).
"""

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


def test_each_property_costs_only_its_sub_test():
    """A bare number read as ns loses the units sub-test only; no validation loses the refusal only."""
    r = run("ch00.to_ns", lambda t: to_ns(t, bare="ns"), seed=5)
    assert r.points == 1.25 and "to_ns('500') returned 500, expected 500000" in r.message
    r = run("ch00.to_ns", lambda t: to_ns(t, strict=False), seed=5)
    assert r.points == 1.25 and "to_ns('0') returned 0" in r.message


def test_all_failures_are_listed():
    """A to_ns with no validation and a ns default fails several inputs: each is named."""
    r = run("ch00.to_ns", lambda t: to_ns(t, bare="ns", strict=False), seed=3)
    assert r.points == 0.5
    lines = r.message.splitlines()
    assert any("'500'" in m for m in lines) and any("'0'" in m for m in lines) and len(lines) >= 3


def test_expected_ns_is_exact_decimal():
    assert expected_ns("12.3ms") == 12_300_000 and expected_ns("0.5s") == 500_000_000
    assert expected_ns("1.5ns") is None and expected_ns("-1ms") is None and expected_ns("0") is None
    assert Decimal("12.3") * 1_000_000 == 12_300_000
