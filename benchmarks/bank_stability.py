"""Answer-bank stability: the closing note's table for issue 26, from N sandboxed gradings per bank.

Issue 26's rule: a check is trusted when its verdicts never change, also on a loaded machine.
CI grades every answer once quiet and the correct answers of the ``timing=True`` exercises once
more under load (tests/test_banks.py); the wrong answers of those exercises are graded under load
only here (``--timing only --conditions loaded``, issue 31). This script runs the N repetitions and
prints, per exercise of chapters 0-7: how many wrong answers its bank holds and the properties
they break, how often the reference scored full, how often the differently written right
answer(s) scored full, how many runs had every answer (wrong ones included) as the bank
expects, and the seconds per run (the load's cost, measured in the same run: the ratio is the
figure to read). Timing exercises (``timing=True``) run serially like everything here: one
sandboxed grading process at a time.

    .venv/bin/python benchmarks/bank_stability.py [--repeats 20] [--banks ch00 ch01]
        [--conditions quiet loaded] [--timing all|only|exclude] [--pending] [--save runs.json]
    .venv/bin/python benchmarks/bank_stability.py --table runs1.json runs2.json   # one table from saved runs

Each run is one sandboxed grading process per bank file with fresh draws (run k draws with
seed_for(check, "bank|answer|k")); "loaded" is ``CpuLoad(processes=2)``, chapter 1's, for the
whole run. ``--pending`` adds tests/banks_pending/ (banks whose 20-run figures are not in yet).
``--save`` writes every verdict (JSON, appended run by run, so a long run that is stopped keeps
what it measured); ``--table`` prints the table of saved files without grading anything.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "lib"))


def load_bank(path: Path):
    spec = importlib.util.spec_from_file_location(f"bank_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return list(module.EXERCISES)


def _frac(hits: int, n: int) -> str:
    return f"{hits}/{n}" if n else "-"


def print_table(rows: dict, conditions: list[str]) -> None:
    """Per exercise: the bank (wrong answers, their properties), the reference's and the right answers' full-score
    counts and the runs with every answer as the bank expects, per condition."""
    head = f"{'exercise':<24}{'wrong':>6}"
    for c in conditions:
        head += f"  {'ref ' + c:>12}{'right ' + c:>14}{'as expected':>13}"
    print(head)
    for check, row in rows.items():
        line = f"{check:<24}{row['wrong']:>6}"
        for c in conditions:
            vs = row.get(c, [])
            ref = [v for v in vs if v["kind"] == "reference"]
            right = [v for v in vs if v["kind"] == "right"]
            by_run: dict[int, list] = {}
            for v in vs:
                by_run.setdefault(v["run"], []).append(v)
            clean = sum(all(v["ok"] for v in r) for r in by_run.values())
            line += (f"  {_frac(sum(v['full'] for v in ref), len(ref)):>12}"
                     f"{_frac(sum(v['full'] for v in right), len(right)):>14}{_frac(clean, len(by_run)):>13}")
        print(line)
    print("\nwrong answers per exercise (the property each breaks; 'unexpected' = runs where it scored other than "
          "the bank says):")
    for check, row in rows.items():
        print(f"  {check}:")
        for name, prop in row["properties"].items():
            vs = [v for c in conditions for v in row.get(c, []) if v["answer"] == name]
            bad = sum(not v["ok"] for v in vs)
            print(f"    - {name} [{prop}]" + (f"  UNEXPECTED in {bad}/{len(vs)} runs" if bad else ""))
    print(flush=True)


def _failed_lines(feedback: str, more: int = 2) -> list[str]:
    """Each failed sub-test's line and up to ``more`` lines of its message that follow."""
    lines, out = feedback.splitlines(), []
    for i, line in enumerate(lines):
        if line.strip().startswith("[FAIL]") and " sub-tests failed" not in line:
            out.append(line)
            for nxt in lines[i + 1:i + 1 + more]:
                if not nxt.strip() or nxt.strip().startswith("["):
                    break
                out.append(nxt)
    return out


def verdict_row(v, condition: str) -> dict:
    return {"check": v.check, "answer": v.answer, "kind": v.kind, "run": v.run, "condition": condition,
            "points": v.points, "weight": v.weight, "full": abs(v.points - v.weight) < 1e-9, "ok": v.ok,
            "problems": v.problems, "seed": v.seed}


