"""Checks for chapter 2's exercises (solutions/02_pendulum_exercises.ipynb)."""

from __future__ import annotations

import math

import numpy as np

from robocourse.grading import CheckFailed, register

# a position servo with a constant load torque and a torque limit: windup and a broken
# integral show up as slow or no settling
SERVO = {"J": 0.01, "b": 0.05, "load": 0.1, "u_max": 0.5, "setpoint": 1.0, "dt": 0.001, "T": 3.0}
GAINS = {"kp": 3.0, "ki": 3.0, "kd": 0.3}


def servo_response(update, servo=SERVO, strict=True):
    """Run ``update(measurement, dt) -> torque`` on the servo; return (settling time s, angles).

    ``strict``: a non-finite output fails the check (student code); otherwise it counts as a
    diverged controller that never settles (the seed's compounding integral overflows).
    """
    th = w = 0.0
    dt, n = servo["dt"], int(servo["T"] / servo["dt"])
    ys = np.empty(n)
    for k in range(n):
        u = float(update(th, dt))
        if not math.isfinite(u):
            if strict:
                raise CheckFailed(f"update() returned {u!r} at step {k}: the output must be a finite torque")
            return servo["T"], ys[:k]
        u = max(-servo["u_max"], min(servo["u_max"], u))
        w += (u - servo["b"] * w - servo["load"]) / servo["J"] * dt
        th += w * dt
        ys[k] = th
    outside = np.nonzero(np.abs(ys - servo["setpoint"]) > 0.02 * servo["setpoint"])[0]
    settle = (outside[-1] + 1) * dt if len(outside) else 0.0
    return settle, ys


def seed_form_update(kp, ki, kd, setpoint):
    """The seed's PID structure used as a torque controller (its compounding integral)."""
    state = {"i": 0.0, "last": 0.0}

    def update(y, dt):
        e = setpoint - y
        state["i"] = ki * (state["i"] + e * dt)
        d = kd * (e - state["last"]) / dt
        state["last"] = e
        return kp * e + state["i"] + d

    return update


@register("ch02.textbook_pid", weight=3, time_limit=30)
def check_textbook_pid(PID):
    """PID: sums the integral, differentiates the measurement, clamps, and does not wind up."""
    pid = PID(1.0, 2.0, 0.5, setpoint=1.0)
    u1 = pid.update(0.0, 0.1)
    if not math.isclose(u1, 1.2, abs_tol=1e-9):
        raise CheckFailed(f"first update(0.0, 0.1) with kp=1, ki=2, kd=0.5, setpoint=1 returned {u1!r}; expected "
                          "1.2 = kp*1 + ki*(1*0.1) + 0 (integrate before output; no derivative on the first call)")
    u2 = pid.update(0.5, 0.1)
    if not math.isclose(u2, -1.7, abs_tol=1e-9):
        hint = ""
        if math.isclose(u2, -1.7 + 5.0, abs_tol=1e-6):
            hint = " (the derivative term has the wrong sign: use -kd * (measurement - previous) / dt)"
        raise CheckFailed(f"second update(0.5, 0.1) returned {u2!r}; expected -1.7 = 0.5 + 2*0.15 + 0.5*(-5){hint}")
    kick = PID(0.0, 0.0, 1.0, setpoint=0.0)
    kick.update(0.0, 0.01)
    kick.setpoint = 1.0  # a setpoint step with the measurement unchanged
    jump = kick.update(0.0, 0.01)
    if abs(jump) > 1e-9:
        raise CheckFailed(f"a setpoint step with the measurement unchanged produced a derivative output of {jump:.3g}: "
                          "that is a derivative kick; take the derivative of the measurement, not of the error "
                          "(and keep the setpoint in an attribute named setpoint)")
    sat = PID(1.0, 5.0, 0.0, setpoint=10.0, u_min=-1.0, u_max=1.0)
    outs = [sat.update(0.0, 0.01) for _ in range(200)]
    if max(outs) > 1.0 + 1e-12 or min(outs) < -1.0 - 1e-12:
        raise CheckFailed(f"output left [u_min, u_max] = [-1, 1]: saw {min(outs):.3g}..{max(outs):.3g}; clamp it")
    released = sat.update(10.0, 0.01)
    if abs(released) > 0.05:
        raise CheckFailed(f"after 2 s saturated at the limit, the error became 0 and the output is {released:.3f}: "
                          "the integral wound up while saturated. Stop integrating while the output is "
                          "saturated and the error pushes further into saturation (anti-windup).")
    settle, ys = servo_response(PID(GAINS["kp"], GAINS["ki"], GAINS["kd"], setpoint=1.0, u_min=-0.5, u_max=0.5).update)
    seed_settle, _ = servo_response(seed_form_update(GAINS["kp"], GAINS["ki"], GAINS["kd"], 1.0), strict=False)
    overshoot = (ys.max() - 1.0) * 100
    if settle > 1.0 or overshoot > 5.0:
        raise CheckFailed(f"on the servo (kp=3, ki=3, kd=0.3, load 0.1 N m, limit 0.5 N m) your PID settles within 2 % "
                          f"after {settle:.2f} s with {overshoot:.1f} % overshoot; the target is <= 1.0 s and <= 5 %")
    return (f"settles in {settle:.2f} s with {max(overshoot, 0):.1f} % overshoot; the seed's integral form "
            f"{'never settles' if seed_settle >= SERVO['T'] else f'settles in {seed_settle:.2f} s'} with the same gains")


