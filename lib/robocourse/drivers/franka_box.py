"""The Franka-style controller box: a 1 kHz UDP state/command loop around the simulated arm.

Counterpart: the Franka robot's controller (the "Control" box) as libfranka sees it through
the research interface: one state every millisecond, one command back per state, a
communication reflex when too many are missing, automatic error recovery. Protocol:
:mod:`robocourse.drivers.franka_protocol`. Runs in its own process
(:func:`robocourse.drivers.start_franka_box`), never in the student's.

Each tick (absolute deadlines, ``period_us`` apart): apply the command that answered the
previous state (or count a missed tick), step the physics one period, send the new state; in
between, receive datagrams until the next deadline.

One client at a time, and a client that dies does not keep the robot. The real robot holds
libfranka's connection on TCP (port 1337): when the client process dies the kernel closes that
connection, the robot aborts a running motion with a communication reflex
(``communication_constraints_violation``), and the next ``franka::Robot(...)`` connects and has
to call ``automaticErrorRecovery()`` before it moves. Our protocol is UDP only, so the box
cannot see a process die; it sees silence. The rule here: the client *holds the slot* while it
has sent any datagram within the last ``client_timeout`` ticks (default 100, i.e. 0.1 s at
1 kHz). A CONNECT from another address is refused ("busy") while the slot is held and
accepted once the holder has been silent longer (``released_silent_clients`` counts these);
if the robot was moving then, that is the communication reflex, exactly as a lost TCP
connection is on the real robot: the new client recovers, then moves. Where we differ: the
release happens when a new client asks (lazily), not on a connection drop, and a live client
that stays silent (reads states, sends nothing) for longer than ``client_timeout`` can lose
its slot to a newcomer (its later commands count as ``rx_foreign``, its reads time out).

A repeated CONNECT from the client that holds the slot (its ACK was lost: this is UDP) is
acknowledged again and changes nothing (``repeated_connects``); a second client object in the
same process has its own socket, hence its own address, and is refused like any other.
"""

from __future__ import annotations

import collections
import json
import socket
import time

import numpy as np

from . import franka_protocol as fp
from .arm import BoxArm, NullArm
from .ticker import TickingBox

_RING = 1 << 15
#: round-trip histogram bin edges in us, log-spaced 10 us .. 100 ms (sent with the stats: the
#: raw ring does not fit in one datagram)
RTT_HIST_EDGES_US = tuple(float(x) for x in np.geomspace(10.0, 100_000.0, 49))


