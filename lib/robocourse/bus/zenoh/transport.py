"""ZenohTransport: a Context's graph reaching other processes and machines, as rmw_zenoh does.

``Context(transport="zenoh", domain_id=0, connect=["tcp/127.0.0.1:7447"])`` opens one zenoh
session (peer mode, multicast scouting off, listening on loopback, connecting to a router:
rmw_zenoh's defaults, ``DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5``). Start the router with
``robocourse zenoh router`` (rmw_zenoh: ``ros2 run rmw_zenoh_cpp rmw_zenohd``).

Two machines, one option: on machine A run ``robocourse zenoh router --listen
tcp/0.0.0.0:7447`` (rmw_zenohd listens on ``tcp/[::]:7447`` by default); on machine B the one
option is ``connect=["tcp/<A's address>:7447"]``. A connect endpoint that is not loopback makes
the context listen on every interface (``tcp/0.0.0.0:0`` instead of ``tcp/127.0.0.1:0``), so
peers the router introduces can open a direct link to it, as rmw_zenoh peers do. Nodes on A
itself keep the loopback default; what B cannot reach directly, the router forwards (zenoh's
peer failover brokering). ``listen=[...]`` still overrides the default either way.

What goes on the wire is exactly rmw_zenoh's (see :mod:`robocourse.bus.zenoh.wire`): every
publisher puts CDR on ``<domain>/<topic>/<dds type>/RIHS01_<hash>`` with the 33-byte
attachment; every node and endpoint declares its liveliness token; services are complete
queryables answered with the request's sequence number and client GID. In-process peers keep
the in-process fast path (the zenoh subscriber only takes samples from other sessions).

Counterparts and differences:
- Samples or queries without a valid attachment are dropped and counted
  (``transport.dropped_no_attachment``), as rmw_zenoh's subscriptions drop them.
- A payload that is not the expected type in CDR (truncated, another definition, a broken
  bound) is dropped and counted (``transport.dropped_undecodable``) with one warning per
  endpoint, as rmw_zenoh logs a failed deserialization; a request gets an error reply, a
  response fails the client's future with the reason.
- A remote endpoint on one of our names with another type or type hash never communicates
  (the key differs, as in rmw_zenoh); unlike rmw_zenoh we log a warning saying why and keep
  it in ``transport.mismatches``.
- QoS (:func:`zenoh_qos`): RELIABLE/BEST_EFFORT map to zenoh reliability, RELIABLE+KEEP_ALL
  to congestion control BLOCK (otherwise DROP); TRANSIENT_LOCAL uses zenoh-ext's advanced
  publisher (a cache of ``depth`` samples, publisher detection) and advanced subscriber
  (history for late joiners), and RELIABLE+TRANSIENT_LOCAL adds sample-miss detection (a
  sporadic heartbeat every 0.5 s on the publisher, recovery by heartbeat on the subscriber),
  as rmw_zenoh. QoS compatibility is not negotiated across the wire (zenoh has no
  such check; rmw_zenoh neither).
- Actions are their three services and two topics (``<action>/_action/send_goal``,
  ``cancel_goal``, ``get_result``, ``feedback``, ``status``) with the action's own wire types
  (``<pkg>::action::dds_::<Action>_SendGoal_`` ...), exactly as rmw_zenoh: nothing
  action-specific on the wire. ``get_result`` queries never time out (rmw_zenoh: UINT64_MAX).
- A request whose query ends without a reply (the server's process died mid-request, or the
  600 s ``queries_default_timeout`` passed) fails its future with ``ServerGoneError``; rclpy's
  future would stay pending forever.
- Discovery trickles in after the session opens: ``transport.settle()`` waits for it to go
  quiet (the CLI does; ``ros2`` keeps a daemon for the same reason).
- Time: across processes the attachment's source timestamp is wall time (ns since 1970),
  whatever the context's clock; simulated time stays in-process. A
  ``Context(use_sim_time=True, transport="zenoh")`` logs one warning saying so (rclpy has no
  such warning: /clock is an ordinary topic there; here it is not carried).
- Remote endpoints appear in the introspection calls (``node_list``, ``topic_list``,
  ``topic_info``, ``service_list``) but not in ``get_subscription_count`` (local only).
"""

