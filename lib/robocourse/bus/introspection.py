"""The ``ros2`` command line as Python calls: each returns data and prints ROS-like text.

==========================================  ====================================================
ROS 2 command                               robocourse call
==========================================  ====================================================
``ros2 topic list -t``                      ``topic_list(ctx)``
``ros2 topic info -v /x``                   ``topic_info(ctx, "/x", verbose=True)``
``ros2 topic echo /x``                      ``topic_echo(ctx, "/x", executor, count=3)``
``ros2 topic hz /x``                        ``topic_hz(ctx, "/x", executor, duration=2.0)``
``ros2 topic bw /x``                        ``topic_bw(ctx, "/x", executor, duration=2.0)``
``ros2 topic pub --once /x T '{...}'``      ``topic_pub(ctx, "/x", T, {...})``
``ros2 node list`` / ``node info /n``        ``node_list(ctx)`` / ``node_info(ctx, "/n")``
``ros2 service list -t`` / ``call``          ``service_list(ctx)`` / ``service_call(ctx, ...)``
``ros2 action list -t`` / ``info``           ``action_list(ctx)`` / ``action_info(ctx, "/a")``
``ros2 action send_goal --feedback``         ``action_send_goal(ctx, "/a", T, {...}, executor)``
``ros2 param list`` / ``get`` / ``set``      ``param_list`` / ``param_get`` / ``param_set``
``ros2 doctor --report`` (QoS part)          ``doctor_report(ctx)``
==========================================  ====================================================

``ctx`` is a Context (or any Node, whose context is used). Calls that need messages to flow
(echo, hz, bw, service call, send_goal) add a hidden node (name starting with ``_``, hidden
from ``node_list`` like ROS hides them) to ``executor``, spin it for ``duration`` seconds of
executor time (simulated time if the context uses it) or until done, then remove it.
Pass ``quiet=True`` to get the data without printing.
"""

from __future__ import annotations

import itertools
import math
import threading
import time as _time

