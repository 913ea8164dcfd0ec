"""The student-side half of chapter 2's checks: the probes, and the servo the PID exercise states.

A probe calls the student's code on the grader's inputs and returns only what came out; the
judges and their expected values are in :mod:`robocourse.pendulum.checks`, which the grading
sandbox hides. The servo (a position servo with a load torque and a torque limit) is stated in
the exercise, so it lives here, where the probe closes the loop with the student's PID.
"""

from __future__ import annotations

import math

from robocourse.grading.probes import call

# a position servo with a constant load torque and a torque limit: windup and a broken
# integral show up as slow or no settling
SERVO = {"J": 0.01, "b": 0.05, "load": 0.1, "u_max": 0.5, "setpoint": 1.0, "dt": 0.001, "T": 3.0}
GAINS = {"kp": 3.0, "ki": 3.0, "kd": 0.3}


def servo_step(th: float, w: float, u: float, servo=SERVO) -> tuple[float, float]:
    """One explicit-Euler step of the servo under torque ``u`` (clamped to the motor's limit)."""
    u = max(-servo["u_max"], min(servo["u_max"], u))
    w += (u - servo["b"] * w - servo["load"]) / servo["J"] * servo["dt"]
    return th + w * servo["dt"], w


def pid_probe(inputs, PID):
    """ch02.textbook_pid: three scripted updates, a setpoint step, 2 s saturated, and the servo loop."""
    i = inputs
    pid = PID(i["kp"], i["ki"], i["kd"], setpoint=i["setpoint"])
    steps = [pid.update(m, i["dt"]) for m in i["measurements"]]
    kick = PID(0.0, 0.0, 1.0, setpoint=0.0)
    kick.update(0.0, 0.01)
    kick.setpoint = i["kick_setpoint"]  # a setpoint step with the measurement unchanged
    jump = kick.update(0.0, 0.01)
    sat = PID(1.0, 5.0, 0.0, setpoint=10.0, u_min=-1.0, u_max=1.0)
    saturated = [sat.update(0.0, 0.01) for _ in range(200)]
    released = sat.update(10.0, 0.01)
    servo = PID(GAINS["kp"], GAINS["ki"], GAINS["kd"], setpoint=SERVO["setpoint"], u_min=-SERVO["u_max"],
                u_max=SERVO["u_max"])
    th = w = 0.0
    torques = []
    for _ in range(int(SERVO["T"] / SERVO["dt"])):
        u = servo.update(th, SERVO["dt"])
        torques.append(u)
        try:
            u = float(u)
        except (TypeError, ValueError):
            break
        if not math.isfinite(u):
            break
        th, w = servo_step(th, w, u)
    return {"steps": steps, "kick": jump, "saturated": saturated, "released": released, "torques": torques}


def margin_probe(inputs, delay_margin):
    """ch02.delay_margin: the student's delay margin of each loop, built as a python-control tf."""
    import control

    return {"cases": [call(delay_margin, control.tf(case["num"], case["den"])) for case in inputs["cases"]]}


def qos_probe(inputs, choose_qos):
    """ch02.qos_choice: each profile's policies by name (and its depth)."""
    got = choose_qos()
    if not isinstance(got, dict):
        return {"type": type(got).__name__, "profiles": None}
    out = {}
    for key, q in list(got.items())[:50]:
        fields = {"type": type(q).__name__}
        for attr in ("reliability", "durability", "history"):
            value = getattr(q, attr, None)
            name = getattr(value, "name", None)
            fields[attr] = name if isinstance(name, str) else None
        depth = getattr(q, "depth", None)
        fields["depth"] = depth if isinstance(depth, int) and not isinstance(depth, bool) else None
        out[str(key)] = fields
    return {"type": "dict", "profiles": out}
