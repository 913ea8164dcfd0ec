"""Checks: a probe that gathers the student's outputs, a judge that decides, a weight.

Like otter-grader's ``grader.check("q1")`` and nbgrader's weighted test cells, with one rule
they do not have: the verdict is never computed by the student's process. A check is three
small functions:

- ``inputs(rng) -> data``: fresh (randomised where the task allows) plain inputs, made by
  the grader;
- ``probe(inputs, *objects) -> data``: runs in the student's process (inside the sandbox under
  ``robocourse grade``), calls the student's objects on the inputs and returns only what they
  produced, as plain data (numbers, strings, lists, dicts);
- ``judge(inputs, outputs) -> message``: runs in the grader's process, computes the reference
  the same way and either returns a message (pass) or raises ``CheckFailed`` with every
  problem it found.

In a notebook, ``check("ch00.to_ns", to_ns)`` runs all three in the student's kernel at once
for instant feedback; ``score("ch00")`` prints "Score: X/Y". The bulk grader ignores whatever
the notebook computed: it sends the inputs into the sandbox, reads back the probe's data and
judges it itself. Chapters register their checks in ``robocourse/<chapter>/checks.py`` and
declare that module as a ``robocourse.checks`` entry point; ``discover`` loads the entry
points, so this package never names (or imports by pattern) a chapter.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.metadata
import importlib.util
import inspect
import json
import os
import re
import signal
import sys
import threading
import time
import traceback
import types
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

EXTRA_CHECKS_ENV = "ROBOCOURSE_EXTRA_CHECKS"
ENTRY_POINTS = "robocourse.checks"  # the group chapters declare their checks module in
GRADING_ENV = "ROBOCOURSE_GRADING"  # set to "1" in every grading sandbox
#: a check cell's call in a notebook: ``check("ch01.jitter_stats", ...)``
CHECK_CALL = re.compile(r"""\bcheck\(\s*["']([A-Za-z_][\w]*\.[\w.]+)["']""")
MAX_LISTED = 8  # problems listed per check; the rest are counted
MAX_LINE = 400  # characters per feedback line (a student's value can be any size)
DEFAULT_MAX_BYTES = 2_000_000  # a probe record's size budget (JSON bytes) unless the check says otherwise
DEFAULT_JUDGE_S = 20.0  # a judge's time budget per record unless the check says otherwise


class CheckFailed(AssertionError):
    """Raise from a judge to fail the check; pass several messages to list every problem."""

    def __init__(self, *messages: str):
        self.messages = [str(m) for m in messages if str(m)]
        super().__init__("\n".join(self.messages))


class CheckTimeout(Exception):
    """A probe ran longer than its time limit."""


class JudgeTimeout(Exception):
    """A judge ran past its time budget (the check's fault once the record passed its schema)."""


class CheckDirError(ValueError):
    """An instructor's check folder cannot be loaded (one line: file, line, what is wrong)."""


class Failures:
    """Collect every problem a judge finds, then raise them together (students see them all).

    >>> f = Failures(); f.expect(1 + 1 == 2, "arithmetic"); f.done("fine")
    'fine'
    """

    def __init__(self):
        self.messages: list[str] = []

    def add(self, message: str) -> None:
        if message not in self.messages:
            self.messages.append(message)

    def expect(self, ok: bool, message: str) -> bool:
        if not ok:
            self.add(message)
        return bool(ok)

    def done(self, success_message: str) -> str:
        if self.messages:
            shown = self.messages[:MAX_LISTED]
            if len(self.messages) > MAX_LISTED:
                shown.append(f"... and {len(self.messages) - MAX_LISTED} more problem(s) like these")
            raise CheckFailed(*shown)
        return success_message


@dataclass(frozen=True)
class SubTest:
    """One scored part of a check (otter: a test case with points; Gradescope: one test).

    ``judge(inputs, outputs) -> message`` passes by returning and fails by raising
    ``CheckFailed``; ``reads``: the top-level keys of the check's :class:`schema.Dict` it
    reads (a malformed part fails only the sub-tests reading it; None: it reads everything).
    """

    name: str
    weight: float
    judge: Callable[[Any, Any], Any]
    reads: tuple[str, ...] | None = None

    @classmethod
    def _single(cls, judge, weight: float) -> SubTest:
        """The one unnamed sub-test of a check registered with a single judge (all or nothing)."""
        st = cls.__new__(cls)
        for k, v in (("name", ""), ("weight", weight), ("judge", judge), ("reads", None)):
            object.__setattr__(st, k, v)
        return st

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"a sub-test needs a name a student understands, got {self.name!r}")
        if not (isinstance(self.weight, (int, float)) and not isinstance(self.weight, bool) and self.weight > 0):
            raise ValueError(f"sub-test {self.name!r}: weight must be a positive number, got {self.weight!r}")
        if not callable(self.judge):
            raise ValueError(f"sub-test {self.name!r}: judge must be a function judge(inputs, outputs) -> message")
        if self.reads is not None:
            object.__setattr__(self, "reads", (self.reads,) if isinstance(self.reads, str) else tuple(self.reads))


@dataclass(frozen=True)
class Check:
    """One graded check (otter: a test case file; nbgrader: an autograder cell)."""

    name: str
    judge: Callable[[Any, Any], Any] | None
    probe: Callable[..., Any]
    uses: tuple[str, ...]
    inputs: Callable[[np.random.Generator], Any] | None = None
    weight: float = 1.0
    time_limit: float = 10.0
    description: str = ""
    #: "module:qualname" of the library implementations this exercise asks the student to write
    #: themselves; calling one from the probed code earns nothing for this check.
    references: tuple[str, ...] = ()
    #: False for an instructor's hidden check (graded even when the notebook never calls it).
    in_notebook: bool = True
    #: the declared form of the probe's outputs (robocourse.grading.schema), validated before judging
    schema: Any = None
    #: the scored parts; a check registered with one judge has one sub-test named ""
    subtests: tuple[SubTest, ...] = ()
    #: the largest probe record (JSON bytes) the judge reads, and its time budget per record
    max_bytes: int = DEFAULT_MAX_BYTES
    judge_time_limit: float = DEFAULT_JUDGE_S
    #: the module that registered the check (its judge side)
    module: str = ""
    #: the check judges real time (a loop against a box on the wall clock): the grader gives its
    #: submission a CPU to itself where it can, and says so where it cannot
    timing: bool = False

    def make_inputs(self, rng: np.random.Generator | None = None):
        return self.inputs(rng if rng is not None else np.random.default_rng()) if self.inputs else None


def seed_for(name: str, digest: str = "", salt: str = "") -> int:
    """The seed of check ``name``'s draws for the submission whose content hash is ``digest``.

    The same submission always gets the same draws (a regrade gives the same score); another
    file, or another ``salt`` (a course's own), gets others. 32 bits, shown in the feedback.
    """
    import hashlib

    h = hashlib.sha256(f"robocourse-draws|{salt}|{name}|{digest}".encode()).digest()
    return int.from_bytes(h[:4], "big")


def fresh_seed() -> int:
    return int.from_bytes(os.urandom(4), "big")


@dataclass
class Result:
    name: str
    passed: bool
    points: float
    weight: float
    message: str
    seconds: float = 0.0
    #: "", "not_implemented", "timeout", "raised", "delegated", "missing", "check_error", "no_output",
    #: "malformed" (the record does not fit the check's schema), "oversize", "tampered"
    reason: str = ""
    extra: dict = field(default_factory=dict)
    #: [{"name", "weight", "points", "passed", "message", "reason"}], one per sub-test
    subtests: list = field(default_factory=list)
    seed: int | None = None
    judge_seconds: float = 0.0

    def line(self) -> str:
        return "\n".join(render(self.name, self.to_dict()))

    def __str__(self) -> str:
        return self.line()

    def _ipython_display_(self):
        """check() has already printed this result; a check cell shows nothing more (no raw repr)."""

    def to_dict(self) -> dict:
        return {"name": self.name, "passed": self.passed, "points": self.points, "weight": self.weight,
                "message": self.message, "seconds": round(self.seconds, 4), "reason": self.reason,
                "subtests": self.subtests, "seed": self.seed, "judge_seconds": round(self.judge_seconds, 4)}


def render(name: str, r: dict, where: str = "") -> list[str]:
    """A check's feedback lines (notebook and grader alike): mark, points, seed, then each
    sub-test with its problems; a failure shared by every sub-test (the code raised, the output
    was malformed) is said once."""
    mark = "PASS" if r["passed"] else "FAIL"
    seed = f" [seed {r['seed']}]" if r.get("seed") is not None else ""
    head = f"[{mark}] {name}{where} ({r['points']:g}/{r['weight']:g}){seed}: "
    named = [s for s in r.get("subtests") or [] if s.get("name")]
    shared = len(named) > 1 and all(not s["passed"] for s in named) and len({s["message"] for s in named}) == 1
    if named and not shared:
        failed = sum(not s["passed"] for s in named)
        out = [head + (f"all {len(named)} sub-tests passed" if not failed else
                       f"{failed} of {len(named)} sub-tests failed")]
        for s in named:
            out += _subtest_lines(s, "    ")
        return out
    msg = (named[0]["message"] if shared else str(r["message"])).splitlines() or [""]
    if len(msg) == 1:
        return [head + msg[0]]
    return [head + f"{len(msg)} problems"] + [f"    - {m}" for m in msg]


def _subtest_lines(s: dict, indent: str) -> list[str]:
    """A sub-test as feedback lines: its mark, name and points, then its problems."""
    msg = str(s.get("message", "")).splitlines() or [""]
    if s["passed"] and msg[0] in ("passed", s["name"]):
        msg = [""]
    head = f"{indent}[{'PASS' if s['passed'] else 'FAIL'}] {s['name']} ({s['points']:g}/{s['weight']:g})"
    if len(msg) == 1:
        return [f"{head}: {msg[0]}" if msg[0] else head]
    return [f"{head}:"] + [f"{indent}    - {m}" for m in msg]


_REGISTRY: dict[str, Check] = {}
_RESULTS: dict[str, Result] = {}
_DISCOVERED = False


def register(name: str, *, uses: tuple[str, ...] | str, probe: Callable[..., Any],
             inputs: Callable[[np.random.Generator], Any] | None = None, weight: float | None = None,
             time_limit: float = 10.0, references: tuple[str, ...] = (), in_notebook: bool | None = None,
             schema=None, subtests: list[SubTest] | None = None, max_bytes: int = DEFAULT_MAX_BYTES,
             judge_time_limit: float = DEFAULT_JUDGE_S, timing: bool = False):
    """Register check ``name`` ("chNN.short_name").

    Two forms. With ``subtests=[SubTest(...), ...]`` the check is registered at once (its
    weight is the sum of theirs) and returned. Without, ``register(...)`` is a decorator on a
    single judge (one sub-test, all or nothing, ``weight`` default 1).

    ``uses``: the notebook globals the probe receives, in order (the names the exercise asks
    for). ``schema``: the form of the probe's outputs (:mod:`robocourse.grading.schema`, or a
    function of the inputs returning one); every record is validated against it before a judge
    reads it, and a check with a schema must keep its probe out of its judge's module (the
    grading sandbox hides judge modules: answer keys are never importable there).
    ``max_bytes``/``judge_time_limit``: the record's size budget and the judge's time budget.
    ``timing``: the check judges real time; its submission gets a CPU to itself where possible.
    ``in_notebook``: default True for library checks, False for checks loaded from an
    instructor's folder (hidden checks the notebook never calls).
    """
    _validate_name(name)
    uses = (uses,) if isinstance(uses, str) else tuple(uses)
    if not uses or not all(isinstance(u, str) and u.isidentifier() for u in uses):
        raise ValueError(f"check {name!r}: uses must name the notebook globals the probe receives, "
                         f"e.g. uses=('to_ns',); got {uses!r}")
    if not callable(probe):
        raise ValueError(f"check {name!r}: probe must be a function probe(inputs, *objects) -> plain data; "
                         f"got {probe!r}. Use robocourse.grading.probes.calls for plain function calls")
    if inputs is not None and not callable(inputs):
        raise ValueError(f"check {name!r}: inputs must be a function inputs(rng) -> plain data or None")
    if weight is not None and not (isinstance(weight, (int, float)) and weight > 0):
        raise ValueError(f"check {name!r}: weight must be a positive number, got {weight!r}")
    if not (isinstance(time_limit, (int, float)) and time_limit > 0):
        raise ValueError(f"check {name!r}: time_limit must be positive seconds, got {time_limit!r}")
    if not (isinstance(max_bytes, int) and max_bytes >= 1000):
        raise ValueError(f"check {name!r}: max_bytes must be an int >= 1000 (JSON bytes of one record), "
                         f"got {max_bytes!r}")
    if not (isinstance(judge_time_limit, (int, float)) and judge_time_limit > 0):
        raise ValueError(f"check {name!r}: judge_time_limit must be positive seconds, got {judge_time_limit!r}")
    if schema is not None:
        from .schema import Node

        if not (isinstance(schema, Node) or callable(schema)):
            raise ValueError(f"check {name!r}: schema must be a robocourse.grading.schema node or a function "
                             f"inputs -> node; got {schema!r}")

    def add(parts: tuple[SubTest, ...], module: str, description: str) -> Check:
        probe_module = getattr(probe, "__module__", "") or ""
        if schema is not None and module.startswith("robocourse.") and probe_module == module:
            raise ValueError(
                f"check {name!r}: its probe {probe.__qualname__} lives in {module}, the module of its judges. "
                "The grading sandbox hides judge modules (answer keys must not be importable there), so move the "
                f"probe to a module the student's process may import, e.g. {module.rsplit('.', 1)[0]}.probes")
        total = float(sum(p.weight for p in parts))
        chk = Check(name, None if len(parts) != 1 or parts[0].name else parts[0].judge, probe, uses, inputs,
                    total, float(time_limit), description, tuple(references),
                    module.startswith("robocourse.") if in_notebook is None else bool(in_notebook), schema, parts,
                    int(max_bytes), float(judge_time_limit), module, bool(timing))
        _REGISTRY[name] = chk
        return chk

    if subtests is not None:
        parts = tuple(subtests)
        if not parts or not all(isinstance(p, SubTest) for p in parts):
            raise ValueError(f"check {name!r}: subtests must be a non-empty list of SubTest(name, weight, judge)")
        names = [p.name for p in parts]
        if len(set(names)) != len(names):
            raise ValueError(f"check {name!r}: sub-test names must differ, got {names}")
        total = sum(p.weight for p in parts)
        if weight is not None and abs(weight - total) > 1e-9:
            raise ValueError(f"check {name!r}: weight={weight!r} but the sub-tests' weights sum to {total:g}; "
                             "leave weight out (it is their sum)")
        module = getattr(parts[0].judge, "__module__", "") or sys._getframe(1).f_globals.get("__name__", "")
        return add(parts, module, "")

    def decorate(judge):
        module = getattr(judge, "__module__", "") or ""
        shown = (judge.__doc__ or "").strip().splitlines()
        add((SubTest._single(judge, 1.0 if weight is None else float(weight)),), module,
            shown[0] if shown else "")
        return judge

    return decorate


def _validate_name(name):
    if not isinstance(name, str) or "." not in name or not all(part.isidentifier() for part in name.split(".")):
        raise ValueError(
            f"check name must look like 'ch01.jitter_stats' (dot-separated identifiers), got {name!r}"
        )


def discover(extra_dirs: list[str | os.PathLike] | None = None) -> dict[str, Check]:
    """Import every ``robocourse.<package>.checks`` module and every ``*.py`` in extra_dirs.

    Chapter modules are the ``robocourse.checks`` entry points each chapter declares in
    pyproject.toml (the plugin pattern of pytest's ``pytest11``): grading names no chapter and
    imports none by pattern, so no import cycle runs through it. Extra directories come from the argument and from ``ROBOCOURSE_EXTRA_CHECKS``
    (os.pathsep-separated): that is how an instructor adds hidden checks.
    """
    global _DISCOVERED
    if not _DISCOVERED:
        for entry in importlib.metadata.entry_points(group=ENTRY_POINTS):
            entry.load()
        _DISCOVERED = True
    dirs = list(extra_dirs or [])
    dirs += [d for d in os.environ.get(EXTRA_CHECKS_ENV, "").split(os.pathsep) if d]
    for d in dirs:
        load_check_dir(d)
    return dict(_REGISTRY)


_DIR_CHECKS: dict[Path, list[str]] = {}


def load_check_dir(directory) -> list[str]:
    """Import every ``*.py`` file of an instructor's check directory; return its check names.

    A file that does not import (syntax error, missing name) raises ``CheckDirError`` with one
    line naming the file, the line and the problem. Each directory is imported once per process.
    """
    path = Path(directory)
    if not path.is_dir():
        raise CheckDirError(
            f"checks directory {str(path)!r} does not exist; pass a folder of .py files "
            "that use @robocourse.grading.register(...)"
        )
    path = path.resolve()
    if path not in _DIR_CHECKS:
        before = set(_REGISTRY)
        for file in sorted(path.glob("*.py")):
            spec = importlib.util.spec_from_file_location(f"robocourse_extra_checks.{file.stem}", file)
            module = importlib.util.module_from_spec(spec)
            try:
                spec.loader.exec_module(module)
            except SyntaxError as exc:
                raise CheckDirError(f"{file}:{exc.lineno}: SyntaxError: {exc.msg}; fix the check file "
                                    "(python -m py_compile FILE shows the same)") from None
            except Exception as exc:
                tb = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == str(file)]
                line = tb[-1].lineno if tb else "?"
                raise CheckDirError(f"{file}:{line}: {type(exc).__name__}: {exc}; the check file must "
                                    "import cleanly") from None
        _DIR_CHECKS[path] = sorted(set(_REGISTRY) - before)
    return list(_DIR_CHECKS[path])


