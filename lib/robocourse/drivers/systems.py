"""``robocourse/URStyleSystem``, and what it shares with ``robocourse/FrankaStyleSystem``.

Counterpart: ur_robot_driver's ``URPositionHardwareInterface`` (read() takes the newest RTDE
package; write() streams the position command as a servoj target; the robot runs on its own).
It serves the six UR5e arm joints with ``position`` / ``velocity`` / ``effort`` state interfaces
and commands ``position``. ``_BoxSystem`` (params, the box a component owns, slots, command mode
switching) is shared with :mod:`robocourse.drivers.franka_system` (franka_hardware on pylibfranka).

Hardware ``<param>``s (strings, all optional):

- ``host`` (127.0.0.1); ``rtde_port`` + ``script_port``: the box to connect to. Missing or 0:
  the component starts its own box process in on_configure and stops it in
  on_cleanup/on_shutdown (``self.box``).
- ``servoj_time`` (0.002), ``servoj_lookahead_time`` (0.03), ``servoj_gain`` (2000)
  (ur_robot_driver's defaults), ``keepalive`` s (0.1, for a box it starts), ``read_timeout``
  s (0.1).

Errors: read() returns ERROR (and ``self.last_error`` says why, logged once outside the
loop's hot path) when the box stops sending or its process dies. The controller manager then
deactivates the controllers using the arm.
"""

from __future__ import annotations

import math
import time as _time

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


class URStyleSystem(_BoxSystem):
    """robocourse/URStyleSystem (see the module docstring)."""

    KIND = "ur"
    COMMAND_MODES = ("position",)
    SUPPORTED_COMMAND_INTERFACES = COMMAND_MODES

    def __init__(self, box: BoxProcess | None = None):
        super().__init__(box)
        self.rtde = None
        self.control = None

    def _read_params(self) -> None:
        from . import ur_protocol as up

        p = self.info.hardware_parameters
        self.host = p.get("host", "127.0.0.1")
        self.rtde_port = int(self._param("rtde_port", 0, 0, 65535))
        self.script_port = int(self._param("script_port", 0, 0, 65535))
        self.servoj_time = self._param("servoj_time", 0.002, *up.SERVOJ_T)
        self.lookahead = self._param("servoj_lookahead_time", 0.03, *up.LOOKAHEAD)
        self.gain = self._param("servoj_gain", 2000.0, *up.GAIN)
        self.keepalive = self._param("keepalive", up.KEEPALIVE_S, 0.004, 10.0)

    def on_configure(self, previous_state):
        from .ur_client import RTDEControlInterface, RTDEError, RTDEReceiveInterface

        self._slots()
        rtde_port, script_port = self.rtde_port, self.script_port
        if rtde_port == 0 or script_port == 0:
            if self.box is None or not self.box.alive():
                if not self._start_box(["--keepalive", str(self.keepalive)]):
                    return CallbackReturn.FAILURE
            rtde_port, script_port = self.box.ports["rtde"], self.box.ports["script"]
        try:
            if self.rtde is None:
                self.rtde = RTDEReceiveInterface(self.host, rtde_port, 500.0,
                                                 ("actual_q", "actual_qd", "actual_joint_torques", "runtime_state"))
            if self.control is None:
                self.control = RTDEControlInterface(self.host, script_port)
        except RTDEError as exc:
            self.get_logger().error(str(exc))
            self._disconnect()
            return CallbackReturn.FAILURE
        if not self.rtde.receive(self.read_timeout * 10):
            self.get_logger().error(f"no RTDE package from the UR-style box at {self.host}:{rtde_port}")
            return CallbackReturn.FAILURE
        v = self.rtde.values
        self._copy_states(v["actual_q"], v["actual_qd"], v["actual_joint_torques"])
        return CallbackReturn.SUCCESS

    def _disconnect(self) -> None:
        for c in (self.rtde, self.control):
            if c is not None:
                c.close()
        self.rtde = self.control = None

    def _stop_motion(self) -> None:
        if self.control is not None:
            try:
                self.control.servoStop()
            except ConnectionError:
                pass

    # --- hot path ----------------------------------------------------------------------------------
    def read(self, time, period):
        r = self.rtde
        if r is None:
            return self.fail("not connected to the box")
        r.receive(0.0)
        if r.closed_by_peer:
            return self.fail("the box closed the RTDE connection (process gone?)")
        if _time.monotonic() - r.last_receive > self.read_timeout:
            return self.fail(f"no RTDE package for {self.read_timeout * 1e3:.0f} ms")
        v = r.values
        self._copy_states(v["actual_q"], v["actual_qd"], v["actual_joint_torques"])
        return return_type.OK

    def write(self, time, period):
        if self.active_mode is None:
            return return_type.OK
        try:
            self.control.servoJ(self._commands(), time=self.servoj_time, lookahead_time=self.lookahead,
                                gain=self.gain)
        except ConnectionError as exc:
            return self.fail(str(exc))
        return return_type.OK
