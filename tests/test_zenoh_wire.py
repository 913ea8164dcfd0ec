"""rmw_zenoh's bytes: checked against the reference values (shared/reference/ros2_zenoh.md)."""

import math

import pytest
from mcap_ros2._dynamic import generate_dynamic

from robocourse.bus.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from robocourse.bus.zenoh import wire
from robocourse.msgs.example_interfaces import AddTwoInts
from robocourse.msgs.std_msgs import String

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
ADD_HASH = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
ZID = "24ecdb58f6ba5a6f774847a559624044"
MP_TOKEN = (f"@ros2_lv/0/{ZID}/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/"
            f"{STRING_HASH}/::,7:,:,:,,")


def test_rihs01_hash_of_std_msgs_string_matches_ros2():
    assert wire.type_hash(String) == STRING_HASH


def test_rihs01_hash_of_add_two_ints_service_matches_ros2():
    assert wire.type_hash(AddTwoInts) == ADD_HASH


def test_data_keys_match_design_md_examples():
    assert wire.data_key(0, "/chatter", String) == f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    assert wire.data_key(0, "/robot1/chatter", String) == \
        f"0/robot1/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    assert wire.data_key(2, "/add_two_ints", AddTwoInts) == \
        f"2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/{ADD_HASH}"


def test_cdr_payload_has_encapsulation_header_and_nul_terminated_string():
    assert wire.to_cdr(String(data="Hello World: 1")).hex() == \
        "00010000" "0f000000" "48656c6c6f20576f726c643a2031" "00"
    assert wire.from_cdr(String, wire.to_cdr(String(data="x"))) == String(data="x")


def test_cdr_decodes_with_mcap_ros2_independently():
    dec = generate_dynamic("example_interfaces/AddTwoIntsRequest",
                           "int64 a\nint64 b\n")["example_interfaces/AddTwoIntsRequest"]
    out = dec(wire.to_cdr(AddTwoInts.Request(a=2, b=-3)))
    assert (out.a, out.b) == (2, -3)


@pytest.mark.parametrize("qos, text", [
    (QoSProfile(depth=10), "::,10:,:,:,,"),
    (QoSProfile(depth=7), "::,7:,:,:,,"),
    (QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT), "2::,5:,:,:,,"),
    (QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL), ":1:,1:,:,:,,"),
    (QoSProfile(depth=42), "::,:,:,:,,"),
    (QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=5), "::2,5:,:,:,,"),
    (QoSProfile(depth=10, deadline=1.5), "::,10:1,500000000:,:,,"),
])
def test_qos_string_encodes_only_non_defaults_and_parses_back(qos, text):
    assert wire.qos_to_keyexpr(qos) == text
    back = wire.keyexpr_to_qos(text)
    assert (back.reliability, back.durability, back.history, back.depth) == \
        (qos.reliability, qos.durability, qos.history, qos.depth)
    assert back.deadline == qos.deadline or math.isclose(back.deadline, qos.deadline)


def test_node_and_endpoint_tokens_are_mangled_like_rmw_zenoh():
    assert wire.node_token(0, ZID, 0, "/", "talker") == f"@ros2_lv/0/{ZID}/0/0/NN/%/%/talker"
    tok = wire.endpoint_token(0, ZID, 0, 10, "MP", "/", "talker", "/chatter", String,
                              QoSProfile(depth=7))
    assert tok == MP_TOKEN
    e = wire.parse_token(tok)
    assert (e.kind, e.topic, e.type_name, e.type_hash, e.node_fqn, e.qos.depth) == \
        ("MP", "/chatter", "std_msgs/msg/String", STRING_HASH, "/talker", 7)
    ns = wire.parse_token(wire.node_token(3, ZID, 4, "/robot1", "driver"))
    assert (ns.domain_id, ns.namespace, ns.node_fqn) == (3, "/robot1", "/robot1/driver")


def test_gid_is_xxh3_128_of_the_token_low_half_first():
    assert wire.gid_of(MP_TOKEN).hex() == "122a4cf3bfcf660855320686e8e3eba5"
    # the reference lists these two values with their labels swapped (NN token <-> "a");
    # python-xxhash and rmw_zenoh's simplified_xxhash3 agree on the values themselves
    assert wire.gid_of(f"@ros2_lv/0/{ZID}/0/0/NN/%/%/talker").hex() == \
        "f96ce904122015ac8cfab5be030faa54"
    assert wire.gid_of("a").hex() == "1f4e961eb632c6e63468f15a70af6fa9"
    assert wire.gid_of("x" * 300).hex() == "5435c87d60b4d1a57abcd72aea375212"


