"""DiffDriveController on mock wheels (GenericSystem with calculate_dynamics: velocity commands integrate).

Scenarios from ros2_controllers' diff_drive_controller/test/test_diff_drive_controller.cpp
(configuration failures, activation with position/velocity feedback, command with zero
timestamp, deactivate then activate, cmd_vel timeout) and the odometry it publishes.
"""

from __future__ import annotations

import math

import pytest
from control_robots import generic, joint, urdf

from robocourse.control import ACTIVE, STRICT, ControllerManager, return_type
from robocourse.control.log import LogSink
from robocourse.msgs.geometry_msgs import TwistStamped
from robocourse.msgs.nav_msgs import Odometry
from robocourse.msgs.tf2_msgs import TFMessage
from robocourse.sim.diffdrive import integrate_pose, quaternion_to_yaw

DD = "diff_drive_controller/DiffDriveController"
SEP, R = 0.4, 0.1


def dd_cm(params=None, activate=True, wheels=("left_wheel_joint", "right_wheel_joint")):
    p = {"left_wheel_names": "[left_wheel_joint]", "right_wheel_names": "[right_wheel_joint]",
         "wheel_separation": str(SEP), "wheel_radius": str(R), **(params or {})}
    p = {k: v for k, v in p.items() if v is not None}
    text = (f"controller_manager:\n  ros__parameters:\n    update_rate: 100\n    dd:\n      type: {DD}\n"
            "dd:\n  ros__parameters:\n" + "".join(f"    {k}: {v}\n" for k, v in p.items()))
    body = "".join(joint(w, ("velocity",), ("position", "velocity")) for w in wheels)
    cm = ControllerManager(urdf(generic(params={"calculate_dynamics": "true"}, body=body), joints=wheels),
                           params=text, log=LogSink(log_to_stderr=False))
    cm.load_controller("dd")
    if cm.configure_controller("dd") != return_type.OK:
        return cm
    if activate:
        assert cm.switch_controller(["dd"], [], STRICT) == return_type.OK
    return cm


def send(cm, v, w, stamp=None):
    node = cm.context.create_node("teleop")
    cm.executor.add_node(node)
    msg = TwistStamped()
    msg.twist.linear.x, msg.twist.angular.z = v, w
    if stamp is not None:
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(stamp), int(round((stamp - int(stamp)) * 1e9))
    node.create_publisher(TwistStamped, "/dd/cmd_vel", 10).publish(msg)


def wheel_cmds(cm):
    impl = cm.rm.components["GenericSystem2dof"].impl
    return impl.get_command("left_wheel_joint/velocity"), impl.get_command("right_wheel_joint/velocity")


@pytest.mark.parametrize("missing", ["wheel_separation", "wheel_radius", "left_wheel_names"])
def test_configure_fails_without_parameters(missing):
    # mirrors diff_drive_controller/test/test_diff_drive_controller.cpp: TEST_F(TestDiffDriveController, configure_fails_without_parameters)
    cm = ControllerManager(urdf(generic(body=joint("left_wheel_joint", ("velocity",), ("position",))),
                                joints=("left_wheel_joint",)), log=LogSink(log_to_stderr=False),
                           params=(f"controller_manager:\n  ros__parameters:\n    dd:\n      type: {DD}\n"
                                   "dd:\n  ros__parameters:\n" + "".join(
                                       f"    {k}: {v}\n" for k, v in {"left_wheel_names": "[a]", "right_wheel_names": "[b]",
                                                                     "wheel_separation": "0.4", "wheel_radius": "0.1"}.items()
                                       if k != missing)))
    assert cm.load_controller("dd") is None
    assert cm.log.count(f"parameter '{missing}' is not initialized") == 1


@pytest.mark.parametrize("key", ["wheel_separation", "wheel_radius"])
def test_wheel_geometry_must_be_positive(key):
    # no upstream counterpart: diff_drive_controller/test/test_diff_drive_controller.cpp does not test wheel_separation/wheel_radius bounds
    cm = ControllerManager(urdf(generic(body=joint("left_wheel_joint", ("velocity",), ("position",))),
                                joints=("left_wheel_joint",)), log=LogSink(log_to_stderr=False),
                           params=(f"controller_manager:\n  ros__parameters:\n    dd:\n      type: {DD}\n"
                                   "dd:\n  ros__parameters:\n    left_wheel_names: [a]\n    right_wheel_names: [b]\n"
                                   f"    wheel_separation: {0.0 if key == 'wheel_separation' else 0.4}\n"
                                   f"    wheel_radius: {0.0 if key == 'wheel_radius' else 0.1}\n"))
    assert cm.load_controller("dd") is None
    assert cm.log.count(f"Parameter '{key}' with the value '0' must be greater than '0'") == 1


def test_configure_fails_with_mismatching_wheel_side_size():
    # mirrors diff_drive_controller/test/test_diff_drive_controller.cpp: TEST_F(TestDiffDriveController, configure_fails_with_mismatching_wheel_side_size)
    cm = dd_cm(params={"right_wheel_names": "[right_wheel_joint, extra_wheel]"}, activate=False)
    assert cm.log.count("The number of left wheels [1] and the number of right wheels [2] are different") == 1


