"""The judge of chapter 5's Franka exercise: ``ch05.franka_loop``.

The student writes ``run_motion(robot, offset, seconds)`` with pylibfranka, the code they would
write for a real FR3: start joint position control, command ``q0 + offset(t)`` each cycle with
``t`` the robot's time since the start (the sum of ``readOnce()``'s durations), end with
``motion_finished`` once ``t >= seconds``; if the robot stops the motion (``ControlException``),
call ``automatic_error_recovery()`` and let the exception out. The probe
(:mod:`robocourse.drivers.franka_probes`) runs it against a simulated FR3 with a few short pauses
inside ``offset``, then once with a 30 ms stall. Sub-tests (4.5 points):

- the motion runs to its end through the pauses (no reflex, no exception): 2. What the machine
  did is kept apart from what the code did (issue 26): the box counts against the loop only the
  lost cycles its thread did not spend waiting for a CPU (``franka_box``'s ``watch``), so a
  correct loop on a loaded grading machine scores full, and the feedback says how many lost
  cycles were the machine's
- ``t`` is the robot's time (it jumps by the pause after each pause; a cycle counter does not): 1
- it starts where the arm is and ends at ``q0 + offset(seconds)``: 0.5
- it ends with ``motion_finished`` (not by dropping the control, which stops the robot): 0.5
- after a 30 ms stall, the reflex reaches the caller, the robot recovered: 0.5

Every sub-test but the first needs the motion to have run to its end: a loop that cannot keep
the robot moving earns nothing (a client that blocks 30 ms scores zero). The robot's limit is
the real one, 20 lost cycles in a row (libfranka's documentation), the same number the chapter
and the box use; the pauses are below it, the stall above it.
"""

from __future__ import annotations

import numpy as np

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Any, Dict, List, Map, Number, Opt, Str

from . import franka_wire as fw
from .franka_probes import PAUSE_MS, PAUSES, SECONDS, STALL_MS, franka_loop_probe

PAUSE_GAP_S = 0.05      # s of robot time at least between two pauses (each moves the robot's clock by up to 14 ms)


def _inputs(rng):
    amplitude = [round(float(a), 3) for a in rng.uniform(0.05, 0.15, 7) * rng.choice([-1, 1], 7)]
    # one pause in each of PAUSES equal slots of 0.2 .. SECONDS - 0.2 s, PAUSE_GAP_S from the slot's edges: two
    # pauses in consecutive cycles add up (the command between them answers a state already lost), and
    # 0.311 s / 0.313 s once made one 21-cycle silence out of two pauses below the limit
    width = (SECONDS - 0.4) / PAUSES
    times = [round(0.2 + k * width + float(rng.uniform(PAUSE_GAP_S / 2, width - PAUSE_GAP_S / 2)), 3)
             for k in range(PAUSES)]
    return {"seconds": SECONDS, "amplitude": amplitude,
            "pauses": [[t, int(rng.integers(PAUSE_MS[0], PAUSE_MS[1] + 1))] for t in times],
            "stall_at": round(float(rng.uniform(0.1, 0.3)), 3), "stall_ms": STALL_MS}


_Q = List(Number(), length=7)
_STATE = Dict(q=_Q, mode=Str(max_len=40), errors=Str(max_len=2000))
_CALL = dict(raised=Opt(Str(max_len=100)), text=Str(max_len=500), returned=Str(max_len=200))
SCHEMA = Dict(setup=Str(max_len=400),
              a=Opt(Dict(**_CALL, q0=_Q, after=_STATE, ts=List(Number(finite=False), max_len=20_000),
                         attempts=Number(integer=True),
                         stats=Map(Any(max_items=10), max_items=20))),
              b=Opt(Dict(**_CALL, after=_STATE, last_reflex=Str(max_len=1000), reflexes=Number(integer=True))))


