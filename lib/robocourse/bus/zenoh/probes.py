"""The student-side half of chapter 7's checks: the probes, run where the student's code runs.

Each probe calls the student's code on the grader's inputs (or runs it in a child process against
a scripted peer on a private zenoh router) and returns what came out as plain data; the judges
and their expected values live in :mod:`robocourse.bus.zenoh.checks`, which the grading sandbox hides.
"""

from __future__ import annotations

import time

from robocourse.grading.probes import call, plain


def _uncached():
    """Empty the wire module's caches, so an answer that calls the library really runs its functions
    (a cache hit would hide the call from the grader's delegation check)."""
    from . import wire

    for value in vars(wire).values():
        if callable(getattr(value, "cache_clear", None)):
            value.cache_clear()


def attachment_probe(inputs, parse_attachment):
    """ch07.attachment: the 33-byte attachments, then the forms that must be refused."""
    _uncached()
    return {"good": [call(parse_attachment, bytes.fromhex(c["hex"])) for c in inputs["good"]],
            "bad": [call(parse_attachment, bytes.fromhex(h)) for h in inputs["bad"]]}


def key_probe(inputs, key_expression):
    """ch07.key_expression: one call per (domain, name, type, hash)."""
    _uncached()
    return {"cases": [call(key_expression, *c) for c in inputs["cases"]]}


def hash_probe(inputs, rihs01):
    """ch07.type_hash: one call per type description."""
    _uncached()
    return {"cases": [call(rihs01, c["description"]) for c in inputs["cases"]]}


def qos_probe(inputs, connects):
    """ch07.qos_connects: one call per (publisher QoS, subscription QoS, across processes)."""
    from robocourse.bus.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    out = []
    for p_r, p_d, s_r, s_d, across, p_depth, s_depth in inputs["pairs"]:
        pub = QoSProfile(depth=p_depth, reliability=ReliabilityPolicy[p_r], durability=DurabilityPolicy[p_d])
        sub = QoSProfile(depth=s_depth, reliability=ReliabilityPolicy[s_r], durability=DurabilityPolicy[s_d])
        out.append(call(connects, pub, sub, across))
    return {"pairs": out}


def node_probe(inputs, accumulator_node):
    """ch07.child_node: ``accumulator_node(ctx)`` in a child process; a scripted peer publishes
    ``values`` on /numbers and records the graph and every /sum that comes back over the wire."""
    from robocourse.bus import introspection
    from robocourse.bus.context import Context
    from robocourse.bus.executors import SingleThreadedExecutor
    from robocourse.bus.qos import QoSProfile
    from robocourse.bus.zenoh.processes import free_router, start_child
    from robocourse.msgs.std_msgs import Int64

    r, ep = free_router()
    ctx = child = None
    try:
        try:
            child = start_child(accumulator_node, connect=[ep], duration=20.0, name="accumulator_node")
        except RuntimeError as exc:
            if "NotImplementedError" in str(exc):
                raise NotImplementedError("accumulator_node") from None
            return {"error": str(exc).splitlines()[0][:400]}
        except (ValueError, TypeError) as exc:
            return {"error": str(exc)[:400]}
        ctx = Context(transport="zenoh", connect=[ep])
        node = ctx.create_node("grader_peer")
        got = []
        node.create_subscription(Int64, "/sum", lambda m: got.append(m.data), QoSProfile(depth=100))
        pub = node.create_publisher(Int64, "/numbers", QoSProfile(depth=100))
        t = ctx.transport
        t.wait_for(lambda t: any(e.kind == "MS" and e.topic == "/numbers" for e in t.remote_entities()), 10)
        t.wait_for(lambda t: any(e.kind == "MP" and e.topic == "/sum" for e in t.remote_entities()), 2)
        time.sleep(0.2)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        for v in inputs["values"]:
            pub.publish(Int64(data=v))
            ex.spin_once(timeout_sec=0.02)
        end = time.monotonic() + 5
        while len(got) < len(inputs["values"]) and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.02)
        ends = [[e.kind, e.topic, e.type_name, e.node_name] for e in t.remote_entities() if e.kind != "NN"]
        return plain({"nodes": introspection.node_list(ctx, quiet=True), "endpoints": ends, "sums": got[:1000],
                      "child_alive": child.alive(), "error": None})
    finally:
        if child is not None:
            child.close()
        if ctx is not None:
            ctx.try_shutdown()
        r.close()