from robocourse.bus.qos import (
    INFINITE,
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from robocourse.msgs import from_dict, to_dict

_ids = itertools.count()
ACTION_MARK = "/_action/"


def _ctx(obj):
    return obj.context if hasattr(obj, "get_fully_qualified_name") else obj


def _out(text, quiet):
    if not quiet:
        print(text)


def _hidden(name: str) -> bool:
    return any(part.startswith("_") for part in name.split("/") if part)


def _remote(ctx, kind):
    """Endpoints other processes announced (liveliness tokens) when ctx has a zenoh transport."""
    t = ctx.transport
    return t.remote_entities(kind) if t is not None else []


def _visible_nodes(ctx, include_hidden=False):
    return [n for n in ctx.nodes if include_hidden or not n.get_name().startswith("_")]


# ----------------------------------------------------------------------------------- topics


def topic_list(ctx, *, show_types: bool = True, include_hidden: bool = False, quiet: bool = False):
    """``ros2 topic list -t``: [(name, [type])] sorted by name."""
    ctx = _ctx(ctx)
    types = {t.name: {t.msg_type._type} for t in ctx._topics.values() if t.pubs or t.subs}
    for e in _remote(ctx, "MP") + _remote(ctx, "MS"):
        types.setdefault(e.topic, set()).add(e.type_name)
    rows = sorted((n, sorted(ts)) for n, ts in types.items() if include_hidden or not _hidden(n))
    _out("\n".join(f"{n} [{', '.join(ts)}]" if show_types else n for n, ts in rows), quiet)
    return rows


def topic_info(ctx, topic: str, *, verbose: bool = False, quiet: bool = False) -> dict:
    """``ros2 topic info [-v]``: type, counts and (verbose) every endpoint with its QoS."""
    ctx = _ctx(ctx)
    t = ctx._topics.get(topic)
    pubs, subs = (t.pubs, t.subs) if t is not None else ([], [])
    rpubs = [e for e in _remote(ctx, "MP") if e.topic == topic]
    rsubs = [e for e in _remote(ctx, "MS") if e.topic == topic]
    if not (pubs or subs or rpubs or rsubs):
        text = f"Unknown topic '{topic}'"
        _out(text, quiet)
        return {"type": None, "publishers": [], "subscriptions": []}

    def ep(e, kind):
        return {"node_name": e._node.get_name(), "node_namespace": e._node.get_namespace(),
                "topic_type": e.msg_type._type, "endpoint_type": kind, "qos": e.qos_profile,
                "entity": e}

    def remote(e, kind):   # another process (zenoh liveliness token)
        return {"node_name": e.node_name, "node_namespace": e.namespace,
                "topic_type": e.type_name, "endpoint_type": kind, "qos": e.qos, "entity": e}

    info = {"type": t.msg_type._type if pubs or subs else (rpubs or rsubs)[0].type_name,
            "publishers": [ep(p, "PUBLISHER") for p in pubs]
            + [remote(e, "PUBLISHER") for e in rpubs],
            "subscriptions": [ep(s, "SUBSCRIPTION") for s in subs]
            + [remote(e, "SUBSCRIPTION") for e in rsubs]}
    lines = [f"Type: {info['type']}", ""]

    def block(items):
        for e in items:
            lines.extend([f"Node name: {e['node_name']}", f"Node namespace: {e['node_namespace']}",
                          f"Topic type: {e['topic_type']}", f"Endpoint type: {e['endpoint_type']}",
                          "QoS profile:", e["qos"].ros_text("  "), ""])

    lines.append(f"Publisher count: {len(info['publishers'])}")
    lines.append("")
    if verbose:
        block(info["publishers"])
    lines.append(f"Subscription count: {len(info['subscriptions'])}")
    if verbose:
        lines.append("")
        block(info["subscriptions"])
    _out("\n".join(lines).rstrip(), quiet)
    return info


def _adapted_qos(ctx, topic) -> QoSProfile:
    """What ros2 topic echo/rosbag2 do: match the publishers' reliability and durability."""
    t = ctx._topics.get(topic)
    qos = [p.qos_profile for p in (t.pubs if t else [])] + \
        [e.qos for e in _remote(ctx, "MP") if e.topic == topic]
    reliable = bool(qos) and all(q.reliability == ReliabilityPolicy.RELIABLE for q in qos)
    latched = bool(qos) and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in qos)
    return QoSProfile(history=HistoryPolicy.KEEP_ALL,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def _topic_type(ctx, topic):
    t = ctx._topics.get(topic)
    if t is None or not (t.pubs or t.subs):
        from robocourse.msgs import REGISTRY

        for e in _remote(ctx, "MP") + _remote(ctx, "MS"):
            if e.topic == topic and e.type_name in REGISTRY:
                return REGISTRY[e.type_name]
        raise ValueError(f"topic {topic!r} does not exist (yet); topics: "
                         f"{[n for n, _ in topic_list(ctx, quiet=True)]}")
    return t.msg_type


class _Probe:
    """A hidden node on an executor for the duration of one CLI call."""

    def __init__(self, ctx, executor, kind):
        from robocourse.bus.node import Node

        self.node = Node(f"_ros2cli_{kind}_{next(_ids)}", context=ctx)
        self.executor = executor
        executor.add_node(self.node)

    def spin(self, duration, until=None):
        ex = self.executor
        if ex.is_spinning_elsewhere():
            # one thread spins an executor (rclpy): that thread runs our node's callbacks; wait in
            # wall time (``duration`` seconds) for ``until``
            end = None if duration is None else _time.monotonic() + duration
            while (until is None or not until()) and (end is None or _time.monotonic() < end):
                _time.sleep(0.002)
            return
        if until is None:
            ex.spin_for(duration)
            return
        end = ex._now_base() + int(duration * 1e9) if duration is not None else None
        while not until():
            if end is not None and ex._now_base() >= end:
                break
            ex.spin_once(timeout_sec=None if end is None else max(0.0, (end - ex._now_base()) / 1e9))

    def close(self):
        self.executor.remove_node(self.node)
        self.node.destroy_node()


def wait_for_future(executor, future, timeout_sec):
    """``executor.spin_until_future_complete(future, timeout_sec)``, or, when another thread already
    spins ``executor`` (one spinner per executor, as in rclpy), wait for that thread to complete the
    future (``timeout_sec`` in wall time)."""
    if not executor.is_spinning_elsewhere():
        executor.spin_until_future_complete(future, timeout_sec)
        return
    done = threading.Event()

    def wake(_f):
        done.set()

    wake._immediate = True   # run in the thread that completes the future, not on an executor
    future.add_done_callback(wake)
    done.wait(timeout_sec)


def to_yaml(msg, indent: str = "") -> str:
    """A message as the YAML ``ros2 topic echo`` prints."""
    return _yaml(to_dict(msg), indent)


def _scalar(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return "''" if v == "" else (f"'{v}'" if any(c in v for c in ":#{}[],&*!|>'\"%@`") else v)
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _yaml(d, indent):
    lines = []
    for k, v in d.items():
        if isinstance(v, dict):
            lines.append(f"{indent}{k}:")
            lines.append(_yaml(v, indent + "  "))
        elif isinstance(v, list):
            if not v:
                lines.append(f"{indent}{k}: []")
                continue
            lines.append(f"{indent}{k}:")
            for item in v:
                if isinstance(item, dict):
                    sub = _yaml(item, indent + "  ").split("\n")
                    sub[0] = indent + "- " + sub[0].lstrip()
                    lines.extend(sub)
                else:
                    lines.append(f"{indent}- {_scalar(item)}")
        else:
            lines.append(f"{indent}{k}: {_scalar(v)}")
    return "\n".join(x for x in lines if x != "")


def topic_echo(ctx, topic: str, executor, *, count: int | None = None,
               duration: float | None = 1.0, quiet: bool = False) -> list:
    """``ros2 topic echo``: collect (and print as YAML, ``---`` separated) messages."""
    ctx = _ctx(ctx)
    msg_type = _topic_type(ctx, topic)
    probe = _Probe(ctx, executor, "echo")
    got = []

    def cb(m):
        if count is None or len(got) < count:
            got.append(m)
            _out(to_yaml(m) + "\n---", quiet)

    try:
        probe.node.create_subscription(msg_type, topic, cb, _adapted_qos(ctx, topic))
        probe.spin(duration, (lambda: len(got) >= count) if count is not None else None)
    finally:
        probe.close()
    return got


def _stamps(ctx, topic, executor, duration, kind, measure=None):
    msg_type = _topic_type(ctx, topic)
    probe = _Probe(ctx, executor, kind)
    clock = probe.node.get_clock()
    stamps, sizes = [], []

    def cb(m):
        stamps.append(clock._now_ns())
        if measure is not None:
            sizes.append(measure(m))

    try:
        probe.node.create_subscription(msg_type, topic, cb, _adapted_qos(ctx, topic))
        probe.spin(duration)
    finally:
        probe.close()
    return stamps, sizes


def topic_hz(ctx, topic: str, executor, *, duration: float = 1.0, quiet: bool = False) -> dict:
    """``ros2 topic hz``: average rate and min/max/std of the periods (node clock)."""
    ctx = _ctx(ctx)
    stamps, _ = _stamps(ctx, topic, executor, duration, "hz")
    if len(stamps) < 2:
        _out("no new messages", quiet)
        return {"rate": 0.0, "min": math.nan, "max": math.nan, "std_dev": math.nan,
                "window": len(stamps)}
    periods = [(b - a) / 1e9 for a, b in zip(stamps, stamps[1:])]
    mean = sum(periods) / len(periods)
    std = math.sqrt(sum((p - mean) ** 2 for p in periods) / len(periods))
    res = {"rate": 1.0 / mean if mean > 0 else math.inf, "min": min(periods), "max": max(periods),
           "std_dev": std, "window": len(stamps)}
    _out(f"average rate: {res['rate']:.3f}\n\tmin: {res['min']:.3f}s max: {res['max']:.3f}s "
         f"std dev: {res['std_dev']:.5f}s window: {res['window']}", quiet)
    return res


def serialized_size(msg) -> int:
    """Bytes of ``msg`` as CDR (what the message costs on a real ROS 2 wire)."""
    from robocourse.bus.recording import _encoder

    return len(_encoder(type(msg))(msg))


def _fmt_bytes(n: float) -> str:
    for unit, scale in (("MB", 1e6), ("KB", 1e3)):
        if n >= scale:
            return f"{n / scale:.2f} {unit}"
    return f"{n:.0f} B"


def topic_bw(ctx, topic: str, executor, *, duration: float = 1.0, quiet: bool = False) -> dict:
    """``ros2 topic bw``: bytes per second of CDR-serialized messages."""
    ctx = _ctx(ctx)
    stamps, sizes = _stamps(ctx, topic, executor, duration, "bw", serialized_size)
    if len(stamps) < 2:
        _out("no new messages", quiet)
        return {"bytes_per_sec": 0.0, "count": len(stamps), "mean": math.nan, "min": 0, "max": 0}
    span = (stamps[-1] - stamps[0]) / 1e9
    bw = sum(sizes[1:]) / span if span > 0 else math.inf
    res = {"bytes_per_sec": bw, "count": len(sizes), "mean": sum(sizes) / len(sizes),
           "min": min(sizes), "max": max(sizes)}
    _out(f"{_fmt_bytes(bw)}/s from {len(sizes)} messages\n\tMessage size mean: "
         f"{_fmt_bytes(res['mean'])} min: {_fmt_bytes(res['min'])} max: {_fmt_bytes(res['max'])}", quiet)
    return res


def topic_pub(ctx, topic: str, msg_type, values: dict | None = None, *, qos=10,
              quiet: bool = False):
    """``ros2 topic pub --once``: publish one message built from ``values`` (a dict)."""
    from robocourse.bus.node import Node

    ctx = _ctx(ctx)
    node = Node(f"_ros2cli_pub_{next(_ids)}", context=ctx)
    try:
        msg = from_dict(msg_type, values or {})
        pub = node.create_publisher(msg_type, topic, qos)
        _out(f"publisher: beginning loop\npublishing #1: {msg!r}\n", quiet)
        pub.publish(msg)
    finally:
        node.destroy_node()
    return msg


# ----------------------------------------------------------------------------------- nodes


def node_list(ctx, *, include_hidden: bool = False, quiet: bool = False) -> list[str]:
    """``ros2 node list`` (sorted fully qualified names; warns about duplicates like ROS)."""
    ctx = _ctx(ctx)
    names = sorted([n.get_fully_qualified_name() for n in _visible_nodes(ctx, include_hidden)]
                   + [e.node_fqn for e in _remote(ctx, "NN")
                      if include_hidden or not e.node_name.startswith("_")])
    text = "\n".join(names)
    if len(set(names)) != len(names):
        text = ("WARNING: Be aware that there are nodes in the graph that share an exact name, "
                "which can have unintended side effects.\n" + text)
    _out(text, quiet)
    return names


def _find_node(ctx, name):
    for n in ctx.nodes:
        if name in (n.get_fully_qualified_name(), n.get_name()):
            return n
    raise ValueError(f"Unable to find node '{name}'; nodes: {node_list(ctx, quiet=True)}")


def node_info(ctx, node_name: str, *, quiet: bool = False) -> dict:
    """``ros2 node info``: subscribers, publishers, services, clients, actions (name: type)."""
    ctx = _ctx(ctx)
    from robocourse.bus.action import ActionClient, ActionServer

    node = _find_node(ctx, node_name)
    info = {
        "Subscribers": sorted({(s.topic_name, s.msg_type._type) for s in node.subscriptions
                               if ACTION_MARK not in s.topic_name}),
        "Publishers": sorted({(p.topic_name, p.msg_type._type) for p in
                              node.publishers + ([node._rosout_publisher]
                                                 if node._rosout_publisher is not None else [])
                              if ACTION_MARK not in p.topic_name}),
        "Service Servers": sorted({(s.srv_name, s.srv_type._type) for s in node.services
                                   if ACTION_MARK not in s.srv_name}),
        "Service Clients": sorted({(c.srv_name, c.srv_type._type) for c in node.clients
                                   if ACTION_MARK not in c.srv_name}),
        "Action Servers": sorted({(w.action_name, w.action_type._type) for w in node.waitables
                                  if isinstance(w, ActionServer)}),
        "Action Clients": sorted({(w.action_name, w._action_type._type) for w in node.waitables
                                  if isinstance(w, ActionClient)}),
    }
    lines = [node.get_fully_qualified_name()]
    for k, rows in info.items():
        lines.append(f"  {k}:")
        lines.extend(f"    {n}: {t}" for n, t in rows)
    _out("\n".join(lines), quiet)
    return info


# ----------------------------------------------------------------------------------- services


def service_list(ctx, *, show_types: bool = True, include_hidden: bool = False,
                 quiet: bool = False):
    """``ros2 service list -t`` (action internals hidden, as ROS does)."""
    ctx = _ctx(ctx)
    types = {s.name: {s.srv_type._type} for s in ctx._services.values() if s.servers}
    for e in _remote(ctx, "SS"):
        types.setdefault(e.topic, set()).add(e.type_name)
    rows = sorted((n, sorted(ts)) for n, ts in types.items() if include_hidden or not _hidden(n))
    _out("\n".join(f"{n} [{', '.join(t)}]" if show_types else n for n, t in rows), quiet)
    return rows


def service_call(ctx, service: str, srv_type, values: dict | None, executor, *,
                 timeout: float = 10.0, quiet: bool = False):
    """``ros2 service call``: send one request, spin until the response, print both."""
    ctx = _ctx(ctx)
    probe = _Probe(ctx, executor, "call")
    try:
        cli = probe.node.create_client(srv_type, service)
        if not cli.service_is_ready():
            _out(f"waiting for service to become available...\nservice {service!r} not available", quiet)
            return None
        req = from_dict(srv_type.Request, values or {})
        _out(f"requester: making request: {req!r}\n", quiet)
        fut = cli.call_async(req)
        wait_for_future(executor, fut, timeout)
        if not fut.done():
            _out("timed out waiting for the response", quiet)
            return None
        resp = fut.result()
        _out(f"response:\n{resp!r}\n", quiet)
        return resp
    finally:
        probe.close()


# ----------------------------------------------------------------------------------- actions


def _actions(ctx):
    from robocourse.bus.action import ActionClient, ActionServer

    found = {}
    for n in ctx.nodes:
        for w in n.waitables:
            if isinstance(w, ActionServer):
                found.setdefault(w.action_name, {"type": w.action_type._type, "servers": [], "clients": []})
                found[w.action_name]["servers"].append(n.get_fully_qualified_name())
            elif isinstance(w, ActionClient) and not n.get_name().startswith("_"):
                found.setdefault(w.action_name, {"type": w._action_type._type, "servers": [], "clients": []})
                found[w.action_name]["clients"].append(n.get_fully_qualified_name())
    return found


def action_list(ctx, *, show_types: bool = True, quiet: bool = False):
    """``ros2 action list -t``."""
    ctx = _ctx(ctx)
    rows = sorted((name, [v["type"]]) for name, v in _actions(ctx).items() if v["servers"])
    _out("\n".join(f"{n} [{', '.join(t)}]" if show_types else n for n, t in rows), quiet)
    return rows


def action_info(ctx, action: str, *, show_types: bool = False, quiet: bool = False) -> dict:
    """``ros2 action info``: the clients and servers of one action."""
    ctx = _ctx(ctx)
    a = _actions(ctx).get(action, {"type": None, "servers": [], "clients": []})
    suffix = f" [{a['type']}]" if show_types and a["type"] else ""
    lines = [f"Action: {action}", f"Action clients: {len(a['clients'])}"]
    lines += [f"    {c}{suffix}" for c in a["clients"]]
    lines += [f"Action servers: {len(a['servers'])}"]
    lines += [f"    {s}{suffix}" for s in a["servers"]]
    _out("\n".join(lines), quiet)
    return a


def action_send_goal(ctx, action: str, action_type, values: dict | None, executor, *,
                     feedback: bool = True, timeout: float | None = 60.0, quiet: bool = False):
    """``ros2 action send_goal [--feedback]``: returns (status, result, [feedback])."""
    from robocourse.bus.action import STATUS_NAMES, ActionClient, _uuid_key

    ctx = _ctx(ctx)
    probe = _Probe(ctx, executor, "action")
    feedbacks = []
    try:
        client = ActionClient(probe.node, action_type, action)
        _out("Waiting for an action server to become available...", quiet)
        if not client.server_is_ready():
            _out(f"Action server {action!r} is not available.", quiet)
            return None, None, []
        goal = from_dict(action_type.Goal, values or {})
        _out(f"Sending goal:\n{to_yaml(goal, '     ')}\n", quiet)

        def on_fb(msg):
            feedbacks.append(msg.feedback)
            if feedback:
                _out(f"Feedback:\n{to_yaml(msg.feedback, '    ')}\n", quiet)

        fut = client.send_goal_async(goal, feedback_callback=on_fb)
        wait_for_future(executor, fut, timeout)
        handle = fut.result()
        if handle is None or not handle.accepted:
            _out("Goal was rejected.", quiet)
            return None, None, feedbacks
        _out(f"Goal accepted with ID: {_uuid_key(handle.goal_id).hex()}\n", quiet)
        rf = handle.get_result_async()
        wait_for_future(executor, rf, timeout)
        if not rf.done():
            _out("Timed out waiting for the result", quiet)
            return None, None, feedbacks
        res = rf.result()
        _out(f"Result:\n{to_yaml(res.result, '    ')}\n\nGoal finished with status: "
             f"{STATUS_NAMES.get(res.status, res.status)}", quiet)
        return res.status, res.result, feedbacks
    finally:
        client.destroy()
        probe.close()


# ----------------------------------------------------------------------------------- params


def param_list(ctx, node_name: str, *, quiet: bool = False) -> list[str]:
    node = _find_node(_ctx(ctx), node_name)
    names = sorted(node._parameters)
    _out(f"{node.get_fully_qualified_name()}:\n" + "\n".join(f"  {n}" for n in names), quiet)
    return names


def param_get(ctx, node_name: str, name: str, *, quiet: bool = False):
    node = _find_node(_ctx(ctx), node_name)
    p = node.get_parameter(name)
    label = {1: "Boolean", 2: "Integer", 3: "Double", 4: "String"}.get(int(p.type_), p.type_.name.title())
    _out(f"{label} value is: {p.value}", quiet)
    return p.value


def param_set(ctx, node_name: str, name: str, value, *, quiet: bool = False):
    from robocourse.bus.parameters import Parameter

    node = _find_node(_ctx(ctx), node_name)
    res = node.set_parameters([Parameter(name, value=value)])[0]
    _out("Set parameter successful" if res.successful else f"Setting parameter failed: {res.reason}", quiet)
    return res


# ----------------------------------------------------------------------------------- doctor


def doctor_report(ctx, *, quiet: bool = False) -> list:
    """The QoS part of ``ros2 doctor --report``: every incompatible publisher/subscription pair."""
    ctx = _ctx(ctx)
    rows = []
    for inc in ctx.incompatibilities:
        rows.append({"topic": inc.topic,
                     "publisher": inc.publisher._node.get_fully_qualified_name(),
                     "subscription": inc.subscription._node.get_fully_qualified_name(),
                     "policy": inc.policy.name, "reason": inc.reason})
    lines = ["   QOS COMPATIBILITY LIST"]
    if not rows:
        lines.append("compatibility status    : No publisher/subscriber pairs found with incompatible QoS")
    for r in rows:
        lines += [f"topic [type]            : {r['topic']}",
                  f"publisher node          : {r['publisher']}",
                  f"subscriber node         : {r['subscription']}",
                  f"compatibility status    : {r['reason']}"]
    _out("\n".join(lines), quiet)
    return rows


def _dur(s):
    return "infinite" if s == INFINITE else f"{s:g} s"
