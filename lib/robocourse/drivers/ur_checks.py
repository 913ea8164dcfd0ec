"""Chapter 5's UR exercise check (solutions/05_hardware_drivers_exercises.ipynb): a servoJ loop with ur_rtde.

``ch05.ur_servo_loop``: the student's ``follow_path(rtde_c, rtde_r, path, duration)`` (the 500 Hz
loop a ur_rtde user writes for a real UR5e: ``initPeriod`` / ``servoJ`` / ``waitPeriod``, the
RTDE watchdog, ``servoStop`` at the end) runs against a UR-style box process through ur_rtde
itself, twice:

- **run A, tracking**: ``path(t)`` is a seeded smooth motion of the first joints. The grader's
  ``path`` stalls once for ``HICCUP_S`` (shorter than the watchdog's window: a gc pause, say) and
  the check adds no load of its own: its stability under chapter 1's CPU load is measured by
  running it under :class:`robocourse.rt.disturb.CpuLoad` (``benchmarks/ur_exercise_stability.py``,
  and the bank's timing runs in CI). The box records the arm's trajectory on ``CLOCK_MONOTONIC`` (``robocourse
  trace``); the judge compares it with the *wall-clock* path: the arm must follow ``path`` with
  a lag of at most ``MAX_LAG_S`` and a residual of at most ``MAX_RESIDUAL`` rad after the hiccup
  (a loop that samples the path at ``k * dt`` falls behind by every stall and never catches up).
  The loop must be paced at 2 ms (the 10th percentile of the intervals between its ``path()``
  calls within ``CYCLE_S``: on a loaded machine most cycles run late, but a paced loop's fastest
  ones still take one period; a flood above ``2 * MAX_HZ`` packages per s fails too),
  no watchdog stop, and ``servoStop`` at the end.
- **run B, the stall**: ``path`` stalls for ``STALL_S``, far longer than the watchdog's
  ``1 / WATCHDOG_HZ``. The robot must stop its program (the RTDE watchdog the loop set) and
  ``follow_path`` must notice (servoJ returns False) and return False promptly.

The probe (:mod:`robocourse.drivers.ur_probes`, with the settings) gathers the box's counters
and trajectory, the calls to ``path``, what ``follow_path`` returned and when; the judges
decide, outside the student's process, one sub-test per stated property. Answer bank:
``tests/banks/ch05_ur.py``.
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.grading import CheckFailed, register
from robocourse.grading.checks import SubTest
from robocourse.grading.schema import Any, Bool, Dict, List, Null, Number, OneOf, Str

from .ur_probes import (
    CYCLE_S,
    HICCUP_AT,
    HICCUP_S,
    MAX_HZ,
    MAX_LAG_S,
    MAX_RESIDUAL,
    RETURN_WITHIN_S,
    RUN_A_S,
    STALL_AT,
    STALL_S,
    WATCHDOG_HZ,
    path_point,
    ur_servo_loop_probe,
)


def _inputs(rng):
    return {"amplitude": [round(float(rng.uniform(0.25, 0.4)), 3), round(float(rng.uniform(0.1, 0.2)), 3)],
            "frequency": round(float(rng.uniform(0.4, 0.6)), 3), "phase": round(float(rng.uniform(0, math.pi)), 3)}


_RUN = Dict(returned=OneOf(Bool(), Null(), Number(), Str(max_len=100)), raised=OneOf(Null(), Str(max_len=400)),
            t_start=Number(), t_end=Number(), calls=List(List(Number(), length=2), max_len=20000),
            before=Any(max_items=2000), after=Any(max_items=2000),
            trace=Dict(t=List(Number(), max_len=6000), q=List(List(Number(), length=6), max_len=6000),
                       runtime_state=List(Number(integer=True), max_len=6000)))
SCHEMA = Dict(error=OneOf(Null(), Str(max_len=400)), optional={"q0": List(Number(), length=6), "A": _RUN, "B": _RUN})


def _runs(out):
    if out.get("error"):
        raise CheckFailed(f"the run stopped: {out['error']}")
    a, b, q0 = out.get("A"), out.get("B"), out.get("q0")
    if not a or not b or q0 is None:
        raise RuntimeError("check error: the probe did not record both runs")
    return a, b, q0


def _delta(run, key) -> int:
    a, b = run.get("after") or {}, run.get("before") or {}
    va, vb = a.get(key, 0), b.get(key, 0)
    return int(va) - int(vb) if isinstance(va, int) and isinstance(vb, int) else 0


def _lag_fit(inputs, q0, t0, trace, window):
    """(lag s, residual rad): the lag minimising the median of |q(t) - path(t - t0 - lag)| over ``window``
    (s after t0), and that median."""
    t = np.asarray(trace["t"], dtype=float) - t0
    q = np.asarray(trace["q"], dtype=float).reshape(-1, 6)
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


def _stopped_at(run) -> float:
    """When the box's trajectory first shows the program not running (CLOCK_MONOTONIC s), or inf."""
    tr = run.get("trace") or {}
    for t, state in zip(tr.get("t", []), tr.get("runtime_state", [])):
        if t >= run["t_start"] and state != 2:
            return float(t)
    return math.inf


