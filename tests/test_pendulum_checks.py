"""Chapter 2's checks pass the reference answers and fail the usual mistakes with a useful message."""

from __future__ import annotations

import math

import control
import pytest

from robocourse.bus import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from robocourse.grading import CheckFailed
from robocourse.pendulum import checks
from robocourse.pendulum.pid import TextbookPID


class GoodPID:
    def __init__(self, kp, ki, kd, setpoint=0.0, u_min=-math.inf, u_max=math.inf):
        self.inner = TextbookPID(kp, ki, kd, setpoint, u_min, u_max)

    def update(self, measurement, dt):
        return self.inner.update(measurement, dt)


class NoAntiWindup(GoodPID):
    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.inner.anti_windup = False


class DerivativeOnError(GoodPID):
    def __init__(self, kp, ki, kd, setpoint=0.0, u_min=-math.inf, u_max=math.inf):
        self.kp, self.ki, self.kd, self.setpoint, self.lo, self.hi = kp, ki, kd, setpoint, u_min, u_max
        self.i, self.last = 0.0, None

    def update(self, y, dt):
        e = self.setpoint - y
        self.i += e * dt
        d = 0.0 if self.last is None else (e - self.last) / dt
        self.last = e
        return min(self.hi, max(self.lo, self.kp * e + self.ki * self.i + self.kd * d))


def test_textbook_pid_check():
    assert "settles in" in checks.check_textbook_pid(GoodPID)
    with pytest.raises(CheckFailed, match="wound up"):
        checks.check_textbook_pid(NoAntiWindup)
    with pytest.raises(CheckFailed, match="derivative kick"):
        checks.check_textbook_pid(DerivativeOnError)


def test_seed_form_diverges_on_the_servo():
    settle, ys = checks.servo_response(checks.seed_form_update(3.0, 3.0, 0.3, 1.0), strict=False)
    assert settle == checks.SERVO["T"]


def test_delay_margin_check():
    def right(loop):
        _, pm, _, wc = control.margin(loop)
        return math.radians(pm) / wc

    def degrees(loop):
        _, pm, _, wc = control.margin(loop)
        return pm / wc

    assert "ms" in checks.check_delay_margin(right)
    with pytest.raises(CheckFailed, match="radians"):
        checks.check_delay_margin(degrees)


def test_qos_check_rejects_a_replayed_stop_and_a_reliable_imu():
    good = {"battery_state": QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
            "imu": QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT),
            "emergency_stop": QoSProfile(depth=10)}
    assert "e-stop" in checks.check_qos_choice(lambda: good)
    with pytest.raises(CheckFailed, match="stale stop"):
        checks.check_qos_choice(lambda: {**good, "emergency_stop": QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)})
    with pytest.raises(CheckFailed, match="BEST_EFFORT"):
        checks.check_qos_choice(lambda: {**good, "imu": QoSProfile(depth=10)})
    with pytest.raises(CheckFailed, match="incompatible"):
        checks.check_qos_choice(lambda: {**good, "battery_state": QoSProfile(depth=1)})
