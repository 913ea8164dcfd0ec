"""Field checks and the generated per-type code of message classes (rosidl_generator_py's job).

rclpy counterpart: the property setters ``rosidl_generator_py`` writes into every message class
(``assert isinstance(value, float), "The 'data' field must be of type 'float'"``). Each field
gets one *converter* ``conv(value) -> stored value`` that checks the value with rclpy's rule
and wording and stores it in rclpy's representation; each message type gets a generated
``__init__``, ``__setattr__``, ``__eq__`` and ``_copy`` (a deep copy that skips the checks,
used by the bus to give every subscription its own value).

Representations (as rclpy): numeric sequences ``T[]``/``T[<=N]`` are ``array.array`` (typecode
``'d'`` for float64 ...); numeric fixed arrays ``T[N]`` are ``numpy.ndarray`` of the field's
dtype; strings, bools and nested messages in arrays are lists.

Where robocourse is more lenient than rclpy (and why):

- a float field accepts an ``int`` (and numpy scalars) and stores ``float(value)``; rclpy
  rejects ``Float64(data=1)``. Course code and student code write ``x=0`` and ``data=k * 2``
  everywhere; the stored value is a float either way, so the wire and the record match rclpy.
- int fields accept numpy integers (stored as ``int``); numeric sequences also accept numpy
  arrays (rclpy insists on a list/array.array).
- ``byte`` and ``char`` are ints in [0, 255] (rclpy uses ``bytes`` of length 1 for ``byte`` and
  a 1-character ``str`` for ``char``); a ``bytes`` of length 1 is accepted for them.
"""

from __future__ import annotations

import array
import math
from collections.abc import Sequence, Set
from typing import Any

import numpy as np

FLOAT32_MAX = 3.402823466e38
FLOAT64_MAX = 1.7976931348623157e308

#: numeric ROS type -> array.array typecode (rclpy's choice for sequences)
TYPECODES = {
    "byte": "B", "char": "B", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
    "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d",
}


class MessageFieldError(TypeError, AssertionError):
    """A field value of the wrong type. Subclasses AssertionError like rclpy's setter checks."""


class MessageFieldRangeError(ValueError, AssertionError):
    """A field value of the right type outside its range, bound or fixed size."""


def _pytype_name(base: str) -> str:
    if base in ("float32", "float64"):
        return "float"
    if base == "bool":
        return "bool"
    if base in ("string", "wstring"):
        return "str"
    return "int"


def _range_text(base: str, ranges) -> str:
    if base == "float64":
        return f"a double in [{-FLOAT64_MAX}, {FLOAT64_MAX}]"
    if base == "float32":
        return f"a float in [{-FLOAT32_MAX}, {FLOAT32_MAX}]"
    lo, hi = ranges[base]
    kind = "an unsigned integer" if lo == 0 else "an integer"
    return f"{kind} in [{lo}, {hi}]"


def _example(base: str) -> str:
    return {"float": "1.0", "int": "1", "bool": "True", "str": "'text'"}[_pytype_name(base)]


