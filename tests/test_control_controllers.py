"""ForwardCommandController (+ JointGroup variants) and JointStateBroadcaster on the bus.

Scenarios from ros2_controllers' test_forward_command_controller.cpp,
test_multi_interface_forward_command_controller.cpp, test_joint_group_effort_controller.cpp and
test_joint_state_broadcaster.cpp.
"""

from __future__ import annotations

import math

import pytest
from control_robots import STANDARD_2DOF, generic, joint, urdf

from robocourse.control import ACTIVE, INACTIVE, STRICT, ControllerManager, return_type
from robocourse.control.log import LogSink
from robocourse.control.msgs import DynamicJointState
from robocourse.msgs.sensor_msgs import JointState
from robocourse.msgs.std_msgs import Float64MultiArray

EFFORT_BODY = (joint("joint1", ("position", "effort"), ("position", "velocity", "effort"),
                     {"position": 1.1, "effort": 7.5})
               + joint("joint2", ("position", "effort"), ("position", "velocity"), {"position": 2.2})
               + '<sensor name="ft"><state_interface name="force.z"/></sensor>')


def cm_with(controllers: dict, body=STANDARD_2DOF) -> ControllerManager:
    lines = ["controller_manager:", "  ros__parameters:", "    update_rate: 100"]
    for name, (ctype, _) in controllers.items():
        lines += [f"    {name}:", f"      type: {ctype}"]
    for name, (_, params) in controllers.items():
        if params:
            lines += [f"{name}:", "  ros__parameters:"] + [f"    {k}: {v}" for k, v in params.items()]
    cm = ControllerManager(urdf(generic(body=body)), params="\n".join(lines) + "\n", log=LogSink(log_to_stderr=False))
    for name in controllers:
        cm.load_and_configure(name)
    return cm


def publisher(cm, topic):
    node = cm.context.create_node("test_commander")
    cm.executor.add_node(node)
    return node.create_publisher(Float64MultiArray, topic, 10)


FWD = {"fwd": ("forward_command_controller/ForwardCommandController",
               {"joints": "[joint1, joint2]", "interface_name": "position"})}
FWD_GROUP = {"fwd": ("position_controllers/JointGroupPositionController", {"joints": "[joint1, joint2]"})}


def command(cm, name):
    return cm.rm.components["GenericSystem2dof"].impl.get_command(name)


def test_forward_command_writes_the_latest_command_and_nothing_before_the_first():
    # mirrors forward_command_controller/test/test_forward_command_controller.cpp: TEST_F(ForwardCommandControllerTest, NoCommandCheckTest) and CommandCallbackTest
    cm = cm_with(FWD)
    assert cm.switch_controller(["fwd"], [], STRICT) == return_type.OK
    cm.step(2)
    assert math.isnan(command(cm, "joint1/position"))
    pub = publisher(cm, "/fwd/commands")
    pub.publish(Float64MultiArray(data=[10.0, 20.0]))
    cm.step(1)
    assert (command(cm, "joint1/position"), command(cm, "joint2/position")) == (10.0, 20.0)
    cm.step(1)
    assert cm.rm.value("joint2/position") == 20.0


def test_forward_command_drops_non_finite_messages():
    # no upstream counterpart: test_forward_command_controller.cpp has no non-finite command case
    cm = cm_with(FWD)
    cm.switch_controller(["fwd"], [], STRICT)
    pub = publisher(cm, "/fwd/commands")
    pub.publish(Float64MultiArray(data=[1.0, 2.0]))
    cm.step(1)
    pub.publish(Float64MultiArray(data=[math.nan, 3.0]))
    pub.publish(Float64MultiArray(data=[math.inf, 3.0]))
    cm.step(1)
    assert (command(cm, "joint1/position"), command(cm, "joint2/position")) == (1.0, 2.0)
    assert cm.controllers["fwd"].c.dropped_non_finite == 2
    assert cm.log.count("command with a non-finite value dropped") == 1


def test_forward_command_wrong_size_returns_error_and_the_manager_deactivates_it():
    # mirrors forward_command_controller/test/test_forward_command_controller.cpp: TEST_F(ForwardCommandControllerTest, WrongCommandCheckTest);
    # the manager deactivating it on ERROR has no counterpart in that file
    cm = cm_with(FWD)
    cm.switch_controller(["fwd"], [], STRICT)
    publisher(cm, "/fwd/commands").publish(Float64MultiArray(data=[1.0, 2.0, 3.0]))
    cm.step(2)
    assert cm.controllers["fwd"].state == INACTIVE
    assert cm.log.count("command size (3) does not match number of interfaces (2)") == 1


