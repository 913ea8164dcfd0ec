"""Chapter 4's checks beyond their answer bank (tests/banks/ch04.py, graded by tests/test_banks.py):
the order of the exercises, the library's own implementations refused as delegation, stubs reported as
"not implemented", and hostile text refused before anything parses it."""

from __future__ import annotations

from pathlib import Path

import nbformat
import numpy as np
import pytest

import robocourse.control.checks  # noqa: F401  (registers ch04.*)
from robocourse.control.motor_board import MotorBoardSystem
from robocourse.grading import exercises
from robocourse.grading.checks import get, run_check

SOL = Path(__file__).resolve().parents[1] / "solutions/04_ros2_control_exercises.ipynb"
ORDER = ["ch04.ros2_control_urdf", "ch04.motor_board", "ch04.controllers_yaml", "ch04.read_error", "ch04.controller",
         "ch04.chainable", "ch04.cubic", "ch04.admittance"]


def _solution() -> dict:
    ns: dict = {}
    for cell in nbformat.read(SOL, as_version=4).cells:
        if cell.cell_type == "code" and cell.source.lstrip().startswith(("def ", "class ", "import ")):
            exec(cell.source.replace("from robocourse.grading import check, score", ""), ns)
    return ns


NS = _solution()


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


def test_every_check_of_ch04_is_called_in_the_exercises_in_order():
    assert exercises.checks_in(nbformat.read(SOL, as_version=4)) == ORDER
    assert sum(get(n).weight for n in ORDER) == 23.0


def test_the_library_component_is_refused_as_delegation():
    class Delegates(MotorBoardSystem):
        pass

    r = run("ch04.motor_board", Delegates)
    assert r.points == 0 and r.reason == "delegated" and "MotorBoardSystem" in r.message


def test_the_judges_reference_controller_is_refused_as_delegation():
    from robocourse.control.checks import _ReferenceSlew

    class Mine(_ReferenceSlew):
        pass

    r = run("ch04.controller", Mine)
    assert r.points == 0 and r.reason == "delegated"


def test_the_jtc_spline_code_is_refused_as_delegation():
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


def test_running_the_manager_to_predict_it_is_refused_as_delegation():
    from robocourse.control.checks import fault_truth

    def by_running_it(controllers, hardware, failed, stage, result):
        return fault_truth({"controllers": controllers, "failed": failed, "stage": stage, "result": result})

    r = run("ch04.read_error", by_running_it)
    assert r.points == 0 and r.reason == "delegated" and "ControllerManager" in r.message


@pytest.mark.parametrize("name, cls, method", [("ch04.motor_board", "BoardSystem", "read"),
                                               ("ch04.controller", "SlewRateController", "on_configure"),
                                               ("ch04.chainable", "JointLimiter", "on_export_reference_interfaces")])
def test_a_stub_is_not_implemented(name, cls, method):
    def stub(self, *args):
        raise NotImplementedError()

    r = run(name, type("Stub", (NS[cls],), {method: stub}))
    assert r.points == 0 and r.reason == "not_implemented", r.message


def test_parameter_text_that_is_not_yaml_or_uses_anchors_is_refused():
    assert "refused the file" in run("ch04.controllers_yaml", lambda: "controller_manager: [unclosed").message
    assert "must return the YAML text" in run("ch04.controllers_yaml", lambda: 42).message
    bomb = "a: &a [x, x]\nb: &b [*a, *a]\ncontroller_manager: {ros__parameters: {update_rate: 200}}\n"
    r = run("ch04.controllers_yaml", lambda: bomb)
    assert r.points == 0 and "without anchors, aliases" in r.message


def test_urdf_text_too_large_or_with_entities_is_refused_before_parsing():
    big = run("ch04.ros2_control_urdf", lambda ip: "<ros2_control>" + " " * 30_000 + "</ros2_control>")
    assert big.points == 0 and "under 20000 characters" in big.message
    ent = run("ch04.ros2_control_urdf", lambda ip: '<!ENTITY a "b"><ros2_control name="RRBot" type="system"/>')
    assert ent.points == 0 and "<!ENTITY>" in ent.message


def test_every_draw_exercises_each_stated_property():
    """The draws the wrong answers depend on: never sorted joints, never a 100 Hz limiter, never a 0.0 initial
    position, a ramp long enough to reach the limit, each kind of hardware fault."""
    from robocourse.control import checks as ck

    for seed in range(40):
        rng = np.random.default_rng(seed)
        ctrl = ck._ctrl_inputs(rng)
        assert ctrl["joints"] != sorted(ctrl["joints"])
        lim = ck._lim_inputs(rng)
        assert lim["rate"] != 100
        reach = (lim["max"][0] - lim["initial"][0]) / lim["max_velocity"]
        assert lim["phases"][1] / lim["rate"] > reach
        assert all(abs(v) >= 0.1 for v in ck._urdf_inputs(rng)["initial_positions"].values())
        kinds = {(s["stage"], s["result"]) for s in ck._fault_inputs(rng)["scenarios"]}
        assert kinds == {("read", "ERROR"), ("write", "ERROR"), ("write", "DEACTIVATE")}
