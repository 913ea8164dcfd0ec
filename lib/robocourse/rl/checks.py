"""Graded checks of chapter 6 (policy deployment): inputs, schemas, sub-tests. Registered as ``ch06.*``.

The probes (:mod:`robocourse.rl.probes`) run the student's code where it runs and send back what it
produced; the judges here compare with the formulas of :mod:`robocourse.rl.export`,
:mod:`robocourse.rl.postprocess`, :class:`robocourse.control.joint_bridge.JointBridge` and, for the
deployment loop, with what a correct brain makes of each tick of the scripted arm
(:class:`robocourse.rl.scripted.ScriptedArm`). Each sub-test scores on its own; every record is
validated against the check's schema first. Exercises 1-4 are never timed; the deployment loop
runs on the wall clock and is judged on what the student's code controls (which state a target
came from, where the policy ran, what was commanded at each tick), never on how fast the machine was.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Any, Array, Bool, Call, Dict, Int, List, Map, Number, Opt, Str

from . import probes

# --- exercise 1: fold the normalizer into the first layer ----------------------------------------------


def _fold_inputs(rng):
    cases = []
    for n_in, n_out in ((4, 3), (21, 6), (int(rng.integers(5, 30)), int(rng.integers(2, 12)))):
        cases.append({"W": rng.normal(0, 1, (n_out, n_in)).tolist(), "b": rng.normal(0, 1, n_out).tolist(),
                      "mean": rng.normal(0, 3, n_in).tolist(), "std": rng.uniform(0.001, 4, n_in).tolist(),
                      "eps": float(rng.choice([1e-2, 1e-8]))})
    return {"cases": cases}


def _fold_cases(inputs, outputs):
    """(case, reference W', b', the student's pair or None, where) per case; raised/shape problems in f."""
    f, rows = Failures(), []
    for c, got in zip(inputs["cases"], outputs["cases"], strict=True):
        w, b, mean, std, eps = (np.array(c[k]) for k in ("W", "b", "mean", "std", "eps"))
        where = f"(W {w.shape}, eps {float(eps)})"
        w_ref = w / (std + eps)
        pair = None
        if "raised" in got:
            f.add(f"raised {got['raised']}: {got['message']} {where}")
        else:
            try:
                w2, b2 = (np.asarray(v, dtype=float) for v in got["value"])
                if w2.shape != w.shape or b2.shape != b.shape:
                    f.add(f"shapes {w2.shape}, {b2.shape}; expected {w.shape}, {b.shape} {where}")
                else:
                    pair = (w2, b2)
            except (TypeError, ValueError):
                f.add(f"return a pair (W_folded, b_folded) of arrays; got {got.get('type')} {where}")
        rows.append((w_ref, b - w_ref @ mean, pair, where))
    return f, rows


def _fold_weights(inputs, outputs):
    f, rows = _fold_cases(inputs, outputs)
    for w_ref, _b_ref, pair, where in rows:
        if pair is not None and not np.allclose(pair[0], w_ref, rtol=1e-9, atol=1e-9):
            f.add(f"W' is wrong {where}: divide each column j by std[j] + eps (the scale of input j)")
    return f.done("W' = W / (std + eps), column by column, eps included")


def _fold_bias(inputs, outputs):
    f, rows = _fold_cases(inputs, outputs)
    for _w_ref, b_ref, pair, where in rows:
        if pair is not None and not np.allclose(pair[1], b_ref, rtol=1e-9, atol=1e-9):
            f.add(f"b' is wrong {where}: expected b - W' @ mean (the mean moves into the bias)")
    return f.done("b' = b - W' @ mean")


register("ch06.fold_normalizer", uses=("fold_normalizer",), probe=probes.fold_probe, inputs=_fold_inputs,
         references=("robocourse.rl.export:fold_normalizer",),
         schema=Dict(cases=List(Call(List(Any(max_items=5000), min_len=0, max_len=10)), length="cases")),
         subtests=[SubTest("W' divides each input's column by std + eps", 1.0, _fold_weights),
                   SubTest("b' moves the mean into the bias: b - W' @ mean", 1.0, _fold_bias)])


# --- exercise 2: EMA + scale + clipping ---------------------------------------------------------------


def _ema_inputs(rng):
    n = 6
    lower = rng.uniform(-2.0, -0.5, n)
    upper = rng.uniform(0.5, 2.0, n)
    return {"default": rng.uniform(-0.3, 0.3, n).tolist(), "scale": float(rng.choice([0.25, 0.5])),
            "alphas": [0.0, 0.3, 0.8], "lower": lower.tolist(), "upper": upper.tolist(),
            "actions": rng.normal(0, 3, (25, n)).tolist()}


def _ema_steps(inputs, outputs):
    """Yield (alpha, step, y_ref, target_ref, n_ref, (gy, gt, gn) or None); problems of form in f."""
    f, rows = Failures(), []
    default, lower, upper = (np.array(inputs[k]) for k in ("default", "lower", "upper"))
    for alpha, seq in zip(inputs["alphas"], outputs["streams"], strict=True):
        y = default.copy()
        for k, (a, got) in enumerate(zip(inputs["actions"], seq)):
            y = alpha * y + (1 - alpha) * (default + inputs["scale"] * np.asarray(a))
            want = np.clip(y, lower, upper)
            if "raised" in got:
                f.add(f"alpha {alpha}, step {k}: raised {got['raised']}: {got['message']}")
                break
            try:
                gy, gt, gn = got["value"]
                gy, gt = np.asarray(gy, dtype=float), np.asarray(gt, dtype=float)
                if gy.shape != y.shape or gt.shape != y.shape:
                    raise ValueError
            except (TypeError, ValueError):
                f.add(f"return (y, target, n_clipped), y and target of {len(y)} values; got {got.get('type')}")
                break
            rows.append((alpha, k, y.copy(), want, int(np.count_nonzero(want != y)), (gy, gt, gn)))
            if not np.allclose(gy, y, atol=1e-9):
                break                                   # the stream diverged: later steps say nothing new
    return f, rows


def _ema_filter(inputs, outputs):
    f, rows = _ema_steps(inputs, outputs)
    for alpha, k, y, _t, _n, (gy, _gt, _gn) in rows:
        if not np.allclose(gy, y, atol=1e-9):
            f.add(f"alpha {alpha}, step {k}: filtered y {np.round(gy, 4).tolist()}, expected {np.round(y, 4).tolist()}: "
                  "y = alpha * y_prev + (1 - alpha) * (default + scale * action), alpha weighs the previous value; "
                  "filter the unclipped value and clip only the target")
            break
    return f.done(f"y right over {len(inputs['actions'])} steps for alpha {', '.join(map(str, inputs['alphas']))}")


def _ema_target(inputs, outputs):
    f, rows = _ema_steps(inputs, outputs)
    for alpha, k, _y, _want, _n, (gy, gt, _gn) in rows:
        # judged on the student's own y: clip(their y) must be their target
        if not np.allclose(gt, np.clip(gy, inputs["lower"], inputs["upper"]), atol=1e-9):
            f.add(f"alpha {alpha}, step {k}: target {np.round(gt, 4).tolist()} is not y clipped to [lower, upper] "
                  "per joint")
            break
    return f.done("target = clip(y, lower, upper) per joint")


def _ema_count(inputs, outputs):
    f, rows = _ema_steps(inputs, outputs)
    for alpha, k, _y, _want, _n, (gy, _gt, gn) in rows:
        n = int(np.count_nonzero(np.clip(gy, inputs["lower"], inputs["upper"]) != gy))
        if not (isinstance(gn, (int, np.integer)) and not isinstance(gn, bool) and int(gn) == n):
            f.add(f"alpha {alpha}, step {k}: n_clipped {gn!r}, expected {n} (the joints whose target was clipped "
                  "in this call, an int)")
            break
    return f.done("n_clipped counts this call's clipped joints")


register("ch06.ema_clip", uses=("ema_clip",), probe=probes.ema_probe, inputs=_ema_inputs,
         references=("robocourse.rl.postprocess:ActionProcessor",),
         schema=Dict(streams=List(List(Call(List(Any(max_items=200), max_len=5)), max_len=25), length="alphas")),
         subtests=[SubTest("y: the EMA of default + scale * action (alpha weighs the previous, unclipped)", 1.0,
                           _ema_filter),
                   SubTest("target: y clipped to [lower, upper] per joint", 0.5, _ema_target),
                   SubTest("n_clipped: how many joints this call clipped", 0.5, _ema_count)])


# --- exercise 3: the bridge's dimension check and command timeout -------------------------------------------


def _bridge_inputs(rng):
    n = int(rng.integers(3, 8))
    timeout = float(rng.choice([0.2, 0.5]))
    events, t = [], 0.0
    q = rng.normal(0, 1, n)
    events.append(["update", t, q.tolist()])                          # no target yet: hold q
    for _ in range(6):
        t += 0.01
        events.append(["submit", rng.normal(0, 1, n).tolist(), t])
        t += 0.05
        events.append(["update", t, rng.normal(0, 1, n).tolist()])
    events.append(["submit", rng.normal(0, 1, n + 1).tolist(), t])    # wrong size
    events.append(["update", t + 0.001, q.tolist()])
    events.append(["submit", rng.normal(0, 1, n - 1).tolist(), t])    # wrong size, shorter
    t += timeout + 0.05                                               # the brain stalls
    q2 = rng.normal(0, 1, n)
    events.append(["update", t, q2.tolist()])
    events.append(["update", t + 0.3, (q2 + 1).tolist()])             # still holding q2, not the new q
    events.append(["submit", rng.normal(0, 1, n).tolist(), t + 0.31])  # fresh: leave the safe mode
    events.append(["update", t + 0.32, q2.tolist()])
    return {"n": n, "timeout": timeout, "events": events}


def _bridge_expected(inputs):
    """One (event, expected, kind) per event, from the library's JointBridge (kind: submit, run, entry, hold, recover)."""
    from robocourse.control.joint_bridge import JointBridge

    ref = JointBridge([f"j{i}" for i in range(inputs["n"])], timeout=inputs["timeout"])
    rows, was_safe = [], False
    for ev in inputs["events"]:
        if ev[0] == "submit":
            rows.append((ev, ref.submit(np.array(ev[1]), now=ev[2]), "submit"))
            continue
        cmd = ref.update(ev[1], np.array(ev[2]))
        kind = ("entry" if not was_safe else "hold") if ref.safe else ("recover" if was_safe else "run")
        was_safe = ref.safe
        rows.append((ev, ("run" if cmd.mode == "run" else "hold", cmd.targets.copy()), kind))
    return rows


def _bridge_made(outputs):
    if "raised" in outputs["made"]:
        m = outputs["made"]
        raise CheckFailed(f"MiniBridge(n, timeout) raised {m['raised']}: {m['message']}")


def _bridge_judge(kinds, rule, success):
    def judge(inputs, outputs):
        _bridge_made(outputs)
        f = Failures()
        for (ev, want, kind), got in zip(_bridge_expected(inputs), outputs["events"], strict=True):
            if kind not in kinds:
                continue
            if ev[0] == "submit":
                what = f"submit({len(ev[1])} values at t={ev[2]:.3f})"
                if "raised" in got:
                    f.add(f"{what} raised {got['raised']}: return False for a wrong size instead")
                elif got.get("value") is not want:
                    f.add(f"{what} returned {got.get('value')!r}, expected {want} ({rule})")
                continue
            what = f"update(t={ev[1]:.3f})"
            if "raised" in got:
                f.add(f"{what} raised {got['raised']}: {got['message']}")
                continue
            try:
                mode, targets = got["value"]
                targets = np.asarray(targets, dtype=float)
            except (TypeError, ValueError):
                f.add(f"{what}: return (mode, targets); got {got.get('type')}")
                continue
            want_mode, want_targets = want
            if mode != want_mode:
                f.add(f"{what}: mode {mode!r}, expected {want_mode!r} ({rule})")
            elif targets.shape != want_targets.shape or not np.allclose(targets, want_targets):
                f.add(f"{what}: targets {np.round(targets, 3).tolist()}, expected "
                      f"{np.round(want_targets, 3).tolist()} ({rule})")
        return f.done(success)
    return judge


_BRIDGE_SCHEMA = Dict(made=Any(max_items=100),
                      events=List(Call(Any(max_items=200)), max_len=40))

register("ch06.bridge_timeout", uses=("MiniBridge",), probe=probes.bridge_probe, inputs=_bridge_inputs,
         references=("robocourse.control.joint_bridge:JointBridge",), schema=_BRIDGE_SCHEMA,
         subtests=[SubTest("submit() accepts n values and refuses any other size", 0.75,
                           _bridge_judge({"submit"}, "a target of the wrong size is refused: the previous one stays",
                                         "sizes checked")),
                   SubTest("update() runs the newest target while targets are fresh", 0.75,
                           _bridge_judge({"run"}, "within the timeout, the newest accepted target",
                                         "the newest target while fresh")),
                   SubTest("no target yet, or none for longer than timeout: hold the position measured then", 1.0,
                           _bridge_judge({"entry", "hold"}, "safe mode: ('hold', the q of the update that entered it),"
                                         " the same q until a fresh target", "hold at the measured position")),
                   SubTest("back to 'run' on a target submitted after the hold began", 0.5,
                           _bridge_judge({"recover"}, "a fresh target submitted after entering the safe mode ends it",
                                         "recovers on a fresh target"))])


# --- exercise 4: the observation from /joint_states, by name ---------------------------------------------------

_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
           "wrist_3_joint")
