"""The scripted mission of ``robocourse mycar demo`` (and the chapter's walkthrough).

Drive with /cmd_vel, turn LED 1 on (and try LED 7), navigate to two poses (the second is
cancelled half-way), stop, all recorded to MCAP, printing what ``ros2 topic/service/action``
would print. Runs in simulated time: deterministic, a few seconds of wall time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from robocourse.bus import introspection
from robocourse.bus.action import ActionClient
from robocourse.msgs.geometry_msgs import Twist

from .launch import launch
from .msgs import NavigateToPose, SetLed


@dataclass
class MissionReport:
    led_ok: bool = False
    led_invalid_ok: bool = True
    goals: list = field(default_factory=list)  # (target, status name, message)
    odom_published: int = 0
    recording: str | None = None
    final_truth: tuple | None = None
    final_odom: tuple | None = None
    watchdog_trips: int = 0


def goal_for(x: float, y: float, yaw: float = 0.0):
    g = NavigateToPose.Goal()
    g.target_pose.header.frame_id = "odom"
    g.target_pose.pose.position.x, g.target_pose.pose.position.y = float(x), float(y)
    g.target_pose.pose.orientation.z, g.target_pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return g


def run_mission(record_path: str | None = None, quiet: bool = False, config=None) -> MissionReport:
    from robocourse.bus.action import STATUS_NAMES
    from robocourse.bus.recording import record

    car = launch(**({"config": config} if config else {}))
    ctx, ex = car.context, car.executor
    rep = MissionReport()
    recorder = record(ctx, record_path, ["/odom", "/cmd_vel", "/ground_truth", "/diagnostics"], executor=ex) \
        if record_path else None
    say = (lambda *a: None) if quiet else print
    node = ctx.create_node("mission")
    ex.add_node(node)

    say("$ ros2 node list")
    introspection.node_list(ctx, quiet=quiet)
    say("\n$ ros2 topic list -t")
    introspection.topic_list(ctx, quiet=quiet)

    say("\n# 1. drive: 0.2 m/s with 0.5 rad/s for 2 s (10 Hz /cmd_vel), then let the watchdog stop it")
    pub = node.create_publisher(Twist, "/cmd_vel", 10)
    tw = Twist()
    tw.linear.x, tw.angular.z = 0.2, 0.5
    for _ in range(20):
        pub.publish(tw)
        ex.spin_for(0.1)
    ex.spin_for(0.5)
    say("\n$ ros2 topic hz /odom")
    introspection.topic_hz(ctx, "/odom", ex, duration=1.0, quiet=quiet)

    say("\n# 2. $ ros2 service call /set_led mycar_msgs/srv/SetLed \"{led_id: 1, state: true}\"")
    resp = introspection.service_call(ctx, "/set_led", SetLed, {"led_id": 1, "state": True}, ex, quiet=quiet)
    rep.led_ok = bool(resp and resp.success)
    say("\n# and an LED that does not exist")
    resp = introspection.service_call(ctx, "/set_led", SetLed, {"led_id": 7, "state": True}, ex, quiet=quiet)
    rep.led_invalid_ok = bool(resp and resp.success)

    say("\n# 3. $ ros2 action send_goal /navigate_to_pose mycar_msgs/action/NavigateToPose ... --feedback")
    target = {"target_pose": {"header": {"frame_id": "odom"}, "pose": {"position": {"x": 1.0, "y": 0.6}, "orientation": {"w": 1.0}}}}
    status, result, fbs = introspection.action_send_goal(ctx, "/navigate_to_pose", NavigateToPose, target, ex,
                                                         feedback=False, quiet=quiet)
    rep.goals.append(((1.0, 0.6), STATUS_NAMES.get(status, str(status)), result.message if result else ""))
    say(f"({len(fbs)} feedback messages, last percent_complete {fbs[-1].percent_complete:.1f})" if fbs else "")

    say("\n# 4. a second goal, cancelled after 1 s")
    client = ActionClient(node, NavigateToPose, "/navigate_to_pose")
    fut = client.send_goal_async(goal_for(0.0, 0.0, math.pi))
    ex.spin_until_future_complete(fut, 5.0)
    handle = fut.result()
    ex.spin_for(1.0)
    cancel = handle.cancel_goal_async()
    ex.spin_until_future_complete(cancel, 5.0)
    rf = handle.get_result_async()
    ex.spin_until_future_complete(rf, 5.0)
    res = rf.result()
    rep.goals.append(((0.0, 0.0), STATUS_NAMES.get(res.status, str(res.status)), res.result.message))
    say(f"Result: {STATUS_NAMES.get(res.status)} ({res.result.message})")
    ex.spin_for(0.5)

    say("\n$ ros2 action info /navigate_to_pose")
    introspection.action_info(ctx, "/navigate_to_pose", quiet=quiet)
    rep.odom_published = car.driver.odom_published
    rep.watchdog_trips = car.driver.watchdog_trips
    rep.final_odom = car.driver.pose
    rep.final_truth = car.simulator.car.pose() if car.simulator else None
    if recorder:
        rep.recording = recorder.close()
        say(f"\nrecorded /odom, /cmd_vel, /ground_truth, /diagnostics to {rep.recording}")
    ctx.try_shutdown()
    return rep
