"""The UR-style controller's joint motion generator: what servoj, speedj, movej and stopj do, every 2 ms.

Counterpart: the trajectory generator inside a UR controller, behind the URScript motion
commands ur_rtde's control script calls (``servoj``, ``speedj``, ``movej``, ``stopj``,
``stopl``). UR does not publish its internals; this is our model, stated so it can be tested:

- **servo** (``servoj(q, a, v, t, lookahead_time, gain)``; ``a``, ``v`` unused, as URScript
  says): each new target starts a linear interpolation from where the previous one had got to,
  reaching the target ``t`` seconds later; the reference then follows it through a first-order
  filter with time constant ``lookahead_time`` (more lookahead: smoother and later), clipped to
  the joint velocity limits. ``gain`` is range-checked by the client and not modelled. A target
  that is not refreshed stays the target: the arm goes there and holds (the script's servo
  thread repeats ``servoj`` with the last target).
- **speed** (``speedj(qd, a, t)``): the joint velocities move toward ``qd`` with the leading
  joint accelerating at ``a`` (all joints reach their velocity together), and keep it until
  another command (the script's speed thread repeats ``speedj``).
- **move** (``movej(q, a, v)``): a synchronised trapezoidal profile in joint space: the joint
  with the farthest to go accelerates at ``a`` to at most ``v`` and decelerates to stop on the
  goal; the others scale along the same profile. ``done`` once there.
- **stop** (``stopj(a)``, ``stopl(a)`` and the stop after a program ends): every joint's
  velocity ramps to zero with the leading joint decelerating at ``a`` (we treat ``stopl``'s
  tool deceleration as a joint one: the difference is a stopping distance, not a behaviour).
- **hold**: nothing moves.

Speed scaling (the speed slider, ``speed_slider_fraction``) scales time as the real trajectory
limiter does: the interpolations, profiles and filters advance ``scaling * 2 ms`` per tick and
speed targets are scaled, so a half slider runs every motion at half speed. Positions are kept
inside the joint limits (a target outside is clipped and counted).
"""

from __future__ import annotations

import math

import numpy as np

HOLD, SERVO, SPEED, MOVE, STOP = "hold", "servo", "speed", "move", "stop"

#: URScript's servoj ranges (ur_rtde checks them before sending)
LOOKAHEAD = (0.03, 0.2)
GAIN = (100.0, 2000.0)


def _trapezoid_time(dist: float, v: float, a: float) -> tuple[float, float, float]:
    """(duration, time accelerating, peak speed) of a rest-to-rest trapezoid over ``dist``."""
    if dist <= 0:
        return 0.0, 0.0, 0.0
    t_acc = v / a
    if a * t_acc * t_acc >= dist:          # never reaches v: a triangle
        t_acc = math.sqrt(dist / a)
        return 2 * t_acc, t_acc, a * t_acc
    return 2 * t_acc + (dist - a * t_acc * t_acc) / v, t_acc, v