def get(name: str) -> Check:
    discover()
    try:
        return _REGISTRY[name]
    except KeyError:
        prefix = name.split(".")[0]
        near = sorted(n for n in _REGISTRY if n.startswith(prefix + "."))
        hint = f" Checks of {prefix}: {', '.join(near)}." if near else ""
        raise KeyError(f"no check named {name!r}.{hint} Did you update robocourse (make setup)?") from None


# -- the probe side (runs where the student's code runs) --------------------------------------

@contextlib.contextmanager
def _time_limit(seconds: float, exc_type=CheckTimeout, message: str | None = None):
    """Raise ``exc_type`` in the main thread after ``seconds`` (SIGALRM); elsewhere no limit.

    Stops a student's endless Python loop in a probe (and a judge past its budget). The bulk
    grader additionally kills the whole sandbox after its own wall-time limit, whatever the
    code does.
    """
    usable = (hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread())
    if not usable:
        yield
        return

    def on_alarm(signum, frame):
        raise exc_type(message or f"took longer than its {seconds:g} s time limit")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    old = signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, *old)
        signal.signal(signal.SIGALRM, previous)


def resolve(ref: str):
    """'package.module:Qual.name' -> the object (a reference implementation or a probe)."""
    module, _, qual = ref.partition(":")
    obj = importlib.import_module(module)
    for part in qual.split("."):
        obj = getattr(obj, part)
    return obj