def _phase_a(inputs, out) -> dict:
    """Phase A's record, or CheckFailed saying why the motion did not run to its end."""
    a = out["a"]
    if a is None:
        raise RuntimeError(f"check error: the probe could not set up the robot: {out['setup']}")
    stats = a["stats"]
    if a["raised"]:
        why = f" (the robot: {stats.get('last_reflex')})" if stats.get("last_reflex") else ""
        tries = f" in each of {a['attempts']} runs" if a["attempts"] > 1 else ""
        own = (f"; your loop's own time without an answer (running or blocked, not waiting for a CPU) reached "
               f"{stats.get('max_own_lost_in_row')} ms, apart from {stats.get('lost_machine', 0)} cycles the machine "
               "held it off the CPU"
               if stats.get("watching") else "")
        if stats.get("reflexes_machine"):
            raise CheckFailed(f"the machine, not your code: in each of {a['attempts']} runs this grading machine held "
                              f"your loop off the CPU past the robot's limit{why}. Grade it again on a quieter "
                              "machine (nothing in your code was found blocking)")
        raise CheckFailed(f"run_motion raised {a['raised']}{tries}: {a['text']}{why}{own}. Through the pauses "
                          f"({', '.join(f'{ms} ms at t = {t} s' for t, ms in inputs['pauses'])}) the loop must keep "
                          f"the robot moving: nothing in the loop may block for {fw.MAX_LOST_IN_ROW} cycles, and the "
                          "command must follow the robot's clock (t from readOnce's durations)")
    if stats.get("reflexes"):
        raise CheckFailed(f"the robot stopped the motion ({stats.get('last_reflex')}) but run_motion returned "
                          f"{a['returned']} without raising: let libfranka's ControlException out")
    return a


def _runs_to_the_end(inputs, out):
    a = _phase_a(inputs, out)
    s = a["stats"]
    if not s.get("motions"):
        raise CheckFailed("run_motion never started a motion: start_joint_position_control(ControllerMode.JointImpedance)")
    if not s.get("commands_ok"):
        raise CheckFailed("the robot never received a command: call control.writeOnce(JointPositions(q)) each cycle")
    machine = (f"; the machine held the loop off the CPU for {s.get('lost_machine')} cycles past the robot's limit "
               "(not counted against your code)" if s.get("lost_machine") else "")
    own = (f"your loop's longest own time without an answer {s.get('max_own_lost_in_row')} ms, "
           if s.get("watching") else "")
    return (f"{s.get('commands_ok')} of {s.get('cycles_moving')} states answered in time through "
            f"{len(inputs['pauses'])} pauses; longest run of lost cycles {s.get('max_lost_in_row')} ({own}the robot "
            f"stops at {fw.MAX_LOST_IN_ROW}){machine}")


def _gated(judge):
    def wrapped(inputs, out):
        try:
            _runs_to_the_end(inputs, out)
        except CheckFailed as exc:
            raise CheckFailed(f"not judged: the motion must run to its end first ({str(exc)[:160]}...)") from None
        return judge(inputs, out)
    return wrapped


def _robot_time(inputs, out):
    ts = np.asarray(out["a"]["ts"], dtype=float)
    f = Failures()
    if len(ts) < 10:
        raise CheckFailed(f"offset(t) was called {len(ts)} times: call it once per cycle")
    if not np.all(np.isfinite(ts)) or np.any(np.diff(ts) < 0):
        raise CheckFailed("the t passed to offset must be finite and never decrease")
    if ts[0] != 0:
        f.add(f"the first t was {ts[0]:.4f} s: the first state of the motion is t = 0 (the duration of that first "
              "read counts the start-up, not the motion); add the durations of the reads after it")
    # each pause made the robot send states the loop never read: robot time then jumps past the
    # cycle count (a cycle counter's t stays at cycles x 1 ms)
    skipped = int(out["a"]["stats"].get("cycles_moving", 0)) - len(ts)
    counted = (len(ts) - 1) * 1e-3
    if skipped >= 3 and ts[-1] < counted + 0.5 * skipped * 1e-3:
        f.add(f"the robot sent {skipped} states your loop never read (during the pauses at t = "
              f"{', '.join(str(t) for t, _ in inputs['pauses'])} s), but your t ended at {ts[-1]:.3f} s after "
              f"{len(ts)} cycles: t must be the robot's time (sum readOnce's durations), not a count of cycles; the "
              "robot extrapolated through each pause and expects the motion where its time says it is")
    if ts[-1] < inputs["seconds"] - 1e-9:
        f.add(f"the last t was {ts[-1]:.3f} s; the motion ends when t >= seconds ({inputs['seconds']} s)")
    return f.done(f"t followed the robot's clock through {len(inputs['pauses'])} pauses ({len(ts)} cycles)")


