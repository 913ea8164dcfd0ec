"""``robocourse release``: the student edition holds no solution, runs its notebooks, and is refused
when it would be unsafe (DIR not empty or inside the course, exercises out of sync, a leak)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from robocourse import release as rel
from robocourse.grading import exercises

ROOT = Path(__file__).resolve().parents[1]

# Single lines of solution blocks that also occur, on their own, in files a student gets. Each is
# accounted for here; any other solution line found in the edition fails the test.
SHARED_LINES = {
    "start = clock.now_ns()": {"chapters/01_realtime_basics.ipynb", "exercises/01_realtime_exercises.ipynb"},
    "lat = np.asarray(latency_ns, dtype=np.int64)": {"lib/robocourse/rt/results_file.py"},
    "clock.sleep_until_ns(deadline)": {"lib/robocourse/rt/checks.py"},
    "self.stopped = False": {"lib/robocourse/mycar/drivers.py"},
    "self.stopped = True": {"lib/robocourse/mycar/drivers.py"},
    # the rclpy idiom every action server with cancel writes (chapter 3 teaches it; not an answer alone)
    "if goal_handle.is_cancel_requested:": {"chapters/03_mycar_comm.ipynb", "lib/robocourse/mycar/navigation.py",
                                            "lib/robocourse/mycar/experiments.py", "tests/test_bus_actions.py",
                                            "lib/robocourse/bus/zenoh/peer.py"},
    # chapter 3's launch-file exercise: launch_ros idioms the chapter's and the library's launch files show (the
    # exercise's own graph, names, namespace, remapping and parameter file are not in them)
    "return LaunchDescription([": {"chapters/03_mycar_comm.ipynb", "lib/robocourse/launch/__init__.py",
                                   "lib/robocourse/mycar/launch.py"},
    "condition=IfCondition(use_sim)),": {"lib/robocourse/mycar/launch.py"},
    "condition=UnlessCondition(use_sim)),": {"lib/robocourse/mycar/launch.py"},
    # chapter 3's teleop and navigation exercises: the call the exercise text names, and the stop key's test
    "await self.sleep_async(STEP)": {"exercises/03_mycar_exercises.ipynb"},
    'if key == "x":': {"lib/robocourse/mycar/checks.py", "lib/robocourse/mycar/teleop_live.py"},
    # a QoS keyword argument the zenoh tests also pass (not the exercise's answer on its own)
    "durability=DurabilityPolicy.TRANSIENT_LOCAL),": {"tests/test_zenoh_wire.py", "tests/test_zenoh_qos.py"},
    # the library's TextbookPID, which chapter 2 teaches (release.KNOWN_OVERLAPS says more)
    "self.kp, self.ki, self.kd, self.setpoint = kp, ki, kd, setpoint": {"lib/robocourse/pendulum/pid.py"},
    "self.integral = 0.0": {"lib/robocourse/pendulum/pid.py"},
    "self.integral = candidate": {"lib/robocourse/pendulum/pid.py"},
    "return min(self.u_max, max(self.u_min, u))": {"lib/robocourse/pendulum/pid.py"},
    # chapter 4's parameter-file exercise: the YAML layout every ros2_control parameter file shares, and the
    # wrist line the chapter's failure robot teaches (the JTC section of the answer is the exercise's own)
    "controller_manager:": {
        "benchmarks/control_loop.py",
        "chapters/04_ros2_control.ipynb",
        "lib/robocourse/control/checks.py",
        "lib/robocourse/control/config/rrbot_controllers.yaml",
        "lib/robocourse/control/config/ur5e_controllers.yaml",
        "lib/robocourse/control/manager/controller_manager.py",
        "lib/robocourse/control/manager/services.py",
        "lib/robocourse/control/parameters.py",
        "lib/robocourse/drivers/config/arm_controllers.yaml",
        "lib/robocourse/drivers/config/fr3_controllers.yaml",
        "lib/robocourse/rl/deployment.py",
        "tests/test_control_admittance.py",
        "tests/test_control_controllers.py",
        "tests/test_control_diff_drive.py",
        "tests/test_control_gripper.py",
        "tests/test_control_jtc.py",
        "tests/test_control_manager.py",
        "tests/test_control_mujoco_system.py",
        "tests/test_control_parameters.py",
        "tests/test_control_pid.py",
    },
    "arm_controller:": {"chapters/04_ros2_control.ipynb", "tests/test_control_parameters.py"},
    # chapter 4's <ros2_control> exercise: the element's head and plugin line, as every RRBot / mock URDF has
    # them (the interfaces, limits, initial values and the sensor are the exercise's own)
    '<ros2_control name="RRBot" type="system">': {"lib/robocourse/sim/robots/rrbot.urdf",
                                                  "tests/test_control_hardware.py"},
    "<plugin>mock_components/GenericSystem</plugin>": {
        "lib/robocourse/control/checks.py", "lib/robocourse/control/probes.py", "lib/robocourse/control/hardware/info.py",
        "lib/robocourse/sim/robots/rrbot.urdf", "lib/robocourse/sim/robots/ur5e.urdf", "lib/robocourse/sim/robots/fr3.urdf", "tests/test_control_manager.py"},
    "wrist_controller: {ros__parameters: {joints: [joint3]}}": {"chapters/04_ros2_control.ipynb"},
    # chapter 5's pylibfranka exercise: the API calls its statement names (libfranka's own loop
    # idiom: the chapter, the box's tests and the measurement use them too; not an answer alone)
    "robot.automatic_error_recovery()": {"chapters/05_hardware_drivers.ipynb", "exercises/05_hardware_drivers_exercises.ipynb",
                                         "lib/robocourse/drivers/checks.py", "lib/robocourse/drivers/franka_probes.py",
                                         "lib/robocourse/drivers/franka_system.py", "tests/test_drivers_franka.py"},
    "except pylibfranka.ControlException:": {"lib/robocourse/drivers/franka_probes.py", "chapters/05_hardware_drivers.ipynb",
                                             "tests/test_drivers_franka.py"},
    "t += period.to_sec()": {"chapters/05_hardware_drivers.ipynb", "tests/test_drivers_franka.py"},
    "if cmd.motion_finished:": {"chapters/05_hardware_drivers.ipynb", "lib/robocourse/drivers/measure.py",
                                "tests/test_drivers_franka.py"},
    "cmd.motion_finished = t >= seconds": {"tests/test_drivers_franka.py"},
    "cmd = pylibfranka.JointPositions(q0.tolist())": {"tests/test_drivers_franka.py"},
    # chapter 5's ur_rtde exercise: ur_rtde's documented servo-loop idiom, which the statement and chapter 5's
    # section 1.6 teach (the watchdog, the path's timing and the stop rule are the exercise's own)
    "t_cycle = rtde_c.initPeriod()": {"chapters/05_hardware_drivers.ipynb", "exercises/05_hardware_drivers_exercises.ipynb"},
    "rtde_c.waitPeriod(t_cycle)": {"chapters/05_hardware_drivers.ipynb", "exercises/05_hardware_drivers_exercises.ipynb"},
    "rtde_c.servoStop()": {"chapters/05_hardware_drivers.ipynb", "exercises/05_hardware_drivers_exercises.ipynb",
                           "lib/robocourse/drivers/ur_checks.py"},
    "t = time.monotonic() - t0": {"chapters/05_hardware_drivers.ipynb"},
    # chapter 4's controller exercise ends update() as the controller manager's own cycle does
    "return return_type.OK if ok else return_type.ERROR": {"lib/robocourse/control/manager/controller_manager.py"},
}

# Lines any timing code starts with: they say nothing about an answer, wherever they occur.
GENERIC_LINES = {"t0 = time.monotonic()", "self.timeout = timeout"}


@pytest.fixture(scope="module")
def edition(tmp_path_factory):
    target = tmp_path_factory.mktemp("release") / "robocourse-student"
    out = rel.release(target, root=ROOT)
    assert out.target == target
    return out


def _blocks_by_json(solutions: Path) -> list[tuple[str, list[str]]]:
    """Solution blocks read straight from the notebooks' JSON (not through robocourse.release)."""
    found = []
    for path in sorted(solutions.glob("*.ipynb")):
        for cell in json.loads(path.read_text())["cells"]:
            src = "".join(cell["source"]) if cell["cell_type"] == "code" else ""
            for body in re.findall(r"### BEGIN SOLUTION\n(.*?)\n[ \t]*### END SOLUTION", src, re.S):
                found.append((path.name, body.splitlines()))
    return found


