"""The periodic loop: absolute deadlines, a wait strategy, latency and page faults per iteration.

Counterpart: rttest's ``rttest_spin`` / ``spin_once`` (and the executor loop of the ROS 2
pendulum demo). Iteration ``k`` (0-based) waits for the absolute deadline
``start_ns + (k + 1) * period_ns``, reads the clock, stores ``wake - deadline`` (signed ns,
negative = woke early) *before* calling the user callback, runs the callback, then stores the
deltas of ``getrusage(RUSAGE_THREAD)`` minor/major page faults. Deadlines never slip: a late
iteration shows up as latency in the following samples, never as drift.

An *overrun* is an iteration whose callback finished after the next deadline. Because the
latency is sampled before the callback, the callback's own duration never shows in its own
sample; it is stored separately as ``busy_ns`` (wake-up to callback end), so
``latency_ns + busy_ns`` is the iteration's response time.
A callback stops the loop by calling ``loop.stop()`` or returning :data:`STOP`.
``iterations <= 0`` runs until stopped (rttest's -i 0): statistics are then accumulated
on the fly and only the most recent ``keep_last`` samples are kept.
"""

from __future__ import annotations

import array
import resource
import sys
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .clock import MonotonicClock
from .stats import RttestStats, RunningStats, compute_stats
from .stats import histogram as _histogram
from .wait import Sleep, WaitStrategy

STOP = object()
"""Return this from a loop callback to end the loop after the current iteration."""

_RUSAGE_THREAD = getattr(resource, "RUSAGE_THREAD", resource.RUSAGE_SELF)


def _faults() -> tuple[int, int]:
    ru = resource.getrusage(_RUSAGE_THREAD)
    return ru.ru_minflt, ru.ru_majflt


class Tick:
    """What the callback receives each iteration (one object, updated in place: do not keep it)."""

    __slots__ = ("iteration", "deadline_ns", "wake_ns", "latency_ns", "period_ns")

    def __init__(self, period_ns: int):
        self.period_ns = period_ns
        self.iteration = 0
        self.deadline_ns = 0
        self.wake_ns = 0
        self.latency_ns = 0

    def __repr__(self) -> str:
        return (f"Tick(iteration={self.iteration}, deadline_ns={self.deadline_ns}, "
                f"wake_ns={self.wake_ns}, latency_ns={self.latency_ns})")


@dataclass
class LoopResult:
    """Everything one run measured. Arrays are numpy int64, one entry per iteration.

    For an endless run the arrays hold the last ``keep_last`` iterations and ``stats()``
    covers all of them (rttest's running statistics).
    """

    period_ns: int
    start_ns: int
    strategy: str
    latency_ns: np.ndarray
    wake_ns: np.ndarray
    minor_pagefaults: np.ndarray
    major_pagefaults: np.ndarray
    busy_ns: np.ndarray
    overruns: int
    overrun_iterations: list[int]
    iterations: int
    requested_iterations: int
    stopped_early: bool
    initial_minor_pagefaults: int = 0
    initial_major_pagefaults: int = 0
    first_iteration: int = 0
    _running: RunningStats | None = field(default=None, repr=False)
    cpu_ns: int = 0
    """CPU time the loop's thread used during the run (``time.thread_time_ns``): wait + callbacks."""
    wall_ns: int = 0
    """Wall time of the run, from its start to the end of the last iteration."""
    cpu_share: float = float("nan")
    """Share of one core the loop's thread used: ``cpu_ns / wall_ns`` (0.02 = 2 % of a core)."""

    @property
    def deadlines_ns(self) -> np.ndarray:
        """The absolute deadline of every stored iteration: start + (k + 1) * period."""
        k = np.arange(self.first_iteration, self.first_iteration + len(self.latency_ns), dtype=np.int64)
        return self.start_ns + (k + 1) * self.period_ns

    @property
    def timestamps_ns(self) -> np.ndarray:
        """rttest's nominal timestamps: period * iteration."""
        k = np.arange(self.first_iteration, self.first_iteration + len(self.latency_ns), dtype=np.int64)
        return k * self.period_ns

    def stats(self) -> RttestStats:
        """rttest's statistics of this run, labelled with the wait strategy that produced them."""
        if self._running is not None and self._running.n > len(self.latency_ns):
            r = self._running
            tail = compute_stats(self.latency_ns) if len(self.latency_ns) else None
            return RttestStats(r.n, int(r.min), int(r.max), r.mean, r.stddev, r.minor, r.major,
                               tail.p50 if tail else float("nan"), tail.p90 if tail else float("nan"),
                               tail.p99 if tail else float("nan"), tail.p999 if tail else float("nan"),
                               self.overruns, self.strategy)
        return replace(compute_stats(self.latency_ns, self.minor_pagefaults, self.major_pagefaults, self.overruns),
                       wait=self.strategy)

    def histogram(self, bins: int = 100, range_ns=None):
        return _histogram(self.latency_ns, bins, range_ns)

    def write(self, path) -> None:
        """Write rttest's results file (see :mod:`robocourse.rt.results_file`)."""
        from .results_file import write_results

        write_results(path, self.latency_ns, self.minor_pagefaults, self.major_pagefaults,
                      self.period_ns, first_iteration=self.first_iteration)

    def summary(self, label: str | None = None) -> str:
        """One line: label (default the wait strategy), percentiles, max, overruns."""
        s = self.stats()
        return (f"{label or self.strategy:<22} n={s.iterations:<6} p50={s.p50 / 1000:8.1f} us  "
                f"p99={s.p99 / 1000:8.1f} us  p99.9={s.p999 / 1000:8.1f} us  "
                f"max={s.max_latency / 1000:8.1f} us  overruns={s.overruns}")


