"""Parameter schemas in the style of generate_parameter_library, and ROS 2 YAML parameter files.

Counterpart: PickNikRobotics/generate_parameter_library (the YAML schema, the generated
``ParamListener`` / ``Params``) with RSL's validators and their C++ error texts, plus rcl's
``--params-file`` YAML layout (``node_name: {ros__parameters: {...}}``, ``/**`` wildcard).
One schema, one mechanism, used by the controller manager and by every controller::

    SCHEMA = ParameterSchema.from_yaml('''
    forward_command_controller:
      joints: {type: string_array, read_only: true, validation: {unique<>: null, not_empty<>: null}}
      interface_name: {type: string, validation: {not_empty<>: null}}
    ''')
    listener = ParamListener(SCHEMA, {"joints": ["joint1"], "interface_name": "position"})
    params = listener.get_params()          # params.joints, params.interface_name

Differences: no code generation (the schema is read at import); values come from a dict (the
controller's flattened ``ros__parameters``) rather than from a node's parameter server; an
undeclared key is reported in ``listener.unused`` (ROS ignores it silently; the manager logs
it). Updates at run time go through :meth:`ParamListener.set` (validated, read_only refused)
and reach the real-time side through :meth:`ParamListener.try_update_params`, a non-blocking
swap, never a parameter read inside update().
"""

from __future__ import annotations

import copy
import threading
from pathlib import Path

import yaml

from robocourse.bus.parameters import InvalidParameterValueException, SetParametersResult

TYPES = ("string", "double", "int", "bool", "string_array", "double_array", "int_array", "bool_array", "none")
_LEAF_KEYS = {"type", "default_value", "read_only", "description", "validation", "additional_constraints"}
_SCALAR_BOUNDS = {"gt", "gt_eq", "lt", "lt_eq"}


class SchemaError(ValueError):
    """A schema YAML generate_parameter_library would refuse (its generation-time messages)."""


class ParameterUninitializedException(ValueError):
    """rclcpp::exceptions::ParameterUninitializedException: a mandatory parameter was not given."""

    def __init__(self, name: str):
        super().__init__(f"parameter '{name}' is not initialized (it has no default_value: set it in the "
                         f"controller's ros__parameters, e.g. {name}: ...)")


class InvalidParameterTypeException(TypeError):
    """rclcpp::exceptions::InvalidParameterTypeException for a value of the wrong type."""

    def __init__(self, name: str, expected: str, got: str):
        super().__init__(f"parameter '{name}' has invalid type: Wrong parameter type, parameter {{{name}}} is "
                         f"of type {{{_ROS_TYPE[expected]}}}, setting it to {{{got}}} is not allowed.")


_ROS_TYPE = {"string": "string", "double": "double", "int": "integer", "bool": "bool",
             "string_array": "string_array", "double_array": "double_array", "int_array": "integer_array",
             "bool_array": "bool_array", "none": "not set"}


def _ros_type_of(value) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "double"
    if isinstance(value, str):
        return "string"
    if isinstance(value, (list, tuple)):
        if not value:
            return "array"
        inner = {_ros_type_of(v) for v in value}
        return f"{inner.pop()}_array" if len(inner) == 1 else "mixed array"
    return type(value).__name__


def _conforms(ptype: str, value) -> bool:
    if ptype.startswith("string_fixed_"):
        ptype = "string"
    scalar = {"string": lambda v: isinstance(v, str), "bool": lambda v: isinstance(v, bool),
              "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
              "double": lambda v: isinstance(v, float)}
    if ptype in scalar:
        return scalar[ptype](value)
    if ptype.endswith("_array"):
        return isinstance(value, (list, tuple)) and all(scalar[ptype[:-6]](v) for v in value)
    return ptype == "none"


def _fmt(v) -> str:
    """RSL formats numbers with fmt ({:g} for doubles); lists as a comma-joined set."""
    if isinstance(v, float):
        return format(v, "g")
    if isinstance(v, (list, tuple)):
        return ", ".join(_fmt(x) for x in v)
    return str(v)


