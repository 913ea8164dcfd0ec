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


# ------------------------------------------------------------------ rclpy-style field checks
# Reference: rosidl_generator_py's setters (e.g. "The 'data' field must be of type 'float'");
# robocourse adds the field path and a fix, and accepts an int in a float field (documented).

from robocourse.msgs import MessageFieldError, MessageFieldRangeError  # noqa: E402
from robocourse.msgs.std_msgs import Bool, Float32, Float64, Int32, Int64, String  # noqa: E402


@pytest.mark.parametrize("build, exc, text", [
    (lambda: Float64(data="x"), MessageFieldError, "The 'data' field must be of type 'float'"),
    (lambda: Int64(data=1.5), MessageFieldError, "The 'data' field must be of type 'int'"),
    (lambda: Int64(data=2**70), MessageFieldRangeError,
     "The 'data' field must be an integer in [-9223372036854775808, 9223372036854775807]"),
    (lambda: Int32(data=-(2**31) - 1), MessageFieldRangeError,
     "The 'data' field must be an integer in [-2147483648, 2147483647]"),
    (lambda: Twist(linear=5), MessageFieldError,
     "The 'linear' field must be a sub message of type 'Vector3'"),
    (lambda: String(data=3), MessageFieldError, "The 'data' field must be of type 'str'"),
    (lambda: Bool(data=1), MessageFieldError, "The 'data' field must be of type 'bool'"),
    (lambda: Float32(data=1e39), MessageFieldRangeError,
     "The 'data' field must be a float in [-3.402823466e+38, 3.402823466e+38]"),
    (lambda: JointState(position=["a"]), MessageFieldError,
     "The 'position' field must be a set or sequence and each value of type 'float'"),
    (lambda: JointState(name="abc"), MessageFieldError,
     "The 'name' field must be a set or sequence and each value of type 'str'"),
    (lambda: Odometry().pose.__setattr__("covariance", [0.0] * 35), MessageFieldRangeError,
     "The 'covariance' field must be a set or sequence with length 36"),
    (lambda: GoalStatus(status=200), MessageFieldRangeError,
     "The 'status' field must be an integer in [-128, 127]"),
])
def test_construction_checks_fields_with_rclpys_words_path_and_fix(build, exc, text):
    with pytest.raises(exc) as info:
        build()
    msg = str(info.value)
    assert msg.startswith(text)
    assert "Fix:" in msg
    assert isinstance(info.value, AssertionError)   # rclpy's setters raise AssertionError


def test_assignment_is_checked_and_names_the_type_and_field():
    m = Float64()
    with pytest.raises(TypeError, match=r"^The 'data' field must be of type 'float' "
                                        r"\(std_msgs/msg/Float64\.data got 'oops' of type str\)"):
        m.data = "oops"
    assert m.data == 0.0
    t = Twist()
    with pytest.raises(TypeError, match=r"geometry_msgs/msg/Vector3\.x got 'fast'"):
        t.linear.x = "fast"
    with pytest.raises(AttributeError, match="has no field 'dat'"):
        m.dat = 1.0


def test_float_fields_accept_int_and_store_float_unlike_rclpy():
    # documented difference: rclpy raises for Float64(data=1); here it is stored as 1.0
    m = Float64(data=1)
    assert m.data == 1.0 and type(m.data) is float
    v = Vector3(x=np.float32(0.5), y=np.int64(2))
    assert (v.x, v.y) == (0.5, 2.0) and type(v.y) is float
    with pytest.raises(TypeError):
        Float64(data=True)              # bool is not a number here, as in rclpy


def test_integer_fields_check_each_widths_range():
    for name, lo, hi in [("int8", -128, 127), ("uint8", 0, 255), ("int16", -32768, 32767),
                         ("uint16", 0, 65535), ("uint32", 0, 2**32 - 1), ("uint64", 0, 2**64 - 1)]:
        T = msgs.make_message(f"range_test/msg/{name.capitalize()}Holder", f"{name} v")
        assert T(v=lo).v == lo and T(v=hi).v == hi
        for bad in (lo - 1, hi + 1):
            with pytest.raises(MessageFieldRangeError, match=rf"\[{lo}, {hi}\]"):
                T(v=bad)
    assert Int64(data=np.int64(7)).data == 7


def test_sequences_are_array_array_and_fixed_arrays_numpy_as_in_rclpy():
    js = JointState(position=[1.0, 2.0], velocity=np.array([0.5, 0.25]))
    assert isinstance(js.position, array.array) and js.position.typecode == "d"
    assert js.velocity.tolist() == [0.5, 0.25] and js.velocity.typecode == "d"
    assert isinstance(Odometry().pose.covariance, np.ndarray)
    with pytest.raises(TypeError):
        js.position.append("x")         # array.array itself refuses a str
    seq = Fibonacci.Feedback(sequence=[1, 2, 3]).sequence
    assert seq.typecode == "i" and seq.tolist() == [1, 2, 3]
    with pytest.raises(MessageFieldRangeError):
        Fibonacci.Feedback(sequence=[2**40])


def test_bounded_strings_and_arrays_are_checked():
    T = msgs.make_message("bound_test/msg/Bounded", "string<=3 s\nfloat64[<=2] a\nint32[3] f")
    assert T(s="abc", a=[1.0, 2.0], f=[1, 2, 3]).f.dtype == np.int32
    with pytest.raises(MessageFieldRangeError, match="must be string with length not greater than 3"):
        T(s="abcd")
    with pytest.raises(MessageFieldRangeError, match="with length <= 2"):
        T(a=[1.0, 2.0, 3.0])
    with pytest.raises(MessageFieldRangeError, match="with length 3"):
        T(f=[1, 2])
    m = T(a=[1.0])
    m.a.extend([2.0, 3.0])              # grown in place past its bound: caught when copied
    with pytest.raises(MessageFieldRangeError, match="with length <= 2"):
        m._copy()


def test_generated_copy_is_deep_and_equal():
    js = JointState(name=["a"], position=[1.0])
    js.header.frame_id = "base"
    c = js._copy()
    assert c == js and c is not js
    assert c.position is not js.position and c.header is not js.header
    o = Odometry()
    oc = o._copy()
    assert oc == o and oc.pose.covariance is not o.pose.covariance
    oc.pose.covariance[0] = 1.0
    assert o.pose.covariance[0] == 0.0 and oc != o


def test_to_numpy_and_to_dict_keep_working_with_rclpy_arrays():
    msgs_ = [JointState(name=["a", "b"], position=[float(k), 2.0 * k]) for k in range(3)]
    arr = to_numpy(msgs_)
    assert arr["position"].shape == (3, 2) and arr["position"][2].tolist() == [2.0, 4.0]
    d = to_dict(Odometry())
    assert d["pose"]["covariance"] == [0.0] * 36 and type(d["pose"]["covariance"][0]) is float


@pytest.mark.parametrize("call, match", [
    (lambda: to_dict(3), "to_dict needs a message object"),
    (lambda: from_dict(dict, {}), "from_dict needs a message type"),
    (lambda: check_message("x"), "check_message needs a message object"),
    (lambda: to_numpy(Float64()), "to_numpy needs a list of messages"),
    (lambda: to_numpy([], msg_type=int), "to_numpy needs a message type"),
])
def test_msgs_entry_points_refuse_bad_arguments(call, match):
    with pytest.raises(TypeError, match=match):
        call()
