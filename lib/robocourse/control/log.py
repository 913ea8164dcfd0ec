"""The control stack's log: ROS-style lines, every record kept for tests and notebooks.

Counterpart: the ``rclcpp::Logger`` of the controller manager / resource manager /
each component. Built on :class:`robocourse.bus.logging.RcutilsLogger` (same line format,
``[WARN] [sec.nsec] [controller_manager]: ...``); the records live in one :class:`LogSink`
shared by the manager, the resource manager, components and controllers, so
``cm.log.records`` shows every event in order and a test can count them.
"""

from __future__ import annotations

from robocourse.bus.logging import (
    LoggingSeverity,
    LogRecord,
    RcutilsLogger,
    console_line,
    console_stream,
)


class LogSink:
    """Where records go: ``records`` (all), printing to stderr unless ``log_to_stderr`` is False."""

    def __init__(self, log_to_stderr: bool = True):
        self.log_records: list[LogRecord] = []
        self.log_to_stderr = log_to_stderr

    @property
    def records(self) -> list[LogRecord]:
        return self.log_records

    def logger(self, name: str, clock=None) -> RcutilsLogger:
        return RcutilsLogger(name, self, clock)

    def messages(self, name: str | None = None, severity: LoggingSeverity | None = None) -> list[str]:
        """Messages (optionally of one logger and one severity), oldest first."""
        return [r.msg for r in self.log_records
                if (name is None or r.name == name) and (severity is None or r.severity == severity)]

    def count(self, text: str) -> int:
        """How many records contain ``text``."""
        return sum(text in r.msg for r in self.log_records)

    def mark(self) -> int:
        """Where the log is now: pass it to :meth:`show` to print only what came after."""
        return len(self.log_records)

    def show(self, since: int = 0, min_severity: LoggingSeverity = LoggingSeverity.INFO, contains: str = "") -> int:
        """Print the records after ``since`` (a :meth:`mark`) at ``min_severity`` or above whose message
        contains ``contains``, as the console would have; return how many were printed.

        A quiet sink (``log_to_stderr=False``) plus ``show`` is how a notebook shows the lines that
        matter to a cell instead of every INFO line of a bring-up."""
        stream = console_stream()
        shown = 0
        for rec in self.log_records[since:]:
            if rec.severity >= min_severity and contains in rec.msg:
                print(console_line(rec, stream), file=stream)
                shown += 1
        return shown


__all__ = ["LogSink", "LoggingSeverity"]
