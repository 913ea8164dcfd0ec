"""Run the system's cyclictest (rt-tests) with settings matching a Python loop, and parse it.

cyclictest is the C reference: one thread per CPU or one thread, ``clock_nanosleep`` to an
absolute deadline, latency = wake - deadline. :func:`run_cyclictest` runs it with verbose
per-sample output (``-v``, in ns with ``-N``) so its percentiles are computed exactly like
the Python loop's, and also parses its summary line; :func:`parse_summary`,
:func:`parse_verbose` and :func:`parse_json` read its three output formats.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field

import numpy as np

INSTALL_HINT = ("cyclictest is not installed. Install it with:  sudo apt-get install rt-tests   "
                "(Fedora: sudo dnf install realtime-tests)")

_SUMMARY = re.compile(
    r"T:\s*(?P<thread>\d+)\s*\(\s*(?P<tid>\d+)\)\s*P:\s*(?P<prio>\d+)\s*I:\s*(?P<interval>\d+)\s*"
    r"C:\s*(?P<cycles>\d+)\s*Min:\s*(?P<min>\d+)\s*Act:\s*(?P<act>\d+)\s*Avg:\s*(?P<avg>\d+)\s*Max:\s*(?P<max>\d+)")
_VERBOSE = re.compile(r"^\s*(\d+):\s*(\d+):\s*(-?\d+)\s*$")


class CyclictestMissing(FileNotFoundError):
    """cyclictest is not on PATH; the message says how to install it."""


@dataclass
class ThreadSummary:
    """One ``T:`` line of cyclictest's summary (values in cyclictest's unit: us, or ns with -N)."""

    thread: int
    tid: int
    priority: int
    interval_us: int
    cycles: int
    min: int
    act: int
    avg: int
    max: int


@dataclass
class CyclictestResult:
    command: list[str]
    returncode: int
    unit: str
    threads: list[ThreadSummary]
    latency_ns: np.ndarray
    stdout: str = field(repr=False, default="")
    stderr: str = field(repr=False, default="")

    def stats(self):
        from .stats import compute_stats

        return compute_stats(self.latency_ns)

    def summary(self, label: str | None = None) -> str:
        s = self.stats()
        return (f"{label or 'cyclictest (C)':<22} n={s.iterations:<6} p50={s.p50 / 1000:8.1f} us  "
                f"p99={s.p99 / 1000:8.1f} us  p99.9={s.p999 / 1000:8.1f} us  "
                f"max={s.max_latency / 1000:8.1f} us")


def cyclictest_path() -> str:
    path = shutil.which("cyclictest")
    if path is None:
        raise CyclictestMissing(INSTALL_HINT)
    return path


def available() -> bool:
    return shutil.which("cyclictest") is not None


def parse_summary(text: str) -> list[ThreadSummary]:
    """Every ``T: 0 ( 9923) P:80 I:1000 C: 2000 Min: 14 Act: 26 Avg: 25 Max: 2915`` line."""
    out = []
    for m in _SUMMARY.finditer(text):
        g = {k: int(v) for k, v in m.groupdict().items()}
        out.append(ThreadSummary(g["thread"], g["tid"], g["prio"], g["interval"], g["cycles"],
                                 g["min"], g["act"], g["avg"], g["max"]))
    return out


def parse_verbose(text: str, thread: int = 0) -> np.ndarray:
    """The per-cycle values of ``cyclictest -v`` (lines ``thread: cycle: value``) for one thread."""
    values = []
    for line in text.splitlines():
        m = _VERBOSE.match(line)
        if m and int(m.group(1)) == thread:
            values.append(int(m.group(3)))
    return np.asarray(values, dtype=np.int64)


def parse_json(text: str) -> dict:
    """cyclictest --json=FILE: {thread: {cycles, min, max, avg, histogram{us: count}}} (ints)."""
    data = json.loads(text)
    threads = {}
    for key, t in data.get("thread", {}).items():
        threads[int(key)] = {
            "cycles": int(t["cycles"]), "min": t["min"], "max": t["max"], "avg": float(t["avg"]),
            "histogram": {int(b): int(c) for b, c in t.get("histogram", {}).items()},
        }
    return {"version": data.get("rt_test_version:", data.get("rt_test_version")),
            "realtime_kernel": bool(data.get("sysinfo", {}).get("realtime", 0)), "threads": threads}


def build_command(interval_us: int = 1000, loops: int = 1000, priority: int | None = None,
                  policy: str | None = None, mlock: bool = False, cpu: int | None = None,
                  verbose: bool = True, json_file: str | None = None) -> list[str]:
    """cyclictest's command line for one thread at ``interval_us`` (ns output, quiet summary)."""
    if interval_us <= 0 or loops <= 0:
        raise ValueError(f"interval_us and loops must be > 0, got {interval_us!r}, {loops!r}")
    cmd = [cyclictest_path(), "-t", "1", "-i", str(int(interval_us)), "-d", "0", "-l", str(int(loops)),
           "-N", "-q"]
    if policy is not None:
        if policy not in ("fifo", "rr", "other"):
            raise ValueError(f"policy {policy!r}: use 'fifo', 'rr' or 'other'")
        cmd.append(f"--policy={policy}")
    if priority is not None:
        cmd += ["-p", str(int(priority))]
    if mlock:
        cmd.append("-m")
    if cpu is not None:
        cmd += ["-a", str(int(cpu))]
    if verbose:
        cmd.append("-v")
    if json_file:
        cmd.append(f"--json={json_file}")
    return cmd


def run_cyclictest(interval_us: int = 1000, loops: int = 1000, priority: int | None = None,
                   policy: str | None = None, mlock: bool = False, cpu: int | None = None,
                   timeout: float | None = None) -> CyclictestResult:
    """Run cyclictest once and return its samples (ns) and summary.

    ``priority`` None runs it under SCHED_OTHER (what an unprivileged user can do); with a
    priority it asks SCHED_FIFO (or ``policy``). Raises :class:`CyclictestMissing` when absent
    and ``RuntimeError`` with cyclictest's own message when it refuses (e.g. no rtprio).
    """
    with tempfile.TemporaryDirectory() as tmp:
        jpath = os.path.join(tmp, "ct.json")
        cmd = build_command(interval_us, loops, priority, policy, mlock, cpu, verbose=True, json_file=jpath)
        limit = timeout if timeout is not None else loops * interval_us / 1e6 * 3 + 10
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=limit)
        samples = parse_verbose(proc.stdout)
        threads = parse_summary(proc.stdout)
        if proc.returncode != 0 or not len(samples):
            msg = (proc.stderr or proc.stdout).strip().splitlines()
            raise RuntimeError(f"cyclictest failed (exit {proc.returncode}): {' / '.join(msg[-3:]) or 'no output'}"
                               + ("; it needs the rtprio limit for -p (see limits.conf)" if priority else ""))
    return CyclictestResult(cmd, proc.returncode, "ns", threads, samples, proc.stdout, proc.stderr)
