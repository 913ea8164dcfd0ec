"""The controller manager's real-time loop and its per-stage timing statistics.

Counterpart: ros2_control_node's main loop (``cm->read(); cm->update(); cm->write();`` then
``std::this_thread::sleep_until(next_iteration_time)``) with the rolling manager's execution
time statistics, plus the "Overrun detected!" check. Here the loop is
:class:`robocourse.rt.PeriodicLoop` (absolute deadlines, a wait strategy, latency per
iteration) and the bus executor spins the manager's services and the controllers' topics in a
second thread, as the C++ node's executor does. ``settings`` applies
:func:`robocourse.rt.realtime` (scheduling, memory locking, gc) for the loop and returns its
honest reports: on a laptop without permissions they say what failed and the loop still runs.
"""

from __future__ import annotations

import contextlib
import threading
import time as _time
from dataclasses import dataclass

import numpy as np

from robocourse.rt import Hybrid, LoopResult, PeriodicLoop, WaitStrategy

STAGES = ("read", "update", "write", "cycle")


@dataclass(frozen=True)
class StageStats:
    """Timing of one stage over a run, in microseconds."""

    stage: str
    count: int
    min_us: float
    mean_us: float
    p50_us: float
    p99_us: float
    max_us: float

    def row(self) -> str:
        return (f"{self.stage:<7} {self.min_us:9.1f} {self.mean_us:9.1f} {self.p50_us:9.1f} "
                f"{self.p99_us:9.1f} {self.max_us:9.1f}")


def stage_stats(stage: str, ns: np.ndarray) -> StageStats:
    if len(ns) == 0:
        raise ValueError(f"no samples for stage '{stage}': run at least one cycle")
    us = np.asarray(ns, dtype=np.float64) / 1e3
    p50, p99 = np.percentile(us, (50, 99))
    return StageStats(stage, len(us), float(us.min()), float(us.mean()), float(p50), float(p99), float(us.max()))


class CycleTimes:
    """Preallocated per-cycle durations (ns) of read, update, write and the whole cycle."""

    def __init__(self, capacity: int):
        self.ns = np.zeros((4, capacity), dtype=np.int64)
        self.count = 0

    def stats(self) -> dict[str, StageStats]:
        n = min(self.count, self.ns.shape[1])
        return {s: stage_stats(s, self.ns[i, :n]) for i, s in enumerate(STAGES)}

    def plot(self, title: str = "controller manager cycle", period_us: float | None = None):
        """Figure: each stage's duration per cycle (us) and the cycle-time histogram; returns the figure."""
        import matplotlib.pyplot as plt

        n = min(self.count, self.ns.shape[1])
        fig, (ax, hx) = plt.subplots(1, 2, figsize=(11, 3.5), gridspec_kw={"width_ratios": [2, 1]})
        for i, stage in enumerate(STAGES):
            ax.plot(self.ns[i, :n] / 1e3, lw=0.8 if stage != "cycle" else 1.2, label=stage)
        hx.hist(self.ns[3, :n] / 1e3, bins=60, color="tab:red", alpha=0.8)
        if period_us is not None:
            ax.axhline(period_us, color="k", ls="--", lw=0.8, label="period")
            hx.axvline(period_us, color="k", ls="--", lw=0.8)
        ax.set(xlabel="cycle", ylabel="duration [us]", title=title, yscale="log")
        ax.legend(loc="upper right", fontsize=8)
        hx.set(xlabel="cycle duration [us]", ylabel="cycles", title="cycle histogram", yscale="log")
        fig.tight_layout()
        return fig

    def table(self) -> str:
        head = f"{'stage':<7} {'min us':>9} {'mean us':>9} {'p50 us':>9} {'p99 us':>9} {'max us':>9}"
        return "\n".join([head] + [s.row() for s in self.stats().values()])


def timed_cycle(cm, times: CycleTimes, time: float, period: float):
    """One read -> update -> write with each stage's duration stored (the hot path); returns
    the update's result."""
    clock = _time.perf_counter_ns
    k = times.count
    ns = times.ns
    t0 = clock()
    cm.read(time, period)
    t1 = clock()
    ret = cm.update(time, period)
    t2 = clock()
    cm.write(time, period)
    t3 = clock()
    if k < ns.shape[1]:
        ns[0, k] = t1 - t0
        ns[1, k] = t2 - t1
        ns[2, k] = t3 - t2
        ns[3, k] = t3 - t0
    times.count = k + 1
    cm.time = time
    cm.cycles += 1
    return ret


