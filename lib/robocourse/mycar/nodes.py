"""MyCar's nodes: the motor driver (with odometry, TF, diagnostics, watchdog), the simulator,
and the LED service (the seed's DriverNode, LedServiceServer, plus a MuJoCo world).

Topics and QoS as in the seed: ``/cmd_vel`` geometry_msgs/Twist RELIABLE VOLATILE (depth 10);
``/odom`` nav_msgs/Odometry BEST_EFFORT at ``odom_rate_hz`` (50); ``/tf`` odom -> base_link;
``/diagnostics`` at 1 Hz. The watchdog stops the motors when no /cmd_vel arrived for
``watchdog_timeout`` (0.2 s), logs it once, and motion resumes with the next command.
Calibration and limits as diff_drive_controller's: ``wheel_separation_multiplier`` scales the
wheel base odometry and the drive formula use; ``max_linear_acceleration`` /
``max_angular_acceleration`` (0: none) ramp the command every 10 ms towards the last /cmd_vel (a
wheel asked for more than the floor's grip slips, and odometry counts the slip as motion); the
watchdog's stop is immediate, never ramped.
"""

from __future__ import annotations

import math

from robocourse.bus import (
    FloatingPointRange,
    IntegerRange,
    Node,
    Parameter,
    ParameterDescriptor,
    QoSProfile,
    ReliabilityPolicy,
    SetParametersResult,
)
from robocourse.msgs.diagnostic_msgs import DiagnosticArray, DiagnosticStatus, KeyValue
from robocourse.msgs.geometry_msgs import TransformStamped, Twist
from robocourse.msgs.nav_msgs import Odometry
from robocourse.msgs.tf2_msgs import TFMessage

from . import kinematics as kin
from .drivers import MotorDriver, MujocoMotorDriver, SimulatedMotorDriver
from .msgs import SetLed

QOS_CMD_VEL = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
QOS_ODOM = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)

_POSITIVE = {
    "wheel_base": (0.15, 0.02, 2.0, "distance between the wheels [m]"),
    "wheel_radius": (0.0325, 0.005, 0.5, "wheel radius [m]"),
    "max_linear_speed": (0.5, 0.01, 10.0, "wheel speed at motor command 1.0 [m/s], for normalisation"),
    "odom_rate_hz": (50.0, 1.0, 1000.0, "odometry publish rate [Hz]"),
    "watchdog_timeout": (0.2, 0.01, 10.0, "stop the motors after this long without /cmd_vel [s]"),
    "wheel_separation_multiplier": (1.0, 0.5, 2.0, "calibration: the effective wheel base is wheel_base times "
                                                   "this (diff_drive_controller's parameter)"),
}


_LIMITS = {
    "max_linear_acceleration": (0.0, 0.0, 100.0, "ramp linear.x by at most this [m/s^2]; 0: no limit "
                                                 "(diff_drive_controller's linear.x.max_acceleration)"),
    "max_angular_acceleration": (0.0, 0.0, 1000.0, "ramp angular.z by at most this [rad/s^2]; 0: no limit "
                                                   "(diff_drive_controller's angular.z.max_acceleration)"),
}
RAMP_PERIOD_S = 0.01   # how often a limited command steps towards the last /cmd_vel


def declare_ranged(node: Node, table: dict) -> None:
    """Declare float parameters from ``{name: (default, min, max, description)}`` with their ranges."""
    for pname, (default, lo, hi, text) in table.items():
        node.declare_parameter(pname, default, ParameterDescriptor(
            description=text, floating_point_range=[FloatingPointRange(from_value=lo, to_value=hi)]))


def _stamp(msg_stamp, ns: int) -> None:
    msg_stamp.sec, msg_stamp.nanosec = divmod(int(ns), 1_000_000_000)


