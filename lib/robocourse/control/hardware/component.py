"""Hardware components: what a student subclasses to drive a robot, and the lifecycle around it.

Counterparts: ``hardware_interface::SystemInterface`` / ``ActuatorInterface`` /
``SensorInterface`` (what you subclass) and ``hardware_interface::System`` / ``Actuator`` /
``Sensor`` (the wrapper that owns the lifecycle state; here :class:`HardwareComponent`).

A component declares its interfaces in the URDF; the resource manager allocates one float64
slot per interface and hands the component numpy views: ``self.state_values`` /
``self.command_values`` with ``self.state_index["joint1/position"]`` giving the slot.
``set_state(name, v)`` / ``get_command(name)`` are the upstream (jazzy+) convenience calls;
the arrays are the allocation-free path for read()/write() at 1 kHz.

Lifecycle (rclcpp_lifecycle rules, as the wrapper applies them):
UNCONFIGURED -configure-> INACTIVE -activate-> ACTIVE; a callback returning FAILURE leaves the
state where it was; ERROR runs on_error: SUCCESS -> UNCONFIGURED, FAILURE/ERROR -> FINALIZED
(unrecoverable). read() runs in INACTIVE and ACTIVE, write() only in ACTIVE.
"""

from __future__ import annotations

import math

import numpy as np

from ..lifecycle import Lifecycle, LifecycleCallbacks
from .info import HardwareInfo
from .types import UNKNOWN, CallbackReturn, State, return_type


class InterfaceDescription:
    """One exported interface: ``prefix/interface`` with its initial value."""

    __slots__ = ("prefix_name", "interface_name", "initial_value", "data_type")

    def __init__(self, prefix_name: str, interface_name: str, initial_value: float = math.nan,
                 data_type: str = "double"):
        self.prefix_name = prefix_name
        self.interface_name = interface_name
        self.initial_value = initial_value
        self.data_type = data_type

    @property
    def name(self) -> str:
        return f"{self.prefix_name}/{self.interface_name}"

    def __repr__(self) -> str:
        return f"InterfaceDescription({self.name!r})"


class HardwareComponentInterface(LifecycleCallbacks):
    """Base of the three kinds: the callbacks a student overrides.

    Override ``on_init(info)`` (call ``super().on_init(info)`` first), ``on_configure``,
    ``on_activate``, ``on_deactivate``, ``on_cleanup``, ``on_shutdown``, ``on_error`` (each takes
    the previous :class:`State` and returns a :class:`CallbackReturn`), ``read(time, period)``
    and, for systems and actuators, ``write(time, period)`` returning a :class:`return_type`.
    ``time`` is seconds (float), ``period`` seconds since the previous call.
    """

    #: "system" / "actuator" / "sensor" (the URDF type this class accepts).
    kind = "system"
    #: Interface names this plugin can serve, or None for any (GenericSystem accepts any).
    SUPPORTED_COMMAND_INTERFACES: tuple[str, ...] | None = None
    SUPPORTED_STATE_INTERFACES: tuple[str, ...] | None = None

    def __init__(self):
        self.info: HardwareInfo | None = None
        self.state_values = np.zeros(0)
        self.command_values = np.zeros(0)
        self.state_index: dict[str, int] = {}
        self.command_index: dict[str, int] = {}
        self._lifecycle_state = UNKNOWN
        self._logger = None

    # --- lifecycle callbacks (override; on_configure .. on_error default to SUCCESS) ---------------
    def on_init(self, info: HardwareInfo) -> CallbackReturn:
        self.info = info
        return CallbackReturn.SUCCESS

    # --- interfaces ---------------------------------------------------------------------------
    def export_state_interfaces(self) -> list[InterfaceDescription]:
        """Every ``<state_interface>`` of the joints, sensors and gpios (override to add more)."""
        out = []
        for comp in self.info.joints + self.info.sensors + self.info.gpios:
            for itf in comp.state_interfaces:
                out.append(InterfaceDescription(comp.name, itf.name, itf.initial(), itf.data_type))
        return out

    def export_command_interfaces(self) -> list[InterfaceDescription]:
        """Every ``<command_interface>`` of the joints and gpios (override to add more)."""
        out = []
        for comp in self.info.joints + self.info.gpios:
            for itf in comp.command_interfaces:
                out.append(InterfaceDescription(comp.name, itf.name, itf.initial(), itf.data_type))
        return out

    def prepare_command_mode_switch(self, start_interfaces: list[str], stop_interfaces: list[str]) -> return_type:
        """Non-real-time check before controllers start/stop using these command interfaces."""
        return return_type.OK

    def perform_command_mode_switch(self, start_interfaces: list[str], stop_interfaces: list[str]) -> return_type:
        """Real-time switch, called in the loop right before the controllers change."""
        return return_type.OK

    # --- the cyclic part (override) -------------------------------------------------------------
    def read(self, time: float, period: float) -> return_type:
        raise NotImplementedError(f"{type(self).__name__} must implement read(time, period)")

    def write(self, time: float, period: float) -> return_type:
        raise NotImplementedError(f"{type(self).__name__} must implement write(time, period)")

    # --- value access (jazzy+ names) ------------------------------------------------------------
    def get_state(self, name: str) -> float:
        return float(self.state_values[self.state_index[name]])

    def set_state(self, name: str, value: float) -> None:
        self.state_values[self.state_index[name]] = value

    def get_command(self, name: str) -> float:
        return float(self.command_values[self.command_index[name]])

    def set_command(self, name: str, value: float) -> None:
        self.command_values[self.command_index[name]] = value

    def get_name(self) -> str:
        return self.info.name if self.info else type(self).__name__

    def get_logger(self):
        """This component's logger (the resource manager's sink, named after the component)."""
        if self._logger is None:
            from ..log import LogSink

            self._logger = LogSink().logger(self.get_name())
        return self._logger

    def get_lifecycle_state(self) -> State:
        return self._lifecycle_state


class SystemInterface(HardwareComponentInterface):
    """Many joints on one channel (hardware_interface::SystemInterface)."""

    kind = "system"


class ActuatorInterface(HardwareComponentInterface):
    """One joint with its own channel (hardware_interface::ActuatorInterface)."""

    kind = "actuator"


class SensorInterface(HardwareComponentInterface):
    """Read-only (hardware_interface::SensorInterface): no command interfaces; write() is OK."""

    kind = "sensor"

    def export_command_interfaces(self) -> list[InterfaceDescription]:
        return []

    def write(self, time: float, period: float) -> return_type:
        return return_type.OK


class HardwareComponent(Lifecycle):
    """The lifecycle wrapper around one component (hardware_interface::System/Actuator/Sensor).

    Each transition method runs the matching callback and applies its consequence
    (:class:`robocourse.control.lifecycle.Lifecycle`); ``initialize()`` calls ``on_init(info)``.
    """

    def __init__(self, impl: HardwareComponentInterface, info: HardwareInfo):
        super().__init__(impl)
        self.info = info

    @property
    def name(self) -> str:
        return self.info.name

    def initialize(self) -> State:
        return super().initialize(self.info)
