"""ur_rtde-like clients for the UR-style box: a receive interface and a control interface.

Counterparts (ur_rtde): ``RTDEReceiveInterface(host, frequency, variables)`` with
``getActualQ()``, ``getActualQd()``, ``getTargetQ()``, ``getTimestamp()``,
``getRuntimeState()``; ``RTDEControlInterface(host)`` with ``servoJ(q, speed, acceleration,
time, lookahead_time, gain)``, ``servoStop()``, ``stopScript()``. Where we differ: snake_case;
no background thread (call :meth:`RTDEReceiveInterface.receive` to take in what arrived; the
newest package wins); the ports are the box's (free ones), not 30004/30002.
"""

from __future__ import annotations

import json
import select
import socket
import struct
import time

import numpy as np

from . import ur_protocol as up

DEFAULT_VARIABLES = ("timestamp", "target_q", "actual_q", "actual_qd", "actual_joint_torques", "runtime_state")


class RTDEError(ConnectionError):
    """The box refused the handshake or went away."""


class RTDEReceiveInterface:
    """Negotiate a recipe at ``frequency`` Hz and take in the state stream."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, frequency: float = 500.0,
                 variables=DEFAULT_VARIABLES, timeout: float = 2.0):
        unknown = [v for v in variables if v not in up.FIELDS]
        if unknown:
            raise ValueError(f"unknown RTDE output(s) {unknown}; available: {sorted(up.FIELDS)}")
        self.address = (host, port)
        self.timeout = float(timeout)
        try:
            self.sock = socket.create_connection(self.address, timeout=self.timeout)
        except OSError as exc:
            raise RTDEError(f"cannot connect to the RTDE port {host}:{port}: {exc}") from None
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._in = bytearray()
        self.variables = list(variables)
        self.messages: list[str] = []
        ok = self._ask(up.REQUEST_PROTOCOL_VERSION, struct.pack(">H", up.RTDE_PROTOCOL_VERSION))
        if ok != b"\x01":
            raise RTDEError(f"the box refused RTDE protocol version {up.RTDE_PROTOCOL_VERSION}")
        self.controller_version = struct.unpack(">4I", self._ask(up.GET_URCONTROL_VERSION))
        reply = self._ask(up.SETUP_OUTPUTS, struct.pack(">d", float(frequency)) + ",".join(self.variables).encode())
        if reply[:1] != b"\x01":
            raise RTDEError(f"the box refused the output recipe {self.variables} at {frequency} Hz: "
                            f"{'; '.join(self.messages) or reply[1:].decode()}")
        self.types = reply[1:].decode().split(",")
        self._struct = up.recipe_struct(self.variables)
        if self._ask(up.START) != b"\x01":
            raise RTDEError("the box refused to start the stream")
        self.sock.setblocking(False)
        self.values = {v: np.zeros(6) if up.FIELDS[v][0] == "VECTOR6D" else np.zeros(1) for v in self.variables}
        self.packages = 0
        self.last_receive = time.monotonic()
        self.closed_by_peer = False

    def _read_package(self) -> tuple[int, bytes] | None:
        if len(self._in) < up.HEADER.size:
            return None
        size, ptype = up.HEADER.unpack_from(self._in)
        if size < up.HEADER.size or len(self._in) < size:
            return None
        payload = bytes(self._in[up.HEADER.size:size])
        del self._in[:size]
        return ptype, payload

    def _ask(self, ptype: int, payload: bytes = b"") -> bytes:
        """Handshake step (blocking, before the stream starts): send and wait for the same type."""
        self.sock.sendall(up.package(ptype, payload))
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            while (p := self._read_package()) is not None:
                if p[0] == up.TEXT_MESSAGE:
                    self.messages.append(p[1].decode(errors="replace"))
                    if p[1].startswith(b"busy"):
                        raise RTDEError(f"the box refused the connection: {p[1].decode()}")
                elif p[0] == ptype:
                    return p[1]
            self.sock.settimeout(max(1e-3, deadline - time.monotonic()))
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                break
            if not data:
                raise RTDEError(f"the box closed the RTDE connection during the handshake "
                                f"({'; '.join(self.messages) or 'no message'})")
            self._in += data
        raise RTDEError(f"no reply to RTDE package {chr(ptype)!r} within {self.timeout} s")

    def receive(self, timeout: float = 0.0) -> int:
        """Take in every package that arrived (waiting up to ``timeout`` s for the first);
        returns how many. The values of the newest are in ``self.values``."""
        got = 0
        deadline = time.monotonic() + timeout
        while True:
            r, _, _ = select.select([self.sock], [], [], 0.0 if got else max(0.0, deadline - time.monotonic()))
            if not r:
                break
            try:
                data = self.sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                data = b""
            if not data:
                self.closed_by_peer = True
                break
            self._in += data
            while (p := self._read_package()) is not None:
                if p[0] == up.DATA_PACKAGE and len(p[1]) == self._struct.size:
                    flat = self._struct.unpack(p[1])[1:]
                    i = 0
                    for v in self.variables:
                        arr = self.values[v]
                        arr[:] = flat[i:i + arr.shape[0]]
                        i += arr.shape[0]
                    got += 1
        if got:
            self.packages += got
            self.last_receive = time.monotonic()
        return got

    def get(self, name: str):
        v = self.values[name]
        return v if v.shape[0] == 6 else float(v[0])

    def getActualQ(self):  # noqa: N802 (ur_rtde's names)
        return self.values["actual_q"].copy()

    def getActualQd(self):  # noqa: N802
        return self.values["actual_qd"].copy()

    def getTargetQ(self):  # noqa: N802
        return self.values["target_q"].copy()

    def getTimestamp(self):  # noqa: N802
        return float(self.values["timestamp"][0])

    def getRuntimeState(self):  # noqa: N802
        return int(self.values["runtime_state"][0])

    def close(self) -> None:
        self.sock.close()


class RTDEControlInterface:
    """Send servoj targets (and stopj) on the script channel; each line is also the keepalive."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, timeout: float = 2.0):
        self.address = (host, port)
        try:
            self.sock = socket.create_connection(self.address, timeout=timeout)
        except OSError as exc:
            raise RTDEError(f"cannot connect to the script port {host}:{port}: {exc}") from None
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.timeout = float(timeout)
        # a refused second client gets an error line and EOF straight away
        r, _, _ = select.select([self.sock], [], [], 0.05)
        if r:
            data = self.sock.recv(4096)
            if data.startswith(b"error:") or not data:
                self.sock.close()
                raise RTDEError(f"the box refused the script connection: {data.decode().strip() or 'closed'}")

    def send_line(self, line: bytes) -> None:
        try:
            self.sock.sendall(line)
        except OSError as exc:
            raise RTDEError(f"the script channel to {self.address} is gone ({exc})") from None

    def servoJ(self, q, speed: float = 0.0, acceleration: float = 0.0, time: float = 0.002,  # noqa: N802
               lookahead_time: float = 0.1, gain: float = 300.0) -> None:
        for name, v, (lo, hi) in (("time", time, up.SERVOJ_T), ("lookahead_time", lookahead_time, up.LOOKAHEAD),
                                  ("gain", gain, up.GAIN)):
            if not lo <= v <= hi:
                raise ValueError(f"servoJ {name}={v!r} must be in [{lo}, {hi}] (URScript's range)")
        self.send_line(up.servoj_line(q, time, lookahead_time, gain))

    def servoStop(self, a: float = 10.0) -> None:  # noqa: N802
        self.send_line(f"stopj({float(a)!r})\n".encode())

    def box_stats(self) -> dict:
        self.send_line(b"stats()\n")
        self.sock.settimeout(self.timeout)
        buf = b""
        while not buf.endswith(b"\n"):
            chunk = self.sock.recv(65536)
            if not chunk:
                raise RTDEError("the box closed the script channel")
            buf += chunk
        return json.loads(buf.splitlines()[-1])

    def close(self) -> None:
        self.sock.close()
