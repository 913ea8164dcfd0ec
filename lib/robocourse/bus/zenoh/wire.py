"""rmw_zenoh's wire format, byte for byte: type hashes, key expressions, attachments, tokens.

Counterparts (rmw_zenoh_cpp/src/detail/): ``liveliness_utils.cpp`` (data keys, liveliness
tokens, name mangling, ``qos_to_keyexpr``), ``attachment_helpers.cpp`` (the 33-byte
attachment), ``type_support.cpp`` (CDR with its encapsulation header), and ros2/rosidl
``rosidl_generator_type_description`` (REP-2011 ``RIHS01_`` type hashes). Everything here is
pure functions on bytes and strings, so it can be checked against the reference values
without a network. The CDR codec is rosbags' (``rosbags.serde``, the Python library for ROS
bags: it compiles a (de)serializer per type), fed with our field specs; no hand-written CDR.
The tests check its bytes against mcap-ros2-support's codec for every registered type.

Differences from rmw_zenoh: none in the bytes. Humble's ``TypeHashNotSupported`` keys are
not produced (we speak the Jazzy+ format, with the 2025 33-byte attachment).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import struct
import time
from dataclasses import dataclass

from robocourse.bus.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from robocourse.msgs._core import (
    REGISTRY,
    ServiceType,
    _has_ndarray,
    _require_type,
    _resolve,
)

ADMIN_SPACE = "@ros2_lv"
RIHS01_PREFIX = "RIHS01_"
ATTACHMENT_SIZE = 33
GID_SIZE = 16

# ---------------------------------------------------------------- REP-2011 type hashes
# rosidl type_description_interfaces/msg/FieldType ids; arrays add 48, bounded sequences 96,
# unbounded sequences 144. rosidl_adapter turns .msg `char` into IDL uint8, so char is 3.
FIELD_TYPE_IDS = {
    "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8,
    "uint64": 9, "float32": 10, "float64": 11, "char": 3, "wchar": 14, "bool": 15,
    "byte": 16, "string": 17, "wstring": 18,
}
NESTED_TYPE = 1
BOUNDED_STRING = 21
BOUNDED_WSTRING = 22
ARRAY, BOUNDED_SEQUENCE, UNBOUNDED_SEQUENCE = 48, 96, 144


def _field_type(spec) -> dict:
    string_capacity = 0
    nested = ""
    if spec.is_primitive:
        tid = FIELD_TYPE_IDS[spec.base_type]
        if spec.string_bound:
            string_capacity = int(spec.string_bound[2:])
            tid = BOUNDED_STRING if spec.base_type == "string" else BOUNDED_WSTRING
    else:
        tid = NESTED_TYPE
        nested = spec.base_type
    capacity = 0
    if spec.is_array:
        if spec.array_size is None:
            tid += UNBOUNDED_SEQUENCE
        elif spec.is_bounded:
            tid += BOUNDED_SEQUENCE
            capacity = spec.array_size
        else:
            tid += ARRAY
            capacity = spec.array_size
    return {"type_id": tid, "capacity": capacity, "string_capacity": string_capacity,
            "nested_type_name": nested}


def _fields(t) -> list[dict]:
    fields = [{"name": s.name, "type": _field_type(s)} for s in t._fields]
    if not fields:   # rosidl gives empty structures one placeholder member
        fields = [{"name": "structure_needs_at_least_one_member",
                   "type": {"type_id": 3, "capacity": 0, "string_capacity": 0,
                            "nested_type_name": ""}}]
    return fields


def _service_event(srv) -> dict:
    """The ``<Srv>_Event`` message Jazzy+ adds to every service's type description."""
    name = srv._type + "_Event"
    req, resp = srv.Request._type, srv.Response._type

    def nested(tid, cap, n):
        return {"type_id": tid, "capacity": cap, "string_capacity": 0, "nested_type_name": n}
    return {"type_name": name, "fields": [
        {"name": "info", "type": nested(NESTED_TYPE, 0, "service_msgs/msg/ServiceEventInfo")},
        {"name": "request", "type": nested(NESTED_TYPE + BOUNDED_SEQUENCE, 1, req)},
        {"name": "response", "type": nested(NESTED_TYPE + BOUNDED_SEQUENCE, 1, resp)}]}


