"""Bulk grading: ``robocourse grade SUBMISSIONS... [-j N] [--out grades.csv] [--feedback DIR]``.

Counterpart of ``otter grade`` / nbgrader autograde. Each submission runs in its own process
(``runner.py``) under a wall-clock limit and a memory limit; the checks it must pass come from
the instructor's notebook in solutions/ (never from the submission), plus any instructor-added
checks with the same chapter prefix. Whatever a submission does (loops forever, raises, calls
sys.exit, deletes its check cells, prints gigabytes, is not JSON, wants another kernel), it
gets zero for the affected checks with a reason, and grading goes on.
"""

from __future__ import annotations

import concurrent.futures
import csv
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import nbformat

from . import checks as checks_mod
from .exercises import checks_in


@dataclass
class Assignment:
    name: str  # solution notebook stem, e.g. "00_setup_exercise"
    solution: Path
    checks: list[str]


@dataclass
class Grade:
    student: str
    submission: Path
    assignment: str
    results: dict = field(default_factory=dict)  # name -> {"points", "weight", "passed", "message"}
    status: str = ""
    seconds: float = 0.0
    errors: list = field(default_factory=list)  # "cell N: Type: message" from the run

    @property
    def points(self) -> float:
        return sum(r["points"] for r in self.results.values())

    @property
    def max_points(self) -> float:
        return sum(r["weight"] for r in self.results.values())

    def feedback(self) -> str:
        lines = [f"Student: {self.student}", f"Assignment: {self.assignment}",
                 f"Submission: {self.submission.name}", f"Score: {self.points:g}/{self.max_points:g}"]
        if self.status:
            lines.append(f"Note: {self.status}")
        lines.append("")
        for name, r in self.results.items():
            mark = "PASS" if r["passed"] else "FAIL"
            lines.append(f"[{mark}] {name} ({r['points']:g}/{r['weight']:g}): {r['message']}")
        if self.errors:
            lines += ["", "Errors while running your notebook:"] + [f"  {e}" for e in self.errors]
        return "\n".join(lines) + "\n"


def load_assignments(solutions_dir: Path, extra_dirs=()) -> dict[str, Assignment]:
    registry = checks_mod.discover()
    # hidden checks: the library's own (declared with uses=...) and those in this call's folders only
    hidden = {n for n, c in registry.items() if c.uses and checks_mod.is_library_check(n)}
    for d in extra_dirs:
        hidden.update(checks_mod.load_check_dir(d))
    out = {}
    for sol in sorted(Path(solutions_dir).glob("*.ipynb")):
        names = checks_in(nbformat.read(sol, as_version=4))
        prefixes = {n.split(".")[0] for n in names}
        extra = [n for n in hidden if n.split(".")[0] in prefixes and n not in names]
        out[sol.stem] = Assignment(sol.stem, sol, names + sorted(extra))
    return out


def identify(path: Path, assignments: dict[str, Assignment], forced: str | None) -> tuple[str, str | None]:
    """(student id, assignment name) for a submission path.

    ``alice/01_realtime_basics.ipynb`` -> alice; ``01_realtime_basics_alice.ipynb`` -> alice.
    """
    stem = path.stem
    if forced:
        name = forced
    else:
        matches = [a for a in assignments if a in stem]
        name = max(matches, key=len) if matches else None
    if name and stem == name:
        student = path.parent.name
    elif name and name in stem:
        student = stem.replace(name, "").strip("_-. ") or path.parent.name
    else:
        student = stem
    return student, name


def _limit_memory(megabytes: int):
    def apply():
        limit = megabytes * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    return apply


def _kill_tree(pid: int):
    import psutil

    try:
        root = psutil.Process(pid)
    except psutil.NoSuchProcess:
        return
    procs = root.children(recursive=True) + [root]
    for p in procs:
        try:
            p.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(procs, timeout=5)


