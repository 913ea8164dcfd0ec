"""geometry_msgs: vectors, poses, twists, transforms (ROS 2 definitions and defaults)."""

from robocourse.msgs import std_msgs  # noqa: F401
from robocourse.msgs._core import message


@message("geometry_msgs/msg/Vector3", """
# This represents a vector in free space.
float64 x
float64 y
float64 z
""")
class Vector3:
    pass


@message("geometry_msgs/msg/Point", """
# This contains the position of a point in free space
float64 x
float64 y
float64 z
""")
class Point:
    pass


@message("geometry_msgs/msg/Quaternion", """
# This represents an orientation in free space in quaternion form.
float64 x 0
float64 y 0
float64 z 0
float64 w 1
""")
class Quaternion:
    """Defaults to the identity rotation (w=1), as in ROS 2."""


@message("geometry_msgs/msg/Pose", """
# A representation of pose in free space, composed of position and orientation.
Point position
Quaternion orientation
""")
class Pose:
    pass


@message("geometry_msgs/msg/PoseStamped", """
# A Pose with reference coordinate frame and timestamp
std_msgs/Header header
Pose pose
""")
class PoseStamped:
    pass


@message("geometry_msgs/msg/PoseWithCovariance", """
# This represents a pose in free space with uncertainty.
Pose pose
# Row-major representation of the 6x6 covariance matrix
float64[36] covariance
""")
class PoseWithCovariance:
    pass


@message("geometry_msgs/msg/Twist", """
# This expresses velocity in free space broken into its linear and angular parts.
Vector3  linear
Vector3  angular
""")
class Twist:
    pass


@message("geometry_msgs/msg/TwistStamped", """
# A twist with reference coordinate frame and timestamp
std_msgs/Header header
Twist twist
""")
class TwistStamped:
    pass


@message("geometry_msgs/msg/TwistWithCovariance", """
# This expresses velocity in free space with uncertainty.
Twist twist
# Row-major representation of the 6x6 covariance matrix
float64[36] covariance
""")
class TwistWithCovariance:
    pass


@message("geometry_msgs/msg/Transform", """
# This represents the transform between two coordinate frames in free space.
Vector3 translation
Quaternion rotation
""")
class Transform:
    pass


@message("geometry_msgs/msg/TransformStamped", """
# This expresses a transform from coordinate frame header.frame_id
# to the coordinate frame child_frame_id at the time of header.stamp
std_msgs/Header header
string child_frame_id
Transform transform
""")
class TransformStamped:
    pass


@message("geometry_msgs/msg/Wrench", """
# This represents force in free space, separated into its linear and angular parts.
Vector3  force
Vector3  torque
""")
class Wrench:
    pass


__all__ = ["Vector3", "Point", "Quaternion", "Pose", "PoseStamped", "PoseWithCovariance",
           "Twist", "TwistStamped", "TwistWithCovariance", "Transform", "TransformStamped",
           "Wrench"]