_SERVICE_EVENT_INFO = {"type_name": "service_msgs/msg/ServiceEventInfo", "fields": [
    {"name": "event_type", "type": {"type_id": 3, "capacity": 0, "string_capacity": 0,
                                    "nested_type_name": ""}},
    {"name": "stamp", "type": {"type_id": 1, "capacity": 0, "string_capacity": 0,
                               "nested_type_name": "builtin_interfaces/msg/Time"}},
    {"name": "client_gid", "type": {"type_id": 3 + ARRAY, "capacity": 16, "string_capacity": 0,
                                    "nested_type_name": ""}},
    {"name": "sequence_number", "type": {"type_id": 8, "capacity": 0, "string_capacity": 0,
                                         "nested_type_name": ""}}]}


def type_description(t) -> dict:
    """The REP-2011 hashable TypeDescription of a message or service type (no default values,
    referenced types sorted by name), as ``rosidl_generator_type_description`` builds it."""
    refs: dict[str, dict] = {}
    # an action's inner services (Fibonacci_SendGoal, _GetResult) are not in REGISTRY
    services = {t._type: t} if isinstance(t, type) and issubclass(t, ServiceType) else {}

    def walk(desc):
        for f in desc["fields"]:
            n = f["type"]["nested_type_name"]
            if n and n not in refs:
                srv = services.get(n[:-6]) or REGISTRY.get(n[:-6])
                if n == _SERVICE_EVENT_INFO["type_name"]:
                    refs[n] = _SERVICE_EVENT_INFO
                elif n.endswith("_Event") and srv is not None:
                    refs[n] = _service_event(srv)
                else:
                    refs[n] = {"type_name": n, "fields": _fields(REGISTRY[n])}
                walk(refs[n])

    if isinstance(t, type) and issubclass(t, ServiceType):
        def nested(n):
            return {"type_id": NESTED_TYPE, "capacity": 0, "string_capacity": 0,
                    "nested_type_name": n}
        top = {"type_name": t._type, "fields": [
            {"name": "request_message", "type": nested(t.Request._type)},
            {"name": "response_message", "type": nested(t.Response._type)},
            {"name": "event_message", "type": nested(t._type + "_Event")}]}
    else:
        top = {"type_name": t._type, "fields": _fields(t)}
    walk(top)
    return {"type_description": top,
            "referenced_type_descriptions": [refs[k] for k in sorted(refs)]}


@functools.cache
def type_hash(t) -> str:
    """``RIHS01_<sha256 hex>`` of ``t`` (a message or service type), exactly as rosidl's
    ``calculate_type_hash``: SHA-256 of ``json.dumps`` with Python's default separators."""
    text = json.dumps(type_description(t), ensure_ascii=True, separators=(", ", ": "))
    return RIHS01_PREFIX + hashlib.sha256(text.encode()).hexdigest()


# ---------------------------------------------------------------- names and keys
def dds_type_name(type_name: str) -> str:
    """``std_msgs/msg/String`` -> ``std_msgs::msg::dds_::String_`` (services keep ``srv``)."""
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def strip_slashes(name: str) -> str:
    """rmw_zenoh's ``strip_slashes``: one leading and one trailing '/' removed."""
    if name.startswith("/"):
        name = name[1:]
    if name.endswith("/"):
        name = name[:-1]
    return name


def data_key(domain_id: int, name: str, t) -> str:
    """The data-plane key: ``<domain>/<name without leading '/'>/<dds type>/RIHS01_<hash>``."""
    return f"{domain_id}/{strip_slashes(name)}/{dds_type_name(t._type)}/{type_hash(t)}"


def mangle(name: str) -> str:
    """Every '/' becomes '%' (liveliness tokens cannot have empty chunks)."""
    return name.replace("/", "%")


def demangle(name: str) -> str:
    return name.replace("%", "/")


# ---------------------------------------------------------------- QoS in tokens
_DEFAULT_DEPTH = 42
_INFINITE_S, _INFINITE_NS = 9223372036, 854775807


def _duration(value) -> str:
    if value == math.inf or value is None:
        return ","
    ns = int(round(value * 1e9))
    s, rest = divmod(ns, 1_000_000_000)
    return f"{s},{rest}"


