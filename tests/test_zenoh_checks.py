"""Chapter 7's checks pass right answers and explain the usual wrong ones (the node check runs
each answer in a real child process against the scripted peer)."""

from __future__ import annotations

import hashlib
import json

import numpy as np

from robocourse.bus.qos import DurabilityPolicy, ReliabilityPolicy, qos_check_compatible
from robocourse.bus.zenoh import checks, wire  # noqa: F401  (registers ch07.*)
from robocourse.grading.checks import get, run_check


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


def parse_ok(data):
    data = bytes(data)
    if len(data) != 33:
        raise ValueError(f"{len(data)} bytes")
    return {"sequence_number": int.from_bytes(data[:8], "little", signed=True),
            "source_timestamp_ns": int.from_bytes(data[8:16], "little", signed=True), "gid": data[17:].hex()}


def test_attachment_read_as_unsigned_scores_zero_on_the_negative_sequence_numbers_it_is_given():
    def unsigned(data):
        data = bytes(data)
        if len(data) != 33:
            raise ValueError(f"{len(data)} bytes")
        return {"sequence_number": int.from_bytes(data[:8], "little"),
                "source_timestamp_ns": int.from_bytes(data[8:16], "little"), "gid": data[17:].hex()}

    for seed in range(5):
        r = run("ch07.attachment", unsigned, seed=seed)
        assert not r.passed and r.points == 0 and "int64: signed" in r.message, r.message


def test_attachment_check_passes_and_names_byte_order_gid_and_length_mistakes():
    for seed in range(3):
        r = run("ch07.attachment", parse_ok, seed=seed)
        assert r.passed and r.points == 2, r.message

    def big_endian(data):
        d = parse_ok(data)
        d["sequence_number"] = int.from_bytes(bytes(data)[:8], "big", signed=True)
        return d
    assert "little-endian" in run("ch07.attachment", big_endian).message

    def gid_with_length(data):
        return {**parse_ok(data), "gid": bytes(data)[16:32].hex()}
    assert "0x10 length byte" in run("ch07.attachment", gid_with_length).message

    def accepts_anything(data):
        d = bytes(data) + bytes(33)
        return parse_ok(d[:33])
    r = run("ch07.attachment", accepts_anything)
    assert not r.passed and "77 bytes must raise ValueError" in r.message and "32 bytes" in r.message
    lib = run("ch07.attachment", lambda d: wire.decode_attachment(d).__dict__)
    assert lib.reason == "delegated" and lib.points == 0


def key_ok(domain_id, topic, type_name, type_hash):
    pkg, kind, name = type_name.split("/")
    return f"{domain_id}/{topic.strip('/')}/{pkg}::{kind}::dds_::{name}_/{type_hash}"


def test_key_expression_check_passes_and_catches_a_leading_slash_and_token_mangling():
    for seed in range(3):
        assert run("ch07.key_expression", key_ok, seed=seed).passed
    slash = run("ch07.key_expression", lambda d, t, ty, h: key_ok(d, "", ty, h).replace("//", f"/{t}/"))
    assert not slash.passed and "gave '0//chatter/" in slash.message and "without the leading '/'" in slash.message
    percent = run("ch07.key_expression", lambda d, t, ty, h: key_ok(d, t.replace("/", "%"), ty, h))
    assert not percent.passed and "%chatter" in percent.message     # tokens mangle names, data keys do not
    assert run("ch07.key_expression", lambda d, t, ty, h: wire.data_key(d, t, wire.REGISTRY[ty])).reason == \
        "delegated"


def test_type_hash_check_passes_and_explains_compact_json_and_missing_prefix():
    ok = lambda d: "RIHS01_" + hashlib.sha256(json.dumps(d).encode()).hexdigest()  # noqa: E731
    r = run("ch07.type_hash", ok)
    assert r.passed and "df668c74" in r.message
    compact = lambda d: "RIHS01_" + hashlib.sha256(json.dumps(d, separators=(",", ":")).encode()).hexdigest()  # noqa: E731
    assert "default separators" in run("ch07.type_hash", compact).message
    bare = lambda d: hashlib.sha256(json.dumps(d).encode()).hexdigest()  # noqa: E731
    assert "prefix 'RIHS01_'" in run("ch07.type_hash", bare).message