# --- validators (RSL texts) --------------------------------------------------------------------------
def _v_bounds(name, v, lo, hi):
    if not lo <= v <= hi:
        return f"Parameter '{name}' with the value '{_fmt(v)}' must be within bounds '[{_fmt(lo)}, {_fmt(hi)}]'"


def _cmp(op, text):
    def check(name, v, x):
        if not op(v, x):
            return f"Parameter '{name}' with the value '{_fmt(v)}' must be {text} '{_fmt(x)}'"
    return check


def _v_one_of(name, v, options):
    if v not in options:
        return f"Parameter '{name}' with the value '{_fmt(v)}' is not in the set '{{{_fmt(options)}}}'"


def _v_not_empty(name, v):
    if len(v) == 0:
        return f"Parameter '{name}' cannot be empty"


def _v_unique(name, v):
    if len(set(v)) != len(v):
        return f"Parameter '{name}' must only contain unique values"


def _v_subset_of(name, v, options):
    for e in v:
        if e not in options:
            return f"Entry '{_fmt(e)}' in parameter '{name}' is not in the set '{{{_fmt(options)}}}'"


def _size(op, text):
    def check(name, v, n):
        if not op(len(v), n):
            return f"Length of parameter '{name}' is '{len(v)}' but must be {text} '{n}'"
    return check


def _v_element_bounds(name, v, lo, hi):
    for e in v:
        if not lo <= e <= hi:
            return f"Value '{_fmt(e)}' in parameter '{name}' must be within bounds '[{_fmt(lo)}, {_fmt(hi)}]'"


def _v_lower_element_bounds(name, v, lo):
    for e in v:
        if e < lo:
            return f"Value '{_fmt(e)}' in parameter '{name}' must be above lower bound of '{_fmt(lo)}'"


def _v_upper_element_bounds(name, v, hi):
    for e in v:
        if e > hi:
            return f"Value '{_fmt(e)}' in parameter '{name}' must be below upper bound of '{_fmt(hi)}'"


VALIDATORS = {
    "bounds": _v_bounds,
    "gt": _cmp(lambda a, b: a > b, "greater than"),
    "gt_eq": _cmp(lambda a, b: a >= b, "greater than or equal to"),
    "lt": _cmp(lambda a, b: a < b, "less than"),
    "lt_eq": _cmp(lambda a, b: a <= b, "less than or equal to"),
    "one_of": _v_one_of,
    "not_empty": _v_not_empty,
    "unique": _v_unique,
    "subset_of": _v_subset_of,
    "fixed_size": _size(lambda a, b: a == b, "equal to"),
    "size_gt": _size(lambda a, b: a > b, "greater than"),
    "size_lt": _size(lambda a, b: a < b, "less than"),
    "element_bounds": _v_element_bounds,
    "lower_element_bounds": _v_lower_element_bounds,
    "upper_element_bounds": _v_upper_element_bounds,
}


