"""Clocks for the periodic loop: the real CLOCK_MONOTONIC and a deterministic fake.

rttest and cyclictest read CLOCK_MONOTONIC and sleep with
``clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, ...)``. Python has no public absolute
sleep (``time.sleep`` is relative), so :class:`MonotonicClock` calls libc's
``clock_nanosleep`` through ctypes (the GIL is released while it sleeps) and falls back to a
relative ``time.sleep`` only where libc offers no such call. :class:`FakeClock` has the same
two methods and lets tests and exercises check loop logic without depending on timing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import time

import numpy as np

CLOCK_MONOTONIC = 1
TIMER_ABSTIME = 1


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


def _load_clock_nanosleep():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        fn = libc.clock_nanosleep
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.POINTER(_Timespec), ctypes.POINTER(_Timespec)]
    fn.restype = ctypes.c_int
    return fn


_clock_nanosleep = _load_clock_nanosleep()


class MonotonicClock:
    """CLOCK_MONOTONIC in integer ns, with an absolute sleep (rttest's clock and sleep)."""

    name = "CLOCK_MONOTONIC"

    def __init__(self):
        self.absolute_sleep = _clock_nanosleep is not None
        self._ts = _Timespec()

    @staticmethod
    def now_ns() -> int:
        return time.monotonic_ns()

    def sleep_until_ns(self, deadline_ns: int) -> None:
        """Sleep until CLOCK_MONOTONIC reaches ``deadline_ns`` (TIMER_ABSTIME; restarts on EINTR)."""
        if _clock_nanosleep is None:
            remaining = deadline_ns - time.monotonic_ns()
            if remaining > 0:
                time.sleep(remaining / 1e9)
            return
        ts = self._ts
        ts.tv_sec, ts.tv_nsec = divmod(int(deadline_ns), 1_000_000_000)
        while True:
            rc = _clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, ctypes.byref(ts), None)
            if rc != errno.EINTR:
                return

    def sleep_ns(self, duration_ns: int) -> None:
        """A *relative* sleep, like ``time.sleep``: the wrong tool for a periodic loop."""
        if duration_ns > 0:
            time.sleep(duration_ns / 1e9)


class FakeClock:
    """A simulated clock: every sleep overshoots by a random 0..``oversleep_ns``; reading costs ``read_cost_ns``.

    Deterministic (seeded). ``work(ns)`` advances time as if a callback computed for ``ns``.
    It records every absolute sleep target in ``sleep_targets`` and every relative sleep in
    ``relative_sleeps`` so a test can see exactly which deadlines a loop asked for.
    """

    name = "FakeClock"

    def __init__(self, start_ns: int = 1_000_000_000, oversleep_ns: int = 50_000,
                 read_cost_ns: int = 50, seed: int = 0):
        if oversleep_ns < 0 or read_cost_ns < 0:
            raise ValueError("FakeClock: oversleep_ns and read_cost_ns must be >= 0")
        self.t = int(start_ns)
        self.oversleep_ns = int(oversleep_ns)
        self.read_cost_ns = int(read_cost_ns)
        self._rng = np.random.default_rng(seed)
        self.sleep_targets: list[int] = []
        self.relative_sleeps: list[int] = []
        self.absolute_sleep = True

    def _oversleep(self) -> int:
        return int(self._rng.integers(0, self.oversleep_ns + 1)) if self.oversleep_ns else 0

    def now_ns(self) -> int:
        self.t += self.read_cost_ns
        return self.t

    def sleep_until_ns(self, deadline_ns: int) -> None:
        self.sleep_targets.append(int(deadline_ns))
        if deadline_ns > self.t:
            self.t = int(deadline_ns) + self._oversleep()

    def sleep_ns(self, duration_ns: int) -> None:
        self.relative_sleeps.append(int(duration_ns))
        if duration_ns > 0:
            self.t += int(duration_ns) + self._oversleep()

    def work(self, duration_ns: int) -> None:
        self.t += int(duration_ns)
