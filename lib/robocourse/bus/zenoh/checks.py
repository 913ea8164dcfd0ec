"""Graded checks of chapter 7 (the graph across processes): inputs, schemas, sub-tests. Registered as ``ch07.*``.

Home: the zenoh transport is part of the ``bus`` foundation, and foundations may import
``grading`` (``rt.checks`` does; grading imports no foundation but finds this module through
its ``robocourse.checks`` entry point), so the chapter's checks live next to the code they
teach, as DESIGN.md asks. The probes are in :mod:`robocourse.bus.zenoh.probes` (run where the
student's code runs); the judges here compare with :mod:`robocourse.bus.zenoh.wire`
(rmw_zenoh's bytes) and :func:`robocourse.bus.qos.qos_check_compatible`, and every record is
validated against the check's schema first. Each sub-test scores on its own. Nothing is timed.
"""

from __future__ import annotations

import json

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Any, Bool, Call, Dict, List, Opt, Str

from . import probes, wire

# --- exercise 1: decode an attachment by hand ----------------------------------------------------


def _att_inputs(rng):
    good = []
    # int64 fields: besides ordinary values, negative ones (the sequence number is signed in rmw_zenoh:
    # an unsigned reading turns -1 into 18446744073709551615) and the extremes of the type
    seqs = [int(rng.integers(1, 2**40)) for _ in range(4)] + [-int(rng.integers(1, 2**40)), -(2**63), 2**63 - 1]
    for i, seq in enumerate(seqs):
        ts = int(rng.integers(1_600_000_000, 2_000_000_000)) * 1_000_000_000 + int(rng.integers(0, 10**9))
        if i == 5:
            ts = -int(rng.integers(1, 10**12))       # a stamp before 1970: still an int64
        gid = bytes(int(b) for b in rng.integers(0, 256, 16))
        good.append({"hex": wire.encode_attachment(seq, gid, ts).hex(), "seq": seq, "ts": ts, "gid": gid.hex()})
    good = [good[int(i)] for i in rng.permutation(len(good))]
    old = b"".join(len(s).to_bytes(1, "little") + s.encode() + v
                   for s, v in (("sequence_number", bytes(8)), ("source_timestamp", bytes(8)),
                                ("source_gid", b"\x10" + bytes(16))))          # the pre-2025 named form
    first = bytes.fromhex(good[0]["hex"])
    wrong_length_byte = first[:16] + b"\x20" + first[17:]                        # 33 bytes, not a 16-byte GID
    return {"good": good, "bad": [old.hex(), first[:32].hex(), wrong_length_byte.hex()]}


def _att_field(key, rule, success):
    def judge(inputs, outputs):
        f = Failures()
        for case, got in zip(inputs["good"], outputs["good"], strict=True):
            if "raised" in got:
                f.add(f"parse_attachment({case['hex'][:16]}...) raised {got['raised']}: {got.get('message')}")
                break
            v = got["value"]
            if not isinstance(v, dict):
                f.add(f"return a dict with keys sequence_number, source_timestamp_ns, gid; got {str(v)[:80]}")
                break
            want = {"sequence_number": case["seq"], "source_timestamp_ns": case["ts"], "gid": case["gid"]}[key]
            g = v.get(key)
            if isinstance(g, str):
                g = g.lower()
            if g != want or type(g) is not type(want):
                hint = rule
                if key != "gid" and isinstance(g, int) and g == int.from_bytes(
                        int(want).to_bytes(8, "little", signed=True), "big", signed=True):
                    hint = "byte order: the integers are little-endian"
                elif key != "gid" and isinstance(g, int) and want < 0 and g == want + 2**64:
                    hint = "the fields are int64: signed, int.from_bytes(..., 'little', signed=True)"
                f.add(f"{key}: got {str(g)[:60]!r}, expected {want!r} for attachment {case['hex']} ({hint})")
                break
        return f.done(success)
    return judge


def _att_refuses(inputs, outputs):
    f = Failures()
    names = ["rmw_zenoh's pre-2025 named form (77 bytes)", "a short one (32 bytes)",
             "33 bytes whose length byte is not 0x10"]
    for name, _h, got in zip(names, inputs["bad"], outputs["bad"], strict=True):
        raised = (got.get("bases") or [got.get("raised")]) if "raised" in got else []
        if "ValueError" not in raised:
            shown = f"raised {got['raised']}" if "raised" in got else f"returned {str(got.get('value'))[:80]}"
            f.add(f"{name} must raise ValueError naming the length (rmw_zenoh only accepts int64, int64, 0x10, "
                  f"16 bytes); it {shown}")
    return f.done("the 77-byte form, a short one and a wrong length byte refused with ValueError")


