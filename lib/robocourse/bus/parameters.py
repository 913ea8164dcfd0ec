"""Parameters: typed, declared, described and validated node settings.

rclpy counterparts: ``rclpy.parameter.Parameter`` (``Parameter.Type``), and from
``rcl_interfaces.msg``: ``ParameterDescriptor``, ``FloatingPointRange``, ``IntegerRange``,
``SetParametersResult``; the node methods ``declare_parameter(s)``, ``get_parameter(s)``,
``get_parameter_or``, ``set_parameters``, ``set_parameters_atomically``, ``has_parameter``,
``undeclare_parameter``, ``describe_parameter(s)``, ``list_parameters``, ``get_parameter_types``,
``add_on_set_parameters_callback``; the exceptions of ``rclpy.exceptions``; and
``rclpy.parameter_service.ParameterService`` (every node's six parameter services, what
``ros2 param`` calls) with each successful set published on ``/parameter_events``.
``ParameterDescriptor``, ``SetParametersResult`` and the ranges are the rcl_interfaces message
types, as in rclpy. ``robocourse.bus.introspection.param_list/param_get/param_set`` are the CLI
equivalents (they read the node directly, without the services).

As rclpy: a parameter declared with a type and no value (``declare_parameter("x",
Parameter.Type.DOUBLE)``) is uninitialized: ``get_parameter`` raises
:class:`ParameterUninitializedException` until it is set; setting a statically typed
parameter to NOT_SET does not undeclare it ("Static parameter cannot be undeclared").
Differences from rclpy: the reason texts of a wrong type or an out-of-range value are
rclcpp's (``Wrong parameter type, parameter {x} is of type {DOUBLE}, ...``); rclpy words them
differently. ``declare_parameter(name)`` without a value or descriptor is dynamically typed as
in rclpy, without rclpy's deprecation warning.
"""

from __future__ import annotations

import math
from enum import IntEnum

from robocourse.msgs.rcl_interfaces import (  # noqa: F401  (the ranges: rclpy's names, re-exported)
    FloatingPointRange,
    IntegerRange,
    ListParametersResult,
    ParameterDescriptor,
    ParameterEvent,
    ParameterValue,
    SetParametersResult,
)
from robocourse.msgs.rcl_interfaces import Parameter as ParameterMsg

#: rclpy's PARAMETER_SEPARATOR_STRING
PARAMETER_SEPARATOR_STRING = "."


class ParameterException(Exception):
    pass


class ParameterNotDeclaredException(ParameterException):
    def __init__(self, names):
        super().__init__(f"Invalid access to undeclared parameter(s): {names}. Declare it first: "
                         f"node.declare_parameter(name, default_value)")


class ParameterAlreadyDeclaredException(ParameterException):
    def __init__(self, names):
        super().__init__(f"Parameter(s) already declared: {names}")


class InvalidParameterValueException(ParameterException):
    def __init__(self, name, value, reason):
        super().__init__(f"Invalid parameter value ({value!r}) for parameter '{name}'. Reason: {reason}")


class InvalidParameterTypeException(ParameterException):
    def __init__(self, parameter, expected, hint: str = ""):
        super().__init__(f"Trying to set parameter '{parameter.name}' to '{parameter.value}' of type "
                         f"'{parameter.type_.name}', expecting type '{expected}'{hint}")


class ParameterImmutableException(ParameterException):
    def __init__(self, name):
        super().__init__(f"Attempted to modify read-only parameter '{name}'")


class ParameterUninitializedException(ParameterException):
    def __init__(self, name):
        super().__init__(f"The parameter '{name}' is not initialized")


class ParameterType(IntEnum):
    """rcl_interfaces/msg/ParameterType values."""

    NOT_SET = 0
    BOOL = 1
    INTEGER = 2
    DOUBLE = 3
    STRING = 4
    BYTE_ARRAY = 5
    BOOL_ARRAY = 6
    INTEGER_ARRAY = 7
    DOUBLE_ARRAY = 8
    STRING_ARRAY = 9


