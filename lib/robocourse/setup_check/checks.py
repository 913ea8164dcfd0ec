"""Checks for the chapter 0 exercise (solutions/00_setup_exercises.ipynb), as probe + judge.

Every run draws fresh durations, periods, user names and priorities; the judges compute the
expected answers from the rules the exercise states (rttest's ``-u``, the 5 % budget,
limits.conf's ``<domain> <type> <item> <value>``) and list every mistake they see.
"""

from __future__ import annotations

from decimal import Decimal, InvalidOperation

from ..grading import Failures, register
from ..grading.probes import call, raised

UNITS = {"ns": 1, "us": 1_000, "ms": 1_000_000, "s": 1_000_000_000, "": 1_000}
FIXED = ["1ms", "250us", "500", "2s", "100ns", "1.5ms", "0.5s", "4.1ms"]  # 4.1 * 1e6 < 4_100_000 in floats
BAD_DURATIONS = ["", "abc", "-1ms", "1 minute", "ms", "1kHz", "0", "0us"]


def expected_ns(text: str) -> int | None:
    """The exercise's rule, exactly (Decimal): number + unit (bare = us), a positive whole ns; else None."""
    s = text.strip()
    unit = next((u for u in ("ns", "us", "ms", "s") if s.endswith(u)), "")
    number = s[: len(s) - len(unit)].strip()
    try:
        value = Decimal(number) * UNITS[unit]
    except (InvalidOperation, ValueError):
        return None
    if not number or number.startswith(("-", "+")) or value <= 0 or value != value.to_integral_value():
        return None
    return int(value)


def _to_ns_inputs(rng):
    good = list(FIXED)
    for unit in ("ns", "us", "ms", "s", ""):
        good.append(f"{int(rng.integers(1, 5000))}{unit}")
    for unit in ("ms", "s"):
        good.append(f"{int(rng.integers(0, 50))}.{int(rng.integers(1, 10))}{unit}")
    return {"good": good, "bad": list(BAD_DURATIONS)}


def _to_ns_probe(inputs, to_ns):
    return {"good": [call(to_ns, t) for t in inputs["good"]], "bad": [call(to_ns, t) for t in inputs["bad"]]}


@register("ch00.to_ns", weight=2, time_limit=5, uses=("to_ns",), probe=_to_ns_probe, inputs=_to_ns_inputs,
          references=("robocourse.rt.options:parse_duration",))
def check_to_ns(inputs, outputs):
    """to_ns parses rttest's -u durations (bare number = microseconds)."""
    f = Failures()
    for text, got in zip(inputs["good"], outputs["good"], strict=True):
        want = expected_ns(text)
        if "raised" in got:
            f.add(f"to_ns({text!r}) raised {got['raised']}: {got['message']}; expected {want}")
        elif got.get("type") != "int":
            f.add(f"to_ns({text!r}) should return an int number of nanoseconds, got {got.get('type')} {got['value']!r}")
        elif got["value"] != want:
            hint = ""
            if "." in text and abs(got["value"] - want) <= 1:
                hint = " (float arithmetic: int() truncates, round() the product)"
            elif not text.rstrip("0123456789.") and got["value"] * 1000 == want:
                hint = " (a bare number means microseconds, as in rttest -u)"
            f.add(f"to_ns({text!r}) returned {got['value']}, expected {want}{hint}")
    for text, got in zip(inputs["bad"], outputs["bad"], strict=True):
        if not raised(got, "ValueError"):
            what = f"raised {got['raised']}" if "raised" in got else f"returned {got['value']!r}"
            f.add(f"to_ns({text!r}) {what}; a period must be a positive duration, so raise ValueError with a "
                  "message naming the value and the accepted suffixes")
    return f.done(f"all {len(inputs['good'])} durations parsed and {len(inputs['bad'])} bad ones rejected")


def _budget_inputs(rng):
    periods = [1_000_000, 500_000, 10_000_000] + [int(p) for p in rng.integers(10_000, 100_000_000, 3)]
    fractions = [round(float(x), 3) for x in rng.uniform(0.01, 0.3, 2)]
    return {"periods": periods, "fractions": fractions, "bad": [0, -1_000_000]}


def _budget_probe(inputs, latency_budget_ns):
    return {"default": [call(latency_budget_ns, p) for p in inputs["periods"]],
            "fraction": [call(latency_budget_ns, 1_000_000, fraction=x) for x in inputs["fractions"]],
            "bad": [call(latency_budget_ns, p) for p in inputs["bad"]]}


