"""RRBot wired as two ActuatorInterfaces plus an external SensorInterface (variant "modular_fts").

Mirrors ros2_control_demos' example 6 (RRBotModularJoint, one actuator per joint) and example 5
(ExternalRRBotForceTorqueSensorHardware); upstream checks these only in launch tests
(example_5/test/test_rrbot_system_with_external_sensor_launch.py, example_6/test/
test_rrbot_modular_actuators_launch.py: the components come up active and the controllers run), so
the scenarios here have no upstream unit test counterpart except where a docstring names one.
"""

from __future__ import annotations

import numpy as np
import pytest
from control_robots import joint, urdf

from robocourse.control import (
    ACTIVE,
    INACTIVE,
    STRICT,
    UNCONFIGURED,
    ControllerInterface,
    InterfaceConfiguration,
    ResourceError,
    ResourceManager,
    URDFError,
    interface_configuration_type,
    introspection,
    return_type,
)
from robocourse.control.bringup import bringup
from robocourse.control.hardware.modular import FT_INTERFACES, ForceTorqueSensor, RandomWrench
from robocourse.control.log import LogSink
from robocourse.control.msgs import DynamicJointState
from robocourse.msgs.std_msgs import Float64MultiArray
from robocourse.sim.robots import urdf_text

FTS = "ExternalRRBotFTSensor"
CONTROLLERS = ["joint_state_broadcaster", "forward_position_controller"]


def quiet():
    return LogSink(log_to_stderr=False)


def modular(spawn=CONTROLLERS, components=None):
    return bringup("rrbot", variant="modular_fts", spawn=spawn, components=components, log=quiet())


def test_variant_loads_two_actuators_and_a_sensor_with_their_types_and_interfaces():
    cm = modular(spawn=())
    comps = {c.name: c for c in introspection.list_hardware_components(cm, quiet=True)}
    assert {n: (c.type, c.plugin_name, c.state.label) for n, c in comps.items()} == {
        "RRBotModularJoint1": ("actuator", "robocourse/RRBotModularJoint", "active"),
        "RRBotModularJoint2": ("actuator", "robocourse/RRBotModularJoint", "active"),
        FTS: ("sensor", "robocourse/ForceTorqueSensor", "active")}
    assert [i.name for i in comps["RRBotModularJoint1"].command_interfaces] == ["joint1/position"]
    assert [i.name for i in comps["RRBotModularJoint2"].state_interfaces] == ["joint2/position"]
    assert comps[FTS].command_interfaces == []
    assert [i.name for i in comps[FTS].state_interfaces] == [f"tcp_fts_sensor/{i}" for i in FT_INTERFACES]
    assert cm.rm.components[FTS].impl.frame_id == "tool_link"


def test_the_system_rrbot_is_one_system_component_with_six_command_interfaces():
    comps = introspection.list_hardware_components(bringup("rrbot", log=quiet()), quiet=True)
    assert [(c.name, c.type, len(c.command_interfaces)) for c in comps] == [("RRBot", "system", 6)]


def test_forward_controller_drives_each_actuator_halfway_per_read():
    """Example 6's joint moves by (command - state) / slowdown per read(); slowdown 2 halves the gap."""
    cm = modular()
    node = cm.context.create_node("commander")
    cm.executor.add_node(node)
    node.create_publisher(Float64MultiArray, "/forward_position_controller/commands", 10).publish(
        Float64MultiArray(data=[0.5, -0.25]))
    cm.step(1)          # read (old command), update takes the message, write
    assert (cm.rm.value("joint1/position"), cm.rm.value("joint2/position")) == (0.0, 0.0)
    for k in range(1, 5):
        cm.step(1)
        gap = 0.5 ** k
        assert cm.rm.value("joint1/position") == pytest.approx(0.5 * (1 - gap), abs=1e-15)
        assert cm.rm.value("joint2/position") == pytest.approx(-0.25 * (1 - gap), abs=1e-15)
    assert [cm.rm.components[f"RRBotModularJoint{i}"].impl.writes for i in (1, 2)] == [5, 5]


