"""Differential-drive kinematics and exact-arc odometry: the one implementation in the course.

Counterpart: the model of ros2_controllers' diff_drive_controller (``odometry.cpp``). Inverse:
a body twist (v, w) gives wheel surface speeds ``v -+ w b / 2`` (divide by the wheel radius
for rad/s); the MyCar seed normalises them by the maximum linear speed into motor commands in
[-1, 1]. Forward: wheel speeds give ``v = (vr + vl) / 2``, ``w = (vr - vl) / b``. Odometry
integrates (v, w) exactly along the arc (the same result for any step when v and w are
constant over it). Used by chapter 3's car (``robocourse.mycar.kinematics`` re-exports it) and
by ``robocourse.control``'s DiffDriveController.
"""

from __future__ import annotations

import math

from robocourse.sim.params import DiffDriveGeometry, quaternion_to_yaw  # noqa: F401  (re-exported)

_SEED_CAR = DiffDriveGeometry()   # the default geometry of every function below


def twist_to_wheel_speeds(v: float, w: float, g: DiffDriveGeometry = _SEED_CAR) -> tuple[float, float]:
    """(left, right) wheel surface speeds in m/s for body speed v (m/s) and yaw rate w (rad/s)."""
    if not (math.isfinite(v) and math.isfinite(w)):
        raise ValueError(f"twist must be finite, got linear.x={v!r}, angular.z={w!r}")
    half = w * g.wheel_base / 2.0
    return v - half, v + half


def wheel_speeds_to_twist(left: float, right: float, g: DiffDriveGeometry = _SEED_CAR) -> tuple[float, float]:
    """(v, w) of the body for (left, right) wheel surface speeds in m/s."""
    return (left + right) / 2.0, (right - left) / g.wheel_base


def twist_to_motor_commands(v: float, w: float, g: DiffDriveGeometry = _SEED_CAR) -> tuple[float, float]:
    """Normalised motor commands in [-1, 1] (the seed's set_motor_speeds arguments).

    When a wheel would exceed full speed both are scaled down together, so the car still turns
    on the commanded arc instead of distorting it (plain clamping would).
    """
    left, right = twist_to_wheel_speeds(v, w, g)
    left, right = left / g.max_linear_speed, right / g.max_linear_speed
    peak = max(abs(left), abs(right))
    if peak > 1.0:
        left, right = left / peak, right / peak
    return left, right


def motor_commands_to_twist(left: float, right: float, g: DiffDriveGeometry = _SEED_CAR) -> tuple[float, float]:
    return wheel_speeds_to_twist(left * g.max_linear_speed, right * g.max_linear_speed, g)


def integrate_pose(x: float, y: float, yaw: float, v: float, w: float, dt: float) -> tuple[float, float, float]:
    """Pose after moving with constant (v, w) for dt seconds (exact arc; straight line when w = 0)."""
    if abs(w) < 1e-9:
        return x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw
    yaw2 = yaw + w * dt
    r = v / w
    return x + r * (math.sin(yaw2) - math.sin(yaw)), y - r * (math.cos(yaw2) - math.cos(yaw)), yaw2


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) quaternion of a rotation by ``yaw`` about z (ROS's order, as in geometry_msgs)."""
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def wrap_angle(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    a = math.fmod(a + math.pi, 2.0 * math.pi)
    if a <= 0:
        a += 2.0 * math.pi
    return a - math.pi


__all__ = ["DiffDriveGeometry", "integrate_pose", "motor_commands_to_twist", "quaternion_to_yaw",
           "twist_to_motor_commands", "twist_to_wheel_speeds", "wheel_speeds_to_twist", "wrap_angle",
           "yaw_to_quaternion"]
