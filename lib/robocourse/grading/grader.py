"""Bulk grading: ``robocourse grade SUBMISSIONS... [-j N] [--out grades.csv] [--feedback DIR]``.

Counterpart of ``otter grade`` / nbgrader autograde. For each submission the grader

1. decides who and what it is (``identify``: the folder name wins over the file name);
2. copies it alone into a private folder and runs it in a sandbox (``sandbox.py``) that sends
   each check's inputs in and gathers the probes' plain data out (``runner.py``);
3. judges that data here, in its own process, against the reference (``checks.judge``):
   nothing the submission writes is a verdict, points never exceed a check's weight, and a
   name the grader did not ask for is ignored;
4. appends the row to an append-only journal (``<out>.journal.jsonl``) at once, so a crash or
   kill of the grader loses nothing and a re-run resumes where it stopped.

The CSV is built from the journal at the end and never replaces an existing CSV that has
more rows unless ``force=True``. Which checks an assignment has comes from the instructor's
notebook in solutions/ (never from the submission), plus hidden checks from ``--checks``
folders with the same chapter prefix.
"""

from __future__ import annotations

import concurrent.futures
import csv
import datetime as dt
import hashlib
import inspect
import json
import os
import re
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import nbformat
import numpy as np

from . import checks as checks_mod
from . import resources, runner, sandbox
from .exercises import CHECK_CALL, checks_in

MAX_NOTEBOOK_BYTES = 50 * 1024 * 1024
MAX_PROBE_BYTES = 64 * 1024 * 1024


@dataclass
class Assignment:
    name: str  # solution notebook stem, e.g. "00_setup_exercises"
    solution: Path
    checks: list[str]


@dataclass
class Grade:
    student: str
    submission: Path
    assignment: str
    results: dict = field(default_factory=dict)  # name -> {"points", "weight", "passed", "message", "reason", "cell"}
    status: str = ""
    seconds: float = 0.0
    errors: list = field(default_factory=list)  # "cell N: Type: message" from the run
    sandbox: str = ""  # "bwrap", "process" (NOT sandboxed) or "" (never ran)
    notes: list = field(default_factory=list)  # identity and duplicate notes for the instructor
    instructor: list = field(default_factory=list)  # hidden-check errors: the instructor's problem
    late_days: int = 0
    penalty: float = 0.0  # fraction of the points removed for lateness
    resumed: bool = False
    judge_seconds: float = 0.0  # the grader's own time judging this submission's records
    resources: str = ""  # how memory, processes and CPU were limited (sandbox.Outcome.resources)
    cpus: list = field(default_factory=list)  # the CPUs it had to itself (none: shared)

    @property
    def raw_points(self) -> float:
        return sum(min(r["points"], r["weight"]) for r in self.results.values())

    @property
    def points(self) -> float:
        return round(self.raw_points * (1.0 - self.penalty), 6)

    @property
    def max_points(self) -> float:
        return sum(r["weight"] for r in self.results.values())

    def feedback(self) -> str:
        from .report import feedback_text

        return feedback_text(self)

    def to_json(self) -> dict:
        d = asdict(self)
        d["submission"] = str(self.submission)
        return d

    @classmethod
    def from_json(cls, d: dict) -> Grade:
        d = dict(d)
        d["submission"] = Path(d["submission"])
        return cls(**{k: v for k, v in d.items() if k in cls.__dataclass_fields__})


class GradeList(list):
    """The grades of one run (a list), with the run's summary for the instructor."""

    summary: str = ""
    ignored: list = []
    unknown: list = []
    refused: list = []
    regraded: list = []


def load_assignments(solutions_dir: Path, extra_dirs=()) -> dict[str, Assignment]:
    """Assignments from solutions/*.ipynb and hidden checks from the instructor's folders."""
    registry = checks_mod.discover()
    hidden: set[str] = set()
    for d in extra_dirs:
        hidden.update(checks_mod.load_check_dir(d))
    out = {}
    for sol in sorted(Path(solutions_dir).glob("*.ipynb")):
        names = [n for n in checks_in(nbformat.read(sol, as_version=4)) if n in registry or n in hidden]
        prefixes = {n.split(".")[0] for n in names}
        extra = [n for n in hidden if n.split(".")[0] in prefixes and n not in names]
        out[sol.stem] = Assignment(sol.stem, sol, names + sorted(extra))
    orphans = sorted(n for n in hidden if not any(n in a.checks for a in out.values()))
    if orphans:
        prefixes = sorted({n.split('.')[0] for a in out.values() for n in a.checks})
        raise ValueError(f"--checks: {', '.join(orphans)} match(es) no assignment; a hidden check's name must "
                         f"start with the chapter prefix of a notebook in {solutions_dir} ({', '.join(prefixes)})")
    return out


