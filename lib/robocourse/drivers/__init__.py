"""robocourse.drivers: simulated arm controller boxes over real sockets, their clients and SystemInterfaces.

Counterparts: libfranka + franka_hardware (a synchronous 1 kHz UDP loop) and a UR e-Series
controller for ur_rtde + ur_robot_driver (RTDE at 500 Hz, the dashboard server, the script ports:
ur_rtde from PyPI drives it unchanged). Each box runs in its own process
(:func:`start_franka_box`, :func:`start_ur_box`) around the UR5e arm in MuJoCo.
Importing this package declares the hardware plugins ``robocourse/FrankaStyleSystem`` and
``robocourse/URStyleSystem`` with :mod:`robocourse.control.pluginlib`.
"""

from __future__ import annotations

from robocourse.control import pluginlib as _pluginlib

from . import franka_protocol as _fp
from .arm import ARM_JOINTS
from .description import CONTROLLERS_YAML, arm_urdf
from .process import BoxProcess, BoxStartError

_pluginlib.register("robocourse/FrankaStyleSystem", "robocourse.drivers.systems:FrankaStyleSystem",
                    _pluginlib.HARDWARE_BASE)
_pluginlib.register("robocourse/URStyleSystem", "robocourse.drivers.ur_system:URStyleSystem",
                    _pluginlib.HARDWARE_BASE)


def start_franka_box(port: int = 0, max_missed: int = _fp.DEFAULT_MAX_MISSED, period_us: int = 1000, initial_positions=None,
                     realtime: bool = False, physics: bool = True, client_timeout: int = 100) -> BoxProcess:
    """Start a Franka-style box process; ``box.ports["udp"]`` is its port. Stop it with ``box.stop()``.

    ``realtime``: the box tries SCHED_FIFO + locked memory (reports nothing if refused: it runs
    on). ``physics=False``: the same packets and timing with no arm behind them (the floor).
    ``client_timeout``: ticks of silence after which another client may take the slot (a dead
    client's; see :mod:`robocourse.drivers.franka_box`).
    """
    args = ["--port", port, "--max-missed", max_missed, "--period-us", period_us, "--client-timeout", client_timeout]
    if not physics:
        args.append("--no-physics")
    if initial_positions is not None:
        args += ["--initial", ",".join(repr(float(x)) for x in initial_positions)]
    if realtime:
        args.append("--rt")
    return BoxProcess("franka", args).start()


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


__all__ = ["ARM_JOINTS", "CONTROLLERS_YAML", "BoxProcess", "BoxStartError", "arm_urdf", "start_franka_box", "start_ur_box"]
