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
judges it itself. Chapters register their checks in ``robocourse/<chapter>/checks.py``;
``discover`` imports every such module it finds, so this package never names a chapter.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import inspect
import os
import pkgutil
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

EXTRA_CHECKS_ENV = "ROBOCOURSE_EXTRA_CHECKS"
GRADING_ENV = "ROBOCOURSE_GRADING"  # set to "1" in every grading sandbox
MAX_LISTED = 8  # problems listed per check; the rest are counted
MAX_LINE = 400  # characters per feedback line (a student's value can be any size)


class CheckFailed(AssertionError):
    """Raise from a judge to fail the check; pass several messages to list every problem."""

    def __init__(self, *messages: str):
        self.messages = [str(m) for m in messages if str(m)]
        super().__init__("\n".join(self.messages))


class CheckTimeout(Exception):
    """A probe ran longer than its time limit."""


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
class Check:
    """One graded check (otter: a test case file; nbgrader: an autograder cell)."""

    name: str
    judge: Callable[[Any, Any], Any]
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

    def make_inputs(self, rng: np.random.Generator | None = None):
        return self.inputs(rng if rng is not None else np.random.default_rng()) if self.inputs else None


@dataclass
class Result:
    name: str
    passed: bool
    points: float
    weight: float
    message: str
    seconds: float = 0.0
    #: "", "not_implemented", "timeout", "raised", "delegated", "missing", "check_error", "no_output"
    reason: str = ""
    extra: dict = field(default_factory=dict)

    def line(self) -> str:
        mark = "PASS" if self.passed else "FAIL"
        head = f"[{mark}] {self.name} ({self.points:g}/{self.weight:g})"
        lines = self.message.splitlines() or [""]
        if len(lines) == 1:
            return f"{head}: {lines[0]}"
        return "\n".join([f"{head}: {len(lines)} problems"] + [f"    - {m}" for m in lines])

    def __str__(self) -> str:
        return self.line()

    def _ipython_display_(self):
        """check() has already printed this result; a check cell shows nothing more (no raw repr)."""

    def to_dict(self) -> dict:
        return {"name": self.name, "passed": self.passed, "points": self.points, "weight": self.weight,
                "message": self.message, "seconds": round(self.seconds, 4), "reason": self.reason}


_REGISTRY: dict[str, Check] = {}
_RESULTS: dict[str, Result] = {}
_DISCOVERED = False


