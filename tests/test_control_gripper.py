"""ParallelGripperController: the ParallelGripperCommand action on mock hardware and on the MuJoCo arm.

Scenarios from ros2_controllers' parallel_gripper_controller tests (test_parallel_gripper_controller.cpp:
parameters not set / empty joint, configure and activate, activate-deactivate-activate) plus the
action behaviours of gripper_action_controller (goal reached, stall with and without
allow_stalling, preemption, cancel). Upstream test names are given where known.
"""

from __future__ import annotations

import math

import pytest
from control_robots import generic, joint, urdf

from robocourse.bus.action import ActionClient
from robocourse.control import ACTIVE, INACTIVE, STRICT, ControllerManager, return_type
from robocourse.control.hardware.mujoco_system import MujocoSystem
from robocourse.control.log import LogSink
from robocourse.control.msgs import ParallelGripperCommand
from robocourse.msgs.action_msgs import GoalStatus
from robocourse.msgs.sensor_msgs import JointState
from robocourse.sim.robots import RobotSim, urdf_text

GRIP = "parallel_gripper_action_controller/GripperActionController"


def mock_cm(params=None, hw_params=None, activate=True, commands=("position",)):
    p = {"joint": "joint1", **(params or {})}
    text = (f"controller_manager:\n  ros__parameters:\n    update_rate: 100\n    grip:\n      type: {GRIP}\n"
            "grip:\n  ros__parameters:\n" + "".join(f"    {k}: {v}\n" for k, v in p.items()))
    hw = generic(params={"calculate_dynamics": "true", **(hw_params or {})},
                 body=joint("joint1", commands, ("position", "velocity"), {"position": 0.0}))
    cm = ControllerManager(urdf(hw, joints=("joint1",)), params=text, log=LogSink(log_to_stderr=False))
    cm.load_and_configure("grip")
    if activate:
        assert cm.switch_controller(["grip"], [], STRICT) == return_type.OK
    return cm


class Client:
    def __init__(self, cm, action="/grip/gripper_cmd"):
        self.cm = cm
        node = cm.context.create_node("gripper_client")
        cm.executor.add_node(node)
        self.client = ActionClient(node, ParallelGripperCommand, action)
        self.feedback = []

    def send(self, position, velocity=(), effort=(), name=()):
        goal = ParallelGripperCommand.Goal(command=JointState(name=list(name), position=list(position),
                                                              velocity=list(velocity), effort=list(effort)))
        fut = self.client.send_goal_async(goal, feedback_callback=self.feedback.append)
        self.cm.step(1)
        self.handle = fut.result()
        self.result = self.handle.get_result_async() if self.handle.accepted else None
        return self.handle

    def outcome(self):
        r = self.result.result()
        return None if r is None else (r.status, r.result.reached_goal, r.result.stalled)


def grip(cm):
    return cm.controllers["grip"].c


def test_parameters_not_set_fails_at_load():
    # mirrors parallel_gripper_controller/test/test_parallel_gripper_controller.cpp: TEST_F(GripperControllerTest, ParametersNotSet) and JointParameterIsEmpty
    text = f"controller_manager:\n  ros__parameters:\n    grip:\n      type: {GRIP}\n"
    cm = ControllerManager(urdf(generic(body=joint("joint1", ("position",), ("position", "velocity"))),
                                joints=("joint1",)), params=text, log=LogSink(log_to_stderr=False))
    assert cm.load_controller("grip") is None
    assert cm.log.count("parameter 'joint' is not initialized") == 1


def test_configure_activate_claims_the_position_and_holds():
    # mirrors parallel_gripper_controller/test/test_parallel_gripper_controller.cpp: TEST_F(GripperControllerTest, ConfigureParamsSuccess) and ActivateSuccess
    cm = mock_cm(params={"max_velocity_interface": '""'})
    c = grip(cm)
    assert [loan.name for loan in c.command_interfaces] == ["joint1/position"]
    assert [loan.name for loan in c.state_interfaces] == ["joint1/position", "joint1/velocity"]
    cm.step(5)
    assert cm.rm.value("joint1/position") == 0.0
    assert (c.params.goal_tolerance, c.params.allow_stalling, c.params.stall_velocity_threshold,
            c.params.stall_timeout, c.params.max_effort, c.params.max_velocity) == (0.01, False, 0.001, 1.0, 10.0, 0.1)


