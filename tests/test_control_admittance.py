"""AdmittanceController on the simulated UR5e (MuJoCo) and the JTC -> admittance chain.

Scenarios from ros2_controllers' admittance_controller/test/test_admittance_controller.cpp
(parameters, interfaces, activation, update, status, references) and the chaining rules of
ros2_control's test_controller_manager chaining tests, run with real controllers. Each test
names the upstream test it mirrors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robocourse.control import ACTIVE, INACTIVE, STRICT, ControllerManager, return_type
from robocourse.control.controllers.admittance_controller import rotation_vector
from robocourse.control.hardware.mujoco_system import MujocoSystem
from robocourse.control.log import LogSink
from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from robocourse.sim.robots import Kinematics, RobotSim, urdf_text

ARM = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
ADM = "admittance_controller/AdmittanceController"
JTC = "joint_trajectory_controller/JointTrajectoryController"


def adm_params(cog=(0.0, 0.0, 0.0), weight=0.0, **over):
    p = {"joints": f"[{', '.join(ARM)}]", "command_interfaces": "[position]",
         "state_interfaces": "[position, velocity]", "chainable_command_interfaces": "[position, velocity]",
         "ft_sensor.name": "tcp_fts_sensor", "ft_sensor.filter_coefficient": "0.1",
         "gravity_compensation.CoG.pos": f"[{cog[0]}, {cog[1]}, {cog[2]}]",
         "gravity_compensation.CoG.force": f"{weight}",
         "admittance.mass": "[5.0, 5.0, 5.0, 0.5, 0.5, 0.5]",
         "admittance.damping_ratio": "[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]",
         "admittance.stiffness": "[500.0, 500.0, 500.0, 50.0, 50.0, 50.0]"}
    p.update(over)
    return p


def params_text(controllers: dict, rate=500) -> str:
    lines = ["controller_manager:", "  ros__parameters:", f"    update_rate: {rate}"]
    for name, (ctype, _) in controllers.items():
        lines += [f"    {name}:", f"      type: {ctype}"]
    for name, (_, params) in controllers.items():
        lines += [f"{name}:", "  ros__parameters:"] + [f"    {k}: {v}" for k, v in params.items()]
    return "\n".join(lines) + "\n"


def arm_cm(controllers: dict, sim=None, configure=True) -> ControllerManager:
    sim = sim or RobotSim("ur5e")
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"), params=params_text(controllers),
                           log=LogSink(log_to_stderr=False), components={"UR5e": MujocoSystem(sim=sim)})
    for name in controllers:
        if configure:
            cm.load_and_configure(name)
    return cm


def q(cm):
    return np.array([cm.rm.value(f"{j}/position") for j in ARM])


def tip(qv):
    return KIN.calculate_link_transform(qv)[:3, 3]


KIN = Kinematics("ur5e")


def compensated(sim, **over):
    m, cog = sim.tool_mass_properties()
    return adm_params(cog=cog, weight=m * 9.81, **over)


# --- parameters and interfaces -----------------------------------------------------------------------------
@pytest.mark.parametrize("key, value, message", [
    ("admittance.mass", "[0.0, 5.0, 5.0, 0.5, 0.5, 0.5]",
     "Value '0' in parameter 'admittance.mass' must be within bounds '[0.0001, 1e+06]'"),
    ("admittance.mass", "[5.0, 5.0, 5.0, 0.5, 0.5]", "Length of parameter 'admittance.mass' is '5' but must be equal to '6'"),
    ("admittance.stiffness", "[-1.0, 500.0, 500.0, 50.0, 50.0, 50.0]",
     "Value '-1' in parameter 'admittance.stiffness' must be within bounds '[0, 1e+08]'"),
    ("admittance.stiffness", "[1.0e+9, 500.0, 500.0, 50.0, 50.0, 50.0]",
     "Value '1e+09' in parameter 'admittance.stiffness' must be within bounds '[0, 1e+08]'"),
    ("admittance.damping_ratio", "[-0.5, 1.0, 1.0, 1.0, 1.0, 1.0]",
     "Value '-0.5' in parameter 'admittance.damping_ratio' must be above lower bound of '0'"),
    ("admittance.selected_axes", "[true, true]", "Length of parameter 'admittance.selected_axes' is '2'"),
    ("ft_sensor.filter_coefficient", "1.5", "Parameter 'ft_sensor.filter_coefficient' with the value '1.5' must be within bounds '[0, 1]'"),
    ("command_interfaces", "[effort]", "Entry 'effort' in parameter 'command_interfaces' is not in the set '{position, velocity}'"),
])
def test_one_parameter_is_invalid(key, value, message):
    # mirrors admittance_controller/test/test_admittance_controller.cpp: TEST_P(AdmittanceControllerTestParameterizedInvalidParameters, invalid_parameters)
    # (named one_parameter_is_invalid in older versions of the file)
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"),
                           params=params_text({"adm": (ADM, adm_params(**{key: value}))}),
                           log=LogSink(log_to_stderr=False))
    assert cm.load_controller("adm") is None
    assert cm.log.count(f"Invalid value set during initialization for parameter '{key}': {message}") == 1


@pytest.mark.parametrize("missing", ["joints", "admittance.mass", "admittance.stiffness", "ft_sensor.name"])
def test_missing_of_parameters(missing):
    # mirrors admittance_controller/test/test_admittance_controller.cpp: TEST_P(AdmittanceControllerTestParameterizedMissingParameters,
    # one_init_parameter_is_missing) (one_parameter_is_missing in older versions)
    p = adm_params()
    del p[missing]
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"), params=params_text({"adm": (ADM, p)}),
                           log=LogSink(log_to_stderr=False))
    assert cm.load_controller("adm") is None
    assert cm.log.count(f"parameter '{missing}' is not initialized") == 1


def test_all_parameters_set_configure_success_and_check_interfaces():
    # mirrors admittance_controller/test/test_admittance_controller.cpp: TEST_F(AdmittanceControllerTest, all_parameters_set_configure_success)
    # and TEST_F(AdmittanceControllerTest, check_interfaces)
    cm = arm_cm({"adm": (ADM, adm_params())})
    c = cm.controllers["adm"].c
    assert c.command_interface_configuration().names == [f"{j}/position" for j in ARM]
    assert c.state_interface_configuration().names == (
        [f"{j}/position" for j in ARM] + [f"{j}/velocity" for j in ARM]
        + [f"tcp_fts_sensor/{i}" for i in ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")])
    assert c.reference_interface_names == ([f"adm/{j}/position" for j in ARM] + [f"adm/{j}/velocity" for j in ARM])
    assert c.rule.damping.tolist() == pytest.approx([2 * math.sqrt(5 * 500)] * 3 + [2 * math.sqrt(0.5 * 50)] * 3)
    assert all(math.isnan(v) for v in c.reference_interfaces)


def test_joints_must_be_the_kinematic_chain_in_order():
    # no upstream counterpart: robocourse checks the joints against its kinematics at configure
    p = adm_params(joints=f"[{', '.join(reversed(ARM))}]")
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"), params=params_text({"adm": (ADM, p)}),
                           log=LogSink(log_to_stderr=False))
    cm.load_controller("adm")
    assert cm.configure_controller("adm") == return_type.ERROR
    assert cm.log.count("must be the kinematic chain base_link -> tool0 in order") == 1


# --- update ----------------------------------------------------------------------------------------------
def test_update_success_gravity_compensated_tool_holds_still():
    # mirrors admittance_controller/test/test_admittance_controller.cpp: TEST_F(AdmittanceControllerTest, update_success) (zero external wrench)
    sim = RobotSim("ur5e", payload_mass=1.0)
    cm = arm_cm({"adm": (ADM, compensated(sim))}, sim=sim)
    start = tip(q(cm))
    assert cm.switch_controller(["adm"], [], STRICT) == return_type.OK
    cm.spin_for(1.0)
    assert np.linalg.norm(tip(q(cm)) - start) < 1e-4
    assert np.abs(cm.controllers["adm"].c.rule.wrench_world).max() < 1e-3


def test_uncompensated_tool_weight_sinks_the_tip_by_weight_over_stiffness():
    # no upstream counterpart: upstream's unit tests do not run the admittance law against a simulated arm
    sim = RobotSim("ur5e", payload_mass=1.0)
    m, _ = sim.tool_mass_properties()
    cm = arm_cm({"adm": (ADM, adm_params())}, sim=sim)
    start = tip(q(cm))
    cm.switch_controller(["adm"], [], STRICT)
    cm.spin_for(2.0)
    d = tip(q(cm)) - start
    assert d[2] == pytest.approx(-m * 9.81 / 500.0, rel=0.03)        # K x = F along world z
    assert abs(d[0]) < 1e-4 and abs(d[1]) < 1e-4


def test_stiffness_zero_axis_is_a_pure_damper_that_keeps_moving():
    # no upstream counterpart: upstream's unit tests do not run the admittance law against a simulated arm
    sim = RobotSim("ur5e", payload_mass=1.0)
    cm = arm_cm({"adm": (ADM, adm_params(**{"admittance.stiffness": "[500.0, 500.0, 0.0, 50.0, 50.0, 50.0]",
                                             "admittance.damping_ratio": "[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]"}))}, sim=sim)
    start = tip(q(cm))
    cm.switch_controller(["adm"], [], STRICT)
    cm.spin_for(0.5)
    z1 = tip(q(cm))[2] - start[2]
    cm.spin_for(0.5)
    z2 = tip(q(cm))[2] - start[2]
    assert z2 < z1 < -0.001        # D = 2 zeta sqrt(M * 0) = 0: only the joint damping resists


def test_selected_axes_false_keeps_the_axis_stiff():
    # no upstream counterpart: upstream's unit tests do not run the admittance law against a simulated arm
    sim = RobotSim("ur5e", payload_mass=1.0)
    cm = arm_cm({"adm": (ADM, adm_params(**{"admittance.selected_axes": "[true, true, false, true, true, true]"}))},
                sim=sim)
    start = tip(q(cm))
    cm.switch_controller(["adm"], [], STRICT)
    cm.spin_for(1.0)
    assert abs(tip(q(cm))[2] - start[2]) < 2e-4


def corrupt_sensor(cm, interface: str, value: float) -> None:
    """From now on the F/T sensor's ``interface`` reads ``value`` (a broken sensor cable)."""
    impl = cm.rm.components["UR5e"].impl
    slot = impl.state_index[f"tcp_fts_sensor/{interface}"]
    original = impl.read

    def bad_read(time, period):
        ret = original(time, period)
        impl.state_values[slot] = value
        return ret

    impl.read = bad_read


