"""Checks for chapter 2's exercises (solutions/02_pendulum_exercises.ipynb): inputs, schemas, sub-tests.

The judge side only (hidden from the grading sandbox); the probes are in
:mod:`robocourse.pendulum.probes`. The PID probe scripts calls with fresh gains and
measurements and runs the closed loop on a servo; each property of the exercise (the law, no
kick, the clamp, anti-windup, the servo's settling) is its own sub-test, and the judge
re-simulates the servo from the student's torques itself. The delay-margin judge names which
mistake (degrees, the wrong crossover, Hz, a product) the answer matches.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Call, Dict, Int, List, Map, Number, Opt, Str

from . import probes
from .probes import GAINS, SERVO, servo_step


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


# --- ch02.textbook_pid ---------------------------------------------------------------------------

@functools.cache
def _seed_settle() -> float:
    """The seed's compounding PID on the same servo (the same every time: computed once)."""
    return servo_response(seed_form_update(GAINS["kp"], GAINS["ki"], GAINS["kd"], 1.0), strict=False)[0]


def _pid_inputs(rng):
    # ki never near 1: there the seed's compounding integral ki*(i + e*dt) equals the sum it must be
    ki = float(rng.uniform(0.5, 0.9)) if rng.random() < 0.3 else float(rng.uniform(1.1, 3.0))
    return {"kp": round(float(rng.uniform(0.5, 2.0)), 3), "ki": round(ki, 3),
            "kd": round(float(rng.uniform(0.1, 1.0)), 3), "setpoint": round(float(rng.uniform(0.5, 2.0)), 3),
            "measurements": [round(float(x), 3) for x in rng.uniform(0.1, 0.9, 3)],
            "dt": float(rng.choice([0.01, 0.02, 0.1])), "kick_setpoint": round(float(rng.uniform(0.5, 3.0)), 3)}


N_SERVO = int(SERVO["T"] / SERVO["dt"])
_NUM = Number(finite=False)


def _law(inputs, out):
    i = inputs
    kp, ki, kd, sp, dt = i["kp"], i["ki"], i["kd"], i["setpoint"], i["dt"]
    args = f"PID(kp={kp}, ki={ki}, kd={kd}, setpoint={sp})"
    integral, previous = 0.0, None
    for k, (m, u) in enumerate(zip(i["measurements"], out["steps"], strict=True)):
        e = sp - m
        integral += e * dt
        d = 0.0 if previous is None else -(m - previous) / dt
        want = kp * e + ki * integral + kd * d
        if not math.isclose(u, want, rel_tol=1e-9, abs_tol=1e-9):
            hint = ""
            if k == 0 and math.isclose(u, kp * e, rel_tol=1e-9, abs_tol=1e-9):
                hint = " (integrate before computing the output: the first output already has ki * e * dt)"
            elif k > 0 and math.isclose(u, want - 2 * kd * d, rel_tol=1e-6, abs_tol=1e-6):
                hint = " (the derivative term has the wrong sign: use -kd * (measurement - previous) / dt)"
            elif k > 0 and math.isclose(u, kp * e + ki * (integral - e * dt) + kd * d, rel_tol=1e-6, abs_tol=1e-6):
                hint = " (the output uses last step's integral: add e * dt to the integral before the output)"
            elif k == 0 and math.isclose(u, want - kd * m / dt, rel_tol=1e-6, abs_tol=1e-6):
                hint = " (no derivative on the first call: there is no previous measurement yet)"
            elif k > 0:
                ints = [(sp - x) * dt for x in i["measurements"][:k + 1]]
                compounding = 0.0
                for part in ints:
                    compounding = ki * (compounding + part)
                if math.isclose(u, kp * e + compounding + kd * d, rel_tol=1e-6, abs_tol=1e-6):
                    hint = " (the integral must be a sum of e*dt, not the seed's compounding ki*(i + e*dt))"
            raise CheckFailed(f"{args}: update({m}, {dt}) number {k + 1} returned {u!r}; expected {want:.6g} = "
                              f"kp*e + ki*sum(e*dt) - kd*(measurement - previous)/dt{hint}")
        previous = m
    return ""


def _no_kick(inputs, out):
    jump = out["kick"]
    if not abs(jump) <= 1e-9:
        raise CheckFailed(f"PID(0, 0, 1): a setpoint step from 0 to {inputs['kick_setpoint']} with the measurement "
                          f"unchanged produced an output of {jump:.3g}: that is a derivative kick; take the derivative "
                          "of the measurement, not of the error (and keep the setpoint in an attribute named setpoint)")
    return ""


