"""What one call of a real-time function allocates: its peak memory and what it keeps, by tracemalloc.

No rttest counterpart (rttest counts page faults, which a warm heap hides); the C++ habit it
stands for is ``RealtimeBox``-style preallocation checked with a malloc hook (ros2_control's
tests use ``osrf_testing_tools_cpp``'s ``EXPECT_NO_MEMORY_OPERATIONS``). CPython boxes every
float, so "no allocation at all" cannot hold in Python; what can be measured and must hold is
that a cycle creates no buffer: tracemalloc records every block Python and NumPy hand out, and
the *peak* above the starting point during one call grows with the data the call copies when it
builds a new array, list or dict, and stays flat when it writes into preallocated storage.
:func:`measure_allocations` reports that peak per call and the bytes a run of calls kept (a
list appended to every cycle, a cache that grows). Compare two sizes of the same call to tell a
buffer (grows with the size) from a boxed scalar (does not).
"""

from __future__ import annotations

import gc
import tracemalloc
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Allocations:
    """Bytes (tracemalloc) of one call: median and largest peak above the start, and kept per call."""

    calls: int
    peak_bytes: int
    max_peak_bytes: int
    retained_bytes_per_call: float


def measure_allocations(fn, calls: int = 50, warmup: int = 10) -> Allocations:
    """Call ``fn()`` ``warmup`` times, then twice ``calls`` times under tracemalloc (gc paused).

    ``peak_bytes``: the median over all traced calls; ``retained_bytes_per_call``: what the second
    ``calls`` calls kept, divided by ``calls``.

    Deterministic for deterministic code (no clock involved), so the same answer on a loaded
    machine. An exception from ``fn`` propagates after tracing is restored.
    """
    if isinstance(calls, bool) or not isinstance(calls, int) or calls < 1:
        raise ValueError(f"calls={calls!r}: measure at least one call, e.g. calls=20")
    if isinstance(warmup, bool) or not isinstance(warmup, int) or warmup < 0:
        raise ValueError(f"warmup={warmup!r}: a number of calls >= 0, e.g. warmup=3")
    if not callable(fn):
        raise ValueError(f"fn={fn!r} must be a function of no argument, e.g. lambda: component.read(t, dt)")
    was_tracing, gc_was_on = tracemalloc.is_tracing(), gc.isenabled()
    gc.disable()
    if not was_tracing:
        tracemalloc.start()
    try:
        for _ in range(warmup):  # traced too: first-call costs (caches, lazy set-up) land here
            tracemalloc.reset_peak()
            fn()
        peaks = np.empty(2 * calls)
        marks = []
        for k in range(2 * calls):
            if k % calls == 0:
                marks.append(tracemalloc.get_traced_memory()[0])
            tracemalloc.reset_peak()
            before = tracemalloc.get_traced_memory()[0]
            fn()
            peaks[k] = tracemalloc.get_traced_memory()[1] - before
        # kept: the second batch's growth only (the first fills CPython's free lists, which
        # tracemalloc still counts as allocated: a flat function shows a few hundred bytes there)
        kept = tracemalloc.get_traced_memory()[0] - marks[1]
    finally:
        if not was_tracing:
            tracemalloc.stop()
        if gc_was_on:
            gc.enable()
    return Allocations(2 * calls, int(np.median(peaks)), int(peaks.max()), kept / calls)


__all__ = ["Allocations", "measure_allocations"]