def test_non_finite_force_reading_returns_error_and_deactivates():
    # no upstream counterpart: test_admittance_controller.cpp has no non-finite sensor case
    sim = RobotSim("ur5e")
    cm = arm_cm({"adm": (ADM, compensated(sim))}, sim=sim)
    cm.switch_controller(["adm"], [], STRICT)
    cm.step(2)
    corrupt_sensor(cm, "force.z", math.nan)
    cm.step(2)
    assert cm.controllers["adm"].state == INACTIVE
    assert cm.log.count("force/torque reading") == 1


def test_receive_joint_references_when_not_chained():
    # mirrors admittance_controller/test/test_admittance_controller.cpp: TEST_F(AdmittanceControllerTest, receive_message_and_publish_updated_status)
    sim = RobotSim("ur5e")
    cm = arm_cm({"adm": (ADM, compensated(sim))}, sim=sim)
    cm.switch_controller(["adm"], [], STRICT)
    target = q(cm) + np.array([0.1, -0.1, 0.1, 0.0, 0.0, 0.1])
    node = cm.context.create_node("refs")
    cm.executor.add_node(node)
    node.create_publisher(JointTrajectoryPoint, "/adm/joint_references", 10).publish(
        JointTrajectoryPoint(positions=target.tolist(), velocities=[0.0] * 6))
    cm.spin_for(1.5)
    assert q(cm) == pytest.approx(target, abs=2e-3)


