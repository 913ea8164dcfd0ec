"""Checks for chapter 3's exercises (solutions/03_mycar_exercises.ipynb), as probe + judge.

Fresh twists, wheel bases and watchdog timings every run; the judges compare with
``mycar.kinematics`` and with the watchdog's stated rule (trip once, re-arm on feed).
"""

from __future__ import annotations

import math

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import call, number, plain

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


def _kin_inputs(rng):
    cases = [[0.2, 1.0, 0.15]]
    cases += [[float(rng.uniform(-1, 1)), float(rng.uniform(-5, 5)), float(rng.uniform(0.05, 0.5))] for _ in range(50)]
    return cases


def _kin_probe(inputs, inverse_kinematics, forward_kinematics):
    out = []
    for v, w, b in inputs:
        inv = call(inverse_kinematics, v, w, b)
        fwd = call(forward_kinematics, *inv["value"], b) if isinstance(inv.get("value"), list) \
            and len(inv["value"]) == 2 else {"raised": "skipped", "message": "inverse_kinematics failed"}
        out.append({"inverse": inv, "forward": fwd})
    return out


def _pair(got) -> tuple[float, float] | None:
    v = got.get("value")
    if not isinstance(v, list) or len(v) != 2:
        return None
    return number(v[0]), number(v[1])


@register("ch03.kinematics", weight=2, time_limit=10, uses=("inverse_kinematics", "forward_kinematics"),
          probe=_kin_probe, inputs=_kin_inputs,
          references=("robocourse.mycar.kinematics:twist_to_wheel_speeds",
                      "robocourse.mycar.kinematics:wheel_speeds_to_twist"))
def check_kinematics(inputs, outputs):
    """inverse/forward differential-drive kinematics agree with the model and with each other."""
    f = Failures()
    for (v, w, b), got in zip(inputs, outputs, strict=True):
        inv = _pair(got["inverse"])
        ref = kin.twist_to_wheel_speeds(v, w, kin.DiffDriveGeometry(wheel_base=b))
        if inv is None:
            f.add(f"inverse_kinematics({v:.3f}, {w:.3f}, {b:.3f}) must return (left, right); got "
                  f"{got['inverse'].get('value', got['inverse'].get('raised'))!r}")
            break
        if not (math.isclose(inv[0], ref[0], abs_tol=1e-9) and math.isclose(inv[1], ref[1], abs_tol=1e-9)):
            hint = ""
            if math.isclose(inv[0], ref[1], abs_tol=1e-9) and math.isclose(inv[1], ref[0], abs_tol=1e-9):
                hint = ": left and right swapped (left is the inner wheel when turning left)"
            f.add(f"inverse_kinematics({v:.3f}, {w:.3f}, {b:.3f}) = ({inv[0]:.4f}, {inv[1]:.4f}), expected "
                  f"({ref[0]:.4f}, {ref[1]:.4f}): each wheel moves at v -+ w * wheel_base / 2{hint}")
            break
    for (v, w, _b), got in zip(inputs, outputs, strict=True):
        fwd = _pair(got["forward"]) if isinstance(got["forward"], dict) else None
        if fwd is None or not (math.isclose(fwd[0], v, abs_tol=1e-9) and math.isclose(fwd[1], w, abs_tol=1e-9)):
            shown = f"({fwd[0]:.4f}, {fwd[1]:.4f})" if fwd else repr(got["forward"].get("raised"))
            f.add(f"forward(inverse(v={v:.3f}, w={w:.3f})) gave {shown}: the round trip must return the same twist; "
                  "w = (right - left) / wheel_base")
            break
    return f.done(f"{len(inputs)} random round trips exact")


def _dog_inputs(rng):
    # binary-exact times (multiples of 1/64 s), so "more than timeout" has no rounding ties
    return {"timeout": float(rng.choice([0.125, 0.25, 0.5])), "feed": float(rng.integers(1, 8)) / 2,
            "step": 1 / 64}