_EXTRA = ("finger_joint", "right_finger_joint")


def _obs_inputs(rng):
    cases = []
    for i in range(5):
        order = [_JOINTS[int(k)] for k in rng.permutation(6)]
        names = list(_JOINTS) + list(_EXTRA[: int(rng.integers(0, 3))])
        names = sorted(names) if i % 2 == 0 else [names[int(k)] for k in rng.permutation(len(names))]
        cases.append({"names": names, "position": rng.uniform(-3, 3, len(names)).tolist(),
                      "velocity": rng.normal(0, 2, len(names)).tolist(), "joint_order": order,
                      "target": rng.uniform(-0.8, 0.8, 3).tolist(), "last_action": rng.uniform(-1, 1, 6).tolist(),
                      "default_pose": rng.uniform(-2, 2, 6).tolist(), "tcp_default": rng.uniform(-0.6, 0.6, 3).tolist(),
                      "dof_vel_scale": float(rng.choice([0.05, 0.1]))})
    return {"cases": cases}


def _obs_block(name, sl, reference, rule):
    def judge(inputs, outputs):
        f = Failures()
        for i, (c, got) in enumerate(zip(inputs["cases"], outputs["cases"], strict=True)):
            if "raised" in got:
                f.add(f"message {i} (names {c['names'][:3]}...): raised {got['raised']}: {got['message']}")
                break
            obs = np.asarray(got["value"], dtype=float).reshape(-1)
            if obs.size != 21:
                f.add(f"{obs.size} numbers; the policy takes 21 (6 + 6 + 3 + 6)")
                break
            want = reference(c)
            if not np.allclose(obs[sl], want, atol=1e-12):
                f.add(f"entries {sl.start}..{sl.stop - 1} should be {name} ({rule}); for /joint_states named "
                      f"{c['names'][:3]}... and joint_order {c['joint_order'][:3]}... expected "
                      f"{np.round(want, 3).tolist()}, got {np.round(obs[sl], 3).tolist()}")
                break
        return f.done(f"{name} right on {len(inputs['cases'])} messages")
    return judge