def qos_to_keyexpr(qos: QoSProfile) -> str:
    """rmw_zenoh's ``qos_to_keyexpr``: each number only when it differs from the default
    (RELIABLE, VOLATILE, KEEP_LAST, depth 42, infinite durations, AUTOMATIC)."""
    rel = qos.reliability
    rel = "" if rel in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.SYSTEM_DEFAULT) else str(int(rel))
    dur = qos.durability
    dur = "" if dur in (DurabilityPolicy.VOLATILE, DurabilityPolicy.SYSTEM_DEFAULT) else str(int(dur))
    hist = qos.history
    hist = "" if hist in (HistoryPolicy.KEEP_LAST, HistoryPolicy.SYSTEM_DEFAULT) else str(int(hist))
    depth = qos.depth or _DEFAULT_DEPTH
    depth = "" if depth == _DEFAULT_DEPTH else str(depth)
    live = qos.liveliness
    live = "" if live in (LivelinessPolicy.AUTOMATIC, LivelinessPolicy.SYSTEM_DEFAULT) else str(int(live))
    lease = _duration(qos.liveliness_lease_duration)
    return (f"{rel}:{dur}:{hist},{depth}:{_duration(qos.deadline)}:{_duration(qos.lifespan)}:"
            f"{live},{lease}")


def keyexpr_to_qos(text: str) -> QoSProfile:
    """Inverse of :func:`qos_to_keyexpr` (rmw_zenoh's ``keyexpr_to_qos``); ValueError if the
    string does not have the 6 ':' parts with 2/2/2/3 ',' subparts."""
    parts = text.split(":")
    if len(parts) < 6:
        raise ValueError(f"QoS string {text!r} has {len(parts)} ':' parts, needs 6 "
                         f"(e.g. '::,10:,:,:,,')")
    hist, deadline, lifespan, live = (p.split(",") for p in parts[2:6])
    if (len(hist), len(deadline), len(lifespan), len(live)) != (2, 2, 2, 3):
        raise ValueError(f"QoS string {text!r}: history, deadline, lifespan and liveliness "
                         f"need 2, 2, 2 and 3 ','-separated parts (e.g. '::,10:,:,:,,')")

    def dur(s, ns):
        if not s and not ns:
            return math.inf
        s, ns = int(s or _INFINITE_S), int(ns or _INFINITE_NS)
        return math.inf if (s, ns) == (_INFINITE_S, _INFINITE_NS) else s + ns * 1e-9

    history = HistoryPolicy(int(hist[0])) if hist[0] else HistoryPolicy.KEEP_LAST
    depth = int(hist[1]) if hist[1] else _DEFAULT_DEPTH
    return QoSProfile(
        history=history, depth=depth,
        reliability=ReliabilityPolicy(int(parts[0])) if parts[0] else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy(int(parts[1])) if parts[1] else DurabilityPolicy.VOLATILE,
        deadline=dur(*deadline), lifespan=dur(*lifespan),
        liveliness=LivelinessPolicy(int(live[0])) if live[0] else LivelinessPolicy.AUTOMATIC,
        liveliness_lease_duration=dur(live[1], live[2]))


# ---------------------------------------------------------------- liveliness tokens
KINDS = {"NN": "node", "MP": "publisher", "MS": "subscription", "SS": "service server",
         "SC": "service client"}


def node_token(domain_id, zid, node_id, namespace, name, enclave="/") -> str:
    return (f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{node_id}/NN/{mangle(enclave)}/"
            f"{mangle(namespace)}/{name}")


def endpoint_token(domain_id, zid, node_id, entity_id, kind, namespace, node_name, topic, t,
                   qos, enclave="/") -> str:
    if kind not in KINDS or kind == "NN":
        raise ValueError(f"endpoint kind {kind!r} must be one of MP, MS, SS, SC")
    return (f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{entity_id}/{kind}/{mangle(enclave)}/"
            f"{mangle(namespace)}/{node_name}/{mangle(topic)}/{mangle(dds_type_name(t._type))}/"
            f"{mangle(type_hash(t))}/{qos_to_keyexpr(qos)}")


