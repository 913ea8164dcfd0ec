"""trajectory_msgs: JointTrajectory and JointTrajectoryPoint."""

from robocourse.msgs import std_msgs  # noqa: F401
from robocourse.msgs._core import message


@message("trajectory_msgs/msg/JointTrajectoryPoint", """
# Each trajectory point specifies either positions[, velocities[, accelerations]]
# or positions[, effort] for the trajectory to be executed.
# All specified values are in the same order as the joint names in JointTrajectory.msg.
float64[] positions
float64[] velocities
float64[] accelerations
float64[] effort
builtin_interfaces/Duration time_from_start
""")
class JointTrajectoryPoint:
    pass


@message("trajectory_msgs/msg/JointTrajectory", """
# The header is used to specify the coordinate frame and the reference time for
# the trajectory durations
std_msgs/Header header

# The names of the active joints in each trajectory point.
string[] joint_names

# Array of trajectory points, which describe the positions, velocities,
# accelerations and/or efforts of the joints at each time point.
JointTrajectoryPoint[] points
""")
class JointTrajectory:
    pass


__all__ = ["JointTrajectory", "JointTrajectoryPoint"]