class FrankaBox(TickingBox):
    def __init__(self, port: int = 0, host: str = "127.0.0.1", period_us: int = 1000, max_missed: int = fp.DEFAULT_MAX_MISSED,
                 initial_positions=None, physics: bool = True, client_timeout: int = 100):
        super().__init__()
        if not isinstance(client_timeout, int) or client_timeout < 1:
            raise ValueError(f"client_timeout={client_timeout!r} must be a whole number of ticks >= 1 "
                             "(silence after which another client may take the slot), e.g. 100")
        self.client_timeout = client_timeout
        self.arm = (BoxArm if physics else NullArm)(timestep=period_us * 1e-6, initial_positions=initial_positions)
        self.n = self.arm.n
        self.period_ns = int(period_us) * 1000
        self.period_us = int(period_us)
        self.max_missed = int(max_missed)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((host, port))   # OSError "Address already in use" reaches main()
        self.sock.setblocking(False)
        self.port = self.sock.getsockname()[1]
        self.client = None
        self.client_heard_seq = 0       # self.seq when the client last sent anything
        self.seq = 0
        self.robot_mode = fp.ROBOT_IDLE
        self.errors = 0
        self.cmd_mode = fp.MODE_POSITION
        self.pending = None             # (mode, finished, values) answering self.seq
        self.window = collections.deque(maxlen=fp.SUCCESS_WINDOW)
        self.missed_in_row = 0
        self._sst = fp.state_struct(self.n)
        self._cst = fp.command_struct(self.n)
        self._buf = bytearray(65536)
        self._out = bytearray(fp.HEADER.size + self._sst.size)
        self._values = np.zeros(4 * self.n + 1)
        self._sent_ns = np.zeros(_RING, dtype=np.int64)    # send time of state seq, at seq % _RING
        self.rtt_ns = np.zeros(_RING, dtype=np.int64)      # round trips of the last _RING commands
        self.rtt_count = 0
        self.max_missed_in_row = 0

    # --- receiving ---------------------------------------------------------------------------------
    def _send(self, data: bytes, addr) -> None:
        try:
            self.sock.sendto(data, addr)
        except OSError:
            self.counters["tx_errors"] += 1

    def handle(self, data: bytes, addr) -> None:
        c = self.counters
        if len(data) < fp.HEADER.size:
            c["rx_short"] += 1
            return
        magic, version, mtype, n, seq = fp.HEADER.unpack_from(data)
        if magic != fp.MAGIC:
            c["rx_bad_magic"] += 1
            return
        if version != fp.VERSION:
            c["rx_bad_version"] += 1
            return
        if addr == self.client:
            self.client_heard_seq = self.seq
        if mtype == fp.CONNECT:
            if self.client is not None and addr != self.client:
                silent = self.seq - self.client_heard_seq
                if silent <= self.client_timeout:
                    c["rejected_connects"] += 1
                    self._send(fp.header(fp.CONNECT_REJECT) + (
                        f"busy: another client ({self.client[0]}:{self.client[1]}) is connected and was heard "
                        f"{silent} ticks ago; disconnect it first, or connect again once it has been silent "
                        f"for more than {self.client_timeout} ticks").encode(), addr)
                    return
                self._release_silent_client()
            if addr == self.client:
                c["repeated_connects"] += 1
            else:
                c["connects"] += 1
            self.client = addr
            self.client_heard_seq = self.seq
            self._send(fp.header(fp.CONNECT_ACK, self.n, self.seq) + fp.ACK.pack(self.period_us, self.max_missed), addr)
            return
        if mtype == fp.STATS:
            self._send(fp.header(fp.STATS) + json.dumps(self.stats()).encode(), addr)
            return
        if addr != self.client:
            c["rx_foreign"] += 1
            return
        if mtype == fp.COMMAND:
            if n != self.n or len(data) != fp.HEADER.size + self._cst.size:
                c["rx_bad_length"] += 1
                return
            if self.robot_mode == fp.ROBOT_REFLEX:
                c["ignored_in_reflex"] += 1
                return
            if seq > self.seq:
                c["rx_bad_seq"] += 1
                return
            if self.seq - seq < _RING:   # the round trip of every answered state, late ones included
                self.rtt_ns[self.rtt_count % _RING] = time.monotonic_ns() - self._sent_ns[seq % _RING]
                self.rtt_count += 1
            if seq < self.seq:
                c["late"] += 1
                return
            mode, finished, *values = self._cst.unpack_from(data, fp.HEADER.size)
            if mode not in fp.MODE_NAMES:
                c["rx_bad_mode"] += 1
                return
            if self.pending is not None:
                c["duplicates"] += 1
            self.pending = (mode, finished, values)
        elif mtype == fp.RECOVER:
            if self.robot_mode == fp.ROBOT_REFLEX:
                self.robot_mode = fp.ROBOT_IDLE
                self.errors = 0
                self.missed_in_row = 0
                self.window.clear()
                c["recoveries"] += 1
            self._send(fp.header(fp.RECOVER_ACK, 0, self.seq) + fp.RECOVER_REPLY.pack(self.errors), addr)
        elif mtype == fp.DISCONNECT:
            self.client = None
            if self.robot_mode == fp.ROBOT_MOVE:
                self.robot_mode = fp.ROBOT_IDLE
                self.arm.hold()
            c["disconnects"] += 1
        else:
            c["rx_bad_type"] += 1

    def _release_silent_client(self) -> None:
        """The holder went silent (a dead process, as far as UDP can tell): free the slot; a
        motion in progress ends in the communication reflex, as a dropped connection does."""
        self.counters["released_silent_clients"] += 1
        self.client = None
        self.pending = None
        if self.robot_mode == fp.ROBOT_MOVE:
            self._reflex()

    def _reflex(self) -> None:
        self.robot_mode = fp.ROBOT_REFLEX
        self.errors |= fp.ERR_COMMUNICATION_CONSTRAINTS_VIOLATION
        self.counters["reflexes"] += 1
        self.arm.hold()

    def sockets(self) -> list:
        return [self.sock]

    def on_readable(self, sock) -> None:
        self.drain()

    def drain(self) -> None:
        while True:
            try:
                nbytes, addr = self.sock.recvfrom_into(self._buf)
            except BlockingIOError:
                return
            except OSError:
                self.counters["rx_errors"] += 1
                return
            self.handle(bytes(self._buf[:nbytes]), addr)

    # --- the tick ----------------------------------------------------------------------------------
    def tick(self) -> None:
        arm, c = self.arm, self.counters
        if self.robot_mode == fp.ROBOT_IDLE and self.pending is not None:
            self.robot_mode = fp.ROBOT_MOVE
            c["motions"] += 1
        if self.robot_mode == fp.ROBOT_MOVE:
            c["ticks_moving"] += 1
            if self.pending is None:
                c["missed"] += 1
                self.missed_in_row += 1
                self.max_missed_in_row = max(self.max_missed_in_row, self.missed_in_row)
                self.window.append(0)
                if self.missed_in_row > self.max_missed:
                    self._reflex()
            else:
                mode, finished, values = self.pending
                c["commands_ok"] += 1
                self.missed_in_row = 0
                self.window.append(1)
                if mode == fp.MODE_POSITION:
                    arm.set_mode("position")
                    np.clip(values, arm.limits_low, arm.limits_high, out=arm.cmd)
                else:
                    arm.set_mode("effort")
                    arm.cmd[:] = np.asarray(values) + arm.gravity()
                if finished:
                    self.robot_mode = fp.ROBOT_IDLE
                    arm.hold()
        self.pending = None
        try:
            arm.step(1)
        except ValueError:              # a non-finite command: reflex-like hold
            c["rejected_nonfinite"] += 1
            arm.hold()
            arm.step(1)
        self.seq += 1
        if self.client is not None:
            v = self._values
            n = self.n
            v[0:n] = arm.q
            v[n:2 * n] = arm.dq
            v[2 * n:3 * n] = arm.tau
            v[3 * n:4 * n] = arm.estimate_external_torque()
            v[4 * n] = (sum(self.window) / len(self.window)) if self.window else 1.0
            fp.HEADER.pack_into(self._out, 0, fp.MAGIC, fp.VERSION, fp.STATE, n, self.seq)
            self._sst.pack_into(self._out, fp.HEADER.size, *v, self.robot_mode, self.errors)
            self._sent_ns[self.seq % _RING] = time.monotonic_ns()
            self._send(self._out, self.client)
            c["states_sent"] += 1

    def stats(self) -> dict:
        k = min(self.rtt_count, _RING)
        rtt = np.sort(self.rtt_ns[:k]) / 1e3 if k else None
        rtt_us = ({"rtt_n": k, "rtt_p50_us": float(rtt[k // 2]), "rtt_p99_us": float(rtt[min(k - 1, int(0.99 * k))]),
                   "rtt_max_us": float(rtt[-1]),
                   "rtt_hist_counts": np.histogram(np.clip(rtt, RTT_HIST_EDGES_US[0], RTT_HIST_EDGES_US[-1]),
                                                   RTT_HIST_EDGES_US)[0].tolist()} if k else {"rtt_n": 0})
        return {**rtt_us, "max_missed_in_row": self.max_missed_in_row, "seq": self.seq, "robot_mode": fp.ROBOT_MODE_NAMES[self.robot_mode],
                "errors": fp.error_names(self.errors), "missed_in_row": self.missed_in_row,
                "success_rate": (sum(self.window) / len(self.window)) if self.window else 1.0,
                "client": list(self.client) if self.client else None, **self.counters}
