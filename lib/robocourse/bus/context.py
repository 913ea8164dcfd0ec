"""Context: one in-process ROS 2 "domain" holding the graph, the clock and the log.

rclpy counterparts: ``rclpy.context.Context``, ``rclpy.init``/``rclpy.shutdown``/``rclpy.ok``
and the DDS discovery that matches publishers with subscriptions. Everything created on one
context can talk; two contexts are isolated like two ROS domains.

``Context(use_sim_time=True)`` gives every node simulated time (``use_sim_time`` parameter
true) driven by the executor; ``Context()`` uses the system clock.
"""

from __future__ import annotations

import contextlib
import threading
import weakref

from robocourse.bus import _args
from robocourse.bus.clock import S_TO_NS, SimTime
from robocourse.bus.qos import (
    DurabilityPolicy,
    LivelinessPolicy,
    QoSCompatibility,
    QoSLivelinessChangedInfo,
    QoSOfferedIncompatibleQoSInfo,
    QoSPublisherMatchedInfo,
    QoSRequestedIncompatibleQoSInfo,
    QoSSubscriptionMatchedInfo,
    qos_check_compatible,
)
from robocourse.bus.transport import Link, LinkDelivery


class Incompatibility:
    """A publisher/subscription pair that exchanges nothing because of QoS."""

    def __init__(self, topic, publisher, subscription, policy, reason):
        self.topic = topic
        self.publisher = publisher
        self.subscription = subscription
        self.policy = policy
        self.reason = reason

    def __repr__(self):
        return (f"Incompatibility({self.topic}: {self.publisher._node.get_fully_qualified_name()} -> "
                f"{self.subscription._node.get_fully_qualified_name()}, {self.policy.name})")


class _Topic:
    __slots__ = ("name", "msg_type", "pubs", "subs")

    def __init__(self, name, msg_type):
        self.name = name
        self.msg_type = msg_type
        self.pubs = []
        self.subs = []


class _ServiceEntry:
    __slots__ = ("name", "srv_type", "servers", "clients")

    def __init__(self, name, srv_type):
        self.name = name
        self.srv_type = srv_type
        self.servers = []
        self.clients = []


