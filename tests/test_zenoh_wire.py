"""rmw_zenoh's bytes: checked against the reference values (shared/reference/ros2_zenoh.md)."""

import array
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
from robocourse.msgs import message
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


def _mcap_codec(t):
    """mcap-ros2-support's CDR codec for ``t``: an independent implementation to check the
    transport's (rosbags') bytes against."""
    from mcap_ros2._dynamic import serialize_dynamic

    from robocourse.msgs import definition_name, full_definition
    from robocourse.msgs._core import wire_view

    schema = definition_name(t._type)
    enc = serialize_dynamic(schema, full_definition(t))[schema]
    dec = generate_dynamic(schema, full_definition(t))[schema]
    return (lambda msg: bytes(enc(wire_view(msg)))), dec


@pytest.mark.parametrize("t", _message_types(), ids=lambda t: t._type)
def test_every_type_encodes_to_mcap_ros2s_bytes_and_decodes_back(t):
    """For every registered type, empty and populated: the publisher's encoder gives exactly
    the bytes of mcap-ros2-support's codec (another implementation of ROS 2 CDR), to_cdr gives
    the same, and the subscription's decoder returns an equal message of the type."""
    enc, _ = _mcap_codec(t)
    for msg in (t(), _populated(t)):
        data = wire.to_cdr(msg)
        assert data == enc(msg)
        assert wire.encoder(t, buffer=True)(msg) == data
        back = wire.decoder(t)(data)
        assert type(back) is t and back == msg == wire.from_cdr(t, data)
        assert wire.to_cdr(back) == data


@message("wire_test_msgs/msg/Inner", """
bool[3] flags
float32[2] xy
string<=4 tag
""")
class Inner:
    pass


@message("wire_test_msgs/msg/Every", """
bool b
byte by
char ch
int8 i8
uint8 u8
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
float64 f64
string s
string<=10 sb
bool[] bseq
bool[2] barr
uint8[] octets
byte[4] byte_arr
int8[<=5] i8b
float64[] f64seq
float64[3] f64arr
string[] sseq
string<=3[2] sarr
wire_test_msgs/Inner inner
wire_test_msgs/Inner[] inners
wire_test_msgs/Inner[2] inner_arr
""")
class Every:
    pass


def _every():
    return Every(
        b=True, by=255, ch=65, i8=-128, u8=255, i16=-32768, u16=65535, i32=-2**31,
        u32=2**32 - 1, i64=-2**63, u64=2**64 - 1, f32=1.5, f64=math.inf, s="h\u00e9llo",
        sb="0123456789", bseq=[True, False, True], barr=[False, True], octets=b"\x00\x01\xff",
        byte_arr=[1, 2, 3, 4], i8b=[-1, 2], f64seq=[1.0, 2.5], f64arr=[1, 2, 3],
        sseq=["a", "", "ccc"], sarr=["ab", "c"],
        inner=Inner(flags=[True, False, True], xy=[1, 2], tag="abcd"),
        inners=[Inner(), Inner(tag="x")])


def test_every_field_kind_at_its_limits_matches_mcap_ros2():
    """Each primitive at its range limits, bounded strings and sequences at their bounds,
    bool/byte/numeric sequences and arrays, nested messages in arrays and sequences,
    alignment after odd sizes: mcap-ros2-support's bytes, and back to an equal message."""
    msg = _every()
    enc, dec = _mcap_codec(Every)
    data = wire.to_cdr(msg)
    assert data == enc(msg)
    assert dec(data).u64 == 2**64 - 1 and dec(data).s == "h\u00e9llo"
    back = wire.from_cdr(Every, data)
    assert back == msg


def test_decoded_arrays_are_the_messages_own_and_writable():
    """A received message owns its values (no view into the payload or another message):
    fixed arrays are writable numpy arrays, sequences array.array, as rclpy's."""
    data = wire.to_cdr(_every())
    a, b = wire.from_cdr(Every, data), wire.from_cdr(Every, data)
    a.f64arr[0] = 99.0
    a.inner.xy[1] = 7.0
    a.f64seq[0] = -1.0
    assert b.f64arr[0] == 1.0 and b.inner.xy[1] == 2.0 and b.f64seq[0] == 1.0
    assert isinstance(b.f64seq, array.array) and b.f64arr.flags.owndata


def test_big_endian_cdr_decodes():
    """The encapsulation header says the byte order; a big-endian sender (00 00 00 00) is read
    as well (we always send little-endian, as ROS 2 on x86/ARM does)."""
    be = bytes.fromhex("00000000" "00000006") + b"hello\x00"
    assert wire.from_cdr(String, be) == String(data="hello")
    be = bytes.fromhex("00000000" "0000000000000002" "fffffffffffffffd")
    assert wire.from_cdr(AddTwoInts.Request, be) == AddTwoInts.Request(a=2, b=-3)


@pytest.mark.parametrize("t, data, match", [
    (String, b"", "not a CDR encapsulation header"),
    (String, b"\x01\x01\x00\x00\x01\x00\x00\x00\x00", "not a CDR encapsulation header"),
    (String, b"\x00\x01\x00\x00\xff\xff\xff\x7fab", "does not decode"),       # length > payload
    (String, b"\x00\x01\x00\x00\x03\x00\x00\x00abc", "does not decode"),      # no NUL
    (String, b"\x00\x01\x00\x00\x03\x00\x00\x00\xff\xfe\x00", "does not decode"),  # not UTF-8
    (AddTwoInts.Request, b"\x00\x01\x00\x00" + bytes(8), "does not decode"),      # truncated
    (AddTwoInts.Request, b"\x00\x01\x00\x00" + bytes(24), "left over"),           # too long
])
def test_undecodable_payloads_are_refused_with_the_reason(t, data, match):
    with pytest.raises(wire.CdrError, match=match) as err:
        wire.from_cdr(t, data)
    assert t._type in str(err.value)


def test_a_bound_broken_by_the_sender_is_refused_like_a_constructor_call():
    """CDR does not carry bounds: a sender with an unbounded definition may put 5 characters
    where ours allows 4 (Inner.tag is string<=4). The type's own check refuses the value."""
    data = wire.to_cdr(Inner(tag="abcd"))
    assert data.endswith(b"\x05\x00\x00\x00abcd\x00")
    longer = data[:-9] + b"\x06\x00\x00\x00abcde\x00"
    with pytest.raises(wire.CdrError, match="does not decode.*tag"):
        wire.from_cdr(Inner, longer)


def test_wstring_fields_are_refused_with_the_fix():
    @message("wire_test_msgs/msg/Wide", "wstring text\n")
    class Wide:
        pass
    with pytest.raises(TypeError, match="wstring.*use string"):
        wire.to_cdr(Wide())


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
