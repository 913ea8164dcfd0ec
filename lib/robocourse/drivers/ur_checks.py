"""Chapter 5's UR exercise check (solutions/05_hardware_drivers_exercises.ipynb): a servoJ loop with ur_rtde.

``ch05.ur_servo_loop``: the student's ``follow_path(rtde_c, rtde_r, path, duration)`` (the 500 Hz
loop a ur_rtde user writes for a real UR5e: ``initPeriod`` / ``servoJ`` / ``waitPeriod``, the
RTDE watchdog, ``servoStop`` at the end) runs against a UR-style box process through ur_rtde
itself, twice:

- **run A, tracking**: ``path(t)`` is a seeded smooth motion of the first joints. The grader's
  ``path`` stalls once for ``HICCUP_S`` (shorter than the watchdog's window: a gc pause, say) and
  the check adds no load of its own: its stability under chapter 1's CPU load is measured by
  running it under :class:`robocourse.rt.disturb.CpuLoad` (``benchmarks/bank_stability.py``, the
  bank's timing runs in CI). Judged on what the loop controls, apart from what the machine did:
  after the pause the loop must ask ``path()`` for the wall-clock time (its ``t`` at most
  ``BEHIND_S`` behind the moment of the call, median: a loop that samples at ``k * dt`` stays
  the pause behind), the robot must receive those targets unchanged, and the arm must follow
  the targets it received within ``MAX_ARM_LAG_S`` (measured in the box's own ticks: servoJ's
  ``t`` + ``lookahead_time``, 32 ms asked; a 0.2 s lookahead lags 0.2 s). A loaded machine that
  delays the loop's targets makes the arm trail the wall-clock path: that lag is shown, never
  judged. The loop must be paced at 2 ms: never more than 12 ``path()`` calls in any 20 ms
  (``DENSE_S``: a machine's delays only thin the calls out; a flood above ``2 * MAX_HZ``
  packages per s fails too) and its own cycle (the median interval between calls less the
  machine's run-queue wait within it) at most ``MAX_CYCLE_S`` (a 100 Hz loop's is 10 ms); never go
  ``1 / WATCHDOG_HZ`` without a cycle *of its own* (each gap less the time the machine kept the
  thread off the CPU: its run-queue wait from ``/proc/thread-self/schedstat``, which the probe
  samples at every ``path()`` call), no watchdog stop, and ``servoStop`` at the end. Where the
  machine held the loop off the CPU long enough for the watchdog to fire, the feedback says the
  machine was at fault.
- **run B, the stall**: ``path`` stalls for ``STALL_S``, far longer than the watchdog's
  ``1 / WATCHDOG_HZ``. The robot must stop its program (the RTDE watchdog the loop set) and
  ``follow_path`` must notice (servoJ returns False) and return False promptly (within
  ``RETURN_WITHIN_S`` of the stall's end, less the machine's run-queue wait meanwhile).

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
    BEHIND_S,
    DENSE_S,
    HICCUP_AT,
    HICCUP_S,
    MAX_ARM_LAG_S,
    MAX_CYCLE_S,
    MAX_HZ,
    RETURN_WITHIN_S,
    RUN_A_S,
    SENT_TOL,
    STALL_AT,
    STALL_S,
    WATCHDOG_HZ,
    path_points,
    ur_servo_loop_probe,
)


def _inputs(rng):
    return {"amplitude": [round(float(rng.uniform(0.25, 0.4)), 3), round(float(rng.uniform(0.1, 0.2)), 3)],
            "frequency": round(float(rng.uniform(0.4, 0.6)), 3), "phase": round(float(rng.uniform(0, math.pi)), 3)}


_RUN = Dict(returned=OneOf(Bool(), Null(), Number(), Str(max_len=100)), raised=OneOf(Null(), Str(max_len=400)),
            t_start=Number(), t_end=Number(), wait_end=Number(), calls=List(List(Number(), length=3), max_len=20000),
            before=Any(max_items=2000), after=Any(max_items=2000),
            trace=Dict(t=List(Number(), max_len=6000), q=List(List(Number(), length=6), max_len=6000),
                       runtime_state=List(Number(integer=True), max_len=6000),
                       sent=List(List(Number(), length=6), max_len=6000),
                       servo=List(List(Number(), length=2), max_len=6000)))
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


class _Loop:
    """The loop's cycles in one run as the judge sees them: when it called path(), with which t, and how long
    the machine kept its thread off the CPU (run-queue wait) between calls: the loop's own time is the rest."""

    def __init__(self, run):
        c = np.array([list(x) + [-1.0] * (3 - len(x)) for x in run["calls"]], dtype=float).reshape(-1, 3)
        self.start = float(c[0, 0])
        self.end = min(float(run["t_end"]), self.start + RUN_A_S)    # the run's nominal end, not the final stop
        c = c[c[:, 0] <= self.end]                                   # (a loop at k * dt runs on past it)
        self.now, self.t, wait = c[:, 0], c[:, 1], c[:, 2]
        wait_end = float(run.get("wait_end", -1.0))
        self.known = bool((wait >= 0).all() and wait_end >= 0)
        self.times = np.r_[self.now, self.end]
        self.gaps = np.diff(self.times)
        if self.known:
            w = np.diff(np.r_[wait, max(wait_end, wait[-1])])
            self.machine = np.clip(w, 0.0, self.gaps)           # held off the CPU within each gap
            self.wait_total = float(max(wait_end, wait[-1]) - wait[0])
        else:
            self.machine = np.zeros_like(self.gaps)
            self.wait_total = math.nan
        self.own = self.gaps - self.machine

    def note(self) -> str:
        """What the machine did to the loop (never counted against it)."""
        if not self.known:
            return "this machine does not report run-queue waits (schedstat): the loop's times are taken as measured"
        held = self.machine > 0.010
        if not held.any():
            return f"the machine kept your loop off the CPU {self.wait_total * 1e3:.0f} ms in all (no cycle by more than 10 ms)"
        return (f"the machine kept your loop off the CPU {self.wait_total * 1e3:.0f} ms in all, {int(held.sum())} cycles by "
                f"more than 10 ms (longest {self.machine.max() * 1e3:.0f} ms): the machine's, not counted against you")