def _by_name(c, field):
    where = {n: i for i, n in enumerate(c["names"])}
    return np.asarray(c[field])[[where[j] for j in c["joint_order"]]]


register("ch06.observation", uses=("reach_observation",), probe=probes.observation_probe, inputs=_obs_inputs,
         references=("robocourse.rl.envs:ArmReachEnv", "robocourse.rl.brain:Brain"),
         schema=Dict(cases=List(Call(Array((None,), max_items=1000)), length="cases")),
         subtests=[SubTest("q - default_pose, each joint looked up by name", 0.5,
                           _obs_block("q - default_pose", slice(0, 6),
                                      lambda c: _by_name(c, "position") - np.asarray(c["default_pose"]),
                                      "positions in joint_order, found by name in /joint_states")),
                   SubTest("dq * dof_vel_scale, by name", 0.5,
                           _obs_block("dq * dof_vel_scale", slice(6, 12),
                                      lambda c: _by_name(c, "velocity") * c["dof_vel_scale"],
                                      "velocities in joint_order, found by name, scaled")),
                   SubTest("target - tcp_default", 0.5,
                           _obs_block("target - tcp_default", slice(12, 15),
                                      lambda c: np.subtract(c["target"], c["tcp_default"]),
                                      "the target relative to the default TCP position")),
                   SubTest("the last action", 0.5,
                           _obs_block("last_action", slice(15, 21), lambda c: np.asarray(c["last_action"]),
                                      "the previous action, as given"))])