def register(name: str, *, uses: tuple[str, ...] | str, probe: Callable[..., Any],
             inputs: Callable[[np.random.Generator], Any] | None = None, weight: float = 1.0,
             time_limit: float = 10.0, references: tuple[str, ...] = (), in_notebook: bool | None = None):
    """Decorator on the judge: register check ``name`` ("chNN.short_name").

    ``uses``: the notebook globals the probe receives, in order (the names the exercise asks
    for). ``in_notebook``: default True for library checks, False for checks loaded from an
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
    if not (isinstance(weight, (int, float)) and weight > 0):
        raise ValueError(f"check {name!r}: weight must be a positive number, got {weight!r}")
    if not (isinstance(time_limit, (int, float)) and time_limit > 0):
        raise ValueError(f"check {name!r}: time_limit must be positive seconds, got {time_limit!r}")

    def decorate(judge):
        module = getattr(judge, "__module__", "") or ""
        shown = (judge.__doc__ or "").strip().splitlines()
        _REGISTRY[name] = Check(name, judge, probe, uses, inputs, float(weight), float(time_limit),
                                shown[0] if shown else "", tuple(references),
                                module.startswith("robocourse.") if in_notebook is None else bool(in_notebook))
        return judge

    return decorate


def _validate_name(name):
    if not isinstance(name, str) or "." not in name or not all(part.isidentifier() for part in name.split(".")):
        raise ValueError(
            f"check name must look like 'ch01.jitter_stats' (dot-separated identifiers), got {name!r}"
        )


def discover(extra_dirs: list[str | os.PathLike] | None = None) -> dict[str, Check]:
    """Import every ``robocourse.<package>.checks`` module and every ``*.py`` in extra_dirs.

    The chapter modules are found by walking the installed package (no chapter is named
    here). Extra directories come from the argument and from ``ROBOCOURSE_EXTRA_CHECKS``
    (os.pathsep-separated): that is how an instructor adds hidden checks.
    """
    global _DISCOVERED
    if not _DISCOVERED:
        import robocourse

        for info in pkgutil.iter_modules(robocourse.__path__):
            if info.ispkg and importlib.util.find_spec(f"robocourse.{info.name}.checks") is not None:
                importlib.import_module(f"robocourse.{info.name}.checks")
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
def _time_limit(seconds: float):
    """Raise CheckTimeout in the main thread after ``seconds`` (SIGALRM); elsewhere no limit.

    Stops a student's endless Python loop in a probe. The bulk grader additionally kills the
    whole sandbox after its own wall-time limit, whatever the code does.
    """
    usable = (hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread())
    if not usable:
        yield
        return

    def on_alarm(signum, frame):
        raise CheckTimeout(f"took longer than its {seconds:g} s time limit")

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


def _reference_codes(references) -> dict:
    """code object -> "module:qualname" for every reference function (and a class's methods)."""
    codes = {}
    for ref in references:
        try:
            obj = resolve(ref)
        except (ImportError, AttributeError):
            continue
        members = [obj]
        if inspect.isclass(obj):
            members = [v for v in vars(obj).values() if inspect.isfunction(v)]
        for m in members:
            code = getattr(inspect.unwrap(m), "__code__", None)
            if code is not None:
                codes[code] = ref
    return codes


def run_probe(chk: Check, inputs, objects) -> dict:
    """Run ``chk``'s probe on the student's objects; return plain data, never a verdict.

    ``{"outputs": ..., "error": "..."|None, "reason": ..., "delegated": [...], "seconds": s}``.
    While the student's code runs, a profile hook notes every call into a reference
    implementation listed in ``chk.references`` (delegation earns nothing).
    """
    from .probes import plain

    codes = _reference_codes(chk.references)
    delegated: set[str] = set()
    for ref in set(codes.values()):
        ref_obj = resolve(ref)
        for obj in objects:
            target = getattr(obj, "func", obj)  # a functools.partial of the reference
            if target is ref_obj or (inspect.isclass(target) and inspect.isclass(ref_obj)
                                     and issubclass(target, ref_obj)):
                delegated.add(ref)

    def hook(frame, event, arg):
        if event == "call" and frame.f_code in codes:
            delegated.add(codes[frame.f_code])

    out = {"outputs": None, "error": None, "reason": "", "delegated": [], "seconds": 0.0}
    start = time.perf_counter()
    previous = sys.getprofile()
    try:
        with _time_limit(chk.time_limit):
            if codes:
                sys.setprofile(hook)
            try:
                raw = chk.probe(inputs, *objects)
            finally:
                if codes:
                    sys.setprofile(previous)
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

def judge(chk: Check, inputs, probed: dict | None) -> Result:
    """Turn a probe's data into a Result: decided here, capped at the weight.

    ``probed`` is untrusted data (from the sandbox); a malformed value fails the check with a
    message, it never crashes the grader. A judge that raises anything but ``CheckFailed``
    is a bug in the check: the Result says so (reason "check_error") and the student is not
    blamed.
    """
    start = time.perf_counter()

    def result(passed, message, reason=""):
        message = "\n".join(m if len(m) <= MAX_LINE else m[:MAX_LINE] + " [...]" for m in str(message).splitlines())
        return Result(chk.name, passed, chk.weight if passed else 0.0, chk.weight, message,
                      float(probed.get("seconds", 0.0)) if isinstance(probed, dict) and
                      isinstance(probed.get("seconds"), (int, float)) else time.perf_counter() - start,
                      reason)

    if not isinstance(probed, dict):
        return result(False, "no output reached the grader for this check", "no_output")
    if probed.get("error"):
        reason = probed.get("reason") if probed.get("reason") in ("timeout", "not_implemented", "raised",
                                                                   "missing") else "raised"
        return result(False, str(probed["error"])[:2000], reason)
    delegated = probed.get("delegated") or []
    if delegated and isinstance(delegated, list):
        names = ", ".join(str(d).replace(":", ".") for d in delegated[:3])
        return result(False, f"this exercise asks you to write it yourself, but your code calls the library's "
                             f"{names}, the reference the grader compares with: no points for this check", "delegated")
    try:
        message = chk.judge(inputs, probed.get("outputs"))
    except CheckFailed as exc:
        return result(False, "\n".join(exc.messages) or "the check failed")
    except AssertionError as exc:
        return result(False, str(exc) or "an assertion in the check failed")
    except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
        if chk.in_notebook:
            # a library judge meeting data of the wrong shape: the student's output is malformed
            return result(False, f"your code returned something of an unexpected type or shape "
                                 f"({type(exc).__name__}: {str(exc)[:200]}); read the exercise's docstring")
        return _check_error(chk, exc, start)
    except Exception as exc:
        return _check_error(chk, exc, start)
    return result(True, message if isinstance(message, str) and message else "passed")


def _check_error(chk: Check, exc: BaseException, start: float) -> Result:
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" ({Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
    return Result(chk.name, False, 0.0, chk.weight,
                  "this check could not be graded because the check itself failed; your instructor has been told",
                  time.perf_counter() - start, "check_error",
                  {"instructor": f"{chk.name}: the judge raised {type(exc).__name__}: {str(exc)[:300]}{where}"})


def run_check(chk: Check, *objects, rng: np.random.Generator | None = None) -> Result:
    """Probe and judge in this process (the notebook's instant feedback, and tests)."""
    inputs = chk.make_inputs(rng)
    return judge(chk, inputs, run_probe(chk, inputs, objects))


def check(name: str, *objects, quiet: bool = False) -> Result:
    """Run check ``name`` on ``objects`` now, print instant feedback, remember the result.

    Under ``robocourse grade`` this feedback is for the student only: the grader probes the
    same objects again with its own inputs and judges outside the notebook.
    """
    chk = get(name)
    if len(objects) != len(chk.uses):
        raise TypeError(f"check({name!r}, ...) takes {len(chk.uses)} object(s): {', '.join(chk.uses)}; "
                        f"got {len(objects)}")
    if os.environ.get(GRADING_ENV) == "1":
        # inside ``robocourse grade``'s sandbox: the grader probes these objects itself after this
        # cell and judges outside; computing the feedback here would only cost time
        result = Result(name, False, 0.0, chk.weight, "graded by robocourse grade, outside this notebook",
                        reason="deferred")
    else:
        result = run_check(chk, *objects)
    _RESULTS[name] = result
    if not quiet and result.reason != "deferred":
        print(result.line())
    return result


def results() -> dict[str, Result]:
    return dict(_RESULTS)


def reset() -> None:
    """Forget this session's results (tests; or a student starting over)."""
    _RESULTS.clear()


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
