"""``robocourse zenoh router``, ``robocourse topic list|echo|info`` and ``robocourse node list``:
the ``ros2`` commands against a graph spread over processes (and machines) through zenoh.

=============================================  =============================================
ROS 2 (rmw_zenoh)                              robocourse
=============================================  =============================================
``ros2 run rmw_zenoh_cpp rmw_zenohd``          ``robocourse zenoh router [--listen EP]``
``ros2 topic list [-t]``                       ``robocourse topic list [-t]``
``ros2 topic info [-v] /x``                    ``robocourse topic info [-v] /x``
``ros2 topic echo /x [--once]``                ``robocourse topic echo /x [--once | -n N]``
``ros2 node list``                             ``robocourse node list``
=============================================  =============================================

The graph commands open a zenoh session like any robocourse process
(``Context(transport="zenoh")``: peer mode, connecting to ``--connect``, default
``tcp/127.0.0.1:7447``, domain ``--domain-id`` or ``$ROS_DOMAIN_ID`` or 0), read the liveliness
tokens, print, and leave (their own hidden node disappears again). Like ``ros2``, they see a
real ROS 2 graph that uses rmw_zenoh on the same router and domain. ``topic echo`` adds
``--timeout SECONDS`` (stop after that long, exit 1 if nothing arrived), so a script never
waits forever.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

PROG = "robocourse"


def register(sub):
    z = sub.add_parser("zenoh", help="the zenoh router robocourse (and rmw_zenoh) nodes meet at")
    zsub = z.add_subparsers(dest="zenoh_command", metavar="ACTION")
    r = zsub.add_parser(
        "router", help="run a zenoh router (rmw_zenohd) until Ctrl-C or SIGTERM",
        description="A zenoh router as rmw_zenoh's rmw_zenohd: nodes connect to it, discover "
                    "each other through it and then talk directly. Default: loopback only, "
                    "multicast scouting off. Two machines: --listen tcp/0.0.0.0:7447 here and "
                    "connect=['tcp/<this host>:7447'] in the other machine's Context.")
    r.add_argument("--listen", action="append", metavar="ENDPOINT",
                   help="zenoh locator to listen on (repeatable); default tcp/127.0.0.1:7447")
    r.set_defaults(func=run_router)
    z.set_defaults(func=lambda args: z.print_help() or 2)

    t = sub.add_parser("topic", help="ros2 topic list/info/echo over zenoh (other processes)")
    tsub = t.add_subparsers(dest="topic_command", metavar="ACTION")
    tl = tsub.add_parser("list", help="topics of the graph (ros2 topic list)")
    tl.add_argument("-t", "--show-types", action="store_true", help="also print each type")
    tl.add_argument("-a", "--include-hidden-topics", action="store_true")
    _session_args(tl)
    tl.set_defaults(func=run_topic_list)
    ti = tsub.add_parser("info", help="type and endpoints of one topic (ros2 topic info)")
    ti.add_argument("topic_name")
    ti.add_argument("-v", "--verbose", action="store_true",
                    help="every publisher and subscription with node and QoS")
    _session_args(ti)
    ti.set_defaults(func=run_topic_info)
    te = tsub.add_parser("echo", help="print messages of one topic as YAML (ros2 topic echo)")
    te.add_argument("topic_name")
    te.add_argument("--once", action="store_true", help="print one message and exit")
    te.add_argument("-n", "--count", type=int, default=None, metavar="N",
                    help="print N messages and exit")
    te.add_argument("--timeout", type=float, default=None, metavar="SECONDS",
                    help="stop after SECONDS (exit 1 if fewer messages than asked arrived)")
    _session_args(te)
    te.set_defaults(func=run_topic_echo)
    t.set_defaults(func=lambda args: t.print_help() or 2)

    n = sub.add_parser("node", help="ros2 node list over zenoh (other processes)")
    nsub = n.add_subparsers(dest="node_command", metavar="ACTION")
    nl = nsub.add_parser("list", help="nodes of the graph (ros2 node list)")
    nl.add_argument("-a", "--all", action="store_true", help="also hidden nodes ('_' names)")
    _session_args(nl)
    nl.set_defaults(func=run_node_list)
    n.set_defaults(func=lambda args: n.print_help() or 2)


def _session_args(p):
    p.add_argument("--connect", action="append", metavar="ENDPOINT",
                   help="router to connect to (repeatable); default tcp/127.0.0.1:7447")
    p.add_argument("--domain-id", type=int, default=None,
                   help="ROS domain (default $ROS_DOMAIN_ID or 0)")


def _domain(args) -> int:
    if args.domain_id is not None:
        return args.domain_id
    env = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not env:
        return 0
    if not env.isdigit():
        raise ValueError(f"ROS_DOMAIN_ID={env!r} must be an integer >= 0 (or unset for 0)")
    return int(env)


def _open(args):
    """A zenoh Context, or None after printing the no-router error (exit 1)."""
    from robocourse.bus.context import Context

    connect = args.connect or None
    try:
        ctx = Context(transport="zenoh", domain_id=_domain(args),
                      **({"connect": connect} if connect else {}))
    except ConnectionError as exc:
        print(f"{PROG} {args.command}: error: {exc}", file=sys.stderr)
        return None
    ctx.transport.settle()
    return ctx


def run_router(args) -> int:
    from robocourse.bus.zenoh.transport import DEFAULT_ROUTER, router

    listen = args.listen or [DEFAULT_ROUTER]
    try:
        r = router(listen)
    except (OSError, ValueError) as exc:
        print(f"{PROG} zenoh router: error: {exc}", file=sys.stderr)
        return 1
    stop = threading.Event()
    # both signals set the flag (a shell's background job inherits SIGINT ignored otherwise)
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGTERM, signal.SIGINT)}
    print(f"zenoh router {r.zid()} listening on {', '.join(listen)} (multicast scouting off); "
          f"Ctrl-C stops it", flush=True)
    try:
        while not stop.wait(0.2):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        r.close()
    print("zenoh router stopped", flush=True)
    return 0


def _with_graph(args, read) -> int:
    """Open the session, settle discovery, run ``read(ctx)`` (it prints; an int it returns is
    the exit code, anything else means 0), leave the graph again whatever happens."""
    ctx = _open(args)
    if ctx is None:
        return 1
    try:
        code = read(ctx)
        return code if isinstance(code, int) else 0
    finally:
        ctx.try_shutdown()


def run_topic_list(args) -> int:
    from robocourse.bus import introspection as ros2

    def read(ctx):
        rows = ros2.topic_list(ctx, show_types=args.show_types,
                               include_hidden=args.include_hidden_topics, quiet=True)
        for name, types in rows:
            print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return _with_graph(args, read)


def run_topic_info(args) -> int:
    from robocourse.bus import introspection as ros2

    return _with_graph(args, lambda ctx: 0 if ros2.topic_info(
        ctx, args.topic_name, verbose=args.verbose)["type"] is not None else 1)


def run_node_list(args) -> int:
    from robocourse.bus import introspection as ros2

    return _with_graph(args, lambda ctx: ros2.node_list(ctx, include_hidden=args.all))


def run_topic_echo(args) -> int:
    from robocourse.bus import introspection as ros2
    from robocourse.bus.executors import SingleThreadedExecutor

    count = 1 if args.once else args.count
    if count is not None and count < 1:
        raise ValueError(f"-n {count}: the number of messages must be >= 1")
    if args.timeout is not None and not args.timeout > 0:
        raise ValueError(f"--timeout {args.timeout}: must be a number of seconds > 0")
    ctx = _open(args)
    if ctx is None:
        return 1
    sys.stdout.reconfigure(line_buffering=True)
    stop = threading.Event()
    previous = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        try:
            msg_type = ros2._topic_type(ctx, args.topic_name)
        except ValueError:
            print(f"{PROG} topic echo: error: could not determine the type of "
                  f"'{args.topic_name}': no publisher or subscription on it in domain "
                  f"{ctx.transport.domain_id} (topics: "
                  f"{[n for n, _ in ros2.topic_list(ctx, quiet=True)]})", file=sys.stderr)
            return 1
        node = ctx.create_node("_robocourse_topic_echo")
        got = []

        def on_msg(m):
            if count is None or len(got) < count:
                got.append(m)
                print(ros2.to_yaml(m) + "\n---")

        node.create_subscription(msg_type, args.topic_name, on_msg,
                                 ros2._adapted_qos(ctx, args.topic_name))
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        end = None if args.timeout is None else time.monotonic() + args.timeout
        while not stop.is_set() and (count is None or len(got) < count):
            left = None if end is None else end - time.monotonic()
            if left is not None and left <= 0:
                break
            ex.spin_once(timeout_sec=0.1 if left is None else min(0.1, left))
    except KeyboardInterrupt:
        return 0
    finally:
        signal.signal(signal.SIGTERM, previous)
        ctx.try_shutdown()
    if count is not None and len(got) < count:
        print(f"{PROG} topic echo: {len(got)} of {count} messages on '{args.topic_name}' "
              f"within {args.timeout} s", file=sys.stderr)
        return 1
    return 0
