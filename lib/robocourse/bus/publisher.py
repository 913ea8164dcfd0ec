"""Publisher: ``node.create_publisher(msg_type, topic, qos)`` then ``pub.publish(msg)``.

rclpy counterpart: ``rclpy.publisher.Publisher`` (publish, get_subscription_count,
topic_name, qos_profile, assert_liveliness, wait_for_all_acked, destroy).

Value semantics, as in ROS 2: every matched subscription (and the TRANSIENT_LOCAL history)
gets its own copy of the message as it was when ``publish`` was called, so the publisher may
reuse and change its message object (``msg.data = i; pub.publish(msg)``) and a callback may
change what it received without affecting anyone else. rclpy gets this by serializing on
publish (CDR) and deserializing per subscription; here each type's generated ``_copy()``
(a deep copy of exactly the message's fields) does it, 10-50x cheaper than a CDR round trip
(see benchmarks/bus_latency.py). The copy also re-checks bounded arrays that were grown in
place, as serialization would.
"""

from __future__ import annotations

from collections import deque

from robocourse.bus.qos import INFINITE, DurabilityPolicy, _Counts, effective_depth


class InvalidHandle(RuntimeError):
    """Using an entity after ``destroy()`` (rclpy raises ``InvalidHandle`` too)."""


class _Expiring:
    """A message with its lifespan expiry (only used when the publisher has a lifespan)."""

    __slots__ = ("msg", "expiry_ns")

    def __init__(self, msg, expiry_ns):
        self.msg = msg
        self.expiry_ns = expiry_ns


class Publisher:
    def __init__(self, node, msg_type, topic, qos, event_callbacks, callback_group):
        self._node = node
        self.msg_type = msg_type
        self.topic_name = topic
        self.qos_profile = qos
        self.event_callbacks = event_callbacks
        self.callback_group = callback_group
        self._subs = []                 # matched subscriptions
        self._deliver = ()              # one delivery per matched subscription (tuple: fast)
        self._pairs = {}                # subscription -> its delivery (context._rewire)
        self._links = {}                # subscription -> LinkDelivery on a modelled link
        self._remote = None             # the zenoh transport's sender (other processes), if any
        self._destroyed = False
        self.counts = _Counts()
        self.publish_count = 0
        self._lifespan_ns = None if qos.lifespan == INFINITE else int(qos.lifespan * 1e9)
        self._clock = node.get_clock()
        if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
            self._history = deque(maxlen=effective_depth(qos))
        else:
            self._history = None
        self._alive = True
        self._asserted = 0
        self._deadline = None           # DeadlineWatch when the profile has a deadline
        self._slow = self._lifespan_ns is not None or self._history is not None

    @property
    def topic(self) -> str:
        return self.topic_name

    @property
    def handle(self):
        if self._destroyed:
            raise InvalidHandle(f"publisher on {self.topic_name!r} was destroyed")
        return self

    def publish(self, msg) -> None:
        """Deliver ``msg`` to every matched subscription (and keep it for late joiners)."""
        if type(msg) is not self.msg_type:
            self._wrong(msg)
        if self._destroyed:
            raise InvalidHandle(
                f"cannot publish on {self.topic_name!r}: the publisher was destroyed "
                f"(destroy_publisher / destroy_node); create a new publisher")
        self.publish_count += 1
        if self._slow:
            self._publish_slow(msg)
            return
        # hot path: one copy per matched subscription (value semantics); the wire gets the
        # message itself: the transport encodes it before publish returns, a snapshot already
        copy = msg._copy
        for deliver in self._deliver:
            deliver(copy())
        if self._remote is not None:
            self._remote(msg)

    def _publish_slow(self, msg):
        """publish with lifespan, a TRANSIENT_LOCAL history or a deadline to keep."""
        copy = msg._copy
        if self._deadline is not None:
            self._deadline.sample(None)
        if self._remote is not None:
            self._remote(msg)
        if self._lifespan_ns is not None:
            expiry = self._clock._now_ns() + self._lifespan_ns
            if self._history is not None:
                self._history.append(_Expiring(copy(), expiry))
            for deliver in self._deliver:
                deliver(_Expiring(copy(), expiry))
            return
        if self._history is not None:
            self._history.append(copy())
        for deliver in self._deliver:
            deliver(copy())

    def _replay_history(self, deliver) -> None:
        """Hand a late-joining TRANSIENT_LOCAL subscription copies of the kept samples."""
        for item in list(self._history):
            if type(item) is _Expiring:
                deliver(_Expiring(item.msg._copy(), item.expiry_ns))
            else:
                deliver(item._copy())

    def _wrong(self, msg):
        if self._destroyed:
            raise InvalidHandle(f"cannot publish on {self.topic_name!r}: the publisher was destroyed")
        got = getattr(msg, "_type", type(msg).__name__)
        raise TypeError(
            f"publisher on {self.topic_name!r} (node {self._node.get_fully_qualified_name()!r}) "
            f"publishes {self.msg_type._type}, got {got} ({msg!r:.80}); "
            f"publish a {self.msg_type.__name__}(...) instead")

    def get_subscription_count(self) -> int:
        return len(self._subs)

    def assert_liveliness(self) -> None:
        """Manual liveliness: tell subscribers this publisher is alive (MANUAL_BY_TOPIC)."""
        self._asserted += 1

    def wait_for_all_acked(self, timeout_sec=None) -> bool:
        """True when no sample is still travelling on a modelled link (``ctx.set_link``)."""
        return not any(getattr(d, "in_flight", 0) for d in self._deliver)

    def destroy(self) -> None:
        self._node.destroy_publisher(self)

    def _describe(self) -> str:
        return f"publisher on topic '{self.topic_name}' of node '{self._node.get_fully_qualified_name()}'"

    def __repr__(self):
        return f"<Publisher {self.topic_name} [{self.msg_type._type}]>"
