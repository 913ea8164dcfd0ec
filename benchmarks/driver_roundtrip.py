"""pylibfranka against the simulated FR3: 1 kHz command success rate and round trip, beside the floor.

    PYTHONPATH=lib python benchmarks/driver_roundtrip.py [--seconds 2] [--rounds 3] [--quick] [--only ur|franka]

Rows, each a fresh box process (libfranka's robot server on its own 127.0.0.x, asking for
SCHED_FIFO as a robot controller is real-time) and pylibfranka 0.21.3 in this process running
the lightest client there is (``start_joint_position_control``, then ``readOnce`` /
``writeOnce`` of the start position) for ``--seconds``:

- "floor": the same box with no arm behind the packets (same datagrams, same 1 ms ticker, the
  same two processes and libfranka): the round trip this machine allows;
- "FR3": the box stepping the FR3 in MuJoCo each tick.

Each under: idle; ``robocourse.rt.disturb.CpuLoad`` with 2 busy processes on the last CPU;
the same on every CPU; and each with and without the real-time settings in the client
(``robocourse.rt.settings.realtime``: SCHED_FIFO 80 (``--priority``; never 99, where the kernel's
watchdog threads run), locked + prefaulted memory, frozen gc; no child process inherits the policy;
refused for an unprivileged user, and then the RT rows measure the default scheduler: the header
says which). Round trip = the box's clock from sending state k to receiving the command for k
(late ones included). Success = states of the motion answered before the next tick / states
(libfranka's control_command_success_rate over the whole run). "worst" = the longest run of
lost cycles; "reflex@20" counts runs where it reached the robot's 20. "ms/s" = robot
milliseconds (states) per wall second: below 1000 when the box itself was starved (those ticks
send no state and count against nobody). Each figure is the median over ``--rounds`` rounds,
[min-max] beside it; "xN" = the FR3 p99 over the floor p99 of the same load and settings.
Then the box's start-up time (``start_franka_box()`` to READY), median of 5, against the goal.

The machine is shared with other engineers' test runs: absolute numbers move from run to run;
compare rows of the same run.

Then (unless ``--only franka``) the UR-style box through ur_rtde: receive rate and jitter, servoJ round trip
and start-up, each beside the same box with no arm behind it (``ur_rows``).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "lib"))

from robocourse.drivers import start_franka_box  # noqa: E402
from robocourse.drivers.franka_wire import MAX_LOST_IN_ROW as LIMIT  # noqa: E402
from robocourse.drivers.measure import franka_roundtrip  # noqa: E402
from robocourse.rt.disturb import CpuLoad  # noqa: E402
from robocourse.rt.settings import (  # noqa: E402
    allowed_cpus,
    current_scheduling,
    reset_scheduling,
    set_scheduling,
)


def load(kind: str):
    cpus = allowed_cpus()
    if kind == "idle":
        return contextlib.nullcontext()
    stack = contextlib.ExitStack()
    for cpu in (cpus[-1:] if kind == "load1" else cpus):
        stack.enter_context(CpuLoad(cpu=cpu, processes=2))
    return stack


LOADS = {"idle": "idle", "load1": "2 busy procs on 1 CPU", "loadall": "2 busy procs on every CPU"}


def med(values):
    return statistics.median(values), min(values), max(values)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="1 s, 1 round")
    ap.add_argument("--only", choices=("franka", "ur"), help="run one driver's rows")
    ap.add_argument("--priority", type=int, default=80,
                    help="SCHED_FIFO priority of the client loop in the RT rows (default 80, as the other benchmarks; "
                         "1..98: never 99, the kernel's watchdog threads run there)")
    a = ap.parse_args(argv)
    if a.quick:
        a.seconds, a.rounds = 1.0, 1
    if not 1 <= a.priority <= 98:
        ap.error(f"--priority {a.priority}: use 1..98 (99 belongs to the kernel's watchdog threads); the default is 80")
    if a.only == "ur":
        return ur_rows(a)
    probe = set_scheduling("fifo", a.priority, quiet=True)
    rt_ok = probe.ok
    reset_scheduling()
    print(f"CPUs {allowed_cpus()}, load average {os.getloadavg()[0]:.1f} (shared machine: other jobs run too); "
          f"real-time scheduling {'available: RT rows run the client at SCHED_FIFO ' + str(a.priority) if rt_ok else 'REFUSED (RT rows run SCHED_OTHER): ' + str(probe)}; "
          f"scheduler now {current_scheduling()}; every child (box, CpuLoad) starts SCHED_OTHER")
    configs = [(ld, rt, phys) for ld in LOADS for rt in (False, True) for phys in (False, True)]
    results = {c: [] for c in configs}
    for r in range(a.rounds):
        for c in configs:           # interleaved: each round runs every configuration once
            ld, rt, phys = c
            with load(ld):
                results[c].append(franka_roundtrip(a.seconds, physics=phys, realtime=rt, priority=a.priority))
        print(f"round {r + 1}/{a.rounds} done", flush=True)
    print(f"\n{'load':<26}{'RT':<4}{'box':<7}{'p50 us':>16}{'p99 us':>21}{'max us':>22}{'success %':>24}"
          f"{'worst':>7}{'reflex@' + str(LIMIT):>11}{'ms/s':>7}")
    floor = {}
    for c in configs:
        ld, rt, phys = c
        rs = results[c]
        p50, p99, mx = (med([getattr(x, f) for x in rs]) for f in ("rtt_p50_us", "rtt_p99_us", "rtt_max_us"))
        sr = med([100 * x.success_rate for x in rs])
        worst = max(x.max_lost_in_row for x in rs)
        reflexes = sum(x.would_reflex(LIMIT) for x in rs)
        rate = med([x.states / x.wall_s if x.wall_s > 0 else float("nan") for x in rs])[0]
        if not phys:
            floor[(ld, rt)] = p99[0]
        ratio = f" x{p99[0] / floor[(ld, rt)]:.1f}" if phys and floor.get((ld, rt)) else ""
        print(f"{LOADS[ld]:<26}{'yes' if rt else 'no':<4}{'FR3' if phys else 'floor':<7}"
              f"{p50[0]:>7.0f} [{p50[1]:>4.0f}-{p50[2]:<4.0f}]"
              f"{p99[0]:>8.0f}{ratio:<6} [{p99[1]:>5.0f}-{p99[2]:<5.0f}]"
              f"{mx[0]:>8.0f} [{mx[1]:>5.0f}-{mx[2]:<6.0f}]"
              f"{sr[0]:>9.2f} [{sr[1]:>6.2f}-{sr[2]:<6.2f}]"
              f"{worst:>6d}{reflexes:>8d}/{len(rs)}{rate:>7.0f}")
    idle_rt = [x.success_rate for x in results[("idle", True, True)]]
    goal = statistics.median(idle_rt) >= 0.999
    counts = ", ".join(f"{x.lost} of {x.states}" for x in results[("idle", True, True)])
    # three decimals: 2 lost of 1999 states is 99.8999 %, which two decimals would show as 99.90 %
    print(f"\ngoal: FR3 box idle with RT settings >= 99.900% success: median "
          f"{100 * statistics.median(idle_rt):.3f}% (lost: {counts}) -> {'MET' if goal else 'NOT MET'} on this run")
    broke = [f"{LOADS[ld]}{' + RT' if rt else ''}" for (ld, rt, phys), rs in results.items()
             if phys and any(x.would_reflex(LIMIT) for x in rs)]
    print(f"runs with {LIMIT} lost cycles in a row (the robot would have stopped): " + (", ".join(broke) if broke else "none"))
    ready = []
    for _ in range(5):
        t0 = time.monotonic()
        box = start_franka_box()
        ready.append(time.monotonic() - t0)
        box.stop()
    r = med(ready)
    print(f"box ready (start_franka_box() to READY, 5 starts): median {r[0]:.2f} s [{r[1]:.2f}-{r[2]:.2f}]; goal < 1 s "
          f"-> {'MET' if r[0] < 1.0 else 'NOT MET'} on this run")
    return 0 if a.only == "franka" else ur_rows(a)



def ur_rows(a) -> int:
    """The UR-style box through ur_rtde (robocourse.drivers.ur_measure), each row beside the same box
    with no arm behind it (the floor: protocol, processes and scheduling only), idle and under load."""
    from robocourse.drivers import ur_measure as um

    try:
        import rtde_receive  # noqa: F401
    except ImportError:
        print("\nUR rows skipped: ur-rtde is not installed (Linux x86_64, CPython <= 3.12)")
        return 0
    print(f"\nUR-style box through ur_rtde 1.6.5: {a.rounds} round(s), {a.seconds:g} s each; median [min-max]")
    rate, rtt, start = {}, {}, {}
    configs = [(ld, rt, phys) for ld in ("idle", "load1") for rt in (False, True) for phys in (False, True)]
    for r in range(a.rounds):
        for c in configs:            # interleaved, as above
            ld, rt, phys = c
            with load(ld):
                rate.setdefault(c, []).append(um.receive_rate(a.seconds, physics=phys, realtime=rt))
                rtt.setdefault(c, []).append(um.servoj_round_trip(int(250 * a.seconds), physics=phys, realtime=rt))
        for phys in (False, True):
            start.setdefault(phys, []).append(um.startup(physics=phys))
        start.setdefault("python", []).append(um.interpreter_startup())
        print(f"UR round {r + 1}/{a.rounds} done", flush=True)
    print(f"{'load':<24}{'RT':<4}{'box':<7}{'receive Hz':>20}{'ticks got %':>13}{'jitter p99 us':>22}"
          f"{'servoJ rtt p50 us':>24}{'p99 us':>9}{'x floor':>9}")
    for c in configs:
        ld, rt, phys = c
        rs, ts = rate[c], rtt[c]
        hz, share, jit = (med([getattr(x, f) for x in rs]) for f in ("rate_hz", "ticks_share", "jitter_p99_us"))
        p50, p99 = (med([getattr(x, f) for x in ts]) for f in ("p50_us", "p99_us"))
        floor = med([x.p50_us for x in rtt[(ld, rt, False)]])[0]
        ratio = f"x{p50[0] / floor:.2f}" if phys else ""
        print(f"{LOADS[ld]:<24}{'yes' if rt else 'no':<4}{'UR5e' if phys else 'floor':<7}"
              f"{hz[0]:>7.1f} [{hz[1]:>4.0f}-{hz[2]:<4.0f}]{100 * share[0]:>11.1f}  "
              f"{jit[0]:>8.0f} [{jit[1]:>5.0f}-{jit[2]:<5.0f}]"
              f"{p50[0]:>10.0f} [{p50[1]:>5.0f}-{p50[2]:<5.0f}]{p99[0]:>8.0f}{ratio:>9}")
    st = {k: med(v) for k, v in start.items()}
    print(f"start to first RTDE package: UR5e box {st[True][0]:.2f} s [{st[True][1]:.2f}-{st[True][2]:.2f}], "
          f"floor box {st[False][0]:.2f} s, `python -c 'import numpy, mujoco'` {st['python'][0]:.2f} s "
          f"(the UR5e box x{st[True][0] / st['python'][0]:.1f} that)")
    idle_hz = med([x.rate_hz for x in rate[("idle", False, True)]])[0]
    ok_rate = abs(idle_hz - 500.0) <= 5.0
    print(f"goal: receive rate 500 Hz +- 1 % idle: median {idle_hz:.1f} Hz -> {'MET' if ok_rate else 'NOT MET'}; "
          f"box ready in < 1 s: median {st[True][0]:.2f} s -> {'MET' if st[True][0] < 1.0 else 'NOT MET'} (this run)")
    print("RT = the box and ur_rtde's threads try SCHED_FIFO (refused without permission: then as 'no'); "
          "receive Hz = packages ur_rtde's receive thread recorded per wall second; ticks got = those packages / "
          "the controller ticks they span; jitter = |arrival interval - 2 ms| at a plain socket client on the same "
          "box; servoJ rtt = servoJ() call to the first state whose target_q moved; x floor = UR5e / floor p50")
    return 0



if __name__ == "__main__":
    sys.exit(main())
