"""Chapter 5's UR exercise check (solutions/05_hardware_drivers_exercises.ipynb): a servoJ loop with ur_rtde.

``ch05.ur_servo_loop``: the student's ``follow_path(rtde_c, rtde_r, path, duration)`` (the 500 Hz
loop a ur_rtde user writes for a real UR5e: ``initPeriod`` / ``servoJ`` / ``waitPeriod``, the
RTDE watchdog, ``servoStop`` at the end) runs against a UR-style box process through ur_rtde
itself, twice:

- **run A, tracking**: ``path(t)`` is a seeded smooth motion of the first joints. The grader's
  ``path`` stalls once for ``HICCUP_S`` (shorter than the watchdog's window: a gc pause, say) and
  the run is under chapter 1's CPU load (:class:`robocourse.rt.disturb.CpuLoad`) for its first
  ``LOAD_S``. The box records the arm's trajectory on ``CLOCK_MONOTONIC`` (``robocourse
  trace``); the judge compares it with the *wall-clock* path: the arm must follow ``path`` with
  a lag of at most ``MAX_LAG_S`` and a residual of at most ``MAX_RESIDUAL`` rad after the hiccup
  (a loop that samples the path at ``k * dt`` falls behind by every stall and never catches up).
  The box counts the servoJ targets it took in: one per 2 ms cycle (``MIN_HZ`` to ``MAX_HZ`` per s),
  no watchdog stop, and ``servoStop`` at the end.
- **run B, the stall**: ``path`` stalls for ``STALL_S``, far longer than the watchdog's
  ``1 / WATCHDOG_HZ``. The robot must stop its program (the RTDE watchdog the loop set) and
  ``follow_path`` must notice (servoJ returns False) and return False promptly.

The probe gathers (the box's counters and trajectory, the calls to ``path``, what
``follow_path`` returned and when); the judge decides, outside the student's process.
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.grading import CheckFailed, Failures, register

WATCHDOG_HZ = 5.0          # the exercise's watchdog: the robot stops 200 ms after the last command
HICCUP_S = 0.08            # run A's stall inside path(): below the watchdog's window
STALL_S = 0.6              # run B's stall: well past it
RUN_A_S, RUN_B_S = 2.0, 1.6
HICCUP_AT, STALL_AT = 0.7, 0.4     # s into each run
LOAD_S = 0.6               # run A's first seconds under CpuLoad
MAX_LAG_S = 0.07           # the arm may follow the wall-clock path this late (servoJ's lookahead + transport)
MAX_RESIDUAL = 0.01       # rad: the median error left after shifting by the lag (a median: a short stall of
                           # a loaded machine makes a burst, a loop that falls behind makes it all the way)
MIN_HZ, MAX_HZ = 200.0, 650.0     # per s of the run, its pause excluded: 500 paced; a 125 Hz loop or a busy one fail
RETURN_WITHIN_S = 0.5      # after the watchdog stopped the robot, follow_path must have returned by then


def _inputs(rng):
    return {"amplitude": [round(float(rng.uniform(0.25, 0.4)), 3), round(float(rng.uniform(0.1, 0.2)), 3)],
            "frequency": round(float(rng.uniform(0.4, 0.6)), 3), "phase": round(float(rng.uniform(0, math.pi)), 3)}


def path_point(inputs, q0, t: float) -> np.ndarray:
    """The path both sides use: q0 plus a smooth motion of the first two joints, zero at t = 0."""
    a0, a1 = inputs["amplitude"]
    w, ph = 2 * math.pi * inputs["frequency"], inputs["phase"]
    q = np.array(q0, dtype=float)
    q[0] += a0 * math.sin(w * t)
    q[1] += a1 * (math.sin(w * t + ph) - math.sin(ph))
    return q


def _probe(inputs, follow_path):
    """Run the student's loop against a UR-style box (run A, then run B); gather, never judge."""
    import contextlib
    import time

    import rtde_control
    import rtde_receive

    from robocourse.rt.disturb import CpuLoad

    from . import start_ur_box
    from .ur_box import read_stats, read_trace

    out = {"error": None}
    box = start_ur_box(realtime=True)
    r = c = None
    load = contextlib.ExitStack()
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
            if run == "A":
                load.enter_context(CpuLoad(processes=1))
            t_start = time.monotonic()
            try:
                result = follow_path(c, r, recorder(stall_at, stall_s, calls), seconds)
                raised = None
            except Exception as exc:  # noqa: BLE001 - reported to the judge
                result, raised = None, f"{type(exc).__name__}: {str(exc)[:200]}"
            t_end = time.monotonic()
            after = read_stats(box.host)      # at once: the watchdog the loop left armed may stop it later
            load.close()
            trace = read_trace(box.host)
            keep = [i for i, t in enumerate(trace["t"]) if t_start - 0.05 <= t <= t_end + 0.3]
            out[run] = {"returned": result if isinstance(result, (bool, int, float, type(None))) else repr(result)[:80],
                        "raised": raised, "t_start": t_start, "t_end": t_end, "calls": calls[:20000],
                        "before": before, "after": after,
                        "trace": {k: [trace[k][i] for i in keep] for k in ("t", "q", "target", "runtime_state")}}
            # a fresh control program for the next run (and no watchdog left armed)
            c.reuploadScript()
    except Exception as exc:  # noqa: BLE001
        out["error"] = f"{type(exc).__name__}: {str(exc)[:300]}"
    finally:
        load.close()
        for client in (c, r):
            if client is not None:
                with contextlib.suppress(Exception):
                    client.disconnect()
        box.stop()
    return out


