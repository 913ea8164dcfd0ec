"""DiffDriveController (ros2_controllers' diff_drive_controller).

Counterpart: ``diff_drive_controller::DiffDriveController``: ``~/cmd_vel``
(geometry_msgs/TwistStamped) -> wheel velocity commands ``w_l = (v - w sep/2) / r_l``,
``w_r = (v + w sep/2) / r_r`` on every wheel of a side; a command older than
``cmd_vel_timeout`` (0.5 s, from its header stamp; a zero stamp counts as "now"; 0.0 disables the
timeout) becomes zero;
odometry from the wheels' position feedback (or velocity feedback, or the commands when
``open_loop``), integrated exactly along the arc, published on ``~/odom`` (``/<controller>/odom``)
(nav_msgs/Odometry) and as the ``odom -> base_link`` transform on ``/tf``.
``wheel_separation`` and ``wheel_radius`` are mandatory and > 0; ``*_multiplier`` correct them.
The kinematics are :mod:`robocourse.sim.diffdrive`, the same functions chapter 3's car uses.

Differences: not chainable (upstream's newest exports linear/angular reference interfaces);
no speed limiter, covariance parameters, rolling-window velocity mean or tf_frame_prefix;
the odometry starts from the wheel positions at activation (upstream from zero).
"""

from __future__ import annotations

import math
from pathlib import Path

from robocourse.msgs.geometry_msgs import TransformStamped, TwistStamped
from robocourse.msgs.nav_msgs import Odometry
from robocourse.msgs.tf2_msgs import TFMessage
from robocourse.sim.diffdrive import (
    DiffDriveGeometry,
    integrate_pose,
    twist_to_wheel_speeds,
    wheel_speeds_to_twist,
    yaw_to_quaternion,
)

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...parameters import ParameterSchema

_HERE = Path(__file__).parent