def _reader_text(path: Path) -> str:
    """What a student can read in a file: a notebook's cell sources and outputs, any other file's text."""
    data = path.read_bytes().decode("utf-8", errors="replace")
    if path.suffix == ".ipynb":
        cells = json.loads(data)["cells"]
        return "\n".join("".join(c["source"]) + "\n" + json.dumps(c.get("outputs", [])) for c in cells)
    return data


def test_every_solution_block_is_found_in_the_source_notebooks():
    blocks = _blocks_by_json(ROOT / "solutions")
    assert len(blocks) == len(rel.solution_blocks(ROOT / "solutions")) >= 19
    # the release's detector finds each block where it is: the search below is not blind
    leaks = rel.find_leaks({f"solutions/{p.name}": p.read_bytes() for p in (ROOT / "solutions").glob("*.ipynb")},
                           rel.solution_blocks(ROOT / "solutions"))
    assert len({(lk.block.notebook, lk.block.cell, lk.block.text) for lk in leaks}) == len(
        {(b.notebook, b.cell, b.text) for b in rel.solution_blocks(ROOT / "solutions")})


def test_edition_contains_no_solution_line(edition):
    files = sorted(p for p in edition.target.rglob("*") if p.is_file())
    assert len(files) == len(edition.files) > 100
    # each file's text with its whitespace collapsed, once (a solution line matches however it is indented)
    texts = {p.relative_to(edition.target).as_posix(): " ".join(_reader_text(p).split()) for p in files}
    blocks = _blocks_by_json(ROOT / "solutions")
    unexpected, searched = [], 0
    for notebook, body in blocks:
        lines = [" ".join(x.split()) for x in body]
        for line in lines:
            if len(line) < 12 or re.fullmatch(r"(return|raise) [\w.]+", line) or line in GENERIC_LINES:
                continue  # `return False`, `return value`: says nothing about the answer
            searched += 1
            for name, text in texts.items():
                if line in text and name not in SHARED_LINES.get(line, ()):
                    unexpected.append(f"{name}: {line!r} (from {notebook})")
        whole = " ".join(" ".join(body).split())
        assert not any(whole in t for t in texts.values()), f"a whole block of {notebook} ships"
    assert searched >= 60
    assert unexpected == [], "\n".join(unexpected)


