"""The cost of the pendulum graph on the loop's tail: pendulum_demo vs an empty loop vs cyclictest.

Alternating rounds, same machine, same run, same policy and priority (SCHED_RR 98 for the
Python loops as in the seed, SCHED_FIFO 98 for cyclictest, mlockall for all): each round runs
cyclictest, an empty robocourse.rt loop and the full demo graph (motor physics thread + executor
with motor, controller and statistics callbacks) for N iterations at 1 kHz, the order reversed
every other round. Both Python loops use the same wait (``--wait``, default ``sleep`` like rttest
and cyclictest; ``--wait hybrid`` spins the last 200 us of every period, a fifth of a core).
Prints per-round figures and the median over rounds, and the ratio demo / empty loop at p99.
The machine is shared and noisy: only the ratios from the same run compare.

    .venv/bin/python benchmarks/pendulum_demo.py [--rounds 5] [--iterations 5000] [--wait sleep|hybrid]
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np

from robocourse.pendulum.demo import run_realtime
from robocourse.rt import PeriodicLoop
from robocourse.rt import settings as rts
from robocourse.rt.cyclictest import CyclictestMissing, run_cyclictest
from robocourse.rt.wait import strategy


def figures(lat_ns: np.ndarray) -> dict:
    return {"p50": np.percentile(lat_ns, 50) / 1e3, "p99": np.percentile(lat_ns, 99) / 1e3,
            "p99.9": np.percentile(lat_ns, 99.9) / 1e3, "max": lat_ns.max() / 1e3}


def empty_loop(n: int, wait) -> np.ndarray:
    saved = rts.current_scheduling()
    rts.set_scheduling("rr", 98, quiet=True)
    rts.lock_memory(quiet=True)
    try:
        return PeriodicLoop(1_000_000, n, wait).run().latency_ns
    finally:
        rts.unlock_memory()
        rts.reset_scheduling(*saved)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--iterations", type=int, default=5000)
    ap.add_argument("--wait", choices=("sleep", "hybrid"), default="sleep",
                    help="wait strategy of both Python loops (default sleep, as rttest)")
    args = ap.parse_args(argv)
    wait = strategy(args.wait)
    rows: dict[str, list[dict]] = {"cyclictest (C)": [], "empty rt loop": [], "pendulum_demo": []}
    counts = []
    def cyclic():
        try:
            ct = run_cyclictest(1000, args.iterations, priority=98, mlock=True)
            rows["cyclictest (C)"].append(figures(ct.latency_ns))
        except (CyclictestMissing, RuntimeError) as exc:
            print(f"cyclictest skipped: {exc}")

    def empty():
        rows["empty rt loop"].append(figures(empty_loop(args.iterations, wait)))

    def pendulum():
        demo = run_realtime(args.iterations, quiet=True, heap_size=16 << 20, wait=wait)
        rows["pendulum_demo"].append(figures(demo.loop.latency_ns))
        counts.append((demo.motor_received, demo.controller_received, demo.loop.iterations))

    for r in range(args.rounds):
        for step in ((cyclic, empty, pendulum) if r % 2 == 0 else (pendulum, empty, cyclic)):
            step()
        print(f"round {r + 1}: " + "  ".join(f"{k} p99 {v[-1]['p99']:.1f} us" for k, v in rows.items() if v))
    print(f"\n1 kHz, {args.iterations} iterations x {args.rounds} rounds, Python loops wait: {wait}; "
          "median over rounds (us); shared, loaded machine")
    print(f"{'loop':<18}{'p50':>9}{'p99':>9}{'p99.9':>9}{'max':>10}")
    med = {}
    for name, rs in rows.items():
        if not rs:
            continue
        med[name] = {k: statistics.median(x[k] for x in rs) for k in ("p50", "p99", "p99.9", "max")}
        m = med[name]
        print(f"{name:<18}{m['p50']:>9.1f}{m['p99']:>9.1f}{m['p99.9']:>9.1f}{m['max']:>10.1f}")
    if "pendulum_demo" in med and "empty rt loop" in med:
        print(f"\ncost of the graph at p99: pendulum_demo / empty loop = "
              f"{med['pendulum_demo']['p99'] / max(med['empty rt loop']['p99'], 1e-9):.2f}x")
    if "cyclictest (C)" in med:
        print(f"pendulum_demo p99 / cyclictest p99 = {med['pendulum_demo']['p99'] / max(med['cyclictest (C)']['p99'], 1e-9):.2f}x")
    m, c, n = (statistics.median(x[i] for x in counts) for i in range(3))
    print(f"messages per run (median): motor {m:.0f}, controller {c:.0f} for {n:.0f} iterations")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
