"""``robocourse pendulum demo``: the seed's pendulum_demo (+ teleop, + logger) in one command.

``robocourse pendulum demo [-i N] [-u 1ms] [-f FILE] [-t PRIO] [-s rr|fifo] [--setpoint RAD] [--log]
[--wait sleep|hybrid|spin]`` prints what pendulum_demo prints: the permission messages, the
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


def _own_options() -> argparse.ArgumentParser:
    own = argparse.ArgumentParser(prog="robocourse pendulum demo", add_help=False)
    own.add_argument("--setpoint", type=float, default=None)
    own.add_argument("--log", action="store_true")
    own.add_argument("--wait", default=None)
    own.add_argument("-h", "--help", action="store_true")
    return own


def run_demo(args) -> int:
    from robocourse.pendulum.demo import run_realtime
    from robocourse.rt import format_rttest
    from robocourse.rt.options import RttestOptions, RttestUsageError, parse_rttest_args
    from robocourse.rt.wait import strategy

    own, rest = _own_options().parse_known_args(args.argv)
    if own.help:
        print(__doc__.strip())
        return 0
    args.setpoint, args.log, args.wait = own.setpoint, own.log, own.wait
    try:
        # the demo's defaults: priority 98 SCHED_RR (rttest's own default priority is 80)
        opts = parse_rttest_args(rest, RttestOptions(priority=98, heap_size=64 << 20))
        wait = strategy(args.wait or opts.wait, opts.spin_ns)
    except (RttestUsageError, ValueError) as exc:
        print(f"robocourse pendulum demo: error: {exc}", file=sys.stderr)
        return 2
    if opts.iterations <= 0:
        print("robocourse pendulum demo: error: -i must be positive here (the demo reports counts at the end)",
              file=sys.stderr)
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
