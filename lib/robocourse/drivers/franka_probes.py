"""The probe of ``ch05.franka_loop``: the student's pylibfranka loop against a simulated FR3.

Runs in the student's place (the grading sandbox); it gathers, the judge in
:mod:`robocourse.drivers.checks` decides. Two phases, each on the same box (its own process, its
own 127.0.0.x, the robot's limit of 20 lost cycles):

A. the pause test: ``run_motion(robot, offset, seconds)`` with the grader's ``offset(t)`` pausing
   a few times (seeded, shown in the feedback) for less than 20 cycles (6-12 ms, extended to at
   least 3 states of the robot's clock, a starved box sending fewer than one per ms, but never
   past 14 ms, the reads of that clock included): a gc pause or a slow step, as a real loop
   meets them.

   What the student's code controls is judged apart from what the machine did: the box is told
   which thread runs the loop (:func:`robocourse.drivers.box_watch`) and counts against it only
   the lost cycles that thread did not spend waiting for a CPU (a grading sandbox cannot give
   the loop real-time priority, and a shared machine holds any loop off the CPU now and then;
   the box's counters ``lost_machine``, ``max_own_lost_in_row`` and ``verdicts_deferred`` show
   it). The probe adds no CPU load of its own: what the machine does is not what is graded.
   Before the motion, the grader warms pylibfranka up with a short hold of its own, so a cold
   first cycle is not the student's. Where the box cannot watch the thread (``watching`` false),
   or watched it held off the CPU past the box's cap (``reflexes_machine``), a communication
   reflex is retried, up to ``ATTEMPTS`` runs in all (the record is the last run's, with
   ``attempts``). Recorded: every ``t`` the loop passed to ``offset``, what it returned or
   raised, the robot's state afterwards and the box's counters. The objects that exist before
   the student's code runs (the grader's) are frozen out of the garbage collector (``gc.freeze()``).
B. the stall: the same call, with ``offset`` blocking 30 ms once (and until the robot has sent
   25 states): the robot must stop with communication_constraints_violation, and the loop must
   recover and let the exception out.
"""

from __future__ import annotations

import gc
import math
import time

_MAX_TS = 20_000
# the load test's parameters (public: the exercise prints them; the seeded draws are in the feedback)
SECONDS = 1.0              # s of robot time per motion
PAUSES = 3                 # pauses inside the loop during phase A, each below the robot's limit
PAUSE_MS = (6, 12)         # ms, whole numbers
STALL_MS = 30              # the stall of phase B: above the robot's 20 lost cycles
ATTEMPTS = 5               # phase A runs again after a communication reflex, where the box cannot watch the loop


def _offset(amplitude, seconds, pauses, record, robot_ms, min_states=3, max_ms=14.0):
    """The grader's offset(t): a smooth cosine from 0 to ``amplitude`` over ``seconds``. It pauses
    at each (t, ms) of ``pauses`` once, when t first reaches it (inside the student's cycle): for
    ``ms`` of wall time, and until the robot has sent at least ``min_states`` states meanwhile (a
    starved box sends fewer than one per ms), never longer than ``max_ms`` of wall time in all,
    the reads of the robot's clock included (``robot_ms(timeout)`` reads it from the box's
    monitor, None if the box did not answer within ``timeout`` s: a starved box must not stretch
    the grader's pause past the robot's limit; an 18 ms pause once made 20 lost cycles)."""
    pending = sorted((float(t), float(ms)) for t, ms in pauses)

    def offset(t):
        t = float(t)
        if len(record) < _MAX_TS:
            record.append(t)
        while pending and t >= pending[0][0]:
            ms = pending.pop(0)[1]
            t0 = time.monotonic()
            end = t0 + max_ms / 1000
            start = robot_ms(ms / 2000)
            time.sleep(max(0.0, t0 + ms / 1000 - time.monotonic()))
            # then until the robot has sent min_states, in few long sleeps (each wake-up waits for
            # a CPU on a loaded machine, and the box counts that wait as the machine's)
            while start is not None and (left := end - time.monotonic()) > 0:
                now = robot_ms(left)
                missing = 1 if now is None else min_states - (now - start)
                if missing <= 0:
                    break
                time.sleep(max(0.0, min(missing * 1e-3, end - time.monotonic())))
        s = min(max(t / seconds, 0.0), 1.0)
        return [a * (1 - math.cos(math.pi * s)) / 2 for a in amplitude]

    return offset


class _RobotClock:
    """The box's robot clock (``message_id``, ms) from its monitor socket; None when the answer
    does not come within ``timeout`` (at most the clock's own; a late answer is read, and
    ignored, by the next call)."""

    def __init__(self, box, timeout: float):
        import socket

        self.address = (box.host, box.ports["monitor"])
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.timeout = timeout

    def __call__(self, timeout: float | None = None) -> int | None:
        import json

        self.sock.setblocking(False)
        try:
            while True:
                self.sock.recv(1 << 16)         # answers that came too late
        except (BlockingIOError, ConnectionRefusedError):
            pass
        self.sock.settimeout(max(1e-4, min(self.timeout, self.timeout if timeout is None else timeout)))
        self.sock.sendto(b"clock", self.address)
        try:
            return int(json.loads(self.sock.recv(1 << 16)).get("message_id", 0))
        except (TimeoutError, ConnectionRefusedError, ValueError):
            return None

    def close(self) -> None:
        self.sock.close()


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
        _recover(robot)
    del control