# -- identity -----------------------------------------------------------------------------------

@dataclass
class Submission:
    path: Path
    student: str
    assignment: str | None
    notes: list
    refused: str = ""  # why the file is not read at all (a symlink, a FIFO, ...)


def identify(path: Path, given: Path | None, assignments: dict[str, Assignment],
             forced: str | None) -> tuple[str, str | None, list[str]]:
    """(student, assignment, notes) for one notebook.

    The rule (stated in the README): a notebook inside a student's own folder under a folder you
    passed (``subs/carol/00_setup_exercises.ipynb``) belongs to that folder's name, ``carol``,
    whatever its file name says; a notebook directly in the folder you passed, or passed as a
    file, belongs to its file name's suffix after the assignment name
    (``00_setup_exercises_dave.ipynb`` -> ``dave``), or to its folder's name when there is none.
    A file name that names someone else is reported, never obeyed.
    """
    stem = path.stem
    if forced:
        name = forced
    else:
        matches = [a for a in assignments if stem.startswith(a) or a in stem]
        name = max(matches, key=len) if matches else None
    suffix = stem.replace(name, "", 1).strip("_-. ") if name else ""
    notes = []
    if given is not None and path.parent != given:
        student = path.relative_to(given).parts[0]
        if suffix and suffix != student:
            notes.append(f"file name {path.name!r} suggests {suffix!r} but the folder says {student!r}: graded as "
                         f"{student!r} (folder wins)")
    else:
        student = suffix or path.parent.name or "unknown"
    return student, name, notes


def _kind_of(path: Path) -> str:
    """'' for a regular file; else what it is (a symlink is never followed)."""
    try:
        st = os.lstat(path)
    except OSError as exc:
        return f"unreadable ({exc.strerror})"
    if stat.S_ISLNK(st.st_mode):
        try:
            target = os.readlink(path)
        except OSError:
            target = "?"
        return f"a symbolic link (to {target!r}), not a file: unzip restores links from an archive; only the " \
               "notebook itself is graded"
    if stat.S_ISREG(st.st_mode):
        return ""
    kind = "a FIFO" if stat.S_ISFIFO(st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode) else \
        "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else "not a regular file"
    return f"{kind}, not a regular file"


def scan(submissions) -> tuple[list[tuple[Path, Path | None]], list[Path], list[tuple[Path, Path | None, str]]]:
    """(notebooks [(path, the folder it was found under or None)], other files ignored,
    refused [(path, folder, why)]): symlinks, FIFOs and other non-regular files are never read
    (a FIFO named x.ipynb would hang the reader); symlinked folders are not entered."""
    found, ignored, refused = [], [], []
    for s in submissions:
        p = Path(s)
        if os.path.islink(p) or (p.exists() and not p.is_dir() and _kind_of(p)):
            if p.suffix == ".ipynb" or os.path.islink(p):
                refused.append((p, None, _kind_of(p)))
            else:
                ignored.append(p)
        elif p.is_dir():
            for root, dirs, files in os.walk(p, followlinks=False):
                dirs[:] = sorted(d for d in dirs if d != ".ipynb_checkpoints" and not d.startswith("."))
                base = Path(root)
                for d in list(dirs):
                    if os.path.islink(base / d):
                        refused.append((base / d, p, _kind_of(base / d)))
                        dirs.remove(d)
                for name in sorted(files):
                    q = base / name
                    if name.startswith("."):
                        continue
                    why = _kind_of(q)
                    if why:
                        refused.append((q, p, why))
                    elif q.suffix == ".ipynb":
                        found.append((q, p))
                    else:
                        ignored.append(q)
        elif p.is_file():
            (found.append((p, None)) if p.suffix == ".ipynb" else ignored.append(p))
        else:
            raise FileNotFoundError(f"submission {s!r} does not exist; pass notebook files or folders of them")
    found.sort()
    return found, ignored, refused


