"""Keep log floods out of a notebook: ``log_level("WARN")``.

A chapter that brings up a controller manager, a driver or a bus graph gets dozens of INFO
lines ("Loading controller ...", "Configuring ...") that bury the table the cell exists for.
``log_level("WARN")`` prints only warnings and errors from then on, from every bus node
(``robocourse.bus.logging.set_console_level``: the quieter lines stay on the context,
``context.log_records``, nothing is lost) and from the library's Python loggers (``logging``'s
``robocourse`` logger: below the level they are dropped, as Python's logging does).

    from robocourse.notebook import log_level
    log_level("WARN")              # for the rest of the notebook
    with log_level("ERROR"):       # for one block, the previous levels restored after
        cm.run(2.0)

ROS 2 counterpart: ``--ros-args --log-level WARN`` (which drops the quieter records instead of
keeping them).
"""

from __future__ import annotations

import logging

_PY_LEVELS = {"DEBUG": logging.DEBUG, "INFO": logging.INFO, "WARN": logging.WARNING, "ERROR": logging.ERROR,
              "FATAL": logging.CRITICAL, "UNSET": logging.NOTSET}


class log_level:  # noqa: N801  (used like a function: log_level("WARN"))
    """Print only log lines at ``level`` or above (DEBUG, INFO, WARN, ERROR, FATAL; UNSET prints all)."""

    def __init__(self, level="WARN"):
        from robocourse.bus.logging import set_console_level

        self._old_bus = set_console_level(level)   # validates: a bad level names the allowed ones
        from robocourse.bus.logging import get_console_level

        self.level = get_console_level()
        py = logging.getLogger("robocourse")
        self._old_py = py.level
        py.setLevel(_PY_LEVELS[self.level.name])

    def restore(self) -> None:
        from robocourse.bus.logging import set_console_level

        set_console_level(self._old_bus)
        logging.getLogger("robocourse").setLevel(self._old_py)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.restore()
        return False

    def __repr__(self):
        return f"log_level({self.level.name!r})"
