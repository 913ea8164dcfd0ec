"""Answer banks: grade many answers to one exercise through the real grading path, and compare.

Counterpart: ``otter assign`` checks its tests against the solution before release; nbgrader's
"validate" runs the source notebook. A bank goes further: a check is only trusted when every
plausible wrong answer (one per property the exercise states) scores 0 or its intended partial,
the reference and a differently written correct answer score full, and the verdicts do not
change from run to run, also under load.

Each answer is graded as a submission is: its code runs in the student's place inside the
sandbox (``runner`` in a bubblewrap sandbox where it works, judge modules hidden), the check's
probe gathers its outputs there, and the judge decides here, after the record passed the
check's schema. One sandbox run grades a whole batch: each answer runs in a fresh namespace
(the notebook's setup cell, the answer's cell, the check cell), so a bank of 20 answers costs
one interpreter start, not 20.

Writing a bank (tests/banks/chNN.py; the data lives in tests/, never in the library, because
the correct answers in it are solutions)::

    from robocourse.grading.bank import Answer, Exercise

    EXERCISES = [
        Exercise("ch01.relative_drift", "01_realtime_exercises",
                 right=[Answer("a plain loop", code='''
    def drift_ns(wake_ns, start_ns, period_ns):
        return [w - (start_ns + (k + 1) * period_ns) for k, w in enumerate(wake_ns)]
    ''')],
                 wrong=[Answer("off by one period", replace=[("+ 1) * period_ns", ") * period_ns")],
                               says="off by one", property="deadline k is start + (k + 1) * period"),
                        ...]),
    ]

- ``Exercise(check, notebook, wrong, right)``: ``notebook`` is the solution notebook's stem;
  the reference answer is its cell that defines the check's ``uses`` names (graded too, must
  score full), the setup is its code cells before the first solution block (imports).
- ``Answer(name, code=...)`` replaces the reference cell by ``code``; ``replace=[(old, new)]``
  edits the reference instead (each ``old`` must occur: a bank goes stale loudly).
- ``score``: what a wrong answer must earn: 0 (default), a total, or ``{sub-test name:
  points}`` (unlisted sub-tests 0). Right answers must earn the full weight.
- ``says`` / ``never_says``: text the feedback must (not) contain: it names the input, what came
  out and the rule; it never blames the machine or misdiagnoses.
- ``property``: the stated property the wrong answer breaks (shown in reports).
- ``Exercise(..., timing=True)``: the check involves real time; CI repeats it under load.

``grade_bank(exercises, repeats=..)`` returns one :class:`Verdict` per answer and run;
``Verdict.problems`` lists how it differs from what the bank expects (empty: as expected).

Porting a check so its bank can pass (what tests/test_banks.py asserts of every banked check):
move the probe (and any constant the notebook prints) to ``<chapter>/probes.py``; keep inputs,
schema, sub-tests and answer keys in ``<chapter>/checks.py`` (the sandbox hides it); declare the
probe's ``schema``; split the judge into one ``SubTest`` per stated property; never put an
expected answer in the inputs (the student's process sees them). Then write the wrong answers
and watch which sub-test each one fails: an answer that scores more than it should is a weak
check (a property never exercised, a peer doing the student's job); fix the check, not the bank.
Cost: CI grades each bank once (tests/test_banks.py: one sandbox start per bank file, about
0.1-1 s per answer); the 20 quiet + 20 loaded runs are ``benchmarks/bank_stability.py``.
"""

from __future__ import annotations

import atexit
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import nbformat
import numpy as np

from . import checks as checks_mod
from . import resources, sandbox
from .exercises import BEGIN


class BankError(ValueError):
    """A bank entry does not fit its exercise (a stale edit, an unknown check or notebook)."""


@dataclass(frozen=True)
class Answer:
    name: str
    code: str | None = None
    replace: tuple = ()
    score: float | dict | None = None
    says: tuple | str = ()
    never_says: tuple | str = ()
    property: str = ""
    setup: str = ""

    def __post_init__(self):
        if (self.code is None) == (not self.replace):
            raise BankError(f"answer {self.name!r}: give either code=... or replace=[(old, new), ...]")
        for key in ("says", "never_says"):
            value = getattr(self, key)
            object.__setattr__(self, key, (value,) if isinstance(value, str) else tuple(value))
        object.__setattr__(self, "replace", tuple(tuple(r) for r in self.replace))


