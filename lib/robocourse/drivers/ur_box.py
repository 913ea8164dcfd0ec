"""The UR-style controller box: RTDE-like state stream at 500 Hz + a servoj script channel.

Counterpart: a UR controller (CB3/e-Series) as ur_rtde and ur_robot_driver see it: the
robot runs its own 500 Hz loop whatever the client does; the client streams servo targets and
the robot follows the latest one; a lapsed keepalive stops the program. Protocol:
:mod:`robocourse.drivers.ur_protocol`. Runs in its own process
(:func:`robocourse.drivers.start_ur_box`).

A client that dies does not keep the robot: both channels are TCP, so when the client's
process dies (even by SIGKILL) the kernel closes its connections, the box reads EOF and frees
the channel at once (``disconnects``); a lapsed keepalive has already stopped the servo
program. A client that hangs without dying (stopped, or its host gone without a FIN) keeps
its connections open: on the script channel the box then hands the slot to a new connection
once the holder has sent nothing for longer than the keepalive (``released_silent_clients``),
as a real UR controller lets a new program replace one that stopped. The RTDE channel has no
such rule, because a streaming RTDE client sends nothing after START, so silence means
nothing there; the real controller avoids the question by serving several RTDE clients at
once, where ours serves one.
"""

from __future__ import annotations

import json
import socket
import time

import numpy as np

from . import ur_protocol as up
from .arm import BoxArm
from .ticker import TickingBox

_MAX_OUT = 1 << 16


class _Conn:
    def __init__(self, sock):
        self.sock = sock
        sock.setblocking(False)
        self.inbuf = bytearray()
        self.outbuf = bytearray()
        self.heard_ns = time.monotonic_ns()   # when it last sent anything


