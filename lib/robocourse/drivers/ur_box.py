"""The UR-style controller box: RTDE (30004), the dashboard (29999) and the script ports (30001-30003).

Counterpart: a UR e-Series controller as ur_rtde 1.6.5 and ur_robot_driver reach it over the
network, so ``rtde_receive``, ``rtde_control``, ``rtde_io`` and ``dashboard_client`` from PyPI
drive it unchanged. It binds UR's fixed port numbers on a loopback address of its own
(127.0.0.x, :mod:`robocourse.drivers.loopback`), runs the controller's 500 Hz cycle
(:class:`robocourse.drivers.ur_controller.URController` around the UR5e arm in MuJoCo) and
serves every connection between ticks. Runs in its own process
(:func:`robocourse.drivers.start_ur_box`).

- **RTDE** (:mod:`robocourse.drivers.rtde`): any number of clients, each with its own protocol
  state, one output recipe streamed at 500 Hz / an integer divisor of it (the frequency asked
  for, rounded to the nearest divisor; 0 or above 500 Hz refused: the reply's recipe id is 0
  and START then fails), and input recipes numbered 1, 2, 3... per connection. An input
  variable belongs to the connection whose recipe named it first: another connection's recipe
  naming it gets ``IN_USE`` (ur_rtde then raises "One of the RTDE input registers are already
  in use!"), until the owner disconnects. Text messages (a refused program, a program stopped,
  the watchdog) go to every streaming client as 'M' packages, never during a handshake.
  Malformed packages (a size below the header, an unknown type, a wrong version, a data package
  for an unknown recipe or of the wrong length) are counted (``rx_bad_*``) and dropped; the
  connection and every other client carry on.
- **Dashboard** (:mod:`robocourse.drivers.ur_dashboard`).
- **Script ports** 30001, 30002, 30003: a complete program is handed to the controller, which
  runs ur_rtde's control script and refuses anything else (:mod:`robocourse.drivers.ur_script`).
  The primary/secondary state streams of 30001/30002 are not sent.

A client that dies does not keep the robot: TCP closes its connections, the box releases its
inputs; a control script keeps running with its last command (as on a real UR), which the RTDE
watchdog stops if the client had set it.
"""

from __future__ import annotations

import json
import socket
import struct
import time

import numpy as np

from . import rtde
from . import ur_dashboard as dash
from .ticker import TickingBox
from .ur_controller import CONTROLLER_VERSION, URController
from .ur_script import program_complete

RTDE_PORT, DASHBOARD_PORT, PRIMARY_PORT, SECONDARY_PORT, REALTIME_PORT = 30004, 29999, 30001, 30002, 30003
PORTS = {"rtde": RTDE_PORT, "dashboard": DASHBOARD_PORT, "primary": PRIMARY_PORT, "secondary": SECONDARY_PORT,
         "realtime": REALTIME_PORT}
CONTROL_HZ = 500
MAX_OUT = 1 << 18          # bytes queued for a client that does not read before packages are dropped
MAX_SCRIPT = 1 << 20       # a program larger than this is refused
MAX_LINE = 4096            # a dashboard line longer than this is refused
TRACE_S = 10.0             # seconds of the arm's trajectory the box keeps for `robocourse trace`


class _Conn:
    __slots__ = ("sock", "kind", "id", "inbuf", "outbuf", "out_names", "out_getters", "out_struct", "divisor",
                 "streaming", "in_recipes", "started")

    def __init__(self, sock, kind: str, cid: int):
        self.sock = sock
        self.kind = kind
        self.id = cid
        self.inbuf = bytearray()
        self.outbuf = bytearray()
        self.out_names: list[str] | None = None
        self.out_getters = None
        self.out_struct = None
        self.divisor = 1
        self.streaming = False
        self.started = False
        self.in_recipes: list[tuple[list[str], struct.Struct]] = []