def connects_ok(pub, sub, across):
    if across:
        return True
    return not (pub.reliability == ReliabilityPolicy.BEST_EFFORT and sub.reliability == ReliabilityPolicy.RELIABLE
                or pub.durability == DurabilityPolicy.VOLATILE
                and sub.durability == DurabilityPolicy.TRANSIENT_LOCAL)


def test_qos_check_passes_and_counts_dds_rules_applied_across_the_wire():
    r = run("ch07.qos_connects", connects_ok)
    assert r.passed and "32 pairs" in r.message
    dds_everywhere = lambda p, s, across: connects_ok(p, s, False)  # noqa: E731
    wrong = run("ch07.qos_connects", dds_everywhere)
    # 16 pairs across processes, of which 7 are incompatible under DDS's rules
    assert not wrong.passed and "25/32 right" in wrong.message and "rmw_zenoh" in wrong.message
    lib = lambda p, s, across: across or qos_check_compatible(p, s).compatibility.name != "ERROR"  # noqa: E731
    assert run("ch07.qos_connects", lib).reason == "delegated"


# --- the node in a child process: each answer is sent to a child by source --------------------


def accumulator_ok(ctx):
    from robocourse.msgs.std_msgs import Int64

    node = ctx.create_node("accumulator")
    pub = node.create_publisher(Int64, "/sum", 100)
    total = [0]

    def cb(m):
        total[0] += m.data
        pub.publish(Int64(data=total[0]))
    node.create_subscription(Int64, "/numbers", cb, 100)


def echo_not_sum(ctx):
    from robocourse.msgs.std_msgs import Int64

    node = ctx.create_node("accumulator")
    pub = node.create_publisher(Int64, "/sum", 100)
    node.create_subscription(Int64, "/numbers", pub.publish, 100)


def forgot_import(ctx):
    node = ctx.create_node("accumulator")
    node.create_publisher(Int64, "/sum", 100)  # noqa: F821 - Int64 is imported at module level only


def not_written(ctx):
    raise NotImplementedError()


def _with_source_changed(fn, old, new, tmp_path):
    """``fn`` with one literal of its source replaced, written to a module file so that its
    source can travel to the child like any answer's."""
    import importlib.util
    import inspect
    import textwrap

    source = textwrap.dedent(inspect.getsource(fn))
    assert source.count(old) == 1, f"{old!r} must occur once in {fn.__name__}"
    path = tmp_path / f"variant_{fn.__name__}.py"
    path.write_text(source.replace(old, new))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, fn.__name__)


def test_child_node_check_runs_the_answer_in_another_process_and_reads_the_wire(tmp_path):
    wrong_name = _with_source_changed(accumulator_ok, '"accumulator"', '"summer"', tmp_path)
    r = run("ch07.child_node", accumulator_ok, seed=3)
    assert r.passed and r.points == 3, r.message
    r = run("ch07.child_node", echo_not_sum, seed=3)
    assert not r.passed and "expected the running sums" in r.message
    r = run("ch07.child_node", wrong_name, seed=3)
    assert not r.passed and "'/accumulator'" in r.message and "running sums right" not in r.message
    r = run("ch07.child_node", forgot_import)
    assert not r.passed and "NameError" in r.message and "import everything inside it" in r.message
    r = run("ch07.child_node", not_written)
    assert r.reason == "not implemented" or "not implemented" in r.message


def test_child_node_check_refuses_a_lambda_with_the_fix():
    r = run("ch07.child_node", lambda ctx: None)
    assert not r.passed and "define it with def" in r.message