from __future__ import annotations

import ipaddress
import itertools
import threading
import time
from dataclasses import dataclass

from robocourse.bus.zenoh import wire

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
#: what a peer listens on: loopback by default (rmw_zenoh: ``tcp/localhost:0``), every
#: interface once it connects to another machine
LISTEN_LOOPBACK, LISTEN_ALL = "tcp/127.0.0.1:0", "tcp/0.0.0.0:0"
#: rmw_zenoh's sporadic sample-miss-detection heartbeat for RELIABLE + TRANSIENT_LOCAL
#: publishers (rmw_publisher_data.cpp), seconds
HEARTBEAT_PERIOD = 0.5
#: rmw_zenoh's ``queries_default_timeout`` (DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5), seconds
QUERY_TIMEOUT = 600.0
#: rmw_zenoh waits forever (UINT64_MAX ms) for ``**/_action/get_result/**``; a year will do
GET_RESULT_TIMEOUT = 365 * 24 * 3600.0


def _config(mode, connect, listen, timeout):
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("mode", f'"{mode}"')
    conf.insert_json5("connect/endpoints", _json_list(connect))
    conf.insert_json5("listen/endpoints", _json_list(listen))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("timestamping/enabled", "true")   # as rmw_zenoh (advanced pub/sub needs it)
    if connect and mode != "router":
        conf.insert_json5("connect/exit_on_failure", "true")
        conf.insert_json5("connect/timeout_ms", str(int(timeout * 1000)))
    return conf


def _json_list(items):
    return "[" + ", ".join(f'"{e}"' for e in items) + "]"


def _endpoints(name, value):
    if value is None:
        return None
    if isinstance(value, str) or not all(isinstance(e, str) and "/" in e for e in value):
        raise ValueError(f"{name}={value!r} must be a list of zenoh locators such as "
                         f"['tcp/127.0.0.1:7447']")
    return list(value)


def is_loopback(endpoint: str) -> bool:
    """True when a zenoh locator (``tcp/127.0.0.1:7447``, ``tcp/localhost:7447``,
    ``tcp/[::1]:7447``) names this machine's loopback interface."""
    addr = endpoint.split("/", 1)[1].split("#", 1)[0]
    host = addr.rsplit(":", 1)[0] if ":" in addr else addr
    host = host.strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False            # a host name: another machine as far as we can tell


def default_listen(mode: str, connect) -> list[str]:
    """The listen endpoints a context gets when ``listen`` is not given: none for a client,
    loopback for a peer that only connects to this machine, every interface for a peer that
    connects to another machine (so peers there can reach it directly)."""
    if mode != "peer":
        return []
    return [LISTEN_ALL] if any(not is_loopback(e) for e in connect) else [LISTEN_LOOPBACK]


@dataclass(frozen=True)
class ZenohQoS:
    """What one endpoint's QoS becomes on zenoh (rmw_zenoh's ``rmw_publisher_data.cpp`` and
    ``rmw_subscription_data.cpp``).

    ``reliable``: zenoh reliability RELIABLE (else BEST_EFFORT). ``block``: congestion control
    BLOCK (else DROP). ``history``: TRANSIENT_LOCAL depth (advanced publisher cache, advanced
    subscriber history with late-publisher detection), None when VOLATILE. ``heartbeat``:
    the publisher's sporadic sample-miss-detection period in seconds, None when off.
    ``recovery``: the subscriber's recovery by heartbeat."""

    reliable: bool
    block: bool
    history: int | None
    heartbeat: float | None
    recovery: bool


