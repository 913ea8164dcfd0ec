"""The probe of chapter 5's UR exercise check (ch05.ur_servo_loop): runs the student's loop, gathers.

Kept apart from the judge (:mod:`robocourse.drivers.ur_checks`), which the grading sandbox hides:
this module is what the student's process may import. It starts a UR-style box, connects
ur_rtde, runs ``follow_path`` twice (tracking, then a stall) and returns what the box and the
calls recorded; it decides nothing.
"""

from __future__ import annotations

import math

import numpy as np

WATCHDOG_HZ = 2.0          # the exercise's watchdog: the robot stops 500 ms after the last command
HICCUP_S = 0.15            # run A's stall inside path(): well below the watchdog's window
STALL_S = 1.2              # run B's stall: well past it
RUN_A_S, RUN_B_S = 2.2, 2.4
HICCUP_AT, STALL_AT = 0.7, 0.4     # s into each run
MAX_LAG_S = 0.12           # the arm may follow the wall-clock path this late (servoJ's lookahead + transport;
                           # a loop at k * dt stays HICCUP_S later still)
MAX_RESIDUAL = 0.05        # rad: the median error left after shifting by the lag (a median: a short stall of
                           # a loaded machine makes a burst, a loop that falls behind makes it all the way)
CYCLE_S = (0.001, 0.006)   # the loop's fastest cycles (10th percentile of the intervals between path() calls):
                           # 2 ms paced; a 100 Hz loop (10 ms) or a busy one (microseconds) falls outside
MAX_HZ = 650.0             # more RTDE packages than 2 x this per s: a flood
RETURN_WITHIN_S = 0.5      # after the watchdog stopped the robot, follow_path must have returned by then


def path_point(inputs, q0, t: float) -> np.ndarray:
    """The path both sides use: q0 plus a smooth motion of the first two joints, zero at t = 0."""
    a0, a1 = inputs["amplitude"]
    w, ph = 2 * math.pi * inputs["frequency"], inputs["phase"]
    q = np.array(q0, dtype=float)
    q[0] += a0 * math.sin(w * t)
    q[1] += a1 * (math.sin(w * t + ph) - math.sin(ph))
    return q



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
                calls.append([now, float(t)])
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
            t_end = time.monotonic()
            after = read_stats(box.host)      # at once: the watchdog the loop left armed may stop it later
            trace = read_trace(box.host)
            keep = [i for i, t in enumerate(trace["t"]) if t_start - 0.05 <= t <= t_end + 0.3]
            out[run] = {"returned": result if isinstance(result, (bool, int, float, type(None))) else repr(result)[:80],
                        "raised": raised, "t_start": t_start, "t_end": t_end, "calls": calls[:20000],
                        "before": before, "after": after,
                        "trace": {k: [trace[k][i] for i in keep] for k in ("t", "q", "runtime_state")}}
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
