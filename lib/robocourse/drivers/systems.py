"""What the box drivers share under ros2_control: ``_BoxSystem``.

The base of ``robocourse/FrankaStyleSystem`` (:mod:`robocourse.drivers.franka_system`,
franka_hardware on pylibfranka) and ``robocourse/URStyleSystem`` (:mod:`robocourse.drivers.ur_system`,
ur_robot_driver on ur_rtde): the joints a driver serves (``JOINTS``), numeric params checked
with the rule in the error, the box process a component owns (started in on_configure when no
robot address is given, stopped in on_cleanup/on_shutdown), state/command slots, one command
mode for all joints at a time, and errors: read()/write() record why they failed
(``self.last_error``), on_error logs it once outside the hot path and disconnects.
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.control.hardware.component import SystemInterface
from robocourse.control.hardware.types import CallbackReturn, return_type

from .arm import ARM_JOINTS
from .process import BoxProcess, BoxStartError

#: read(): how long to wait for a state before returning ERROR (the default of the read_timeout param)
READ_TIMEOUT_S = 0.1

_STATES = ("position", "velocity", "effort")


class _BoxSystem(SystemInterface):
    """What both drivers share: params, the box they own, slots for the six joints, mode switching."""

    KIND = ""
    JOINTS: tuple[str, ...] = ARM_JOINTS
    URDF_HINT = "robocourse.drivers.arm_urdf(plugin)"
    COMMAND_MODES: tuple[str, ...] = ()
    SUPPORTED_STATE_INTERFACES = _STATES

    def __init__(self, box: BoxProcess | None = None):
        super().__init__()
        self.box = box
        self._own_box = False
        self.last_error = ""
        self.active_mode: str | None = None

    def _param(self, name: str, default: float, lo: float, hi: float) -> float:
        raw = self.info.hardware_parameters.get(name, str(default))
        try:
            v = float(raw)
        except ValueError:
            v = math.nan
        if not lo <= v <= hi:
            raise ValueError(f"{type(self).__name__} '{self.info.name}': <param name=\"{name}\">{raw}</param> "
                             f"must be a number in [{lo}, {hi}], e.g. {default}")
        return v

    def on_init(self, info):
        super().on_init(info)
        names = [j.name for j in info.joints]
        if sorted(names) != sorted(self.JOINTS):
            self.get_logger().error(f"{type(self).__name__} '{info.name}' serves exactly the {len(self.JOINTS)} arm "
                                    f"joints {list(self.JOINTS)}, got {names}; build the URDF with {self.URDF_HINT}")
            return CallbackReturn.ERROR
        for j in info.joints:
            bad = [c.name for c in j.command_interfaces if c.name not in self.COMMAND_MODES]
            if bad:
                self.get_logger().error(f"joint '{j.name}': command interfaces {bad} are not served by "
                                        f"{type(self).__name__} (it offers {list(self.COMMAND_MODES)})")
                return CallbackReturn.ERROR
        try:
            self.read_timeout = self._param("read_timeout", READ_TIMEOUT_S, 0.001, 10.0)
            self._read_params()
        except ValueError as exc:
            self.get_logger().error(str(exc))
            return CallbackReturn.ERROR
        return CallbackReturn.SUCCESS

    def _read_params(self) -> None:
        pass

    def _slots(self) -> None:
        si, ci = self.state_index, self.command_index
        self._state_slots = [np.array([si.get(f"{j}/{s}", -1) for j in self.JOINTS], dtype=np.intp) for s in _STATES]
        self._cmd_slots = {m: np.array([ci.get(f"{j}/{m}", -1) for j in self.JOINTS], dtype=np.intp)
                           for m in self.COMMAND_MODES}
        self._cmd = np.zeros(len(self.JOINTS))

    def _start_box(self, args: list[str]) -> bool:
        if self.box is not None and self.box.alive():
            return True
        try:
            self.box = BoxProcess(self.KIND, args).start()
        except BoxStartError as exc:
            self.get_logger().error(str(exc))
            return False
        self._own_box = True
        return True

    def _stop_box(self) -> None:
        if self._own_box and self.box is not None:
            self.box.stop()
            self.box = None
            self._own_box = False

    def fail(self, why: str) -> return_type:
        """Record why the cycle failed (logged once, by on_error, outside the hot path)."""
        self.last_error = why
        return return_type.ERROR

    def on_error(self, previous_state):
        self.get_logger().error(f"{type(self).__name__} '{self.info.name}': {self.last_error or 'error'}")
        self._disconnect()
        return CallbackReturn.SUCCESS

    def on_cleanup(self, previous_state):
        self._disconnect()
        self._stop_box()
        return CallbackReturn.SUCCESS

    def on_shutdown(self, previous_state):
        return self.on_cleanup(previous_state)

    def _disconnect(self) -> None:
        raise NotImplementedError

    def prepare_command_mode_switch(self, start_interfaces, stop_interfaces):
        mine = {f"{j}/{m}": m for j in self.JOINTS for m in self.COMMAND_MODES}
        modes = {mine[k] for k in start_interfaces if k in mine}
        joints = {k.rpartition("/")[0] for k in start_interfaces if k in mine}
        if len(modes) > 1 or (modes and len(joints) != len(self.JOINTS)):
            self.get_logger().error(f"{type(self).__name__}: a controller must claim one command mode for all "
                                    f"{len(self.JOINTS)} arm joints at once, got {sorted(k for k in start_interfaces if k in mine)}")
            return return_type.ERROR
        return return_type.OK

    def perform_command_mode_switch(self, start_interfaces, stop_interfaces):
        mine = {f"{j}/{m}": m for j in self.JOINTS for m in self.COMMAND_MODES}
        if any(k in mine for k in stop_interfaces):
            self._stop_motion()
            self.active_mode = None
        started = {mine[k] for k in start_interfaces if k in mine}
        if started:
            self.active_mode = started.pop()
            slots = self._cmd_slots[self.active_mode]
            q = self.state_values[self._state_slots[0]]
            self.command_values[slots] = q if self.active_mode == "position" else 0.0
        return return_type.OK

    def _stop_motion(self) -> None:
        pass

    def on_deactivate(self, previous_state):
        self._stop_motion()
        self.active_mode = None
        return CallbackReturn.SUCCESS

    def _copy_states(self, q, dq, tau) -> None:
        st = self.state_values
        for slots, src in zip(self._state_slots, (q, dq, tau)):
            st[slots] = src

    def _commands(self) -> np.ndarray:
        """The active mode's six commands; NaN ones replaced (position: measured q; effort: 0)."""
        cmd = self._cmd
        np.take(self.command_values, self._cmd_slots[self.active_mode], out=cmd)
        if np.isnan(cmd).any():
            fill = self.state_values[self._state_slots[0]] if self.active_mode == "position" else 0.0
            np.copyto(cmd, fill, where=np.isnan(cmd))
        return cmd
