"""rttest's command-line options, parsed with clear usage errors.

Counterpart: ``rttest_read_args`` (getopt "i:u:p:t:s:m:d:f:r"). Same letters, same defaults,
same units: -u takes ns/us/ms/s (a bare number is microseconds), -m and -d take gb/mb/kb/b
(a bare number is megabytes). Where rttest silently exits on a bad value, this names the
value, the rule and a fix. Extra long options (robocourse only) pick the wait strategy and
the CPU: --wait sleep|hybrid|adaptive|spin, --spin DURATION (hybrid's window, adaptive's upper
bound), --cpu N. The default wait is ``sleep``, rttest's only one (clock_nanosleep to the
absolute deadline); the others must be asked for, because they change both the latency figures
and the CPU the loop burns.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, replace

KIB = 1024
MIB = 1024 * KIB
GIB = 1024 * MIB

_DURATION_UNITS = {"ns": 1, "us": 1_000, "ms": 1_000_000, "s": 1_000_000_000}
_SIZE_UNITS = {"b": 1, "kb": KIB, "mb": MIB, "gb": GIB}
_NUMBER = re.compile(r"^\s*(-?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+))\s*([a-zA-Z]*)\s*$")

_OPTIONS_USAGE = ("[-i ITERATIONS] [-u PERIOD] [-t PRIORITY] [-s fifo|rr] [-m STACK] [-d HEAP] [-f FILE] "
                  "[--wait sleep|hybrid|adaptive|spin] [--spin DURATION] [--cpu N]")
USAGE = f"usage: robocourse rttest {_OPTIONS_USAGE}"

#: what each option means: one table for every command that takes rttest's options
OPTION_HELP = (
    ("-i N", "iterations (default 1000; <= 0 runs until Ctrl-C and keeps no samples file)"),
    ("-u T", "period, ns/us/ms/s (bare number = us; default 1ms)"),
    ("-t P", "real-time priority 1..98 (99 is the kernel's watchdogs'; default 80)"),
    ("-s POL", "fifo or rr (default rr)"),
    ("-m S", "stack prefault, gb/mb/kb/b (bare number = MB; default 1mb)"),
    ("-d S", "heap prefault cap, same units (rttest: 8gb; robocourse uses 64mb unless -d is given; "
             "never more than a quarter of MemAvailable)"),
    ("-f FILE", "write rttest's results file"),
    ("--wait W", "sleep (default: rttest's clock_nanosleep), hybrid (sleep, then spin the last --spin), "
                 "adaptive (sleep, then spin only the window this machine needs, learned as it runs, at most "
                 "--spin) or spin (busy-wait: a whole core)"),
    ("--spin T", "hybrid's spin window, adaptive's upper bound (default 200us)"),
    ("--cpu N", "pin the loop to CPU N"),
)


def usage(prog: str = "robocourse rttest", extra: str = "") -> str:
    """The one-line usage of a command taking rttest's options (``extra``: its own options)."""
    return f"usage: {prog} {_OPTIONS_USAGE}{' ' + extra if extra else ''}"


def help_text(prog: str = "robocourse rttest", extra_usage: str = "", extra_help=(), defaults: dict | None = None) -> str:
    """Usage plus one line per option (``extra_help``: (flag, text) pairs of the command's own options;
    ``defaults``: flag -> text replacing an rttest default the command changes)."""
    rows = list(OPTION_HELP) + list(extra_help)
    width = max(len(f) for f, _ in rows) + 2
    lines = [usage(prog, extra_usage), "", "options:"]
    for flag, text in rows:
        lines.append(f"  {flag:<{width}}{(defaults or {}).get(flag, text)}")
    return "\n".join(lines)


class RttestUsageError(ValueError):
    """A bad rttest option: the message names the option, the value, the rule and a fix."""


@dataclass(frozen=True)
class RttestOptions:
    """rttest's parameters (``struct rttest_params``) plus robocourse's wait strategy."""

    iterations: int = 1000
    period_ns: int = 1_000_000
    priority: int = 80
    policy: str = "rr"
    stack_size: int = 1 * MIB
    heap_size: int = 8 * GIB
    filename: str | None = None
    wait: str = "sleep"
    spin_ns: int = 200_000
    cpu: int | None = None

    def with_(self, **changes) -> RttestOptions:
        return replace(self, **changes)


def parse_duration(text: str, option: str = "-u") -> int:
    """'1ms' -> 1_000_000; '250' -> 250_000 (bare = us); suffixes ns, us, ms, s."""
    m = _NUMBER.match(str(text))
    if not m:
        raise RttestUsageError(f"{option} {text!r}: not a duration; write a number with an optional "
                               f"unit ns, us, ms or s (a bare number is microseconds), e.g. {option} 1ms")
    value, unit = m.group(1), m.group(2).lower()
    unit = unit or "us"
    if unit not in _DURATION_UNITS:
        raise RttestUsageError(f"{option} {text!r}: unknown unit {m.group(2)!r}; use ns, us, ms or s "
                               f"(e.g. {option} 1ms)")
    ns = float(value) * _DURATION_UNITS[unit]
    if ns != int(ns):
        raise RttestUsageError(f"{option} {text!r}: is not a whole number of nanoseconds; "
                               f"round it, e.g. {option} {max(1, round(ns))}ns")
    if ns <= 0:
        raise RttestUsageError(f"{option} {text!r}: the period must be greater than zero (e.g. {option} 1ms)")
    return int(ns)


