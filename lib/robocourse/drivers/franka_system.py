"""``robocourse/FrankaStyleSystem``: franka_hardware's SystemInterface, running on pylibfranka.

Counterpart: franka_hardware's ``FrankaHardwareInterface`` (franka_ros2), which runs on libfranka:
read() is ``readOnce()`` (it waits for the robot's next state, so the robot clocks the
controller manager's loop at 1 kHz), write() is ``writeOnce()`` (it answers that state). A
command mode switch starts the matching libfranka control: ``position`` ->
``start_joint_position_control(JointImpedance)``, ``velocity`` ->
``start_joint_velocity_control(JointImpedance)``, ``effort`` -> ``start_torque_control()`` (the
robot adds gravity). The seven FR3 joints ``fr3_joint1..7`` with ``position`` / ``velocity`` /
``effort`` states (q, dq, tau_J).

Hardware ``<param>``s (strings, all optional):

- ``robot_ip``: the robot (a Franka box's ``box.host``). Missing: the component starts its own
  box process in on_configure and stops it in on_cleanup/on_shutdown (``self.box``).
- ``max_lost`` (20): for a box it starts, lost packets in a row before the communication reflex.
- ``limit_rate`` (true): pass position and velocity commands through a rate limiter
  (:class:`_RateLimiter`, in the spirit of libfranka's ``franka::limitRate``: the commanded
  velocity, acceleration and jerk kept below the FR3's limits, from the robot's last applied
  command), as libfranka's C++ ``Robot::control(..., limit_rate)`` offers.
  Without it, a command sampled on the controller manager's wall clock carries that clock's
  jitter against the robot's 1 ms grid, which the robot's jerk check (5000 rad/s³ = 5 µrad per
  cycle³) sees as a discontinuity; torques are never limited here.

Errors: read() returns ERROR (``self.last_error`` says why, logged once by on_error) when
pylibfranka raises: a reflex (``ControlException``: "libfranka: Move command aborted: motion
aborted by reflex! ["communication_constraints_violation"]", or a limit the command broke), a
silent robot (``NetworkException``: "libfranka: UDP receive: Timeout" after 1 s), or when the
box process it was given is gone (checked first, so that is immediate). The controller manager
then deactivates the controllers. A reflex is cleared only by :meth:`automatic_error_recovery`
(franka_hardware's ``~/error_recovery`` service); on_activate refuses while the robot reports
errors. Where we differ: no rate limiter or low-pass filter (as pylibfranka's writeOnce; a
controller must send commands the robot accepts, e.g. a trajectory controller's), no gripper,
no Cartesian interfaces, no automatic recovery at activation.
"""

from __future__ import annotations

import numpy as np

from robocourse.control.hardware.types import CallbackReturn, return_type
from robocourse.rt import settings

from . import franka_wire as fw
from .fr3_arm import FR3_JOINTS
from .systems import _BoxSystem