def _infer_type(value) -> ParameterType:
    if value is None:
        return ParameterType.NOT_SET
    if isinstance(value, bool):
        return ParameterType.BOOL
    if isinstance(value, int):
        return ParameterType.INTEGER
    if isinstance(value, float):
        return ParameterType.DOUBLE
    if isinstance(value, str):
        return ParameterType.STRING
    if isinstance(value, (bytes, bytearray)):
        return ParameterType.BYTE_ARRAY
    if isinstance(value, (list, tuple)):
        if not value:
            return ParameterType.STRING_ARRAY  # ambiguous; rclpy rejects, we pick string
        if all(isinstance(v, bool) for v in value):
            return ParameterType.BOOL_ARRAY
        if all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            return ParameterType.INTEGER_ARRAY
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            return ParameterType.DOUBLE_ARRAY
        if all(isinstance(v, str) for v in value):
            return ParameterType.STRING_ARRAY
    try:
        import numpy as np

        if isinstance(value, np.ndarray):
            return _infer_type(value.tolist())
        if isinstance(value, np.generic):
            return _infer_type(value.item())
    except ImportError:  # pragma: no cover
        pass
    raise TypeError(f"unsupported parameter value {value!r} ({type(value).__name__}): use bool, "
                    f"int, float, str, bytes or a list of one of them")


_VALUE_FIELDS = {
    ParameterType.BOOL: "bool_value", ParameterType.INTEGER: "integer_value",
    ParameterType.DOUBLE: "double_value", ParameterType.STRING: "string_value",
    ParameterType.BYTE_ARRAY: "byte_array_value", ParameterType.BOOL_ARRAY: "bool_array_value",
    ParameterType.INTEGER_ARRAY: "integer_array_value",
    ParameterType.DOUBLE_ARRAY: "double_array_value",
    ParameterType.STRING_ARRAY: "string_array_value",
}


def parameter_value_to_python(parameter_value):
    """rclpy ``parameter_value_to_python``: the Python value a ParameterValue message holds
    (None for NOT_SET; arrays as lists; a byte array as ``bytes``)."""
    t = parameter_value.type
    if t == ParameterType.NOT_SET:
        return None
    try:
        field = _VALUE_FIELDS[ParameterType(t)]
    except (ValueError, KeyError):
        raise RuntimeError(f"unexpected parameter type {t}") from None
    v = getattr(parameter_value, field)
    if t == ParameterType.BYTE_ARRAY:
        return bytes(v)
    if t >= ParameterType.BYTE_ARRAY:
        return list(v)
    return v


class Parameter:
    """rclpy.parameter.Parameter(name, type_=None, value=None)."""

    Type = ParameterType

    def __init__(self, name: str, type_: ParameterType | None = None, value=None):
        if type_ is None:
            type_ = _infer_type(value)
        self._name = name
        self._type = ParameterType(type_)
        if value is not None and type_ != ParameterType.NOT_SET:
            inferred = _infer_type(value)
            ok = inferred == type_ or (type_ == ParameterType.DOUBLE_ARRAY and inferred == ParameterType.INTEGER_ARRAY) \
                or (type_ >= ParameterType.BYTE_ARRAY and isinstance(value, (list, tuple)) and not value)
            if not ok:
                raise TypeError(f"parameter '{name}': type {type_.name} does not match value {value!r}")
            if isinstance(value, tuple):
                value = list(value)
            if type_ == ParameterType.DOUBLE_ARRAY:
                value = [float(v) for v in value]
        self._value = value

    @property
    def name(self) -> str:
        return self._name

    @property
    def type_(self) -> ParameterType:
        return self._type

    @property
    def value(self):
        return self._value

    def get_parameter_value(self) -> ParameterValue:
        """rclpy: the value as an ``rcl_interfaces/msg/ParameterValue`` (type + one field)."""
        pv = ParameterValue(type=int(self._type))
        field = _VALUE_FIELDS.get(self._type)
        if field is not None:
            v = self._value
            if self._type == ParameterType.BYTE_ARRAY:
                v = [b if isinstance(b, int) else b[0] for b in v]
            setattr(pv, field, v)
        return pv

    def to_parameter_msg(self) -> ParameterMsg:
        return ParameterMsg(name=self._name, value=self.get_parameter_value())

    @classmethod
    def from_parameter_msg(cls, param_msg) -> Parameter:
        """rclpy ``Parameter.from_parameter_msg``: an ``rcl_interfaces/msg/Parameter`` -> Parameter."""
        return cls(param_msg.name, ParameterType(param_msg.value.type),
                   parameter_value_to_python(param_msg.value))

    def __repr__(self):
        return f"Parameter({self._name!r}, {self._type.name}, {self._value!r})"

    def __eq__(self, other):
        return (isinstance(other, Parameter) and other.name == self.name
                and other.type_ == self.type_ and other.value == self.value)


