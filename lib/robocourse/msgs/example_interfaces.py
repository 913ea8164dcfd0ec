"""example_interfaces: AddTwoInts and the Fibonacci action of the ROS 2 tutorials."""

from robocourse.msgs import action_msgs  # noqa: F401  (actions need GoalStatus/CancelGoal)
from robocourse.msgs._core import action, service

AddTwoInts = service("example_interfaces/srv/AddTwoInts", """
int64 a
int64 b
---
int64 sum
""")

Fibonacci = action("example_interfaces/action/Fibonacci", """
# goal definition
int32 order
---
# result definition
int32[] sequence
---
# feedback
int32[] sequence
""")

__all__ = ["AddTwoInts", "Fibonacci"]