def test_activate_deactivate_activate_success():
    # mirrors parallel_gripper_controller/test/test_parallel_gripper_controller.cpp: TEST_F(GripperControllerTest, ActivateDeactivateActivateSuccess)
    cm = mock_cm()
    assert cm.switch_controller([], ["grip"], STRICT) == return_type.OK
    assert cm.switch_controller(["grip"], [], STRICT) == return_type.OK
    assert cm.controllers["grip"].state == ACTIVE


def test_goal_reached_at_max_velocity():
    # no upstream counterpart: test_parallel_gripper_controller.cpp stops at activation; no action test
    cm = mock_cm()
    c = Client(cm)
    assert c.send([0.03]).accepted
    cm.step(20)                  # 0.2 s at 0.1 m/s: 0.02 of 0.03
    assert cm.rm.value("joint1/position") == pytest.approx(0.02, abs=0.0011)
    cm.step(20)
    status, reached, stalled = c.outcome()
    assert (status, reached, stalled) == (GoalStatus.STATUS_SUCCEEDED, True, False)
    assert c.feedback and c.feedback[-1].feedback.state.name == ["joint1"]


def test_goal_velocity_overrides_max_velocity():
    # no upstream counterpart: test_parallel_gripper_controller.cpp stops at activation; no action test
    cm = mock_cm()
    c = Client(cm)
    c.send([0.03], velocity=[0.05])
    cm.step(20)
    assert cm.rm.value("joint1/position") == pytest.approx(0.01, abs=0.0006)


def test_blocked_gripper_stalls_and_aborts():
    # no upstream counterpart: stall handling (check_for_success in parallel_gripper_action_controller_impl.hpp) is not unit-tested upstream
    cm = mock_cm(hw_params={"disable_commands": "true"}, params={"stall_timeout": "0.5"})
    c = Client(cm)
    c.send([0.03])
    cm.step(40)
    assert c.result.result() is None                   # 0.4 s without movement: not yet stalled
    cm.step(20)
    assert c.outcome() == (GoalStatus.STATUS_ABORTED, False, True)


def test_blocked_gripper_with_allow_stalling_succeeds_stalled():
    # no upstream counterpart: stall handling (check_for_success in parallel_gripper_action_controller_impl.hpp) is not unit-tested upstream
    cm = mock_cm(hw_params={"disable_commands": "true"}, params={"stall_timeout": "0.5", "allow_stalling": "true"})
    c = Client(cm)
    c.send([0.03])
    cm.step(70)
    assert c.outcome() == (GoalStatus.STATUS_SUCCEEDED, False, True)


def test_goal_beyond_the_joint_limits_is_rejected():
    # no upstream counterpart: a robocourse check (upstream accepts the goal and leaves limits to the hardware)
    cm = mock_cm()
    c = Client(cm)
    assert not c.send([4.0]).accepted
    assert grip(cm).rejections == ["Goal position 4 of joint 'joint1' is outside its limits [-3.14, 3.14] (URDF "
                                   "<limit>); send a position inside them"]


@pytest.mark.parametrize("position, name, why", [
    ([], (), "Goal needs exactly one position for joint 'joint1', got []"),
    ([math.nan], (), "Goal has a non-finite value: position [nan], velocity [], effort []"),
    ([0.01], ("joint2",), "Goal names joints ['joint2']; this gripper controls only 'joint1'"),
])
def test_malformed_goals_are_rejected(position, name, why):
    # no upstream counterpart: upstream's goal_callback rejects a wrong number of positions, but no test sends one
    cm = mock_cm()
    c = Client(cm)
    assert not c.send(position, name=name).accepted
    assert grip(cm).rejections == [why]