def _dog_probe(inputs, Watchdog):
    timeout, feed, step = inputs["timeout"], inputs["feed"], inputs["step"]
    dog = Watchdog(timeout)
    early = dog.update(0.05)
    dog.feed(feed)
    times = [feed + step * k for k in range(1, int(1.0 / step))]
    trips = [t for t in times if dog.update(t)]
    stopped = getattr(dog, "stopped", None)
    dog.feed(feed + 1.0)
    rearmed = getattr(dog, "stopped", None)
    soon = dog.update(feed + 1.0 + timeout / 2)
    later = dog.update(feed + 1.0 + timeout + 0.05)
    return plain({"early": early, "trips": trips, "stopped": stopped, "rearmed_stopped": rearmed, "soon": soon,
                  "later": later})


@register("ch03.watchdog", weight=2, time_limit=10, uses=("Watchdog",), probe=_dog_probe, inputs=_dog_inputs)
def check_watchdog(inputs, out):
    """Watchdog(timeout): trips once after `timeout` without feed(), re-arms on the next feed()."""
    timeout, feed, step = inputs["timeout"], inputs["feed"], inputs["step"]
    f = Failures()
    if out["early"]:
        f.add("update(0.05) tripped before any command was ever received: only arm after the first feed()")
    trips = [number(t) for t in out["trips"]]
    first_due = next(feed + step * k for k in range(1, 1000) if step * k > timeout)
    if not trips:
        f.add(f"fed at t={feed:.2f} s, then update() every {step * 1e3:g} ms for 1 s never returned True; it must trip once more "
              f"than {timeout:g} s passed without feed()")
    elif len(trips) > 1:
        f.add(f"update() returned True {len(trips)} times (first at {trips[0]:.4f} s): report the trip once, not on "
              "every check (the seed logs the stop once)")
    if trips and trips[0] != first_due:
        f.add(f"tripped at {trips[0]:.4f} s for a feed at {feed:g} s and timeout {timeout:g} s; expected at the "
              f"first check later than {feed + timeout:g} s ({first_due:.4f} s): trip when more than the timeout "
              "passed, not at exactly the timeout")
    if trips and out["stopped"] is not True:
        f.add("after the trip, .stopped must be True")
    if out["rearmed_stopped"] is not False:
        f.add("a new feed() must re-arm the watchdog (.stopped False): motion resumes on the next command")
    if out["soon"]:
        f.add(f"tripped {timeout / 2:g} s after a feed with a {timeout:g} s timeout")
    if not out["later"]:
        f.add(f"did not trip again {timeout + 0.05:g} s after the second feed")
    return f.done(f"trips once at {first_due:.4f} s (timeout {timeout:g} s after a feed at {feed:g} s), re-arms on feed")


def _quiz_probe(inputs, quiz_answers):
    return plain(quiz_answers() if callable(quiz_answers) else quiz_answers)


@register("ch03.quiz", weight=2, time_limit=5, uses=("quiz_answers",), probe=_quiz_probe)
def check_quiz(inputs, answers):
    """Topic, service or action for ten robot features (``quiz_answers()`` returns the dict)."""
    if not isinstance(answers, dict):
        raise CheckFailed("quiz_answers() must return a dict feature -> 'topic' | 'service' | 'action'")
    missing = [f for f in QUIZ if f not in answers]
    if missing:
        raise CheckFailed(f"answer every feature; missing: {missing}")
    wrong, bad = [], []
    for feature, (right, why) in QUIZ.items():
        given = str(answers[feature]).strip().lower()
        if given not in ("topic", "service", "action"):
            bad.append(f"{feature!r}: answer 'topic', 'service' or 'action', not {answers[feature]!r}")
        elif given != right:
            wrong.append(f"{feature!r} is a {right}, not a {given}: {why}")
    if wrong or bad:
        raise CheckFailed(f"{len(QUIZ) - len(wrong) - len(bad)}/{len(QUIZ)} right.", *bad, *wrong)
    return "10/10"
