"""Differential-drive kinematics and wheel odometry for MyCar (diff_drive_controller's model).

The functions live in :mod:`robocourse.sim.diffdrive` (one implementation for the car and for
``robocourse.control``'s DiffDriveController); this module re-exports them under the names
chapter 3 uses.
"""

from __future__ import annotations

from robocourse.sim.diffdrive import (  # noqa: F401  (re-exported)
    DiffDriveGeometry,
    integrate_pose,
    motor_commands_to_twist,
    quaternion_to_yaw,
    twist_to_motor_commands,
    twist_to_wheel_speeds,
    wheel_speeds_to_twist,
    wrap_angle,
    yaw_to_quaternion,
)
