"""Every solution notebook scores full marks and runs every cell without error; every generated
exercise scores zero, cleanly.

This is the suite's one run of the solutions (``pyproject.toml``'s testpaths no longer hand them
to nbmake as well, issue 31): the grader executes every code cell in order, so a cell that raises,
times out or stops the run fails here, named, as it failed nbmake.

The solutions whose assignment has a check that judges real time (a timing check of the
registry, or an exercise its bank marks ``timing=True``: chapter 5's 1 kHz Franka and 500 Hz UR
loops, chapter 6's deployment loop) are graded in one run of their own, alone (``serial``,
tests/conftest.py): beside two other test workers on two cores their verdict would be the
machine's. The other solutions and every exercise (they stop at the first "not implemented")
are graded in one run beside the rest of the suite.
"""

from __future__ import annotations

import nbformat
import pytest
from test_banks import BANKS

from conftest import ROOT
from robocourse.grading import checks as checks_mod
from robocourse.grading.exercises import checks_in
from robocourse.grading.grader import grade

SOLUTIONS = sorted((ROOT / "solutions").glob("*.ipynb"))
_BANK_TIMED = {ex.check for exercises in BANKS.values() for ex in exercises if ex.timing}


def _judges_real_time(path) -> bool:
    registry = checks_mod.discover()
    names = set(checks_in(nbformat.read(path, as_version=4)))
    return bool(names & _BANK_TIMED) or any(registry[n].timing for n in names if n in registry)


TIMED = {p.stem for p in SOLUTIONS if _judges_real_time(p)}
_GRADES: dict[bool, dict] = {}


def grades(timed: bool) -> dict:
    """One grading run per group: the timed solutions; the others and every exercise."""
    if timed not in _GRADES:
        paths = [str(p) for p in SOLUTIONS if (p.stem in TIMED) == timed]
        if not timed:
            paths += [str(ROOT / "exercises" / p.name) for p in SOLUTIONS]
        result = grade(paths, solutions_dir=ROOT / "solutions", jobs=2, time_limit=240)
        _GRADES[timed] = {(g.student, g.assignment): g for g in result}
    return _GRADES[timed]


def test_the_real_time_solutions_are_known():
    """The serial group is not empty by accident (a renamed check would make every solution parallel)."""
    assert "05_hardware_drivers_exercises" in TIMED, TIMED


@pytest.mark.parametrize("name", [pytest.param(p.stem, marks=[pytest.mark.serial] if p.stem in TIMED else [])
                                  for p in SOLUTIONS])
def test_solution_scores_full_marks_and_every_cell_runs(name):
    g = grades(name in TIMED)[("solutions", name)]
    assert g.max_points > 0 and g.points == g.max_points, g.feedback()
    assert g.status == "", g.status              # it ran to its last cell: no time limit, no crash
    assert not g.errors, "\n".join(g.errors)    # "cell N: Type: message" of every cell that raised


@pytest.mark.parametrize("name", [p.stem for p in SOLUTIONS])
def test_exercise_scores_zero_without_crashing(name):
    g = grades(False)[("exercises", name)]
    assert g.max_points > 0 and g.points == 0, g.feedback()
    assert g.status == "", g.status  # it ran to the end: no crash, no timeout
    assert all("not implemented" in r["message"] or "did not run" in r["message"] or "raised" in r["message"]
               for r in g.results.values()), g.feedback()
