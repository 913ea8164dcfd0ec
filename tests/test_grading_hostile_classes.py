"""Issue 26's hostile classes, each attack bounded in size and time, graded in one CLI run.

- judges trust no probe data: a forged first record, a 30 MB answer (not parsed, judged in ms);
- neighbours share the machine: 900 MB held in memfds (outside every process) under a 600 MB
  limit, a disk filler, a CPU spinner beside an honest neighbour (each on its own CPU slot);
- public shortcuts: importing the answer key, delegating to the library from a pool thread;
- what reaches the instructor: escape sequences and spreadsheet formulas in reasons and folder
  names, a submission that is a symlink, a FIFO named *.ipynb;
- bookkeeping: a rerun with a changed option grades again and says why; an unchanged rerun
  reuses the journal and says so.
Honest neighbours must score exactly as alone. The cgroup cases run where the grader may
create cgroups (root here); elsewhere the documented fallback is asserted instead.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest

from conftest import ROOT
from robocourse.grading import resources, sandbox

ASSIGNMENT = "00_setup_exercises"
FULL = {"ch00.to_ns": 2.0, "ch00.budget": 1.0, "ch00.limits_conf": 2.0}
CGROUPS = resources.mode() != "polling"
pytestmark = pytest.mark.timeout(900)  # one graded class of 13 and three reruns; slow only on a loaded machine
BWRAP = sandbox.bwrap_works()


def _solution():
    return nbformat.read(ROOT / "solutions" / f"{ASSIGNMENT}.ipynb", as_version=4)


def _after(nb, text, source):
    i = next(i for i, c in enumerate(nb.cells) if c.cell_type == "code" and text in c.source)
    nb.cells.insert(i + 1, nbformat.v4.new_code_cell(source))
    return nb


def _replace(nb, text, source):
    cell = next(c for c in nb.cells if c.cell_type == "code" and text in c.source)
    cell.source = source
    return nb


FORGE_FIRST = """
import json
with open('probes.jsonl', 'a') as fh:
    for name in ('ch00.to_ns', 'ch00.budget', 'ch00.limits_conf'):
        fh.write(json.dumps({'name': name, 'outputs': {'good': [], 'bad': [], 'default': [], 'fraction': [],
                                                        'custom': [], 'periods': []}, 'error': None,
                             'delegated': [], 'seconds': 0.0}) + '\\n')
"""

HUGE = """
_honest_to_ns = to_ns
def to_ns(text):
    return 'x' * 30_000_000 if text == '1ms' else _honest_to_ns(text)
"""

MEMFD = """
import os, time
chunk = b'x' * (1 << 20)
held = []
for k in range(15):
    fd = os.memfd_create(f'hog{k}')
    for _ in range(60):
        os.write(fd, chunk)
    held.append(fd)
time.sleep(5)
"""

DISK = """
import os
written = 0
try:
    for k in range(8):
        with open(f'/tmp/fill{k}.bin', 'wb') as fh:
            fh.write(b'\\0' * (60 << 20))
        written += 60
except OSError as exc:
    print('stopped at', written, 'MB:', exc)
"""

SPIN = """
import subprocess, sys, time
spinners = [subprocess.Popen([sys.executable, '-c', 'while True: pass']) for _ in range(3)]
time.sleep(3)
"""

KEY_THIEF = """
from robocourse.setup_check.checks import expected_ns

def to_ns(text):
    value = expected_ns(text)
    if value is None:
        raise ValueError(f'bad duration {text!r}')
    return value
"""

POOL_DELEGATE = """
import concurrent.futures
from robocourse.rt.options import parse_duration
pool = concurrent.futures.ThreadPoolExecutor(1)

def to_ns(text):
    return pool.submit(parse_duration, text).result()
"""

ESCAPES = """
import json
raise RuntimeError('\\x1b[2J\\x1b[31m=cmd|" /C calc"!A0')
"""

STATUS_FORGE = """
import json, os
with open('status.json', 'w') as fh:
    json.dump({'finished': True, 'reason': '=HYPERLINK("http://x","\\x1b[31mclick")', 'errors': []}, fh)
