"""Chapter 3's checks pass right answers and explain the usual wrong ones."""

from __future__ import annotations

import math

import numpy as np

from robocourse.bus import Node, QoSProfile, ReliabilityPolicy
from robocourse.bus.action import ActionServer, CancelResponse, GoalResponse
from robocourse.grading.checks import get, run_check
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.nav_msgs import Odometry
from robocourse.msgs.std_msgs import Float64MultiArray
from robocourse.mycar import checks
from robocourse.mycar.msgs import NavigateToPose, SetLed


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


class Dog:
    def __init__(self, timeout, once=True):
        self.timeout, self.last, self.stopped, self.once = timeout, None, False, once

    def feed(self, t):
        self.last, self.stopped = t, False

    def update(self, t):
        if self.last is None or (self.stopped and self.once):
            return False
        if t - self.last > self.timeout:
            self.stopped = True
            return True
        return False


def test_watchdog_check():
    for seed in range(4):
        assert "trips once" in run("ch03.watchdog", Dog, seed=seed).message
    assert "report the trip once" in run("ch03.watchdog", lambda t: Dog(t, once=False)).message


class EagerDog(Dog):
    def update(self, t):
        if self.last is not None and not self.stopped and t - self.last >= self.timeout:
            self.stopped = True
            return True
        return False


def test_watchdog_tripping_at_exactly_the_timeout_is_named():
    r = run("ch03.watchdog", EagerDog, seed=1)
    assert r.points == 0 and "not at exactly the timeout" in r.message


def test_quiz_check():
    right = {f: a for f, (a, _) in checks.QUIZ.items()}
    assert run("ch03.quiz", lambda: right).message == "10/10"
    wrong = dict(right, **{"camera images": "service", "battery voltage": "action"})
    lines = run("ch03.quiz", lambda: wrong).message.splitlines()
    assert lines[0] == "8/10 right." and any("camera images" in m for m in lines) and len(lines) == 3
    assert "missing" in run("ch03.quiz", lambda: {}).message


def test_quiz_feedback_never_reveals_an_answer():
    right = {f: a for f, (a, _) in checks.QUIZ.items()}
    rotate = {"topic": "service", "service": "action", "action": "topic"}
    all_wrong = {f: rotate[a] for f, a in right.items()}
    r = run("ch03.quiz", lambda: all_wrong)
    assert r.points == 0 and r.message.splitlines()[0] == "0/10 right."
    for feature, answer in right.items():
        assert feature in r.message
        # the only place a kind is named is the fixed list of questions, the same for every feature
        assert f"{feature!r} is a" not in r.message and f"{feature}: {answer}" not in r.message
    assert r.message.count("(topic)") == r.message.count("(service)") == r.message.count("(action)") == 1
    for why in (w for _, w in checks.QUIZ.values()):
        assert why not in r.message
    typo = dict(right, **{"camera image": "topic"})
    assert "copy the names exactly" in run("ch03.quiz", lambda: typo).message


# ---------------------------------------------------------------- the node exercises, on the bus
# Reference answers (this file is instructor-only: release excludes tests/test_*_checks.py).


class DriveNode(Node):
    def __init__(self, **kwargs):
        super().__init__("drive_node", **kwargs)
        self.declare_parameter("wheel_base", 0.15)
        self.declare_parameter("publish_rate", 50.0)
        self.v = self.w = 0.0
        self.x, self.y, self.yaw = 0.0, 0.0, 0.0
        self.wheels_out = self.create_publisher(Float64MultiArray, "/wheel_speeds", 10)
        self.odom_out = self.create_publisher(Odometry, "/odom", 10)
        self.create_subscription(Twist, "/cmd_vel", self.on_cmd_vel, 10)
        self.t_last = self.get_clock().now().nanoseconds
        self.create_timer(1.0 / self.get_parameter("publish_rate").value, self.on_timer)

    def on_cmd_vel(self, msg):
        lin, ang = msg.linear.x, msg.angular.z
        if not all(map(math.isfinite, (lin, ang))):
            self.get_logger().error(f"ignoring /cmd_vel with v={lin}, w={ang}")
            return
        self.v, self.w = lin, ang
        half = self.get_parameter("wheel_base").value / 2
        self.wheels_out.publish(Float64MultiArray(data=[lin - ang * half, lin + ang * half]))

    def on_timer(self):
        stamp_ns = self.get_clock().now().nanoseconds
        dt, self.t_last = (stamp_ns - self.t_last) * 1e-9, stamp_ns
        heading = self.yaw + self.w * dt / 2  # midpoint heading over the tick
        self.x += self.v * math.cos(heading) * dt
        self.y += self.v * math.sin(heading) * dt
        self.yaw += self.w * dt
        out = Odometry()
        out.header.stamp.sec, out.header.stamp.nanosec = divmod(stamp_ns, 10**9)
        out.header.frame_id, out.child_frame_id = "odom", "base_link"
        out.pose.pose.position.x, out.pose.pose.position.y = self.x, self.y
        out.pose.pose.orientation.z = math.sin(self.yaw / 2)
        out.pose.pose.orientation.w = math.cos(self.yaw / 2)
        out.twist.twist.linear.x, out.twist.twist.angular.z = self.v, self.w
        self.odom_out.publish(out)