def _wall_lag(inputs, q0, t0, trace, window):
    """(lag s, median residual rad) of the arm behind the wall-clock path over ``window`` (s after t0): what the
    machine and the loop did together (shown, not judged)."""
    t = np.asarray(trace["t"], dtype=float) - t0
    q = np.asarray(trace["q"], dtype=float).reshape(-1, 6)
    sel = (t >= window[0]) & (t <= window[1])
    if sel.sum() < 50:
        return None, None
    t, q = t[sel], q[sel, :2]
    lags = np.arange(0.0, 0.4, 0.002)
    err = [float(np.median(np.abs(q - path_points(inputs, q0, t - lag)[:, :2]))) for lag in lags]
    i = int(np.argmin(err))
    return float(lags[i]), err[i]


def _arm_lag(sent, q) -> int:
    """Ticks by which the arm's positions follow the servo targets the box received (first two joints)."""
    best, err = 0, math.inf
    for s in range(0, min(150, len(q) - 30)):
        e = float(np.median(np.abs(q[s:, :2] - sent[: len(sent) - s, :2])))
        if e < err:
            best, err = s, e
    return best


def _nearest_path(inputs, q0, targets, ts) -> np.ndarray:
    """For each received target, the distance (rad, worst joint) to the nearest path(t) the loop asked for."""
    ref = path_points(inputs, q0, ts)
    out = np.empty(len(targets))
    for i in range(0, len(targets), 64):
        block = targets[i:i + 64]
        out[i:i + 64] = np.abs(block[:, None, :] - ref[None, :, :]).max(axis=2).min(axis=1)
    return out


def _machine_stop(a, loop) -> str | None:
    """Why the watchdog fired in the tracking run when the machine, not the loop, left the robot without a
    command: the loop's own share of every gap stayed under the window but a gap did not."""
    window = 1.0 / WATCHDOG_HZ
    if loop.known and loop.gaps.max() >= window and loop.own.max() < window:
        i = int(np.argmax(loop.gaps))
        return (f"the machine kept your loop off the CPU for {loop.machine[i] * 1e3:.0f} ms of a {loop.gaps[i] * 1e3:.0f} ms "
                f"gap, longer than the watchdog's {window * 1e3:.0f} ms, and the robot stopped: the grading machine was "
                "at fault, not your code (ask for a regrade on a quieter machine)")
    return None