def test_edition_leaves_out_solutions_and_instructor_tests(edition):
    names = set(edition.files)
    assert not any(n.startswith("solutions/") for n in names)
    for instructor_only in ("tests/test_exercises.py", "tests/test_solutions_grade.py", "tests/test_grader.py",
                            "tests/test_release.py", "tests/test_rt_checks.py", "tests/test_mycar_checks.py",
                            "tests/test_pendulum_checks.py"):
        assert instructor_only not in names, instructor_only
    for name in names:
        if name.startswith(("tests/", "benchmarks/")):
            text = (edition.target / name).read_text()
            assert not re.search(rel.READS_SOLUTIONS, text), f"{name} reads solutions/"
    # everything a student works with is there, as it is in the course
    for folder, pattern in (("chapters", "*.ipynb"), ("exercises", "*.ipynb"), ("lib", "**/*.py")):
        for src in (ROOT / folder).glob(pattern):
            if "__pycache__" in src.parts:
                continue
            name = src.relative_to(ROOT).as_posix()
            assert (edition.target / name).read_bytes() == src.read_bytes(), name
    for name in ("Makefile", "requirements.txt", ".gitignore", "tests/conftest.py", "tests/test_lab.py",
                 "tests/test_grading_checks.py", "tests/test_rt_stats.py"):
        assert name in names, name
    assert [e for e in edition.left_out if e[0] == "solutions/"] == [
        ("solutions/", len(list((ROOT / "solutions").glob("*.ipynb"))), "the instructor's notebooks, with the answers")]


def test_edition_exercises_are_the_generated_ones(edition):
    for sol in (ROOT / "solutions").glob("*.ipynb"):
        assert (edition.target / "exercises" / sol.name).read_text() == exercises.expected_text(sol)