class FieldRule:
    """Everything the checks of one field need: its spec, owner type and nested type."""

    def __init__(self, spec, owner: str, nested: type | None, ranges):
        self.spec = spec
        self.owner = owner
        self.nested = nested
        self.ranges = ranges
        self.where = f"{owner}.{spec.name}"

    def fail(self, rclpy_text: str, value, fix: str, *, range_error: bool = False):
        shown = repr(value)
        if len(shown) > 60:
            shown = shown[:57] + "..."
        cls = MessageFieldRangeError if range_error else MessageFieldError
        raise cls(f"{rclpy_text} ({self.where} got {shown} of type {type(value).__name__}). "
                  f"Fix: {fix}")

    # ---------------------------------------------------------------- scalars
    def scalar(self, v):
        """Check one scalar value of this field's base type; return it as stored."""
        spec = self.spec
        base = spec.base_type
        name = spec.name
        if self.nested is not None:
            if isinstance(v, self.nested):
                return v
            short = self.nested.__name__
            self.fail(f"The '{name}' field must be a sub message of type '{short}'", v,
                      f"pass a {short}(...) ({self.nested._type}), e.g. {name}={short}()")
        kind = _pytype_name(base)
        if kind == "float":
            if type(v) is not float:
                if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                    self.fail(f"The '{name}' field must be of type 'float'", v,
                              f"pass a number, e.g. {name}=1.0 (convert with float(...))")
                v = float(v)
            limit = FLOAT32_MAX if base == "float32" else FLOAT64_MAX
            if (v < -limit or v > limit) and not math.isinf(v):
                self.fail(f"The '{name}' field must be {_range_text(base, self.ranges)}", v,
                          f"keep {base} values within +-{limit:g} (or use float64)",
                          range_error=True)
            return v
        if kind == "int":
            if type(v) is not int:
                if isinstance(v, (bytes, bytearray)) and base in ("byte", "char") and len(v) == 1:
                    v = v[0]
                elif isinstance(v, (int, np.integer)):
                    v = int(v)
                else:
                    self.fail(f"The '{name}' field must be of type 'int'", v,
                              f"pass an int, e.g. {name}=1 (round(x) or int(x) to convert)")
            lo, hi = self.ranges[base]
            if not lo <= v <= hi:
                self.fail(f"The '{name}' field must be {_range_text(base, self.ranges)}", v,
                          f"keep {base} values in [{lo}, {hi}]"
                          + ("" if base.endswith("64") else " or use a wider type in the .msg"),
                          range_error=True)
            return v
        if kind == "bool":
            if type(v) is not bool:
                if not isinstance(v, np.bool_):
                    self.fail(f"The '{name}' field must be of type 'bool'", v,
                              "pass True or False (bool(x) to convert)")
                v = bool(v)
            return v
        if type(v) is not str:
            if not isinstance(v, str):
                self.fail(f"The '{name}' field must be of type 'str'", v,
                          f"pass a str, e.g. {name}='text' (str(x) to convert)")
            v = str(v)
        bound = spec.string_bound
        if bound and len(v) > int(bound[2:]):
            self.fail(f"The '{name}' field must be string with length not greater than "
                      f"{bound[2:]}", v, f"shorten the text to {bound[2:]} characters",
                      range_error=True)
        return v

    # ---------------------------------------------------------------- arrays
    def _shape_text(self) -> str:
        spec = self.spec
        if spec.array_size is None:
            return ""
        return f" with length {'<= ' if spec.is_bounded else ''}{spec.array_size}"

    def _seq_fail(self, v, range_error=False):
        spec = self.spec
        base = spec.base_type
        if self.nested is not None:
            each = f"each value of type '{self.nested.__name__}'"
            fix = f"pass a list of {self.nested.__name__}(...)"
        else:
            each = f"each value of type '{_pytype_name(base)}'"
            if base in TYPECODES:
                each += " and each " + _range_text(base, self.ranges).split(" ", 1)[1]
            fix = f"pass a list of {_pytype_name(base)}, e.g. {spec.name}=[{_example(base)}]"
        if spec.array_size is not None:
            fix += (f" with {'at most' if spec.is_bounded else 'exactly'} {spec.array_size} "
                    f"elements")
        self.fail(f"The '{spec.name}' field must be a set or sequence{self._shape_text()} and "
                  f"{each}", v, fix, range_error=range_error)

    def _check_len(self, v, n):
        spec = self.spec
        size = spec.array_size
        if size is not None and (n > size if spec.is_bounded else n != size):
            self._seq_fail(v, range_error=True)

    def _numbers(self, v):
        """Check a numpy array or a sequence holds numbers this field can store."""
        base = self.spec.base_type
        is_float = base.startswith("float")
        if isinstance(v, np.ndarray):
            if v.ndim != 1 or v.dtype.kind not in ("biuf" if is_float else "biu"):
                self._seq_fail(v)
            if not is_float and v.size:
                lo, hi = self.ranges[base]
                if int(v.min()) < lo or int(v.max()) > hi:
                    self._seq_fail(v, range_error=True)
            return
        ok = (float, int, np.floating, np.integer) if is_float else (int, np.integer)
        for x in v:
            if type(x) is not float and (isinstance(x, bool) and is_float or not isinstance(x, ok)):
                self._seq_fail(v)
        if not is_float and v:
            lo, hi = self.ranges[base]
            if min(v) < lo or max(v) > hi:
                self._seq_fail(v, range_error=True)

    def sequence(self, v):
        """Check a whole array value; return it in rclpy's representation."""
        spec = self.spec
        base = spec.base_type
        if isinstance(v, str) or not isinstance(v, (Sequence, Set, array.array, np.ndarray)):
            self._seq_fail(v)
        if self.nested is None and base in TYPECODES:
            if spec.is_fixed_array:
                return self._fixed(v)
            code = TYPECODES[base]
            if type(v) is array.array and v.typecode == code:
                out = v
            elif isinstance(v, np.ndarray):
                self._numbers(v)
                out = array.array(code)
                out.frombytes(np.ascontiguousarray(v, dtype=_NUMPY[base]).tobytes())
            else:
                if type(v) is array.array:
                    v = v.tolist()
                self._numbers(v)
                try:
                    out = array.array(code, v)
                except OverflowError:
                    self._seq_fail(v, range_error=True)
            self._check_len(v, len(out))
            return out
        out = list(v)
        for x in out:
            try:
                self.scalar(x)
            except (MessageFieldError, MessageFieldRangeError):
                self._seq_fail(v)
        if self.nested is None and base == "bool":
            out = [bool(x) for x in out]
        self._check_len(v, len(out))
        return out

    def _fixed(self, v):
        spec = self.spec
        dtype = np.dtype(_NUMPY[spec.base_type])
        if isinstance(v, np.ndarray):
            if v.dtype != dtype:
                if v.dtype.kind not in "biuf" or (dtype.kind in "iu" and v.dtype.kind == "f"):
                    self.fail(f"The '{spec.name}' numpy.ndarray() must have the dtype of "
                              f"'numpy.{dtype.name}'", v,
                              f"pass np.asarray(x, dtype=np.{dtype.name})")
                v = v.astype(dtype)
            if v.ndim != 1 or v.size != spec.array_size:
                self.fail(f"The '{spec.name}' numpy.ndarray() must have a size of "
                          f"{spec.array_size}", v,
                          f"pass {spec.array_size} values (shape ({spec.array_size},))",
                          range_error=True)
            return v
        if isinstance(v, array.array):
            v = v.tolist()
        elif isinstance(v, (bytes, bytearray)) and dtype == np.uint8:   # CDR decoders give bytes
            v = list(v)
        if len(v) != spec.array_size:
            self._seq_fail(v, range_error=True)
        self._numbers(v)
        try:
            return np.array(v, dtype=dtype)
        except OverflowError:
            self._seq_fail(v, range_error=True)

    def converter(self):
        return self.sequence if self.spec.is_array else self.scalar


