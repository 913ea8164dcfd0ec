"""Graded checks of chapter 6 (policy deployment), as probe + judge. Registered as ``ch06.*``.

The probes run the student's code on fresh random inputs and return only what it produced; the
judges compare with the formulas of :mod:`robocourse.rl.export`, :mod:`robocourse.rl.postprocess`
and :class:`robocourse.control.joint_bridge.JointBridge`, computed in the grader. Nothing is timed.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading import Failures, register
from robocourse.grading.probes import call

# --- exercise 1: fold the normalizer into the first layer ----------------------------------------------


def _fold_inputs(rng):
    cases = []
    for n_in, n_out in ((4, 3), (21, 6), (int(rng.integers(5, 30)), int(rng.integers(2, 12)))):
        cases.append({"W": rng.normal(0, 1, (n_out, n_in)).tolist(), "b": rng.normal(0, 1, n_out).tolist(),
                      "mean": rng.normal(0, 3, n_in).tolist(), "std": rng.uniform(0.001, 4, n_in).tolist(),
                      "eps": float(rng.choice([1e-2, 1e-8]))})
    return cases


def _fold_probe(inputs, fold_normalizer):
    def nested(*args):  # keep the matrix's shape (plain data flattens arrays)
        return [np.asarray(v, dtype=float).tolist() for v in fold_normalizer(*args)]

    out = []
    for c in inputs:
        out.append(call(nested, np.array(c["W"]), np.array(c["b"]), np.array(c["mean"]), np.array(c["std"]),
                        c["eps"]))
    return out


@register("ch06.fold_normalizer", weight=2, uses=("fold_normalizer",), probe=_fold_probe, inputs=_fold_inputs,
          references=("robocourse.rl.export:fold_normalizer",))
def check_fold_normalizer(inputs, outputs):
    """fold_normalizer(W, b, mean, std, eps) -> (W', b') with W' x + b' == W (x - mean)/(std + eps) + b."""
    f = Failures()
    for c, got in zip(inputs, outputs, strict=True):
        w, b, mean, std, eps = (np.array(c[k]) for k in ("W", "b", "mean", "std", "eps"))
        where = f"(W {w.shape}, eps {float(eps)})"
        if "raised" in got:
            f.add(f"raised {got['raised']}: {got['message']} {where}")
            continue
        value = got["value"]
        try:
            w2, b2 = (np.asarray(v, dtype=float) for v in value)
        except (TypeError, ValueError):
            f.add(f"return a pair (W_folded, b_folded); got {got.get('type')} {where}")
            continue
        w_ref = w / (std + eps)
        b_ref = b - w_ref @ mean
        if w2.shape != w.shape or b2.shape != b.shape:
            f.add(f"shapes {w2.shape}, {b2.shape}; expected {w.shape}, {b.shape} {where}")
            continue
        if not np.allclose(w2, w_ref, rtol=1e-9, atol=1e-9):
            f.add(f"W' is wrong {where}: divide each column j by std[j] + eps (the scale of input j)")
        if not np.allclose(b2, b_ref, rtol=1e-9, atol=1e-9):
            f.add(f"b' is wrong {where}: expected b - W' @ mean (the mean moves into the bias)")
    return f.done(f"folded {len(inputs)} layers exactly, eps included")


# --- exercise 2: EMA + scale + clipping ---------------------------------------------------------------


def _ema_inputs(rng):
    n = 6
    lower = rng.uniform(-2.0, -0.5, n)
    upper = rng.uniform(0.5, 2.0, n)
    return {"default": rng.uniform(-0.3, 0.3, n).tolist(), "scale": float(rng.choice([0.25, 0.5])),
            "alphas": [0.0, 0.3, 0.8], "lower": lower.tolist(), "upper": upper.tolist(),
            "actions": rng.normal(0, 3, (25, n)).tolist()}


def _ema_probe(inputs, ema_clip):
    out = []
    for alpha in inputs["alphas"]:
        y = np.array(inputs["default"], dtype=float)
        seq = []
        for a in inputs["actions"]:
            rec = call(ema_clip, np.array(a), y.copy(), np.array(inputs["default"]), inputs["scale"], alpha,
                       np.array(inputs["lower"]), np.array(inputs["upper"]))
            seq.append(rec)
            try:
                y = np.asarray(rec["value"][0], dtype=float)
            except (KeyError, TypeError, IndexError, ValueError):
                break
        out.append(seq)
    return out


@register("ch06.ema_clip", weight=2, uses=("ema_clip",), probe=_ema_probe, inputs=_ema_inputs,
          references=("robocourse.rl.postprocess:ActionProcessor",))
def check_ema_clip(inputs, outputs):
    """ema_clip(action, y_prev, default, scale, alpha, lower, upper) -> (y, target, n_clipped)."""
    f = Failures()
    default, lower, upper = (np.array(inputs[k]) for k in ("default", "lower", "upper"))
    for alpha, seq in zip(inputs["alphas"], outputs, strict=True):
        y = default.copy()
        for k, (a, got) in enumerate(zip(inputs["actions"], seq)):
            x = default + inputs["scale"] * np.asarray(a)
            y = alpha * y + (1 - alpha) * x
            want = np.clip(y, lower, upper)
            n = int(np.count_nonzero(want != y))
            if "raised" in got:
                f.add(f"alpha {alpha}, step {k}: raised {got['raised']}: {got['message']}")
                break
            try:
                gy, gt, gn = got["value"]
                gy, gt = np.asarray(gy, dtype=float), np.asarray(gt, dtype=float)
            except (TypeError, ValueError, KeyError):
                f.add(f"return (y, target, n_clipped); got {got.get('type')}")
                break
            if not np.allclose(gy, y, atol=1e-9):
                f.add(f"alpha {alpha}, step {k}: filtered y wrong (expected {np.round(y, 4).tolist()}): "
                      "y = alpha * y_prev + (1 - alpha) * (default + scale * action), alpha weighs the previous "
                      "value; filter the unclipped value and clip only the target")
                break
            if not np.allclose(gt, want, atol=1e-9):
                f.add(f"alpha {alpha}, step {k}: target wrong: clip y to [lower, upper] per joint")
                break
            if gn != n:
                f.add(f"alpha {alpha}, step {k}: n_clipped {gn}, expected {n} (the joints whose target was clipped)")
                break
    return f.done(f"EMA, scale and clipping right over {len(inputs['actions'])} steps for alpha "
                  f"{', '.join(str(a) for a in inputs['alphas'])}")


# --- exercise 3: the bridge's dimension check and command timeout -------------------------------------------


def _bridge_inputs(rng):
    n = int(rng.integers(3, 8))
    timeout = float(rng.choice([0.2, 0.5]))
    events, t = [], 0.0
    q = rng.normal(0, 1, n)
    events.append(["update", t, q.tolist()])                          # no target yet
    for _ in range(6):
        t += 0.01
        events.append(["submit", rng.normal(0, 1, n).tolist(), t])
        t += 0.05
        events.append(["update", t, q.tolist()])
    events.append(["submit", rng.normal(0, 1, n + 1).tolist(), t])    # wrong size
    events.append(["update", t + 0.001, q.tolist()])
    t += timeout + 0.05                                               # the brain stalls
    q2 = rng.normal(0, 1, n)
    events.append(["update", t, q2.tolist()])
    events.append(["update", t + 0.3, (q2 + 1).tolist()])             # still holding q2
    events.append(["submit", rng.normal(0, 1, n).tolist(), t + 0.31])  # fresh: leave the safe mode
    events.append(["update", t + 0.32, q2.tolist()])
    return {"n": n, "timeout": timeout, "events": events}


def _bridge_probe(inputs, MiniBridge):
    made = call(MiniBridge, inputs["n"], inputs["timeout"])
    if "raised" in made:
        return [made]
    bridge = MiniBridge(inputs["n"], inputs["timeout"])
    out = []
    for ev in inputs["events"]:
        if ev[0] == "submit":
            out.append(call(bridge.submit, np.array(ev[1]), ev[2]))
        else:
            out.append(call(bridge.update, ev[1], np.array(ev[2])))
    return out


@register("ch06.bridge_timeout", weight=3, uses=("MiniBridge",), probe=_bridge_probe, inputs=_bridge_inputs,
          references=("robocourse.control.joint_bridge:JointBridge",))
def check_bridge_timeout(inputs, outputs):
    """MiniBridge(n, timeout): submit() rejects a wrong size; update() holds after the timeout, until a fresh target."""
    from robocourse.control.joint_bridge import JointBridge

    f = Failures()
    if len(outputs) == 1 and "raised" in outputs[0]:
        f.add(f"MiniBridge({inputs['n']}, {inputs['timeout']}) raised {outputs[0]['raised']}: {outputs[0]['message']}")
        return f.done("")
    ref = JointBridge([f"j{i}" for i in range(inputs["n"])], timeout=inputs["timeout"])
    for ev, got in zip(inputs["events"], outputs, strict=True):
        if ev[0] == "submit":
            want = ref.submit(np.array(ev[1]), now=ev[2])
            what = f"submit({len(ev[1])} values at t={ev[2]:.3f})"
            if "raised" in got:
                f.add(f"{what} raised {got['raised']}: return False for a wrong size instead")
            elif got.get("value") is not want:
                f.add(f"{what} returned {got.get('value')!r}, expected {want}"
                      + (" (the size differs from n: reject it)" if not want else ""))
        else:
            cmd = ref.update(ev[1], np.array(ev[2]))
            want_mode = "run" if cmd.mode == "run" else "hold"
            what = f"update(t={ev[1]:.3f})"
            if "raised" in got:
                f.add(f"{what} raised {got['raised']}: {got['message']}")
                continue
            try:
                mode, got_targets = got["value"]
                got_targets = np.asarray(got_targets, dtype=float)
            except (TypeError, ValueError, KeyError):
                f.add(f"{what}: return (mode, targets); got {got.get('type')}")
                continue
            if mode != want_mode:
                f.add(f"{what}: mode {mode!r}, expected {want_mode!r} (timeout {inputs['timeout']} s; hold until a "
                      "target arrives after entering the safe mode)")
            elif got_targets.shape != cmd.targets.shape or not np.allclose(got_targets, cmd.targets):
                f.add(f"{what}: targets {np.round(got_targets, 3).tolist()}, expected {np.round(cmd.targets, 3).tolist()}"
                      + (" (hold the position measured when the timeout fired)" if want_mode == "hold" else ""))
    return f.done(f"dimension check, {inputs['timeout']} s timeout, hold and recovery right over "
                  f"{len(inputs['events'])} events")


# --- exercise 4: the observation layout the policy was trained on ---------------------------------------------


def _obs_inputs(rng):
    cases = []
    for _ in range(5):
        cases.append({"q": rng.uniform(-3, 3, 6).tolist(), "dq": rng.normal(0, 2, 6).tolist(),
                      "target": rng.uniform(-0.8, 0.8, 3).tolist(), "last_action": rng.uniform(-1, 1, 6).tolist(),
                      "default_pose": rng.uniform(-2, 2, 6).tolist(), "tcp_default": rng.uniform(-0.6, 0.6, 3).tolist(),
                      "dof_vel_scale": float(rng.choice([0.05, 0.1]))})
    return cases


def _obs_probe(inputs, reach_observation):
    return [call(reach_observation, *(np.array(c[k]) if isinstance(c[k], list) else c[k]
                                      for k in ("q", "dq", "target", "last_action", "default_pose", "tcp_default",
                                                "dof_vel_scale"))) for c in inputs]


@register("ch06.observation", weight=2, uses=("reach_observation",), probe=_obs_probe, inputs=_obs_inputs,
          references=("robocourse.rl.envs:ArmReachEnv", "robocourse.rl.deployment:PolicyDeployment"))
def check_observation(inputs, outputs):
    """reach_observation(...) -> the 21 numbers in the reach task's order."""
    f = Failures()
    for c, got in zip(inputs, outputs, strict=True):
        if "raised" in got:
            f.add(f"raised {got['raised']}: {got['message']}")
            continue
        try:
            obs = np.asarray(got["value"], dtype=float).reshape(-1)
        except (TypeError, ValueError):
            f.add(f"return 21 numbers; got {got.get('type')}")
            continue
        ref = np.concatenate([np.subtract(c["q"], c["default_pose"]), np.multiply(c["dq"], c["dof_vel_scale"]),
                              np.subtract(c["target"], c["tcp_default"]), c["last_action"]])
        if obs.shape != ref.shape:
            f.add(f"{obs.size} numbers; the policy takes 21 (6 + 6 + 3 + 6)")
            continue
        names = ("q - default_pose", "dq * dof_vel_scale", "target - tcp_default", "last_action")
        for name, sl in zip(names, (slice(0, 6), slice(6, 12), slice(12, 15), slice(15, 21))):
            if not np.allclose(obs[sl], ref[sl], atol=1e-12):
                f.add(f"entries {sl.start}..{sl.stop - 1} should be {name}")
        if f.messages:
            break
    return f.done(f"the layout matches the training env on {len(inputs)} states")