@dataclass(frozen=True)
class Entity:
    """One parsed liveliness token (rmw_zenoh's ``Entity``)."""

    key: str
    domain_id: int
    zid: str
    node_id: str
    entity_id: str
    kind: str
    enclave: str
    namespace: str
    node_name: str
    topic: str = ""
    type_name: str = ""         # "std_msgs/msg/String" (from the dds name)
    type_hash: str = ""
    qos: QoSProfile | None = None

    @property
    def node_fqn(self) -> str:
        return (self.namespace.rstrip("/") + "/" + self.node_name) if self.namespace != "/" \
            else "/" + self.node_name

    @property
    def gid(self) -> bytes:
        return gid_of(self.key)


def parse_token(key: str) -> Entity:
    """Parse a liveliness token; ValueError (naming the rule) for anything rmw_zenoh rejects:
    another admin space, an empty chunk, an unknown kind, the wrong number of chunks."""
    parts = str(key).split("/")
    if parts[0] != ADMIN_SPACE:
        raise ValueError(f"token {key!r}: admin space must be {ADMIN_SPACE!r}")
    if any(not p for p in parts):
        raise ValueError(f"token {key!r} has an empty chunk (names must be mangled, '/' -> '%')")
    if len(parts) < 9:
        raise ValueError(f"token {key!r} has {len(parts)} chunks; a node token has 9")
    kind = parts[5]
    if kind not in KINDS:
        raise ValueError(f"token {key!r}: unknown entity kind {kind!r} (one of {list(KINDS)})")
    try:
        domain = int(parts[1])
    except ValueError:
        raise ValueError(f"token {key!r}: domain {parts[1]!r} is not an integer") from None
    common = dict(key=key, domain_id=domain, zid=parts[2], node_id=parts[3],
                  entity_id=parts[4], kind=kind, enclave=demangle(parts[6]),
                  namespace=demangle(parts[7]), node_name=parts[8])
    if kind == "NN":
        if len(parts) != 9:
            raise ValueError(f"token {key!r}: a node token has 9 chunks, found {len(parts)}")
        return Entity(**common)
    if len(parts) not in (13, 14):
        raise ValueError(f"token {key!r}: an endpoint token has 13 chunks, found {len(parts)}")
    dds = demangle(parts[10])
    pieces = dds.split("::")
    if len(pieces) != 4 or pieces[2] != "dds_" or not pieces[3].endswith("_"):
        raise ValueError(f"token {key!r}: type {dds!r} is not '<pkg>::msg::dds_::<Type>_'")
    return Entity(**common, topic=demangle(parts[9]),
                  type_name=f"{pieces[0]}/{pieces[1]}/{pieces[3][:-1]}",
                  type_hash=demangle(parts[11]), qos=keyexpr_to_qos(parts[12]))


def gid_of(key: str) -> bytes:
    """The entity GID: XXH3-128 of the token, low 64 bits first, little-endian (16 bytes)."""
    import xxhash

    return xxhash.xxh3_128_intdigest(key.encode()).to_bytes(16, "little")


# ---------------------------------------------------------------- attachment
#: the attachment's layout: int64 sequence number, int64 source timestamp, LEB128 16, GID
ATTACHMENT = struct.Struct("<qqB16s")


def encode_attachment(sequence_number: int, gid: bytes, source_timestamp_ns: int | None = None) -> bytes:
    """33 bytes: int64 LE sequence number, int64 LE source timestamp (ns since 1970, wall
    time), LEB128 length 16, the 16-byte GID (zenoh's serializer, as attachment_helpers.cpp)."""
    if len(gid) != GID_SIZE:
        raise ValueError(f"gid has {len(gid)} bytes; a GID has {GID_SIZE}")
    if source_timestamp_ns is None:
        source_timestamp_ns = time.time_ns()
    return ATTACHMENT.pack(sequence_number, source_timestamp_ns, GID_SIZE, bytes(gid))


@dataclass(frozen=True)
class Attachment:
    sequence_number: int
    source_timestamp_ns: int
    gid: bytes


def attachment_ok(data: bytes) -> bool:
    """True when ``data`` has the 33-byte form :func:`decode_attachment` accepts (the hot
    receive path only validates; it never needs the fields)."""
    return len(data) == ATTACHMENT_SIZE and data[16] == GID_SIZE


