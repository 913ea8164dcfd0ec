"""Grading: checks split into a probe and a judge, in-notebook feedback, sandboxed bulk grading.

Counterparts: otter-grader (``grader.check``, ``otter grade``), nbgrader (solution markers,
generated student version, autograde) and Gradescope's throwaway container per submission.
This package knows no chapter: each chapter's checks live in ``robocourse/<chapter>/checks.py``
and are found by walking the package (``discover``); instructors add hidden checks from a
folder (``robocourse grade --checks DIR``), kept outside lib/ and outside every sandbox.

Writing a check (the API chapter authors use)
----------------------------------------------
A check is a judge function decorated with :func:`register`::

    from robocourse.grading import Failures, register
    from robocourse.grading.probes import call

    def _inputs(rng):                        # grader side: fresh plain inputs for every run
        return {"texts": ["1ms", f"{int(rng.integers(1, 999))}us"]}

    def _probe(inputs, to_ns):               # student side (sandbox): gather, never decide
        return [call(to_ns, t) for t in inputs["texts"]]

    @register("ch00.to_ns", uses=("to_ns",), probe=_probe, inputs=_inputs, weight=2,
              time_limit=5, references=("robocourse.rt.options:parse_duration",))
    def judge(inputs, outputs):              # grader side: compare with the reference
        f = Failures()
        for text, got in zip(inputs["texts"], outputs):
            f.expect(got.get("value") == expected(text), f"to_ns({text!r}) returned ...")
        return f.done("all durations right")  # raises CheckFailed listing every problem

Rules:

- ``uses``: the notebook globals the probe receives, in order (the names the exercise asks
  for); the notebook's check cell passes the same objects: ``check("ch00.to_ns", to_ns)``.
- ``inputs(rng) -> plain data`` runs in the grader; draw fresh random inputs where the task
  allows (``rng`` is freshly seeded per submission). ``None`` if the check needs none.
- ``probe(inputs, *objects) -> plain data`` runs where the student's code runs. It calls the
  student's objects and returns only what they produced (``probes.call`` records a value or
  an exception; ``probes.plain`` converts numpy). A probe must be a module-level function of
  a ``robocourse.*`` module, or (hidden checks) a self-contained ``def`` whose source is sent
  into the sandbox; it may build library objects (a FakeClock, a transfer function) from the
  plain inputs, and must not call the reference implementations itself.
- ``judge(inputs, outputs) -> message`` runs in the grader's process only. ``outputs`` is
  untrusted plain data: read it defensively (``probes.number``); report student mistakes with
  ``Failures``/``CheckFailed`` (all of them, not just the first). Any other exception in a
  hidden check is reported to the instructor as a CHECK ERROR, not blamed on the student.
- ``references``: "module:qualname" of the library code the exercise asks students to write
  themselves; a probe that reaches one (passed directly, wrapped, or called) earns 0 with
  feedback saying why.

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

__all__ = ["Check", "CheckDirError", "CheckFailed", "CheckTimeout", "Failures", "Result", "check", "discover",
           "judge", "probes", "register", "reset", "results", "run_check", "run_probe", "score"]
