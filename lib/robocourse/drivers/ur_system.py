"""``robocourse/URStyleSystem``: a UR e-Series arm under ros2_control, through ur_rtde.

Counterpart: ur_robot_driver's ``URPositionHardwareInterface``, which runs on its own client
library (ur_client_library); ours runs on ur_rtde 1.6.5 from PyPI, the client a student uses on a
real UR5e, so the same calls reach a real robot. read() takes the newest RTDE state ur_rtde's
receive thread holds; write() sends the position command as a ``servoJ`` target; the robot's
controller runs its own 500 Hz loop whatever this one does. Six arm joints, ``position`` /
``velocity`` / ``effort`` states (effort = ``actual_current`` in A, as ur_robot_driver reports
it), ``position`` commands.

Hardware ``<param>``s (strings, all optional):

- ``robot_ip``: the controller's address. Missing: the component starts its own UR-style box
  (:func:`robocourse.drivers.start_ur_box`) in on_configure and stops it in on_cleanup/on_shutdown.
- ``servoj_time`` (0.002 s), ``servoj_lookahead_time`` (0.03 s), ``servoj_gain`` (2000):
  ur_robot_driver's defaults for its servoj.
- ``keepalive`` (0.1 s): the RTDE watchdog set at activation (``setWatchdog(1 / keepalive)``):
  when write() stops reaching the robot for longer, the robot stops its control program.
- ``read_timeout`` (0.1 s): read() returns ERROR when the controller's timestamp has not
  advanced for this long (the box is gone or the network is).

Errors, and the one recovery rule. read()/write() return ERROR (``self.last_error`` says why,
logged once by on_error) when the state stream stops, the box process dies, the robot reports a
protective stop, or its control program is no longer running (the watchdog fired, someone
stopped it). The controller manager then deactivates the controllers using the arm and the
component goes to unconfigured. Nothing restarts by itself: an operator clears the robot's side
(a protective stop: :meth:`URStyleSystem.unlock_protective_stop`, the dashboard's ``unlock
protective stop``), then brings the component back to active (on_configure reconnects and
uploads the control script again, on_activate re-arms the watchdog), then activates the
controllers: the same two explicit steps as every driver in the course.
"""

from __future__ import annotations

import sys
import time as _time

from robocourse.control.hardware.types import CallbackReturn, return_type

from .systems import _BoxSystem

KEEPALIVE_S = 0.1
LOOKAHEAD = (0.03, 0.2)     # URScript's servoj ranges (ur_rtde refuses values outside)
GAIN = (100.0, 2000.0)
RECIPE = ["timestamp", "actual_q", "actual_qd", "actual_current", "robot_mode", "safety_status_bits",
          "runtime_state", "speed_scaling"]