def _reference_functions(references) -> list[tuple[Any, str]]:
    """(function, "module:qualname") for every reference function (and a class's methods)."""
    out = []
    for ref in references:
        try:
            obj = resolve(ref)
        except (ImportError, AttributeError):
            continue
        members = [obj]
        if inspect.isclass(obj):
            members = []
            for v in vars(obj).values():
                v = getattr(v, "__func__", v)  # staticmethod / classmethod
                if isinstance(v, property):
                    members += [f for f in (v.fget, v.fset, v.fdel) if f is not None]
                elif inspect.isfunction(v):
                    members.append(v)
        for m in members:
            m = inspect.unwrap(m)
            if inspect.isfunction(m):
                out.append((m, ref))
    return out


# Delegation on every thread: while a probe runs, each reference function's code is swapped for
# a trampoline that notes the call and runs the original (a copy of the function with the
# original code), so a call from any thread (a pool, a thread started in an earlier cell) is
# seen. A profile hook on the probing thread and on threads started during the probe also sees
# copies of a reference's code object.
_TRIPWIRE = "__robocourse_tripwire__"
_ORIGINALS: dict[int, Any] = {}
_TRIPWIRE_HITS: list[tuple[set, dict]] = []  # the active probes' (hits, key -> ref)
_TRIPWIRE_LOCK = threading.Lock()


