"""Chapter 4's checks against their wrong-answer bank (tests/ch04_bank.py): every wrong answer scores 0 and its
feedback names the property it breaks, every differently written correct answer and the solution notebook's
code score full marks; the library's references are refused as delegation; stubs are "not implemented".

One draw per bank entry here (seed 0) and three for the references; benchmarks/ch04_bank_stability.py
runs every entry on 20 draws, quiet and under chapter 1's CPU load."""

from __future__ import annotations

import nbformat
import numpy as np
import pytest
from ch04_bank import BANK, ORDER, SOL, references

import robocourse.control.checks  # noqa: F401  (registers ch04.*)
from robocourse.control.motor_board import MotorBoardSystem
from robocourse.grading import exercises
from robocourse.grading.checks import get, run_check


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


def test_every_check_of_ch04_is_called_in_the_exercises_and_has_a_bank():
    assert exercises.checks_in(nbformat.read(SOL, as_version=4)) == ORDER
    for name in ORDER:
        wrong = [e for e in BANK[name] if e[3] is not None]
        right = [e for e in BANK[name] if e[3] is None]
        assert len(wrong) >= 3 and len(right) >= 1, name


@pytest.mark.parametrize("name", ORDER)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_solutions_score_full_marks(name, seed):
    r = run(name, references()[name], seed=seed)
    assert r.passed and r.points == r.weight == get(name).weight, r.message


@pytest.mark.parametrize("name, answer, expected, fragment",
                         [pytest.param(n, *e[1:], id=f"{n}-{e[0]}") for n in ORDER for e in BANK[n]])
def test_bank(name, answer, expected, fragment):
    r = run(name, answer)
    if fragment is None:
        assert r.passed and r.points == get(name).weight, r.message
    else:
        assert r.points == expected and not r.passed, r.message
        assert fragment in r.message, r.message


# --- refusals: the library's own implementation, and stubs ---------------------------------------------------------

class Delegates(MotorBoardSystem):
    pass


def test_motor_board_reference_is_refused():
    r = run("ch04.motor_board", Delegates)
    assert r.points == 0 and r.reason == "delegated" and "MotorBoardSystem" in r.message


def test_controller_reference_is_refused():
    from robocourse.control.checks import _ReferenceSlew

    class Mine(_ReferenceSlew):
        pass

    r = run("ch04.controller", Mine)
    assert r.points == 0 and r.reason == "delegated"


def test_cubic_reference_is_refused():
    from robocourse.control.controllers.joint_trajectory_controller.trajectory import (
        Sample,
        Trajectory,
    )

    def via_library(p0, v0, p1, v1, T, t):
        traj = Trajectory([0.0, T], [p0, p1], velocities=[v0, v1], start_time=1.0)
        s = Sample(len(p0))
        traj.sample(1.0 + t, s)
        return s.positions, s.velocities, s.accelerations

    r = run("ch04.cubic", via_library)
    assert r.points == 0 and r.reason == "delegated"


def test_read_error_reference_is_refused():
    from robocourse.control.checks import fault_truth

    def by_running_it(controllers, hardware, failed, stage, result):
        return fault_truth({"controllers": controllers, "failed": failed, "stage": stage, "result": result})

    r = run("ch04.read_error", by_running_it)
    assert r.points == 0 and r.reason == "delegated" and "ControllerManager" in r.message


@pytest.mark.parametrize("name", ["ch04.motor_board", "ch04.controller", "ch04.chainable"])
def test_a_stub_is_not_implemented(name):
    cls = references()[name]
    method = {"ch04.motor_board": "read", "ch04.controller": "on_configure",
              "ch04.chainable": "on_export_reference_interfaces"}[name]

    def stub(self, *args):
        raise NotImplementedError()

    r = run(name, type("Stub", (cls,), {method: stub}))
    assert r.points == 0 and r.reason == "not_implemented", r.message


def test_controllers_yaml_not_yaml():
    assert "refused the file" in run("ch04.controllers_yaml", lambda: "controller_manager: [unclosed").message
    assert "must be the YAML text" in run("ch04.controllers_yaml", lambda: 42).message


def test_urdf_text_too_large_or_with_entities_is_refused_before_parsing():
    big = run("ch04.ros2_control_urdf", lambda ip: "<ros2_control>" + " " * 30_000 + "</ros2_control>")
    assert big.points == 0 and "under 20000 characters" in big.message
    ent = run("ch04.ros2_control_urdf", lambda ip: '<!ENTITY a "b"><ros2_control name="RRBot" type="system"/>')
    assert ent.points == 0 and "<!ENTITY>" in ent.message