class JointMotion:
    """The reference joint trajectory (``q``, ``qd``, ``qdd``: target_q/qd/qdd) advanced by
    :meth:`tick`; the arm's servos follow ``q``."""

    def __init__(self, q0, dt: float, lower, upper, vmax):
        self.dt = float(dt)
        self.q = np.array(q0, dtype=float)
        self.qd = np.zeros(6)
        self.qdd = np.zeros(6)
        self.lower, self.upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        self.vmax = np.asarray(vmax, dtype=float)
        self.mode = HOLD
        self.scaling = 1.0
        self.clipped = 0                 # targets clipped into the joint limits
        # servo
        self.target = self.q.copy()
        self.interp = self.q.copy()
        self.interp_start = self.q.copy()
        self.elapsed = 0.0
        self.servo_t, self.lookahead = 0.002, 0.1
        # speed / stop
        self.qd_target = np.zeros(6)
        self.acc = 1.0
        # move
        self.start = self.q.copy()
        self.goal = self.q.copy()
        self.profile = (0.0, 0.0, 0.0)
        self.dist = 0.0
        self.done = True

    def _clip(self, q) -> np.ndarray:
        c = np.clip(q, self.lower, self.upper)
        if not np.array_equal(c, q):
            self.clipped += 1
        return c

    # --- commands ------------------------------------------------------------------------------
    def servo(self, q, t: float, lookahead: float) -> None:
        if self.mode != SERVO:
            self.interp[:] = self.q
        self.mode = SERVO
        self.interp_start[:] = self.interp
        self.target[:] = self._clip(np.asarray(q, dtype=float))
        self.servo_t, self.lookahead = max(float(t), self.dt), float(lookahead)   # t below one tick: one tick
        self.elapsed = 0.0

    def speed(self, qd, a: float) -> None:
        self.mode = SPEED
        self.qd_target[:] = np.clip(np.asarray(qd, dtype=float), -self.vmax, self.vmax)
        self.acc = float(a)

    def move(self, q, v: float, a: float) -> None:
        self.start[:] = self.q
        self.goal[:] = self._clip(np.asarray(q, dtype=float))
        d = np.abs(self.goal - self.start)
        self.dist = float(d.max())
        moving = d > 0
        # the leading joint's speed v must not drive any other joint past its own limit
        vlim = float(np.min(self.vmax[moving] * self.dist / d[moving])) if moving.any() else math.inf
        self.profile = _trapezoid_time(self.dist, min(float(v), vlim), float(a))
        self.elapsed = 0.0
        self.mode = MOVE
        self.done = self.dist == 0.0

    def stop(self, a: float) -> None:
        """Decelerate to rest with the leading joint at ``a`` rad/s^2 (a no-op when resting)."""
        if self.mode == HOLD:
            return
        self.mode = STOP
        self.qd_target[:] = 0.0
        self.acc = float(a)

    def hold(self) -> None:
        """Stop at once where the reference is (brakes; used when power goes off)."""
        self.mode = HOLD
        self.qd[:] = 0.0
        self.qdd[:] = 0.0

    @property
    def moving(self) -> bool:
        return self.mode != HOLD

    # --- the 2 ms tick -------------------------------------------------------------------------
    def _ramp_velocity(self, goal) -> None:
        delta = goal - self.qd
        lead = float(np.max(np.abs(delta)))
        step = self.acc * self.dt * self.scaling
        self.qd += delta if lead <= step else delta * (step / lead)

    def tick(self) -> None:
        dt, s = self.dt, self.scaling
        qd_prev = self.qd.copy()
        if self.mode == SERVO:
            self.elapsed += dt * s
            frac = min(1.0, self.elapsed / self.servo_t)
            self.interp[:] = self.interp_start + (self.target - self.interp_start) * frac
            alpha = min(1.0, dt * s / self.lookahead)
            step = np.clip((self.interp - self.q) * alpha, -self.vmax * dt, self.vmax * dt)
            self.q += step
            self.qd[:] = step / dt
        elif self.mode == SPEED or self.mode == STOP:
            self._ramp_velocity(self.qd_target * (s if self.mode == SPEED else 1.0))
            self.q += self.qd * dt
            if self.mode == STOP and not self.qd.any():
                self.mode = HOLD
        elif self.mode == MOVE:
            self.elapsed += dt * s
            total, t_acc, peak = self.profile
            t = min(self.elapsed, total)
            if total == 0.0:
                sdist, sspeed = self.dist, 0.0
            elif t < t_acc:
                sdist, sspeed = 0.5 * peak / t_acc * t * t, peak / t_acc * t
            elif t > total - t_acc:
                r = total - t
                sdist, sspeed = self.dist - 0.5 * peak / t_acc * r * r, peak / t_acc * r
            else:
                sdist, sspeed = 0.5 * peak * t_acc + peak * (t - t_acc), peak
            u = (self.goal - self.start) / self.dist if self.dist > 0 else np.zeros(6)
            self.q[:] = self.start + u * sdist
            self.qd[:] = u * sspeed * s
            if self.elapsed >= total:
                self.q[:] = self.goal
                self.qd[:] = 0.0
                self.mode = HOLD
                self.done = True
        else:
            self.qd[:] = 0.0
        lo, hi = self.q < self.lower, self.q > self.upper
        if lo.any() or hi.any():                   # a speed command ran into a joint limit
            np.clip(self.q, self.lower, self.upper, out=self.q)
            self.qd[lo | hi] = 0.0
            self.clipped += 1
        self.qdd[:] = (self.qd - qd_prev) / dt
