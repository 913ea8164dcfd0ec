"""Timers and rates on a node's clock.

rclpy counterparts: ``rclpy.timer.Timer`` (``node.create_timer(period_sec, callback)``:
cancel, reset, is_canceled, is_ready, time_until_next_call, time_since_last_call,
timer_period_ns) and ``rclpy.timer.Rate`` (``node.create_rate(hz)``). A timer follows its
clock: under simulated time it fires at exact multiples of the period of simulated time. A
timer that falls behind skips the missed periods (rcl does the same) and counts them in
``missed_periods``.
"""

from __future__ import annotations

import threading


class Timer:
    _is_timer = True

    def __init__(self, node, period_sec, callback, callback_group, clock, autostart=True,
                 oneshot=False, hidden=False):
        period_ns = int(round(float(period_sec) * 1e9))
        if period_ns < 0:
            raise ValueError(f"timer period must be >= 0 s, got {period_sec}")
        self._node = node
        self.callback = callback
        self.callback_group = callback_group
        self._clock = clock
        self.timer_period_ns = period_ns
        self._scheduled = False
        self._executor = None
        self._oneshot = oneshot
        self._hidden = hidden
        self._destroyed = False
        self._last_ns = clock._now_ns()
        self._next_ns = self._last_ns + period_ns if autostart else None
        self.call_count = 0
        self.missed_periods = 0

    @property
    def clock(self):
        return self._clock

    # executor protocol
    def _take_check(self) -> bool:
        return False

    def _take(self):
        now = self._clock._now_ns()
        nxt = self._next_ns
        period = self.timer_period_ns
        self._last_ns = now
        if self._oneshot:
            self._next_ns = None
        elif period == 0:
            self._next_ns = now
        else:
            nxt += period
            if nxt <= now:   # fell behind: skip missed periods like rcl
                missed = (now - nxt) // period + 1
                self.missed_periods += missed
                nxt += missed * period
            self._next_ns = nxt
        return True

    def _execute(self, _work):
        self.call_count += 1
        self.callback()

    def _describe(self) -> str:
        return f"timer callback of node '{self._node.get_fully_qualified_name()}'"

    # public API
    def cancel(self) -> None:
        self._next_ns = None

    def is_canceled(self) -> bool:
        return self._next_ns is None

    def reset(self) -> None:
        self._last_ns = self._clock._now_ns()
        self._next_ns = self._last_ns + self.timer_period_ns
        ex = self._executor
        if ex is not None:
            ex._wake()

    def is_ready(self) -> bool:
        return self._next_ns is not None and self._next_ns <= self._clock._now_ns()

    def time_until_next_call(self) -> int | None:
        if self._next_ns is None:
            return None
        return self._next_ns - self._clock._now_ns()

    def time_since_last_call(self) -> int:
        return self._clock._now_ns() - self._last_ns

    @property
    def timer_period_sec(self) -> float:
        return self.timer_period_ns / 1e9

    def destroy(self) -> None:
        self._node.destroy_timer(self)

    def __repr__(self):
        return f"<Timer period={self.timer_period_ns / 1e9}s>"


class Rate:
    """rclpy.timer.Rate: ``rate.sleep()`` blocks until the next period (needs another thread
    spinning the node's executor, as in rclpy). In simulated time prefer a timer or
    ``await node.sleep_async(dt)``.
    """

    def __init__(self, timer: Timer):
        self._timer = timer
        self._event = threading.Event()
        timer.callback = self._event.set

    def sleep(self) -> None:
        from robocourse.bus.executors import current_callback

        ex = self._timer._executor
        if ex is None or not ex.is_spinning_elsewhere():
            cur = current_callback()
            raise RuntimeError(
                "Rate.sleep() would block forever: no executor is spinning this node on another "
                "thread" + (" (called inside a callback)" if cur else "") +
                ". Spin the node in a background thread, or use a timer instead of a loop.")
        self._event.clear()
        self._event.wait()

    def destroy(self) -> None:
        self._timer.destroy()