def expand(submissions) -> tuple[list[tuple[Path, Path | None]], list[Path]]:
    """([(notebook, the folder it was found under or None)], [non-notebook files ignored])."""
    found, ignored, _ = scan(submissions)
    return found, ignored


def read_submission(path: Path, limit: int = MAX_NOTEBOOK_BYTES) -> bytes:
    """At most ``limit`` + 1 bytes of a regular file, never following a link, never blocking on a FIFO."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise OSError(f"{path} is not a regular file")
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


# -- one submission -----------------------------------------------------------------------------

def _probe_spec(chk: checks_mod.Check) -> dict:
    module = getattr(chk.probe, "__module__", "") or ""
    if module.startswith("robocourse."):
        return {"ref": f"{module}:{chk.probe.__qualname__}"}
    try:
        return {"source": inspect.getsource(chk.probe), "func": chk.probe.__name__}
    except (OSError, TypeError) as exc:
        raise ValueError(f"check {chk.name}: its probe {chk.probe!r} has no source the sandbox can run ({exc}); "
                         "define it with def in the check file") from None


_NAME_PREFIX = re.compile(r'^\{"name": ("(?:[^"\\]|\\.){0,300}")')


def _read_probes(path: Path, budgets: dict[str, int]) -> dict[str, tuple[dict, int]]:
    """{record name: (record, its JSON bytes)} for every asked-for name; everything else ignored.

    ``budgets``: name -> the largest record its check reads. A record past it is not parsed
    (``{"oversize": bytes}``); two records under one name mean the file was written to by
    someone other than the probe (``{"tampered": why}``): only the runner writes one per name.
    """
    text, _ = sandbox.read_bounded(path, MAX_PROBE_BYTES)
    out: dict[str, tuple[dict, int]] = {}
    counts: dict[str, int] = {}
    for line in text.splitlines():
        m = _NAME_PREFIX.match(line)
        try:
            name = json.loads(m.group(1)) if m else None
        except ValueError:
            name = None
        if name is None and len(line) < 1_000_000:
            try:
                r = json.loads(line)
                name = r.get("name") if isinstance(r, dict) else None
            except (ValueError, RecursionError):
                continue  # a half-written line from a killed run, or junk
        if name not in budgets:
            continue
        counts[name] = counts.get(name, 0) + 1
        nbytes = len(line.encode("utf-8", errors="replace"))
        if counts[name] > 1:
            out[name] = ({"tampered": f"the grader received {counts[name]} records for this check where its probe "
                                      "writes one: something in the notebook wrote to the grader's probe file, so "
                                      "none of them is trusted"}, nbytes)
            continue
        if nbytes > budgets[name] + 10_000:  # the envelope (name, error, seconds) around the outputs
            out[name] = ({"oversize": nbytes}, nbytes)
            continue
        try:
            r = json.loads(line)
        except (ValueError, RecursionError):
            out[name] = ({"outputs": None, "error": "the probe's record could not be read (malformed JSON)",
                          "reason": "raised"}, nbytes)
            continue
        out[name] = (r if isinstance(r, dict) else {}, nbytes)
    return out


def _check_cells(data: bytes) -> dict[str, int]:
    try:
        nb = json.loads(data)
        cells = nb["cells"]
    except (ValueError, KeyError, TypeError):
        return {}
    where = {}
    for index, cell in enumerate(cells if isinstance(cells, list) else []):
        if isinstance(cell, dict) and cell.get("cell_type") == "code":
            src = cell.get("source", "")
            src = "".join(src) if isinstance(src, list) else str(src)
            for name in CHECK_CALL.findall(src):
                where.setdefault(name, index)
    return where


def warm_font_cache(workroot: Path) -> Path:
    """Build matplotlib's font list once per run; each sandbox gets a copy (saves ~1 s per notebook)."""
    cache = workroot / "mplcache"
    cache.mkdir(exist_ok=True)
    env = {"PATH": os.environ.get("PATH", "/usr/bin"), "MPLCONFIGDIR": str(cache), "MPLBACKEND": "Agg"}
    try:
        subprocess.run([sys.executable, "-c", "import matplotlib.font_manager"], env=env, timeout=120,
                       capture_output=True)
    except (OSError, subprocess.TimeoutExpired):
        pass
    return cache


