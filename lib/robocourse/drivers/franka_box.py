"""The simulated FR3 controller: libfranka's robot server (version 10), so pylibfranka drives it unchanged.

Counterpart: the Franka Control box as libfranka >= 0.18 sees it (wire format:
:mod:`robocourse.drivers.franka_wire`; facts: shared/reference/arm_drivers.md B/C). Runs in its
own process (:func:`robocourse.drivers.start_franka_box`): pylibfranka holds the GIL while it
waits for a response (pitfall C8), so a server thread inside the client's process would never run.

- TCP ``host:1337``: Connect (version check), Move, StopMove, AutomaticErrorRecovery,
  SetCollisionBehavior, SetJointImpedance, SetCartesianImpedance, SetGuidingMode, SetEEToK,
  SetNEToEE, SetLoad, GetRobotModel (the FR3 URDF this course ships). Several clients may be
  connected and read states; one motion at a time.
- UDP: every 1 ms tick a 1377-byte RobotState to each connected client (``message_id`` = ms since
  the box started), and the 371-byte RobotCommand answers. A command echoing the state of tick k
  that arrives before tick k+1 is applied at k+1; otherwise the packet is *lost* for that tick
  (a motion command is extrapolated, a torque command reused, as the robot does; the robot
  documents constant acceleration, ours continues at the last commands' mean velocity: see
  ``_Track``); a command for an older state is *late* (counted, discarded). ``MAX_LOST_IN_ROW``
  (20) lost in a row: the communication_constraints_violation reflex, the brakes close, the
  client's Move ends with ReflexAborted, and only AutomaticErrorRecovery clears it.
- ``control_command_success_rate``: the share of the last 100 states sent during the motion that
  got their command in time (0 when no motion runs). The motion's first state, the one whose
  modes switched, is not expected to be answered: libfranka's startMotion reads it and sends
  nothing, and the first readOnce() waits for the next state (``mode_switch_states``). A tick the box itself could not keep (its
  process was descheduled: ``box_ticks_skipped``) sends no state and is not counted against the
  client; nor is it made up, and a tick that runs late re-phases the schedule so the client
  always has a whole millisecond to answer (``box_late_ticks``): the simulated robot's clock (``message_id``, ms) and its physics
  advance one millisecond per state sent, so a starved box runs slower than wall time (robot
  ms per wall s shows it) but never shows the client a gap the robot would not have had.
- Checks with libfranka's error names (each a reflex, as on the robot): a commanded joint
  position outside the URDF limits (joint_motion_generator_position_limits_violation), a
  commanded velocity above q̇max (..._velocity_limits_violation), a torque rate above twice
  1000 N m/s (controller_torque_discontinuity). The acceleration and jerk reflexes
  (..._velocity_discontinuity, ..._acceleration_discontinuity) exist but are off by default
  (``franka_wire.DISCONTINUITY_MARGIN``: libfranka's own stamping makes a correct but busy
  client look discontinuous by a millisecond); a non-finite command is treated as a position-limit
  violation. Derivatives are divided differences on the robot's clock (the ``message_id`` each
  command answers), so ``q_d``, ``dq_d``, ``ddq_d`` of a state are the command of the previous
  millisecond and its derivatives. Not modelled: collisions, Cartesian motion generators (rejected, "command not
  possible"), guiding mode, the gripper.
- Malformed input is counted and survived: a UDP datagram of the wrong length, for a state never
  sent, or from an address that holds no motion; a TCP message with a size or command libfranka
  never sends closes that one connection (``tcp_malformed``), never the box.

A monitor socket (UDP, the box's own, not part of libfranka's protocol) answers ``stats`` with
the counters as JSON: what a benchmark or a grader reads without touching the client; ``clock``
with the robot's clock alone (``{"message_id": N}``, cheap: the grader's pauses ask it in a cycle).

The machine apart from the client (ours, for grading; off unless asked): ``watch <tid>`` on the
monitor names the client's thread (the one calling ``readOnce``/``writeOnce``). The box then
reads that thread's run-queue wait (``/proc/<tid>/schedstat``: time it was runnable but another
task had the CPU) as each state leaves and while a run of lost cycles lasts, and counts against
the client only the lost cycles it did not spend waiting for a CPU since the first unanswered
state was sent: the communication reflex trips when the client's *own* share of the silence (its
code running, or blocking: a sleep, a slow call) reaches the limit, in milliseconds (a box
starved itself ticks fewer times than milliseconds pass, so its count of lost cycles would let a
busy client off). The kernel records a wait
only when it ends; while the client is runnable the box blames it only if it is over the limit
even counting every millisecond it could not see as a wait, and otherwise decides once the client
has run or blocked (``verdicts_deferred``), for at most ``MACHINE_CAP_MS`` of silence: a reflex
then is the machine's (``reflexes_machine``).
A correct loop on a loaded machine, held off the CPU for 30 ms, keeps the motion going (the
robot extrapolates, as it does for any lost cycle; ``lost_machine`` counts those cycles); a loop
that sleeps 30 ms trips it as the robot would. A robot's own controller never starves, and a
real-time client is not held off the CPU by ordinary load: this is the same verdict on a shared
grading machine. Where the file cannot be read (no CONFIG_SCHED_INFO, another PID namespace),
``watch`` answers ``unavailable`` and the box keeps the robot's plain rule.
"""

from __future__ import annotations

import collections
import json
import os
import socket
import time
from dataclasses import dataclass, field

import numpy as np

from . import franka_wire as fw
from .fr3_arm import FR3Arm, NullArm
from .loopback import bind_all, bind_free_loopback
from .ticker import TickingBox

