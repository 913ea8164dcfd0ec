"""rcl_interfaces: the log message of /rosout, parameters and the six parameter services.

Field lists as in ros2/rcl_interfaces (Jazzy, unchanged through 2.2.0): ``msg/Log``,
``msg/Parameter``, ``msg/ParameterValue``, ``msg/ParameterType``, ``msg/ParameterDescriptor``,
``msg/ParameterEvent``, ``msg/SetParametersResult``, ``msg/ListParametersResult``,
``msg/FloatingPointRange``, ``msg/IntegerRange`` and ``srv/DescribeParameters``,
``GetParameterTypes``, ``GetParameters``, ``ListParameters``, ``SetParameters``,
``SetParametersAtomically``. Their RIHS01 type hashes equal the ones real Jazzy nodes announce
(tests/test_bus_node_services.py checks them), so rmw_zenoh peers match our keys.
"""

from robocourse.msgs import builtin_interfaces  # noqa: F401
from robocourse.msgs._core import message, service


@message("rcl_interfaces/msg/Log", """
# one log line as a node's rosout publisher sends it (rqt_console shows these)
uint8 DEBUG=10
uint8 INFO=20
uint8 WARN=30
uint8 ERROR=40
uint8 FATAL=50
builtin_interfaces/Time stamp
uint8 level
string name      # the logger's name
string msg
string file      # where the log call is
string function
uint32 line
""")
class Log:
    pass


@message("rcl_interfaces/msg/ParameterType", """
uint8 PARAMETER_NOT_SET=0
uint8 PARAMETER_BOOL=1
uint8 PARAMETER_INTEGER=2
uint8 PARAMETER_DOUBLE=3
uint8 PARAMETER_STRING=4
uint8 PARAMETER_BYTE_ARRAY=5
uint8 PARAMETER_BOOL_ARRAY=6
uint8 PARAMETER_INTEGER_ARRAY=7
uint8 PARAMETER_DOUBLE_ARRAY=8
uint8 PARAMETER_STRING_ARRAY=9
""")
class ParameterType:
    pass


@message("rcl_interfaces/msg/ParameterValue", """
# a tagged value: 'type' (a ParameterType constant) says which field holds it
uint8 type
bool bool_value
int64 integer_value
float64 double_value
string string_value
byte[] byte_array_value
bool[] bool_array_value
int64[] integer_array_value
float64[] double_array_value
string[] string_array_value
""")
class ParameterValue:
    pass


@message("rcl_interfaces/msg/Parameter", """
string name
ParameterValue value
""")
class Parameter:
    pass


@message("rcl_interfaces/msg/FloatingPointRange", """
# inclusive range; step 0 means any value in it
float64 from_value
float64 to_value
float64 step
""")
class FloatingPointRange:
    pass


@message("rcl_interfaces/msg/IntegerRange", """
# inclusive range; step 0 means any value in it
int64 from_value
int64 to_value
uint64 step
""")
class IntegerRange:
    pass


@message("rcl_interfaces/msg/ParameterDescriptor", """
string name
uint8 type
string description
string additional_constraints
bool read_only false
bool dynamic_typing false
FloatingPointRange[<=1] floating_point_range
IntegerRange[<=1] integer_range
""")
class ParameterDescriptor:
    pass


@message("rcl_interfaces/msg/ParameterEvent", """
# what changed in one set of one node's parameters (topic /parameter_events)
builtin_interfaces/Time stamp
string node
Parameter[] new_parameters
Parameter[] changed_parameters
Parameter[] deleted_parameters
""")
class ParameterEvent:
    pass


@message("rcl_interfaces/msg/SetParametersResult", """
bool successful
string reason
""")
class SetParametersResult:
    pass


@message("rcl_interfaces/msg/ListParametersResult", """
string[] names
string[] prefixes
""")
class ListParametersResult:
    pass


DescribeParameters = service("rcl_interfaces/srv/DescribeParameters", """
string[] names
---
ParameterDescriptor[] descriptors
""")

GetParameterTypes = service("rcl_interfaces/srv/GetParameterTypes", """
string[] names
---
uint8[] types
""")

GetParameters = service("rcl_interfaces/srv/GetParameters", """
string[] names
---
ParameterValue[] values
""")

ListParameters = service("rcl_interfaces/srv/ListParameters", """
uint64 DEPTH_RECURSIVE=0
string[] prefixes
uint64 depth
---
ListParametersResult result
""")

SetParameters = service("rcl_interfaces/srv/SetParameters", """
Parameter[] parameters
---
SetParametersResult[] results
""")

SetParametersAtomically = service("rcl_interfaces/srv/SetParametersAtomically", """
Parameter[] parameters
---
SetParametersResult result
""")

__all__ = ["DescribeParameters", "FloatingPointRange", "GetParameterTypes", "GetParameters",
           "IntegerRange", "ListParameters", "ListParametersResult", "Log", "Parameter",
           "ParameterDescriptor", "ParameterEvent", "ParameterType", "ParameterValue",
           "SetParameters", "SetParametersAtomically", "SetParametersResult"]
