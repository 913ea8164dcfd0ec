"""robocourse/EthercatSystem (robocourse.ethercat.ros2_control): the UR5e arm on simulated CiA 402 drives under the controller manager
(ethercat_driver_ros2's URDF layout, automatic transitions, reset_fault, GPIO, slave faults)."""

from __future__ import annotations

import numpy as np
import pytest

import robocourse.drivers as drivers
from robocourse.control.bringup import bringup
from robocourse.control.hardware.types import ACTIVE, INACTIVE, return_type
from robocourse.ethercat.devices import FAULT, OPERATION_ENABLED, cia402_state
from robocourse.ethercat.ros2_control import ARM_JOINTS, ethercat_arm_urdf, next_controlword

SPAWN = ["joint_state_broadcaster", "forward_position_controller"]


def make(**kw):
    cm = bringup(urdf=ethercat_arm_urdf(**kw), param_file=drivers.CONTROLLERS_YAML, spawn=SPAWN)
    return cm, cm.rm.components["UR5e"].impl


def q(system):
    return np.array([system.get_state(f"{j}/position") for j in ARM_JOINTS])


@pytest.mark.parametrize("statusword,cw,edge,expected", [
    (0x0040, 0x0000, False, 0x0006),   # switch on disabled -> shutdown
    (0x0231, 0x0006, False, 0x0007),   # ready to switch on -> switch on
    (0x0233, 0x0007, False, 0x000F),   # switched on -> enable operation
    (0x0217, 0x0002, False, 0x000F),   # quick stop active -> enable operation
    (0x0237, 0x000F, False, 0x000F),   # operation enabled: keep
    (0x0208, 0x000F, True, 0x008F),    # fault + rising reset -> bit 7
    (0x0208, 0x008F, False, 0x000F),   # fault, no reset: bit 7 cleared (the next edge can rise)
])
def test_automatic_transitions_write_the_reference_controlwords(statusword, cw, edge, expected):
    assert next_controlword(statusword, cw, edge) == expected


def test_bring_up_enables_six_drives_and_tracks_position_commands():
    cm, system = make()
    try:
        m = system.master
        assert [s.name for s in m.slaves] == ["RC1100"] + ["RC-Servo"] * 6 + ["RC1008", "RC2008"]
        cm.step(1)
        assert all(cia402_state(int(system.get_state(f"{j}/statusword"))) == OPERATION_ENABLED
                   for j in ARM_JOINTS)
        q0 = q(system)
        target = q0 + np.array([0.2, -0.1, 0.1, 0.0, 0.1, -0.1])
        cm.controllers["forward_position_controller"].c.set_command(list(target))
        cm.step(1000)
        np.testing.assert_allclose(q(system), target, atol=1e-3)
        assert system.last_wkc == m.expected_wkc == 21      # 2 x 7 writers + 7 readers (6 drives, 2 IO terms)
    finally:
        cm.shutdown()


def test_gpio_interfaces_reach_the_io_terminals():
    cm, system = make()
    try:
        system.set_command("io_out/dig_output.1", 1.0)
        system.set_command("io_out/dig_output.3", 1.0)
        system.bus.slaves[7].inputs = 0b1000_0010
        cm.step(3)
        assert system.bus.slaves[8].outputs == 0b0000_0101
        assert [system.get_state(f"io_in/dig_input.{ch}") for ch in range(1, 9)] == [0, 1, 0, 0, 0, 0, 0, 1]
    finally:
        cm.shutdown()


def test_drive_fault_disables_the_drive_until_a_rising_reset_fault():
    cm, system = make()
    try:
        cm.step(10)
        drive = system.bus.slaves[1]             # shoulder_pan_joint's drive
        drive.inject_fault(0x2310)
        cm.step(5)
        assert cia402_state(int(system.get_state("shoulder_pan_joint/statusword"))) == FAULT
        assert cm.controllers["forward_position_controller"].state == ACTIVE    # a drive fault is no bus error
        cm.step(20)
        assert cia402_state(int(system.get_state("shoulder_pan_joint/statusword"))) == FAULT   # stays until reset
        system.set_command("shoulder_pan_joint/reset_fault", 1.0)
        cm.step(10)
        assert cia402_state(int(system.get_state("shoulder_pan_joint/statusword"))) == OPERATION_ENABLED
        assert drive.error_code == 0
    finally:
        cm.shutdown()


def test_auto_fault_reset_recovers_without_the_interface():
    cm, system = make(auto_fault_reset=True)
    try:
        cm.step(10)
        system.bus.slaves[3].inject_fault()
        cm.step(5)
        assert cia402_state(int(system.get_state("elbow_joint/statusword"))) != OPERATION_ENABLED
        cm.step(20)     # fault reset, then the four-step enable: each answer one exchange later
        assert cia402_state(int(system.get_state("elbow_joint/statusword"))) == OPERATION_ENABLED
    finally:
        cm.shutdown()