def _tripwire_call(key, args, kwargs):
    for hits, refs in list(_TRIPWIRE_HITS):
        if key in refs:
            hits.add(refs[key])
    return _ORIGINALS[key](*args, **kwargs)


def _trampoline_code(nfree: int, key: int):
    """A code object calling the tripwire with ``key``, with ``nfree`` (unused) free variables so
    it fits the swapped function's closure."""
    names = [f"_v{i}" for i in range(nfree)]
    body = [f"    {n} = None" for n in names] + ["    def _tripwire(*args, **kwargs):"]
    if names:
        body.append(f"        ({', '.join(names)},)")
    body += [f"        return {_TRIPWIRE}({key}, args, kwargs)", "    return _tripwire"]
    namespace: dict = {}
    exec(compile("def _outer():\n" + "\n".join(body) + "\n", "<robocourse tripwire>", "exec"), namespace)
    return namespace["_outer"]().__code__


@contextlib.contextmanager
def _tripwire(references):
    hits: set[str] = set()
    functions = _reference_functions(references)
    codes = {f.__code__: ref for f, ref in functions}
    refs: dict[int, str] = {}
    swapped = []
    with _TRIPWIRE_LOCK:
        for func, ref in functions:
            key = id(func)
            if func.__code__.co_name == "_tripwire" and key in _ORIGINALS:  # already swapped (nested probe)
                refs[key] = ref
                continue
            original = types.FunctionType(func.__code__, func.__globals__, func.__name__, func.__defaults__,
                                          func.__closure__)
            original.__kwdefaults__ = func.__kwdefaults__
            original.__qualname__ = func.__qualname__
            _ORIGINALS[key] = original
            func.__globals__[_TRIPWIRE] = _tripwire_call
            saved = func.__code__
            try:
                func.__code__ = _trampoline_code(len(saved.co_freevars), key)
            except (ValueError, TypeError):
                continue  # left to the profile hook
            swapped.append((func, saved))
            refs[key] = ref
        _TRIPWIRE_HITS.append((hits, refs))
    active = [True]

    def hook(frame, event, arg):
        if not active[0]:
            sys.setprofile(None)  # a thread started during the probe outlived it
            return
        if event == "call":
            ref = codes.get(frame.f_code)
            if ref is not None:
                hits.add(ref)

    previous_thread_hook = threading.getprofile() if hasattr(threading, "getprofile") else None
    previous = sys.getprofile()
    if codes:
        threading.setprofile(hook)
        sys.setprofile(hook)
    try:
        yield hits
    finally:
        active[0] = False
        if codes:
            sys.setprofile(previous)
            threading.setprofile(previous_thread_hook)
        with _TRIPWIRE_LOCK:
            for func, saved in swapped:
                func.__code__ = saved
            _TRIPWIRE_HITS[:] = [h for h in _TRIPWIRE_HITS if h[0] is not hits]