class PeriodicLoop:
    """A periodic loop with absolute deadlines (rttest's spin loop).

    ``PeriodicLoop(1_000_000, 1000).run(callback)`` runs 1000 iterations at 1 kHz and returns a
    :class:`LoopResult`. ``callback(tick)`` is optional. The default wait is :class:`Sleep`,
    rttest's; pass ``wait=Hybrid(spin_ns=200_000)`` to sleep-then-spin, or
    ``wait=Adaptive(max_spin_ns=300_000)`` to spin only the window this machine needs.
    """

    def __init__(self, period_ns: int, iterations: int = 1000, wait: WaitStrategy | None = None,
                 clock=None, pagefaults: bool = True, keep_last: int = 100_000):
        if isinstance(period_ns, bool) or not isinstance(period_ns, (int, np.integer)) or period_ns <= 0:
            raise ValueError(f"period_ns must be a positive int number of ns, got {period_ns!r} "
                             "(1 kHz is 1_000_000)")
        if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)):
            raise ValueError(f"iterations must be an int (<= 0 means endless), got {iterations!r}")
        if not isinstance(keep_last, int) or keep_last < 1:
            raise ValueError(f"keep_last must be a positive int, got {keep_last!r}")
        if wait is not None and not isinstance(wait, WaitStrategy):
            raise ValueError(f"wait must be Sleep(), Hybrid(spin_ns=...), Adaptive(max_spin_ns=...) or Spin(), "
                             f"got {wait!r}")
        self.period_ns = int(period_ns)
        self.iterations = int(iterations)
        self.wait = wait if wait is not None else Sleep()
        self.clock = clock if clock is not None else MonotonicClock()
        self.pagefaults = pagefaults
        self.keep_last = keep_last
        self._stop = False

    def stop(self) -> None:
        """Ask the loop to end after the current iteration (safe from the callback)."""
        self._stop = True

    def run(self, callback=None, start_ns: int | None = None) -> LoopResult:
        """Run the loop; ``start_ns`` anchors the deadlines (default: the clock now)."""
        if callback is not None and not callable(callback):
            raise ValueError(f"callback must be callable (taking one Tick argument), got {callback!r}")
        bounded = self.iterations > 0
        size = self.iterations if bounded else self.keep_last
        lat = array.array("q", bytes(8 * size))
        wake = array.array("q", bytes(8 * size))
        minflt = array.array("q", bytes(8 * size))
        majflt = array.array("q", bytes(8 * size))
        busy = array.array("q", bytes(8 * size))
        running = None if bounded else RunningStats()
        overrun_iterations: list[int] = []
        self._stop = False
        clock = self.clock
        now = clock.now_ns
        wait_until = self.wait.wait_until
        period = self.period_ns
        count_faults = self.pagefaults
        tick = Tick(period)
        init_min, init_maj = _faults() if count_faults else (0, 0)
        prev_min, prev_maj = init_min, init_maj
        cpu0, wall0 = time.thread_time_ns(), time.monotonic_ns()
        start = now() if start_ns is None else int(start_ns)
        k = 0
        stopped = False
        stop_sentinel = STOP
        try:
            while bounded is False or k < self.iterations:
                deadline = start + (k + 1) * period
                wait_until(clock, deadline)
                t = now()
                latency = t - deadline
                slot = k if bounded else k % size
                lat[slot] = latency
                wake[slot] = t
                if callback is not None:
                    tick.iteration = k
                    tick.deadline_ns = deadline
                    tick.wake_ns = t
                    tick.latency_ns = latency
                    if callback(tick) is stop_sentinel:
                        self._stop = True
                end = now()
                busy[slot] = end - t
                if end > deadline + period:
                    overrun_iterations.append(k)
                if count_faults:
                    cur_min, cur_maj = _faults()
                    dmin, dmaj = cur_min - prev_min, cur_maj - prev_maj
                    prev_min, prev_maj = cur_min, cur_maj
                    minflt[slot] = dmin
                    majflt[slot] = dmaj
                else:
                    dmin = dmaj = 0
                if running is not None:
                    running.add(latency, dmin, dmaj)
                k += 1
                if self._stop:
                    stopped = True
                    break
        except KeyboardInterrupt:
            if bounded:
                raise
            stopped = True
            print(f"stopped by Ctrl-C after {k} iterations", file=sys.stderr)
        cpu_ns, wall_ns = time.thread_time_ns() - cpu0, time.monotonic_ns() - wall0

        def arr(a):
            x = np.frombuffer(a, dtype=np.int64)
            if bounded:
                return x[:k].copy()
            if k <= size:
                return x[:k].copy()
            cut = k % size
            return np.concatenate([x[cut:], x[:cut]])

        first = 0 if bounded or k <= size else k - size
        return LoopResult(period, start, str(self.wait), arr(lat), arr(wake), arr(minflt), arr(majflt),
                          arr(busy), len(overrun_iterations), overrun_iterations, k, self.iterations,
                          stopped and (not bounded or k < self.iterations), init_min, init_maj, first,
                          running, cpu_ns, wall_ns, cpu_ns / wall_ns if wall_ns > 0 else float("nan"))


def run_loop(period_ns: int = 1_000_000, iterations: int = 1000, wait: WaitStrategy | None = None,
             callback=None, **kwargs) -> LoopResult:
    """One-call form: ``run_loop(1_000_000, 2000, Sleep())``."""
    return PeriodicLoop(period_ns, iterations, wait, **kwargs).run(callback)