def _delta(run, key) -> int:
    a, b = run.get("after") or {}, run.get("before") or {}
    va, vb = a.get(key, 0), b.get(key, 0)
    return int(va) - int(vb) if isinstance(va, int) and isinstance(vb, int) else 0


def _lag_fit(inputs, q0, t0, trace, window):
    """(lag s, residual rad): the lag minimising the median of |q(t) - path(t - t0 - lag)| over ``window``
    (s after t0), and that median."""
    t = np.asarray(trace["t"], dtype=float) - t0
    q = np.asarray(trace["q"], dtype=float)
    sel = (t >= window[0]) & (t <= window[1])
    if sel.sum() < 50:
        return None, None
    t, q = t[sel], q[sel]
    best = (None, math.inf)
    for lag in np.arange(0.0, 0.4, 0.002):
        ref = np.array([path_point(inputs, q0, x) for x in t - lag])
        med = float(np.median(np.abs(q[:, :2] - ref[:, :2])))
        if med < best[1]:
            best = (float(lag), med)
    return best


@register("ch05.ur_servo_loop", weight=5, time_limit=60, uses=("follow_path",), probe=_probe, inputs=_inputs)
def check_ur_servo_loop(inputs, out):
    """follow_path() servos a UR5e through ur_rtde at 500 Hz, follows the wall-clock path, and stops on a stall."""
    if not isinstance(out, dict):
        raise CheckFailed(f"the probe returned {str(out)[:80]}")
    if out.get("error"):
        raise CheckFailed(f"the run stopped: {out['error']}")
    a, b, q0 = out.get("A") or {}, out.get("B") or {}, out.get("q0")
    if not a or not b or not isinstance(q0, list):
        raise RuntimeError("check error: the probe did not record both runs")
    f = Failures()
    # --- run A: the loop, tracking, the end
    calls = a.get("calls") or []
    if len(calls) < 10:
        raise CheckFailed(*([f"follow_path raised {a['raised']} in the tracking run"] if a.get("raised") else []),
                          f"follow_path called path() {len(calls)} times in a {RUN_A_S} s run: call it once per "
                          "cycle with the time since you started (path(t) gives the six joint targets)")
    if a.get("raised"):
        f.add(f"follow_path raised {a['raised']} in the tracking run")
    t0 = calls[0][0]
    duration = (a["t_end"] - a["t_start"]) or 1e-9
    servo = _delta(a, "cmd_servoj")          # servoJ commands with a new target the robot took in
    rate = servo / max(1e-3, duration - HICCUP_S)
    packages = _delta(a, "rx_data")
    if packages / duration > 2 * MAX_HZ:
        f.add(f"your loop sent {packages} RTDE packages in {duration:.2f} s ({packages / duration:.0f} per s): one "
              "servoJ per 2 ms cycle is 500 per s; pace it with t = rtde_c.initPeriod() ... rtde_c.waitPeriod(t)")
    if _delta(a, "watchdog_stops") and not a.get("raised"):
        f.add("the robot stopped its program during the tracking run (the RTDE watchdog fired although your loop "
              f"only paused {HICCUP_S * 1e3:.0f} ms once): the loop stalled for longer than 1/{WATCHDOG_HZ:g} s")
    if servo == 0:
        f.add("the box received no servoJ command in the tracking run: send rtde_c.servoJ(path(t), ...) every cycle")
    elif not MIN_HZ <= rate <= MAX_HZ:
        f.add(f"the robot took in {servo} servoJ targets in {duration:.2f} s ({rate:.0f} per s): one servoJ per 2 ms "
              f"cycle is 500 per s (accepted {MIN_HZ:.0f}-{MAX_HZ:.0f}); pace it with t = rtde_c.initPeriod() ... "
              "rtde_c.waitPeriod(t)")
    hiccup_end = HICCUP_AT + HICCUP_S
    lag, resid = _lag_fit(inputs, q0, t0, a.get("trace") or {}, (hiccup_end + 0.25, min(RUN_A_S, duration) - 0.05))
    if lag is None:
        f.add("the box recorded too little of the tracking run to judge it (did follow_path return early?)")
    elif lag > MAX_LAG_S or resid > MAX_RESIDUAL:
        f.add(f"after the {HICCUP_S * 1e3:.0f} ms pause in path() the arm followed the wall-clock path "
              f"{lag * 1e3:.0f} ms late (median residual {resid * 1e3:.1f} mrad); at most {MAX_LAG_S * 1e3:.0f} ms and "
              f"{MAX_RESIDUAL * 1e3:.0f} mrad are expected: sample path(t) at the time elapsed since you started "
              "(time.monotonic()), not at cycle count x dt, and keep servoJ's lookahead_time short (0.03-0.05 s)")
    if a.get("returned") is not True:
        f.add(f"follow_path returned {a.get('returned')!r} after a run the robot completed: return True then")
    if _delta(a, "cmd_servo_stop") < 1:
        f.add("the robot was still in servo mode after follow_path returned: end with rtde_c.servoStop()")
    armed = (a.get("after") or {}).get("watchdogs") or {}
    wd = [v for v in armed.values() if isinstance(v, (int, float))]
    if not wd and not _delta(a, "watchdog_stops"):
        f.add(f"no RTDE watchdog was armed during the run: call rtde_c.setWatchdog({WATCHDOG_HZ:g}) before the loop "
              f"(the robot then stops when your loop is silent for 1/{WATCHDOG_HZ:g} s)")
    elif wd and abs(wd[0] - WATCHDOG_HZ) > 1e-9:
        f.add(f"the watchdog was set to {wd[0]:g} Hz; the exercise asks for {WATCHDOG_HZ:g} Hz "
              f"(a stop {1e3 / WATCHDOG_HZ:.0f} ms after the last command)")
    # --- run B: the stall
    stops = _delta(b, "watchdog_stops")
    if b.get("raised"):
        f.add(f"follow_path raised {b['raised']} when the robot stopped; return False instead")
    if stops < 1:
        f.add(f"path() stalled your loop for {STALL_S * 1e3:.0f} ms and the robot kept its program running: "
              f"the RTDE watchdog (rtde_c.setWatchdog({WATCHDOG_HZ:g})) must stop it after 1/{WATCHDOG_HZ:g} s")
    else:
        stall_end = (b.get("calls") or [[b["t_start"]]])[0][0] + STALL_AT + STALL_S
        if b.get("returned") is not False:
            f.add(f"the robot stopped (watchdog) but follow_path returned {b.get('returned')!r}: when servoJ "
                  "returns False the program is gone; stop the loop and return False")
        elif b["t_end"] > stall_end + RETURN_WITHIN_S:
            f.add(f"follow_path returned {b['t_end'] - stall_end:.2f} s after the stall ended; the first servoJ "
                  f"after it already returns False: return within {RETURN_WITHIN_S} s")
    return f.done(f"tracked the wall-clock path {lag * 1e3:.0f} ms late (median residual {resid * 1e3:.1f} mrad) through a "
                  f"{HICCUP_S * 1e3:.0f} ms pause and CPU load, {rate:.0f} servoJ targets per s, servoStop at the "
                  f"end; the {STALL_S * 1e3:.0f} ms stall stopped the robot (watchdog) and follow_path returned False")