def attachment_packer(gid: bytes):
    """``pack(sequence_number, source_timestamp_ns) -> bytes``: :func:`encode_attachment`
    with the GID checked and bound once (a publisher's GID never changes)."""
    if len(gid) != GID_SIZE:
        raise ValueError(f"gid has {len(gid)} bytes; a GID has {GID_SIZE}")
    pack, gid = ATTACHMENT.pack, bytes(gid)
    return lambda seq, ts: pack(seq, ts, GID_SIZE, gid)


def decode_attachment(data: bytes) -> Attachment:
    """Inverse of :func:`encode_attachment`; ValueError for anything but the 33-byte form
    (e.g. the 77-byte named-field form of rmw_zenoh before mid-2025)."""
    data = bytes(data)
    if len(data) != ATTACHMENT_SIZE or data[16] != GID_SIZE:
        raise ValueError(f"attachment of {len(data)} bytes is not rmw_zenoh's 33-byte form "
                         f"(int64 seq, int64 timestamp, 0x10, 16-byte gid)")
    seq, ts, _, gid = ATTACHMENT.unpack(data)
    return Attachment(seq, ts, gid)


# ---------------------------------------------------------------- CDR payload
# rosbags' CDR codec (rosbags.serde): per type it compiles straight-line Python that packs and
# unpacks the fields with struct, alignment worked out once. Our message classes are registered
# as its classes, so decoding calls our generated constructor (rclpy's field checks) directly.
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4         # rosbags.interfaces.Nodetype
#: the member rosidl adds to an empty structure (one uint8 0 on the wire)
_EMPTY_MEMBER = "structure_needs_at_least_one_member"


class CdrError(ValueError):
    """A payload that is not a valid CDR encoding of the expected type."""


@functools.cache
def _store():
    from rosbags.typesys.store import Typestore

    return Typestore()


def _field_desc(spec, owner):
    if spec.is_primitive:
        if spec.base_type == "wstring":
            raise TypeError(f"{owner}.{spec.name}: wstring fields cannot be carried by the zenoh "
                            f"transport (the CDR codec, rosbags, has no wstring); use string")
        bound = int(spec.string_bound[2:]) if spec.string_bound else 0
        # byte and char are one octet 0..255 in ROS 2 (rosbags' byte is signed, ROS 1's int8)
        base = "uint8" if spec.base_type in ("byte", "char") else spec.base_type
        desc = (_BASE, (base, bound))
    else:
        desc = (_NAME, _resolve(spec.base_type)._type)
    if not spec.is_array:
        return desc
    if spec.array_size is not None and not spec.is_bounded:
        return (_ARRAY, (desc, spec.array_size))
    return (_SEQUENCE, (desc, spec.array_size or 0))


def _register(t) -> None:
    """Register ``t`` and every type it nests in the codec's store, ``t`` itself as the class
    rosbags builds (empty types keep rosbags' own class with rosidl's placeholder member)."""
    store = _store()
    if t._type in store.fielddefs:
        return
    fields = []
    for spec in t._fields:
        if not spec.is_primitive:
            _register(_resolve(spec.base_type))
        fields.append((spec.name, _field_desc(spec, t._type)))
    if not fields:
        store.register({t._type: ([], [(_EMPTY_MEMBER, (_BASE, ("uint8", 0)))])})
        return
    store.register({t._type: ([], fields)})
    store.types[t._type] = t


@functools.cache
def _msgdef(t):
    _require_type(t, "CDR codec")
    _register(t)
    return _store().get_msgdef(t._type)