# --- exercise 5: the deployment loop -----------------------------------------------------------------



def _deploy_inputs(rng):
    joints = list(_JOINTS)
    policy_joints = [joints[int(i)] for i in rng.permutation(6)]
    command_joints = list(joints) if rng.random() < 0.5 else [joints[int(i)] for i in rng.permutation(6)]
    state_names = sorted(joints + list(_EXTRA)) if rng.random() < 0.5 else \
        [n for n in np.array(joints + list(_EXTRA))[rng.permutation(8)]]
    spec = {"policy_joints": policy_joints, "command_joints": command_joints,
            "default_pose": rng.uniform(-1.0, 1.0, 6).round(4).tolist(), "action_scale": 0.5, "dof_vel_scale": 0.05,
            "target": rng.uniform(-0.6, 0.6, 3).round(4).tolist(), "tcp_default": rng.uniform(-0.6, 0.6, 3).round(4).tolist(),
            "decimation": int(rng.choice([4, 5])), "timeout": float(rng.choice([0.2, 0.3])), "rate_hz": 100.0}
    w = rng.normal(0.0, 0.06, (6, 21))   # small enough that clip(action, -1, 1) never saturates: every state
    w[:, 15:] = 0.0      # gives its own target; the last action is in the observation, but the grader's policy
    #                      ignores it: each target then tells which /joint_states it came from, however many
    #                      targets a brain never handed over
    return {"joints": joints, "state_names": [str(n) for n in state_names], "spec": spec,
            "W": w.round(6).tolist(), "b": rng.normal(0.0, 0.1, 6).round(6).tolist(),
            "trajectory_seed": int(rng.integers(0, 2**31 - 1)), "stall_after": 12, "stall_s": 1.0, "settle_s": 0.6,
            "max_s": 20.0, "grace_s": 15.0}   # max_s: a brain process that starts slowly on a loaded
    #   machine (4 s to start an interpreter at load average 33 here) still reaches its stall; a normal run stops
    #   settle_s after the stall, about 3 s in