def rows_from(saved: list[dict], banks: dict) -> dict:
    rows: dict = {}
    for ex in banks:
        rows[ex.check] = {"wrong": len(ex.wrong), "right": len(ex.right),
                          "properties": {a.name: a.property for a in ex.wrong}}
    for v in saved:
        if v["check"] in rows:
            rows[v["check"]].setdefault(v["condition"], []).append(v)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=20, help="runs per condition (default 20)")
    ap.add_argument("--banks", nargs="*", help="bank files by stem (default: every tests/banks/*.py)")
    ap.add_argument("--conditions", nargs="+", default=["quiet", "loaded"], choices=["quiet", "loaded"])
    ap.add_argument("--no-load", action="store_true", help="quiet runs only (same as --conditions quiet)")
    ap.add_argument("--timing", choices=["all", "only", "exclude"], default="all",
                    help="the exercises marked timing=True: with the rest, alone, or left out")
    ap.add_argument("--pending", action="store_true", help="add tests/banks_pending/*.py")
    ap.add_argument("--save", type=Path, help="write every verdict to this JSON file (rewritten after each run)")
    ap.add_argument("--table", nargs="+", type=Path, metavar="JSON", help="print the table of saved runs and exit")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats must be >= 1, got {args.repeats}")
    conditions = ["quiet"] if args.no_load else list(dict.fromkeys(args.conditions))
    paths = sorted((ROOT / "tests" / "banks").glob("*.py"))
    if args.pending or args.table:
        paths += sorted((ROOT / "tests" / "banks_pending").glob("*.py"))
    if args.banks:
        unknown = set(args.banks) - {p.stem for p in paths}
        if unknown:
            ap.error(f"no bank {sorted(unknown)}; the banks are {[p.stem for p in paths]} (--pending adds "
                     "tests/banks_pending/)")
        paths = [p for p in paths if p.stem in args.banks]
    banks = {p: [ex for ex in load_bank(p) if args.timing == "all" or ex.timing == (args.timing == "only")]
             for p in paths}
    if args.table:
        saved = [v for f in args.table for v in json.loads(f.read_text())["verdicts"]]
        seen = list(dict.fromkeys(v["condition"] for v in saved))
        print_table({k: r for k, r in rows_from(saved, [ex for exs in banks.values() for ex in exs]).items()
                     if any(r.get(c) for c in seen)}, seen)
        return 0

    from robocourse.grading.bank import grade_bank
    from robocourse.rt.disturb import CpuLoad

    saved: list[dict] = []
    seconds: dict[str, list[float]] = {c: [] for c in conditions}
    loadavg: dict[str, list[float]] = {c: [] for c in conditions}  # the shared machine's 1-min load after each run
    for path, exercises in banks.items():
        if not exercises:
            continue
        for run in range(args.repeats):
            for condition in conditions if run % 2 == 0 else conditions[::-1]:  # alternate the order
                around = CpuLoad(processes=2) if condition == "loaded" else contextlib.nullcontext()
                start = time.monotonic()
                with around:
                    verdicts = grade_bank(exercises, solutions_dir=ROOT / "solutions", repeats=1,
                                          first_run=run + (1000 if condition == "loaded" else 0))
                seconds[condition].append(time.monotonic() - start)
                loadavg[condition].append(os.getloadavg()[0])
                saved += [verdict_row(v, condition) for v in verdicts]
                if args.save:
                    args.save.write_text(json.dumps({"conditions": conditions, "verdicts": saved}))
                bad = [v for v in verdicts if not v.ok]
                print(f"{path.stem} run {run + 1}/{args.repeats} {condition:<6} {seconds[condition][-1]:6.1f} s  "
                      f"load avg {loadavg[condition][-1]:4.1f}  "
                      f"{len(verdicts) - len(bad)}/{len(verdicts)} as expected"
                      + "".join(f"\n    UNEXPECTED {v.check} / {v.answer}: {'; '.join(v.problems)}"
                                + "".join(f"\n        {line.strip()[:400]}" for line in _failed_lines(v.feedback))
                                for v in bad[:5]),
                      flush=True)
        if len(banks) > 1:  # a long run shows each bank's table as soon as it is done
            print_table(rows_from(saved, exercises), conditions)
    print()
    print_table(rows_from(saved, [ex for exs in banks.values() for ex in exs]), conditions)
    print()
    for c in conditions:
        s = seconds[c]
        if s:
            print(f"{c:<7} seconds per bank run: median {statistics.median(s):.1f} (min {min(s):.1f}, max {max(s):.1f}) "
                  f"over {len(s)} runs; 1-min load average after a run: median {statistics.median(loadavg[c]):.1f} "
                  f"(max {max(loadavg[c]):.1f}) on {os.cpu_count()} CPUs")
    if seconds.get("loaded") and seconds.get("quiet"):
        print(f"loaded / quiet: {statistics.median(seconds['loaded']) / statistics.median(seconds['quiet']):.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