class FrankaStyleSystem(_BoxSystem):
    """robocourse/FrankaStyleSystem (see the module docstring)."""

    KIND = "franka"
    JOINTS = FR3_JOINTS
    URDF_HINT = "robocourse.drivers.fr3_urdf(plugin)"
    COMMAND_MODES = ("position", "velocity", "effort")
    SUPPORTED_COMMAND_INTERFACES = COMMAND_MODES

    def __init__(self, box=None):
        super().__init__(box)
        self.robot = None
        self.control = None
        self._limiter = None

    def _read_params(self) -> None:
        p = self.info.hardware_parameters
        self.robot_ip = p.get("robot_ip", "")
        self.max_lost = int(self._param("max_lost", fw.MAX_LOST_IN_ROW, 1, 100000))
        raw = p.get("limit_rate", "true").strip().lower()
        if raw not in ("true", "false"):
            raise ValueError(f"FrankaStyleSystem '{self.info.name}': <param name=\"limit_rate\">{raw}</param> must be "
                             "true or false, e.g. true")
        self.limit_rate = raw == "true"

    def _connect(self):
        import pylibfranka

        ip = self.robot_ip or self.box.host
        # libfranka's Robot() raises the constructing thread (here the controller manager's caller,
        # often a notebook kernel) to SCHED_FIFO 99 when allowed and keeps it there; the manager's
        # loop sets its own priority (rt.settings), so the thread gets its policy back at once
        with settings.scheduling_kept():
            self.robot = pylibfranka.Robot(ip, pylibfranka.RealtimeConfig.kIgnore)
        return self.robot

    def on_configure(self, previous_state):
        import pylibfranka

        self._slots()
        if not self.robot_ip and (self.box is None or not self.box.alive()):
            if not self._start_box(["--max-lost", str(self.max_lost)]):
                return CallbackReturn.FAILURE
        try:
            if self.robot is None:
                self._connect()
            state = self.robot.read_once()
        except pylibfranka.FrankaException as exc:   # NetworkException, IncompatibleVersion, ...
            self.get_logger().error(f"cannot connect to the FR3 at {self.robot_ip or self.box.host}: {exc}")
            self.robot = None
            return CallbackReturn.FAILURE
        except RuntimeError as exc:
            self.get_logger().error(f"cannot connect to the FR3 at {self.robot_ip or self.box.host}: {exc}")
            self.robot = None
            return CallbackReturn.FAILURE
        self._copy(state)
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        state = self.robot.read_once()
        if state.current_errors:
            self.get_logger().error(f"the robot reports {state.current_errors}: call automatic_error_recovery() "
                                    "(franka_hardware's ~/error_recovery) before activating")
            return CallbackReturn.FAILURE
        return CallbackReturn.SUCCESS

    def automatic_error_recovery(self) -> list[str]:
        """franka_hardware's ~/error_recovery: ``automatic_error_recovery()``; returns the errors left."""
        if self.robot is None:
            self._connect()
        self.robot.automatic_error_recovery()
        errors = self.robot.read_once().current_errors
        return [name for name in fw.ERROR_NAMES if getattr(errors, name, False)]

    def _disconnect(self) -> None:
        self.control = None          # pylibfranka ends a running motion (StopMove) when it is dropped
        self.robot = None

    def _stop_motion(self) -> None:
        """End the running control with a last command marked motion_finished, as franka_hardware does."""
        import pylibfranka

        c = self.control
        self.control = None
        if c is None or self.robot is None:
            return
        try:
            c.writeOnce(self._command(motion_finished=True))
        except (pylibfranka.FrankaException, RuntimeError):
            pass

    def perform_command_mode_switch(self, start_interfaces, stop_interfaces):
        import pylibfranka

        if super().perform_command_mode_switch(start_interfaces, stop_interfaces) != return_type.OK:
            return return_type.ERROR
        if self.active_mode is None or self.control is not None:
            return return_type.OK
        mode = pylibfranka.ControllerMode.JointImpedance
        try:
            self.control = {"position": lambda: self.robot.start_joint_position_control(mode),
                            "velocity": lambda: self.robot.start_joint_velocity_control(mode),
                            "effort": self.robot.start_torque_control}[self.active_mode]()
            self._state, _ = self.control.readOnce()
            self._limiter = _RateLimiter(self.active_mode)
            self.control.writeOnce(self._command())     # answer at once: the robot counts from its first state
        except (pylibfranka.FrankaException, RuntimeError) as exc:
            self.get_logger().error(f"FrankaStyleSystem: starting {self.active_mode} control failed: {exc}")
            self.control = None
            self.active_mode = None
            return return_type.ERROR
        return return_type.OK

    def _command(self, motion_finished: bool = False):
        import pylibfranka

        values = self._commands()
        if self.limit_rate and self.active_mode in ("position", "velocity"):
            values = self._limiter.limit(values, self._state)
        values = values.tolist()
        cmd = {"position": pylibfranka.JointPositions, "velocity": pylibfranka.JointVelocities,
               "effort": pylibfranka.Torques}[self.active_mode](values) if self.active_mode else None
        if cmd is None:   # stopping with no mode: hold where the arm is
            cmd = pylibfranka.JointPositions(list(self._state.q))
        cmd.motion_finished = motion_finished
        return cmd

    def _copy(self, state) -> None:
        self._state = state
        self._copy_states(np.asarray(state.q), np.asarray(state.dq), np.asarray(state.tau_J))

    # --- hot path ------------------------------------------------------------------------------
    def read(self, time, period):
        import pylibfranka

        if self.robot is None:
            return self.fail("not connected to the robot")
        if self.box is not None and not self.box.alive():
            return self.fail(f"the Franka box process (pid {self.box.pid}) is gone")
        try:
            if self.control is not None:
                state = self.control.readOnce()[0]
            else:
                state = self.robot.read_once()
        except (pylibfranka.FrankaException, RuntimeError) as exc:   # ControlException, NetworkException
            self.control = None
            return self.fail(str(exc))
        self._copy(state)
        return return_type.OK

    def write(self, time, period):
        import pylibfranka

        if self.control is None:
            return return_type.OK
        try:
            self.control.writeOnce(self._command())
        except (pylibfranka.FrankaException, RuntimeError) as exc:
            self.control = None
            return self.fail(str(exc))
        return return_type.OK


class _RateLimiter:
    """A rate limiter in the spirit of libfranka's ``limitRate``: the next command's velocity,
    acceleration and jerk kept below the FR3's limits, starting from what the robot last applied
    (the state's q_d, dq_d, ddq_d, so a lost or late packet the robot extrapolated is accounted
    for), one cycle ahead (``dt``: readOnce's Duration, the robot's clock).

    Counterpart: ``franka::limitRate`` (include/franka/rate_limiting.h@0.21.2), which also starts
    from the state's desired values. Ours differs: the target is approached through a critically
    damped second-order filter (``WN`` = 2π·20 Hz: a 0.3 rad quintic over 1 s lags by ~9 mrad at
    its peak speed), not in one cycle, because libfranka's one-cycle chase rings around a target
    that arrives with the controller manager's wall-clock jitter; the limits carry a 5 % margin
    (the state is float32 on the wire: its rounding alone is ~120 rad/s³ of jerk at 1 ms); the
    velocity limit is the constant q̇max, not the position-dependent envelope."""

    WN = 2 * np.pi * 20.0

    def __init__(self, mode: str):
        from robocourse.sim.robots import joint_limits

        lim = joint_limits("fr3")
        self.vmax = 0.95 * np.array([lim[j].velocity for j in FR3_JOINTS])
        self.amax, self.jmax = 0.95 * fw.MAX_JOINT_ACCELERATION, 0.95 * fw.MAX_JOINT_JERK
        self.mode = mode

    def limit(self, desired: np.ndarray, state) -> np.ndarray:
        dt, wn = 1e-3, self.WN
        v, a = np.asarray(state.dq_d, dtype=float), np.asarray(state.ddq_d, dtype=float)
        if self.mode == "position":
            x = np.asarray(state.q_d, dtype=float)
            a_goal = wn * wn * (desired - x) - 2.0 * wn * v
        else:
            a_goal = wn * (np.clip(desired, -self.vmax, self.vmax) - v)
        a = np.clip(a + np.clip((a_goal - a) / dt, -self.jmax, self.jmax) * dt, -self.amax, self.amax)
        v = np.clip(v + a * dt, -self.vmax, self.vmax)
        return x + v * dt if self.mode == "position" else v
