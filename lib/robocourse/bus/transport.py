"""A seeded model of the network between a publisher and a subscription: loss and delay.

ROS 2 counterpart: what the DDS/zenoh middleware does on a real link. In one process
nothing is ever lost, so ``ctx.set_link(...)`` adds a lossy, slow link on a topic or between
two nodes to show what the reliability QoS buys:

- BEST_EFFORT pair (either side BEST_EFFORT): a sample is lost with probability ``loss``; the
  subscription's ``message_lost`` event fires (``QoSMessageLostInfo``, as rmw reports sample
  loss) and ``sub.counts.message_lost`` counts it. Samples that get through arrive ``delay``
  (+ uniform ``jitter``) seconds later, possibly out of order when there is jitter.
- RELIABLE pair: a lost sample is resent after ``retransmit_delay`` until it gets through
  (each attempt lost with probability ``loss``), and samples are handed over in publish order,
  so one loss holds back the samples behind it (head-of-line blocking): nothing is lost, it
  arrives late. With KEEP_ALL history nothing is ever dropped; with KEEP_LAST the
  subscription's queue may still overwrite old samples (``counts.dropped_keep_last``).

Differences from DDS: no write blocking (a RELIABLE KEEP_ALL writer in DDS blocks when its
resource limits fill; here the link buffers without bound), no fragmentation (loss is per
sample, whatever its size), and the random draws are one ``random.Random(seed)`` per link, so
the same graph and seed lose the same samples every run.
"""

from __future__ import annotations

import heapq
import math
import random
import threading

from robocourse.bus.qos import QoSMessageLostInfo, ReliabilityPolicy