def _clamp(inputs, out):
    outs = out["saturated"]
    if not (max(outs) <= 1.0 + 1e-12 and min(outs) >= -1.0 - 1e-12):
        raise CheckFailed(f"PID(1, 5, 0, setpoint=10, u_min=-1, u_max=1) at measurement 0: outputs "
                          f"{min(outs):.3g}..{max(outs):.3g} left [u_min, u_max] = [-1, 1]; clamp the output")
    return ""


def _anti_windup(inputs, out):
    released = out["released"]
    if not abs(released) <= 0.05:
        raise CheckFailed(f"PID(1, 5, 0, setpoint=10, u_min=-1, u_max=1) held saturated for 2 s, then the error "
                          f"became 0 and the output is {released:.3f} (expected about 0): the integral wound up while "
                          "saturated. Do not keep the new integral while the output is saturated and the error pushes "
                          "further into saturation (anti-windup).")
    return ""


def _servo(inputs, out):
    torques = out["torques"]
    if not all(math.isfinite(u) for u in torques):
        k = next(k for k, u in enumerate(torques) if not math.isfinite(u))
        raise CheckFailed(f"on the servo, update() returned {torques[k]!r} at step {k}: the output must be a finite "
                          "torque")
    if len(torques) != N_SERVO:
        raise CheckFailed(f"the servo run returned {len(torques)} torques, expected {N_SERVO}")
    # the judge re-simulates the servo from the student's torques: the angles are its own
    th = w = 0.0
    ys = np.empty(len(torques))
    for k, u in enumerate(torques):
        th, w = servo_step(th, w, u)
        ys[k] = th
    settle = settling_time(ys)
    overshoot = (ys.max() - SERVO["setpoint"]) * 100
    if settle > 1.0 or overshoot > 5.0:
        raise CheckFailed(f"on the servo (kp=3, ki=3, kd=0.3, load 0.1 N m, limit 0.5 N m) your PID settles within 2 % "
                          f"after {settle:.2f} s with {overshoot:.1f} % overshoot; the target is <= 1.0 s and <= 5 %")
    seed_settle = _seed_settle()
    seed = "never settles" if seed_settle >= SERVO["T"] else f"settles in {seed_settle:.2f} s"
    return (f"settles in {settle:.2f} s with {max(overshoot, 0):.1f} % overshoot; the seed's integral form {seed} "
            "with the same gains")


register("ch02.textbook_pid", uses=("PID",), probe=probes.pid_probe, inputs=_pid_inputs, time_limit=30,
         references=("robocourse.pendulum.pid:TextbookPID",),
         schema=Dict(steps=List(_NUM, length="measurements"), kick=_NUM, saturated=List(_NUM, length=200),
                     released=_NUM, torques=List(_NUM, min_len=1, max_len=N_SERVO)),
         subtests=[SubTest("the law: kp*e + ki*sum(e*dt) - kd*d(measurement)/dt, integral first", 1.0, _law,
                           reads="steps"),
                   SubTest("no derivative kick when the setpoint jumps", 0.5, _no_kick, reads="kick"),
                   SubTest("the output clamped to [u_min, u_max]", 0.5, _clamp, reads="saturated"),
                   SubTest("anti-windup: no integral build-up while saturated", 0.5, _anti_windup, reads="released"),
                   SubTest("the servo settles within 1 s with at most 5 % overshoot", 0.5, _servo, reads="torques")])


# --- ch02.delay_margin ---------------------------------------------------------------------------

def _margin_inputs(rng):
    from . import analysis

    k = round(float(rng.uniform(1.0, 10.0)), 3)
    a, b = round(float(rng.uniform(2.0, 5.0)), 3), round(float(rng.uniform(10.0, 30.0)), 3)
    gain = round(float(rng.uniform(0.3, 0.6)) * a, 4)
    # L = gain / (s (s/a + 1) (s/b + 1)): a phase crossover exists, so a wrong-crossover answer differs
    den = np.polymul(np.polymul([1.0, 0.0], [1.0 / a, 1.0]), [1.0 / b, 1.0])
    cart = analysis.cartpole_loop()
    return {"cases": [{"name": f"L(s) = {k:g}/s", "num": [k], "den": [1.0, 0.0]},
                      {"name": f"L(s) = {gain:g}/(s (s/{a:g} + 1)(s/{b:g} + 1))", "num": [gain], "den": den.tolist()},
                      {"name": "the demo cart-pole loop", "num": np.ravel(cart.num[0][0]).tolist(),
                       "den": np.ravel(cart.den[0][0]).tolist()}]}