def run_probe(chk: Check, inputs, objects) -> dict:
    """Run ``chk``'s probe on the student's objects; return plain data, never a verdict.

    ``{"outputs": ..., "error": "..."|None, "reason": ..., "delegated": [...], "seconds": s}``.
    While the student's code runs, every call into a reference implementation listed in
    ``chk.references``, from any thread, is noted (delegation earns nothing).
    """
    from .probes import plain

    delegated: set[str] = set()
    for ref in chk.references:
        try:
            ref_obj = resolve(ref)
        except (ImportError, AttributeError):
            continue
        for obj in objects:
            target = getattr(obj, "func", obj)  # a functools.partial of the reference
            if target is ref_obj or (inspect.isclass(target) and inspect.isclass(ref_obj)
                                     and issubclass(target, ref_obj)):
                delegated.add(ref)

    out = {"outputs": None, "error": None, "reason": "", "delegated": [], "seconds": 0.0}
    start = time.perf_counter()
    try:
        with _time_limit(chk.time_limit):
            with _tripwire(chk.references) as hits:
                try:
                    raw = chk.probe(inputs, *objects)
                finally:
                    delegated |= hits
        out["outputs"] = plain(raw)
    except CheckTimeout as exc:
        out["error"], out["reason"] = f"{exc}. Look for an endless loop or a too-slow algorithm.", "timeout"
    except NotImplementedError:
        out["error"], out["reason"] = ("not implemented yet: replace `raise NotImplementedError` with your code.",
                                       "not_implemented")
    except Exception as exc:  # the student's code raised: say where, briefly
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" (line {tb[-1].lineno} in {tb[-1].name})" if tb else ""
        out["error"], out["reason"] = f"your code raised {type(exc).__name__}: {str(exc)[:300]}{where}", "raised"
    out["seconds"] = round(time.perf_counter() - start, 4)
    out["delegated"] = sorted(delegated)
    return out


