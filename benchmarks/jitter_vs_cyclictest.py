"""Python's periodic loop against cyclictest (C) on this machine, in the same run.

Alternates cyclictest and each Python wait strategy (sleep, hybrid, spin) at 1 kHz with the same
policy, priority, CPU and memory locking, for --pairs rounds (the order rotates every round so
no strategy always follows another). Prints p50 / p99 / p99.9 / max of each (the median over the
rounds) and the ratio of the Python hybrid loop's p99 to cyclictest's p99 (median of the per-round
ratios). Goal: ratio <= 1.0.

    python benchmarks/jitter_vs_cyclictest.py [--pairs 5] [--iterations 5000] [--priority 80]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))

from robocourse.rt import Hybrid, PeriodicLoop, Sleep, Spin, settings  # noqa: E402
from robocourse.rt import cyclictest as ct  # noqa: E402
from robocourse.rt.capabilities import preemption_model  # noqa: E402


def percentiles(lat_ns: np.ndarray) -> dict:
    p50, p99, p999 = np.percentile(lat_ns, [50, 99, 99.9])
    return {"p50": p50, "p99": p99, "p99.9": p999, "max": float(lat_ns.max())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5, help="rounds of (cyclictest + each Python loop); >= 5")
    ap.add_argument("--iterations", type=int, default=5000, help="iterations per run (default 5000 = 5 s)")
    ap.add_argument("--period-us", type=int, default=1000, help="period in us (default 1000 = 1 kHz)")
    ap.add_argument("--priority", type=int, default=80, help="SCHED_FIFO priority for both (default 80)")
    ap.add_argument("--spin-us", type=int, default=200, help="hybrid spin window in us (default 200)")
    ap.add_argument("--cpu", type=int, default=None, help="pin both to this CPU (default: not pinned)")
    args = ap.parse_args(argv)
    if args.pairs < 5:
        ap.error(f"--pairs {args.pairs}: use at least 5 so the median means something")
    if args.iterations < 100 or args.period_us <= 0 or not 1 <= args.priority <= 98:
        ap.error("need --iterations >= 100, --period-us > 0 and --priority in 1..98")
    try:
        ct.cyclictest_path()
    except ct.CyclictestMissing as exc:
        print(exc, file=sys.stderr)
        return 2

    period_ns = args.period_us * 1000
    privileged = settings.set_scheduling("fifo", args.priority, quiet=True).ok
    settings.reset_scheduling()
    if not privileged:
        print(f"no permission for SCHED_FIFO {args.priority}: both sides run under SCHED_OTHER "
              f"(fix: {settings.rtprio_fix(args.priority).splitlines()[0]})")
    policy = f"SCHED_FIFO {args.priority}" if privileged else "SCHED_OTHER"
    print(f"{platform.node()}: {os.cpu_count()} CPUs, kernel {platform.release()} ({preemption_model()}), "
          f"Python {platform.python_version()}")
    print(f"{args.pairs} rounds x {args.iterations} iterations at {1e6 / args.period_us:.0f} Hz, {policy}, "
          f"memory locked: {privileged}, CPU: {args.cpu if args.cpu is not None else 'any'}")

    reports = []
    if args.cpu is not None:
        reports.append(settings.set_affinity(args.cpu))
    if privileged:
        reports += settings.lock_and_prefault(1 << 20, 64 << 20, quiet=True)
    reports.append(settings.gc_freeze())
    if not all(r.ok for r in reports):
        print(settings.describe(r for r in reports if not r.ok))

    names = ["cyclictest (C)", "python sleep", f"python hybrid ({args.spin_us} us)", "python spin"]
    waits = {names[1]: Sleep(), names[2]: Hybrid(spin_ns=args.spin_us * 1000), names[3]: Spin()}
    results: dict[str, list[dict]] = {n: [] for n in names}
    ratios = []
    for round_no in range(args.pairs):
        order = names[round_no % len(names):] + names[:round_no % len(names)]
        this_round = {}
        for name in order:
            if name == names[0]:
                r = ct.run_cyclictest(interval_us=args.period_us, loops=args.iterations,
                                      priority=args.priority if privileged else None,
                                      policy="fifo" if privileged else None, mlock=privileged, cpu=args.cpu)
                lat = r.latency_ns
            else:
                if privileged:
                    settings.set_scheduling("fifo", args.priority, quiet=True)
                lat = PeriodicLoop(period_ns, args.iterations, wait=waits[name]).run().latency_ns
                settings.reset_scheduling()
            this_round[name] = percentiles(lat)
            results[name].append(this_round[name])
        ratio = this_round[names[2]]["p99"] / this_round[names[0]]["p99"]
        ratios.append(ratio)
        print(f"round {round_no + 1}: " + ", ".join(f"{n.split(' (')[0]} p99 {v['p99'] / 1000:.1f} us"
                                                  for n, v in this_round.items())
              + f"; hybrid/C p99 = {ratio:.2f}", flush=True)

    print()
    print(f"median over {args.pairs} rounds (us)")
    print(f"| {'loop':<22} | {'p50':>8} | {'p99':>8} | {'p99.9':>8} | {'max':>9} |")
    print(f"|{'-' * 24}|{'-' * 10}|{'-' * 10}|{'-' * 10}|{'-' * 11}|")
    for name in names:
        med = {k: float(np.median([r[k] for r in results[name]])) / 1000 for k in ("p50", "p99", "p99.9", "max")}
        print(f"| {name:<22} | {med['p50']:8.1f} | {med['p99']:8.1f} | {med['p99.9']:8.1f} | {med['max']:9.1f} |")
    ratio = float(np.median(ratios))
    print()
    print(f"python hybrid p99 / cyclictest p99: median {ratio:.2f} (rounds: {', '.join(f'{x:.2f}' for x in ratios)}); "
          f"goal <= 1.0: {'met' if ratio <= 1.0 else 'NOT met'}")
    spin_max = float(np.median([r["max"] for r in results[names[3]]]))
    if privileged and spin_max > 10 * period_ns:
        try:
            runtime = int(Path("/proc/sys/kernel/sched_rt_runtime_us").read_text())
            rt_period = int(Path("/proc/sys/kernel/sched_rt_period_us").read_text())
            print(f"python spin never sleeps: under SCHED_FIFO the kernel's RT throttling "
                  f"(sched_rt_runtime_us {runtime} of {rt_period}) stops it for up to "
                  f"{(rt_period - runtime) / 1000:.0f} ms each second, hence its {spin_max / 1e6:.1f} ms max")
        except (OSError, ValueError):
            pass
    settings.unlock_memory()
    return 0


if __name__ == "__main__":
    sys.exit(main())
