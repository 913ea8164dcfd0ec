"""What a controller is: ControllerInterface and ChainableControllerInterface.

Counterparts: ``controller_interface::ControllerInterface`` and
``controller_interface::ChainableControllerInterface`` (ros2_control:controller_interface/).
A controller declares which interfaces it needs (``command_interface_configuration()`` /
``state_interface_configuration()`` with ALL / INDIVIDUAL / NONE), receives loans in
``self.command_interfaces`` / ``self.state_interfaces`` (in the configured order) when the
manager activates it, and computes in ``update(time, period)``.

Parameters: a controller class sets ``PARAMS`` to a :class:`~robocourse.control.parameters.
ParameterSchema`; the manager validates the controller's ``ros__parameters`` against it when
loading (a bad value fails the load with upstream's message) and ``self.params`` holds the
result. ``update_rate`` (int Hz, 0 = the manager's rate) is read like upstream's per-controller
``update_rate`` parameter.

A chainable controller exports reference interfaces ``<controller>/<name>`` (values in
``self.reference_interfaces``, a numpy array the preceding controller writes through its loan)
and optionally state interfaces (``self.exported_state_interfaces``). In chained mode its
``update()`` skips ``update_reference_from_subscribers()``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from ..hardware.types import UNKNOWN, CallbackReturn, State, return_type
from ..lifecycle import LifecycleCallbacks
from ..parameters import ParameterSchema, ParamListener


class interface_configuration_type(IntEnum):  # noqa: N801  (upstream spelling)
    ALL = 0
    INDIVIDUAL = 1
    NONE = 2


@dataclass
class InterfaceConfiguration:
    """``controller_interface::InterfaceConfiguration{type, names}``."""

    type: interface_configuration_type = interface_configuration_type.NONE
    names: list[str] = field(default_factory=list)


class ControllerInterface(LifecycleCallbacks):
    """Subclass and override the callbacks; the manager calls them (never call them yourself)."""

    #: generate_parameter_library-style schema of this controller's parameters (or None).
    PARAMS: ParameterSchema | None = None

    def __init__(self):
        self.command_interfaces: list = []
        self.state_interfaces: list = []
        self.name = ""
        self.params = None
        self.param_listener: ParamListener | None = None
        self.update_rate = 0
        self.is_async = False
        #: URDF joint limits by joint name (JointLimits), filled by the manager at load (upstream
        #: controllers read them from robot_description)
        self.joint_limits: dict = {}
        self._lifecycle_state: State = UNKNOWN
        self._node = None
        self._node_factory = None
        self._logger = None

    # --- called by the manager --------------------------------------------------------------------
    def init(self, name: str, parameters: dict, cm_update_rate: int, node_factory=None, logger=None) -> CallbackReturn:
        """controller_interface::ControllerInterfaceBase::init: parameters, then on_init()."""
        self.name = name
        self._node_factory = node_factory
        self._logger = logger
        rate = parameters.get("update_rate", 0)
        if isinstance(rate, bool) or not isinstance(rate, int) or rate < 0:
            raise ValueError(f"update_rate of controller '{name}' must be an int >= 0 (Hz, 0 = the manager's "
                             f"{cm_update_rate} Hz), got {rate!r}")
        self.update_rate = rate if rate else cm_update_rate
        if parameters.get("is_async", False):
            raise ValueError(f"is_async: true for controller '{name}' is not supported by robocourse (every controller "
                             "runs in the manager's loop); remove the parameter")
        if self.PARAMS is not None:
            own = {k: v for k, v in parameters.items() if k not in ("update_rate", "is_async", "type")}
            self.param_listener = ParamListener(self.PARAMS, own)
            self.params = self.param_listener.get_params()
            self.unused_parameters = self.param_listener.unused
        return self.on_init()

    def assign_interfaces(self, command_interfaces, state_interfaces) -> None:
        self.command_interfaces = list(command_interfaces)
        self.state_interfaces = list(state_interfaces)

    def release_interfaces(self) -> None:
        for loan in self.command_interfaces:
            loan.release()
        self.command_interfaces = []
        self.state_interfaces = []

    # --- override these ---------------------------------------------------------------------------
    def on_init(self) -> CallbackReturn:
        return CallbackReturn.SUCCESS

    def command_interface_configuration(self) -> InterfaceConfiguration:
        raise NotImplementedError(f"{type(self).__name__} must say which command interfaces it needs")

    def state_interface_configuration(self) -> InterfaceConfiguration:
        raise NotImplementedError(f"{type(self).__name__} must say which state interfaces it needs")

    def update(self, time: float, period: float) -> return_type:
        raise NotImplementedError(f"{type(self).__name__} must implement update(time, period)")

    # --- helpers ------------------------------------------------------------------------------------
    def is_chainable(self) -> bool:
        return False

    def get_node(self):
        """The controller's bus node (created on first use, named after the controller)."""
        if self._node is None:
            if self._node_factory is None:
                raise RuntimeError(f"controller '{self.name}' has no node yet: the manager creates it when "
                                   "it loads the controller")
            self._node = self._node_factory(self.name)
        return self._node

    def get_logger(self):
        if self._logger is None:
            from ..log import LogSink

            self._logger = LogSink().logger(self.name or type(self).__name__)
        return self._logger

    def get_lifecycle_state(self) -> State:
        return self._lifecycle_state

    def get_update_rate(self) -> int:
        return self.update_rate


class ChainableControllerInterface(ControllerInterface):
    """A controller whose inputs other controllers can write (reference interfaces)."""

    def __init__(self):
        super().__init__()
        self.reference_interface_names: list[str] = []
        self.reference_interfaces = np.zeros(0)
        self.exported_state_interface_names: list[str] = []
        self.exported_state_interfaces = np.zeros(0)
        self._chained = False

    def is_chainable(self) -> bool:
        return True

    # --- override these ---------------------------------------------------------------------------
    def on_export_reference_interfaces(self) -> list[str]:
        """Names (without the controller prefix) of the reference interfaces, e.g. ``joint1/position``."""
        return []

    def on_export_state_interfaces(self) -> list[str]:
        return []

    def on_set_chained_mode(self, chained_mode: bool) -> bool:
        return True

    def update_reference_from_subscribers(self, time: float, period: float) -> return_type:
        raise NotImplementedError(f"{type(self).__name__} must implement update_reference_from_subscribers")

    def update_and_write_commands(self, time: float, period: float) -> return_type:
        raise NotImplementedError(f"{type(self).__name__} must implement update_and_write_commands")

    # --- framework ----------------------------------------------------------------------------------
    def export_reference_interfaces(self) -> list[str]:
        """Full names ``<controller>/<name>``; values start as NaN (upstream)."""
        local = list(self.on_export_reference_interfaces())
        self.reference_interface_names = [f"{self.name}/{n}" for n in local]
        self.reference_interfaces = np.full(len(local), np.nan)
        return self.reference_interface_names

    def export_state_interfaces(self) -> list[str]:
        local = list(self.on_export_state_interfaces())
        self.exported_state_interface_names = [f"{self.name}/{n}" for n in local]
        self.exported_state_interfaces = np.full(len(local), np.nan)
        return self.exported_state_interface_names

    def set_chained_mode(self, chained_mode: bool) -> bool:
        if self.on_set_chained_mode(chained_mode):
            self._chained = chained_mode
            return True
        return False

    def is_in_chained_mode(self) -> bool:
        return self._chained

    def update(self, time: float, period: float) -> return_type:
        if not self._chained:
            ret = self.update_reference_from_subscribers(time, period)
            if ret != return_type.OK:
                return ret
        return self.update_and_write_commands(time, period)
