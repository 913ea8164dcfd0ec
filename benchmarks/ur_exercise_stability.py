"""Is chapter 5's UR exercise check (ch05.ur_servo_loop) stable? The reference N times under chapter 1's
CPU load, and a stalled loop N times; the verdict must be the same every time.

    PYTHONPATH=lib python benchmarks/ur_exercise_stability.py [--runs 20] [--load-processes 2]

Each run is the whole check (a fresh UR-style box, ur_rtde, both of the check's runs) with a
seeded draw (seed = run index, shown). "Under load" = ``robocourse.rt.disturb.CpuLoad`` with
``--load-processes`` busy processes for the whole run, on top of the CPU load the check's own
tracking run adds. The stalled loop sends servoJ for 0.3 s, then stops sending and waits the
run out (what a loop stuck in a long computation does). Prints pass counts and the spread of
the measured lag; exits 1 if the reference did not pass every run or the stalled loop ever did.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "lib"))

import nbformat  # noqa: E402
import numpy as np  # noqa: E402

from robocourse.grading import discover  # noqa: E402
from robocourse.grading.checks import get, run_check  # noqa: E402
from robocourse.rt.disturb import CpuLoad  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def reference():
    ns: dict = {}
    cell = next(c for c in nbformat.read(ROOT / "solutions/05_hardware_drivers_exercises.ipynb", as_version=4).cells
                if "def follow_path" in c.source)
    exec(cell.source, ns)
    return ns["follow_path"]


def stalled(rtde_c, rtde_r, path, duration):
    rtde_c.setWatchdog(2.0)
    t0 = time.monotonic()
    while (t := time.monotonic() - t0) < duration:
        t_cycle = rtde_c.initPeriod()
        if t > 0.3:
            time.sleep(duration - t)
            break
        rtde_c.servoJ(list(path(t)), 0.0, 0.0, 0.002, 0.03, 300)
        rtde_c.waitPeriod(t_cycle)
    return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--load-processes", type=int, default=2)
    a = ap.parse_args(argv)
    discover()
    check = get("ch05.ur_servo_loop")
    print(f"CPUs {os.cpu_count()}, load average {os.getloadavg()[0]:.1f} (shared machine)")
    results = {"reference under CpuLoad": [], "stalled loop": []}
    for k in range(a.runs):
        with CpuLoad(processes=a.load_processes):
            r = run_check(check, reference(), rng=np.random.default_rng(k))
        results["reference under CpuLoad"].append(r)
        s = run_check(check, stalled, rng=np.random.default_rng(k))
        results["stalled loop"].append(s)
        print(f"seed {k:2d}: reference {r.points:g}/{r.weight:g} ({r.seconds:.1f} s) | stalled {s.points:g}/{s.weight:g}"
              + ("" if r.passed else f"\n    reference failed: {r.message[:300]}"), flush=True)
    ref, bad = results["reference under CpuLoad"], results["stalled loop"]
    lags = [float(x.message.split(" ms late")[0].split()[-1]) for x in ref if x.passed]   # the arm behind its targets
    print(f"\nreference under CpuLoad({a.load_processes}): full marks {sum(x.passed for x in ref)}/{len(ref)}; "
          f"arm behind its targets: median {statistics.median(lags) if lags else float('nan'):.0f} ms [{min(lags, default=0):.0f}-"
          f"{max(lags, default=0):.0f}]")
    print(f"stalled loop: zero {sum(x.points == 0 for x in bad)}/{len(bad)}")
    return 0 if all(x.passed for x in ref) and all(x.points == 0 for x in bad) else 1


if __name__ == "__main__":
    sys.exit(main())