class _Deployment:
    """What one run of the student's deploy() did, worked out once per record (judge side)."""

    TOL = 1e-4          # the policy runs in float32 (NumpyRuntime): targets agree to about 1e-6

    def __init__(self, inputs, out):
        from robocourse.rl.scripted import ScriptedArm

        self.inputs, self.out, self.spec = inputs, out, inputs["spec"]
        s = self.spec
        self.rate, self.dec, self.timeout = float(s["rate_hz"]), int(s["decimation"]), float(s["timeout"])
        self.arm = ScriptedArm(inputs["joints"], inputs["state_names"], s["command_joints"], self.rate, 1,
                               seed=inputs["trajectory_seed"])
        self.W, self.b = np.array(inputs["W"]), np.array(inputs["b"])
        self.default = np.array(s["default_pose"])
        self.target_rel = np.subtract(s["target"], s["tcp_default"])
        names = inputs["state_names"]
        self.p_idx = [names.index(j) for j in s["policy_joints"]]
        self.to_cmd = [s["policy_joints"].index(j) for j in s["command_joints"]]
        arm = out["arm"]
        self.n = int(arm["ticks"])
        self.cmd = {int(k): np.array(v, dtype=float) for k, v in arm["commands"].items()}
        served = arm["served"]
        self.wall = {int(r[0]): float(r[1]) for r in served}
        ids = [(int(r[2]), int(r[3])) for r in served]
        self.rt = max(set(ids), key=ids.count) if ids else None
        self.calls = out["calls"]
        self.window = self.n                                          # any earlier tick: a stalled or queued brain lags
        states = [self.arm.state(k) for k in range(self.n + 1)]
        self._q, self._dq = np.array([q for q, _ in states]), np.array([dq for _, dq in states])
        self._classify()

    # the reference brain, vectorised over candidate ticks: the policy's action for the state of each
    # tick in `ticks` after the last action `last`, and the target it becomes
    def _states(self, ticks):
        return self._q[ticks], self._dq[ticks]

    def actions(self, ticks, last, by_index=False):
        q, dq = self._states(ticks)
        cols = slice(0, len(self.p_idx)) if by_index else self.p_idx
        obs = np.hstack([q[:, cols] - self.default, dq[:, cols] * self.spec["dof_vel_scale"],
                         np.tile(self.target_rel, (len(ticks), 1)), np.tile(last, (len(ticks), 1))])
        return np.clip(obs @ self.W.T + self.b, -1.0, 1.0)

    def targets_of(self, acts, mapped=True):
        t = self.default + self.spec["action_scale"] * acts
        return t[:, self.to_cmd] if mapped else t

    def hold_of(self, k):
        return self.arm.joint_positions(k, self.spec["command_joints"])

    def _find(self, ticks, last, c, by_index=False, mapped=True):
        if len(ticks) == 0:
            return None
        acts = self.actions(ticks, last, by_index)
        hit = np.flatnonzero(np.all(np.abs(self.targets_of(acts, mapped) - c) <= self.TOL, axis=1))
        return (int(ticks[hit[0]]), acts[hit[0]]) if len(hit) else None

    def _match(self, k, c, last, by_index=False, mapped=True):
        return self._find(np.arange(k, max(-1, k - self.window - 1), -1), last, c, by_index, mapped)

    def _misread(self, k, c, last):
        """How a wrong deployment would have produced ``c``: the feedback's diagnosis, or None."""
        for kind, kw in (("index", {"by_index": True}), ("policy order", {"mapped": False})):
            m = self._match(k, c, last, **kw)
            if m is not None:
                return (kind, *m)
        return None

    def _classify(self):
        self.events, self.unexplained, self.misread = [], [], []
        last = np.zeros(len(self.p_idx))
        prev = None
        for k in range(self.n):
            c = self.cmd.get(k)
            if c is None or (prev is not None and np.array_equal(c, prev)):
                prev = c if c is not None else prev
                continue
            prev = c
            m = self._match(k, c, last)
            if m is not None:
                self.events.append(("target", k, k - m[0]))
                last = m[1]
                continue
            if any(np.allclose(c, self.hold_of(j), atol=1e-9) for j in (k, k - 1) if j >= 0):
                self.events.append(("hold", k, None))
                continue
            bad = self._misread(k, c, last)
            if bad is not None:
                self.misread.append((bad[0], k))
                self.events.append(("misread", k, k - bad[1]))
                last = bad[2]
                continue
            self.unexplained.append(k)

    def targets(self):
        return [e for e in self.events if e[0] in ("target", "misread")]


