"""Exercise generation: markers, stubs, sync check on the real course and on broken trees."""

from __future__ import annotations

import shutil
import subprocess
import sys

import nbformat
import pytest

from robocourse.grading import exercises


def test_strip_keeps_indentation_and_code_around():
    src = "def f(x):\n    ### BEGIN SOLUTION\n    return 2 * x\n    ### END SOLUTION\n\nprint(f)"
    assert exercises.strip_solution(src) == (
        "def f(x):\n    # YOUR CODE HERE\n    raise NotImplementedError()\n\nprint(f)")


@pytest.mark.parametrize("src, fragment", [
    ("### BEGIN SOLUTION\nx = 1", "never closed"),
    ("x = 1\n### END SOLUTION", "without a matching"),
    ("### BEGIN SOLUTION\n### BEGIN SOLUTION\n### END SOLUTION", "inside another solution block"),
])
def test_unbalanced_markers_are_errors_with_line_numbers(src, fragment):
    with pytest.raises(exercises.MarkerError, match=fragment) as err:
        exercises.strip_solution(src, "nb.ipynb, cell 3")
    assert "nb.ipynb, cell 3, line" in str(err.value)


def test_make_exercise_clears_outputs_and_drops_solution_only_cells():
    nb = nbformat.v4.new_notebook()
    c = nbformat.v4.new_code_cell("### BEGIN SOLUTION\ny = 2\n### END SOLUTION", execution_count=4,
                                  outputs=[nbformat.v4.new_output("stream", text="hi")])
    secret = nbformat.v4.new_markdown_cell("instructor notes")
    secret.metadata["tags"] = ["solution_only"]
    nb.cells = [c, secret]
    ex = exercises.make_exercise(nb, "x.ipynb")
    assert len(ex.cells) == 1 and ex.cells[0].outputs == [] and ex.cells[0].execution_count is None
    assert "raise NotImplementedError()" in ex.cells[0].source and "y = 2" not in ex.cells[0].source
    assert nb.cells[0].source.startswith("### BEGIN")  # the source notebook is untouched


def test_course_exercises_are_in_sync(root):
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "exercises", "check", "--root", str(root)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "in sync" in proc.stdout


def test_every_solution_has_checks_and_no_solution_leaks(root):
    for sol in sorted((root / "solutions").glob("*.ipynb")):
        nb = nbformat.read(sol, as_version=4)
        assert exercises.checks_in(nb), f"{sol.name} calls no check(...)"
        ex = (root / "exercises" / sol.name).read_text()
        assert exercises.BEGIN not in ex and "NotImplementedError" in ex


def test_check_reports_edits_missing_and_stray_files(tmp_path, root):
    shutil.copytree(root / "solutions", tmp_path / "solutions")
    assert len(exercises.build(tmp_path)) == len(list((root / "solutions").glob("*.ipynb")))
    assert exercises.build(tmp_path) == []  # nothing changed: nothing rewritten
    assert exercises.check(tmp_path) == []
    target = sorted((tmp_path / "exercises").glob("*.ipynb"))[0]
    target.write_text(target.read_text().replace("YOUR CODE HERE", "edited by hand"))
    (tmp_path / "exercises" / "stray.ipynb").write_text("{}")
    problems = [str(p) for p in exercises.check(tmp_path)]
    assert any(target.name in p and "differs from the generated version" in p for p in problems)
    assert any("stray.ipynb" in p and "never written by hand" in p for p in problems)
    target.unlink()
    assert any("missing" in str(p) for p in exercises.check(tmp_path))
    exercises.build(tmp_path)
    assert exercises.check(tmp_path) == [] and not (tmp_path / "exercises" / "stray.ipynb").exists()


def test_every_check_cell_passes_the_globals_its_check_probes(root):
    """The bulk grader probes the globals named by ``uses``: the notebook's check call must pass the same."""
    import ast

    from robocourse.grading import checks

    registry = checks.discover()
    seen = 0
    for sol in sorted((root / "solutions").glob("*.ipynb")):
        for cell in nbformat.read(sol, as_version=4).cells:
            if cell.cell_type != "code" or "check(" not in cell.source:
                continue
            for node in ast.walk(ast.parse(cell.source)):
                if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "check":
                    name = node.args[0].value
                    passed = tuple(a.id for a in node.args[1:])
                    assert passed == registry[name].uses, f"{sol.name}: check({name!r}, ...) passes {passed}"
                    seen += 1
    assert seen == 41  # chapters 0-3: 18, chapter 4: 8, chapter 5: 5, chapter 6: 5, chapter 7: 5
