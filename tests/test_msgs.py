"""robocourse.msgs: definitions, defaults, conversions, custom types, MCAP compatibility."""

import array

import numpy as np
import pytest
from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

from robocourse import msgs
from robocourse.msgs import (
    MessageDefinitionError,
    check_message,
    definition_name,
    from_dict,
    full_definition,
    get_message_type,
    message,
    to_dict,
    to_numpy,
)
from robocourse.msgs._core import wire_view
from robocourse.msgs.action_msgs import CancelGoal, GoalStatus
from robocourse.msgs.builtin_interfaces import Time
from robocourse.msgs.diagnostic_msgs import DiagnosticArray, DiagnosticStatus, KeyValue
from robocourse.msgs.example_interfaces import AddTwoInts, Fibonacci
from robocourse.msgs.geometry_msgs import Pose, Quaternion, Twist, Vector3
from robocourse.msgs.nav_msgs import Odometry
from robocourse.msgs.sensor_msgs import JointState
from robocourse.msgs.std_msgs import Float64MultiArray
from robocourse.msgs.tf2_msgs import TFMessage
from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

REQUIRED = [
    "builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration", "std_msgs/msg/Header",
    "std_msgs/msg/Bool", "std_msgs/msg/String", "std_msgs/msg/Float64",
    "std_msgs/msg/Float64MultiArray", "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Point",
    "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Pose", "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/Twist", "geometry_msgs/msg/Transform",
    "geometry_msgs/msg/TransformStamped", "nav_msgs/msg/Odometry", "sensor_msgs/msg/JointState",
    "trajectory_msgs/msg/JointTrajectory", "trajectory_msgs/msg/JointTrajectoryPoint",
    "diagnostic_msgs/msg/DiagnosticArray", "diagnostic_msgs/msg/DiagnosticStatus",
    "diagnostic_msgs/msg/KeyValue", "tf2_msgs/msg/TFMessage", "action_msgs/msg/GoalStatus",
    "action_msgs/msg/GoalInfo", "action_msgs/srv/CancelGoal",
]


@pytest.mark.parametrize("name", REQUIRED)
def test_required_types_exist_with_their_full_name(name):
    t = msgs.REGISTRY[name]
    assert t._type == name


def test_ros_defaults():
    assert Quaternion() == Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    assert Twist().linear == Vector3(0.0, 0.0, 0.0)
    o = Odometry()
    # rclpy: a fixed numeric array is a numpy array of its dtype, a sequence an array.array
    assert isinstance(o.pose.covariance, np.ndarray) and o.pose.covariance.dtype == np.float64
    assert o.pose.covariance.shape == (36,) and not o.pose.covariance.any()
    assert o.header.frame_id == "" and o.header.stamp == Time(sec=0, nanosec=0)
    assert JointState().name == [] and JointState().position == array.array("d")
    # mutable defaults are not shared between instances
    a, b = JointState(), JointState()
    a.position.append(1.0)
    assert b.position.tolist() == []


def test_constants_are_class_attributes():
    assert [GoalStatus.STATUS_UNKNOWN, GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING,
            GoalStatus.STATUS_CANCELING, GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED,
            GoalStatus.STATUS_ABORTED] == [0, 1, 2, 3, 4, 5, 6]
    assert (CancelGoal.Response.ERROR_NONE, CancelGoal.Response.ERROR_REJECTED,
            CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID, CancelGoal.Response.ERROR_GOAL_TERMINATED) == (0, 1, 2, 3)
    assert DiagnosticStatus.WARN == 1


def test_definition_text_is_carried():
    assert "Vector3  linear" in Twist._definition
    assert Twist._type == "geometry_msgs/msg/Twist"
    assert "int64 a" in AddTwoInts._definition and AddTwoInts.Response().sum == 0
    assert Fibonacci.Goal().order == 0 and Fibonacci.Result().sequence == array.array("i")


def test_full_definition_appends_dependencies_once():
    text = full_definition(Odometry)
    assert text.startswith("std_msgs/Header header\n")
    for dep in ("std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance",
                "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion",
                "geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist", "geometry_msgs/Vector3"):
        assert text.count(f"MSG: {dep}\n") == 1, dep
    assert "=" * 80 + "\nMSG: std_msgs/Header" in text


ALL_MESSAGES = sorted(n for n, t in msgs.REGISTRY.items() if hasattr(t, "_fields"))


@pytest.mark.parametrize("name", ALL_MESSAGES)
def test_every_message_round_trips_through_the_ros2_cdr_codec(name):
    t = msgs.REGISTRY[name]
    schema = definition_name(name)
    enc = serialize_dynamic(schema, full_definition(t))[schema]
    dec = generate_dynamic(schema, full_definition(t))[schema]
    m = t()
    back = from_dict(t, dec(enc(wire_view(m))))
    assert back == m


def test_cdr_round_trip_with_values():
    js = JointState(name=["a", "b"], position=[1.5, -2.0], velocity=[0.1, 0.2], effort=[])
    js.header.stamp = Time(sec=3, nanosec=500)
    js.header.frame_id = "base"
    enc = serialize_dynamic("sensor_msgs/JointState", full_definition(JointState))["sensor_msgs/JointState"]
    dec = generate_dynamic("sensor_msgs/JointState", full_definition(JointState))["sensor_msgs/JointState"]
    assert from_dict(JointState, dec(enc(js))) == js