class LedServer(Node):
    def __init__(self, **kwargs):
        super().__init__("led_server", **kwargs)
        self.declare_parameter("led_count", 2)
        n = self.get_parameter("led_count").value
        self.leds = dict.fromkeys(range(1, n + 1), False)
        self.create_service(SetLed, "/set_led", callback=self.on_set_led)

    def on_set_led(self, request, response):
        response.success = request.led_id in self.leds
        if response.success:
            self.leds[request.led_id] = request.state
        else:
            self.get_logger().warning(f"no LED {request.led_id}: this car has LEDs 1..{len(self.leds)}")
        return response


STEP = 0.05  # s between control steps


class NavigationServer(Node):
    def __init__(self, **kwargs):
        super().__init__("navigation_server", **kwargs)
        self.pose = None
        self.create_subscription(Odometry, "/odom", self.on_odom, QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.cmd_out = self.create_publisher(Twist, "/cmd_vel", 10)
        ActionServer(self, NavigateToPose, "/navigate_to_pose", execute_callback=self.execute,
                     goal_callback=self.on_goal, cancel_callback=lambda request: CancelResponse.ACCEPT)

    def on_odom(self, msg):
        quat = msg.pose.pose.orientation
        self.pose = (msg.pose.pose.position.x, msg.pose.pose.position.y, 2 * math.atan2(quat.z, quat.w))

    def on_goal(self, goal_request):
        frame = goal_request.target_pose.header.frame_id
        where = goal_request.target_pose.pose.position
        if frame != "odom":
            self.get_logger().warning(f"rejected: goal in frame {frame!r}, I drive in 'odom'")
            return GoalResponse.REJECT
        if not all(map(math.isfinite, (where.x, where.y))):
            self.get_logger().warning(f"rejected: goal ({where.x}, {where.y}) is not finite")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    async def execute(self, goal_handle):
        def finish(transition, **fields):  # stop the car, end the goal, build its result
            self.cmd_out.publish(Twist())
            transition()
            return NavigateToPose.Result(**fields)

        p = goal_handle.request.target_pose.pose.position
        start = None
        while True:
            if goal_handle.is_cancel_requested:
                return finish(goal_handle.canceled, success=False, message="cancelled by the client")
            if self.pose is not None:
                px, py, heading = self.pose
                left = math.hypot(p.x - px, p.y - py)
                start = left if start is None else start
                progress = NavigateToPose.Feedback()
                progress.percent_complete = 100.0 * max(0.0, 1.0 - left / start) if start > 0 else 100.0
                goal_handle.publish_feedback(progress)
                if left < 0.04:
                    return finish(goal_handle.succeed, success=True, message=f"{left * 100:.1f} cm from the goal",
                                  position_error=left)
                turn = math.remainder(math.atan2(p.y - py, p.x - px) - heading, 2 * math.pi)
                drive = Twist()
                drive.angular.z = max(-2.0, min(2.0, 4.0 * turn))
                if abs(turn) < 0.4:
                    drive.linear.x = min(0.3, 1.0 * left)
                self.cmd_out.publish(drive)
            await self.sleep_async(STEP)


SEEDS = (0, 1, 2)


def test_right_nodes_score_full_marks_on_several_seeds():
    for seed in SEEDS:
        for name, cls in (("ch03.drive_node", DriveNode), ("ch03.led_service", LedServer),
                          ("ch03.navigation_action", NavigationServer)):
            r = run(name, cls, seed=seed)
            assert r.passed and r.points == r.weight, (name, seed, r.message)


class SwappedWheels(DriveNode):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        real = self.wheels_out.publish
        self.wheels_out.publish = lambda m: real(Float64MultiArray(data=list(m.data)[::-1]))


class NoNanGuard(DriveNode):
    def on_cmd_vel(self, msg):
        self.v, self.w = msg.linear.x, msg.angular.z
        half = self.get_parameter("wheel_base").value / 2
        self.wheels_out.publish(Float64MultiArray(data=[self.v - self.w * half, self.v + self.w * half]))


class FixedWheelBase(DriveNode):
    def on_cmd_vel(self, msg):
        v, w = msg.linear.x, msg.angular.z
        if math.isfinite(v):
            self.v, self.w = v, w
            self.wheels_out.publish(Float64MultiArray(data=[v - w * 0.075, v + w * 0.075]))


class YawIgnored(DriveNode):
    def on_timer(self):
        self.w_saved = self.w
        self.w = 0.0  # integrates as if never turning
        super().on_timer()
        self.w = self.w_saved


def test_drive_node_wrong_attempts_get_zero_and_the_reason():
    r = run("ch03.drive_node", SwappedWheels)
    assert r.points == 0 and "left and right swapped" in r.message
    r = run("ch03.drive_node", NoNanGuard)
    assert r.points == 0 and "NaN" in r.message and "ignored" in r.message
    r = run("ch03.drive_node", FixedWheelBase, seed=1)
    assert r.points == 0 and "wheel_base parameter" in r.message
    r = run("ch03.drive_node", YawIgnored)
    assert r.points == 0 and "integrating the commands gives" in r.message
    r = run("ch03.drive_node", DriverNodeLike)
    assert r.points == 0 and r.reason == "delegated"


class DriverNodeLike(DriveNode):
    """Hands the formula to the library: delegation earns nothing."""

    def on_cmd_vel(self, msg):
        from robocourse.mycar.kinematics import DiffDriveGeometry, twist_to_wheel_speeds

        self.v, self.w = msg.linear.x, msg.angular.z
        if math.isfinite(self.v):
            g = DiffDriveGeometry(wheel_base=self.get_parameter("wheel_base").value)
            self.wheels_out.publish(Float64MultiArray(data=list(twist_to_wheel_speeds(self.v, self.w, g))))


class TwoLedsOnly(LedServer):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.leds = {1: False, 2: False}


class RaisesOnBadId(LedServer):
    def on_set_led(self, request, response):
        self.leds[request.led_id]  # KeyError for an unknown id
        return super().on_set_led(request, response)


class SilentLed(LedServer):
    def on_set_led(self, request, response):
        response.success = request.led_id in self.leds
        if response.success:
            self.leds[request.led_id] = request.state
        return response


def test_led_service_wrong_attempts_get_zero_and_the_reason():
    r = run("ch03.led_service", TwoLedsOnly, seed=0)
    assert r.points == 0 and "read the led_count parameter" in r.message
    r = run("ch03.led_service", RaisesOnBadId)
    assert r.points == 0 and "raised" in r.message and "success=False instead" in r.message
    r = run("ch03.led_service", SilentLed)
    assert r.points == 0 and "warnings" in r.message


class DefaultCancel(NavigationServer):
    """ActionServer's default cancel_callback rejects every cancel (rclpy's default)."""

    def __init__(self, **kwargs):
        Node.__init__(self, "navigation_server", **kwargs)
        self.pose = None
        self.create_subscription(Odometry, "/odom", self.on_odom, QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.cmd_out = self.create_publisher(Twist, "/cmd_vel", 10)
        ActionServer(self, NavigateToPose, "/navigate_to_pose", self.execute, goal_callback=self.on_goal)


class AnyFrame(NavigationServer):
    def on_goal(self, goal_request):
        return GoalResponse.ACCEPT if math.isfinite(goal_request.target_pose.pose.position.x) else GoalResponse.REJECT


class ReliableOdom(NavigationServer):
    def __init__(self, **kwargs):
        Node.__init__(self, "navigation_server", **kwargs)
        self.pose = None
        self.create_subscription(Odometry, "/odom", self.on_odom, 10)
        self.cmd_out = self.create_publisher(Twist, "/cmd_vel", 10)
        ActionServer(self, NavigateToPose, "/navigate_to_pose", self.execute, goal_callback=self.on_goal,
                     cancel_callback=lambda request: CancelResponse.ACCEPT)


def test_navigation_wrong_attempts_get_zero_and_the_reason():
    r = run("ch03.navigation_action", DefaultCancel)
    assert r.points == 0 and "default cancel_callback rejects" in r.message
    r = run("ch03.navigation_action", AnyFrame)
    assert r.points == 0 and "'map'" in r.message and "was accepted" in r.message
    r = run("ch03.navigation_action", ReliableOdom)
    assert r.points == 0 and "QoS mismatch" in r.message and "BEST_EFFORT" in r.message


def test_node_checks_survive_a_constructor_that_raises():
    class Broken(Node):
        def __init__(self, **kwargs):
            raise RuntimeError("forgot super().__init__")

    for name in ("ch03.drive_node", "ch03.led_service", "ch03.navigation_action"):
        r = run(name, Broken)
        assert r.points == 0 and r.reason == "raised" and "forgot super" in r.message
