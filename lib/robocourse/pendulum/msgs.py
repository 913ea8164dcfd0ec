"""pendulum_msgs: the seed demo's message types (JointState, JointCommand, RttestResults)."""

from robocourse.msgs import (
    builtin_interfaces,  # noqa: F401  (RttestResults needs Time)
    message,
)


@message("pendulum_msgs/msg/JointState", """
float64 position
float64 velocity
float64 effort
""")
class JointState:
    pass


@message("pendulum_msgs/msg/JointCommand", """
float64 position
""")
class JointCommand:
    pass


@message("pendulum_msgs/msg/RttestResults", """
builtin_interfaces/Time stamp
pendulum_msgs/JointCommand command
pendulum_msgs/JointState state
uint64 cur_latency
float64 mean_latency
uint64 min_latency
uint64 max_latency
uint64 minor_pagefaults
uint64 major_pagefaults
""")
class RttestResults:
    pass
