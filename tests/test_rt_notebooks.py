"""Chapter 1's notebooks as files: stripped, right kernel, exercises in sync with solutions.

(Executing them is nbmake's job: pytest --nbmake chapters/01_realtime_basics.ipynb ...)
"""

from pathlib import Path

import nbformat

from robocourse.grading import exercises

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = [ROOT / "chapters/01_realtime_basics.ipynb", ROOT / "solutions/01_realtime_exercises.ipynb",
             ROOT / "exercises/01_realtime_exercises.ipynb"]


def test_notebooks_are_stripped_and_use_the_course_kernel():
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        assert nb.metadata["kernelspec"] == {"name": "robocourse", "display_name": "Python (robocourse)",
                                             "language": "python"}, path
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: outputs not stripped"


def test_student_version_is_generated_from_the_solution():
    problems = [p for p in exercises.check(ROOT) if "01_realtime" in str(p)]
    assert problems == []
    student = nbformat.read(NOTEBOOKS[2], as_version=4)
    text = "\n".join(c.source for c in student.cells if c.cell_type == "code")
    assert "### BEGIN SOLUTION" not in text and text.count("raise NotImplementedError()") == 6
    assert 'score("ch01")' in student.cells[-1].source


def test_every_check_of_ch01_is_called_in_the_exercises():
    sol = nbformat.read(NOTEBOOKS[1], as_version=4)
    assert exercises.checks_in(sol) == ["ch01.rttest_stats", "ch01.drift_free_loop", "ch01.relative_drift",
                                        "ch01.budget", "ch01.which_knob"]
