"""A chain of simulated slaves that an EtherCAT frame passes through, on the fly.

The counterpart of a real line topology: the frame enters slave 1 at port 0, each ESC reads
and writes its part of every datagram as the frame passes (auto-increment ADP counting, OR on
broadcast reads, FMMU logical mapping, working-counter increments), forwards it on port 1, and
the last slave (port 1 closed) sends it back through all of them to the master. Each slave adds
its own forwarding delay (``forward_ns`` through the processing unit, ``return_ns`` back), so
the DC port receive times differ by something real.

Faults a test or notebook can inject: a cable cut after slave k (``cut_after``), lost frames
(``lose_frames``), a bit error on the link into slave k (``corrupt``: the ESC counts it in
its RX error counter 0x0300 and the frame is destroyed, as a failed FCS), a slave dropping to
SAFE_OP with an AL status code (``slave_error``), and the SM watchdog (let simulated time pass
without process data). Every dropped frame is counted with its reason in ``dropped``.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence

from .esc import Esc
from .frames import (
    MIN_FRAME_LEN,
    SLAVE_SOURCE_BIT,
    Command,
    FrameError,
    decode_frame,
    encode_frame,
)
from .pcap import PcapWriter

# command kind: 0 nop, 1 auto-increment, 2 configured, 3 broadcast, 4 logical, 5 ARMW, 6 FRMW
_KIND = {Command.NOP: 0, Command.APRD: 1, Command.APWR: 1, Command.APRW: 1, Command.FPRD: 2,
         Command.FPWR: 2, Command.FPRW: 2, Command.BRD: 3, Command.BWR: 3, Command.BRW: 3,
         Command.LRD: 4, Command.LWR: 4, Command.LRW: 4, Command.ARMW: 5, Command.FRMW: 6}
# read/write flags of each command (1 read, 2 write)
_RW = {Command.NOP: 0, Command.APRD: 1, Command.APWR: 2, Command.APRW: 3, Command.FPRD: 1,
       Command.FPWR: 2, Command.FPRW: 3, Command.BRD: 1, Command.BWR: 2, Command.BRW: 3,
       Command.LRD: 1, Command.LWR: 2, Command.LRW: 3, Command.ARMW: 0, Command.FRMW: 0}
WIRE_NS_PER_BYTE = 80  # 100 Mbit/s: 8 bits x 10 ns
WIRE_OVERHEAD_BYTES = 24  # preamble + SFD (8), FCS (4), inter-frame gap (12)


def frame_size(frame) -> int:
    """Bytes of ``frame`` on the wire without FCS (before padding)."""
    return 16 + sum(12 + len(d.data) for d in frame.datagrams)


def wire_time_ns(frame_len: int) -> int:
    """Time one frame of ``frame_len`` bytes (no FCS) occupies a 100 Mbit/s line."""
    return (max(frame_len, MIN_FRAME_LEN) + WIRE_OVERHEAD_BYTES) * WIRE_NS_PER_BYTE


class Bus:
    """Slaves in a line; ``process(frame)`` returns the reply the master would receive."""

    def __init__(self, slaves: Sequence[Esc], *, clock: Callable[[], int] = time.monotonic_ns,
                 forward_ns: Sequence[float] | float = 500.0,
                 return_ns: Sequence[float] | float = 500.0,
                 capture: PcapWriter | None = None) -> None:
        if not slaves:
            raise ValueError("a bus needs at least one slave, e.g. Bus([DigitalInputs()])")
        self.slaves = list(slaves)
        n = len(self.slaves)
        self.forward_ns = tuple(self._per_slave(forward_ns, n, "forward_ns"))  # fixed: the
        self.return_ns = tuple(self._per_slave(return_ns, n, "return_ns"))  # timing is cached
        self.clock = clock
        self.capture = capture
        self.connected = n
        self.frames = 0
        self.dropped: Counter[str] = Counter()
        self.last_error: str | None = None
        self._lose = 0
        self._corrupt: list[int] = []
        self._wire_free = 0.0
        self._link_up(n)

    @staticmethod
    def _per_slave(v, n: int, what: str) -> list[float]:
        vals = [float(v)] * n if isinstance(v, (int, float)) else [float(x) for x in v]
        if len(vals) != n or any(x < 0 for x in vals):
            raise ValueError(f"{what} must be one non-negative delay or one per slave ({n}); got {v!r}")
        return vals

    # ---- faults -------------------------------------------------------------------------
    def cut_after(self, k: int) -> None:
        """Cut the cable after slave ``k`` (1-based): slaves k+1.. no longer see frames."""
        if not 0 <= k <= len(self.slaves):
            raise ValueError(f"cut_after({k}): k must be 0..{len(self.slaves)} (slave positions)")
        self._link_up(k)

    def reconnect(self) -> None:
        """Mend every cable: all slaves see frames again (in whatever AL state they are in)."""
        self._link_up(len(self.slaves))

    def _link_up(self, k: int) -> None:
        self.connected = k
        self._offsets = self._timing(k)
        for i, s in enumerate(self.slaves):
            s.set_port_link(0, i < k)
            s.set_port_link(1, i + 1 < k)

    def _timing(self, n: int) -> tuple[list[float], list[float], float]:
        """Offsets from a frame's departure: arrival at each slave's port 0, arrival back at
        its port 1, and return to the master. The last slave turns the frame round inside
        (port 1 closed); every other one sees it back at port 1 and returns it via port 0."""
        fwd, t = [], 0.0
        for i in range(n):
            fwd.append(t)
            t += self.forward_ns[i]
        back, t_exit = [t] * n, t
        for i in range(n - 2, -1, -1):
            back[i] = t_exit
            t_exit += self.return_ns[i]
        return fwd, back, t_exit

    def lose_frames(self, n: int = 1) -> None:
        """The next ``n`` frames vanish on the wire (no reply at all)."""
        self._lose += n

    def corrupt(self, k: int, n: int = 1) -> None:
        """A bit error on the link into slave ``k`` (1-based) for the next ``n`` frames."""
        if not 1 <= k <= len(self.slaves):
            raise ValueError(f"corrupt({k}): k must be 1..{len(self.slaves)}")
        self._corrupt += [k] * n

    def power_cycle(self, k: int) -> None:
        """Slave ``k`` (1-based) loses power and restarts: INIT, station address 0."""
        esc = self.slaves[k - 1]
        esc.power_on()
        esc.set_port_link(0, k <= self.connected)
        esc.set_port_link(1, k < self.connected)

    def slave_error(self, k: int, code: int, state: int = 0x04) -> None:
        """Slave ``k`` (1-based) reports an application error: drop to ``state`` + error flag."""
        self.slaves[k - 1].fail(code, state)

    # ---- the wire -----------------------------------------------------------------------
    def process(self, raw: bytes) -> bytes | None:
        """Pass one frame from the master through the chain; None when nothing comes back."""
        now = float(self.clock())
        self.frames += 1
        if self.capture is not None:
            self.capture.write(raw)
        if self._lose:
            self._lose -= 1
            self.dropped["lost"] += 1
            return None
        try:
            frame = decode_frame(raw)
        except FrameError as e:
            self.last_error = str(e)
            self.dropped["malformed"] += 1
            return None
        reply = self._pass(frame, now)
        if reply is None:
            return None
        out = encode_frame(frame)
        if self.capture is not None:
            self.capture.write(out)
        return out

    def _pass(self, frame, now: float) -> object | None:
        dgs = frame.datagrams
        slaves = self.slaves
        n = self.connected
        if n == 0:
            self.dropped["no slave"] += 1
            return None
        bad = self._corrupt.pop(0) if self._corrupt else 0
        # arrival time at each slave's port 0 on the way out, at port 1 on the way back; a
        # frame cannot leave before the previous one is back (one line, one frame at a time)
        t = max(now, self._wire_free)
        fwd, back, exit_off = self._offsets
        t_in = [t + o for o in fwd]
        t_back = [t + o for o in back]
        t_exit = t + exit_off
        plan = [(d, _KIND[d.cmd], _RW[d.cmd]) for d in dgs]
        for i in range(n):
            esc = slaves[i]
            if bad == i + 1:
                rx = 0x0300  # port 0 invalid frame counter
                esc.mem[rx] = min(esc.mem[rx] + 1, 0xFF)
                self.dropped["corrupted"] += 1
                return None
            esc.poll(t_in[i])
            esc.t_port0, esc.t_port1 = t_in[i], t_back[i]
            self._slave_pass(esc, plan)
        self._wire_free = t_exit + wire_time_ns(frame_size(frame))
        frame.src = bytes([frame.src[0] | SLAVE_SOURCE_BIT]) + frame.src[1:]
        for i in range(n):
            slaves[i].application(t_back[i])
        return frame

    @staticmethod
    def _slave_pass(esc: Esc, plan) -> None:
        """One ESC processes every datagram of the frame (the hot path: keep it short)."""
        irq = esc.irq
        for d, kind, rw in plan:
            if kind == 0:
                continue
            d.irq |= irq
            if kind == 4:
                got = esc.logical(rw & 1, rw & 2, d.logical, d.data)
                if got:
                    d.wkc += got if rw == 3 else 1
                continue
            if kind == 1 or kind == 5:
                hit = d.adp == 0
                d.adp = (d.adp + 1) & 0xFFFF
            elif kind == 2 or kind == 6:
                hit = d.adp == esc.station or d.adp == esc.alias_active
            else:  # broadcast: every slave, and every slave increments ADP
                d.adp = (d.adp + 1) & 0xFFFF
                Bus._broadcast(esc, d)
                continue
            if kind >= 5:  # ARMW/FRMW: the addressed slave reads, every other one writes
                if hit:
                    got = esc.read(d.ado, len(d.data))
                    if got is not None:
                        d.data[:] = got
                        d.wkc += 1
                elif esc.write(d.ado, d.data):
                    d.wkc += 1
                continue
            if not hit:
                continue
            if rw == 1:
                got = esc.read(d.ado, len(d.data))
                if got is not None:
                    d.data[:] = got
                    d.wkc += 1
            elif rw == 2:
                if esc.write(d.ado, d.data):
                    d.wkc += 1
            else:
                old = esc.read(d.ado, len(d.data))
                if esc.write(d.ado, bytes(d.data)):
                    d.wkc += 2
                if old is not None:
                    d.data[:] = old
                    d.wkc += 1

    @staticmethod
    def _broadcast(esc: Esc, d) -> None:
        rw = _RW[d.cmd]
        n = len(d.data)
        if rw & 2:
            incoming = bytes(d.data)
            old = esc.read(d.ado, n) if rw & 1 else None
            if esc.write(d.ado, incoming):
                d.wkc += 2 if rw == 3 else 1
            if old is not None:
                d.data[:] = (int.from_bytes(incoming, "little") | int.from_bytes(old, "little")) \
                    .to_bytes(n, "little")
                d.wkc += 1
            return
        got = esc.read(d.ado, n)
        if got is not None:
            d.data[:] = (int.from_bytes(d.data, "little") | int.from_bytes(got, "little")) \
                .to_bytes(n, "little")
            d.wkc += 1

    def sync_error_ns(self, bus_ns: float | None = None) -> float:
        """Largest |system time - reference's system time| over DC slaves at one instant."""
        t = float(self.clock()) if bus_ns is None else bus_ns
        dc = [s for s in self.slaves[:self.connected] if s.clock is not None]
        if len(dc) < 2:
            return 0.0
        ref = dc[0].system_time(t)
        return float(max(abs(((s.system_time(t) - ref + (1 << 63)) % (1 << 64)) - (1 << 63))
                         for s in dc[1:]))