def _start_and_end(inputs, out):
    a = out["a"]
    q0, q = np.asarray(a["q0"]), np.asarray(a["after"]["q"])
    target = q0 + np.asarray(inputs["amplitude"])
    err = float(np.max(np.abs(q - target)))
    if err > 5e-3:
        raise CheckFailed(f"the arm ended at {np.round(q, 3).tolist()}, {1e3 * err:.1f} mrad from q0 + offset(seconds) = "
                          f"{np.round(target, 3).tolist()}: command q0 + offset(t) with q0 the q of the first state")
    return f"ended {1e3 * err:.2f} mrad from q0 + offset(seconds)"


def _motion_finished(inputs, out):
    s = out["a"]["stats"]
    if s.get("tcp_StopMove") or not s.get("motions_finished"):
        raise CheckFailed("the motion was not ended by a command with motion_finished = True (the control was dropped, "
                          "so libfranka sent StopMove: on a robot that is an abrupt stop). Set cmd.motion_finished = "
                          "True on the last command, once t >= seconds, and stop reading")
    return "ended by a command with motion_finished"


def _reflex_reaches_the_caller(inputs, out):
    b = out["b"]
    if b is None:
        raise CheckFailed(f"after the load test the robot could not be used again: {out['setup']} (end every "
                          "control: finish it, or let it go when an exception leaves the loop)")
    f = Failures()
    if not b["reflexes"]:
        raise RuntimeError("check error: the deliberate stall did not trigger the robot's reflex")
    if b["raised"] != "ControlException" or "communication_constraints_violation" not in b["text"]:
        f.add(f"with offset(t) blocking {inputs['stall_ms']} ms at t = {inputs['stall_at']} s the robot stopped "
              f"({b['last_reflex'] or 'communication_constraints_violation'}), but run_motion "
              + (f"raised {b['raised']}: {b['text'][:120]}" if b["raised"] else f"returned {b['returned']}")
              + ": let libfranka's ControlException out after recovering")
    if b["after"]["mode"] != "Idle" or b["after"]["errors"] not in ("[]", ""):
        f.add(f"after the reflex the robot was left in {b['after']['mode']} with errors {b['after']['errors']}: call "
              "robot.automatic_error_recovery() before raising")
    return f.done(f"a {inputs['stall_ms']} ms stall: ControlException reached the caller, the robot recovered")


register("ch05.franka_loop", uses=("run_motion",), probe=franka_loop_probe, inputs=_inputs, time_limit=90, timing=True,
         schema=SCHEMA,
         subtests=[SubTest("the motion runs to its end through the pauses", 2.0, _runs_to_the_end),
                   SubTest("t is the robot's time (readOnce's durations)", 1.0, _gated(_robot_time)),
                   SubTest("starts where the arm is, ends at q0 + offset(seconds)", 0.5, _gated(_start_and_end)),
                   SubTest("ends with motion_finished", 0.5, _gated(_motion_finished)),
                   SubTest("a reflex reaches the caller after automatic_error_recovery()", 0.5,
                           _gated(_reflex_reaches_the_caller))])