register("ch07.attachment", uses=("parse_attachment",), probe=probes.attachment_probe, inputs=_att_inputs,
         references=("robocourse.bus.zenoh.wire:decode_attachment",),
         schema=Dict(good=List(Call(Any(max_items=50)), length="good"), bad=List(Call(Any(max_items=50)), length="bad")),
         subtests=[SubTest("sequence_number: int64, little-endian, signed", 0.5,
                           _att_field("sequence_number", "bytes 0-7, int64 little-endian, signed",
                                      "sequence numbers right, negative and extreme ones too")),
                   SubTest("source_timestamp_ns: int64, little-endian, signed", 0.5,
                           _att_field("source_timestamp_ns", "bytes 8-15, int64 little-endian, signed",
                                      "timestamps right, one before 1970 too")),
                   SubTest("gid: the last 16 bytes, as 32 lowercase hex characters", 0.5,
                           _att_field("gid", "the GID is the last 16 bytes, after the 0x10 length byte, as hex",
                                      "GIDs right")),
                   SubTest("anything but the 33-byte form raises ValueError", 0.5, _att_refuses)])


# --- exercise 2: the key expression ----------------------------------------------------------------

_TYPES = ["std_msgs/msg/String", "geometry_msgs/msg/Twist", "sensor_msgs/msg/JointState", "nav_msgs/msg/Odometry",
          "std_msgs/msg/Int32", "example_interfaces/srv/AddTwoInts", "std_srvs/srv/Trigger"]
_NAMES = ["chatter", "cmd_vel", "joint_states", "odom", "scan", "add_two_ints", "reset"]
_NS = ["", "/robot1", "/fleet/arm_2"]


def _key_inputs(rng):
    from robocourse.msgs import REGISTRY

    cases = [[0, "/chatter", "std_msgs/msg/String", wire.type_hash(REGISTRY["std_msgs/msg/String"])],
             [int(rng.integers(1, 233)), "/fleet/arm_2/odom", "nav_msgs/msg/Odometry",
              wire.type_hash(REGISTRY["nav_msgs/msg/Odometry"])],
             [int(rng.integers(0, 233)), "/reset", "std_srvs/srv/Trigger", wire.type_hash(REGISTRY["std_srvs/srv/Trigger"])]]
    for _ in range(6):
        t = _TYPES[int(rng.integers(len(_TYPES)))]
        name = _NS[int(rng.integers(len(_NS)))] + "/" + _NAMES[int(rng.integers(len(_NAMES)))]
        cases.append([int(rng.integers(0, 233)), name, t, wire.type_hash(REGISTRY[t])])
    return {"cases": cases}


def _key_part(head, rule, success):
    def judge(inputs, outputs):
        f = Failures()
        for (domain, name, type_name, type_hash), got in zip(inputs["cases"], outputs["cases"], strict=True):
            if "raised" in got:
                f.add(f"key_expression({domain}, {name!r}, {type_name!r}) raised {got['raised']}: {got.get('message')}")
                break
            key = got["value"]
            pre = f"{domain}/{wire.strip_slashes(name)}/"
            post = f"/{wire.dds_type_name(type_name)}/{type_hash}"
            ok = isinstance(key, str) and (key.startswith(pre) if head else key.endswith(post))
            if not ok:
                want = pre + "..." if head else "..." + post
                f.add(f"key_expression({domain}, {name!r}, {type_name!r}) gave {str(key)[:120]!r}; it should "
                      f"{'start' if head else 'end'} with {want!r} ({rule})")
                break
        return f.done(success)
    return judge


register("ch07.key_expression", uses=("key_expression",), probe=probes.key_probe, inputs=_key_inputs,
         references=("robocourse.bus.zenoh.wire:data_key", "robocourse.bus.zenoh.wire:dds_type_name"),
         schema=Dict(cases=List(Call(Any(max_items=10)), length="cases")),
         subtests=[SubTest("<domain>/<name>: the leading '/' dropped, inner '/' kept", 1.0,
                           _key_part(True, "domain id, then the name without its leading '/'; inner '/' stay",
                                     "domain and name right, namespaces included")),
                   SubTest("<pkg>::<msg|srv>::dds_::<Type>_/<hash>", 1.0,
                           _key_part(False, "the DDS type name keeps msg or srv and ends with '_', then the hash",
                                     "DDS type names right, services included"))])


# --- exercise 3: the type hash ---------------------------------------------------------------------