@register("ch02.delay_margin", weight=2, time_limit=30)
def check_delay_margin(delay_margin):
    """delay_margin(loop) returns PM / w_c in seconds for a python-control loop transfer."""
    import control

    from . import analysis, cartpole, jitter

    k = 4.0
    got = delay_margin(control.tf([k], [1, 0]))
    if not math.isclose(got, (math.pi / 2) / k, rel_tol=1e-3):
        raise CheckFailed(f"for L(s) = 4/s (phase margin 90 deg at w_c = 4 rad/s) you returned {got!r}; "
                          f"expected pi/2 / 4 = {math.pi / 8:.4f} s. Convert the phase margin to radians.")
    for name, K, p in (("demo cart-pole", cartpole.DEMO_K, None), ("fast cart-pole", *jitter.fast_design()[::-1])):
        want = analysis.delay_margin(K, p)
        got = delay_margin(analysis.cartpole_loop(K, p))
        if not math.isclose(got, want, rel_tol=0.01):
            raise CheckFailed(f"{name}: you returned {got!r} s, expected {want:.4f} s (PM in rad / gain crossover in rad/s)")
    return f"4/s: {math.pi / 8 * 1e3:.0f} ms; demo cart-pole: {analysis.delay_margin() * 1e3:.0f} ms"


@register("ch02.qos_choice", weight=2, time_limit=10)
def check_qos_choice(choose_qos):
    """choose_qos() picks publisher QoS for three new topics that fit their use."""
    from robocourse.bus import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSCompatibility,
        QoSProfile,
        ReliabilityPolicy,
        qos_check_compatible,
    )

    got = choose_qos()
    if not isinstance(got, dict) or set(got) != {"battery_state", "imu", "emergency_stop"}:
        raise CheckFailed(f"choose_qos() must return a dict with keys battery_state, imu, emergency_stop; got {got!r}")
    for key, q in got.items():
        if not isinstance(q, QoSProfile):
            raise CheckFailed(f"{key}: expected a QoSProfile, got {type(q).__name__}")
    dashboard = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    res = qos_check_compatible(got["battery_state"], dashboard)
    if res.compatibility == QoSCompatibility.ERROR:
        raise CheckFailed(f"battery_state: a dashboard started later subscribes RELIABLE + TRANSIENT_LOCAL and must get "
                          f"the last value at once; your publisher is incompatible: {res.reason}")
    imu = got["imu"]
    if imu.reliability != ReliabilityPolicy.BEST_EFFORT or imu.history != HistoryPolicy.KEEP_LAST or imu.depth > 5:
        raise CheckFailed("imu: 1 kHz samples for a controller want the newest sample, never a retransmitted old one "
                          "or a queue: BEST_EFFORT, KEEP_LAST with a small depth (<= 5)")
    stop = got["emergency_stop"]
    if stop.reliability != ReliabilityPolicy.RELIABLE:
        raise CheckFailed("emergency_stop: a lost stop command is dangerous: it must be RELIABLE")
    if stop.durability != DurabilityPolicy.VOLATILE:
        raise CheckFailed("emergency_stop: TRANSIENT_LOCAL would replay an old stop to every node that starts later "
                          "(a stale stop); keep it VOLATILE")
    return "battery latched for late dashboards, imu lossy and fresh, e-stop reliable and never replayed"
