"""``mock_components/GenericSystem``: a system that mirrors commands to states.

Counterpart: ros2_control:hardware_interface/src/mock_components/generic_system.cpp. Every
upstream parameter (``<hardware><param>``, strings parsed like upstream's ``parse_bool``):

- ``calculate_dynamics`` (false): integrate position/velocity/acceleration from the joint's
  active command mode (position by default, switched by ``perform_command_mode_switch``);
- ``custom_interface_with_following_offset`` (""): write ``position cmd + offset`` to this
  state interface instead of offsetting ``position``;
- ``disable_commands`` (false): read() leaves every state alone (lost feedback);
- ``mock_gpio_commands`` / ``mock_sensor_commands`` (false): add a command interface for every
  gpio / sensor state interface and mirror it;
- ``position_state_following_offset`` (0.0): added to position when mirroring (and once to the
  initial position at configure).

Without dynamics a state takes its same-named command when that command is finite; NaN leaves
the state alone; an infinite command makes read() return ERROR. Mimic joints follow
``offset + multiplier * mimicked`` (velocity and acceleration scaled). Vectorised with numpy
index arrays built at configure, so read() is a handful of array calls.
"""

from __future__ import annotations

import math

import numpy as np

from .component import InterfaceDescription, SystemInterface
from .types import CallbackReturn, return_type

_MODES = ("position", "velocity", "acceleration")


def parse_bool(text: str) -> bool:
    return str(text).strip().lower() == "true"