def _started(a):
    calls = a.get("calls") or []
    if len(calls) < 10:
        raise CheckFailed(*([f"follow_path raised {a['raised']} in the tracking run"] if a.get("raised") else []),
                          f"follow_path called path() {len(calls)} times in a {RUN_A_S} s run: call it once per "
                          "cycle with the time since you started (path(t) gives the six joint targets)")
    return calls


def _tracking(inputs, out):
    a, _b, q0 = _runs(out)
    calls = _started(a)
    duration = a["t_end"] - a["t_start"]
    problems = []
    if a.get("raised"):
        problems.append(f"follow_path raised {a['raised']} in the tracking run")
    if _delta(a, "watchdog_stops") and _stopped_at(a) < calls[0][0] + RUN_A_S:   # not the final servoStop's wait
        problems.append("the robot stopped its program during the tracking run (the RTDE watchdog fired although "
                        f"path() paused only {HICCUP_S * 1e3:.0f} ms once): the loop left the robot without a "
                        f"command for more than 1/{WATCHDOG_HZ:g} s")
    lag, resid = _lag_fit(inputs, q0, calls[0][0], a.get("trace") or {},
                          (HICCUP_AT + HICCUP_S + 0.25, min(RUN_A_S, duration) - 0.05))
    if lag is None:
        problems.append("the box recorded too little of the tracking run to judge it (did follow_path return early?)")
    elif lag > MAX_LAG_S or resid > MAX_RESIDUAL:
        problems.append(f"after the {HICCUP_S * 1e3:.0f} ms pause in path() the arm followed the wall-clock path "
                        f"{lag * 1e3:.0f} ms late (median residual {resid * 1e3:.1f} mrad); at most "
                        f"{MAX_LAG_S * 1e3:.0f} ms and {MAX_RESIDUAL * 1e3:.0f} mrad are expected: sample path(t) at "
                        "the time elapsed since you started (time.monotonic()), not at cycle count x dt, with servoJ's "
                        "lookahead_time 0.03 s")
    if problems:
        raise CheckFailed(*problems)
    return (f"followed the wall-clock path {lag * 1e3:.0f} ms late (median residual {resid * 1e3:.1f} mrad) through "
            f"a {HICCUP_S * 1e3:.0f} ms pause")


