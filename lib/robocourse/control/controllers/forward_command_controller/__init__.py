"""ForwardCommandController and its fixed-interface variants (ros2_controllers).

Counterparts: ``forward_command_controller::ForwardCommandController`` /
``MultiInterfaceForwardCommandController`` (both on ``ForwardControllersBase``) and
``position_controllers`` / ``velocity_controllers`` / ``effort_controllers::JointGroup*Controller``.
The controller subscribes ``~/commands`` (std_msgs/Float64MultiArray); a message with a
non-finite value is dropped in the subscription callback (logged once per burst); update()
writes the latest command to the claimed interfaces, and returns ERROR when its size does not
match them. Before the first message nothing is written. The effort variant writes 0.0 on
deactivation (upstream's JointGroupEffortController does, so a motor does not keep pushing).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robocourse.msgs.std_msgs import Float64MultiArray

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...manager.loaned import InterfaceGroup
from ...parameters import ParameterSchema

_HERE = Path(__file__).parent


class ForwardControllersBase(ControllerInterface):
    """forward_command_controller::ForwardControllersBase: ``~/commands`` -> command interfaces."""

    def __init__(self):
        super().__init__()
        self.command_interface_names: list[str] = []
        self._command = None          # the real-time buffer: the newest valid command (numpy array)
        self._group: InterfaceGroup | None = None
        self.dropped_non_finite = 0
        self._warned_size = False

    def declare_command_interfaces(self) -> CallbackReturn:
        """Fill ``self.command_interface_names`` from the parameters (subclasses)."""
        raise NotImplementedError

    def on_configure(self, previous_state):
        ret = self.declare_command_interfaces()
        if ret != CallbackReturn.SUCCESS:
            return ret
        if self._node is None:
            self.get_node().create_subscription(Float64MultiArray, "~/commands", self._on_commands, 10)
        return CallbackReturn.SUCCESS

    def _on_commands(self, msg) -> None:
        data = msg.data
        if not all(math.isfinite(v) for v in data):
            self.dropped_non_finite += 1
            if self.dropped_non_finite == 1:
                self.get_logger().warning(f"'{self.name}': command with a non-finite value dropped: {list(data)}")
            return
        self._command = np.array(data, dtype=float)

    def command_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL, list(self.command_interface_names))

    def state_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.NONE)

    def on_activate(self, previous_state):
        if len(self.command_interfaces) != len(self.command_interface_names):
            self.get_logger().error(f"Expected {len(self.command_interface_names)} command interfaces, got "
                                    f"{len(self.command_interfaces)}")
            return CallbackReturn.ERROR
        self._group = InterfaceGroup(self.command_interfaces)
        self._command = None
        self._warned_size = False
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state):
        self._command = None
        self._group = None
        return CallbackReturn.SUCCESS

    def set_command(self, values) -> None:
        """Same as receiving a ``~/commands`` message (for notebooks that skip the bus)."""
        self._on_commands(Float64MultiArray(data=[float(v) for v in values]))

    def update(self, time, period):
        cmd = self._command
        if cmd is None:
            return return_type.OK
        if len(cmd) != len(self._group):
            if not self._warned_size:
                self._warned_size = True
                self.get_logger().error(f"command size ({len(cmd)}) does not match number of interfaces "
                                        f"({len(self._group)})")
            return return_type.ERROR
        self._group.set(cmd)
        return return_type.OK


class ForwardCommandController(ForwardControllersBase):
    """Parameters ``joints`` and ``interface_name``; commands ``<joint>/<interface_name>``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("parameters.yaml").read_text())

    def declare_command_interfaces(self):
        p = self.params
        if not p.joints:
            self.get_logger().error("'joints' parameter was empty")
            return CallbackReturn.ERROR
        if not p.interface_name:
            self.get_logger().error("'interface_name' parameter was empty")
            return CallbackReturn.ERROR
        self.command_interface_names = [f"{j}/{p.interface_name}" for j in p.joints]
        return CallbackReturn.SUCCESS


class MultiInterfaceForwardCommandController(ForwardControllersBase):
    """Parameters ``joint`` and ``interface_names``; commands ``<joint>/<each interface>``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("multi_interface_parameters.yaml").read_text())

    def declare_command_interfaces(self):
        p = self.params
        if not p.joint:
            self.get_logger().error("'joint' parameter is empty")
            return CallbackReturn.ERROR
        if not p.interface_names:
            self.get_logger().error("'interfaces' parameter is empty")
            return CallbackReturn.ERROR
        self.command_interface_names = [f"{p.joint}/{i}" for i in p.interface_names]
        return CallbackReturn.SUCCESS


class _JointGroupController(ForwardControllersBase):
    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("joint_group_parameters.yaml").read_text())
    INTERFACE = ""

    def declare_command_interfaces(self):
        if not self.params.joints:
            self.get_logger().error("'joints' parameter was empty")
            return CallbackReturn.ERROR
        self.command_interface_names = [f"{j}/{self.INTERFACE}" for j in self.params.joints]
        return CallbackReturn.SUCCESS


class JointGroupPositionController(_JointGroupController):
    """position_controllers::JointGroupPositionController (interface ``position``)."""

    INTERFACE = "position"


class JointGroupVelocityController(_JointGroupController):
    """velocity_controllers::JointGroupVelocityController (interface ``velocity``)."""

    INTERFACE = "velocity"


class JointGroupEffortController(_JointGroupController):
    """effort_controllers::JointGroupEffortController (interface ``effort``; zero on deactivate)."""

    INTERFACE = "effort"

    def on_deactivate(self, previous_state):
        for loan in self.command_interfaces:
            loan.set_value(0.0)
        return super().on_deactivate(previous_state)


__all__ = ["ForwardCommandController", "ForwardControllersBase", "JointGroupEffortController",
           "JointGroupPositionController", "JointGroupVelocityController", "MultiInterfaceForwardCommandController"]
