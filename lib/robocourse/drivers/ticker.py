"""The boxes' main loop: a tick every period on absolute deadlines, sockets served in between.

Counterpart: a robot controller's fixed-rate servo cycle. A box subclasses :class:`TickingBox`
and provides ``sockets()``, ``on_readable(sock)`` and ``tick()``. When a tick ends past the
next deadline the box counts ``box_overruns`` and skips the lost ticks instead of bursting to
catch up (a real controller keeps its rate too).
"""

from __future__ import annotations

import collections
import select
import time


class TickingBox:
    period_ns: int = 1_000_000
    #: True: a tick that starts late (by more than a tenth of a period) re-phases the schedule,
    #: so the next tick comes a full period after it (the client always gets a whole period to
    #: answer; a starved box runs slower instead: ``box_late_ticks`` counts these). False: keep
    #: the absolute grid (the next tick may follow a late one at once).
    rephase: bool = False

    def __init__(self):
        self.counters = collections.Counter()
        self.running = True
        self.t0_ns = time.monotonic_ns()
        self.tick_index = 0

    def sockets(self) -> list:
        raise NotImplementedError

    def on_readable(self, sock) -> None:
        raise NotImplementedError

    def tick(self) -> None:
        raise NotImplementedError

    def run(self) -> None:
        period = self.period_ns
        next_t = time.monotonic_ns() + period
        while self.running:
            while True:
                left = next_t - time.monotonic_ns()
                # when late (the box was not scheduled), still take in what arrived meanwhile before the
                # tick: a client's inputs sent on time must not look late to the tick (a watchdog would fire)
                readable, _, _ = select.select(self.sockets(), [], [], max(0, left) * 1e-9)
                for s in readable:
                    self.on_readable(s)
                if left <= 0:
                    break
            started = time.monotonic_ns()
            self.tick()
            self.tick_index += 1
            if self.rephase and started - next_t > period // 10:
                self.counters["box_late_ticks"] += 1
                next_t = started
            next_t += period
            behind = time.monotonic_ns() - next_t
            if behind > 0:
                self.counters["box_overruns"] += 1
                skipped = behind // period + 1
                self.counters["box_ticks_skipped"] += skipped
                self.tick_index += skipped
                next_t += skipped * period
