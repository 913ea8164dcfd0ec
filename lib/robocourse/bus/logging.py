"""Node loggers: ``node.get_logger().info(...)`` printing ROS-style lines.

rclpy counterpart: ``rclpy.impl.rcutils_logger.RcutilsLogger``. Lines look like
``[WARN] [1700000000.123456789] [talker]: message`` on stderr; every record is also kept on
the context (``context.log_records``) so tests and notebooks can read what was reported.
``context.log_to_stderr = False`` silences printing (records are still kept).
"""

from __future__ import annotations

import sys
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


class RcutilsLogger:
    def __init__(self, name: str, context, clock=None):
        self.name = name
        self._context = context
        self._clock = clock
        self.level = LoggingSeverity.INFO

    def get_child(self, suffix: str) -> RcutilsLogger:
        return RcutilsLogger(f"{self.name}.{suffix}", self._context, self._clock)

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
        ctx = self._context
        if ctx is not None:
            ctx.log_records.append(rec)
            if not ctx.log_to_stderr:
                return True
        print(str(rec), file=sys.stderr)
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
