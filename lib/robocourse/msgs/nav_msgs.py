"""nav_msgs/Odometry."""

from robocourse.msgs import geometry_msgs  # noqa: F401
from robocourse.msgs._core import message


@message("nav_msgs/msg/Odometry", """
# This represents an estimate of a position and velocity in free space.
# The pose in this message should be specified in the coordinate frame given by header.frame_id
# The twist in this message should be specified in the coordinate frame given by the child_frame_id
std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
""")
class Odometry:
    pass


__all__ = ["Odometry"]
