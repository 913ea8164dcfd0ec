"""Every solution notebook scores full marks; every generated exercise scores zero, cleanly."""

from __future__ import annotations

import pytest

from conftest import ROOT
from robocourse.grading.grader import grade

SOLUTIONS = sorted((ROOT / "solutions").glob("*.ipynb"))
# chapter 5's Franka link is graded at 1 kHz against the box, under CpuLoad: run alone (conftest.py)
pytestmark = pytest.mark.serial


@pytest.fixture(scope="module")
def grades():
    paths = [str(p) for p in SOLUTIONS] + [str(ROOT / "exercises" / p.name) for p in SOLUTIONS]
    result = grade(paths, solutions_dir=ROOT / "solutions", jobs=2, time_limit=240)
    return {(g.student, g.assignment): g for g in result}


@pytest.mark.parametrize("name", [p.stem for p in SOLUTIONS])
def test_solution_scores_full_marks(grades, name):
    g = grades[("solutions", name)]
    assert g.max_points > 0 and g.points == g.max_points, g.feedback()


@pytest.mark.parametrize("name", [p.stem for p in SOLUTIONS])
def test_exercise_scores_zero_without_crashing(grades, name):
    g = grades[("exercises", name)]
    assert g.max_points > 0 and g.points == 0, g.feedback()
    assert g.status == "", g.status  # it ran to the end: no crash, no timeout
    assert all("not implemented" in r["message"] or "did not run" in r["message"] or "raised" in r["message"]
               for r in g.results.values()), g.feedback()
