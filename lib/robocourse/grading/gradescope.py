"""A Gradescope autograder for one assignment: ``robocourse grade export-gradescope CHAPTER``.

For classes that outgrow one machine. Gradescope's autograder specification: a zip with
``setup.sh`` (run once as root while the image is built, on Ubuntu) and ``run_autograder`` (run
for every submission, working directory /autograder) at its root; the zip is extracted to
/autograder/source, the student's files are in /autograder/submission, and run_autograder
writes /autograder/results/results.json (per-test ``score``, ``max_score``, ``status``,
``name``, ``number``, ``output``, ``visibility``, ``tags``, ``extra_data``; top-level ``score``,
``execution_time``, ``output``, ``visibility``, ``stdout_visibility``, ``extra_data``). What
run_autograder prints goes to /autograder/results/stdout, shown to the instructor only.

The package holds the course library and its pinned requirements (setup.sh installs them in
/autograder/venv: the same stack as ``make setup``), the instructor's hidden checks if any,
and the assignment as a notebook of its check cells only (which checks it has; no solution
ever leaves the instructor's machine). run_autograder grades the submitted notebook with
``robocourse grade`` itself (sandboxed where bubblewrap works in the container, with the same
limits, seeds and judges) and turns the one Grade into results.json: one Gradescope test per
check, its sub-tests, seed and feedback in the test's output; hidden checks stay hidden until
the grades are published. A broken submission (no notebook, invalid JSON, a crash) still gets a
results.json that says what is wrong; the grader's own failure says so too.

Known limit: where bubblewrap cannot create namespaces inside Gradescope's container (Docker
without user namespaces; in this project's harness, bwrap inside bwrap), the submission runs
unsandboxed in the container (the run summary in stdout says NOT SANDBOXED). The container is
still thrown away after each submission, but the submission can then read the installed
library, the judge modules and their answer keys included.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import nbformat

#: the documented fields of results.json and of each test in it
RESULT_FIELDS = {"score": (int, float), "execution_time": (int, float), "output": str, "output_format": str,
                 "test_output_format": str, "test_name_format": str, "visibility": str, "stdout_visibility": str,
                 "extra_data": dict, "tests": list, "leaderboard": list}
TEST_FIELDS = {"score": (int, float), "max_score": (int, float), "status": str, "name": str, "name_format": str,
               "number": str, "output": str, "output_format": str, "tags": list, "visibility": str,
               "extra_data": dict}
VISIBILITY = ("hidden", "after_due_date", "after_published", "visible")
FORMATS = ("text", "html", "simple_format", "md", "ansi")
CONFIG = "gradescope.json"

SETUP_SH = """#!/usr/bin/env bash
# Gradescope runs this once, as root, while it builds the autograder image (Ubuntu).
# It installs the course's pinned stack into /autograder/venv, as `make setup` does.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends python3 python3-venv python3-dev build-essential bubblewrap
python3 -m venv /autograder/venv
/autograder/venv/bin/python -m pip install --quiet --upgrade pip
/autograder/venv/bin/python -m pip install --quiet -r /autograder/source/course/requirements.txt
/autograder/venv/bin/python -m pip install --quiet --no-deps /autograder/source/course
"""

RUN_AUTOGRADER = """#!/usr/bin/env bash
# Gradescope runs this for every submission (working directory /autograder); it writes
# /autograder/results/results.json. Its output goes to the instructor's stdout view only.
cd /autograder
PY=/autograder/venv/bin/python
[ -x "$PY" ] || PY=python3
exec "$PY" -m robocourse.grading.gradescope /autograder
"""


def find_assignment(chapter: str, solutions_dir: Path) -> Path:
    """The solution notebook for ``chapter`` ("ch00", "00" or "00_setup_exercises")."""
    stems = sorted(p.stem for p in Path(solutions_dir).glob("*.ipynb"))
    key = chapter[2:] if chapter.startswith("ch") and chapter[2:].isdigit() else chapter
    hits = [s for s in stems if s == key or s.split("_")[0] == key]
    if len(hits) != 1:
        raise ValueError(f"export-gradescope {chapter!r}: name one assignment of {solutions_dir} by its chapter "
                         f"(e.g. ch00 or 00) or its notebook name; the assignments are {stems}")
    return Path(solutions_dir) / f"{hits[0]}.ipynb"


def export(chapter: str, out: str | os.PathLike, *, solutions_dir="solutions", course_root=None, extra_dirs=(),
           time_limit: float = 600.0, memory_mb: int = 4096, max_processes: int = 64, cell_timeout: float = 120.0,
           salt: str = "") -> Path:
    """Write the autograder zip for ``chapter``; return its path."""
    from .exercises import checks_in
    from .grader import load_assignments

    root = Path(course_root) if course_root else Path(__file__).resolve().parents[3]
    for needed in ("pyproject.toml", "requirements.txt", "lib/robocourse"):
        if not (root / needed).exists():
            raise FileNotFoundError(f"export-gradescope needs the course folder (with {needed}); run it from the "
                                    f"course's clone, not from {root}")
    solution = find_assignment(chapter, Path(solutions_dir))
    assignments = load_assignments(Path(solutions_dir), list(extra_dirs))
    checks = assignments[solution.stem].checks
    stub = nbformat.v4.new_notebook()
    stub.cells = [nbformat.v4.new_markdown_cell(f"The checks of {solution.stem} (no solutions).")]
    stub.cells += [nbformat.v4.new_code_cell(f"check({name!r})") for name in checks_in(nbformat.read(solution, 4))]
    stub.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    config = {"assignment": solution.stem, "checks": checks, "time_limit": time_limit, "memory_mb": memory_mb,
              "max_processes": max_processes, "cell_timeout": cell_timeout, "salt": salt}
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for name, text in (("setup.sh", SETUP_SH), ("run_autograder", RUN_AUTOGRADER)):
            info = zipfile.ZipInfo(name)
            info.external_attr = 0o755 << 16
            z.writestr(info, text)
        for rel in ("pyproject.toml", "requirements.txt", "README.md"):
            if (root / rel).exists():
                z.write(root / rel, f"course/{rel}")
        for path in sorted((root / "lib" / "robocourse").rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts and path.suffix != ".pyc":
                z.write(path, f"course/{path.relative_to(root)}")
        for d in extra_dirs:
            for path in sorted(Path(d).glob("*.py")):
                z.write(path, f"course/checks/{path.name}")
        z.writestr(f"course/assignment/{solution.stem}.ipynb", nbformat.writes(stub))
        z.writestr(f"course/{CONFIG}", json.dumps(config, indent=1))
    return out


def results_json(g, registry) -> dict:
    """One Grade as Gradescope's results.json: a test per check, its sub-tests in the output."""
    from .report import check_lines, for_terminal

    tests = []
    for k, (name, r) in enumerate(g.results.items(), start=1):
        chk = registry.get(name)
        tests.append({
            "name": f"{name}" + (f": {chk.description}" if chk is not None and chk.description else ""),
            "number": str(k), "score": float(r["points"]), "max_score": float(r["weight"]),
            "status": "passed" if r["passed"] else "failed",
            "output": for_terminal("\n".join(check_lines(name, r))), "output_format": "text",
            "visibility": "visible" if chk is None or chk.in_notebook else "after_published",
            "tags": [name.split(".")[0]],
            "extra_data": {"seed": r.get("seed"), "reason": r.get("reason", ""),
                           "subtests": [{"name": s["name"], "score": s["points"], "max_score": s["weight"]}
                                        for s in r.get("subtests") or [] if s.get("name")]}})
    notes = [f"Note: {g.status}"] if g.status else []
    notes += [f"Note: {n}" for n in g.notes]
    if g.errors:
        notes += ["Errors while running your notebook:"] + [f"  {e}" for e in g.errors]
    return {"score": float(sum(t["score"] for t in tests)), "execution_time": round(g.seconds, 1),
            "output": for_terminal("\n".join(notes) or f"Graded {len(tests)} check(s)."), "output_format": "text",
            "visibility": "visible", "stdout_visibility": "hidden", "tests": tests,
            "extra_data": {"assignment": g.assignment, "sandbox": g.sandbox, "resources": g.resources,
                           "judge_seconds": g.judge_seconds}}