@dataclass
class Execution:
    """What one sandboxed run of the runner left: its outcome, the probe records, its status."""

    outcome: sandbox.Outcome
    records: dict  # name -> (record, JSON bytes)
    status: dict


def execute(request: dict, notebook: bytes | None, workroot: Path, limits: sandbox.Limits, mode: str,
            budgets: dict[str, int], cpus: tuple[int, ...] | None = None) -> Execution:
    """Run ``runner`` on ``request`` (and the notebook's bytes) in a fresh private folder.

    The folder holds the submission alone, size-limited (``sandbox.workdir``); judge-side
    modules are hidden (bwrap); ``cpus`` is a CPU slot the run has to itself; the folder is
    deleted afterwards. Used for submissions and for the answer banks (``bank.py``).
    """
    with sandbox.workdir(workroot, limits) as work:
        if notebook is not None:
            (work / runner.NOTEBOOK).write_bytes(notebook)
        (work / "tmp").mkdir()
        for cached in (workroot / "mplcache").glob("fontlist-*.json"):
            shutil.copy(cached, work / "tmp" / cached.name)
        (work / runner.REQUEST).write_text(json.dumps(request))
        hide = sandbox.hidden_files(checks_mod.judge_side_modules()) if mode == "bwrap" else []
        outcome = sandbox.run([sys.executable, "-m", "robocourse.grading.runner",
                               sandbox.SANDBOX_ROOT if mode == "bwrap" else str(work)], work, limits, mode, hide=hide,
                              cpus=cpus)
        records = _read_probes(work / runner.PROBES, budgets)
        text, _ = sandbox.read_bounded(work / runner.STATUS, 1_000_000)
        try:
            status = json.loads(text) if text else {}
            status = status if isinstance(status, dict) else {}
        except ValueError:
            status = {}
        return Execution(outcome, records, status)


def probe_request(chk: checks_mod.Check, inputs, name: str | None = None) -> dict:
    """The runner's request entry for one probe of ``chk`` (record ``name``, default the check's)."""
    return {"name": name or chk.name, "check": chk.name, "uses": list(chk.uses), "probe": _probe_spec(chk),
            "inputs": inputs, "time_limit": chk.time_limit, "references": list(chk.references)}


@dataclass
class Probed:
    """A submission after its sandboxed run, before judging (``judge_submission``)."""

    grade: Grade
    checks: list
    inputs: dict
    seeds: dict
    records: dict
    where: dict