def _pacing(inputs, out):
    a, _b, _q0 = _runs(out)
    calls = _started(a)
    duration = (a["t_end"] - a["t_start"]) or 1e-9
    servo = _delta(a, "cmd_servoj")          # servoJ commands with a new target the robot took in
    packages = _delta(a, "rx_data")
    if servo == 0:
        raise CheckFailed("the box received no servoJ command in the tracking run: send "
                          "rtde_c.servoJ(path(t), ...) every cycle")
    if packages / duration > 2 * MAX_HZ:
        raise CheckFailed(f"your loop sent {packages} RTDE packages in {duration:.2f} s ({packages / duration:.0f} "
                          "per s): one servoJ per 2 ms cycle is 500 per s; pace it with t = rtde_c.initPeriod() ... "
                          "rtde_c.waitPeriod(t)")
    # the cycle the loop keeps when it gets the CPU: the 10th percentile of the intervals between its
    # path() calls (a loaded machine makes most cycles late, never shorter than the loop's own period)
    gaps = np.diff([c[0] for c in calls] + [min(a["t_end"], calls[0][0] + RUN_A_S)])   # to the run's end, not the stop
    typical = float(np.percentile(gaps, 10)) if len(gaps) else math.inf
    if gaps.max() >= 1.0 / WATCHDOG_HZ:
        raise CheckFailed(f"your loop went {gaps.max() * 1e3:.0f} ms without a cycle (no path() call, no servoJ) "
                          f"although path() paused only {HICCUP_S * 1e3:.0f} ms: a loop that stops streaming leaves "
                          "the robot to its watchdog; keep one servoJ per 2 ms cycle until the duration is over")
    if not CYCLE_S[0] <= typical <= CYCLE_S[1]:
        raise CheckFailed(f"your loop's fastest cycles took {typical * 1e3:.2f} ms (the 10th percentile of the "
                          f"intervals between its path() calls; {servo / duration:.0f} servoJ targets per s): one "
                          f"servoJ per 2 ms cycle, accepted {CYCLE_S[0] * 1e3:g}-{CYCLE_S[1] * 1e3:g} ms; pace it "
                          "with t = rtde_c.initPeriod() ... rtde_c.waitPeriod(t) and call path() once per cycle")
    return f"fastest cycles {typical * 1e3:.2f} ms (10th percentile), {servo / duration:.0f} servoJ targets per s"


def _end(inputs, out):
    a, _b, _q0 = _runs(out)
    _started(a)
    problems = []
    if a.get("returned") is not True:
        problems.append(f"follow_path returned {a.get('returned')!r} after a run the robot completed: return True")
    if _delta(a, "cmd_servo_stop") < 1:
        problems.append("the robot was still in servo mode after follow_path returned: end with rtde_c.servoStop()")
    if problems:
        raise CheckFailed(*problems)
    return "servoStop() at the end, True returned"


def _stall(inputs, out):
    a, b, _q0 = _runs(out)
    problems = []
    armed = [v for v in ((a.get("after") or {}).get("watchdogs") or {}).values() if isinstance(v, (int, float))]
    if armed and abs(armed[0] - WATCHDOG_HZ) > 1e-9:
        problems.append(f"the watchdog was set to {armed[0]:g} Hz; the exercise asks for {WATCHDOG_HZ:g} Hz "
                        f"(a stop {1e3 / WATCHDOG_HZ:.0f} ms after the last command)")
    if b.get("raised"):
        problems.append(f"follow_path raised {b['raised']} when the robot stopped; return False instead")
    if _delta(b, "watchdog_stops") < 1:
        problems.append(f"path() stalled your loop for {STALL_S * 1e3:.0f} ms and the robot kept its program "
                        f"running: arm the RTDE watchdog first, rtde_c.setWatchdog({WATCHDOG_HZ:g}), so the robot "
                        f"stops 1/{WATCHDOG_HZ:g} s after the last command")
    else:
        calls = b.get("calls") or [[b["t_start"], 0.0]]
        stall_end = calls[0][0] + STALL_AT + STALL_S
        if b.get("returned") is not False:
            problems.append(f"the robot stopped (watchdog) but follow_path returned {b.get('returned')!r}: when "
                            "servoJ returns False the program is gone; stop the loop and return False")
        elif b["t_end"] > stall_end + RETURN_WITHIN_S:
            problems.append(f"follow_path returned {b['t_end'] - stall_end:.2f} s after the stall ended; the first "
                            f"servoJ after it already returns False: return within {RETURN_WITHIN_S} s")
    if problems:
        raise CheckFailed(*problems)
    return (f"the {STALL_S * 1e3:.0f} ms stall stopped the robot (watchdog, {WATCHDOG_HZ:g} Hz) and follow_path "
            "returned False")


register("ch05.ur_servo_loop", uses=("follow_path",), probe=ur_servo_loop_probe, inputs=_inputs, time_limit=60,
         schema=SCHEMA, max_bytes=4_000_000,
         subtests=[SubTest("follows the wall-clock path through a pause", 1.5, _tracking),
                   SubTest("one servoJ per 2 ms cycle (initPeriod / waitPeriod)", 1.0, _pacing),
                   SubTest("servoStop at the end, True returned", 0.5, _end),
                   SubTest("a stall stops the robot (setWatchdog) and follow_path returns False", 2.0, _stall)])
