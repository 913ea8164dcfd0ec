"""The simulated UR e-Series controller behind the UR-style box: modes, IO, registers, the control script.

Counterpart: the UR controller (its robot, safety and program state machines, its IO and RTDE
registers, the URScript runtime running ur_rtde's control script) as ur_rtde and
ur_robot_driver see it through RTDE, the dashboard server and the script ports. No sockets
here: :class:`robocourse.drivers.ur_box.URBox` feeds it what arrives and sends what it says.

State machines (UR's names and numbers):

- robot mode: POWER_OFF (3) -> ``power on`` -> IDLE (5, brakes on) -> ``brake release`` ->
  RUNNING (7). The box starts in RUNNING unless asked to start powered off. (A real arm takes
  seconds for each step; ours takes none.)
- safety mode: NORMAL (1); PROTECTIVE_STOP (3) after ``triggerProtectiveStop()``: the arm
  stops (decelerating at :data:`STOP_DECELERATION`), the program stops, and the dashboard's
  ``unlock protective stop`` clears it, refused for the first ``unlock_delay`` s as on a real
  robot (5 s).
- runtime state: STOPPED (1), PLAYING (2), PAUSED (4). A program runs only in RUNNING mode.
  When it stops (stopScript, the watchdog, a runtime error, ``stop`` on the dashboard, a
  protective stop, power off) every watchdog is removed and the arm decelerates to rest.

The control script's register protocol is in :mod:`robocourse.drivers.ur_script`; motions in
:mod:`robocourse.drivers.ur_motion`. The RTDE watchdog (``setWatchdog(f)`` = URScript
``rtde_set_watchdog("input_int_register_0", f, "stop")``): when no RTDE package updates that
register for longer than 1/f s, the program stops (``watchdog_stops``), as UR documents it.

What the outputs carry (:meth:`URController.outputs`): target_q/qd/qdd from the motion
generator; actual_q/qd from MuJoCo; target_moment the joint servos' torque; currents = torque
/ :data:`TORQUE_CONSTANT` (ours: the simulation has no motor model); TCP pose and speed from
the arm's kinematics (flange tool0 plus the TCP offset, UR's rotation-vector poses in the base
frame); actual_TCP_force the flange force/torque sensor in the base frame at the TCP, less
the payload's weight (set by setPayload, default the gripper's mass) and the zeroFtSensor
offset; ft_raw_wrench the sensor in the flange frame uncompensated; the accelerometer the
specific force of gravity in the flange frame (quasi-static). Honest constants, not modelled:
joint temperatures :data:`JOINT_TEMPERATURE`, tool temperature :data:`TOOL_TEMPERATURE`, 48 V
supplies, digital and analog inputs 0 (nothing wired), euromap67 0, joint_control_output = the
target current.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import ur_script as us
from .ur_motion import HOLD, JointMotion

# robot modes
ROBOT_MODE_POWER_OFF, ROBOT_MODE_POWER_ON, ROBOT_MODE_IDLE, ROBOT_MODE_RUNNING = 3, 4, 5, 7
ROBOT_MODE_NAMES = {-1: "NO_CONTROLLER", 0: "DISCONNECTED", 1: "CONFIRM_SAFETY", 2: "BOOTING", 3: "POWER_OFF",
                    4: "POWER_ON", 5: "IDLE", 6: "BACKDRIVE", 7: "RUNNING", 8: "UPDATING_FIRMWARE"}
# safety modes
SAFETY_NORMAL, SAFETY_PROTECTIVE_STOP = 1, 3
SAFETY_MODE_NAMES = {1: "NORMAL", 2: "REDUCED", 3: "PROTECTIVE_STOP", 4: "RECOVERY", 5: "SAFEGUARD_STOP",
                     6: "SYSTEM_EMERGENCY_STOP", 7: "ROBOT_EMERGENCY_STOP", 8: "VIOLATION", 9: "FAULT"}
# runtime states
RUNTIME_STOPPED, RUNTIME_PLAYING, RUNTIME_PAUSED = 1, 2, 4
RUNTIME_NAMES = {0: "STOPPING", 1: "STOPPED", 2: "PLAYING", 3: "PAUSING", 4: "PAUSED", 5: "RESUMING"}
# joint modes
JOINT_POWER_OFF, JOINT_RUNNING, JOINT_IDLE = 239, 253, 255
# robot_status_bits / safety_status_bits
STATUS_POWER_ON, STATUS_PROGRAM_RUNNING = 1 << 0, 1 << 1
SAFETY_BIT_NORMAL, SAFETY_BIT_PROTECTIVE_STOPPED = 1 << 0, 1 << 2

CONTROLLER_VERSION = (5, 15, 0, 0)     # claimed: ur_rtde's default recipes at 5.15 (below 5.23, see reference C4)
SERIAL_NUMBER = "20235500001"
ROBOT_MODEL = "UR5"                    # what the dashboard's `get robot model` says for a UR5e
STOP_DECELERATION = 10.0               # rad/s^2: program stop, protective stop (ours)
UNLOCK_DELAY_S = 5.0                   # UR: a protective stop cannot be unlocked within 5 s
TORQUE_CONSTANT = (12.5, 12.5, 12.5, 4.0, 4.0, 4.0)   # N m/A at the joint (ours)
JOINT_TEMPERATURE, TOOL_TEMPERATURE, SUPPLY_V = 35.0, 30.0, 48.0
GRAVITY = np.array([0.0, 0.0, -9.81])


def _cross(a, b) -> np.ndarray:
    """a x b for 3-vectors (numpy's cross costs ~20 us of Python per call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def rotvec(rot: np.ndarray) -> np.ndarray:
    """Rotation matrix -> UR's rotation vector (axis * angle, angle in [0, pi])."""
    import mujoco

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot).ravel())
    if q[0] < 0:
        q = -q
    v = np.empty(3)
    mujoco.mju_quat2Vel(v, q, 1.0)
    return v