# -- the judge side (the grader's own process) -------------------------------------------------

PROBE_REASONS = ("timeout", "not_implemented", "raised", "missing")


def _cut(message: str) -> str:
    return "\n".join(m if len(m) <= MAX_LINE else m[:MAX_LINE] + " [...]" for m in str(message).splitlines())


def judge(chk: Check, inputs, probed: dict | None, *, nbytes: int | None = None, seed: int | None = None) -> Result:
    """Turn a probe's data into a Result: decided here, per sub-test, capped at the weight.

    ``probed`` is untrusted data (from the sandbox). In order: the record's envelope (an error
    the probe reported, delegation), its size (``nbytes`` of JSON, or measured here) against
    ``chk.max_bytes``, its form against ``chk.schema``; then each sub-test judges the parts it
    reads, within ``chk.judge_time_limit`` in all. A record that fails any of these is the
    student's failure with a message; a judge that raises anything but ``CheckFailed`` on a
    validated record (or on any record, for a hidden check) is a bug in the check: the Result
    says so (reason "check_error") and the student is not blamed.
    """
    start = time.perf_counter()
    probe_seconds = None
    if isinstance(probed, dict) and isinstance(probed.get("seconds"), (int, float)) \
            and not isinstance(probed.get("seconds"), bool):
        probe_seconds = float(probed["seconds"])

    def finish(subs: list[dict], reason: str = "", extra: dict | None = None) -> Result:
        points = min(chk.weight, sum(s["points"] for s in subs))
        passed = all(s["passed"] for s in subs)
        if len(subs) == 1 and not subs[0]["name"]:
            message = subs[0]["message"]
        elif passed:
            message = "; ".join(s["message"] for s in subs if s["message"])
        elif all(not s["passed"] for s in subs) and len({s["message"] for s in subs}) == 1:
            message = subs[0]["message"]
        else:
            message = "\n".join(f"{s['name']}: {line}" for s in subs if not s["passed"]
                                for line in (s["message"].splitlines() or [""]))
        if not reason:
            reason = next((s["reason"] for s in subs if not s["passed"] and s["reason"]), "")
        judged = time.perf_counter() - start
        return Result(chk.name, passed, points, chk.weight, message,
                      probe_seconds if probe_seconds is not None else judged, reason, extra or {}, subs, seed,
                      judged)

    def sub(st: SubTest, passed: bool, message: str, reason: str = "") -> dict:
        return {"name": st.name, "weight": st.weight, "points": st.weight if passed else 0.0, "passed": passed,
                "message": _cut(message), "reason": "" if passed else reason}

    def everything(passed: bool, message: str, reason: str = "", extra=None) -> Result:
        return finish([sub(st, passed, message, reason) for st in chk.subtests], reason, extra)

    if not isinstance(probed, dict):
        return everything(False, "no output reached the grader for this check", "no_output")
    if probed.get("tampered"):
        return everything(False, str(probed.get("tampered"))[:500], "tampered")
    if probed.get("oversize"):
        return everything(False, _oversize(chk, probed.get("oversize")), "oversize")
    if probed.get("error"):
        reason = probed.get("reason") if probed.get("reason") in PROBE_REASONS else "raised"
        return everything(False, str(probed["error"])[:2000], reason)
    delegated = probed.get("delegated") or []
    if delegated and isinstance(delegated, list):
        names = ", ".join(str(d).replace(":", ".") for d in delegated[:3])
        return everything(False, f"this exercise asks you to write it yourself, but your code calls the library's "
                                 f"{names}, the reference the grader compares with: no points for this check",
                          "delegated")
    outputs = probed.get("outputs")
    if nbytes is None:
        try:
            nbytes = len(json.dumps(outputs))
        except (TypeError, ValueError, RecursionError):
            return everything(False, "the output of this check is not plain data the grader can read", "malformed")
    if nbytes > chk.max_bytes:
        return everything(False, _oversize(chk, nbytes), "oversize")
    try:
        with _time_limit(chk.judge_time_limit, JudgeTimeout,
                         f"the judge ran past its {chk.judge_time_limit:g} s budget"):
            subs, extra = _judge_subtests(chk, inputs, outputs, sub)
    except JudgeTimeout as exc:
        return everything(False, "this check could not be graded in its time budget; your instructor has been told",
                          "check_error", {"instructor": f"{chk.name}: {exc} on a record of {nbytes} bytes"})
    return finish(subs, "", extra)


