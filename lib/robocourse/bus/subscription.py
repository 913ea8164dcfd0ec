"""Subscription: ``node.create_subscription(msg_type, topic, callback, qos)``.

rclpy counterpart: ``rclpy.subscription.Subscription``. The history QoS sizes the queue:
KEEP_LAST n keeps the newest n messages (the oldest is dropped and counted in
``counts.dropped_keep_last``), KEEP_ALL keeps every message. Messages whose lifespan passed
before the callback could run are dropped (counted in ``counts.lifespan_expired``), as DDS does.
"""

from __future__ import annotations

from collections import deque

from robocourse.bus.publisher import _Expiring
from robocourse.bus.qos import _Counts, effective_depth


class Subscription:
    def __init__(self, node, msg_type, topic, callback, qos, event_callbacks, callback_group,
                 raw=False):
        self._node = node
        self.msg_type = msg_type
        self.topic_name = topic
        self.callback = callback
        self.qos_profile = qos
        self.event_callbacks = event_callbacks
        self.callback_group = callback_group
        self._maxlen = effective_depth(qos)
        self._queue = deque(maxlen=self._maxlen)
        self._pubs = []
        self._scheduled = False
        self._executor = None
        self._destroyed = False
        self.counts = _Counts()
        self.receive_count = 0
        self._clock = node.get_clock()
        self._deadline = None           # DeadlineWatch when the profile has a deadline
        if self._maxlen is None:
            self._deliver = self._deliver_all
        else:
            self._deliver = self._deliver_last

    @property
    def topic(self) -> str:
        return self.topic_name

    # hot path: called by Publisher.publish in the publishing thread
    def _deliver_all(self, msg):
        self._queue.append(msg)
        if not self._scheduled:
            ex = self._executor
            if ex is not None:
                ex._schedule(self)

    def _deliver_last(self, msg):
        q = self._queue
        if len(q) == self._maxlen:
            self.counts.dropped_keep_last += 1
        q.append(msg)
        if not self._scheduled:
            ex = self._executor
            if ex is not None:
                ex._schedule(self)

    # executor protocol
    def _take_check(self) -> bool:
        return bool(self._queue)

    def _take(self):
        q = self._queue
        while q:
            msg = q.popleft()
            if type(msg) is _Expiring:
                if self._clock._now_ns() > msg.expiry_ns:
                    self.counts.lifespan_expired += 1
                    continue
                msg = msg.msg
            return msg
        return None

    def _execute(self, msg):
        self.receive_count += 1
        return self.callback(msg)

    def _describe(self) -> str:
        return (f"subscription callback on topic '{self.topic_name}' of node "
                f"'{self._node.get_fully_qualified_name()}'")

    def get_publisher_count(self) -> int:
        return len(self._pubs)

    def destroy(self) -> None:
        self._node.destroy_subscription(self)

    def __repr__(self):
        return f"<Subscription {self.topic_name} [{self.msg_type._type}]>"
