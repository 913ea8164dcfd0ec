"""A hostile class: every attack of issue 15, each built from the real chapter 0 notebooks.

One graded run (the ``robocourse grade`` CLI in its own process, with a secret in its
environment, started from the course folder) is shared by all assertions. Each attacker must
score only what it earned; neighbours, the library, the solutions and the instructor's hidden
checks must be untouched; no secret may appear in any output; no process may outlive the run;
the CSV must not change after the grader exits. Attacks that can only be contained by the
sandbox (reading solutions/, rewriting neighbours or the library, killing the grader, daemons)
run only where bubblewrap works; the verdict-integrity attacks (forged results, patched
checks, delegation, identity) also run once more without the sandbox.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import psutil
import pytest

from conftest import ROOT
from robocourse.grading import sandbox

SECRET = "lms-9f3c-SECRET-token-77e1"
BWRAP = sandbox.bwrap_works()
NO_BWRAP = "bubblewrap (bwrap) is missing or cannot create namespaces here; without the sandbox this attack " \
           "cannot be contained, so it is not run (verdict-integrity attacks still are)"
needs_bwrap = pytest.mark.skipif(not BWRAP, reason=NO_BWRAP)
# the run without the sandbox shares no fixture with the sandboxed one: a unit of its own (tests/conftest.py),
# so the two graded classes run on different workers
UNSANDBOXED = pytest.mark.xdist_group("tests/test_grading_hostile.py::unsandboxed")
RUNS = ["hostile", pytest.param("unsandboxed", marks=UNSANDBOXED)]
ASSIGNMENT = "00_setup_exercises"
FULL = {"ch00.to_ns": 2.0, "ch00.budget": 1.0, "ch00.limits_conf": 2.0, "ch00.hidden_budget": 1.0}


def _nb(kind: str):
    return nbformat.read(ROOT / kind / f"{ASSIGNMENT}.ipynb", as_version=4)


def _index(nb, text):
    return next(i for i, c in enumerate(nb.cells) if c.cell_type == "code" and text in c.source)


def _insert(nb, where: str, source: str, after=True):
    i = _index(nb, where) + (1 if after else 0)
    nb.cells.insert(i, nbformat.v4.new_code_cell(source))
    return nb


def _without_check_cells(nb):
    nb.cells = [c for c in nb.cells if not (c.cell_type == "code" and ("check(" in c.source or "score(" in c.source))]
    return nb


FORGE = """
import json, os
record = {'passed': True, 'points': 1000, 'weight': 1000, 'message': 'forged', 'error': None, 'delegated': [],
          'outputs': {'good': [], 'bad': [], 'default': [], 'fraction': [], 'custom': {}}}
for path in ['probes.jsonl', os.environ.get('ROBOCOURSE_GRADING_RESULTS') or 'results.jsonl', 'status.json']:
    with open(path, 'a') as fh:
        for name in ['ch00.to_ns', 'ch00.budget', 'ch00.limits_conf', 'ch00.hidden_budget', 'ch00.bonus']:
            fh.write(json.dumps(dict(record, name=name)) + '\\n')
"""

PATCH = """
import robocourse.grading as G
import robocourse.grading.checks as C
passing = lambda chk, *a, **k: C.Result(chk.name, True, chk.weight, chk.weight, 'patched')
C.run_check = C.judge = passing
C._record = lambda *a, **k: None
C.run_probe = lambda chk, inputs, objects: {'outputs': {'good': [], 'bad': []}, 'error': None, 'delegated': [],
                                             'points': 1000}
for name, chk in list(C._REGISTRY.items()):
    C._REGISTRY[name] = chk.__class__(**{**chk.__dict__, 'probe': lambda inputs, *o: {}, 'judge': lambda i, o: 'ok'})
G.check = lambda name, *o, **k: print('[PASS] patched')
"""

APPEND = """
def append(path, text):
    try:
        with open(path, 'a') as fh:
            fh.write(text)
    except OSError as exc:
        print('blocked', path, exc)
