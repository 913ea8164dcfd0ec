"""robocourse.control.hardware: URDF parsing, component lifecycle, mock_components/GenericSystem.

GenericSystem tests name the upstream test (ros2_control:hardware_interface/test/mock_components/
test_generic_system.cpp) whose scenario and numbers they reproduce.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from control_robots import STANDARD_2DOF, generic, joint, urdf

from robocourse.control import (
    ACTIVE,
    FINALIZED,
    INACTIVE,
    UNCONFIGURED,
    CallbackReturn,
    ResourceError,
    ResourceManager,
    SensorInterface,
    SystemInterface,
    URDFError,
    parse_control_resources_from_urdf,
    register,
    return_type,
)
from robocourse.control.log import LogSink


def quiet() -> LogSink:
    return LogSink(log_to_stderr=False)


def rm_for(*blocks, joints=("joint1", "joint2"), **kw) -> ResourceManager:
    return ResourceManager(urdf(*blocks, joints=joints), log=quiet(), **kw)


# --- HardwareInfo from the URDF ---------------------------------------------------------------------------
def test_hardware_info_has_plugin_params_interfaces_limits_and_rate():
    text = urdf(generic("RRBot", {"example_param": "2.0"}, rw_rate=50, body=(
        '<joint name="joint1"><command_interface name="position"><param name="min">-1</param>'
        '<param name="max">1</param></command_interface><state_interface name="position">'
        '<param name="initial_value">0.5</param></state_interface></joint>'
        '<sensor name="tcp_fts"><state_interface name="force.x"/><param name="frame_id">tool0</param></sensor>'
        '<gpio name="flange_vacuum"><command_interface name="vacuum"/><state_interface name="vacuum"/></gpio>')),
        joints=("joint1",))
    (info,) = parse_control_resources_from_urdf(text)
    assert (info.name, info.type, info.hardware_plugin_name, info.rw_rate) == ("RRBot", "system",
                                                                              "mock_components/GenericSystem", 50)
    assert info.hardware_parameters == {"example_param": "2.0"}
    cmd = info.joints[0].command_interfaces[0]
    assert (cmd.name, cmd.min, cmd.max, cmd.initial_value) == ("position", "-1", "1", "")
    assert math.isnan(cmd.initial())
    assert info.joints[0].state_interfaces[0].initial() == 0.5
    assert info.sensors[0].name == "tcp_fts" and info.sensors[0].parameters == {"frame_id": "tool0"}
    assert [i.name for i in info.gpios[0].command_interfaces] == ["vacuum"]
    assert info.limits["joint1"].max_position == 3.14 and info.limits["joint1"].max_velocity == 2.0
    assert info.original_xml.startswith("<ros2_control")


def test_missing_plugin_gives_upstream_text_line_and_fix():
    text = urdf('<ros2_control name="RRBot" type="system">\n<hardware>\n</hardware>\n</ros2_control>')
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(text)
    assert err.value.text == "Missing <plugin> tag of <hardware> element for 'RRBot' in your URDF."
    assert err.value.line == text.splitlines().index("<hardware>") + 1
    assert "mock_components/GenericSystem" in err.value.fix


def test_unknown_plugin_gives_pluginlib_text_with_declared_types_and_line():
    text = urdf(generic(body=STANDARD_2DOF).replace("mock_components/GenericSystem", "my_robot/Nope"))
    with pytest.raises(URDFError) as err:
        ResourceManager(text, log=quiet())
    assert err.value.text.startswith("According to the loaded plugin descriptions the class my_robot/Nope with "
                                     "base class type hardware_interface::SystemInterface does not exist.")
    assert "mock_components/GenericSystem" in err.value.text
    assert err.value.line == 4 and "register(" in err.value.fix


def test_unknown_interface_for_a_plugin_that_declares_its_interfaces():
    class PositionOnly(SystemInterface):
        SUPPORTED_COMMAND_INTERFACES = ("position",)

    register("test_robot/PositionOnly", PositionOnly)
    body = joint("joint1", ("position",), ("position",)) + joint("joint2", ("torque",), ("position",))
    text = urdf(generic(body=body).replace("mock_components/GenericSystem", "test_robot/PositionOnly"))
    with pytest.raises(URDFError) as err:
        ResourceManager(text, log=quiet())
    assert err.value.text == "test_robot/PositionOnly has no command interface 'torque' (joint 'joint2' of 'GenericSystem2dof')"
    assert "['position']" in err.value.fix and err.value.line > 0


def test_duplicate_joint_in_one_component_names_both_lines():
    body = joint("joint1", ("position",), ("position",)) + "\n" + joint("joint1", ("velocity",), ("position",))
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(urdf(generic(body=body)))
    assert "Joint 'joint1' is declared twice" in err.value.text and "first on line" in err.value.text


def test_duplicate_command_interface_across_components():
    a = generic("A", body=joint("joint1", ("position",), ("position",)))
    b = generic("B", body=joint("joint1", ("position",), ("position",)))
    with pytest.raises(URDFError, match="command interface 'joint1/position' is exported by both 'A' and 'B'"):
        parse_control_resources_from_urdf(urdf(a, b))


def test_duplicate_urdf_joint_is_not_unique():
    text = urdf(generic(body=STANDARD_2DOF), joints=("joint1", "joint2", "joint1"))
    with pytest.raises(URDFError, match="joint 'joint1' is not unique"):
        parse_control_resources_from_urdf(text)


def test_malformed_xml_reports_the_line():
    text = urdf(generic(body=STANDARD_2DOF)).replace("</hardware>", "</hardwar>")
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(text)
    assert err.value.text == "invalid URDF passed in to robot parser: mismatched tag"
    assert err.value.line == 4


@pytest.mark.parametrize("text, message", [
    ("", "empty URDF passed to robot"),
    ("<sdf/>", "the robot tag is not root element in URDF or sdf tag is not root element in SDF"),
    ('<robot name="r"/>', "no 'ros2_control' tag found in the URDF"),
])
def test_parser_top_level_errors(text, message):
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(text)
    assert err.value.text == message


def test_invalid_tag_unknown_joint_and_bad_rw_rate():
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(urdf(generic(body=STANDARD_2DOF + "<actuator name='x'/>")))
    assert err.value.text == "invalid tag name 'actuator'"
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(urdf(generic(body=joint("elbow", ("position",), ("position",)))))
    assert err.value.text == "Joint 'elbow' not found in URDF"
    with pytest.raises(URDFError) as err:
        parse_control_resources_from_urdf(urdf(generic(body=STANDARD_2DOF, rw_rate=-5)))
    assert err.value.text == ('Could not parse rw_rate tag in "GenericSystem2dof". Got "-5", but expected a '
                              'positive integer.')


def test_mimic_joint_read_from_urdf_and_missing_mimic_target():
    mimic = '<mimic joint="joint1" multiplier="-2" offset="0.0"/>'
    (info,) = parse_control_resources_from_urdf(urdf(generic(body=STANDARD_2DOF), extra=mimic))
    assert info.joints[1].is_mimic and (info.mimic_joints[0].joint_index, info.mimic_joints[0].mimicked_joint_index,
                                        info.mimic_joints[0].multiplier) == (1, 0, -2.0)
    with pytest.raises(URDFError, match="Joint 'joint1' has no mimic information in the URDF"):
        parse_control_resources_from_urdf(urdf(generic(body=STANDARD_2DOF.replace(
            '<joint name="joint1">', '<joint name="joint1" mimic="true">'))))


# --- lifecycle, transition by transition -----------------------------------------------------------------
class Scripted(SystemInterface):
    """Returns what the test scripts for each callback; counts read/write calls."""

    def __init__(self, script=None):
        super().__init__()
        self.script = dict(script or {})
        self.calls: list[str] = []
        self.reads = self.writes = 0

    def _cb(self, name):
        self.calls.append(name)
        r = self.script.get(name, CallbackReturn.SUCCESS)
        if isinstance(r, Exception):
            raise r
        return r

    def on_configure(self, s): return self._cb("on_configure")
    def on_activate(self, s): return self._cb("on_activate")
    def on_deactivate(self, s): return self._cb("on_deactivate")
    def on_cleanup(self, s): return self._cb("on_cleanup")
    def on_shutdown(self, s): return self._cb("on_shutdown")
    def on_error(self, s): return self._cb("on_error")

    def read(self, time, period):
        self.reads += 1
        return self.script.get("read", return_type.OK)

    def write(self, time, period):
        self.writes += 1
        return self.script.get("write", return_type.OK)


def scripted_rm(script=None, activate=False):
    impl = Scripted(script)
    rm = ResourceManager(urdf(generic("S", body=STANDARD_2DOF)), components={"S": impl}, log=quiet(),
                         activate_all=activate)
    return rm, impl


@pytest.mark.parametrize("callback, result, start, target, end", [
    ("on_configure", CallbackReturn.SUCCESS, UNCONFIGURED, INACTIVE, INACTIVE),
    ("on_configure", CallbackReturn.FAILURE, UNCONFIGURED, INACTIVE, UNCONFIGURED),
    ("on_configure", CallbackReturn.ERROR, UNCONFIGURED, INACTIVE, UNCONFIGURED),   # on_error SUCCESS
    ("on_activate", CallbackReturn.SUCCESS, INACTIVE, ACTIVE, ACTIVE),
    ("on_activate", CallbackReturn.FAILURE, INACTIVE, ACTIVE, INACTIVE),
    ("on_activate", CallbackReturn.ERROR, INACTIVE, ACTIVE, UNCONFIGURED),
    ("on_deactivate", CallbackReturn.SUCCESS, ACTIVE, INACTIVE, INACTIVE),
    ("on_deactivate", CallbackReturn.FAILURE, ACTIVE, INACTIVE, ACTIVE),
    ("on_deactivate", CallbackReturn.ERROR, ACTIVE, INACTIVE, UNCONFIGURED),
    ("on_cleanup", CallbackReturn.SUCCESS, INACTIVE, UNCONFIGURED, UNCONFIGURED),
    ("on_cleanup", CallbackReturn.FAILURE, INACTIVE, UNCONFIGURED, INACTIVE),
    ("on_shutdown", CallbackReturn.SUCCESS, ACTIVE, FINALIZED, FINALIZED),
    ("on_shutdown", CallbackReturn.FAILURE, INACTIVE, FINALIZED, INACTIVE),
    ("on_activate", RuntimeError("boom"), INACTIVE, ACTIVE, UNCONFIGURED),          # a raise is an ERROR
])
def test_component_lifecycle_transition(callback, result, start, target, end):
    rm, impl = scripted_rm()
    assert rm.set_component_state("S", start) == return_type.OK
    impl.script[callback] = result
    ret = rm.set_component_state("S", target)
    assert rm.get_components_status()["S"] == end
    assert ret == (return_type.OK if end == target else return_type.ERROR)
    errored = isinstance(result, Exception) or result == CallbackReturn.ERROR
    assert impl.calls[-1] == ("on_error" if errored else callback)


def test_on_error_failure_finalizes_and_component_is_unrecoverable():
    rm, impl = scripted_rm({"on_activate": CallbackReturn.ERROR, "on_error": CallbackReturn.FAILURE})
    assert rm.set_component_state("S", ACTIVE) == return_type.ERROR
    assert rm.get_components_status()["S"] == FINALIZED
    assert rm.set_component_state("S", ACTIVE) == return_type.ERROR
    assert rm.get_components_status()["S"] == FINALIZED
    assert rm.available_state_interfaces() == []


def test_read_runs_in_inactive_and_active_write_only_in_active():
    rm, impl = scripted_rm()
    for target, reads, writes in ((UNCONFIGURED, 0, 0), (INACTIVE, 1, 0), (ACTIVE, 2, 1)):
        rm.set_component_state("S", target)
        rm.read(0.0, 0.01)
        rm.write(0.0, 0.01)
        assert (impl.reads, impl.writes) == (reads, writes)


# --- mock_components/GenericSystem ------------------------------------------------------------------------
def test_generic_system_2dof_symmetric_interfaces():
    body = (joint("joint1", ("position",), ("position",), {"position": 1.57})
            + joint("joint2", ("position",), ("position",), {"position": 0.7854}))
    rm = rm_for(generic(body=body))
    assert rm.value("joint1/position") == 1.57 and rm.value("joint2/position") == 0.7854
    assert math.isnan(rm.command_values[0]) and math.isnan(rm.command_values[1])


def test_generic_system_2dof_asymmetric_interfaces():
    body = (joint("joint1", ("position",), ("velocity",), {"velocity": 1.57})
            + joint("joint2", ("acceleration",), ("position",), {"position": 0.7854}))
    rm = rm_for(generic(body=body))
    assert rm.state_interface_keys() == ["joint1/velocity", "joint2/position"]
    assert rm.command_interface_keys() == ["joint1/position", "joint2/acceleration"]
    with pytest.raises(ResourceError, match="Command interface with 'joint1/velocity' does not exist"):
        rm.claim_command_interface("joint1/velocity")
    with pytest.raises(ResourceError, match="State interface with key 'joint2/velocity' does not exist"):
        rm.claim_state_interface("joint2/velocity")


def claim_all(rm, values):
    loans = [rm.claim_command_interface(k) for k in values]
    for loan, v in zip(loans, values.values()):
        loan.set_value(v)
    return loans


@pytest.mark.parametrize("offset, expected_initial, expected_pos", [
    (None, (3.45, 2.78), (0.11, 0.33)),        # generic_system_2dof_functionality
    (-3, (0.45, -0.22), (-2.89, -2.67)),       # generic_system_2dof_functionality_with_offset
])
def test_generic_system_2dof_functionality(offset, expected_initial, expected_pos):
    params = {"position_state_following_offset": offset} if offset is not None else {}
    rm = rm_for(generic(params=params, body=STANDARD_2DOF, rw_rate=100))
    keys = ["joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity"]
    assert [rm.value(k) for k in keys] == pytest.approx([expected_initial[0], 0.0, expected_initial[1], 0.0])
    loans = [rm.claim_command_interface(k) for k in keys]
    rm.write(0.0, 0.01)
    rm.read(0.01, 0.01)                       # NaN commands change nothing
    assert [rm.value(k) for k in keys] == pytest.approx([expected_initial[0], 0.0, expected_initial[1], 0.0])
    for loan, v in zip(loans, (0.11, 0.22, 0.33, 0.44)):
        loan.set_value(v)
    rm.write(0.02, 0.01)                      # write() changes nothing
    assert rm.value("joint1/position") == pytest.approx(expected_initial[0])
    rm.read(0.03, 0.01)
    assert [rm.value(k) for k in keys] == pytest.approx([expected_pos[0], 0.22, expected_pos[1], 0.44])


def test_generic_system_custom_interface_with_following_offset():
    body = (joint("joint1", ("position",), ("position", "actual_position"), {"position": 3.45})
            + joint("joint2", ("position",), ("position",), {"position": 2.78}))
    rm = rm_for(generic(params={"position_state_following_offset": -3,
                                "custom_interface_with_following_offset": "actual_position"}, body=body))
    assert rm.value("joint1/position") == 3.45       # offset not applied to position
    claim_all(rm, {"joint1/position": 0.11, "joint2/position": 0.33})
    rm.read(0.01, 0.01)
    assert rm.value("joint1/position") == pytest.approx(0.11)
    assert rm.value("joint1/actual_position") == pytest.approx(-2.89)


def test_generic_system_error_propagation_infinite_command():
    """generic_system_error_propagation: +inf command -> read() ERROR, interfaces gone, re-activation recovers."""
    rm = rm_for(generic(body=STANDARD_2DOF))
    loans = claim_all(rm, {"joint1/position": math.inf, "joint1/velocity": math.inf})
    status = rm.read(0.01, 0.01)
    assert status.result == return_type.ERROR and status.failed_hardware_names == ["GenericSystem2dof"]
    assert rm.get_components_status()["GenericSystem2dof"] == UNCONFIGURED
    assert not rm.state_interface_is_available("joint1/position")
    assert not rm.command_interface_is_available("joint2/position")
    for loan in loans:
        loan.set_value(0.0)
    assert rm.read(0.02, 0.01).ok                     # an unconfigured component is not read
    assert rm.set_component_state("GenericSystem2dof", ACTIVE) == return_type.OK
    assert rm.read(0.03, 0.01).ok and rm.value("joint1/position") == 0.0
    assert rm.log.count("because its read() returned ERROR") == 1


def test_generic_system_group_fails_together():
    a = generic("A", body=joint("joint1", ("position",), ("position",)), group="Group1")
    b = generic("B", body=joint("joint2", ("position",), ("position",)), group="Group1")
    rm = rm_for(a, b)
    claim_all(rm, {"joint1/position": math.inf})
    status = rm.read(0.01, 0.01)
    assert status.failed_hardware_names == ["A", "B"]
    assert rm.get_components_status() == {"A": UNCONFIGURED, "B": UNCONFIGURED}


def test_hw_sys_2dof_with_mimic_joint():
    mimic = '<mimic joint="joint1" multiplier="-2"/>'
    rm = ResourceManager(urdf(generic(body=STANDARD_2DOF), extra=mimic), log=quiet())
    claim_all(rm, {"joint1/position": 0.11, "joint1/velocity": 0.05})
    rm.read(0.01, 0.01)
    assert [rm.value(k) for k in ("joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity")] == \
        pytest.approx([0.11, 0.05, -0.22, -0.1])


def dynamics_rm():
    body = (joint("joint1", ("position", "velocity", "effort"), ("position", "velocity", "acceleration"),
                  {"position": 3.45})
            + joint("joint2", ("velocity", "acceleration"), ("position", "velocity", "acceleration"),
                    {"position": 2.78})
            + '<gpio name="flange_vacuum"><command_interface name="vacuum"/>'
              '<state_interface name="vacuum"><param name="initial_value">1.0</param></state_interface></gpio>')
    return rm_for(generic(params={"calculate_dynamics": "true"}, body=body))


def test_simple_dynamics_mode_switch_accepts_and_rejects():
    """simple_dynamics_pos_vel_acc_control_modes_interfaces: which combinations prepare accepts."""
    rm = dynamics_rm()
    assert rm.prepare_command_mode_switch(["joint1/position", "joint2/acceleration", "flange_vacuum/vacuum"], [])
    assert not rm.prepare_command_mode_switch(["joint1/effort", "joint2/acceleration"], [])
    assert rm.log.count("Joint 'joint1' has to have 'position', 'velocity', or 'acceleration' interface!") == 1
    assert not rm.prepare_command_mode_switch(["joint1/position", "joint2/velocity", "joint2/acceleration"], [])
    assert rm.log.count("Got multiple (2) starting interfaces for joint 'joint2' - this is not supported!") == 1


def test_simple_dynamics_position_and_acceleration_modes_integrate():
    """simple_dynamics_pos_vel_acc_control_modes_interfaces numbers, PERIOD 0.1 s."""
    rm = dynamics_rm()
    start = ["joint1/position", "joint2/acceleration"]
    assert rm.prepare_command_mode_switch(start, []) and rm.perform_command_mode_switch(start, [])
    claim_all(rm, {"joint1/position": 0.11, "joint2/acceleration": 3.5})
    rm.read(0.1, 0.1)
    v1 = (0.11 - 3.45) / 0.1
    got = [rm.value(f"joint{j}/{i}") for j in (1, 2) for i in ("position", "velocity", "acceleration")]
    assert got == pytest.approx([0.11, v1, v1 / 0.1, 2.78 + 0.035, 0.35, 3.5])
    rm.read(0.2, 0.1)
    got = [rm.value(f"joint{j}/{i}") for j in (1, 2) for i in ("position", "velocity", "acceleration")]
    assert got == pytest.approx([0.11, 0.0, (0.0 - v1) / 0.1, 2.78 + 0.035 + 0.070, 0.70, 3.5])


def test_simple_dynamics_velocity_mode_integrates_position():
    rm = dynamics_rm()
    rm.perform_command_mode_switch(["joint2/velocity"], [])
    claim_all(rm, {"joint2/velocity": 0.5})
    rm.read(0.1, 0.1)
    rm.read(0.2, 0.1)
    assert [rm.value(f"joint2/{i}") for i in ("position", "velocity", "acceleration")] == \
        pytest.approx([2.78 + 0.1, 0.5, 0.0])


def test_disabled_commands_flag_is_active():
    rm = rm_for(generic(params={"disable_commands": "True"}, body=STANDARD_2DOF))
    claim_all(rm, {"joint1/position": 0.11})
    rm.write(0.01, 0.01)
    rm.read(0.01, 0.01)
    rm.read(0.02, 0.01)
    assert rm.value("joint1/position") == 3.45
    assert rm.log.count("Command propagation is disabled - no values will be returned!") == 1


def test_mock_sensor_and_gpio_commands_are_created_and_mirrored():
    body = (joint("joint1", ("position",), ("position",)) + joint("joint2", ("position",), ("position",))
            + '<sensor name="tcp_force_sensor"><state_interface name="fx"/><state_interface name="tx"/></sensor>'
            + '<gpio name="flange_analog_IOs"><command_interface name="analog_output1"/>'
              '<state_interface name="analog_output1"/><state_interface name="analog_input1"/></gpio>')
    rm = rm_for(generic(params={"mock_sensor_commands": "true", "mock_gpio_commands": "true"}, body=body))
    assert {"tcp_force_sensor/fx", "tcp_force_sensor/tx", "flange_analog_IOs/analog_output1",
            "flange_analog_IOs/analog_input1"} <= set(rm.command_interface_keys())
    claim_all(rm, {"tcp_force_sensor/fx": 1.11, "flange_analog_IOs/analog_input1": 2.22})
    rm.read(0.01, 0.01)
    assert rm.value("tcp_force_sensor/fx") == 1.11 and rm.value("flange_analog_IOs/analog_input1") == 2.22
    plain = rm_for(generic(body=body))
    assert "tcp_force_sensor/fx" not in plain.command_interface_keys()
    assert "flange_analog_IOs/analog_input1" not in plain.command_interface_keys()


def test_loans_are_views_of_the_component_arrays():
    rm = rm_for(generic(body=STANDARD_2DOF))
    impl = rm.components["GenericSystem2dof"].impl
    loan = rm.claim_command_interface("joint2/velocity")
    loan.set_value(0.75)
    assert impl.get_command("joint2/velocity") == 0.75
    assert np.shares_memory(impl.command_values, rm.command_values)
    state = rm.claim_state_interface("joint1/position")
    impl.set_state("joint1/position", -1.25)
    assert state.get_value() == -1.25


# --- kinds, rates ------------------------------------------------------------------------------------------
class CountingSensor(SensorInterface):
    def __init__(self):
        super().__init__()
        self.reads = 0

    def read(self, time, period):
        self.reads += 1
        self.set_state("ft/force.z", 9.81)
        return return_type.OK


def test_sensor_component_has_no_commands_and_is_never_written():
    block = ('<ros2_control name="FT" type="sensor"><hardware><plugin>test/CountingSensor</plugin></hardware>'
             '<sensor name="ft"><state_interface name="force.z"/></sensor></ros2_control>')
    rm = ResourceManager(urdf(block), components={"FT": CountingSensor()}, log=quiet())
    rm.read(0.0, 0.01)
    assert rm.write(0.0, 0.01).ok and rm.command_interface_keys() == [] and rm.value("ft/force.z") == 9.81
    with pytest.raises(URDFError, match="is declared type=\"system\" but its plugin CountingSensor is a sensor"):
        ResourceManager(urdf(block.replace('type="sensor"', 'type="system"')), components={"FT": CountingSensor()},
                        log=quiet())


def test_rw_rate_below_the_manager_rate_skips_cycles_and_passes_its_own_period():
    rm, impl = None, Scripted()
    rm = ResourceManager(urdf(generic("S", body=STANDARD_2DOF, rw_rate=50)), components={"S": impl}, log=quiet(),
                         update_rate=100)
    periods = []
    orig = impl.read

    def read(t, p):
        periods.append(round(p, 6))
        return orig(t, p)

    impl.read = read
    for k in range(1, 11):
        rm.read(k * 0.01, 0.01)
        rm.write(k * 0.01, 0.01)
    assert impl.reads == 5 and impl.writes == 5
    assert periods == [0.02, 0.02, 0.02, 0.02, 0.02]


def test_initial_states_parameter_and_activation_from_unconfigured():
    text = urdf(generic("A", body=joint("joint1", ("position",), ("position",))),
                generic("B", body=joint("joint2", ("position",), ("position",))))
    rm = ResourceManager(text, initial_states={"A": "unconfigured", "B": "inactive"}, log=quiet())
    assert rm.get_components_status() == {"A": UNCONFIGURED, "B": INACTIVE}
    assert rm.available_state_interfaces() == ["joint2/position"]
    assert rm.available_command_interfaces() == ["joint2/position"]     # INACTIVE still offers commands (#931)
    assert rm.set_component_state("A", "active") == return_type.OK      # configures on the way
    assert rm.set_component_state("A", "active") == return_type.OK
    assert rm.get_components_status()["A"] == ACTIVE
    with pytest.raises(ValueError, match="hardware component 'C' does not exist"):
        rm.set_component_state("C", "active")
    with pytest.raises(ValueError, match="unknown lifecycle state 'running'"):
        rm.set_component_state("A", "running")


def test_async_components_are_refused_clearly():
    text = urdf(generic(body=STANDARD_2DOF)).replace('type="system"', 'type="system" is_async="true"')
    with pytest.raises(URDFError, match='is_async="true" on <ros2_control name="GenericSystem2dof"> is not supported'):
        ResourceManager(text, log=quiet())


def test_unknown_actuator_plugin_names_the_actuator_base_class():
    block = ('<ros2_control name="A" type="actuator"><hardware><plugin>my_robot/NoActuator</plugin></hardware>'
             + joint("joint1", ("position",), ("position",)) + "</ros2_control>")
    with pytest.raises(URDFError, match="the class my_robot/NoActuator with base class type "
                                        "hardware_interface::ActuatorInterface does not exist"):
        ResourceManager(urdf(block), log=quiet())