os.chmod('status.json', 0o444)  # the runner's later writes fail: this reason is what the grader reads
"""


def build_class(folder: Path) -> dict[str, Path]:
    subs = {
        "honest_a": _solution(),
        "honest_b": _solution(),
        "forger_first": _after(_solution(), "from robocourse.grading import", FORGE_FIRST),
        "huge": _after(_solution(), "def to_ns", HUGE),
        "memfd_hog": _after(_solution(), 'check("ch00.to_ns"', MEMFD),
        "disk_filler": _after(_solution(), 'check("ch00.to_ns"', DISK),
        "spinner": _after(_solution(), 'check("ch00.to_ns"', SPIN),
        "key_thief": _replace(_solution(), "def to_ns", KEY_THIEF),
        "pool_delegate": _replace(_solution(), "def to_ns", POOL_DELEGATE),
        "=1+1": _after(_solution(), 'check("ch00.limits_conf"', ESCAPES),
        "status_forger": _after(_solution(), 'check("ch00.limits_conf"', STATUS_FORGE),
    }
    paths = {}
    for student, nb in subs.items():
        (folder / student).mkdir(parents=True)
        paths[student] = folder / student / f"{ASSIGNMENT}.ipynb"
        paths[student].write_text(nbformat.writes(nb))
    (folder / "linker").mkdir()
    os.symlink(paths["honest_a"], folder / "linker" / f"{ASSIGNMENT}.ipynb")
    (folder / "fifo_student").mkdir()
    os.mkfifo(folder / "fifo_student" / f"{ASSIGNMENT}.ipynb")
    return paths


def _cli(args, timeout=600):
    start = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "grade", *args, "--no-progress"],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    return proc, time.monotonic() - start


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("classes")
    paths = build_class(tmp / "class")
    out = tmp / "out" / "grades.csv"
    out.parent.mkdir()
    proc, elapsed = _cli([str(tmp / "class"), "-j", "2", "--out", str(out), "--feedback", str(tmp / "out" / "fb"),
                          "--solutions", str(ROOT / "solutions"), "--time-limit", "90", "--cell-timeout", "40",
                          "--memory", "600", "--work-mb", "200"])
    rows = {r["student"]: r for r in csv.DictReader(out.open())} if out.exists() else {}
    return {"proc": proc, "elapsed": elapsed, "rows": rows, "csv": out.read_text() if out.exists() else "",
            "fb": tmp / "out" / "fb", "paths": paths, "out": out, "tmp": tmp}


def points(run, student):
    return {c: float(run["rows"][student][c]) for c in FULL}


def test_the_run_finishes_bounded_and_honest_neighbours_score_as_alone(run):
    assert run["proc"].returncode == 0, run["proc"].stderr[-2000:]
    # a FIFO, a spinner and a 30 MB answer hold nothing up: no submission was stopped by its time limit (a run
    # they held up would end at _cli's timeout instead); judged by the grader's own verdicts, not the wall
    # clock, which a loaded machine stretches
    assert not {s: r["status"] for s, r in run["rows"].items() if "time limit" in r["status"]}
    for student in ("honest_a", "honest_b"):
        assert points(run, student) == FULL, run["rows"][student]


def test_a_forged_first_record_is_seen_as_tampering_and_earns_nothing(run):
    assert points(run, "forger_first") == dict.fromkeys(FULL, 0.0)
    text = (run["fb"] / f"forger_first__{ASSIGNMENT}.txt").read_text()
    assert "records for this check" in text and "none of them is trusted" in text


def test_a_huge_answer_is_refused_by_size_without_being_judged(run):
    got = points(run, "huge")
    assert got == {**FULL, "ch00.to_ns": 0.0}
    text = (run["fb"] / f"huge__{ASSIGNMENT}.txt").read_text()
    assert "the check reads at most" in text
    judge_s = float(next(line for line in run["proc"].stdout.splitlines()
                         if line.startswith("judging took")).split()[2])
    assert judge_s < 10  # the 30 MB line was never parsed, let alone judged


@pytest.mark.skipif(not CGROUPS, reason="no cgroup can be created here (not root, no delegated cgroup v2): "
                                        "memory held outside processes is not counted by the polling fallback")
def test_memory_held_in_memfds_counts_against_the_submission(run):
    got = points(run, "memfd_hog")
    assert got["ch00.to_ns"] == 2.0 and got["ch00.budget"] == 0.0  # earned before, stopped at the limit after
    assert "600 MB memory limit" in run["rows"]["memfd_hog"]["status"]


@pytest.mark.skipif(not BWRAP, reason="bubblewrap is missing: the work folder cannot be private")
def test_a_disk_filler_fills_only_its_own_folder(run):
    got = points(run, "disk_filler")
    assert got["ch00.to_ns"] == 2.0  # earned before it filled its folder
    assert "its folder was full" in run["rows"]["disk_filler"]["status"]
    assert points(run, "honest_a") == points(run, "honest_b") == FULL


def test_cpu_spinners_get_one_cpus_worth_and_neighbours_their_points(run):
    assert points(run, "spinner") == FULL and points(run, "honest_b") == FULL
    if CGROUPS:
        assert "one CPU's worth each" in run["proc"].stdout


def test_the_answer_key_is_not_importable_in_the_sandbox(run):
    if not BWRAP:
        pytest.skip("without bubblewrap the judge modules cannot be hidden (rows are marked NOT SANDBOXED)")
    assert points(run, "key_thief") == {**FULL, "ch00.to_ns": 0.0}
    text = (run["fb"] / f"key_thief__{ASSIGNMENT}.txt").read_text()
    assert "robocourse.setup_check.checks" in text  # the import error, shown to the student


def test_delegation_from_a_pool_thread_is_caught(run):
    assert points(run, "pool_delegate") == {**FULL, "ch00.to_ns": 0.0}
    assert "write it yourself" in (run["fb"] / f"pool_delegate__{ASSIGNMENT}.txt").read_text()


def test_no_escape_sequence_or_formula_reaches_the_instructor(run):
    assert "\x1b" not in run["proc"].stdout + run["csv"]
    for f in run["fb"].glob("*.txt"):
        assert "\x1b" not in f.read_text(), f
    for row in csv.reader(run["csv"].splitlines()):
        assert not any(cell[:1] in "=+-@" for cell in row if cell), row
    assert "'=1+1" in run["csv"] and "'=HYPERLINK" in run["csv"]
    assert points(run, "'=1+1") == FULL  # the row keeps its (neutralised) name and its points


def test_symlinks_and_fifos_are_refused_with_a_note_never_read(run):
    for student in ("linker", "fifo_student"):
        row = run["rows"][student]
        assert float(row["total"]) == 0.0 and row["status"].startswith("refused:"), row
    assert "symbolic link" in run["rows"]["linker"]["status"]
    assert "FIFO" in run["rows"]["fifo_student"]["status"]


@pytest.mark.xdist_group("tests/test_grading_hostile_classes.py::rerun")  # its own class: a unit of its own
def test_a_rerun_with_changed_options_grades_again_and_says_why(tmp_path):
    folder = tmp_path / "class"
    for student in ("ana", "ben"):
        (folder / student).mkdir(parents=True)
        (folder / student / f"{ASSIGNMENT}.ipynb").write_text(nbformat.writes(_solution()))
    out = tmp_path / "grades.csv"
    base = [str(folder), "--out", str(out), "--solutions", str(ROOT / "solutions"), "-j", "2"]
    first, _ = _cli(base + ["--time-limit", "60"])
    assert first.returncode == 0, first.stderr
    same, _ = _cli(base + ["--time-limit", "60"])
    assert "(same notebook, same options, same checks; --restart grades them again): 2" in same.stdout
    changed, _ = _cli(base + ["--time-limit", "90"])
    assert "graded again although journaled, because what grades them changed (2)" in changed.stdout
    assert "time_limit 60.0 -> 90.0" in changed.stdout
    assert [r["total"] for r in csv.DictReader(out.open())] == ["5", "5"]
    if resources.mode() == "polling":
        return  # no cgroup here: a polled row is all this machine can give, and is reused
    # a row whose cgroup could not be made that time (polled limits, the fallback) is graded again now
    journal = Path(f"{out}.journal.jsonl")
    lines = [json.loads(line) for line in journal.read_text().splitlines()]
    lines[-1]["grade"]["resources"] = "polling: 600 MB of resident memory; the cgroup could not be made (test)"
    journal.write_text("".join(json.dumps(e) + "\n" for e in lines))
    again, _ = _cli(base + ["--time-limit", "90"])
    assert "graded again although journaled, because what grades them changed (1)" in again.stdout, again.stdout
    assert "its limits were only polled then (polling: 600 MB" in again.stdout
    assert "reused from the journal" in again.stdout and [r["total"] for r in csv.DictReader(out.open())] == ["5", "5"]


def test_resources_confine_a_process_to_its_cpu_slot():
    """The cpuset a submission gets is enforced: it cannot widen its own affinity."""
    if not CGROUPS or resources.mode() != "cgroup-v1":
        pytest.skip("no cgroup v1 here: CPU slots are an affinity mask the code could change (documented)")
    cpus = resources.allowed_cpus()
    if len(cpus) < 2:
        pytest.skip("one CPU: no slot to confine to")
    code = ("import os\nprint(sorted(os.sched_getaffinity(0)))\n"
            f"try:\n    os.sched_setaffinity(0, {{{cpus[1]}}})\n    print('widened')\nexcept OSError as exc:\n"
            "    print('refused', exc.errno)\n")
    with resources.Box(512, 64, (cpus[0],)) as box:
        proc = subprocess.run([sys.executable, "-c", code], preexec_fn=box.join, capture_output=True, text=True,
                              timeout=60)
    assert proc.stdout.splitlines() == [f"[{cpus[0]}]", "refused 22"], proc.stdout + proc.stderr