@dataclass
class ControlLoopResult:
    """What :func:`run_realtime` measured: stage timings, the loop's latency record, settings reports."""

    times: CycleTimes
    loop: LoopResult
    settings_reports: list
    cpu_s: float
    wall_s: float

    @property
    def overruns(self) -> int:
        return self.loop.overruns

    @property
    def cpu_fraction(self) -> float:
        """Process CPU time / wall time during the run (1.0 = one core busy)."""
        return self.cpu_s / self.wall_s if self.wall_s > 0 else 0.0

    def table(self) -> str:
        return (self.times.table() + f"\noverruns: {self.overruns} of {self.loop.iterations} cycles; "
                f"CPU {100 * self.cpu_fraction:.1f}% of one core")


def run_realtime(cm, seconds: float, wait: WaitStrategy | None = None, settings: dict | None = None,
                 spin_bus: bool = True) -> ControlLoopResult:
    """Run ``cm`` on the wall clock for ``seconds`` at its update rate; return the measurements.

    While it runs, ``cm.switch_controller`` from another thread (or a service call) blocks until
    the loop applies the switch at the end of an update, like upstream. Ctrl-C stops the run and
    the controllers and hardware stay as they are (call ``cm.shutdown()`` to deactivate them).
    """
    if not seconds > 0:
        raise ValueError(f"seconds must be > 0, got {seconds!r}")
    iterations = max(1, int(round(seconds * cm.update_rate)))
    period_ns = int(round(1e9 / cm.update_rate))
    times = CycleTimes(iterations)
    period = 1.0 / cm.update_rate
    t_start = cm.time
    # on a simulated-time context the sim clock follows the cycles, as in step(): the controllers'
    # nodes stamp with the cycle's time and their timers fire (like /clock driven by the loop);
    # claimed before the bus thread starts, so that executor follows it instead of jumping ahead
    sim = getattr(cm.context, "sim", None)
    if sim is not None:
        if sim.driver is not None:
            raise RuntimeError(f"the simulated clock is already driven by {sim.driver!r}: one loop at a time "
                               "may own it (stop the other run first)")
        sim.driver = cm
    executor = thread = None
    if spin_bus:
        from robocourse.bus import SingleThreadedExecutor

        executor = SingleThreadedExecutor(context=cm.context)
        for node in cm.executor.get_nodes():
            executor.add_node(node)
        cm.bus_executor = executor
        thread = threading.Thread(target=executor.spin, name="controller_manager_executor", daemon=True)
        thread.start()
    loop = PeriodicLoop(period_ns, iterations, wait if wait is not None else Hybrid())
    start_holder = []

    def callback(tick):
        if not start_holder:
            start_holder.append(tick.deadline_ns - period_ns)
        time = t_start + (tick.deadline_ns - start_holder[0]) * 1e-9
        if sim is not None:
            sim.advance_to(int(round(time * 1e9)))
        timed_cycle(cm, times, time, period)

    reports: list = []
    cm.rt_thread_running = True
    cpu0, wall0 = _time.process_time(), _time.perf_counter()
    try:
        if settings:
            from robocourse.rt import realtime

            with realtime(**{"quiet": True, **settings}) as reports:
                result = loop.run(callback)
                reports = list(reports)
        else:
            result = loop.run(callback)
    finally:
        cm.rt_thread_running = False
        if sim is not None:
            sim.driver = None
        cpu_s, wall_s = _time.process_time() - cpu0, _time.perf_counter() - wall0
        if executor is not None:
            cm.bus_executor = None           # from here on new nodes join the manager's executor
            nodes = executor.get_nodes()     # shutdown() detaches them: hand them back to the manager's executor
            executor.shutdown()
            thread.join(timeout=2.0)
            for node in nodes:
                cm.executor.add_node(node)
        with contextlib.suppress(Exception):
            cm._fail_pending_switch()
    if result.overruns and cm.params.overruns.print_warnings:
        cm.logger.warning(f"Overrun detected! The controller manager missed its desired rate of {cm.update_rate} Hz "
                          f"in {result.overruns} of {result.iterations} cycles")
    return ControlLoopResult(times, result, reports, cpu_s, wall_s)


__all__ = ["STAGES", "ControlLoopResult", "CycleTimes", "StageStats", "run_realtime", "stage_stats", "timed_cycle"]
