"""JointTrajectoryController: sampling, validation, topic, action, tolerances, PID, on the manager.

Scenarios from ros2_controllers' joint_trajectory_controller tests: test_trajectory.cpp (sampling),
test_trajectory_controller.cpp (topic, validation, tolerances, PID) and test_trajectory_actions.cpp
(the FollowJointTrajectory action). Each test names the upstream test it mirrors. Hardware:
mock_components/GenericSystem with three joints (upstream's joint1..joint3), so a position
command is the next cycle's position state (+ position_state_following_offset).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from control_robots import generic, joint, urdf

from robocourse.bus.action import ActionClient
from robocourse.control import ACTIVE, INACTIVE, STRICT, ControllerManager, return_type
from robocourse.control.controllers.joint_trajectory_controller.trajectory import Sample, Trajectory
from robocourse.control.log import LogSink
from robocourse.control.msgs import (
    FollowJointTrajectory,
    JointTolerance,
    JointTrajectoryControllerState,
)
from robocourse.msgs.action_msgs import GoalStatus
from robocourse.msgs.builtin_interfaces import Duration
from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

JTC = "joint_trajectory_controller/JointTrajectoryController"
JOINTS = ("joint1", "joint2", "joint3")
INITIAL = (1.1, 2.1, 3.1)
Result = FollowJointTrajectory.Result


def dur(s: float) -> Duration:
    ns = int(round(s * 1e9))
    return Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def body(commands=("position",), states=("position", "velocity")):
    return "".join(joint(j, commands, states, {"position": p}) for j, p in zip(JOINTS, INITIAL))


def make_cm(params=None, commands=("position",), states=("position", "velocity"), hw_params=None,
            hw_commands=None, hw_states=("position", "velocity"), activate=True):
    params = {"joints": "[joint1, joint2, joint3]", "command_interfaces": f"[{', '.join(commands)}]",
              "state_interfaces": f"[{', '.join(states)}]", **(params or {})}
    text = (f"controller_manager:\n  ros__parameters:\n    update_rate: 100\n    jtc:\n      type: {JTC}\n"
            "jtc:\n  ros__parameters:\n" + "".join(f"    {k}: {v}\n" for k, v in params.items()))
    hw = generic(params=hw_params or {}, body=body(hw_commands or commands, hw_states))
    cm = ControllerManager(urdf(hw, joints=JOINTS), params=text, log=LogSink(log_to_stderr=False))
    cm.load_and_configure("jtc")
    if activate:
        assert cm.switch_controller(["jtc"], [], STRICT) == return_type.OK
    return cm


def command(cm, iface="position"):
    return [cm.rm.components["GenericSystem2dof"].impl.get_command(f"{j}/{iface}") for j in JOINTS]


def positions(cm):
    return [cm.rm.value(f"{j}/position") for j in JOINTS]


def traj(points, names=JOINTS, stamp=0.0):
    """points: (time_from_start, positions[, velocities[, accelerations]])."""
    msg = JointTrajectory(joint_names=list(names))
    msg.header.stamp.sec = int(stamp)
    msg.header.stamp.nanosec = int(round((stamp - int(stamp)) * 1e9))
    for t, *fields in points:
        pt = JointTrajectoryPoint(positions=list(fields[0]), time_from_start=dur(t))
        if len(fields) > 1:
            pt.velocities = list(fields[1])
        if len(fields) > 2:
            pt.accelerations = list(fields[2])
        msg.points.append(pt)
    return msg


def publish(cm, msg):
    node = cm.context.create_node(f"commander{len(cm.context.nodes) if hasattr(cm.context, 'nodes') else ''}")
    cm.executor.add_node(node)
    node.create_publisher(JointTrajectory, "/jtc/joint_trajectory", 10).publish(msg)


def jtc(cm):
    return cm.controllers["jtc"].c


# --- sampling (test_trajectory.cpp) -----------------------------------------------------------------------
def _sample(tr, t):
    out = Sample(1)
    idx = tr.sample(t, out)
    return idx, out


def test_sample_trajectory_positions_linear_from_the_state_before_and_hold_after():
    # mirrors joint_trajectory_controller/test/test_trajectory.cpp: TEST(TestTrajectory, sample_trajectory_positions)
    tr = Trajectory([1.0, 2.0, 3.0], [[1.0], [2.0], [3.0]], start_time=0.0)
    start = Sample(1)
    t0 = 10.0
    tr.set_point_before_trajectory(t0, start)
    idx, s = _sample(tr, t0)
    assert idx == 0 and s.positions[0] == pytest.approx(0.0) and s.velocities[0] == pytest.approx(1.0)
    assert s.accelerations[0] == 0.0
    assert _sample(tr, t0 - 0.5)[0] == -1
    for dt, want in ((0.5, 0.5), (1.0, 1.0), (1.5, 1.5), (2.5, 2.5), (3.0, 3.0), (3.125, 3.0), (30.0, 3.0)):
        assert _sample(tr, t0 + dt)[1].positions[0] == pytest.approx(want, abs=1e-8), dt
    assert [_sample(tr, t0 + dt)[0] for dt in (0.5, 1.0, 2.5, 3.0)] == [0, 1, 2, 3]


def test_interpolation_pos_vel_is_the_cubic_x3_minus_2x():
    # mirrors joint_trajectory_controller/test/test_trajectory.cpp: TEST(TestTrajectory, interpolation_pos_vel)
    tr = Trajectory([1.0, 3.0], [[0.0], [4.0]], velocities=[[-2.0], [10.0]], start_time=5.0)
    tr.set_point_before_trajectory(5.0, Sample(1))
    for t, p, v, a in ((1.0, 0.0, -2.0, 0.0), (1.0 + math.sqrt(2), 0.0, 4.0, 6 * math.sqrt(2)), (2.999999999, 4.0, 10.0, 12.0)):
        s = _sample(tr, 5.0 + t)[1]
        assert (s.positions[0], s.velocities[0], s.accelerations[0]) == pytest.approx((p, v, a), abs=1e-6)


def test_interpolation_pos_vel_accel_is_the_quintic():
    # mirrors joint_trajectory_controller/test/test_trajectory.cpp: TEST(TestTrajectory, interpolation_pos_vel_accel); x(x-1)(x-2)(x-3)(x-4), x = t - 1
    tr = Trajectory([1.0, 3.0], [[0.0], [0.0]], velocities=[[24.0], [4.0]], accelerations=[[-100.0], [0.0]],
                    start_time=5.0)
    tr.set_point_before_trajectory(5.0, Sample(1))
    s = _sample(tr, 7.0)[1]
    assert (s.positions[0], s.velocities[0], s.accelerations[0]) == pytest.approx((0.0, -6.0, 10.0), abs=1e-8)
    s = _sample(tr, 6.0)[1]
    assert (s.positions[0], s.velocities[0], s.accelerations[0]) == pytest.approx((0.0, 24.0, -100.0), abs=1e-8)


def test_skip_interpolation_returns_the_next_point():
    # mirrors joint_trajectory_controller/test/test_trajectory.cpp: TEST(TestTrajectory, skip_interpolation)
    tr = Trajectory([1.0, 2.0, 3.0], [[1.0], [2.0], [3.0]])
    tr.set_point_before_trajectory(10.0, Sample(1))
    got = []
    for dt in (0.0, 0.5, 1.0, 1.5, 2.5, 3.0):
        out = Sample(1)
        tr.sample(10.0 + dt, out, interpolate=False)
        got.append(out.positions[0])
    assert got == [0.0, 0.0, 2.0, 2.0, 3.0, 3.0]


# --- configuration ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("commands, states", [
    ((), ("position",)), (("effort", "velocity"), ("position", "velocity")),
    (("effort", "acceleration"), ("position", "velocity")), (("velocity", "acceleration"), ("position", "velocity")),
    (("acceleration",), ("position", "velocity")), (("position",), ()), (("position",), ("velocity",)),
    (("position",), ("velocity", "acceleration")), (("position",), ("position", "acceleration")),
])
def test_incorrect_interface_combinations_fail_init(commands, states):
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_F(TrajectoryControllerTest, incorrect_initialization_using_interface_parameters)
    with pytest.raises(RuntimeError):
        make_cm(commands=commands, states=states, hw_commands=("position", "velocity", "acceleration", "effort"),
                activate=False)


@pytest.mark.parametrize("commands", [("velocity",), ("effort",), ("position", "effort")])
def test_velocity_or_effort_commands_without_velocity_state_fail_configure(commands):
    # mirrors the 'init OK, configure fails' cases of joint_trajectory_controller/test/test_trajectory_controller.cpp:
    # TEST_F(TrajectoryControllerTest, incorrect_initialization_using_interface_parameters)
    with pytest.raises(RuntimeError):
        make_cm(commands=commands, states=("position",), hw_commands=("position", "velocity", "effort"),
                activate=False)


@pytest.mark.parametrize("values, message", [
    ({"joints": "[]"}, "Length of parameter 'joints' is '0' but must be greater than '0'"),
    ({"command_interfaces": "[position, bad_name]"},
     "Entry 'bad_name' in parameter 'command_interfaces' is not in the set '{position, velocity, acceleration, effort}'"),
    ({"constraints.goal_time": "-1.0"}, "must be greater than or equal to '0'"),
])
def test_parameters_outside_the_schema_are_refused_with_the_validator_text(values, message):
    # no upstream counterpart: the validator texts come from generate_parameter_library, not a JTC test
    with pytest.raises(Exception) as err:
        make_cm(params=values, activate=False)
    assert message in str(err.value) or message in str(err.value.__cause__)


# --- activation and the topic ----------------------------------------------------------------------------
def test_activation_holds_the_current_position():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, activate) and
    # TEST_P(TrajectoryControllerTestParameterized, test_hw_states_has_offset_first_controller_start)
    cm = make_cm()
    cm.step(5)
    assert positions(cm) == pytest.approx(INITIAL, abs=1e-12)
    assert jtc(cm).state_desired.positions.tolist() == pytest.approx(INITIAL)


def test_topic_trajectory_reaches_its_points_at_their_times():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, correct_initialization_using_parameters)
    # (a trajectory on ~/joint_trajectory reaches its points)
    cm = make_cm()
    cm.step(1)
    publish(cm, traj([(0.25, (2.0, 3.0, 4.0)), (0.5, (1.0, 1.0, 1.0))]))
    cm.step(25)   # the command leads by one period: at t_start + 0.24 s it commands the 0.25 s point
    assert command(cm) == pytest.approx([2.0, 3.0, 4.0], abs=1e-9)
    cm.step(1)    # GenericSystem: the state follows the command at the next read
    assert positions(cm) == pytest.approx([2.0, 3.0, 4.0], abs=1e-9)
    cm.step(30)
    assert positions(cm) == pytest.approx([1.0, 1.0, 1.0], abs=1e-12)


def test_jumbled_joint_order_is_mapped_to_the_controllers_order():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_jumbled_joint_order)
    cm = make_cm()
    cm.step(1)
    publish(cm, traj([(0.1, (3.3, 1.1, 2.2))], names=("joint3", "joint1", "joint2")))
    cm.step(20)
    assert positions(cm) == pytest.approx([1.1, 2.2, 3.3], abs=1e-12)


def test_partial_joint_list_holds_the_missing_joints():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_partial_joint_list)
    cm = make_cm(params={"allow_partial_joints_goal": "true"})
    cm.step(1)
    publish(cm, traj([(0.1, (5.0, 6.0))], names=("joint2", "joint1")))
    cm.step(20)
    assert positions(cm) == pytest.approx([6.0, 5.0, INITIAL[2]], abs=1e-12)


def test_partial_joint_list_not_allowed_is_dropped():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_partial_joint_list_not_allowed)
    cm = make_cm()
    cm.step(1)
    publish(cm, traj([(0.1, (5.0, 6.0))], names=("joint2", "joint1")))
    cm.step(20)
    assert positions(cm) == pytest.approx(INITIAL, abs=1e-12)
    assert jtc(cm).rejections == ["Joints on incoming trajectory don't match the controller joints."]


def _bad(kind):
    good = [(0.1, (1.0, 2.0, 3.0)), (0.2, (1.5, 2.5, 3.5))]
    if kind == "empty":
        return traj([])
    if kind == "empty_names":
        return traj(good, names=())
    if kind == "unknown":
        return traj(good, names=("joint1", "joint2", "elbow"))
    if kind == "time":
        return traj([(0.2, (1.0, 2.0, 3.0)), (0.2, (1.5, 2.5, 3.5))])
    if kind == "size":
        return traj([(0.1, (1.0, 2.0))])
    if kind == "velocity_size":
        return traj([(0.1, (1.0, 2.0, 3.0), (0.0, 0.0))])
    if kind == "nan":
        return traj([(0.1, (1.0, math.nan, 3.0))])
    if kind == "final_velocity":
        return traj([(0.1, (1.0, 2.0, 3.0), (0.0, 0.5, 0.0))])
    if kind == "past":
        return traj(good, stamp=0.001)
    raise AssertionError(kind)


BAD = {
    "empty": "Empty trajectory received.",
    "empty_names": "Joints on incoming trajectory don't match the controller joints.",
    "unknown": "Incoming joint elbow doesn't match the controller's joints.",
    "time": "Time between points 0 and 1 is not strictly increasing, it is 0.200000 and 0.200000 respectively",
    "size": "Mismatch between joint_names size (3) and positions (2) at point #0.",
    "velocity_size": "Mismatch between joint_names size (3) and velocities (2) at point #0.",
    "nan": "Non-finite value in positions at point #0: [1.0, nan, 3.0] (every value must be finite)",
    "final_velocity": "Velocity of last trajectory point of joint joint2 is not zero: 0.500000000000000",
    "past": "Received trajectory with non-zero start time (0.001000) that ends in the past (0.201000)",
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_invalid_trajectory_messages_are_dropped_with_upstreams_reason(kind):
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, invalid_message)
    cm = make_cm()
    cm.step(30)
    publish(cm, _bad(kind))
    cm.step(30)
    assert positions(cm) == pytest.approx(INITIAL, abs=1e-12)
    assert jtc(cm).rejections == [BAD[kind]]


def test_trajectory_replace_starts_from_the_current_state():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_trajectory_replace)
    cm = make_cm()
    cm.step(1)
    publish(cm, traj([(1.0, (3.0, 3.0, 3.0))]))
    cm.step(50)
    mid = command(cm)
    publish(cm, traj([(1.0, (0.0, 0.0, 0.0))]))
    cm.step(1)
    # the new trajectory starts where the joints are (the state = the last command), 1/100 of the way
    assert command(cm) == pytest.approx([m + (0.0 - m) * 0.01 for m in mid], abs=1e-9)
    cm.step(120)
    assert positions(cm) == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)


def test_state_tolerance_violation_holds_position_in_topic_mode():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_state_tolerances_fail)
    cm = make_cm(params={"constraints.joint1.trajectory": "0.05"}, hw_params={"position_state_following_offset": "0.1"})
    cm.step(2)
    publish(cm, traj([(1.0, (3.0, 3.0, 3.0))]))
    cm.step(5)
    assert cm.log.count("Holding position due to state tolerance violation") == 1
    held = positions(cm)
    cm.step(50)
    assert positions(cm) == pytest.approx(held, abs=1e-12)   # holds (the state sits 0.1 above the held command)
    assert positions(cm)[1] < 2.6                             # never went on towards 3.0


def test_goal_time_exceeded_holds_position_in_topic_mode():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_goal_tolerances_fail)
    cm = make_cm(params={"constraints.joint1.goal": "0.05", "constraints.goal_time": "0.1"},
                 hw_params={"position_state_following_offset": "0.1"})
    cm.step(2)
    publish(cm, traj([(0.2, (3.0, 3.0, 3.0))]))
    cm.step(40)
    assert cm.log.count("Exceeded goal_time_tolerance: holding position...") == 1


def test_cmd_timeout_holds_position_after_the_last_point():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, timeout) (cmd_timeout 0.1 s: hold the last point)
    cm = make_cm(params={"cmd_timeout": "0.3"})
    cm.step(1)
    publish(cm, traj([(0.1, (2.0, 2.0, 2.0))]))
    cm.step(35)
    assert cm.log.count("Aborted due to command timeout") == 0
    cm.step(10)
    assert cm.log.count("Aborted due to command timeout") == 1
    assert jtc(cm)._is_holding


def test_update_dynamic_tolerances_are_picked_up_by_the_next_update():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, update_dynamic_tolerances)
    cm = make_cm()
    c = jtc(cm)
    d = c.default_tolerances
    assert (d.goal_time, d.state_position.tolist(), d.goal_position.tolist(), d.goal_velocity.tolist()) == (
        0.0, [0.0] * 3, [0.0] * 3, [0.01] * 3)
    for name, value in (("constraints.goal_time", 1.0), ("constraints.stopped_velocity_tolerance", 0.02)):
        assert c.param_listener.set(name, value).successful
    for n, j in enumerate(JOINTS, 1):
        assert c.param_listener.set(f"constraints.{j}.trajectory", float(n)).successful
        assert c.param_listener.set(f"constraints.{j}.goal", 10.0 * n).successful
    cm.step(1)
    d = c.default_tolerances
    assert (d.goal_time, d.state_position.tolist(), d.goal_position.tolist(), d.goal_velocity.tolist()) == (
        1.0, [1.0, 2.0, 3.0], [10.0, 20.0, 30.0], [0.02] * 3)


def test_velocity_only_uses_the_pid_with_feed_forward():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, use_closed_loop_pid) (OnlyVelocityTrajectoryControllers)
    cm = make_cm(params={"gains.joint1.p": "2.0", "gains.joint2.p": "2.0", "gains.joint3.p": "2.0",
                         "gains.joint1.ff_velocity_scale": "1.0"},
                 commands=("velocity",), hw_params={"calculate_dynamics": "true"},
                 hw_commands=("velocity",))
    c = jtc(cm)
    assert c.use_closed_loop_pid
    cm.step(1)
    publish(cm, traj([(1.0, (2.1, 2.1, 3.1))]))
    cm.step(2)
    # joint1: ff 1.0 rad/s (the linear segment's slope) + 2.0 * error; joint2: error only; joint3: nothing to do
    v = [cm.rm.value(f"{j}/velocity") for j in JOINTS]
    assert v[2] == pytest.approx(0.0, abs=1e-12)
    assert v[0] > 0.99 and v[1] == pytest.approx(0.0, abs=1e-9)
    cm.step(150)
    assert positions(cm)[0] == pytest.approx(2.1, abs=0.02)


def test_position_effort_writes_the_interpolated_effort():
    # no upstream counterpart: joint_trajectory_controller/test/test_trajectory_controller.cpp's parameterized suites instantiate position, position+velocity,
    # position+velocity+acceleration, velocity and effort, not position+effort
    cm = make_cm(commands=("position", "effort"), hw_commands=("position", "effort"))
    cm.step(1)
    msg = traj([(0.5, (1.1, 2.1, 3.1))])
    msg.points[0].effort = [4.0, 0.0, -4.0]
    publish(cm, msg)
    cm.step(25)   # command sampled at 0.25 s (+ one period ahead): half-way on the linear effort ramp
    assert command(cm, "effort") == pytest.approx([2.0, 0.0, -2.0], abs=0.1)


def test_controller_state_topic_reports_reference_feedback_error_output():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, state_topic_consistency)
    cm = make_cm()
    got = []
    node = cm.context.create_node("state_listener")
    node.create_subscription(JointTrajectoryControllerState, "/jtc/controller_state", got.append, 10)
    cm.executor.add_node(node)
    cm.step(3)
    assert len(got) >= 2
    msg = got[-1]
    assert msg.joint_names == list(JOINTS)
    assert msg.reference.positions == pytest.approx(INITIAL) and msg.feedback.positions == pytest.approx(INITIAL)
    assert msg.error.positions == pytest.approx([0.0] * 3) and msg.output.positions == pytest.approx(INITIAL)


# --- the action (test_trajectory_actions.cpp) -----------------------------------------------------------------
class Client:
    def __init__(self, cm):
        self.cm = cm
        node = cm.context.create_node("fjt_client")
        cm.executor.add_node(node)
        self.client = ActionClient(node, FollowJointTrajectory, "/jtc/follow_joint_trajectory")
        self.feedback = []

    def send(self, msg, path=(), goal=(), goal_time=0.0):
        g = FollowJointTrajectory.Goal(trajectory=msg, path_tolerance=list(path), goal_tolerance=list(goal),
                                       goal_time_tolerance=dur(goal_time))
        fut = self.client.send_goal_async(g, feedback_callback=self.feedback.append)
        self.cm.step(1)
        handle = fut.result()
        self.result = handle.get_result_async() if handle.accepted else None
        return handle

    def outcome(self):
        r = self.result.result()
        return None if r is None else (r.status, r.result.error_code, r.result.error_string)


def test_success_single_point_sendgoal():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_success_single_point_sendgoal)
    cm = make_cm()
    c = Client(cm)
    h = c.send(traj([(0.5, (1.0, 2.0, 3.0))]))
    assert h.accepted
    cm.step(70)
    assert c.outcome() == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL, "Goal successfully reached!")
    assert positions(cm) == pytest.approx([1.0, 2.0, 3.0], abs=1e-12)
    fb = c.feedback[-1].feedback
    assert fb.joint_names == list(JOINTS) and len(fb.desired.positions) == 3


def test_success_multi_point_sendgoal_with_feedback():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_success_multi_point_sendgoal)
    cm = make_cm()
    c = Client(cm)
    c.send(traj([(0.2, (1.0, 2.0, 3.0)), (0.4, (2.0, 3.0, 4.0))]))
    cm.step(60)
    assert c.outcome()[:2] == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL)
    assert positions(cm) == pytest.approx([2.0, 3.0, 4.0], abs=1e-12)
    assert 5 <= len(c.feedback) <= 15           # 20 Hz monitor over ~0.4 s
    assert all(f.feedback.error.positions == pytest.approx([0.0] * 3, abs=1e-9) for f in c.feedback[1:])


def test_goal_rejected_while_the_controller_is_inactive():
    # no upstream counterpart: joint_trajectory_controller/test/test_trajectory_actions.cpp sends goals only to an active controller
    cm = make_cm(activate=False)
    c = Client(cm)
    h = c.send(traj([(0.5, (1.0, 2.0, 3.0))]))
    assert not h.accepted
    assert jtc(cm).rejections == ["Can't accept new action goals. Controller is not running."]


def test_allow_nonzero_velocity_at_trajectory_end_false_rejects_the_goal():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_allow_nonzero_velocity_at_trajectory_end_false)
    cm = make_cm()
    h = Client(cm).send(traj([(0.5, (1.0, 2.0, 3.0), (0.0, 0.0, 1.0))]))
    assert not h.accepted
    assert jtc(cm).rejections == ["Velocity of last trajectory point of joint joint3 is not zero: 1.000000000000000"]


def test_allow_nonzero_velocity_at_trajectory_end_true_accepts_and_succeeds():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_allow_nonzero_velocity_at_trajectory_end_true)
    cm = make_cm(params={"allow_nonzero_velocity_at_trajectory_end": "true", "constraints.stopped_velocity_tolerance": "0.0"})
    c = Client(cm)
    assert c.send(traj([(0.5, (1.0, 2.0, 3.0), (0.0, 0.0, 1.0))])).accepted
    cm.step(70)
    assert c.outcome()[:2] == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL)


def test_state_tolerances_fail_aborts_with_path_tolerance_violated():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_state_tolerances_fail)
    cm = make_cm(hw_params={"position_state_following_offset": "0.1"})
    c = Client(cm)
    c.send(traj([(1.0, (3.0, 3.0, 3.0))]), path=[JointTolerance(name="joint1", position=0.05)])
    cm.step(20)
    assert c.outcome() == (GoalStatus.STATUS_ABORTED, Result.PATH_TOLERANCE_VIOLATED,
                           "Aborted due to path tolerance violation")
    assert cm.log.count("Aborted due to state tolerance violation") == 1


def test_goal_tolerances_fail_aborts_with_goal_tolerance_violated():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_goal_tolerances_fail)
    cm = make_cm(hw_params={"position_state_following_offset": "0.1"})
    c = Client(cm)
    c.send(traj([(0.2, (3.0, 3.0, 3.0))]), goal=[JointTolerance(name="joint2", position=0.05)], goal_time=0.1)
    cm.step(60)
    status, code, text = c.outcome()
    assert (status, code) == (GoalStatus.STATUS_ABORTED, Result.GOAL_TOLERANCE_VIOLATED)
    assert text.startswith("Aborted due to goal_time_tolerance exceeding by 0.1") and text.endswith(" seconds")


def test_goal_tolerances_single_point_success():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_F(TestTrajectoryActions, test_goal_tolerances_single_point_success)
    cm = make_cm(hw_params={"position_state_following_offset": "0.01"})
    c = Client(cm)
    c.send(traj([(0.2, (3.0, 3.0, 3.0))]), goal=[JointTolerance(name=j, position=0.05) for j in JOINTS],
           goal_time=0.1)
    cm.step(60)
    assert c.outcome()[:2] == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL)


def test_cancel_hold_position():
    # mirrors joint_trajectory_controller/test/test_trajectory_actions.cpp: TEST_P(TestTrajectoryActionsTestParameterized, test_cancel_hold_position)
    cm = make_cm()
    c = Client(cm)
    h = c.send(traj([(1.0, (3.0, 3.0, 3.0))]))
    cm.step(30)
    h.cancel_goal_async()
    cm.step(1)
    held = positions(cm)
    cm.step(20)
    assert c.outcome()[0] == GoalStatus.STATUS_CANCELED
    assert positions(cm) == pytest.approx(held, abs=1e-12)
    assert INITIAL[0] < held[0] < 3.0


def test_preempted_goal_is_aborted_with_upstreams_text():
    # no upstream counterpart: joint_trajectory_controller/test/test_trajectory_actions.cpp has no preemption case; the text is preempt_active_goal()'s (jazzy+)
    cm = make_cm()
    c1, c2 = Client(cm), None
    c1.send(traj([(1.0, (3.0, 3.0, 3.0))]))
    cm.step(10)
    c2 = Client.__new__(Client)
    c2.cm, c2.client, c2.feedback = cm, c1.client, []
    c2.send(traj([(0.2, (0.0, 0.0, 0.0))]))
    cm.step(40)
    assert c1.outcome() == (GoalStatus.STATUS_ABORTED, Result.INVALID_GOAL,
                            "Current goal preempted by new incoming action.")
    assert c2.outcome()[:2] == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL)
    assert positions(cm) == pytest.approx([0.0] * 3, abs=1e-12)


def test_deactivate_controller_aborts_action():
    # no upstream counterpart: joint_trajectory_controller/test/test_trajectory_actions.cpp has no deactivation case; on_deactivate() aborts the goal upstream
    cm = make_cm()
    c = Client(cm)
    c.send(traj([(1.0, (3.0, 3.0, 3.0))]))
    cm.step(10)
    assert cm.switch_controller([], ["jtc"], STRICT) == return_type.OK
    cm.step(10)
    assert cm.controllers["jtc"].state == INACTIVE
    assert c.outcome() == (GoalStatus.STATUS_ABORTED, Result.INVALID_GOAL,
                           "Current goal cancelled during deactivate transition.")


def test_reactivation_holds_the_last_command_not_a_jump():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, test_hw_states_has_offset_later_controller_start)
    # (set_last_command_interface_value_as_state_on_activation)
    cm = make_cm()
    cm.step(1)
    publish(cm, traj([(0.2, (2.0, 2.0, 2.0))]))
    cm.step(30)
    cm.switch_controller([], ["jtc"], STRICT)
    cm.switch_controller(["jtc"], [], STRICT)
    cm.step(10)
    assert cm.controllers["jtc"].state == ACTIVE
    assert positions(cm) == pytest.approx([2.0, 2.0, 2.0], abs=1e-12)
    assert np.all(np.isfinite(positions(cm)))


def test_position_velocity_acceleration_commands_follow_the_quintic():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp's PositionVelocityAccelerationTrajectoryControllers instantiation of
    # TEST_P(TrajectoryControllerTestParameterized, test_jumbled_joint_order) (commands follow the spline)
    cm = make_cm(commands=("position", "velocity", "acceleration"), hw_commands=("position", "velocity", "acceleration"))
    cm.step(1)
    # from rest at INITIAL to INITIAL + 1 in 1 s, rest to rest: the quintic 10s^3 - 15s^4 + 6s^5
    publish(cm, traj([(1.0, tuple(p + 1.0 for p in INITIAL), (0.0,) * 3, (0.0,) * 3)]))
    cm.step(50)   # the command is sampled one period ahead: s = 0.5 exactly
    assert command(cm) == pytest.approx([p + 0.5 for p in INITIAL], abs=1e-9)
    assert command(cm, "velocity") == pytest.approx([1.875] * 3, abs=1e-9)         # 30 s^2 - 60 s^3 + 30 s^4
    assert command(cm, "acceleration") == pytest.approx([0.0] * 3, abs=1e-9)       # 60 s - 180 s^2 + 120 s^3


def test_effort_only_closes_the_loop_with_the_pid():
    # mirrors joint_trajectory_controller/test/test_trajectory_controller.cpp: TEST_P(TrajectoryControllerTestParameterized, use_closed_loop_pid) (OnlyEffortTrajectoryControllers)
    cm = make_cm(params={f"gains.{j}.p": "10.0" for j in JOINTS}, commands=("effort",), hw_commands=("effort",))
    c = jtc(cm)
    assert c.use_closed_loop_pid
    cm.step(1)
    publish(cm, traj([(0.5, (1.6, 2.1, 3.1))]))
    cm.step(2)
    eff = command(cm, "effort")
    # reference one period into a 0.5 s linear segment from 1.1 to 1.6: error 0.01, effort 10 * 0.01
    assert eff == pytest.approx([0.1, 0.0, 0.0], abs=1e-9)


# --- issue 30: deactivation and illegal action tolerances as upstream -------------------------------------------
def test_deactivate_leaves_the_position_command_where_it_is_and_zeroes_velocity():
    # joint_trajectory_controller.cpp on_deactivate(): each position command is set to its own value, velocity /
    # acceleration / effort commands to 0.0. With a following offset the state differs from the command, so writing
    # the state back (the old behaviour here) would move the command by the offset.
    cm = make_cm(commands=("position", "velocity"), hw_params={"position_state_following_offset": "0.1"})
    cm.step(1)
    publish(cm, traj([(0.3, (2.0, 2.0, 2.0), (0.0, 0.0, 0.0))]))
    cm.step(15)                                  # mid-trajectory: commands move, velocities nonzero
    before = command(cm)
    assert any(abs(v) > 0 for v in command(cm, "velocity"))
    assert cm.switch_controller([], ["jtc"], STRICT) == return_type.OK
    assert command(cm) == before
    assert command(cm, "velocity") == [0.0, 0.0, 0.0]
    assert positions(cm) != pytest.approx(before)           # the offset is real: state != command


@pytest.mark.parametrize("path, goal, goal_time, logged", [
    ([JointTolerance(name="joint1", position=-0.5)], [], 0.0,
     "joint 'joint1' specified in goal.path_tolerance has a invalid position tolerance. Using default tolerances."),
    ([], [JointTolerance(name="joint3", velocity=-2.0)], 0.0,
     "joint 'joint3' specified in goal.goal_tolerance has a invalid velocity tolerance. Using default tolerances."),
    ([JointTolerance(name="joint9", position=0.05)], [], 0.0,
     "joint 'joint9' specified in goal.path_tolerance does not exist. Using default tolerances."),
    ([], [], -0.5, "Specified illegal goal_time_tolerance: -0.500000. Using default tolerances"),
])
def test_illegal_action_tolerances_fall_back_to_the_defaults_for_the_whole_goal(path, goal, goal_time, logged):
    # tolerances.hpp get_segment_tolerances() / resolve_tolerance_source(): a negative tolerance other than -1, or a
    # joint the controller does not have, logs an error and the goal runs with the default tolerances (it is not
    # rejected). The goal also carries a legal joint2 path tolerance (0.05 under a 0.1 following offset) that
    # would abort it if it were applied: with the defaults (0 = not checked) it succeeds.
    cm = make_cm(hw_params={"position_state_following_offset": "0.1"})
    c = Client(cm)
    h = c.send(traj([(0.2, (3.0, 3.0, 3.0))]), path=[JointTolerance(name="joint2", position=0.05), *path],
               goal=goal, goal_time=goal_time)
    assert h.accepted and jtc(cm).rejections == []
    cm.step(60)
    assert c.outcome() == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL, "Goal successfully reached!")
    assert cm.log.count(logged) == 1


def test_erase_value_minus_one_turns_a_default_tolerance_off():
    # resolve_tolerance_source(): -1 erases the default (0 = not checked); a legal goal tolerance still applies
    cm = make_cm(params={"constraints.joint2.trajectory": "0.05"}, hw_params={"position_state_following_offset": "0.1"})
    c = Client(cm)
    c.send(traj([(0.2, (3.0, 3.0, 3.0))]), path=[JointTolerance(name="joint2", position=-1.0)])
    cm.step(60)
    assert c.outcome()[:2] == (GoalStatus.STATUS_SUCCEEDED, Result.SUCCESSFUL)
    c.send(traj([(0.2, (1.0, 1.0, 1.0))]))           # no goal tolerances: the 0.05 default aborts it
    cm.step(60)
    assert c.outcome()[:2] == (GoalStatus.STATUS_ABORTED, Result.PATH_TOLERANCE_VIOLATED)