class URStyleSystem(_BoxSystem):
    """robocourse/URStyleSystem (see the module docstring)."""

    KIND = "ur"
    COMMAND_MODES = ("position",)
    SUPPORTED_COMMAND_INTERFACES = COMMAND_MODES

    def __init__(self, box=None):
        super().__init__(box)
        self.rtde_r = None
        self.rtde_c = None
        self.host = None
        self._stamp = None
        self._stamp_seen = 0.0

    def _read_params(self) -> None:
        p = self.info.hardware_parameters
        self.robot_ip = p.get("robot_ip") or None
        self.servoj_time = self._param("servoj_time", 0.002, 0.002, 0.2)
        self.lookahead = self._param("servoj_lookahead_time", 0.03, *LOOKAHEAD)
        self.gain = self._param("servoj_gain", 2000.0, *GAIN)
        self.keepalive = self._param("keepalive", KEEPALIVE_S, 0.004, 10.0)

    def on_configure(self, previous_state):
        import rtde_control
        import rtde_receive

        self._slots()
        host = self.robot_ip
        if host is None:
            if self.box is None or not self.box.alive():
                if not self._start_box([]):
                    return CallbackReturn.FAILURE
            host = self.box.host
        self.host = host
        try:
            if self.rtde_r is None:
                self.rtde_r = rtde_receive.RTDEReceiveInterface(host, 500.0, RECIPE)
            if self.rtde_r.isProtectiveStopped():
                self.get_logger().error(f"the robot at {host} is in a protective stop: unlock it first "
                                        "(unlock_protective_stop(), the dashboard's 'unlock protective stop')")
                self._disconnect()
                return CallbackReturn.FAILURE
            if self.rtde_c is None:
                self.rtde_c = rtde_control.RTDEControlInterface(host)   # uploads and starts the control script
        except RuntimeError as exc:
            self.get_logger().error(f"ur_rtde could not connect to {host}: {exc}")
            self._disconnect()
            return CallbackReturn.FAILURE
        self._copy_states(self.rtde_r.getActualQ(), self.rtde_r.getActualQd(), self.rtde_r.getActualCurrent())
        self._stamp, self._stamp_seen = self.rtde_r.getTimestamp(), _time.monotonic()
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        c = self.rtde_c
        if c is None or not c.isProgramRunning():
            self.get_logger().error("the control program is not running on the robot: bring the component back "
                                    "through configure (it uploads the script again)")
            return CallbackReturn.FAILURE
        if not c.setWatchdog(1.0 / self.keepalive):
            self.get_logger().error("the robot refused setWatchdog()")
            return CallbackReturn.FAILURE
        return CallbackReturn.SUCCESS

    def unlock_protective_stop(self) -> str:
        """The dashboard's ``unlock protective stop`` (ur_robot_driver: the dashboard client's
        ``~/unlock_protective_stop`` service); returns the robot's reply."""
        import dashboard_client

        host = self.host or self.robot_ip or (self.box.host if self.box is not None else None)
        d = dashboard_client.DashboardClient(host)
        d.connect()
        try:
            d.send("unlock protective stop\n")
            return d.receive()
        finally:
            d.disconnect()

    def _disconnect(self) -> None:
        """Close both ur_rtde clients. Each ``disconnect()`` ends with a fixed 500 ms sleep (ur_rtde's
        "wait until everything has disconnected"), and each client's destructor calls ``disconnect()``
        again, sleep included: an explicit ``disconnect()`` then the destructor cost a second per
        client. When this component holds the last reference, dropping it is the one disconnect;
        a client someone else still holds is disconnected explicitly."""
        for name in ("rtde_c", "rtde_r"):
            client = getattr(self, name)
            setattr(self, name, None)
            if client is None:
                continue
            try:
                if sys.getrefcount(client) > 2:     # this frame and getrefcount's argument: anyone else?
                    client.disconnect()
            except RuntimeError:
                pass
            del client                              # the last reference: the destructor disconnects here

    def _stop_motion(self) -> None:
        c = self.rtde_c
        if c is not None and self.active_mode is not None:
            try:
                if c.isProgramRunning():
                    c.kickWatchdog()      # the stop blocks the client: give it the watchdog's whole window
                    c.servoStop()
            except RuntimeError:
                pass

    # --- hot path ----------------------------------------------------------------------------------
    def read(self, time, period):
        r = self.rtde_r
        if r is None:
            return self.fail("not connected to the robot")
        if self.box is not None and not self.box.alive():
            return self.fail(f"the box process (pid {self.box.pid}) is gone")
        now = _time.monotonic()
        stamp = r.getTimestamp()
        if stamp != self._stamp:
            self._stamp, self._stamp_seen = stamp, now
        elif now - self._stamp_seen > self.read_timeout:
            return self.fail(f"no new RTDE state for {(now - self._stamp_seen) * 1e3:.0f} ms "
                             f"(read_timeout {self.read_timeout * 1e3:.0f} ms)")
        if r.isProtectiveStopped():
            return self.fail("the robot is in a protective stop (unlock it, then bring the component back to active)")
        if self.active_mode is not None and r.getRuntimeState() != 2:
            return self.fail("the robot's control program stopped (the RTDE watchdog, a stop, a runtime error); "
                             "bring the component back to active to upload it again")
        self._copy_states(r.getActualQ(), r.getActualQd(), r.getActualCurrent())
        return return_type.OK

    def write(self, time, period):
        if self.active_mode is None:
            return return_type.OK
        if not self.rtde_c.servoJ(self._commands().tolist(), 0.0, 0.0, self.servoj_time, self.lookahead, self.gain):
            return self.fail("servoJ refused: the control program is not running")
        return return_type.OK
