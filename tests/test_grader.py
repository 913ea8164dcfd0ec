"""Bulk grading: every kind of broken submission is graded for what it earned, with a reason.

Fixture notebooks are built from the real chapter 0 solution notebook, so they stay in step
with its checks: each one breaks it in one way a real student submission can.
"""

from __future__ import annotations

import csv
import subprocess
import sys

import nbformat
import pytest

from robocourse.grading import checks as checks_mod
from robocourse.grading.grader import grade

SOLUTION = "solutions/00_setup_exercises.ipynb"
CHECKS = ["ch00.to_ns", "ch00.budget", "ch00.limits_conf"]


def _solution(root):
    return nbformat.read(root / SOLUTION, as_version=4)


def _code_index(nb, text):
    return next(i for i, c in enumerate(nb.cells) if c.cell_type == "code" and text in c.source)


def _write(nb, path):
    path.write_text(nbformat.writes(nb))
    return path


def make_fixtures(root, folder):
    """{fixture name: path}; every name is a student id in the grades."""
    folder.mkdir(parents=True, exist_ok=True)
    out = {}

    nb = _solution(root)
    out["good"] = _write(nb, folder / "00_setup_exercises_good.ipynb")

    nb = _solution(root)  # an endless loop after the first check
    nb.cells.insert(_code_index(nb, 'check("ch00.to_ns"') + 1, nbformat.v4.new_code_cell("while True:\n    pass"))
    out["loop"] = _write(nb, folder / "00_setup_exercises_loop.ipynb")

    nb = _solution(root)  # an exception in the budget function's cell
    nb.cells[_code_index(nb, "def latency_budget_ns")].source = "raise RuntimeError('oops')"
    out["raises"] = _write(nb, folder / "00_setup_exercises_raises.ipynb")

    nb = _solution(root)  # sys.exit() after the first check
    nb.cells.insert(_code_index(nb, 'check("ch00.to_ns"') + 1, nbformat.v4.new_code_cell("import sys\nsys.exit(3)"))
    out["sysexit"] = _write(nb, folder / "00_setup_exercises_sysexit.ipynb")

    nb = _solution(root)  # the kernel itself dies after the first check
    nb.cells.insert(_code_index(nb, 'check("ch00.to_ns"') + 1, nbformat.v4.new_code_cell("import os\nos._exit(1)"))
    out["kernel_dies"] = _write(nb, folder / "00_setup_exercises_kernel_dies.ipynb")

    nb = _solution(root)  # the student deleted the limits_conf check cell
    del nb.cells[_code_index(nb, 'check("ch00.limits_conf"')]
    out["deleted"] = _write(nb, folder / "00_setup_exercises_deleted.ipynb")

    nb = _solution(root)  # tens of MB of output
    nb.cells.insert(1, nbformat.v4.new_code_cell("for i in range(300_000):\n    print('x' * 100)"))
    out["huge_output"] = _write(nb, folder / "00_setup_exercises_huge_output.ipynb")

    nb = _solution(root)  # allocates far beyond the memory limit
    nb.cells.insert(_code_index(nb, 'check("ch00.to_ns"') + 1,
                    nbformat.v4.new_code_cell("hog = bytearray(8 * 1024**3)"))
    out["memory"] = _write(nb, folder / "00_setup_exercises_memory.ipynb")

    bad = folder / "00_setup_exercises_badjson.ipynb"  # truncated JSON
    bad.write_text(nbformat.writes(_solution(root))[:500])
    out["badjson"] = bad

    nb = _solution(root)  # saved with an R kernel
    nb.metadata["kernelspec"] = {"name": "ir", "display_name": "R", "language": "R"}
    nb.metadata["language_info"] = {"name": "R"}
    out["rkernel"] = _write(nb, folder / "00_setup_exercises_rkernel.ipynb")
    return out


@pytest.fixture(scope="module")
def graded(tmp_path_factory, request):
    root = request.config.rootpath
    folder = tmp_path_factory.mktemp("subs")
    fixtures = make_fixtures(root, folder)
    out = folder / "grades.csv"
    feedback = folder / "feedback"
    grades = grade([str(folder)], solutions_dir=root / "solutions", jobs=2, time_limit=40, cell_timeout=8,
                   memory_mb=3072, out=out, feedback_dir=feedback)
    return {g.student: g for g in grades}, fixtures, out, feedback


def _points(g):
    return {name: r["points"] for name, r in g.results.items()}


def test_good_submission_scores_full_marks(graded):
    grades, *_ = graded
    g = grades["good"]
    assert (g.points, g.max_points) == (5.0, 5.0), g.feedback()
    assert g.status == ""


def test_endless_loop_is_interrupted_and_grading_goes_on(graded):
    grades, *_ = graded
    g = grades["loop"]
    assert _points(g)["ch00.to_ns"] == 2.0  # earned before the loop
    # the cell timeout interrupts the loop and execution goes on, so later checks still run
    assert g.points == 5.0
    assert any("CellTimeout" in e for e in g.errors), g.errors