def test_dict_round_trip_nested_sequences():
    traj = JointTrajectory(joint_names=["j1"], points=[
        JointTrajectoryPoint(positions=[0.0], time_from_start=msgs.REGISTRY["builtin_interfaces/msg/Duration"](sec=1)),
        JointTrajectoryPoint(positions=[1.0])])
    d = to_dict(traj)
    assert d["points"][0]["time_from_start"] == {"sec": 1, "nanosec": 0}
    assert from_dict(JointTrajectory, d) == traj
    diag = DiagnosticArray(status=[DiagnosticStatus(level=1, name="motor", values=[KeyValue("t", "40")])])
    assert from_dict(DiagnosticArray, to_dict(diag)) == diag
    tf = TFMessage(transforms=[msgs.REGISTRY["geometry_msgs/msg/TransformStamped"](child_frame_id="x")])
    assert from_dict(TFMessage, to_dict(tf)) == tf


def test_from_dict_rejects_unknown_fields():
    with pytest.raises(KeyError, match="no field"):
        from_dict(Twist, {"linear": {"x": 1.0}, "angualr": {}})


def test_to_numpy_flattens_numeric_fields():
    ts = []
    for i in range(5):
        t = Twist()
        t.linear.x = float(i)
        t.angular.z = -float(i)
        ts.append(t)
    arr = to_numpy(ts)
    np.testing.assert_array_equal(arr["linear.x"], [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(arr["angular.z"], [0, -1, -2, -3, -4])
    assert arr["linear.x"].dtype == np.float64
    js = [JointState(position=[float(i), 2.0 * i]) for i in range(3)]
    a = to_numpy(js)
    assert a["position"].shape == (3, 2)
    np.testing.assert_array_equal(a["position"][:, 1], [0, 2, 4])
    stamped = [Odometry() for _ in range(2)]
    stamped[1].header.stamp = Time(sec=1, nanosec=500_000_000)
    np.testing.assert_allclose(to_numpy(stamped)["header.stamp"], [0.0, 1.5])
    m = Float64MultiArray(data=[1.0, 2.0, 3.0])
    assert to_numpy([m])["data"].shape == (1, 3)


def test_custom_type_with_decorator_and_methods():
    @message("robocourse_test_msgs/msg/WheelSpeeds", """
    std_msgs/Header header
    float64 left   # rad/s
    float64 right 2.5
    uint8 MODE_IDLE=0
    uint8 mode
    """)
    class WheelSpeeds:
        def mean(self):
            return 0.5 * (self.left + self.right)

    w = WheelSpeeds(left=1.5)
    assert w.right == 2.5 and w.mean() == 2.0 and WheelSpeeds.MODE_IDLE == 0
    assert get_message_type("robocourse_test_msgs/WheelSpeeds") is WheelSpeeds
    text = full_definition(WheelSpeeds)
    enc = serialize_dynamic("robocourse_test_msgs/WheelSpeeds", text)["robocourse_test_msgs/WheelSpeeds"]
    dec = generate_dynamic("robocourse_test_msgs/WheelSpeeds", text)["robocourse_test_msgs/WheelSpeeds"]
    assert from_dict(WheelSpeeds, dec(enc(w))) == w
    with pytest.raises(AttributeError):
        w.lfet = 3.0   # slotted: typos in field names fail loudly


@pytest.mark.parametrize("name,text,match", [
    ("Bad/msg/X", "int32 a", "must look like"),
    ("pkg/msg/lower", "int32 a", "must look like"),
    ("pkg/msg/X", "int32", "expected"),
    ("pkg/msg/X", "int32 BadName", "lower_snake_case"),
    ("pkg/msg/X", "int8 a 300", "out of range"),
    ("pkg/msg/X", "int32[ a", "malformed type"),
    ("pkg/msg/X", "NoSuchType a", "unknown message type"),
    ("pkg/msg/X", "bool a maybe", "true/false"),
])
def test_malformed_definitions_are_rejected(name, text, match):
    with pytest.raises(MessageDefinitionError, match=match):
        msgs.make_message(name, text)


def test_redefining_a_type_differently_is_an_error():
    with pytest.raises(MessageDefinitionError, match="already registered"):
        msgs.make_message("geometry_msgs/msg/Twist", "float64 x")


def test_check_message_names_the_bad_field():
    # assignments are checked when they happen; check_message catches in-place changes
    js = JointState(name=["a"])
    js.name.append(3)
    with pytest.raises(TypeError, match=r"JointState\.name: The 'name' field must be a set or sequence"):
        check_message(js)
    p = Pose()
    check_message(p)
    o = Odometry()
    with pytest.raises(ValueError, match="must be a set or sequence with length 36"):
        o.pose.covariance = [0.0] * 35
    with pytest.raises(ValueError, match=r"The 'status' field must be an integer in \[-128, 127\]"):
        GoalStatus(status=200)
