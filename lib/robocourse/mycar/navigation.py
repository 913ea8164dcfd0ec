"""``/navigate_to_pose``: the seed's NavigationActionServer, really driving the car.

rclpy counterpart: an ``ActionServer`` whose execute callback is a coroutine: every control
step it reads the latest /odom, publishes /cmd_vel (turn towards the target, then drive, then
turn to the target heading), publishes ``percent_complete`` feedback and ``await``s the next
step, so a single-threaded executor (and simulated time) keeps running the driver, the
watchdog and cancel requests meanwhile. Goals with NaN/inf, a zero quaternion or farther than
``max_distance`` are rejected (the reason is logged and kept in ``rejections``: ROS goal
responses carry no text); cancel stops the car and returns ``canceled``; the goal is aborted
(the car stopped, the reason logged and in the result's message) after ``timeout``, or when
odometry has shown no motion for ``stall_timeout`` (a stuck car, a driver that died).

Frames, as Nav2 treats them: the goal's ``header.frame_id`` says which frame the pose is in.
A goal in ``odom`` is driven as is; a goal in another frame is transformed into ``odom`` with
the latest transforms heard on ``/tf`` and ``/tf_static`` (:mod:`robocourse.mycar.tf2`, a
planar tf2 buffer), and rejected with the reason when no chain exists (an empty frame_id is rejected too: tf2 refuses
empty frame ids). Success is judged by odometry, the only pose the robot has; the result also
reports how far the true pose (``/ground_truth``, the simulator's chassis pose in ``world``,
whose origin is where odometry started) is from the goal, so odometry drift is visible.
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
from .tf2 import Buffer, TransformException, TransformListener, compose

_PARAMS = {
    "goal_tolerance": (0.05, 0.005, 1.0, "position tolerance [m]"),
    "yaw_tolerance": (0.1, 0.01, 1.0, "final heading tolerance [rad]"),
    "max_distance": (5.0, 0.1, 100.0, "goals farther than this from the car are rejected [m]"),
    "timeout": (30.0, 0.1, 600.0, "abort a goal after this long [s]"),
    "stall_timeout": (3.0, 0.1, 600.0, "abort when odometry shows no motion for this long [s]"),
    "max_linear": (0.3, 0.01, 5.0, "top driving speed [m/s]"),
    "max_angular": (2.0, 0.1, 20.0, "top turning rate [rad/s]"),
    "control_rate": (20.0, 1.0, 200.0, "control steps per second [Hz]"),
}


ODOM_FRAME = "odom"


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
        self.truth: tuple[float, float, float] | None = None
        self.rejections: list[str] = []
        self.results: list = []  # every Result returned, in order (for the chapter's drift table)
        self.tf = Buffer(logger=self.get_logger())
        self.tf_listener = TransformListener(self.tf, self)
        self.create_subscription(Odometry, "/odom", self.on_odom, QOS_ODOM)
        self.create_subscription(Odometry, "/ground_truth", self.on_truth, QOS_ODOM)
        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", QOS_CMD_VEL)
        self.server = ActionServer(self, NavigateToPose, "/navigate_to_pose", self.execute,
                                   goal_callback=self.on_goal, cancel_callback=self.on_cancel)

    def p(self, name):
        return self.get_parameter(name).value

    def on_odom(self, msg: Odometry) -> None:
        o = msg.pose.pose.orientation
        self.pose = (msg.pose.pose.position.x, msg.pose.pose.position.y, kin.quaternion_to_yaw(o.x, o.y, o.z, o.w))

    def on_truth(self, msg: Odometry) -> None:
        o = msg.pose.pose.orientation
        self.truth = (msg.pose.pose.position.x, msg.pose.pose.position.y, kin.quaternion_to_yaw(o.x, o.y, o.z, o.w))

    def goal_in_odom(self, target_pose):
        """(x, y, yaw) of the goal in the odom frame, or the reason it cannot be had (a str)."""
        frame = target_pose.header.frame_id.lstrip("/")
        if not frame:
            return (f"target_pose.header.frame_id is empty: say which frame the pose is in "
                    f"(frame_id='{ODOM_FRAME}' for odometry coordinates)")
        p, q = target_pose.pose.position, target_pose.pose.orientation
        pose = (p.x, p.y, kin.quaternion_to_yaw(q.x, q.y, q.z, q.w))
        if frame == ODOM_FRAME:
            return pose
        try:
            tf = self.tf.lookup_transform(ODOM_FRAME, frame)   # the latest transform, as Nav2 does for a goal
        except TransformException as err:
            known = ", ".join(self.tf.all_frames()) or "none"
            return (f"goal is in frame '{frame}', and no transform {ODOM_FRAME} <- {frame} is on /tf or /tf_static "
                    f"(frames heard: {known}; tf2 says: {err}); send it in '{ODOM_FRAME}' or publish the "
                    f"{frame} -> {ODOM_FRAME} transform (a localisation node does)")
        return compose(tf, pose)

    def on_goal(self, goal_request) -> GoalResponse:
        reason = check_goal(goal_request.target_pose, max_distance=math.inf)  # NaN, zero quaternion
        if not reason:
            where = self.goal_in_odom(goal_request.target_pose)
            if isinstance(where, str):
                reason = where
            else:
                x, y = self.pose[:2] if self.pose else (0.0, 0.0)
                d = math.hypot(where[0] - x, where[1] - y)
                if d > self.p("max_distance"):
                    reason = (f"target is {d:.2f} m away in {ODOM_FRAME}, beyond max_distance "
                              f"{self.p('max_distance')} m: unreachable")
        if reason:
            self.rejections.append(reason)
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_cancel(self, cancel_request) -> CancelResponse:
        return CancelResponse.ACCEPT

    def _done(self, result):
        self.results.append(result)
        return result

    def stop(self) -> None:
        self.cmd_pub.publish(Twist())

    async def execute(self, goal_handle):
        result = NavigateToPose.Result(position_error=math.nan, true_position_error=math.nan)
        where = self.goal_in_odom(goal_handle.request.target_pose)
        if isinstance(where, str):  # the transform vanished between acceptance and execution
            goal_handle.abort()
            result.success, result.message = False, where
            return self._done(result)
        gx, gy, gyaw = where
        clock = self.get_clock()
        start = clock.now().nanoseconds
        step = 1.0 / self.p("control_rate")
        d0 = None
        moved_at, moved_pose = start, self.pose   # the last time odometry showed motion, and where
        while True:
            if goal_handle.is_cancel_requested:
                self.stop()
                goal_handle.canceled()
                result.success, result.message = False, "canceled"
                return self._done(result)
            now = clock.now().nanoseconds
            elapsed = (now - start) * 1e-9
            if self.pose is not None and (moved_pose is None or math.hypot(
                    self.pose[0] - moved_pose[0], self.pose[1] - moved_pose[1]) > 0.01
                    or abs(kin.wrap_angle(self.pose[2] - moved_pose[2])) > 0.05):
                moved_at, moved_pose = now, self.pose
            reason = None
            if elapsed > self.p("timeout"):
                reason = f"timeout: not there after {self.p('timeout'):g} s"
            elif (now - moved_at) * 1e-9 > self.p("stall_timeout"):
                reason = (f"stalled: odometry shows no motion for {self.p('stall_timeout'):g} s (the car is stuck, or "
                          "the driver stopped publishing /odom)")
            if reason:
                self.stop()
                goal_handle.abort()
                result.success, result.message = False, reason
                self.get_logger().warning(f"goal aborted: {reason}")
                return self._done(result)
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
                    result.position_error = dist
                    truth = "no /ground_truth"
                    if self.truth is not None:
                        result.true_position_error = math.hypot(gx - self.truth[0], gy - self.truth[1])
                        truth = f"true pose {result.true_position_error * 100:.1f} cm from the goal"
                    result.message = (f"reached ({x:.3f}, {y:.3f}, {yaw:.3f}) by odometry ({dist * 100:.1f} cm "
                                      f"from the goal) in {elapsed:.2f} s; {truth}")
                    self.get_logger().info(result.message)
                    return self._done(result)
                cmd.angular.z = max(-self.p("max_angular"), min(self.p("max_angular"), 3.0 * yaw_err))
            self.cmd_pub.publish(cmd)
            fb = NavigateToPose.Feedback()
            progress = 100.0 * (1.0 - dist / d0) if d0 > 1e-9 else 100.0
            fb.percent_complete = float(min(100.0, max(0.0, progress)))  # turning may first move it away
            goal_handle.publish_feedback(fb)
            await self.sleep_async(step)
