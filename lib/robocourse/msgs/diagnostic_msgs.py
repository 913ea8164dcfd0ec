"""diagnostic_msgs: DiagnosticArray, DiagnosticStatus, KeyValue."""

from robocourse.msgs import std_msgs  # noqa: F401
from robocourse.msgs._core import message


@message("diagnostic_msgs/msg/KeyValue", """
# What to label this value when viewing.
string key
# A value to track over time.
string value
""")
class KeyValue:
    pass


@message("diagnostic_msgs/msg/DiagnosticStatus", """
# This message holds the status of an individual component of the robot.

# Possible levels of operations.
byte OK=0
byte WARN=1
byte ERROR=2
byte STALE=3

# Level of operation enumerated above.
byte level
# A description of the test/component reporting.
string name
# A description of the status.
string message
# A hardware unique string.
string hardware_id
# An array of values associated with the status.
KeyValue[] values
""")
class DiagnosticStatus:
    pass


@message("diagnostic_msgs/msg/DiagnosticArray", """
# This message is used to send diagnostic information about the state of the robot.
std_msgs/Header header # for timestamp
DiagnosticStatus[] status # an array of components being reported on
""")
class DiagnosticArray:
    pass


__all__ = ["KeyValue", "DiagnosticStatus", "DiagnosticArray"]