def test_goal_rejected_while_inactive():
    # no upstream counterpart: test_parallel_gripper_controller.cpp sends no goals
    cm = mock_cm(activate=False)
    assert not Client(cm).send([0.01]).accepted
    assert grip(cm).rejections == ["Can't accept new action goals. Controller is not running."]


def test_new_goal_preempts_and_cancel_holds():
    # no upstream counterpart: test_parallel_gripper_controller.cpp sends no goals
    cm = mock_cm()
    c1 = Client(cm)
    c1.send([0.03])
    cm.step(5)
    c2 = Client.__new__(Client)
    c2.cm, c2.client, c2.feedback = cm, c1.client, []
    c2.send([-0.03])
    cm.step(5)
    assert c1.outcome()[0] == GoalStatus.STATUS_ABORTED
    c2.handle.cancel_goal_async()
    cm.step(2)
    held = cm.rm.value("joint1/position")
    cm.step(20)
    assert c2.outcome()[0] == GoalStatus.STATUS_CANCELED
    assert cm.rm.value("joint1/position") == pytest.approx(held, abs=1e-3)


def test_deactivation_aborts_the_goal():
    # no upstream counterpart: test_parallel_gripper_controller.cpp sends no goals
    cm = mock_cm()
    c = Client(cm)
    c.send([0.03])
    cm.step(3)
    cm.switch_controller([], ["grip"], STRICT)
    cm.step(10)
    assert cm.controllers["grip"].state == INACTIVE
    assert c.outcome()[0] == GoalStatus.STATUS_ABORTED


def test_max_effort_interface_gets_the_goal_effort_or_the_default():
    # no upstream counterpart: test_parallel_gripper_controller.cpp sends no goals; the rule is
    # parallel_gripper_action_controller_impl.hpp's: accepted_callback writes the goal's effort when
    # max_effort_interface is set and the goal has one (as given, not clamped to max_effort), otherwise
    # max_effort; set_hold_position() (on cancel) restores max_effort
    cm = mock_cm(params={"max_effort": "10.0", "max_effort_interface": "max_effort"},
                 commands=("position", "max_effort"))
    assert [loan.name for loan in grip(cm).command_interfaces] == ["joint1/position", "joint1/max_effort"]
    cm.step(1)
    hw = cm.rm.components["GenericSystem2dof"].impl
    assert hw.get_command("joint1/max_effort") == 10.0           # the default before any goal
    c = Client(cm)
    c.send([0.03], effort=[4.0])
    assert hw.get_command("joint1/max_effort") == 4.0
    c.send([0.03], effort=[25.0])
    assert hw.get_command("joint1/max_effort") == 25.0           # above max_effort: passed on as upstream does
    c.handle.cancel_goal_async()
    cm.step(2)
    assert c.outcome()[0] == GoalStatus.STATUS_CANCELED
    assert hw.get_command("joint1/max_effort") == 10.0           # hold: back to the default
    c.send([0.01])
    assert hw.get_command("joint1/max_effort") == 10.0           # a goal without effort: the default
    c.send([0.02], effort=[0.0])
    assert hw.get_command("joint1/max_effort") == 0.0            # zero too: the goal's value as given


def test_ur5e_gripper_in_mujoco_opens_and_closes():
    # no upstream counterpart: runs the controller on the MuJoCo arm
    text = (f"controller_manager:\n  ros__parameters:\n    update_rate: 250\n    grip:\n      type: {GRIP}\n"
            "grip:\n  ros__parameters:\n    joint: finger_joint\n    goal_tolerance: 0.002\n")
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"), params=text,
                           log=LogSink(log_to_stderr=False), components={"UR5e": MujocoSystem(sim=RobotSim("ur5e"))})
    cm.load_and_configure("grip")
    assert cm.switch_controller(["grip"], [], STRICT) == return_type.OK
    c = Client(cm)
    assert not c.send([0.05]).accepted                     # the finger's URDF stroke is [0, 0.04]
    assert c.send([0.01]).accepted
    cm.spin_for(1.0)
    assert c.outcome()[:2] == (GoalStatus.STATUS_SUCCEEDED, True)
    assert cm.rm.value("finger_joint/position") == pytest.approx(0.01, abs=0.002)