class DriverNode(Node):
    """The seed's ``DriverNode``: /cmd_vel in, motor commands out, /odom + TF + /diagnostics back."""

    def __init__(self, driver: MotorDriver | None = None, name: str = "driver_node", **kwargs):
        super().__init__(name, **kwargs)
        declare_ranged(self, _POSITIVE)
        declare_ranged(self, _LIMITS)
        self.declare_parameter("driver", "simulated", ParameterDescriptor(
            description="simulated (logs PWM) or mujoco (drives the physical model)", read_only=True))
        self.add_on_set_parameters_callback(self._on_parameters)
        kind = self.get_parameter("driver").value
        if driver is None:
            driver = self._driver_for(kind)
        self.driver = driver
        self.driver.init()
        self.pose = (0.0, 0.0, 0.0)
        self.twist = (0.0, 0.0)
        self.last_cmd_ns: int | None = None
        self.watchdog_tripped = False
        self.watchdog_trips = 0
        self.commands_received = 0
        self.odom_published = 0
        self.create_subscription(Twist, "/cmd_vel", self.on_cmd_vel, QOS_CMD_VEL)
        self.odom_pub = self.create_publisher(Odometry, "/odom", QOS_ODOM)
        self.tf_pub = self.create_publisher(TFMessage, "/tf", 100)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        period = 1.0 / self.get_parameter("odom_rate_hz").value
        self.odom_timer = self.create_timer(period, self.on_odom_timer)
        self.watchdog_timer = self.create_timer(0.01, self.on_watchdog)
        self.target = (0.0, 0.0)     # the last valid /cmd_vel (v, w)
        self.applied = (0.0, 0.0)    # what the motors are told now (ramped towards target when limited)
        self.ramp_timer = self.create_timer(RAMP_PERIOD_S, self.on_ramp)
        self.create_timer(1.0, self.publish_diagnostics)
        self._last_odom_ns = self.get_clock().now().nanoseconds

    def _driver_for(self, kind: str) -> MotorDriver:
        if kind == "simulated":
            return SimulatedMotorDriver()
        if kind == "mujoco":   # the car of the simulator node started before us (a Gazebo plugin finds its world)
            sims = [n for n in self.context.nodes if isinstance(n, SimulatorNode)]
            if not sims:
                raise ValueError("driver: mujoco drives the simulator's car, and no SimulatorNode runs in this "
                                 "context: start the simulator first (executable 'simulator' in a launch file) or "
                                 "pass MujocoMotorDriver(car)")
            return MujocoMotorDriver(sims[-1].car)
        raise ValueError(f"driver parameter {kind!r}: use 'simulated' (logs PWM) or 'mujoco' (the simulator's car)")

    @property
    def geometry(self) -> kin.DiffDriveGeometry:
        """The geometry odometry and the drive formula use, from the current parameters (a change
        applies at once): the wheel base is ``wheel_base * wheel_separation_multiplier``."""
        return kin.DiffDriveGeometry(
            self.get_parameter("wheel_base").value * self.get_parameter("wheel_separation_multiplier").value,
            self.get_parameter("wheel_radius").value, self.get_parameter("max_linear_speed").value)

    def _on_parameters(self, params):
        for p in params:
            if p.name in _POSITIVE and not (isinstance(p.value, (int, float)) and math.isfinite(p.value) and p.value > 0):
                return SetParametersResult(successful=False, reason=f"{p.name} must be a positive number, got {p.value!r}")
        return SetParametersResult(successful=True)

    def on_cmd_vel(self, msg: Twist) -> None:
        self.commands_received += 1
        self.last_cmd_ns = self.get_clock().now().nanoseconds
        if self.watchdog_tripped:
            self.get_logger().info("cmd_vel received again: motors re-enabled")
            self.watchdog_tripped = False
        v, w = msg.linear.x, msg.angular.z
        if not (math.isfinite(v) and math.isfinite(w)):
            self.get_logger().error(f"ignoring /cmd_vel with non-finite values (linear.x={v}, angular.z={w})")
            return
        self.target = (v, w)
        if not self._limited():
            self._apply(v, w)

    def _limited(self) -> bool:
        return self.get_parameter("max_linear_acceleration").value > 0 or \
            self.get_parameter("max_angular_acceleration").value > 0

    def _apply(self, v: float, w: float) -> None:
        self.applied = (v, w)
        left, right = kin.twist_to_motor_commands(v, w, self.geometry)
        self.driver.set_motor_speeds(left, right)

    def on_ramp(self) -> None:
        """Step the applied twist towards the target within the acceleration limits."""
        if self.watchdog_tripped or self.applied == self.target or not self._limited():
            return
        out = []
        for now, want, name in zip(self.applied, self.target, ("max_linear_acceleration", "max_angular_acceleration")):
            a = self.get_parameter(name).value
            step = a * RAMP_PERIOD_S if a > 0 else math.inf
            out.append(now + max(-step, min(step, want - now)))
        self._apply(*out)

    def on_watchdog(self) -> None:
        if self.last_cmd_ns is None or self.watchdog_tripped:
            return
        age = (self.get_clock().now().nanoseconds - self.last_cmd_ns) * 1e-9
        if age > self.get_parameter("watchdog_timeout").value:
            self.driver.emergency_stop()
            self.target = self.applied = (0.0, 0.0)
            self.watchdog_tripped = True
            self.watchdog_trips += 1
            self.tripped_at_age = age
            self.get_logger().warning(f"no /cmd_vel for {age * 1e3:.0f} ms: emergency stop")

    def wheel_speeds(self) -> tuple[float, float]:
        """Wheel surface speeds (m/s): measured by the MuJoCo car's encoders, else as commanded."""
        g = self.geometry
        if isinstance(self.driver, MujocoMotorDriver):
            wl, wr = self.driver.car.wheel_speeds()
            return wl * g.wheel_radius, wr * g.wheel_radius
        return self.driver.left * g.max_linear_speed, self.driver.right * g.max_linear_speed

    def on_odom_timer(self) -> None:
        now = self.get_clock().now().nanoseconds
        dt = (now - self._last_odom_ns) * 1e-9
        self._last_odom_ns = now
        v, w = kin.wheel_speeds_to_twist(*self.wheel_speeds(), self.geometry)
        self.pose = kin.integrate_pose(*self.pose, v, w, dt)
        self.twist = (v, w)
        x, y, yaw = self.pose
        q = kin.yaw_to_quaternion(yaw)
        odom = Odometry()
        _stamp(odom.header.stamp, now)
        odom.header.frame_id, odom.child_frame_id = "odom", "base_link"
        odom.pose.pose.position.x, odom.pose.pose.position.y = x, y
        o = odom.pose.pose.orientation
        o.x, o.y, o.z, o.w = q
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = v, w
        self.odom_pub.publish(odom)
        self.odom_published += 1
        tf = TransformStamped()
        tf.header.stamp = odom.header.stamp
        tf.header.frame_id, tf.child_frame_id = "odom", "base_link"
        tf.transform.translation.x, tf.transform.translation.y = x, y
        r = tf.transform.rotation
        r.x, r.y, r.z, r.w = q
        self.tf_pub.publish(TFMessage(transforms=[tf]))

    def publish_diagnostics(self) -> None:
        now = self.get_clock().now().nanoseconds
        age = "never" if self.last_cmd_ns is None else f"{(now - self.last_cmd_ns) * 1e-9:.3f}"
        status = DiagnosticStatus(name="mycar: motors", hardware_id=type(self.driver).__name__,
                                  level=DiagnosticStatus.WARN if self.watchdog_tripped else DiagnosticStatus.OK,
                                  message="watchdog stop" if self.watchdog_tripped else "ok",
                                  values=[KeyValue(key="left", value=f"{self.driver.left:.3f}"),
                                          KeyValue(key="right", value=f"{self.driver.right:.3f}"),
                                          KeyValue(key="command_age_s", value=age),
                                          KeyValue(key="watchdog_trips", value=str(self.watchdog_trips))])
        arr = DiagnosticArray(status=[status])
        _stamp(arr.header.stamp, now)
        self.diag_pub.publish(arr)


