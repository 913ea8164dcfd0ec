"""robocourse.control: ros2_control in Python.

Mirrors upstream's split:

- ``hardware``: component base classes (:class:`SystemInterface`, :class:`ActuatorInterface`,
  :class:`SensorInterface`), ``HardwareInfo`` from the URDF ``<ros2_control>`` element,
  ``mock_components/GenericSystem``, ``robocourse/MujocoSystem``;
- ``manager``: the :class:`ResourceManager` (interface values, loans, claims, hardware
  lifecycle), :class:`ControllerInterface` / :class:`ChainableControllerInterface`, the
  :class:`ControllerManager` (switching, chaining, the loop) and its bus services;
- ``parameters``: generate_parameter_library-style schemas and ROS 2 parameter files;
- ``controllers``: ros2_controllers, one folder each (forward command, joint state broadcaster);
- ``pluginlib``: plugins by name; ``introspection``: ``ros2 control`` output and the picture;
- ``joint_bridge``: :class:`JointBridge`, the brain/cerebellum bridge (command timeout, safe mode)
  between a non-real-time command source (chapter 6's policy) and the control loop.
"""

from . import (
    introspection,  # ``ros2 control`` verbs: robocourse.control.introspection.list_controllers(cm)
)
from .hardware.component import (
    ActuatorInterface,
    HardwareComponentInterface,
    SensorInterface,
    SystemInterface,
)
from .hardware.info import HardwareInfo, URDFError, parse_control_resources_from_urdf
from .hardware.types import (
    ACTIVE,
    FINALIZED,
    INACTIVE,
    UNCONFIGURED,
    UNKNOWN,
    CallbackReturn,
    State,
    return_type,
)
from .manager.controller_interface import (
    ChainableControllerInterface,
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from .manager.controller_manager import BEST_EFFORT, STRICT, ControllerManager
from .manager.resource_manager import ResourceError, ResourceManager
from .pluginlib import plugin, register

__all__ = [
    "ACTIVE", "BEST_EFFORT", "FINALIZED", "INACTIVE", "STRICT", "UNCONFIGURED", "UNKNOWN",
    "ActuatorInterface", "CallbackReturn", "ChainableControllerInterface", "ControllerInterface",
    "ControllerManager", "HardwareComponentInterface", "HardwareInfo", "InterfaceConfiguration",
    "ResourceError", "ResourceManager", "SensorInterface", "State", "SystemInterface", "URDFError",
    "interface_configuration_type", "introspection", "parse_control_resources_from_urdf", "plugin", "register",
    "return_type",
]
