"""A libfranka-like client for the Franka-style box: ``Robot(host, port).control(callback)``.

Counterparts (libfranka): ``franka::Robot`` (``control``, ``readOnce``, ``automaticErrorRecovery``),
``franka::RobotState`` (``q``, ``dq``, ``tau_J``, ``tau_ext_hat_filtered``,
``control_command_success_rate``, ``robot_mode``, ``current_errors``), ``franka::JointPositions``
/ ``franka::Torques`` with ``motion_finished``, ``franka::ControlException`` and
``franka::NetworkException``; the ActiveControl pair ``readOnce()`` / ``writeOnce()`` that
franka_hardware uses from ros2_control is :meth:`Robot.read_latest` + :meth:`Robot.write_command`.
Where we differ: snake_case names; one UDP socket (no TCP command channel); the state arrays
from :meth:`read_latest` are views into the receive buffer (no allocation per tick).
"""

from __future__ import annotations

import json
import select
import socket
import time
from dataclasses import dataclass, field

import numpy as np

from . import franka_protocol as fp


class NetworkException(ConnectionError):
    """franka::NetworkException: the box did not answer or is gone."""


class ControlException(RuntimeError):
    """franka::ControlException: the box stopped the motion (its errors are in ``errors``)."""

    def __init__(self, message: str, errors: list[str]):
        super().__init__(message)
        self.errors = errors


@dataclass
class RobotState:
    """One state from the box (franka::RobotState's fields that we send)."""

    seq: int
    q: np.ndarray
    dq: np.ndarray
    tau_J: np.ndarray  # noqa: N815 (libfranka's name)
    tau_ext_hat_filtered: np.ndarray
    control_command_success_rate: float
    robot_mode: str
    current_errors: list[str] = field(default_factory=list)


@dataclass
class JointPositions:
    q: list | np.ndarray
    motion_finished: bool = False


@dataclass
class Torques:
    tau_J: list | np.ndarray  # noqa: N815
    motion_finished: bool = False


def query_box_stats(host: str = "127.0.0.1", port: int = 0, timeout: float = 1.0) -> dict:
    """The box's counters without connecting (STATS is answered to anyone): what a monitoring
    tool reads while another client, or none, holds the robot."""
    if not isinstance(port, int) or not 0 < port < 65536:
        raise ValueError(f"port={port!r} must be the box's UDP port (1..65535), e.g. box.ports['udp']")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect((host, port))
        s.settimeout(timeout / 3)
        for _attempt in range(3):
            s.send(fp.header(fp.STATS))
            try:
                reply = s.recv(65536)
            except (TimeoutError, ConnectionRefusedError):
                continue
            if len(reply) >= fp.HEADER.size and fp.HEADER.unpack_from(reply)[2] == fp.STATS:
                return json.loads(reply[fp.HEADER.size:])
    raise NetworkException(f"no STATS reply from the box at {host}:{port} within {timeout} s (is it running?)")