class URBox(TickingBox):
    """One simulated UR e-Series controller (see the module docstring)."""

    period_ns = 1_000_000_000 // CONTROL_HZ

    def __init__(self, listeners: dict[str, socket.socket], host: str, *, initial_positions=None,
                 physics: bool = True, powered: bool = True, unlock_delay: float | None = None):
        super().__init__()
        from .arm import BoxArm, NullArm

        self.host = host
        self.listeners = listeners
        self._kind_of = {s: k for k, s in listeners.items()}
        if physics:
            from robocourse.sim.robots.kinematics import Kinematics

            arm, kin = BoxArm(timestep=0.001, initial_positions=initial_positions), Kinematics("ur5e", "tool0")
        else:
            arm, kin = NullArm(initial_positions=initial_positions), None
        kw = {} if unlock_delay is None else {"unlock_delay": unlock_delay}
        self.ctrl = URController(arm, 1.0 / CONTROL_HZ, powered=powered, kinematics=kin, **kw)
        self.getters = self.ctrl.outputs()
        self.conns: dict[socket.socket, _Conn] = {}
        self.owner: dict[str, int] = {}          # input variable -> connection id
        self._next_id = 1
        self.tick_count = 0
        # the last TRACE_S of (CLOCK_MONOTONIC time, actual_q, target_q, runtime_state, the servoj target last
        # received and its (t, lookahead_time), zeros outside servo mode): `robocourse trace`
        n = int(TRACE_S * CONTROL_HZ)
        self.trace_t, self.trace_q = np.full(n, np.nan), np.zeros((n, 6))
        self.trace_target, self.trace_state = np.zeros((n, 6)), np.zeros(n, dtype=np.int8)
        self.trace_sent, self.trace_servo = np.zeros((n, 6)), np.zeros((n, 2))

    def sockets(self) -> list:
        return [*self.listeners.values(), *self.conns]

    # --- connections -----------------------------------------------------------------------------
    def on_readable(self, sock) -> None:
        kind = self._kind_of.get(sock)
        if kind is not None:
            try:
                conn, _ = sock.accept()
            except (BlockingIOError, InterruptedError):
                return
            conn.setblocking(False)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            c = _Conn(conn, kind, self._next_id)
            self._next_id += 1
            self.conns[conn] = c
            self.counters[f"connects_{kind}"] += 1
            if kind == "dashboard":
                self._send(c, (dash.WELCOME + "\n").encode())
            return
        c = self.conns.get(sock)
        if c is None:
            return
        try:
            data = sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._close(c)
            return
        c.inbuf += data
        if c.kind == "rtde":
            self._parse_rtde(c)
        elif c.kind == "dashboard":
            self._parse_dashboard(c)
        else:
            self._parse_script(c)

    def _close(self, c: _Conn) -> None:
        if self.conns.pop(c.sock, None) is None:
            return
        c.sock.close()
        for name in [n for n, o in self.owner.items() if o == c.id]:
            del self.owner[name]
        self.counters[f"disconnects_{c.kind}"] += 1

    def _send(self, c: _Conn, data: bytes) -> None:
        if len(c.outbuf) > MAX_OUT:
            self.counters["tx_dropped"] += 1      # the client does not read: drop, never block the cycle
            return
        c.outbuf += data
        try:
            sent = c.sock.send(c.outbuf)
            del c.outbuf[:sent]
        except (BlockingIOError, InterruptedError):
            pass
        except OSError:
            self._close(c)

    # --- RTDE --------------------------------------------------------------------------------------
    def _parse_rtde(self, c: _Conn) -> None:
        buf = c.inbuf
        while len(buf) >= rtde.HEADER.size:
            size, ptype = rtde.HEADER.unpack_from(buf)
            if size < rtde.HEADER.size:          # no way to find the next package boundary: drop what we have
                self.counters["rx_bad_size"] += 1
                buf.clear()
                return
            if len(buf) < size:
                return
            payload = bytes(buf[rtde.HEADER.size:size])
            del buf[:size]
            self._rtde_package(c, ptype, payload)
            if c.sock not in self.conns:
                return

    def _reply(self, c: _Conn, ptype: int, payload: bytes) -> None:
        self._send(c, rtde.package(ptype, payload))

    def _rtde_package(self, c: _Conn, ptype: int, payload: bytes) -> None:
        cnt = self.counters
        if ptype == rtde.DATA_PACKAGE:
            if not payload:
                cnt["rx_bad_size"] += 1
                return
            rid = payload[0]
            if not 1 <= rid <= len(c.in_recipes):
                cnt["rx_bad_recipe"] += 1
                return
            names, st = c.in_recipes[rid - 1]
            if len(payload) != st.size:
                cnt["rx_bad_size"] += 1
                return
            values = st.unpack(payload)[1:]
            self.ctrl.apply_inputs(names, self._group(names, values))
            cnt["rx_data"] += 1
        elif ptype == rtde.REQUEST_PROTOCOL_VERSION:
            if len(payload) != 2:
                cnt["rx_bad_size"] += 1
                return
            ok = int.from_bytes(payload, "big") == rtde.PROTOCOL_VERSION
            if not ok:
                cnt["rx_bad_version"] += 1
            self._reply(c, ptype, bytes([ok]))
        elif ptype == rtde.GET_URCONTROL_VERSION:
            self._reply(c, ptype, struct.pack(">4I", *CONTROLLER_VERSION))
        elif ptype == rtde.SETUP_OUTPUTS:
            self._setup_outputs(c, payload)
        elif ptype == rtde.SETUP_INPUTS:
            self._setup_inputs(c, payload)
        elif ptype == rtde.START:
            ok = c.out_names is not None or bool(c.in_recipes)
            c.started = ok
            c.streaming = ok and c.out_names is not None
            if not ok:
                cnt["rejected_starts"] += 1
            self._reply(c, ptype, bytes([ok]))
        elif ptype == rtde.PAUSE:
            c.streaming = c.started = False
            self._reply(c, ptype, b"\x01")
        else:
            cnt["rx_bad_type"] += 1

    @staticmethod
    def _group(names, flat):
        """Flat struct values -> one value (or tuple) per name (vector inputs: external_force_torque)."""
        if len(flat) == len(names):
            return flat
        out, i = [], 0
        for n in names:
            k = rtde.TYPES[rtde.INPUTS[n]][1]
            out.append(flat[i] if k == 1 else flat[i:i + k])
            i += k
        return out

    def _setup_outputs(self, c: _Conn, payload: bytes) -> None:
        if len(payload) < 8:
            self.counters["rx_bad_size"] += 1
            return
        freq = struct.unpack(">d", payload[:8])[0]
        names = rtde.split_names(payload[8:])
        types = [rtde.OUTPUTS.get(n, rtde.NOT_FOUND) for n in names]
        ok = bool(names) and rtde.NOT_FOUND not in types and 0 < freq <= CONTROL_HZ and not c.streaming
        if ok:
            c.out_names = names
            c.out_getters = [self.getters[n] for n in names]
            c.out_struct = rtde.recipe_struct(types)
            c.divisor = max(1, round(CONTROL_HZ / freq))
        else:
            self.counters["rejected_recipes"] += 1
        self._reply(c, rtde.SETUP_OUTPUTS, bytes([1 if ok else 0]) + ",".join(types).encode())

    def _setup_inputs(self, c: _Conn, payload: bytes) -> None:
        names = rtde.split_names(payload)
        types = []
        for n in names:
            if n not in rtde.INPUTS:
                types.append(rtde.NOT_FOUND)
            elif self.owner.get(n, c.id) != c.id:
                types.append(rtde.IN_USE)
            else:
                types.append(rtde.INPUTS[n])
        ok = bool(names) and rtde.NOT_FOUND not in types and rtde.IN_USE not in types and len(c.in_recipes) < 255
        rid = 0
        if ok:
            c.in_recipes.append((names, rtde.recipe_struct(types)))
            rid = len(c.in_recipes)
            for n in names:
                self.owner[n] = c.id
        else:
            self.counters["rejected_recipes"] += 1
        self._reply(c, rtde.SETUP_INPUTS, bytes([rid]) + ",".join(types).encode())

    def _data_package(self, c: _Conn) -> bytes:
        flat = [v for g in c.out_getters for v in g()]
        return rtde.package(rtde.DATA_PACKAGE, c.out_struct.pack(1, *flat))

    # --- dashboard ---------------------------------------------------------------------------------
    def _parse_dashboard(self, c: _Conn) -> None:
        while b"\n" in c.inbuf:
            i = c.inbuf.index(b"\n")
            line = bytes(c.inbuf[:i]).decode(errors="replace").rstrip("\r")
            del c.inbuf[:i + 1]
            reply, action = dash.answer(self.ctrl, line)
            self.counters["dashboard_commands"] += 1
            if action == "stats":
                reply = json.dumps(self.stats())
            elif action == "trace":
                reply = json.dumps(self.trace())
            self._send(c, (reply + "\n").encode())
            if action == "quit":
                self._close(c)
                return
            if action == "shutdown":
                self.running = False
                return
        if len(c.inbuf) > MAX_LINE:
            self.counters["rx_bad_line"] += 1
            c.inbuf.clear()
            self._send(c, b"could not understand: a line longer than 4096 bytes\n")

    # --- script ports ------------------------------------------------------------------------------
    def _parse_script(self, c: _Conn) -> None:
        if len(c.inbuf) > MAX_SCRIPT:
            self.counters["scripts_refused"] += 1
            self.ctrl.message(f"script refused: more than {MAX_SCRIPT} bytes without a complete program")
            c.inbuf.clear()
            return
        text = c.inbuf.decode(errors="replace")
        if program_complete(text):
            c.inbuf.clear()
            self.ctrl.upload(text)

    # --- the 500 Hz tick ---------------------------------------------------------------------------
    def tick(self) -> None:
        ctrl = self.ctrl
        ctrl.tick()
        i = self.tick_count % self.trace_t.shape[0]
        self.trace_t[i] = time.monotonic()
        self.trace_q[i] = ctrl.arm.q
        self.trace_target[i] = ctrl.motion.q
        self.trace_state[i] = ctrl.runtime_state
        m = ctrl.motion
        if m.mode == "servo":
            self.trace_sent[i] = m.target
            self.trace_servo[i] = (m.servo_t, m.lookahead)
        else:
            self.trace_sent[i] = 0.0
            self.trace_servo[i] = 0.0
        self.tick_count += 1
        msgs = ctrl.messages
        if msgs:
            packed = b"".join(rtde.text_message(t, "robocourse", lvl) for t, lvl in msgs)
            msgs.clear()
        else:
            packed = b""
        for c in list(self.conns.values()):
            if c.streaming and c.kind == "rtde":
                if packed:
                    self._send(c, packed)
                if self.tick_count % c.divisor == 0:
                    self._send(c, self._data_package(c))
                    self.counters["packages_sent"] += 1

    def trace(self) -> dict:
        """The kept trajectory in time order: t (CLOCK_MONOTONIC s, comparable with the clients' time.monotonic()
        on this machine), actual q, target q (rad), runtime_state per tick; in servo mode also the servoj
        target last received (``sent``, rad) and its ``servo`` (t, lookahead_time) s (zeros otherwise)."""
        order = np.argsort(self.trace_t)
        keep = order[np.isfinite(self.trace_t[order])]
        return {"t": self.trace_t[keep].tolist(), "q": self.trace_q[keep].tolist(),
                "target": self.trace_target[keep].tolist(), "runtime_state": self.trace_state[keep].tolist(),
                "sent": self.trace_sent[keep].tolist(), "servo": self.trace_servo[keep].tolist()}

    def stats(self) -> dict:
        rtde_conns = [c for c in self.conns.values() if c.kind == "rtde"]
        return {"host": self.host, "ticks": self.tick_count, "box_overruns": self.counters["box_overruns"],
                "rtde_clients": len(rtde_conns), "streaming": sum(c.streaming for c in rtde_conns),
                "target_q": [float(x) for x in self.ctrl.motion.q], "actual_q": [float(x) for x in self.ctrl.arm.q],
                **self.ctrl.stats(), **{k: v for k, v in self.counters.items() if k != "box_overruns"}}