def _oversize(chk: Check, nbytes) -> str:
    return (f"your code's output for this check is {nbytes} bytes; the check reads at most {chk.max_bytes} "
            "(an answer this large is not what the exercise asks for: look for a result that grows without bound)")


def _judge_subtests(chk: Check, inputs, outputs, sub) -> tuple[list[dict], dict]:
    problems: dict[str, list[str]] = {}
    data = outputs
    if chk.schema is not None:
        from .schema import validate_parts

        data, problems = validate_parts(chk.schema, outputs, inputs)
    results, extra = [], {}
    for st in chk.subtests:
        if problems:
            bad = list(problems.get("", []))
            for key in (st.reads if st.reads is not None else list(problems)):
                bad += problems.get(key, [])
            if bad:
                results.append(sub(st, False, "what your code returned does not have the form this check reads:\n"
                                   + "\n".join(bad[:MAX_LISTED]), "malformed"))
                continue
        try:
            message = st.judge(inputs, data)
        except CheckFailed as exc:
            results.append(sub(st, False, "\n".join(exc.messages) or "the check failed"))
            continue
        except JudgeTimeout:
            raise
        except AssertionError as exc:
            results.append(sub(st, False, str(exc) or "an assertion in the check failed"))
            continue
        except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
            if chk.in_notebook and chk.schema is None:
                # an unported library judge meeting data of the wrong shape: the student's output is malformed
                results.append(sub(st, False, f"your code returned something of an unexpected type or shape "
                                              f"({type(exc).__name__}: {str(exc)[:200]}); read the exercise's "
                                              "docstring", "malformed"))
                continue
            results.append(_error_sub(chk, st, exc, sub, extra))
            continue
        except Exception as exc:
            results.append(_error_sub(chk, st, exc, sub, extra))
            continue
        results.append(sub(st, True, message if isinstance(message, str) and message else "passed"))
    return results, extra


