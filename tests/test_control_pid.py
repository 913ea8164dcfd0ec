"""PidController, alone (topic references) and as a chain (position PID -> velocity PID -> hardware).

Scenarios from ros2_controllers' pid_controller/test/test_pid_controller.cpp (configure, exported
interfaces, feed-forward off/on, angle wraparound off/on, chained mode ignores the subscriber,
reference message -> state message) on mock_components/GenericSystem, and the chaining rules
of ros2_control with two real PidControllers. Upstream test names are given where known.
"""

from __future__ import annotations

import math

import pytest
from control_robots import generic, joint, urdf

from robocourse.control import STRICT, ControllerManager, return_type
from robocourse.control.log import LogSink
from robocourse.control.msgs import MultiDOFCommand, MultiDOFStateStamped

PID = "pid_controller/PidController"


def cm_for(controllers: dict, hw_params=None, commands=("velocity",), states=("position", "velocity"), initial=1.1):
    lines = ["controller_manager:", "  ros__parameters:", "    update_rate: 100"]
    for name in controllers:
        lines += [f"    {name}:", f"      type: {PID}"]
    for name, params in controllers.items():
        lines += [f"{name}:", "  ros__parameters:"] + [f"    {k}: {v}" for k, v in params.items()]
    hw = generic(params=hw_params or {}, body=joint("joint1", commands, states, {"position": initial}))
    cm = ControllerManager(urdf(hw, joints=("joint1",)), params="\n".join(lines) + "\n", log=LogSink(log_to_stderr=False))
    for name in controllers:
        cm.load_and_configure(name)
    return cm


def pid_params(**gains):
    p = {"dof_names": "[joint1]", "command_interface": "velocity", "reference_and_state_interfaces": "[position]"}
    p.update({f"gains.joint1.{k}": v for k, v in gains.items()})
    return p


def velocity_command(cm):
    return cm.rm.components["GenericSystem2dof"].impl.get_command("joint1/velocity")


def set_reference(cm, values, values_dot=()):
    cm.controllers["pid"].c._on_reference(MultiDOFCommand(dof_names=["joint1"], values=list(values),
                                                          values_dot=list(values_dot)))


def test_all_parameters_set_configure_success_and_check_exported_interfaces():
    # mirrors pid_controller/test/test_pid_controller.cpp: TEST_F(PidControllerTest, all_parameters_set_configure_success) and
    # TEST_F(PidControllerTest, check_exported_interfaces)
    cm = cm_for({"pid": pid_params(p="1.0")})
    c = cm.controllers["pid"].c
    assert c.command_interface_configuration().names == ["joint1/velocity"]
    assert c.state_interface_configuration().names == ["joint1/position"]
    assert c.reference_interface_names == ["pid/joint1/position"]


@pytest.mark.parametrize("key, value, message", [
    ("reference_and_state_interfaces", "[position, velocity, effort]",
     "Length of parameter 'reference_and_state_interfaces' is '3' but must be less than '3'"),
    ("dof_names", "[]", "Parameter 'dof_names' cannot be empty"),
    ("gains.joint1.i_clamp", "-1.0", "must be greater than or equal to '0'"),
])
def test_invalid_parameters_are_refused(key, value, message):
    # no upstream counterpart: pid_controller/test/test_pid_controller.cpp has no invalid-parameter case (the validators come from the parameter schema)
    p = pid_params()
    p[key] = value
    with pytest.raises(RuntimeError):
        cm_for({"pid": p})


def test_update_logic_feedforward_off():
    # mirrors pid_controller/test/test_pid_controller.cpp: TEST_F(PidControllerTest, test_update_logic_feedforward_off) (older versions;
    # the newest file has test_update_logic_zero_feedforward_gain)
    cm = cm_for({"pid": pid_params(p="1.0")})
    cm.switch_controller(["pid"], [], STRICT)
    set_reference(cm, [5.0])
    cm.step(1)
    assert velocity_command(cm) == pytest.approx(5.0 - 1.1)


def test_update_logic_feedforward_on():
    # mirrors pid_controller/test/test_pid_controller.cpp: TEST_F(PidControllerTest, test_update_logic_feedforward_on) (older versions;
    # the newest file has test_update_chained_non_zero_feedforward_gain)
    cm = cm_for({"pid": pid_params(p="1.0", feedforward_gain="1.0")})
    cm.switch_controller(["pid"], [], STRICT)
    set_reference(cm, [5.0])
    cm.step(1)
    assert velocity_command(cm) == pytest.approx(5.0 - 1.1 + 5.0)


@pytest.mark.parametrize("wrap, expected", [("false", 6.0), ("true", 6.0 - 2 * math.pi)])
def test_update_logic_angle_wraparound(wrap, expected):
    # mirrors pid_controller/test/test_pid_controller.cpp: TEST_F(PidControllerTest, test_update_logic_angle_wraparound_off) and
    # TEST_F(PidControllerTest, test_update_logic_angle_wraparound_on)
    cm = cm_for({"pid": pid_params(p="1.0", angle_wraparound=wrap)}, initial=-3.0)
    cm.switch_controller(["pid"], [], STRICT)
    set_reference(cm, [3.0])
    cm.step(1)
    assert velocity_command(cm) == pytest.approx(expected)


