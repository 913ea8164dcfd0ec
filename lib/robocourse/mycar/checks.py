"""Checks for chapter 3's exercises (solutions/03_mycar_exercises.ipynb)."""

from __future__ import annotations

import math
import random

from robocourse.grading import CheckFailed, register

from . import kinematics as kin

QUIZ = {
    "wheel encoder ticks at 100 Hz": ("topic", "a continuous stream that many nodes may read"),
    "set the maximum speed limit": ("service", "a quick request with a definite yes/no answer (or a parameter)"),
    "drive to the charging dock": ("action", "long-running, needs progress feedback and must be cancellable"),
    "camera images": ("topic", "a high-rate stream; late frames are useless, so no request/reply"),
    "take one snapshot and return it": ("service", "one request, one answer, quickly"),
    "map the whole room": ("action", "takes minutes, reports progress, may be cancelled"),
    "battery voltage": ("topic", "a periodic stream for whoever listens (dashboards, loggers)"),
    "reset the odometry to zero": ("service", "a quick command that must confirm it was done"),
    "follow a 20-waypoint path": ("action", "long task with feedback (current waypoint) and cancel"),
    "emergency stop button state": ("topic", "a state everyone must see continuously, no round trip"),
}


@register("ch03.kinematics", weight=2, time_limit=10)
def check_kinematics(inverse_kinematics, forward_kinematics):
    """inverse/forward differential-drive kinematics agree with the model and with each other."""
    left, right = inverse_kinematics(0.2, 1.0, 0.15)
    if not (math.isclose(left, 0.125, abs_tol=1e-9) and math.isclose(right, 0.275, abs_tol=1e-9)):
        raise CheckFailed(f"inverse_kinematics(0.2, 1.0, 0.15) = ({left}, {right}); expected (0.125, 0.275): "
                          "each wheel moves at v -+ w * wheel_base / 2 (left is the inner wheel when turning left)")
    rng = random.Random(3)
    for _ in range(200):
        v, w, b = rng.uniform(-1, 1), rng.uniform(-5, 5), rng.uniform(0.05, 0.5)
        vl, vr = inverse_kinematics(v, w, b)
        v2, w2 = forward_kinematics(vl, vr, b)
        ref = kin.twist_to_wheel_speeds(v, w, kin.DiffDriveGeometry(wheel_base=b))
        if not (math.isclose(vl, ref[0], abs_tol=1e-9) and math.isclose(vr, ref[1], abs_tol=1e-9)):
            raise CheckFailed(f"inverse_kinematics({v:.3f}, {w:.3f}, {b:.3f}) = ({vl:.4f}, {vr:.4f}), "
                              f"expected ({ref[0]:.4f}, {ref[1]:.4f})")
        if not (math.isclose(v2, v, abs_tol=1e-9) and math.isclose(w2, w, abs_tol=1e-9)):
            raise CheckFailed(f"forward(inverse(v={v:.3f}, w={w:.3f})) gave ({v2:.4f}, {w2:.4f}): the round trip must "
                              "return the same twist; w = (right - left) / wheel_base")
    return "200 random round trips exact"


@register("ch03.watchdog", weight=2, time_limit=10)
def check_watchdog(Watchdog):
    """Watchdog(timeout): trips once after `timeout` without feed(), re-arms on the next feed()."""
    dog = Watchdog(0.2)
    if dog.update(0.05):
        raise CheckFailed("update(0.05) tripped before any command was ever received: only arm after the first feed()")
    dog.feed(1.0)
    trips = [t / 100 for t in range(101, 200) if dog.update(t / 100)]
    if not trips:
        raise CheckFailed("fed at t=1.0 s, then update() every 10 ms until 1.99 s never returned True; it must trip "
                          "once more than 0.2 s passed without feed()")
    if len(trips) > 1:
        raise CheckFailed(f"update() returned True {len(trips)} times (first at {trips[0]:.2f} s): report the trip once, "
                          "not on every check (the seed logs the stop once)")
    if not (1.2 < trips[0] <= 1.21 + 1e-9):
        raise CheckFailed(f"tripped at {trips[0]:.2f} s for a feed at 1.00 s and timeout 0.2 s; expected at the first "
                          "check later than 1.20 s (1.21 s)")
    if not dog.stopped:
        raise CheckFailed("after the trip, .stopped must be True")
    dog.feed(2.0)
    if dog.stopped:
        raise CheckFailed("a new feed() must re-arm the watchdog (.stopped False): motion resumes on the next command")
    if dog.update(2.1):
        raise CheckFailed("tripped 0.1 s after a feed with a 0.2 s timeout")
    if not dog.update(2.25):
        raise CheckFailed("did not trip again 0.25 s after the second feed")
    return "trips once at 1.21 s, re-arms on feed"


@register("ch03.quiz", weight=2, time_limit=5)
def check_quiz(quiz_answers):
    """Topic, service or action for ten robot features (``quiz_answers()`` returns the dict)."""
    answers = quiz_answers() if callable(quiz_answers) else quiz_answers
    if not isinstance(answers, dict):
        raise CheckFailed(f"quiz_answers() must return a dict feature -> 'topic' | 'service' | 'action', got {type(answers).__name__}")
    missing = [f for f in QUIZ if f not in answers]
    if missing:
        raise CheckFailed(f"answer every feature; missing: {missing}")
    wrong = []
    for feature, (right, why) in QUIZ.items():
        given = str(answers[feature]).strip().lower()
        if given not in ("topic", "service", "action"):
            raise CheckFailed(f"{feature!r}: answer 'topic', 'service' or 'action', not {answers[feature]!r}")
        if given != right:
            wrong.append(f"{feature!r} is a {right}, not a {given}: {why}")
    if wrong:
        raise CheckFailed(f"{len(QUIZ) - len(wrong)}/{len(QUIZ)} right. " + " | ".join(wrong))
    return "10/10"
