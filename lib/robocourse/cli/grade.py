"""``robocourse grade SUBMISSIONS... [-j N] [--out grades.csv] [--feedback DIR]`` (otter grade)."""

from __future__ import annotations


def register(sub):
    p = sub.add_parser("grade", help="grade submitted notebooks in bulk; one CSV row per student")
    p.add_argument("submissions", nargs="+", help="notebooks or folders of notebooks")
    p.add_argument("-j", "--jobs", type=int, default=1, help="submissions graded in parallel (default 1)")
    p.add_argument("--out", default="grades.csv", help="CSV to write (default grades.csv)")
    p.add_argument("--feedback", metavar="DIR", help="write one feedback file per student here")
    p.add_argument("--solutions", default="solutions", help="instructor notebooks (default solutions/)")
    p.add_argument("--assignment", help="solution notebook name, when file names do not contain it")
    p.add_argument("--checks", action="append", default=[], metavar="DIR",
                   help="folder of instructor-added checks (*.py using @register); repeatable")
    p.add_argument("--time-limit", type=float, default=300.0, help="seconds per submission (default 300)")
    p.add_argument("--cell-timeout", type=float, default=120.0, help="seconds per cell (default 120)")
    p.add_argument("--memory", type=int, default=4096, help="memory limit per submission in MB (default 4096)")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocourse.grading.grader import grade

    def progress(g):
        print(f"{g.student:>20}  {g.assignment:<28} {g.points:g}/{g.max_points:g}"
              f"  ({g.seconds:.1f} s){'  ' + g.status if g.status else ''}", flush=True)

    grades = grade(args.submissions, solutions_dir=args.solutions, jobs=args.jobs,
                   time_limit=args.time_limit, memory_mb=args.memory, cell_timeout=args.cell_timeout,
                   extra_dirs=args.checks, assignment=args.assignment, out=args.out,
                   feedback_dir=args.feedback, progress=progress)
    print(f"graded {len(grades)} submission(s) -> {args.out}"
          + (f", feedback in {args.feedback}/" if args.feedback else ""))
    return 0
