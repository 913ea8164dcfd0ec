"""Measure a driver's round trip on this machine: the numbers chapter 5 and the benchmark print.

Counterpart: libfranka's ``communication_test`` example (it reports the control command
success rate over a few thousand 1 kHz cycles) with the round-trip percentiles an rttest-style
report gives. The client is pylibfranka itself (``start_joint_position_control``, then
``readOnce`` / ``writeOnce`` each cycle); the box timestamps each state it sends and each command
that answers it (monotonic clock, same machine), so the round trip includes both processes'
scheduling, the loopback stack, libfranka and the client's work between read and write.

How the counts add up (one run, all from the box except ``client_cycles``): every state the box
sends during the motion either gets its command before the next tick (``commands_ok``) or not
(``lost``): ``states = commands_ok + lost``. The client answers every state it reads, once:
``client_cycles = commands_ok + late`` (a late command answered a state the box had already
replaced). A state the client never read (libfranka keeps only the newest when several wait) is
lost, never answered. Ticks the box itself could not keep (``box_ticks_skipped``: the box process
was descheduled) send no state, so they count neither way; ``message_id`` still advances by the
milliseconds that passed.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np

from . import box_stats, start_franka_box
from . import franka_wire as fw
from .franka_box import RTT_HIST_EDGES_US


@dataclass(frozen=True)
class RoundTrip:
    """One run of a pylibfranka loop against a Franka box: round trip (us) and how many cycles had their command."""

    label: str
    seconds: float
    states: int                # states the box sent during the motion
    commands_ok: int           # ... whose command arrived before the next tick
    lost: int                  # ... whose command did not (states = commands_ok + lost)
    late: int                  # commands that arrived after their tick (counted, discarded)
    max_lost_in_row: int       # the longest run of lost cycles (the reflex fires at fw.MAX_LOST_IN_ROW)
    rtt_p50_us: float
    rtt_p99_us: float
    rtt_max_us: float
    box_ticks_skipped: int     # ticks the box itself could not keep (no state sent, not the client's fault)
    client_cycles: int = 0     # readOnce/writeOnce pairs the client ran (= commands_ok + late)
    wall_s: float = float("nan")   # wall time from the first to the last readOnce
    rtt_hist_counts: tuple = ()    # round trips per bin of RTT_HIST_EDGES_US
    realtime_applied: str = ""     # what the RT settings did (empty: not asked)

    @property
    def rtt_hist_edges_us(self) -> np.ndarray:
        return np.asarray(RTT_HIST_EDGES_US)

    @property
    def success_rate(self) -> float:
        """commands_ok / states: libfranka's control_command_success_rate over the whole run."""
        return self.commands_ok / self.states if self.states else 0.0

    def would_reflex(self, max_lost: int = fw.MAX_LOST_IN_ROW) -> bool:
        return self.max_lost_in_row >= max_lost

    def row(self) -> str:
        return (f"{self.label:<34} {self.rtt_p50_us:8.0f} {self.rtt_p99_us:8.0f} {self.rtt_max_us:9.0f} "
                f"{100 * self.success_rate:8.2f}% {self.lost:6d} {self.max_lost_in_row:5d} {self.box_ticks_skipped:7d}")


HEADER = (f"{'run':<34} {'p50 us':>8} {'p99 us':>8} {'max us':>9} {'success':>9} {'lost':>6} "
          f"{'worst':>5} {'box-skip':>7}")


def franka_roundtrip(seconds: float = 2.0, *, physics: bool = True, realtime: bool = False,
                     work=None, label: str | None = None, priority: int = 80, around=None) -> RoundTrip:
    """Run a fresh Franka box and a pylibfranka joint position loop (read the state, call
    ``work()`` if given, command the start position) for ``seconds``; return what the box counted.

    ``realtime``: this loop (the client) tries SCHED_FIFO at ``priority`` (80, as the other
    benchmarks; never 99, where the kernel's watchdog threads run) + locked memory + a frozen gc
    (what :func:`robocourse.rt.settings.realtime` does; refused for an unprivileged user: the run
    then measures the default scheduler, and ``realtime_applied`` says so). The box, like a robot's
    controller, always asks for them (``start_franka_box``'s default). The box allows any number
    of lost cycles here (no reflex) so the whole run is measured; ``max_lost_in_row`` tells
    whether the robot's limit (20) would have stopped it.

    libfranka's ``Robot()`` raises the thread that constructs it to SCHED_FIFO 99 when the kernel
    allows (root, or an rtprio limit of 99), even with ``RealtimeConfig.kIgnore``, and leaves it
    there; this function gives the thread its policy back at once, so a row without ``realtime``
    measures the default scheduler for root too.

    ``around``: a context manager entered for the client's loop only, once the box is up and the
    client connected (e.g. ``CpuLoad(processes=2)``): a disturbance of the loop, not of the box's
    start-up.
    """
    import pylibfranka

    from robocourse.rt import settings

    if not 0 < seconds <= 600:
        raise ValueError(f"seconds={seconds!r} must be in (0, 600]")
    if isinstance(priority, bool) or not isinstance(priority, int) or not 1 <= priority <= 98:
        raise ValueError(f"priority={priority!r} must be a SCHED_FIFO priority in 1..98 (99 belongs to the kernel's "
                         "watchdog threads); the benchmarks use 80")
    box = start_franka_box(max_lost=10 ** 9, physics=physics)
    applied = ""
    try:
        with settings.scheduling_kept():   # libfranka's Robot() raises this thread to SCHED_FIFO 99 if allowed
            robot = pylibfranka.Robot(box.host, pylibfranka.RealtimeConfig.kIgnore)
        q0 = list(robot.read_once().q)
        ctx = (settings.realtime(priority=priority, quiet=True, heap_size=16 * 1024 * 1024) if realtime
               else contextlib.nullcontext())
        with ctx as reports:
            if realtime:
                applied = ", ".join(f"{r.name} {'ok' if r.ok else 'refused'}" for r in reports)
            with around if around is not None else contextlib.nullcontext():
                control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
                cmd = pylibfranka.JointPositions(q0)
                cycles, first, end = 0, None, time.monotonic() + seconds
                while True:
                    control.readOnce()
                    now = time.monotonic()
                    first = first or now
                    if work is not None:
                        work()
                    cmd.motion_finished = now >= end
                    control.writeOnce(cmd)
                    cycles += 1
                    if cmd.motion_finished:
                        break
                wall = now - first
        del control
        time.sleep(0.01)
        s = box_stats(box)
    finally:
        box.stop()
    return RoundTrip(label or f"{'FR3 box' if physics else 'no physics (floor)'}{', RT' if realtime else ''}",
                     seconds, s.get("cycles_moving", 0), s.get("commands_ok", 0), s.get("lost", 0), s.get("late", 0),
                     s.get("max_lost_in_row", 0), s.get("rtt_p50_us", float("nan")), s.get("rtt_p99_us", float("nan")),
                     s.get("rtt_max_us", float("nan")), s.get("box_ticks_skipped", 0), cycles, wall,
                     tuple(s.get("rtt_hist_counts", ())), applied)
