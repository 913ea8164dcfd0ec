"""Deadline QoS: a miss is a period longer than ``deadline`` without a sample.

ROS 2 counterpart: the DDS DEADLINE policy behind rclpy's ``deadline`` event callbacks
(``QoSRequestedDeadlineMissedInfo`` on a subscription, ``QoSOfferedDeadlineMissedInfo`` on a
publisher). Time is measured from the last sample of each publisher/subscription pair (a
subscription with two publishers misses its deadline when either of them goes quiet), on the
node's clock, so simulated time works. Each whole period without a sample counts one miss,
and the next deadline is measured from the missed one, as DDS does.
"""

from __future__ import annotations

from robocourse.bus.qos import QoSOfferedDeadlineMissedInfo, QoSRequestedDeadlineMissedInfo
from robocourse.bus.timer import Timer


class DeadlineWatch:
    """Last-sample times per pair (key: the publisher, or None on the publisher's own side)."""

    def __init__(self, ent, is_pub: bool):
        node = ent._node
        self.ent = ent
        self.is_pub = is_pub
        self.period_ns = int(round(ent.qos_profile.deadline * 1e9))
        self.last: dict = {}
        self.total = 0
        self.clock = node.get_clock()
        self.timer = Timer(node, 0.0, self._check, ent.callback_group, self.clock,
                           autostart=False, hidden=True)
        node._add_entity(self.timer, node.timers)

    def start(self, key) -> None:
        """Start measuring for ``key`` (on match, or on the publisher's creation)."""
        self.last[key] = self.clock._now_ns()
        self._arm()

    def stop(self, key) -> None:
        self.last.pop(key, None)
        self._arm()

    def sample(self, key) -> None:
        """A sample went out (publisher side) or arrived (subscription side) for ``key``."""
        self.last[key] = self.clock._now_ns()

    def wrap(self, key, deliver):
        """``deliver`` that also records the sample's arrival for the pair ``key``."""
        last, now = self.last, self.clock._now_ns

        def deliver_noting(msg):
            last[key] = now()
            deliver(msg)

        return deliver_noting

    def close(self) -> None:
        node = self.ent._node
        node._remove_entity(self.timer, node.timers)
        self.last.clear()

    def _arm(self) -> None:
        t = self.timer
        nxt = min(self.last.values()) + self.period_ns + 1 if self.last else None
        old = t._next_ns
        t._next_ns = nxt
        if nxt is not None and (old is None or nxt < old):
            ex = t._executor
            if ex is not None:
                ex._wake()

    def _check(self) -> None:
        if self.ent._destroyed:
            return
        now = self.clock._now_ns()
        p = self.period_ns
        missed = 0
        for key, t in list(self.last.items()):
            if now > t + p:
                n = (now - t - 1) // p
                missed += n
                self.last[key] = t + n * p
        self._arm()
        if not missed:
            return
        self.total += missed
        self.ent.counts.deadline_missed += missed
        info = (QoSOfferedDeadlineMissedInfo if self.is_pub else QoSRequestedDeadlineMissedInfo)(
            self.total, missed)
        cbs = self.ent.event_callbacks
        if cbs is not None and cbs.deadline is not None:
            cbs.deadline(info)