class ParamSpec:
    """One leaf of the schema: type, default, read_only, description, validators."""

    def __init__(self, path: str, spec: dict):
        self.path = path
        if not isinstance(spec, dict) or "type" not in spec:
            raise SchemaError(f"No type defined for parameter {path}")
        for key in spec:
            if key not in _LEAF_KEYS:
                raise SchemaError(f"Invalid syntax in parameter {path}. '{key}' is not valid syntax")
        ptype = spec["type"]
        self.validators: list[tuple[str, list]] = []
        if isinstance(ptype, str) and ptype.startswith("string_fixed_"):
            size = int(ptype[len("string_fixed_"):])
            self.validators.append(("size_lt", [size + 1]))
        elif ptype not in TYPES:
            raise SchemaError(f"Invalid parameter type `{ptype}` for parameter {path}. Allowed types are: "
                              + ", ".join(TYPES + ("string_fixed_XX",)))
        self.type = ptype
        self.read_only = bool(spec.get("read_only", False))
        self.description = spec.get("description", "")
        self.has_default = "default_value" in spec
        default = spec.get("default_value")
        if self.has_default and ptype != "none":
            if ptype == "double" and isinstance(default, int) and not isinstance(default, bool):
                default = float(default)
            if ptype == "double_array" and isinstance(default, list):
                default = [float(x) if isinstance(x, int) and not isinstance(x, bool) else x for x in default]
            if not _conforms(ptype, default):
                raise SchemaError(f"Parameter {path} has incorrect type. Expected: {ptype}, got: "
                                  f"{_ros_type_of(default)}")
        self.default = default
        for vname, args in (spec.get("validation") or {}).items():
            base = vname[:-2] if vname.endswith("<>") else vname
            if base not in VALIDATORS:
                raise SchemaError(f"Invalid syntax in parameter {path}. validator '{vname}' is not one of "
                                  f"{sorted(VALIDATORS)}")
            self.validators.append((base, [] if args is None else list(args)))
        names = {v for v, _ in self.validators}
        if "bounds" in names and names & _SCALAR_BOUNDS:
            raise SchemaError(f"Parameter {path} cannot combine 'bounds' with scalar bound validators "
                              "(gt/gt_eq/lt/lt_eq). Use either 'bounds' or the scalar validators.")
        if "element_bounds" in names and names & {"lower_element_bounds", "upper_element_bounds"}:
            raise SchemaError(f"Parameter {path} cannot combine 'element_bounds' with "
                              "'lower_element_bounds/upper_element_bounds'.")
        if self.has_default and ptype != "none":
            msg = self.validate(path, self.default)
            if msg:
                raise SchemaError(f"default_value of {path} fails its own validation: {msg}")

    def coerce(self, name: str, value):
        if self.type == "double" and isinstance(value, int) and not isinstance(value, bool):
            raise InvalidParameterTypeException(name, self.type, "integer")
        if not _conforms(self.type, value):
            raise InvalidParameterTypeException(name, self.type if not self.type.startswith("string_fixed")
                                                else "string", _ros_type_of(value))
        return list(value) if isinstance(value, tuple) else value

    def validate(self, name: str, value) -> str | None:
        for vname, args in self.validators:
            msg = VALIDATORS[vname](name, value, *args)
            if msg:
                return msg
        return None


class ParameterSchema:
    """A parsed generate_parameter_library YAML: ``namespace`` and a tree of :class:`ParamSpec`."""

    def __init__(self, definition: dict):
        if not isinstance(definition, dict) or len(definition) != 1:
            raise SchemaError("The yaml definition must only have one root element")
        self.namespace, body = next(iter(definition.items()))
        self.tree = self._build(body, "")

    @classmethod
    def from_yaml(cls, text_or_path) -> ParameterSchema:
        text = Path(text_or_path).read_text() if isinstance(text_or_path, Path) else text_or_path
        return cls(yaml.safe_load(text))

    def _build(self, node: dict, prefix: str):
        tree = {}
        for key, sub in node.items():
            path = f"{prefix}{key}"
            if isinstance(sub, dict) and ("type" in sub or not any(isinstance(v, dict) for v in sub.values())):
                tree[key] = ParamSpec(path, sub)
            elif isinstance(sub, dict):
                tree[key] = self._build(sub, path + ".")
            else:
                raise SchemaError(f"No type defined for parameter {path}")
        return tree

    def leaves(self, values: dict) -> list[tuple[str, ParamSpec]]:
        """(dotted name, spec) for every parameter, with ``__map_<list>`` expanded from ``values``."""
        out: list[tuple[str, ParamSpec]] = []

        def walk(tree, prefix, scopes):
            for key, sub in tree.items():
                if key.startswith("__map_"):
                    list_name = key[len("__map_"):]
                    entries = self._lookup_list(list_name, prefix, values)
                    for entry in entries:
                        walk(sub if isinstance(sub, dict) else {"": sub}, f"{prefix}{entry}.", scopes)
                    continue
                name = f"{prefix}{key}"
                if isinstance(sub, ParamSpec):
                    out.append((name.rstrip("."), sub))
                else:
                    walk(sub, name + ".", scopes)
        walk(self.tree, "", [])
        return out

    def _lookup_list(self, list_name: str, prefix: str, values: dict) -> list:
        scope = prefix.rstrip(".").split(".") if prefix else []
        while True:
            key = ".".join(scope + [list_name])
            if key in values:
                return list(values[key])
            spec = self._spec_at(key)
            if spec is not None and spec.has_default:
                return list(spec.default)
            if not scope:
                return []
            scope.pop()

    def _spec_at(self, dotted: str):
        node = self.tree
        for part in dotted.split("."):
            if not isinstance(node, dict) or part not in node:
                return None
            node = node[part]
        return node if isinstance(node, ParamSpec) else None


