"""Checks: named, weighted, time-limited tests of a student's objects.

Like otter-grader's ``grader.check("q1")`` and nbgrader's weighted test cells: in a notebook,
``check("ch00.to_ns", to_ns)`` runs the check at once and prints feedback; ``score()`` prints
"Score: X/Y" with a line per check. Under ``robocourse grade`` every result is also appended
to the file named by ``ROBOCOURSE_GRADING_RESULTS`` the moment it is known, so a notebook that
crashes later keeps the points it already earned.

A check function takes the student's objects and either returns (optionally a message) to
pass, or raises ``CheckFailed``/``AssertionError`` with a message a student understands.
Chapters register their checks in ``robocourse/<chapter>/checks.py``; this module imports
every such module on first use, so it never names a chapter itself.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import json
import os
import pkgutil
import signal
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

RESULTS_ENV = "ROBOCOURSE_GRADING_RESULTS"
EXTRA_CHECKS_ENV = "ROBOCOURSE_EXTRA_CHECKS"


class CheckFailed(AssertionError):
    """Raise from a check function to fail it with a student-facing message."""


class CheckTimeout(Exception):
    """A check ran longer than its time limit."""


@dataclass(frozen=True)
class Check:
    """One graded check (otter: a test case file; nbgrader: an autograder cell)."""

    name: str
    func: Callable[..., Any]
    weight: float = 1.0
    time_limit: float = 10.0
    description: str = ""
    #: Names of notebook globals the grader passes when the notebook never called the check
    #: itself (instructor-added checks). Empty: the check must be called in the notebook.
    uses: tuple[str, ...] = ()


@dataclass
class Result:
    name: str
    passed: bool
    points: float
    weight: float
    message: str
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)

    def line(self) -> str:
        mark = "PASS" if self.passed else "FAIL"
        return f"[{mark}] {self.name} ({self.points:g}/{self.weight:g}): {self.message}"

    def to_json(self) -> str:
        return json.dumps(
            {"name": self.name, "passed": self.passed, "points": self.points,
             "weight": self.weight, "message": self.message, "seconds": round(self.seconds, 4)}
        )


_REGISTRY: dict[str, Check] = {}
_RESULTS: dict[str, Result] = {}
_DISCOVERED = False


def register(name: str, *, weight: float = 1.0, time_limit: float = 10.0, uses: tuple[str, ...] = ()):
    """Decorator: register ``func`` as check ``name`` ("chNN.short_name")."""
    _validate_name(name)
    if not (isinstance(weight, (int, float)) and weight > 0):
        raise ValueError(f"check {name!r}: weight must be a positive number, got {weight!r}")
    if not (isinstance(time_limit, (int, float)) and time_limit > 0):
        raise ValueError(f"check {name!r}: time_limit must be positive seconds, got {time_limit!r}")

    def decorate(func):
        _REGISTRY[name] = Check(name, func, float(weight), float(time_limit),
                                (func.__doc__ or "").strip().splitlines()[0] if func.__doc__ else "",
                                tuple(uses))
        return func

    return decorate


def _validate_name(name):
    if not isinstance(name, str) or "." not in name or not all(part.isidentifier() for part in name.split(".")):
        raise ValueError(
            f"check name must look like 'ch01.jitter_stats' (dot-separated identifiers), got {name!r}"
        )


def discover(extra_dirs: list[str | os.PathLike] | None = None) -> dict[str, Check]:
    """Import every ``robocourse.<package>.checks`` module and every ``*.py`` in extra_dirs.

    Extra directories come from the argument and from ``ROBOCOURSE_EXTRA_CHECKS``
    (os.pathsep-separated): that is how an instructor adds checks of their own.
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

    Each directory is imported once per process; later calls return the same names.
    """
    path = Path(directory)
    if not path.is_dir():
        raise FileNotFoundError(
            f"extra checks directory {str(path)!r} does not exist; pass a folder of .py files "
            "that use @robocourse.grading.register(...)"
        )
    path = path.resolve()
    if path not in _DIR_CHECKS:
        before = set(_REGISTRY)
        for file in sorted(path.glob("*.py")):
            spec = importlib.util.spec_from_file_location(f"robocourse_extra_checks.{file.stem}", file)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        _DIR_CHECKS[path] = sorted(set(_REGISTRY) - before)
    return list(_DIR_CHECKS[path])


def is_library_check(name: str) -> bool:
    """True for checks shipped in ``robocourse.<chapter>.checks`` (not an instructor's folder)."""
    chk = _REGISTRY.get(name)
    return chk is not None and getattr(chk.func, "__module__", "").startswith("robocourse.")


def get(name: str) -> Check:
    discover()
    try:
        return _REGISTRY[name]
    except KeyError:
        prefix = name.split(".")[0]
        near = sorted(n for n in _REGISTRY if n.startswith(prefix + "."))
        hint = f" Checks of {prefix}: {', '.join(near)}." if near else ""
        raise KeyError(f"no check named {name!r}.{hint} Did you update robocourse (make setup)?") from None


@contextlib.contextmanager
def _time_limit(seconds: float):
    """Raise CheckTimeout in the main thread after ``seconds`` (SIGALRM); elsewhere no limit.

    Notebook cells run in the kernel's main thread, so this stops a student's infinite loop in
    Python code. The bulk grader still kills the whole kernel after its own time limit.
    """
    usable = (hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread())
    if not usable:
        yield
        return

    def on_alarm(signum, frame):
        raise CheckTimeout(f"took longer than its {seconds:g} s time limit")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_check(chk: Check, *objects) -> Result:
    """Run one check on the student's objects and turn every outcome into a Result."""
    start = time.perf_counter()
    try:
        with _time_limit(chk.time_limit):
            message = chk.func(*objects)
        passed, text = True, (message if isinstance(message, str) and message else "passed")
    except CheckTimeout as exc:
        passed, text = False, f"{exc}. Look for an endless loop or a too-slow algorithm."
    except NotImplementedError:
        passed, text = False, "not implemented yet: replace `raise NotImplementedError` with your code."
    except AssertionError as exc:
        passed, text = False, str(exc) or "an assertion in the check failed"
    except Exception as exc:  # the student's code raised: say where, briefly
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" (line {tb[-1].lineno} in {tb[-1].name})" if tb else ""
        passed, text = False, f"your code raised {type(exc).__name__}: {exc}{where}"
    seconds = time.perf_counter() - start
    return Result(chk.name, passed, chk.weight if passed else 0.0, chk.weight, text, seconds)


def _record(result: Result) -> None:
    _RESULTS[result.name] = result
    path = os.environ.get(RESULTS_ENV)
    if path:
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(result.to_json() + "\n")


def check(name: str, *objects, quiet: bool = False) -> Result:
    """Run check ``name`` on ``objects`` now, print instant feedback, remember the result."""
    chk = get(name)
    result = run_check(chk, *objects)
    _record(result)
    if not quiet:
        print(result.line())
    return result


def run_pending(namespace: dict, names: list[str] | None = None) -> list[Result]:
    """Run registered checks that declare ``uses`` and have not run yet, on notebook globals.

    The bulk grader appends a cell calling this, so instructor-added checks (which the
    student's notebook never calls) are graded too. A missing global fails with its name.
    """
    discover()
    out = []
    for chk in _REGISTRY.values():
        if not chk.uses or chk.name in _RESULTS or (names is not None and chk.name not in names):
            continue
        missing = [n for n in chk.uses if n not in namespace]
        if missing:
            result = Result(chk.name, False, 0.0, chk.weight,
                            f"the notebook defines no {', '.join(missing)}: keep the names the exercise asks for")
        else:
            result = run_check(chk, *(namespace[n] for n in chk.uses))
        _record(result)
        out.append(result)
    return out


def results() -> dict[str, Result]:
    return dict(_RESULTS)


def reset() -> None:
    """Forget this session's results (tests; or a student starting over)."""
    _RESULTS.clear()


def score(names: str | list[str] | None = None, *, quiet: bool = False) -> tuple[float, float]:
    """Print "Score: X/Y" and a line per check; return (points, max points).

    ``names``: a chapter prefix (``score("ch01")``: every registered check named ``ch01.*``),
    or a list of check names; checks never run count as 0. Default: the checks run so far.
    """
    discover()
    if isinstance(names, str):
        prefix = names.rstrip(".") + "."
        names = sorted(n for n, c in _REGISTRY.items() if n.startswith(prefix) and not c.uses) + sorted(
            n for n in _RESULTS if n.startswith(prefix) and _REGISTRY.get(n) and _REGISTRY[n].uses)
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
            weight = chk.weight if chk else 1.0
            r = Result(name, False, 0.0, weight, "not run yet: execute its check cell")
        points += r.points
        total += r.weight
        lines.append(r.line())
    if not quiet:
        print(f"Score: {points:g}/{total:g}")
        for line in lines:
            print("  " + line)
    return points, total