def validate_results(data) -> list[str]:
    """Every way ``data`` departs from Gradescope's documented results.json (empty: it fits)."""
    problems = []
    if not isinstance(data, dict):
        return ["results.json must hold a JSON object"]
    for key, value in data.items():
        if key not in RESULT_FIELDS:
            problems.append(f"unknown top-level field {key!r}")
        elif not isinstance(value, RESULT_FIELDS[key]) or isinstance(value, bool):
            problems.append(f"{key}: expected {RESULT_FIELDS[key]}, got {type(value).__name__}")
    tests = data.get("tests", [])
    if "score" not in data and not (tests and all("score" in t for t in tests if isinstance(t, dict))):
        problems.append("a score is required at the top level or on every test")
    for field in ("visibility", "stdout_visibility"):
        if field in data and data[field] not in VISIBILITY:
            problems.append(f"{field} {data[field]!r} is not one of {VISIBILITY}")
    for field in ("output_format", "test_output_format", "test_name_format"):
        if field in data and data[field] not in FORMATS:
            problems.append(f"{field} {data[field]!r} is not one of {FORMATS}")
    for i, t in enumerate(tests if isinstance(tests, list) else []):
        if not isinstance(t, dict):
            problems.append(f"tests[{i}] is not an object")
            continue
        for key, value in t.items():
            if key not in TEST_FIELDS:
                problems.append(f"tests[{i}]: unknown field {key!r}")
            elif not isinstance(value, TEST_FIELDS[key]) or isinstance(value, bool):
                problems.append(f"tests[{i}].{key}: expected {TEST_FIELDS[key]}, got {type(value).__name__}")
        if t.get("status") not in (None, "passed", "failed"):
            problems.append(f"tests[{i}].status {t['status']!r} is not passed or failed")
        if t.get("visibility") not in (None, *VISIBILITY):
            problems.append(f"tests[{i}].visibility {t['visibility']!r} is not one of {VISIBILITY}")
        if t.get("output_format") not in (None, *FORMATS):
            problems.append(f"tests[{i}].output_format {t['output_format']!r} is not one of {FORMATS}")
        if isinstance(t.get("score"), (int, float)) and isinstance(t.get("max_score"), (int, float)) \
                and not 0 <= t["score"] <= t["max_score"]:
            problems.append(f"tests[{i}]: score {t['score']} outside 0..max_score {t['max_score']}")
    return problems