def _margin(inputs, out):
    import control

    f = Failures()
    shown = []
    for case, got in zip(inputs["cases"], out["cases"], strict=True):
        _, pm_deg, w_pc, w_gc = control.margin(control.tf(case["num"], case["den"]))
        pm = math.radians(pm_deg)
        want = pm / w_gc
        shown.append(f"{case['name']}: {want * 1e3:.1f} ms")
        if "raised" in got:
            f.add(f"{case['name']}: your delay_margin raised {got['raised']}: {got['message']}")
            continue
        value = got["value"]
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


register("ch02.delay_margin", uses=("delay_margin",), probe=probes.margin_probe, inputs=_margin_inputs,
         time_limit=30, references=("robocourse.pendulum.analysis:margins", "robocourse.pendulum.analysis:delay_margin"),
         schema=Dict(cases=List(Call(Number(finite=False)), length="cases")),
         subtests=[SubTest("PM in radians over the gain crossover in rad/s, in seconds", 2.0, _margin)])


# --- ch02.qos_choice -----------------------------------------------------------------------------

_POLICY = Opt(Str(max_len=40))
_QOS_SCHEMA = Dict(type=Str(max_len=100), profiles=Opt(Map(Dict(type=Str(max_len=100), reliability=_POLICY,
                                                                durability=_POLICY, history=_POLICY,
                                                                depth=Opt(Int())), max_items=50)))


def _profile(out, key):
    """The student's profile for ``key`` as a QoSProfile, or CheckFailed saying what is missing."""
    from robocourse.bus import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    profiles = out["profiles"]
    if profiles is None:
        raise CheckFailed(f"choose_qos() must return a dict with keys battery_state, imu, emergency_stop; got a "
                          f"{out['type']}")
    if key not in profiles:
        raise CheckFailed(f"choose_qos() has no {key!r}: the dict needs battery_state, imu and emergency_stop "
                          f"(got {sorted(profiles)[:5]})")
    p = profiles[key]
    try:
        return QoSProfile(history=HistoryPolicy[p["history"]], depth=p["depth"] or 1,
                          reliability=ReliabilityPolicy[p["reliability"]], durability=DurabilityPolicy[p["durability"]])
    except (KeyError, TypeError, ValueError):
        raise CheckFailed(f"{key}: expected a QoSProfile, got {p['type']}") from None


def _battery(inputs, out):
    from robocourse.bus import (
        DurabilityPolicy,
        QoSCompatibility,
        QoSProfile,
        ReliabilityPolicy,
        qos_check_compatible,
    )

    q = _profile(out, "battery_state")
    dashboard = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    res = qos_check_compatible(q, dashboard)
    if res.compatibility == QoSCompatibility.ERROR:
        raise CheckFailed("battery_state: a dashboard started later subscribes RELIABLE + TRANSIENT_LOCAL and must get "
                          f"the last value at once; your publisher is incompatible: {res.reason}")
    return "latched for late dashboards"


def _imu(inputs, out):
    from robocourse.bus import HistoryPolicy, ReliabilityPolicy

    q = _profile(out, "imu")
    if q.reliability != ReliabilityPolicy.BEST_EFFORT or q.history != HistoryPolicy.KEEP_LAST or q.depth > 5:
        raise CheckFailed(f"imu: you chose {q.reliability.name}, {q.history.name} depth {q.depth}; 1 kHz samples for a "
                          "controller want the newest sample, never a retransmitted old one or a queue: BEST_EFFORT, "
                          "KEEP_LAST with a small depth (<= 5)")
    return "lossy and fresh"


def _estop(inputs, out):
    from robocourse.bus import DurabilityPolicy, ReliabilityPolicy

    q = _profile(out, "emergency_stop")
    f = Failures()
    if q.reliability != ReliabilityPolicy.RELIABLE:
        f.add(f"emergency_stop: {q.reliability.name} may lose a stop command, which is dangerous: it must be RELIABLE")
    if q.durability != DurabilityPolicy.VOLATILE:
        f.add("emergency_stop: TRANSIENT_LOCAL would replay an old stop to every node that starts later (a stale "
              "stop); keep it VOLATILE")
    return f.done("reliable and never replayed")


register("ch02.qos_choice", uses=("choose_qos",), probe=probes.qos_probe, time_limit=10, schema=_QOS_SCHEMA,
         subtests=[SubTest("battery_state: a late dashboard gets the last value", 0.75, _battery),
                   SubTest("imu: the newest sample, no retransmission, no queue", 0.5, _imu),
                   SubTest("emergency_stop: never lost, never replayed", 0.75, _estop)])
