"""Chapter 5's UR exercise (ch05.ur_servo_loop): wrong answers, one per stated property, and a
differently written correct one. Each runs against a UR-style box through ur_rtde in the sandbox.

Not in the bank: a loop with no pacing at all (thousands of servoJ per second). It scores 0 on
pacing every time, but what it does to the rest depends on how long the machine takes to
swallow the flood, so its other sub-tests are not stable enough to state here.
"""

from robocourse.grading.bank import Answer, Exercise

NB = "05_hardware_drivers_exercises"
T = "follows the wall-clock path through a pause"
P = "one servoJ per 2 ms cycle (initPeriod / waitPeriod)"
E = "servoStop at the end, True returned"
S = "a stall stops the robot (setWatchdog) and follow_path returns False"
FULL = {T: 1.5, P: 1.0, E: 0.5, S: 2.0}


def but(*lost):
    return {k: v for k, v in FULL.items() if k not in lost}


UR_LOOP = Exercise(
    "ch05.ur_servo_loop", NB, timing=True,
    right=[Answer("absolute deadlines with time.sleep, a class, another gain", code='''
import time


class Streamer:
    def __init__(self, control, period=0.002):
        self.c, self.period = control, period

    def run(self, path, duration):
        self.c.setWatchdog(2.0)
        start = next_t = time.perf_counter()
        while (elapsed := time.perf_counter() - start) < duration:
            if not self.c.servoJ(path(elapsed), 0, 0, self.period, 0.03, 500):
                return False
            next_t += self.period
            while (late := time.perf_counter() - next_t) > 0:      # behind: skip the missed ticks
                next_t += self.period * (late // self.period + 1)
            time.sleep(max(0.0, next_t - time.perf_counter()))   # preempted past it: go on
        return self.c.servoStop(8.0)


def follow_path(rtde_c, rtde_r, path, duration):
    return Streamer(rtde_c).run(path, duration)
''')],
    wrong=[
        Answer("no watchdog", replace=[("    if not rtde_c.setWatchdog(2.0):\n        return False\n", "")],
               score=but(S), property="arms the RTDE watchdog (the robot stops on a stall)", says="setWatchdog(2)"),
        Answer("a 0.5 Hz watchdog", replace=[("setWatchdog(2.0)", "setWatchdog(0.5)")], score=but(S),
               property="the watchdog at 2 Hz", says="set to 0.5 Hz"),
        Answer("path sampled at k * dt", code='''
import time


def follow_path(rtde_c, rtde_r, path, duration):
    rtde_c.setWatchdog(2.0)
    k = 0
    while k * 0.002 < duration:
        t_cycle = rtde_c.initPeriod()
        if not rtde_c.servoJ(list(path(k * 0.002)), 0.0, 0.0, 0.002, 0.03, 300):
            return False
        k += 1
        rtde_c.waitPeriod(t_cycle)
    rtde_c.servoStop()
    return True
''', score=but(T), property="samples the path at the wall-clock time since the start",
               says="behind the clock"),
        Answer("a long lookahead_time", replace=[("0.002, 0.03, 300", "0.002, 0.2, 300")], score=but(T),
               property="lookahead_time 0.03 s (the arm keeps up with the path)", says="ms late"),
        Answer("a 100 Hz loop", code='''
import time


def follow_path(rtde_c, rtde_r, path, duration):
    rtde_c.setWatchdog(2.0)
    t0 = time.monotonic()
    while (t := time.monotonic() - t0) < duration:
        if not rtde_c.servoJ(list(path(t)), 0.0, 0.0, 0.01, 0.03, 300):
            return False
        time.sleep(0.01)
    rtde_c.servoStop()
    return True
''', score=but(P), property="one servoJ per 2 ms cycle", says="of its own"),
        Answer("servoJ's False ignored", replace=[("            return False                      # the robot stopped",
                                                   "            pass                              # the robot stopped")],
               score=but(S), property="returns False when the robot stopped", says="returned True"),
        Answer("no servoStop at the end", replace=[("    rtde_c.servoStop()\n", "")], score=but(E),
               property="ends with servoStop()", says="servoStop"),
        Answer("a stalled loop: stops sending after 0.3 s", code='''
import time


def follow_path(rtde_c, rtde_r, path, duration):
    rtde_c.setWatchdog(2.0)
    t0 = time.monotonic()
    while (t := time.monotonic() - t0) < duration:
        t_cycle = rtde_c.initPeriod()
        if t > 0.3:
            time.sleep(duration - t)      # stuck in something else until the time is up (longer than the watchdog)
            break
        rtde_c.servoJ(list(path(t)), 0.0, 0.0, 0.002, 0.03, 300)
        rtde_c.waitPeriod(t_cycle)
    rtde_c.servoStop()
    return True
''', score=0, property="keeps streaming (a stalled loop earns nothing)", says="stopped its program"),
    ])

EXERCISES = [UR_LOOP]
