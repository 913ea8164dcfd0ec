"""Chapter 4's checks: the solution notebook's code scores full marks, the usual mistakes score 0, named.

The right answers are exec'd from solutions/04_ros2_control_exercises.ipynb; each wrong answer below
changes one thing a student gets wrong (the activation jump, a swallowed read error, a wrong cubic
coefficient, a controller that cannot claim its joint, an underdamped admittance...).
"""

from __future__ import annotations

import math
from pathlib import Path

import nbformat
import numpy as np
import pytest

import robocourse.control.checks  # noqa: F401  (registers ch04.*)
from robocourse.control import CallbackReturn, return_type
from robocourse.control.motor_board import MotorBoardSystem
from robocourse.grading import exercises
from robocourse.grading.checks import get, run_check

SOL = Path(__file__).resolve().parents[1] / "solutions/04_ros2_control_exercises.ipynb"


def _solution() -> dict:
    ns: dict = {}
    for cell in nbformat.read(SOL, as_version=4).cells:
        if cell.cell_type == "code" and cell.source.lstrip().startswith(("def ", "class ", "import ")):
            exec(cell.source.replace("from robocourse.grading import check, score", ""), ns)
    return ns


_NS = _solution()
BoardSystem, cubic_sample, controllers_yaml = _NS["BoardSystem"], _NS["cubic_sample"], _NS["controllers_yaml"]
after_hardware_error, tune_admittance = _NS["after_hardware_error"], _NS["tune_admittance"]


def test_every_check_of_ch04_is_called_in_the_exercises():
    assert exercises.checks_in(nbformat.read(SOL, as_version=4)) == [
        "ch04.motor_board", "ch04.cubic", "ch04.controllers_yaml", "ch04.read_error", "ch04.admittance"]


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


def zero(name, *objects, seed=0):
    r = run(name, *objects, seed=seed)
    assert r.points == 0, r.message
    return r.message


@pytest.mark.parametrize("name, answer", [
    ("ch04.motor_board", BoardSystem), ("ch04.cubic", cubic_sample), ("ch04.controllers_yaml", controllers_yaml),
    ("ch04.read_error", after_hardware_error), ("ch04.admittance", tune_admittance)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_solutions_score_full_marks(name, answer, seed):
    r = run(name, answer, seed=seed)
    assert r.passed and r.points == r.weight == get(name).weight, r.message


# --- ch04.motor_board ------------------------------------------------------------------------------------------


class Forgetful(BoardSystem):
    def on_activate(self, previous_state):
        return CallbackReturn.SUCCESS          # the activation jump


class Swallows(BoardSystem):
    def read(self, time, period):
        self.board.read(time, self.q, self.dq)   # ignores False: stale states, controllers keep running
        self.state_values[self.p_idx] = self.q
        self.state_values[self.v_idx] = self.dq
        return return_type.OK


class Raises(BoardSystem):
    def read(self, time, period):
        if not self.board.read(time, self.q, self.dq):
            raise OSError("board not answering")
        self.state_values[self.p_idx] = self.q
        self.state_values[self.v_idx] = self.dq
        return return_type.OK


class IgnoresWrite(BoardSystem):
    def write(self, time, period):
        np.take(self.command_values, self.c_idx, out=self.out)
        self.board.write(self.out)
        return return_type.OK


class Chatty(BoardSystem):
    def write(self, time, period):
        self.get_logger().info(f"writing {self.out}")
        return super().write(time, period)


class Trusting(BoardSystem):
    def on_init(self, info):
        return super(BoardSystem, self).on_init(info)    # never compares joints with motors


class NoStates(BoardSystem):
    def read(self, time, period):
        return return_type.OK if self.board.read(time, self.q, self.dq) else return_type.ERROR


class Delegates(MotorBoardSystem):
    pass


class Wraps(BoardSystem):
    def __init__(self, board):
        super().__init__(board)
        self.inner = MotorBoardSystem(board)

    def read(self, time, period):
        return MotorBoardSystem.read(self, time, period)


@pytest.mark.parametrize("cls, fragment", [
    (Forgetful, "activation jump"),
    (Swallows, "not swallow it and return OK"),
    (Raises, "never raise in the loop"),
    (IgnoresWrite, "board.write() returned False) but write() returned OK"),
    (Chatty, "must not log"),
    (Trusting, "on_init must compare len(info.joints)"),
    (NoStates, "read() must copy"),
])
def test_motor_board_mistakes_are_named(cls, fragment):
    assert fragment in zero("ch04.motor_board", cls)


@pytest.mark.parametrize("cls", [Delegates, Wraps])
def test_motor_board_reference_is_refused(cls):
    r = run("ch04.motor_board", cls)
    assert r.points == 0 and r.reason == "delegated" and "MotorBoardSystem" in r.message


def test_motor_board_not_implemented_scores_zero():
    class Empty(BoardSystem):
        def read(self, time, period):
            raise NotImplementedError()

    r = run("ch04.motor_board", Empty)
    assert r.points == 0 and r.reason == "not_implemented"


# --- ch04.cubic -------------------------------------------------------------------------------------------------


def test_cubic_wrong_coefficients_are_named():
    def wrong_a3(p0, v0, p1, v1, T, t):
        p, v, a = cubic_sample(p0, v0, p1, v1, T, t)
        a3_err = (np.asarray(v0) * T) / T**3          # forgot v1 in a3
        return p - a3_err * t**3, v - 3 * a3_err * t**2, a - 6 * a3_err * t

    msg = zero("ch04.cubic", wrong_a3)
    assert "a3 = (2(p0-p1) + (v0 + v1) T) / T^3" in msg and "position" in msg

    def no_acceleration(p0, v0, p1, v1, T, t):
        p, v, _ = cubic_sample(p0, v0, p1, v1, T, t)
        return p, v, np.zeros_like(p)

    assert "acceleration wrong" in zero("ch04.cubic", no_acceleration)

    def scalar(p0, v0, p1, v1, T, t):
        p, v, a = cubic_sample(p0, v0, p1, v1, T, t)
        return float(p[0]), float(v[0]), float(a[0])

    assert "one value per joint" in zero("ch04.cubic", scalar, seed=3)


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


# --- ch04.controllers_yaml ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("edit, fragment", [
    (("update_rate: 200", "update_rate: 100"), "update_rate is 100 Hz"),
    (("joint_trajectory_controller/JointTrajectoryController", "joint_trajectory_controller/JTC"),
     "'arm_controller' could not be loaded"),
    (("{joints: [joint3]}", "{interface_name: position}"), "'wrist_controller' was loaded but ended"),
    (("goal_time: 1.0", "goal_time: -1.0"), "must be"),
    (("joint2: {goal: 0.01}", "joint2: {goal: 0.1}"), "constraints.joint2.goal is 0.1"),
    (("state_interfaces: [position, velocity]", "state_interfaces: [position]"),
     "state_interfaces ['position']"),
])
def test_controllers_yaml_mistakes_are_named(edit, fragment):
    text = controllers_yaml().replace(*edit)
    assert text != controllers_yaml()
    assert fragment in zero("ch04.controllers_yaml", lambda: text)