def _deployment(inputs, out) -> _Deployment:
    if out.get("error"):
        raise CheckFailed(f"deploy(robot, spec) raised {out['error']}",
                          "the traceback's last lines: " + (out.get("trace") or "")[-300:])
    if not out.get("returned"):
        raise CheckFailed(f"deploy(robot, spec) did not return within {inputs['max_s'] + inputs['grace_s']:g} s; "
                          "it must return once robot.wait_for_tick() returns None (and stop its brain)")
    return _Deployment(inputs, out)


def _deploy_every_tick(inputs, out):
    d = _deployment(inputs, out)
    arm = out["arm"]
    if arm["bad_commands"]:
        raise CheckFailed(f"robot.command() got what it cannot apply: {arm['bad_commands'][0]}")
    if d.n < 20:
        raise CheckFailed(f"the run ended after {d.n} ticks; keep calling robot.wait_for_tick() until it returns None")
    missing = [k for k in range(d.n) if k not in d.cmd]
    if missing:
        first = "from the first tick on: hold the measured position until the first target arrives" \
            if missing[0] == 0 else "every tick, also while the brain is busy or silent"
        raise CheckFailed(f"{len(missing)} of {d.n} ticks had no command (the first at tick {missing[0]}); "
                          f"command {first}")
    return f"a command at each of the {d.n} ticks"


def _deploy_by_name(inputs, out):
    d = _deployment(inputs, out)
    s = d.spec
    got = d.targets()
    if d.misread:
        kind, k = d.misread[0]
        if kind == "index":
            raise CheckFailed(f"the target at tick {k} was computed from /joint_states read in its own order "
                              f"({', '.join(inputs['state_names'][:3])}, ...): look every joint up by name "
                              f"(the policy's order is {', '.join(s['policy_joints'][:3])}, ...)")
        raise CheckFailed(f"the target at tick {k} is in the policy's joint order; the controller takes "
                          f"{', '.join(s['command_joints'][:3])}, ...: map each joint by name")
    if d.unexplained:
        k = d.unexplained[0]
        raise CheckFailed(f"the command at tick {k}, {np.round(d.cmd[k], 4).tolist()}, is neither a policy target "
                          f"(default + action_scale * clip(action, -1, 1), in command_joints order, from one of the "
                          f"recent /joint_states) nor the measured position (hold)")
    if len(got) < 3:
        raise CheckFailed(f"only {len(got)} policy targets reached the robot in {d.n} ticks; the brain must run "
                          f"every {d.dec} ticks and its targets must reach robot.command()")
    return f"{len(got)} targets, each from one /joint_states sample, by name, in the controller's order"


def _before_stall(d: _Deployment) -> list:
    """The targets that reached the robot before the brain's stall: those served before the stalled call
    began (the call log's clock and the arm's are both CLOCK_MONOTONIC), else up to the longest pause
    between targets. (A policy inside the loop stalls the ticks too, so its targets never pause in ticks.)"""
    tgts = d.targets()
    stall_t = d.out.get("stall_t")
    if stall_t is not None:
        began = stall_t - d.inputs["stall_s"]
        return [e for e in tgts if d.wall.get(e[1], float("inf")) < began]
    if len(tgts) < 2:
        return tgts
    gaps = [b[1] - a[1] for a, b in zip(tgts, tgts[1:])]
    return tgts[: int(np.argmax(gaps)) + 1]


STALL_ALLOWANCE_S = 0.03    # a policy step this much longer than decimation asks is the machine's (a stall)


def _decimation_steps(steps, dec: int, allowance: int):
    """(kept, stalls): the steps between the targets' states, less the machine's stalls. A step longer than
    ``dec + allowance`` ticks is a stall (the brain did not get the CPU: a tick-paced brain then misses whole
    windows), and the steps right after it (as many as the windows it missed) are its catch-up (a brain on
    absolute deadlines then runs several steps at once, from states 0-2 ticks apart): neither is the code's."""
    kept, stalls, skip = [], 0, 0
    for st in steps:
        if skip:
            skip -= 1
        elif st > dec + allowance:
            stalls += 1
            skip = max(0, int(round(st / dec)) - 1)
        else:
            kept.append(int(st))
    return kept, stalls


