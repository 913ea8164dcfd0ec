"""How the loop waits for its next deadline: sleep, sleep-then-spin (hybrid), adaptive, or spin.

rttest and cyclictest only sleep (``clock_nanosleep`` with TIMER_ABSTIME). On a stock kernel
without real-time scheduling a sleeping thread wakes late by the timer slack (50 us under
SCHED_OTHER) plus the scheduler's wake-up latency; :class:`Hybrid` sleeps until ``spin_ns``
before the deadline and spins the rest, trading CPU time for a punctual wake-up. :class:`Adaptive`
learns how late this machine's sleeps wake (a running high quantile of the overshoot) and spins
only that window, never more than a bound the user sets. :class:`Spin` never sleeps (and a
SCHED_FIFO thread that never sleeps hits RT throttling). None of these has a ROS 2 counterpart:
rttest, rclcpp's executors and cyclictest all sleep.
"""

from __future__ import annotations

import array
from dataclasses import dataclass

import numpy as np


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


def _ns_arg(value, what: str, example: str, lowest: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lowest:
        raise ValueError(f"Adaptive({what}={value!r}): must be an int >= {lowest} in ns, e.g. {example}")
    return int(value)


class Adaptive(WaitStrategy):
    """Sleep until a learned window before the deadline, then spin: the window is what this
    machine needs right now, never more than ``max_spin_ns``.

    Every wait sleeps (absolute, like :class:`Sleep`) until ``deadline - window`` and measures
    the *overshoot*: how late that sleep woke. ``window`` is the ``quantile`` of the last
    ``history`` overshoots plus ``margin_ns``, recomputed every ``update_every`` waits in time
    the loop would sleep through anyway (never when that would make it late), and clamped to
    ``[0, max_spin_ns]``. A sleep that overshoots the window raises it at once (to that
    overshoot plus the margin): a load that appears is followed within one period; a load that
    goes away is forgotten once ``history`` newer wake-ups replace it. Until ``update_every``
    overshoots are known the window is ``max_spin_ns`` (start cautious).

    It keeps state, so use one object per loop. ``spin_ns_total / waits`` is the average spin
    per period, ``late`` how many sleeps woke after the deadline they were meant to precede,
    ``window_trace`` the (wait number, window ns) of every change.
    """

    name = "adaptive"

    def __init__(self, max_spin_ns: int = 300_000, quantile: float = 0.99, margin_ns: int = 10_000,
                 history: int = 1000, update_every: int = 50):
        self.max_spin_ns = _ns_arg(max_spin_ns, "max_spin_ns", "Adaptive(max_spin_ns=300_000) for 300 us")
        self.margin_ns = _ns_arg(margin_ns, "margin_ns", "Adaptive(margin_ns=10_000) for 10 us")
        if isinstance(quantile, bool) or not isinstance(quantile, (int, float)) or not 0.5 <= quantile < 1:
            raise ValueError(f"Adaptive(quantile={quantile!r}): the learned quantile of the sleep "
                             "overshoot must be in [0.5, 1), e.g. Adaptive(quantile=0.99)")
        if isinstance(history, bool) or not isinstance(history, int) or history < 10:
            raise ValueError(f"Adaptive(history={history!r}): keep at least 10 overshoots, "
                             "e.g. Adaptive(history=1000) (1 s at 1 kHz)")
        if isinstance(update_every, bool) or not isinstance(update_every, int) or not 1 <= update_every <= history:
            raise ValueError(f"Adaptive(update_every={update_every!r}): must be an int in 1..history "
                             f"({history}), e.g. Adaptive(update_every=50)")
        self.quantile = float(quantile)
        self.history = history
        self.update_every = update_every
        self.reset()

    def reset(self) -> None:
        """Forget what was learned: the next wait starts from ``max_spin_ns`` again."""
        self.window_ns = self.max_spin_ns
        self._ring = array.array("q", bytes(8 * self.history))
        self._n = 0                     # overshoots recorded in all
        self._since_update = 0
        self._update_cost_ns = 20_000   # what a recomputation may take; learned as it runs
        self.waits = 0
        self.spin_ns_total = 0
        self.late = 0
        self.window_trace: list[tuple[int, int]] = [(0, self.window_ns)]

    def __repr__(self) -> str:
        return (f"Adaptive(max_spin_ns={self.max_spin_ns}, quantile={self.quantile}, "
                f"margin_ns={self.margin_ns}, history={self.history}, update_every={self.update_every})")

    def __str__(self) -> str:
        return f"adaptive (<= {self.max_spin_ns // 1000} us spin)"

    @property
    def mean_spin_ns(self) -> float:
        """Average spin per wait so far (the CPU the strategy adds to a plain sleep)."""
        return self.spin_ns_total / self.waits if self.waits else 0.0

    def describe(self, period_ns: int | None = None) -> str:
        """One paragraph: what it learned and what it cost (the CLI prints it after a run)."""
        q = self.learned_quantile_ns()
        n = min(self._n, self.history)
        text = (f"adaptive wait: window {self.window_ns / 1000:.1f} us at the end "
                f"(p{100 * self.quantile:g} of the last {n} sleep overshoots "
                + (f"{q / 1000:.1f} us" if n else "unknown") + f" + {self.margin_ns / 1000:g} us margin, "
                f"at most {self.max_spin_ns / 1000:g} us); spun {self.mean_spin_ns / 1000:.1f} us per wait on average")
        if period_ns:
            text += f" ({100 * self.mean_spin_ns / period_ns:.1f} % of a core)"
        return text + (f"; {self.late} of {self.waits} sleeps woke after the deadline"
                       f" ({len(self.window_trace) - 1} window changes)")

    def learned_quantile_ns(self) -> float:
        """The ``quantile`` of the recorded overshoots (nan before any)."""
        n = min(self._n, self.history)
        if n == 0:
            return float("nan")
        data = np.frombuffer(self._ring, dtype=np.int64)[:n]
        k = min(n - 1, int(self.quantile * n))
        return float(np.partition(data, k)[k])

    def _set_window(self, ns: float) -> None:
        w = int(min(max(ns, 0), self.max_spin_ns))
        if w != self.window_ns:
            self.window_ns = w
            self.window_trace.append((self.waits, w))

    # --- hot path: one call per period ---------------------------------------------------------
    def wait_until(self, clock, deadline_ns: int) -> None:
        now = clock.now_ns
        t = now()
        if (self._since_update >= self.update_every
                and deadline_ns - self.window_ns - t > 2 * self._update_cost_ns):
            self._since_update = 0           # recompute in time the loop would sleep through anyway
            self._set_window(self.learned_quantile_ns() + self.margin_ns)
            t2 = now()
            self._update_cost_ns = max(t2 - t, self._update_cost_ns * 7 // 8)
            t = t2
        window = self.window_ns
        target = deadline_ns - window
        if t < target:
            clock.sleep_until_ns(target)
            t = now()
            over = t - target
            self._ring[self._n % self.history] = over
            self._n += 1
            self._since_update += 1
            if over > window:                # woke after the deadline: widen at once
                self.late += 1
                self._set_window(over + self.margin_ns)
        spin_from = t
        while t < deadline_ns:
            t = now()
        self.waits += 1
        self.spin_ns_total += t - spin_from


def strategy(name: str, spin_ns: int = 200_000) -> WaitStrategy:
    """``"sleep"`` / ``"hybrid"`` / ``"adaptive"`` / ``"spin"`` -> a strategy object (CLI, notebooks).

    ``spin_ns`` is the hybrid's fixed window, and the adaptive wait's upper bound."""
    key = str(name).strip().lower()
    if key == "sleep":
        return Sleep()
    if key == "hybrid":
        return Hybrid(spin_ns=spin_ns)
    if key == "adaptive":
        return Adaptive(max_spin_ns=spin_ns)
    if key == "spin":
        return Spin()
    raise ValueError(f"unknown wait strategy {name!r}: use 'sleep', 'hybrid', 'adaptive' or 'spin'")
