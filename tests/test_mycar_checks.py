"""Chapter 3's checks pass right answers and explain the usual wrong ones."""

from __future__ import annotations

import numpy as np

from robocourse.grading.checks import get, run_check
from robocourse.mycar import checks, kinematics


def run(name, *objects, seed=0):
    return run_check(get(name), *objects, rng=np.random.default_rng(seed))


def test_kinematics_check():
    inv = lambda v, w, b=0.15: (v - w * b / 2, v + w * b / 2)  # noqa: E731
    fwd = lambda left, right, b=0.15: ((left + right) / 2, (right - left) / b)  # noqa: E731
    assert "round trips" in run("ch03.kinematics", inv, fwd).message
    swapped = lambda v, w, b=0.15: (v + w * b / 2, v - w * b / 2)  # noqa: E731
    assert "inner wheel" in run("ch03.kinematics", swapped, fwd).message
    no_half = lambda left, right, b=0.15: ((left + right) / 2, (right - left) / (2 * b))  # noqa: E731
    assert "round trip" in run("ch03.kinematics", inv, no_half).message
    lib = lambda v, w, b=0.15: kinematics.twist_to_wheel_speeds(v, w, kinematics.DiffDriveGeometry(wheel_base=b))  # noqa: E731
    r = run("ch03.kinematics", lib, fwd)
    assert r.reason == "delegated" and r.points == 0


class Dog:
    def __init__(self, timeout, once=True):
        self.timeout, self.last, self.stopped, self.once = timeout, None, False, once

    def feed(self, t):
        self.last, self.stopped = t, False

    def update(self, t):
        if self.last is None or (self.stopped and self.once):
            return False
        if t - self.last > self.timeout:
            self.stopped = True
            return True
        return False


def test_watchdog_check():
    for seed in range(4):
        assert "trips once" in run("ch03.watchdog", Dog, seed=seed).message
    assert "report the trip once" in run("ch03.watchdog", lambda t: Dog(t, once=False)).message


class EagerDog(Dog):
    def update(self, t):
        if self.last is not None and not self.stopped and t - self.last >= self.timeout:
            self.stopped = True
            return True
        return False


def test_watchdog_tripping_at_exactly_the_timeout_is_named():
    r = run("ch03.watchdog", EagerDog, seed=1)
    assert r.points == 0 and "not at exactly the timeout" in r.message


def test_quiz_check():
    right = {f: a for f, (a, _) in checks.QUIZ.items()}
    assert run("ch03.quiz", lambda: right).message == "10/10"
    wrong = dict(right, **{"camera images": "service", "battery voltage": "action"})
    lines = run("ch03.quiz", lambda: wrong).message.splitlines()
    assert lines[0] == "8/10 right." and any("camera images" in m for m in lines) and len(lines) == 3
    assert "missing" in run("ch03.quiz", lambda: {}).message