def _check_range(param: Parameter, desc: ParameterDescriptor) -> str | None:
    v = param.value
    if desc.floating_point_range and param.type_ == ParameterType.DOUBLE:
        r = desc.floating_point_range[0]
        tol = 1e-9 * max(1.0, abs(r.to_value), abs(r.from_value))
        if v < r.from_value - tol or v > r.to_value + tol:
            return (f"Parameter {{{param.name}}} doesn't comply with floating point range: "
                    f"value {v} not in [{r.from_value}, {r.to_value}]")
        if r.step:
            k = (v - r.from_value) / r.step
            if abs(k - round(k)) > 1e-6 and not math.isclose(v, r.to_value):
                return (f"Parameter {{{param.name}}} doesn't comply with floating point range: "
                        f"value {v} is not a multiple of step {r.step} from {r.from_value}")
    if desc.integer_range and param.type_ == ParameterType.INTEGER:
        r = desc.integer_range[0]
        if v < r.from_value or v > r.to_value:
            return (f"Parameter {{{param.name}}} doesn't comply with integer range: value {v} "
                    f"not in [{r.from_value}, {r.to_value}]")
        if r.step and (v - r.from_value) % r.step and v != r.to_value:
            return (f"Parameter {{{param.name}}} doesn't comply with integer range: value {v} "
                    f"is not a multiple of step {r.step} from {r.from_value}")
    return None


