"""The student-side half of chapter 6's checks: the probes, run where the student's code runs.

A probe calls the student's code on the grader's inputs (or runs it against a scripted peer) and
returns what came out as plain data; the judges, their expected values and their rules live in
:mod:`robocourse.rl.checks`, which the grading sandbox hides.
"""

from __future__ import annotations

import tempfile
import threading
import time
import traceback
from pathlib import Path

import numpy as np

from robocourse.grading.probes import call


def fold_probe(inputs, fold_normalizer):
    """ch06.fold_normalizer: one call per layer; the pair returned as nested lists (the matrix keeps its shape)."""
    def nested(*args):
        return [np.asarray(v, dtype=float).tolist() for v in fold_normalizer(*args)]

    return {"cases": [call(nested, np.array(c["W"]), np.array(c["b"]), np.array(c["mean"]), np.array(c["std"]),
                           c["eps"]) for c in inputs["cases"]]}


def ema_probe(inputs, ema_clip):
    """ch06.ema_clip: a stream of actions per alpha, each call fed the ``y`` the previous call returned."""
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
                if y.shape != (len(inputs["default"]),):
                    break
            except (KeyError, TypeError, IndexError, ValueError):
                break
        out.append(seq)
    return {"streams": out}


def bridge_probe(inputs, MiniBridge):  # noqa: N803 - the exercise's class name
    """ch06.bridge_timeout: the scripted events, in order, on one MiniBridge."""
    made = call(MiniBridge, inputs["n"], inputs["timeout"])
    if "raised" in made:
        return {"made": made, "events": []}
    bridge = MiniBridge(inputs["n"], inputs["timeout"])
    out = []
    for ev in inputs["events"]:
        if ev[0] == "submit":
            out.append(call(bridge.submit, np.array(ev[1]), ev[2]))
        else:
            out.append(call(bridge.update, ev[1], np.array(ev[2])))
    return {"made": {"value": True}, "events": out}


def joint_state(names, position, velocity):
    """A sensor_msgs/JointState as /joint_states carries it."""
    from robocourse.msgs.sensor_msgs import JointState

    return JointState(name=list(names), position=[float(v) for v in position], velocity=[float(v) for v in velocity],
                      effort=[0.0] * len(names))


def observation_probe(inputs, reach_observation):
    """ch06.observation: one call per /joint_states message (its own joint order, extra joints included)."""
    out = []
    for c in inputs["cases"]:
        msg = joint_state(c["names"], c["position"], c["velocity"])
        out.append(call(reach_observation, msg, list(c["joint_order"]), np.array(c["target"]),
                        np.array(c["last_action"]), np.array(c["default_pose"]), np.array(c["tcp_default"]),
                        c["dof_vel_scale"]))
    return {"cases": out}


# --- ch06.deployment_loop -------------------------------------------------------------------------

def deploy_probe(inputs, deploy):
    """ch06.deployment_loop: ``deploy(robot, spec)`` against a scripted arm, the policy recording its calls.

    The policy (a linear layer from the inputs) is a file; ``spec["policy"]`` are the arguments of
    :func:`robocourse.rl.load_runtime` that load it with a call log and a stall (call number
    ``stall_after + 1`` sleeps ``stall_s``). The arm stops ``settle_s`` after the stalled call
    returned (the brain's recovery seen), or after ``max_s`` of ticks. ``deploy`` runs in a thread
    of this process (the grader waits at most the run's length plus ``grace_s``).
    """
    from robocourse.rl.policy import MLPPolicy
    from robocourse.rl.runtime import read_call_log
    from robocourse.rl.scripted import ScriptedArm

    work = Path(tempfile.mkdtemp(prefix="ch06_deploy_"))
    MLPPolicy([(np.array(inputs["W"]), np.array(inputs["b"]))]).save(work / "policy.npz")
    log = work / "calls.jsonl"
    spec = dict(inputs["spec"])
    spec["policy"] = {"path": str(work / "policy.npz"), "call_log": str(log), "stall_after": inputs["stall_after"],
                      "stall_s": inputs["stall_s"]}
    stalled = inputs["stall_after"] + 1
    settle = float(inputs["settle_s"])

    def stop_when(arm):
        recs = [r for r in read_call_log(log) if r.get("n") == stalled]
        return bool(recs) and time.monotonic() - recs[0]["t"] > settle

    rate = float(spec["rate_hz"])
    arm = ScriptedArm(inputs["joints"], inputs["state_names"], spec["command_joints"], rate,
                      int(inputs["max_s"] * rate), seed=inputs["trajectory_seed"], stop_when=stop_when)
    box: dict = {}

    def run():
        try:
            deploy(arm, spec)
            box["returned"] = True
        except NotImplementedError:
            box["not_implemented"] = True
        except BaseException as exc:  # noqa: BLE001 - the student's error is reported, not raised here
            box["error"] = f"{type(exc).__name__}: {exc}"
            box["trace"] = traceback.format_exc()[-1500:]

    th = threading.Thread(target=run, name="deploy", daemon=True)
    t0 = time.monotonic()
    th.start()
    th.join(inputs["max_s"] + inputs["grace_s"])
    if box.get("not_implemented"):
        raise NotImplementedError("deploy")
    rec = arm.record()
    return {"returned": bool(box.get("returned")), "error": box.get("error"), "trace": box.get("trace"),
            "seconds": time.monotonic() - t0, "arm": rec, "calls": read_call_log(log)[:2000],
            "stall_t": next((r["t"] for r in read_call_log(log) if r.get("n") == stalled), None)}
