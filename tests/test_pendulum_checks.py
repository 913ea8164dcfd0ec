"""Chapter 2's checks in the student's kernel: right answers pass on fresh draws, messages name the mistake.

The plausible wrong answers with their partial scores are the bank's (tests/banks/ch02.py).
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from robocourse.bus import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from robocourse.grading import checks as checks_mod
from robocourse.grading.checks import get, run_check, run_probe
from robocourse.pendulum import checks
from robocourse.pendulum.pid import TextbookPID


class GoodPID:
    """The exercise's answer written out (no library code): integral of e*dt, derivative of the
    measurement, clamp, conditional integration as anti-windup."""

    anti_windup = True

    def __init__(self, kp, ki, kd, setpoint=0.0, u_min=-math.inf, u_max=math.inf):
        self.kp, self.ki, self.kd, self.setpoint, self.u_min, self.u_max = kp, ki, kd, setpoint, u_min, u_max
        self.integral, self.previous = 0.0, None

    def update(self, measurement, dt):
        e = self.setpoint - measurement
        candidate = self.integral + e * dt
        d = 0.0 if self.previous is None else -(measurement - self.previous) / dt
        self.previous = measurement
        u = self.kp * e + self.ki * candidate + self.kd * d
        if not self.anti_windup or not ((u > self.u_max and e > 0) or (u < self.u_min and e < 0)):
            self.integral = candidate
        return min(self.u_max, max(self.u_min, u))


class NoAntiWindup(GoodPID):
    anti_windup = False


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


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


class WrongSign(DerivativeOnError):
    def update(self, y, dt):
        e = self.setpoint - y
        cand = self.i + e * dt
        d = 0.0 if self.last is None else (y - self.last) / dt  # + instead of -
        self.last = y
        u = self.kp * e + self.ki * cand + self.kd * d
        if self.lo <= u <= self.hi:
            self.i = cand
        return min(self.hi, max(self.lo, u))


class Unclamped(GoodPID):
    def __init__(self, kp, ki, kd, setpoint=0.0, u_min=-math.inf, u_max=math.inf):
        super().__init__(kp, ki, kd, setpoint)


def delegating(kp, ki, kd, setpoint=0.0, u_min=-math.inf, u_max=math.inf):
    return TextbookPID(kp, ki, kd, setpoint, u_min, u_max)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_textbook_pid_check_passes_a_right_pid_on_fresh_gains(seed):
    r = run("ch02.textbook_pid", GoodPID, seed=seed)
    assert r.points == 3, r.message
    assert "settles in" in r.line() and "never settles" in r.line()


@pytest.mark.parametrize("attempt, fragment, failed", [
    (NoAntiWindup, "wound up", {"anti-windup", "the servo"}),
    (DerivativeOnError, "derivative kick", {"no derivative kick", "anti-windup", "the servo"}),  # no anti-windup either
    (WrongSign, "wrong sign", {"the law", "the servo"}),
    (Unclamped, "clamp the output", {"the output clamped", "anti-windup", "the servo"}),
])
def test_textbook_pid_check_names_the_mistake_in_its_sub_test(attempt, fragment, failed):
    r = run("ch02.textbook_pid", attempt, seed=4)
    assert fragment in r.message, r.message
    failing = {s["name"] for s in r.subtests if not s["passed"]}
    assert failing == {s["name"] for s in r.subtests if any(s["name"].startswith(x) for x in failed)}, failing


def test_textbook_pid_delegation_to_the_library_earns_nothing():
    """GoodPID wraps TextbookPID: the library's own PID is the reference, not the student's work."""
    for attempt in (TextbookPID, delegating):
        r = run("ch02.textbook_pid", attempt)
        assert (r.points, r.reason) == (0, "delegated") and "TextbookPID" in r.message


def test_textbook_pid_judge_resimulates_the_servo_from_the_torques():
    """A forged closed loop (good angles, useless torques) fails: the judge simulates the plant itself."""
    chk = get("ch02.textbook_pid")
    inputs = chk.make_inputs(np.random.default_rng(0))
    honest = run_probe(chk, inputs, [WrongSign])["outputs"]
    from robocourse.pendulum.pid import TextbookPID as Ref

    good = run_probe(chk, inputs, [lambda *a, **k: Ref(*a, **k)])["outputs"]  # gathered with the library's PID
    forged = dict(good, torques=[0.0] * len(good["torques"]))
    r = checks_mod.judge(chk, inputs, {"outputs": forged})
    servo = next(s for s in r.subtests if s["name"].startswith("the servo"))
    assert not servo["passed"] and "settles within 2 %" in servo["message"]
    assert checks_mod.judge(chk, inputs, {"outputs": honest}).points < 3


def test_seed_form_diverges_on_the_servo():
    settle, ys = checks.servo_response(checks.seed_form_update(3.0, 3.0, 0.3, 1.0), strict=False)
    assert settle == checks.SERVO["T"]


def _margins(loop):
    _, pm, w_pc, w_gc = control.margin(loop)
    return math.radians(pm), pm, w_pc, w_gc


@pytest.mark.parametrize("seed", [0, 5])
def test_delay_margin_check_passes_pm_over_gain_crossover(seed):
    r = run("ch02.delay_margin", lambda loop: _margins(loop)[0] / _margins(loop)[3], seed=seed)
    assert r.points == 2 and "demo cart-pole loop" in r.line(), r.line()


@pytest.mark.parametrize("attempt, fragment, not_fragment", [
    (lambda loop: _margins(loop)[1] / _margins(loop)[3], "convert it to radians", "crossover"),
    (lambda loop: _margins(loop)[0] / _margins(loop)[2], "phase-crossover frequency", "radians"),
    (lambda loop: _margins(loop)[0] / (_margins(loop)[3] / (2 * math.pi)), "keep it in rad/s", "radians first"),
    (lambda loop: _margins(loop)[0] * _margins(loop)[3], "not PM * w_c", "radians first"),
])
def test_delay_margin_check_names_the_actual_mistake(attempt, fragment, not_fragment):
    """Issue 16: a wrong crossover was told to "convert the phase margin to radians"."""
    r = run("ch02.delay_margin", attempt, seed=2)
    assert r.points == 0 and fragment in r.message, r.message
    wrong_crossover_lines = [m for m in r.message.splitlines() if fragment in m]
    assert all(not_fragment not in m for m in wrong_crossover_lines), r.message


def test_delay_margin_delegation_to_analysis_earns_nothing():
    from robocourse.pendulum import analysis

    r = run("ch02.delay_margin", lambda loop: analysis.margins(loop)["delay_margin_s"])
    assert r.reason == "delegated" and "analysis.margins" in r.message


def test_qos_check_scores_each_topic_and_lists_every_problem():
    good = {"battery_state": QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
            "imu": QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT),
            "emergency_stop": QoSProfile(depth=10)}
    assert run("ch02.qos_choice", lambda: good).points == 2
    both = {**good, "imu": QoSProfile(depth=10), "emergency_stop": QoSProfile(
        depth=1, reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.TRANSIENT_LOCAL)}
    r = run("ch02.qos_choice", lambda: both)
    assert r.points == 0.75  # the battery sub-test only
    assert "RELIABLE" in r.message and "BEST_EFFORT" in r.message and "stale stop" in r.message
    r = run("ch02.qos_choice", lambda: {"imu": good["imu"]})
    assert r.points == 0.5 and "has no 'battery_state'" in r.message
