"""``robocourse/FrankaStyleSystem`` (and the base both box drivers share): the boxes under ros2_control.

Counterpart: franka_hardware's ``FrankaHardwareInterface`` (read() = libfranka's
``readOnce()``: wait for the robot's next state; write() = ``writeOnce()``: answer it; the
robot clocks the loop, and a reflex makes read() fail). It serves the six arm joints with
``position`` / ``velocity`` / ``effort`` state interfaces and commands ``position`` or
``effort`` (torque mode, gravity added by the box). ``robocourse/URStyleSystem`` (on ur_rtde)
is in :mod:`robocourse.drivers.ur_system`.

Hardware ``<param>``s (strings, all optional):

- ``host`` (127.0.0.1); ``port`` (Franka UDP): the box to connect to. Missing or 0: the
  component starts its own box process in on_configure and stops it in on_cleanup/on_shutdown
  (``self.box``).
- ``max_missed`` (20, for a box it starts), ``read_timeout`` s (0.1: read() returns
  ERROR when no new state arrives for this long: the box is dead or unreachable).

Errors: read() returns ERROR (and ``self.last_error`` says why, logged once outside the
loop's hot path) when the box stops sending, its process dies, or (Franka) it reports a reflex.
The controller manager then deactivates the controllers using the arm. A Franka reflex is
cleared only by :meth:`FrankaStyleSystem.automatic_error_recovery` (franka_hardware's
``~/error_recovery`` service); on_activate refuses while the box reports an error.
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.control.hardware.component import SystemInterface
from robocourse.control.hardware.types import CallbackReturn, return_type

from . import franka_protocol as fp
from .arm import ARM_JOINTS
from .process import BoxProcess, BoxStartError

#: read(): how long to wait for a state before returning ERROR (the default of the read_timeout param)
READ_TIMEOUT_S = 0.1

_STATES = ("position", "velocity", "effort")


class _BoxSystem(SystemInterface):
    """What both drivers share: params, the box they own, slots for the six joints, mode switching."""

    KIND = ""
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
        if sorted(names) != sorted(ARM_JOINTS):
            self.get_logger().error(f"{type(self).__name__} '{info.name}' serves exactly the six arm joints "
                                    f"{list(ARM_JOINTS)}, got {names}; build the URDF with "
                                    "robocourse.drivers.arm_urdf(plugin)")
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
        self._state_slots = [np.array([si.get(f"{j}/{s}", -1) for j in ARM_JOINTS], dtype=np.intp) for s in _STATES]
        self._cmd_slots = {m: np.array([ci.get(f"{j}/{m}", -1) for j in ARM_JOINTS], dtype=np.intp)
                           for m in self.COMMAND_MODES}
        self._cmd = np.zeros(6)

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
        mine = {f"{j}/{m}": m for j in ARM_JOINTS for m in self.COMMAND_MODES}
        modes = {mine[k] for k in start_interfaces if k in mine}
        joints = {k.rpartition("/")[0] for k in start_interfaces if k in mine}
        if len(modes) > 1 or (modes and len(joints) != 6):
            self.get_logger().error(f"{type(self).__name__}: a controller must claim one command mode for all six "
                                    f"arm joints at once, got {sorted(k for k in start_interfaces if k in mine)}")
            return return_type.ERROR
        return return_type.OK

    def perform_command_mode_switch(self, start_interfaces, stop_interfaces):
        mine = {f"{j}/{m}": m for j in ARM_JOINTS for m in self.COMMAND_MODES}
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


class FrankaStyleSystem(_BoxSystem):
    """robocourse/FrankaStyleSystem (see the module docstring)."""

    KIND = "franka"
    COMMAND_MODES = ("position", "effort")
    SUPPORTED_COMMAND_INTERFACES = COMMAND_MODES

    def __init__(self, box: BoxProcess | None = None):
        super().__init__(box)
        self.robot = None

    def _read_params(self) -> None:
        p = self.info.hardware_parameters
        self.host = p.get("host", "127.0.0.1")
        self.port = int(self._param("port", 0, 0, 65535))
        self.max_missed = int(self._param("max_missed", fp.DEFAULT_MAX_MISSED, 0, 100000))

    def on_configure(self, previous_state):
        from .franka_client import NetworkException, Robot

        self._slots()
        port = self.port
        if port == 0:
            if self.box is None or not self.box.alive():
                if not self._start_box(["--max-missed", str(self.max_missed)]):
                    return CallbackReturn.FAILURE
            port = self.box.ports["udp"]
        if self.robot is None:
            try:
                self.robot = Robot(self.host, port, timeout=max(1.0, self.read_timeout))
            except NetworkException as exc:
                self.get_logger().error(str(exc))
                return CallbackReturn.FAILURE
        if not self.robot.read_latest(self.read_timeout * 10):
            self.get_logger().error(f"no state from the Franka-style box at {self.host}:{port}")
            return CallbackReturn.FAILURE
        self._copy_states(self.robot.q, self.robot.dq, self.robot.tau_J)
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        if self.robot.errors:
            self.get_logger().error(f"the robot is in reflex {fp.error_names(self.robot.errors)}: call "
                                    "automatic_error_recovery() before activating")
            return CallbackReturn.FAILURE
        return CallbackReturn.SUCCESS

    def automatic_error_recovery(self) -> list[str]:
        """franka_hardware's error recovery: clear the box's reflex (connects if needed)."""
        if self.robot is None:
            from .franka_client import Robot

            self.robot = Robot(self.host, self.port or self.box.ports["udp"])
        return self.robot.automatic_error_recovery()

    def _disconnect(self) -> None:
        if self.robot is not None:
            self.robot.close()
            self.robot = None

    def _stop_motion(self) -> None:
        r = self.robot
        if r is not None and self.active_mode is not None and r.errors == 0:
            try:
                r.write_command(self._commands(), fp.MODE_POSITION if self.active_mode == "position"
                                else fp.MODE_TORQUE, motion_finished=True)
            except ConnectionError:
                pass

    # --- hot path ----------------------------------------------------------------------------------
    def read(self, time, period):
        r = self.robot
        if r is None:
            return self.fail("not connected to the box")
        if self.box is not None and not self.box.alive():
            return self.fail(f"the box process (pid {self.box.pid}) is gone")
        try:
            fresh = r.read_latest(self.read_timeout)
        except ConnectionError as exc:
            return self.fail(str(exc))
        if not fresh:
            return self.fail(f"no new robot state for {self.read_timeout * 1e3:.0f} ms")
        if r.errors:
            return self.fail(f"the robot stopped with {fp.error_names(r.errors)} (success rate "
                             f"{r.success_rate:.3f}); call automatic_error_recovery()")
        self._copy_states(r.q, r.dq, r.tau_J)
        return return_type.OK

    def write(self, time, period):
        if self.active_mode is None:
            return return_type.OK
        try:
            self.robot.write_command(self._commands(), fp.MODE_POSITION if self.active_mode == "position"
                                     else fp.MODE_TORQUE)
        except ConnectionError as exc:
            return self.fail(str(exc))
        return return_type.OK