def test_controllers_yaml_not_yaml():
    assert "refused the file" in zero("ch04.controllers_yaml", lambda: "controller_manager: [unclosed")
    assert "must be the YAML text" in zero("ch04.controllers_yaml", lambda: 42)


# --- ch04.read_error -------------------------------------------------------------------------------------------------


def test_read_error_forgetting_state_users_is_named():
    def commands_only(controllers, hardware, failed, stage, result):
        mine = set(hardware[failed])
        hit = [n for n, c in controllers.items() if mine & set(c["command"])]
        return {"deactivated": hit, "hardware_state": "inactive" if result == "DEACTIVATE" else "unconfigured"}

    msg = "\n".join(zero("ch04.read_error", commands_only, seed=s) for s in range(3) if run(
        "ch04.read_error", commands_only, seed=s).points == 0)
    assert "command OR state interfaces" in msg


def test_read_error_wrong_hardware_state_and_deactivate_rule_are_named():
    def all_users(controllers, hardware, failed, stage, result):
        mine = set(hardware[failed])
        hit = [n for n, c in controllers.items() if mine & (set(c["command"]) | set(c["state"]))]
        return {"deactivated": hit, "hardware_state": "finalized"}

    msg = zero("ch04.read_error", all_users)
    assert "the component ends 'unconfigured'" in msg or "the component ends 'inactive'" in msg
    msgs = [run("ch04.read_error", all_users, seed=s).message for s in range(6)]
    assert any("DEACTIVATE only stops the controllers holding" in m for m in msgs)


def test_read_error_reference_is_refused():
    from robocourse.control.checks import fault_truth

    def by_running_it(controllers, hardware, failed, stage, result):
        return fault_truth({"controllers": controllers, "failed": failed, "stage": stage, "result": result})

    r = run("ch04.read_error", by_running_it)
    assert r.points == 0 and r.reason == "delegated" and "ControllerManager" in r.message


# --- ch04.admittance ------------------------------------------------------------------------------------------------


def tuned(k_of, zeta, d_of=None):
    def tune(mass, force, deflection, settle):
        k = k_of(force, deflection)
        d = d_of(mass, k, zeta) if d_of else 2 * zeta * math.sqrt(mass * k)
        return {"stiffness": k, "damping_ratio": zeta, "damping": d}
    return tune


@pytest.mark.parametrize("answer, fragment", [
    (tuned(lambda f, x: f / x, 0.4), "< 1 oscillates"),
    (tuned(lambda f, x: f / x, 4.0), "more damping than needed"),
    (tuned(lambda f, x: f * x, 1.0), "K = force / deflection"),
    (tuned(lambda f, x: f / x, 1.0, lambda m, k, z: 2 * z * math.sqrt(k / m)), "D = 2 zeta sqrt(M K)"),
    (tuned(lambda f, x: -f / x, 1.0, lambda m, k, z: 0.0), "refuses these values"),
])
def test_admittance_mistakes_are_named(answer, fragment):
    assert fragment in zero("ch04.admittance", answer)
