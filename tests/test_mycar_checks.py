"""Chapter 3's checks pass right answers and explain the usual wrong ones."""

from __future__ import annotations

import pytest

from robocourse.grading import CheckFailed
from robocourse.mycar import checks


def test_kinematics_check():
    inv = lambda v, w, b=0.15: (v - w * b / 2, v + w * b / 2)  # noqa: E731
    fwd = lambda left, right, b=0.15: ((left + right) / 2, (right - left) / b)  # noqa: E731
    assert "round trips" in checks.check_kinematics(inv, fwd)
    swapped = lambda v, w, b=0.15: (v + w * b / 2, v - w * b / 2)  # noqa: E731
    with pytest.raises(CheckFailed, match="inner wheel"):
        checks.check_kinematics(swapped, fwd)
    no_half = lambda left, right, b=0.15: ((left + right) / 2, (right - left) / (2 * b))  # noqa: E731
    with pytest.raises(CheckFailed, match="round trip"):
        checks.check_kinematics(inv, no_half)


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
    assert "trips once" in checks.check_watchdog(Dog)
    with pytest.raises(CheckFailed, match="once"):
        checks.check_watchdog(lambda t: Dog(t, once=False))


def test_quiz_check():
    right = {f: a for f, (a, _) in checks.QUIZ.items()}
    assert checks.check_quiz(lambda: right) == "10/10"
    wrong = dict(right, **{"camera images": "service"})
    with pytest.raises(CheckFailed, match="9/10 right.*camera images"):
        checks.check_quiz(lambda: wrong)
    with pytest.raises(CheckFailed, match="missing"):
        checks.check_quiz(lambda: {})
