"""sensor_msgs/JointState."""

from robocourse.msgs import std_msgs  # noqa: F401
from robocourse.msgs._core import message


@message("sensor_msgs/msg/JointState", """
# This is a message that holds data to describe the state of a set of torque controlled joints.
std_msgs/Header header

string[] name
float64[] position
float64[] velocity
float64[] effort
""")
class JointState:
    pass


__all__ = ["JointState"]
