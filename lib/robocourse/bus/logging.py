"""Node loggers: ``node.get_logger().info(...)`` printing ROS-style lines.

rclpy counterpart: ``rclpy.impl.rcutils_logger.RcutilsLogger``. Lines look like
``[WARN] [1700000000.123456789] [talker]: message``; every record is also kept on the context
(``context.log_records``) so tests and notebooks can read what was reported.
``context.log_to_stderr = False`` silences printing (records are still kept).

Console output follows rcutils: the stream is stderr unless ``RCUTILS_LOGGING_USE_STDOUT=1``,
colour by severity (DEBUG green, INFO plain, WARN yellow, ERROR and FATAL red) when
``RCUTILS_COLORIZED_OUTPUT=1`` or, unset, when the stream is a terminal. One difference, for
notebooks: inside a Jupyter kernel the default stream is stdout and colour is on, because
Jupyter paints everything on stderr pink, so an INFO line would look like an error there.

``set_console_level(WARN)`` prints only WARN and above from every node, as ``--ros-args
--log-level WARN`` does, with one difference: the quieter lines are still kept on the context
(``context.log_records``), so a notebook can hide a flood of INFO without losing it
(``robocourse.notebook.log_level`` is the notebook-facing spelling).
"""

from __future__ import annotations

import os
import sys
import threading
from dataclasses import dataclass
from enum import IntEnum


class LoggingSeverity(IntEnum):
    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


@dataclass
class LogRecord:
    severity: LoggingSeverity
    name: str
    msg: str
    stamp_ns: int

    def __str__(self):
        s, ns = divmod(self.stamp_ns, 1_000_000_000)
        return f"[{self.severity.name}] [{s}.{ns:09d}] [{self.name}]: {self.msg}"


#: rcutils' console colours (ANSI SGR), by severity
COLORS = {LoggingSeverity.DEBUG: "\033[32m", LoggingSeverity.INFO: "", LoggingSeverity.WARN: "\033[33m",
          LoggingSeverity.ERROR: "\033[31m", LoggingSeverity.FATAL: "\033[31m"}
RESET = "\033[0m"

#: the lowest severity printed on the console (records below it are kept on the context only)
_console_level = LoggingSeverity.UNSET


def set_console_level(level) -> LoggingSeverity:
    """Print only records at ``level`` or above (``"WARN"``, ``LoggingSeverity.WARN``, 30); return the old level."""
    global _console_level
    if isinstance(level, str):
        try:
            new = LoggingSeverity[level.strip().upper().replace("WARNING", "WARN")]
        except KeyError:
            raise ValueError(f"log level {level!r}: use one of {', '.join(s.name for s in LoggingSeverity)}, "
                             "e.g. set_console_level('WARN')") from None
    else:
        try:
            new = LoggingSeverity(level)
        except ValueError:
            raise ValueError(f"log level {level!r}: use one of {', '.join(f'{s.name} ({s.value})' for s in LoggingSeverity)}"
                             ) from None
    old, _console_level = _console_level, new
    return old


def get_console_level() -> LoggingSeverity:
    return _console_level


def _in_jupyter_kernel() -> bool:
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    shell = ipython.get_ipython()
    return shell is not None and shell.__class__.__name__ == "ZMQInteractiveShell"


def _env_flag(name: str):
    """True / False for an rcutils-style 1/0 variable, None when unset or empty."""
    value = os.environ.get(name, "").strip()
    if not value:
        return None
    if value not in ("0", "1"):
        raise ValueError(f"{name}={value!r}: rcutils accepts 1 or 0 (or unset for the default)")
    return value == "1"


def console_stream():
    """Where log lines go: stdout if RCUTILS_LOGGING_USE_STDOUT=1 (or, unset, in a notebook), else stderr."""
    use_stdout = _env_flag("RCUTILS_LOGGING_USE_STDOUT")
    if use_stdout is None:
        use_stdout = _in_jupyter_kernel()
    return sys.stdout if use_stdout else sys.stderr