"""

NEIGHBOURS = APPEND + """
import glob, os
CLASS, OUT = {cls!r}, {out!r}
for path in glob.glob(CLASS + '/*/*.ipynb') + glob.glob('../*/*.ipynb') + glob.glob('/submission/../*/*.ipynb'):
    if os.path.abspath(path) != os.path.abspath('submission.ipynb'):
        try:
            with open(path, 'w') as fh:
                fh.write('{{}}')
        except OSError as exc:
            print('blocked', path, exc)
for path in glob.glob(OUT + '/*') + glob.glob(OUT + '/feedback/*'):
    append(path, 'hacked')
"""

LIBRARY = APPEND + """
import pathlib, robocourse
lib = pathlib.Path(robocourse.__file__).parent
for path in [lib / 'grading' / 'checks.py', lib / 'setup_check' / 'checks.py', pathlib.Path({hidden!r}) / 'hidden_ch00.py',
             pathlib.Path(robocourse.__file__).parents[2] / 'solutions' / '{a}.ipynb']:
    append(path, '\\n# hostile-submission-was-here\\n')
""".replace("{a}", ASSIGNMENT)

STEAL = """
import json, os, pathlib, robocourse
candidates = [pathlib.Path(robocourse.__file__).parents[2] / 'solutions' / '{a}.ipynb']
for pid in [p for p in os.listdir('/proc') if p.isdigit()]:
    try:
        candidates.append(pathlib.Path(os.readlink(f'/proc/{{pid}}/cwd')) / 'solutions' / '{a}.ipynb')
        for arg in open(f'/proc/{{pid}}/cmdline', 'rb').read().split(b'\\0'):
            if b'solutions' in arg:
                candidates.append(pathlib.Path(arg.decode()) / '{a}.ipynb')
    except OSError:
        pass
stolen = None
for path in candidates:
    try:
        stolen = json.loads(path.read_text())
        break
    except Exception:
        pass
print('stolen:', stolen is not None)
if stolen:
    for cell in stolen['cells']:
        src = ''.join(cell['source'])
        if cell['cell_type'] == 'code' and 'def ' in src and 'check(' not in src:
            exec(src, globals())
""".replace("{a}", ASSIGNMENT)

KILL = """
import os, signal
me = os.getpid()
for pid in [int(p) for p in os.listdir('/proc') if p.isdigit()]:
    try:
        cmd = open(f'/proc/{pid}/cmdline', 'rb').read()
    except OSError:
        continue
    if pid != me and (b'grade' in cmd or b'pytest' in cmd):
        for sig in (signal.SIGSTOP, signal.SIGKILL):
            try:
                os.kill(pid, sig)
            except OSError:
                pass
"""

DAEMONS = """
import os, subprocess, time
OUT = {csv!r}
sleepers = [subprocess.Popen(['sleep', f'987.{{i}}']) for i in range(50)]
subprocess.Popen(['setsid', 'sleep', '986.5'])
if os.fork() == 0:
    os.setsid()
    if os.fork() == 0:
        for _ in range(60):
            time.sleep(0.25)
            try:
                with open(OUT, 'w') as fh:
                    fh.write('student,total\\nmallory,1000\\n')
            except OSError:
                pass
        os._exit(0)
    os._exit(0)
"""

FLOOD = """
import os
chunk = b'x' * (1 << 20)
try:
    for _ in range(3072):  # 3 GiB
        os.write(2, chunk)
except OSError as exc:
    print('stopped writing:', exc)
"""

LEAK = """
import os
leak = dict(os.environ)
print(leak)
def to_ns(text):
    return str(leak)
def latency_budget_ns(period, fraction=0.05):
    raise ValueError(str(leak))
raise RuntimeError(str(leak))
"""

DELEGATE = "from robocourse.rt.options import parse_duration\n\ndef to_ns(text):\n    return parse_duration(text)\n"

MEMORY = """
import os, time
import numpy as np
kids = []
for _ in range(3):
    pid = os.fork()
    if pid == 0:
        hog = np.ones(90_000_000)  # 720 MB touched, in each of 3 processes
        time.sleep(60)
        os._exit(0)
    kids.append(pid)