_RING = 1 << 15
#: ours: a starved box sends fewer states than milliseconds pass, so a client silent this long (ms of
#: wall time since its last command) with at least SILENCE_LOST states unanswered also trips the communication reflex
#: (for the robot's 20 lost cycles; a box given another ``max_lost`` scales SILENCE_MS with it)
SILENCE_MS, SILENCE_LOST = 25, 5
#: a watched client (``watch``) instead: its own time without an answer (since the first unanswered state was sent,
#: less its CPU waits) reaching ``max_lost`` ms, what 20 lost cycles are on a robot that never starves. While it is
#: runnable (a CPU wait not on record yet) the verdict waits, at most MACHINE_CAP_MS of silence
MACHINE_CAP_MS = 500
#: the thresholds of the discontinuity reflexes (published limits x our margin, see franka_wire)
_ACC = fw.MAX_JOINT_ACCELERATION * fw.DISCONTINUITY_MARGIN
_JERK = fw.MAX_JOINT_JERK * fw.DISCONTINUITY_MARGIN
_TORQUE_RATE = fw.MAX_TORQUE_RATE * fw.TORQUE_RATE_MARGIN
_MAX_MESSAGE = 1 << 16
#: round-trip histogram bin edges in us, log-spaced 10 us .. 100 ms
RTT_HIST_EDGES_US = tuple(float(x) for x in np.geomspace(10.0, 100_000.0, 49))
_IDENTITY = np.eye(4).ravel()   # column-major identity


@dataclass
class _Conn:
    sock: socket.socket
    peer: tuple
    buf: bytearray = field(default_factory=bytearray)
    udp: tuple | None = None          # (ip, port) states go to, set by Connect