def rotmat(rv) -> np.ndarray:
    """UR's rotation vector -> rotation matrix."""
    import mujoco

    rv = np.asarray(rv, dtype=float)
    angle = float(np.linalg.norm(rv))
    if angle < 1e-15:
        return np.eye(3)
    q = np.empty(4)
    mujoco.mju_axisAngle2Quat(q, rv / angle, angle)
    m = np.empty(9)
    mujoco.mju_quat2Mat(m, q)
    return m.reshape(3, 3)


class ControlScript:
    """The running control program's main-loop state (see :mod:`robocourse.drivers.ur_script`)."""

    def __init__(self, program: us.ControlProgram):
        self.program = program
        self.executing = False          # a non-real-time command ran and waits for the client's 0
        self.blocking: str | None = None   # a synchronous motion the main loop waits for
        self.async_op: str | None = None   # an asynchronous motion (move_thread / stop_thread)
        self.servo_params: tuple | None = None
        self.async_wr_count = 0
        self.async_op_id = 0


class URController:
    """The controller state behind one UR-style box (see the module docstring)."""

    def __init__(self, arm, dt: float = 0.002, *, powered: bool = True, unlock_delay: float = UNLOCK_DELAY_S,
                 kinematics=None, clock=time.monotonic):
        self.arm = arm
        self.dt = float(dt)
        self.clock = clock
        self.t0 = clock()
        self.unlock_delay = float(unlock_delay)
        self.kin = kinematics
        self.motion = JointMotion(arm.q, dt, arm.limits_low, arm.limits_high, arm.velocity_limits)
        self.robot_mode = ROBOT_MODE_RUNNING if powered else ROBOT_MODE_POWER_OFF
        self.safety_mode = SAFETY_NORMAL
        self.protective_stop_at = -math.inf
        self.runtime_state = RUNTIME_STOPPED
        self.script: ControlScript | None = None
        self.last_program = ""
        self.counters: dict[str, int] = {}
        self.messages: list[tuple[str, int]] = []     # (text, level) for the RTDE clients
        # registers and IO
        self.in_int = np.zeros(48, dtype=np.int64)
        self.in_double = np.zeros(48)
        self.out_int = np.zeros(48, dtype=np.int64)
        self.out_double = np.zeros(48)
        self.in_bits = 0
        self.out_bits = 0
        self.std_do = self.conf_do = self.tool_do = 0
        self.analog_out = [0.0, 0.0]          # ratio 0..1 as written
        self.analog_out_types = 0             # bit i: output i in voltage (1) or current (0)
        self.slider = 1.0
        self.updated: dict[str, float] = {}   # input variable -> when an RTDE package last wrote it
        self._inputs_seq = self._counted_seq = 0  # RTDE input packages applied / when commands were last counted
        self.watchdogs: dict[str, tuple[float, str]] = {}
        # payload, TCP, F/T
        if hasattr(arm, "sim"):
            mass, cog = arm.sim.tool_mass_properties()
        else:
            mass, cog = 0.0, np.zeros(3)
        self.payload_mass, self.payload_cog = float(mass), np.array(cog, dtype=float)
        self.payload_inertia = np.zeros(6)
        self.tcp_offset = np.zeros(6)
        self._tcp_rot: np.ndarray | None = None      # rotation of tcp_offset, cached
        self.ft_offset = np.zeros(6)
        self.exec_time_ms = 0.0
        self._cache: dict = {}
        sim = getattr(arm, "sim", None)
        # the joint servos get the reference velocity too: cmd = q_ref + kd/kp qd_ref makes MuJoCo's
        # kp (q_cmd - q) - kd qd a PD on both position and velocity errors, so the arm tracks target_q
        # within milliradians while it moves, as a UR's joint controllers do (without it, kd/kp = 0.1 s of lag)
        self._vel_ff = (np.array([sim.gains[j].kd / sim.gains[j].kp for j in sim.joint_names[:6]])
                        if sim is not None else np.zeros(6))
        if sim is not None:
            self._tool_body, self._elbow_body = sim.model.body("tool0").id, sim.model.body("forearm_link").id
            self._jacp, self._jacr = np.zeros((3, sim.model.nv)), np.zeros((3, sim.model.nv))

    def count(self, key: str, n: int = 1) -> None:
        self.counters[key] = self.counters.get(key, 0) + n

    def message(self, text: str, level: int = 1) -> None:
        self.messages.append((text, level))

    @property
    def now(self) -> float:
        """The controller's timestamp: seconds since it started, on its 2 ms grid (a late tick
        reports the tick it stands for, as a real controller's cycle counter would)."""
        return round((self.clock() - self.t0) / self.dt) * self.dt

    # --- program ---------------------------------------------------------------------------------
    def upload(self, text: str) -> str | None:
        """A program arrived on a script port: start it, or return why it was refused."""
        try:
            program = us.parse_program(text)
        except us.ScriptRefused as exc:
            self.count("scripts_refused")
            self.message(str(exc))
            return str(exc)
        if self.robot_mode != ROBOT_MODE_RUNNING or self.safety_mode != SAFETY_NORMAL:
            why = (f"program {program.name!r} not started: the robot is in {ROBOT_MODE_NAMES[self.robot_mode]} mode, "
                   f"safety {SAFETY_MODE_NAMES.get(self.safety_mode)}; power on and release the brakes (dashboard: "
                   "power on, brake release) or unlock the protective stop first")
            self.count("scripts_refused")
            self.message(why)
            return why
        if self.script is not None:
            self.stop_program("replaced by a new program")
        self.script = ControlScript(program)
        self.runtime_state = RUNTIME_PLAYING
        self.last_program = program.name
        self.count("programs_started")
        self._write_async(-1)
        self._set_out_int(0, us.READY)
        self.message(f"{program.name}: RTDE Control Script Loaded", 3)
        return None

    def stop_program(self, why: str, deceleration: float = STOP_DECELERATION) -> None:
        """End the running program (any reason): watchdogs removed, the arm decelerates to rest."""
        if self.script is None and self.runtime_state == RUNTIME_STOPPED:
            return
        name = self.script.program.name if self.script else "program"
        self.script = None
        self.runtime_state = RUNTIME_STOPPED
        self.watchdogs.clear()
        self.motion.stop(deceleration)
        self.count("programs_stopped")
        self.message(f"{name} stopped: {why}")

    def _off(self, reg: int, kind: str) -> int:
        p = self.script.program
        return reg + (p.offset_int if kind == "int" else p.offset_float)

    def _set_out_int(self, reg: int, value: int) -> None:
        self.out_int[self._off(reg, "int")] = value

    def _get_in_int(self, reg: int) -> int:
        return int(self.in_int[self._off(reg, "int")])

    def _in_doubles(self, first: int, n: int) -> np.ndarray:
        i = self._off(first, "float")
        return self.in_double[i:i + n].copy()

    def _out_doubles(self, values) -> None:
        i = self._off(0, "float")
        self.out_double[i:i + 6] = values

    def _write_async(self, value: int) -> None:
        """The script's write_async_progress_register(value): >= 0 running with progress, < 0 finished."""
        sc = self.script
        sc.async_wr_count = (sc.async_wr_count + 1) % 128
        if value == 0:
            sc.async_op_id = (sc.async_op_id + 1) % 128
        reg = sc.async_wr_count * 65536 + sc.async_op_id * 16777216
        if value >= 0:
            reg += min(value, 32767) + 32768
        self._set_out_int(2, reg)

    def _end_async(self) -> None:
        if self.script.async_op is not None:
            self.script.async_op = None
            self._write_async(-1)

    def _runtime_error(self, cmd: int, why: str) -> None:
        self.count("unsupported_commands" if cmd not in us.SUPPORTED else "runtime_errors")
        self.stop_program(f"URScript runtime error: {us.command_name(cmd)} (command {cmd}) {why}")

    def _process(self, cmd: int) -> bool:
        """One command of ur_rtde's script (its process_cmd). False: the program ended."""
        m = self.motion
        if cmd not in us.SUPPORTED:
            self._runtime_error(cmd, "is not supported by this UR-style box; supported: "
                                + ", ".join(us.command_name(c) for c in sorted(us.SUPPORTED)))
            return False
        if cmd not in us.REALTIME or self._inputs_seq != self._counted_seq:   # RT commands repeat every cycle:
            self._counted_seq = self._inputs_seq                                # count each one the client sent once
            self.count(f"cmd_{us.command_name(cmd).lower()}")
        if cmd == 255:                                              # stopScript
            self.stop_program("stopScript()")
            return False
        if cmd == 11:                                               # servoJ
            d = self._in_doubles(0, 11)
            params = tuple(d[:6]) + (d[8], d[9])
            if params != self.script.servo_params or m.mode != "servo":
                if not np.all(np.isfinite(d)) or d[8] <= 0:
                    self._runtime_error(cmd, f"with a non-finite target or t = {d[8]!r} <= 0")
                    return False
                self.script.servo_params = params
                m.servo(d[:6], d[8], d[9])
            return True
        self.script.servo_params = None
        if cmd == 9:                                                # speedJ
            d = self._in_doubles(0, 8)
            if not np.all(np.isfinite(d)):
                self._runtime_error(cmd, "with a non-finite speed")
                return False
            m.speed(d[:6], d[6])
            return True
        if cmd == 1:                                                # moveJ
            d = self._in_doubles(0, 8)
            if not np.all(np.isfinite(d)) or d[6] <= 0 or d[7] <= 0:
                self._runtime_error(cmd, f"with target {d[:6].tolist()}, speed {d[6]}, acceleration {d[7]}")
                return False
            self._end_async()
            m.move(d[:6], d[6], d[7])
            if self._get_in_int(1) == 1:
                self.script.async_op = "move"
                self._write_async(0)
            else:
                self.script.blocking = "move"
            return True
        if cmd in (15, 16):                                         # speedStop / servoStop
            # ur_rtde's script kills its speed / servo thread and answers at once ("servo_stop done"):
            # the arm decelerates after the call returned (ours: at the deceleration the client sent).
            # Blocking until rest here made a servoStop outlast a 100 ms RTDE watchdog, which then
            # stopped the program under the client's wait: "RTDE control script is not running!"
            m.stop(float(self._in_doubles(0, 1)[0]))
            return True
        if cmd in (33, 34):                                         # stopL / stopJ
            self._end_async()
            m.stop(float(self._in_doubles(0, 1)[0]))
            if self._get_in_int(1) == 1:
                self.script.async_op = "stop"
                self._write_async(0)
            else:
                self.script.blocking = "stop"
            return True
        if cmd == 35:                                               # setWatchdog
            f = float(self._in_doubles(0, 1)[0])
            name = f"input_int_register_{self._off(0, 'int')}"
            if not f > 0:
                self._runtime_error(cmd, f"with min_frequency {f} (must be > 0 Hz)")
                return False
            self.watchdogs[name] = (f, "stop")
            self.updated[name] = self.clock()
            return True
        if cmd == 17:                                               # setPayload
            d = self._in_doubles(0, 4)
            self.payload_mass = float(d[0])
            if d[1:].any():
                self.payload_cog = d[1:].copy()
            return True
        if cmd == 29:                                               # setTcp
            self.tcp_offset = self._in_doubles(0, 6)
            self._tcp_rot = None
            return True
        if cmd == 40:                                               # getTCPOffset
            self._out_doubles(self.tcp_offset)
            return True
        if cmd == 38:                                               # getJointTorques
            self._out_doubles(self.arm.tau - self.arm.gravity())
            return True
        if cmd == 43:                                               # getForwardKinematics()
            self._out_doubles(self.tcp_pose(self.arm.q, self.tcp_offset))
            return True
        if cmd == 44:                                               # getForwardKinematics(q[, tcp]): d0-5, d6-11
            d = self._in_doubles(0, 12)
            self._out_doubles(self.tcp_pose(d[:6], d[6:]))
            return True
        if cmd == 58:                                               # getActualToolFlangePose
            self._out_doubles(self.tcp_pose(self.arm.q, np.zeros(6)))
            return True
        if cmd == 47:                                               # isSteady
            self._set_out_int(1, int(m.mode == HOLD and float(np.max(np.abs(self.arm.dq))) < 1e-3))
            return True
        if cmd == 37:                                               # isJointsWithinSafetyLimits
            q = self._in_doubles(0, 6)
            ok = bool(np.all(q >= self.arm.limits_low) and np.all(q <= self.arm.limits_high))
            self._set_out_int(1, int(ok))
            return True
        if cmd == 26:                                               # getStepTime
            self.out_double[self._off(0, "float")] = self.dt
            return True
        if cmd == 8:                                                # zeroFtSensor
            self.ft_offset = self.ft_offset + self._tcp_force()
            return True
        if cmd == 31:                                               # triggerProtectiveStop
            self.protective_stop("protective_stop() from the control script")
            return False
        raise AssertionError(f"command {cmd} listed as supported but not handled")

    def _script_cycle(self) -> None:
        """One pass of the control script's main loop (once per 2 ms tick)."""
        sc = self.script
        if sc is None or self.runtime_state != RUNTIME_PLAYING:
            return
        if sc.async_op is not None and self.motion.mode == HOLD:
            self._end_async()
        if sc.blocking is not None:
            if self.motion.mode != HOLD:
                return                                   # movej / stopj still running: the loop waits
            sc.blocking = None
            self._set_out_int(0, us.DONE)
            return
        cmd = self._get_in_int(0)
        if cmd in us.REALTIME:
            if self._process(cmd) and self.script is sc:
                self._set_out_int(0, us.READY)
        elif cmd == 0:
            sc.executing = False
            self._set_out_int(0, us.READY)
        elif not sc.executing:
            sc.executing = True
            if self._process(cmd) and self.script is sc and sc.blocking is None:
                self._set_out_int(0, us.DONE)

    # --- safety, power -----------------------------------------------------------------------------
    def protective_stop(self, why: str) -> None:
        self.safety_mode = SAFETY_PROTECTIVE_STOP
        self.protective_stop_at = self.clock()
        self.count("protective_stops")
        self.stop_program(f"protective stop ({why})")
        self.motion.stop(STOP_DECELERATION)

    def unlock_protective_stop(self) -> str:
        if self.safety_mode != SAFETY_PROTECTIVE_STOP:
            return "Protective stop releasing"
        if self.clock() - self.protective_stop_at < self.unlock_delay:
            return ("Cannot unlock protective stop until 5s after occurrence. Always inspect cause of protective "
                    "stop before unlocking")
        self.safety_mode = SAFETY_NORMAL
        return "Protective stop releasing"

    def power(self, on: bool) -> None:
        if on and self.robot_mode == ROBOT_MODE_POWER_OFF:
            self.robot_mode = ROBOT_MODE_IDLE
        elif not on and self.robot_mode != ROBOT_MODE_POWER_OFF:
            self.stop_program("power off")
            self.robot_mode = ROBOT_MODE_POWER_OFF
            self.motion.hold()
            self.motion.q[:] = self.arm.q

    def brake_release(self) -> None:
        if self.robot_mode in (ROBOT_MODE_IDLE, ROBOT_MODE_POWER_ON):
            self.motion.q[:] = self.arm.q
            self.robot_mode = ROBOT_MODE_RUNNING

    # --- RTDE inputs -------------------------------------------------------------------------------
    def apply_inputs(self, names, values) -> None:
        """An RTDE data package's input values (already decoded), in recipe order."""
        now = self.clock()
        self._inputs_seq += 1
        v = dict(zip(names, values))
        upd = self.updated
        for name in names:
            upd[name] = now
        for name, x in v.items():
            if name.startswith("input_int_register_"):
                self.in_int[int(name[19:])] = x
            elif name.startswith("input_double_register_"):
                self.in_double[int(name[22:])] = x
            elif name.startswith("input_bit_register_"):
                bit = int(name[19:])
                self.in_bits = (self.in_bits | (1 << bit)) if x else (self.in_bits & ~(1 << bit))
            elif name == "input_bit_registers0_to_31":
                self.in_bits = (self.in_bits & ~0xFFFFFFFF) | int(x)
            elif name == "input_bit_registers32_to_63":
                self.in_bits = (self.in_bits & ~(0xFFFFFFFF << 32)) | (int(x) << 32)
        for mask_name, value_name, attr in (("standard_digital_output_mask", "standard_digital_output", "std_do"),
                                            ("configurable_digital_output_mask", "configurable_digital_output",
                                             "conf_do"),
                                            ("tool_digital_output_mask", "tool_digital_output", "tool_do")):
            if mask_name in v and value_name in v:
                mask = int(v[mask_name])
                setattr(self, attr, (getattr(self, attr) & ~mask) | (int(v[value_name]) & mask))
        if v.get("speed_slider_mask") == 1 and "speed_slider_fraction" in v:
            self.slider = min(1.0, max(0.0, float(v["speed_slider_fraction"])))
        if "standard_analog_output_mask" in v:
            mask = int(v["standard_analog_output_mask"])
            types = int(v.get("standard_analog_output_type", self.analog_out_types))
            for i in (0, 1):
                if mask & (1 << i):
                    self.analog_out[i] = min(1.0, max(0.0, float(v.get(f"standard_analog_output_{i}", 0.0))))
                    self.analog_out_types = (self.analog_out_types & ~(1 << i)) | (types & (1 << i))

    def _check_watchdogs(self) -> None:
        now = self.clock()
        for name, (f, _action) in list(self.watchdogs.items()):
            gap = now - self.updated.get(name, now)
            if gap > 1.0 / f:
                self.count("watchdog_stops")
                self.stop_program(f"RTDE watchdog: {name} not updated for {gap * 1e3:.0f} ms (min frequency "
                                  f"{f:g} Hz, at most {1e3 / f:.0f} ms)")
                return

    # --- the 2 ms tick -----------------------------------------------------------------------------
    def tick(self) -> None:
        t = time.perf_counter()
        self._cache.clear()
        if self.watchdogs:
            self._check_watchdogs()
        self._script_cycle()
        m = self.motion
        m.scaling = self.slider if self.runtime_state == RUNTIME_PLAYING else 1.0
        if self.robot_mode == ROBOT_MODE_RUNNING:
            m.tick()
            np.multiply(m.qd, self._vel_ff, out=self.arm.cmd)
            self.arm.cmd += m.q
        else:
            self.arm.cmd[:] = m.q                # brakes: hold where the reference stopped
        self.arm.step(2)
        self.exec_time_ms = (time.perf_counter() - t) * 1e3

    # --- outputs -----------------------------------------------------------------------------------
    def _frames(self, which: str):
        """(tool0 transform, tool0 Jacobian) at the actual or the target q, computed once per tick
        (actual: from the simulation's own data after its step; target: the kinematics model)."""
        key = ("frames", which)
        hit = self._cache.get(key)
        if hit is None:
            sim = getattr(self.arm, "sim", None)
            if which == "actual" and sim is not None:
                hit = self._sim_frame(sim, self._tool_body)
            else:
                q = self.arm.q if which == "actual" else self.motion.q
                hit = (self.kin.calculate_link_transform(q), self.kin.calculate_jacobian(q))
            self._cache[key] = hit
        return hit

    def _sim_frame(self, sim, body: int):
        """(4x4 transform, 6x6 Jacobian) of ``body`` from the simulation's current positions."""
        import mujoco

        m, d = sim.model, sim.data
        if not self._cache.get("sim_kinematics"):
            mujoco.mj_kinematics(m, d)       # positions after the last step (mj_step left the step's start)
            mujoco.mj_comPos(m, d)
            self._cache["sim_kinematics"] = True
        t = np.eye(4)
        t[:3, :3] = d.xmat[body].reshape(3, 3)
        t[:3, 3] = d.xpos[body]
        mujoco.mj_jacBody(m, d, self._jacp, self._jacr, body)
        return t, np.vstack([self._jacp[:, :6], self._jacr[:, :6]])

    def tcp_pose(self, q, tcp, transform=None, tcp_rot=None) -> np.ndarray:
        """UR's pose [x, y, z, rx, ry, rz] of the TCP ``tcp`` (a pose in the flange frame) at ``q``."""
        if self.kin is None:
            return np.zeros(6)
        t = self.kin.calculate_link_transform(np.asarray(q, dtype=float)) if transform is None else transform
        rot = t[:3, :3] @ (rotmat(tcp[3:]) if tcp_rot is None else tcp_rot)
        pos = t[:3, 3] + t[:3, :3] @ np.asarray(tcp[:3], dtype=float)
        return np.concatenate([pos, rotvec(rot)])

    def _pose(self, which: str) -> list:
        if self.kin is None:
            return [0.0] * 6
        if self._tcp_rot is None:
            self._tcp_rot = rotmat(self.tcp_offset[3:])
        return self.tcp_pose(None, self.tcp_offset, self._frames(which)[0], self._tcp_rot).tolist()

    def _speed(self, which: str) -> list:
        if self.kin is None:
            return [0.0] * 6
        t, jac = self._frames(which)
        tw = jac @ (self.arm.dq if which == "actual" else self.motion.qd)
        tw[:3] += _cross(tw[3:], t[:3, :3] @ self.tcp_offset[:3])
        return tw.tolist()

    def _raw_wrench(self) -> np.ndarray:
        sim = getattr(self.arm, "sim", None)
        return sim.wrench.copy() if sim is not None else np.zeros(6)

    def _tcp_force(self) -> np.ndarray:
        """External wrench at the TCP in the base frame: sensor less payload weight, before the zero offset."""
        if self.kin is None:
            return np.zeros(6)
        hit = self._cache.get("force")
        if hit is not None:
            return hit
        rot = self._frames("actual")[0][:3, :3]
        raw = self._raw_wrench()
        weight = self.payload_mass * GRAVITY
        f = rot @ raw[:3] - weight
        tau = rot @ raw[3:] - _cross(rot @ self.payload_cog, weight) - _cross(rot @ self.tcp_offset[:3], f)
        self._cache["force"] = out = np.concatenate([f, tau])
        return out

    def robot_status_bits(self) -> int:
        bits = STATUS_POWER_ON if self.robot_mode != ROBOT_MODE_POWER_OFF else 0
        return bits | (STATUS_PROGRAM_RUNNING if self.runtime_state == RUNTIME_PLAYING else 0)

    def safety_status_bits(self) -> int:
        return SAFETY_BIT_PROTECTIVE_STOPPED if self.safety_mode == SAFETY_PROTECTIVE_STOP else SAFETY_BIT_NORMAL

    def joint_mode(self) -> list:
        mode = {ROBOT_MODE_POWER_OFF: JOINT_POWER_OFF, ROBOT_MODE_RUNNING: JOINT_RUNNING}.get(self.robot_mode,
                                                                                          JOINT_IDLE)
        return [mode] * 6

    def outputs(self) -> dict:
        """name -> function() returning the variable's value(s) as a list (see the module docstring).
        Derived values (kinematics, the F/T compensation) are computed once per tick, on demand."""
        arm, m = self.arm, self.motion
        inv_kt = 1.0 / np.asarray(TORQUE_CONSTANT)

        def elbow_frame():
            hit = self._cache.get("elbow")
            if hit is None:
                sim = getattr(arm, "sim", None)
                if sim is not None:
                    hit = self._sim_frame(sim, self._elbow_body)
                else:
                    hit = (self.kin.calculate_link_transform(arm.q, "forearm_link"),
                           self.kin.calculate_jacobian(arm.q, "forearm_link"))
                self._cache["elbow"] = hit
            return hit

        def elbow():
            if self.kin is None:
                return [0.0] * 3
            return elbow_frame()[0][:3, 3].tolist()

        def elbow_velocity():
            if self.kin is None:
                return [0.0] * 3
            return (elbow_frame()[1][:3] @ arm.dq).tolist()

        def accelerometer():
            if self.kin is None:
                return [0.0, 0.0, 9.81]
            return (self._frames("actual")[0][:3, :3].T @ -GRAVITY).tolist()

        def momentum():
            sim = getattr(arm, "sim", None)
            if sim is None:
                return [0.0]
            import mujoco

            mujoco.mj_subtreeVel(sim.model, sim.data)
            return [float(np.linalg.norm(sim.data.subtree_linvel[0]) * sim.model.body_subtreemass[0])]

        def analog_out(i):
            def f():
                r = self.analog_out[i]
                return [r * 10.0 if self.analog_out_types & (1 << i) else 0.004 + r * 0.016]
            return f

        def current():
            return (arm.tau * inv_kt).tolist()

        zeros6 = [0.0] * 6
        out = {
            "timestamp": lambda: [self.now],
            "target_q": m.q.tolist, "target_qd": m.qd.tolist, "target_qdd": m.qdd.tolist,
            "target_current": current, "target_moment": arm.tau.tolist,
            "actual_q": arm.q.tolist, "actual_qd": arm.dq.tolist, "actual_current": current,
            "actual_current_window": lambda: zeros6, "actual_current_as_torque": arm.tau.tolist,
            "joint_control_output": current,
            "actual_TCP_pose": lambda: self._pose("actual"), "actual_TCP_speed": lambda: self._speed("actual"),
            "actual_TCP_force": lambda: (self._tcp_force() - self.ft_offset).tolist(),
            "target_TCP_pose": lambda: self._pose("target"), "target_TCP_speed": lambda: self._speed("target"),
            "actual_digital_input_bits": lambda: [0],
            "joint_temperatures": lambda: [JOINT_TEMPERATURE] * 6,
            "actual_execution_time": lambda: [self.exec_time_ms],
            "robot_mode": lambda: [self.robot_mode], "joint_mode": self.joint_mode,
            "safety_mode": lambda: [self.safety_mode], "safety_status": lambda: [self.safety_mode],
            "actual_tool_accelerometer": accelerometer,
            "speed_scaling": lambda: [self.slider], "target_speed_fraction": lambda: [self.slider],
            "actual_momentum": momentum, "actual_main_voltage": lambda: [SUPPLY_V],
            "actual_robot_voltage": lambda: [SUPPLY_V if self.robot_mode != ROBOT_MODE_POWER_OFF else 0.0],
            "actual_robot_current": lambda: [0.5 + float(np.abs(arm.tau * arm.dq).sum()) / SUPPLY_V],
            "actual_joint_voltage": lambda: [SUPPLY_V] * 6,
            "actual_digital_output_bits": lambda: [self.std_do | (self.conf_do << 8) | (self.tool_do << 16)],
            "runtime_state": lambda: [self.runtime_state],
            "elbow_position": elbow, "elbow_velocity": elbow_velocity,
            "robot_status_bits": lambda: [self.robot_status_bits()],
            "safety_status_bits": lambda: [self.safety_status_bits()],
            "analog_io_types": lambda: [self.analog_out_types << 2],
            "standard_analog_input0": lambda: [0.0], "standard_analog_input1": lambda: [0.0],
            "standard_analog_output0": analog_out(0), "standard_analog_output1": analog_out(1),
            "io_current": lambda: [0.0],
            "euromap67_input_bits": lambda: [0], "euromap67_output_bits": lambda: [0],
            "euromap67_24V_voltage": lambda: [0.0], "euromap67_24V_current": lambda: [0.0],
            "tool_mode": lambda: [0], "tool_analog_input_types": lambda: [0],
            "tool_analog_input0": lambda: [0.0], "tool_analog_input1": lambda: [0.0],
            "tool_output_voltage": lambda: [0], "tool_output_current": lambda: [0.0],
            "tool_temperature": lambda: [TOOL_TEMPERATURE],
            "tcp_force_scalar": lambda: [float(np.linalg.norm((self._tcp_force() - self.ft_offset)[:3]))],
            "tool_output_mode": lambda: [0], "tool_digital_output0_mode": lambda: [0],
            "tool_digital_output1_mode": lambda: [0],
            "payload": lambda: [self.payload_mass], "payload_cog": lambda: self.payload_cog.tolist(),
            "payload_inertia": lambda: self.payload_inertia.tolist(),
            "script_control_line": lambda: [0], "ft_raw_wrench": lambda: self._raw_wrench().tolist(),
            "joint_position_deviation_ratio": lambda: [0.0], "collision_detection_ratio": lambda: [0.0],
            "time_scale_source": lambda: [0], "tcp_offset": lambda: self.tcp_offset.tolist(),
            "output_bit_registers0_to_31": lambda: [self.out_bits & 0xFFFFFFFF],
            "output_bit_registers32_to_63": lambda: [(self.out_bits >> 32) & 0xFFFFFFFF],
            "input_bit_registers0_to_31": lambda: [self.in_bits & 0xFFFFFFFF],
            "input_bit_registers32_to_63": lambda: [(self.in_bits >> 32) & 0xFFFFFFFF],
        }
        for i in range(48):
            out[f"output_int_register_{i}"] = (lambda i=i: [int(self.out_int[i])])
            out[f"output_double_register_{i}"] = (lambda i=i: [float(self.out_double[i])])
            out[f"input_int_register_{i}"] = (lambda i=i: [int(self.in_int[i])])
            out[f"input_double_register_{i}"] = (lambda i=i: [float(self.in_double[i])])
        for i in range(64, 128):
            out[f"output_bit_register_{i}"] = (lambda i=i: [bool(self.out_bits >> i & 1)])
            out[f"input_bit_register_{i}"] = (lambda i=i: [bool(self.in_bits >> i & 1)])
        return out

    def stats(self) -> dict:
        return {"robot_mode": ROBOT_MODE_NAMES[self.robot_mode], "safety_mode": SAFETY_MODE_NAMES[self.safety_mode],
                "runtime_state": RUNTIME_NAMES[self.runtime_state], "program": self.last_program,
                "watchdogs": {k: v[0] for k, v in self.watchdogs.items()}, "motion": self.motion.mode,
                "speed_slider": self.slider, **self.counters}