def zenoh_qos(qos) -> ZenohQoS:
    """rmw_zenoh's mapping: RELIABLE -> reliable; RELIABLE + KEEP_ALL -> BLOCK, otherwise
    DROP; TRANSIENT_LOCAL -> a ``depth`` cache / history (KEEP_LAST depth 0: rmw_zenoh's default
    depth 42; KEEP_ALL depth 0 keeps 1); RELIABLE +
    TRANSIENT_LOCAL -> sporadic heartbeat every :data:`HEARTBEAT_PERIOD` s on the publisher
    and recovery with heartbeat on the subscriber."""
    from robocourse.bus.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        ReliabilityPolicy,
        effective_depth,
    )

    reliable = qos.reliability != ReliabilityPolicy.BEST_EFFORT
    latched = qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
    return ZenohQoS(reliable=reliable, block=reliable and qos.history == HistoryPolicy.KEEP_ALL,
                    history=(qos.depth or (effective_depth(qos) or 1)) if latched else None,
                    heartbeat=HEARTBEAT_PERIOD if latched and reliable else None,
                    recovery=latched and reliable)


def router(listen=(DEFAULT_ROUTER,)):
    """Open a zenoh router session (what ``rmw_zenohd`` is): peers connect to it, learn about
    each other by gossip and then talk directly. Keep the returned session open; close() it."""
    import zenoh

    listen = _endpoints("listen", listen)
    try:
        return zenoh.open(_config("router", [], listen, 0))
    except zenoh.ZError as exc:
        raise OSError(f"cannot start a zenoh router listening on {listen}: {exc}. Another router "
                      f"probably holds the port; use it, or pick another port "
                      f"(listen=['tcp/127.0.0.1:7448'])") from None


class _Local:
    """One of our entities on the wire: its token, GID and zenoh objects."""

    __slots__ = ("token_key", "token", "gid", "zobj", "seq", "key", "kind", "name", "t")

    def __init__(self, token_key, token, key=None, zobj=None):
        self.token_key = token_key
        self.token = token
        self.gid = wire.gid_of(token_key)
        self.key = key
        self.zobj = zobj
        self.seq = itertools.count(1)
        self.kind = self.name = self.t = None


