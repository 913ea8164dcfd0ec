"""A joint trajectory and its sampling: linear, cubic or quintic splines per segment.

Counterpart: ``joint_trajectory_controller::Trajectory`` (trajectory.cpp). The first segment
runs from the state at the first ``sample()`` (the "point before the trajectory") to point 0;
the polynomial degree of a segment follows what both of its ends carry (positions only ->
linear, + velocities -> cubic, + accelerations -> quintic); before point 0 the start state's
missing velocities/accelerations count as zero so the first segment has point 0's degree;
after the last point the last point is held (missing velocities/accelerations zero).
``interpolation_method="none"`` returns the start state before point 0 and the NEXT point
inside a segment, as upstream does. Efforts are interpolated linearly.

Differences: joint values are numpy rows (points x joints) in the controller's joint order;
the trajectory start time is a float in seconds (0 = "start at the first sample", like a zero
header stamp). Hot path (``sample``) allocates nothing: it writes into a :class:`Sample`.
"""

from __future__ import annotations

import numpy as np


class Sample:
    """Positions, velocities, accelerations, efforts of every joint at one instant (preallocated)."""

    __slots__ = ("positions", "velocities", "accelerations", "effort", "has_velocities",
                 "has_accelerations", "has_effort")

    def __init__(self, dof: int):
        self.positions = np.zeros(dof)
        self.velocities = np.zeros(dof)
        self.accelerations = np.zeros(dof)
        self.effort = np.zeros(dof)
        self.has_velocities = self.has_accelerations = self.has_effort = False

    def copy_from(self, other: Sample) -> None:
        self.positions[:] = other.positions
        self.velocities[:] = other.velocities
        self.accelerations[:] = other.accelerations
        self.effort[:] = other.effort
        self.has_velocities, self.has_accelerations = other.has_velocities, other.has_accelerations
        self.has_effort = other.has_effort


