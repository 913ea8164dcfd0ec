"""Each notebook's headless time in test mode, median of 3, beside the 60 s budget.

The 60 s per notebook is a goal measured here, not a test timeout (the nbmake timeout in
``tests/conftest.py`` is a safety net well above it): a loaded machine makes every notebook
slower, and a red suite because another job ran at the same time says nothing about the course.
Each notebook runs as nbmake runs it (every cell, in its own folder, ``ROBOCOURSE_TEST=1``), its
kernel over IPC (``robocourse.notebook.run``). Repeats are interleaved (every notebook once,
then again), so a burst of someone else's work lands on one repeat of several notebooks rather
than on every repeat of one. The machine is shared: read the spread, not only the median.
``--load`` runs every repeat with chapter 1's disturbance (``CpuLoad(processes=2)``, two busy
processes on the last allowed CPU), as the under-load test does. ``--claims DIR`` writes the
claims each notebook rendered in its last repeat (``robocourse.notebook.claim``: what was
measured, the verdict, the sentence) to ``DIR/<notebook>.<quiet|loaded>.json``.

Beside the wall time, the CPU time the run cost (user + system of the kernel and of every
process it waited for, from ``getrusage(RUSAGE_CHILDREN)``): less sensitive to the neighbours'
load than the wall time, it tells a notebook that computes too much from one that waits too
long. ``--cells N`` lists each notebook's N slowest cells (median seconds over the repeats) and
the load average at the start, so a slow notebook says where its time goes.

    .venv/bin/python benchmarks/notebook_times.py [--repeats 3] [--load] [--claims DIR] [--cells N] [chapters/01_realtime_basics.ipynb ...]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import statistics
import sys
from pathlib import Path

from robocourse.notebook.claims import recorded_claims
from robocourse.notebook.run import execute
from robocourse.rt.disturb import CpuLoad

ROOT = Path(__file__).resolve().parents[1]
BUDGET_S = 60.0


def children_cpu_s() -> float:
    """User + system seconds of this process's children that have been waited for, so far."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def cell_seconds(nb) -> dict[int, float]:
    """{cell index: seconds} from nbclient's timing metadata (execute_input to execute_reply)."""
    from datetime import datetime

    out = {}
    for i, cell in enumerate(nb.cells):
        ex = cell.get("metadata", {}).get("execution", {})
        if "iopub.execute_input" in ex and "shell.execute_reply" in ex:
            t0, t1 = (datetime.fromisoformat(ex[k].replace("Z", "+00:00"))
                      for k in ("iopub.execute_input", "shell.execute_reply"))
            out[i] = (t1 - t0).total_seconds()
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("notebooks", nargs="*", type=Path,
                    help="notebooks to time (default: chapters/*.ipynb and solutions/*.ipynb)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each notebook (default 3)")
    ap.add_argument("--load", action="store_true", help="run under chapter 1's CPU load (two busy processes)")
    ap.add_argument("--claims", type=Path, metavar="DIR", help="write each notebook's rendered claims there (JSON)")
    ap.add_argument("--cells", type=int, default=0, metavar="N", help="list each notebook's N slowest cells")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats {args.repeats}: run each notebook at least once, e.g. --repeats 3")
    paths = args.notebooks or sorted(ROOT.glob("chapters/*.ipynb")) + sorted(ROOT.glob("solutions/*.ipynb"))
    for p in paths:
        if not p.is_file():
            ap.error(f"{p}: no such notebook; pass paths like chapters/01_realtime_basics.ipynb")
    if args.cells < 0:
        ap.error(f"--cells {args.cells}: give the number of slowest cells to list, e.g. --cells 5")
    load_at_start = os.getloadavg()
    times: dict[Path, list[float]] = {p: [] for p in paths}
    cpu: dict[Path, list[float]] = {p: [] for p in paths}
    cells: dict[Path, dict[int, list[float]]] = {p: {} for p in paths}
    failed: dict[Path, str] = {}
    for r in range(args.repeats):
        for p in paths:
            if p in failed:
                continue
            load = CpuLoad(processes=2) if args.load else contextlib.nullcontext()
            try:
                with load:   # the load's own processes are reaped after the CPU reading below
                    cpu0 = children_cpu_s()
                    ran, seconds = execute(p, env={"ROBOCOURSE_TEST": "1"})
                    cpu[p].append(children_cpu_s() - cpu0)
            except Exception as exc:  # a failing notebook is reported, the others still timed
                failed[p] = f"{type(exc).__name__}: {str(exc).strip().splitlines()[-1] if str(exc).strip() else ''}"
                continue
            times[p].append(seconds)
            for i, sec in cell_seconds(ran).items():
                cells[p].setdefault(i, []).append(sec)
            if args.claims is not None:
                args.claims.mkdir(parents=True, exist_ok=True)
                rows = [{k: rec[k] for k in ("what", "verdict", "text")} for rec in recorded_claims(ran)]
                (args.claims / f"{p.stem}.{'loaded' if args.load else 'quiet'}.json").write_text(
                    json.dumps(rows, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
            print(f"repeat {r + 1}/{args.repeats}: {p.relative_to(ROOT) if p.is_absolute() else p} {seconds:.1f} s, "
                  f"CPU {cpu[p][-1]:.1f} s, load average {os.getloadavg()[0]:.1f}", file=sys.stderr)
    width = max(len(str(p.relative_to(ROOT) if p.is_absolute() else p)) for p in paths)
    cond = "under load (two busy processes)" if args.load else "quiet"
    print(f"headless time in test mode, {cond}, median [lowest-highest] of {args.repeats}; budget {BUDGET_S:.0f} s")
    print(f"load average (1, 5, 15 min) at the start: {load_at_start[0]:.1f} {load_at_start[1]:.1f} "
          f"{load_at_start[2]:.1f}; at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())} ({os.cpu_count()} CPUs)")
    print(f"{'notebook':<{width}}  {'median s':>9}  {'range s':>13}  {'CPU s':>6}  {'budget s':>8}  {'median/budget':>13}")
    over = 0
    for p in paths:
        name = str(p.relative_to(ROOT) if p.is_absolute() else p)
        if p in failed:
            print(f"{name:<{width}}  FAILED: {failed[p]}")
            continue
        t = times[p]
        med = statistics.median(t)
        over += med > BUDGET_S
        print(f"{name:<{width}}  {med:9.1f}  {min(t):6.1f}-{max(t):<6.1f}  {statistics.median(cpu[p]):6.1f}  "
              f"{BUDGET_S:8.0f}  {med / BUDGET_S:12.2f}x"
              + ("  OVER BUDGET" if med > BUDGET_S else ""))
    if args.cells:
        for p in paths:
            if not cells[p]:
                continue
            slowest = sorted(cells[p].items(), key=lambda kv: -statistics.median(kv[1]))[:args.cells]
            print(f"{p.name}: slowest cells (index: median s) "
                  + ", ".join(f"{i}: {statistics.median(v):.1f}" for i, v in slowest))
    total = sum(statistics.median(t) for p, t in times.items() if t)
    print(f"total of medians: {total:.0f} s; {over} notebook(s) over budget; {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