class _Track:
    """The last four samples of a commanded signal with their times (s): its derivatives by
    divided differences, and the extrapolation for a lost packet. The robot documents constant
    acceleration; ours continues at the mean velocity of the last three commands, because
    libfranka stamps a command with the newest state it has received, so a busy client's command
    can land a millisecond late, and an acceleration estimated from such a zig-zag runs the
    extrapolation away within a few lost cycles."""

    def __init__(self, x: np.ndarray, t: float):
        self.t = [t, t - 1e-3, t - 2e-3, t - 3e-3]
        self.x = [x.copy(), x.copy(), x.copy(), x.copy()]

    def derivatives(self, x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First, second and third time derivative at the new sample ``x`` at ``t``."""
        ts, xs = [t, *self.t[:3]], [x, *self.x[:3]]
        d1 = [(xs[i] - xs[i + 1]) / (ts[i] - ts[i + 1]) for i in range(3)]
        d2 = [(d1[i] - d1[i + 1]) / (ts[i] - ts[i + 2]) for i in range(2)]
        return d1[0], 2.0 * d2[0], 6.0 * (d2[0] - d2[1]) / (ts[0] - ts[3])

    def push(self, x: np.ndarray, t: float) -> None:
        self.t = [t, *self.t[:3]]
        self.x = [x, *self.x[:3]]

    def extrapolate(self, t: float, order: int = 1) -> np.ndarray:
        """The value at ``t`` continued from the last samples: ``order`` 0 holds, 1 continues at
        the mean velocity of the last three samples."""
        (t0, _t1, t2), (x0, _x1, x2) = self.t[:3], self.x[:3]
        if order == 0:
            return x0.copy()
        return x0 + (x0 - x2) / (t0 - t2) * (t - t0)


@dataclass
class _Motion:
    conn: _Conn
    command_id: int
    controller: int                   # state enum
    generator: int                    # state enum
    q: _Track                         # commanded positions (joint position generator)
    dq: _Track                        # commanded velocities (joint velocity generator)
    tau: _Track                       # commanded torques (external controller)
    received: tuple | None = None     # (t, q_c) of the last position command that came (not extrapolated)
    answered: bool = False            # has any command of this motion come in time?


class _ClientThread:
    """The client's thread as the kernel sees it (``/proc/<tid>/schedstat`` and ``stat``): its CPU
    time and its run-queue wait (time runnable while another task had the CPU) since the state
    that is waiting for its answer was sent (:meth:`mark` at each send, :meth:`restart` when that
    state's answer is missing). The kernel adds a wait to ``schedstat`` only when it ends: a wait
    still going on (the thread in state R) is not on record yet: :meth:`waited_ms` returns the
    recorded waits plus an estimate of the ongoing one (state R with CPU time and wait standing
    still since the last look), and :attr:`unknown_ms` bounds what may be missing (the time
    since the last look that saw the thread asleep, or since the look before it ran), so the box
    blames the client only for what it did even if every unknown millisecond was a wait."""

    def __init__(self, tid: int):
        self.tid = tid
        self.fds = [os.open(f"/proc/{tid}/schedstat", os.O_RDONLY), os.open(f"/proc/{tid}/stat", os.O_RDONLY)]
        got = self._look()
        if got is None:
            self.close()
            raise ValueError(f"/proc/{tid}/schedstat has no run-queue wait here")
        self.marked = self.base = self.last = got[:2]
        self.last_ns = time.monotonic_ns()
        self.last_ms = self.recorded_ms = self.ran_ms = self.unknown_ms = 0.0
        self.runnable = False
        self.queued_since: int | None = None
        self.known_ns = self.last_ns     # up to here every wait of the thread is on record

    def _look(self) -> tuple[int, int, bool] | None:
        """(CPU time ns, run-queue wait ns, runnable) or None if the thread is gone."""
        try:
            cpu, wait = (int(x) for x in os.pread(self.fds[0], 128, 0).split()[:2])
            stat = os.pread(self.fds[1], 1024, 0)
        except (OSError, ValueError):
            return None
        state = stat[stat.rfind(b")") + 2:stat.rfind(b")") + 3]
        return cpu, wait, state == b"R"

    def mark(self) -> tuple[int, int]:
        """At a state's send: the thread's CPU time and wait then (the baseline if its answer goes missing)."""
        got = self._look()
        if got is not None:
            self.marked = got[:2]
        return self.marked

    def restart(self, base: tuple[int, int], base_ns: int) -> None:
        """Count from ``base`` (the mark of the first unanswered state's send, at ``base_ns``)."""
        self.base, self.queued_since = (int(base[0]), int(base[1])), None
        self.last, self.last_ns = self.base, base_ns
        self.known_ns = base_ns

    def waited_ms(self) -> float:
        """Run-queue wait (ms) since the baseline, the ongoing one estimated; updates ran_ms and runnable."""
        now = time.monotonic_ns()
        got = self._look()
        if got is None:
            self.runnable = False
            return self.last_ms
        cpu, wait, self.runnable = got
        if not self.runnable:
            self.known_ns = now               # asleep: no wait going on
        elif (cpu, wait) != self.last:
            self.known_ns = self.last_ns      # it ran since the last look: a wait going on began after it
        if (cpu, wait) != self.last or not self.runnable:
            self.queued_since = None          # it ran, or a wait ended (and is in ``wait`` now), or it sleeps
        elif self.queued_since is None:
            self.queued_since = self.last_ns  # runnable and standing still since the last look
        self.unknown_ms = (now - self.known_ns) / 1e6 if self.runnable else 0.0
        self.last, self.last_ns = (cpu, wait), now
        ongoing = now - self.queued_since if self.queued_since is not None else 0
        self.recorded_ms = (wait - self.base[1]) / 1e6
        self.last_ms = self.recorded_ms + ongoing / 1e6
        self.ran_ms = (cpu - self.base[0]) / 1e6
        return self.last_ms

    def where(self) -> str:
        """Where the thread is now, as the kernel says (its state and wait channel)."""
        try:
            stat = os.pread(self.fds[1], 1024, 0)
            state = stat[stat.rfind(b")") + 2:stat.rfind(b")") + 3].decode()
            with open(f"/proc/{self.tid}/wchan") as f:
                return f", now in state {state} at {f.read().strip() or '-'}"
        except (OSError, ValueError):
            return ""

    def close(self) -> None:
        for fd in self.fds:
            os.close(fd)
        self.fds = []


class FrankaBox(TickingBox):
    rephase = True       # a late tick still leaves the client a whole millisecond to answer
    def __init__(self, host: str | None = None, command_port: int = fw.COMMAND_PORT, initial_positions=None,
                 physics: bool = True, max_lost: int = fw.MAX_LOST_IN_ROW, server_version: int = fw.VERSION):
        super().__init__()
        if not isinstance(max_lost, int) or max_lost < 1:
            raise ValueError(f"max_lost={max_lost!r} must be a whole number of cycles >= 1 (libfranka's robot: 20)")
        from robocourse.sim.robots import urdf_path

        self.arm = (FR3Arm if physics else NullArm)(timestep=0.001, initial_positions=initial_positions)
        self.max_lost = max_lost
        self.server_version = int(server_version)
        # libfranka's command port is fixed: the box takes a loopback address of its own (the
        # UDP ports are the box's choice: libfranka answers to where the states come from)
        ports = [(command_port, socket.SOCK_STREAM), (0, socket.SOCK_DGRAM), (0, socket.SOCK_DGRAM)]
        if host:
            socks = bind_all(host, ports)
        else:
            host, socks = bind_free_loopback(ports)
        self.listener, self.udp, self.monitor = socks
        self.host = host
        self.command_port = self.listener.getsockname()[1]
        self.udp_port = self.udp.getsockname()[1]
        self.monitor_port = self.monitor.getsockname()[1]
        self.urdf = urdf_path("fr3").read_bytes()   # what GetRobotModel serves
        self.conns: dict[socket.socket, _Conn] = {}
        self.motion: _Motion | None = None
        self.robot_mode = fw.MODE_IDLE
        self.generator, self.controller = fw.GEN_IDLE, fw.CTRL_JOINT_IMPEDANCE
        self.errors = np.zeros(41, dtype=bool)
        self.reflex_reason = np.zeros(41, dtype=bool)
        self.message_id = 0
        self.pending: tuple | None = None       # the newest command answering self.message_id
        self.window = collections.deque(maxlen=fw.SUCCESS_WINDOW)
        self.lost_in_row = 0
        self.max_lost_in_row = 0
        self._buf = bytearray(65536)
        self._last_state_moving = False       # was the newest state sent during a motion?
        self._mode_switch_state = False       # ... and the motion's first (no libfranka client answers it)?
        for k in ("cycles_moving", "commands_ok", "lost", "late", "reflexes", "motions", "motions_finished"):
            self.counters[k] = 0               # in every stats answer, 0 included
        self._last_command_ns = time.monotonic_ns()   # when the last command of the motion came
        self._sent_ns = np.zeros(_RING, dtype=np.int64)
        self._marks = np.zeros((_RING, 2), dtype=np.int64)   # a watched client's (CPU time, wait) at each send
        self.rtt_ns = np.zeros(_RING, dtype=np.int64)
        self.rtt_count = 0
        n = 7
        self.q_d, self.dq_d, self.ddq_d = self.arm.q.copy(), np.zeros(n), np.zeros(n)
        self.tau_J_d, self.dtau_J = np.zeros(n), np.zeros(n)
        self.prev_tau = np.zeros(n)
        self.NE_T_EE, self.EE_T_K = _IDENTITY.copy(), _IDENTITY.copy()
        self.load = (0.0, np.zeros(3), np.zeros(9))
        self._flange = np.zeros(16)
        self._ee = np.zeros(16)
        self.tau_ext = np.zeros(n)
        self.last_reflex = ""
        self._values = self._state_template()
        self._watch: _ClientThread | None = None   # the client's thread (``watch``), or None
        self.max_own_lost_in_row = 0           # the longest run counted against the client (watched: its own ms)
        self._unanswered_since_ns = 0          # when the first state of the current run of lost cycles was sent

    # --- the state datagram -------------------------------------------------------------------------
    def _state_template(self) -> np.ndarray:
        v = np.zeros((), dtype=fw.STATE_DTYPE)
        for name in ("F_T_EE", "F_T_NE", "NE_T_EE", "EE_T_K"):
            v[name] = _IDENTITY
        v["O_ddP_O"] = (0.0, 0.0, -9.81)      # libfranka's Model.gravity reads it (pitfall C14)
        return v

    def _pack_state(self) -> None:
        """Fill the state record (float32 on the wire, as the robot sends it)."""
        arm, v = self.arm, self._values
        arm.flange_pose(self._flange)
        ee = (self._flange.reshape(4, 4).T @ self.NE_T_EE.reshape(4, 4).T).T.ravel()   # O_T_F * NE_T_EE (F_T_NE = I)
        # tau_ext_hat_filtered: measured torque minus the quasi-static model (gravity + the
        # external controller's own torque), low-pass filtered (ours: no inertial terms)
        self.tau_ext += 0.1 * ((arm.tau - arm.gravity() - self.tau_J_d) - self.tau_ext)
        v["message_id"] = self.message_id
        v["O_T_EE"] = v["O_T_EE_d"] = v["O_T_EE_c"] = ee
        v["NE_T_EE"] = v["F_T_EE"] = self.NE_T_EE
        v["EE_T_K"] = self.EE_T_K
        v["m_load"], v["F_x_Cload"], v["I_load"] = self.load
        v["tau_J"], v["tau_J_d"], v["dtau_J"] = arm.tau, self.tau_J_d, self.dtau_J
        v["q"], v["q_d"], v["dq"], v["dq_d"], v["ddq_d"] = arm.q, self.q_d, arm.dq, self.dq_d, self.ddq_d
        v["theta"], v["dtheta"] = arm.q, arm.dq
        v["tau_ext_hat_filtered"] = self.tau_ext
        v["motion_generator_mode"], v["controller_mode"], v["robot_mode"] = self.generator, self.controller, self.robot_mode
        v["errors"], v["reflex_reason"] = self.errors, self.reflex_reason
        v["control_command_success_rate"] = (sum(self.window) / len(self.window)) if (
            self.motion is not None and self.window) else 0.0

    # --- sockets ------------------------------------------------------------------------------------
    def sockets(self) -> list:
        return [self.listener, self.udp, self.monitor, *self.conns]

    def on_readable(self, sock) -> None:
        if sock is self.udp:
            self._drain_udp()
        elif sock is self.listener:
            self._accept()
        elif sock is self.monitor:
            self._serve_monitor()
        elif sock in self.conns:
            self._read_tcp(self.conns[sock])

    def _accept(self) -> None:
        try:
            s, peer = self.listener.accept()
        except OSError:
            return
        s.setblocking(False)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.conns[s] = _Conn(s, peer)
        self.counters["tcp_connections"] += 1

    def _close(self, conn: _Conn, why: str) -> None:
        self.conns.pop(conn.sock, None)
        try:
            conn.sock.close()
        except OSError:
            pass
        self.counters[why] += 1
        if self.motion is not None and self.motion.conn is conn:
            # the client is gone mid-motion: on the robot the connection drop ends the motion in
            # the communication reflex; nobody is left to read the Move response
            self.motion = None
            self._reflex(fw.ERR_COMMUNICATION_CONSTRAINTS_VIOLATION, reply=False)

    def _send_tcp(self, conn: _Conn, data: bytes) -> None:
        try:
            conn.sock.sendall(data)        # responses are small; the client reads them promptly
        except OSError:
            self._close(conn, "tcp_send_errors")

    def _reply(self, conn: _Conn, command: int, command_id: int, payload: bytes) -> None:
        self._send_tcp(conn, fw.HEADER.pack(command, command_id, fw.HEADER.size + len(payload)) + payload)

    def _read_tcp(self, conn: _Conn) -> None:
        try:
            chunk = conn.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            chunk = b""
        if not chunk:
            self._close(conn, "tcp_disconnects")
            return
        conn.buf += chunk
        while len(conn.buf) >= fw.HEADER.size and conn.sock in self.conns:
            command, command_id, size = fw.HEADER.unpack_from(conn.buf)
            if size < fw.HEADER.size or size > _MAX_MESSAGE or command not in fw.REQUEST \
                    or size != fw.HEADER.size + fw.REQUEST[command].size:
                self._close(conn, "tcp_malformed")
                return
            if len(conn.buf) < size:
                return
            payload = bytes(conn.buf[fw.HEADER.size:size])
            del conn.buf[:size]
            if conn.udp is None and command != fw.CONNECT:
                self._close(conn, "tcp_malformed")
                return
            self.counters[f"tcp_{fw.COMMAND_NAMES[command]}"] += 1
            self._handle(conn, command, command_id, fw.REQUEST[command].unpack(payload))

    # --- TCP commands -------------------------------------------------------------------------------
    def _handle(self, conn: _Conn, command: int, cid: int, args: tuple) -> None:
        ok = fw.STATUS.pack
        if command == fw.CONNECT:
            version, udp_port = args
            if version != self.server_version:
                self.counters["incompatible_connects"] += 1
                self._reply(conn, command, cid, fw.CONNECT_REPLY.pack(fw.CONNECT_INCOMPATIBLE_VERSION, self.server_version))
                return
            conn.udp = (conn.peer[0], udp_port)
            self._reply(conn, command, cid, fw.CONNECT_REPLY.pack(fw.CONNECT_SUCCESS, self.server_version))
        elif command == fw.MOVE:
            self._start_motion(conn, cid, args)
        elif command == fw.STOP_MOVE:
            if self.motion is not None and self.motion.conn is conn:
                self._reply(conn, command, cid, ok(fw.STOP_SUCCESS))
                self._end_motion(fw.MOVE_PREEMPTED)
            else:
                self._reply(conn, command, cid, ok(fw.STOP_SUCCESS if self.motion is None else fw.STOP_NOT_POSSIBLE))
        elif command == fw.AUTOMATIC_ERROR_RECOVERY:
            if self.motion is not None:
                self._reply(conn, command, cid, ok(fw.RECOVERY_NOT_POSSIBLE))
                return
            if self.robot_mode == fw.MODE_REFLEX:
                self.counters["recoveries"] += 1
            self.errors[:] = False
            self.robot_mode = fw.MODE_IDLE
            self.lost_in_row = 0
            self._reply(conn, command, cid, ok(fw.RECOVERY_SUCCESS))
        elif command == fw.GET_ROBOT_MODEL:
            self._reply(conn, command, cid, ok(fw.MODEL_SUCCESS) + self.urdf)
        else:
            self._reply(conn, command, cid, ok(self._setter(command, args)))

    def _setter(self, command: int, args: tuple) -> int:
        """The Set* commands: refused while a motion runs (as the robot does), checked, stored."""
        if self.motion is not None:
            return fw.SET_NOT_POSSIBLE
        a = np.asarray(args, dtype=float)
        if not np.all(np.isfinite(a)):
            return fw.SET_INVALID_ARGUMENT
        if command == fw.SET_JOINT_IMPEDANCE:
            if np.any(a < 0) or np.any(a > 14250):     # 14250 N m/rad: libfranka's documented maximum for K_theta
                return fw.SET_INVALID_ARGUMENT
            self.arm.set_stiffness(a)
        elif command == fw.SET_NE_TO_EE:
            self.NE_T_EE = a.copy()
        elif command == fw.SET_EE_TO_K:
            self.EE_T_K = a.copy()
        elif command == fw.SET_LOAD:
            if a[0] < 0:
                return fw.SET_INVALID_ARGUMENT
            self.load = (float(a[0]), a[1:4].copy(), a[4:13].copy())
        elif command in (fw.SET_COLLISION_BEHAVIOR, fw.SET_CARTESIAN_IMPEDANCE):
            if np.any(a < 0):
                return fw.SET_INVALID_ARGUMENT
        return fw.SET_SUCCESS

    def _start_motion(self, conn: _Conn, cid: int, args: tuple) -> None:
        controller, generator = args[0], args[1]

        def refuse(status: int, why: str) -> None:
            self.counters[why] += 1
            self._reply(conn, fw.MOVE, cid, fw.STATUS.pack(status))

        if controller not in fw.MOVE_CONTROLLERS or generator not in fw.MOVE_GENERATORS:
            return refuse(fw.MOVE_INVALID_ARGUMENT, "move_invalid")
        if generator == 4 and controller != 2:            # no generator needs an external controller
            return refuse(fw.MOVE_INVALID_ARGUMENT, "move_invalid")
        if self.robot_mode == fw.MODE_REFLEX or self.errors.any() or self.motion is not None:
            return refuse(fw.MOVE_COMMAND_NOT_POSSIBLE, "move_not_possible")
        if generator in (2, 3) or controller == 1:       # Cartesian generators / impedance: not simulated
            return refuse(fw.MOVE_COMMAND_NOT_POSSIBLE, "move_unsupported")
        t = self.message_id * 1e-3
        self.motion = _Motion(conn, cid, fw.STATE_CONTROLLER_OF_MOVE[controller], fw.STATE_GENERATOR_OF_MOVE[generator],
                              _Track(self.arm.q.copy(), t), _Track(np.zeros(7), t), _Track(np.zeros(7), t))
        self.generator, self.controller = self.motion.generator, self.motion.controller
        self.robot_mode = fw.MODE_MOVE
        self.reflex_reason[:] = False
        self.window.clear()
        self.lost_in_row = 0
        self.pending = None
        self._last_command_ns = time.monotonic_ns()
        self.counters["motions"] += 1
        self.arm.set_mode("effort" if self.controller == fw.CTRL_EXTERNAL else
                          ("velocity" if self.generator == fw.GEN_JOINT_VELOCITY else "position"))
        if self.arm.mode == "effort":
            self.arm.cmd[:] = self.arm.gravity()
        self.prev_tau[:] = 0.0
        self._reply(conn, fw.MOVE, cid, fw.STATUS.pack(fw.MOVE_MOTION_STARTED))

    def _end_motion(self, status: int, reply: bool = True) -> None:
        m = self.motion
        self.motion = None
        self.generator, self.controller = fw.GEN_IDLE, fw.CTRL_JOINT_IMPEDANCE
        if self.robot_mode == fw.MODE_MOVE:
            self.robot_mode = fw.MODE_IDLE
        self.arm.hold(m.q.x[0] if m is not None and m.generator == fw.GEN_JOINT_POSITION and status == fw.MOVE_SUCCESS
                      else None)
        self.q_d[:] = self.arm.cmd
        self.dq_d[:] = self.ddq_d[:] = 0.0
        self.tau_J_d[:] = 0.0
        self.pending = None
        if m is not None and reply and m.conn.sock in self.conns:
            self._reply(m.conn, fw.MOVE, m.command_id, fw.STATUS.pack(status))

    def _reflex(self, error: int, reply: bool = True, detail: str = "") -> None:
        self.last_reflex = f"{fw.ERROR_NAMES[error]} at message_id {self.message_id}" + (f": {detail}" if detail else "")
        self.errors[error] = True
        self.reflex_reason[error] = True
        self.counters["reflexes"] += 1
        self.counters[f"reflex_{fw.ERROR_NAMES[error]}"] += 1
        if self.motion is not None:
            self._end_motion(fw.MOVE_REFLEX_ABORTED, reply)
        self.robot_mode = fw.MODE_REFLEX
        self.arm.hold()
        self.q_d[:] = self.arm.q

    # --- UDP ----------------------------------------------------------------------------------------
    def _drain_udp(self) -> None:
        c = self.counters
        while True:
            try:
                nbytes, addr = self.udp.recvfrom_into(self._buf)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                c["udp_errors"] += 1
                return
            if nbytes != fw.COMMAND.size:
                c["udp_bad_length"] += 1
                continue
            m = self.motion
            if m is None or addr != m.conn.udp:
                c["udp_foreign" if m is not None else "udp_idle"] += 1
                continue
            mid = int.from_bytes(self._buf[0:8], "little")
            if mid > self.message_id:
                c["udp_bad_id"] += 1
                continue
            back = self.message_id - mid
            if back < _RING:
                self.rtt_ns[self.rtt_count % _RING] = time.monotonic_ns() - self._sent_ns[mid % _RING]
                self.rtt_count += 1
            if back:
                c["late"] += 1
                if self._watch is not None and self.lost_in_row and back < _RING:
                    # it has caught up with state mid: from here it waits for (or works on) mid + 1,
                    # which the box may not have sent yet (a box held off the CPU mid-tick counts
                    # an answer that came during its tick as late): its silence starts at that send
                    self._start_silence(mid + 1)
                continue
            if self.pending is not None:
                c["duplicates"] += 1
            self.pending = fw.COMMAND.unpack_from(self._buf)
            self._last_command_ns = time.monotonic_ns()

    def _serve_monitor(self) -> None:
        while True:
            try:
                data, addr = self.monitor.recvfrom(256)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            words = data.split()
            if words == [b"stats"]:
                reply = json.dumps(self.stats()).encode()
            elif words == [b"clock"]:         # the robot's clock alone: cheap enough to ask within a cycle
                reply = b'{"message_id": %d}' % self.message_id
            elif len(words) == 2 and words[0] == b"watch" and words[1].isdigit():
                reply = self._start_watch(int(words[1])).encode()
            else:
                self.counters["monitor_malformed"] += 1
                continue
            try:
                self.monitor.sendto(reply, addr)
            except OSError:
                self.counters["monitor_errors"] += 1

    def _start_watch(self, tid: int) -> str:
        """Attribute lost cycles between the client thread ``tid`` and the machine (see the module
        docstring); 'ok', or 'unavailable: why' (the robot's plain rule stays)."""
        if self._watch is not None:
            self._watch.close()
            self._watch = None
        try:
            self._watch = _ClientThread(tid)
        except OSError as exc:
            return f"unavailable: /proc/{tid}: {exc.strerror}"
        except ValueError as exc:
            return f"unavailable: {exc}"
        self.counters["watches"] += 1
        return "ok"

    # --- the tick -----------------------------------------------------------------------------------
    def _apply(self, cmd: tuple) -> None:
        """Check and apply the RobotCommand answering the newest state (a reflex if it breaks a limit)."""
        m, arm = self.motion, self.arm
        t = self.message_id * 1e-3
        if m.generator == fw.GEN_JOINT_POSITION:
            q = np.array(cmd[fw.CMD_Q])
            if not np.all(np.isfinite(q)) or np.any(q < arm.limits_low) or np.any(q > arm.limits_high):
                return self._reflex(fw.ERR_JOINT_MG_POSITION_LIMITS, detail=f"q_c {np.round(q, 4).tolist()}")
            v, a, j = m.q.derivatives(q, t)
            # the velocity limit against the last command that came, over the time between them:
            # after lost cycles the robot's own extrapolation is not the client's motion
            t_rx, q_rx = m.received if m.received is not None else (m.q.t[0], m.q.x[0])
            v_rx = (q - q_rx) / max(t - t_rx, 1e-3)
            m.received = (t, q)
            checks = ((fw.ERR_JOINT_MG_VELOCITY_LIMITS, v_rx, arm.velocity_limits, "velocity rad/s"),
                      (fw.ERR_JOINT_MG_VELOCITY_DISCONTINUITY, a, _ACC, "acceleration rad/s^2"),
                      (fw.ERR_JOINT_MG_ACCELERATION_DISCONTINUITY, j, _JERK, "jerk rad/s^3"))
            m.q.push(q, t)
            arm.cmd[:] = q
            self.q_d[:], self.dq_d[:], self.ddq_d[:] = q, v, a
        elif m.generator == fw.GEN_JOINT_VELOCITY:
            dq = np.array(cmd[fw.CMD_DQ])
            if not np.all(np.isfinite(dq)):
                return self._reflex(fw.ERR_JOINT_MG_VELOCITY_LIMITS, detail=f"dq_c {dq.tolist()}")
            a, j, _ = m.dq.derivatives(dq, t)
            checks = ((fw.ERR_JOINT_MG_VELOCITY_LIMITS, dq, arm.velocity_limits, "velocity rad/s"),
                      (fw.ERR_JOINT_MG_VELOCITY_DISCONTINUITY, a, _ACC, "acceleration rad/s^2"),
                      (fw.ERR_JOINT_MG_ACCELERATION_DISCONTINUITY, j, _JERK, "jerk rad/s^3"))
            m.dq.push(dq, t)
            arm.cmd[:] = dq
            self.dq_d[:], self.ddq_d[:] = dq, a
            self.q_d[:] = arm.q
        else:
            checks = ()
        if m.controller == fw.CTRL_EXTERNAL:
            tau = np.array(cmd[fw.CMD_TAU])
            if not np.all(np.isfinite(tau)):
                return self._reflex(fw.ERR_CONTROLLER_TORQUE_DISCONTINUITY, detail=f"tau_J_d {tau.tolist()}")
            rate = m.tau.derivatives(tau, t)[0]
            checks += ((fw.ERR_CONTROLLER_TORQUE_DISCONTINUITY, rate, _TORQUE_RATE, "torque rate N m/s"),)
            m.tau.push(tau, t)
            self.dtau_J[:] = rate
            self.tau_J_d[:] = tau
            np.clip(tau + arm.gravity(), -arm.effort_limits, arm.effort_limits, out=arm.cmd)
            self.q_d[:] = arm.q
        for err, x, lim, what in checks:
            if np.any(np.abs(x) > lim):
                j = int(np.argmax(np.abs(x) / lim))
                track = m.q if m.generator == fw.GEN_JOINT_POSITION else (m.dq if m.generator == fw.GEN_JOINT_VELOCITY
                                                                           else m.tau)
                history = ", ".join(f"{1e3 * tk:.0f} ms: {xk[j]:.7f}" for tk, xk in zip(track.t, track.x))
                return self._reflex(err, detail=f"commanded {what} {np.round(x, 3).tolist()} (limit {lim}); joint "
                                                f"{j + 1}'s commands, newest first: {history}")
        if cmd[fw.CMD_MOTION_FINISHED] or cmd[fw.CMD_TORQUE_FINISHED]:
            self.counters["motions_finished"] += 1
            self._end_motion(fw.MOVE_SUCCESS)

    def _extrapolate(self, stamp: int) -> None:
        """A lost packet (the command for state ``stamp`` never came, or the box skipped that
        tick): the motion extrapolated at constant acceleration, the torque reused."""
        m, arm = self.motion, self.arm
        t = stamp * 1e-3
        if m.generator == fw.GEN_JOINT_POSITION:
            q = np.clip(m.q.extrapolate(t, order=1), arm.limits_low, arm.limits_high)
            v, a, _ = m.q.derivatives(q, t)
            m.q.push(q, t)
            arm.cmd[:] = q
            self.q_d[:], self.dq_d[:], self.ddq_d[:] = q, v, a
        elif m.generator == fw.GEN_JOINT_VELOCITY:
            dq = np.clip(m.dq.extrapolate(t, order=1), -arm.velocity_limits, arm.velocity_limits)
            a = m.dq.derivatives(dq, t)[0]
            m.dq.push(dq, t)
            arm.cmd[:] = dq
            self.dq_d[:], self.ddq_d[:] = dq, a
        if m.controller == fw.CTRL_EXTERNAL:
            m.tau.push(m.tau.x[0], t)
            np.clip(m.tau.x[0] + arm.gravity(), -arm.effort_limits, arm.effort_limits, out=arm.cmd)

    def _silent_ms(self) -> float:
        """How long (ms of wall time) the first state of the current run of lost cycles has been
        waiting for its answer: the box's own starvation before it sent that state is not the client's."""
        return (time.monotonic_ns() - self._unanswered_since_ns) / 1e6

    def _silence_too_long(self) -> bool:
        """The robot's rule as a starved box can keep it: silent for SILENCE_MS of wall time since
        the last command, with SILENCE_LOST states unanswered; scaled with ``max_lost`` (a box that
        allows more lost cycles than the robot's 20, a benchmark's, allows as much more silence)."""
        silent = (time.monotonic_ns() - self._last_command_ns) / 1e6
        return silent >= SILENCE_MS * self.max_lost / fw.MAX_LOST_IN_ROW and self.lost_in_row >= SILENCE_LOST

    def _own_ms(self, machine_ms: float) -> float:
        """A watched client's own time (ms) without an answer: since the first unanswered state
        was sent, less what it spent waiting for a CPU (``machine_ms``); its running and its
        blocking (a sleep, a slow call) count. On a robot that never starves, 20 lost cycles.
        Before the motion's first command, lost cycles less its waits instead: libfranka's
        startMotion reads every state that is queued when the modes switch and answers none, so
        the client may be waiting for the box's next state while one it never saw counts as lost."""
        if self.motion is not None and not self.motion.answered:
            return self.lost_in_row - machine_ms
        return self._silent_ms() - machine_ms

    def _machine_note(self) -> str:
        if self._watch is None:
            return ""
        return (f"; the client waited {self._watch.last_ms:.0f} ms of it for a CPU, ran {self._watch.ran_ms:.0f} ms"
                f"{self._watch.where()}")

    def _start_silence(self, mid: int) -> None:
        """The client's silence runs from the send of state ``mid`` (its first unanswered one)."""
        since = int(self._sent_ns[mid % _RING])
        if since > self._unanswered_since_ns:
            self._unanswered_since_ns = since
            if self._watch is not None:
                self._watch.restart(self._marks[mid % _RING], since)

    def _machine_ms(self) -> float:
        """How much of the current run of lost cycles (ms) the watched client spent waiting for a
        CPU, counted from the send of its first unanswered state (0 when nothing is watched)."""
        if self._watch is None:
            return 0.0
        return self._watch.waited_ms()

    def tick(self) -> None:
        c = self.counters
        switch, self._mode_switch_state = self._mode_switch_state, False
        if switch and self.motion is not None and self.pending is None:
            # the motion's first state (its modes switched) is read by libfranka's startMotion, which
            # sends nothing; every client's first readOnce() then waits for the next one. No client
            # answers it, so it is neither lost nor in time: the robot holds
            c["mode_switch_states"] += 1
            self._extrapolate(self.message_id)
        elif self.motion is not None and self._last_state_moving:   # a state of this motion awaits its command
            c["cycles_moving"] += 1
            cmd, self.pending = self.pending, None
            if cmd is not None:
                c["commands_ok"] += 1
                self.motion.answered = True
                self.lost_in_row = 0
                self.window.append(1)
                self._apply(cmd)
            else:
                c["lost"] += 1
                self.lost_in_row += 1
                self.max_lost_in_row = max(self.max_lost_in_row, self.lost_in_row)
                self.window.append(0)
                # the robot's rule is 20 lost cycles in a row; a starved box sends fewer states
                # than milliseconds pass, so a long silence in wall time trips it too
                # (_silence_too_long: a box that stalled itself is not the client's fault)
                if self.lost_in_row == 1:     # the state sent last tick is the first one left unanswered
                    self._unanswered_since_ns = 0
                    self._start_silence(self.message_id)
                machine_ms = self._machine_ms()
                if self._watch is None:       # the robot's rule (and the silence rule of a starved box)
                    own = self.lost_in_row
                    trip = own >= self.max_lost or self._silence_too_long()
                else:                         # the client's own time, its CPU waits apart
                    own = self._own_ms(machine_ms)
                    trip = own >= self.max_lost
                    if trip and self._watch.runnable:
                        # runnable: it may be waiting for a CPU now, a wait the kernel puts on
                        # record only when it ends. Blame it only if it is over the limit even when
                        # every unseen millisecond was a wait; else decide once it has run or
                        # blocked (up to MACHINE_CAP_MS of silence: then the reflex is the machine's)
                        if self._own_ms(self._watch.recorded_ms + self._watch.unknown_ms) < self.max_lost:
                            own = min(own, self.max_lost - 1)
                            if self._silent_ms() < MACHINE_CAP_MS:
                                trip = False
                                c["verdicts_deferred"] += 1
                            else:
                                c["reflexes_machine"] += 1
                self.max_own_lost_in_row = max(self.max_own_lost_in_row, max(0, int(own)))
                if trip:
                    self._reflex(fw.ERR_COMMUNICATION_CONSTRAINTS_VIOLATION,
                                 detail=f"{self.lost_in_row} lost in a row" + self._machine_note())
                else:
                    if self.lost_in_row >= self.max_lost or self._silence_too_long():
                        c["lost_machine"] += 1     # the robot's rule would trip: the machine's doing
                    self._extrapolate(self.message_id)
        else:
            self.pending = None
            if self.motion is None:
                self.q_d[:] = self.arm.q
        # physics and the robot's clock: one millisecond per state. A tick the box process could
        # not keep (descheduled) is not made up: the simulated robot's time stops with it, as a
        # simulator's clock does, so the client never sees a gap the robot would not have had.
        try:
            self.arm.step(1)
        except ValueError:
            c["rejected_nonfinite"] += 1
            self.arm.hold()
            self.arm.step(1)
        self.message_id += 1
        self._pack_state()
        out = self._values.tobytes()
        self._mode_switch_state = self.motion is not None and not self._last_state_moving
        self._last_state_moving = self.motion is not None
        if self._watch is not None and self.motion is not None:
            self._marks[self.message_id % _RING] = self._watch.mark()   # the client's CPU time and wait as it leaves
        self._sent_ns[self.message_id % _RING] = time.monotonic_ns()
        for conn in list(self.conns.values()):
            if conn.udp is not None:
                try:
                    self.udp.sendto(out, conn.udp)
                except OSError:
                    c["udp_send_errors"] += 1
        c["states_sent"] += 1
        if self.motion is not None:
            c["states_sent_moving"] += 1

    def stats(self) -> dict:
        k = min(self.rtt_count, _RING)
        rtt = np.sort(self.rtt_ns[:k]) / 1e3 if k else None
        rtt_us = ({"rtt_n": k, "rtt_p50_us": float(rtt[k // 2]), "rtt_p99_us": float(rtt[min(k - 1, int(0.99 * k))]),
                   "rtt_max_us": float(rtt[-1]),
                   "rtt_hist_counts": np.histogram(np.clip(rtt, RTT_HIST_EDGES_US[0], RTT_HIST_EDGES_US[-1]),
                                                   RTT_HIST_EDGES_US)[0].tolist()} if k else {"rtt_n": 0})
        return {**rtt_us, "message_id": self.message_id, "last_reflex": self.last_reflex, "robot_mode": self.robot_mode,
                "errors": fw.error_names(self.errors), "last_motion_errors": fw.error_names(self.reflex_reason),
                "lost_in_row": self.lost_in_row, "max_lost_in_row": self.max_lost_in_row, "max_lost": self.max_lost,
                "max_own_lost_in_row": self.max_own_lost_in_row, "watching": self._watch is not None,
                "success_rate": (sum(self.window) / len(self.window)) if self.window else 0.0,
                "clients": len(self.conns), "moving": self.motion is not None, **self.counters}
