"""Chapter 0's answer bank (solutions/00_setup_exercises.ipynb): one wrong answer per stated property."""

from robocourse.grading.bank import Answer, Exercise

NB = "00_setup_exercises"

TO_NS = Exercise(
    "ch00.to_ns", NB,
    right=[Answer("string methods and Decimal", code='''
from decimal import Decimal, InvalidOperation


def to_ns(text):
    s = str(text).strip()
    for suffix, scale in (("ns", 1), ("us", 1_000), ("ms", 1_000_000), ("s", 1_000_000_000)):
        if s.endswith(suffix):
            number = s[: -len(suffix)].strip()
            break
    else:
        number, scale = s, 1_000
    try:
        value = Decimal(number) * scale
    except InvalidOperation:
        raise ValueError(f"{text!r} is not a duration like 1ms, 250us, 500 (us) or 2s") from None
    if not number or not value > 0:
        raise ValueError(f"{text!r}: a period must be positive")
    return int(value.to_integral_value())
''')],
    wrong=[
        Answer("a bare number in nanoseconds", replace=[('"": 1_000}', '"": 1}')], score=1.25,
               property="a bare number means microseconds", says="a bare number means microseconds"),
        Answer("the s suffix tested first", code='''
def to_ns(text):
    text = str(text).strip()
    for suffix, scale in (("s", 1_000_000_000), ("ms", 1_000_000), ("us", 1_000), ("ns", 1)):
        if text.endswith(suffix):
            value = round(float(text[: -len(suffix)]) * scale)
            break
    else:
        value = round(float(text) * 1_000)
    if value <= 0:
        raise ValueError(f"bad duration {text!r}")
    return value
''', score=0.0, property="each suffix parsed (ms, us, ns are not s)", says="to_ns('1ms') raised ValueError"),
        Answer("int() truncates", replace=[("value = round(float(m.group(1)) * units[m.group(2)])",
                                            "value = int(float(m.group(1)) * units[m.group(2)])")],
               score=1.5, property="decimals exact", says="int() truncates"),
        Answer("returns a float", replace=[("    return value\n", "    return float(value)\n")], score=1.5,
               property="an int number of ns", says="return an int number of nanoseconds"),
        Answer("zero and negatives accepted", replace=[(r"(\d+(?:\.\d*)?|\.\d+)", r"(-?\d+(?:\.\d*)?|\.\d+)"),
                                                       ("    if value <= 0:\n", "    if False:\n")],
               score=1.25, property="a period must be positive", says="to_ns('0') returned 0"),
        Answer("a message that does not name the value", replace=[
            ('raise ValueError(f"bad duration {text!r}: use a positive number with ns, us, ms or s (bare = us)")',
             'raise ValueError("bad duration")'),
            ('raise ValueError(f"bad duration {text!r}: a period must be positive")',
             'raise ValueError("a period must be positive")')],
               score=1.25, property="the message names the value", says="name the value in the message"),
        Answer("KeyError for an unknown unit", code='''
import re

UNITS = {"ns": 1, "us": 1_000, "ms": 1_000_000, "s": 1_000_000_000, "": 1_000}


def to_ns(text):
    m = re.fullmatch(r"\\s*([0-9.]+)\\s*([a-zA-Z]*)\\s*", str(text))
    if not m:
        raise ValueError(f"bad duration {text!r}")
    value = round(float(m.group(1)) * UNITS[m.group(2)])
    if value <= 0:
        raise ValueError(f"bad duration {text!r}: must be positive")
    return value
''', score=1.25, property="ValueError for a bad unit, not another exception", says="raised KeyError"),
    ])

BUDGET = Exercise(
    "ch00.budget", NB,
    right=[Answer("integer arithmetic", code='''
def latency_budget_ns(period_ns, fraction=0.05):
    if not period_ns > 0:
        raise ValueError(f"period_ns={period_ns}: a period is a positive number of ns")
    return int(period_ns * fraction + 0.5)
''')],
    wrong=[
        Answer("ignores the fraction", replace=[("return round(period_ns * fraction)", "return round(period_ns * 0.05)")],
               score=0.75, property="the fraction given", says="use the fraction given"),
        Answer("returns a float", replace=[("return round(period_ns * fraction)", "return period_ns * fraction")],
               score=0.75, property="an int number of ns", says="return an int"),
        Answer("no check of the period", replace=[("    if period_ns <= 0:\n        raise ValueError(f\"period_ns must be "
                                                   "positive, got {period_ns}\")\n", "")],
               score=0.75, property="ValueError for a period that is not positive", says="should raise ValueError"),
        Answer("the fraction as a percentage", code='''
def latency_budget_ns(period_ns, fraction=5):
    if period_ns <= 0:
        raise ValueError(f"period_ns must be positive, got {period_ns}")
    return round(period_ns * fraction / 100)
''', score=0.75, property="fraction is a fraction (0.05), not a percentage", says="use the fraction given"),
    ])

LIMITS = Exercise(
    "ch00.limits_conf", NB,
    right=[Answer("a loop over the items", code='''
def limits_conf_lines(user, rtprio=98, memlock_kb=-1):
    if rtprio not in range(1, 99):
        raise ValueError(f"rtprio={rtprio}: give 1..98; 99 is the kernel watchdogs' priority")
    return [" ".join([user, "-", item, str(value)]) for item, value in (("rtprio", rtprio), ("memlock", memlock_kb))]
''')],
    wrong=[
        Answer("hard limits only", replace=[("f\"{user} - rtprio", "f\"{user} hard rtprio"),
                                            ("f\"{user} - memlock", "f\"{user} hard memlock")],
               score=0.75, property="the type '-' (soft and hard)", says="'-' sets the soft and hard limit"),
        Answer("unlimited written out", code='''
def limits_conf_lines(user, rtprio=98, memlock_kb=None):
    if not 1 <= int(rtprio) <= 98:
        raise ValueError(f"rtprio {rtprio} is outside 1..98 (99 is for kernel watchdogs)")
    return [f"{user} - rtprio {int(rtprio)}", f"{user} - memlock {memlock_kb or 'unlimited'}"]
''', score=1.5, property="memlock -1 by default", says="memlock -1"),
        Answer("refuses only 99", replace=[("    if not 1 <= int(rtprio) <= 98:", "    if int(rtprio) == 99:")],
               score=1.25, property="priorities outside 1..98 refused", says="rtprio=0"),
        Answer("edges refused too", replace=[("    if not 1 <= int(rtprio) <= 98:", "    if not 1 < int(rtprio) < 98:")],
               score=0.75, property="1 and 98 are valid priorities", says="rtprio=1"),
        Answer("memlock in bytes", replace=[("f\"{user} - memlock {int(memlock_kb)}\"",
                                             "f\"{user} - memlock {int(memlock_kb) * 1024 if memlock_kb > 0 else -1}\"")],
               score=1.25, property="memlock in kB", says="memlock_kb="),
    ])

EXERCISES = [TO_NS, BUDGET, LIMITS]
