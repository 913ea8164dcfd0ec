"""The ``robocourse`` command: one subcommand per demo or tool.

Each module in this package that defines ``register(subparsers)`` adds its subcommands
(``robocourse exercises build``, ``robocourse grade ...``), so a chapter adds a file here and
touches nothing else. Like the ``ros2`` CLI, errors are one clear line and a non-zero exit.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robocourse", description="robocourse: real-time robot control the ROS 2 way")
    from robocourse import __version__

    parser.add_argument("--version", action="version", version=f"robocourse {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (ValueError, FileNotFoundError, KeyError) as exc:
        print(f"robocourse {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
