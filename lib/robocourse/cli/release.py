"""``robocourse release DIR``: write the student edition of the course (nbgrader release, otter assign).

What goes in is the manifest in :mod:`robocourse.release` (include/exclude rules, first match
wins, everything unmatched stays out); nothing is written when a check fails (exercises out of
sync with solutions/, a solution block found in a file of the edition, DIR not empty or inside
the course folder).
"""

from __future__ import annotations


def register(sub):
    p = sub.add_parser("release", help="write the student edition (no solutions/, no instructor-only tests) into DIR")
    p.add_argument("dir", metavar="DIR", help="an empty folder outside the course folder, e.g. ../robocourse-student")
    p.add_argument("--root", default=".", help="the instructor's course folder, holding solutions/ (default: .)")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty DIR: the previous edition's files are replaced, "
                        "anything else there (a .git folder) is kept")
    p.add_argument("--list", action="store_true", help="also print every file of the edition")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocourse.release import release

    edition = release(args.dir, root=args.root, force=args.force)
    tops: dict[str, int] = {}
    for rel in edition.files:
        top = rel.split("/")[0] + ("/" if "/" in rel else "")
        tops[top] = tops.get(top, 0) + 1
    if args.list:
        for rel in sorted(edition.files):
            print(f"  {rel}")
    print(f"student edition written to {edition.target}: {len(edition.files)} files")
    print("  " + ", ".join(f"{top} ({n})" if top.endswith("/") else top for top, n in sorted(tops.items())))
    if edition.removed:
        print(f"removed {len(edition.removed)} file(s) of the previous edition: {', '.join(edition.removed[:5])}"
              + (" ..." if len(edition.removed) > 5 else ""))
    print("left out:")
    for entry, count, why in edition.left_out:
        print(f"  {entry:<34} {count:>3} file(s)  {why}")
    for leak, overlap in edition.known_overlaps:
        print(f"warning: {leak}; known overlap: {overlap.why}")
    print(f"next: cd {edition.target} && make test   (then publish it: git init / commit / push)")
    return 0