def test_wheel_speeds_from_cmd_vel_and_exact_arc_odometry():
    # mirrors diff_drive_controller/test/test_diff_drive_controller.cpp: TEST_F(TestDiffDriveController, correct_initialization_using_parameters)
    # (cmd_vel -> wheel commands) and diff_drive_controller/test/test_odometry.cpp: TEST_F(OdometryTest, TestCurvedMotion_ExactArc)
    cm = dd_cm()
    odoms, tfs = [], []
    node = cm.context.create_node("listener")
    node.create_subscription(Odometry, "/dd/odom", odoms.append, 10)     # upstream's "~/odom"
    node.create_subscription(TFMessage, "/tf", tfs.append, 10)
    cm.executor.add_node(node)
    v, w = 0.3, 0.8
    send(cm, v, w)
    cm.step(1)
    assert wheel_cmds(cm) == pytest.approx(((v - w * SEP / 2) / R, (v + w * SEP / 2) / R))
    for _ in range(20):      # keep the command fresh for 2 s
        send(cm, v, w)
        cm.step(10)
    c = cm.controllers["dd"].c
    left, right = cm.rm.value("left_wheel_joint/position"), cm.rm.value("right_wheel_joint/position")
    x, y, yaw = integrate_pose(0.0, 0.0, 0.0, R * (left + right) / 2, R * (right - left) / SEP, 1.0)
    assert (c.x, c.y, c.yaw) == pytest.approx((x, y, yaw), abs=1e-12)
    assert yaw == pytest.approx(w * 2.0, rel=0.02)          # about 2 s of turning at 0.8 rad/s
    msg = odoms[-1]
    assert (msg.header.frame_id, msg.child_frame_id) == ("odom", "base_link")
    q = msg.pose.pose.orientation
    assert quaternion_to_yaw(q.x, q.y, q.z, q.w) == pytest.approx(math.remainder(yaw, 2 * math.pi))
    assert msg.twist.twist.linear.x == pytest.approx(v) and msg.twist.twist.angular.z == pytest.approx(w)
    assert tfs[-1].transforms[0].transform.translation.x == pytest.approx(x)


def test_cmd_vel_timeout_stops_the_wheels():
    # mirrors diff_drive_controller/test/test_diff_drive_controller.cpp: TEST_F(TestDiffDriveController, command_with_zero_timestamp_is_accepted_with_warning)
    # and the cmd_vel_timeout part of TEST_F(TestDiffDriveController, chainable_controller_unchained_mode)
    cm = dd_cm()
    send(cm, 0.5, 0.0, stamp=0.0)   # zero stamp: taken as "now" with upstream's warning
    cm.step(1)
    assert wheel_cmds(cm) == pytest.approx((5.0, 5.0))
    assert cm.log.count("Received TwistStamped with zero timestamp") == 1
    cm.step(49)
    assert wheel_cmds(cm) == pytest.approx((5.0, 5.0))     # 0.5 s old: still valid
    cm.step(2)
    assert wheel_cmds(cm) == (0.0, 0.0)


def test_old_stamped_command_is_ignored():
    # mirrors the late-message part of diff_drive_controller/test/test_diff_drive_controller.cpp: TEST_F(TestDiffDriveController, chainable_controller_unchained_mode)
    cm = dd_cm()
    cm.step(100)
    send(cm, 0.5, 0.0, stamp=0.2)    # 0.8 s old when it arrives
    cm.step(1)
    assert wheel_cmds(cm) == (0.0, 0.0)


def test_non_finite_cmd_vel_is_dropped():
    # no upstream counterpart: diff_drive_controller/test/test_diff_drive_controller.cpp has no non-finite cmd_vel case
    cm = dd_cm()
    send(cm, math.nan, 0.0)
    cm.step(1)
    assert cm.controllers["dd"].c.dropped_commands == 1 and wheel_cmds(cm) == (0.0, 0.0)


def test_deactivate_then_activate_zeroes_and_resumes():
    # mirrors diff_drive_controller/test/test_diff_drive_controller.cpp: TEST_F(TestDiffDriveController, deactivate_then_activate)
    cm = dd_cm()
    send(cm, 0.2, 0.0)
    cm.step(2)
    assert cm.switch_controller([], ["dd"], STRICT) == return_type.OK
    assert wheel_cmds(cm) == (0.0, 0.0)
    assert cm.switch_controller(["dd"], [], STRICT) == return_type.OK
    send(cm, 0.2, 0.0)
    cm.step(2)
    assert cm.controllers["dd"].state == ACTIVE and wheel_cmds(cm) == pytest.approx((2.0, 2.0))


def test_open_loop_odometry_integrates_the_command():
    # mirrors diff_drive_controller/test/test_odometry.cpp: TEST_F(OdometryTest, TestOpenLoopUpdate) (through the controller, open_loop: true)
    cm = dd_cm(params={"open_loop": "true"})
    send(cm, 0.1, 0.0)
    cm.step(30)
    assert cm.controllers["dd"].c.x == pytest.approx(0.1 * 0.3)


def test_odometry_is_published_on_the_controllers_own_odom_topic():
    # diff_drive_controller.cpp: DEFAULT_ODOMETRY_TOPIC = "~/odom", DEFAULT_TRANSFORM_TOPIC = "/tf"
    cm = dd_cm()
    names = {n: t for n, t in cm.node.get_topic_names_and_types()}
    assert names.get("/dd/odom") == ["nav_msgs/msg/Odometry"]
    assert "/odom" not in names and names.get("/tf") == ["tf2_msgs/msg/TFMessage"]


def test_cmd_vel_timeout_zero_disables_the_timeout():
    # diff_drive_controller.cpp update(): "A cmd_vel_timeout of 0.0 disables the timeout." (and the subscription
    # callback keeps a message of any age when the timeout is 0)
    cm = dd_cm({"cmd_vel_timeout": "0.0"})
    send(cm, 0.5, 0.0, stamp=0.0)
    cm.step(300)                                   # 3 s without a new command
    assert wheel_cmds(cm) == pytest.approx((5.0, 5.0))
    send(cm, 0.2, 0.0, stamp=0.5)                  # stamped 2.5 s in the past: still taken
    cm.step(1)
    assert wheel_cmds(cm) == pytest.approx((2.0, 2.0))