def open_listeners(host: str | None) -> tuple[str, dict[str, socket.socket]]:
    """Bind UR's five ports on ``host``, or on a free 127.0.0.x when ``host`` is None."""
    from .loopback import bind_all, bind_free_loopback

    spec = [(p, socket.SOCK_STREAM) for p in PORTS.values()]
    if host is None:
        host, socks = bind_free_loopback(spec)
    else:
        socks = bind_all(host, spec)
    return host, dict(zip(PORTS, socks))


def _ask_json(host: str, command: bytes, timeout: float) -> dict:
    with socket.create_connection((host, DASHBOARD_PORT), timeout=timeout) as s:
        f = s.makefile("rb")
        f.readline()                                  # welcome
        s.sendall(command + b"\n")
        line = f.readline()
    if not line:
        raise ConnectionError(f"the UR-style box at {host} closed the dashboard connection")
    return json.loads(line)


def read_stats(host: str, timeout: float = 2.0) -> dict:
    """The box's counters, asked on the dashboard port (``robocourse stats``)."""
    return _ask_json(host, b"robocourse stats", timeout)


def read_trace(host: str, timeout: float = 5.0) -> dict:
    """The box's last seconds of trajectory (``robocourse trace``, see :meth:`URBox.trace`)."""
    return _ask_json(host, b"robocourse trace", timeout)


__all__ = ["PORTS", "URBox", "open_listeners", "read_stats", "read_trace"]