class ParameterMixin:
    """Parameter methods of Node (mixed in; uses self._parameters/_descriptors)."""

    def _init_parameters(self, overrides, allow_undeclared, auto_declare):
        self._parameters: dict[str, Parameter] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._overrides: dict[str, Parameter] = {}
        for p in overrides or []:
            if not isinstance(p, Parameter):
                raise TypeError(f"parameter_overrides must be a list of Parameter, got {p!r}")
            self._overrides[p.name] = p
        self._allow_undeclared = allow_undeclared
        self._on_set_callbacks = []
        self._pre_set_callbacks = []
        self._post_set_callbacks = []
        if auto_declare:
            for p in self._overrides.values():
                self.declare_parameter(p.name, p.value)

    def declare_parameter(self, name: str, value=None, descriptor: ParameterDescriptor | None = None,
                          ignore_override: bool = False) -> Parameter:
        """rclpy ``declare_parameter``: ``value`` may be a default, a ``Parameter.Type`` (a
        static type without a value: uninitialized until set) or None with no descriptor (a
        dynamically typed parameter, as rclpy's name-only form)."""
        if isinstance(value, ParameterType):   # declare_parameter(name, Parameter.Type.DOUBLE)
            if value == ParameterType.NOT_SET:
                raise ValueError(f"Cannot declare parameter {{{name}}} as statically typed of "
                                 f"type NOT_SET")
            if descriptor is not None and descriptor.dynamic_typing:
                raise ValueError(f"When declaring parameter {{{name}}} passing a descriptor with "
                                 f"`dynamic_typing=True` is not allowed when the parameter type "
                                 f"is provided")
            value_type, value = value, None
        else:
            value_type = None
        return self.declare_parameters("", [(name, value, descriptor or ParameterDescriptor())],
                                       ignore_override, _types=[value_type])[0]

    def declare_parameters(self, namespace: str, parameters, ignore_override: bool = False,
                           _types=None) -> list[Parameter]:
        out = []
        for i, item in enumerate(parameters):
            name, value, desc = (list(item) + [None, None])[:3]
            desc = desc._copy() if desc is not None else ParameterDescriptor()
            full = f"{namespace}.{name}" if namespace else name
            if not full or any(not part for part in full.split(".")):
                raise InvalidParameterValueException(full, value, "parameter names must be non-empty")
            if full in self._parameters:
                raise ParameterAlreadyDeclaredException([full])
            ptype = _types[i] if _types and _types[i] is not None else None
            if not ignore_override and full in self._overrides:
                declared = ptype if ptype is not None else (_infer_type(value) if value is not None else None)
                override = self._overrides[full]
                if declared is not None and not desc.dynamic_typing and override.type_ != declared and not (
                        declared == ParameterType.DOUBLE_ARRAY and override.type_ == ParameterType.INTEGER_ARRAY):
                    # rclpy refuses an override of another type than the declared one (static typing)
                    hint = ""
                    if declared == ParameterType.DOUBLE and override.type_ == ParameterType.INTEGER:
                        hint = f"; write {override.value}.0 (a YAML 1 is an integer, 1.0 a double)"
                    raise InvalidParameterTypeException(override, declared.name, hint)
                value = override.value
            if value is None and ptype is None and not desc.dynamic_typing:
                if desc.type:
                    ptype = ParameterType(desc.type)
                else:   # rclpy's name-only declaration: dynamically typed
                    desc.dynamic_typing = True
            param = Parameter(full, value=value) if value is not None else \
                Parameter(full, ParameterType.NOT_SET)
            if ptype is not None and value is not None and param.type_ != ptype:
                raise InvalidParameterTypeException(param, ptype.name)
            desc.name = full
            if not desc.type:
                desc.type = int(ptype if ptype is not None else param.type_)
            if param.value is not None:
                reason = _check_range(param, desc)
                if reason:
                    raise InvalidParameterValueException(full, param.value, reason)
                res = self._call_on_set([param])
                if not res.successful:
                    raise InvalidParameterValueException(full, param.value, res.reason)
            self._parameters[full] = param
            self._descriptors[full] = desc
            self._parameter_event(new=[param])
            out.append(param)
        return out

    def undeclare_parameter(self, name: str) -> None:
        if name not in self._parameters:
            raise ParameterNotDeclaredException(name)
        if self._descriptors[name].read_only:
            raise ParameterImmutableException(name)
        del self._parameters[name]
        del self._descriptors[name]

    def has_parameter(self, name: str) -> bool:
        return name in self._parameters

    def get_parameter(self, name: str) -> Parameter:
        """rclpy: the parameter; ParameterNotDeclaredException if it was never declared,
        ParameterUninitializedException if it is statically typed and has no value yet."""
        param = self._parameters.get(name)
        if param is not None:
            if param.type_ != ParameterType.NOT_SET or self._descriptors[name].dynamic_typing:
                return param
            raise ParameterUninitializedException(name)
        if self._allow_undeclared:
            return Parameter(name, ParameterType.NOT_SET, None)
        raise ParameterNotDeclaredException(name)

    def get_parameter_or(self, name: str, alternative_value: Parameter | None = None) -> Parameter:
        """The parameter, or ``alternative_value`` if it is undeclared or has no value."""
        param = self._parameters.get(name)
        if param is not None and param.type_ != ParameterType.NOT_SET:
            return param
        return alternative_value if alternative_value is not None else Parameter(name, ParameterType.NOT_SET)

    def get_parameters(self, names) -> list[Parameter]:
        return [self.get_parameter(n) for n in names]

    def get_parameter_type(self, name: str) -> ParameterType:
        """rclpy: the stored type (NOT_SET for an uninitialized or, if allowed, undeclared one)."""
        if name in self._parameters:
            return self._parameters[name].type_
        if self._allow_undeclared:
            return ParameterType.NOT_SET
        raise ParameterNotDeclaredException(name)

    def get_parameter_types(self, names) -> list[ParameterType]:
        return [self.get_parameter_type(n) for n in names]

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, Parameter]:
        pre = prefix + "." if prefix else ""
        return {n[len(pre):]: p for n, p in self._parameters.items() if n.startswith(pre)}

    def list_parameters(self, prefixes, depth: int) -> ListParametersResult:
        """rclpy ``Node.list_parameters``: names under ``prefixes`` (all if empty) at most
        ``depth`` separators deep (0 = ``ListParameters.Request.DEPTH_RECURSIVE``), and the
        prefixes of the names listed."""
        if not isinstance(prefixes, list) or not all(isinstance(p, str) for p in prefixes):
            raise TypeError(f"list_parameters: prefixes={prefixes!r} must be a list of str")
        if isinstance(depth, bool) or not isinstance(depth, int):
            raise TypeError(f"list_parameters: depth={depth!r} must be an int")
        if depth < 0:
            raise ValueError("The depth must be greater than or equal to zero")
        sep = PARAMETER_SEPARATOR_STRING
        result = ListParametersResult()

        def shallow(s):
            return s.count(sep) < depth

        recursive = not prefixes and depth == 0
        for name in self._parameters:
            if not recursive:
                if not (not prefixes and shallow(name)) and not any(
                        name == pre or (name.startswith(pre + sep)
                                        and (depth == 0 or shallow(name[len(pre) + 1:])))
                        for pre in prefixes):
                    continue
            result.names.append(name)
            cut = name.rfind(sep)
            if cut != -1 and name[:cut] not in result.prefixes:
                result.prefixes.append(name[:cut])
        return result

    def describe_parameter(self, name: str) -> ParameterDescriptor:
        if name not in self._descriptors:
            if self._allow_undeclared:
                return ParameterDescriptor()
            raise ParameterNotDeclaredException(name)
        return self._descriptors[name]

    def describe_parameters(self, names) -> list[ParameterDescriptor]:
        return [self.describe_parameter(n) for n in names]

    def set_descriptor(self, name: str, descriptor: ParameterDescriptor):
        if name not in self._descriptors:
            raise ParameterNotDeclaredException(name)
        desc = descriptor._copy()
        desc.name = name
        self._descriptors[name] = desc
        return self.get_parameter(name)

    def add_on_set_parameters_callback(self, callback) -> None:
        """``callback(list[Parameter]) -> SetParametersResult``; a False result rejects the set."""
        self._on_set_callbacks.insert(0, callback)

    def remove_on_set_parameters_callback(self, callback) -> None:
        self._on_set_callbacks.remove(callback)

    def add_post_set_parameters_callback(self, callback) -> None:
        self._post_set_callbacks.append(callback)

    def _call_on_set(self, params) -> SetParametersResult:
        for cb in self._on_set_callbacks:
            res = cb(params)
            if not isinstance(res, SetParametersResult):
                raise TypeError(f"on-set-parameters callback {cb!r} must return SetParametersResult, "
                                f"got {res!r}")
            if not res.successful:
                return res
        return SetParametersResult(successful=True)

    def _validate(self, param: Parameter) -> SetParametersResult:
        name = param.name
        if name not in self._parameters:
            if self._allow_undeclared:
                return SetParametersResult(successful=True)
            raise ParameterNotDeclaredException(name)
        desc = self._descriptors[name]
        if desc.read_only:
            return SetParametersResult(False, f"Trying to set a read-only parameter: {name}.")
        if not desc.dynamic_typing:
            if param.type_ == ParameterType.NOT_SET:    # rclpy's _apply_descriptor
                return SetParametersResult(False, "Static parameter cannot be undeclared")
            expected = ParameterType(desc.type)
            if expected != ParameterType.NOT_SET and param.type_ != expected:
                return SetParametersResult(
                    False, f"Wrong parameter type, parameter {{{name}}} is of type {{{expected.name}}}, "
                           f"setting it to {{{param.type_.name}}} is not allowed.")
        reason = _check_range(param, desc)
        if reason:
            return SetParametersResult(False, reason)
        return SetParametersResult(successful=True)

    def set_parameters(self, parameter_list) -> list[SetParametersResult]:
        """Set each parameter on its own; returns one SetParametersResult per parameter."""
        return [self.set_parameters_atomically([p]) for p in parameter_list]

    def set_parameters_atomically(self, parameter_list) -> SetParametersResult:
        for p in parameter_list:
            if not isinstance(p, Parameter):
                raise TypeError(f"set_parameters takes Parameter objects, got {p!r}")
            res = self._validate(p)
            if not res.successful:
                return res
        res = self._call_on_set(list(parameter_list))
        if not res.successful:
            return res
        new, changed, deleted = [], [], []
        for p in parameter_list:
            if p.type_ == ParameterType.NOT_SET:     # a dynamically typed (or undeclared) one
                self._parameters.pop(p.name, None)
                self._descriptors.pop(p.name, None)
                deleted.append(p)
                continue
            old = self._parameters.get(p.name)
            (new if old is None or old.type_ == ParameterType.NOT_SET else changed).append(p)
            self._parameters[p.name] = p
            desc = self._descriptors.get(p.name)
            if desc is None:
                self._descriptors[p.name] = ParameterDescriptor(name=p.name, type=int(p.type_),
                                                                dynamic_typing=True)
            elif desc.dynamic_typing:
                desc.type = int(p.type_)
            self._on_parameter_changed(p)
        self._parameter_event(new, changed, deleted)
        for cb in self._post_set_callbacks:
            cb(list(parameter_list))
        return res

    def _parameter_event(self, new=(), changed=(), deleted=()) -> None:
        """Publish an ``rcl_interfaces/msg/ParameterEvent`` on /parameter_events (rclpy does
        it for every successful declaration and set)."""
        pub = getattr(self, "_parameter_event_publisher", None)
        if pub is None or not (new or changed or deleted):
            return
        pub.publish(ParameterEvent(
            stamp=self.get_clock().now().to_msg(), node=self.get_fully_qualified_name(),
            new_parameters=[p.to_parameter_msg() for p in new],
            changed_parameters=[p.to_parameter_msg() for p in changed],
            deleted_parameters=[p.to_parameter_msg() for p in deleted]))

    def _on_parameter_changed(self, param: Parameter) -> None:
        pass