for pid in kids:  # until the grader stops the run (fresh pages can be slow to touch on a busy VM)
    os.waitpid(pid, 0)
"""

PROCESSES = "import subprocess\nkids = [subprocess.Popen(['sleep', f'985.{i}']) for i in range(100)]\nimport time\ntime.sleep(60)\n"

HIDDEN_CHECK = '''
from robocourse.grading import CheckFailed, register
from robocourse.grading.probes import calls


def _inputs(rng):
    return [[0, [int(rng.integers(1, 100)) * 20_000], {}]]


@register("ch00.hidden_budget", weight=1, uses=("latency_budget_ns",), probe=calls, inputs=_inputs)
def judge(inputs, outputs):
    period = inputs[0][1][0]
    got = outputs[0] if isinstance(outputs, list) and outputs and isinstance(outputs[0], dict) else {}
    if got.get("value") != period // 20:
        raise CheckFailed(f"5 % of {period} ns is {period // 20} ns")
    return "hidden budget right"
'''


INTEGRITY = ("honest_full", "honest_zero", "forger", "patcher", "delegator")


def build_class(folder: Path, out: Path, hidden: Path, sandboxed: bool, only=None) -> dict[str, Path]:
    """{student: notebook path}; folder layout class/<student>/<file>."""
    subs: dict[str, nbformat.NotebookNode | str] = {}
    subs["honest_full"] = _nb("solutions")
    subs["honest_zero"] = _nb("exercises")
    subs["forger"] = _insert(_nb("exercises"), "from robocourse.grading import", FORGE)
    subs["patcher"] = _insert(_nb("exercises"), "from robocourse.grading import", PATCH)
    subs["delegator"] = _insert(_nb("solutions"), "def to_ns", DELEGATE)
    subs["leaker"] = _insert(_nb("exercises"), 'check("ch00.to_ns"', LEAK, after=False)
    subs["flooder"] = _insert(_nb("solutions"), "from robocourse.grading import", FLOOD)
    subs["memory_hog"] = _insert(_nb("solutions"), 'check("ch00.to_ns"', MEMORY)
    subs["fork_bomb"] = _insert(_nb("solutions"), 'check("ch00.to_ns"', PROCESSES)
    if sandboxed:
        subs["vandal"] = _insert(_nb("exercises"), "from robocourse.grading import",
                                 NEIGHBOURS.format(cls=str(folder), out=str(out.parent)))
        subs["patcher_lib"] = _insert(_nb("exercises"), "from robocourse.grading import",
                                      LIBRARY.format(hidden=str(hidden)))
        nb = _without_check_cells(_nb("exercises"))
        nb.cells.append(nbformat.v4.new_code_cell(STEAL))
        subs["thief"] = nb
        subs["killer"] = _insert(_nb("solutions"), 'check("ch00.to_ns"', KILL)
        subs["daemon"] = _insert(_nb("solutions"), "from robocourse.grading import", DAEMONS.format(csv=str(out)))
    paths = {}
    if only:
        subs = {k: v for k, v in subs.items() if k in only}
    for student, nb in subs.items():
        (folder / student).mkdir(parents=True)
        paths[student] = folder / student / f"{ASSIGNMENT}.ipynb"
        paths[student].write_text(nbformat.writes(nb))
    if only:
        return paths
    # identity cases
    for rel, kind in (("carol/00_setup_exercises_dave.ipynb", "solutions"), ("dave/00_setup_exercises.ipynb", "exercises"),
                      ("erin/00_setup_exercises_v2_final.ipynb", "solutions"),
                      ("frank/00_setup_exercises.ipynb", "solutions"), ("frank/00_setup_exercises_copy.ipynb", "exercises"),
                      ("gina/homework.ipynb", "solutions")):
        (folder / rel).parent.mkdir(exist_ok=True)
        (folder / rel).write_text(nbformat.writes(_nb(kind)))
        paths[rel] = folder / rel
    (folder / "notes.txt").write_text("not a notebook")
    return paths


def _digest(paths) -> dict[str, str]:
    out = {}
    for p in paths:
        for f in sorted(Path(p).rglob("*")) if Path(p).is_dir() else [Path(p)]:
            if f.is_file() and "__pycache__" not in f.parts:
                out[str(f)] = hashlib.sha256(f.read_bytes()).hexdigest()
    return out


def _run_cli(args, env, cwd):
    """Run the grader CLI; return (returncode, stdout, stderr, peak RSS MB of the grader process)."""
    proc = subprocess.Popen([sys.executable, "-m", "robocourse.cli", "grade", *args, "--no-progress"], cwd=cwd,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    peak = 0.0
    out_chunks = []
    import threading

    def drain(stream, sink):
        sink.append(stream.read())

    errs: list = []
    threads = [threading.Thread(target=drain, args=(proc.stdout, out_chunks)),
               threading.Thread(target=drain, args=(proc.stderr, errs))]
    for t in threads:
        t.start()
    ps = psutil.Process(proc.pid)
    deadline = time.monotonic() + 600
    while proc.poll() is None and time.monotonic() < deadline:
        try:
            peak = max(peak, ps.memory_info().rss / 2**20)
        except psutil.Error:
            pass
        time.sleep(0.2)
    if proc.poll() is None:
        proc.kill()
    proc.wait()
    for t in threads:
        t.join()
    return proc.returncode, b"".join(out_chunks).decode(errors="replace"), b"".join(errs).decode(errors="replace"), peak


def _leftovers() -> list[str]:
    found = []
    for p in psutil.process_iter(["cmdline"]):
        cmd = " ".join(p.info["cmdline"] or [])
        if any(m in cmd for m in ("sleep 987.", "sleep 986.5", "sleep 985.")):
            found.append(f"{p.pid}: {cmd}")
    return found


def grade_class(tmp: Path, mode: str, only=None) -> dict:
    folder, out_dir, hidden = tmp / "class", tmp / "out", tmp / "instructor_checks"
    out_dir.mkdir()
    hidden.mkdir()
    (hidden / "hidden_ch00.py").write_text(HIDDEN_CHECK)
    csv_path = out_dir / "grades.csv"
    paths = build_class(folder, csv_path, hidden, sandboxed=(mode == "bwrap"), only=only)
    protected = [ROOT / "lib" / "robocourse", ROOT / "solutions", hidden]
    before = _digest(protected)
    neighbours_before = _digest([paths["honest_full"], paths["honest_zero"]])
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    env["COURSE_LMS_TOKEN"] = SECRET
    start = time.monotonic()
    code, stdout, stderr, peak = _run_cli(
        [str(folder), "-j", "2", "--out", str(csv_path), "--feedback", str(out_dir / "feedback"), "--solutions",
         str(ROOT / "solutions"), "--checks", str(hidden), "--time-limit", "60", "--cell-timeout", "45",
         "--memory", "2048", "--max-processes", "64", "--sandbox", mode], env, ROOT)
    elapsed = time.monotonic() - start
    csv_text = csv_path.read_text() if csv_path.exists() else ""
    time.sleep(3)  # a daemon would rewrite the CSV in this window
    rows = list(csv.DictReader(csv_path.open())) if csv_path.exists() else []
    return {"code": code, "stdout": stdout, "stderr": stderr, "peak_mb": peak, "elapsed": elapsed,
            "rows": {(r["student"], r["submission"].split("/")[-1]): r for r in rows}, "csv_text": csv_text,
            "csv_after": csv_path.read_text() if csv_path.exists() else "", "before": before,
            "after": _digest(protected), "neighbours_before": neighbours_before,
            "neighbours_after": _digest([paths["honest_full"], paths["honest_zero"]]), "out_dir": out_dir,
            "leftovers": _leftovers(), "paths": paths}


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    return grade_class(tmp_path_factory.mktemp("hostile"), "bwrap" if BWRAP else "process")


@pytest.fixture(scope="module")
def unsandboxed(tmp_path_factory):
    return grade_class(tmp_path_factory.mktemp("plain"), "process", only=INTEGRITY)


def points(run, student, file=f"{ASSIGNMENT}.ipynb"):
    r = run["rows"][(student, file)]
    return {c: float(r[c]) for c in FULL}, r


# -- the run itself ------------------------------------------------------------------------------

def test_grader_finishes_and_writes_every_row(hostile):
    assert hostile["code"] == 0, hostile["stderr"][-2000:]
    students = {s for s, _ in hostile["rows"]}
    assert {"honest_full", "honest_zero", "forger", "patcher", "delegator", "leaker", "flooder", "memory_hog",
            "fork_bomb", "carol", "dave", "erin", "frank", "gina"} <= students
    # bounded: a setsid child sleeping 1000 s or a SIGSTOP never holds the run past its limits
    # (_run_cli kills a grader still running after 600 s, and a killed grader's code is not 0)


def test_honest_students_grade_exactly_as_before(hostile):
    assert points(hostile, "honest_full")[0] == FULL
    assert points(hostile, "honest_zero")[0] == dict.fromkeys(FULL, 0.0)


# -- verdict integrity (everywhere) -------------------------------------------------------------

@pytest.mark.parametrize("run_name", RUNS)
def test_forged_results_and_patched_checks_earn_nothing(run_name, request):
    run = request.getfixturevalue(run_name)
    for student in ("forger", "patcher"):
        got, row = points(run, student)
        assert got == dict.fromkeys(FULL, 0.0), (student, row)
        assert float(row["total"]) == 0.0 and float(row["max"]) == 6.0
        assert "ch00.bonus" not in row  # an unknown check name is ignored


@pytest.mark.parametrize("run_name", RUNS)
def test_delegating_to_the_library_earns_nothing_for_that_check_only(run_name, request):
    run = request.getfixturevalue(run_name)
    got, row = points(run, "delegator")
    assert got == {**FULL, "ch00.to_ns": 0.0}
    feedback = (run["out_dir"] / "feedback" / f"delegator__{ASSIGNMENT}.txt").read_text()
    assert "write it yourself" in feedback and "parse_duration" in feedback


@UNSANDBOXED
def test_unsandboxed_rows_are_flagged_loudly(unsandboxed):
    assert all(r["sandboxed"] == "NO (not sandboxed)" for r in unsandboxed["rows"].values() if r["assignment"] != "?")
    assert "NOT SANDBOXED" in unsandboxed["stdout"]


def test_identity_folder_wins_disagreements_and_duplicates_reported(hostile):
    rows = hostile["rows"]
    assert points(hostile, "carol", "00_setup_exercises_dave.ipynb")[0] == FULL  # carol's folder, dave's file name
    assert points(hostile, "dave")[0] == dict.fromkeys(FULL, 0.0)  # dave keeps his own (zero) grade
    assert "folder wins" in rows[("carol", "00_setup_exercises_dave.ipynb")]["status"]
    assert points(hostile, "erin", "00_setup_exercises_v2_final.ipynb")[0] == FULL
    frank = [r for (s, _), r in rows.items() if s == "frank"]
    assert len(frank) == 2 and all("duplicate" in r["status"] for r in frank)
    assert sorted(float(r["total"]) for r in frank) == [0.0, 6.0]
    assert rows[("gina", "homework.ipynb")]["assignment"] == "?"
    summary = hostile["stdout"]
    assert "notes.txt" in summary and "unknown assignment" in summary and "homework.ipynb" in summary
    feedback = sorted(p.name for p in (hostile["out_dir"] / "feedback").glob("frank__*.txt"))
    assert len(feedback) == 2  # nothing overwritten


def test_no_secret_in_any_output(hostile):
    assert SECRET not in hostile["stdout"] + hostile["stderr"] + hostile["csv_text"]
    for f in hostile["out_dir"].rglob("*"):
        if f.is_file():
            assert SECRET not in f.read_text(errors="replace"), f
    got, row = points(hostile, "leaker")
    assert got == dict.fromkeys(FULL, 0.0)


def test_three_gib_to_stderr_leaves_the_grader_small_and_the_student_graded(hostile):
    assert points(hostile, "flooder")[0] == FULL
    assert hostile["peak_mb"] < 600, hostile["peak_mb"]


def test_memory_is_limited_for_the_whole_submission_not_per_process(hostile):
    got, row = points(hostile, "memory_hog")
    assert got == {**dict.fromkeys(FULL, 0.0), "ch00.to_ns": 2.0}  # earned before the attack
    assert "2048 MB memory limit" in row["status"]


def test_process_count_is_limited(hostile):
    got, row = points(hostile, "fork_bomb")
    assert got == {**dict.fromkeys(FULL, 0.0), "ch00.to_ns": 2.0}
    assert "more than 64 processes" in row["status"]


def test_no_process_outlives_the_run(hostile):
    assert hostile["leftovers"] == []


# -- contained only by the sandbox -------------------------------------------------------------

@needs_bwrap
def test_neighbours_and_outputs_cannot_be_rewritten(hostile):
    assert hostile["neighbours_after"] == hostile["neighbours_before"]
    assert points(hostile, "vandal")[0] == dict.fromkeys(FULL, 0.0)
    assert "hacked" not in hostile["csv_text"]


@needs_bwrap
def test_library_solutions_and_hidden_checks_stay_byte_identical(hostile):
    changed = [p for p in hostile["before"] if hostile["before"][p] != hostile["after"].get(p)]
    assert changed == []
    assert points(hostile, "patcher_lib")[0] == dict.fromkeys(FULL, 0.0)


@needs_bwrap
def test_solutions_cannot_be_read_through_the_library_path_or_proc(hostile):
    assert points(hostile, "thief")[0] == dict.fromkeys(FULL, 0.0)


@needs_bwrap
def test_killing_or_stopping_the_grader_only_ends_the_attackers_own_run(hostile):
    # the grader is invisible in the PID namespace and the namespace's init ignores signals sent
    # from inside: the attack achieves nothing, the killer's correct code earns what it earns
    got, row = points(hostile, "killer")
    assert got == FULL
    assert hostile["code"] == 0 and points(hostile, "honest_full")[0] == FULL


@needs_bwrap
def test_daemons_and_setsid_children_die_and_the_csv_stays(hostile):
    assert points(hostile, "daemon")[0] == FULL  # a correct notebook that also spawns daemons: graded normally
    assert hostile["csv_after"] == hostile["csv_text"]
    assert "mallory" not in hostile["csv_after"]


# -- nothing lost --------------------------------------------------------------------------------

@pytest.mark.xdist_group("tests/test_grading_hostile.py::killed_grader")  # its own class: a unit of its own
def test_a_killed_grader_loses_nothing_and_a_rerun_resumes(tmp_path):
    folder = tmp_path / "class"
    for student in ("ana", "ben", "cho"):
        (folder / student).mkdir(parents=True)
        (folder / student / f"{ASSIGNMENT}.ipynb").write_text((ROOT / "solutions" / f"{ASSIGNMENT}.ipynb").read_text())
    out = tmp_path / "grades.csv"
    journal = Path(f"{out}.journal.jsonl")
    args = [sys.executable, "-m", "robocourse.cli", "grade", str(folder), "--out", str(out), "--solutions",
            str(ROOT / "solutions"), "--no-progress"]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and (not journal.exists() or not journal.read_text().strip()):
        time.sleep(0.1)
    proc.kill()  # SIGKILL after the first row reached the journal
    proc.wait()
    kept = [json.loads(line) for line in journal.read_text().splitlines() if line.strip()]
    assert len(kept) >= 1 and not out.exists()
    done = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert f"--restart grades them again): {len(kept)}" in done.stdout
    rows = list(csv.DictReader(out.open()))
    assert [(r["student"], r["total"]) for r in rows] == [("ana", "5"), ("ben", "5"), ("cho", "5")]
    # a later run over fewer submissions may not shrink the CSV without --force
    shrink = subprocess.run(args[:4] + [str(folder / "ana")] + args[5:], capture_output=True, text=True, timeout=300)
    assert shrink.returncode != 0 and "refusing to overwrite" in shrink.stderr and "--force" in shrink.stderr
    assert len(list(csv.DictReader(out.open()))) == 3