def probe_submission(sub: Submission, assignment: Assignment | None, *, limits: sandbox.Limits,
                     cell_timeout: float, mode: str, workroot: Path, salt: str = "",
                     cpus: tuple[int, ...] | None = None) -> Probed:
    """Run one submission in its sandbox and gather its probe records (no verdict yet)."""
    g = Grade(sub.student, sub.path, assignment.name if assignment else "?", notes=list(sub.notes))
    if sub.refused and assignment is not None:
        g.status = f"refused: {sub.refused}"
        registry = checks_mod.discover()
        chks = [registry[n] for n in assignment.checks]
        return Probed(g, chks, {c.name: None for c in chks}, {}, {}, {})
    if assignment is None:
        g.status = ("cannot tell which assignment this is: its file name contains no notebook name from "
                    "solutions/; rename it or pass --assignment NAME")
        return Probed(g, [], {}, {}, {}, {})
    registry = checks_mod.discover()
    chks = [registry[n] for n in assignment.checks]
    start = time.monotonic()
    try:
        data = read_submission(sub.path)
    except OSError as exc:
        data, g.status = b"", f"cannot read the submission: {exc}"
    if len(data) > MAX_NOTEBOOK_BYTES:
        g.status = f"the notebook is larger than {MAX_NOTEBOOK_BYTES // 2**20} MB; clear its outputs and resubmit"
    digest = hashlib.sha256(data).hexdigest()
    seeds = {c.name: checks_mod.seed_for(c.name, digest, salt) for c in chks}
    inputs = {c.name: c.make_inputs(np.random.default_rng(seeds[c.name])) for c in chks}
    where = _check_cells(data)
    records: dict = {}
    if not g.status:
        request = {"cell_timeout": min(cell_timeout, limits.time_s),
                   "checks": [probe_request(c, inputs[c.name]) for c in chks]}
        run = execute(request, data, workroot, limits, mode, {c.name: c.max_bytes for c in chks}, cpus=cpus)
        outcome, status, records = run.outcome, run.status, run.records
        g.sandbox = outcome.sandbox
        if outcome.stopped == "time":
            g.status = f"stopped after the {limits.time_s:g} s time limit (an endless loop or a very slow cell)"
        elif outcome.stopped == "memory":
            g.status = f"stopped: used more than the {limits.memory_mb} MB memory limit"
        elif outcome.stopped == "processes":
            g.status = f"stopped: started more than {limits.max_processes} processes"
        elif outcome.stopped == "disk":
            g.status = (f"its folder was full: it wrote more than the {limits.work_mb} MB its folder and /tmp may hold, "
                        "so the grader could not keep what the checks after that point gathered")
        elif isinstance(status.get("reason"), str) and status["reason"]:
            g.status = status["reason"][:500]
        elif not status.get("finished"):
            g.status = ("the notebook's process died (os._exit, a crash, or the memory limit); "
                        "checks after that point did not run")
            if not status:
                g.errors.append("log: " + outcome.log.strip()[-300:])
        if outcome.leftover:
            g.notes.append(f"{outcome.leftover} process(es) survived the kill")
        g.resources = outcome.resources
        g.cpus = list(outcome.cpus) if outcome.cpus else []
        if isinstance(status.get("output_chars"), int) and status["output_chars"] > limits.output_bytes:
            g.notes.append(f"printed {status['output_chars']} characters (not kept)")
        errs = status.get("errors", [])
        g.errors += [str(e)[:300] for e in (errs if isinstance(errs, list) else [])][:20]
    g.seconds = round(time.monotonic() - start, 3)
    return Probed(g, chks, inputs, seeds, records, where)


def result_entry(result: checks_mod.Result, chk: checks_mod.Check, cell=None) -> dict:
    """A judged Result as the journal/CSV/feedback row entry of one check."""
    return {"points": min(result.points, chk.weight), "weight": chk.weight, "passed": result.passed,
            "message": result.message, "reason": result.reason, "cell": cell, "subtests": result.subtests,
            "seed": result.seed, "judge_seconds": round(result.judge_seconds, 4)}


def judge_submission(p: Probed) -> Grade:
    """Judge every check of a probed submission here, in the grader's process."""
    g = p.grade
    for chk in p.checks:
        got = p.records.get(chk.name)
        if got is None:
            why = g.status or "its probe never ran (the notebook stopped before)"
            result = checks_mod.Result(chk.name, False, 0.0, chk.weight, f"did not run: {why}", reason="no_output",
                                       subtests=[{"name": s.name, "weight": s.weight, "points": 0.0, "passed": False,
                                                  "message": f"did not run: {why}", "reason": "no_output"}
                                                 for s in chk.subtests if s.name],
                                       seed=p.seeds.get(chk.name) if chk.inputs else None)
        else:
            record, nbytes = got
            result = checks_mod.judge(chk, p.inputs[chk.name], record, nbytes=nbytes,
                                      seed=p.seeds.get(chk.name) if chk.inputs else None)
        if result.reason == "check_error":
            g.instructor.append(result.extra.get("instructor", chk.name))
        g.results[chk.name] = result_entry(result, chk, p.where.get(chk.name))
        g.judge_seconds = round(g.judge_seconds + result.judge_seconds, 4)
    return g


def grade_one(sub: Submission, assignment: Assignment | None, *, limits: sandbox.Limits, cell_timeout: float,
              mode: str, workroot: Path, salt: str = "") -> Grade:
    """Probe one submission in its sandbox, then judge it here."""
    return judge_submission(probe_submission(sub, assignment, limits=limits, cell_timeout=cell_timeout, mode=mode,
                                             workroot=workroot, salt=salt))


# -- the run ------------------------------------------------------------------------------------

