"""tf2_msgs/TFMessage (the /tf and /tf_static topics)."""

from robocourse.msgs import geometry_msgs  # noqa: F401
from robocourse.msgs._core import message


@message("tf2_msgs/msg/TFMessage", """
geometry_msgs/TransformStamped[] transforms
""")
class TFMessage:
    pass


__all__ = ["TFMessage"]