def test_attachment_is_the_33_byte_form():
    gid = bytes.fromhex("122a4cf3bfcf660855320686e8e3eba5")
    att = wire.encode_attachment(1, gid, 1700000000123456789)
    assert att.hex() == "0100000000000000" "15cd853dfe9c9717" "10" "122a4cf3bfcf660855320686e8e3eba5"
    back = wire.decode_attachment(att)
    assert (back.sequence_number, back.source_timestamp_ns, back.gid) == (1, 1700000000123456789, gid)


def test_attachment_matches_zenohs_own_serializer():
    from zenoh.ext import Int64, UInt8, z_serialize

    gid = bytes(range(16))
    ours = wire.encode_attachment(5, gid, 123)
    assert z_serialize((Int64(5), Int64(123), [UInt8(b) for b in gid])).to_bytes() == ours


@pytest.mark.parametrize("data", [b"", b"\x00" * 32, b"\x00" * 16 + b"\x08" + b"\x00" * 16, b"\x00" * 77])
def test_malformed_attachments_are_refused(data):
    with pytest.raises(ValueError, match="33-byte"):
        wire.decode_attachment(data)


@pytest.mark.parametrize("token, match", [
    ("@ros2_lv/0/z/0/0/NN/%/%/", "empty chunk"),
    ("@other/0/z/0/0/NN/%/%/talker", "admin space"),
    ("@ros2_lv/0/z/0/0/XX/%/%/talker", "unknown entity kind"),
    ("@ros2_lv/0/z/0/0/NN/%/%", "9"),
    ("@ros2_lv/x/z/0/0/NN/%/%/talker", "not an integer"),
    (f"@ros2_lv/0/z/0/1/MP/%/%/talker/%chatter/String/{STRING_HASH}/::,7:,:,:,,", "dds_"),
    (f"@ros2_lv/0/z/0/1/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/{STRING_HASH}/::", "6"),
])
def test_malformed_tokens_are_refused_with_the_rule(token, match):
    with pytest.raises(ValueError, match=match):
        wire.parse_token(token)


# ---------------------------------------------------------------- the hot-path helpers
def _populated(t):
    """A message of type ``t`` with every field set away from its default: numbers, strings,
    sequences of two items, fixed arrays filled, nested messages populated in turn."""
    from robocourse.msgs._core import _resolve

    values = {"bool": True, "string": "abc", "wstring": "abc", "float32": 1.5, "float64": -2.25,
              "byte": 7, "char": 7}
    msg = t()
    for spec in t._fields:
        if spec.is_primitive:
            one = values.get(spec.base_type, 3)
            if spec.string_bound:
                one = one[: int(spec.string_bound[2:])]
        else:
            one = None
        if spec.is_array:
            n = spec.array_size if spec.array_size is not None and not spec.is_bounded else \
                min(2, spec.array_size or 2)
            items = [one if one is not None else _populated(_resolve(spec.base_type))
                     for _ in range(n)]
            setattr(msg, spec.name, items)
        else:
            setattr(msg, spec.name, one if one is not None else
                    _populated(_resolve(spec.base_type)))
    return msg


def _message_types():
    from robocourse.msgs._core import REGISTRY

    return sorted((t for t in set(REGISTRY.values()) if hasattr(t, "_fields")),
                  key=lambda t: t._type)


@pytest.mark.parametrize("t", _message_types(), ids=lambda t: t._type)
def test_bound_encoder_and_decoder_give_to_cdr_bytes_for_every_type(t):
    """The publisher/subscription hot path (wire.encoder / wire.decoder) puts exactly
    to_cdr's bytes on the wire and decodes them to equal values, empty and populated."""
    for msg in (t(), _populated(t)):
        data = wire.to_cdr(msg)
        assert wire.encoder(t)(msg) == data
        back = wire.decoder(t)(data)
        assert type(back) is t and back == msg == wire.from_cdr(t, data)
        assert wire.to_cdr(back) == data


def test_attachment_packer_matches_encode_attachment():
    gid = bytes(range(16))
    pack = wire.attachment_packer(gid)
    assert pack(9, 1700000000123456789) == wire.encode_attachment(9, gid, 1700000000123456789)
    assert wire.attachment_ok(pack(1, 2))
    with pytest.raises(ValueError, match="16"):
        wire.attachment_packer(b"\x00" * 8)


@pytest.mark.parametrize("data", [b"", b"\x00" * 32, b"\x00" * 16 + b"\x08" + b"\x00" * 16, b"\x00" * 77])
def test_attachment_ok_refuses_what_decode_attachment_refuses(data):
    assert not wire.attachment_ok(data)
