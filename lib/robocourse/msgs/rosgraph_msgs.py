"""rosgraph_msgs/Clock (the /clock topic that drives simulated time)."""

from robocourse.msgs import builtin_interfaces  # noqa: F401
from robocourse.msgs._core import message


@message("rosgraph_msgs/msg/Clock", """
# This message communicates the current time.
builtin_interfaces/Time clock
""")
class Clock:
    pass


__all__ = ["Clock"]
