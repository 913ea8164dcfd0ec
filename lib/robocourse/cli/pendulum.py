"""``robocourse pendulum demo``: the seed's pendulum_demo (+ teleop, + logger) in one command.

``robocourse pendulum demo [-i N] [-u 1ms] [-f FILE] [-t PRIO] [-s rr|fifo] [--setpoint RAD] [--log]
[--wait sleep|hybrid|spin]`` (``--help`` lists every option) prints what pendulum_demo prints: the permission messages, the
rttest statistics block (preceded by the wait strategy that ran: ``sleep`` unless told
otherwise, as the seed's rttest loop) and the two "received N messages" lines; -f writes
rttest's results file for ``rttest-plot``.
"""

from __future__ import annotations

import argparse
import sys


def register(sub):
    p = sub.add_parser("pendulum", help="the ROS 2 pendulum demo (pendulum_control)")
    psub = p.add_subparsers(dest="pendulum_command", metavar="ACTION")
    d = psub.add_parser("demo", help="run pendulum_demo: motor + PID controller in rttest's loop",
                        description="Options as the seed (rttest's -i -u -t -s -m -d -f) plus --setpoint RAD, "
                                    "--log and --wait sleep|hybrid|spin (default sleep, as the seed).", prefix_chars="+", add_help=False)
    d.add_argument("argv", nargs=argparse.REMAINDER)
    d.set_defaults(func=run_demo)
    p.set_defaults(func=lambda args: p.print_help() or 2)


PROG = "robocourse pendulum demo"
OWN_USAGE = "[--setpoint RAD] [--log] [-h]"
OWN_HELP = (("--setpoint RAD", "publish this setpoint first, as pendulum_teleop does: radians from the ground, "
                               "0..pi, pi/2 = 1.5708 upright (default: none)"),
            ("--log", "run pendulum_logger too and print its last statistics lines"),
            ("-h, --help", "show this help and exit"))


def _usage() -> str:
    from robocourse.rt.options import usage

    return usage(PROG, OWN_USAGE)


def _own_options() -> argparse.ArgumentParser:
    own = argparse.ArgumentParser(prog=PROG, add_help=False)
    own.add_argument("--setpoint", default=None)
    own.add_argument("--log", action="store_true")
    own.add_argument("-h", "--help", action="store_true")
    return own


def run_demo(args) -> int:
    import math

    from robocourse.pendulum.demo import run_realtime
    from robocourse.rt import format_rttest
    from robocourse.rt.options import RttestOptions, RttestUsageError, help_text, parse_rttest_args
    from robocourse.rt.wait import strategy

    own, rest = _own_options().parse_known_args(args.argv)
    if own.help:
        print(help_text(PROG, OWN_USAGE, OWN_HELP, defaults={"-t P": "real-time priority 1..98 (default 98, as the "
                                                                    "seed's SCHED_RR 98)",
                                                             "-i N": "iterations (default 1000; must be positive here)",
                                                             "-d S": "heap prefault cap (default 64mb here)"}))
        print("\nWhat it prints: the permission messages, the rttest statistics block (preceded by the wait "
              "strategy that ran) and the two 'received N messages' lines, as the seed's pendulum_demo.")
        return 0
    args.log = own.log
    try:
        if own.setpoint is not None:
            try:
                args.setpoint = float(own.setpoint)
            except ValueError:
                raise RttestUsageError(f"--setpoint {own.setpoint!r}: not a number; an angle in radians, "
                                       "e.g. --setpoint 1.3") from None
            if not (math.isfinite(args.setpoint) and 0.0 <= args.setpoint <= math.pi):
                raise RttestUsageError(f"--setpoint {own.setpoint!r}: the seed's angle runs from 0 to pi = "
                                       f"{math.pi:.4f} rad (from the ground: 0 and pi lie flat, pi/2 = "
                                       f"{math.pi / 2:.4f} is upright) and its motor clamps anything outside it; "
                                       "e.g. --setpoint 1.3")
        else:
            args.setpoint = None
        # the demo's defaults: priority 98 SCHED_RR (rttest's own default priority is 80)
        opts = parse_rttest_args(rest, RttestOptions(priority=98, heap_size=64 << 20), usage_line=_usage())
        wait = strategy(opts.wait, opts.spin_ns)
    except (RttestUsageError, ValueError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    if opts.iterations <= 0:
        print(f"{PROG}: error: -i {opts.iterations}: must be positive here (the demo reports counts at the end), "
              "e.g. -i 5000", file=sys.stderr)
        return 2
    run = run_realtime(opts.iterations, opts.period_ns, opts.priority, opts.policy, setpoint=args.setpoint,
                       log=args.log, stack_size=opts.stack_size, heap_size=opts.heap_size, wait=wait)
    print(format_rttest(run.loop.stats(), extended=False).rstrip())
    if opts.filename:
        run.loop.write(opts.filename)
        print(f"results written to {opts.filename} (draw them: robocourse rttest-plot {opts.filename})")
    print(f"PendulumMotor received {run.motor_received} messages")
    print(f"PendulumController received {run.controller_received} messages")
    return 0