def test_edition_pytest_config_collects_tests_chapters_and_exercises_only(edition):
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    conf = tomllib.loads((edition.target / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]
    assert conf["testpaths"] == ["tests", "chapters", "exercises"]
    source = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert source["tool"]["pytest"]["ini_options"]["testpaths"] != conf["testpaths"]  # the rewrite was needed
    conf.pop("testpaths")
    source_conf = source["tool"]["pytest"]["ini_options"]
    source_conf.pop("testpaths")
    assert conf == source_conf  # nothing else changed


def test_edition_readme_opens_with_for_students(edition):
    text = (edition.target / "README.md").read_text()
    headings = [line for line in text.splitlines() if line.startswith("## ")]
    assert headings[0] == "## For students"
    assert not any(h.startswith("## For instructors") for h in headings)
    assert "robocourse grade" not in text and "### BEGIN SOLUTION" not in text
    assert not any(line.startswith("solutions/") for line in text.splitlines())
    source_headings = [line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith("## ")]
    assert len(headings) == len([h for h in source_headings if not h.startswith("## For instructors")])


def test_edition_collects_and_runs_its_notebooks(edition):
    """The edition's own pytest config, on its own library: collection, then two notebooks executed."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PYTEST_ADDOPTS")}
    env["PYTHONPATH"] = str(edition.target / "lib")  # the kernel inherits it: the edition's robocourse
    # timeouts are safety nets: collection imports the whole stack, which takes minutes on a loaded machine
    collect = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider"],
                             cwd=edition.target, env=env, capture_output=True, text=True, timeout=600)
    assert collect.returncode == 0, collect.stdout[-3000:] + collect.stderr[-3000:]
    collected = [line for line in collect.stdout.splitlines() if "::" in line]
    notebooks = {path for path in (line.split("::")[0] for line in collected) if path.endswith(".ipynb")}
    assert notebooks == {f"{d}/{p.name}" for d in ("chapters", "exercises") for p in (ROOT / d).glob("*.ipynb")}
    assert not any("solutions" in line for line in collected)
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "chapters/00_setup_check.ipynb", "exercises/00_setup_exercises.ipynb"],
                         cwd=edition.target, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "2 passed" in run.stdout
    # the kernel imported the edition's library, not the course's (bytecode written next to it)
    assert list((edition.target / "lib/robocourse/setup_check").glob("__pycache__/*.pyc"))


# --- refusals, on a small course built here ---------------------------------------------------------

SOLUTION_CELL = ("def double(x):\n    ### BEGIN SOLUTION\n    result = 2 * x  # the answer\n"
                 "    return result + 0 * len(str(x))\n    ### END SOLUTION\n")
README = "# tiny\n\nintro\n\n## Layout\n\n```\nsolutions/  answers\nexercises/  yours\n```\n\n" \
         "## For instructors\n\nrobocourse grade ...\n\n## For students\n\nclone, make lab\n"


def make_course(folder: Path) -> Path:
    for sub in ("solutions", "exercises", "chapters", "tests", "lib/tiny"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(SOLUTION_CELL), nbformat.v4.new_code_cell('check("t.double", double)')]
    nbformat.write(nb, folder / "solutions/00_tiny.ipynb")
    nbformat.write(nbformat.v4.new_notebook(), folder / "chapters/00_intro.ipynb")
    exercises.build(folder)
    (folder / "README.md").write_text(README)
    (folder / "pyproject.toml").write_text('[tool.pytest.ini_options]\n# old comment\n'
                                           'testpaths = ["tests", "chapters", "solutions"]\naddopts = "-ra"\n')
    (folder / "lib/tiny/__init__.py").write_text("VALUE = 1\n")
    (folder / "tests/test_tiny.py").write_text("def test_one():\n    assert 1\n")
    (folder / "notes.txt").write_text("instructor's notes\n")
    return folder


def test_tiny_course_release_and_its_summary(tmp_path):
    course = make_course(tmp_path / "course")
    out = rel.release(tmp_path / "student", root=course)
    assert sorted(out.files) == [".robocourse-edition.json", "README.md", "chapters/00_intro.ipynb",
                                 "exercises/00_tiny.ipynb", "lib/tiny/__init__.py", "pyproject.toml",
                                 "tests/test_tiny.py"]
    assert ("notes.txt", 1, "no rule includes it") in out.left_out
    readme = (tmp_path / "student/README.md").read_text()
    assert readme == "# tiny\n\nintro\n\n## For students\n\nclone, make lab\n\n## Layout\n\n```\nexercises/  yours\n```\n\n"
    assert "testpaths = [\"tests\", \"chapters\", \"exercises\"]" in (tmp_path / "student/pyproject.toml").read_text()
    assert "old comment" not in (tmp_path / "student/pyproject.toml").read_text()
    marker = json.loads((tmp_path / "student" / rel.MARKER_FILE).read_text())
    assert marker["files"] == sorted(out.files) and marker["built_by"] == "robocourse release"


def test_refuses_non_empty_dir_and_force_replaces_the_previous_edition(tmp_path):
    course = make_course(tmp_path / "course")
    target = tmp_path / "student"
    (target / ".git").mkdir(parents=True)
    (target / ".git/HEAD").write_text("ref: refs/heads/main\n")
    with pytest.raises(ValueError, match=r"is not empty \(1 entries, e.g. '.git'\).*--force"):
        rel.release(target, root=course)
    assert sorted(p.name for p in target.iterdir()) == [".git"]  # nothing written
    rel.release(target, root=course, force=True)
    (course / "tests/test_tiny.py").unlink()  # the next edition drops a test
    (course / "tests/test_other.py").write_text("def test_two():\n    assert 2\n")
    again = rel.release(target, root=course, force=True)
    assert again.removed == ["tests/test_tiny.py"]
    assert sorted(p.name for p in (target / "tests").iterdir()) == ["test_other.py"]
    assert (target / ".git/HEAD").read_text() == "ref: refs/heads/main\n"  # kept


@pytest.mark.parametrize("where", ["course/student", "course/chapters/x", "."])
def test_refuses_a_dir_inside_the_course_or_around_it(tmp_path, where):
    course = make_course(tmp_path / "course")
    with pytest.raises(ValueError, match="inside the course folder|contains the course folder"):
        rel.release(tmp_path / where, root=course)
    assert not (course / "student").exists()


def test_a_root_that_is_not_a_course_folder_is_named_first(tmp_path):
    # run from a folder that is not the course (no solutions/): that is the error, not "inside the course folder"
    (tmp_path / "old").mkdir()
    (tmp_path / "old/f").write_text("x")
    with pytest.raises(FileNotFoundError, match=r"is not the instructor's course folder.*--root"):
        rel.release(tmp_path / "old", root=tmp_path, force=True)
    assert (tmp_path / "old/f").read_text() == "x"


def test_refuses_exercises_out_of_sync(tmp_path):
    course = make_course(tmp_path / "course")
    ex = course / "exercises/00_tiny.ipynb"
    ex.write_text(ex.read_text().replace("YOUR CODE HERE", "my edit"))
    with pytest.raises(ValueError, match=r"out of sync.*robocourse exercises build"):
        rel.release(tmp_path / "student", root=course)
    assert not (tmp_path / "student").exists()


def test_refuses_a_test_that_carries_a_solution(tmp_path):
    course = make_course(tmp_path / "course")
    (course / "tests/test_reference.py").write_text(  # two lines of the block, reindented: still found
        "def reference(x):\n        result = 2 * x\n        return result + 0 * len(str(x))\n")
    with pytest.raises(ValueError, match=r"tests/test_reference.py holds solution block 00_tiny.ipynb, cell 0.*MANIFEST"):
        rel.release(tmp_path / "student", root=course)
    assert not (tmp_path / "student").exists()


def test_refuses_a_manifest_that_ships_solutions(tmp_path):
    bad = (rel.Rule("include", "solutions/*.ipynb", "oops"),) + rel.MANIFEST
    with pytest.raises(ValueError, match=r"solutions/\d\d_\w+\.ipynb holds solution block"):
        rel.plan(ROOT, bad)


def test_known_overlap_is_reported_not_hidden():
    out = rel.plan(ROOT)
    assert [(leak.path, leak.block.notebook) for leak, _ in out.known_overlaps] == [
        ("lib/robocourse/pendulum/pid.py", "02_pendulum_exercises.ipynb")]


def test_glob_rules():
    assert rel.Rule("include", "lib/**", "").matches("lib/a/b.py", None)
    assert not rel.Rule("include", "lib/**", "").matches("library.py", None)
    assert rel.Rule("exclude", "**/hidden_checks/**", "").matches("hidden_checks/a.py", None)
    assert rel.Rule("exclude", "**/hidden_checks/**", "").matches("lib/x/hidden_checks/a.py", None)
    assert rel.Rule("exclude", "tests/test_*_checks.py", "").matches("tests/test_rt_checks.py", None)
    assert not rel.Rule("exclude", "tests/test_*_checks.py", "").matches("tests/sub/test_rt_checks.py", None)
    reads = rel.Rule("exclude", "tests/**", "", mentions=rel.READS_SOLUTIONS)
    assert reads.matches("tests/t.py", 'ROOT / "solutions" / x') and not reads.matches("tests/t.py", "my_solutions = 1")
    with pytest.raises(ValueError, match="use 'include' or 'exclude'"):
        rel.Rule("keep", "x", "")


@pytest.mark.xdist_group("tests/test_release.py::cli")  # a release of its own: a unit of its own (tests/conftest.py)
def test_cli_release_prints_the_summary_and_fails_cleanly(tmp_path):
    course = make_course(tmp_path / "course")
    cmd = [sys.executable, "-m", "robocourse.cli", "release", str(tmp_path / "student"), "--root", str(course)]
    ok = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert ok.returncode == 0, ok.stderr
    assert f"student edition written to {tmp_path / 'student'}: 7 files" in ok.stdout
    assert re.search(r"notes.txt\s+1 file\(s\)  no rule includes it", ok.stdout)
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert again.returncode == 2 and "robocourse release: error:" in again.stderr and "--force" in again.stderr
