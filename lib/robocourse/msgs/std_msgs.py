"""std_msgs: Header and the basic wrappers (rclpy: ``from std_msgs.msg import Float64``)."""

from robocourse.msgs import builtin_interfaces  # noqa: F401  (Header needs Time)
from robocourse.msgs._core import message


@message("std_msgs/msg/Header", """
# Standard metadata for higher-level stamped data types.
builtin_interfaces/Time stamp
string frame_id
""")
class Header:
    pass


@message("std_msgs/msg/Empty", "")
class Empty:
    pass


@message("std_msgs/msg/Bool", "bool data")
class Bool:
    pass


@message("std_msgs/msg/String", "string data")
class String:
    pass


@message("std_msgs/msg/Int32", "int32 data")
class Int32:
    pass


@message("std_msgs/msg/Int64", "int64 data")
class Int64:
    pass


@message("std_msgs/msg/Float32", "float32 data")
class Float32:
    pass


@message("std_msgs/msg/Float64", "float64 data")
class Float64:
    pass


@message("std_msgs/msg/MultiArrayDimension", """
string label   # label of given dimension
uint32 size    # size of given dimension (in type units)
uint32 stride  # stride of given dimension
""")
class MultiArrayDimension:
    pass


@message("std_msgs/msg/MultiArrayLayout", """
MultiArrayDimension[] dim # Array of dimension properties
uint32 data_offset        # padding bytes at front of data
""")
class MultiArrayLayout:
    pass


@message("std_msgs/msg/Float64MultiArray", """
# Please look at the MultiArrayLayout message definition for
# documentation on all multiarrays.

MultiArrayLayout  layout        # specification of data layout
float64[]         data          # array of data
""")
class Float64MultiArray:
    pass


__all__ = ["Header", "Empty", "Bool", "String", "Int32", "Int64", "Float32", "Float64",
           "MultiArrayDimension", "MultiArrayLayout", "Float64MultiArray"]