class DiffDriveController(ControllerInterface):
    """``diff_drive_controller/DiffDriveController``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("parameters.yaml").read_text())

    def __init__(self):
        super().__init__()
        self.x = self.y = self.yaw = 0.0          # odometry pose
        self.linear = self.angular = 0.0          # odometry twist
        self._cmd = None                          # (stamp s, v, w): the real-time buffer of ~/cmd_vel
        self.dropped_commands = 0

    def on_configure(self, previous_state):
        p = self.params
        if len(p.left_wheel_names) != len(p.right_wheel_names):
            self.get_logger().error(f"The number of left wheels [{len(p.left_wheel_names)}] and the number of right "
                                    f"wheels [{len(p.right_wheel_names)}] are different")
            return CallbackReturn.ERROR
        self._geometry()
        if self._node is None:
            node = self.get_node()
            node.create_subscription(TwistStamped, "~/cmd_vel", self._on_cmd_vel, 10)
            self._odom_pub = node.create_publisher(Odometry, "~/odom", 10)
            self._tf_pub = node.create_publisher(TFMessage, "/tf", 10)
        return CallbackReturn.SUCCESS

    def _geometry(self) -> None:
        p = self.params
        self.separation = p.wheel_separation * p.wheel_separation_multiplier
        self.r_left = p.wheel_radius * p.left_wheel_radius_multiplier
        self.r_right = p.wheel_radius * p.right_wheel_radius_multiplier
        self.geometry = DiffDriveGeometry(wheel_base=self.separation, wheel_radius=p.wheel_radius)

    def _on_cmd_vel(self, msg) -> None:
        v, w = msg.twist.linear.x, msg.twist.angular.z
        if not (math.isfinite(v) and math.isfinite(w)):
            self.dropped_commands += 1
            self.get_logger().error(f"cmd_vel with a non-finite value dropped: linear.x={v}, angular.z={w}")
            return
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        if stamp == 0.0:
            self.get_logger().warning("Received TwistStamped with zero timestamp, setting it to current time, this "
                                      "message will only be shown once")
            stamp = self.get_node().get_clock().now().nanoseconds * 1e-9
        self._cmd = (stamp, v, w)

    def set_command(self, v: float, w: float, stamp: float) -> None:
        """Same as a ``~/cmd_vel`` message stamped ``stamp`` (notebooks that skip the bus)."""
        msg = TwistStamped()
        msg.twist.linear.x, msg.twist.angular.z = float(v), float(w)
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(stamp), int(round((stamp - int(stamp)) * 1e9))
        self._on_cmd_vel(msg)

    def command_interface_configuration(self):
        p = self.params
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{j}/velocity" for j in list(p.left_wheel_names) + list(p.right_wheel_names)])

    def state_interface_configuration(self):
        p = self.params
        feedback = "position" if p.position_feedback else "velocity"
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{j}/{feedback}" for j in list(p.left_wheel_names) + list(p.right_wheel_names)])

    def on_activate(self, previous_state):
        n = len(self.params.left_wheel_names)
        self._left_cmd, self._right_cmd = self.command_interfaces[:n], self.command_interfaces[n:]
        self._left_fb, self._right_fb = self.state_interfaces[:n], self.state_interfaces[n:]
        self._old_left, self._old_right = self._mean(self._left_fb), self._mean(self._right_fb)
        self._cmd = None
        self.linear = self.angular = 0.0
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state):
        for loan in self.command_interfaces:
            loan.set_value(0.0)
        return CallbackReturn.SUCCESS

    @staticmethod
    def _mean(loans) -> float:
        return sum(loan.get_value() for loan in loans) / len(loans)

    def update(self, time, period):
        if self.param_listener.try_update_params(self.params):
            self._geometry()
        p = self.params
        cmd = self._cmd
        v = w = 0.0
        if cmd is not None and (p.cmd_vel_timeout == 0.0 or time - cmd[0] <= p.cmd_vel_timeout):
            v, w = cmd[1], cmd[2]
        # odometry: wheel travel (m) over this period -> exact arc
        if p.open_loop:
            dist, dyaw = v * period, w * period
        else:
            left, right = self._mean(self._left_fb), self._mean(self._right_fb)
            if p.position_feedback:
                dl, dr = (left - self._old_left) * self.r_left, (right - self._old_right) * self.r_right
                self._old_left, self._old_right = left, right
            else:
                dl, dr = left * self.r_left * period, right * self.r_right * period
            if not (math.isfinite(dl) and math.isfinite(dr)):
                self.get_logger().error(f"wheel feedback is not finite: left {left}, right {right}")
                return return_type.ERROR
            dist, dyaw = wheel_speeds_to_twist(dl, dr, self.geometry)
        self.x, self.y, self.yaw = integrate_pose(self.x, self.y, self.yaw, dist, dyaw, 1.0)
        if period > 0.0:
            self.linear, self.angular = dist / period, dyaw / period
        self._publish(time)
        # wheel commands (rad/s)
        left_speed, right_speed = twist_to_wheel_speeds(v, w, self.geometry)
        for loan in self._left_cmd:
            loan.set_value(left_speed / self.r_left)
        for loan in self._right_cmd:
            loan.set_value(right_speed / self.r_right)
        return return_type.OK

    def _publish(self, time: float) -> None:
        p = self.params
        ns = int(round(time * 1e9))
        sec, nanosec = ns // 1_000_000_000, ns % 1_000_000_000
        qx, qy, qz, qw = yaw_to_quaternion(self.yaw)
        odom = Odometry(child_frame_id=p.base_frame_id)
        odom.header.stamp.sec, odom.header.stamp.nanosec, odom.header.frame_id = sec, nanosec, p.odom_frame_id
        pose = odom.pose.pose
        pose.position.x, pose.position.y = self.x, self.y
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = qx, qy, qz, qw
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = self.linear, self.angular
        self._odom_pub.publish(odom)
        if p.enable_odom_tf:
            tf = TransformStamped(child_frame_id=p.base_frame_id)
            tf.header.stamp.sec, tf.header.stamp.nanosec, tf.header.frame_id = sec, nanosec, p.odom_frame_id
            tf.transform.translation.x, tf.transform.translation.y = self.x, self.y
            r = tf.transform.rotation
            r.x, r.y, r.z, r.w = qx, qy, qz, qw
            self._tf_pub.publish(TFMessage(transforms=[tf]))


__all__ = ["DiffDriveController"]
