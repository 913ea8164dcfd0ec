"""controller_manager_msgs (and lifecycle_msgs/State) as robocourse message types.

Counterpart: ros-controls/ros2_control:controller_manager_msgs (msg/ and srv/) and
ros2/rcl_interfaces:lifecycle_msgs/msg/State. Field names and constants are upstream's; the
deprecated ``class_type`` field of HardwareComponentState is kept (same value as plugin_name).
"""

from robocourse.msgs import builtin_interfaces, message, service, std_msgs  # noqa: F401  (Duration, Header)


@message("lifecycle_msgs/msg/State", """
uint8 PRIMARY_STATE_UNKNOWN = 0
uint8 PRIMARY_STATE_UNCONFIGURED = 1
uint8 PRIMARY_STATE_INACTIVE = 2
uint8 PRIMARY_STATE_ACTIVE = 3
uint8 PRIMARY_STATE_FINALIZED = 4
uint8 id
string label
""")
class LifecycleState:
    pass


@message("controller_manager_msgs/msg/ChainConnection", """
string name
string[] reference_interfaces
""")
class ChainConnection:
    pass


@message("controller_manager_msgs/msg/ControllerState", """
string name
string state
string type
bool is_async
uint16 update_rate
string[] claimed_interfaces
string[] required_command_interfaces
string[] required_state_interfaces
bool is_chainable
bool is_chained
string[] exported_state_interfaces
string[] reference_interfaces
ChainConnection[] chain_connections
""")
class ControllerState:
    pass


@message("controller_manager_msgs/msg/HardwareInterface", """
string name
string data_type
bool is_available
bool is_claimed
""")
class HardwareInterface:
    pass


@message("controller_manager_msgs/msg/HardwareComponentState", """
string name
string type
string class_type
string plugin_name
lifecycle_msgs/State state
bool is_async
uint16 rw_rate
HardwareInterface[] command_interfaces
HardwareInterface[] state_interfaces
""")
class HardwareComponentState:
    pass


ListControllers = service("controller_manager_msgs/srv/ListControllers", """
---
ControllerState[] controller
""")

ListControllerTypes = service("controller_manager_msgs/srv/ListControllerTypes", """
---
string[] types
string[] base_classes
""")

ListHardwareInterfaces = service("controller_manager_msgs/srv/ListHardwareInterfaces", """
---
HardwareInterface[] command_interfaces
HardwareInterface[] state_interfaces
""")

ListHardwareComponents = service("controller_manager_msgs/srv/ListHardwareComponents", """
---
HardwareComponentState[] component
""")

LoadController = service("controller_manager_msgs/srv/LoadController", """
string name
---
bool ok
""")

ConfigureController = service("controller_manager_msgs/srv/ConfigureController", """
string name
---
bool ok
""")

UnloadController = service("controller_manager_msgs/srv/UnloadController", """
string name
---
bool ok
""")

SwitchController = service("controller_manager_msgs/srv/SwitchController", """
string[] activate_controllers
string[] deactivate_controllers
int32 strictness
int32 BEST_EFFORT=1
int32 STRICT=2
int32 AUTO=3
int32 FORCE_AUTO=4
bool activate_asap
builtin_interfaces/Duration timeout
---
bool ok
string message
""")

SetHardwareComponentState = service("controller_manager_msgs/srv/SetHardwareComponentState", """
string name
lifecycle_msgs/State target_state
---
bool ok
lifecycle_msgs/State state
""")


# --- control_msgs types the joint state broadcaster publishes ------------------------------------------
@message("control_msgs/msg/InterfaceValue", """
string[] interface_names
float64[] values
""")
class InterfaceValue:
    pass


@message("control_msgs/msg/DynamicJointState", """
std_msgs/Header header
string[] joint_names
InterfaceValue[] interface_values
""")
class DynamicJointState:
    pass
