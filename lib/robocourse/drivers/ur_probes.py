"""The probe of chapter 5's UR exercise check (ch05.ur_servo_loop): runs the student's loop, gathers.

Kept apart from the judge (:mod:`robocourse.drivers.ur_checks`), which the grading sandbox hides:
this module is what the student's process may import. It starts a UR-style box, connects
ur_rtde, runs ``follow_path`` twice (tracking, then a stall) and returns what the box and the
calls recorded; it decides nothing. Each ``path(t)`` call is recorded as (CLOCK_MONOTONIC s, t,
the calling thread's run-queue wait so far in s): the wait (``/proc/thread-self/schedstat``'s
second field, time the thread was runnable while another task had the CPU; -1 where the kernel
does not keep it) is what lets the judge tell the machine's delays from the loop's own.
"""

from __future__ import annotations

import math

import numpy as np

WATCHDOG_HZ = 2.0          # the exercise's watchdog: the robot stops 500 ms after the last command
HICCUP_S = 0.15            # run A's stall inside path(): well below the watchdog's window
STALL_S = 1.2              # run B's stall: well past it
RUN_A_S, RUN_B_S = 2.2, 2.4
HICCUP_AT, STALL_AT = 0.7, 0.4     # s into each run
BEHIND_S = 0.05            # after the pause, path(t) may be asked for a time at most this far behind the clock
                           # (median; a loop at k * dt stays HICCUP_S behind and more)
MAX_ARM_LAG_S = 0.08       # the arm may follow the targets it received this late: servoJ's t + lookahead_time
                           # (0.002 + 0.03 s asked; a lookahead_time of 0.2 s lags 0.2 s)
SENT_TOL = 1e-6            # rad: a target the robot received is one path(t) returned (RTDE carries doubles)
MAX_CYCLE_S = 0.006        # the loop's own cycle (median interval between path() calls, less the time the machine
                           # kept it off the CPU) at most this: 2 ms paced, a 100 Hz loop's 10 ms fails
DENSE_S = 0.02             # and never more than DENSE_S / 2 ms + 2 path() calls in any window this long (faster
                           # than 2 ms: a machine's delays only thin the calls out)
MAX_HZ = 650.0             # more RTDE packages than 2 x this per s: a flood
RETURN_WITHIN_S = 0.5      # after the watchdog stopped the robot, follow_path must have returned by then


def path_points(inputs, q0, t) -> np.ndarray:
    """The path both sides use, at the times ``t`` (s, an array): q0 plus a smooth motion of the first two
    joints, zero at t = 0; one row of six joint positions per time."""
    a0, a1 = inputs["amplitude"]
    w, ph = 2 * math.pi * inputs["frequency"], inputs["phase"]
    t = np.asarray(t, dtype=float).reshape(-1)
    q = np.tile(np.asarray(q0, dtype=float), (len(t), 1))
    q[:, 0] += a0 * np.sin(w * t)
    q[:, 1] += a1 * (np.sin(w * t + ph) - math.sin(ph))
    return q


def path_point(inputs, q0, t: float) -> np.ndarray:
    """:func:`path_points` at one time."""
    return path_points(inputs, q0, [t])[0]


def runqueue_wait_s() -> float:
    """The calling thread's run-queue wait since it started (s), or -1 where schedstat is not kept."""
    try:
        with open("/proc/thread-self/schedstat", "rb") as f:
            return int(f.read().split()[1]) / 1e9
    except (OSError, ValueError, IndexError):
        return -1.0



def ur_servo_loop_probe(inputs, follow_path):
    """Run the student's loop against a UR-style box (run A, then run B); gather, never judge."""
    import contextlib
    import time

    import rtde_control
    import rtde_receive

    from . import start_ur_box
    from .ur_box import read_stats, read_trace

    out = {"error": None}
    box = start_ur_box(realtime=True)
    r = c = None
    try:
        r = rtde_receive.RTDEReceiveInterface(box.host, 500.0, ["timestamp", "actual_q", "runtime_state"])
        c = rtde_control.RTDEControlInterface(box.host)
        q0 = list(r.getActualQ())
        out["q0"] = q0

        def recorder(stall_at, stall_s, calls):
            state = {"stalled": False}

            def path(t):
                now = time.monotonic()
                calls.append([now, float(t), runqueue_wait_s()])
                if not state["stalled"] and calls[0] and now - calls[0][0] >= stall_at:
                    state["stalled"] = True
                    time.sleep(stall_s)
                return path_point(inputs, q0, float(t)).tolist()
            return path

        for run, (seconds, stall_at, stall_s) in (("A", (RUN_A_S, HICCUP_AT, HICCUP_S)),
                                                  ("B", (RUN_B_S, STALL_AT, STALL_S))):
            deadline = time.monotonic() + 5
            while not c.isProgramRunning() and time.monotonic() < deadline:
                time.sleep(0.01)
            before = read_stats(box.host)
            calls: list = []
            t_start = time.monotonic()
            try:
                result = follow_path(c, r, recorder(stall_at, stall_s, calls), seconds)
                raised = None
            except Exception as exc:  # noqa: BLE001 - reported to the judge
                result, raised = None, f"{type(exc).__name__}: {str(exc)[:200]}"
            t_end, wait_end = time.monotonic(), runqueue_wait_s()
            after = read_stats(box.host)      # at once: the watchdog the loop left armed may stop it later
            trace = read_trace(box.host)
            keep = [i for i, t in enumerate(trace["t"]) if t_start - 0.05 <= t <= t_end + 0.3]
            out[run] = {"returned": result if isinstance(result, (bool, int, float, type(None))) else repr(result)[:80],
                        "raised": raised, "t_start": t_start, "t_end": t_end, "wait_end": wait_end,
                        "calls": calls[:20000], "before": before, "after": after,
                        "trace": {k: [trace[k][i] for i in keep] for k in ("t", "q", "runtime_state", "sent", "servo")}}
            # a fresh control program for the next run (and no watchdog left armed)
            c.reuploadScript()
    except Exception as exc:  # noqa: BLE001
        out["error"] = f"{type(exc).__name__}: {str(exc)[:300]}"
    finally:
        for client in (c, r):
            if client is not None:
                with contextlib.suppress(Exception):
                    client.disconnect()
        box.stop()
    return out
