"""Probe-output schemas: what a check's probe may send back, checked by the judge side first.

Counterpart: the test-case format of otter-grader and Gradescope's ``results.json`` are
declared shapes too; nbgrader has no equivalent (its tests run inside the student's kernel).
Here the probe's data crosses from the student's process to the grader as JSON, and the first
record for a check may have been written by the student's own code. Nothing in it is trusted:
before a judge reads it, the record is validated against the schema its check declares, so a
judge never meets a value of the wrong kind, an empty list where cases were sent, a NaN that
makes every comparison false, or a string of 50 MB. A record that fails is the student's
failure, with a message naming where and what was wrong.

    from robocourse.grading.schema import Call, Dict, Int, List, Number, Str

    schema = Dict(good=List(Call(Int()), length="good"),      # one call record per input
                  bad=List(Call(), length="bad"))

``length="good"`` reads the length from the inputs (``len(inputs["good"])``); an int is a
fixed length. Every node takes ``label=`` (the words used in messages instead of the path).

Nodes: :class:`Number` (finite by default; ``integer=True`` wants an int), :class:`Int`,
:class:`Bool`, :class:`Str`, :class:`Null`, :class:`Opt`, :class:`OneOf`, :class:`List`,
:class:`Array` (nested lists of numbers with a shape; judged as a numpy array), :class:`Dict`
(fixed keys), :class:`Map` (string keys), :class:`Call` (a :func:`probes.call` record),
:class:`Hex` (bytes sent as hex) and :class:`Any` (any JSON, bounded). ``validate`` returns the
normalised value (numbers as Python floats/ints, ``"nan"`` strings read back, arrays as numpy)
and the list of problems.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any as _Any

import numpy as np

MAX_PROBLEMS = 8
_MISSING = object()


class SchemaError(ValueError):
    """A schema itself is wrong (the check author's mistake, raised at registration)."""


class Invalid(Exception):
    """Internal: stops validation of one value (the problem is already recorded)."""


def _show(value, limit=60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def _kind(value) -> str:
    if value is None:
        return "None"
    if isinstance(value, bool):
        return f"bool {value}"
    if isinstance(value, (int, float)):
        return f"{type(value).__name__} {value!r}"
    if isinstance(value, str):
        return f"str {_show(value, 40)}"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        if set(value) == {"type", "repr"}:  # probes.plain's rendering of an object it cannot send
            return f"a {value.get('type')} object"
        return f"a dict with keys {sorted(value)[:6]}"
    return type(value).__name__


class _Context:
    def __init__(self, inputs, max_problems):
        self.inputs = inputs
        self.problems: list[str] = []
        self.max_problems = max_problems

    def fail(self, path: str, message: str):
        if len(self.problems) < self.max_problems:
            self.problems.append(f"{path}: {message}" if path else message)
        raise Invalid()


class Node:
    """Base of every schema node; ``label`` replaces the path in messages."""

    label: str | None = None

    def _where(self, path: str) -> str:
        return self.label or path

    def check(self, value, path: str, ctx: _Context):  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self) -> str:
        return type(self).__name__.lower()


def _resolve_length(length, ctx: _Context, what: str):
    if length is None or isinstance(length, int):
        return length
    if isinstance(length, str):
        source = ctx.inputs.get(length) if isinstance(ctx.inputs, dict) else None
        if source is None:
            raise SchemaError(f"length={length!r}: the inputs have no list {length!r} to take the length of {what}")
        return len(source)
    if callable(length):
        return int(length(ctx.inputs))
    raise SchemaError(f"length must be None, an int, an inputs key or a function of the inputs; got {length!r}")


class Number(Node):
    """An int or float (never a bool); finite unless ``finite=False``; optional bounds.

    Non-finite numbers arrive as the strings "nan", "inf", "-inf" (JSON has none): read back.
    """

    def __init__(self, *, finite: bool = True, lo: float | None = None, hi: float | None = None,
                 integer: bool = False, label: str | None = None):
        self.finite, self.lo, self.hi, self.integer, self.label = finite, lo, hi, integer, label

    def describe(self):
        what = "an int" if self.integer else ("a finite number" if self.finite else "a number")
        if self.lo is not None and self.hi is not None:
            what += f" in [{self.lo:g}, {self.hi:g}]"
        elif self.lo is not None:
            what += f" >= {self.lo:g}"
        elif self.hi is not None:
            what += f" <= {self.hi:g}"
        return what

    def check(self, value, path, ctx):
        if isinstance(value, str) and value in ("nan", "inf", "-inf") and not self.integer:
            value = float(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            ctx.fail(self._where(path), f"expected {self.describe()}, got {_kind(value)}")
        if self.integer and not isinstance(value, int):
            ctx.fail(self._where(path), f"expected an int, got {_kind(value)}")
        if self.finite and isinstance(value, float) and not math.isfinite(value):
            ctx.fail(self._where(path), f"expected a finite number, got {value!r}")
        if (self.lo is not None and value < self.lo) or (self.hi is not None and value > self.hi):
            ctx.fail(self._where(path), f"expected {self.describe()}, got {value!r}")
        return value


def Int(*, lo: int | None = None, hi: int | None = None, label: str | None = None) -> Number:
    """An int (not a bool, not a float that happens to be whole)."""
    return Number(integer=True, lo=lo, hi=hi, label=label)


class Bool(Node):
    def __init__(self, *, label: str | None = None):
        self.label = label

    def describe(self):
        return "True or False"

    def check(self, value, path, ctx):
        if not isinstance(value, bool):
            ctx.fail(self._where(path), f"expected True or False, got {_kind(value)}")
        return value


class Str(Node):
    """A string of at most ``max_len`` characters, optionally one of ``choices``."""

    def __init__(self, *, max_len: int = 10_000, choices: tuple[str, ...] | None = None, label: str | None = None):
        self.max_len, self.choices, self.label = max_len, tuple(choices) if choices else None, label

    def describe(self):
        return f"one of {list(self.choices)}" if self.choices else "a string"

    def check(self, value, path, ctx):
        if not isinstance(value, str):
            ctx.fail(self._where(path), f"expected {self.describe()}, got {_kind(value)}")
        if len(value) > self.max_len:
            ctx.fail(self._where(path), f"a string of {len(value)} characters; at most {self.max_len} are read")
        if self.choices is not None and value not in self.choices:
            ctx.fail(self._where(path), f"expected {self.describe()}, got {_show(value)}")
        return value


class Null(Node):
    def __init__(self, *, label: str | None = None):
        self.label = label

    def describe(self):
        return "None"

    def check(self, value, path, ctx):
        if value is not None:
            ctx.fail(self._where(path), f"expected None, got {_kind(value)}")
        return None


class OneOf(Node):
    """The first alternative that accepts the value wins."""

    def __init__(self, *options: Node, label: str | None = None):
        if not options or not all(isinstance(o, Node) for o in options):
            raise SchemaError(f"OneOf needs schema nodes, got {options!r}")
        self.options, self.label = options, label

    def describe(self):
        return " or ".join(o.describe() for o in self.options)

    def check(self, value, path, ctx):
        for option in self.options:
            trial = _Context(ctx.inputs, 1)
            try:
                return option.check(value, path, trial)
            except Invalid:
                continue
        ctx.fail(self._where(path), f"expected {self.describe()}, got {_kind(value)}")


def Opt(node: Node, *, label: str | None = None) -> OneOf:
    """``node`` or None."""
    return OneOf(Null(), node, label=label)


class List(Node):
    """A list of ``item``; ``length`` exact (int, inputs key or function of the inputs) or bounds."""

    def __init__(self, item: Node, *, length=None, min_len: int = 0, max_len: int = 100_000,
                 label: str | None = None):
        if not isinstance(item, Node):
            raise SchemaError(f"List(item): item must be a schema node, got {item!r}")
        self.item, self.length, self.min_len, self.max_len, self.label = item, length, min_len, max_len, label

    def describe(self):
        return f"a list of {self.item.describe()}"

    def check(self, value, path, ctx):
        where = self._where(path)
        if not isinstance(value, list):
            ctx.fail(where, f"expected a list, got {_kind(value)}")
        want = _resolve_length(self.length, ctx, where)
        if want is not None and len(value) != want:
            ctx.fail(where, f"expected {want} item(s) (one per case the grader sent), got {len(value)}")
        if len(value) < self.min_len:
            ctx.fail(where, f"expected at least {self.min_len} item(s), got {len(value)}")
        if len(value) > self.max_len:
            ctx.fail(where, f"{len(value)} items; at most {self.max_len} are read")
        out, bad = [], False
        for i, v in enumerate(value):
            try:
                out.append(self.item.check(v, f"{where}[{i}]", ctx))
            except Invalid:
                bad = True
                if len(ctx.problems) >= ctx.max_problems:
                    break
        if bad:
            raise Invalid()
        return out


class Array(Node):
    """Nested lists of numbers with ``shape`` (None: any length on that axis): a numpy array.

    ``integer=True`` wants ints (an int64 array); otherwise ints and floats (a float64 array).
    Finite by default; ``lo``/``hi`` bound every element; ``max_items`` bounds the total.
    """

    def __init__(self, shape: tuple, *, integer: bool = False, finite: bool = True, lo: float | None = None,
                 hi: float | None = None, max_items: int = 1_000_000, label: str | None = None):
        if not isinstance(shape, tuple) or not shape:
            raise SchemaError(f"Array(shape): a tuple of lengths (None = any), e.g. (None, 3); got {shape!r}")
        self.shape, self.integer, self.finite, self.lo, self.hi = shape, integer, finite, lo, hi
        self.max_items, self.label = max_items, label

    def describe(self):
        dims = " x ".join("n" if d is None else str(d) for d in self.shape)
        return f"a {dims} array of {'ints' if self.integer else 'finite numbers' if self.finite else 'numbers'}"

    def check(self, value, path, ctx):
        where = self._where(path)
        flat = []
        level = [value]
        shape = []
        for axis, want in enumerate(self.shape):
            want = _resolve_length(want, ctx, where)
            lengths = set()
            nxt = []
            for v in level:
                if not isinstance(v, list):
                    ctx.fail(where, f"expected {self.describe()}; at depth {axis} found {_kind(v)}")
                lengths.add(len(v))
                nxt.extend(v)
                if len(nxt) > self.max_items:
                    ctx.fail(where, f"more than {self.max_items} numbers; at most {self.max_items} are read")
            if len(lengths) > 1:
                ctx.fail(where, f"rows of different lengths {sorted(lengths)[:5]} on axis {axis}")
            n = lengths.pop() if lengths else (want or 0)
            if want is not None and n != want and level:
                ctx.fail(where, f"expected length {want} on axis {axis}, got {n}")
            shape.append(n)
            level = nxt
        flat = level
        kinds = set(map(type, flat))
        if kinds - {int, float, str}:
            odd = next(v for v in flat if type(v) not in (int, float, str))
            ctx.fail(where, f"expected {self.describe()}, found {_kind(odd)}")
        if str in kinds:
            if self.integer:
                ctx.fail(where, f"expected ints, found {_kind(next(v for v in flat if isinstance(v, str)))}")
            conv = []
            for v in flat:
                if isinstance(v, str):
                    if v not in ("nan", "inf", "-inf"):
                        ctx.fail(where, f"expected numbers, found {_kind(v)}")
                    v = float(v)
                conv.append(v)
            flat = conv
        if self.integer and float in kinds:
            ctx.fail(where, f"expected ints, found {_kind(next(v for v in flat if isinstance(v, float)))}")
        try:
            arr = np.array(flat, dtype=np.int64 if self.integer else np.float64).reshape(shape)
        except OverflowError:
            ctx.fail(where, "an integer too large for 64 bits")
        if not self.integer and self.finite and arr.size and not np.all(np.isfinite(arr)):
            ctx.fail(where, f"expected finite numbers, found {float(arr.ravel()[~np.isfinite(arr.ravel())][0])!r}")
        if arr.size and ((self.lo is not None and arr.min() < self.lo) or (self.hi is not None and arr.max() > self.hi)):
            ctx.fail(where, f"values must lie in [{self.lo}, {self.hi}]; found {arr.min()!r}..{arr.max()!r}")
        return arr


class Dict(Node):
    """A dict with exactly the given keys (plus ``optional`` ones; others refused unless ``extra``)."""

    def __init__(self, fields: dict[str, Node] | None = None, *, optional: dict[str, Node] | None = None,
                 extra: bool = False, label: str | None = None, **kw_fields: Node):
        self.fields = dict(fields or {}, **kw_fields)
        self.optional = dict(optional or {})
        for k, v in {**self.fields, **self.optional}.items():
            if not isinstance(v, Node):
                raise SchemaError(f"Dict field {k!r}: expected a schema node, got {v!r}")
        self.extra, self.label = extra, label

    def describe(self):
        return f"a dict with keys {sorted(self.fields)}"

    def check(self, value, path, ctx):
        where = self._where(path)
        if not isinstance(value, dict):
            ctx.fail(where, f"expected {self.describe()}, got {_kind(value)}")
        missing = [k for k in self.fields if k not in value]
        if missing:
            ctx.fail(where, f"missing key(s) {missing}")
        unknown = [k for k in value if k not in self.fields and k not in self.optional]
        if unknown and not self.extra:
            ctx.fail(where, f"unexpected key(s) {sorted(map(str, unknown))[:6]}")
        out, bad = {}, False
        for k, node in list(self.fields.items()) + [(k, n) for k, n in self.optional.items() if k in value]:
            try:
                out[k] = node.check(value[k], f"{where}.{k}" if where else k, ctx)
            except Invalid:
                bad = True
                if len(ctx.problems) >= ctx.max_problems:
                    break
        if bad:
            raise Invalid()
        return out

    def check_parts(self, value, ctx) -> tuple[dict, dict[str, list[str]]]:
        """Validate each top-level key on its own: (normalised parts, {key: problems})."""
        if not isinstance(value, dict):
            ctx.fail("", f"expected {self.describe()}, got {_kind(value)}")
        unknown = [k for k in value if k not in self.fields and k not in self.optional]
        if unknown and not self.extra:
            ctx.fail("", f"unexpected key(s) {sorted(map(str, unknown))[:6]}")
        parts, problems = {}, {}
        for k, node in list(self.fields.items()) + list(self.optional.items()):
            if k not in value:
                if k in self.fields:
                    problems[k] = [f"{k}: missing"]
                continue
            sub = _Context(ctx.inputs, ctx.max_problems)
            try:
                parts[k] = node.check(value[k], k, sub)
            except Invalid:
                problems[k] = sub.problems
        return parts, problems


class Map(Node):
    """A dict with string keys (``keys``: the allowed ones, if given) and ``value`` values."""

    def __init__(self, value: Node, *, keys: tuple[str, ...] | None = None, max_items: int = 1000,
                 label: str | None = None):
        self.value, self.keys, self.max_items, self.label = value, tuple(keys) if keys else None, max_items, label

    def describe(self):
        return f"a dict of {self.value.describe()}"

    def check(self, value, path, ctx):
        where = self._where(path)
        if not isinstance(value, dict):
            ctx.fail(where, f"expected {self.describe()}, got {_kind(value)}")
        if len(value) > self.max_items:
            ctx.fail(where, f"{len(value)} entries; at most {self.max_items} are read")
        if self.keys is not None:
            unknown = [k for k in value if k not in self.keys]
            if unknown:
                ctx.fail(where, f"unexpected key(s) {[_show(k, 30) for k in unknown[:5]]}; the keys are {list(self.keys)}")
        out, bad = {}, False
        for k, v in value.items():
            try:
                out[k] = self.value.check(v, f"{where}[{_show(k, 30)}]", ctx)
            except Invalid:
                bad = True
        if bad:
            raise Invalid()
        return out


class Call(Node):
    """One :func:`probes.call` record: ``{"value": <value>, "type": name}`` or an exception.

    ``value``: the schema of what the student's function must return (default: any bounded
    JSON). ``raises=False`` makes an exception a schema failure too (rarely wanted: a judge
    usually names the input that raised).
    """

    def __init__(self, value: Node | None = None, *, raises: bool = True, label: str | None = None):
        self.value = value if value is not None else Any()
        self.raises, self.label = raises, label

    def describe(self):
        return f"a call returning {self.value.describe()}"

    def check(self, value, path, ctx):
        where = self._where(path)
        if not isinstance(value, dict):
            ctx.fail(where, f"expected a call record, got {_kind(value)}")
        if "raised" in value:
            if not self.raises:
                ctx.fail(where, f"your code raised {_show(value.get('raised'), 40)}: {_show(value.get('message'), 200)}")
            name, message, bases = value.get("raised"), value.get("message", ""), value.get("bases", [])
            if not isinstance(name, str) or len(name) > 200 or not isinstance(message, str) or len(message) > 2000 \
                    or not isinstance(bases, list) or len(bases) > 50 or not all(isinstance(b, str) and len(b) < 200
                                                                                 for b in bases):
                ctx.fail(where, "a malformed exception record")
            return {"raised": name, "message": message, "bases": bases or [name]}
        if set(value) - {"value", "type"} or "value" not in value:
            ctx.fail(where, f"expected a call record, got {_kind(value)}")
        kind = value.get("type", "")
        if not isinstance(kind, str) or len(kind) > 200:
            ctx.fail(where, "a malformed call record")
        got = value["value"]
        sub = _Context(ctx.inputs, 1)
        try:
            checked = self.value.check(got, "", sub)
        except Invalid:
            detail = sub.problems[0] if sub.problems else "malformed"
            ctx.fail(where, f"your function returned {kind or _kind(got)} {_show(got)}: {detail.lstrip(': ')}")
        return {"value": checked, "type": kind}


class Hex(Node):
    """Bytes sent as a hex string (at most ``max_bytes``): judged as ``bytes``."""

    def __init__(self, *, max_bytes: int = 65_536, label: str | None = None):
        self.max_bytes, self.label = max_bytes, label

    def describe(self):
        return "bytes"

    def check(self, value, path, ctx):
        where = self._where(path)
        if not isinstance(value, str) or len(value) > 2 * self.max_bytes:
            ctx.fail(where, f"expected at most {self.max_bytes} bytes as hex, got {_kind(value)}")
        try:
            return bytes.fromhex(value)
        except ValueError:
            ctx.fail(where, "not a hex string")


class Any(Node):
    """Any JSON value of at most ``max_items`` nested items and ``max_depth`` levels."""

    def __init__(self, *, max_items: int = 10_000, max_depth: int = 20, label: str | None = None):
        self.max_items, self.max_depth, self.label = max_items, max_depth, label

    def describe(self):
        return "a value"

    def check(self, value, path, ctx):
        stack, seen = [(value, 0)], 0
        while stack:
            v, depth = stack.pop()
            seen += 1
            if seen > self.max_items or depth > self.max_depth:
                ctx.fail(self._where(path), f"a value larger than the {self.max_items} items / {self.max_depth} levels "
                                            "this check reads")
            if isinstance(v, list):
                stack.extend((x, depth + 1) for x in v)
            elif isinstance(v, dict):
                stack.extend((x, depth + 1) for x in v.values())
            elif isinstance(v, str) and len(v) > 100_000:
                ctx.fail(self._where(path), f"a string of {len(v)} characters")
        return value


Schema = Node | Callable[[_Any], Node]


def resolve(schema: Schema, inputs) -> Node:
    """A schema, or a function of the inputs returning one."""
    node = schema(inputs) if callable(schema) and not isinstance(schema, Node) else schema
    if not isinstance(node, Node):
        raise SchemaError(f"a check's schema must be a schema node or a function of the inputs returning one; "
                          f"got {node!r}")
    return node


def validate(schema: Schema, value, inputs=None, *, max_problems: int = MAX_PROBLEMS):
    """(normalised value, problems): problems empty when ``value`` fits ``schema``."""
    node = resolve(schema, inputs)
    ctx = _Context(inputs, max_problems)
    try:
        return node.check(value, "", ctx), []
    except Invalid:
        return None, ctx.problems or ["malformed"]
    except RecursionError:
        return None, ["nested too deeply"]


def validate_parts(schema: Schema, value, inputs=None, *, max_problems: int = MAX_PROBLEMS):
    """Like :func:`validate`, but a :class:`Dict` schema is checked key by key.

    Returns (normalised parts or value, {part: problems}); the part ``""`` holds problems of
    the whole (not a dict, unknown keys), which invalidate every part.
    """
    node = resolve(schema, inputs)
    if not isinstance(node, Dict):
        checked, problems = validate(node, value, inputs, max_problems=max_problems)
        return checked, ({"": problems} if problems else {})
    ctx = _Context(inputs, max_problems)
    try:
        parts, problems = node.check_parts(value, ctx)
    except Invalid:
        return None, {"": ctx.problems or ["malformed"]}
    except RecursionError:
        return None, {"": ["nested too deeply"]}
    return parts, problems