def grade_one(path: Path, assignment: Assignment | None, student: str, *, time_limit: float,
              memory_mb: int, cell_timeout: float, extra_dirs=()) -> Grade:
    g = Grade(student, path, assignment.name if assignment else "?")
    if assignment is None:
        g.status = ("cannot tell which assignment this is: its file name contains no notebook name from "
                    "solutions/; rename it or pass --assignment NAME")
        return g
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="robocourse-grade-") as tmp:
        results_file, status_file = Path(tmp) / "results.jsonl", Path(tmp) / "status.json"
        results_file.touch()
        env = dict(os.environ)
        env["ROBOCOURSE_TEST"] = "1"
        env["MPLBACKEND"] = "Agg"
        env.pop("PYTEST_CURRENT_TEST", None)
        if extra_dirs:
            env[checks_mod.EXTRA_CHECKS_ENV] = os.pathsep.join(str(Path(d).resolve()) for d in extra_dirs)
        cmd = [sys.executable, "-m", "robocourse.grading.runner", str(path.resolve()), str(results_file),
               str(status_file), "--cell-timeout", str(min(cell_timeout, time_limit)),
               "--checks", ",".join(assignment.checks)]
        # The submission runs in a copy of its folder so it cannot overwrite other submissions.
        proc = subprocess.Popen(cmd, cwd=tmp, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                preexec_fn=_limit_memory(memory_mb), start_new_session=True)
        timed_out = False
        try:
            _, err = proc.communicate(timeout=time_limit)
        except subprocess.TimeoutExpired:
            timed_out = True
            status = _read_json(status_file)
            if status.get("kernel_pid"):
                _kill_tree(status["kernel_pid"])
            _kill_tree(proc.pid)
            _, err = proc.communicate()
        status = _read_json(status_file)
        recorded = _read_results(results_file)
    g.seconds = time.monotonic() - start
    g.errors = list(status.get("errors", []))[:20]
    if timed_out:
        g.status = f"stopped after the {time_limit:g} s time limit (an endless loop or a very slow cell)"
    elif status.get("reason"):
        g.status = status["reason"]
    elif not status:
        tail = (err or b"").decode(errors="replace").strip().splitlines()[-1:] or ["no output"]
        g.status = f"the grading process failed before running the notebook: {tail[0][:200]}"
    if status.get("output_truncated"):
        g.status = (g.status + "; " if g.status else "") + "output was too large and was truncated"
    for name in assignment.checks:
        weight = registry_weight(name)
        if name in recorded:
            r = recorded[name]
            g.results[name] = {"points": float(r["points"]), "weight": weight,
                               "passed": bool(r["passed"]), "message": r["message"]}
        else:
            why = g.status or "its check cell was deleted or never reached"
            g.results[name] = {"points": 0.0, "weight": weight, "passed": False, "message": f"did not run: {why}"}
    return g


def registry_weight(name: str) -> float:
    chk = checks_mod.discover().get(name)
    return chk.weight if chk else 1.0


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _read_results(path: Path) -> dict:
    out = {}
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return out
    for line in text.splitlines():
        try:
            r = json.loads(line)
            out[r["name"]] = r
        except (ValueError, KeyError, TypeError):
            continue  # a half-written line from a killed kernel
    return out


def expand(submissions) -> list[Path]:
    paths = []
    for s in submissions:
        p = Path(s)
        if p.is_dir():
            paths += sorted(q for q in p.rglob("*.ipynb") if ".ipynb_checkpoints" not in q.parts)
        elif p.exists():
            paths.append(p)
        else:
            raise FileNotFoundError(f"submission {s!r} does not exist; pass notebook files or folders of them")
    return paths


def grade(submissions, *, solutions_dir="solutions", jobs: int = 1, time_limit: float = 300.0,
          memory_mb: int = 4096, cell_timeout: float = 120.0, extra_dirs=(), assignment: str | None = None,
          out: str | os.PathLike | None = None, feedback_dir: str | os.PathLike | None = None,
          progress=None) -> list[Grade]:
    """Grade every submission; write the CSV and feedback files if asked; return the grades."""
    if jobs < 1:
        raise ValueError(f"-j must be at least 1, got {jobs}")
    if time_limit <= 0 or memory_mb < 256:
        raise ValueError(f"time limit must be > 0 s and memory >= 256 MB, got {time_limit} s, {memory_mb} MB")
    assignments = load_assignments(Path(solutions_dir), extra_dirs)
    if not assignments:
        raise FileNotFoundError(f"no solution notebooks in {solutions_dir!r}; pass --solutions DIR")
    if assignment and assignment not in assignments:
        raise ValueError(f"--assignment {assignment!r} is not one of {sorted(assignments)}")
    paths = expand(submissions)
    work = []
    for p in paths:
        student, name = identify(p, assignments, assignment)
        work.append((p, assignments.get(name) if name else None, student))
    grades: list[Grade] = [None] * len(work)  # type: ignore[list-item]
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        futures = {pool.submit(grade_one, p, a, s, time_limit=time_limit, memory_mb=memory_mb,
                               cell_timeout=cell_timeout, extra_dirs=extra_dirs): i
                   for i, (p, a, s) in enumerate(work)}
        for fut in concurrent.futures.as_completed(futures):
            i = futures[fut]
            grades[i] = fut.result()
            if progress:
                progress(grades[i])
    if out:
        write_csv(grades, out)
    if feedback_dir:
        write_feedback(grades, feedback_dir)
    return grades


def write_csv(grades: list[Grade], out) -> None:
    columns: list[str] = []
    for g in grades:
        for name in g.results:
            if name not in columns:
                columns.append(name)
    with open(out, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["student", "assignment", "submission", *columns, "total", "max", "status"])
        for g in grades:
            w.writerow([g.student, g.assignment, str(g.submission),
                        *[f"{g.results[c]['points']:g}" if c in g.results else "" for c in columns],
                        f"{g.points:g}", f"{g.max_points:g}", g.status])


def write_feedback(grades: list[Grade], directory) -> None:
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    for g in grades:
        safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in g.student) or "student"
        (d / f"{safe}__{g.assignment}.txt").write_text(g.feedback(), encoding="utf-8")
