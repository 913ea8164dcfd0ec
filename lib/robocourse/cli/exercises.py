"""``robocourse exercises build|check``: generate exercises/ from solutions/ (nbgrader assign)."""

from __future__ import annotations

from pathlib import Path


def register(sub):
    p = sub.add_parser("exercises", help="generate or verify the student notebooks in exercises/")
    p.add_argument("action", choices=["build", "check"],
                   help="build: write exercises/ from solutions/; check: fail if they are out of sync")
    p.add_argument("--root", default=".", help="course folder holding solutions/ and exercises/ (default: .)")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocourse.grading import exercises

    root = Path(args.root)
    if not (root / "solutions").is_dir():
        raise FileNotFoundError(f"{root / 'solutions'} not found; run from the course folder or pass --root")
    if args.action == "build":
        changed = exercises.build(root)
        for path in changed:
            print(f"wrote {path}")
        total = len(list((root / "solutions").glob("*.ipynb")))
        print(f"{len(changed)} exercise notebook(s) regenerated, {total - len(changed)} already up to date")
        return 0
    problems = exercises.check(root)
    for p in problems:
        print(f"out of sync: {p}")
    if problems:
        print("exercises/ is out of sync with solutions/: run `robocourse exercises build` and commit.")
        return 1
    print(f"exercises/ is in sync with solutions/ ({len(list((root / 'solutions').glob('*.ipynb')))} notebooks)")
    return 0