class GenericSystem(SystemInterface):
    """mock_components::GenericSystem (see the module docstring for parameters and behaviour)."""

    def on_init(self, info):
        super().on_init(info)
        p = info.hardware_parameters
        self.calculate_dynamics = parse_bool(p.get("calculate_dynamics", "false"))
        self.custom_interface_with_following_offset = p.get("custom_interface_with_following_offset", "")
        self.disable_commands = parse_bool(p.get("disable_commands", "false"))
        self.mock_gpio_commands = parse_bool(p.get("mock_gpio_commands", "false"))
        self.mock_sensor_commands = parse_bool(p.get("mock_sensor_commands", "false"))
        try:
            self.position_state_following_offset = float(p.get("position_state_following_offset", "0.0"))
        except ValueError:
            self.get_logger().error(f"position_state_following_offset must be a number, got "
                                    f"{p['position_state_following_offset']!r}")
            return CallbackReturn.ERROR
        self._warned_disabled = False
        return CallbackReturn.SUCCESS

    def export_command_interfaces(self):
        out = super().export_command_interfaces() if not self.mock_gpio_commands else [
            InterfaceDescription(j.name, i.name, i.initial()) for j in self.info.joints for i in j.command_interfaces]
        names = {d.name for d in out}
        extra = []
        if self.mock_sensor_commands:
            extra += [(s.name, i.name) for s in self.info.sensors for i in s.state_interfaces]
        if self.mock_gpio_commands:
            extra += [(g.name, i.name) for g in self.info.gpios for i in g.state_interfaces]
            extra += [(g.name, i.name) for g in self.info.gpios for i in g.command_interfaces]
        for prefix, itf in extra:
            if f"{prefix}/{itf}" not in names:
                names.add(f"{prefix}/{itf}")
                out.append(InterfaceDescription(prefix, itf, math.nan))
        return out

    # --- lifecycle ------------------------------------------------------------------------------
    def on_configure(self, previous_state):
        off = self.position_state_following_offset
        custom = self.custom_interface_with_following_offset
        initial = {d.name: d.initial_value for d in SystemInterface.export_state_interfaces(self)}
        for name, i in self.state_index.items():
            v = initial.get(name, math.nan)
            self.state_values[i] = 0.0 if math.isnan(v) else v
        for j in self.info.joints:
            key = f"{j.name}/position"
            if key in self.state_index and not custom:
                self.state_values[self.state_index[key]] += off
        self._build_index()
        self.mode = {j.name: "position" for j in self.info.joints}
        return CallbackReturn.SUCCESS

    def _build_index(self):
        off = self.position_state_following_offset
        custom = self.custom_interface_with_following_offset
        src, dst, add = [], [], []
        for comp in self.info.joints + self.info.sensors + self.info.gpios:
            for itf in comp.state_interfaces:
                key = f"{comp.name}/{itf.name}"
                if key in self.command_index:
                    src.append(self.command_index[key])
                    dst.append(self.state_index[key])
                    add.append(off if (itf.name == "position" and comp.type == "joint" and not custom) else 0.0)
            if custom and comp.type == "joint":
                ckey, skey = f"{comp.name}/position", f"{comp.name}/{custom}"
                if ckey in self.command_index and skey in self.state_index:
                    src.append(self.command_index[ckey])
                    dst.append(self.state_index[skey])
                    add.append(off)
        self._src = np.array(src, dtype=np.intp)
        self._dst = np.array(dst, dtype=np.intp)
        self._add = np.array(add)
        self._buf = np.zeros(len(src))
        self._old = np.zeros(len(src))
        self._nan = np.zeros(len(src), dtype=bool)
        # joints' position/velocity/acceleration (state slot or -1, command slot or -1)
        self._joint_slots = []
        for j in self.info.joints:
            s = [self.state_index.get(f"{j.name}/{m}", -1) for m in _MODES]
            c = [self.command_index.get(f"{j.name}/{m}", -1) for m in _MODES]
            self._joint_slots.append((j.name, s, c))
        self._dyn = np.zeros((len(self.info.joints), 3))  # p, v, a per joint
        for k, (_, s, _) in enumerate(self._joint_slots):
            for m in range(3):
                if s[m] >= 0:
                    self._dyn[k, m] = self.state_values[s[m]]
        self._mimic = [(m.joint_index, m.mimicked_joint_index, m.multiplier, m.offset) for m in self.info.mimic_joints]

    def on_activate(self, previous_state):
        return CallbackReturn.SUCCESS

    # --- command modes ----------------------------------------------------------------------------
    def prepare_command_mode_switch(self, start_interfaces, stop_interfaces):
        if not self.calculate_dynamics:
            return return_type.OK
        joints = {j.name for j in self.info.joints}
        per_joint: dict[str, list[str]] = {}
        for key in start_interfaces:
            prefix, _, itf = key.rpartition("/")
            if prefix in joints:
                per_joint.setdefault(prefix, []).append(itf)
        for joint, itfs in per_joint.items():
            modes = [i for i in itfs if i in _MODES]
            if not modes:
                self.get_logger().error(f"Joint '{joint}' has to have 'position', 'velocity', or 'acceleration' interface!")
                return return_type.ERROR
            if len(modes) > 1:
                self.get_logger().error(f"Got multiple ({len(modes)}) starting interfaces for joint '{joint}' - "
                                   "this is not supported!")
                return return_type.ERROR
        return return_type.OK

    def perform_command_mode_switch(self, start_interfaces, stop_interfaces):
        if not self.calculate_dynamics:
            return return_type.OK
        joints = {j.name for j in self.info.joints}
        for key in start_interfaces:
            prefix, _, itf = key.rpartition("/")
            if prefix in joints and itf in _MODES:
                self.mode[prefix] = itf
        return return_type.OK

    # --- cyclic -------------------------------------------------------------------------------------
    def write(self, time, period):
        return return_type.OK

    def read(self, time, period):
        if self.disable_commands:
            if not self._warned_disabled:
                self._warned_disabled = True
                self.get_logger().warning("Command propagation is disabled - no values will be returned!")
            return return_type.OK
        cmd, st = self.command_values, self.state_values
        buf = self._buf
        if len(buf):
            np.take(cmd, self._src, out=buf)
            if np.isinf(buf, out=self._nan).any():     # preallocated mask: no new array per cycle
                return return_type.ERROR
            if self.calculate_dynamics:
                self._dynamics(cmd, st, period)
            buf += self._add
            np.isnan(buf, out=self._nan)
            np.take(st, self._dst, out=self._old)
            np.copyto(buf, self._old, where=self._nan)
            if self.calculate_dynamics:
                self._restore_dynamic_states(buf)
            st[self._dst] = buf
        elif self.calculate_dynamics:
            self._dynamics(cmd, st, period)
        for ji, mi, mult, off in self._mimic:
            _, s, _ = self._joint_slots[ji]
            _, sm, _ = self._joint_slots[mi]
            for m in range(3):
                if s[m] >= 0 and sm[m] >= 0:
                    st[s[m]] = (off if m == 0 else 0.0) + mult * st[sm[m]]
        return return_type.OK

    def _dynamics(self, cmd, st, period):
        dt = period if period > 0 else 0.0
        off = self.position_state_following_offset
        for k, (name, s, c) in enumerate(self._joint_slots):
            p, v, a = self._dyn[k]
            mode = self.mode[name]
            if mode == "position" and c[0] >= 0 and not math.isnan(cmd[c[0]]):
                p_new = cmd[c[0]] + off
                v_new = (p_new - p) / dt if dt else 0.0
                a = (v_new - v) / dt if dt else 0.0
                p, v = p_new, v_new
            elif mode == "velocity" and c[1] >= 0 and not math.isnan(cmd[c[1]]):
                v_new = cmd[c[1]]
                a = (v_new - v) / dt if dt else 0.0
                v = v_new
                p = p + v * dt
            elif mode == "acceleration" and c[2] >= 0 and not math.isnan(cmd[c[2]]):
                a = cmd[c[2]]
                v = v + a * dt
                p = p + v * dt
            self._dyn[k] = (p, v, a)
            for m in range(3):
                if s[m] >= 0:
                    st[s[m]] = self._dyn[k, m]

    def _restore_dynamic_states(self, buf):
        # with dynamics, position/velocity/acceleration states come from the integrator, not mirroring
        dyn_slots = {s[m] for _, s, _ in self._joint_slots for m in range(3) if s[m] >= 0}
        for i, d in enumerate(self._dst):
            if int(d) in dyn_slots:
                buf[i] = self.state_values[d]
