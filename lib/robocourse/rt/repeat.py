"""Repeated, interleaved measurements: medians with their spread, and sentences built from them.

No rttest counterpart: rttest measures one run. One run of a loop on a shared machine says
little (a single burst of someone else's work can swap a ranking), so a chapter that compares
two settings runs each of them ``rounds`` times, alternating the order every round (A B C,
C B A, A B C, ...: no setting always runs first or always follows the same neighbour), and
reports each figure as the median over the rounds with its range. ``Repeated.claim`` words a
comparison from those numbers with :func:`robocourse.notebook.claim` (a verdict only when the
rounds' ranges do not overlap and there are enough of them, "this run cannot tell" otherwise),
so the prose of a notebook cannot contradict its own output.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: metric name -> how to read it off a run (anything with ``.stats()``; ns unless said otherwise)
METRICS = {
    "p50": lambda r: r.stats().p50,
    "p90": lambda r: r.stats().p90,
    "p99": lambda r: r.stats().p99,
    "p99.9": lambda r: r.stats().p999,
    "max": lambda r: float(r.stats().max_latency),
    "mean": lambda r: r.stats().mean_latency,
    "overruns": lambda r: float(r.stats().overruns),
    "minor faults": lambda r: float(r.stats().minor_pagefaults),
    "busy p50": lambda r: float(np.percentile(r.busy_ns, 50)),
    "busy p99": lambda r: float(np.percentile(r.busy_ns, 99)),
    "busy max": lambda r: float(np.max(r.busy_ns)),
}


def _metric(metric):
    if callable(metric):
        return metric
    try:
        return METRICS[metric]
    except KeyError:
        raise ValueError(f"unknown metric {metric!r}: use one of {', '.join(METRICS)} or a function of a run") from None


@dataclass
class Repeated:
    """Every run of every named experiment, in the order they ran (``order[k]`` = round k's order)."""

    runs: dict[str, list] = field(default_factory=dict)
    order: list[list[str]] = field(default_factory=list)
    extra: dict[str, list] = field(default_factory=dict)

    @property
    def rounds(self) -> int:
        return len(self.order)

    def values(self, name: str, metric) -> np.ndarray:
        """One value per round of experiment ``name`` (see :data:`METRICS`)."""
        if name not in self.runs:
            raise KeyError(f"no experiment {name!r}; measured: {', '.join(self.runs)}")
        get = _metric(metric)
        return np.array([float(get(r)) for r in self.runs[name]])

    def median(self, name: str, metric) -> float:
        return float(np.median(self.values(name, metric)))

    def spread(self, name: str, metric) -> tuple[float, float]:
        """(lowest, highest) over the rounds."""
        v = self.values(name, metric)
        return float(v.min()), float(v.max())

    def last(self, name: str):
        """The last run of ``name`` (for plots of one representative run)."""
        return self.runs[name][-1]

    def pooled_latency_ns(self, name: str) -> np.ndarray:
        """All rounds' latency samples of ``name`` concatenated."""
        return np.concatenate([np.asarray(r.latency_ns) for r in self.runs[name]])

    def wins(self, a: str, b: str, metric) -> int:
        """In how many rounds ``a``'s metric was strictly lower than ``b``'s (same round)."""
        return int(np.sum(self.values(a, metric) < self.values(b, metric)))

    def cell(self, name: str, metric, scale: float = 1e-3, digits: int = 1) -> str:
        """'12.3 [10.1-15.0]': median and range, scaled (default ns -> us)."""
        lo, hi = self.spread(name, metric)
        return f"{self.median(name, metric) * scale:.{digits}f} [{lo * scale:.{digits}f}-{hi * scale:.{digits}f}]"

    def claim(self, a: str, b: str | None, metric, scale: float = 1e-3, unit: str = "us", digits: int = 1,
              what: str | None = None, each: str = "", limit: float | None = None, limit_name: str = "the limit"):
        """A :func:`robocourse.notebook.claim` from the rounds: ``a`` against ``b`` on ``metric``, or
        ``a`` alone (``b=None``, with or without ``limit``). ``what`` defaults to the metric's name."""
        from robocourse.notebook.claims import claim

        label = what or (metric if isinstance(metric, str) else "value")
        values = {a: self.values(a, metric)}
        if b is not None:
            values[b] = self.values(b, metric)
        return claim(label, values, unit=unit, scale=scale, digits=digits, each=each, limit=limit,
                     limit_name=limit_name)

    def table(self, metrics=("p50", "p99", "max"), scale: float = 1e-3, unit: str = "us", digits: int = 1) -> str:
        """A text table: one row per experiment, each cell 'median [min-max]' over the rounds."""
        width = max(len(n) for n in self.runs) + 2
        head = f"{'':<{width}}" + "".join(f" {(m + ' ' + unit if isinstance(m, str) else unit).strip():>28}"
                                          for m in metrics)
        lines = [f"median [lowest-highest] over {self.rounds} rounds, order alternating every round", head]
        for name in self.runs:
            lines.append(f"{name:<{width}}" + "".join(f" {self.cell(name, m, scale, digits):>28}" for m in metrics))
        return "\n".join(lines)


def measure_rounds(experiments: dict, rounds: int = 3, between=None, progress: bool = False) -> Repeated:
    """Run each ``experiments[name]()`` once per round, alternating the order every round.

    Each experiment is a function of no argument returning a run (a LoopResult, a
    CyclictestResult, ...). ``between(name, run)`` is called after each run (cleanup).
    ``progress=True`` shows a progress line (:class:`robocourse.notebook.progress`), advanced
    *between* runs, never inside a loop.
    """
    if isinstance(rounds, bool) or not isinstance(rounds, int) or rounds < 1:
        raise ValueError(f"rounds={rounds!r}: run every experiment at least once, e.g. rounds=3")
    if not experiments:
        raise ValueError("measure_rounds needs at least one experiment, e.g. {'sleep': lambda: loop.run()}")
    for name, fn in experiments.items():
        if not callable(fn):
            raise ValueError(f"experiment {name!r} must be a function of no argument returning a run, got {fn!r}")
    names = list(experiments)
    rep = Repeated({n: [] for n in names})
    bar = None
    if progress:
        from robocourse.notebook.progress_line import progress as progress_line

        bar = progress_line(rounds * len(names), "runs")
    try:
        for k in range(rounds):
            order = names if k % 2 == 0 else names[::-1]
            rep.order.append(list(order))
            for name in order:
                run = experiments[name]()
                rep.runs[name].append(run)
                if between is not None:
                    between(name, run)
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return rep