def _fraction(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 1.0:
        raise ValueError(f"{name}={value!r} must be a probability in [0, 1]; e.g. {name}=0.1 "
                         f"for 10 % of samples")
    return float(value)


def _delay(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value < 0:
        raise ValueError(f"{name}={value!r} must be a finite number of seconds >= 0; e.g. "
                         f"{name}=0.002 for 2 ms")
    return float(value)


class Link:
    """One lossy/slow link: which pairs it applies to, its parameters and its counters.

    ``sent`` counts samples offered to the link, ``lost`` the BEST_EFFORT samples it dropped,
    ``retransmitted`` the resends of RELIABLE samples, ``delivered`` the samples handed to a
    subscription queue.
    """

    def __init__(self, *, topic=None, publisher_node=None, subscription_node=None, loss=0.0,
                 delay=0.0, jitter=0.0, retransmit_delay=None, seed=0):
        for name, v in (("topic", topic), ("publisher_node", publisher_node),
                        ("subscription_node", subscription_node)):
            if v is not None and (not isinstance(v, str) or not v.startswith("/")):
                raise ValueError(f"{name}={v!r} must be a fully qualified name starting with '/' "
                                 f"(e.g. '/chatter' or '/talker'), or None for any")
        if topic is None and publisher_node is None and subscription_node is None:
            raise ValueError("set_link needs a topic, a publisher_node or a subscription_node to "
                             "apply to; e.g. ctx.set_link(topic='/chatter', loss=0.1)")
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise ValueError(f"seed={seed!r} must be an int (the same seed loses the same samples)")
        self.topic = topic
        self.publisher_node = publisher_node
        self.subscription_node = subscription_node
        self.loss = _fraction("loss", loss)
        if self.loss == 1.0:
            raise ValueError("loss=1.0 would make a RELIABLE link resend forever; use loss < 1 "
                             "(or destroy the publisher to model a broken link)")
        self.delay = _delay("delay", delay)
        self.jitter = _delay("jitter", jitter)
        default_rt = max(2 * self.delay, 0.001)
        self.retransmit_delay = _delay("retransmit_delay",
                                       default_rt if retransmit_delay is None else retransmit_delay)
        self.seed = seed
        self._rng = random.Random(seed)
        self.sent = 0
        self.lost = 0
        self.retransmitted = 0
        self.delivered = 0

    def applies(self, pub, sub) -> bool:
        return ((self.topic is None or self.topic == pub.topic_name)
                and (self.publisher_node is None
                     or self.publisher_node == pub._node.get_fully_qualified_name())
                and (self.subscription_node is None
                     or self.subscription_node == sub._node.get_fully_qualified_name()))

    def __repr__(self):
        where = ", ".join(f"{k}={v!r}" for k, v in (
            ("topic", self.topic), ("publisher_node", self.publisher_node),
            ("subscription_node", self.subscription_node)) if v is not None)
        return (f"Link({where}, loss={self.loss}, delay={self.delay}, jitter={self.jitter}; "
                f"sent={self.sent}, lost={self.lost}, retransmitted={self.retransmitted}, "
                f"delivered={self.delivered})")


def pair_is_reliable(pub, sub) -> bool:
    """The reliability a matched pair runs with: BEST_EFFORT if either side asks for it."""
    p, s = pub.qos_profile.reliability, sub.qos_profile.reliability
    return ReliabilityPolicy.BEST_EFFORT not in (p, s)


class LinkDelivery:
    """Delivers one publisher's samples to one subscription through a :class:`Link`."""

    def __init__(self, pub, sub, link, inner):
        from robocourse.bus.timer import Timer

        self.pub = pub
        self.sub = sub
        self.link = link
        self.inner = inner          # the pair's plain delivery (sub._deliver or deadline-aware)
        self.reliable = pair_is_reliable(pub, sub)
        self._heap = []
        self._lock = threading.Lock()   # a publisher thread pushes while the executor pops
        self._seq = 0
        self._last_due = 0
        self._clock = sub._node.get_clock()
        node = sub._node
        self.timer = Timer(node, 0.0, self._release, sub.callback_group, self._clock,
                           autostart=False, hidden=True)
        node._add_entity(self.timer, node.timers)

    def close(self):
        node = self.sub._node
        node._remove_entity(self.timer, node.timers)
        self._heap.clear()

    def __call__(self, msg):
        link = self.link
        rng = link._rng
        link.sent += 1
        delay = link.delay
        if link.jitter:
            delay += rng.uniform(0.0, link.jitter)
        if link.loss and rng.random() < link.loss:
            if not self.reliable:
                link.lost += 1
                self._lost()
                return
            delay += link.retransmit_delay
            link.retransmitted += 1
            while rng.random() < link.loss:
                delay += link.retransmit_delay
                link.retransmitted += 1
        if delay == 0.0 and not self._heap:     # nothing queued ahead: hand over now
            link.delivered += 1
            self.inner(msg)
            return
        with self._lock:
            due = self._clock._now_ns() + int(round(delay * 1e9))
            if self.reliable and due < self._last_due:
                due = self._last_due        # in-order hand-over: wait behind the earlier sample
            self._last_due = due
            self._seq += 1
            heapq.heappush(self._heap, (due, self._seq, msg))
            t = self.timer
            earlier = t._next_ns is None or due < t._next_ns
            if earlier:
                t._next_ns = due
        if earlier:
            ex = t._executor
            if ex is not None:
                ex._wake()

    def _lost(self):
        from robocourse.bus.context import _emit

        sub = self.sub
        sub.counts.message_lost += 1
        _emit(sub, "message_lost", QoSMessageLostInfo(sub.counts.message_lost, 1))

    def _release(self):
        """Timer callback: hand every sample whose time has come to the subscription."""
        now = self._clock._now_ns()
        heap = self._heap
        due = []
        with self._lock:
            while heap and heap[0][0] <= now:
                due.append(heapq.heappop(heap)[2])
            self.timer._next_ns = heap[0][0] if heap else None
        for msg in due:
            self.link.delivered += 1
            self.inner(msg)

    @property
    def in_flight(self) -> int:
        return len(self._heap)
