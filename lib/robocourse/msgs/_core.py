"""Message machinery: build dataclass types from ROS 2 .msg / .srv / .action text.

rclpy counterpart: the Python classes that ``rosidl_generator_py`` generates from .msg files
(``from geometry_msgs.msg import Twist``). Here the .msg text is the single source: the
``message`` decorator parses it and turns a class into a slotted dataclass whose fields, types
and defaults follow the ROS definition. Differences from rosidl-generated classes:

- field values are checked on construction and assignment with rclpy's rules and wording plus
  the field path and a fix (``robocourse.msgs._fields``); robocourse also accepts an ``int`` in
  a float field (stored as float; rclpy rejects it) and numpy arrays for sequences;
- numeric sequences are ``array.array`` and numeric fixed arrays ``numpy.ndarray`` as in rclpy;
  ``byte``/``char`` fields hold ints 0..255 (rclpy: ``bytes``/``str`` of length 1);
- a message can be built with positional arguments in field order (rclpy: keywords only);
- every type has ``_copy()``, a generated deep copy the bus uses for value semantics.

A chapter adds its own type the same way as the built-in ones::

    from robocourse.msgs import message

    @message("mycar_msgs/msg/WheelSpeeds", '''
    std_msgs/Header header
    float64 left   # rad/s
    float64 right  # rad/s
    ''')
    class WheelSpeeds:
        def mean(self):            # methods are allowed; fields come from the text
            return 0.5 * (self.left + self.right)

Services use :func:`service` (request and response separated by ``---``) and actions
:func:`action` (goal, result and feedback separated by ``---``).
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass as _dataclass
from typing import Any

import numpy as np

from robocourse.msgs._fields import (
    FieldRule,
    MessageFieldError,
    MessageFieldRangeError,
    build_methods,
    default_maker,
)

#: Primitive ROS field types -> (python type, default value).
PRIMITIVES: dict[str, tuple[type, Any]] = {
    "bool": (bool, False),
    "byte": (int, 0),
    "char": (int, 0),
    "int8": (int, 0),
    "uint8": (int, 0),
    "int16": (int, 0),
    "uint16": (int, 0),
    "int32": (int, 0),
    "uint32": (int, 0),
    "int64": (int, 0),
    "uint64": (int, 0),
    "float32": (float, 0.0),
    "float64": (float, 0.0),
    "string": (str, ""),
    "wstring": (str, ""),
}

INT_RANGES = {
    "byte": (0, 255), "char": (0, 255), "int8": (-(2**7), 2**7 - 1), "uint8": (0, 2**8 - 1),
    "int16": (-(2**15), 2**15 - 1), "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1), "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1), "uint64": (0, 2**64 - 1),
}

NUMPY_DTYPES = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
}

#: Every registered type, by full name ("geometry_msgs/msg/Twist").
REGISTRY: dict[str, type] = {}

_NAME_RE = re.compile(r"^([a-z][a-z0-9_]*)/(msg|srv|action)/([A-Z][A-Za-z0-9]*)$")
_FIELD_NAME_RE = re.compile(r"^[a-z][a-z0-9_]*$")
_CONST_NAME_RE = re.compile(r"^[A-Z][A-Z0-9_]*$")
_TYPE_RE = re.compile(
    r"^(?P<base>[A-Za-z][A-Za-z0-9_/]*)(?P<strbound><=\d+)?(?P<arr>\[(?P<bound><=)?(?P<size>\d*)\])?$")


class MessageDefinitionError(ValueError):
    """A .msg/.srv/.action text or type name that does not follow the ROS 2 rules."""


@_dataclass(frozen=True)
class FieldSpec:
    """One field of a message definition (name, ROS type, array shape, default)."""

    name: str
    base_type: str            # "float64", "string" or a full type "geometry_msgs/msg/Vector3"
    is_array: bool = False
    array_size: int | None = None   # fixed size N for T[N]; bound for T[<=N]; None unbounded
    is_bounded: bool = False
    default_text: str | None = None
    string_bound: str = ""

    @property
    def is_primitive(self) -> bool:
        return self.base_type in PRIMITIVES

    @property
    def is_fixed_array(self) -> bool:
        return self.is_array and self.array_size is not None and not self.is_bounded


def _split_comment(line: str) -> str:
    # '#' starts a comment except inside a quoted string default.
    out, quote = [], None
    for ch in line:
        if quote:
            out.append(ch)
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
            out.append(ch)
        elif ch == "#":
            break
        else:
            out.append(ch)
    return "".join(out).strip()


def _parse_literal(base: str, text: str, where: str):
    text = text.strip()
    if base in ("string", "wstring"):
        if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
            return text[1:-1]
        return text
    if base == "bool":
        low = text.lower()
        if low in ("true", "1"):
            return True
        if low in ("false", "0"):
            return False
        raise MessageDefinitionError(f"{where}: bool default must be true/false, got {text!r}")
    try:
        if base in ("float32", "float64"):
            return float(text)
        value = int(text, 0)
    except ValueError:
        raise MessageDefinitionError(f"{where}: cannot parse {text!r} as {base}") from None
    lo, hi = INT_RANGES[base]
    if not lo <= value <= hi:
        raise MessageDefinitionError(f"{where}: {value} out of range for {base} [{lo}, {hi}]")
    return value


def _parse_default(spec: FieldSpec, where: str):
    if spec.default_text is None:
        return None
    if spec.is_array:
        body = spec.default_text.strip()
        if not (body.startswith("[") and body.endswith("]")):
            raise MessageDefinitionError(f"{where}: array default must be [a, b, ...]")
        items = [s for s in body[1:-1].split(",") if s.strip()]
        return [_parse_literal(spec.base_type, s, where) for s in items]
    return _parse_literal(spec.base_type, spec.default_text, where)


def parse_definition(text: str, package: str, where: str = "definition"):
    """Parse .msg text -> (fields, constants). Nested types become full names.

    ``package`` resolves short names (``Vector3`` inside geometry_msgs). ``Header`` alone is
    accepted as ``std_msgs/msg/Header`` like ROS 2's rosidl does for compatibility.
    """
    fields: list[FieldSpec] = []
    constants: dict[str, Any] = {}
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = _split_comment(raw)
        if not line:
            continue
        loc = f"{where}, line {lineno} ({raw.strip()!r})"
        parts = line.split(None, 1)
        if len(parts) != 2:
            raise MessageDefinitionError(f"{loc}: expected '<type> <name>'")
        type_text, rest = parts
        m = _TYPE_RE.match(type_text)
        if not m:
            raise MessageDefinitionError(f"{loc}: malformed type {type_text!r}")
        base = m.group("base")
        if "=" in rest.split(None, 1)[0] or re.match(r"^[A-Z][A-Z0-9_]*\s*=", rest):
            cname, _, ctext = rest.partition("=")
            cname = cname.strip()
            if not _CONST_NAME_RE.match(cname):
                raise MessageDefinitionError(f"{loc}: constant name {cname!r} must be UPPER_CASE")
            if base not in PRIMITIVES or m.group("arr"):
                raise MessageDefinitionError(f"{loc}: constants must have a primitive type")
            constants[cname] = _parse_literal(base, ctext, loc)
            continue
        name_default = rest.split(None, 1)
        fname = name_default[0]
        default_text = name_default[1] if len(name_default) == 2 else None
        if not _FIELD_NAME_RE.match(fname) or "__" in fname or fname.endswith("_"):
            raise MessageDefinitionError(
                f"{loc}: field name {fname!r} must be lower_snake_case (letters, digits, single _)")
        if base not in PRIMITIVES:
            if base == "Header":
                base = "std_msgs/msg/Header"
            elif "/" not in base:
                base = f"{package}/msg/{base}"
            elif base.count("/") == 1:
                pkg, name = base.split("/")
                base = f"{pkg}/msg/{name}"
            if default_text is not None:
                raise MessageDefinitionError(f"{loc}: nested message fields cannot have defaults")
        arr = m.group("arr")
        size = m.group("size")
        spec = FieldSpec(
            name=fname, base_type=base, is_array=bool(arr),
            array_size=int(size) if size else None, is_bounded=bool(m.group("bound")),
            default_text=default_text, string_bound=m.group("strbound") or "")
        _parse_default(spec, loc)  # validate now so errors name the line
        fields.append(spec)
    return fields, constants


def _check_text_args(what: str, type_name, definition) -> None:
    if not isinstance(type_name, str):
        raise TypeError(f"{what}(type_name, definition): type_name={type_name!r} must be a str "
                        f"such as 'my_pkg/msg/MyType'")
    if not isinstance(definition, str):
        raise TypeError(f"{what}({type_name!r}, definition): definition={definition!r:.60} must be "
                        f"the .msg/.srv/.action text as a str, e.g. 'float64 x\\nfloat64 y'")


def _resolve(type_name: str) -> type:
    try:
        return REGISTRY[type_name]
    except KeyError:
        raise MessageDefinitionError(
            f"unknown message type {type_name!r}: define it (with @message) before the types "
            f"that use it, or import the module that defines it") from None


class _Constants:
    pass


def message(type_name: str, definition: str):
    """Class decorator: make a ROS 2 message type from its .msg ``definition``.

    The class becomes a slotted dataclass with one field per line of the definition (ROS
    names and defaults), constants become class attributes, and it carries
    ``_type`` ("pkg/msg/Name"), ``_definition`` (the .msg text) and ``_fields`` (FieldSpec).
    """
    _check_text_args("message", type_name, definition)
    m = _NAME_RE.match(type_name)
    if not m:
        raise MessageDefinitionError(
            f"message type name {type_name!r} must look like 'my_pkg/msg/MyType' "
            f"(lowercase package, 'msg', CamelCase name)")
    return _builder(type_name, definition, m.group(1))


def _builder(type_name: str, definition: str, package: str):
    fields, constants = parse_definition(definition, package, where=type_name)

    def wrap(cls):
        if not isinstance(cls, type):
            raise TypeError(f"@message({type_name!r}, ...) decorates a class, got {cls!r}")
        rules, defaults = {}, {}
        for spec in fields:
            nested = None if spec.is_primitive else _resolve(spec.base_type)
            rules[spec.name] = FieldRule(spec, type_name, nested, INT_RANGES)
            defaults[spec.name] = default_maker(spec, _parse_default(spec, type_name), nested)
        namespace = {k: v for k, v in cls.__dict__.items()
                     if k not in ("__dict__", "__weakref__", "__slots__")}
        namespace["__slots__"] = tuple(s.name for s in fields)
        namespace["__annotations__"] = {s.name: Any for s in fields}
        namespace["__hash__"] = None          # mutable value type, like rclpy's classes
        namespace.setdefault("__repr__", _message_repr)
        new_cls = type(cls.__name__, cls.__bases__, namespace)
        new_cls.__module__ = cls.__module__
        new_cls.__qualname__ = cls.__qualname__
        for cname, cvalue in constants.items():
            setattr(new_cls, cname, cvalue)
        new_cls._type = type_name
        new_cls._definition = definition.strip("\n")
        new_cls._fields = tuple(fields)
        new_cls._constants = dict(constants)
        new_cls.__doc__ = (cls.__doc__ or f"ROS 2 message {type_name}.") + (
            f"\n\nDefinition ({type_name}):\n\n" + _indent(definition.strip("\n")))
        build_methods(new_cls, fields, rules, defaults)
        new_cls.__copy__ = new_cls._copy
        new_cls.__deepcopy__ = lambda self, memo=None: self._copy()
        if type_name in REGISTRY and REGISTRY[type_name]._definition != new_cls._definition:
            raise MessageDefinitionError(
                f"{type_name} is already registered with a different definition; "
                f"pick another type name for your own message")
        REGISTRY[type_name] = new_cls
        definition_name(type_name)   # records the alias of '_' names for look-ups
        return new_cls

    return wrap


def _message_repr(self) -> str:
    return f"{type(self).__name__}(" + ", ".join(
        f"{s.name}={getattr(self, s.name)!r}" for s in self._fields) + ")"


def _indent(text: str) -> str:
    return "\n".join("    " + line for line in text.splitlines())


def make_message(type_name: str, definition: str) -> type:
    """Functional form of :func:`message`: ``Foo = make_message("pkg/msg/Foo", "int32 a")``."""
    name = type_name.rsplit("/", 1)[-1]
    return message(type_name, definition)(type(name, (), {"__module__": __name__}))


class ServiceType:
    """Base of service types: ``AddTwoInts.Request`` / ``AddTwoInts.Response`` (rosidl shape)."""

    Request: type
    Response: type
    _type: str
    _definition: str


class ActionType:
    """Base of action types: ``Goal``/``Result``/``Feedback`` and the ``Impl`` wire types."""

    Goal: type
    Result: type
    Feedback: type
    _type: str
    _definition: str


def _split_parts(text: str, n: int, type_name: str) -> list[str]:
    parts = re.split(r"^---\s*$", text, flags=re.M)
    if len(parts) != n:
        raise MessageDefinitionError(
            f"{type_name}: expected {n} parts separated by '---' lines, found {len(parts)}")
    return [p.strip("\n") for p in parts]


def service(type_name: str, definition: str) -> type:
    """Make a service type from .srv text (request ``---`` response)."""
    _check_text_args("service", type_name, definition)
    m = _NAME_RE.match(type_name)
    if not m or m.group(2) != "srv":
        raise MessageDefinitionError(f"service type name {type_name!r} must look like 'pkg/srv/Name'")
    pkg, name = m.group(1), m.group(3)
    req_text, resp_text = _split_parts(definition, 2, type_name)
    req = _make_sub(f"{pkg}/srv/{name}_Request", req_text, pkg)
    resp = _make_sub(f"{pkg}/srv/{name}_Response", resp_text, pkg)
    cls = type(name, (ServiceType,), {"Request": req, "Response": resp, "_type": type_name,
                                      "_definition": definition.strip("\n"),
                                      "__doc__": f"ROS 2 service {type_name}.\n\n" + _indent(definition.strip("\n"))})
    REGISTRY[type_name] = cls
    return cls


def _make_sub(full: str, text: str, pkg: str) -> type:
    """Request/Response/Goal... parts: registered as 'pkg/srv/Name_Request' like rosidl."""
    short = full.rsplit("/", 1)[-1]
    return _builder(full, text, pkg)(type(short, (), {"__module__": __name__}))


def action(type_name: str, definition: str) -> type:
    """Make an action type from .action text (goal ``---`` result ``---`` feedback).

    Besides ``Goal``, ``Result`` and ``Feedback`` the type carries the wire types rclpy uses
    under ``Impl``: ``SendGoalService``, ``GetResultService`` and ``FeedbackMessage``.
    """
    _check_text_args("action", type_name, definition)
    m = _NAME_RE.match(type_name)
    if not m or m.group(2) != "action":
        raise MessageDefinitionError(f"action type name {type_name!r} must look like 'pkg/action/Name'")
    pkg, name = m.group(1), m.group(3)
    g, r, f = _split_parts(definition, 3, type_name)
    goal = _make_sub(f"{pkg}/action/{name}_Goal", g, pkg)
    result = _make_sub(f"{pkg}/action/{name}_Result", r, pkg)
    feedback = _make_sub(f"{pkg}/action/{name}_Feedback", f, pkg)
    base = f"{pkg}/action/{name}"
    # The wire types reference the parts by their full names; make them resolvable.
    send_goal = _impl_service(f"{base}_SendGoal", [
        ("unique_identifier_msgs/msg/UUID", "goal_id"), (goal._type, "goal")],
        [("bool", "accepted"), ("builtin_interfaces/msg/Time", "stamp")])
    get_result = _impl_service(f"{base}_GetResult", [
        ("unique_identifier_msgs/msg/UUID", "goal_id")],
        [("int8", "status"), (result._type, "result")])
    fb_fields = [("unique_identifier_msgs/msg/UUID", "goal_id"), (feedback._type, "feedback")]
    fb_msg = _impl_message(f"{base}_FeedbackMessage", fb_fields)
    impl = type("Impl", (), {"SendGoalService": send_goal, "GetResultService": get_result,
                             "FeedbackMessage": fb_msg,
                             "CancelGoalService": REGISTRY.get("action_msgs/srv/CancelGoal"),
                             "GoalStatusMessage": REGISTRY.get("action_msgs/msg/GoalStatusArray")})
    cls = type(name, (ActionType,), {"Goal": goal, "Result": result, "Feedback": feedback,
                                     "Impl": impl, "_type": type_name,
                                     "_definition": definition.strip("\n"),
                                     "__doc__": f"ROS 2 action {type_name}.\n\n" + _indent(definition.strip("\n"))})
    REGISTRY[type_name] = cls
    return cls


def _impl_message(full: str, fields: list[tuple[str, str]]) -> type:
    text = "\n".join(f"{t} {n}" for t, n in fields)
    pkg = full.split("/", 1)[0]
    return _make_sub(full, text, pkg)


def _impl_service(full: str, req, resp) -> type:
    req_cls = _impl_message(full + "_Request", req)
    resp_cls = _impl_message(full + "_Response", resp)
    return type(full.rsplit("/", 1)[-1], (ServiceType,), {
        "Request": req_cls, "Response": resp_cls, "_type": full, "_definition": ""})


# --------------------------------------------------------------------------- helpers


def is_message_type(obj) -> bool:
    return isinstance(obj, type) and hasattr(obj, "_fields") and hasattr(obj, "_type")


def get_message_type(type_name: str) -> type:
    """Look up a registered type by full name (``"geometry_msgs/msg/Twist"``) or ``pkg/Name``."""
    if not isinstance(type_name, str) or type_name.count("/") not in (1, 2):
        raise MessageDefinitionError(
            f"get_message_type: {type_name!r} must be a type name such as "
            f"'geometry_msgs/msg/Twist' or 'geometry_msgs/Twist'")
    if type_name.count("/") == 1:
        if type_name in ALIASES:
            return _resolve(ALIASES[type_name])
        pkg, name = type_name.split("/")
        type_name = f"{pkg}/msg/{name}"
    else:
        alias = definition_name(type_name)
        if alias in ALIASES and type_name not in REGISTRY:
            return _resolve(ALIASES[alias])
    return _resolve(type_name)


#: "pkg/Name" used in definitions -> full type name, for the rosidl-generated parts whose
#: names contain '_' (Fibonacci_Goal): the ROS 2 .msg parser only accepts [A-Z][A-Za-z0-9]*,
#: so definitions and MCAP schemas spell them without '_' (Fibonacci_Goal -> FibonacciGoal).
ALIASES: dict[str, str] = {}


def definition_name(type_name: str) -> str:
    """The ``pkg/Name`` spelling of a type in .msg text and MCAP schemas."""
    pkg, _, name = type_name.split("/")
    if "_" in name:
        alias = f"{pkg}/{name.replace('_', '')}"
        ALIASES[alias] = type_name
        return alias
    return f"{pkg}/{name}"


def _ros_type_name(spec: FieldSpec) -> str:
    if spec.is_primitive:
        base = spec.base_type + spec.string_bound
    else:
        base = definition_name(spec.base_type)
    if spec.is_array:
        if spec.array_size is None:
            return base + "[]"
        return base + (f"[<={spec.array_size}]" if spec.is_bounded else f"[{spec.array_size}]")
    return base


def full_definition(msg_type: type) -> str:
    """The .msg text with every nested definition appended (``====`` / ``MSG: pkg/Type``).

    This is the concatenated form ROS 2 bags and MCAP files (ros2msg encoding) carry, and what
    ``mcap_ros2.writer.Writer.register_msgdef`` parses. Nested types are written ``pkg/Type``.
    """
    def own_text(t: type) -> str:
        lines = []
        for cname, cval in t._constants.items():
            ctype = _const_type(t, cname)
            lines.append(f"{ctype} {cname}={_literal(cval)}")
        for spec in t._fields:
            line = f"{_ros_type_name(spec)} {spec.name}"
            if spec.default_text is not None:
                line += f" {spec.default_text.strip()}"
            lines.append(line)
        return "\n".join(lines)

    seen: list[str] = []

    def walk(t: type):
        for spec in t._fields:
            if not spec.is_primitive and spec.base_type not in seen:
                seen.append(spec.base_type)
                walk(_resolve(spec.base_type))

    walk(msg_type)
    out = [own_text(msg_type)]
    for name in seen:
        out.append("=" * 80 + f"\nMSG: {definition_name(name)}\n" + own_text(_resolve(name)))
    return "\n".join(out) + "\n"


def _const_type(t: type, cname: str) -> str:
    for raw in t._definition.splitlines():
        line = _split_comment(raw)
        if not line:
            continue
        ty, _, rest = line.partition(" ")
        if rest.replace(" ", "").startswith(cname + "="):
            return ty
    return "int32"


def _literal(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v + '"'
    return repr(v)


def _require_message(msg, what: str) -> None:
    if not is_message_type(type(msg)):
        raise TypeError(f"{what} needs a message object (e.g. Twist()), got {msg!r:.80} of type "
                        f"{type(msg).__name__}; build one first, e.g. {what}(Float64(data=1.0))")


def _require_type(msg_type, what: str) -> None:
    if not is_message_type(msg_type):
        raise TypeError(f"{what} needs a message type (a class such as Twist, made with "
                        f"@message), got {msg_type!r:.80}; e.g. {what}(Twist, ...)")


def to_dict(msg) -> dict:
    """Message -> plain nested dict/list (ROS field names), e.g. for YAML or JSON."""
    _require_message(msg, "to_dict")
    return _to_dict(msg)


def _to_dict(msg) -> dict:
    out = {}
    for spec in msg._fields:
        v = getattr(msg, spec.name)
        if spec.is_primitive:
            out[spec.name] = (v.tolist() if hasattr(v, "tolist") else list(v)) if spec.is_array else v
        elif spec.is_array:
            out[spec.name] = [_to_dict(x) for x in v]
        else:
            out[spec.name] = _to_dict(v)
    return out


@functools.cache
def _has_ndarray(msg_type: type) -> bool:
    for spec in msg_type._fields:
        if spec.is_primitive:
            if spec.is_fixed_array and spec.base_type in NUMPY_DTYPES:
                return True
        elif _has_ndarray(_resolve(spec.base_type)):
            return True
    return False


def wire_view(msg):
    """What the ROS 2 CDR encoder (mcap_ros2) accepts for ``msg``: the message itself, or a
    plain dict for types holding numpy fixed arrays (the encoder takes lists, not ndarrays)."""
    return _to_dict(msg) if _has_ndarray(type(msg)) else msg


def from_dict(msg_type: type, data) -> Any:
    """Plain dict (or any object with the fields as attributes) -> message of ``msg_type``.

    Missing keys keep their defaults; unknown keys raise ``KeyError`` naming the field; values
    are checked like constructor arguments.
    """
    _require_type(msg_type, "from_dict")
    return _from_dict(msg_type, data)


@functools.cache
def _field_map(msg_type: type) -> dict:
    return {s.name: s for s in msg_type._fields}


def _from_dict(msg_type: type, data) -> Any:
    msg = msg_type()
    names = _field_map(msg_type)
    if isinstance(data, dict):
        items = data.items()
        unknown = [k for k in data if k not in names]
        if unknown:
            raise KeyError(f"{msg_type._type} has no field(s) {unknown}; fields: {list(names)}")
    else:
        items = [(n, getattr(data, n)) for n in names if hasattr(data, n)]
    for key, value in items:
        spec = names[key]
        if spec.is_primitive:
            if isinstance(value, (bytes, bytearray)) and not spec.is_array and \
                    spec.base_type in ("byte", "uint8", "char"):
                value = value[0]
            setattr(msg, key, value)
        else:
            sub = _resolve(spec.base_type)
            if spec.is_array:
                setattr(msg, key, [_from_dict(sub, x) for x in value])
            else:
                setattr(msg, key, _from_dict(sub, value))
    return msg


def check_message(msg) -> None:
    """Check every field again (values changed in place, e.g. ``msg.name.append(3)``).

    Assignments are checked when they happen; this walks the whole message and raises
    :class:`MessageFieldError` / :class:`MessageFieldRangeError` naming the field path.
    """
    _require_message(msg, "check_message")
    _check(msg, msg._type)


def _check(msg, path):
    cls = type(msg)
    for spec in msg._fields:
        v = getattr(msg, spec.name)
        try:
            cls._converters[spec.name](v)
        except (MessageFieldError, MessageFieldRangeError) as exc:
            raise type(exc)(f"{path}.{spec.name}: {exc}") from None
        if not spec.is_primitive:
            for i, x in enumerate(v if spec.is_array else [v]):
                _check(x, f"{path}.{spec.name}" + (f"[{i}]" if spec.is_array else ""))


def numeric_paths(msg_type: type, prefix: str = "") -> list[tuple[str, FieldSpec]]:
    """Dotted paths of every numeric/bool leaf field (``"twist.twist.linear.x"``)."""
    out = []
    for spec in msg_type._fields:
        path = prefix + spec.name
        if spec.is_primitive:
            if spec.base_type in NUMPY_DTYPES:
                out.append((path, spec))
        elif not spec.is_array:
            out.extend(numeric_paths(_resolve(spec.base_type), path + "."))
    return out


def to_numpy(messages, msg_type: type | None = None) -> dict[str, np.ndarray]:
    """A list of messages -> ``{"linear.x": array(N), ...}`` for plotting.

    Scalar numeric fields become shape (N,) arrays; fixed arrays and equal-length sequences
    become (N, k); sequences whose length varies become an object array of 1-D arrays. Nested
    sequences of messages are skipped. ``builtin_interfaces/Time`` fields additionally get a
    ``<path>`` entry in float seconds (``"header.stamp"``).
    """
    if isinstance(messages, (str, bytes)) or not hasattr(messages, "__iter__"):
        raise TypeError(f"to_numpy needs a list of messages, got {messages!r:.80}; e.g. "
                        f"to_numpy(received) where received = [msg, ...]")
    messages = list(messages)
    if msg_type is not None:
        _require_type(msg_type, "to_numpy")
    if msg_type is None:
        if not messages:
            raise ValueError("to_numpy needs msg_type when the message list is empty")
        msg_type = type(messages[0])
    out: dict[str, np.ndarray] = {}
    for path, spec in numeric_paths(msg_type):
        getters = path.split(".")
        vals = []
        for m in messages:
            v = m
            for g in getters:
                v = getattr(v, g)
            vals.append(v)
        dtype = NUMPY_DTYPES[spec.base_type]
        if spec.is_array:
            lengths = {len(v) for v in vals}
            if len(lengths) <= 1:
                n = lengths.pop() if lengths else 0
                out[path] = np.asarray(vals, dtype=dtype).reshape(len(vals), n)
            else:
                arr = np.empty(len(vals), dtype=object)
                for i, v in enumerate(vals):
                    arr[i] = np.asarray(v, dtype=dtype)
                out[path] = arr
        else:
            out[path] = np.asarray(vals, dtype=dtype)
    for path in list(out):
        if path.endswith(".sec") and path[:-4] + ".nanosec" in out:
            out[path[:-4]] = out[path].astype(np.float64) + out[path[:-4] + ".nanosec"] * 1e-9
    return out
