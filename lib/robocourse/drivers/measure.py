"""Measure a driver's round trip on this machine: the numbers chapter 5 and the benchmark print.

Counterpart: libfranka's ``communication_test`` example (it reports the control command
success rate over a few thousand 1 kHz cycles) with the round-trip percentiles an rttest-style
report gives. The box timestamps each state it sends and each command that answers it
(monotonic clock, same machine), so the round trip includes both processes' scheduling, the
loopback stack and the client's work between read and write.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np

from . import franka_protocol as fp
from . import start_franka_box
from .franka_box import RTT_HIST_EDGES_US
from .franka_client import Robot


@dataclass(frozen=True)
class RoundTrip:
    """One run of the Franka-style loop: round trip (us) and how many ticks had their command."""

    label: str
    seconds: float
    ticks: int                 # ticks the box spent moving
    commands_ok: int           # ticks whose command arrived before the next tick
    missed: int
    late: int                  # commands that arrived after their tick (counted, discarded)
    max_missed_in_row: int     # the longest run of missed ticks (the reflex fires above max_missed)
    rtt_p50_us: float
    rtt_p99_us: float
    rtt_max_us: float
    box_overruns: int          # ticks the box itself could not keep
    states_sent: int = 0       # states the box sent during the run (by their sequence numbers)
    wall_s: float = float("nan")   # wall time from the first to the last state read
    rtt_hist_counts: tuple = ()    # round trips per bin of RTT_HIST_EDGES_US

    @property
    def state_rate_hz(self) -> float:
        """States per second of wall time (the box's clock, as the client saw it run)."""
        return self.states_sent / self.wall_s if self.wall_s > 0 else float("nan")

    @property
    def rtt_hist_edges_us(self) -> np.ndarray:
        return np.asarray(RTT_HIST_EDGES_US)

    @property
    def success_rate(self) -> float:
        return self.commands_ok / self.ticks if self.ticks else 0.0

    def would_reflex(self, max_missed: int = fp.DEFAULT_MAX_MISSED) -> bool:
        return self.max_missed_in_row > max_missed

    def row(self) -> str:
        return (f"{self.label:<34} {self.rtt_p50_us:8.0f} {self.rtt_p99_us:8.0f} {self.rtt_max_us:9.0f} "
                f"{100 * self.success_rate:8.2f}% {self.missed:6d} {self.max_missed_in_row:5d} {self.box_overruns:6d}")


HEADER = (f"{'run':<34} {'p50 us':>8} {'p99 us':>8} {'max us':>9} {'success':>9} {'missed':>6} "
          f"{'worst':>5} {'box-ov':>6}")


def franka_roundtrip(seconds: float = 2.0, *, physics: bool = True, realtime: bool = False,
                     work=None, label: str | None = None) -> RoundTrip:
    """Run a fresh Franka-style box and a client loop (read the state, call ``work()`` if given,
    answer with the measured position) for ``seconds``; return what the box counted.

    ``realtime``: both the box and this loop try SCHED_FIFO + locked memory + a frozen gc (what
    :func:`robocourse.rt.settings.realtime` does; refused silently for an unprivileged user:
    the run then measures the default scheduler, say so when you print it). The box allows any
    number of missed ticks here (no reflex) so the whole run is measured; ``max_missed_in_row``
    tells whether the default limit would have stopped the robot.
    """
    from robocourse.rt import settings

    if not 0 < seconds <= 600:
        raise ValueError(f"seconds={seconds!r} must be in (0, 600]")
    box = start_franka_box(max_missed=10 ** 9, physics=physics, realtime=realtime)
    try:
        with Robot(port=box.ports["udp"]) as robot:
            robot.read_latest()
            ctx = settings.realtime(quiet=True, heap_size=16 * 1024 * 1024) if realtime else contextlib.nullcontext()
            with ctx:
                robot.resync()          # entering the settings took a while: start from a fresh state
                end = time.monotonic() + seconds
                first = last = None     # (seq, time) of the first and the last state read
                finished = False
                while not finished:     # the last command ends the motion, inside the settings' block
                    if not robot.read_latest(0.5):
                        break
                    last = (robot.last_seq, time.monotonic())
                    first = first or last
                    if work is not None:
                        work()
                    finished = time.monotonic() >= end
                    robot.write_command(robot.q, motion_finished=finished)
                states, wall = (last[0] - first[0], last[1] - first[1]) if last else (0, 0.0)  # the box numbers its states
            time.sleep(0.01)
            s = robot.box_stats()
    finally:
        box.stop()
    return RoundTrip(label or f"{'franka box' if physics else 'UDP echo (no physics)'}"
                     f"{', RT' if realtime else ''}", seconds, s.get("ticks_moving", 0), s.get("commands_ok", 0),
                     s.get("missed", 0), s.get("late", 0), s.get("max_missed_in_row", 0),
                     s.get("rtt_p50_us", float("nan")), s.get("rtt_p99_us", float("nan")),
                     s.get("rtt_max_us", float("nan")), s.get("box_overruns", 0),
                     states, wall, tuple(s.get("rtt_hist_counts", ())))
