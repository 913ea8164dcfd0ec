"""Entry point of a box process: ``python -m robocourse.drivers.box {franka|ur} [options]``.

Started by :class:`robocourse.drivers.process.BoxProcess`; prints ``READY name=port ...`` once
its sockets are bound, then runs until SIGTERM, or until its parent is gone. A failure to start
(a port in use) exits with code 2 and one line on stderr naming the port and the fix.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time

from .franka_wire import MAX_LOST_IN_ROW, VERSION
from .ur_protocol import KEEPALIVE_S


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m robocourse.drivers.box")
    p.add_argument("kind", choices=("franka", "ur"))
    p.add_argument("--host", default="", help="address to bind (franka default: a free 127.0.0.x; ur: 127.0.0.1)")
    p.add_argument("--port", type=int, default=0, help="franka: TCP command port (0 = libfranka's 1337); ur: RTDE port (0 = free)")
    p.add_argument("--script-port", type=int, default=0, help="ur: script channel port (0 = free)")
    p.add_argument("--max-lost", type=int, default=MAX_LOST_IN_ROW,
                   help="franka: lost command packets in a row before the communication reflex (the robot: 20)")
    p.add_argument("--server-version", type=int, default=VERSION,
                   help="franka: the robot server version the box claims (libfranka 0.21 needs 10)")
    p.add_argument("--keepalive", type=float, default=KEEPALIVE_S, help="ur: script keepalive timeout in s")
    p.add_argument("--initial", default="", help="comma-separated initial joint positions (rad)")
    p.add_argument("--no-physics", action="store_true", help="franka: no arm behind the packets (the round-trip floor)")
    p.add_argument("--rt", action="store_true", help="try SCHED_FIFO + mlockall for the box")
    return p


def _watch_parent(ppid: int) -> None:
    while True:
        if os.getppid() != ppid:
            os._exit(0)
        time.sleep(0.5)


def main(argv=None) -> int:
    a = _parser().parse_args(argv)
    initial = [float(x) for x in a.initial.split(",")] if a.initial else None
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True).start()
    try:
        if a.kind == "franka":
            from .franka_box import FrankaBox
            from .franka_wire import COMMAND_PORT

            box = FrankaBox(host=a.host or None, command_port=a.port or COMMAND_PORT, initial_positions=initial,
                            physics=not a.no_physics, max_lost=a.max_lost, server_version=a.server_version)
            ready = f"READY host={box.host} command={box.command_port} udp={box.udp_port} monitor={box.monitor_port}"
        else:
            from .ur_box import URBox

            box = URBox(port=a.port, script_port=a.script_port, host=a.host or "127.0.0.1", keepalive=a.keepalive,
                        initial_positions=initial)
            ready = f"READY rtde={box.port} script={box.script_port}"
    except OSError as exc:
        print(f"cannot bind {a.kind} box on {a.host} (port {a.port}, script port {a.script_port}): {exc}; "
              "pick another port or pass 0 for a free one", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"cannot start the {a.kind} box: {exc}", file=sys.stderr)
        return 2
    def stop(signum, frame):
        box.running = False

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if a.rt:       # settings first (prefaulting the heap takes a while), then READY: a client never waits on them
        from robocourse.rt import settings

        with settings.realtime(quiet=True, heap_size=16 * 1024 * 1024):
            print(ready, flush=True)
            box.run()
    else:
        print(ready, flush=True)
        box.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