@dataclass(frozen=True)
class Exercise:
    check: str
    notebook: str
    wrong: tuple = ()
    right: tuple = ()
    setup: str | None = None
    timing: bool = False

    def __post_init__(self):
        object.__setattr__(self, "wrong", tuple(self.wrong))
        object.__setattr__(self, "right", tuple(self.right))
        names = [a.name for a in self.wrong + self.right]
        if len(set(names)) != len(names) or "reference" in names:
            raise BankError(f"{self.check}: answer names must be unique and not 'reference'; got {names}")


@dataclass
class Verdict:
    check: str
    answer: str
    kind: str  # "reference", "right", "wrong"
    run: int
    points: float
    weight: float
    expected: float | dict
    subtests: list
    feedback: str
    seed: int | None
    seconds: float
    reason: str
    problems: list = field(default_factory=list)
    breaks: str = ""  # the property a wrong answer breaks

    @property
    def ok(self) -> bool:
        return not self.problems

    def report(self) -> str:
        head = f"{self.check} / {self.answer} ({self.kind}, run {self.run}, seed {self.seed}): " \
               f"{self.points:g}/{self.weight:g}"
        return "\n".join([head] + [f"  BANK: {p}" for p in self.problems] + ["  " + x for x in self.feedback.splitlines()])


_DEFINES = "(?m)^(?:def|class)\\s+{0}\\b|^{0}\\s*="


def notebook_parts(solutions_dir: Path, notebook: str, uses: tuple[str, ...]) -> tuple[str, str]:
    """(setup code, reference cell) of a solution notebook for an exercise using ``uses``."""
    path = Path(solutions_dir) / f"{notebook}.ipynb"
    if not path.exists():
        raise BankError(f"no solution notebook {path}")
    cells = [c for c in nbformat.read(path, as_version=4).cells if c.cell_type == "code"]
    first = next((i for i, c in enumerate(cells) if BEGIN in c.source), len(cells))
    setup = "\n\n".join(c.source for c in cells[:first] if "check(" not in c.source and "score(" not in c.source)
    defining = [c.source for c in cells if any(re.search(_DEFINES.format(re.escape(u)), c.source) for u in uses)]
    if not defining:
        raise BankError(f"{path.name}: no cell defines {', '.join(uses)}")
    return setup, "\n\n".join(dict.fromkeys(defining))


def answer_code(answer: Answer, reference: str, check: str) -> str:
    if answer.code is not None:
        return answer.code
    code = reference
    for old, new in answer.replace:
        if old not in code:
            raise BankError(f"{check} / {answer.name}: the reference no longer contains {old!r}; update the bank")
        code = code.replace(old, new)
    return code


_WORKROOT: list[Path] = []


def _workroot() -> Path:
    if not _WORKROOT:
        from .grader import warm_font_cache

        root = Path(tempfile.mkdtemp(prefix="robocourse-bank-"))
        atexit.register(shutil.rmtree, root, True)
        warm_font_cache(root)
        sandbox.compile_library(checks_mod.judge_side_modules())
        _WORKROOT.append(root)
    return _WORKROOT[0]


def _expected_problems(chk, answer: Answer | None, kind: str, result, feedback: str) -> list[str]:
    problems = []
    if kind in ("reference", "right"):
        if result.points != chk.weight:
            problems.append(f"a correct answer must score {chk.weight:g}, scored {result.points:g}")
    else:
        want = 0.0 if answer.score is None else answer.score
        if isinstance(want, dict):
            named = {s["name"]: s["points"] for s in result.subtests}
            unknown = [k for k in want if k not in named]
            if unknown:
                problems.append(f"score names unknown sub-test(s) {unknown}; the check has {list(named)}")
            for name, points in named.items():
                if abs(points - float(want.get(name, 0.0))) > 1e-9:
                    problems.append(f"sub-test {name!r} scored {points:g}, the bank expects {want.get(name, 0.0):g}")
        elif abs(result.points - float(want)) > 1e-9:
            problems.append(f"scored {result.points:g}, the bank expects {float(want):g}")
    if answer is not None:
        for text in answer.says:
            if text not in feedback:
                problems.append(f"the feedback does not say {text!r}")
        for text in answer.never_says:
            if text in feedback:
                problems.append(f"the feedback says {text!r} (a misdiagnosis)")
    if result.reason == "check_error":
        problems.append(f"CHECK ERROR: {result.extra.get('instructor', '')}")
    return problems


