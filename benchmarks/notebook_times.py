"""Each notebook's headless time in test mode, median of 3, beside the 60 s budget.

The 60 s per notebook is a goal measured here, not a test timeout (the nbmake timeout in
``tests/conftest.py`` is a safety net well above it): a loaded machine makes every notebook
slower, and a red suite because another job ran at the same time says nothing about the course.
Each notebook runs as nbmake runs it (every cell, in its own folder, ``ROBOCOURSE_TEST=1``), its
kernel over IPC (``robocourse.notebook.run``). Repeats are interleaved (every notebook once,
then again), so a burst of someone else's work lands on one repeat of several notebooks rather
than on every repeat of one. The machine is shared: read the spread, not only the median.
``--load`` runs every repeat with chapter 1's disturbance (``CpuLoad(processes=2)``, two busy
processes on the last allowed CPU), as the under-load test does. Each run's 1-minute load
average is read before and after it (other people's work shows there; ``--load`` adds about 2).

``--claims DIR`` keeps what each notebook rendered in its last repeat: the claims
(``robocourse.notebook.claim``: key, what was measured, the verdict, the sentence, the cell and
section) in ``DIR/<notebook>.<quiet|loaded>.json``, the executed notebook beside it
(``.ipynb``, to read as a student would), and ``DIR/claims.md``: per notebook, each claim's
sentence in the quiet run beside the loaded one (rebuilt from every JSON in DIR, so run once
without and once with ``--load`` into the same DIR). ``--list DIR`` only rebuilds that list.
"Quiet" means without our CpuLoad, not an idle machine: read the load averages it records.

Beside the wall time, the CPU time each run cost (user + system of the kernel and of every
process it waited for: the boxes, chapter 1's CpuLoad processes a chapter starts, from
``getrusage(RUSAGE_CHILDREN)``): less sensitive to the neighbours' load than the wall time, it
tells a notebook that computes too much from one that waits too long. ``--cells N`` lists each
notebook's N slowest cells (median seconds over the repeats, from nbclient's timing metadata).

    .venv/bin/python benchmarks/notebook_times.py [--repeats 3] [--load] [--claims DIR] [--cells N] [chapters/01_realtime_basics.ipynb ...]
    .venv/bin/python benchmarks/notebook_times.py --repeats 1 --claims /tmp/claims chapters/*.ipynb
    .venv/bin/python benchmarks/notebook_times.py --repeats 1 --claims /tmp/claims --load chapters/*.ipynb
    .venv/bin/python benchmarks/notebook_times.py --list /tmp/claims     # rebuild /tmp/claims/claims.md
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import statistics
import sys
import time
from pathlib import Path

import nbformat

from robocourse.notebook.claims import write_claims
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
    ap.add_argument("--claims", type=Path, metavar="DIR",
                    help="keep each notebook's rendered claims (JSON), its executed copy and DIR/claims.md there")
    ap.add_argument("--list", type=Path, metavar="DIR",
                    help="only rebuild DIR/claims.md from the JSON files a --claims run left there (runs nothing)")
    ap.add_argument("--cells", type=int, default=0, metavar="N", help="list each notebook's N slowest cells")
    args = ap.parse_args(argv)
    if args.list is not None:
        if args.notebooks or args.claims or args.load:
            ap.error("--list DIR runs nothing: pass it alone, e.g. --list /tmp/claims")
        if not sorted(args.list.glob("*.json")):
            ap.error(f"--list {args.list}: no claim files (<notebook>.quiet.json / .loaded.json) there; "
                     "write them first with --claims DIR")
        out = write_list(args.list)
        print(f"wrote {out}")
        return 0
    if args.repeats < 1:
        ap.error(f"--repeats {args.repeats}: run each notebook at least once, e.g. --repeats 3")
    if args.cells < 0:
        ap.error(f"--cells {args.cells}: give the number of slowest cells to list, e.g. --cells 5")
    paths = args.notebooks or sorted(ROOT.glob("chapters/*.ipynb")) + sorted(ROOT.glob("solutions/*.ipynb"))
    for p in paths:
        if not p.is_file():
            ap.error(f"{p}: no such notebook; pass paths like chapters/01_realtime_basics.ipynb")
    times: dict[Path, list[float]] = {p: [] for p in paths}
    loads: dict[Path, list[float]] = {p: [] for p in paths}
    cpu: dict[Path, list[float]] = {p: [] for p in paths}
    cells: dict[Path, dict[int, list[float]]] = {p: {} for p in paths}
    failed: dict[Path, str] = {}
    cond = "loaded" if args.load else "quiet"
    for r in range(args.repeats):
        for p in paths:
            if p in failed:
                continue
            load = CpuLoad(processes=2) if args.load else contextlib.nullcontext()
            before = os.getloadavg()[0]
            started = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
            try:
                with load:   # the load's own processes are reaped after the CPU reading below
                    cpu0 = children_cpu_s()
                    ran, seconds = execute(p, env={"ROBOCOURSE_TEST": "1"})
                    cpu[p].append(children_cpu_s() - cpu0)
            except Exception as exc:  # a failing notebook is reported, the others still timed
                failed[p] = f"{type(exc).__name__}: {str(exc).strip().splitlines()[-1] if str(exc).strip() else ''}"
                continue
            after = os.getloadavg()[0]
            times[p].append(seconds)
            loads[p] += [before, after]
            for i, sec in cell_seconds(ran).items():
                cells[p].setdefault(i, []).append(sec)
            if args.claims is not None and r == args.repeats - 1:
                write_claims(args.claims, p.stem, cond, ran, started=started, seconds=round(seconds, 1),
                             loadavg_before=round(before, 2), loadavg_after=round(after, 2),
                             cpu_load="CpuLoad(processes=2)" if args.load else "none")
                nbformat.write(ran, args.claims / f"{p.stem}.{cond}.ipynb")
            print(f"repeat {r + 1}/{args.repeats}: {_name(p)} {seconds:.1f} s, CPU {cpu[p][-1]:.1f} s "
                  f"(load average {before:.2f} before, {after:.2f} after)", file=sys.stderr)
    width = max(len(_name(p)) for p in paths)
    how = "under load (two busy processes)" if args.load else "quiet (no CpuLoad of ours)"
    print(f"headless time in test mode, {how}, median [lowest-highest] of {args.repeats}; budget {BUDGET_S:.0f} s")
    print(f"{'notebook':<{width}}  {'median s':>9}  {'range s':>13}  {'CPU s':>6}  {'budget s':>8}  "
          f"{'median/budget':>13}  {'load avg':>11}")
    over = 0
    for p in paths:
        name = _name(p)
        if p in failed:
            print(f"{name:<{width}}  FAILED: {failed[p]}")
            continue
        t = times[p]
        med = statistics.median(t)
        over += med > BUDGET_S
        print(f"{name:<{width}}  {med:9.1f}  {min(t):6.1f}-{max(t):<6.1f}  {statistics.median(cpu[p]):6.1f}  "
              f"{BUDGET_S:8.0f}  {med / BUDGET_S:12.2f}x"
              f"  {min(loads[p]):5.2f}-{max(loads[p]):<5.2f}" + ("  OVER BUDGET" if med > BUDGET_S else ""))
    for p in paths if args.cells else ():
        if cells[p]:
            slowest = sorted(cells[p].items(), key=lambda kv: -statistics.median(kv[1]))[:args.cells]
            print(f"{_name(p)}: slowest cells (index: median s) "
                  + ", ".join(f"{i}: {statistics.median(v):.1f}" for i, v in slowest))
    total = sum(statistics.median(t) for p, t in times.items() if t)
    print(f"total of medians: {total:.0f} s; {over} notebook(s) over budget; {len(failed)} failed "
          "(load avg: the machine's 1-minute load average before and after each run, lowest-highest)")
    if args.claims is not None:
        print(f"claims: {write_list(args.claims)}")
    return 1 if failed else 0


def _name(p: Path) -> str:
    return str(p.relative_to(ROOT) if p.is_absolute() and p.is_relative_to(ROOT) else p)


def _about(run: dict | None) -> str:
    if run is None:
        return "not run"
    a = run.get("about", {})
    parts = [a.get("started", ""), f"{a['seconds']} s" if "seconds" in a else ""]
    if "loadavg_before" in a:
        parts.append(f"load average {a['loadavg_before']} before, {a['loadavg_after']} after")
    elif "loadavg_after" in a:
        parts.append(f"load average {a['loadavg_after']} after")
    return ", ".join(x for x in parts if x) + f", {len(run['claims'])} claims"


def write_list(folder: Path) -> Path:
    """Rebuild ``folder/claims.md``: per notebook, each claim key with its quiet and loaded sentence."""
    runs: dict[str, dict[str, dict]] = {}
    for f in sorted(folder.glob("*.json")):
        data = json.loads(f.read_text(encoding="utf-8"))
        if not isinstance(data, dict) or "claims" not in data:
            continue        # an older file (a bare list) or something else: not ours
        runs.setdefault(data["notebook"], {})[data["condition"]] = data
    lines = ["# Rendered claims per notebook, quiet and loaded", "",
             "Written by `benchmarks/notebook_times.py --claims` (test mode, `ROBOCOURSE_TEST=1`). *Quiet*: no "
             "CpuLoad of ours (the machine may still be busy: see each run's load average); *loaded*: "
             "chapter 1's `CpuLoad(processes=2)` running. A claim's key is its `what` (with `#n` for a later "
             "claim of the same name); a verdict that differs between the runs is marked.", ""]
    for nb in sorted(runs):
        quiet, loaded = runs[nb].get("quiet"), runs[nb].get("loaded")
        lines += [f"## {nb}", "", f"- quiet run: {_about(quiet)}", f"- loaded run: {_about(loaded)}", ""]
        q = {c["key"]: c for c in (quiet or {}).get("claims", [])}
        ld = {c["key"]: c for c in (loaded or {}).get("claims", [])}
        keys = list(q) + [k for k in ld if k not in q]
        if not keys:
            lines += ["(no rendered claims)", ""]
            continue
        for k in keys:
            a, b = q.get(k), ld.get(k)
            where = a or b
            va, vb = (a or {}).get("verdict", "-"), (b or {}).get("verdict", "-")
            mark = "  **(verdict differs)**" if a and b and va != vb else ""
            sec = f", {where['section']}" if where.get("section") else ""
            lines.append(f"### `{k}` (cell {where['cell']}{sec}): {va} / {vb}{mark}")
            lines.append("")
            lines.append(f"- quiet: {a['text'] if a else '(not rendered in this run)'}")
            lines.append(f"- loaded: {b['text'] if b else '(not rendered in this run)'}")
            lines.append("")
    out = folder / "claims.md"
    out.write_text("\n".join(lines), encoding="utf-8")
    return out


if __name__ == "__main__":
    sys.exit(main())
