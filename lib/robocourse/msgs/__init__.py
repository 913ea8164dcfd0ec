"""robocourse.msgs: ROS 2 message, service and action types as dataclasses.

Import like rclpy code does, one module per ROS package::

    from robocourse.msgs.geometry_msgs import Twist
    from robocourse.msgs.std_msgs import Float64
    from robocourse.msgs.example_interfaces import AddTwoInts, Fibonacci

Each type carries ``_type`` ("geometry_msgs/msg/Twist") and ``_definition`` (the .msg text);
:func:`full_definition` gives the text with nested definitions appended, as ROS bags and MCAP
files store it. Chapters add their own types with :func:`message`, :func:`service` and
:func:`action` (see ``robocourse.msgs._core``). Conversions: :func:`to_dict`,
:func:`from_dict`, :func:`to_numpy` (a list of messages -> arrays per numeric field).
"""

from robocourse.msgs import (  # noqa: F401  (import order registers dependencies first)
    action_msgs,
    builtin_interfaces,
    diagnostic_msgs,
    example_interfaces,
    geometry_msgs,
    nav_msgs,
    rcl_interfaces,
    rosgraph_msgs,
    sensor_msgs,
    std_msgs,
    std_srvs,
    tf2_msgs,
    trajectory_msgs,
    type_description_interfaces,
    unique_identifier_msgs,
)
from robocourse.msgs._core import (
    REGISTRY,
    ActionType,
    FieldSpec,
    MessageDefinitionError,
    MessageFieldError,
    MessageFieldRangeError,
    ServiceType,
    action,
    check_message,
    definition_name,
    from_dict,
    full_definition,
    get_message_type,
    is_message_type,
    make_message,
    message,
    numeric_paths,
    service,
    to_dict,
    to_numpy,
)

__all__ = [
    "REGISTRY", "ActionType", "FieldSpec", "MessageDefinitionError", "MessageFieldError",
    "MessageFieldRangeError", "ServiceType", "action",
    "check_message", "definition_name", "from_dict", "full_definition", "get_message_type", "is_message_type",
    "make_message", "message", "numeric_paths", "service", "to_dict", "to_numpy",
]