@functools.cache
def _wire_viewer(t):
    """None when rosbags' serializer takes ``t``'s messages as they are, else
    ``view(msg) -> object`` with the same fields where rosbags needs numpy: numeric
    sequences (``array.array`` -> a zero-copy ``numpy.frombuffer``), bool arrays (lists),
    fixed numeric arrays made contiguous; nested messages viewed in turn."""
    import types

    import numpy as np

    from robocourse.msgs._fields import _NUMPY

    parts, needed = [], False
    for spec in t._fields:
        conv = None
        if spec.is_primitive and spec.is_array and spec.base_type == "bool":
            conv = lambda v: np.array(v, dtype=np.bool_)                     # noqa: E731
        elif spec.is_primitive and spec.is_array and spec.base_type in _NUMPY:
            dtype = np.dtype(_NUMPY[spec.base_type])
            if spec.is_fixed_array:
                conv = np.ascontiguousarray
            else:
                conv = lambda v, d=dtype: np.frombuffer(v, dtype=d)          # noqa: E731
        elif not spec.is_primitive:
            sub = _wire_viewer(_resolve(spec.base_type))
            if sub is not None:
                conv = (lambda v, sub=sub: [sub(x) for x in v]) if spec.is_array else sub
        needed = needed or conv is not None
        parts.append((spec.name, conv))
    if not needed:
        return None
    parts = tuple(parts)
    space = types.SimpleNamespace

    def view(msg):
        kw = {}
        for name, conv in parts:
            v = getattr(msg, name)
            kw[name] = v if conv is None else conv(v)
        return space(**kw)
    return view


@functools.cache
def encoder(t, buffer: bool = False):
    """``encode(msg) -> bytes`` for messages of type ``t``, little-endian with the encapsulation
    header (a publisher's hot path: rosbags' generated functions bound once). ``buffer=True``
    returns the ``bytearray`` it filled (what zenoh's ``put`` takes) instead of a bytes copy."""
    md, store = _msgdef(t), _store()
    if not t._fields:
        data = bytes(store.serialize_cdr(md.cls(0), t._type, little_endian=True))
        return lambda msg: data
    size, getsize, ser = md.size_cdr, md.getsize_cdr, md.serialize_cdr_le
    view = _wire_viewer(t)

    def encode(msg):
        raw = bytearray(4 + (size or getsize(0, msg, store)))
        raw[1] = 1                                  # 00 01 00 00: CDR, little-endian
        ser(memoryview(raw)[4:], 0, msg, store)
        return raw
    if view is not None:
        plain = encode
        encode = lambda msg: plain(view(msg))                            # noqa: E731
    if buffer:
        return encode
    return lambda msg: bytes(encode(msg))


@functools.cache
def decoder(t):
    """``decode(data) -> message of type t`` (a subscription's hot path). Either byte order;
    ``CdrError`` naming the type for anything that is not ``t`` in CDR. The message is built
    by its own constructor (the same checks as any ``t(...)``); its arrays own their memory."""
    md, store = _msgdef(t), _store()
    le, be, cls = md.deserialize_cdr_le, md.deserialize_cdr_be, md.cls
    if not t._fields:
        finish = lambda msg: t()                                           # noqa: E731
    elif _has_ndarray(t):     # fixed numeric arrays are read-only views of the payload
        finish = t._copy
    else:
        finish = None

    def decode(data):
        try:
            if len(data) < 4 or data[0]:
                raise CdrError(f"{t._type}: payload starts {bytes(data[:4]).hex(' ')}, not a "
                               f"CDR encapsulation header (00 01 00 00 little-endian or 00 00 "
                               f"00 00 big-endian)")
            msg, pos = (le if data[1] else be)(data[4:], 0, cls, store)
        except CdrError:
            raise
        except Exception as exc:  # noqa: BLE001 - rosbags' SerdeError, struct.error, our checks
            raise CdrError(f"{t._type}: the {len(data)}-byte payload does not decode: "
                           f"{type(exc).__name__}: {exc}") from None
        if pos + 7 < len(data):     # CDR pads to 4 bytes at most (rosbags checks the same)
            raise CdrError(f"{t._type}: {len(data) - 4 - pos} bytes left over after the "
                           f"message: the sender uses another definition of the type")
        return msg if finish is None else finish(msg)
    return decode


def to_cdr(msg) -> bytes:
    """ROS 2 CDR with the 4-byte encapsulation header (``00 01 00 00``, little-endian)."""
    return encoder(type(msg))(msg)


def from_cdr(t, data: bytes):
    """CDR bytes -> a message of type ``t`` (checked like a constructor call); ``CdrError``
    for a payload that is not ``t`` in CDR."""
    _require_type(t, "from_cdr")
    return decoder(t)(bytes(data))