def _pick_notebook(submission: Path, assignment: str) -> tuple[Path | None, list[str]]:
    found = sorted(p for p in submission.rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts)
    if not found:
        return None, []
    named = [p for p in found if p.stem == assignment] or [p for p in found if assignment in p.stem]
    chosen = (named or found)[0]
    return chosen, [str(p.relative_to(submission)) for p in found if p != chosen]


def run_autograder(root: Path) -> dict:
    """Grade /autograder/submission and return results.json's content (never raises)."""
    from . import checks as checks_mod
    from .grader import grade

    start = time.monotonic()
    course = root / "source" / "course"
    try:
        cfg = json.loads((course / CONFIG).read_text())
        notebook, others = _pick_notebook(root / "submission", cfg["assignment"])
        if notebook is None:
            return {"score": 0.0, "execution_time": round(time.monotonic() - start, 1),
                    "output": f"no notebook (.ipynb) in your submission: upload {cfg['assignment']}.ipynb",
                    "tests": [], "stdout_visibility": "hidden"}
        work = Path(tempfile.mkdtemp(prefix="gradescope-"))
        try:
            copy = work / "submission" / f"{cfg['assignment']}.ipynb"  # one file, under the assignment's name
            copy.parent.mkdir()
            shutil.copyfile(notebook, copy)
            extra = [str(course / "checks")] if (course / "checks").is_dir() else []
            grades = grade([str(copy.parent)], solutions_dir=course / "assignment", assignment=cfg["assignment"],
                           extra_dirs=extra, time_limit=cfg["time_limit"], memory_mb=cfg["memory_mb"],
                           max_processes=cfg["max_processes"], cell_timeout=cfg["cell_timeout"], salt=cfg["salt"])
        finally:
            shutil.rmtree(work, ignore_errors=True)
        print(grades.summary)
        data = results_json(grades[0], checks_mod.discover())
        if others:
            data["output"] += f"\nOnly {notebook.name} was graded; also in your submission: {', '.join(others)}"
        return data
    except Exception as exc:  # the autograder's own failure: reported, never blamed on the student
        print(f"the autograder failed: {type(exc).__name__}: {exc}")
        return {"score": 0.0, "execution_time": round(time.monotonic() - start, 1), "tests": [],
                "output": "the autograder itself failed on this submission; your instructor has been told "
                          "(resubmitting will not help until they fix it)",
                "extra_data": {"error": f"{type(exc).__name__}: {str(exc)[:500]}"}, "stdout_visibility": "hidden"}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    root = Path(argv[0] if argv else "/autograder")
    data = run_autograder(root)
    (root / "results").mkdir(exist_ok=True)
    (root / "results" / "results.json").write_text(json.dumps(data, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
