"""The probe of ``ch05.franka_loop``: the student's pylibfranka loop against a simulated FR3.

Runs in the student's place (the grading sandbox); it gathers, the judge in
:mod:`robocourse.drivers.checks` decides. Two phases, each on the same box (its own process, its
own 127.0.0.x, the robot's limit of 20 lost cycles):

A. the load test: ``run_motion(robot, offset, seconds)`` under chapter 1's CPU load
   (:class:`robocourse.rt.disturb.CpuLoad`), with the grader's ``offset(t)`` pausing a few times
   (seeded, shown in the feedback) for less than 20 cycles (6-12 ms, extended to at least 3
   states of the robot's clock, a starved box sending fewer than one per ms, but never past
   15 ms): a gc pause or a slow step,
   as a real loop meets them. Before it, the grader warms pylibfranka up with a short hold of its
   own, so a cold first cycle is not the student's. A communication reflex is retried (up to
   ``ATTEMPTS`` runs in all: a loaded grading machine can stall any loop once; a loop that blocks
   by itself trips it every time); the record is the last run's, with ``attempts``. Recorded: every ``t`` the loop passed to ``offset``, what it returned or
   raised, the robot's state afterwards and the box's counters.
B. the stall: the same call, with ``offset`` blocking 30 ms once (and until the robot has sent
   25 states): the robot must stop with communication_constraints_violation, and the loop must
   recover and let the exception out.
"""

from __future__ import annotations

import math
import time

_MAX_TS = 20_000
# the load test's parameters (public: the exercise prints them; the seeded draws are in the feedback)
SECONDS = 1.0              # s of robot time per motion
PAUSES = 3                 # pauses inside the loop during phase A, each below the robot's limit
PAUSE_MS = (6, 12)         # ms, whole numbers
STALL_MS = 30              # the stall of phase B: above the robot's 20 lost cycles
ATTEMPTS = 5               # phase A runs again (up to this many times) after a communication reflex
LOAD_PROCESSES = 1         # chapter 1's CpuLoad: one busy process beside the loop


def _offset(amplitude, seconds, pauses, record, robot_ms, min_states=3, max_ms=15.0):
    """The grader's offset(t): a smooth cosine from 0 to ``amplitude`` over ``seconds``. It pauses
    at each (t, ms) of ``pauses`` once, when t first reaches it (inside the student's cycle): for
    ``ms`` of wall time, and until the robot has sent at least ``min_states`` states meanwhile (a
    starved box sends fewer than one per ms), never longer than ``max_ms`` of wall time
    (``robot_ms()`` reads the robot's clock from the box's monitor)."""
    pending = sorted((float(t), float(ms)) for t, ms in pauses)

    def offset(t):
        t = float(t)
        if len(record) < _MAX_TS:
            record.append(t)
        while pending and t >= pending[0][0]:
            ms = pending.pop(0)[1]
            start, t0 = robot_ms(), time.monotonic()
            time.sleep(ms / 1000)
            while robot_ms() - start < min_states and time.monotonic() - t0 < max_ms / 1000:
                time.sleep(0.0005)
        s = min(max(t / seconds, 0.0), 1.0)
        return [a * (1 - math.cos(math.pi * s)) / 2 for a in amplitude]

    return offset


def _warm_up(robot, pylibfranka) -> None:
    """A short hold of the grader's own, so a cold first cycle (code paged in, caches filled) is
    not the student's: 300 cycles at the start position, finished."""
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    try:
        state, _ = control.readOnce()
        cmd = pylibfranka.JointPositions(list(state.q))
        for k in range(300):
            cmd.motion_finished = k == 299
            control.writeOnce(cmd)
            if not cmd.motion_finished:
                control.readOnce()
    except pylibfranka.ControlException:     # this machine stalled the grader's own loop: start clean
        control = None
        robot.automatic_error_recovery()
    del control


def _state(robot) -> dict:
    s = robot.read_once()
    return {"q": [float(x) for x in s.q], "mode": s.robot_mode.name, "errors": str(s.current_errors)}


def _call(run_motion, robot, offset, seconds) -> dict:
    try:
        returned = run_motion(robot, offset, seconds)
        return {"raised": None, "text": "", "returned": repr(returned)[:100]}
    except NotImplementedError:
        raise                     # the exercise left as handed out: the grader says "not implemented"
    except Exception as exc:  # noqa: BLE001 - the student's exception is the data
        return {"raised": type(exc).__name__, "text": str(exc)[:400], "returned": ""}


_COUNTS = ("cycles_moving", "commands_ok", "lost", "late", "reflexes", "motions", "motions_finished", "tcp_StopMove",
           "box_ticks_skipped")
_STATS = ("cycles_moving", "commands_ok", "lost", "late", "max_lost_in_row", "reflexes", "motions",
          "motions_finished", "tcp_StopMove", "box_ticks_skipped", "last_reflex")


def franka_loop_probe(inputs, run_motion):
    import pylibfranka

    from robocourse.rt.disturb import CpuLoad

    from . import box_stats, start_franka_box

    out = {"setup": "", "a": None, "b": None}
    box = start_franka_box()
    try:
        robot = pylibfranka.Robot(box.host, pylibfranka.RealtimeConfig.kIgnore)

        def robot_ms() -> int:
            return int(box_stats(box).get("message_id", 0))

        with CpuLoad(processes=inputs["load_processes"]):
            _warm_up(robot, pylibfranka)
            for attempt in range(1, ATTEMPTS + 1):
                before = _state(robot)
                base = box_stats(box)          # earlier attempts' and the warm-up's counts, subtracted below
                ts: list[float] = []
                offset = _offset(inputs["amplitude"], inputs["seconds"], inputs["pauses"], ts, robot_ms)
                result = _call(run_motion, robot, offset, inputs["seconds"])
                stats = box_stats(box)
                out["a"] = {**result, "q0": before["q"], "after": _state(robot), "ts": ts, "attempts": attempt,
                            "stats": {k: (stats.get(k, 0) - base.get(k, 0)) if k in _COUNTS else stats.get(k, 0)
                                      for k in _STATS}}
                # only the communication reflex is retried: a loaded grading machine can stall any loop
                # once; a loop that blocks by itself trips it every time
                comm = "reflex_communication_constraints_violation"
                if int(stats.get(comm, 0)) - int(base.get(comm, 0)) == 0:   # the robot's own count, not the text
                    break
                if out["a"]["after"]["mode"] != "Idle":
                    robot.automatic_error_recovery()
        if out["a"]["after"]["mode"] != "Idle":   # the loop left the robot stopped: phase B starts clean
            robot.automatic_error_recovery()
        base_b = box_stats(box)
        ts_b: list[float] = []
        # the stall: 30 ms, and until the robot has sent 25 states (past its limit of 20)
        stall = _offset([0.05] * 7, 1.0, [[inputs["stall_at"], inputs["stall_ms"]]], ts_b, robot_ms,
                        min_states=25, max_ms=500.0)
        result = _call(run_motion, robot, stall, 1.0)
        stats_b = box_stats(box)
        out["b"] = {**result, "after": _state(robot), "last_reflex": stats_b.get("last_reflex", ""),
                    "reflexes": int(stats_b.get("reflexes", 0)) - int(base_b.get("reflexes", 0))}
    except NotImplementedError:
        raise
    except Exception as exc:  # noqa: BLE001 - a setup failure is reported, not raised
        out["setup"] = f"{type(exc).__name__}: {str(exc)[:300]}"
    finally:
        box.stop()
    return out
