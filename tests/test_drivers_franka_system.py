"""robocourse/FrankaStyleSystem (franka_hardware on pylibfranka) under the controller manager:
a smooth trajectory, a torque hold, a step the robot refuses, the communication reflex and
recovery, a killed box, a wrong description. Bounded by construction (fixed cycle counts; every
pylibfranka wait ends by the robot's rules)."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("pylibfranka", reason="pylibfranka (PyPI, Linux x86_64) is not installed")

import robocourse.drivers as drivers  # noqa: E402
from robocourse.control import ControllerManager  # noqa: E402
from robocourse.control.bringup import bringup  # noqa: E402
from robocourse.control.hardware.types import ACTIVE, INACTIVE, UNCONFIGURED  # noqa: E402
from robocourse.control.log import LogSink  # noqa: E402

pytestmark = [pytest.mark.timeout(120), pytest.mark.serial]   # 1 kHz loops: timing-sensitive by nature
LENIENT = {"max_lost": 100_000}


def franka_cm(spawn, params=LENIENT, interfaces=("position", "velocity", "effort")):
    urdf = drivers.fr3_urdf("robocourse/FrankaStyleSystem", params, command_interfaces=interfaces)
    return bringup(urdf=urdf, param_file=drivers.FR3_CONTROLLERS_YAML, spawn=["joint_state_broadcaster", spawn])


def system(cm):
    (comp,) = cm.rm.components.values()
    return comp.impl


def states(cm, what="position"):
    sys_ = system(cm)
    return np.array([sys_.get_state(f"{j}/{what}") for j in drivers.FR3_JOINTS])


def controller_states(cm):
    return {n: s.state for n, s in cm.controllers.items()}


def test_joint_trajectory_controller_runs_a_smooth_trajectory_through_pylibfranka():
    from robocourse.msgs.builtin_interfaces import Duration
    from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

    cm = franka_cm("joint_trajectory_controller", interfaces=("position",))
    try:
        sys_ = system(cm)
        assert sys_.box is not None and sys_.box.alive()         # the component started its own box
        q0 = states(cm)
        goal = q0 + np.array([0.3, -0.2, 0.2, 0.2, 0.1, 0.2, -0.2])
        msg = JointTrajectory(joint_names=list(drivers.FR3_JOINTS))
        # positions, velocities and accelerations: the JTC interpolates a quintic, smooth enough
        # for the robot's acceleration and jerk checks (a position-only point would be linear)
        msg.points.append(JointTrajectoryPoint(positions=list(goal), velocities=[0.0] * 7, accelerations=[0.0] * 7,
                                               time_from_start=Duration(sec=1, nanosec=0)))
        node = cm.context.create_node("commander")
        cm.executor.add_node(node)
        node.create_publisher(JointTrajectory, "/joint_trajectory_controller/joint_trajectory", 10).publish(msg)
        cm.step(1500)
        # the arm settles on the goal; cycles the box extrapolated while this process was held off the CPU may
        # leave a joint still on its way after 1.5 s (0.03 rad, 2 of 6 loaded runs): a bounded wait for it
        for _ in range(3500):
            if np.allclose(states(cm), goal, rtol=0, atol=0.01):
                break
            cm.step(1)
        np.testing.assert_allclose(states(cm), goal, atol=0.01, err_msg=str(sys_.last_error))
        assert controller_states(cm)["joint_trajectory_controller"] == ACTIVE, sys_.last_error
        box = sys_.box
    finally:
        cm.shutdown()
    assert not box.alive() and sys_.box is None                   # cleanup stopped the box it owned


def test_zero_effort_holds_the_arm_because_the_robot_adds_gravity():
    cm = franka_cm("forward_effort_controller", interfaces=("effort",))
    try:
        q0 = states(cm)
        cm.controllers["forward_effort_controller"].c.set_command([0.0] * 7)
        cm.step(500)
        assert controller_states(cm)["forward_effort_controller"] == ACTIVE, system(cm).last_error
        assert np.max(np.abs(states(cm) - q0)) < 1e-3
        assert np.all(np.abs(states(cm, "effort")) < 87)          # tau_J: the gravity torques it holds
    finally:
        cm.shutdown()


def test_a_position_step_is_refused_by_the_robot_and_the_controllers_stop():
    cm = franka_cm("forward_position_controller", {**LENIENT, "limit_rate": False}, interfaces=("position",))
    try:
        target = states(cm)
        target[0] += 0.2                                    # 0.2 rad in one ms, and no rate limiter
        cm.controllers["forward_position_controller"].c.set_command(list(target))
        cm.step(20)
        assert controller_states(cm)["forward_position_controller"] == INACTIVE
        assert "joint_motion_generator_velocity_limits_violation" in system(cm).last_error
    finally:
        cm.shutdown()


def test_a_stalled_loop_gets_the_communication_reflex_and_needs_explicit_recovery():
    cm = franka_cm("forward_position_controller", params={}, interfaces=("position",))   # the robot's 20
    try:
        sys_ = system(cm)
        cm.step(50)
        # the loop stalls until the robot trips its reflex (20 cycles unanswered): a fixed 0.1 s was not always
        # 20 of the box's cycles on a loaded machine (a starved box sends fewer states); 30 s is a safety net
        deadline, before = time.monotonic() + 30, drivers.box_stats(sys_.box)["reflexes"]
        while drivers.box_stats(sys_.box)["reflexes"] == before and time.monotonic() < deadline:
            time.sleep(0.02)
        # the next cycles read the robot's error (the states queued during the stall may come first): bounded
        for _ in range(200):
            cm.step(1)
            if controller_states(cm)["forward_position_controller"] == INACTIVE:
                break
        assert controller_states(cm)["forward_position_controller"] == INACTIVE, drivers.box_stats(sys_.box)
        assert sys_.last_error == ('libfranka: Move command aborted: motion aborted by reflex! '
                                   '["communication_constraints_violation"]')
        assert cm.rm.components["FR3"].wrapper.state == UNCONFIGURED
        # activation is refused while the robot reports the error, whatever the manager tries
        assert cm.set_hardware_component_state("FR3", "active") != 0
        assert cm.rm.components["FR3"].wrapper.state != ACTIVE
        assert sys_.automatic_error_recovery() == []
        assert cm.set_hardware_component_state("FR3", "active") == 0
        assert cm.switch_controller(["joint_state_broadcaster", "forward_position_controller"], [], strictness=2) == 0
        # from here the box counts against this thread only the lost cycles it did not spend waiting for a CPU
        # (the grader's rule on a shared machine): under the robot's plain 20, a loaded machine that held this
        # process off the CPU for 20 ms tripped the reflex again (1 in a loaded -n 2 sweep)
        drivers.box_watch(sys_.box)
        cm.step(50)
        assert controller_states(cm)["forward_position_controller"] == ACTIVE, sys_.last_error
    finally:
        cm.shutdown()


def test_a_killed_box_mid_motion_is_a_hardware_error():
    cm = franka_cm("forward_position_controller", interfaces=("position",))
    try:
        sys_ = system(cm)
        cm.step(20)
        pid = sys_.box.pid
        sys_.box.kill()
        cm.step(5)
        assert controller_states(cm) == {"joint_state_broadcaster": INACTIVE, "forward_position_controller": INACTIVE}
        assert cm.rm.components["FR3"].wrapper.state == UNCONFIGURED    # on_error -> unconfigured
        assert f"pid {pid}" in sys_.last_error, sys_.last_error
        assert any("went into error" in r.msg or "resulted in an error" in r.msg for r in cm.log.records)
    finally:
        cm.shutdown()


def test_a_description_without_the_seven_fr3_joints_is_refused_with_the_fix():
    log = LogSink(log_to_stderr=False)
    with pytest.raises(RuntimeError, match="Failed to initialize hardware 'UR5e'"):
        ControllerManager(drivers.arm_urdf("robocourse/FrankaStyleSystem"), log=log)
    msgs = " ".join(r.msg for r in log.records)
    assert "serves exactly the 7 arm joints" in msgs and "fr3_urdf" in msgs