def journal_key(sub: Submission, assignment: Assignment | None, data: bytes) -> str:
    h = hashlib.sha256(data)
    h.update(json.dumps([str(sub.path.resolve()), sub.student, assignment.name if assignment else None,
                         assignment.checks if assignment else []]).encode())
    return h.hexdigest()


class Journal:
    """Append-only JSON lines, one per finished submission, fsync'ed (nothing lost on a kill).

    Each line carries the options it was graded with (limits, sandbox, seed salt, a digest of
    the checks' code): a rerun reuses a row only when they are the same, and says so.
    """

    def __init__(self, path: Path):
        self.path = path
        self.lock = threading.Lock()
        self.done: dict[str, tuple[dict, dict]] = {}
        if path.exists():
            for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
                try:
                    entry = json.loads(line)
                    self.done[entry["key"]] = (entry.get("options") or {}, entry["grade"])
                except (ValueError, KeyError, TypeError):
                    continue  # the half line a killed grader left

    def append(self, key: str, grade: Grade, options: dict | None = None) -> None:
        line = json.dumps({"key": key, "options": options or {}, "grade": grade.to_json(), "time": time.time()}) + "\n"
        with self.lock, open(self.path, "a", encoding="utf-8") as fh:
            fh.write(line)
            fh.flush()
            os.fsync(fh.fileno())


def checks_digest(assignment: Assignment | None) -> str:
    """A digest of the code that grades ``assignment``: its checks' judge and probe modules (a
    changed check re-grades a journaled row)."""
    if assignment is None:
        return ""
    registry = checks_mod.discover()
    h = hashlib.sha256()
    files = set()
    for name in assignment.checks:
        chk = registry.get(name)
        if chk is None:
            continue
        for fn in [chk.probe, chk.inputs] + [st.judge for st in chk.subtests]:
            try:
                files.add(inspect.getsourcefile(fn) or "")
            except TypeError:
                continue
        h.update(name.encode())
    for f in sorted(x for x in files if x):
        try:
            h.update(Path(f).read_bytes())
        except OSError:
            h.update(f.encode())
    return h.hexdigest()[:16]


def _changed(old: dict, new: dict) -> list[str]:
    if not old:
        return ["the options were not recorded (an older journal)"]
    return [f"{k} {old.get(k)!r} -> {new[k]!r}" for k in sorted(new) if old.get(k) != new[k]]


