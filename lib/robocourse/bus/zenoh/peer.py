"""A second process for chapter 7, the tests and the benchmark: ``python -m
robocourse.bus.zenoh.peer ROLE --connect tcp/127.0.0.1:7447``.

Roles (each prints ``READY`` once its endpoints are declared, then runs until killed or
``--count`` is reached):

- ``talker``: node ``/talker`` publishes ``std_msgs/String`` "hello N" on ``/chatter``
  (depth 7) every ``--period`` seconds and serves ``/add_two_ints``
  (``example_interfaces/AddTwoInts``), like ROS 2's demo_nodes talker and add_two_ints_server.
- ``echo``: node ``/echo`` republishes every message of ``--type`` from ``/ping`` on ``/pong``
  (the benchmark's and the split pendulum's other half).
- ``fibonacci``: node ``/fibonacci_server`` serves the ``/fibonacci`` action
  (``example_interfaces/action/Fibonacci``) like ROS 2's action tutorial server: one
  feedback per ``--period`` seconds with the partial sequence, cancel requests accepted,
  result the whole sequence.
"""

from __future__ import annotations

import argparse
import sys
import threading


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m robocourse.bus.zenoh.peer")
    ap.add_argument("role", choices=["talker", "echo", "fibonacci"])
    ap.add_argument("--connect", default="tcp/127.0.0.1:7447")
    ap.add_argument("--domain-id", type=int, default=0)
    ap.add_argument("--period", type=float, default=0.01)
    ap.add_argument("--count", type=int, default=0, help="stop after N messages (0: never)")
    ap.add_argument("--type", default="std_msgs/msg/String")
    ap.add_argument("--best-effort", action="store_true")
    ap.add_argument("--keep-all", action="store_true",
                    help="KEEP_ALL history (RELIABLE: the publisher blocks instead of dropping)")
    a = ap.parse_args(argv)

    from robocourse.bus.context import Context
    from robocourse.bus.executors import SingleThreadedExecutor
    from robocourse.bus.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from robocourse.bus.zenoh.processes import exit_with_parent
    from robocourse.msgs import REGISTRY
    from robocourse.msgs.example_interfaces import AddTwoInts
    from robocourse.msgs.std_msgs import String

    ctx = Context(transport="zenoh", domain_id=a.domain_id, connect=[a.connect])
    ex = SingleThreadedExecutor(context=ctx)
    qos = QoSProfile(depth=7, history=HistoryPolicy.KEEP_ALL if a.keep_all else
                     HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.BEST_EFFORT if a.best_effort
                     else ReliabilityPolicy.RELIABLE)
    if a.role == "talker":
        node = ctx.create_node("talker")
        pub = node.create_publisher(String, "/chatter", qos)

        def add(req, resp):
            resp.sum = req.a + req.b
            return resp
        node.create_service(AddTwoInts, "/add_two_ints", add)
        msg, n = String(), [0]

        def tick():
            n[0] += 1
            msg.data = f"hello {n[0]}"
            pub.publish(msg)
            if a.count and n[0] >= a.count:
                ctx.try_shutdown()
        node.create_timer(a.period, tick)
    elif a.role == "fibonacci":
        node = ctx.create_node("fibonacci_server")
        _fibonacci_server(node, a.period)
    else:
        node = ctx.create_node("echo")
        t = REGISTRY[a.type]
        pub = node.create_publisher(t, "/pong", qos)
        node.create_subscription(t, "/ping", pub.publish, qos)
    ex.add_node(node)
    print("READY", ctx.transport.zid, flush=True)
    threading.Thread(target=exit_with_parent, daemon=True).start()
    try:
        ex.spin()               # as rclpy.spin(node): until the context shuts down
    except KeyboardInterrupt:
        pass
    ctx.try_shutdown()
    return 0


def _fibonacci_server(node, period):
    from robocourse.bus.action import ActionServer, CancelResponse
    from robocourse.msgs.example_interfaces import Fibonacci

    async def execute(goal_handle):
        seq = [0, 1]
        for i in range(1, goal_handle.request.order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                return Fibonacci.Result(sequence=seq)
            seq.append(seq[i] + seq[i - 1])
            goal_handle.publish_feedback(Fibonacci.Feedback(sequence=seq))
            await node.sleep_async(period)
        goal_handle.succeed()
        return Fibonacci.Result(sequence=seq)

    return ActionServer(node, Fibonacci, "/fibonacci", execute,
                        cancel_callback=lambda _goal: CancelResponse.ACCEPT)




if __name__ == "__main__":
    sys.exit(main())
