"""Checks for chapter 2's exercises (solutions/02_pendulum_exercises.ipynb), as probe + judge.

The PID probe scripts calls with fresh gains and measurements and runs the closed loop on a
servo; the judge recomputes every expected output from the textbook law and re-simulates the
servo from the student's torques itself. The delay-margin probe builds loop transfer functions
from plain coefficients; the judge names which mistake (degrees, the wrong crossover, Hz, a
product) the answer matches.
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import call, number

# a position servo with a constant load torque and a torque limit: windup and a broken
# integral show up as slow or no settling
SERVO = {"J": 0.01, "b": 0.05, "load": 0.1, "u_max": 0.5, "setpoint": 1.0, "dt": 0.001, "T": 3.0}
GAINS = {"kp": 3.0, "ki": 3.0, "kd": 0.3}


def servo_step(th: float, w: float, u: float, servo=SERVO) -> tuple[float, float]:
    """One explicit-Euler step of the servo under torque ``u`` (clamped to the motor's limit)."""
    u = max(-servo["u_max"], min(servo["u_max"], u))
    w += (u - servo["b"] * w - servo["load"]) / servo["J"] * servo["dt"]
    return th + w * servo["dt"], w


def servo_response(update, servo=SERVO, strict=True):
    """Run ``update(measurement, dt) -> torque`` on the servo; return (settling time s, angles).

    ``strict``: a non-finite output fails the check (student code); otherwise it counts as a
    diverged controller that never settles (the seed's compounding integral overflows).
    """
    th = w = 0.0
    n = int(servo["T"] / servo["dt"])
    ys = np.empty(n)
    for k in range(n):
        u = float(update(th, servo["dt"]))
        if not math.isfinite(u):
            if strict:
                raise CheckFailed(f"update() returned {u!r} at step {k}: the output must be a finite torque")
            return servo["T"], ys[:k]
        th, w = servo_step(th, w, u, servo)
        ys[k] = th
    return settling_time(ys, servo), ys


def settling_time(ys: np.ndarray, servo=SERVO) -> float:
    outside = np.nonzero(np.abs(ys - servo["setpoint"]) > 0.02 * servo["setpoint"])[0]
    return (outside[-1] + 1) * servo["dt"] if len(outside) else 0.0


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


def _pid_inputs(rng):
    return {"kp": round(float(rng.uniform(0.5, 2.0)), 3), "ki": round(float(rng.uniform(0.5, 3.0)), 3),
            "kd": round(float(rng.uniform(0.1, 1.0)), 3), "setpoint": round(float(rng.uniform(0.5, 2.0)), 3),
            "m2": round(float(rng.uniform(0.1, 0.9)), 3), "dt": float(rng.choice([0.01, 0.02, 0.1])),
            "kick_setpoint": round(float(rng.uniform(0.5, 3.0)), 3)}


def _pid_probe(inputs, PID):
    i = inputs
    pid = PID(i["kp"], i["ki"], i["kd"], setpoint=i["setpoint"])
    steps = [pid.update(0.0, i["dt"]), pid.update(i["m2"], i["dt"])]
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
    torques, measured = [], []
    for _ in range(int(SERVO["T"] / SERVO["dt"])):
        u = float(servo.update(th, SERVO["dt"]))
        torques.append(u)
        measured.append(th)
        if not math.isfinite(u):
            break
        th, w = servo_step(th, w, u)
    return {"steps": steps, "kick": jump, "saturated": saturated, "released": released, "torques": torques,
            "measured": measured}


@register("ch02.textbook_pid", weight=3, time_limit=30, uses=("PID",), probe=_pid_probe, inputs=_pid_inputs,
          references=("robocourse.pendulum.pid:TextbookPID",))
def check_textbook_pid(inputs, outputs):
    """PID: sums the integral, differentiates the measurement, clamps, and does not wind up."""
    i = inputs
    f = Failures()
    kp, ki, kd, sp, dt, m2 = i["kp"], i["ki"], i["kd"], i["setpoint"], i["dt"], i["m2"]
    e1, e2 = sp, sp - m2
    want1 = kp * e1 + ki * e1 * dt
    want2 = kp * e2 + ki * (e1 + e2) * dt - kd * (m2 - 0.0) / dt
    u1, u2 = (number(v) for v in outputs["steps"])
    args = f"kp={kp}, ki={ki}, kd={kd}, setpoint={sp}"
    if not math.isclose(u1, want1, rel_tol=1e-9, abs_tol=1e-9):
        f.add(f"first update(0.0, {dt}) with {args} returned {u1!r}; expected {want1:.6g} = kp*e + ki*(e*dt) "
              "(integrate before output; no derivative on the first call)")
    elif not math.isclose(u2, want2, rel_tol=1e-9, abs_tol=1e-9):
        hint = ""
        if math.isclose(u2, want2 + 2 * kd * m2 / dt, rel_tol=1e-6, abs_tol=1e-6):
            hint = " (the derivative term has the wrong sign: use -kd * (measurement - previous) / dt)"
        elif math.isclose(u2, want2 + ki * e1 * dt, rel_tol=1e-6, abs_tol=1e-6):
            hint = " (the integral must be a sum of e*dt, not an accumulated output)"
        f.add(f"second update({m2}, {dt}) returned {u2!r}; expected {want2:.6g} = kp*e + ki*sum(e*dt) "
              f"- kd*(measurement - previous)/dt{hint}")
    jump = number(outputs["kick"])
    if abs(jump) > 1e-9:
        f.add(f"a setpoint step with the measurement unchanged produced a derivative output of {jump:.3g}: that is a "
              "derivative kick; take the derivative of the measurement, not of the error (and keep the setpoint "
              "in an attribute named setpoint)")
    outs = [number(v) for v in outputs["saturated"]]
    if len(outs) != 200:
        raise CheckFailed(f"the saturation test made 200 updates, {len(outs)} outputs came back")
    if max(outs) > 1.0 + 1e-12 or min(outs) < -1.0 - 1e-12:
        f.add(f"output left [u_min, u_max] = [-1, 1]: saw {min(outs):.3g}..{max(outs):.3g}; clamp it")
    released = number(outputs["released"])
    if abs(released) > 0.05:
        f.add(f"after 2 s saturated at the limit, the error became 0 and the output is {released:.3f}: the integral "
              "wound up while saturated. Stop integrating while the output is saturated and the error pushes "
              "further into saturation (anti-windup).")
    torques = [number(v) for v in outputs["torques"]]
    if not torques or not all(math.isfinite(u) for u in torques):
        f.add("on the servo, update() returned a non-finite torque: the output must be a finite number")
        return f.done("")
    if len(torques) != int(SERVO["T"] / SERVO["dt"]):
        raise CheckFailed(f"the servo run returned {len(torques)} torques, expected {int(SERVO['T'] / SERVO['dt'])}")
    # the judge re-simulates the servo from the student's torques: the angles are its own
    th = w = 0.0
    ys = np.empty(len(torques))
    for k, u in enumerate(torques):
        th, w = servo_step(th, w, u)
        ys[k] = th
    settle = settling_time(ys)
    overshoot = (ys.max() - SERVO["setpoint"]) * 100
    seed_settle, _ = servo_response(seed_form_update(GAINS["kp"], GAINS["ki"], GAINS["kd"], 1.0), strict=False)
    if settle > 1.0 or overshoot > 5.0:
        f.add(f"on the servo (kp=3, ki=3, kd=0.3, load 0.1 N m, limit 0.5 N m) your PID settles within 2 % after "
              f"{settle:.2f} s with {overshoot:.1f} % overshoot; the target is <= 1.0 s and <= 5 %")
    seed = "never settles" if seed_settle >= SERVO["T"] else f"settles in {seed_settle:.2f} s"
    return f.done(f"settles in {settle:.2f} s with {max(overshoot, 0):.1f} % overshoot; the seed's integral form "
                  f"{seed} with the same gains")


def _loop_inputs(rng):
    from . import analysis

    k = round(float(rng.uniform(1.0, 10.0)), 3)
    a, b = round(float(rng.uniform(2.0, 5.0)), 3), round(float(rng.uniform(10.0, 30.0)), 3)
    gain = round(float(rng.uniform(0.3, 0.6)) * a, 4)
    # L = gain / (s (s/a + 1) (s/b + 1)): a phase crossover exists, so a wrong-crossover answer differs
    den = np.polymul(np.polymul([1.0, 0.0], [1.0 / a, 1.0]), [1.0 / b, 1.0])
    cart = analysis.cartpole_loop()
    return [{"name": f"L(s) = {k:g}/s", "num": [k], "den": [1.0, 0.0]},
            {"name": f"L(s) = {gain:g}/(s (s/{a:g} + 1)(s/{b:g} + 1))", "num": [gain], "den": den.tolist()},
            {"name": "the demo cart-pole loop", "num": np.ravel(cart.num[0][0]).tolist(),
             "den": np.ravel(cart.den[0][0]).tolist()}]


def _loop_probe(inputs, delay_margin):
    import control

    return [call(delay_margin, control.tf(case["num"], case["den"])) for case in inputs]


@register("ch02.delay_margin", weight=2, time_limit=30, uses=("delay_margin",), probe=_loop_probe,
          inputs=_loop_inputs, references=("robocourse.pendulum.analysis:margins",
                                            "robocourse.pendulum.analysis:delay_margin"))
def check_delay_margin(inputs, outputs):
    """delay_margin(loop) returns PM / w_c in seconds (phase margin in rad, gain crossover in rad/s)."""
    import control

    f = Failures()
    shown = []
    for case, got in zip(inputs, outputs, strict=True):
        _, pm_deg, w_pc, w_gc = control.margin(control.tf(case["num"], case["den"]))
        pm = math.radians(pm_deg)
        want = pm / w_gc
        shown.append(f"{case['name']}: {want * 1e3:.1f} ms")
        if "raised" in got:
            f.add(f"{case['name']}: your delay_margin raised {got['raised']}: {got['message']}")
            continue
        value = number(got["value"])
        if math.isclose(value, want, rel_tol=1e-3):
            continue
        mistakes = [(pm_deg / w_gc, "you divided the phase margin in degrees: convert it to radians first "
                                    "(math.radians)"),
                    (pm / w_pc, "you divided by the phase-crossover frequency (where the phase is -180 deg, the "
                                "gain margin's); use the gain crossover w_c, where |L(jw)| = 1"),
                    (pm / (w_gc / (2 * math.pi)), "you converted the crossover to Hz; keep it in rad/s"),
                    (pm * w_gc, "the delay margin is PM / w_c (seconds), not PM * w_c"),
                    (pm_deg / w_pc, "degrees and the phase-crossover frequency: convert the phase margin to radians "
                                    "and divide by the gain crossover w_c, where |L(jw)| = 1")]
        why = next((text for guess, text in mistakes if math.isfinite(guess) and guess != 0
                    and math.isclose(value, guess, rel_tol=1e-3)), "")
        f.add(f"{case['name']}: you returned {value:.6g} s, expected {want:.6g} s "
              f"(PM {pm_deg:.1f} deg at w_c = {w_gc:.3g} rad/s)" + (f": {why}" if why else ""))
    return f.done("; ".join(shown))


def _qos_probe(inputs, choose_qos):
    got = choose_qos()
    if not isinstance(got, dict):
        return {"type": type(got).__name__}
    out = {}
    for key, q in got.items():
        fields = {"type": type(q).__name__}
        for attr in ("reliability", "durability", "history"):
            value = getattr(q, attr, None)
            fields[attr] = getattr(value, "name", None)
        depth = getattr(q, "depth", None)
        fields["depth"] = depth if isinstance(depth, int) else None
        out[str(key)] = fields
    return {"type": "dict", "profiles": out}


@register("ch02.qos_choice", weight=2, time_limit=10, uses=("choose_qos",), probe=_qos_probe)
def check_qos_choice(inputs, outputs):
    """choose_qos() picks publisher QoS for three new topics that fit their use."""
    from robocourse.bus import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSCompatibility,
        QoSProfile,
        ReliabilityPolicy,
        qos_check_compatible,
    )

    keys = {"battery_state", "imu", "emergency_stop"}
    profiles = outputs.get("profiles") if isinstance(outputs, dict) else None
    if not isinstance(profiles, dict) or set(profiles) != keys:
        raise CheckFailed("choose_qos() must return a dict with keys battery_state, imu, emergency_stop; got "
                          f"{sorted(profiles) if isinstance(profiles, dict) else outputs.get('type')}")
    f = Failures()
    qos = {}
    for key, p in profiles.items():
        if p.get("type") != "QoSProfile" or None in (p.get("reliability"), p.get("durability"), p.get("history")):
            f.add(f"{key}: expected a QoSProfile, got {p.get('type')}")
            continue
        qos[key] = QoSProfile(history=HistoryPolicy[p["history"]], depth=p["depth"] or 1,
                              reliability=ReliabilityPolicy[p["reliability"]],
                              durability=DurabilityPolicy[p["durability"]])
    if "battery_state" in qos:
        dashboard = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                               durability=DurabilityPolicy.TRANSIENT_LOCAL)
        res = qos_check_compatible(qos["battery_state"], dashboard)
        if res.compatibility == QoSCompatibility.ERROR:
            f.add("battery_state: a dashboard started later subscribes RELIABLE + TRANSIENT_LOCAL and must get the "
                  f"last value at once; your publisher is incompatible: {res.reason}")
    if "imu" in qos:
        imu = qos["imu"]
        if imu.reliability != ReliabilityPolicy.BEST_EFFORT or imu.history != HistoryPolicy.KEEP_LAST or imu.depth > 5:
            f.add("imu: 1 kHz samples for a controller want the newest sample, never a retransmitted old one or a "
                  "queue: BEST_EFFORT, KEEP_LAST with a small depth (<= 5)")
    if "emergency_stop" in qos:
        stop = qos["emergency_stop"]
        if stop.reliability != ReliabilityPolicy.RELIABLE:
            f.add("emergency_stop: a lost stop command is dangerous: it must be RELIABLE")
        if stop.durability != DurabilityPolicy.VOLATILE:
            f.add("emergency_stop: TRANSIENT_LOCAL would replay an old stop to every node that starts later (a stale "
                  "stop); keep it VOLATILE")
    return f.done("battery latched for late dashboards, imu lossy and fresh, e-stop reliable and never replayed")