def test_exception_costs_only_the_affected_check(graded):
    grades, *_ = graded
    p = _points(grades["raises"])
    assert p == {"ch00.to_ns": 2.0, "ch00.budget": 0.0, "ch00.limits_conf": 2.0}
    assert any("RuntimeError: oops" in e for e in grades["raises"].errors)
    assert any("NameError" in e and "latency_budget_ns" in e for e in grades["raises"].errors)


def test_sys_exit_does_not_stop_grading(graded):
    grades, *_ = graded
    # IPython turns SystemExit into an error output; the following cells still run
    assert _points(grades["sysexit"]) == {"ch00.to_ns": 2.0, "ch00.budget": 1.0, "ch00.limits_conf": 2.0}
    assert any("SystemExit" in e for e in grades["sysexit"].errors), grades["sysexit"].errors


def test_kernel_death_keeps_points_earned_before_it(graded):
    grades, *_ = graded
    g = grades["kernel_dies"]
    assert _points(g) == {"ch00.to_ns": 2.0, "ch00.budget": 0.0, "ch00.limits_conf": 0.0}
    assert "process died" in g.results["ch00.budget"]["message"]


def test_deleted_check_cell_is_graded_anyway(graded):
    """nbgrader restores the instructor's test cells: deleting a check cell changes nothing."""
    grades, *_ = graded
    g = grades["deleted"]
    assert _points(g) == {"ch00.to_ns": 2.0, "ch00.budget": 1.0, "ch00.limits_conf": 2.0}
    assert g.results["ch00.limits_conf"]["cell"] is None


def test_huge_output_is_counted_not_kept(graded):
    grades, *_ = graded
    g = grades["huge_output"]
    assert g.points == 5.0
    [note] = [n for n in g.notes if n.startswith("printed ")]
    assert int(note.split()[1]) > 2_000_000 and "(not kept)" in note  # counted past the 2 MB output limit


def test_memory_hog_hits_the_limit_and_grading_goes_on(graded):
    grades, *_ = graded
    g = grades["memory"]
    assert g.points == 5.0  # MemoryError in one cell; the rest of the notebook still runs
    assert any("MemoryError" in e for e in g.errors), g.errors


def test_invalid_json_gets_zero_with_reason(graded):
    grades, *_ = graded
    g = grades["badjson"]
    assert g.points == 0.0 and g.max_points == 5.0
    assert "not a valid notebook" in g.status


def test_foreign_kernel_gets_zero_with_reason(graded):
    grades, *_ = graded
    g = grades["rkernel"]
    assert g.points == 0.0
    assert "'ir'" in g.status and "Python (robocourse)" in g.status


def test_csv_has_one_row_per_student_with_per_check_points(graded):
    grades, fixtures, out, feedback = graded
    rows = list(csv.DictReader(out.open()))
    assert sorted(r["student"] for r in rows) == sorted(fixtures)
    assert list(rows[0].keys()) == ["student", "assignment", "submission", *CHECKS, "total", "max", "late_days",
                                    "sandboxed", "status"]
    by = {r["student"]: r for r in rows}
    assert by["good"]["total"] == "5" and by["good"]["max"] == "5"
    assert by["badjson"]["total"] == "0"
    files = sorted(p.name for p in feedback.iterdir())
    assert len(files) == 2 * len(fixtures)  # text and HTML
    assert "Score: 5/5" in (feedback / "good__00_setup_exercises.txt").read_text()
    html = (feedback / "raises__00_setup_exercises.html").read_text()
    assert "ch00.budget" in html and "check cell 7" in html and "RuntimeError: oops" in html


# the tests below grade classes of their own (no module fixture): units of their own (tests/conftest.py), so
# they spread over the workers instead of queueing behind the graded class above
@pytest.mark.xdist_group("tests/test_grader.py::three_copies")
def test_cli_grades_three_copies_in_parallel(tmp_path, root):
    nb = (root / SOLUTION).read_text()
    for student in ("ana", "ben", "cho"):
        (tmp_path / student).mkdir()
        (tmp_path / student / "00_setup_exercises.ipynb").write_text(nb)
    out = tmp_path / "grades.csv"
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "grade", str(tmp_path), "-j", "2",
                           "--out", str(out), "--solutions", str(root / "solutions")],
                          capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(out.open()))
    assert [(r["student"], r["total"], r["max"]) for r in rows] == [("ana", "5", "5"), ("ben", "5", "5"), ("cho", "5", "5")]
    assert all(r["ch00.to_ns"] == "2" and r["ch00.budget"] == "1" and r["ch00.limits_conf"] == "2" for r in rows)


HIDDEN = """
from robocourse.grading import CheckFailed, register
from robocourse.grading.probes import calls


@register('ch00.hidden_budget', weight=3, uses=('latency_budget_ns',), probe=calls,
          inputs=lambda rng: [[0, [2_000_000], {}]])
def hidden(inputs, outputs):
    if outputs[0].get('value') != 100_000:
        raise CheckFailed('5 % of 2 ms is 100 us')
    return 'hidden budget right'
"""


