"""``/navigate_to_pose``: the seed's NavigationActionServer, really driving the car.

rclpy counterpart: an ``ActionServer`` whose execute callback is a coroutine: every control
step it reads the latest /odom, publishes /cmd_vel (turn towards the target, then drive, then
turn to the target heading), publishes ``percent_complete`` feedback and ``await``s the next
step, so a single-threaded executor (and simulated time) keeps running the driver, the
watchdog and cancel requests meanwhile. Goals with NaN/inf, a zero quaternion or farther than
``max_distance`` are rejected (the reason is logged and kept in ``rejections``: ROS goal
responses carry no text); cancel stops the car and returns ``canceled``; ``timeout`` aborts.

Frames, as Nav2 treats them: the goal's ``header.frame_id`` says which frame the pose is in.
A goal in ``odom`` is driven as is; a goal in another frame is transformed into ``odom`` with
the transforms heard on ``/tf`` and ``/tf_static`` (a chain of any length, 2D: x, y, yaw), and
rejected with the reason when no chain exists (an empty frame_id is rejected too: tf2 refuses
empty frame ids). Success is judged by odometry, the only pose the robot has; the result also
reports how far the true pose (``/ground_truth``, the simulator's chassis pose in ``world``,
whose origin is where odometry started) is from the goal, so odometry drift is visible.
"""

from __future__ import annotations

import math

from robocourse.bus import DurabilityPolicy, Node, QoSProfile
from robocourse.bus.action import ActionServer, CancelResponse, GoalResponse
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.nav_msgs import Odometry
from robocourse.msgs.tf2_msgs import TFMessage

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


ODOM_FRAME = "odom"


def compose(a, b):
    """2D transform a * b: (x, y, yaw) of frame c in frame p, from a = T_p_q and b = T_q_c."""
    ax, ay, ayaw = a
    bx, by, byaw = b
    c, s = math.cos(ayaw), math.sin(ayaw)
    return ax + c * bx - s * by, ay + s * bx + c * by, kin.wrap_angle(ayaw + byaw)


def invert(a):
    """The 2D transform T_q_p from a = T_p_q."""
    x, y, yaw = a
    c, s = math.cos(yaw), math.sin(yaw)
    return -c * x - s * y, s * x - c * y, kin.wrap_angle(-yaw)


class TfBuffer2D:
    """The latest transform per (parent, child) from /tf and /tf_static, looked up along chains.

    A planar cut of tf2's BufferCore: no time travel (the latest transform of each edge is used),
    and only x, y and yaw (MyCar drives on a floor).
    """

    def __init__(self):
        self.edges: dict[tuple[str, str], tuple[float, float, float]] = {}

    def add(self, msg: TFMessage) -> None:
        for t in msg.transforms:
            r, p = t.transform.rotation, t.transform.translation
            self.edges[(t.header.frame_id, t.child_frame_id)] = (p.x, p.y, kin.quaternion_to_yaw(r.x, r.y, r.z, r.w))

    def frames(self) -> list[str]:
        return sorted({f for edge in self.edges for f in edge})

    def lookup(self, target: str, source: str):
        """T_target_source (a pose in ``source`` mapped into ``target``), or None without a chain."""
        if target == source:
            return (0.0, 0.0, 0.0)
        known = {target: (0.0, 0.0, 0.0)}
        todo = [target]
        while todo:
            frame = todo.pop(0)
            for (parent, child), tf in self.edges.items():
                if parent == frame and child not in known:
                    known[child] = compose(known[frame], tf)
                    todo.append(child)
                elif child == frame and parent not in known:
                    known[parent] = compose(known[frame], invert(tf))
                    todo.append(parent)
            if source in known:
                return known[source]
        return None


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
        self.tf = TfBuffer2D()
        self.create_subscription(Odometry, "/odom", self.on_odom, QOS_ODOM)
        self.create_subscription(Odometry, "/ground_truth", self.on_truth, QOS_ODOM)
        self.create_subscription(TFMessage, "/tf", self.tf.add, 100)
        self.create_subscription(TFMessage, "/tf_static", self.tf.add, QoSProfile(
            depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL))
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
        tf = self.tf.lookup(ODOM_FRAME, frame)
        if tf is None:
            known = ", ".join(self.tf.frames()) or "none"
            return (f"goal is in frame '{frame}', and no transform {ODOM_FRAME} <- {frame} is on /tf or /tf_static "
                    f"(frames heard: {known}); send it in '{ODOM_FRAME}' or publish the {frame} -> {ODOM_FRAME} "
                    "transform (a localisation node does)")
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
        while True:
            if goal_handle.is_cancel_requested:
                self.stop()
                goal_handle.canceled()
                result.success, result.message = False, "canceled"
                return self._done(result)
            elapsed = (clock.now().nanoseconds - start) * 1e-9
            if elapsed > self.p("timeout"):
                self.stop()
                goal_handle.abort()
                result.success, result.message = False, f"timeout: not there after {self.p('timeout'):g} s"
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