def _tracking(inputs, out):
    a, _b, q0 = _runs(out)
    _started(a)
    loop = _Loop(a)
    problems = []
    if a.get("raised"):
        problems.append(f"follow_path raised {a['raised']} in the tracking run")
    if _delta(a, "watchdog_stops") and _stopped_at(a) < loop.start + RUN_A_S:   # not the final servoStop's wait
        problems.append(_machine_stop(a, loop) or
                        "the robot stopped its program during the tracking run (the RTDE watchdog fired although "
                        f"path() paused only {HICCUP_S * 1e3:.0f} ms once): the loop left the robot without a "
                        f"command for more than 1/{WATCHDOG_HZ:g} s")
    # 1. what the loop asked for: path(t) at the wall-clock time (its t against the moment it called)
    after_from = HICCUP_AT + HICCUP_S + 0.1
    offset = loop.now - loop.t
    after = (loop.now - loop.start >= after_from) & (loop.now - loop.start <= RUN_A_S)
    behind = math.nan
    if after.sum() < 20:
        problems.append(f"your loop called path() {int(after.sum())} times between {after_from:.2f} s and {RUN_A_S} s "
                        "after it started: keep one servoJ(path(t), ...) per 2 ms cycle until the duration is over")
    else:
        behind = float(np.median(offset[after]) - offset.min())
        if behind > BEHIND_S:
            problems.append(f"after the {HICCUP_S * 1e3:.0f} ms pause in path() your loop asked for the path "
                            f"{behind * 1e3:.0f} ms behind the clock (median over {int(after.sum())} calls; at most "
                            f"{BEHIND_S * 1e3:.0f} ms): sample path(t) at the time elapsed since you started "
                            "(time.monotonic() - t0), not at cycle count x dt, so the robot is where the path is now")
    # 2. what the robot received: those targets, and an arm that follows them with servoJ's short lookahead
    tr = a.get("trace") or {}
    tt = np.asarray(tr.get("t", []), dtype=float) - loop.start
    servo = np.asarray(tr.get("servo", []), dtype=float).reshape(-1, 2)
    arm_lag = math.nan
    if len(servo) != len(tt) or len(tr.get("sent", [])) != len(tt):
        raise RuntimeError("check error: the box's trace has no servo targets")
    window = np.flatnonzero((tt >= after_from) & (tt <= min(RUN_A_S, loop.end - loop.start)))
    sel = window[servo[window, 0] > 0]
    box_note = ""
    if len(window) == 0 or len(sel) < 0.5 * len(window):
        if after.sum() >= 20:
            problems.append("the robot was not servoing for most of the tracking run after the pause (the box recorded "
                            f"{len(sel)} of {len(window)} ticks in servo mode): send rtde_c.servoJ(path(t), 0.0, 0.0, "
                            "0.002, 0.03, 300) every cycle")
    else:
        sent_all = np.asarray(tr["sent"], dtype=float).reshape(-1, 6)
        off = _nearest_path(inputs, q0, np.unique(sent_all[sel], axis=0), loop.t)
        if float(np.median(off)) > SENT_TOL:
            problems.append(f"the targets the robot received are not what path(t) returned (median {np.median(off):.3g} "
                            "rad from the nearest path(t) your loop asked for): send servoJ(path(t), ...) unchanged")
        st, la = (float(np.median(servo[sel, k])) for k in (0, 1))
        # the arm's lag in the box's own ticks, over the longest stretch of consecutive servo ticks
        runs = np.split(sel, np.flatnonzero(np.diff(sel) != 1) + 1)
        block = max(runs, key=len)
        if len(block) < 60:      # the machine starved the box itself: too few ticks to measure the arm
            box_note = (f"; the box ran only {len(window)} ticks in {tt[window[-1]] - tt[window[0]]:.2f} s (the machine "
                        "starved the robot's controller): the arm's lag could not be measured, not counted against you")
        else:
            arm_lag = _arm_lag(sent_all[block], np.asarray(tr["q"], dtype=float).reshape(-1, 6)[block]) * 0.002
            if arm_lag > MAX_ARM_LAG_S:
                problems.append(f"the arm followed the targets your loop sent {arm_lag * 1e3:.0f} ms late (at most "
                                f"{MAX_ARM_LAG_S * 1e3:.0f} ms; the robot received servoJ's t = {st:g} s, lookahead_time "
                                f"= {la:g} s): the arm's filter lags by lookahead_time; send servoJ(path(t), 0.0, 0.0, "
                                "0.002, 0.03, 300)")
    wall, _ = _wall_lag(inputs, q0, loop.start, tr, (after_from, min(RUN_A_S, loop.end - loop.start) - 0.05))
    seen = (f"the arm followed the wall-clock path {wall * 1e3:.0f} ms late" if wall is not None else
            "the box recorded too little to compare the arm with the wall-clock path") + f"; {loop.note()}{box_note}"
    if problems:
        raise CheckFailed(*problems, f"(for information, not judged: {seen})")
    arm = f"the arm followed the targets {arm_lag * 1e3:.0f} ms late" if arm_lag == arm_lag else "the arm not measured"
    return f"after the pause path(t) was asked for the time {behind * 1e3:.0f} ms behind the clock (median), {arm}; {seen}"