class Params:
    """The generated ``Params`` struct: attributes, nested structs, ``get_entry`` for ``__map_`` entries."""

    def __init__(self):
        self._stamp = 0

    def get_entry(self, key: str):
        """Python gpl's access to a ``__map_`` entry: ``params.gains.get_entry("joint1").p``."""
        return getattr(self, key)

    def __repr__(self) -> str:
        items = ", ".join(f"{k}={v!r}" for k, v in vars(self).items() if not k.startswith("_"))
        return f"Params({items})"


def _assign(root: Params, dotted: str, value) -> None:
    node = root
    parts = dotted.split(".")
    for part in parts[:-1]:
        if not hasattr(node, part) or not isinstance(getattr(node, part), Params):
            setattr(node, part, Params())
        node = getattr(node, part)
    setattr(node, parts[-1], value)


class ParamListener:
    """``ParamListener(schema, values, prefix="")``: validate at construction, then serve Params.

    Raises upstream's exceptions at construction: a mandatory parameter missing
    (:class:`ParameterUninitializedException`), a wrong type
    (:class:`InvalidParameterTypeException`), or a failed validator
    (``InvalidParameterValueException`` with "Invalid value set during initialization for
    parameter '<name>': <validator message>").
    """

    def __init__(self, schema: ParameterSchema, values: dict | None = None, prefix: str = ""):
        self.schema = schema
        self.prefix = prefix
        given = dict(values or {})
        self._lock = threading.Lock()
        self._values: dict = {}
        self._specs: dict[str, ParamSpec] = {}
        for name, spec in schema.leaves(given):
            full = prefix + name
            if name in given:
                value = spec.coerce(full, given[name])
            elif spec.has_default:
                value = copy.deepcopy(spec.default)
            else:
                raise ParameterUninitializedException(full)
            msg = spec.validate(full, value)
            if msg:
                raise InvalidParameterValueException(
                    full, value, f"Invalid value set during initialization for parameter '{full}': {msg}")
            self._values[name] = value
            self._specs[name] = spec
        self.unused = sorted(set(given) - set(self._values))
        self._stamp = 1
        self._params = self._make()

    def _make(self) -> Params:
        p = Params()
        for name, value in self._values.items():
            _assign(p, name, copy.deepcopy(value))
        p._stamp = self._stamp
        return p

    def get_params(self) -> Params:
        """A fresh copy of the current parameters (call outside the real-time loop)."""
        with self._lock:
            return self._make()

    def is_old(self, params: Params) -> bool:
        return params._stamp != self._stamp

    def try_update_params(self, params: Params) -> bool:
        """Real-time safe: if newer values exist and the lock is free, copy them into ``params``."""
        if params._stamp == self._stamp or not self._lock.acquire(blocking=False):
            return False
        try:
            fresh = self._make()
        finally:
            self._lock.release()
        params.__dict__.update(fresh.__dict__)
        return True

    def set(self, name: str, value) -> SetParametersResult:
        """Change one parameter at run time (rclcpp's set_parameter through the listener's callback)."""
        spec = self._specs.get(name)
        if spec is None:
            return SetParametersResult(False, f"parameter '{self.prefix}{name}' is not declared; declared: "
                                              f"{sorted(self._specs)}")
        if spec.read_only:
            return SetParametersResult(False, f"parameter '{self.prefix}{name}' cannot be set because it is read-only")
        try:
            value = spec.coerce(self.prefix + name, value)
        except InvalidParameterTypeException as exc:
            return SetParametersResult(False, str(exc))
        msg = spec.validate(self.prefix + name, value)
        if msg:
            return SetParametersResult(False, msg)
        with self._lock:
            self._values[name] = value
            self._stamp += 1
        return SetParametersResult(True, "")

    def values(self) -> dict:
        return dict(self._values)

    def describe(self) -> list[tuple[str, str, object, bool, str]]:
        """(name, type, value, read_only, description) for every parameter: a table for notebooks."""
        return [(n, s.type, self._values[n], s.read_only, s.description) for n, s in self._specs.items()]


