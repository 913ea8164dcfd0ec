"""Generate student notebooks (exercises/) from instructor notebooks (solutions/).

nbgrader's convention: code between ``### BEGIN SOLUTION`` and ``### END SOLUTION`` is replaced
by ``# YOUR CODE HERE`` and ``raise NotImplementedError()`` at the marker's indentation;
cells tagged ``solution_only`` are removed; outputs and execution counts are cleared.
``build`` writes exercises/, ``check`` reports every exercise that differs from what ``build``
would write (the test suite runs it, so the two can never drift apart).
"""

from __future__ import annotations

import copy
import difflib
from dataclasses import dataclass
from pathlib import Path

import nbformat

BEGIN = "### BEGIN SOLUTION"
END = "### END SOLUTION"
REMOVE_TAG = "solution_only"
from .checks import CHECK_CALL  # noqa: E402,F401  (the runner reads it without importing nbformat)


class MarkerError(ValueError):
    """Unbalanced or nested solution markers in a solution notebook."""


def strip_solution(source: str, where: str = "cell") -> str:
    """Return ``source`` with every solution block replaced by the student stub."""
    out: list[str] = []
    inside_indent: str | None = None
    begin_line = 0
    for lineno, line in enumerate(source.splitlines(), start=1):
        stripped = line.strip()
        if stripped == BEGIN:
            if inside_indent is not None:
                raise MarkerError(f"{where}, line {lineno}: '{BEGIN}' inside another solution block "
                                  f"(opened at line {begin_line}); close it with '{END}' first")
            inside_indent = line[: len(line) - len(line.lstrip())]
            begin_line = lineno
            out.append(f"{inside_indent}# YOUR CODE HERE")
            out.append(f"{inside_indent}raise NotImplementedError()")
        elif stripped == END:
            if inside_indent is None:
                raise MarkerError(f"{where}, line {lineno}: '{END}' without a matching '{BEGIN}'")
            inside_indent = None
        elif inside_indent is None:
            out.append(line)
    if inside_indent is not None:
        raise MarkerError(f"{where}, line {begin_line}: '{BEGIN}' is never closed; add '{END}'")
    return "\n".join(out)


def make_exercise(nb: nbformat.NotebookNode, name: str = "notebook") -> nbformat.NotebookNode:
    """The student version of a solution notebook (a new object; ``nb`` is left unchanged)."""
    ex = copy.deepcopy(nb)
    cells = []
    for index, cell in enumerate(ex.cells):
        if REMOVE_TAG in cell.get("metadata", {}).get("tags", []):
            continue
        if cell.cell_type == "code":
            cell.source = strip_solution(cell.source, f"{name}, cell {index}")
            cell.outputs = []
            cell.execution_count = None
        cells.append(cell)
    ex.cells = cells
    ex.metadata.setdefault("robocourse", {})["generated_from"] = f"solutions/{name}"
    return ex


def checks_in(nb: nbformat.NotebookNode) -> list[str]:
    """Names of the checks a notebook calls (``check("chNN.x", ...)``), in order, unique."""
    names: list[str] = []
    for cell in nb.cells:
        if cell.cell_type == "code":
            for name in CHECK_CALL.findall(cell.source):
                if name not in names:
                    names.append(name)
    return names


def dumps(nb: nbformat.NotebookNode) -> str:
    return nbformat.writes(nb, version=4) + "\n"


@dataclass
class Difference:
    exercise: Path
    reason: str

    def __str__(self):
        return f"{self.exercise}: {self.reason}"


def _pairs(root: Path):
    for sol in sorted((root / "solutions").glob("*.ipynb")):
        yield sol, root / "exercises" / sol.name


def expected_text(solution: Path) -> str:
    nb = nbformat.read(solution, as_version=4)
    return dumps(make_exercise(nb, solution.name))


def build(root: Path | str = ".") -> list[Path]:
    """Write exercises/ from solutions/; remove exercises without a solution.

    Returns the paths whose content changed (an up-to-date file is not rewritten).
    """
    root = Path(root)
    (root / "exercises").mkdir(exist_ok=True)
    written = []
    for sol, ex in _pairs(root):
        text = expected_text(sol)
        if not ex.exists() or ex.read_text(encoding="utf-8") != text:
            ex.write_text(text, encoding="utf-8")
            written.append(ex)
    known = {ex.name for _, ex in _pairs(root)}
    for stale in (root / "exercises").glob("*.ipynb"):
        if stale.name not in known:
            stale.unlink()
    return written


def check(root: Path | str = ".") -> list[Difference]:
    """Every way exercises/ differs from what ``build`` would write (empty list: in sync)."""
    root = Path(root)
    problems = []
    expected = set()
    for sol, ex in _pairs(root):
        expected.add(ex.name)
        want = expected_text(sol)
        if not ex.exists():
            problems.append(Difference(ex, f"missing; generate it from {sol} with `robocourse exercises build`"))
            continue
        have = ex.read_text(encoding="utf-8")
        if have != want:
            diff = list(difflib.unified_diff(want.splitlines(), have.splitlines(), "generated", "on disk", n=0, lineterm=""))
            first = next((d for d in diff[2:] if not d.startswith("@@")), "")
            problems.append(Difference(ex, f"differs from the generated version ({len(diff) - 2} diff lines, "
                                           f"first: {first[:100]!r}); edit {sol} and run `robocourse exercises build`"))
    for ex in sorted((root / "exercises").glob("*.ipynb")) if (root / "exercises").is_dir() else []:
        if ex.name not in expected:
            problems.append(Difference(ex, "has no solution notebook in solutions/; exercises are generated, never written by hand"))
    return problems
