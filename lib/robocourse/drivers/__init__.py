"""robocourse.drivers: simulated arm controller boxes over real sockets, their clients and SystemInterfaces.

Counterparts: a Franka FR3 as libfranka sees it (its robot server, version 10: pylibfranka from
PyPI drives :func:`start_franka_box` unchanged, and franka_hardware's SystemInterface runs on
pylibfranka) and a UR e-Series controller for ur_rtde + ur_robot_driver (RTDE at 500 Hz, the
dashboard server, the script ports: ur_rtde from PyPI drives it unchanged). Each box runs in its
own process on its own loopback address.
Importing this package declares the hardware plugins ``robocourse/FrankaStyleSystem`` and
``robocourse/URStyleSystem`` with :mod:`robocourse.control.pluginlib`.
"""

from __future__ import annotations

from robocourse.control import pluginlib as _pluginlib

from . import franka_wire as _fw
from .arm import ARM_JOINTS
from .description import CONTROLLERS_YAML, FR3_CONTROLLERS_YAML, arm_urdf, fr3_urdf
from .fr3_arm import FR3_JOINTS
from .process import BoxProcess, BoxStartError

_pluginlib.register("robocourse/FrankaStyleSystem", "robocourse.drivers.franka_system:FrankaStyleSystem",
                    _pluginlib.HARDWARE_BASE)
_pluginlib.register("robocourse/URStyleSystem", "robocourse.drivers.ur_system:URStyleSystem",
                    _pluginlib.HARDWARE_BASE)


def start_franka_box(max_lost: int = _fw.MAX_LOST_IN_ROW, initial_positions=None, realtime: bool = True,
                     physics: bool = True, host: str | None = None, server_version: int = _fw.VERSION) -> BoxProcess:
    """Start a simulated FR3 (libfranka's robot server) in its own process on a free loopback address.

    Connect with pylibfranka: ``pylibfranka.Robot(box.host, pylibfranka.RealtimeConfig.kIgnore)``.
    ``box.host`` is the 127.0.0.x it bound (TCP 1337 is fixed by libfranka, so each box has its
    own address); ``box.ports`` = {"command", "udp", "monitor"}; stop it with ``box.stop()``.
    ``max_lost``: lost command packets in a row before the communication reflex (the robot's
    20). ``realtime`` (on by default: the robot's controller is a real-time computer): the box
    tries SCHED_FIFO + locked memory and carries on if refused (an unprivileged user's box then
    competes with everything else, and skips ticks when starved: it counts them).
    ``physics=False``: the same packets and timing with no arm behind them (the floor).
    ``server_version``: the version it claims in Connect (10 for libfranka 0.21; another one
    shows the client's version check).
    """
    if isinstance(max_lost, bool) or not isinstance(max_lost, int) or max_lost < 1:
        raise ValueError(f"max_lost={max_lost!r} must be a whole number of cycles >= 1; the FR3 uses 20")
    args = ["--max-lost", max_lost, "--server-version", server_version]
    if host:
        args += ["--host", host]
    if not physics:
        args.append("--no-physics")
    if initial_positions is not None:
        args += ["--initial", ",".join(repr(float(x)) for x in initial_positions)]
    if realtime:
        args.append("--rt")
    return BoxProcess("franka", args).start()


def box_stats(box: BoxProcess, timeout: float = 1.0) -> dict:
    """A Franka box's counters (lost, late, commands_ok, reflexes, tcp_malformed, ...) from its
    monitor socket: read from outside the client, which never sees them."""
    import json
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.settimeout(timeout / 3)
        for _attempt in range(3):
            s.sendto(b"stats", (box.host, box.ports["monitor"]))
            try:
                return json.loads(s.recv(1 << 16))
            except (TimeoutError, ConnectionRefusedError):
                continue
    raise TimeoutError(f"the Franka box at {box.host} did not answer its monitor within {timeout} s (is it running?)")


def box_watch(box: BoxProcess, tid: int | None = None, timeout: float = 1.0) -> str:
    """Tell a Franka box which thread runs the client (default: the calling one), so it counts
    against the client only the lost cycles that thread did not spend waiting for a CPU (a
    grader's rule on a shared machine; see :mod:`robocourse.drivers.franka_box`). Returns "ok"
    or "unavailable: why" (the box then keeps the robot's plain rule)."""
    import socket
    import threading

    tid = threading.get_native_id() if tid is None else int(tid)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.settimeout(timeout / 3)
        for _attempt in range(3):
            s.sendto(f"watch {tid}".encode(), (box.host, box.ports["monitor"]))
            try:
                return s.recv(1024).decode(errors="replace")
            except (TimeoutError, ConnectionRefusedError):
                continue
    raise TimeoutError(f"the Franka box at {box.host} did not answer its monitor within {timeout} s (is it running?)")


def start_ur_box(host: str | None = None, initial_positions=None, realtime: bool = False, physics: bool = True,
                 powered: bool = True, unlock_delay: float | None = None) -> BoxProcess:
    """Start a UR-style box process (a UR e-Series controller for ur_rtde); ``box.host`` is its
    address, where it listens on UR's ports (``box.ports``: RTDE 30004, dashboard 29999, script
    ports 30001-30003). ``host``: None picks a free loopback address 127.0.0.x, so several boxes
    (and other people's tests) run side by side. Stop it with ``box.stop()``.

    ``physics=False``: the same protocol and timing with no arm behind it (a benchmark's floor).
    ``powered=False``: starts in POWER_OFF (dashboard ``power on``, ``brake release``).
    ``unlock_delay``: seconds before a protective stop may be unlocked (UR's 5 by default).
    """
    args = [] if host is None else ["--host", host]
    if not physics:
        args.append("--no-physics")
    if not powered:
        args.append("--power-off")
    if unlock_delay is not None:
        args += ["--unlock-delay", float(unlock_delay)]
    if initial_positions is not None:
        args += ["--initial", ",".join(repr(float(x)) for x in initial_positions)]
    if realtime:
        args.append("--rt")
    return BoxProcess("ur", args).start()


__all__ = ["ARM_JOINTS", "CONTROLLERS_YAML", "FR3_CONTROLLERS_YAML", "FR3_JOINTS", "BoxProcess", "BoxStartError",
           "arm_urdf", "box_stats", "box_watch", "fr3_urdf", "start_franka_box", "start_ur_box"]