class ZenohTransport:
    """The zenoh side of one Context (``ctx.transport``); made by ``Context(transport="zenoh")``."""

    def __init__(self, ctx, *, domain_id: int = 0, connect=None, listen=None,
                 mode: str = "peer", connect_timeout: float = 2.0):
        import zenoh

        if isinstance(domain_id, bool) or not isinstance(domain_id, int) or domain_id < 0:
            raise ValueError(f"domain_id={domain_id!r} must be an int >= 0 (ROS_DOMAIN_ID, "
                             f"0 by default)")
        if mode not in ("peer", "client"):
            raise ValueError(f"mode={mode!r} must be 'peer' (rmw_zenoh's default) or 'client'")
        connect = _endpoints("connect", connect) if connect is not None else [DEFAULT_ROUTER]
        listen = _endpoints("listen", listen) if listen is not None else \
            default_listen(mode, connect)
        self.ctx = ctx
        self.domain_id = domain_id
        self.connect = connect
        self.listen = listen
        try:
            self.session = zenoh.open(_config(mode, connect, listen, connect_timeout))
        except zenoh.ZError as exc:
            raise ConnectionError(
                f"no zenoh router reachable at {connect} ({exc}). Fix: start one in another "
                f"terminal with 'robocourse zenoh router' (on a ROS 2 machine: 'ros2 run "
                f"rmw_zenoh_cpp rmw_zenohd'), or pass connect=['tcp/<host>:<port>'] where one "
                f"listens") from None
        self.zid = str(self.session.zid())
        self._zenoh = zenoh
        self._ids = itertools.count()
        self._lock = threading.RLock()
        self._nodes = {}                # node -> _Local (NN token)
        self._local = {}                # entity -> _Local
        self.remote: dict[str, wire.Entity] = {}
        self.dropped_no_attachment = 0
        self.dropped_undecodable = 0
        self.malformed_tokens: list[tuple[str, str]] = []
        self.mismatches: list[str] = []
        self._closed = False
        self._last_token = time.monotonic()
        self._graph_sub = self.session.liveliness().declare_subscriber(
            f"{wire.ADMIN_SPACE}/{domain_id}/**", self._on_token, history=True)
        # as rmw_zenoh at init: one liveliness query so the graph is complete on return (the
        # subscriber's history arrives asynchronously; `robocourse topic list` cannot wait)
        for reply in self.session.liveliness().get(f"{wire.ADMIN_SPACE}/{domain_id}/**",
                                                   timeout=max(connect_timeout, 1.0)):
            if reply.ok is not None:
                self._on_token(reply.ok)
        ctx.add_graph_listener(self.sync)
        ctx.on_shutdown(self.close)
        if ctx.use_sim_time:
            from robocourse.bus.logging import RcutilsLogger

            RcutilsLogger("zenoh_transport", ctx).warning(
                "use_sim_time=True with transport='zenoh': simulated time stays in this "
                "process. Nodes in other processes keep their own clocks, and every sample's "
                "attachment carries wall time (ns since 1970), not this context's simulated "
                "time. Fix: drive both sides from wall time (Context(transport='zenoh') "
                "without use_sim_time) when they must agree on time, or keep a simulated graph "
                "in one process")
        self.sync()

    # ------------------------------------------------------------------ our entities
    def sync(self) -> None:
        """Declare tokens (and zenoh entities) for what the context gained, undeclare what it
        lost. Runs on every graph change of the context."""
        if self._closed:
            return
        with self._lock:
            nodes = list(self.ctx.nodes)
            for node in nodes:
                if node not in self._nodes:
                    nid = next(self._ids)
                    key = wire.node_token(self.domain_id, self.zid, nid, node.get_namespace(),
                                          node.get_name())
                    self._nodes[node] = _Local(key, self._declare_token(key))
                    self._nodes[node].key = nid
            alive = set()
            for ent, kind in self._context_entities():
                alive.add(ent)
                if ent not in self._local and ent._node in self._nodes:
                    self._add(ent._node, self._nodes[ent._node].key, ent, kind)
            for ent in [e for e in self._local if e not in alive]:
                self._drop(self._local.pop(ent))
                if hasattr(ent, "_remote"):
                    ent._remote = None
            for node in [n for n in self._nodes if n not in nodes]:
                self._drop(self._nodes.pop(node))

    def _context_entities(self):
        ctx = self.ctx
        with ctx._lock:
            for t in ctx._topics.values():
                yield from ((p, "MP") for p in t.pubs)
                yield from ((s, "MS") for s in t.subs)
            for e in ctx._services.values():
                yield from ((s, "SS") for s in e.servers)
                yield from ((c, "SC") for c in e.clients)

    def _declare_token(self, key):
        return self.session.liveliness().declare_token(key)

    def _add(self, node, nid, ent, kind):
        t = ent.msg_type if kind in ("MP", "MS") else ent.srv_type
        name = ent.topic_name if kind in ("MP", "MS") else ent.srv_name
        tok = wire.endpoint_token(self.domain_id, self.zid, nid, next(self._ids), kind,
                                  node.get_namespace(), node.get_name(), name, t, ent.qos_profile)
        key = wire.data_key(self.domain_id, name, t)
        loc = _Local(tok, None, key)
        loc.kind, loc.name, loc.t = kind, name, t
        self._local[ent] = loc
        if kind == "MP":
            loc.zobj = self._declare_publisher(key, ent.qos_profile)
            ent._remote = self._sender(loc)
        elif kind == "MS":
            loc.zobj = self._declare_subscriber(key, ent)
        elif kind == "SS":
            loc.zobj = self.session.declare_queryable(key, self._on_query(ent, key),
                                                      complete=True)
        loc.token = self._declare_token(tok)
        for r in list(self.remote.values()):
            self._check_mismatch(r, ent, kind, name, t)

    def _drop(self, loc):
        for obj in (loc.zobj, loc.token):
            if obj is not None:
                try:
                    obj.undeclare()
                except Exception:  # noqa: BLE001 - session already closed
                    pass

    def _declare_publisher(self, key, qos):
        z, q = self._zenoh, zenoh_qos(qos)
        cc = z.CongestionControl.BLOCK if q.block else z.CongestionControl.DROP
        rel = z.Reliability.RELIABLE if q.reliable else z.Reliability.BEST_EFFORT
        if q.history is not None:
            from zenoh import ext

            miss = None if q.heartbeat is None else \
                ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=q.heartbeat)
            return ext.declare_advanced_publisher(
                self.session, key, congestion_control=cc, reliability=rel,
                allowed_destination=z.Locality.REMOTE, cache=ext.CacheConfig(q.history),
                sample_miss_detection=miss, publisher_detection=True)
        return self.session.declare_publisher(key, congestion_control=cc, reliability=rel,
                                              allowed_destination=z.Locality.REMOTE)

    def _sender(self, loc):
        """The publisher's remote delivery (``Publisher._remote``, given the published message
        itself): encoder, attachment packer, sequence counter and ``put`` bound once, so a
        publish does no lookups."""
        put, seq, encode = loc.zobj.put, loc.seq, wire.encoder(loc.t, buffer=True)
        pack, now, gid, n = wire.ATTACHMENT.pack, time.time_ns, loc.gid, wire.GID_SIZE

        def send(msg):
            put(encode(msg), attachment=pack(next(seq), now(), n, gid))
        return send

    def _declare_subscriber(self, key, sub):
        z, q = self._zenoh, zenoh_qos(sub.qos_profile)
        on_sample = self._on_sample(sub)
        if q.history is not None:
            from zenoh import ext

            recovery = ext.RecoveryConfig(periodic_queries=None, heartbeat=True) \
                if q.recovery else None
            return ext.declare_advanced_subscriber(
                self.session, key, on_sample, allowed_origin=z.Locality.REMOTE,
                history=ext.HistoryConfig(detect_late_publishers=True, max_samples=q.history),
                recovery=recovery, subscriber_detection=True)
        return self.session.declare_subscriber(key, on_sample, allowed_origin=z.Locality.REMOTE)

    def _dropped(self, what, where, node):
        self.dropped_no_attachment += 1
        if self.dropped_no_attachment == 1:
            node.get_logger().warning(
                f"{what} on '{where}' without rmw_zenoh's 33-byte attachment dropped (as "
                f"rmw_zenoh does); the sender must attach sequence number, timestamp and GID. "
                f"transport.dropped_no_attachment counts them")

    def _on_sample(self, sub):
        """The zenoh callback (a zenoh thread): validate the attachment, decode, queue for
        the executor. Decoder and checks are bound once per subscription. A payload that does
        not decode is dropped, counted in ``transport.dropped_undecodable`` and logged once per
        subscription (rmw_zenoh logs a failed deserialization and takes nothing)."""
        decode, node, size, gid = wire.decoder(sub.msg_type), sub._node, \
            wire.ATTACHMENT_SIZE, wire.GID_SIZE
        CdrError = wire.CdrError
        warned = []

        def on_sample(sample):
            att = sample.attachment
            if att is not None:
                att = att.to_bytes()
            if att is None or len(att) != size or att[16] != gid:
                self._dropped("sample", sub.topic_name, node)
                return
            try:
                msg = decode(sample.payload.to_bytes())
            except CdrError as exc:
                self._undecodable(node, f"sample on '{sub.topic_name}' dropped", exc, warned)
                return
            if not sub._destroyed:
                sub._deliver(msg)
        return on_sample

    def _undecodable(self, node, what, exc, warned):
        """Count a payload that does not decode; warn once per endpoint (``warned``)."""
        self.dropped_undecodable += 1
        if not warned:
            warned.append(True)
            node.get_logger().warning(f"{what}: {exc}. transport.dropped_undecodable counts them")

    def _on_query(self, srv, key):
        warned = []

        def on_query(query):
            att = query.attachment
            try:
                a = wire.decode_attachment(att.to_bytes() if att is not None else b"")
            except ValueError:
                self._dropped("request", srv.srv_name, srv._node)
                return
            try:
                req = wire.from_cdr(srv.srv_type.Request, query.payload.to_bytes())
            except wire.CdrError as exc:
                self._undecodable(srv._node, f"request to service '{srv.srv_name}' refused",
                                  exc, warned)
                query.reply_err(f"request does not decode: {exc}".encode())
                query.drop()
                return
            srv._receive(req, _RemoteCaller(query, key, a), None)
        return on_query

    # ------------------------------------------------------------------ clients
    def has_server(self, name, srv_type) -> bool:
        h = wire.type_hash(srv_type)
        return any(e.kind == "SS" and e.topic == name and e.type_hash == h
                   for e in list(self.remote.values()))

    def call(self, client, request, future) -> None:
        """Send ``request`` as a zenoh query (ALL_COMPLETE, no consolidation, as rmw_zenoh's
        client); the first reply carrying our sequence number completes ``future``.

        Timeout as rmw_zenoh: ``queries_default_timeout`` (600 s) for services, none for an
        action's ``get_result`` (a goal may run for hours). If the query ends with no reply
        (the server's process died or closed before answering, or the timeout passed), the
        future gets a :class:`~robocourse.bus.service.ServerGoneError` instead of waiting
        forever: zenoh finalizes a query whose queryable disappears."""
        from robocourse.bus.service import ServerGoneError, ServiceCallbackError

        z = self._zenoh
        loc = self._local[client]
        seq = next(loc.seq)
        done = []
        long_running = "/_action/get_result" in client.srv_name
        timeout = GET_RESULT_TIMEOUT if long_running else QUERY_TIMEOUT
        started = time.monotonic()

        def on_reply(reply):
            if done:
                return
            if reply.ok is None:
                done.append(True)
                client._respond(future, None, ServiceCallbackError(
                    f"service '{client.srv_name}' replied with an error: "
                    f"{reply.err.payload.to_string()}"))
                return
            att = reply.ok.attachment
            try:
                a = wire.decode_attachment(att.to_bytes() if att is not None else b"")
            except ValueError:
                self.dropped_no_attachment += 1
                return
            if a.sequence_number != seq:
                return
            done.append(True)
            try:
                response = wire.from_cdr(client.srv_type.Response, reply.ok.payload.to_bytes())
            except wire.CdrError as exc:
                self.dropped_undecodable += 1
                client._respond(future, None, ServiceCallbackError(
                    f"the response of service '{client.srv_name}' does not decode: {exc}"))
                return
            client._respond(future, response, None)

        def on_end():
            if done or self._closed:
                return
            done.append(True)
            waited = time.monotonic() - started
            why = (f"no reply within the {timeout:.0f} s query timeout" if waited >= timeout
                   else f"its server went away after {waited:.2f} s without answering (its "
                        f"process was killed, crashed or shut down)")
            client._respond(future, None, ServerGoneError(
                f"request {seq} to service '{client.srv_name}' got no response: {why}. The "
                f"request is lost; check 'robocourse node list' and call again once "
                f"wait_for_service() is true"))

        self.session.get(loc.key, z.handlers.Callback(on_reply, on_end),
                         payload=wire.to_cdr(request),
                         attachment=wire.encode_attachment(seq, loc.gid),
                         target=z.QueryTarget.ALL_COMPLETE,
                         consolidation=z.ConsolidationMode.NONE, timeout=timeout)

    # ------------------------------------------------------------------ remote graph
    def settle(self, quiet: float = 0.3, timeout: float = 3.0) -> int:
        """Wait until no liveliness token came or went for ``quiet`` seconds (at most
        ``timeout``): discovery across processes trickles in after the session opens. The
        one-shot CLI commands call it before reading the graph (``ros2`` keeps a daemon for
        the same reason). Returns the number of remote entities known."""
        end = time.monotonic() + timeout
        while True:
            now = time.monotonic()
            if now - self._last_token >= quiet or now >= end:
                return len(self.remote)
            time.sleep(min(0.02, max(end - now, 0.0)))

    def _on_token(self, sample):
        self._last_token = time.monotonic()
        key = str(sample.key_expr)
        put = sample.kind == self._zenoh.SampleKind.PUT
        if not put:
            if self.remote.pop(key, None) is not None:
                self._graph_changed()
            return
        try:
            e = wire.parse_token(key)
        except ValueError as exc:
            self.malformed_tokens.append((key, str(exc)))
            return
        if e.zid == self.zid:
            return
        self.remote[key] = e
        if e.kind != "NN":
            with self._lock:
                for ent, loc in list(self._local.items()):
                    self._check_mismatch(e, ent, loc.kind, loc.name, loc.t)
        self._graph_changed()

    def _check_mismatch(self, e, ent, kind, name, t):
        topic_kinds = ("MP", "MS")
        if e.topic != name or (e.kind in topic_kinds) != (kind in topic_kinds):
            return
        ours = (t._type, wire.type_hash(t))
        if (e.type_name, e.type_hash) == ours:
            return
        text = (f"'{name}': {wire.KINDS[e.kind]} of remote node '{e.node_fqn}' uses "
                f"{e.type_name} {e.type_hash}, our {wire.KINDS[kind]} of node "
                f"'{ent._node.get_fully_qualified_name()}' uses {ours[0]} {ours[1]}: they will "
                f"never communicate (rmw_zenoh's keys carry the type and its hash). Use the "
                f"same message definition on both sides")
        if text not in self.mismatches:
            self.mismatches.append(text)
            ent._node.get_logger().warning(text)

    def _graph_changed(self):
        with self.ctx._lock:
            self.ctx.graph_version += 1
            listeners = [cb for cb in self.ctx._graph_listeners if cb != self.sync]
        for cb in listeners:
            cb()

    def remote_entities(self, kind=None) -> list[wire.Entity]:
        return [e for e in list(self.remote.values()) if kind is None or e.kind == kind]

    def wait_for(self, predicate, timeout: float = 5.0) -> bool:
        """Poll ``predicate(transport)`` until true or ``timeout`` seconds (discovery is
        asynchronous across processes)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate(self):
                return True
            time.sleep(0.01)
        return bool(predicate(self))

    def close(self) -> None:
        """Undeclare everything (others see DELETE at once) and close the session."""
        if self._closed:
            return
        self._closed = True
        with self._lock:
            for loc in list(self._local.values()) + list(self._nodes.values()):
                self._drop(loc)
            self._local.clear()
            self._nodes.clear()
        try:
            self.session.close()
        except Exception:  # noqa: BLE001
            pass


class _RemoteCaller:
    """Stands in for the client when a request came over zenoh: ``Service`` answers it with
    ``_respond`` and the reply carries the request's sequence number and client GID."""

    __slots__ = ("query", "key", "att")

    def __init__(self, query, key, att):
        self.query, self.key, self.att = query, key, att

    def _respond(self, future, response, error):
        q, self.query = self.query, None
        if q is None:
            return
        if error is not None:
            q.reply_err(str(error).encode())
        else:
            q.reply(self.key, wire.to_cdr(response),
                    attachment=wire.encode_attachment(self.att.sequence_number, self.att.gid))
        q.drop()
