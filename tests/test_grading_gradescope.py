"""The Gradescope autograder package, run as Gradescope runs it.

``robocourse grade export-gradescope ch00`` writes the zip; for a correct, a wrong and a broken
submission the test lays out a directory the way Gradescope's harness does (the zip extracted
to source/, run_autograder beside it, the student's file in submission/, an empty results/),
binds it at /autograder inside a bubblewrap sandbox (no network, working directory
/autograder) and runs /autograder/run_autograder; results.json must fit Gradescope's documented
fields and score what the submission earned.

setup.sh is Gradescope's to run while it builds the image (apt and pip from the network,
minutes): here it is checked for syntax and for installing exactly the course's pins, and the
sandbox gets this checkout's virtual environment at /autograder/venv, where setup.sh puts one,
with the zip's own copy of the library first on the path.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import nbformat
import pytest

from conftest import ROOT
from robocourse.grading import gradescope, sandbox

pytestmark = pytest.mark.skipif(not sandbox.bwrap_works(), reason="bubblewrap is missing or cannot create "
                                                                    "namespaces: the /autograder layout needs it")
NB = "00_setup_exercises"


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "autograder.zip"
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "grade", "export-gradescope", "ch00", "--out",
                           str(out), "--solutions", str(ROOT / "solutions"), "--time-limit", "120"],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    return out


def run_autograder(package: Path, tmp: Path, name: str, content: bytes) -> tuple[dict, str]:
    ag = tmp / "autograder"
    (ag / "submission").mkdir(parents=True)
    (ag / "results").mkdir()
    (ag / "venv").mkdir()
    with zipfile.ZipFile(package) as z:
        z.extractall(ag / "source")
    shutil.copy(ag / "source" / "run_autograder", ag / "run_autograder")
    os.chmod(ag / "run_autograder", 0o755)
    (ag / "submission" / name).write_bytes(content)
    venv = Path(sys.prefix)
    cmd = [sandbox.bwrap_path(), "--tmpfs", "/"]  # a fresh root: the machine's folders read-only, /autograder new
    for top in sorted(os.listdir("/")):
        path = f"/{top}"
        if top in ("proc", "dev", "sys", "tmp", "autograder", "run"):
            continue
        cmd += ["--symlink", os.readlink(path), path] if os.path.islink(path) else ["--ro-bind", path, path]
    cmd += ["--dev", "/dev", "--proc", "/proc", "--tmpfs", "/tmp", "--ro-bind", "/sys", "/sys",
            "--bind", str(ag), "/autograder", "--ro-bind", str(venv), "/autograder/venv", "--unshare-net",
           "--unshare-pid", "--die-with-parent", "--chdir", "/autograder",
           "--setenv", "PYTHONPATH", "/autograder/source/course/lib", "/autograder/run_autograder"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
    results = ag / "results" / "results.json"
    assert results.exists(), proc.stdout[-2000:] + proc.stderr[-2000:]
    return json.loads(results.read_text()), proc.stdout


def test_the_package_has_setup_and_run_autograder_at_its_root_and_no_solution(package):
    with zipfile.ZipFile(package) as z:
        names = z.namelist()
        assert {"setup.sh", "run_autograder"} <= set(names)
        assert (z.getinfo("run_autograder").external_attr >> 16) & 0o111  # executable
        setup = z.read("setup.sh").decode()
        assert z.read("course/requirements.txt") == (ROOT / "requirements.txt").read_bytes()
        stub = z.read(f"course/assignment/{NB}.ipynb").decode()
    assert "pip install --quiet -r /autograder/source/course/requirements.txt" in setup
    assert subprocess.run(["bash", "-n"], input=setup, text=True).returncode == 0
    assert not any(n.startswith(("course/solutions", "course/tests")) for n in names)
    assert "BEGIN SOLUTION" not in stub and "def to_ns" not in stub and "check('ch00.to_ns')" in stub


@pytest.mark.parametrize("kind", ["correct", "wrong", "broken"])
def test_run_autograder_writes_documented_results(package, tmp_path, kind):
    source = {"correct": ROOT / "solutions" / f"{NB}.ipynb", "wrong": ROOT / "exercises" / f"{NB}.ipynb"}
    if kind == "broken":
        content = (ROOT / "solutions" / f"{NB}.ipynb").read_bytes()[:700]  # a truncated upload
    else:
        nb = nbformat.read(source[kind], as_version=4)
        content = nbformat.writes(nb).encode()
    data, stdout = run_autograder(package, tmp_path, f"{NB}.ipynb", content)
    assert gradescope.validate_results(data) == [], data
    tests = {t["name"].split(":")[0]: t for t in data["tests"]}
    assert set(tests) == {"ch00.to_ns", "ch00.budget", "ch00.limits_conf"}
    assert sum(t["max_score"] for t in tests.values()) == 5.0
    assert data["score"] == sum(t["score"] for t in tests.values())
    if kind == "correct":
        assert data["score"] == 5.0 and all(t["status"] == "passed" for t in tests.values())
        assert "[seed " in tests["ch00.to_ns"]["output"] and "sub-tests passed" in tests["ch00.to_ns"]["output"]
    elif kind == "wrong":
        assert data["score"] == 0.0 and all("not implemented" in t["output"] for t in tests.values())
    else:
        assert data["score"] == 0.0 and "not a valid notebook" in data["output"]
    assert "Graded 1 submission" in stdout  # the instructor's view (stdout) has the run summary


def test_a_submission_without_a_notebook_is_told_what_to_upload(package, tmp_path):
    data, _ = run_autograder(package, tmp_path, "answers.py", b"print('hi')\n")
    assert gradescope.validate_results(data) == [] and data["score"] == 0.0
    assert f"upload {NB}.ipynb" in data["output"]


def test_the_validator_names_departures_from_the_documented_fields():
    bad = {"score": "5", "tests": [{"score": 3, "max_score": 2, "status": "ok", "visibility": "public",
                                    "points": 1}], "colour": "red"}
    problems = gradescope.validate_results(bad)
    assert any("score: expected" in p for p in problems) and any("unknown top-level field 'colour'" in p
                                                                  for p in problems)
    assert any("status 'ok'" in p for p in problems) and any("visibility 'public'" in p for p in problems)
    assert any("unknown field 'points'" in p for p in problems) and any("outside 0..max_score" in p for p in problems)