def parse_size(text: str, option: str = "-m") -> int:
    """'1mb' -> 1 MiB; '512kb'; '2gb'; '100b'; bare number = MB (rttest's rule)."""
    m = _NUMBER.match(str(text))
    if not m:
        raise RttestUsageError(f"{option} {text!r}: not a size; write a number with an optional unit "
                               f"gb, mb, kb or b (a bare number is megabytes), e.g. {option} 1mb")
    value, unit = m.group(1), m.group(2).lower() or "mb"
    if unit not in _SIZE_UNITS:
        raise RttestUsageError(f"{option} {text!r}: unknown unit {m.group(2)!r}; use gb, mb, kb or b "
                               f"(e.g. {option} 8mb)")
    size = float(value) * _SIZE_UNITS[unit]
    if size < 0:
        raise RttestUsageError(f"{option} {text!r}: a size cannot be negative, e.g. {option} 1mb")
    if size != int(size):
        raise RttestUsageError(f"{option} {text!r}: is not a whole number of bytes; use a smaller unit")
    return int(size)


def _parse_int(text: str, option: str, what: str) -> int:
    try:
        return int(str(text).strip(), 10)
    except ValueError:
        raise RttestUsageError(f"{option} {text!r}: {what} must be a whole number, e.g. {option} "
                               f"{'1000' if option == '-i' else '80'}") from None


_SHORT = {"-i", "-u", "-t", "-s", "-m", "-d", "-f"}
_LONG = {"--wait", "--spin", "--cpu"}


def parse_rttest_args(argv, defaults: RttestOptions | None = None, usage_line: str = USAGE) -> RttestOptions:
    """Parse rttest options (``-i 1000 -u 1ms -s fifo -t 98 ...``; also ``-i1000``, ``--wait=spin``).

    ``usage_line`` ends the messages about unknown or incomplete options (the calling command's)."""
    opts = defaults or RttestOptions()
    values: dict[str, str] = {}
    args = list(argv)
    i = 0
    while i < len(args):
        arg = str(args[i])
        if arg.startswith("--"):
            key, eq, val = arg.partition("=")
            if key not in _LONG:
                raise RttestUsageError(f"unknown option {arg!r}. {usage_line}")
            if not eq:
                if i + 1 >= len(args):
                    raise RttestUsageError(f"option {key} needs a value. {usage_line}")
                i += 1
                val = str(args[i])
            values[key] = val
        elif arg.startswith("-") and len(arg) >= 2 and not arg[1].isdigit():
            key, val = arg[:2], arg[2:]
            if key not in _SHORT:
                raise RttestUsageError(f"unknown option {arg!r}. {usage_line}")
            if not val:
                if i + 1 >= len(args):
                    raise RttestUsageError(f"option {key} needs a value. {usage_line}")
                i += 1
                val = str(args[i])
            values[key] = val
        else:
            raise RttestUsageError(f"unexpected argument {arg!r}: rttest takes only options. {usage_line}")
        i += 1

    changes: dict = {}
    if "-i" in values:
        changes["iterations"] = _parse_int(values["-i"], "-i", "the iteration count")
    if "-u" in values:
        changes["period_ns"] = parse_duration(values["-u"], "-u")
    if "-t" in values:
        prio = _parse_int(values["-t"], "-t", "the priority")
        if prio == 99:
            raise RttestUsageError(f"-t {values['-t']!r}: priority 99 is where the kernel's watchdog and migration "
                                   "threads run, and a loop there can starve them; this course takes 1 to 98 "
                                   "(rttest itself would accept 99), e.g. -t 98")
        if not 1 <= prio <= 98:
            raise RttestUsageError(f"-t {values['-t']!r}: real-time priorities run from 1 to 98 here (99 belongs to "
                                   "the kernel's watchdogs), e.g. -t 80")
        changes["priority"] = prio
    if "-s" in values:
        policy = values["-s"].strip().lower()
        if policy not in ("fifo", "rr"):
            raise RttestUsageError(f"-s {values['-s']!r}: the scheduling policy must be fifo or rr, e.g. -s fifo")
        changes["policy"] = policy
    if "-m" in values:
        changes["stack_size"] = parse_size(values["-m"], "-m")
    if "-d" in values:
        changes["heap_size"] = parse_size(values["-d"], "-d")
    if "-f" in values:
        name = values["-f"]
        if not name.strip():
            raise RttestUsageError("-f '': the results file name is empty, e.g. -f results.txt")
        parent = os.path.dirname(os.path.abspath(name))
        if not os.path.isdir(parent):
            raise RttestUsageError(f"-f {name!r}: the folder {parent} does not exist; create it or pick another path")
        changes["filename"] = name
    if "--wait" in values:
        wait = values["--wait"].strip().lower()
        if wait not in ("sleep", "hybrid", "adaptive", "spin"):
            raise RttestUsageError(f"--wait {values['--wait']!r}: use sleep, hybrid, adaptive or spin, "
                                   "e.g. --wait adaptive")
        changes["wait"] = wait
    if "--spin" in values:
        spin = parse_duration(values["--spin"], "--spin")
        changes["spin_ns"] = spin
    if "--cpu" in values:
        cpu = _parse_int(values["--cpu"], "--cpu", "the CPU number")
        allowed = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
        if allowed and cpu not in allowed:
            raise RttestUsageError(f"--cpu {values['--cpu']!r}: this process may run on CPUs "
                                   f"{', '.join(map(str, allowed))}; pick one of them")
        changes["cpu"] = cpu
    period = changes.get("period_ns", opts.period_ns)
    spin = changes.get("spin_ns", opts.spin_ns)
    if "--spin" in values and spin > period:
        raise RttestUsageError(f"--spin {values['--spin']!r}: the spin window ({spin} ns) is longer than the "
                               f"period ({period} ns); use at most the period, e.g. --spin 200us")
    return replace(opts, **changes)