def _deploy_decimation(inputs, out):
    # judged on the states the targets came from (ticks apart), not on the wall clock, by the mean step over
    # the steps the machine did not disturb (see _decimation_steps; measured sandboxed under CpuLoad(2) at load
    # average 18: a tick-paced reference brain starved for 300 ms at a time, steps [5, 5, 5, 5, 5, 10, 35, 30]).
    # Only the steps before the stall: after it a brain on absolute deadlines catches up with many short steps
    # (measured on a loaded machine: 20 steps of 1-3 ticks for decimation 4)
    d = _deployment(inputs, out)
    tgts = _before_stall(d)
    if len(tgts) < 5:
        raise CheckFailed(f"only {len(tgts)} targets reached the robot before the brain stalled; the policy should "
                          f"run every {d.dec} ticks")
    steps = np.diff([k - age for _, k, age in tgts])
    allowance = int(np.ceil(STALL_ALLOWANCE_S * d.rate - 1e-9))
    kept, stalls = _decimation_steps(steps, d.dec, allowance)
    shown = f"steps {steps[:10].tolist()}{' ...' if len(steps) > 10 else ''}"
    if len(kept) < max(3, len(steps) // 4):
        raise CheckFailed(f"{stalls} of {len(steps)} steps between the targets' states were longer than {d.dec} + "
                          f"{allowance} ticks ({shown}): decimation {d.dec} asks for one policy step every {d.dec} "
                          f"ticks (a step up to {STALL_ALLOWANCE_S * 1e3:.0f} ms longer, and a machine's occasional "
                          "stall, are not counted)")
    mean = float(np.mean(kept))
    if mean < d.dec - 1:
        raise CheckFailed(f"the targets came from states {mean:.1f} ticks apart (mean over {len(kept)} steps; {shown}): "
                          f"decimation {d.dec} asks for one policy step every {d.dec} ticks")
    return (f"one policy step every {mean:.2f} ticks (mean over {len(kept)} steps before the stall"
            + (f"; {stalls} longer step(s) the machine's, with their catch-up" if stalls else "")
            + f") for decimation {d.dec}")


def _deploy_latest(inputs, out):
    d = _deployment(inputs, out)
    ages = [e[2] for e in d.targets()]
    if len(ages) < 4:
        raise CheckFailed("too few targets reached the robot to see which state each was built from")
    limit = 2 * d.dec + 4
    third = max(1, len(ages) // 3)
    first, last = float(np.median(ages[:third])), float(np.median(ages[-third:]))
    if float(np.median(ages)) > limit or last > first + d.dec + 4:
        raise CheckFailed(f"each target was built from a state {int(np.median(ages))} ticks old (median; "
                          f"{int(first)} at the start, {int(last)} at the end): hand the brain the newest "
                          f"/joint_states, not the oldest queued one (a latest-value buffer)")
    return f"targets built from states {int(np.median(ages))} ticks old (median)"


def _deploy_safe_mode(inputs, out):
    d = _deployment(inputs, out)
    tgts = [e for e in d.events if e[0] in ("target", "misread")]
    if len(tgts) < 2:
        raise CheckFailed("too few targets reached the robot to see what happens when the brain stops")
    gap, k_a, k_b = max((b[1] - a[1], a[1], b[1]) for a, b in zip(tgts, tgts[1:]))
    stall, _pace = _stall_ticks(d, out)        # the ticks this machine let the loop serve meanwhile
    if gap < 0.5 * stall:
        raise CheckFailed(f"the brain stopped answering for {inputs['stall_s']:g} s (its call {inputs['stall_after'] + 1}) "
                          "but the targets never paused: the control loop waited for the brain")
    t_ticks = d.timeout * d.rate
    last = d.cmd[k_a]
    k_s = next((k for k in range(k_a + 1, k_b) if not np.array_equal(d.cmd.get(k, last), last)), None)
    if k_s is None:
        raise CheckFailed(f"no target for {gap / d.rate:.2f} s (ticks {k_a}-{k_b}) and the robot kept the last one: "
                          f"after timeout = {d.timeout:g} s without a target, hold the measured position")
    if k_s < k_a + t_ticks - 2 or k_s > k_a + t_ticks + 3:
        raise CheckFailed(f"the last target arrived at tick {k_a}; the command changed at tick {k_s}, "
                          f"{(k_s - k_a) / d.rate:.2f} s later; the timeout is {d.timeout:g} s (use the /joint_states "
                          "stamp as the time)")
    held = d.cmd[k_s]
    if not any(np.allclose(held, d.hold_of(j), atol=1e-9) for j in (k_s, k_s - 1)):
        raise CheckFailed(f"after the timeout (tick {k_s}) the command was {np.round(held, 4).tolist()}; the safe mode "
                          f"holds the position measured then, {np.round(d.hold_of(k_s), 4).tolist()}")
    moved = [k for k in range(k_s, k_b) if not np.array_equal(d.cmd.get(k, held), held)]
    if moved:
        raise CheckFailed(f"the held command changed at tick {moved[0]} before a fresh target: hold the position "
                          "measured when the timeout fired")
    return (f"last target held {(k_s - k_a) / d.rate:.2f} s, then the measured position, until a fresh target at "
            f"tick {k_b}")


def _deploy_outside_loop(inputs, out):
    d = _deployment(inputs, out)
    if not d.calls:
        raise CheckFailed("the policy was never called (load it with robocourse.rl.load_runtime(**spec['policy']))")
    inside = [c for c in d.calls if (c["pid"], c["thread"]) == d.rt]
    if inside:
        raise CheckFailed(f"{len(inside)} of {len(d.calls)} policy calls ran in the control loop's own thread: run the "
                          "brain outside the real-time loop")
    return "no policy call in the control loop's thread"


def _deploy_own_process(inputs, out):
    d = _deployment(inputs, out)
    if not d.calls:
        raise CheckFailed("the policy was never called")
    same = [c for c in d.calls if c["pid"] == (d.rt[0] if d.rt else None)]
    if same:
        raise CheckFailed(f"the policy ran in the control loop's process ({len(same)} of {len(d.calls)} calls): in "
                          "CPython a thread there shares the loop's GIL (chapter 6 measured what that costs); "
                          "give the brain a process of its own")
    return "the policy ran in another process"


def _stall_ticks(d: _Deployment, out) -> tuple[float, float]:
    """(ticks a loop that never waits serves during the brain's stall on this machine, its ticks per s before
    the stall): the loop's own pace, not the nominal rate: a starved machine slows every tick alike (measured
    under CpuLoad(2): 56 of 100 served by a loop that never waits); a loop that waits serves about none."""
    stall_s, stall_t = d.inputs["stall_s"], out.get("stall_t")
    before = sorted(w for w in d.wall.values() if stall_t is None or w < stall_t - stall_s)
    pace = (len(before) - 1) / (before[-1] - before[0]) if len(before) > 10 and before[-1] > before[0] else d.rate
    return min(stall_s * d.rate, pace * stall_s), pace


def _deploy_keeps_ticking(inputs, out):
    d = _deployment(inputs, out)
    t_end = out.get("stall_t")
    if t_end is None:
        raise CheckFailed(f"the policy never reached its call {inputs['stall_after'] + 1}, when the brain stalls")
    t0 = t_end - inputs["stall_s"]
    served = sum(1 for w in d.wall.values() if t0 <= w <= t_end)
    want = inputs["stall_s"] * d.rate
    expect, pace = _stall_ticks(d, out)
    if served < 0.6 * expect:
        raise CheckFailed(f"while the brain was stuck for {inputs['stall_s']:g} s the control loop served {served} of "
                          f"{int(want)} ticks ({pace:.0f} per s before the stall on this machine): the loop must not "
                          "wait for the brain")
    return (f"{served} ticks served while the brain was stuck"
            + (f" ({pace:.0f} per s before it: the machine's pace)" if pace < 0.9 * d.rate else ""))


_DEPLOY_SCHEMA = Dict(
    returned=Bool(), error=Opt(Str(max_len=2000)), trace=Opt(Str(max_len=4000)), seconds=Number(lo=0),
    arm=Dict(rate_hz=Number(lo=1, hi=2000), ticks=Int(lo=0, hi=200_000),
             served=Array((None, 4), max_items=800_000), commands=Map(Array((6,)), max_items=200_000),
             bad_commands=List(Str(max_len=400), max_len=20), late_ticks=Int(lo=0), stopped_early=Bool()),
    calls=List(Dict(pid=Int(lo=0), thread=Int(lo=0), thread_name=Str(max_len=200), t=Number(), n=Int(lo=1)),
               max_len=2000),
    stall_t=Opt(Number()))

register("ch06.deployment_loop", uses=("deploy",), probe=probes.deploy_probe, inputs=_deploy_inputs, time_limit=60,
         max_bytes=4_000_000, judge_time_limit=60, schema=_DEPLOY_SCHEMA,
         references=("robocourse.rl.deployment:PolicyDeployment", "robocourse.rl.brain:brain_process_main"),
         subtests=[SubTest("a command every tick, from the first (hold while the brain starts)", 0.5,
                           _deploy_every_tick),
                   SubTest("targets from /joint_states by name, in the controller's joint order", 1.0, _deploy_by_name),
                   SubTest("the policy runs once every `decimation` ticks", 0.5, _deploy_decimation),
                   SubTest("the brain gets the newest state (a latest-value hand-over)", 0.5, _deploy_latest),
                   SubTest("timeout: the last target, then hold the measured position until a fresh target", 1.0,
                           _deploy_safe_mode),
                   SubTest("the policy never runs in the control loop's thread", 0.5, _deploy_outside_loop),
                   SubTest("the policy runs in a process of its own (no GIL shared with the loop)", 0.5,
                           _deploy_own_process),
                   SubTest("the control loop keeps ticking while the brain is stuck", 0.5, _deploy_keeps_ticking)])
