"""Homogeneous transforms in float64, computed here rather than by meshcat.transformations.

meshcat 0.3.2's transformations module calls ``np.array(..., copy=False)``, which raises on
NumPy 2 whenever a copy is needed (course_practice.md), so the viewer never calls it.
Quaternions are (w, x, y, z) like MuJoCo; ROS messages use (x, y, z, w): convert explicitly.
"""

from __future__ import annotations

import numpy as np


def _vec(value, n: int, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.shape != (n,):
        raise ValueError(f"{name} must have {n} numbers, got shape {np.shape(value)}: {value!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()} (NaN/inf would blank the viewer)")
    return arr


def rotation_from_quaternion(quat_wxyz) -> np.ndarray:
    """3x3 rotation matrix of a (w, x, y, z) quaternion (normalised first)."""
    q = _vec(quat_wxyz, 4, "quaternion (w, x, y, z)")
    norm = np.linalg.norm(q)
    if norm < 1e-12:
        raise ValueError("quaternion has zero length; the identity is (1, 0, 0, 0)")
    w, x, y, z = q / norm
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def quaternion_from_rotation(rot) -> np.ndarray:
    """(w, x, y, z) of a 3x3 rotation matrix, w >= 0 (Shepperd's method)."""
    m = np.asarray(rot, dtype=np.float64).reshape(3, 3)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    return q if q[0] >= 0 else -q


def transform(position=(0.0, 0.0, 0.0), quat_wxyz=None, rotation=None) -> np.ndarray:
    """4x4 float64 pose from a position and either a quaternion (w, x, y, z) or a 3x3 rotation."""
    if quat_wxyz is not None and rotation is not None:
        raise ValueError("give quat_wxyz or rotation, not both")
    out = np.eye(4)
    out[:3, 3] = _vec(position, 3, "position")
    if quat_wxyz is not None:
        out[:3, :3] = rotation_from_quaternion(quat_wxyz)
    elif rotation is not None:
        r = np.asarray(rotation, dtype=np.float64)
        if r.shape != (3, 3) or not np.all(np.isfinite(r)):
            raise ValueError(f"rotation must be a finite 3x3 matrix, got shape {r.shape}")
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise ValueError(f"rotation is not a proper rotation matrix (R R^T != I or det {np.linalg.det(r):.3g} != 1); "
                             "build it with rot_x/rot_y/rot_z or rotation_from_quaternion")
        out[:3, :3] = r
    return out


def rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def as_matrix(pose) -> np.ndarray:
    """Validate a 4x4 homogeneous transform and return it as a float64 array."""
    m = np.asarray(pose, dtype=np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise ValueError(f"a pose must be a finite 4x4 matrix, got shape {m.shape}; build one with viz.transform(position, quat_wxyz)")
    return m