def test_actuator_activation_copies_state_into_command():
    cm = modular(spawn=())
    impl = cm.rm.components["RRBotModularJoint1"].impl
    impl.set_command("joint1/position", 0.8)
    cm.step(3)
    moved = impl.get_state("joint1/position")
    assert moved == pytest.approx(0.8 * (1 - 0.5 ** 3))
    cm.set_hardware_component_state("RRBotModularJoint1", "inactive")
    impl.set_command("joint1/position", -1.0)          # a stale command left over
    cm.set_hardware_component_state("RRBotModularJoint1", "active")
    assert impl.get_command("joint1/position") == moved
    cm.step(2)
    assert impl.get_state("joint1/position") == moved   # no jump


def listen_dynamic(cm):
    got = []
    node = cm.context.create_node("listener")
    node.create_subscription(DynamicJointState, "/dynamic_joint_states", got.append, 10)
    cm.executor.add_node(node)
    return got


def test_broadcaster_publishes_the_sensor_values_read_from_its_source():
    def source(t):
        return (1.0 + t, 2.0, 3.0, 0.1, 0.2, 0.3 * t)

    cm = modular(components={FTS: ForceTorqueSensor(source)})
    got = listen_dynamic(cm)
    cm.step(3)
    msg = got[-1]
    assert msg.joint_names == ["joint1", "joint2", "tcp_fts_sensor"]
    sensor = msg.interface_values[2]
    assert sensor.interface_names == list(FT_INTERFACES)
    t = 0.03          # the third cycle at 100 Hz (read and broadcast in the same cycle)
    assert list(sensor.values) == pytest.approx([1.0 + t, 2.0, 3.0, 0.1, 0.2, 0.3 * t], abs=1e-12)


def test_sensor_without_a_source_reads_the_demos_bounded_random_walk():
    cm = modular(spawn=())
    cm.step(20)
    values = np.array([cm.rm.value(f"tcp_fts_sensor/{i}") for i in FT_INTERFACES])
    again = RandomWrench(seed=0)
    for _ in range(20):
        expected = again(0.0)
    assert values.tolist() == expected.tolist()


def test_random_wrench_steps_at_most_max_change_and_stays_in_range():
    w = RandomWrench(ranges=(1.0, 1.0, 1.0, 0.5, 0.5, 0.5), max_change=0.3, seed=7)
    prev = np.zeros(6)
    for _ in range(200):
        now = w(0.0).copy()
        assert np.all(np.abs(now - prev) <= 0.3 + 1e-12)
        assert np.all(np.abs(now) <= [1.0, 1.0, 1.0, 0.5, 0.5, 0.5])
        prev = now
    assert RandomWrench(seed=3)(0.0).tolist() == RandomWrench(seed=3)(0.0).tolist()
    with pytest.raises(ValueError, match="ranges=.* must be 6 numbers >= 0"):
        RandomWrench(ranges=(1.0, 2.0))


class ClaimsSensor(ControllerInterface):
    """A controller that (wrongly) asks for a sensor value as a command interface."""

    def command_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL, ["tcp_fts_sensor/force.x"])

    def state_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.NONE)

    def update(self, time, period):
        return return_type.OK


def test_a_sensor_has_no_command_interfaces_and_claiming_one_is_refused_with_upstreams_wording():
    cm = modular(spawn=())
    assert cm.rm.components[FTS].command_keys == []
    with pytest.raises(ResourceError, match=r"^Command interface with 'tcp_fts_sensor/force.x' does not exist$"):
        cm.rm.claim_command_interface("tcp_fts_sensor/force.x")
    assert cm.load_controller("pusher", controller=ClaimsSensor()) is not None
    assert cm.configure_controller("pusher") == return_type.OK
    assert cm.switch_controller(["pusher"], [], STRICT) == return_type.ERROR
    assert ("Unable to activate controller 'pusher' since the command interface 'tcp_fts_sensor/force.x' is not "
            "available.") in cm.last_switch_message
    assert cm.controllers["pusher"].state == INACTIVE


def test_a_failing_sensor_deactivates_only_the_controllers_reading_it():
    """ros2_control test_controller_manager_hardware_error_handling.cpp's read-error scenario, on a sensor."""
    broken = {"now": False}

    def source(t):
        if broken["now"]:
            raise OSError("cable unplugged")
        return (0.0, 0.0, 9.81, 0.0, 0.0, 0.0)

    sensor = ForceTorqueSensor(source)
    cm = modular(components={FTS: sensor})
    cm.step(2)
    broken["now"] = True
    cm.step(1)
    assert sensor.read_errors == 1
    assert cm.rm.components[FTS].wrapper.state == UNCONFIGURED        # on_error SUCCESS -> unconfigured
    states = {n: s.state for n, s in cm.controllers.items()}
    assert states == {"joint_state_broadcaster": INACTIVE, "forward_position_controller": ACTIVE}
    assert not cm.rm.state_interface_is_available("tcp_fts_sensor/force.z")