_NUMPY = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
}


# --------------------------------------------------------------------------- code generation

_MISSING = object()


def default_maker(spec, default, nested) -> tuple[Any, bool]:
    """(value or factory, is_factory) for a field's default (a fresh object per message)."""
    if spec.is_array:
        base = spec.base_type
        if nested is not None:
            if spec.is_fixed_array:
                return (lambda n=spec.array_size, c=nested: [c() for _ in range(n)]), True
            return list, True
        zero = {"bool": False, "string": "", "wstring": ""}.get(base, 0)
        if spec.is_fixed_array:
            dtype = _NUMPY.get(base)
            if dtype is not None:
                vals = default if default is not None else [zero] * spec.array_size
                return (lambda v=tuple(vals), d=dtype: np.array(v, dtype=d)), True
            vals = default if default is not None else [zero] * spec.array_size
            return (lambda v=tuple(vals): list(v)), True
        if base in TYPECODES:
            vals = tuple(default or ())
            return (lambda c=TYPECODES[base], v=vals: array.array(c, v)), True
        vals = tuple(default or ())
        return (lambda v=vals: list(v)), True
    if nested is not None:
        return nested, True
    if default is not None:
        return default, False
    return {"bool": False, "string": "", "wstring": "", "float32": 0.0,
            "float64": 0.0}.get(spec.base_type, 0), False