class URBox(TickingBox):
    period_ns = 1_000_000_000 // up.CONTROL_HZ

    def __init__(self, port: int = 0, script_port: int = 0, host: str = "127.0.0.1",
                 keepalive: float = up.KEEPALIVE_S, initial_positions=None):
        super().__init__()
        self.dt = 1.0 / up.CONTROL_HZ
        self.arm = BoxArm(timestep=0.001, initial_positions=initial_positions)
        self.keepalive_ns = int(keepalive * 1e9)
        self.rtde_listener = self._listen(host, port)
        self.script_listener = self._listen(host, script_port)
        self.port = self.rtde_listener.getsockname()[1]
        self.script_port = self.script_listener.getsockname()[1]
        self.rtde: _Conn | None = None
        self.script: _Conn | None = None
        self.recipe: list[str] | None = None
        self.recipe_struct = None
        self.divisor = 1
        self.streaming = False
        self.tick_count = 0
        q = self.arm.q.copy()
        self.target = q.copy()           # latest servoj target
        self.interp_start = q.copy()
        self.interp = q.copy()
        self.ref = q.copy()              # what the joint servos get (target_q)
        self.ref_qd = np.zeros(6)
        self.t_cmd_ns = 0
        self.servo_t = 0.002
        self.lookahead = 0.1
        self.playing = False
        self.last_line_ns = 0

    @staticmethod
    def _listen(host, port):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.bind((host, port))            # OSError "Address already in use" reaches main()
        s.listen(2)
        s.setblocking(False)
        return s

    def sockets(self) -> list:
        socks = [self.rtde_listener, self.script_listener]
        socks += [c.sock for c in (self.rtde, self.script) if c is not None]
        return socks

    # --- connections -----------------------------------------------------------------------------
    def on_readable(self, sock) -> None:
        if sock is self.rtde_listener or sock is self.script_listener:
            conn, _ = sock.accept()
            is_rtde = sock is self.rtde_listener
            if (not is_rtde and self.script is not None
                    and time.monotonic_ns() - self.script.heard_ns > self.keepalive_ns):
                self.counters["released_silent_clients"] += 1
                self._close(self.script)
            if (self.rtde if is_rtde else self.script) is not None:
                self.counters["rejected_connects"] += 1
                msg = (up.package(up.TEXT_MESSAGE, b"busy: another RTDE client is connected") if is_rtde
                       else b"error: busy: another script client is connected and sent a line within the "
                       b"keepalive; stop it (or let it go silent for longer than the keepalive) first\n")
                try:
                    conn.send(msg)
                finally:
                    conn.close()
                return
            if is_rtde:
                self.rtde = _Conn(conn)
                self.streaming = False
            else:
                self.script = _Conn(conn)
            self.counters["connects"] += 1
            return
        conn = self.rtde if self.rtde is not None and sock is self.rtde.sock else self.script
        try:
            data = sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._close(conn)
            return
        conn.heard_ns = time.monotonic_ns()
        conn.inbuf += data
        if conn is self.rtde:
            self._parse_rtde(conn)
        else:
            self._parse_script(conn)

    def _close(self, conn: _Conn) -> None:
        conn.sock.close()
        if conn is self.rtde:
            self.rtde, self.streaming = None, False
        else:
            self.script = None
        self.counters["disconnects"] += 1

    def _send(self, conn: _Conn, data: bytes) -> None:
        if len(conn.outbuf) > _MAX_OUT:
            self.counters["tx_dropped"] += 1     # the client does not read: drop, never block the loop
            return
        conn.outbuf += data
        try:
            sent = conn.sock.send(conn.outbuf)
            del conn.outbuf[:sent]
        except (BlockingIOError, InterruptedError):
            pass
        except OSError:
            self._close(conn)

    # --- RTDE --------------------------------------------------------------------------------------
    def _parse_rtde(self, conn: _Conn) -> None:
        buf, c = conn.inbuf, self.counters
        while len(buf) >= up.HEADER.size:
            size, ptype = up.HEADER.unpack_from(buf)
            if size < up.HEADER.size:           # cannot find the next package boundary: drop what we have
                c["rx_bad_size"] += 1
                buf.clear()
                return
            if len(buf) < size:
                return
            payload = bytes(buf[up.HEADER.size:size])
            del buf[:size]
            self._rtde_package(conn, ptype, payload)
            if self.rtde is not conn:
                return

    def _rtde_package(self, conn: _Conn, ptype: int, payload: bytes) -> None:
        c = self.counters
        if ptype == up.REQUEST_PROTOCOL_VERSION:
            if len(payload) != 2:
                c["rx_bad_size"] += 1
                return
            ok = int.from_bytes(payload, "big") == up.RTDE_PROTOCOL_VERSION
            if not ok:
                c["rx_bad_version"] += 1
            self._send(conn, up.package(ptype, bytes([ok])))
        elif ptype == up.GET_URCONTROL_VERSION:
            self._send(conn, up.package(ptype, b"".join(v.to_bytes(4, "big") for v in up.URCONTROL_VERSION)))
        elif ptype == up.SETUP_OUTPUTS:
            if len(payload) < 9:
                c["rx_bad_size"] += 1
                return
            freq = float(np.frombuffer(payload[:8], dtype=">f8")[0])
            names = [n.strip() for n in payload[8:].decode(errors="replace").split(",")]
            types = [up.FIELDS[n][0] if n in up.FIELDS else "NOT_FOUND" for n in names]
            if "NOT_FOUND" in types or not 0 < freq <= up.CONTROL_HZ or self.streaming:
                c["rejected_recipes"] += 1
                reason = ("stop streaming (PAUSE) before a new recipe" if self.streaming else
                          f"frequency {freq} Hz must be in (0, {up.CONTROL_HZ}]" if not 0 < freq <= up.CONTROL_HZ
                          else f"unknown fields {[n for n, t in zip(names, types) if t == 'NOT_FOUND']}")
                self._send(conn, up.package(up.TEXT_MESSAGE, reason.encode()))
                self._send(conn, up.package(ptype, b"\x00" + ",".join(types).encode()))
                return
            self.recipe = names
            self.recipe_struct = up.recipe_struct(names)
            self.divisor = max(1, round(up.CONTROL_HZ / freq))
            self._send(conn, up.package(ptype, b"\x01" + ",".join(types).encode()))
        elif ptype == up.START:
            ok = self.recipe is not None
            self.streaming = ok
            self._send(conn, up.package(ptype, bytes([ok])))
        elif ptype == up.PAUSE:
            self.streaming = False
            self._send(conn, up.package(ptype, b"\x01"))
        else:
            c["rx_bad_type"] += 1

    def _data_package(self) -> bytes:
        arm = self.arm
        values = {"timestamp": ((time.monotonic_ns() - self.t0_ns) * 1e-9,), "target_q": self.ref,
                  "actual_q": arm.q, "actual_qd": arm.dq, "target_qd": self.ref_qd,
                  "actual_joint_torques": arm.tau, "robot_mode": (up.ROBOT_MODE_RUNNING,),
                  "runtime_state": (up.RUNTIME_PLAYING if self.playing else up.RUNTIME_STOPPED,),
                  "speed_scaling": (1.0,)}
        flat = [v for n in self.recipe for v in values[n]]
        return up.package(up.DATA_PACKAGE, self.recipe_struct.pack(1, *flat))

    # --- script ------------------------------------------------------------------------------------
    def _parse_script(self, conn: _Conn) -> None:
        while b"\n" in conn.inbuf:
            i = conn.inbuf.index(b"\n")
            line = bytes(conn.inbuf[:i]).decode(errors="replace")
            del conn.inbuf[:i + 1]
            self._script_line(conn, line)
        if len(conn.inbuf) > 4096:      # no newline in 4 kB: not our protocol
            self.counters["rx_bad_line"] += 1
            conn.inbuf.clear()

    def _script_line(self, conn: _Conn, line: str) -> None:
        c = self.counters
        m = up.SERVOJ_RE.fullmatch(line)
        if m:
            try:
                nums = [float(x) for x in m.groups()]
            except ValueError:
                c["rx_bad_line"] += 1
                return
            q, t, lookahead, gain = np.array(nums[:6]), nums[8], nums[9], nums[10]
            if (not np.all(np.isfinite(q)) or not up.SERVOJ_T[0] <= t <= up.SERVOJ_T[1]
                    or not up.LOOKAHEAD[0] <= lookahead <= up.LOOKAHEAD[1] or not up.GAIN[0] <= gain <= up.GAIN[1]):
                c["rx_out_of_range"] += 1
                return
            self.interp_start[:] = self.interp
            self.target[:] = np.clip(q, self.arm.limits_low, self.arm.limits_high)
            self.servo_t, self.lookahead = t, lookahead
            self.t_cmd_ns = time.monotonic_ns()
            self.last_line_ns = self.t_cmd_ns
            if not self.playing:
                c["programs_started"] += 1
            self.playing = True
            c["servoj"] += 1
            return
        if up.STOPJ_RE.fullmatch(line):
            self._stop()
            c["stopj"] += 1
            return
        if line.strip() == "stats()":
            self._send(conn, json.dumps(self.stats()).encode() + b"\n")
            return
        c["rx_bad_line"] += 1

    def _stop(self) -> None:
        """Stop the servo program: the reference stops where it is, the arm settles there."""
        self.playing = False
        self.target[:] = self.ref
        self.interp[:] = self.ref
        self.interp_start[:] = self.ref

    # --- the 500 Hz tick ---------------------------------------------------------------------------
    def tick(self) -> None:
        now = time.monotonic_ns()
        if self.playing and now - self.last_line_ns > self.keepalive_ns:
            self.counters["keepalive_lapsed"] += 1
            self._stop()
        if self.playing:
            frac = min(1.0, (now - self.t_cmd_ns) * 1e-9 / self.servo_t)
            self.interp[:] = self.interp_start + (self.target - self.interp_start) * frac
            alpha = min(1.0, self.dt / self.lookahead)
        else:
            alpha = 1.0
        step = np.clip((self.interp - self.ref) * alpha, -self.arm.velocity_limits * self.dt,
                       self.arm.velocity_limits * self.dt)
        self.ref += step
        self.ref_qd[:] = step / self.dt
        self.arm.cmd[:] = self.ref
        self.arm.step(2)
        self.tick_count += 1
        if self.streaming and self.rtde is not None and self.tick_count % self.divisor == 0:
            self._send(self.rtde, self._data_package())
            self.counters["packages_sent"] += 1

    def stats(self) -> dict:
        return {"ticks": self.tick_count, "playing": self.playing, "streaming": self.streaming,
                "recipe": self.recipe, **self.counters}
