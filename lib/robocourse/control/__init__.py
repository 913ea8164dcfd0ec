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

from __future__ import annotations

import importlib

from .pluginlib import plugin, register

#: the package's names, imported on first use (PEP 562): a process that needs one corner of it
#: (a box process importing ``robocourse.drivers``, which declares its plugins with ``pluginlib``)
#: does not pay for the manager, the bus and the messages (about a second of start-up)
_LAZY = {
    **dict.fromkeys(("ActuatorInterface", "HardwareComponentInterface", "SensorInterface", "SystemInterface"),
                    ".hardware.component"),
    **dict.fromkeys(("HardwareInfo", "URDFError", "parse_control_resources_from_urdf"), ".hardware.info"),
    **dict.fromkeys(("ACTIVE", "FINALIZED", "INACTIVE", "UNCONFIGURED", "UNKNOWN", "CallbackReturn", "State",
                     "return_type"), ".hardware.types"),
    **dict.fromkeys(("ChainableControllerInterface", "ControllerInterface", "InterfaceConfiguration",
                     "interface_configuration_type"), ".manager.controller_interface"),
    **dict.fromkeys(("BEST_EFFORT", "STRICT", "ControllerManager"), ".manager.controller_manager"),
    **dict.fromkeys(("ResourceError", "ResourceManager"), ".manager.resource_manager"),
}


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    else:
        try:     # a submodule: ``robocourse.control.introspection`` (``ros2 control`` verbs)
            value = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *_LAZY})


__all__ = [
    "ACTIVE", "BEST_EFFORT", "FINALIZED", "INACTIVE", "STRICT", "UNCONFIGURED", "UNKNOWN",
    "ActuatorInterface", "CallbackReturn", "ChainableControllerInterface", "ControllerInterface",
    "ControllerManager", "HardwareComponentInterface", "HardwareInfo", "InterfaceConfiguration",
    "ResourceError", "ResourceManager", "SensorInterface", "State", "SystemInterface", "URDFError",
    "interface_configuration_type", "introspection", "parse_control_resources_from_urdf", "plugin", "register",
    "return_type",
]