@pytest.mark.parametrize("fault", ["slave_error", "cut"])
def test_slave_fault_is_a_hardware_error_that_deactivates_the_controllers(fault):
    cm, system = make()
    try:
        cm.step(10)
        if fault == "cut":
            system.bus.cut_after(4)
        else:
            system.bus.slave_error(2, 0x001B)    # sync manager watchdog: drops to SAFE_OP
        cm.step(3)
        assert {n: s.state for n, s in cm.controllers.items()} == {"joint_state_broadcaster": INACTIVE,
                                                                  "forward_position_controller": INACTIVE}
        assert system.last_error.startswith("working counter") and "expected 21" in system.last_error
        assert any("went into error" in r.msg or "resulted in an error" in r.msg for r in cm.log.records)
    finally:
        cm.shutdown()


def test_module_without_bus_position_is_refused():
    from robocourse.control import ControllerManager
    from robocourse.control.log import LogSink

    text = ethercat_arm_urdf(io=False).replace('<param name="position">3</param>', "", 1)
    log = LogSink(log_to_stderr=False)
    with pytest.raises(RuntimeError, match="Failed to initialize hardware 'UR5e'"):
        ControllerManager(text, log=log)
    assert any("drive3" in r.msg and "position" in r.msg and "missing" in r.msg for r in log.records)


def test_the_plugin_is_declared_by_importing_robocourse_ethercat_alone():
    # a fresh interpreter: no robocourse.drivers, so the declaration must come from robocourse.ethercat
    import subprocess
    import sys

    code = ("import sys, robocourse.ethercat\n"
            "from robocourse.control import pluginlib\n"
            "cls = pluginlib.load('robocourse/EthercatSystem', pluginlib.HARDWARE_BASE)\n"
            "print(cls.__module__, 'robocourse.drivers' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["robocourse.ethercat.ros2_control", "False"]


@pytest.mark.parametrize("freq", [0, 2.5, "1000"])
def test_ethercat_arm_urdf_refuses_a_bad_control_frequency(freq):
    with pytest.raises(ValueError, match="control_frequency"):
        ethercat_arm_urdf(control_frequency=freq)


@pytest.mark.parametrize("outage_ns, acked", [(3_000_000, 0), (500_000_000, 7)], ids=["3ms", "500ms"])
def test_cable_cut_then_reconnect_reactivate_and_the_drives_follow_commands_again(outage_ns, acked):
    cm, system = make()
    try:
        cm.step(10)
        q0 = q(system)
        system.bus.cut_after(4)                  # coupler + the first three drives still answer
        cm.step(3)
        hw = cm.rm.components["UR5e"].wrapper
        assert hw.state.label == "unconfigured"  # read() returned ERROR
        assert {n: s.state for n, s in cm.controllers.items()} == {"joint_state_broadcaster": INACTIVE,
                                                                  "forward_position_controller": INACTIVE}
        assert system.last_wkc == 9              # 3 drives x (write 2 + read 1)
        assert "slave 5 not responding (lost)" in system.last_error
        # the cable stays out this long; no frame reaches any slave meanwhile, so after 500 ms the
        # 100 ms SM watchdog has expired on all 7 slaves with outputs (6 drives, the RC2008)
        system.clock.ns += outage_ns
        system.bus.reconnect()
        n_log = len(cm.log.records)
        assert cm.set_hardware_component_state("UR5e", "active") == return_type.OK
        assert hw.state.label == "active" and system.last_error == ""
        recovery = [r.msg for r in cm.log.records[n_log:]]
        assert sum("SAFE_OP + ERROR, attempting ack" in m for m in recovery) == acked
        assert cm.switch_controller(SPAWN) == return_type.OK
        assert {n: s.state for n, s in cm.controllers.items()} == {"joint_state_broadcaster": ACTIVE,
                                                                  "forward_position_controller": ACTIVE}
        target = q0 + np.array([0.1, -0.1, 0.1, 0.1, -0.1, 0.1])   # drives 4-6 sat behind the cut
        cm.controllers["forward_position_controller"].c.set_command(list(target))
        system.set_command("io_out/dig_output.2", 1.0)
        cm.step(1000)
        assert system.last_wkc == system.master.expected_wkc == 21
        assert all(cia402_state(int(system.get_state(f"{j}/statusword"))) == OPERATION_ENABLED for j in ARM_JOINTS)
        np.testing.assert_allclose(q(system), target, atol=1e-3)
        assert system.bus.slaves[8].outputs == 0b0000_0010
    finally:
        cm.shutdown()