def test_integral_and_derivative_terms():
    # no upstream counterpart: pid_controller/test/test_pid_controller.cpp checks a first update only (integral term zero)
    cm = cm_for({"pid": pid_params(i="2.0", d="0.5")})
    cm.switch_controller(["pid"], [], STRICT)
    set_reference(cm, [5.0])
    cm.step(1)
    assert velocity_command(cm) == pytest.approx(2.0 * 0.01 * 3.9)        # no derivative on the first update
    set_reference(cm, [6.0])
    cm.step(1)
    assert velocity_command(cm) == pytest.approx(2.0 * 0.01 * (3.9 + 4.9) + 0.5 * (4.9 - 3.9) / 0.01)


def test_velocity_reference_drives_the_derivative_term():
    # no upstream counterpart: not found in pid_controller/test/test_pid_controller.cpp
    p = pid_params(d="2.0")
    p["reference_and_state_interfaces"] = "[position, velocity]"
    cm = cm_for({"pid": p})
    cm.switch_controller(["pid"], [], STRICT)
    set_reference(cm, [1.1], [0.25])
    cm.step(1)
    assert velocity_command(cm) == pytest.approx(2.0 * 0.25)      # the velocity state is 0 before the first command


def test_nan_reference_writes_no_command():
    # no upstream counterpart: not found in pid_controller/test/test_pid_controller.cpp
    cm = cm_for({"pid": pid_params(p="1.0")})
    cm.switch_controller(["pid"], [], STRICT)
    cm.step(3)
    assert math.isnan(velocity_command(cm))


def test_receive_message_and_publish_updated_status():
    # mirrors pid_controller/test/test_pid_controller.cpp: TEST_F(PidControllerTest, receive_message_and_publish_updated_status)
    cm = cm_for({"pid": pid_params(p="2.0")})
    got = []
    node = cm.context.create_node("probe")
    node.create_subscription(MultiDOFStateStamped, "/pid/controller_state", got.append, 10)
    pub = node.create_publisher(MultiDOFCommand, "/pid/reference", 10)
    cm.executor.add_node(node)
    cm.switch_controller(["pid"], [], STRICT)
    pub.publish(MultiDOFCommand(dof_names=["joint1"], values=[2.0], values_dot=[]))
    cm.step(2)
    s = got[-1].dof_states[0]
    assert s.name == "joint1"
    assert (s.reference, s.feedback, s.error, s.output, s.time_step) == pytest.approx((2.0, 1.1, 0.9, 1.8, 0.01))


# --- the chain: position PID -> velocity PID -> acceleration command (double integrator) ------------------------
CASCADE = {
    "vel_pid": {"dof_names": "[joint1]", "command_interface": "acceleration",
                "reference_and_state_interfaces": "[velocity]", "gains.joint1.p": "20.0"},
    "pos_pid": {"dof_names": "[vel_pid/joint1]", "reference_and_state_dof_names": "[joint1]",
                "command_interface": "velocity", "reference_and_state_interfaces": "[position]",
                "gains.vel_pid/joint1.p": "4.0"},
}


def cascade():
    return cm_for(CASCADE, hw_params={"calculate_dynamics": "true"}, commands=("acceleration",),
                  states=("position", "velocity", "acceleration"), initial=0.0)


def test_pid_chain_activation_order_and_tracking():
    # mirrors ros2_control controller_manager/test/test_controllers_chaining_with_controller_manager.cpp:
    # TEST_P(TestControllerChainingWithControllerManager, test_chained_controllers), with real PIDs
    cm = cascade()
    assert cm.ordered_controllers() == ["pos_pid", "vel_pid"]
    assert cm.switch_controller(["pos_pid"], [], STRICT) == return_type.ERROR
    assert cm.switch_controller(["vel_pid", "pos_pid"], [], STRICT) == return_type.OK
    assert cm.controllers["vel_pid"].c.is_in_chained_mode()
    cm.controllers["pos_pid"].c._on_reference(MultiDOFCommand(values=[1.0]))
    cm.spin_for(4.0)
    assert cm.rm.value("joint1/position") == pytest.approx(1.0, abs=1e-3)
    assert cm.controllers["vel_pid"].c.reference_interfaces[0] == pytest.approx(0.0, abs=5e-3)
    assert cm.switch_controller([], ["vel_pid"], STRICT) == return_type.ERROR
    assert "since its preceding controller 'pos_pid' is active" in cm.last_switch_message
    assert cm.switch_controller([], ["vel_pid", "pos_pid"], STRICT) == return_type.OK


def test_chained_mode_ignores_the_subscriber():
    # mirrors pid_controller/test/test_pid_controller.cpp: TEST_F(PidControllerTest, test_update_logic_chainable_not_use_subscriber_update)
    cm = cascade()
    cm.switch_controller(["vel_pid", "pos_pid"], [], STRICT)
    cm.controllers["vel_pid"].c._on_reference(MultiDOFCommand(values=[100.0]))
    cm.controllers["pos_pid"].c._on_reference(MultiDOFCommand(values=[0.0]))
    cm.step(5)
    assert cm.controllers["vel_pid"].c.reference_interfaces[0] == pytest.approx(0.0, abs=1e-9)
