"""Two PID controllers for the pendulum: the seed's, exactly, and a textbook one beside it.

``SeedPID`` is ros2/demos ``PendulumController``: its integral term *compounds*
(``i_term = i * (i_term + error * dt)``: the gain multiplies the accumulated term again on
every step, so for i < 1 it forgets and for i > 1 it explodes), and its output is a position
command ``position + p_term + i_term + d_term`` clamped to [0, pi]. ``TextbookPID`` sums
``ki * integral(error)``, differentiates the measurement (no derivative kick), clamps its
output, and stops integrating while saturated (conditional-integration anti-windup).
"""

from __future__ import annotations

import math
import numbers

from .physics import PI

INVALID_DT = "Invalid dt_ calculated in PendulumController constructor"
NAN_SENSOR = "Sensor value was NaN in on_sensor_message callback"
NAN_RESULT = "Resulting command was NaN in on_sensor_message callback"


class SeedPID:
    """The seed's controller (``PIDProperties`` defaults p=1, i=0, d=0, command=pi/2)."""

    def __init__(self, period_s: float, p: float = 1.0, i: float = 0.0, d: float = 0.0, command: float = PI / 2):
        if period_s is None or math.isnan(period_s) or period_s == 0:
            raise RuntimeError(INVALID_DT)  # the seed's own check and text
        if not (math.isfinite(period_s) and period_s > 0):
            raise ValueError(f"SeedPID(period_s={period_s!r}): the controller period is a positive, finite "
                             "number of seconds, e.g. SeedPID(0.00096) for the seed's 960 us")
        for name, value in (("p", p), ("i", i), ("d", d), ("command", command)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
                raise ValueError(f"SeedPID({name}={value!r}): gains and the command are numbers (not NaN), "
                                 f"e.g. SeedPID(0.001, p=1.0, i=0.0, d=0.0, command=math.pi / 2)")
        self.dt = float(period_s)
        self.p, self.i, self.d, self.command = float(p), float(i), float(d), float(command)
        self.i_term = 0.0
        self.last_error = 0.0

    def update(self, position: float) -> float:
        """One ``on_sensor_message``: return the next position command."""
        if math.isnan(position):
            raise RuntimeError(NAN_SENSOR)
        error = self.command - position
        p_term = self.p * error
        self.i_term = self.i * (self.i_term + error * self.dt)
        d_term = self.d * (error - self.last_error) / self.dt
        self.last_error = error
        out = position + p_term + self.i_term + d_term
        if out > PI:
            out = PI
        elif out < 0.0:
            out = 0.0
        if math.isnan(out):
            raise RuntimeError(NAN_RESULT)
        return out


class TextbookPID:
    """u = kp e + ki * integral(e) - kd * d(measurement)/dt, clamped, with anti-windup.

    The output is whatever the plant takes (a torque, a force, a position correction);
    ``u_min``/``u_max`` are its actuator limits.
    """

    def __init__(self, kp: float, ki: float = 0.0, kd: float = 0.0, setpoint: float = 0.0,
                 u_min: float = -math.inf, u_max: float = math.inf, anti_windup: bool = True):
        for name, value in (("kp", kp), ("ki", ki), ("kd", kd), ("setpoint", setpoint), ("u_min", u_min),
                            ("u_max", u_max)):
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise ValueError(f"TextbookPID({name}={value!r}): {name} must be a number (int or float), not "
                                 f"{type(value).__name__}; e.g. TextbookPID(kp=1.0), or float({value!r}) if it "
                                 "came from text")
            if name not in ("u_min", "u_max") and not math.isfinite(value):
                raise ValueError(f"TextbookPID({name}={value!r}): {name} must be finite, e.g. {name}=0.0")
        if not u_min < u_max:
            raise ValueError(f"TextbookPID(u_min={u_min!r}, u_max={u_max!r}): u_min must be below u_max "
                             "(the actuator's limits), e.g. u_min=-1.0, u_max=1.0")
        self.kp, self.ki, self.kd, self.setpoint = kp, ki, kd, setpoint
        self.u_min, self.u_max, self.anti_windup = u_min, u_max, anti_windup
        self.integral = 0.0
        self.last_measurement: float | None = None

    def reset(self) -> None:
        self.integral, self.last_measurement = 0.0, None

    def update(self, measurement: float, dt: float) -> float:
        if math.isnan(measurement):
            raise RuntimeError(NAN_SENSOR)
        if not dt > 0:
            raise ValueError(f"dt must be positive seconds, got {dt!r}")
        error = self.setpoint - measurement
        derivative = 0.0 if self.last_measurement is None else -(measurement - self.last_measurement) / dt
        self.last_measurement = measurement
        candidate = self.integral + error * dt
        u = self.kp * error + self.ki * candidate + self.kd * derivative
        saturated = u > self.u_max or u < self.u_min
        # anti-windup: keep the integral only if it does not push further into saturation
        if not (self.anti_windup and saturated and (u > self.u_max) == (error > 0)):
            self.integral = candidate
        return min(self.u_max, max(self.u_min, u))