def grade_bank(exercises, *, solutions_dir="solutions", repeats: int = 1, mode: str = "auto",
               first_run: int = 0, memory_mb: int = 4096, max_processes: int = 64, progress=None) -> list[Verdict]:
    """Grade every answer of ``exercises`` (the references included) ``repeats`` times.

    Each run is one sandboxed process grading every answer once, with the draws of run ``k``
    (``seed_for(check, "bank|answer|k")``: every run draws afresh, the same run number always
    draws the same). Answers whose record did not come back (a crash) are graded again alone.
    """
    from .grader import execute, probe_request
    from .report import check_lines

    registry = checks_mod.discover()
    mode = sandbox.choose_mode(mode)
    plan = []  # (exercise, check, kind, answer or None, setup, code)
    for ex in exercises:
        if ex.check not in registry:
            raise BankError(f"bank names check {ex.check!r}, which is not registered")
        chk = registry[ex.check]
        setup, reference = notebook_parts(Path(solutions_dir), ex.notebook, chk.uses)
        setup = setup if ex.setup is None else ex.setup
        plan.append((ex, chk, "reference", None, setup, reference))
        for kind, answers in (("right", ex.right), ("wrong", ex.wrong)):
            for a in answers:
                plan.append((ex, chk, kind, a, setup, answer_code(a, reference, ex.check)))
    verdicts = []
    for run in range(first_run, first_run + repeats):
        items = []
        for ex, chk, kind, a, setup, code in plan:
            label = a.name if a else "reference"
            seed = checks_mod.seed_for(chk.name, f"bank|{label}|{run}")
            inputs = chk.make_inputs(np.random.default_rng(seed))
            rid = f"{chk.name}#{label}#{run}"
            cells = [setup, (a.setup if a else ""), code, f"check({chk.name!r}, {', '.join(chk.uses)})"]
            items.append((rid, ex, chk, kind, a, seed, inputs, [c for c in cells if c.strip()]))
        records = _run_items(items, execute, probe_request, mode, memory_mb, max_processes)
        for rid, _ex, chk, kind, a, seed, inputs, _cells in items:
            got = records.get(rid)
            start = time.perf_counter()
            if got is None:
                result = checks_mod.Result(chk.name, False, 0.0, chk.weight, "no record came back", reason="no_output")
            else:
                result = checks_mod.judge(chk, inputs, got[0], nbytes=got[1], seed=seed)
            from .grader import result_entry

            feedback = "\n".join(check_lines(chk.name, result_entry(result, chk)))
            v = Verdict(chk.name, a.name if a else "reference", kind, run, result.points, chk.weight,
                        (a.score if a and a.score is not None else (0.0 if kind == "wrong" else chk.weight)),
                        result.subtests, feedback, seed, result.seconds + time.perf_counter() - start, result.reason,
                        _expected_problems(chk, a, kind, result, feedback), a.property if a else "")
            verdicts.append(v)
            if progress:
                progress(v)
    return verdicts


def _run_items(items, execute, probe_request, mode, memory_mb, max_processes) -> dict:
    def batch(chosen):
        request = {"cell_timeout": max(c[2].time_limit for c in chosen) + 30,
                   "checks": [probe_request(c[2], c[6], name=c[0]) for c in chosen],
                   "segments": [{"cells": c[7], "probes": [c[0]]} for c in chosen]}
        limits = sandbox.Limits(time_s=60 + sum(2 * c[2].time_limit + 5 for c in chosen), memory_mb=memory_mb,
                                max_processes=max_processes)
        # a timing check runs as the grader runs it: alone, with every CPU as its slot (resources.CpuGate)
        cpus = tuple(resources.allowed_cpus()) if any(c[2].timing for c in chosen) else None
        return execute(request, None, _workroot(), limits, mode, {c[0]: c[2].max_bytes for c in chosen},
                       cpus=cpus).records

    records = batch(items)
    missing = [c for c in items if c[0] not in records]
    for c in missing:  # a crash took the rest of the batch with it: each alone, once
        records.update(batch([c]))
    return records
