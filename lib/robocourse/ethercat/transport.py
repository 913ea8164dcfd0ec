"""How frames reach the bus: in-process (a function call) or raw Ethernet (AF_PACKET).

``InProcess(bus)`` hands each frame to ``Bus.process`` (deterministic, fast: notebooks and
most tests). ``RawSocket(ifname)`` is what SOEM's nicdrv.c does: a packet socket bound to a
network interface for EtherType 0x88A4. ``serve(bus, ifname)`` puts the simulated bus on an
interface, so any master bound to the peer of a veth pair (SOEM through pysoem, or ours)
talks to it. Raw sockets need CAP_NET_RAW (root); without it the error says so.
"""

from __future__ import annotations

import select
import socket
import threading
import time

from .bus import Bus
from .frames import ETHERTYPE_ECAT

PACKET_OUTGOING = 4  # linux/if_packet.h: a frame this host sent


class InProcess:
    """The master calls the bus directly."""

    def __init__(self, bus: Bus) -> None:
        self.bus = bus

    def exchange(self, frame: bytes, timeout_s: float = 0.002) -> bytes | None:
        return self.bus.process(frame)

    def close(self) -> None:
        pass


def open_raw(ifname: str) -> socket.socket:
    """A packet socket on ``ifname`` for EtherCAT frames, with a clear error when not allowed."""
    try:
        sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETHERTYPE_ECAT))
    except PermissionError as e:
        from robocourse.rt.capabilities import setcap_advice

        raise PermissionError(
            f"opening a raw socket for {ifname!r} needs CAP_NET_RAW ({e}): run the master as root (sudo), "
            + setcap_advice("cap_net_raw", lead="or, without sudo, set it")) from e
    try:
        sock.bind((ifname, ETHERTYPE_ECAT))
    except OSError as e:
        sock.close()
        raise OSError(f"cannot bind a raw socket to interface {ifname!r}: {e}; list interfaces "
                      "with: ip link") from e
    return sock


class RawSocket:
    """A master's side of raw Ethernet: send a frame, wait for the reply with its index."""

    def __init__(self, ifname: str) -> None:
        self.ifname = ifname
        self.sock = open_raw(ifname)

    def exchange(self, frame: bytes, timeout_s: float = 0.002) -> bytes | None:
        idx = frame[17] if len(frame) > 17 else -1
        self.sock.send(frame)
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            r, _, _ = select.select([self.sock], [], [], left)
            if not r:
                return None
            data, addr = self.sock.recvfrom(2048)
            if addr[2] == PACKET_OUTGOING or len(data) < 18:
                continue
            if data[17] == idx and data[6] & 0x02:
                return data

    def close(self) -> None:
        self.sock.close()


class BusServer:
    """The simulated bus answering on ``ifname`` in a background thread until ``stop()``."""

    def __init__(self, bus: Bus, ifname: str) -> None:
        self.bus = bus
        self.sock = open_raw(ifname)
        self.replies = 0
        self._stop = threading.Event()
        self.lock = threading.Lock()  # hold it to inspect devices between frames
        self._thread = threading.Thread(target=self._run, name=f"ecat-bus-{ifname}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        sock, bus = self.sock, self.bus
        while not self._stop.is_set():
            r, _, _ = select.select([sock], [], [], 0.05)
            if not r:
                continue
            data, addr = sock.recvfrom(2048)
            if addr[2] == PACKET_OUTGOING:
                continue
            with self.lock:
                reply = bus.process(data)
            if reply is not None:
                sock.send(reply)
                self.replies += 1

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.sock.close()


def serve(bus: Bus, ifname: str) -> BusServer:
    """Start answering EtherCAT frames on ``ifname``; call ``.stop()`` when done."""
    return BusServer(bus, ifname)
