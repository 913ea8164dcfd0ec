"""URStyleSystem under the controller manager: tracking, a killed box, bad descriptions, and no
box left behind when its parent dies (FrankaStyleSystem: tests/test_drivers_franka_system.py)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import robocourse.drivers as drivers
from robocourse.control import ControllerManager
from robocourse.control.bringup import bringup
from robocourse.control.hardware.types import ACTIVE, INACTIVE, UNCONFIGURED
from robocourse.control.log import LogSink

# ros2_control loops driving the 1 kHz / 500 Hz boxes: these run alone (tests/conftest.py: serial)
pytestmark = pytest.mark.serial

SPAWN = ["joint_state_broadcaster", "forward_position_controller"]


# a generous read_timeout: the machine is shared, and a box stalled by the scheduler for 100 ms
# must not fail a test that is not about stalls (the fault tests set their own)
def ur_cm(**params):
    urdf = drivers.arm_urdf("robocourse/URStyleSystem", {"read_timeout": 2.0, "keepalive": 2.0, **params},
                            command_interfaces=("position",))
    return bringup(urdf=urdf, param_file=drivers.CONTROLLERS_YAML, spawn=SPAWN)


def system(cm):
    (comp,) = cm.rm.components.values()
    return comp.impl


def states(cm, what="position"):
    sys_ = system(cm)
    return np.array([sys_.get_state(f"{j}/{what}") for j in drivers.ARM_JOINTS])


def controller_states(cm):
    return {n: s.state for n, s in cm.controllers.items()}


def ur_cycles(cm, n):
    for _ in range(n):
        cm.step(1)
        time.sleep(0.002)


@pytest.mark.parametrize("make,cycle", [(ur_cm, ur_cycles)], ids=["ur"])
def test_forward_position_controller_moves_the_arm_through_the_box(make, cycle):
    cm = make()
    try:
        sys_ = system(cm)
        assert sys_.box is not None and sys_.box.alive()         # the component started its own box
        q0 = states(cm)
        target = q0.copy()
        target[0] += 0.2
        target[2] -= 0.1
        cm.controllers["forward_position_controller"].c.set_command(list(target))
        cycle(cm, 600)
        np.testing.assert_allclose(states(cm), target, atol=0.02)
        assert controller_states(cm) == {"joint_state_broadcaster": ACTIVE, "forward_position_controller": ACTIVE}
        box = sys_.box
    finally:
        cm.shutdown()
    assert not box.alive() and sys_.box is None                   # cleanup stopped the box it owned


@pytest.mark.parametrize("make,cycle", [(ur_cm, ur_cycles)], ids=["ur"])
def test_killed_box_makes_read_fail_and_the_manager_deactivates_the_controllers(make, cycle):
    cm = make(read_timeout=0.05)
    try:
        sys_ = system(cm)
        cycle(cm, 20)
        pid = sys_.box.pid
        sys_.box.kill()
        cycle(cm, 5)
        assert controller_states(cm) == {"joint_state_broadcaster": INACTIVE,
                                         "forward_position_controller": INACTIVE}
        assert cm.rm.components["UR5e"].wrapper.state == UNCONFIGURED    # on_error -> unconfigured
        assert (f"pid {pid}" in sys_.last_error or "no new RTDE state" in sys_.last_error
                or "no new robot state" in sys_.last_error), sys_.last_error
        assert any("went into error" in r.msg or "resulted in an error" in r.msg for r in cm.log.records)
    finally:
        cm.shutdown()


def test_bad_param_is_refused_with_the_rule():
    urdf = drivers.arm_urdf("robocourse/URStyleSystem", {"servoj_lookahead_time": 0.5},
                            command_interfaces=("position",))
    log = LogSink(log_to_stderr=False)
    with pytest.raises(RuntimeError, match="Failed to initialize hardware 'UR5e'"):
        ControllerManager(urdf, log=log)
    msgs = " ".join(r.msg for r in log.records)
    assert '<param name="servoj_lookahead_time">0.5</param> must be a number in [0.03, 0.2]' in msgs


def test_box_dies_with_its_parent():
    code = ("import robocourse.drivers as d, sys; b = d.start_franka_box(); "
            "print(b.pid, flush=True); sys.stdin.read()")
    parent = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        box_pid = int(parent.stdout.readline())
        os.kill(box_pid, 0)                          # alive
        parent.send_signal(signal.SIGKILL)
        parent.wait(5)
        deadline = time.monotonic() + 5
        gone = False
        while time.monotonic() < deadline and not gone:
            try:   # gone, or a zombie nobody reaped yet (state Z): either way it runs no more
                with open(f"/proc/{box_pid}/stat") as f:
                    gone = f.read().rpartition(")")[2].split()[0] == "Z"
            except FileNotFoundError:
                gone = True
            time.sleep(0.05)
        assert gone, f"box pid {box_pid} outlived its parent"
    finally:
        if parent.poll() is None:
            parent.kill()
        parent.stdout.close()
        parent.stdin.close()


def test_a_box_started_from_a_sched_fifo_thread_starts_sched_other():
    """A benchmark's real-time loop starting a box (or any child) must not hand it SCHED_FIFO."""
    from robocourse.rt import settings

    if not settings.set_scheduling("fifo", 80, quiet=True).ok:
        pytest.skip("SCHED_FIFO refused here (not root, no rtprio): nothing to inherit")
    try:
        box = drivers.start_franka_box(realtime=False)
    finally:
        settings.reset_scheduling()
    try:
        assert os.sched_getscheduler(box.pid) == os.SCHED_OTHER
    finally:
        box.stop()


@pytest.mark.parametrize("plugin,cycle", [("robocourse/URStyleSystem", ur_cycles)], ids=["ur"])
def test_joint_trajectory_controller_runs_a_trajectory_through_the_box(plugin, cycle):
    from robocourse.msgs.builtin_interfaces import Duration
    from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

    params = {"read_timeout": 2.0, "keepalive": 2.0}
    urdf = drivers.arm_urdf(plugin, params, command_interfaces=("position",))
    cm = bringup(urdf=urdf, param_file=drivers.CONTROLLERS_YAML,
                 spawn=["joint_state_broadcaster", "joint_trajectory_controller"])
    try:
        q0 = states(cm)
        goal = q0 + np.array([0.3, -0.2, 0.2, 0.0, 0.1, 0.0])
        msg = JointTrajectory(joint_names=list(drivers.ARM_JOINTS))
        msg.points.append(JointTrajectoryPoint(positions=list(goal), time_from_start=Duration(sec=0, nanosec=400_000_000)))
        node = cm.context.create_node("commander")
        cm.executor.add_node(node)
        node.create_publisher(JointTrajectory, "/joint_trajectory_controller/joint_trajectory", 10).publish(msg)
        cycle(cm, 700)
        np.testing.assert_allclose(states(cm), goal, atol=0.02)
        assert controller_states(cm)["joint_trajectory_controller"] == ACTIVE
    finally:
        cm.shutdown()