def console_line(rec: LogRecord, stream) -> str:
    """``rec`` as rcutils prints it on ``stream``: coloured if RCUTILS_COLORIZED_OUTPUT=1 or, unset,
    if the stream is a terminal or a notebook (Jupyter renders ANSI colours)."""
    colour = _env_flag("RCUTILS_COLORIZED_OUTPUT")
    if colour is None:
        isatty = getattr(stream, "isatty", None)
        colour = _in_jupyter_kernel() or bool(isatty and isatty())
    code = COLORS.get(rec.severity, "") if colour else ""
    return f"{code}{rec}{RESET}" if code else str(rec)


_THIS_FILE = __file__
_publishing = threading.local()


def _caller():
    """(file, function, line) of the code that called the logger (rclpy passes the same)."""
    f = sys._getframe(2)
    while f is not None and f.f_code.co_filename == _THIS_FILE:
        f = f.f_back
    if f is None:
        return "", "", 0
    return f.f_code.co_filename, f.f_code.co_name, f.f_lineno


class RcutilsLogger:
    """A named logger; a node's logger (and its children) also publish each emitted line on
    the node's /rosout publisher as ``rcl_interfaces/msg/Log`` (rcl_logging_rosout)."""

    def __init__(self, name: str, context, clock=None):
        self.name = name
        self._context = context
        self._clock = clock
        self.level = LoggingSeverity.INFO
        self._rosout = None
        self._parent = None

    def get_child(self, suffix: str) -> RcutilsLogger:
        child = RcutilsLogger(f"{self.name}.{suffix}", self._context, self._clock)
        child._parent = self       # a sublogger publishes on its node's /rosout (rcl >= Iron)
        return child

    def _rosout_publisher(self):
        logger = self
        while logger is not None:
            if logger._rosout is not None:
                return logger._rosout
            logger = logger._parent
        return None

    def _publish_rosout(self, rec: LogRecord) -> None:
        pub = self._rosout_publisher()
        if pub is None or pub._destroyed or getattr(_publishing, "active", False):
            return      # no node, or a log line written while publishing one (no recursion)
        from robocourse.msgs.builtin_interfaces import Time
        from robocourse.msgs.rcl_interfaces import Log

        file, function, line = _caller()
        sec, nsec = divmod(rec.stamp_ns, 1_000_000_000)
        _publishing.active = True
        try:
            pub.publish(Log(stamp=Time(sec=sec, nanosec=nsec), level=int(rec.severity),
                            name=rec.name, msg=rec.msg, file=file, function=function,
                            line=line))
        except Exception:  # noqa: BLE001 - a log line never fails its caller
            pass
        finally:
            _publishing.active = False

    def set_level(self, level) -> None:
        self.level = LoggingSeverity(level)

    def get_effective_level(self) -> LoggingSeverity:
        return self.level

    def log(self, msg, severity: LoggingSeverity) -> bool:
        if severity < self.level:
            return False
        import time

        stamp = self._clock.now_ns() if self._clock is not None else time.time_ns()
        rec = LogRecord(LoggingSeverity(severity), self.name, str(msg), stamp)
        if self._rosout is not None or self._parent is not None:
            self._publish_rosout(rec)
        ctx = self._context
        if ctx is not None:
            ctx.log_records.append(rec)
            if not ctx.log_to_stderr:
                return True
        if severity < _console_level:
            return True
        stream = console_stream()
        print(console_line(rec, stream), file=stream)
        return True

    def debug(self, msg, **_):
        return self.log(msg, LoggingSeverity.DEBUG)

    def info(self, msg, **_):
        return self.log(msg, LoggingSeverity.INFO)

    def warning(self, msg, **_):
        return self.log(msg, LoggingSeverity.WARN)

    warn = warning

    def error(self, msg, **_):
        return self.log(msg, LoggingSeverity.ERROR)

    def fatal(self, msg, **_):
        return self.log(msg, LoggingSeverity.FATAL)
