"""robocourse.drivers: simulated arm controller boxes over real sockets, their clients and SystemInterfaces.

Counterparts: libfranka + franka_hardware (a synchronous 1 kHz UDP loop) and ur_rtde +
ur_robot_driver (an asynchronous 500 Hz RTDE stream plus servoj targets). Each box runs in its
own process (:func:`start_franka_box`, :func:`start_ur_box`) around the UR5e arm in MuJoCo.
Importing this package declares the hardware plugins ``robocourse/FrankaStyleSystem`` and
``robocourse/URStyleSystem`` with :mod:`robocourse.control.pluginlib`.
"""

from __future__ import annotations

from robocourse.control import pluginlib as _pluginlib

from . import franka_protocol as _fp
from . import ur_protocol as _up
from .arm import ARM_JOINTS
from .description import CONTROLLERS_YAML, arm_urdf
from .process import BoxProcess, BoxStartError

_pluginlib.register("robocourse/FrankaStyleSystem", "robocourse.drivers.systems:FrankaStyleSystem",
                    _pluginlib.HARDWARE_BASE)
_pluginlib.register("robocourse/URStyleSystem", "robocourse.drivers.systems:URStyleSystem",
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


def start_ur_box(rtde_port: int = 0, script_port: int = 0, keepalive: float = _up.KEEPALIVE_S, initial_positions=None,
                 realtime: bool = False) -> BoxProcess:
    """Start a UR-style box process; ``box.ports["rtde"]`` and ``box.ports["script"]`` are its ports."""
    args = ["--port", rtde_port, "--script-port", script_port, "--keepalive", keepalive]
    if initial_positions is not None:
        args += ["--initial", ",".join(repr(float(x)) for x in initial_positions)]
    if realtime:
        args.append("--rt")
    return BoxProcess("ur", args).start()


__all__ = ["ARM_JOINTS", "CONTROLLERS_YAML", "BoxProcess", "BoxStartError", "arm_urdf", "start_franka_box", "start_ur_box"]