def grade(submissions, *, solutions_dir="solutions", jobs: int = 1, time_limit: float = 300.0,
          memory_mb: int = 4096, max_processes: int = 64, cell_timeout: float = 120.0, extra_dirs=(),
          assignment: str | None = None, out: str | os.PathLike | None = None,
          feedback_dir: str | os.PathLike | None = None, progress=None, sandbox_mode: str = "auto",
          force: bool = False, due: dt.datetime | None = None, late_penalty: float = 0.0,
          overrides: str | os.PathLike | None = None, canvas: str | os.PathLike | None = None,
          gradescope: str | os.PathLike | None = None, resume: bool = True, salt: str = "", work_mb: int = 1024,
          shm_mb: int = 256) -> GradeList:
    """Grade every submission; write the CSV, exports and feedback if asked; return the grades."""
    from . import report

    if jobs < 1:
        raise ValueError(f"-j must be at least 1, got {jobs}")
    if not 0 <= late_penalty <= 100:
        raise ValueError(f"--late-penalty is a percentage per started day in 0..100, got {late_penalty}")
    limits = sandbox.Limits(time_limit, memory_mb, max_processes, work_mb=work_mb, shm_mb=shm_mb)
    mode = sandbox.choose_mode(sandbox_mode)
    assignments = load_assignments(Path(solutions_dir), extra_dirs)
    if not assignments:
        raise FileNotFoundError(f"no solution notebooks in {solutions_dir!r}; pass --solutions DIR")
    if assignment and assignment not in assignments:
        raise ValueError(f"--assignment {assignment!r} is not one of {sorted(assignments)}")
    found, ignored, refused = scan(submissions)
    if not found and not refused:
        raise FileNotFoundError(f"no notebooks (*.ipynb) in {', '.join(map(str, submissions)) or 'the arguments'}"
                                + (f" ({len(ignored)} other file(s) ignored)" if ignored else "")
                                + "; pass the folder holding the students' notebooks")
    override_rows = report.read_overrides(overrides) if overrides else []
    subs = []
    for path, given in found:
        student, name, notes = identify(path, given, assignments, assignment)
        subs.append(Submission(path, student, name, notes))
    refused_other = []
    for path, given, why in refused:
        if path.suffix == ".ipynb":  # a notebook that is not a file: a row with the reason, never read
            student, name, notes = identify(path, given, assignments, assignment)
            subs.append(Submission(path, student, name, notes, refused=why))
        else:
            refused_other.append(f"{path}: {why}")
    seen: dict[tuple, list[Submission]] = {}
    for s in subs:
        seen.setdefault((s.student, s.assignment), []).append(s)
    for (student, name), group in seen.items():
        if len(group) > 1 and name:
            for s in group:
                others = [str(o.path) for o in group if o is not s]
                s.notes.append(f"duplicate: {student} also submitted {', '.join(others)} for {name}; both graded")
    unknown = [s.path for s in subs if s.assignment is None]

    journal = Journal(Path(f"{out}.journal.jsonl")) if out else None
    options = {"time_limit": limits.time_s, "memory_mb": limits.memory_mb, "max_processes": limits.max_processes,
               "cell_timeout": cell_timeout, "work_mb": limits.work_mb, "shm_mb": limits.shm_mb, "sandbox": mode,
               "salt": salt, "resources": resources.mode()}  # a polled row is graded again where cgroups now work
    digests = {name: checks_digest(a) for name, a in assignments.items()}
    regraded: list[tuple[str, list[str]]] = []
    workroot = Path(tempfile.mkdtemp(prefix="robocourse-grade-"))
    os.chmod(workroot, 0o700)
    if any(s.assignment for s in subs):
        warm_font_cache(workroot)
        if mode == "bwrap":
            sandbox.compile_library(checks_mod.judge_side_modules(checks_mod.discover()))
    grades: list[Grade | None] = [None] * len(subs)

    gate = resources.CpuGate()
    registry = checks_mod.discover()

    def one(i: int):
        """In a worker thread: a journaled Grade, or the Probed submission to judge."""
        s = subs[i]
        a = assignments.get(s.assignment) if s.assignment else None
        try:
            data = read_submission(s.path)
        except OSError:
            data = b""
        key = journal_key(s, a, data)
        opts = {**options, "checks": digests.get(s.assignment, "")}
        if journal and resume and key in journal.done:
            was, saved = journal.done[key]
            changed = _changed(was, opts)
            fell_back = str(saved.get("resources", "")) if isinstance(saved, dict) else ""
            if not changed and options["resources"] != "polling" and fell_back.startswith("polling"):
                changed = [f"its limits were only polled then ({fell_back[:160]})"]
            if not changed:
                g = Grade.from_json(saved)
                g.resumed = True
                return key, g
            regraded.append((str(s.path), changed))
        timing = a is not None and any(registry[n].timing for n in a.checks if n in registry)
        with gate.hold(exclusive=timing) as cpus:  # a timing check runs with no other submission beside it
            busy = resources.machine_busy() if timing else ""
            probed = probe_submission(s, a, limits=limits, cell_timeout=cell_timeout, mode=mode, workroot=workroot,
                                      salt=salt, cpus=cpus)
            busy = busy or (resources.machine_busy() if timing else "")
        if busy:
            probed.grade.notes.append(f"the machine was busy with other programs ({busy}) while your timing checks ran "
                                      "(no other submission ran beside them): a failed timing sub-test may be the "
                                      "machine's, not yours; ask for a regrade")
        return key, probed

    def failed(i: int, exc: BaseException) -> Grade:
        # the grader's own failure: reported, never blamed on the student, not journaled (a re-run grades it)
        s = subs[i]
        return Grade(s.student, s.path, s.assignment or "?", notes=list(s.notes),
                     status=f"not graded: the grader failed ({type(exc).__name__}: {str(exc)[:200]})",
                     instructor=[f"{s.path}: the grader raised {type(exc).__name__}: {str(exc)[:200]}"])

    start = time.monotonic()
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
            futures = {pool.submit(one, i): i for i in range(len(subs))}
            for fut in concurrent.futures.as_completed(futures):
                i = futures[fut]
                try:
                    key, got = fut.result()
                    # judging happens here, in the calling thread (the judge's time budget is a
                    # SIGALRM where that is the main thread)
                    g = got if isinstance(got, Grade) else judge_submission(got)
                    if journal and not g.resumed:
                        journal.append(key, g, {**options, "checks": digests.get(g.assignment, "")})
                except Exception as exc:
                    g = failed(i, exc)
                grades[i] = g
                if progress:
                    progress(g)
    finally:
        shutil.rmtree(workroot, ignore_errors=True)
    result = GradeList(g for g in grades if g is not None)
    if due is not None:
        report.apply_late(result, due, late_penalty)
    report.apply_overrides(result, override_rows)
    result.ignored, result.unknown, result.refused, result.regraded = ignored, unknown, refused_other, regraded
    result.summary = report.summary(result, ignored=ignored, unknown=unknown, refused=refused_other, regraded=regraded,
                                    seconds=time.monotonic() - start,
                                    mode=mode, jobs=jobs, due=due, late_penalty=late_penalty,
                                    limits_line=_limits_line(limits))
    if out:
        write_csv(result, out, force=force)
        Path(f"{out}.summary.txt").write_text(result.summary, encoding="utf-8")
    if canvas:
        report.write_canvas(result, canvas)
    if gradescope:
        report.write_gradescope(result, gradescope)
    if feedback_dir:
        report.write_feedback(result, feedback_dir)
    return result