def _hash_inputs(rng):
    from robocourse.msgs import REGISTRY

    names = ["std_msgs/msg/String"] + [str(t) for t in rng.choice(
        ["geometry_msgs/msg/Twist", "std_msgs/msg/Header", "sensor_msgs/msg/JointState", "nav_msgs/msg/Odometry",
         "geometry_msgs/msg/PoseStamped", "std_msgs/msg/Float64"], 3, replace=False)]
    return {"cases": [{"name": n, "description": wire.type_description(REGISTRY[n]), "hash": wire.type_hash(REGISTRY[n])}
                      for n in names]}


def _hashes(inputs, outputs, f):
    """(case, returned value) per case, until one raised (told in ``f``)."""
    out = []
    for c, got in zip(inputs["cases"], outputs["cases"], strict=True):
        if "raised" in got:
            f.add(f"rihs01({c['name']}) raised {got['raised']}: {got.get('message')}")
            break
        out.append((c, got.get("value")))
    return out


def _hash_prefix(inputs, outputs):
    f = Failures()
    for c, v in _hashes(inputs, outputs, f):
        if not (isinstance(v, str) and v.startswith("RIHS01_")):
            f.add(f"rihs01({c['name']}) gave {str(v)[:90]!r}: a REP-2011 hash starts with 'RIHS01_'")
            break
    return f.done("the RIHS01_ prefix")


def _hash_digest(inputs, outputs):
    f = Failures()
    for c, v in _hashes(inputs, outputs, f):
        want = c["hash"][len("RIHS01_"):]
        digest = v.rsplit("_", 1)[-1].lower() if isinstance(v, str) else None
        if digest != want:
            f.add(f"rihs01({c['name']}): the digest {str(digest)[:70]!r} should be {want} (sha256 of json.dumps(description) "
                  "with Python's default separators ', ' and ': ', keys in the given order)")
            break
    return f.done("sha256 digests exact, std_msgs/String's is the reference's df668c74...")


register("ch07.type_hash", uses=("rihs01",), probe=probes.hash_probe, inputs=_hash_inputs,
         references=("robocourse.bus.zenoh.wire:type_hash",),
         schema=Dict(cases=List(Call(Any(max_items=10)), length="cases")),
         subtests=[SubTest("starts with RIHS01_", 0.25, _hash_prefix),
                   SubTest("the sha256 of the description's JSON text (json.dumps defaults)", 0.75, _hash_digest)])


# --- exercise 4: which QoS pairs connect -----------------------------------------------------------

_REL = ["RELIABLE", "BEST_EFFORT"]
_DUR = ["VOLATILE", "TRANSIENT_LOCAL"]


def _qos_inputs(rng):
    pairs = [[p_r, p_d, s_r, s_d, across] for p_r in _REL for p_d in _DUR for s_r in _REL for s_d in _DUR
             for across in (False, True)]
    order = rng.permutation(len(pairs))
    return {"pairs": [pairs[int(i)] + [int(rng.integers(1, 20)), int(rng.integers(1, 20))] for i in order]}


def _connects(p_r, p_d, s_r, s_d, across):
    from robocourse.bus.qos import (
        DurabilityPolicy,
        QoSCompatibility,
        QoSProfile,
        ReliabilityPolicy,
        qos_check_compatible,
    )

    if across:
        return True
    pub = QoSProfile(depth=1, reliability=ReliabilityPolicy[p_r], durability=DurabilityPolicy[p_d])
    sub = QoSProfile(depth=1, reliability=ReliabilityPolicy[s_r], durability=DurabilityPolicy[s_d])
    return qos_check_compatible(pub, sub).compatibility != QoSCompatibility.ERROR


def _qos_group(select, what, success):
    def judge(inputs, outputs):
        f, wrong, n = Failures(), [], 0
        for (p_r, p_d, s_r, s_d, across, *_), got in zip(inputs["pairs"], outputs["pairs"], strict=True):
            if not select(p_r, p_d, s_r, s_d, across):
                continue
            n += 1
            v = got.get("value")
            if not isinstance(v, bool):
                f.add(f"connects(...) must return True or False; got {str(v if 'value' in got else got.get('raised'))[:60]!r}")
                break
            want = _connects(p_r, p_d, s_r, s_d, across)
            if v != want:
                wrong.append(f"publisher {p_r}/{p_d}, subscription {s_r}/{s_d} "
                             f"{'across processes' if across else 'in one process'}: "
                             f"{'connects' if want else 'does not connect'} ({what})")
        if wrong:
            f.add(f"{n - len(wrong)}/{n} of these pairs right")
            for w in wrong[:4]:
                f.add(w)
        return f.done(success)
    return judge


