"""Entry point of a box process: ``python -m robocourse.drivers.box {franka|ur} [options]``.

Started by :class:`robocourse.drivers.process.BoxProcess`; prints ``READY name=port ...`` (the UR
box: ``READY host=127.0.0.x rtde=30004 ...``) once its sockets are bound, then runs until
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

from .franka_protocol import DEFAULT_MAX_MISSED


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m robocourse.drivers.box")
    p.add_argument("kind", choices=("franka", "ur"))
    p.add_argument("--host", default=None,
                   help="franka: address (default 127.0.0.1); ur: address (default: a free 127.0.0.x)")
    p.add_argument("--port", type=int, default=0, help="franka: UDP port (0 = free)")
    p.add_argument("--period-us", type=int, default=1000, help="franka: state period in us")
    p.add_argument("--max-missed", type=int, default=DEFAULT_MAX_MISSED, help="franka: missed ticks in a row before the reflex")
    p.add_argument("--client-timeout", type=int, default=100,
                   help="franka: ticks of silence after which another client may take the slot")
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

            box = FrankaBox(port=a.port, host=a.host or "127.0.0.1", period_us=a.period_us, max_missed=a.max_missed,
                            initial_positions=initial, physics=not a.no_physics,
                            client_timeout=a.client_timeout)
            ready = f"READY udp={box.port}"
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
        print(f"cannot bind {a.kind} box on {a.host} (port {a.port}): {exc}; "
              "pick another port or pass 0 for a free one", file=sys.stderr)
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

        with settings.realtime(quiet=True, heap_size=16 * 1024 * 1024):
            print(ready, flush=True)
            box.run()
    else:
        print(ready, flush=True)
        box.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
