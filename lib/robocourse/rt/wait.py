"""How the loop waits for its next deadline: sleep, sleep-then-spin (hybrid), or spin.

rttest and cyclictest only sleep (``clock_nanosleep`` with TIMER_ABSTIME). On a stock kernel
without real-time scheduling a sleeping thread wakes late by the timer slack (50 us under
SCHED_OTHER) plus the scheduler's wake-up latency; :class:`Hybrid` sleeps until ``spin_ns``
before the deadline and spins the rest, trading CPU time for a punctual wake-up. :class:`Spin`
never sleeps (and a SCHED_FIFO thread that never sleeps hits RT throttling).
"""

from __future__ import annotations

from dataclasses import dataclass


class WaitStrategy:
    """Base class: ``wait_until(clock, deadline_ns)`` returns when the deadline has come."""

    name = "wait"

    def wait_until(self, clock, deadline_ns: int) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class Sleep(WaitStrategy):
    """Plain absolute sleep: what rttest and cyclictest do."""

    name = "sleep"

    def wait_until(self, clock, deadline_ns: int) -> None:
        clock.sleep_until_ns(deadline_ns)


@dataclass(frozen=True)
class Hybrid(WaitStrategy):
    """Sleep until ``spin_ns`` before the deadline, then busy-wait on the clock."""

    spin_ns: int = 200_000

    def __post_init__(self):
        if not isinstance(self.spin_ns, int) or isinstance(self.spin_ns, bool) or self.spin_ns < 0:
            raise ValueError(f"Hybrid(spin_ns={self.spin_ns!r}): the spin window must be an int >= 0 "
                             "in ns, e.g. Hybrid(spin_ns=200_000) for 200 us")

    @property
    def name(self) -> str:  # type: ignore[override]
        return f"hybrid({self.spin_ns // 1000} us spin)"

    def wait_until(self, clock, deadline_ns: int) -> None:
        wake_at = deadline_ns - self.spin_ns
        if clock.now_ns() < wake_at:
            clock.sleep_until_ns(wake_at)
        now = clock.now_ns
        while now() < deadline_ns:
            pass


@dataclass(frozen=True)
class Spin(WaitStrategy):
    """Busy-wait on the clock: punctual, burns a whole core."""

    name = "spin"

    def wait_until(self, clock, deadline_ns: int) -> None:
        now = clock.now_ns
        while now() < deadline_ns:
            pass


def strategy(name: str, spin_ns: int = 200_000) -> WaitStrategy:
    """``"sleep"`` / ``"hybrid"`` / ``"spin"`` -> a strategy object (CLI and notebooks)."""
    key = str(name).strip().lower()
    if key == "sleep":
        return Sleep()
    if key == "hybrid":
        return Hybrid(spin_ns=spin_ns)
    if key == "spin":
        return Spin()
    raise ValueError(f"unknown wait strategy {name!r}: use 'sleep', 'hybrid' or 'spin'")
