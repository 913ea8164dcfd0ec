"""Entry point of a box process: ``python -m robocourse.drivers.box {franka|ur} [options]``.

Started by :class:`robocourse.drivers.process.BoxProcess`; prints ``READY host=127.0.0.x
name=port ...`` once its sockets are bound, then runs until
SIGTERM, or until its parent is gone. A failure to start (a port in use) exits with code 2 and
one line on stderr naming the port and the fix.
"""

from __future__ import annotations

import argparse
import faulthandler
import os
import signal
import sys
import threading
import time

from .franka_wire import MAX_LOST_IN_ROW, VERSION


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m robocourse.drivers.box")
    p.add_argument("kind", choices=("franka", "ur"))
    p.add_argument("--host", default=None, help="address to bind (default: a free 127.0.0.x)")
    p.add_argument("--max-lost", type=int, default=MAX_LOST_IN_ROW,
                   help="franka: lost command packets in a row before the communication reflex (the robot: 20)")
    p.add_argument("--server-version", type=int, default=VERSION,
                   help="franka: the robot server version the box claims (libfranka 0.21 needs 10)")
    p.add_argument("--power-off", action="store_true", help="ur: start powered off (dashboard: power on, brake release)")
    p.add_argument("--unlock-delay", type=float, default=None,
                   help="ur: seconds before a protective stop may be unlocked (UR: 5)")
    p.add_argument("--initial", default="", help="comma-separated initial joint positions (rad)")
    p.add_argument("--no-physics", action="store_true", help="no arm behind the packets (round-trip floor)")
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

            box = FrankaBox(host=a.host, initial_positions=initial, physics=not a.no_physics, max_lost=a.max_lost,
                            server_version=a.server_version)
            ready = f"READY host={box.host} command={box.command_port} udp={box.udp_port} monitor={box.monitor_port}"
        else:
            from .ur_box import PORTS, URBox, open_listeners

            try:
                host, listeners = open_listeners(a.host)
            except OSError as exc:
                print(f"cannot bind the ur box's ports {list(PORTS.values())} on {a.host or 'a free 127.0.0.x'}: "
                      f"{exc}; stop the box using them, or pass no host to get a free loopback address",
                      file=sys.stderr)
                return 2
            box = URBox(listeners, host, initial_positions=initial, physics=not a.no_physics,
                        powered=not a.power_off, unlock_delay=a.unlock_delay)
            ready = "READY host=" + host + "".join(f" {k}={v}" for k, v in PORTS.items())
    except OSError as exc:
        print(f"cannot bind the {a.kind} box on {a.host or 'a free 127.0.0.x'}: {exc}; stop the box using it, "
              "or pass no host to get a free loopback address", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"cannot start the {a.kind} box: {exc}", file=sys.stderr)
        return 2
    def stop(signum, frame):
        box.running = False

    signal.signal(signal.SIGTERM, stop)
    faulthandler.register(signal.SIGUSR1)    # `kill -USR1 <pid>` prints where a stuck box is (stderr)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if a.rt:       # settings first (prefaulting the heap takes a while), then READY: a client never waits on them
        from robocourse.rt import settings

        with settings.realtime(quiet=True, heap_size=4 * 1024 * 1024):
            print(ready, flush=True)
            box.run()
    else:
        print(ready, flush=True)
        box.run()
    return 0


if __name__ == "__main__":
    code = main()
    # nothing is left to write (the sockets close with the process), so skip the interpreter's
    # teardown (every module, MuJoCo's model): a stopped box is gone at once, not half a second later
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