def _pacing(inputs, out):
    a, _b, _q0 = _runs(out)
    _started(a)
    loop = _Loop(a)
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
    # a gap without a cycle is the loop's when its own share (the gap less the machine's run-queue wait) is long
    i = int(np.argmax(loop.own))
    if loop.own[i] >= 1.0 / WATCHDOG_HZ:
        raise CheckFailed(f"your loop went {loop.gaps[i] * 1e3:.0f} ms without a cycle (no path() call, no servoJ"
                          + (f"; the machine held it off the CPU {loop.machine[i] * 1e3:.0f} ms of that" if loop.known else "")
                          + f") although path() paused only {HICCUP_S * 1e3:.0f} ms: a loop that stops streaming "
                          "leaves the robot to its watchdog; keep one servoJ per 2 ms cycle until the duration is over")
    # not faster than one cycle per 2 ms: the most path() calls in any DENSE_S window (a machine's delays only
    # ever thin the calls out; a loop that catches up after a delay makes one short cycle, not a burst)
    dense = int(np.max(np.searchsorted(loop.now, loop.now + DENSE_S, side="left") - np.arange(len(loop.now))))
    most = int(round(DENSE_S / 0.002)) + 2
    if dense > most:
        raise CheckFailed(f"your loop called path() {dense} times within {DENSE_S * 1e3:.0f} ms ({servo / duration:.0f} "
                          f"servoJ targets per s in all): one servoJ per 2 ms cycle is {most - 2} in {DENSE_S * 1e3:.0f} "
                          "ms; pace it with t = rtde_c.initPeriod() ... rtde_c.waitPeriod(t) and call path() once per cycle")
    # not slower: the loop's own cycle, the median interval between its path() calls less the time the machine
    # kept it off the CPU within each (a loaded machine makes cycles late; their own share stays one period)
    own = float(np.median(loop.own))
    if own > MAX_CYCLE_S:
        raise CheckFailed(f"your loop's cycles took {own * 1e3:.1f} ms of its own (the median interval between its "
                          "path() calls" + (", less the time the machine kept it off the CPU" if loop.known else "")
                          + f"; {servo / duration:.0f} servoJ targets per s): one servoJ per 2 ms cycle, accepted up "
                          f"to {MAX_CYCLE_S * 1e3:g} ms; pace it with t = rtde_c.initPeriod() ... rtde_c.waitPeriod(t) "
                          "and call path() once per cycle")
    return (f"at most {dense} path() calls in {DENSE_S * 1e3:.0f} ms, {own * 1e3:.2f} ms of its own per cycle (median), "
            f"{np.median(loop.gaps) * 1e3:.2f} ms by the clock, {servo / duration:.0f} servoJ targets per s; "
            f"{loop.note()}")


def _end(inputs, out):
    a, _b, _q0 = _runs(out)
    _started(a)
    problems = []
    if a.get("returned") is not True:
        why = _machine_stop(a, _Loop(a)) if _delta(a, "watchdog_stops") else None
        problems.append(f"follow_path returned {a.get('returned')!r} after the tracking run: " +
                        (why if why else "return True when the duration is over (the robot was still running)"))
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
        else:
            # the loop's own time to return: less what the machine held it off the CPU since the stalled call
            stalled = next((c for c in calls if c[0] >= calls[0][0] + STALL_AT), None)
            held = 0.0
            if stalled is not None and len(stalled) > 2 and stalled[2] >= 0 and b.get("wait_end", -1) >= 0:
                held = max(0.0, float(b["wait_end"]) - float(stalled[2]))
            took = b["t_end"] - stall_end
            if took - held > RETURN_WITHIN_S:
                problems.append(f"follow_path returned {took:.2f} s after the stall ended"
                                + (f" ({held:.2f} s of it the machine's)" if held > 0.01 else "")
                                + f"; the first servoJ after it already returns False: return within {RETURN_WITHIN_S} s")
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
