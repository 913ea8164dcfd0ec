"""Chapter 7's checks in the student's own kernel: what the bank (tests/banks/ch07.py) cannot show.

The bank grades plausible wrong answers through the sandbox with their partial scores. Here:
several mistakes at once are each told in their sub-test; an unsigned reading of the int64 fields
fails on the negative values the grader always sends; delegating to the library scores 0; the
node exercise's answer really runs in another process (a forgotten import, a lambda and an
unwritten answer are told what to do).
"""

from __future__ import annotations

import numpy as np

from robocourse.bus.qos import qos_check_compatible
from robocourse.bus.zenoh import checks, wire  # noqa: F401  (registers ch07.*)
from robocourse.grading.checks import get, run_check


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


def parse_ok(data):
    data = bytes(data)
    if len(data) != 33 or data[16] != 0x10:
        raise ValueError(f"{len(data)} bytes")
    return {"sequence_number": int.from_bytes(data[:8], "little", signed=True),
            "source_timestamp_ns": int.from_bytes(data[8:16], "little", signed=True), "gid": data[17:].hex()}


def failed(result):
    return {s["name"] for s in result.subtests if not s["passed"]}


def test_attachment_read_as_unsigned_fails_on_the_negative_values_it_is_always_given():
    def unsigned(data):
        d = parse_ok(data)
        d["sequence_number"] = int.from_bytes(bytes(data)[:8], "little")
        return d

    for seed in range(5):
        r = run("ch07.attachment", unsigned, seed=seed)
        assert failed(r) == {"sequence_number: int64, little-endian, signed"} and "signed=True" in r.message


def test_attachment_mistakes_each_told_in_their_sub_test():
    def two_mistakes(data):
        d = {**parse_ok(data[:16] + b"\x10" + data[17:]), "gid": bytes(data)[16:32].hex()}
        return d                                               # the GID off by one, and no length-byte check

    r = run("ch07.attachment", two_mistakes, seed=1)
    assert failed(r) == {"gid: the last 16 bytes, as 32 lowercase hex characters",
                         "anything but the 33-byte form raises ValueError"}
    assert "33 bytes whose length byte is not 0x10 must raise ValueError" in r.message
    lib = run("ch07.attachment", lambda d: wire.decode_attachment(d).__dict__)
    assert lib.reason == "delegated" and lib.points == 0


def test_key_expression_and_type_hash_delegating_to_the_library_score_zero():
    assert run("ch07.key_expression", lambda d, t, ty, h: wire.data_key(d, t, wire.REGISTRY[ty])).reason == "delegated"
    assert run("ch07.type_hash", lambda desc: wire.type_hash(wire.REGISTRY[desc["type_description"]["type_name"]])
               ).points == 0


def test_qos_answers_of_the_wrong_kind_are_told():
    r = run("ch07.qos_connects", lambda p, s, across: "yes")
    assert r.points == 0 and "True or False" in r.message
    lib = lambda p, s, across: across or qos_check_compatible(p, s).compatibility.name != "ERROR"  # noqa: E731
    assert run("ch07.qos_connects", lib).reason == "delegated"


# --- the node in a child process: each answer is sent to a child by source --------------------


def forgot_import(ctx):
    node = ctx.create_node("accumulator")
    node.create_publisher(Int64, "/sum", 100)  # noqa: F821 - Int64 is imported at module level only


def not_written(ctx):
    raise NotImplementedError()


def test_child_node_check_tells_a_forgotten_import_and_an_unwritten_answer():
    r = run("ch07.child_node", forgot_import)
    assert r.points == 0 and "NameError" in r.message and "import everything inside it" in r.message
    r = run("ch07.child_node", not_written)
    assert r.reason == "not_implemented" or "not implemented" in r.message.lower()


def test_child_node_check_refuses_a_lambda_with_the_fix():
    r = run("ch07.child_node", lambda ctx: None)
    assert r.points == 0 and "define it with def" in r.message
