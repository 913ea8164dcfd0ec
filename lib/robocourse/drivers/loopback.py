"""A free loopback address for a box whose port numbers are fixed (RTDE 30004, libfranka 1337, ...).

Counterpart: a robot's controller is its own computer with its own IP address, so its ports
are fixed numbers the vendors' clients hard-code (ur_rtde: 30004, 29999, 30001-30003;
libfranka: 1337). Several simulated robots on one machine (tests running side by side, other
users' notebooks) therefore each need their own address. Linux routes the whole of
127.0.0.0/8 to the loopback interface, so 127.0.0.2, 127.0.0.3, ... all work without any set-up.

:func:`bind_free_loopback` binds every socket a box needs on one address, trying addresses
from a random starting point until one has all its ports free. Binding is the test (atomic,
no race with another box starting at the same moment); the sockets stay bound, so nobody can
take the address between the choice and its use. 127.0.0.1 is never chosen: real services
(and other courses' tools) listen there.

Where only 127.0.0.1 exists (macOS, unless you alias more with
``sudo ifconfig lo0 alias 127.0.0.2 up``), the error says so.
"""

from __future__ import annotations

import errno
import random
import socket
from collections.abc import Sequence

#: the addresses tried: 127.0.0.2 .. 127.0.0.254
FIRST, LAST = 2, 254


class NoFreeAddress(OSError):
    """No loopback address has all the requested ports free (or the platform has only 127.0.0.1)."""


def _bind(host: str, port: int, kind: int) -> socket.socket:
    s = socket.socket(socket.AF_INET, kind)
    try:
        if kind == socket.SOCK_STREAM:
            # a listener may rebind while old connections of a previous box sit in TIME_WAIT
            # (never set on UDP: there it would let two sockets share the port)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((host, port))
        if kind == socket.SOCK_STREAM:
            s.listen(8)
    except OSError:
        s.close()
        raise
    s.setblocking(False)
    return s


def bind_all(host: str, ports: Sequence[tuple[int, int]]) -> list[socket.socket]:
    """Bind ``ports`` ((port, socket.SOCK_STREAM or SOCK_DGRAM) pairs; TCP ones listen) on
    ``host``; all or none (an OSError from the first that fails, the others closed)."""
    bound: list[socket.socket] = []
    try:
        for port, kind in ports:
            bound.append(_bind(host, port, kind))
    except OSError:
        for s in bound:
            s.close()
        raise
    return bound


def bind_free_loopback(ports: Sequence[tuple[int, int]], rng: random.Random | None = None
                       ) -> tuple[str, list[socket.socket]]:
    """Bind ``ports`` on the first address of 127.0.0.2..127.0.0.254 (from a random start) where
    all are free; returns (address, sockets in the order of ``ports``)."""
    if not ports:
        raise ValueError("ports must list at least one (port, socket type) pair, e.g. [(30004, socket.SOCK_STREAM)]")
    rng = rng or random.Random()
    n = LAST - FIRST + 1
    start = rng.randrange(n)
    busy = 0
    for k in range(n):
        host = f"127.0.0.{FIRST + (start + k) % n}"
        try:
            return host, bind_all(host, ports)
        except OSError as exc:
            if exc.errno == errno.EADDRNOTAVAIL:
                raise NoFreeAddress(errno.EADDRNOTAVAIL,
                                    f"this machine has no loopback address {host} (only 127.0.0.1?): on macOS add "
                                    f"some with `sudo ifconfig lo0 alias {host} up`, or pass host='127.0.0.1' "
                                    "for a single box") from None
            if exc.errno != errno.EADDRINUSE:
                raise
            busy += 1
    raise NoFreeAddress(errno.EADDRINUSE, f"ports {[p for p, _ in ports]} are in use on all {busy} loopback "
                                          f"addresses 127.0.0.{FIRST}..127.0.0.{LAST}: stop some boxes first")
