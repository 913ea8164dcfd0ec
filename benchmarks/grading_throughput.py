"""Grading throughput: submissions per minute, sandboxed (bubblewrap) vs not, -j 1 and -j 2.

A class of 24 notebooks: the 4 exercise notebooks x 6 students (3 hand in the completed
solution, 3 the untouched exercise, so both the full and the early-exit paths are timed).
Every configuration grades the same 24 files in the same run; rounds alternate the order of
the configurations so a load change on the machine does not favour one of them. Prints the
median per configuration (with min..max over rounds) and the sandbox's cost as a ratio.

    .venv/bin/python benchmarks/grading_throughput.py [--rounds 1] [--jobs 1 2]

The machine is shared (other engineers, 2 cores): absolute figures move with the load; the
ratio between configurations measured in the same round is the figure to read.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "lib"))

from robocourse.grading import sandbox  # noqa: E402
from robocourse.grading.grader import grade  # noqa: E402


def make_class(folder: Path) -> int:
    n = 0
    for k in range(6):
        student = folder / f"student{k + 1}"
        student.mkdir(parents=True)
        source = ROOT / ("solutions" if k < 3 else "exercises")
        for nb in sorted(source.glob("*.ipynb")):
            shutil.copy(nb, student / nb.name)
            n += 1
    return n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=1, help="repetitions of every configuration (default 1)")
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="-j values to compare (default 1 2)")
    args = ap.parse_args(argv)
    modes = ["process", "bwrap"] if sandbox.bwrap_works() else ["process"]
    if len(modes) == 1:
        print("bubblewrap is not usable here: only the unsandboxed configuration is measured")
    tmp = Path(tempfile.mkdtemp(prefix="grading-bench-"))
    try:
        n = make_class(tmp / "class")
        configs = [(j, m) for j in args.jobs for m in modes]
        seconds: dict[tuple, list[float]] = {c: [] for c in configs}
        full: dict[tuple, int] = {}
        for r in range(args.rounds):
            order = configs if r % 2 == 0 else configs[::-1]
            for jobs, mode in order:
                start = time.monotonic()
                grades = grade([str(tmp / "class")], solutions_dir=ROOT / "solutions", jobs=jobs, time_limit=240,
                               sandbox_mode=mode)
                seconds[(jobs, mode)].append(time.monotonic() - start)
                full[(jobs, mode)] = sum(g.points == g.max_points for g in grades)
                print(f"round {r + 1}: -j {jobs} {mode:<8} {seconds[(jobs, mode)][-1]:6.1f} s", flush=True)
        load = os.getloadavg()
        print()
        print(f"{n} notebooks (4 assignments x 6 students), {args.rounds} round(s), load average "
              f"{load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on {os.cpu_count()} cores (shared machine)")
        print(f"{'config':<18}{'median s':>10}{'min..max':>16}{'subs/min':>10}{'full marks':>12}")
        for jobs, mode in configs:
            s = seconds[(jobs, mode)]
            med = statistics.median(s)
            label = f"-j {jobs} {'sandboxed' if mode == 'bwrap' else 'unsandboxed'}"
            print(f"{label:<18}{med:>10.1f}{f'{min(s):.1f}..{max(s):.1f}':>16}{n / med * 60:>10.1f}"
                  f"{full[(jobs, mode)]:>12}")
        if "bwrap" in modes:
            print()
            for jobs in args.jobs:
                base = statistics.median(seconds[(jobs, "process")])
                sand = statistics.median(seconds[(jobs, "bwrap")])
                print(f"-j {jobs}: sandboxed throughput = {base / sand:.2f} x unsandboxed "
                      f"(cost {100 * (sand - base) / base:+.0f} %; goal: cost < 25 %)")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