@pytest.mark.xdist_group("tests/test_grader.py::checks_dirs")
def test_instructor_checks_from_a_directory(tmp_path, root):
    extra = tmp_path / "mychecks"
    extra.mkdir()
    (extra / "extra_ch00.py").write_text(HIDDEN)
    sub = tmp_path / "subs"
    sub.mkdir()
    (sub / "00_setup_exercises_dan.ipynb").write_text((root / SOLUTION).read_text())
    (sub / "00_setup_exercises_eve.ipynb").write_text((root / "exercises/00_setup_exercises.ipynb").read_text())
    grades = {g.student: g for g in grade([str(sub)], solutions_dir=root / "solutions", jobs=2,
                                          extra_dirs=[str(extra)], time_limit=60)}
    assert grades["dan"].results["ch00.hidden_budget"]["points"] == 3.0
    assert (grades["dan"].points, grades["dan"].max_points) == (8.0, 8.0)
    assert grades["eve"].results["ch00.hidden_budget"]["points"] == 0.0
    assert "not implemented" in grades["eve"].results["ch00.hidden_budget"]["message"]
    # a later grading run without --checks does not expect the instructor's check any more
    [g] = grade([str(sub / "00_setup_exercises_dan.ipynb")], solutions_dir=root / "solutions", time_limit=60)
    assert list(g.results) == CHECKS and g.points == 5.0


@pytest.mark.xdist_group("tests/test_grader.py::checks_dirs")
def test_a_hidden_check_that_raises_is_the_instructors_problem(tmp_path, root):
    extra = tmp_path / "buggy"
    extra.mkdir()
    (extra / "buggy_ch00.py").write_text(HIDDEN.replace("hidden_budget", "buggy").replace(
        "    if outputs[0]", "    1 / 0\n    if outputs[0]"))
    sub = tmp_path / "subs"
    sub.mkdir()
    (sub / "00_setup_exercises_fay.ipynb").write_text((root / SOLUTION).read_text())
    grades = grade([str(sub)], solutions_dir=root / "solutions", extra_dirs=[str(extra)], time_limit=60,
                   out=tmp_path / "g.csv")
    [g] = grades
    assert g.results["ch00.buggy"]["reason"] == "check_error" and g.points == 5.0
    assert "your instructor has been told" in g.results["ch00.buggy"]["message"]
    assert "ZeroDivisionError" not in g.feedback()
    assert "CHECK ERRORS" in grades.summary and "ZeroDivisionError" in grades.summary
    assert "CHECK ERROR (instructor)" in (tmp_path / "g.csv").read_text()


@pytest.mark.xdist_group("tests/test_grader.py::checks_folder")
def test_checks_folder_problems_are_one_clear_line(tmp_path, root):
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "bad.py").write_text("def judge(:\n")
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "grade", str(root / SOLUTION), "--solutions",
                           str(root / "solutions"), "--checks", str(broken), "--out", str(tmp_path / "g.csv")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0
    assert proc.stderr.strip().count("\n") == 0 and "bad.py:1: SyntaxError" in proc.stderr
    orphan = tmp_path / "orphan"
    orphan.mkdir()
    (orphan / "ch09.py").write_text(HIDDEN.replace("ch00.hidden_budget", "ch09.hidden"))
    with pytest.raises(ValueError, match="ch09.hidden match.*no assignment"):
        grade([str(root / SOLUTION)], solutions_dir=root / "solutions", extra_dirs=[str(orphan)])
    checks_mod._REGISTRY.pop("ch09.hidden", None)


def test_unknown_assignment_is_reported_not_crashed(tmp_path, root):
    (tmp_path / "homework.ipynb").write_text((root / SOLUTION).read_text())
    [g] = grade([str(tmp_path)], solutions_dir=root / "solutions")
    assert g.points == 0.0 and "--assignment" in g.status
    [g] = grade([str(tmp_path)], solutions_dir=root / "solutions", assignment="00_setup_exercises", time_limit=60)
    assert g.points == 5.0


def test_bad_arguments_are_clear(tmp_path, root):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        grade([str(tmp_path / "nope.ipynb")], solutions_dir=root / "solutions")
    with pytest.raises(ValueError, match="-j must be at least 1"):
        grade([], solutions_dir=root / "solutions", jobs=0)
    with pytest.raises(ValueError, match="not one of"):
        grade([], solutions_dir=root / "solutions", assignment="99_nothing")
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "readme.txt").write_text("x")
    with pytest.raises(FileNotFoundError, match="no notebooks.*1 other file"):
        grade([str(tmp_path / "empty")], solutions_dir=root / "solutions")
    with pytest.raises(ValueError, match="memory limit must be >= 256 MB"):
        grade([], solutions_dir=root / "solutions", memory_mb=10)
