"""Latency statistics exactly as rttest computes them, plus percentiles and a histogram.

rttest's ``calculate_statistics``: min and max of the latency buffer (int ns), mean over the
whole buffer, *population* standard deviation (divide by n, not n-1), and the sums of the
per-iteration minor and major page-fault deltas. ``format_rttest`` prints rttest's block
(``results_to_string``, with its std::fixed six decimals) character for character.
Percentiles (p50, p90, p99, p99.9) are what the mean hides: a loop is judged by its tail.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

PERCENTILES = (50.0, 90.0, 99.0, 99.9)


@dataclass(frozen=True)
class RttestStats:
    """rttest's ``rttest_results`` (iteration, min/max/mean/stddev latency, page faults) + tail."""

    iterations: int
    min_latency: int
    max_latency: int
    mean_latency: float
    latency_stddev: float
    minor_pagefaults: int
    major_pagefaults: int
    p50: float
    p90: float
    p99: float
    p999: float
    overruns: int = 0
    wait: str = ""
    """The wait strategy that produced the samples ("sleep", "hybrid(200 us spin)", ...); "" if unknown."""

    def as_dict(self) -> dict:
        return asdict(self)

    def format(self, name: str | None = None, extended: bool = True) -> str:
        return format_rttest(self, name=name, extended=extended)

    def __str__(self) -> str:
        return self.format()


def _as_int_array(values, what: str) -> np.ndarray:
    """Whole numbers as int64, or a ValueError naming the first bad value (never a silent cast)."""
    arr = np.asarray(values)
    if arr.ndim != 1:
        raise ValueError(f"{what} must be a 1-D sequence of whole ns values, got shape {arr.shape}")
    if arr.size and (arr.dtype == bool or not np.issubdtype(arr.dtype, np.number)):
        raise ValueError(f"{what} must hold whole numbers (int ns), got dtype {arr.dtype}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"{what}[{bad[0]}] is {float(arr[bad[0]])!r}: rttest's samples are whole, finite ns; "
                             "drop or re-measure that iteration")
        frac = np.flatnonzero(arr != np.round(arr))
        if frac.size:
            raise ValueError(f"{what}[{frac[0]}] is {float(arr[frac[0]])!r}: rttest's samples are whole ns and "
                             "would be truncated; round them first, e.g. np.rint(x).astype(np.int64)")
    return arr.astype(np.int64, copy=False)


def compute_stats(latency_ns, minor_pagefaults=None, major_pagefaults=None, overruns: int = 0) -> RttestStats:
    """rttest statistics of a latency buffer (ns) and per-iteration page-fault deltas."""
    lat = _as_int_array(latency_ns, "latency_ns")
    if lat.size == 0:
        raise ValueError("latency_ns is empty: run the loop for at least one iteration (-i 1 or more)")
    minor = 0 if minor_pagefaults is None else int(_as_int_array(minor_pagefaults, "minor_pagefaults").sum())
    major = 0 if major_pagefaults is None else int(_as_int_array(major_pagefaults, "major_pagefaults").sum())
    mean = float(lat.sum(dtype=np.float64) / lat.size)
    diff = lat.astype(np.float64) - mean
    stddev = float(np.sqrt(np.dot(diff, diff) / lat.size))
    p50, p90, p99, p999 = (float(v) for v in np.percentile(lat, PERCENTILES))
    return RttestStats(int(lat.size), int(lat.min()), int(lat.max()), mean, stddev, minor, major,
                       p50, p90, p99, p999, int(overruns))


def describe_wait(wait: str) -> str:
    """One line saying how the loop waited, and whether that is what rttest does."""
    if not wait:
        return ""
    if wait == "sleep":
        return "Wait strategy: sleep (clock_nanosleep to each absolute deadline, as rttest does)"
    if wait.startswith("hybrid"):
        return (f"Wait strategy: {wait}: sleeps, then busy-waits up to the deadline "
                "(rttest only sleeps; compare with --wait sleep)")
    if wait == "spin":
        return "Wait strategy: spin: busy-waits the whole period (rttest only sleeps; compare with --wait sleep)"
    return f"Wait strategy: {wait}"


def format_rttest(stats: RttestStats, name: str | None = None, extended: bool = True) -> str:
    """rttest's statistics block; with ``extended`` a second block with the tail and overruns.

    When the statistics know their wait strategy a line naming it comes first, so a block is
    never read as rttest's sleeping loop when it was not; rttest's block follows unchanged.
    """
    wait_line = describe_wait(stats.wait)
    lines = ([wait_line] if wait_line else []) + [
        "rttest statistics" + (f" for {name}:" if name else ":"),
        f"  - Minor pagefaults: {stats.minor_pagefaults}",
        f"  - Major pagefaults: {stats.major_pagefaults}",
        "  Latency (time after deadline was missed):",
        f"    - Min: {stats.min_latency} ns",
        f"    - Max: {stats.max_latency} ns",
        f"    - Mean: {stats.mean_latency:.6f} ns",
        f"    - Standard deviation: {stats.latency_stddev:.6f}",
        "",
    ]
    if extended:
        lines += [
            f"robocourse tail ({stats.iterations} iterations):",
            f"    - p50: {stats.p50:.0f} ns",
            f"    - p90: {stats.p90:.0f} ns",
            f"    - p99: {stats.p99:.0f} ns",
            f"    - p99.9: {stats.p999:.0f} ns",
            f"    - Overruns (callback ended after the next deadline): {stats.overruns}",
            "",
        ]
    return "\n".join(lines)


def histogram(latency_ns, bins: int = 100, range_ns: tuple[int, int] | None = None):
    """(counts, edges_ns) like rttest_plot's 100-bin latency histogram."""
    lat = _as_int_array(latency_ns, "latency_ns")
    if not isinstance(bins, int) or bins < 1:
        raise ValueError(f"bins must be a positive int, got {bins!r}")
    return np.histogram(lat, bins=bins, range=range_ns)


class RunningStats:
    """rttest's ``accumulate_statistics`` for endless runs (-i 0): nothing is buffered.

    Min, max, running mean and (Welford) population variance, and page-fault totals.
    """

    __slots__ = ("n", "min", "max", "mean", "_m2", "minor", "major")

    def __init__(self):
        self.n = 0
        self.min = None
        self.max = None
        self.mean = 0.0
        self._m2 = 0.0
        self.minor = 0
        self.major = 0

    def add(self, latency: int, minor: int = 0, major: int = 0) -> None:
        self.n += 1
        if self.min is None or latency < self.min:
            self.min = latency
        if self.max is None or latency > self.max:
            self.max = latency
        delta = latency - self.mean
        self.mean += delta / self.n
        self._m2 += delta * (latency - self.mean)
        self.minor += minor
        self.major += major

    @property
    def stddev(self) -> float:
        return float(np.sqrt(self._m2 / self.n)) if self.n else 0.0