def test_sensor_source_returning_the_wrong_count_is_a_read_error():
    sensor = ForceTorqueSensor(lambda t: (1.0, 2.0))
    cm = modular(spawn=(), components={FTS: sensor})
    cm.step(1)
    assert sensor.read_errors == 1 and cm.rm.components[FTS].wrapper.state == UNCONFIGURED


@pytest.mark.parametrize("edit, error, message", [
    (('<param name="slowdown">2.0</param>', '<param name="slowdown">0.5</param>'),
     "Failed to initialize hardware 'RRBotModularJoint1'",
     "<param name=\"slowdown\"> of 'RRBotModularJoint1' is '0.5'; it must be a number >= 1"),
    (('<state_interface name="position"/>', '<state_interface name="position"/><state_interface name="velocity"/>'),
     "robocourse/RRBotModularJoint has no state interface 'velocity' (joint 'joint1' of 'RRBotModularJoint1')", None),
    (('<state_interface name="torque.z"/>', '<state_interface name="temperature"/>'),
     "Failed to initialize hardware 'ExternalRRBotFTSensor'",
     "sensor 'tcp_fts_sensor' has state interfaces ['force.x', 'force.y', 'force.z', 'torque.x', 'torque.y', "
     "'temperature']; a force/torque sensor offers a non-empty subset of"),
])
def test_bad_descriptions_are_refused_with_the_rule(edit, error, message):
    text = urdf_text("rrbot", variant="modular_fts")
    assert edit[0] in text
    log = quiet()
    with pytest.raises((RuntimeError, URDFError)) as err:
        bringup(urdf=text.replace(edit[0], edit[1], 1), log=log)
    assert error in str(err.value)
    if message is not None:
        assert log.count(message) == 1


def test_urdf_variant_errors_name_the_rule():
    with pytest.raises(ValueError, match="unknown variant 'modular' of rrbot: its variants are \\['modular_fts'\\]"):
        urdf_text("rrbot", variant="modular")
    with pytest.raises(ValueError, match="variant='modular_fts' names its own plugins"):
        urdf_text("rrbot", plugin="robocourse/MujocoSystem", variant="modular_fts")
    text = urdf_text("rrbot", variant="modular_fts")
    assert text.count("<ros2_control ") == 3 and "mock_components/GenericSystem" not in text
    assert text.count('<joint name="joint1" type="continuous">') == 1      # the robot's links/joints kept


def test_actuator_refuses_a_second_joint():
    block = ('<ros2_control name="TwoJoints" type="actuator"><hardware><plugin>robocourse/RRBotModularJoint</plugin>'
             '</hardware>' + joint("joint1", ("position",), ("position",))
             + joint("joint2", ("position",), ("position",)) + "</ros2_control>")
    log = quiet()
    with pytest.raises(RuntimeError, match="Failed to initialize hardware 'TwoJoints'"):
        ResourceManager(urdf(block), log=log)
    assert log.count("'TwoJoints' is an actuator: it drives exactly one <joint> (got 2 joints") == 1


def test_source_must_be_callable():
    with pytest.raises(ValueError, match="source=3 must be a callable source"):
        ForceTorqueSensor(3)
    assert ForceTorqueSensor(lambda t: (0,) * 6).read_errors == 0


def test_mujoco_loads_the_modular_variant_with_the_same_bodies_and_joints():
    # the real client: MuJoCo ignores the <ros2_control> elements, so both wirings are one robot
    mujoco = pytest.importorskip("mujoco")
    from robocourse.sim.robots import urdf_text

    plain = mujoco.MjModel.from_xml_string(urdf_text("rrbot"))
    modular = mujoco.MjModel.from_xml_string(urdf_text("rrbot", variant="modular_fts"))
    assert [modular.joint(i).name for i in range(modular.njnt)] == ["joint1", "joint2"]
    assert (modular.nbody, modular.njnt, modular.nq) == (plain.nbody, plain.njnt, plain.nq)
    assert modular.body_mass.tolist() == plain.body_mass.tolist()
