"""rttest's results file: write it exactly as rttest does, read it back.

Counterpart: ``Rttest::write_results_file``. One header line
``iteration timestamp latency minor_pagefaults major_pagefaults`` then one line per iteration,
space separated, with the *nominal* timestamp ``period_ns * iteration`` (not the wake time).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

HEADER = "iteration timestamp latency minor_pagefaults major_pagefaults"


@dataclass
class ResultsData:
    """The five columns of a results file as int64 arrays."""

    iteration: np.ndarray
    timestamp: np.ndarray
    latency: np.ndarray
    minor_pagefaults: np.ndarray
    major_pagefaults: np.ndarray

    @property
    def period_ns(self) -> int | None:
        """The period recovered from the nominal timestamps (None with fewer than 2 rows)."""
        if len(self.timestamp) < 2 or self.iteration[1] == self.iteration[0]:
            return None
        return int((self.timestamp[1] - self.timestamp[0]) // (self.iteration[1] - self.iteration[0]))

    def stats(self):
        from .stats import compute_stats

        return compute_stats(self.latency, self.minor_pagefaults, self.major_pagefaults)


def format_results(latency_ns, minor_pagefaults, major_pagefaults, period_ns: int, first_iteration: int = 0) -> str:
    lat = np.asarray(latency_ns, dtype=np.int64)
    minor = np.asarray(minor_pagefaults, dtype=np.int64)
    major = np.asarray(major_pagefaults, dtype=np.int64)
    if not (len(lat) == len(minor) == len(major)):
        raise ValueError(f"columns differ in length: latency {len(lat)}, minor {len(minor)}, major {len(major)}")
    if int(period_ns) <= 0:
        raise ValueError(f"period_ns must be > 0, got {period_ns!r}")
    lines = [HEADER]
    for j in range(len(lat)):
        i = first_iteration + j
        lines.append(f"{i} {int(period_ns) * i} {lat[j]} {minor[j]} {major[j]}")
    return "\n".join(lines) + "\n"


def write_results(path, latency_ns, minor_pagefaults, major_pagefaults, period_ns: int,
                  first_iteration: int = 0) -> Path:
    """Write a results file; an empty run is refused like rttest's endless mode."""
    if len(latency_ns) == 0:
        raise ValueError("no samples were buffered (an endless or empty run); nothing to write")
    path = Path(path)
    path.write_text(format_results(latency_ns, minor_pagefaults, major_pagefaults, period_ns, first_iteration))
    return path


def read_results(path) -> ResultsData:
    """Read a results file written by rttest or robocourse; errors name the line at fault."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results file (write one with `robocourse rttest -f {path}`)")
    lines = path.read_text().splitlines()
    if not lines or lines[0].split() != HEADER.split():
        got = lines[0] if lines else "an empty file"
        raise ValueError(f"{path}: not an rttest results file: the first line must be {HEADER!r}, got {got!r}")
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split()
        if len(fields) != 5:
            raise ValueError(f"{path}, line {number}: expected 5 space-separated numbers, got {len(fields)}: {line!r}")
        try:
            rows.append([int(f) for f in fields])
        except ValueError:
            raise ValueError(f"{path}, line {number}: not whole numbers: {line!r}") from None
    data = np.array(rows, dtype=np.int64).reshape(-1, 5)
    return ResultsData(*(data[:, c].copy() for c in range(5)))
