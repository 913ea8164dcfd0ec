"""``robocourse doctor``: the setup check of chapter 0 as a terminal command."""

from __future__ import annotations


def register(sub):
    p = sub.add_parser("doctor", help="check Python, packages, the 3D viewer and real-time permissions")
    p.add_argument("--no-try", action="store_true", help="do not attempt SCHED_FIFO and mlockall, only read limits")
    p.set_defaults(func=run)


def run(args) -> int:
    from robocourse.setup_check import report

    print(report(try_calls=not args.no_try))
    return 0
