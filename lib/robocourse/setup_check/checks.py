"""Checks for the chapter 0 exercise (solutions/00_setup_exercises.ipynb): inputs, schemas, sub-tests.

The judge side only (hidden from the grading sandbox); the probes are in
:mod:`robocourse.setup_check.probes`. Every run draws fresh durations, periods, user names and
priorities; the judges compute the expected answers from the rules the exercise states
(rttest's ``-u``, the 5 % budget, limits.conf's ``<domain> <type> <item> <value>``), score each
stated property as its own sub-test and list every mistake they see.
"""

from __future__ import annotations

from decimal import Decimal, InvalidOperation

from ..grading import CheckFailed, Failures, SubTest, register
from ..grading.probes import raised
from ..grading.schema import Call, Dict, List, Str
from . import probes

UNITS = {"ns": 1, "us": 1_000, "ms": 1_000_000, "s": 1_000_000_000, "": 1_000}
UNIT_CASES = ["1ms", "250us", "500", "2s", "100ns"]
DECIMAL_CASES = ["1.5ms", "0.5s", "4.1ms", "12.3us"]  # 4.1 * 1e6 < 4_100_000 in floats
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


# --- ch00.to_ns --------------------------------------------------------------------------------

def _to_ns_inputs(rng):
    units = list(UNIT_CASES) + [f"{int(rng.integers(1, 5000))}{u}" for u in ("ns", "us", "ms", "s", "")]
    decimals = list(DECIMAL_CASES) + [f"{int(rng.integers(0, 50))}.{int(rng.integers(1, 10))}{u}" for u in ("ms", "s")]
    bad = list(BAD_DURATIONS) + [f"-{int(rng.integers(1, 999))}{rng.choice(['ms', 'us', ''])}",
                                 f"{int(rng.integers(1, 99))}{rng.choice(['min', 'Hz', 'sec', 'm'])}"]
    return {"good": units + decimals, "n_units": len(units), "bad": bad}


def _to_ns_units(inputs, outputs):
    f = Failures()
    n = inputs["n_units"]
    for text, got in zip(inputs["good"][:n], outputs["good"][:n], strict=True):
        want = expected_ns(text)
        if "raised" in got:
            f.add(f"to_ns({text!r}) raised {got['raised']}: {got['message']}; expected {want}")
        elif got["value"] != want:
            hint = ""
            if not text.rstrip("0123456789") and got["value"] * 1000 == want:
                hint = " (a bare number means microseconds, as in rttest -u)"
            f.add(f"to_ns({text!r}) returned {got['value']!r}, expected {want}{hint}")
    return f.done("")


def _to_ns_decimals(inputs, outputs):
    f = Failures()
    n = inputs["n_units"]
    for text, got in zip(inputs["good"], outputs["good"], strict=True):
        want = expected_ns(text)
        if "raised" in got:
            if inputs["good"].index(text) >= n:
                f.add(f"to_ns({text!r}) raised {got['raised']}: {got['message']}; expected {want}")
        elif got["type"] != "int":
            f.add(f"to_ns({text!r}) returned {got['type']} {got['value']!r}: return an int number of nanoseconds")
        elif got["value"] != want and "." in text:
            hint = " (float arithmetic: int() truncates, round() the product)" if abs(got["value"] - want) <= 1 else ""
            f.add(f"to_ns({text!r}) returned {got['value']}, expected {want}{hint}")
    return f.done("")


def _to_ns_refuses(inputs, outputs):
    f = Failures()
    for text, got in zip(inputs["bad"], outputs["bad"], strict=True):
        if not raised(got, "ValueError"):
            what = f"raised {got['raised']}" if "raised" in got else f"returned {got['value']!r}"
            f.add(f"to_ns({text!r}) {what}; a period must be a positive duration, so raise ValueError with a "
                  "message naming the value and the accepted suffixes")
        elif text.strip() and text not in got["message"]:
            f.add(f"to_ns({text!r}) raised ValueError({got['message']!r}): name the value in the message, e.g. "
                  f"ValueError(f\"bad duration {{text!r}}: ...\")")
    return f.done("")


register("ch00.to_ns", uses=("to_ns",), probe=probes.to_ns_probe, inputs=_to_ns_inputs, time_limit=5,
         references=("robocourse.rt.options:parse_duration",),
         schema=Dict(good=List(Call(), length="good"), bad=List(Call(), length="bad")),
         subtests=[SubTest("the units ns, us, ms, s, and a bare number in microseconds", 0.75, _to_ns_units,
                           reads="good"),
                   SubTest("an int number of ns, decimals exact", 0.5, _to_ns_decimals, reads="good"),
                   SubTest("ValueError naming the value for anything but a positive duration", 0.75, _to_ns_refuses,
                           reads="bad")])


# --- ch00.budget -------------------------------------------------------------------------------

def _budget_inputs(rng):
    periods = [1_000_000, 500_000, 10_000_000] + [int(p) for p in rng.integers(10_000, 100_000_000, 3)]
    fractions = [[1_000_000, round(float(x), 3)] for x in rng.uniform(0.01, 0.3, 2)] + \
                [[int(rng.integers(10_000, 10_000_000)), round(float(rng.uniform(0.01, 0.5)), 3)]]
    return {"periods": periods, "fractions": fractions, "bad": [0, -1_000_000, -int(rng.integers(1, 10**6))]}


