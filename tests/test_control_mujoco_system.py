"""robocourse/MujocoSystem: the shipped robots (robocourse.sim.robots) behind ros2_control interfaces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robocourse.control import (
    ACTIVE,
    INACTIVE,
    STRICT,
    UNCONFIGURED,
    ControllerManager,
    URDFError,
    return_type,
)
from robocourse.control.hardware.mujoco_system import MujocoSystem
from robocourse.control.log import LogSink
from robocourse.sim.robots import RobotSim, urdf_text

ARM = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
PARAMS = """
controller_manager:
  ros__parameters:
    update_rate: 250
    pos: {type: position_controllers/JointGroupPositionController}
    vel: {type: velocity_controllers/JointGroupVelocityController}
    eff: {type: effort_controllers/JointGroupEffortController}
pos: {ros__parameters: {joints: [%s]}}
vel: {ros__parameters: {joints: [%s]}}
eff: {ros__parameters: {joints: [%s]}}
""" % ((", ".join(ARM),) * 3)


def ur5e_cm(**kw) -> ControllerManager:
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"), params=PARAMS,
                           log=LogSink(log_to_stderr=False), **kw)
    for name in ("pos", "vel", "eff"):
        cm.load_and_configure(name)
    return cm


def positions(cm):
    return np.array([cm.rm.value(f"{j}/position") for j in ARM])


def test_position_controller_drives_the_arm_to_the_command():
    cm = ur5e_cm()
    start = positions(cm)
    assert start == pytest.approx([0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0])
    assert cm.switch_controller(["pos"], [], STRICT) == return_type.OK
    cm.step(5)
    assert positions(cm) == pytest.approx(start, abs=1e-3)        # activation holds: no jump
    target = [0.3, -1.2, 1.0, -1.4, -1.57, 0.2]
    cm.controllers["pos"].c.set_command(target)
    cm.spin_for(2.0)
    assert positions(cm) == pytest.approx(target, abs=2e-3)
    assert cm.rm.components["UR5e"].impl.sim.time == pytest.approx(2.0 + 5 / 250)


def test_switching_to_velocity_mode_changes_the_servo():
    cm = ur5e_cm()
    cm.switch_controller(["pos"], [], STRICT)
    cm.step(2)
    assert cm.switch_controller(["vel"], ["pos"], STRICT) == return_type.OK
    sim = cm.rm.components["UR5e"].impl.sim
    assert sim.mode("shoulder_pan_joint") == "velocity"
    cm.controllers["vel"].c.set_command([0.5, 0, 0, 0, 0, 0])
    before = positions(cm)[0]
    cm.spin_for(1.0)
    assert positions(cm)[0] - before == pytest.approx(0.5, abs=0.02)
    assert cm.rm.value("shoulder_pan_joint/velocity") == pytest.approx(0.5, abs=1e-2)


def test_mode_switch_with_two_modes_on_one_joint_is_rejected():
    cm = ur5e_cm()
    cm.switch_controller(["pos"], [], STRICT)
    assert cm.switch_controller(["vel"], [], STRICT) == return_type.ERROR     # claims are fine, modes are not
    assert "prepare command mode switch was rejected" in cm.last_switch_message
    assert cm.log.count("Joint 'elbow_joint' needs exactly one of 'position', 'velocity', 'effort' among the "
                        "started interfaces, got ['position', 'velocity']") == 1


def test_effort_mode_without_gravity_compensation_falls_and_measures_effort():
    cm = ur5e_cm()
    cm.switch_controller(["eff"], [], STRICT)
    cm.controllers["eff"].c.set_command([0.0] * 6)
    cm.spin_for(0.2)
    assert positions(cm)[1] < -math.pi / 2 - 0.05 or positions(cm)[1] > -math.pi / 2 + 0.05
    assert cm.rm.value("shoulder_lift_joint/effort") == 0.0


def test_flange_sensor_reads_the_gripper_weight():
    cm = ur5e_cm()
    cm.switch_controller(["pos"], [], STRICT)
    cm.spin_for(0.5)
    sim = cm.rm.components["UR5e"].impl.sim
    force = np.array([cm.rm.value(f"tcp_fts_sensor/force.{a}") for a in "xyz"])
    mass, _ = sim.tool_mass_properties()
    assert np.linalg.norm(force) == pytest.approx(mass * 9.81, rel=0.05)


def test_nan_command_holds_and_infinite_command_is_a_write_error():
    cm = ur5e_cm()
    cm.switch_controller(["pos"], [], STRICT)
    cm.step(2)
    start = positions(cm)
    loan = cm.controllers["pos"].c.command_interfaces[0]
    loan.set_value(math.nan)
    cm.step(25)
    assert positions(cm) == pytest.approx(start, abs=1e-3)
    loan.set_value(math.inf)
    cm.step(2)
    assert cm.controllers["pos"].state == INACTIVE
    assert cm.rm.get_components_status()["UR5e"] == UNCONFIGURED
    assert cm.log.count("non-finite command") == 1


def test_rrbot_guessed_from_its_joints_and_a_ready_simulation_can_be_passed():
    rr = ControllerManager(urdf_text("rrbot", plugin="robocourse/MujocoSystem"), log=LogSink(log_to_stderr=False))
    assert rr.rm.components["RRBot"].impl.sim.name == "rrbot"
    assert rr.rm.get_components_status()["RRBot"] == ACTIVE
    sim = RobotSim("ur5e", payload_mass=1.0)
    cm = ur5e_cm(components={"UR5e": MujocoSystem(sim=sim)})
    assert cm.rm.components["UR5e"].impl.sim is sim


def test_unknown_interface_for_mujoco_system_is_a_urdf_error():
    text = urdf_text("rrbot", plugin="robocourse/MujocoSystem").replace(
        '<command_interface name="effort">', '<command_interface name="torque">', 1)
    with pytest.raises(URDFError) as err:
        ControllerManager(text, log=LogSink(log_to_stderr=False))
    assert err.value.text == "robocourse/MujocoSystem has no command interface 'torque' (joint 'joint1' of 'RRBot')"