class Context:
    """A self-contained ROS graph. ``ctx.create_node("talker")`` makes a node on it."""

    def __init__(self, *, use_sim_time: bool = False, start_time: float = 0.0,
                 transport: str | None = None, **transport_options):
        """``transport="zenoh"`` (with ``domain_id``, ``connect``, ``listen``, ``mode``) also
        puts the graph on the wire in rmw_zenoh's format: see
        :mod:`robocourse.bus.zenoh.transport`. Without it everything stays in-process."""
        if transport not in (None, "zenoh"):
            raise ValueError(f"Context(transport={transport!r}): the only transport is 'zenoh' "
                             f"(or None for in-process only)")
        if transport is None and transport_options:
            raise TypeError(f"Context got {sorted(transport_options)} without transport='zenoh'; "
                            f"these options configure the zenoh transport")
        if not isinstance(use_sim_time, bool):
            raise TypeError(f"Context: use_sim_time={use_sim_time!r} must be True or False")
        _args.seconds(start_time, "Context(start_time)", name="start_time")
        self.use_sim_time = bool(use_sim_time)
        self.sim = SimTime(int(round(start_time * S_TO_NS))) if use_sim_time else None
        self._ok = True
        self._lock = threading.RLock()
        self.nodes = []
        self._topics: dict[str, _Topic] = {}
        self._services: dict[str, _ServiceEntry] = {}
        self.log_records = []
        self.log_to_stderr = True
        self.callback_errors = []
        self.incompatibilities: list[Incompatibility] = []
        self.links: list[Link] = []
        self._executors = weakref.WeakSet()
        self._graph_listeners = []
        self._on_shutdown = []
        self.graph_version = 0
        self._batching = 0
        self._batched = False
        self.transport = None
        if transport == "zenoh":
            from robocourse.bus.zenoh.transport import ZenohTransport

            self.transport = ZenohTransport(self, **transport_options)

    # ----------------------------------------------------------------- lifecycle
    def ok(self) -> bool:
        return self._ok

    def shutdown(self) -> None:
        """Stop every executor spinning this context (running callbacks finish first)."""
        if not self._ok:
            raise RuntimeError("Context.shutdown() called twice; use try_shutdown()")
        self.try_shutdown()

    def try_shutdown(self) -> None:
        if not self._ok:
            return
        self._ok = False
        for ex in list(self._executors):
            ex._wake()
        for cb in self._on_shutdown:
            cb()

    def on_shutdown(self, callback) -> None:
        self._on_shutdown.append(callback)

    def now(self) -> float:
        """Current ROS time of this context in seconds (simulated or system)."""
        import time

        return self.sim.ns / S_TO_NS if self.sim is not None else time.time()

    def create_node(self, node_name: str, **kwargs):
        from robocourse.bus.node import Node

        return Node(node_name, context=self, **kwargs)

    # ----------------------------------------------------------------- graph changes
    def _changed(self):
        self.graph_version += 1
        if self._batching:
            self._batched = True
            return
        for cb in list(self._graph_listeners):
            cb()

    @contextlib.contextmanager
    def _graph_batch(self):
        """Tell graph listeners (the zenoh transport's sync) once, after a node made its
        built-in publishers and services, instead of once per entity."""
        with self._lock:
            self._batching += 1
        try:
            yield
        finally:
            with self._lock:
                self._batching -= 1
                fire = not self._batching and self._batched
                if fire:
                    self._batched = False
            if fire:
                for cb in list(self._graph_listeners):
                    cb()

    def add_graph_listener(self, callback) -> None:
        self._graph_listeners.append(callback)

    def remove_graph_listener(self, callback) -> None:
        if callback in self._graph_listeners:
            self._graph_listeners.remove(callback)

    def _topic_for(self, name, msg_type, what, node):
        t = self._topics.get(name)
        if t is None or (not t.pubs and not t.subs):
            t = _Topic(name, msg_type)
            self._topics[name] = t
            return t
        if t.msg_type is not msg_type:
            other = (t.pubs or t.subs)[0]
            raise TypeError(
                f"topic {name!r} carries {t.msg_type._type} (e.g. {type(other).__name__.lower()} "
                f"of node {other._node.get_fully_qualified_name()!r}); node "
                f"{node.get_fully_qualified_name()!r} asked for a {what} of {msg_type._type}. "
                f"One topic has one type in robocourse (ROS would silently never match them): "
                f"use the same type or another topic name")
        return t

    def _add_publisher(self, pub):
        with self._lock:
            t = self._topic_for(pub.topic_name, pub.msg_type, "publisher", pub._node)
            t.pubs.append(pub)
            for sub in t.subs:
                self._match(pub, sub)
        self._changed()

    def _add_subscription(self, sub):
        with self._lock:
            t = self._topic_for(sub.topic_name, sub.msg_type, "subscription", sub._node)
            t.subs.append(sub)
            for pub in t.pubs:
                self._match(pub, sub)
        self._changed()

    def _match(self, pub, sub):
        res = qos_check_compatible(pub.qos_profile, sub.qos_profile)
        if res.compatibility == QoSCompatibility.ERROR:
            self.incompatibilities.append(
                Incompatibility(pub.topic_name, pub, sub, res.policy, res.reason))
            self._incompatible(pub, sub, res.policy)
            return
        pub._subs.append(sub)
        sub._pubs.append(pub)
        if sub._deadline is not None:
            sub._deadline.start(pub)
        self._rewire(pub)
        pc, sc = pub.counts, sub.counts
        pc.matched_total += 1
        pc.matched_current += 1
        sc.matched_total += 1
        sc.matched_current += 1
        _emit(pub, "matched", QoSPublisherMatchedInfo(pc.matched_total, 1, pc.matched_current, 1))
        _emit(sub, "matched", QoSSubscriptionMatchedInfo(sc.matched_total, 1, sc.matched_current, 1))
        if pub.qos_profile.liveliness != LivelinessPolicy.MANUAL_BY_TOPIC or pub._alive:
            alive = sum(1 for p in sub._pubs if p._alive)
            sc.liveliness_changes += 1
            _emit(sub, "liveliness", QoSLivelinessChangedInfo(alive, len(sub._pubs) - alive, 1, 0))
        if pub._history is not None and sub.qos_profile.durability in (
                DurabilityPolicy.TRANSIENT_LOCAL, DurabilityPolicy.BEST_AVAILABLE):
            pub._replay_history(pub._pairs[sub])

    def _rewire(self, pub) -> None:
        """Rebuild ``pub._deliver``: one delivery per matched subscription, through the
        subscription's deadline watch and the modelled link of the pair when there is one."""
        old_links, links, pairs = pub._links, {}, {}
        for sub in pub._subs:
            deliver = sub._deliver
            if sub._deadline is not None:
                deliver = sub._deadline.wrap(pub, deliver)
            link = next((k for k in reversed(self.links) if k.applies(pub, sub)), None)
            if link is not None:
                ld = old_links.pop(sub, None)
                if ld is not None and ld.link is link:
                    ld.inner = deliver
                else:
                    if ld is not None:
                        ld.close()
                    ld = LinkDelivery(pub, sub, link, deliver)
                links[sub] = ld
                deliver = ld
            pairs[sub] = deliver
        for ld in old_links.values():
            ld.close()
        pub._links = links
        pub._pairs = pairs
        pub._deliver = tuple(pairs.values())

    # ----------------------------------------------------------------- modelled links
    def set_link(self, *, topic: str | None = None, publisher_node: str | None = None,
                 subscription_node: str | None = None, loss: float = 0.0, delay: float = 0.0,
                 jitter: float = 0.0, retransmit_delay: float | None = None,
                 seed: int = 0) -> Link:
        """Model a lossy/slow network on a topic or between two nodes (seeded).

        ``ctx.set_link(topic="/chatter", loss=0.2, delay=0.005, seed=1)``: BEST_EFFORT pairs
        lose 20 % of samples (``message_lost`` events), RELIABLE pairs resend them after
        ``retransmit_delay`` (default 2 x delay, at least 1 ms) and deliver in order. Names
        are fully qualified (``'/chatter'``, ``'/talker'``); ``None`` matches any. The last
        link set that applies to a pair wins. Returns the :class:`Link` (its counters).
        See :mod:`robocourse.bus.transport`.
        """
        link = Link(topic=topic, publisher_node=publisher_node,
                    subscription_node=subscription_node, loss=loss, delay=delay, jitter=jitter,
                    retransmit_delay=retransmit_delay, seed=seed)
        with self._lock:
            self.links.append(link)
            self._rewire_all()
        return link

    def remove_link(self, link: Link) -> None:
        """Take a modelled link away (samples still in flight on it are dropped)."""
        if link not in self.links:
            raise ValueError(f"{link!r} is not a link of this context (ctx.links lists them)")
        with self._lock:
            self.links.remove(link)
            self._rewire_all()

    def _rewire_all(self) -> None:
        for t in self._topics.values():
            for pub in t.pubs:
                self._rewire(pub)

    def _incompatible(self, pub, sub, policy):
        pc, sc = pub.counts, sub.counts
        pc.incompatible_qos += 1
        pc.last_policy = policy
        sc.incompatible_qos += 1
        sc.last_policy = policy
        name = f"{policy.name}_QOS_POLICY"
        if not _emit(sub, "incompatible_qos",
                     QoSRequestedIncompatibleQoSInfo(sc.incompatible_qos, 1, policy)):
            sub._node.get_logger().warning(
                f"New publisher discovered on topic '{sub.topic_name}', offering incompatible "
                f"QoS. No messages will be received from it. Last incompatible policy: {name}")
        if not _emit(pub, "incompatible_qos",
                     QoSOfferedIncompatibleQoSInfo(pc.incompatible_qos, 1, policy)):
            pub._node.get_logger().warning(
                f"New subscription discovered on topic '{pub.topic_name}', requesting "
                f"incompatible QoS. No messages will be sent to it. Last incompatible policy: "
                f"{name}")

    def _remove_publisher(self, pub):
        with self._lock:
            t = self._topics.get(pub.topic_name)
            if t is not None and pub in t.pubs:
                t.pubs.remove(pub)
            for sub in list(pub._subs):
                self._unmatch(pub, sub)
            self.incompatibilities = [i for i in self.incompatibilities if i.publisher is not pub]
        self._changed()

    def _remove_subscription(self, sub):
        with self._lock:
            t = self._topics.get(sub.topic_name)
            if t is not None and sub in t.subs:
                t.subs.remove(sub)
            for pub in list(sub._pubs):
                self._unmatch(pub, sub)
            self.incompatibilities = [i for i in self.incompatibilities if i.subscription is not sub]
        self._changed()

    def _unmatch(self, pub, sub):
        if sub in pub._subs:
            pub._subs.remove(sub)
            self._rewire(pub)
        if pub in sub._pubs:
            sub._pubs.remove(pub)
        if sub._deadline is not None:
            sub._deadline.stop(pub)
        pc, sc = pub.counts, sub.counts
        pc.matched_current -= 1
        sc.matched_current -= 1
        _emit(pub, "matched", QoSPublisherMatchedInfo(pc.matched_total, 0, pc.matched_current, -1))
        _emit(sub, "matched", QoSSubscriptionMatchedInfo(sc.matched_total, 0, sc.matched_current, -1))
        alive = sum(1 for p in sub._pubs if p._alive)
        sc.liveliness_changes += 1
        _emit(sub, "liveliness", QoSLivelinessChangedInfo(
            alive, len(sub._pubs) - alive, -1 if pub._alive else 0, 0 if pub._alive else -1))

    # services
    def _service_entry(self, name, srv_type, node, what):
        e = self._services.get(name)
        if e is None or (not e.servers and not e.clients):
            e = _ServiceEntry(name, srv_type)
            self._services[name] = e
        elif e.srv_type is not srv_type:
            raise TypeError(
                f"service {name!r} has type {e.srv_type._type}; node "
                f"{node.get_fully_qualified_name()!r} asked for a {what} of {srv_type._type}")
        return e

    def _add_service(self, srv):
        with self._lock:
            e = self._service_entry(srv.srv_name, srv.srv_type, srv._node, "service server")
            if e.servers and not srv._builtin:   # duplicate node names: the node warned already
                srv._node.get_logger().warning(
                    f"service {srv.srv_name!r} already has a server in node "
                    f"{e.servers[0]._node.get_fully_qualified_name()!r}; requests go to the "
                    f"first server (ROS leaves this undefined)")
            e.servers.append(srv)
        self._changed()

    def _add_client(self, cli):
        with self._lock:
            e = self._service_entry(cli.srv_name, cli.srv_type, cli._node, "client")
            e.clients.append(cli)
        self._changed()

    def _remove_service(self, srv):
        with self._lock:
            e = self._services.get(srv.srv_name)
            if e is not None and srv in e.servers:
                e.servers.remove(srv)
        self._changed()

    def _remove_client(self, cli):
        with self._lock:
            e = self._services.get(cli.srv_name)
            if e is not None and cli in e.clients:
                e.clients.remove(cli)
        self._changed()

    def _server_for(self, name):
        e = self._services.get(name)
        if e is None or not e.servers:
            return None
        return e.servers[0]