def _near(got, want) -> bool:
    """An int within 1 ns of the exact budget (rounded or truncated)."""
    return "value" in got and isinstance(got["value"], (int, float)) and not isinstance(got["value"], bool) \
        and abs(got["value"] - want) < 1


def _shown(got) -> str:
    return f"raised {got['raised']}" if "raised" in got else f"returned {got['value']!r}"


def _budget_default(inputs, outputs):
    f = Failures()
    for period, got in zip(inputs["periods"], outputs["default"], strict=True):
        if not _near(got, period * 0.05):
            f.add(f"latency_budget_ns({period}) {_shown(got)}; 5 % of {period} ns is {round(period * 0.05)} ns")
    return f.done("")


def _budget_fraction(inputs, outputs):
    f = Failures()
    for (period, fraction), got in zip(inputs["fractions"], outputs["fraction"], strict=True):
        if not _near(got, period * fraction):
            f.add(f"latency_budget_ns({period}, fraction={fraction}) {_shown(got)}, expected "
                  f"{round(period * fraction)}: use the fraction given")
    return f.done("")


def _budget_int(inputs, outputs):
    f = Failures()
    for period, got in zip(inputs["periods"] + [p for p, _ in inputs["fractions"]],
                           outputs["default"] + outputs["fraction"], strict=True):
        if "value" in got and got["type"] != "int":
            f.add(f"latency_budget_ns({period}) returned {got['type']} {got['value']!r}: return an int number of "
                  "ns (round() the product)")
    return f.done("")


def _budget_refuses(inputs, outputs):
    f = Failures()
    for period, got in zip(inputs["bad"], outputs["bad"], strict=True):
        if not raised(got, "ValueError"):
            f.add(f"latency_budget_ns({period}) {_shown(got)}; it should raise ValueError: a period must be positive")
    return f.done("")


register("ch00.budget", uses=("latency_budget_ns",), probe=probes.budget_probe, inputs=_budget_inputs, time_limit=5,
         schema=Dict(default=List(Call(), length="periods"), fraction=List(Call(), length="fractions"),
                     bad=List(Call(), length="bad")),
         subtests=[SubTest("5 % of the period by default", 0.25, _budget_default, reads="default"),
                   SubTest("the fraction given", 0.25, _budget_fraction, reads="fraction"),
                   SubTest("an int number of ns", 0.25, _budget_int, reads=("default", "fraction")),
                   SubTest("ValueError for a period that is not positive", 0.25, _budget_refuses, reads="bad")])


# --- ch00.limits_conf --------------------------------------------------------------------------

USERS = ["alice", "bob", "chen", "dara", "emil", "farah", "gosia", "hiro"]


def _limits_inputs(rng):
    a, b, c, d = (str(u) for u in rng.choice(USERS, 4, replace=False))
    custom = [[b, int(rng.integers(2, 98)), int(rng.integers(1, 64)) * 65536], [c, 1, -1], [d, 98, 4096]]
    return {"default_user": a, "custom": custom,
            "bad": [99, 0, 100, -int(rng.integers(1, 50)), int(rng.integers(101, 200))]}


_LINES = Call(List(Str(max_len=500), max_len=50))


def _norm(value) -> list[str]:
    return sorted(" ".join(line.split()) for line in value)


def _lines_problem(call_text: str, got, want: list[str]) -> str:
    if "raised" in got:
        return f"{call_text} raised {got['raised']}: {got['message']}; expected {want}"
    if len(got["value"]) != 2:
        return f"{call_text} should return a list of 2 lines, got {got['value']!r}"
    if _norm(got["value"]) != want:
        return (f"{call_text} returned {got['value']!r}; each line is '<user> - <item> <value>' ('-' sets the soft and "
                f"hard limit), expected {want}")
    return ""


def _limits_default(inputs, outputs):
    u = inputs["default_user"]
    problem = _lines_problem(f"limits_conf_lines({u!r})", outputs["default"],
                             sorted([f"{u} - rtprio 98", f"{u} - memlock -1"]))
    if problem:
        raise CheckFailed(problem + " (by default rtprio 98 and memlock -1, unlimited)")
    return ""


def _limits_custom(inputs, outputs):
    f = Failures()
    for (user, prio, mem), got in zip(inputs["custom"], outputs["custom"], strict=True):
        problem = _lines_problem(f"limits_conf_lines({user!r}, rtprio={prio}, memlock_kb={mem})", got,
                                 sorted([f"{user} - rtprio {prio}", f"{user} - memlock {mem}"]))
        if problem:
            f.add(problem)
    return f.done("")


def _limits_refuses(inputs, outputs):
    f = Failures()
    for prio, got in zip(inputs["bad"], outputs["bad"], strict=True):
        if not raised(got, "ValueError"):
            f.add(f"limits_conf_lines({inputs['default_user']!r}, rtprio={prio}) {_shown(got)}; it should raise "
                  "ValueError: use 1..98 (99 belongs to the kernel's watchdog threads)")
    return f.done("")


register("ch00.limits_conf", uses=("limits_conf_lines",), probe=probes.limits_probe, inputs=_limits_inputs,
         time_limit=5,
         schema=Dict(default=_LINES, custom=List(_LINES, length="custom"), bad=List(Call(), length="bad")),
         subtests=[SubTest("the default lines: rtprio 98, memlock -1", 0.5, _limits_default, reads="default"),
                   SubTest("the given user, priority (1..98) and memlock", 0.75, _limits_custom, reads="custom"),
                   SubTest("ValueError for a priority outside 1..98", 0.75, _limits_refuses, reads="bad")])
