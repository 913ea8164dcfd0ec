"""Grading throughput: submissions per minute, sandboxed (bubblewrap) vs not, with and without cgroups.

A class of 24 notebooks: the first 4 assignments' notebooks x 6 students (3 hand in the
completed solution, 3 the untouched exercise, so both the full and the early-exit paths are
timed). Every configuration grades the same 24 files in the same run: unsandboxed, sandboxed
with the polled limits, sandboxed with a cgroup per submission (issue 26's limits: memory with
shared memory counted, one CPU's worth each, a private size-limited folder and /dev/shm; only
where the grader may create cgroups). Rounds alternate the order of the configurations so a
load change on the machine does not favour one of them. Prints the median per configuration
(with min..max over rounds) and each configuration's cost against the unsandboxed baseline.
``--bytecode`` adds the sandboxed polled configuration with the library's bytecode removed (every
sandbox then compiles the library from source: what ``sandbox.compile_library`` saves).

    .venv/bin/python benchmarks/grading_throughput.py [--rounds 1] [--jobs 2] [--bytecode]

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

from robocourse.grading import resources, sandbox  # noqa: E402
from robocourse.grading.grader import grade  # noqa: E402


def make_class(folder: Path) -> int:
    n = 0
    for k in range(6):
        student = folder / f"student{k + 1}"
        student.mkdir(parents=True)
        source = ROOT / ("solutions" if k < 3 else "exercises")
        for nb in sorted(source.glob("*.ipynb"))[:4]:
            shutil.copy(nb, student / nb.name)
            n += 1
    return n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=1, help="repetitions of every configuration (default 1)")
    ap.add_argument("--jobs", type=int, nargs="+", default=[2], help="-j values to compare (default 2)")
    ap.add_argument("--bytecode", action="store_true",
                    help="also grade sandboxed (polled) with the library's bytecode removed and not compiled: what "
                         "sandbox.compile_library saves")
    args = ap.parse_args(argv)
    ap_limits = resources.mode()
    modes = [("process", "polling")]
    if sandbox.bwrap_works():
        modes.append(("bwrap", "polling"))
        if args.bytecode:
            modes.append(("bwrap", "polling, no .pyc"))
        if ap_limits != "polling":
            modes.append(("bwrap", ap_limits))
    else:
        print("bubblewrap is not usable here: only the unsandboxed configuration is measured")
    tmp = Path(tempfile.mkdtemp(prefix="grading-bench-"))
    try:
        n = make_class(tmp / "class")
        sandbox.compile_library()   # every configuration but "no .pyc" starts from a compiled library
        configs = [(j, m, r) for j in args.jobs for m, r in modes]
        seconds: dict[tuple, list[float]] = {c: [] for c in configs}
        full: dict[tuple, int] = {}
        for rnd in range(args.rounds):
            order = configs if rnd % 2 == 0 else configs[::-1]
            for jobs, mode, limits in order:
                resources._MODE[:] = [limits.split(",")[0]]
                no_pyc = limits.endswith("no .pyc")
                if no_pyc:
                    for pyc in (ROOT / "lib" / "robocourse").rglob("__pycache__/*.pyc"):
                        pyc.unlink(missing_ok=True)
                os.environ["ROBOCOURSE_COMPILE_LIBRARY"] = "0" if no_pyc else "1"
                start = time.monotonic()
                grades = grade([str(tmp / "class")], solutions_dir=ROOT / "solutions", jobs=jobs, time_limit=240,
                               sandbox_mode=mode)
                seconds[(jobs, mode, limits)].append(time.monotonic() - start)
                if no_pyc:   # the next configuration starts from a compiled library again
                    os.environ["ROBOCOURSE_COMPILE_LIBRARY"] = "1"
                    sandbox.compile_library()
                full[(jobs, mode, limits)] = sum(g.points == g.max_points for g in grades)
                print(f"round {rnd + 1}: -j {jobs} {mode:<8} {limits:<12} {seconds[(jobs, mode, limits)][-1]:6.1f} s",
                      flush=True)
        os.environ.pop("ROBOCOURSE_COMPILE_LIBRARY", None)
        sandbox.compile_library()   # leave the library compiled, as a grading run does
        load = os.getloadavg()
        print()
        print(f"{n} notebooks (4 assignments x 6 students), {args.rounds} round(s), load average "
              f"{load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on {os.cpu_count()} cores (shared machine)")
        print(f"{'config':<34}{'median s':>10}{'min..max':>16}{'subs/min':>10}{'full marks':>12}{'vs base':>9}")
        for jobs, mode, limits in configs:
            s = seconds[(jobs, mode, limits)]
            med = statistics.median(s)
            base = statistics.median(seconds[(jobs, "process", "polling")])
            label = f"-j {jobs} {'sandboxed' if mode == 'bwrap' else 'unsandboxed'}, {limits}"
            print(f"{label:<34}{med:>10.1f}{f'{min(s):.1f}..{max(s):.1f}':>16}{n / med * 60:>10.1f}"
                  f"{full[(jobs, mode, limits)]:>12}{base / med:>8.2f}x")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
