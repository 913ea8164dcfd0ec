"""Frames and orientations a deployment reads: projected gravity, quaternion orders, the UR base frames.

Counterparts: legged_gym's ``projected_gravity`` (``quat_rotate_inverse(base_quat, [0, 0, -1])``)
and unitree deploy_mujoco's ``get_gravity_orientation`` (the same vector from a (w, x, y, z)
quaternion); rl_sar's ``gravity_vec``. The orders that meet in one deployment: MuJoCo's free
joint and IsaacLab store (w, x, y, z); ROS's ``geometry_msgs/Quaternion`` and SciPy's
``Rotation.as_quat()`` (default) give (x, y, z, w). ur_description's ``base`` frame (the UR
controller's "Base", what the teach pendant shows) is ``base_link`` rotated by pi about z
(``base_link-base_fixed_joint``).
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.viz.transforms import rot_z, rotation_from_quaternion

#: ur_description: base = base_link rotated by pi about z (x and y flip sign)
UR_BASE_IN_BASE_LINK = rot_z(math.pi)


def projected_gravity(quat_wxyz) -> np.ndarray:
    """Gravity's direction in the base frame, ``R(q)^T [0, 0, -1]``, from a (w, x, y, z) quaternion."""
    q = np.asarray(quat_wxyz, dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or not np.linalg.norm(q) > 0:
        raise ValueError(f"quaternion {quat_wxyz!r} must be 4 finite numbers (w, x, y, z), not all 0")
    return rotation_from_quaternion(q / np.linalg.norm(q)).T @ np.array([0.0, 0.0, -1.0])


def wxyz_from_ros(x: float, y: float, z: float, w: float) -> np.ndarray:
    """A ``geometry_msgs/Quaternion``'s fields (x, y, z, w) in the (w, x, y, z) order MuJoCo and IsaacLab use."""
    return np.array([w, x, y, z], dtype=float)


def ur_base_to_base_link(point) -> np.ndarray:
    """A point given in the UR controller's ``base`` frame, expressed in ``base_link`` (ROS, REP-103)."""
    p = np.asarray(point, dtype=float)
    if p.shape != (3,):
        raise ValueError(f"point {point!r} must be 3 numbers (x, y, z) in m")
    return UR_BASE_IN_BASE_LINK @ p
