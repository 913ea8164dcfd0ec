"""``/navigate_to_pose``: the seed's NavigationActionServer, really driving the car.

rclpy counterpart: an ``ActionServer`` whose execute callback is a coroutine: every control
step it reads the latest /odom, publishes /cmd_vel (turn towards the target, then drive, then
turn to the target heading), publishes ``percent_complete`` feedback and ``await``s the next
step, so a single-threaded executor (and simulated time) keeps running the driver, the
watchdog and cancel requests meanwhile. Goals with NaN/inf, a zero quaternion or farther than
``max_distance`` are rejected (the reason is logged: ROS goal responses carry no text);
cancel stops the car and returns ``canceled``; ``timeout`` aborts.
"""

from __future__ import annotations

import math

from robocourse.bus import Node
from robocourse.bus.action import ActionServer, CancelResponse, GoalResponse
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.nav_msgs import Odometry

from . import kinematics as kin
from .msgs import NavigateToPose
from .nodes import QOS_CMD_VEL, QOS_ODOM, declare_ranged

_PARAMS = {
    "goal_tolerance": (0.05, 0.005, 1.0, "position tolerance [m]"),
    "yaw_tolerance": (0.1, 0.01, 1.0, "final heading tolerance [rad]"),
    "max_distance": (5.0, 0.1, 100.0, "goals farther than this from the car are rejected [m]"),
    "timeout": (30.0, 0.1, 600.0, "abort a goal after this long [s]"),
    "max_linear": (0.3, 0.01, 5.0, "top driving speed [m/s]"),
    "max_angular": (2.0, 0.1, 20.0, "top turning rate [rad/s]"),
    "control_rate": (20.0, 1.0, 200.0, "control steps per second [Hz]"),
}


def check_goal(target_pose, current=(0.0, 0.0, 0.0), max_distance: float = 5.0) -> str | None:
    """Why a goal must be rejected, or None. ``target_pose`` is a geometry_msgs/PoseStamped."""
    p, q = target_pose.pose.position, target_pose.pose.orientation
    values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values):
        return f"target pose has NaN or inf values {values}"
    if math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) < 1e-6:
        return "target orientation is a zero quaternion; use w=1 for 'no rotation'"
    d = math.hypot(p.x - current[0], p.y - current[1])
    if d > max_distance:
        return f"target is {d:.2f} m away, beyond max_distance {max_distance} m: unreachable"
    return None


class NavigationActionServer(Node):
    def __init__(self, name: str = "navigation_server", **kwargs):
        super().__init__(name, **kwargs)
        declare_ranged(self, _PARAMS)
        self.pose: tuple[float, float, float] | None = None
        self.rejections: list[str] = []
        self.create_subscription(Odometry, "/odom", self.on_odom, QOS_ODOM)
        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", QOS_CMD_VEL)
        self.server = ActionServer(self, NavigateToPose, "/navigate_to_pose", self.execute,
                                   goal_callback=self.on_goal, cancel_callback=self.on_cancel)

    def p(self, name):
        return self.get_parameter(name).value

    def on_odom(self, msg: Odometry) -> None:
        o = msg.pose.pose.orientation
        self.pose = (msg.pose.pose.position.x, msg.pose.pose.position.y, kin.quaternion_to_yaw(o.x, o.y, o.z, o.w))

    def on_goal(self, goal_request) -> GoalResponse:
        reason = check_goal(goal_request.target_pose, self.pose or (0.0, 0.0, 0.0), self.p("max_distance"))
        if reason:
            self.rejections.append(reason)
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_cancel(self, cancel_request) -> CancelResponse:
        return CancelResponse.ACCEPT

    def stop(self) -> None:
        self.cmd_pub.publish(Twist())

    async def execute(self, goal_handle):
        target = goal_handle.request.target_pose.pose
        q = target.orientation
        gx, gy, gyaw = target.position.x, target.position.y, kin.quaternion_to_yaw(q.x, q.y, q.z, q.w)
        result = NavigateToPose.Result()
        clock = self.get_clock()
        start = clock.now().nanoseconds
        step = 1.0 / self.p("control_rate")
        d0 = None
        while True:
            if goal_handle.is_cancel_requested:
                self.stop()
                goal_handle.canceled()
                result.success, result.message = False, "canceled"
                return result
            elapsed = (clock.now().nanoseconds - start) * 1e-9
            if elapsed > self.p("timeout"):
                self.stop()
                goal_handle.abort()
                result.success, result.message = False, f"timeout: not there after {self.p('timeout'):g} s"
                return result
            if self.pose is None:  # no odometry yet
                await self.sleep_async(step)
                continue
            x, y, yaw = self.pose
            dist = math.hypot(gx - x, gy - y)
            d0 = dist if d0 is None else d0
            cmd = Twist()
            if dist > self.p("goal_tolerance"):
                heading = kin.wrap_angle(math.atan2(gy - y, gx - x) - yaw)
                cmd.angular.z = max(-self.p("max_angular"), min(self.p("max_angular"), 3.0 * heading))
                if abs(heading) < 0.5:  # roughly facing it: drive, slowing down near the goal
                    cmd.linear.x = min(self.p("max_linear"), 1.5 * dist) * math.cos(heading)
            else:
                yaw_err = kin.wrap_angle(gyaw - yaw)
                if abs(yaw_err) <= self.p("yaw_tolerance"):
                    self.stop()
                    done = NavigateToPose.Feedback()
                    done.percent_complete = 100.0
                    goal_handle.publish_feedback(done)
                    goal_handle.succeed()
                    result.success = True
                    result.message = f"reached ({x:.3f}, {y:.3f}, {yaw:.3f}) in {elapsed:.2f} s"
                    return result
                cmd.angular.z = max(-self.p("max_angular"), min(self.p("max_angular"), 3.0 * yaw_err))
            self.cmd_pub.publish(cmd)
            fb = NavigateToPose.Feedback()
            progress = 100.0 * (1.0 - dist / d0) if d0 > 1e-9 else 100.0
            fb.percent_complete = float(min(100.0, max(0.0, progress)))  # turning may first move it away
            goal_handle.publish_feedback(fb)
            await self.sleep_async(step)