register("ch07.qos_connects", uses=("connects",), probe=probes.qos_probe, inputs=_qos_inputs,
         references=("robocourse.bus.qos:qos_check_compatible",),
         schema=Dict(pairs=List(Call(Any(max_items=5)), length="pairs")),
         subtests=[SubTest("in one process, BEST_EFFORT never feeds a RELIABLE subscription", 0.5,
                           _qos_group(lambda p_r, p_d, s_r, s_d, a: not a and (p_r, s_r) == ("BEST_EFFORT", "RELIABLE"),
                                      "DDS request/offer: a subscription may not ask for more reliability than "
                                      "offered", "the reliability rule")),
                   SubTest("in one process, VOLATILE never feeds a TRANSIENT_LOCAL subscription", 0.5,
                           _qos_group(lambda p_r, p_d, s_r, s_d, a: not a and (p_d, s_d) == ("VOLATILE", "TRANSIENT_LOCAL")
                                      and (p_r, s_r) != ("BEST_EFFORT", "RELIABLE"),
                                      "DDS request/offer: a subscription may not ask for more durability than "
                                      "offered", "the durability rule")),
                   SubTest("in one process, every other pair connects", 0.5,
                           _qos_group(lambda p_r, p_d, s_r, s_d, a: not a and (p_r, s_r) != ("BEST_EFFORT", "RELIABLE")
                                      and (p_d, s_d) != ("VOLATILE", "TRANSIENT_LOCAL"),
                                      "what is offered covers what is asked", "compatible pairs connect")),
                   SubTest("across processes, every pair connects (rmw_zenoh matches keys, not QoS)", 0.5,
                           _qos_group(lambda p_r, p_d, s_r, s_d, a: a,
                                      "rmw_zenoh: no QoS matching across the wire, the key decides",
                                      "rmw_zenoh's rule"))])


# --- exercise 5: a node in another process ---------------------------------------------------------


def _node_inputs(rng):
    return {"values": [int(v) for v in rng.integers(-1000, 1000, int(rng.integers(5, 11)))]}


def _node_started(out):
    if out.get("error"):
        raise CheckFailed(f"the child process did not start your node: {out['error']}",
                          "remember: only the function's source travels; import everything inside it")


def _node_name(inputs, out):
    _node_started(out)
    nodes = out.get("nodes") or []
    if "/accumulator" not in nodes:
        raise CheckFailed(f"the graph seen from another process has nodes {nodes}; expected '/accumulator' (create "
                          "it with ctx.create_node('accumulator'))")
    return "/accumulator found from another process"


def _node_endpoint(kind, topic, what):
    def judge(inputs, out):
        _node_started(out)
        ends = [tuple(e) for e in out.get("endpoints") or []]
        if not any(e[:3] == (kind, topic, "std_msgs/msg/Int64") for e in ends):
            raise CheckFailed(f"no {what} of node 'accumulator' on {topic} (std_msgs/msg/Int64) in the graph; found "
                              f"{ends[:6]}")
        return f"{what} on {topic}, std_msgs/msg/Int64"
    return judge


def _node_sums(inputs, out):
    _node_started(out)
    values, sums = inputs["values"], out.get("sums") or []
    want, total = [], 0
    for v in values:
        total += v
        want.append(total)
    if sums != want:
        raise CheckFailed(f"sent {values} on /numbers; /sum carried {sums[:20]}, expected the running sums {want}"
                          + (" (one sum per message, in order)" if len(sums) != len(want) else ""))
    return f"{len(values)} running sums right: {json.dumps(want[-3:])[1:-1]} ..."


_NODE_SCHEMA = Dict(error=Opt(Str(max_len=1000)),
                    optional={"nodes": List(Str(max_len=300), max_len=100),
                              "endpoints": List(List(Str(max_len=300), length=4), max_len=200),
                              "sums": List(Any(max_items=2), max_len=1000), "child_alive": Bool()})

register("ch07.child_node", time_limit=90, uses=("accumulator_node",), probe=probes.node_probe, inputs=_node_inputs,
         schema=_NODE_SCHEMA,
         subtests=[SubTest("a node named accumulator, seen from another process", 0.5, _node_name),
                   SubTest("it subscribes /numbers (std_msgs/msg/Int64)", 0.5,
                           _node_endpoint("MS", "/numbers", "subscription")),
                   SubTest("it publishes /sum (std_msgs/msg/Int64)", 0.5, _node_endpoint("MP", "/sum", "publisher")),
                   SubTest("one running sum per number, in order", 1.5, _node_sums)])