def _state(robot, clock=None) -> dict:
    """The robot's state, from a state the robot sent after ``clock()`` (its message_id now): a
    state still queued from before (a starved box had sent none since the student's
    automatic_error_recovery()) showed a recovered robot in Reflex once."""
    since = clock() if clock is not None else None
    for _ in range(1000):                        # read_once waits for a newer state each time: bounded
        s = robot.read_once()
        if since is None or round(s.time.to_sec() * 1000) > since:
            break
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
           "box_ticks_skipped", "box_late_ticks", "lost_machine", "reflexes_machine", "verdicts_deferred")
_STATS = ("cycles_moving", "commands_ok", "lost", "late", "max_lost_in_row", "max_own_lost_in_row", "lost_machine",
          "reflexes", "reflexes_machine", "verdicts_deferred", "motions", "motions_finished", "tcp_StopMove",
          "box_ticks_skipped", "box_late_ticks", "last_reflex", "watching")


def _recover(robot) -> None:
    """automatic_error_recovery(), again after a moment if the robot still holds a motion that
    is ending (a control the student's code has not released yet)."""
    import pylibfranka

    for attempt in range(3):
        try:
            robot.automatic_error_recovery()
            return
        except pylibfranka.ControlException:
            if attempt == 2:
                raise
            import gc

            gc.collect()              # a control object kept alive by a traceback
            time.sleep(0.05)


def franka_loop_probe(inputs, run_motion):
    import pylibfranka

    from robocourse.rt import settings

    from . import box_stats, box_watch, start_franka_box

    out = {"setup": "", "a": None, "b": None}
    # libfranka's Robot() raises this thread to SCHED_FIFO 99 where the kernel allows: the student's
    # loop runs so, as it would on the robot; the kernel running the probe gets its scheduling back
    kept = settings.current_scheduling()
    box = start_franka_box()
    try:
        robot = pylibfranka.Robot(box.host, pylibfranka.RealtimeConfig.kIgnore)

        quick, patient = _RobotClock(box, 0.002), _RobotClock(box, 0.1)   # the pauses' clock; the stall's

        watching = box_watch(box) == "ok"     # this thread runs the student's loop
        # the grader's own heap (the runner, earlier answers) is not the student's to collect: what
        # exists now is frozen out of the collector, so a collection in the loop sees only the
        # loop's own objects (chapter 1's gc.freeze(), what robocourse.rt.settings.realtime does)
        gc.collect()
        gc.freeze()
        _warm_up(robot, pylibfranka)
        for attempt in range(1, ATTEMPTS + 1):
            before = _state(robot)
            base = box_stats(box)          # earlier attempts' and the warm-up's counts, subtracted below
            ts: list[float] = []
            offset = _offset(inputs["amplitude"], inputs["seconds"], inputs["pauses"], ts, quick)
            result = _call(run_motion, robot, offset, inputs["seconds"])
            stats = box_stats(box)
            out["a"] = {**result, "q0": before["q"], "after": _state(robot, patient), "ts": ts, "attempts": attempt,
                        "stats": {k: (stats.get(k, 0) - base.get(k, 0)) if k in _COUNTS else stats.get(k, 0)
                                  for k in _STATS}}
            # retried only where the machine, not the loop, may have tripped it: the box could not
            # watch the loop, or it watched the loop held off the CPU for longer than its cap. A loop
            # that blocks by itself trips it every time
            comm = "reflex_communication_constraints_violation"
            machine = int(stats.get("reflexes_machine", 0)) - int(base.get("reflexes_machine", 0))
            if (watching and not machine) or int(stats.get(comm, 0)) - int(base.get(comm, 0)) == 0:
                break
            if out["a"]["after"]["mode"] != "Idle":
                _recover(robot)
        if out["a"]["after"]["mode"] != "Idle":   # the loop left the robot stopped: phase B starts clean
            _recover(robot)
        base_b = box_stats(box)
        ts_b: list[float] = []
        # the stall: 30 ms, and until the robot has sent 25 states (past its limit of 20)
        stall = _offset([0.05] * 7, 1.0, [[inputs["stall_at"], inputs["stall_ms"]]], ts_b, patient,
                        min_states=25, max_ms=500.0)
        result = _call(run_motion, robot, stall, 1.0)
        stats_b = box_stats(box)
        out["b"] = {**result, "after": _state(robot, patient), "last_reflex": stats_b.get("last_reflex", ""),
                    "reflexes": int(stats_b.get("reflexes", 0)) - int(base_b.get("reflexes", 0))}
    except NotImplementedError:
        raise
    except Exception as exc:  # noqa: BLE001 - a setup failure is reported, not raised
        out["setup"] = f"{type(exc).__name__}: {str(exc)[:380]}"
    finally:
        gc.unfreeze()
        box.stop()
        settings.reset_scheduling(*kept)
    return out