def test_rotation_vector_of_a_quarter_turn_about_z():
    # no upstream counterpart: a robocourse helper (upstream uses Eigen's AngleAxis)
    c, s = 0.0, 1.0
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    assert rotation_vector(R) == pytest.approx([0.0, 0.0, math.pi / 2])
    assert rotation_vector(np.diag([1.0, -1.0, -1.0])) == pytest.approx([math.pi, 0.0, 0.0])


# --- the chain: JTC -> admittance -> hardware -------------------------------------------------------------------
def chain_cm(sim=None):
    sim = sim or RobotSim("ur5e", payload_mass=0.5)
    jtc = {"joints": f"[{', '.join(ARM)}]", "command_joints": f"[{', '.join('adm/' + j for j in ARM)}]",
           "command_interfaces": "[position, velocity]", "state_interfaces": "[position, velocity]"}
    return arm_cm({"adm": (ADM, compensated(sim)), "jtc": (JTC, jtc)}, sim=sim), sim


def test_chain_jtc_preceding_admittance_activation_order_rules():
    # mirrors ros2_control controller_manager/test/test_controllers_chaining_with_controller_manager.cpp:
    # TEST_P(TestControllerChainingWithControllerManager, test_chained_controllers) and
    # test_chained_controllers_activation_error_handling: activation needs the followers active (or in the
    # same request); a follower cannot leave while its preceding controller stays active
    cm, _ = chain_cm()
    assert cm.ordered_controllers() == ["jtc", "adm"]
    assert cm.switch_controller(["jtc"], [], STRICT) == return_type.ERROR
    assert "since its following controller 'adm' is not active" in cm.last_switch_message
    assert cm.switch_controller(["adm", "jtc"], [], STRICT) == return_type.OK
    assert cm.controllers["adm"].c.is_in_chained_mode()
    assert cm.switch_controller([], ["adm"], STRICT) == return_type.ERROR
    assert "since its preceding controller 'jtc' is active" in cm.last_switch_message
    assert cm.switch_controller([], ["jtc"], STRICT) == return_type.OK
    assert not cm.controllers["adm"].c.is_in_chained_mode() and cm.controllers["adm"].state == ACTIVE
    assert cm.switch_controller([], ["adm"], STRICT) == return_type.OK