def _emit(entity, kind, info) -> bool:
    """Run the entity's event callback of ``kind`` on its executor; False if none is set."""
    cbs = entity.event_callbacks
    cb = getattr(cbs, kind, None) if cbs is not None else None
    if cb is None:
        return False
    entity._node.create_task(cb, info)
    return True


_default_context: Context | None = None


def init(*, context: Context | None = None, use_sim_time: bool = False, args=None) -> Context:
    """rclpy.init(): create (or install) the default context."""
    global _default_context
    if context is not None:
        _default_context = context
    elif _default_context is None or not _default_context.ok():
        _default_context = Context(use_sim_time=use_sim_time)
    else:
        raise RuntimeError("init() called twice without shutdown(); call shutdown() first")
    return _default_context


def get_default_context(create: bool = True) -> Context | None:
    if _default_context is None and create:
        raise RuntimeError(
            "no context: call robocourse.bus.init() first (like rclpy.init()), or pass "
            "context=Context(...) to Node")
    return _default_context


def shutdown(*, context: Context | None = None) -> None:
    """rclpy.shutdown()."""
    global _default_context
    ctx = context or _default_context
    if ctx is None:
        raise RuntimeError("shutdown() without init()")
    ctx.shutdown()
    if ctx is _default_context:
        _default_context = None


def ok(*, context: Context | None = None) -> bool:
    ctx = context or _default_context
    return ctx is not None and ctx.ok()