class Robot:
    """Connect to a Franka-style box (``franka::Robot``); ``n`` joints and ``period_us`` come from it."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, timeout: float = 1.0):
        if not isinstance(port, int) or not 0 < port < 65536:
            raise ValueError(f"port={port!r} must be the box's UDP port (1..65535), e.g. box.ports['udp']")
        self.address = (host, port)
        self.timeout = float(timeout)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.connect(self.address)
        self.sock.setblocking(False)
        self._buf = bytearray(65536)
        self.n = 0
        self.last_seq = -1        # the newest state received
        self.answered_seq = -1    # the state the last command answered
        self.stale_dropped = 0    # states overtaken by a newer one before being read
        reply = self._request(fp.header(fp.CONNECT), (fp.CONNECT_ACK, fp.CONNECT_REJECT))
        mtype = fp.HEADER.unpack_from(reply)[2]
        if mtype == fp.CONNECT_REJECT:
            self.sock.close()
            raise NetworkException(f"the box at {host}:{port} refused the connection: "
                                   f"{reply[fp.HEADER.size:].decode(errors='replace')}")
        self.n = fp.HEADER.unpack_from(reply)[3]
        self.period_us, self.max_missed = fp.ACK.unpack_from(reply, fp.HEADER.size)
        self._sst = fp.state_struct(self.n)
        self._state_len = fp.HEADER.size + self._sst.size
        n = self.n
        self._state = bytearray(self._state_len)
        floats = np.frombuffer(self._state, dtype="<f8", count=4 * n + 1, offset=fp.HEADER.size)
        self.q, self.dq, self.tau_J, self.tau_ext = (floats[0:n], floats[n:2 * n], floats[2 * n:3 * n],
                                                     floats[3 * n:4 * n])
        self._rate = floats[4 * n:4 * n + 1]
        self._cmd = bytearray(fp.HEADER.size + fp.command_struct(n).size)
        self._cst = fp.command_struct(n)
        self.robot_mode = fp.ROBOT_IDLE
        self.errors = 0

    # --- plumbing ------------------------------------------------------------------------------------
    def _recv(self, timeout: float) -> bytes | None:
        r, _, _ = select.select([self.sock], [], [], timeout)
        if not r:
            return None
        try:
            nbytes = self.sock.recv_into(self._buf)
        except (BlockingIOError, InterruptedError):
            return None
        except ConnectionRefusedError as exc:
            raise NetworkException(f"the box at {self.address[0]}:{self.address[1]} is gone ({exc})") from None
        return memoryview(self._buf)[:nbytes]

    def _request(self, data: bytes, want: tuple[int, ...]) -> bytes:
        """Send ``data`` and wait for a reply of a type in ``want`` (states in between are skipped)."""
        for _attempt in range(3):
            try:
                self.sock.send(data)
            except ConnectionRefusedError as exc:
                raise NetworkException(f"the box at {self.address[0]}:{self.address[1]} is gone ({exc})") from None
            deadline = time.monotonic() + self.timeout / 3
            while (left := deadline - time.monotonic()) > 0:
                msg = self._recv(left)
                if msg is not None and len(msg) >= fp.HEADER.size and fp.HEADER.unpack_from(msg)[2] in want:
                    return bytes(msg)
        raise NetworkException(f"no {[fp.TYPE_NAMES[w] for w in want]} from the box at "
                               f"{self.address[0]}:{self.address[1]} within {self.timeout} s "
                               "(is it running? start_franka_box() prints its port)")

    # --- the cyclic pair (franka_hardware's readOnce / writeOnce) -----------------------------------------
    def read_latest(self, timeout: float | None = None) -> bool:
        """Wait for a state newer than the last one answered; keep the newest if several queued.

        Afterwards ``q``, ``dq``, ``tau_J``, ``tau_ext``, ``success_rate``, ``robot_mode``,
        ``errors`` and ``last_seq`` hold it (views: copy what you keep). Returns False on timeout.
        """
        wait = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + wait
        got = False
        hs, sl = fp.HEADER.size, self._state_len
        while True:
            msg = self._recv(0.0 if got else max(0.0, deadline - time.monotonic()))
            if msg is None:
                if got or time.monotonic() >= deadline:
                    return got
                continue
            if len(msg) != sl or fp.HEADER.unpack_from(msg)[2] != fp.STATE:
                continue
            seq = fp.HEADER.unpack_from(msg)[4]
            if got:
                self.stale_dropped += 1
            self.last_seq = seq
            self._state[:] = msg          # the float views (q, dq, ...) look into self._state
            self.robot_mode, self.errors = self._sst.unpack_from(msg, hs)[-2:]
            if seq > self.answered_seq:
                got = True

    def resync(self) -> None:
        """Drop every queued state, so the next :meth:`read_latest` waits for one sent after now
        (after a pause, the queue holds states the box sent long ago: answering them is late)."""
        while self._recv(0.0) is not None:
            pass
        self.answered_seq = max(self.answered_seq, self.last_seq)

    @property
    def success_rate(self) -> float:
        return float(self._rate[0])

    def write_command(self, values, mode: int = fp.MODE_POSITION, motion_finished: bool = False) -> None:
        """Answer the newest state with a command (``mode`` 1 position, 2 torque)."""
        fp.HEADER.pack_into(self._cmd, 0, fp.MAGIC, fp.VERSION, fp.COMMAND, self.n, self.last_seq)
        self._cst.pack_into(self._cmd, fp.HEADER.size, mode, motion_finished, *values)
        self.answered_seq = self.last_seq
        try:
            self.sock.send(self._cmd)
        except ConnectionRefusedError as exc:
            raise NetworkException(f"the box at {self.address[0]}:{self.address[1]} is gone ({exc})") from None

    # --- libfranka's high-level calls ---------------------------------------------------------------------
    def read_once(self) -> RobotState:
        """franka::Robot::readOnce: the next state, copied."""
        if not self.read_latest():
            raise NetworkException(f"no robot state within {self.timeout} s from {self.address}")
        return self.state()

    def state(self) -> RobotState:
        return RobotState(self.last_seq, self.q.copy(), self.dq.copy(), self.tau_J.copy(), self.tau_ext.copy(),
                          self.success_rate, fp.ROBOT_MODE_NAMES[self.robot_mode], fp.error_names(self.errors))

    def control(self, callback, mode: str = "position", max_duration: float | None = None) -> RobotState:
        """franka::Robot::control: ``callback(state, period_s)`` returns JointPositions or Torques each tick.

        Runs until a command has ``motion_finished`` (returns the last state), ``max_duration``
        seconds pass, or the box reports an error (raises ControlException, as libfranka does).
        """
        if mode not in ("position", "torque"):
            raise ValueError(f"mode={mode!r} must be 'position' or 'torque'")
        want = JointPositions if mode == "position" else Torques
        code = fp.MODE_POSITION if mode == "position" else fp.MODE_TORQUE
        self.resync()
        start = time.monotonic()
        prev_seq = None
        while True:
            if not self.read_latest():
                raise NetworkException(f"no robot state within {self.timeout} s from {self.address}")
            if self.errors:
                raise ControlException(f"Motion aborted by reflex! [{', '.join(fp.error_names(self.errors))}]",
                                       fp.error_names(self.errors))
            period = 0.0 if prev_seq is None else (self.last_seq - prev_seq) * self.period_us * 1e-6
            prev_seq = self.last_seq
            out = callback(self.state(), period)
            if not isinstance(out, want):
                raise TypeError(f"the {mode} control callback must return {want.__name__}, got {type(out).__name__}")
            values = out.q if mode == "position" else out.tau_J
            finished = out.motion_finished or (max_duration is not None and time.monotonic() - start >= max_duration)
            self.write_command(values, code, finished)
            if finished:
                return self.state()

    def automatic_error_recovery(self) -> list[str]:
        """franka::Robot::automaticErrorRecovery: clear a reflex; returns the errors left (none)."""
        reply = self._request(fp.header(fp.RECOVER), (fp.RECOVER_ACK,))
        errors = fp.RECOVER_REPLY.unpack_from(reply, fp.HEADER.size)[0]
        self.errors = errors
        return fp.error_names(errors)

    def box_stats(self) -> dict:
        """The box's counters (missed, late, rx_short, rx_bad_version, ...)."""
        return json.loads(self._request(fp.header(fp.STATS), (fp.STATS,))[fp.HEADER.size:])

    def close(self) -> None:
        if self.sock.fileno() >= 0:
            try:
                self.sock.send(fp.header(fp.DISCONNECT))
            except OSError:
                pass
            self.sock.close()

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
