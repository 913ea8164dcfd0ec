"""builtin_interfaces: Time and Duration (rclpy: ``from builtin_interfaces.msg import Time``)."""

from robocourse.msgs._core import message


@message("builtin_interfaces/msg/Time", """
# Time indicates a specific point in time, relative to a clock's 0 point.
int32 sec
uint32 nanosec
""")
class Time:
    """A point in time: ``sec`` + ``nanosec``. ``to_sec()`` is a robocourse convenience."""

    def to_sec(self) -> float:
        return self.sec + self.nanosec * 1e-9

    def to_nanoseconds(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec

    @classmethod
    def from_nanoseconds(cls, ns: int):
        sec, nsec = divmod(int(ns), 1_000_000_000)
        return cls(sec=sec, nanosec=nsec)


@message("builtin_interfaces/msg/Duration", """
# Duration defines a period between two time points.
int32 sec
uint32 nanosec
""")
class Duration:
    """A span of time: ``sec`` + ``nanosec``."""

    def to_sec(self) -> float:
        return self.sec + self.nanosec * 1e-9


__all__ = ["Time", "Duration"]