def test_chain_jtc_trajectory_through_admittance_reaches_the_goal():
    # no upstream counterpart: upstream chains test controllers, not a JTC into an admittance controller
    cm, sim = chain_cm()
    assert cm.switch_controller(["adm", "jtc"], [], STRICT) == return_type.OK
    cm.step(5)
    start = q(cm)
    goal = start + np.array([0.2, -0.1, 0.15, 0.0, 0.0, 0.3])
    node = cm.context.create_node("commander")
    cm.executor.add_node(node)
    msg = JointTrajectory(joint_names=list(ARM))
    pt = JointTrajectoryPoint(positions=goal.tolist(), velocities=[0.0] * 6)
    pt.time_from_start.sec = 1
    msg.points.append(pt)
    node.create_publisher(JointTrajectory, "/jtc/joint_trajectory", 10).publish(msg)
    cm.spin_for(0.5)
    mid = q(cm)
    assert np.all(np.abs(mid - start) > 0.2 * np.abs(goal - start) - 1e-9)
    cm.spin_for(1.5)
    assert q(cm) == pytest.approx(goal, abs=3e-3)
    refs = cm.controllers["adm"].c.reference_interfaces
    assert refs[:6] == pytest.approx(goal, abs=1e-9)     # the JTC writes the admittance's references


def test_hardware_error_deactivates_the_whole_chain():
    # mirrors ros2_control controller_manager/test/test_controllers_chaining_with_controller_manager.cpp:
    # TEST_P(TestControllerChainingWithControllerManager, test_chained_controllers_deactivation_error_handling):
    # an update() returning ERROR deactivates the controller and those preceding it
    cm, sim = chain_cm()
    cm.switch_controller(["adm", "jtc"], [], STRICT)
    cm.step(2)
    corrupt_sensor(cm, "torque.x", math.inf)
    cm.step(2)
    assert {n: s.state for n, s in cm.controllers.items()} == {"adm": INACTIVE, "jtc": INACTIVE}


def test_a_chain_with_a_cycle_is_rejected():
    # no upstream counterpart: not found in the chaining tests read
    sim = RobotSim("ur5e")
    a = compensated(sim, command_joints=f"[{', '.join('b/' + j for j in ARM)}]")
    b = compensated(sim, command_joints=f"[{', '.join('a/' + j for j in ARM)}]")
    cm = arm_cm({"a": (ADM, a), "b": (ADM, b)}, sim=sim)
    assert cm.switch_controller(["a", "b"], [], STRICT) == return_type.ERROR
    assert "part of a chaining cycle a -> b -> a" in cm.last_switch_message
    assert cm.controllers["a"].state == INACTIVE and cm.controllers["b"].state == INACTIVE


def test_robot_sim_infinite_command_is_refused_without_a_numpy_warning():
    # no upstream counterpart: a robocourse.sim check
    sim = RobotSim("ur5e")
    sim.commands[0] = math.inf
    with pytest.raises(ValueError, match="non-finite command"):
        sim.step()