_BUILD = {
    "wheel_base": (0.15, 0.02, 2.0, "distance between the wheel centres of the model [m]"),
    "wheel_radius": (0.0325, 0.005, 0.5, "wheel radius of the model [m]"),
    "max_linear_speed": (0.5, 0.01, 10.0, "wheel speed at motor command 1.0 [m/s]"),
    "rate_hz": (200.0, 10.0, 2000.0, "physics steps published per second [Hz]"),
}


class SimulatorNode(Node):
    """Steps the MuJoCo car (ground truth) on a timer and publishes ``/ground_truth`` (Odometry).

    Counterpart of a Gazebo/MuJoCo simulator node; not in the seed (which had no physics).
    Without a ``car`` it builds one from its parameters (the model's dimensions, as built:
    odometry's calibration lives in the driver's parameters, not here).
    """

    def __init__(self, car=None, rate_hz: float | None = None, name: str = "mycar_sim", **kwargs):
        super().__init__(name, **kwargs)
        declare_ranged(self, _BUILD)
        if rate_hz is not None:
            self.set_parameters([Parameter("rate_hz", value=float(rate_hz))])
        if car is None:
            from robocourse.sim.car import MujocoCar

            car = MujocoCar(kin.DiffDriveGeometry(*(self.get_parameter(k).value for k in
                                                    ("wheel_base", "wheel_radius", "max_linear_speed"))))
        self.car = car
        self.dt = 1.0 / self.get_parameter("rate_hz").value
        self.truth_pub = self.create_publisher(Odometry, "/ground_truth", QOS_ODOM)
        self.create_timer(self.dt, self.step)
        self.steps = 0

    def step(self) -> None:
        self.car.step(self.dt)
        self.steps += 1
        if self.steps % 4 == 0:
            x, y, yaw = self.car.pose()
            msg = Odometry()
            _stamp(msg.header.stamp, self.get_clock().now().nanoseconds)
            msg.header.frame_id, msg.child_frame_id = "world", "base_link"
            msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
            o = msg.pose.pose.orientation
            o.x, o.y, o.z, o.w = kin.yaw_to_quaternion(yaw)
            self.truth_pub.publish(msg)


class LedServiceServer(Node):
    """The seed's ``/set_led`` service: LEDs 1..led_count (2) exist; any other id fails with a warning."""

    def __init__(self, name: str = "led_service_server", **kwargs):
        super().__init__(name, **kwargs)
        self.declare_parameter("led_count", 2, ParameterDescriptor(
            description="LEDs 1..led_count exist", read_only=True, integer_range=[IntegerRange(
                from_value=1, to_value=64)]))
        self.leds = {i: False for i in range(1, self.get_parameter("led_count").value + 1)}
        self.create_service(SetLed, "/set_led", self.on_set_led)

    def on_set_led(self, request, response):
        if request.led_id not in self.leds:
            self.get_logger().warning(f"Invalid LED ID: {request.led_id} (valid: 1..{len(self.leds)})")
            response.success = False
            return response
        self.leds[request.led_id] = bool(request.state)
        self.get_logger().info(f"LED {request.led_id} turned {'ON' if request.state else 'OFF'}")
        response.success = True
        return response