def _fast_check(spec, nested, var: str) -> str:
    """The inline test that lets the common, already-correct value skip the converter.

    It calls ``_typeof`` (the builtin ``type``), since a field may itself be named ``type``
    (controller_manager_msgs/ControllerState) and shadow the builtin inside ``__init__``.
    """
    if spec.is_array:
        if nested is None and spec.base_type in TYPECODES and not spec.is_fixed_array \
                and spec.array_size is None:
            return f"_typeof({var}) is not _array or {var}.typecode != {TYPECODES[spec.base_type]!r}"
        return "True"
    if nested is not None:
        return f"_typeof({var}) is not _T_{spec.name}"
    kind = _pytype_name(spec.base_type)
    if spec.base_type == "float64":
        return f"_typeof({var}) is not float"
    if kind == "str" and not spec.string_bound:
        return f"_typeof({var}) is not str"
    if kind == "bool":
        return f"_typeof({var}) is not bool"
    return "True"


def build_methods(cls, specs, rules: dict, defaults: dict) -> None:
    """Generate and install ``__init__``, ``__setattr__``, ``__eq__``, ``_copy`` on ``cls``."""
    g: dict[str, Any] = {"_array": array.array, "_MISSING": _MISSING, "_new": object.__new__,
                         "_cls": cls, "_np": np, "_ndarray": np.ndarray, "_typeof": type}
    params, body, copy_lines, eq_terms = [], [], [], []
    setters, converters = {}, {}
    for spec in specs:
        n = spec.name
        rule = rules[n]
        conv = rule.converter()
        desc = cls.__dict__[n]      # the slot's member descriptor
        g[f"_s_{n}"] = desc.__set__
        g[f"_c_{n}"] = conv
        if rule.nested is not None:
            g[f"_T_{n}"] = rule.nested
        value, is_factory = defaults[n]
        if is_factory:
            g[f"_f_{n}"] = value
            params.append(f"{n}=_MISSING")
            body.append(f"    if {n} is _MISSING:\n        {n} = _f_{n}()\n"
                        f"    elif {_fast_check(spec, rule.nested, n)}:\n        {n} = _c_{n}({n})")
        else:
            g[f"_d_{n}"] = value
            params.append(f"{n}=_d_{n}")
            body.append(f"    if {_fast_check(spec, rule.nested, n)}:\n        {n} = _c_{n}({n})")
        body.append(f"    _s_{n}(self, {n})")

        def setter(obj, v, s=desc.__set__, c=conv):
            s(obj, c(v))

        setters[n] = setter
        converters[n] = conv
        if spec.is_array:
            if rule.nested is not None:
                copy_lines.append(f"    _s_{n}(n, [x._copy() for x in self.{n}])")
            elif spec.is_fixed_array and spec.base_type in TYPECODES:
                copy_lines.append(f"    _s_{n}(n, self.{n}.copy())")
            else:
                copy_lines.append(f"    _s_{n}(n, self.{n}[:])")
            if spec.is_bounded:
                copy_lines.append(f"    if len(self.{n}) > {spec.array_size}:\n"
                                  f"        _c_{n}(self.{n})")
            eq_terms.append(f"_seq_eq(self.{n}, other.{n})")
        else:
            if rule.nested is not None:
                copy_lines.append(f"    _s_{n}(n, self.{n}._copy())")
            else:
                copy_lines.append(f"    _s_{n}(n, self.{n})")
            eq_terms.append(f"self.{n} == other.{n}")
    g["_seq_eq"] = _seq_eq
    src = (f"def __init__(self, {', '.join(params)}):\n" + "\n".join(body or ["    pass"]) + "\n"
           "def _copy(self):\n    n = _new(_cls)\n" + "\n".join(copy_lines) + "\n    return n\n"
           "def __eq__(self, other):\n    if type(other) is not type(self):\n"
           "        return NotImplemented\n"
           f"    return {' and '.join(eq_terms) or 'True'}\n")
    exec(compile(src, f"<robocourse message {cls._type}>", "exec"), g)
    cls.__init__ = g["__init__"]
    cls._copy = g["_copy"]
    cls.__eq__ = g["__eq__"]
    cls._setters = setters
    cls._converters = converters

    def __setattr__(self, name, value, setters=setters, cls=cls):
        try:
            s = setters[name]
        except KeyError:
            raise AttributeError(
                f"{cls._type} has no field {name!r}; its fields are {list(setters)}") from None
        s(self, value)

    cls.__setattr__ = __setattr__


def _seq_eq(a, b) -> bool:
    if type(a) is type(b) and type(a) is not np.ndarray:
        return a == b            # list == list, array == array: element-wise in C
    if len(a) != len(b):
        return False
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b))
    return all(x == y for x, y in zip(a, b, strict=True))