@pytest.mark.parametrize("params, message", [
    ({"joints": "[]", "interface_name": "position"}, "'joints' parameter was empty"),
    ({"joints": "[joint1]", "interface_name": '""'}, "'interface_name' parameter was empty"),
])
def test_forward_command_configure_fails_on_empty_parameters(params, message):
    # mirrors forward_command_controller/test/test_forward_command_controller.cpp: TEST_F(ForwardCommandControllerTest, JointsParameterIsEmpty) and InterfaceParameterEmpty
    ctype = "forward_command_controller/ForwardCommandController"
    with pytest.raises(RuntimeError):
        cm_with({"fwd": (ctype, params)})
    cm = ControllerManager(urdf(generic(body=STANDARD_2DOF)), log=LogSink(log_to_stderr=False), params=(
        f"controller_manager:\n  ros__parameters:\n    fwd:\n      type: {ctype}\n"
        "fwd:\n  ros__parameters:\n" + "".join(f"    {k}: {v}\n" for k, v in params.items())))
    cm.load_controller("fwd")
    assert cm.configure_controller("fwd") == return_type.ERROR and cm.log.count(message) == 1


def test_multi_interface_forward_command_controller():
    # mirrors forward_command_controller/test/test_multi_interface_forward_command_controller.cpp: TEST_F(MultiInterfaceForwardCommandControllerTest, CommandSuccessTest)
    cm = cm_with({"multi": ("forward_command_controller/MultiInterfaceForwardCommandController",
                            {"joint": "joint1", "interface_names": "[position, velocity]"})})
    cm.switch_controller(["multi"], [], STRICT)
    cm.controllers["multi"].c.set_command([0.3, -0.4])
    cm.step(2)
    assert (cm.rm.value("joint1/position"), cm.rm.value("joint1/velocity")) == (0.3, -0.4)


def test_joint_group_effort_controller_zeroes_commands_on_deactivate():
    # mirrors effort_controllers/test/test_joint_group_effort_controller.cpp: TEST_F(JointGroupEffortControllerTest, StopJointsOnDeactivateTest)
    cm = cm_with({"eff": ("effort_controllers/JointGroupEffortController", {"joints": "[joint1, joint2]"})},
                 body=EFFORT_BODY)
    cm.switch_controller(["eff"], [], STRICT)
    cm.controllers["eff"].c.set_command([5.0, -5.0])
    cm.step(1)
    assert command(cm, "joint1/effort") == 5.0
    cm.switch_controller([], ["eff"], STRICT)
    assert (command(cm, "joint1/effort"), command(cm, "joint2/effort")) == (0.0, 0.0)


def listen(cm, topic="/joint_states"):
    got = []
    node = cm.context.create_node("test_listener")
    node.create_subscription(JointState, topic, got.append, 10)
    cm.executor.add_node(node)
    return got


JSB = "joint_state_broadcaster/JointStateBroadcaster"


def test_joint_state_broadcaster_all_interfaces_nan_for_missing_sorted_joints():
    # mirrors joint_state_broadcaster/test/test_joint_state_broadcaster.cpp: TEST_F(JointStateBroadcasterTest, JointStatePublishTest) and
    # TEST_F(JointStateBroadcasterTest, ActivateTestTwoJointTwoInterfacesOneMissing) (NaN for a missing interface)
    cm = cm_with({"jsb": (JSB, {})}, body=EFFORT_BODY)
    got = listen(cm)
    assert cm.switch_controller(["jsb"], [], STRICT) == return_type.OK
    cm.step(3)
    assert len(got) == 3
    msg = got[-1]
    assert msg.name == ["joint1", "joint2"]                       # the sensor has no position/velocity/effort
    assert msg.position.tolist() == [1.1, 2.2] and msg.velocity.tolist() == [0.0, 0.0]
    assert msg.effort[0] == 7.5 and math.isnan(msg.effort[1])     # joint2 has no effort state
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (0, 30_000_000, "base_link")


