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


# --- control_msgs types of the trajectory, gripper, admittance and PID controllers --------------------
from robocourse.msgs import geometry_msgs, sensor_msgs, trajectory_msgs  # noqa: E402,F401  (field types)
from robocourse.msgs._core import action  # noqa: E402


@message("control_msgs/msg/JointTolerance", """
# 0 = use the controller's default, -1 = no tolerance (not checked), > 0 = this tolerance
string name
float64 position
float64 velocity
float64 acceleration
""")
class JointTolerance:
    pass


@message("control_msgs/msg/JointTrajectoryControllerState", """
std_msgs/Header header
string[] joint_names
trajectory_msgs/JointTrajectoryPoint reference
trajectory_msgs/JointTrajectoryPoint feedback
trajectory_msgs/JointTrajectoryPoint error
trajectory_msgs/JointTrajectoryPoint output
float64 speed_scaling_factor
""")
class JointTrajectoryControllerState:
    pass


FollowJointTrajectory = action("control_msgs/action/FollowJointTrajectory", """
trajectory_msgs/JointTrajectory trajectory
JointTolerance[] path_tolerance
JointTolerance[] goal_tolerance
builtin_interfaces/Duration goal_time_tolerance
---
int32 error_code
int32 SUCCESSFUL = 0
int32 INVALID_GOAL = -1
int32 INVALID_JOINTS = -2
int32 OLD_HEADER_TIMESTAMP = -3
int32 PATH_TOLERANCE_VIOLATED = -4
int32 GOAL_TOLERANCE_VIOLATED = -5
string error_string
---
std_msgs/Header header
string[] joint_names
trajectory_msgs/JointTrajectoryPoint desired
trajectory_msgs/JointTrajectoryPoint actual
trajectory_msgs/JointTrajectoryPoint error
int32 index
""")


@message("control_msgs/msg/GripperCommand", """
float64 position
float64 max_effort
""")
class GripperCommand:
    pass


GripperCommandAction = action("control_msgs/action/GripperCommand", """
GripperCommand command
---
float64 position
float64 effort
bool stalled
bool reached_goal
---
float64 position
float64 effort
bool stalled
bool reached_goal
""")

ParallelGripperCommand = action("control_msgs/action/ParallelGripperCommand", """
# name, position, velocity (max velocity), effort (max effort) of the gripper joint
sensor_msgs/JointState command
---
sensor_msgs/JointState state
bool stalled
bool reached_goal
---
sensor_msgs/JointState state
""")


@message("control_msgs/msg/MultiDOFCommand", """
string[] dof_names
float64[] values
float64[] values_dot
""")
class MultiDOFCommand:
    pass


@message("control_msgs/msg/SingleDOFState", """
string name
float64 reference
float64 feedback
float64 feedback_dot
float64 error
float64 error_dot
float64 time_step
float64 output
""")
class SingleDOFState:
    pass


@message("control_msgs/msg/MultiDOFStateStamped", """
std_msgs/Header header
SingleDOFState[] dof_states
""")
class MultiDOFStateStamped:
    pass


# upstream's wrench_base is a WrenchStamped and it also carries admittance_acceleration (AccelStamped);
# robocourse.msgs has neither type, so the wrench is a plain Wrench stamped by the header.
@message("control_msgs/msg/AdmittanceControllerState", """
std_msgs/Header header
string[] joint_names
float64[] mass
float64[] damping
float64[] stiffness
geometry_msgs/Wrench wrench_base
geometry_msgs/PoseStamped admittance_position
geometry_msgs/TwistStamped admittance_velocity
trajectory_msgs/JointTrajectoryPoint joint_state
trajectory_msgs/JointTrajectoryPoint ref_trajectory
""")
class AdmittanceControllerState:
    pass