# --- ROS 2 parameter files --------------------------------------------------------------------------
def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def load_parameter_file(source) -> dict[str, dict]:
    """A ``--params-file`` YAML -> ``{node_name: {dotted.param: value}}``.

    Accepts a path, YAML text, or the same layout already loaded as a dict. Layout:
    ``node: {ros__parameters: {...}}``; ``/**`` (any node) is merged under every node that asks
    (key ``"/**"``); namespaces (``/ns/node``) keep their last component. A node entry without
    ``ros__parameters`` is an error naming the node and the fix.
    """
    if isinstance(source, dict):
        data = source
    else:
        is_path = isinstance(source, Path) or (isinstance(source, str) and "\n" not in source and (
            source.endswith((".yaml", ".yml")) or Path(source).is_file()))
        text = Path(source).read_text() if is_path else source
        data = yaml.safe_load(text) or {}
    if not isinstance(data, dict):
        raise ValueError("a ROS 2 parameter file must be a mapping of node names, e.g. "
                         "'controller_manager:\\n  ros__parameters:\\n    update_rate: 100'")
    out: dict[str, dict] = {}

    def visit(d: dict, path: str):
        for key, val in d.items():
            if key == "ros__parameters":
                if not path:
                    raise ValueError("'ros__parameters' must sit under a node name: "
                                     "{'controller_manager': {'ros__parameters': {'update_rate': 100}}}")
                if not isinstance(val, dict):
                    raise ValueError(f"'ros__parameters' of '{path}' must be a mapping")
                name = path.rstrip("/").rsplit("/", 1)[-1] if path not in ("/**", "**") else "/**"
                out.setdefault(name, {}).update(_flatten(val))
            elif isinstance(val, dict):
                visit(val, f"{path}/{key}" if path else str(key))
            else:
                raise ValueError(f"'{path}/{key}: {val!r}' is outside any 'ros__parameters' block; parameters "
                                 f"go under '<node>:\\n  ros__parameters:\\n    {key}: {val!r}'")
    visit(data, "")
    return out


def as_parameter_files(params) -> dict[str, dict]:
    """What a ``params=`` argument may be, as ``{node: {dotted.param: value}}``: a path or YAML text
    of a ROS 2 parameter file, the same layout as a dict (``{node: {"ros__parameters": {...}}}``),
    or already per node (``{node: {"update_rate": 100, "jtc.type": ...}}``, nested dicts allowed)."""
    if params is None:
        return {}
    if not isinstance(params, dict):
        return load_parameter_file(params)
    if "ros__parameters" in params or any(isinstance(v, dict) and "ros__parameters" in v for v in params.values()):
        return load_parameter_file(params)
    for node, values in params.items():
        if not isinstance(values, dict):
            raise ValueError(f"params[{node!r}] is {values!r}: give each node a dict of its parameters, "
                             f"{{{node!r}: {{'ros__parameters': {{...}}}}}} as in a parameter file, or "
                             f"{{{node!r}: {{'name': value}}}}")
    return {node: _flatten(values) for node, values in params.items()}


def params_for(files: dict[str, dict], node: str) -> dict:
    """Parameters for ``node`` from :func:`load_parameter_file`'s output (``/**`` first, then the node's)."""
    merged = dict(files.get("/**", {}))
    merged.update(files.get(node, {}))
    return merged


__all__ = ["InvalidParameterTypeException", "InvalidParameterValueException", "ParamListener", "ParamSpec",
           "ParameterSchema", "ParameterUninitializedException", "Params", "SchemaError", "as_parameter_files",
           "load_parameter_file",
           "params_for"]
