"""Plots: rttest_plot's four pictures, and the comparisons the chapter draws.

Counterpart: rttest's ``rttest_plot`` script, which reads a results file and writes
``<prefix>_latency``, ``<prefix>_latency_hist`` (100 bins), ``<prefix>_minflt`` and
``<prefix>_majflt``; the default prefix is ``<file>_plot``. Figures are built on
``matplotlib.figure.Figure`` (no pyplot, no display needed: the Agg canvas renders them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

SUFFIXES = ("latency", "latency_hist", "minflt", "majflt")


def _figure(size=(8, 4.5)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def rttest_plot(source, prefix: str | None = None, fmt: str = "svg") -> list[Path]:
    """Draw the four rttest_plot figures from a results file (path) or a LoopResult/ResultsData."""
    from .results_file import ResultsData, read_results

    fmt = fmt.lower().lstrip(".")
    if fmt not in ("svg", "png"):
        raise ValueError(f"format {fmt!r}: rttest_plot writes svg or png")
    if isinstance(source, (str, Path)):
        data = read_results(source)
        prefix = prefix or f"{source}_plot"
    elif isinstance(source, ResultsData):
        data = source
    else:  # a LoopResult
        data = ResultsData(np.arange(source.first_iteration, source.first_iteration + len(source.latency_ns)),
                           source.timestamps_ns, source.latency_ns, source.minor_pagefaults,
                           source.major_pagefaults)
    if prefix is None:
        raise ValueError("give a prefix for the plot files, e.g. prefix='run1_plot'")
    if len(data.latency) == 0:
        raise ValueError("the results hold no samples; nothing to plot")
    t_ms = data.timestamp / 1e6
    paths = []
    panels = [
        ("latency", "Latency over time", "latency (ns)", data.latency),
        ("minflt", "Minor pagefaults per iteration", "minor pagefaults", data.minor_pagefaults),
        ("majflt", "Major pagefaults per iteration", "major pagefaults", data.major_pagefaults),
    ]
    for suffix, title, ylabel, values in panels:
        fig = _figure()
        ax = fig.add_subplot()
        ax.plot(t_ms, values, lw=0.7)
        ax.set(title=title, xlabel="time (ms, nominal)", ylabel=ylabel)
        ax.grid(alpha=0.3)
        path = Path(f"{prefix}_{suffix}.{fmt}")
        fig.savefig(path)
        paths.append(path)
    fig = _figure()
    ax = fig.add_subplot()
    ax.hist(data.latency, bins=100)
    ax.set(title="Latency histogram", xlabel="latency (ns)", ylabel="iterations")
    ax.set_yscale("log")
    ax.grid(alpha=0.3)
    path = Path(f"{prefix}_latency_hist.{fmt}")
    fig.savefig(path)
    paths.insert(1, path)
    return paths


def log_bins(arrays, bins: int = 80, floor: float = 0.1) -> np.ndarray:
    """Log-spaced bin edges spanning every value of ``arrays`` (values below ``floor`` go to it).

    A latency distribution spans four decades (a 1 us median, a 10 ms worst case): on linear
    bins it is one bar and an invisible tail; on log-spaced bins each decade gets the same width.
    """
    vals = [np.asarray(a, dtype=float).reshape(-1) for a in arrays]
    vals = [v for v in vals if v.size]
    if not vals:
        raise ValueError("log_bins needs at least one non-empty array")
    if not floor > 0:
        raise ValueError(f"floor={floor!r}: log bins need a positive floor, e.g. 0.1 (us)")
    lo = max(floor, min(float(v.min()) for v in vals))
    hi = max(max(float(v.max()) for v in vals), lo * 10)
    return np.geomspace(lo, hi * 1.0001, bins + 1)


def log_hist(ax, values, bins: int = 80, floor: float = 0.1, **kwargs):
    """Histogram on log-spaced bins with log axes; values below ``floor`` are counted in the first bin."""
    edges = log_bins([values], bins, floor)
    ax.hist(np.clip(np.asarray(values, dtype=float), edges[0], edges[-1]), bins=edges, **kwargs)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(bottom=0.8)
    return edges


def compare(results: dict, period_ns: int | None = None, title: str = "", axes=None, budget_fraction=0.05,
            floor_us: float = 0.1):
    """Latency over time and a shared-bin histogram for several named runs, on log axes.

    ``results``: name -> LoopResult (or latency array). Both axes are logarithmic and span the
    data (no empty decades): values below ``floor_us`` are drawn at it (a loop that spins wakes
    within a fraction of a microsecond). Draws the 5 %-of-period line when ``period_ns`` is given.
    Returns the matplotlib figure (pyplot's, so notebooks show it).
    """
    import matplotlib.pyplot as plt

    if not results:
        raise ValueError("compare() needs at least one run")
    lats = {name: np.asarray(getattr(r, "latency_ns", r)) / 1000.0 for name, r in results.items()}
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    else:
        fig = axes[0].figure
    edges = log_bins(lats.values(), 80, floor_us)
    for name, v in lats.items():
        axes[0].plot(np.clip(v, edges[0], None), lw=0.6, label=name)
        axes[1].hist(np.clip(v, edges[0], edges[-1]), bins=edges, histtype="step", label=name)
    if period_ns:
        limit = budget_fraction * period_ns / 1000.0
        for ax in axes:
            (ax.axhline if ax is axes[0] else ax.axvline)(limit, color="red", ls="--", lw=1,
                                                         label=f"{budget_fraction:.0%} of period")
    clipped = any(bool(np.any(v < edges[0])) for v in lats.values())
    note = f"; < {edges[0]:.2g} us drawn at {edges[0]:.2g}" if clipped else ""
    axes[0].set(xlabel="iteration", ylabel=f"latency (us, log{note})",
                title=title or "latency per iteration", yscale="log", ylim=(edges[0] / 1.2, edges[-1] * 1.5))
    axes[1].set(xlabel=f"latency (us, log-spaced bins{note})", ylabel="iterations (log)",
                title="histogram", xscale="log", yscale="log", ylim=(0.8, None))
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
