"""``robocourse/EthercatSystem``: the arm on simulated EtherCAT drives, in ethercat_driver_ros2's shape.

Counterpart: ICube-Robotics' ethercat_driver_ros2 (``ethercat_driver/EthercatDriver`` with
``ethercat_generic_plugins/EcCiA402Drive`` and ``GenericEcSlave`` modules). The URDF layout
is theirs: one ``<ec_module name=...>`` inside each ``<joint>`` / ``<gpio>`` with a
``<plugin>`` and ``<param>``s (``position`` on the bus, ``mode_of_operation``,
``auto_fault_reset``)::

    <joint name="shoulder_pan_joint">
      <command_interface name="position"/> <command_interface name="reset_fault"/>
      <state_interface name="position"/> <state_interface name="velocity"/> <state_interface name="effort"/>
      <ec_module name="drive0"><plugin>ethercat_generic_plugins/EcCiA402Drive</plugin>
        <param name="position">1</param><param name="mode_of_operation">8</param></ec_module>
    </joint>
    <gpio name="io"> <command_interface name="dig_output.1"/> <state_interface name="dig_input.1"/>
      <ec_module name="out"><plugin>ethercat_generic_plugins/GenericEcSlave</plugin>
        <param name="position">3</param><param name="device">RC2008</param></ec_module> ... </gpio>

Importing :mod:`robocourse.ethercat` declares the plugin with :mod:`robocourse.control.pluginlib`;
:func:`ethercat_arm_urdf` writes the UR5e URDF in this layout.

Where we differ: the bus is robocourse.ethercat's in-process simulation, built from the
modules (a coupler at position 0 when no module takes it; drives ``Cia402Drive``, IO
``DigitalInputs`` (``device`` RC1008) / ``DigitalOutputs`` (RC2008)), brought up by
robocourse.ethercat's SOEM-shaped master; a ``slave_config`` yaml is not read (the PDO layout
comes from the slaves' SII, as SOEM maps it). Each drive's motor is a joint of the UR5e arm in
MuJoCo (:class:`ArmJointMotor`: the drive's torque plus the arm's gravity torque, as the
arm's own servos feed gravity forward; the arm steps once per cycle), so the CSP position loop
runs inside the drive.

The CiA 402 plugin, as the reference describes ethercat_driver_ros2's: with automatic
transitions each cycle writes Switch on disabled -> (cw & 0x7E) | 0x06, Ready to switch on ->
(cw & 0x77) | 0x07, Switched on / Quick stop active -> (cw & 0x7F) | 0x0F; Fault -> cw | 0x80
only with ``auto_fault_reset`` or on a rising edge of the ``reset_fault`` command interface; the
target position defaults to the last actual position until a command arrives.

Cycle: write() puts commands in the output image, sends and receives the process data (the
drives and the arm advance one period); read() decodes the inputs. A slave fault (a working
counter other than expected: a cable cut, a slave dropped to SAFE_OP with an AL status code,
a lost frame; the message names the slave from the master's diagnosis) makes read() return
ERROR, so the controller manager deactivates the controllers. A CiA 402 drive fault is the
drive's business, as in ethercat_driver_ros2: it disables (no torque), the ``statusword``
state interface shows it, and a rising edge on ``reset_fault`` (or ``auto_fault_reset``)
brings it back through the automatic transitions. Re-activating the component after an
error first brings the bus back (configure runs simple_test's ecatcheck every cycle until the
working counter is the expected one: error acknowledge for slaves whose SM watchdog expired
while the cable was out, SAFE_OP -> OP, lost slaves found again), then resets faults and runs
the enable sequence again.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

from robocourse.control.hardware.component import SystemInterface
from robocourse.control.hardware.types import CallbackReturn, return_type

from .bus import Bus
from .devices import (
    FAULT,
    OPERATION_ENABLED,
    QUICK_STOP_ACTIVE,
    READY_TO_SWITCH_ON,
    SWITCH_ON_DISABLED,
    SWITCHED_ON,
    Cia402Drive,
    Coupler,
    DigitalInputs,
    DigitalOutputs,
    cia402_state,
    drive_inputs,
    drive_outputs,
)
from .master import Master, MasterError

CIA402 = "ethercat_generic_plugins/EcCiA402Drive"
GENERIC = "ethercat_generic_plugins/GenericEcSlave"
_MODES = {8: "position", 9: "velocity", 10: "effort"}
_ENABLE_CYCLES = 200
_RECOVER_CYCLES = 50


#: The UR5e's arm joints (ur_description's names); the gripper finger and the F/T sensor get no module.
ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
              "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
_ROS2_CONTROL = re.compile(r"<ros2_control\s[^>]*>.*?</ros2_control>", re.S)


def ethercat_arm_urdf(io: bool = True, auto_fault_reset: bool = False, control_frequency: int = 1000) -> str:
    """The UR5e URDF for ``robocourse/EthercatSystem`` in ethercat_driver_ros2's layout: a coupler
    at bus position 0, one CiA 402 drive per arm joint (positions 1-6, CSP, ``position`` and
    ``reset_fault`` commands, a ``statusword`` state) and, with ``io``, an 8-channel input (7) and
    output (8) terminal as the gpios ``io_in`` / ``io_out`` (``dig_input.1..8`` states,
    ``dig_output.1..8`` commands)."""
    from robocourse.sim.robots import urdf_text

    if not isinstance(control_frequency, int) or not 1 <= control_frequency <= 100_000:
        raise ValueError(f"control_frequency={control_frequency!r} must be an int in 1..100000 Hz, e.g. 1000")
    text = urdf_text("ur5e", plugin="robocourse/EthercatSystem",
                     params={"control_frequency": control_frequency})
    m = _ROS2_CONTROL.search(text)
    element = ET.fromstring(m.group(0))
    for child in list(element):
        if child.tag == "sensor" or (child.tag == "joint" and child.get("name") not in ARM_JOINTS):
            element.remove(child)
    for i, joint in enumerate(element.findall("joint")):
        for itf in joint.findall("command_interface"):
            if itf.get("name") != "position":
                joint.remove(itf)
        ET.SubElement(joint, "command_interface", name="reset_fault")
        ET.SubElement(joint, "state_interface", name="statusword")
        mod = ET.SubElement(joint, "ec_module", name=f"drive{i + 1}")
        ET.SubElement(mod, "plugin").text = CIA402
        for k, v in (("position", i + 1), ("mode_of_operation", 8),
                     ("auto_fault_reset", str(bool(auto_fault_reset)).lower())):
            ET.SubElement(mod, "param", name=k).text = str(v)
    if io:
        for name, device, pos, tag, itf in (("io_in", "RC1008", 7, "state_interface", "dig_input"),
                                            ("io_out", "RC2008", 8, "command_interface", "dig_output")):
            gpio = ET.SubElement(element, "gpio", name=name)
            for ch in range(1, 9):
                ET.SubElement(gpio, tag, name=f"{itf}.{ch}")
            mod = ET.SubElement(gpio, "ec_module", name=name)
            ET.SubElement(mod, "plugin").text = GENERIC
            ET.SubElement(mod, "param", name="position").text = str(pos)
            ET.SubElement(mod, "param", name="device").text = device
    ET.indent(element, space="  ", level=1)
    return text[:m.start()] + ET.tostring(element, encoding="unicode") + text[m.end():]


class SimTime:
    """The bus clock: advanced by the system one period per cycle (deterministic)."""

    def __init__(self):
        self.ns = 0

    def __call__(self) -> int:
        return self.ns


class ArmJointMotor:
    """A drive's motor that is one joint of a RobotSim (the drive's MotorModel interface).

    ``step(torque, dt)`` records the drive's torque; :meth:`ArmDrives.advance` applies all of
    them (plus gravity) and steps the arm. Position/velocity are the joint's, in rad.
    """

    counts_per_rev = 1 << 17

    def __init__(self, sim, k: int, rated_torque: float):
        self.sim, self.k = sim, k
        self.rated_torque = rated_torque
        self.torque = 0.0

    @property
    def position(self) -> float:
        return float(self.sim.positions[self.k])

    @property
    def velocity(self) -> float:
        return float(self.sim.velocities[self.k])

    def step(self, torque: float, dt: float) -> None:
        self.torque = torque

    @property
    def counts(self) -> int:
        return int(round(self.position / (2 * math.pi) * self.counts_per_rev))

    def to_rad(self, counts: float) -> float:
        return counts * 2 * math.pi / self.counts_per_rev


def rad_to_counts(q: float) -> int:
    return int(round(q / (2 * math.pi) * ArmJointMotor.counts_per_rev))


def next_controlword(statusword: int, cw: int, reset_edge: bool) -> int:
    """ethercat_driver_ros2's automatic CiA 402 transitions (the reference's table)."""
    s = cia402_state(statusword)
    if s == SWITCH_ON_DISABLED:
        return (cw & 0x7E) | 0x06
    if s == READY_TO_SWITCH_ON:
        return (cw & 0x77) | 0x07
    if s in (SWITCHED_ON, QUICK_STOP_ACTIVE):
        return (cw & 0x7F) | 0x0F
    if s == FAULT:
        return (cw | 0x80) if reset_edge else (cw & 0x7F)
    return cw & 0x7F


class _Module:
    def __init__(self, comp, name: str, plugin: str, params: dict[str, str]):
        self.comp, self.name, self.plugin, self.params = comp, name, plugin, params
        self.position = int(params.get("position", "-1"))


class EthercatSystem(SystemInterface):
    """robocourse/EthercatSystem (see the module docstring)."""

    SUPPORTED_COMMAND_INTERFACES = None
    SUPPORTED_STATE_INTERFACES = None

    def __init__(self, sim=None):
        super().__init__()
        self.sim = sim
        self.master = None
        self.bus = None
        self.last_error = ""
        self.last_wkc = 0

    # --- description ----------------------------------------------------------------------------
    def on_init(self, info):
        super().on_init(info)
        try:
            self.modules = self._modules(info)
        except ValueError as exc:
            self.get_logger().error(str(exc))
            return CallbackReturn.ERROR
        return CallbackReturn.SUCCESS

    def _modules(self, info) -> list[_Module]:
        root = ET.fromstring(info.original_xml)
        comps = {c.name: c for c in info.joints + info.gpios}
        mods = []
        for el in root:
            if el.tag not in ("joint", "gpio"):
                continue
            found = el.findall("ec_module")
            comp = comps[el.get("name")]
            if len(found) != 1:
                raise ValueError(f"{el.tag} '{comp.name}' needs exactly one <ec_module> (ethercat_driver_ros2's "
                                 f"layout), found {len(found)}")
            m = found[0]
            plugin = (m.findtext("plugin") or "").strip()
            params = {p.get("name"): (p.text or "").strip() for p in m.findall("param")}
            if plugin not in (CIA402, GENERIC):
                raise ValueError(f"ec_module '{m.get('name')}' of '{comp.name}': plugin '{plugin}' is not one of "
                                 f"{CIA402}, {GENERIC}")
            if plugin == CIA402 and el.tag != "joint":
                raise ValueError(f"{CIA402} belongs in a <joint>, not in <{el.tag}> '{comp.name}'")
            mod = _Module(comp, m.get("name", ""), plugin, params)
            if mod.position < 0:
                raise ValueError(f"ec_module '{mod.name}' of '{comp.name}': <param name=\"position\"> (its "
                                 f"place on the bus, 0 = first slave) is missing or negative")
            if plugin == CIA402:
                mode = int(params.get("mode_of_operation", "8"))
                if mode not in _MODES:
                    raise ValueError(f"ec_module '{mod.name}': mode_of_operation {mode} must be 8 (CSP), 9 (CSV) "
                                     "or 10 (CST)")
                mod.mode = mode
                mod.auto_reset = params.get("auto_fault_reset", "false").lower() == "true"
            else:
                mod.device = params.get("device", "")
                if mod.device not in ("RC1008", "RC2008"):
                    raise ValueError(f"ec_module '{mod.name}': <param name=\"device\"> must be RC1008 (8 digital "
                                     f"inputs) or RC2008 (8 digital outputs), got '{mod.device}'")
            mods.append(mod)
        positions = [m.position for m in mods]
        if len(set(positions)) != len(positions):
            raise ValueError(f"two ec_modules share a bus position: {sorted(positions)}")
        return mods

    # --- bring-up ---------------------------------------------------------------------------------
    def on_configure(self, previous_state):
        if self.master is None:
            if self.sim is None:
                from robocourse.sim.robots import RobotSim

                self.sim = RobotSim(self.info.hardware_parameters.get("robot", "ur5e"))
            sim = self.sim
            self.period = 1.0 / float(self.info.hardware_parameters.get("control_frequency", "1000"))
            n_slaves = max(m.position for m in self.modules) + 1
            slaves: list = [None] * n_slaves
            self.drives = []
            for m in self.modules:
                if m.plugin == CIA402:
                    if m.comp.name not in sim.joint_names:
                        self.get_logger().error(f"joint '{m.comp.name}' is not a joint of the {sim.name} arm "
                                                f"({list(sim.joint_names)})")
                        return CallbackReturn.ERROR
                    k = sim.joint_names.index(m.comp.name)
                    lim = sim.limits[m.comp.name]
                    g = sim.gains[m.comp.name]
                    motor = ArmJointMotor(sim, k, lim.effort)
                    slaves[m.position] = Cia402Drive(motor, kp=g.kp, kd=g.kd, kv=g.kv, max_torque=lim.effort,
                                                     following_error_window=rad_to_counts(0.5))
                    self.drives.append((m, motor, k))
                else:
                    slaves[m.position] = DigitalInputs() if m.device == "RC1008" else DigitalOutputs()
            for i, s in enumerate(slaves):
                if s is None:
                    slaves[i] = Coupler()
            sim.set_mode([sim.joint_names[k] for _, _, k in self.drives], "effort")
            self.clock = SimTime()
            self.bus = Bus(slaves, clock=self.clock)
            self.master = Master()
            self.master.open(self.bus)
            try:
                self.master.bring_up(dc=True)
            except MasterError as exc:
                self.get_logger().error(f"EtherCAT bring-up failed: {exc}")
                self.master = None
                return CallbackReturn.FAILURE
        self._bind()
        if not self._recover():
            self.get_logger().error(f"EtherCAT bus not back in {_RECOVER_CYCLES} cycles: {self.last_error}")
            return CallbackReturn.FAILURE
        self.last_error = ""
        self.read(0.0, 0.0)
        return CallbackReturn.SUCCESS

    def _recover(self) -> bool:
        """Exchange process data until the working counter is the expected one, running one
        pass of the master's ecatcheck (ack errors, request OP, find lost slaves) after every
        short cycle; at bring-up the first exchange already returns it."""
        m = self.master
        for _ in range(_RECOVER_CYCLES):
            wkc = self._exchange()
            if wkc == m.expected_wkc:
                return True
            self.last_error = str(m.diagnose(wkc))
            for msg in m.check():
                self.get_logger().info(msg)
        return False

    def _bind(self) -> None:
        si, ci, m = self.state_index, self.command_index, self.master
        self._drive_io = []
        for mod, motor, k in self.drives:
            slave = m.slaves[mod.position]
            j = mod.comp.name
            self._drive_io.append(dict(
                mod=mod, slave=slave, k=k, cw=0, reset_prev=0.0,
                st=[si.get(f"{j}/{s}", -1) for s in ("position", "velocity", "effort")],
                sw=si.get(f"{j}/statusword", -1),
                cmd={i: ci[f"{j}/{i}"] for i in ("position", "velocity", "effort") if f"{j}/{i}" in ci},
                reset=ci.get(f"{j}/reset_fault", -1), rated=motor.rated_torque))
        self._gpio_io = []
        for mod in self.modules:
            if mod.plugin == GENERIC:
                slave = m.slaves[mod.position]
                chans = []
                for itf in (mod.comp.state_interfaces if mod.device == "RC1008" else mod.comp.command_interfaces):
                    prefix, _, ch = itf.name.rpartition(".")
                    chans.append((int(ch), (si if mod.device == "RC1008" else ci)[f"{mod.comp.name}/{itf.name}"]))
                self._gpio_io.append((mod, slave, chans))

    def _exchange(self) -> int:
        """One process-data cycle: the bus clock and the arm advance one period."""
        self.clock.ns += int(round(self.period * 1e9))
        self.master.send_processdata()
        wkc = self.last_wkc = self.master.receive_processdata()
        sim = self.sim
        g = sim.gravity_torques()
        for _mod, motor, k in self.drives:
            sim.commands[k] = motor.torque + g[k]
        n = max(1, int(round(self.period / sim.model.opt.timestep)))
        sim.step(n)
        return wkc

    def on_activate(self, previous_state):
        """Enable every drive (fault reset edge if needed, then the automatic transitions)."""
        in_op = {id(d["slave"]): 0 for d in self._drive_io}
        for cycle in range(_ENABLE_CYCLES):
            for d in self._drive_io:
                sw, pos, *_ = drive_inputs(d["slave"].input)
                edge = cia402_state(sw) == FAULT and cycle % 2 == 0   # rising edges: 0x80 on, off, on...
                d["cw"] = next_controlword(sw, d["cw"], edge)
                self._put(d, d["cw"], pos)
                in_op[id(d["slave"])] = in_op[id(d["slave"])] + 1 if cia402_state(sw) == OPERATION_ENABLED else 0
            if all(v >= 2 for v in in_op.values()):       # initialised: two cycles in Operation enabled
                break
            self._exchange()
        else:
            states = [cia402_state(drive_inputs(d["slave"].input)[0]) for d in self._drive_io]
            self.get_logger().error(f"drives did not reach operation enabled in {_ENABLE_CYCLES} cycles: {states}")
            return CallbackReturn.FAILURE
        for d in self._drive_io:
            _sw, pos, *_ = drive_inputs(d["slave"].input)
            for itf, slot in d["cmd"].items():
                self.command_values[slot] = self.sim.positions[d["k"]] if itf == "position" else 0.0
            if d["reset"] >= 0:
                self.command_values[d["reset"]] = 0.0
        return CallbackReturn.SUCCESS

    def _put(self, d, cw: int, target_counts: int, vel: int = 0, torque: int = 0) -> None:
        d["slave"].output = drive_outputs(cw, target_counts, vel, torque, d["mod"].mode)

    def on_deactivate(self, previous_state):
        for d in self._drive_io:      # disable operation -> switched on (no drive torque; the arm
            d["cw"] = 0x07            # keeps only its gravity feed-forward), as a stopped driver does
            self._put(d, 0x07, drive_inputs(d["slave"].input)[1])
        self._exchange()
        return CallbackReturn.SUCCESS

    def on_error(self, previous_state):
        self.get_logger().error(f"EthercatSystem '{self.info.name}': {self.last_error}")
        return CallbackReturn.SUCCESS

    # --- hot path ---------------------------------------------------------------------------------
    def read(self, time, period):
        m = self.master
        if m is None:
            self.last_error = "the master is not up"
            return return_type.ERROR
        if self.last_wkc != m.expected_wkc:
            self.last_error = str(m.diagnose(self.last_wkc))   # names the lost / not-OP slaves
            return return_type.ERROR
        st = self.state_values
        for d in self._drive_io:
            sw, pos, vel, tq, _mode = drive_inputs(d["slave"].input)
            if d["sw"] >= 0:
                st[d["sw"]] = sw
            ip, iv, ie = d["st"]
            if ip >= 0:
                st[ip] = pos * 2 * math.pi / ArmJointMotor.counts_per_rev
            if iv >= 0:
                st[iv] = vel * 2 * math.pi / ArmJointMotor.counts_per_rev
            if ie >= 0:
                st[ie] = tq / 1000.0 * d["rated"]
        for mod, slave, chans in self._gpio_io:
            if mod.device == "RC1008":
                byte = slave.input[0]
                for ch, slot in chans:
                    st[slot] = float((byte >> (ch - 1)) & 1)
        return return_type.OK

    def write(self, time, period):
        cmd = self.command_values
        for d in self._drive_io:
            sw, pos, *_ = drive_inputs(d["slave"].input)
            edge = False
            if d["reset"] >= 0:
                r = cmd[d["reset"]]
                edge = r > 0.5 and not d["reset_prev"] > 0.5
                d["reset_prev"] = r
            d["cw"] = next_controlword(sw, d["cw"], edge or d["mod"].auto_reset)
            target, vel, torque = pos, 0, 0
            mode = _MODES[d["mod"].mode]
            if mode in d["cmd"]:
                v = cmd[d["cmd"][mode]]
                if not math.isfinite(v):
                    v = None
                if v is not None:
                    if mode == "position":
                        target = rad_to_counts(v)
                    elif mode == "velocity":
                        vel = rad_to_counts(v)
                    else:
                        torque = int(round(max(-1000.0, min(1000.0, v / d["rated"] * 1000.0))))
            self._put(d, d["cw"], target, vel, torque)
        for mod, slave, chans in self._gpio_io:
            if mod.device == "RC2008":
                byte = 0
                for ch, slot in chans:
                    if cmd[slot] > 0.5:
                        byte |= 1 << (ch - 1)
                slave.output = bytes([byte])
        self._exchange()
        return return_type.OK

