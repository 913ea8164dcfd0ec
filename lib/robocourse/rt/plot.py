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


def compare(results: dict, period_ns: int | None = None, title: str = "", axes=None, budget_fraction=0.05):
    """Latency over time and a shared-bin histogram for several named runs.

    ``results``: name -> LoopResult (or latency array). Draws the 5 %-of-period line when
    ``period_ns`` is given. Returns the matplotlib figure (pyplot's, so notebooks show it).
    """
    import matplotlib.pyplot as plt

    if not results:
        raise ValueError("compare() needs at least one run")
    lats = {name: np.asarray(getattr(r, "latency_ns", r)) / 1000.0 for name, r in results.items()}
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    else:
        fig = axes[0].figure
    hi = max(float(np.percentile(v, 99.9)) for v in lats.values() if len(v))
    lo = min(float(v.min()) for v in lats.values() if len(v))
    bins = np.linspace(min(lo, 0.0), max(hi * 1.2, 1.0), 80)
    for name, v in lats.items():
        axes[0].plot(v, lw=0.6, label=name)
        axes[1].hist(np.clip(v, bins[0], bins[-1]), bins=bins, histtype="step", label=name)
    if period_ns:
        limit = budget_fraction * period_ns / 1000.0
        for ax in axes:
            (ax.axhline if ax is axes[0] else ax.axvline)(limit, color="red", ls="--", lw=1,
                                                         label=f"{budget_fraction:.0%} of period")
    axes[0].set(xlabel="iteration", ylabel="latency (us)", title=title or "latency per iteration")
    axes[0].set_yscale("symlog", linthresh=10)
    axes[1].set(xlabel="latency (us, p99.9 and above piled in the last bin)", ylabel="iterations",
                title="histogram")
    axes[1].set_yscale("log")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