def test_dynamic_joint_states_carry_every_state_interface_with_its_value():
    # mirrors joint_state_broadcaster/test/test_joint_state_broadcaster.cpp:
    # TEST_F(JointStateBroadcasterTest, DynamicJointStatePublishTest)
    cm = cm_with({**FWD_GROUP, "jsb": (JSB, {})}, body=EFFORT_BODY)
    dynamic = []
    node = cm.context.create_node("dynamic_listener")
    node.create_subscription(DynamicJointState, "/dynamic_joint_states", dynamic.append, 10)
    cm.executor.add_node(node)
    assert cm.switch_controller(["fwd", "jsb"], [], STRICT) == return_type.OK
    cm.controllers["fwd"].c.set_command([0.25, -0.5])
    cm.step(3)
    msg = dynamic[-1]
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (0, 30_000_000)
    # every joint and sensor of the hardware, each with exactly its own state interfaces: no NaN padding
    # (joint2 has no effort state, the sensor only force.z); joints and interfaces sorted by name
    assert msg.joint_names == ["ft", "joint1", "joint2"]
    assert [list(v.interface_names) for v in msg.interface_values] == [
        ["force.z"], ["effort", "position", "velocity"], ["position", "velocity"]]
    got = {f"{j}/{i}": x for j, v in zip(msg.joint_names, msg.interface_values)
           for i, x in zip(v.interface_names, v.values)}
    assert sorted(got) == sorted(cm.rm.state_interface_keys())
    assert got == {k: cm.rm.value(k) for k in got}
    assert (got["joint1/position"], got["joint2/position"], got["joint1/effort"]) == (0.25, -0.5, 7.5)


def test_joint_state_broadcaster_joints_order_extra_joints_local_topic():
    # mirrors joint_state_broadcaster/test/test_joint_state_broadcaster.cpp: TEST_F(JointStateBroadcasterTest, ExtraJointStatePublishTest),
    # JointStatePublishTestLocalTopic and ActivateTestOneJointTwoInterfaces
    params = {"joints": "[joint2, joint1]", "interfaces": "[position, velocity]", "extra_joints": "[gripper]",
              "use_local_topics": "true"}
    cm = cm_with({"jsb": (JSB, params)}, body=EFFORT_BODY)
    got = listen(cm, "/jsb/joint_states")
    assert cm.switch_controller(["jsb"], [], STRICT) == return_type.OK
    cm.step(1)
    msg = got[-1]
    assert msg.name == ["joint2", "joint1", "gripper"]
    assert msg.position.tolist() == [2.2, 1.1, 0.0] and math.isnan(msg.effort[0]) and msg.effort[2] == 0.0


def test_joint_state_broadcaster_map_interface_to_joint_state():
    # mirrors joint_state_broadcaster/test/test_joint_state_broadcaster.cpp: TEST_F(JointStateBroadcasterTest, TestCustomInterfaceMappingUpdate)
    params = {"joints": "[joint1]", "interfaces": "[effort]", "map_interface_to_joint_state.position": "effort"}
    cm = cm_with({"jsb": (JSB, params)}, body=EFFORT_BODY)
    got = listen(cm)
    cm.switch_controller(["jsb"], [], STRICT)
    cm.step(1)
    assert got[-1].position.tolist() == [7.5] and math.isnan(got[-1].effort[0])


def test_joint_state_broadcaster_needs_joints_and_interfaces_together():
    # mirrors joint_state_broadcaster/test/test_joint_state_broadcaster.cpp: TEST_F(JointStateBroadcasterTest, ActivateTestWithoutInterfacesParameter), with a
    # difference: upstream warns and falls back to all interfaces; robocourse refuses at configure
    cm = ControllerManager(urdf(generic(body=EFFORT_BODY)), log=LogSink(log_to_stderr=False), params=(
        f"controller_manager:\n  ros__parameters:\n    jsb:\n      type: {JSB}\n"
        "jsb:\n  ros__parameters:\n    joints: [joint1]\n"))
    cm.load_controller("jsb")
    assert cm.configure_controller("jsb") == return_type.ERROR
    assert cm.log.count("'joints' and 'interfaces' parameters have to be both specified or both empty") == 1


def test_broadcaster_and_forwarder_together_close_the_loop():
    # no upstream counterpart: two controllers under one manager (upstream tests each controller alone)
    cm = cm_with({**FWD, "jsb": (JSB, {})})
    got = listen(cm)
    cm.switch_controller(["fwd", "jsb"], [], STRICT)
    cm.controllers["fwd"].c.set_command([0.5, -0.5])
    cm.step(2)
    assert got[-1].position.tolist() == [0.5, -0.5]
    assert {c.name: c.state for c in cm.list_controllers()} == {"fwd": "active", "jsb": "active"}
    assert cm.controllers["jsb"].state == ACTIVE
