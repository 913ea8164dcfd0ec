"""Grading: checks split into a probe and a judge, in-notebook feedback, sandboxed bulk grading.

Counterparts: otter-grader (``grader.check``, ``otter grade``), nbgrader (solution markers,
generated student version, autograde) and Gradescope's throwaway container per submission.
This package knows no chapter: each chapter's checks live in ``robocourse/<chapter>/checks.py``
and are declared in pyproject.toml as a ``robocourse.checks`` entry point (``discover`` loads
the group; a new chapter adds one line there); instructors add hidden checks from a
folder (``robocourse grade --checks DIR``), kept outside lib/ and outside every sandbox.

Writing a check (the API chapter authors use)
----------------------------------------------
A chapter keeps two modules: ``<chapter>/probes.py`` (student side: the probes, and any
constant the notebook prints) and ``<chapter>/checks.py`` (judge side: inputs, schemas,
sub-tests, answer keys; the grading sandbox hides it, so nothing in it is importable by a
submission). A check declares the form of its probe's data and its scored sub-tests::

    # robocourse/rt/probes.py  (runs where the student's code runs: gathers, never decides)
    def drift_probe(inputs, drift_ns):
        return {"cases": [call(drift_ns, np.asarray(c["wake"]), c["start"], c["period"])
                          for c in inputs["cases"]]}

    # robocourse/rt/checks.py  (the grader's side only)
    def _inputs(rng):                         # fresh plain inputs, drawn from the seeded rng
        return {"cases": [...]}                # never an expected answer: the probe's process sees these

    def _values(inputs, outputs):             # one sub-test: pass (return) or fail (CheckFailed)
        f = Failures()
        for case, got in zip(inputs["cases"], outputs["cases"]):
            f.expect(..., f"for wake {case['wake']} expected ..., got ...")   # input, output, rule
        return f.done("")

    register("ch01.relative_drift", uses=("drift_ns",), probe=probes.drift_probe, inputs=_inputs,
             time_limit=10, schema=Dict(cases=List(Call(Any()), length="cases")),
             subtests=[SubTest("the drift of each wake-up", 0.75, _values),
                       SubTest("returned as a numpy array", 0.25, _type)])

Rules:

- ``uses``: the notebook globals the probe receives, in order (the names the exercise asks
  for); the notebook's check cell passes the same objects: ``check("ch01.relative_drift", drift_ns)``.
- ``inputs(rng) -> plain data`` runs in the grader; ``rng`` is seeded per submission (from its
  content: a regrade draws the same) and the seed is shown in the feedback; the notebook's
  ``check(name, obj, seed=N)`` repeats a draw. The inputs reach the student's process: never put
  an expected answer in them.
- ``probe(inputs, *objects) -> plain data`` runs where the student's code runs. It calls the
  student's objects and returns only what they produced (``probes.call`` records a value or
  an exception; ``probes.plain`` converts numpy). A probe is a module-level function of a
  ``robocourse.*`` module other than its judges' (or, for an instructor's hidden check, a
  self-contained ``def`` whose source is sent into the sandbox).
- ``schema`` (:mod:`robocourse.grading.schema`): the form of the probe's outputs (types, lengths
  from the inputs, finite numbers, sizes). Every record is validated before a sub-test reads it;
  a malformed part fails the sub-tests that read it (``SubTest(..., reads="cases")``) with a
  message naming where and what; ``max_bytes`` and ``judge_time_limit`` bound each record.
- ``subtests``: ``SubTest(name, weight, judge)`` per property the exercise states (the check's
  weight is their sum; the feedback lists each). A judge reads validated data; an exception
  other than ``CheckFailed`` is the check's bug (CHECK ERROR to the instructor, never blamed on
  the student). The older form ``@register(..., weight=2)`` on one judge still works (one
  all-or-nothing sub-test, no schema) for checks not yet ported.
- ``references``: "module:qualname" of the library code the exercise asks students to write
  themselves; a call into one during the probe, from any thread, earns 0 with feedback saying why.
- Every exercise has an answer bank in ``tests/banks/`` (see :mod:`robocourse.grading.bank`).

In the notebook, ``check(name, *objects)`` runs inputs, probe and judge in the student's own
kernel for instant feedback and ``score("ch00")`` prints "Score: X/Y"; ``robocourse grade``
never trusts either (see ``grader.py`` and ``sandbox.py``).
"""

from . import probes
from .checks import (
    Check,
    CheckDirError,
    CheckFailed,
    CheckTimeout,
    Failures,
    Result,
    SubTest,
    check,
    discover,
    judge,
    register,
    reset,
    results,
    run_check,
    run_probe,
    score,
)

__all__ = ["Check", "CheckDirError", "CheckFailed", "CheckTimeout", "Failures", "Result", "SubTest", "check", "discover",
           "judge", "probes", "register", "reset", "results", "run_check", "run_probe", "score"]
