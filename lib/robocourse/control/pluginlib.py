"""Plugins by name, like pluginlib's ``ClassLoader``: hardware components and controllers.

Counterpart: ``pluginlib::ClassLoader<Base>::createSharedInstance("pkg/Class")`` with the
classes declared in a plugin description XML. Here a class is declared with
:func:`register` (a student's class too: ``register("my_robot/MyArm", MyArm)`` or the
``@plugin("my_robot/MyArm")`` decorator); built-in ones are declared lazily as
``"module:Class"`` strings so importing the registry imports no chapter code.
An unknown name gets pluginlib's message listing the declared types.
"""

from __future__ import annotations

import importlib

HARDWARE_BASE = "hardware_interface::SystemInterface"
CONTROLLER_BASE = "controller_interface::ControllerInterface"

_DECLARED: dict[str, dict[str, object]] = {HARDWARE_BASE: {}, CONTROLLER_BASE: {}}


class PluginlibException(LookupError):
    """pluginlib::LibraryLoadException / CreateClassException."""


def _base_for(cls) -> str:
    from .hardware.component import HardwareComponentInterface

    return HARDWARE_BASE if issubclass(cls, HardwareComponentInterface) else CONTROLLER_BASE


def register(name: str, cls, base: str | None = None) -> None:
    """Declare ``cls`` under ``name`` ("package/Class"). Re-registering a name replaces it."""
    if not isinstance(name, str) or "/" not in name:
        raise ValueError(f"plugin name {name!r} must look like 'package/ClassName' "
                         "(e.g. 'my_robot/MyArm')")
    if isinstance(cls, str):
        if base is None:
            raise ValueError("a lazily declared plugin ('module:Class') needs its base")
    else:
        from .hardware.component import HardwareComponentInterface
        from .manager.controller_interface import ControllerInterface

        if not isinstance(cls, type) or not issubclass(cls, (HardwareComponentInterface, ControllerInterface)):
            raise ValueError(f"plugin {name!r} must be a SystemInterface/ActuatorInterface/SensorInterface "
                             f"or ControllerInterface subclass, got {cls!r}")
        base = base or _base_for(cls)
    _DECLARED[base][name] = cls


def plugin(name: str):
    """Class decorator form of :func:`register`."""
    def deco(cls):
        register(name, cls)
        return cls
    return deco


def declared(base: str) -> list[str]:
    return sorted(_DECLARED[base])


def load(name: str, base: str, base_label: str | None = None) -> type:
    """The class declared as ``name`` for ``base``, or pluginlib's error (naming ``base_label`` if given)."""
    entry = _DECLARED[base].get(name)
    if entry is None:
        raise PluginlibException(
            f"According to the loaded plugin descriptions the class {name} with base class type "
            f"{base_label or base} does not exist. Declared types are  {' '.join(declared(base))}")
    if isinstance(entry, str):
        module, _, attr = entry.partition(":")
        entry = getattr(importlib.import_module(module), attr)
        _DECLARED[base][name] = entry
    return entry


def _builtins() -> None:
    hw = "robocourse.control.hardware."
    register("mock_components/GenericSystem", hw + "mock_components:GenericSystem", HARDWARE_BASE)
    register("robocourse/MujocoSystem", hw + "mujoco_system:MujocoSystem", HARDWARE_BASE)
    register("robocourse/RRBotModularJoint", hw + "modular:RRBotModularJoint", HARDWARE_BASE)
    register("robocourse/ForceTorqueSensor", hw + "modular:ForceTorqueSensor", HARDWARE_BASE)
    c = "robocourse.control.controllers."
    fcc = c + "forward_command_controller:"
    register("forward_command_controller/ForwardCommandController", fcc + "ForwardCommandController", CONTROLLER_BASE)
    register("forward_command_controller/MultiInterfaceForwardCommandController",
             fcc + "MultiInterfaceForwardCommandController", CONTROLLER_BASE)
    register("position_controllers/JointGroupPositionController", fcc + "JointGroupPositionController",
             CONTROLLER_BASE)
    register("velocity_controllers/JointGroupVelocityController", fcc + "JointGroupVelocityController",
             CONTROLLER_BASE)
    register("effort_controllers/JointGroupEffortController", fcc + "JointGroupEffortController", CONTROLLER_BASE)
    register("joint_state_broadcaster/JointStateBroadcaster",
             c + "joint_state_broadcaster:JointStateBroadcaster", CONTROLLER_BASE)
    register("joint_trajectory_controller/JointTrajectoryController",
             c + "joint_trajectory_controller:JointTrajectoryController", CONTROLLER_BASE)
    register("parallel_gripper_action_controller/GripperActionController",
             c + "parallel_gripper_controller:ParallelGripperController", CONTROLLER_BASE)
    register("diff_drive_controller/DiffDriveController", c + "diff_drive_controller:DiffDriveController",
             CONTROLLER_BASE)
    register("pid_controller/PidController", c + "pid_controller:PidController", CONTROLLER_BASE)
    register("admittance_controller/AdmittanceController", c + "admittance_controller:AdmittanceController",
             CONTROLLER_BASE)


_builtins()
