"""``robocourse grade SUBMISSIONS... [-j N] [--out grades.csv] [--feedback DIR]`` (otter grade), and
``robocourse grade export-gradescope CHAPTER [--out autograder.zip]`` (otter generate: a Gradescope
autograder for classes past one machine).

Every submission runs in its own bubblewrap sandbox (``--sandbox auto``); the run summary
says loudly if any could not be. Rows go to ``<out>.journal.jsonl`` as each submission
finishes; re-running the same command resumes from it.
"""

from __future__ import annotations

import datetime as dt
import sys


def register(sub):
    p = sub.add_parser("grade", help="grade submitted notebooks in bulk, each in its own sandbox; one CSV row each")
    p.add_argument("submissions", nargs="+", help="notebooks or folders of notebooks (one folder per student, "
                                                   "or files named <assignment>_<student>.ipynb)")
    p.add_argument("-j", "--jobs", type=int, default=1, help="submissions graded in parallel (default 1)")
    p.add_argument("--out", default="grades.csv", help="CSV to write (default grades.csv); its journal and "
                                                       "summary go beside it")
    p.add_argument("--feedback", metavar="DIR", help="write a .txt and .html feedback file per submission here")
    p.add_argument("--solutions", default="solutions", help="instructor notebooks (default solutions/)")
    p.add_argument("--assignment", help="solution notebook name, when file names do not contain it")
    p.add_argument("--checks", action="append", default=[], metavar="DIR",
                   help="folder of instructor-added hidden checks (*.py using @register); repeatable")
    p.add_argument("--time-limit", type=float, default=300.0, help="wall seconds per submission (default 300)")
    p.add_argument("--cell-timeout", type=float, default=120.0, help="seconds per cell (default 120)")
    p.add_argument("--memory", type=int, default=4096, help="memory for the whole submission in MB (default 4096)")
    p.add_argument("--max-processes", type=int, default=64, help="processes per submission (default 64)")
    p.add_argument("--work-mb", type=int, default=1024, help="size of each submission's own folder and /tmp in MB "
                                                             "(default 1024)")
    p.add_argument("--shm-mb", type=int, default=256, help="size of each submission's own /dev/shm in MB (default 256)")
    p.add_argument("--seed-salt", default="", help="a course's own salt for the draws (default none): the same "
                                                   "notebook always draws the same inputs for a given salt")
    p.add_argument("--sandbox", choices=["auto", "bwrap", "process"], default="auto",
                   help="auto: bubblewrap if it works here, else an unisolated process (reported); bwrap: "
                        "refuse to run without it; process: no isolation (trusted notebooks only)")
    p.add_argument("--force", action="store_true", help="replace an existing CSV even if it has more rows")
    p.add_argument("--restart", action="store_true", help="ignore the journal of an earlier run and grade again")
    p.add_argument("--due", help="deadline, ISO 8601 (2026-11-20T23:59 local time, or with +00:00)")
    p.add_argument("--late-penalty", type=float, default=0.0, metavar="PCT",
                   help="percent of the points removed per started day after --due (default 0: report only)")
    p.add_argument("--overrides", metavar="CSV", help="manual grades: columns student,check,points,comment "
                                                      "(optional assignment)")
    p.add_argument("--canvas", metavar="CSV", help="also write a Canvas gradebook import file")
    p.add_argument("--gradescope", metavar="CSV", help="also write a Gradescope-style scores file")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _due(text):
    if text is None:
        return None
    try:
        return dt.datetime.fromisoformat(text)
    except ValueError:
        raise ValueError(f"--due {text!r} is not an ISO 8601 date; write e.g. --due 2026-11-20T23:59") from None


def export_gradescope(args) -> int:
    """``robocourse grade export-gradescope CHAPTER [--out autograder.zip]``: Gradescope's autograder zip."""
    from robocourse.grading import gradescope

    if len(args.submissions) != 2:
        raise ValueError("usage: robocourse grade export-gradescope CHAPTER [--out autograder.zip] "
                         "(CHAPTER: ch00, 00 or the notebook's name)")
    chapter = args.submissions[1]
    out = args.out if args.out != "grades.csv" else f"autograder_{chapter}.zip"
    path = gradescope.export(chapter, out, solutions_dir=args.solutions, extra_dirs=args.checks,
                             time_limit=args.time_limit, memory_mb=args.memory, max_processes=args.max_processes,
                             cell_timeout=args.cell_timeout, salt=args.seed_salt)
    print(f"-> {path}: upload it as the assignment's autograder (Gradescope: Configure Autograder > Zip file)")
    return 0


def run(args) -> int:
    from robocourse.grading.grader import grade

    if args.submissions and args.submissions[0] == "export-gradescope":
        return export_gradescope(args)

    bar = None

    from robocourse.grading.report import for_terminal

    def progress(g):
        note = f"  {g.status}" if g.status else ""
        line = for_terminal(f"{g.student:>20}  {g.assignment:<26} {g.points:g}/{g.max_points:g}  ({g.seconds:.1f} s)"
                            f"{note}")
        if bar is not None:
            bar.update(1)
            bar.write(line)
        else:
            print(line, flush=True)

    if not args.no_progress and sys.stderr.isatty():
        try:
            from tqdm import tqdm

            from robocourse.grading.grader import expand

            bar = tqdm(total=len(expand(args.submissions)[0]), unit="sub", desc="grading", file=sys.stderr)
        except ImportError:
            bar = None
    try:
        grades = grade(args.submissions, solutions_dir=args.solutions, jobs=args.jobs, time_limit=args.time_limit,
                       memory_mb=args.memory, max_processes=args.max_processes, cell_timeout=args.cell_timeout,
                       extra_dirs=args.checks, assignment=args.assignment, out=args.out,
                       feedback_dir=args.feedback, progress=progress, sandbox_mode=args.sandbox, force=args.force,
                       due=_due(args.due), late_penalty=args.late_penalty, overrides=args.overrides,
                       canvas=args.canvas, gradescope=args.gradescope, resume=not args.restart, work_mb=args.work_mb,
                       shm_mb=args.shm_mb, salt=args.seed_salt)
    finally:
        if bar is not None:
            bar.close()
    print()
    print(grades.summary, end="")
    print(f"-> {args.out}" + (f", feedback in {args.feedback}/" if args.feedback else "")
          + (f", Canvas {args.canvas}" if args.canvas else "") + (f", Gradescope {args.gradescope}" if args.gradescope else ""))
    return 0
