"""Answer-bank stability: every bank answer graded N times quiet and N times under chapter 1's CPU load.

Issue 26's rule: a check is trusted when its verdicts never change, also on a loaded machine.
CI grades every answer once (tests/test_banks.py); this script runs the 20 repetitions and
prints, per exercise, how many wrong and right answers its bank holds, how often the reference
scored full (quiet and loaded), whether every answer kept its expected score in every run, and
the seconds per run (the load's cost, measured in the same run: the ratio is the figure to read).

    .venv/bin/python benchmarks/bank_stability.py [--repeats 20] [--banks ch00 ch01] [--no-load]

Each run is one sandboxed grading process per bank file with fresh draws (run k draws with
seed_for(check, "bank|answer|k")); the load is ``CpuLoad(processes=2)``, chapter 1's.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "lib"))

from robocourse.grading.bank import grade_bank  # noqa: E402
from robocourse.rt.disturb import CpuLoad  # noqa: E402


def load_bank(path: Path):
    spec = importlib.util.spec_from_file_location(f"bank_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return list(module.EXERCISES)


def print_table(rows: dict, conditions: list[str]) -> None:
    """Per exercise: bank size, the reference's full-score count and the runs with every answer as expected."""
    head = f"{'exercise':<22}{'wrong':>6}{'right':>6}"
    for c in conditions:
        head += f"{'ref full ' + c:>19}{'all as expected':>17}"
    print(head)
    for check, row in rows.items():
        line = f"{check:<22}{row['wrong']:>6}{row['right']:>6}"
        for c in conditions:
            ref = [v for v in row[c] if v.answer == "reference"]
            runs = len(ref)
            by_run: dict[int, list] = {}
            for v in row[c]:
                by_run.setdefault(v.run, []).append(v)
            clean = sum(all(v.ok for v in vs) for vs in by_run.values())
            line += f"{f'{sum(v.ok for v in ref)}/{runs}':>19}{f'{clean}/{len(by_run)} runs':>17}"
        print(line)
    print(flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=20, help="runs per condition (default 20)")
    ap.add_argument("--banks", nargs="*", help="bank files by stem (default: every tests/banks/*.py)")
    ap.add_argument("--no-load", action="store_true", help="quiet runs only")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats must be >= 1, got {args.repeats}")
    paths = sorted((ROOT / "tests" / "banks").glob("*.py"))
    if args.banks:
        unknown = set(args.banks) - {p.stem for p in paths}
        if unknown:
            ap.error(f"no bank {sorted(unknown)}; the banks are {[p.stem for p in paths]}")
        paths = [p for p in paths if p.stem in args.banks]
    conditions = ["quiet"] + ([] if args.no_load else ["loaded"])
    rows: dict[str, dict] = {}
    seconds: dict[str, list[float]] = {c: [] for c in conditions}
    loadavg: dict[str, list[float]] = {c: [] for c in conditions}  # the shared machine's 1-min load after each run
    for path in paths:
        exercises = load_bank(path)
        for ex in exercises:
            rows[ex.check] = {"wrong": len(ex.wrong), "right": len(ex.right), **{c: [] for c in conditions}}
        for run in range(args.repeats):
            for condition in conditions if run % 2 == 0 else conditions[::-1]:  # alternate the order
                around = CpuLoad(processes=2) if condition == "loaded" else contextlib.nullcontext()
                start = time.monotonic()
                with around:
                    verdicts = grade_bank(exercises, solutions_dir=ROOT / "solutions", repeats=1,
                                          first_run=run + (1000 if condition == "loaded" else 0))
                seconds[condition].append(time.monotonic() - start)
                loadavg[condition].append(os.getloadavg()[0])
                for v in verdicts:
                    rows[v.check][condition].append(v)
                bad = [v for v in verdicts if not v.ok]
                print(f"{path.stem} run {run + 1}/{args.repeats} {condition:<6} {seconds[condition][-1]:6.1f} s  "
                      f"load avg {loadavg[condition][-1]:4.1f}  "
                      f"{len(verdicts) - len(bad)}/{len(verdicts)} as expected"
                      + "".join(f"\n    UNEXPECTED {v.check} / {v.answer}: {'; '.join(v.problems)}"
                                + "".join(f"\n        {line.strip()}" for line in v.feedback.splitlines()
                                          if line.strip().startswith("[FAIL]") and " sub-tests failed" not in line)
                                for v in bad[:5]),
                      flush=True)
        if len(paths) > 1:  # a long run shows each bank's table as soon as it is done
            print_table({ex.check: rows[ex.check] for ex in exercises}, conditions)
    print()
    print_table(rows, conditions)
    print()
    for c in conditions:
        s = seconds[c]
        print(f"{c:<7} seconds per bank run: median {statistics.median(s):.1f} (min {min(s):.1f}, max {max(s):.1f}) "
              f"over {len(s)} runs; 1-min load average after a run: median {statistics.median(loadavg[c]):.1f} "
              f"(max {max(loadavg[c]):.1f}) on {os.cpu_count()} CPUs")
    if "loaded" in conditions:
        print(f"loaded / quiet: {statistics.median(seconds['loaded']) / statistics.median(seconds['quiet']):.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
