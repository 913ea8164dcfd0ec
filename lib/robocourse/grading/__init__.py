"""Grading: checks with weights and time limits, in-notebook feedback, bulk grading, exercises.

Counterparts: otter-grader (``grader.check``, ``otter grade``) and nbgrader (solution markers,
generated student version, autograde). This package knows no chapter: each chapter's checks
live in ``robocourse/<chapter>/checks.py`` and register themselves.
"""

from .checks import (
    Check,
    CheckFailed,
    CheckTimeout,
    Result,
    check,
    discover,
    register,
    reset,
    results,
    run_pending,
    score,
)

__all__ = ["Check", "CheckFailed", "CheckTimeout", "Result", "check", "discover", "register",
           "reset", "results", "run_pending", "score"]