def _error_sub(chk: Check, st: SubTest, exc: BaseException, sub, extra: dict) -> dict:
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" ({Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
    what = f" (sub-test {st.name!r})" if st.name else ""
    extra["instructor"] = (extra.get("instructor", "") + "; " if extra.get("instructor") else "") + \
        f"{chk.name}{what}: the judge raised {type(exc).__name__}: {str(exc)[:300]}{where}"
    return sub(st, False, "this check could not be graded because the check itself failed; your instructor has been "
                          "told", "check_error")


def run_check(chk: Check, *objects, rng: np.random.Generator | None = None, seed: int | None = None) -> Result:
    """Probe and judge in this process (the notebook's instant feedback, and tests).

    The draws come from ``rng`` if given, else from ``seed`` (a fresh one if None), which the
    Result shows so the same draws can be asked for again: ``check(name, obj, seed=...)``.
    """
    if rng is None:
        seed = fresh_seed() if seed is None else int(seed)
        rng = np.random.default_rng(seed)
    inputs = chk.make_inputs(rng)
    return judge(chk, inputs, run_probe(chk, inputs, objects), seed=seed if chk.inputs is not None else None)


def check(name: str, *objects, quiet: bool = False, seed: int | None = None) -> Result:
    """Run check ``name`` on ``objects`` now, print instant feedback, remember the result.

    ``seed``: repeat the draws a result showed (``[seed N]``). Under ``robocourse grade`` this
    cell does nothing: the grader probes the same objects again with its own inputs and
    judges outside the notebook (the judges are not even importable there).
    """
    if os.environ.get(GRADING_ENV) == "1":
        # inside ``robocourse grade``'s sandbox: the grader probes these objects itself after this
        # cell and judges outside; the judge modules are hidden here
        result = Result(name, False, 0.0, 0.0, "graded by robocourse grade, outside this notebook",
                        reason="deferred")
        _RESULTS[name] = result
        return result
    chk = get(name)
    if len(objects) != len(chk.uses):
        raise TypeError(f"check({name!r}, ...) takes {len(chk.uses)} object(s): {', '.join(chk.uses)}; "
                        f"got {len(objects)}")
    result = run_check(chk, *objects, seed=seed)
    _RESULTS[name] = result
    if not quiet:
        print(result.line())
    return result


def results() -> dict[str, Result]:
    return dict(_RESULTS)


def reset() -> None:
    """Forget this session's results (tests; or a student starting over)."""
    _RESULTS.clear()


def judge_side_modules(registry: dict[str, Check] | None = None) -> list[str]:
    """Library modules that register judges and hold no probe: the grading sandbox hides them.

    A chapter whose checks declare schemas keeps its probes in another module (``probes.py``),
    so its ``checks.py`` (judges, answer keys, expected values) never reaches a submission.
    """
    reg = _REGISTRY if registry is None else registry
    judges = {c.module for c in reg.values() if c.module.startswith("robocourse.")}
    probes = {getattr(c.probe, "__module__", "") or "" for c in reg.values()}
    return sorted(m for m in judges - probes if not m.startswith("robocourse.grading"))


class Score(tuple):
    """(points, max points); a score cell shows the printed table only, not this tuple."""

    def _ipython_display_(self):
        """score() has already printed the table."""


def score(names: str | list[str] | None = None, *, quiet: bool = False) -> Score:
    """Print "Score: X/Y" and a line per check; return (points, max points).

    ``names``: a chapter prefix (``score("ch01")``: every check of the notebook named
    ``ch01.*``), or a list of check names; checks never run count as 0. Default: the checks
    run so far. The score is for the student; the bulk grader computes its own.
    """
    if os.environ.get(GRADING_ENV) == "1":
        return Score((0.0, 0.0))  # inside the grading sandbox: the grader scores outside the notebook
    discover()
    if isinstance(names, str):
        prefix = names.rstrip(".") + "."
        names = [n for n, c in _REGISTRY.items() if n.startswith(prefix) and c.in_notebook]
        if not names:
            raise KeyError(f"no checks registered under {prefix!r}; is the chapter prefix right?")
    names = list(names) if names is not None else list(_RESULTS)
    points = total = 0.0
    lines = []
    for name in names:
        if name in _RESULTS:
            r = _RESULTS[name]
        else:
            chk = _REGISTRY.get(name)
            r = Result(name, False, 0.0, chk.weight if chk else 1.0, "not run yet: execute its check cell")
        points += r.points
        total += r.weight
        lines.append(r.line())
    if not quiet:
        print(f"Score: {points:g}/{total:g}")
        for line in lines:
            print("  " + line.replace("\n", "\n  "))
    return Score((points, total))