class Trajectory:
    """``Trajectory(times, positions, velocities=None, accelerations=None, effort=None, start_time=0.0)``.

    ``times`` are the points' time_from_start (s, strictly increasing); value arrays are
    (points x joints). ``start_time`` 0 means "at the first sample" (header stamp zero).
    """

    def __init__(self, times, positions, velocities=None, accelerations=None, effort=None,
                 start_time: float = 0.0):
        self.times = np.asarray(times, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        self.velocities = None if velocities is None else np.asarray(velocities, dtype=float)
        self.accelerations = None if accelerations is None else np.asarray(accelerations, dtype=float)
        self.effort = None if effort is None else np.asarray(effort, dtype=float)
        self.start_time = float(start_time)
        self.sampled_already = False
        self.dof = self.positions.shape[1]
        self.before = Sample(self.dof)        # the state before the trajectory (set at the first sample)
        self.time_before = 0.0
        self.last_index = 0                   # segment search starts here (time only moves forward)
        self._coef = np.zeros((6, self.dof))  # the current segment's polynomial (cached per segment)
        self._key = -3                        # which segment _coef holds (-1 the first, -2/-3 none)
        self._powers = np.zeros((3, 6))       # rows: d^0, d^1, d^2 of [1, t, .., t^5]
        self._powers[0, 0], self._powers[1, 1], self._powers[2, 2] = 1.0, 1.0, 2.0
        self._pva = np.zeros((3, self.dof))

    def __len__(self) -> int:
        return len(self.times)

    @property
    def end_time(self) -> float:
        """Absolute time of the last point (valid once started)."""
        return self.start_time + float(self.times[-1])

    def set_point_before_trajectory(self, time: float, state: Sample) -> None:
        """``set_point_before_trajectory_msg``: where the first segment starts."""
        self.time_before = time
        self.before.copy_from(state)
        self._key = -3

    def sample(self, t: float, out: Sample, interpolate: bool = True) -> int:
        """Fill ``out`` with the trajectory at absolute time ``t``.

        Returns the index of the segment's end point (0 before point 0, k inside (k-1, k),
        ``len(self)`` past the last point), or -1 if ``t`` is before the trajectory start.
        """
        if not self.sampled_already:
            if self.start_time == 0.0:
                self.start_time = t
            self.sampled_already = True
        if t < self.start_time:
            return -1
        times, start = self.times, self.start_time
        first = start + times[0]
        if t < first:
            if not interpolate:
                out.copy_from(self.before)
                return 0
            self._interpolate_first(t, out)
            return 0
        n = len(times)
        k = self.last_index
        if k < 1 or start + times[k - 1] > t:
            k = 1
        while k < n and start + times[k] <= t:
            k += 1
        if k < n:
            self.last_index = k
            if not interpolate:
                self._point(k, out)
                return k
            self._interpolate(k - 1, k, t - (start + times[k - 1]), times[k] - times[k - 1], out)
            return k
        self.last_index = n - 1
        self._point(n - 1, out)
        return n

    # --- helpers --------------------------------------------------------------------------------------
    def _point(self, i: int, out: Sample) -> None:
        out.positions[:] = self.positions[i]
        for arr, dst in ((self.velocities, out.velocities), (self.accelerations, out.accelerations),
                         (self.effort, out.effort)):
            if arr is None:
                dst.fill(0.0)
            else:
                dst[:] = arr[i]
        out.has_velocities = out.has_accelerations = True
        out.has_effort = self.effort is not None

    def _interpolate_first(self, t: float, out: Sample) -> None:
        b = self.before
        T = self.start_time + self.times[0] - self.time_before
        dt = max(t - self.time_before, 0.0)
        if self._key != -1:
            zeros = np.zeros(self.dof)
            v0 = b.velocities if b.has_velocities else zeros
            a0 = b.accelerations if b.has_accelerations else zeros
            v1 = None if self.velocities is None else self.velocities[0]
            a1 = None if self.accelerations is None else self.accelerations[0]
            self._key = -1 if _coefficients(b.positions, v0, a0, self.positions[0], v1, a1, T, self._coef) else -2
        self._evaluate(dt, T, out)
        if self.effort is not None:
            e0 = b.effort if b.has_effort else np.zeros(self.dof)
            np.multiply(self.effort[0] - e0, dt / T if T > 0 else 1.0, out=out.effort)
            out.effort += e0
            out.has_effort = True
        else:
            out.effort.fill(0.0)
            out.has_effort = False

    def _interpolate(self, i: int, j: int, dt: float, T: float, out: Sample) -> None:
        if self._key != i:
            v, a = self.velocities, self.accelerations
            ok = _coefficients(self.positions[i], None if v is None else v[i], None if a is None else a[i],
                               self.positions[j], None if v is None else v[j], None if a is None else a[j], T,
                               self._coef)
            self._key = i if ok else -2
        self._evaluate(dt, T, out)
        if self.effort is not None:
            np.multiply(self.effort[j] - self.effort[i], dt / T, out=out.effort)
            out.effort += self.effort[i]
            out.has_effort = True
        else:
            out.effort.fill(0.0)
            out.has_effort = False

    def _evaluate(self, t: float, T: float, out: Sample) -> None:
        """positions, velocities, accelerations = powers of t times the cached segment coefficients."""
        t = min(max(t, 0.0), T) if T > 0.0 else 0.0
        t2 = t * t
        t3 = t2 * t
        m = self._powers
        m[0, 1], m[0, 2], m[0, 3], m[0, 4], m[0, 5] = t, t2, t3, t3 * t, t3 * t2
        m[1, 2], m[1, 3], m[1, 4], m[1, 5] = 2.0 * t, 3.0 * t2, 4.0 * t3, 5.0 * t3 * t
        m[2, 3], m[2, 4], m[2, 5] = 6.0 * t, 12.0 * t2, 20.0 * t3
        np.dot(m, self._coef, out=self._pva)
        out.positions[:] = self._pva[0]
        out.velocities[:] = self._pva[1]
        out.accelerations[:] = self._pva[2]
        out.has_velocities = out.has_accelerations = True


def _coefficients(p0, v0, a0, p1, v1, a1, T, C) -> bool:
    """Fill C (6 x joints) with the segment polynomial's coefficients (upstream's formulas).

    Degree from what the END point has: velocities and accelerations -> quintic, velocities ->
    cubic, positions only -> linear (the start's missing fields count as zero). A segment of
    zero duration is the end point held (velocity and acceleration of the end point). Returns
    False for that case (nothing to cache).
    """
    C.fill(0.0)
    if T <= 0.0:
        C[0] = p1
        C[1] = 0.0 if v1 is None else v1
        C[2] = 0.0 if a1 is None else 0.5 * a1
        return False
    if v1 is None:  # linear
        C[0] = p0
        C[1] = (p1 - p0) / T
    elif a1 is None:  # cubic: a2=(-3p0+3p1-2v0T-v1T)/T^2, a3=(2p0-2p1+v0T+v1T)/T^3
        C[0], C[1] = p0, v0
        C[2] = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * T) / (T * T)
        C[3] = (2.0 * (p0 - p1) + (v0 + v1) * T) / (T * T * T)
    else:  # quintic
        T2, T3 = T * T, T * T * T
        C[0], C[1], C[2] = p0, v0, 0.5 * a0
        C[3] = (-20.0 * p0 + 20.0 * p1 - 3.0 * a0 * T2 + a1 * T2 - 12.0 * v0 * T - 8.0 * v1 * T) / (2.0 * T3)
        C[4] = (30.0 * p0 - 30.0 * p1 + 3.0 * a0 * T2 - 2.0 * a1 * T2 + 16.0 * v0 * T + 14.0 * v1 * T) / (2.0 * T3 * T)
        C[5] = (-12.0 * p0 + 12.0 * p1 - a0 * T2 + a1 * T2 - 6.0 * v0 * T - 6.0 * v1 * T) / (2.0 * T3 * T2)
    return True


__all__ = ["Sample", "Trajectory"]