def _limits_line(limits: sandbox.Limits) -> str:
    how = {"cgroup-v1": "cgroup v1 per submission (shared memory and memfd counted)",
           "cgroup-v2-delegated": "a delegated cgroup v2 per submission (systemd-run --user --scope)",
           "polling": "polled resident memory and process count (no cgroup could be created: shared memory outside "
                      "the sandbox is not counted)"}[resources.mode()]
    cpu = ("a submission with a timing check ran alone with every CPU; the others side by side, one CPU's worth each"
           if resources.mode() != "polling" else
           "a submission with a timing check ran alone; the others side by side (no CPU cap without a cgroup)")
    hint = resources.fallback_hint()
    return (f"limits per submission: {limits.memory_mb} MB, {limits.max_processes} processes, a {limits.work_mb} MB "
            f"folder, a {limits.shm_mb} MB /dev/shm, {limits.time_s:g} s; enforced by {how}; {cpu}"
            + (f"; {hint}" if hint else ""))


def _rows(path) -> int:
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return max(0, sum(1 for _ in csv.reader(fh)) - 1)
    except OSError:
        return 0


def write_csv(grades: list[Grade], out, *, force: bool = False) -> None:
    """One row per submission; refuses to replace a CSV that has more rows unless ``force``.

    Every text cell a submission could have written (its folder name, its status) goes through
    ``report.for_csv``: no formula, no escape sequence reaches the instructor's spreadsheet."""
    from .report import for_csv

    existing = _rows(out) if Path(out).exists() else 0
    if existing > len(grades) and not force:
        raise ValueError(f"{out} already holds {existing} graded row(s) and this run has only {len(grades)}; "
                         "refusing to overwrite it: pass --force, or --out another file")
    columns: list[str] = []
    for g in grades:
        for name in g.results:
            if name not in columns:
                columns.append(name)
    tmp = Path(f"{out}.tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["student", "assignment", "submission", *columns, "total", "max", "late_days", "sandboxed",
                    "status"])
        for g in sorted(grades, key=lambda g: (g.student, g.assignment, str(g.submission))):
            status = "; ".join([g.status] * bool(g.status) + g.notes
                               + [f"CHECK ERROR (instructor): {e}" for e in g.instructor])
            w.writerow([for_csv(g.student), for_csv(g.assignment), for_csv(g.submission),
                        *[f"{g.results[c]['points']:g}" if c in g.results else "" for c in columns],
                        f"{g.points:g}", f"{g.max_points:g}", g.late_days,
                        {"bwrap": "yes", "process": "NO (not sandboxed)", "": ""}[g.sandbox], for_csv(status)])
    os.replace(tmp, out)


_SAFE = re.compile(r"[^A-Za-z0-9._-]")


def safe_name(text: str) -> str:
    return _SAFE.sub("_", text) or "student"