def _must_refuse(f: Failures, bad_inputs, outputs, message: str) -> None:
    """Each bad input must have raised ValueError (or a subclass); ``message`` formats the input."""
    for value, got in zip(bad_inputs, outputs, strict=True):
        if not raised(got, "ValueError"):
            f.add(message.format(value))


def _value(got):
    v = got.get("value")
    return v if isinstance(v, (int, float)) and not isinstance(v, bool) else None


@register("ch00.budget", weight=1, time_limit=5, uses=("latency_budget_ns",), probe=_budget_probe,
          inputs=_budget_inputs)
def check_budget(inputs, outputs):
    """latency_budget_ns gives the 5 % latency budget of a period."""
    f = Failures()
    for period, got in zip(inputs["periods"], outputs["default"], strict=True):
        want = period * 0.05
        v = _value(got)
        if v is None or abs(v - want) > 1:
            shown = f"raised {got['raised']}" if "raised" in got else f"returned {got.get('value')!r}"
            f.add(f"latency_budget_ns({period}) {shown}; 5 % of {period} ns is {round(want)} ns")
    for fraction, got in zip(inputs["fractions"], outputs["fraction"], strict=True):
        want = 1_000_000 * fraction
        v = _value(got)
        if v is None or abs(v - want) > 1:
            f.add(f"latency_budget_ns(1_000_000, fraction={fraction}) returned {got.get('value', got.get('raised'))!r}, "
                  f"expected {round(want)}")
    _must_refuse(f, inputs["bad"], outputs["bad"], "latency_budget_ns({}) should raise ValueError: a period must "
                 "be positive")
    return f.done("the 1 kHz budget is 50 us, and every other period and fraction right")


USERS = ["alice", "bob", "chen", "dara", "emil", "farah", "gosia", "hiro"]


def _limits_inputs(rng):
    a, b = (str(u) for u in rng.choice(USERS, 2, replace=False))
    return {"default_user": a, "user": b, "rtprio": int(rng.integers(1, 99)),
            "memlock_kb": int(rng.integers(1, 64)) * 65536, "bad": [99, 0, 100]}


def _limits_probe(inputs, limits_conf_lines):
    return {"default": call(limits_conf_lines, inputs["default_user"]),
            "custom": call(limits_conf_lines, inputs["user"], rtprio=inputs["rtprio"], memlock_kb=inputs["memlock_kb"]),
            "bad": [call(limits_conf_lines, inputs["default_user"], rtprio=p) for p in inputs["bad"]]}


def _norm(got):
    lines = got.get("value")
    if not isinstance(lines, list):
        return None
    return sorted(" ".join(str(line).split()) for line in lines)


@register("ch00.limits_conf", weight=2, time_limit=5, uses=("limits_conf_lines",), probe=_limits_probe,
          inputs=_limits_inputs)
def check_limits_conf(inputs, outputs):
    """limits_conf_lines writes the two /etc/security/limits.conf lines real-time work needs."""
    f = Failures()
    u = inputs["default_user"]
    want = sorted([f"{u} - rtprio 98", f"{u} - memlock -1"])
    got = outputs["default"]
    if _norm(got) is None or len(got["value"]) != 2:
        f.add(f"limits_conf_lines({u!r}) should return a list of 2 lines, got {got.get('value', got.get('raised'))!r}")
    elif _norm(got) != want:
        f.add(f"limits_conf_lines({u!r}) returned {got['value']!r}; each line is '<user> - <item> <value>', "
              f"expected {want}")
    b, prio, mem = inputs["user"], inputs["rtprio"], inputs["memlock_kb"]
    want = sorted([f"{b} - rtprio {prio}", f"{b} - memlock {mem}"])
    if _norm(outputs["custom"]) != want:
        f.add(f"limits_conf_lines({b!r}, rtprio={prio}, memlock_kb={mem}) returned "
              f"{outputs['custom'].get('value', outputs['custom'].get('raised'))!r}, expected {want}")
    _must_refuse(f, inputs["bad"], outputs["bad"], "rtprio={} should raise ValueError: use 1..98 (99 belongs to the "
                 "kernel's watchdog threads)")
    return f.done("both lines right for any user, and priority 99 refused")
