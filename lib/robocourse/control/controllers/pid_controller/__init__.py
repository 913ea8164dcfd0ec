"""PidController (ros2_controllers' pid_controller), chainable.

Counterpart: ``pid_controller::PidController``. One PID per DOF (``gains.<dof>.p/i/d/i_clamp``)
on the error ``reference - state`` (``angle_wraparound``: the shortest angular distance in
[-pi, pi]); with ``reference_and_state_interfaces: [position, velocity]`` the derivative term
uses ``reference_dot - state_dot``, otherwise the error's change since the last update. The
command is ``feedforward_gain * reference + PID`` on ``<dof>/<command_interface>``.
References are exported as ``<controller>/<dof>/<interface>`` for a preceding controller (chained
mode) or come from ``~/reference`` (control_msgs/MultiDOFCommand: values, values_dot) when not
chained; a DOF whose reference or state is NaN gets no new command. ``~/controller_state``
publishes control_msgs/MultiDOFStateStamped.

Differences: no ``use_external_measured_states`` topic, no exported state interfaces, no
``~/set_feedforward_control`` service (feed-forward is the gain, as newest upstream); the
integral clamp is symmetric (control_toolbox has separate min/max and anti-windup modes).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ChainableControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...manager.loaned import InterfaceGroup
from ...msgs import MultiDOFCommand, MultiDOFStateStamped, SingleDOFState
from ...parameters import ParameterSchema
from ..control_toolbox import Pid

_HERE = Path(__file__).parent


class PidController(ChainableControllerInterface):
    """``pid_controller/PidController``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("parameters.yaml").read_text())

    def __init__(self):
        super().__init__()
        self._ref_msg = None
        self._state_pub = None

    def _prefixes(self) -> list[str]:
        p = self.params
        return list(p.reference_and_state_dof_names) or list(p.dof_names)

    def on_configure(self, previous_state):
        p = self.params
        self.dof = len(p.dof_names)
        if len(self._prefixes()) != self.dof:
            self.get_logger().error(f"'reference_and_state_dof_names' ({len(self._prefixes())}) must name as many "
                                    f"DOFs as 'dof_names' ({self.dof}) or be empty")
            return CallbackReturn.ERROR
        self.pid = Pid(*self._gains())
        self._wrap = np.array([p.gains.get_entry(d).angle_wraparound for d in p.dof_names], dtype=bool)
        self._ff = np.array([p.gains.get_entry(d).feedforward_gain for d in p.dof_names])
        n = self.dof * len(p.reference_and_state_interfaces)
        self.measured = np.zeros(n)
        self.error = np.zeros(self.dof)
        self.command = np.zeros(self.dof)
        if self._node is None:
            node = self.get_node()
            node.create_subscription(MultiDOFCommand, "~/reference", self._on_reference, 10)
            self._state_pub = node.create_publisher(MultiDOFStateStamped, "~/controller_state", 10)
        return CallbackReturn.SUCCESS

    def _gains(self):
        g = [self.params.gains.get_entry(d) for d in self.params.dof_names]
        return [x.p for x in g], [x.i for x in g], [x.d for x in g], [x.i_clamp for x in g]

    def _on_reference(self, msg) -> None:
        names = list(self.params.dof_names)
        if list(msg.dof_names) and list(msg.dof_names) != names:
            self.get_logger().error(f"reference dof_names {list(msg.dof_names)} do not match {names}")
            return
        if len(msg.values) != self.dof or (len(msg.values_dot) not in (0, self.dof)):
            self.get_logger().error(f"reference needs {self.dof} values (and 0 or {self.dof} values_dot), got "
                                    f"{len(msg.values)} and {len(msg.values_dot)}")
            return
        self._ref_msg = msg

    def command_interface_configuration(self):
        p = self.params
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{d}/{p.command_interface}" for d in p.dof_names])

    def state_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{d}/{i}" for i in self.params.reference_and_state_interfaces
                                       for d in self._prefixes()])

    def on_export_reference_interfaces(self):
        return [f"{d}/{i}" for i in self.params.reference_and_state_interfaces for d in self.params.dof_names]

    def on_activate(self, previous_state):
        self._cmd = InterfaceGroup(self.command_interfaces)
        self._states = InterfaceGroup(self.state_interfaces)
        self.reference_interfaces[:] = np.nan
        self._ref_msg = None
        self.pid.reset()
        return CallbackReturn.SUCCESS

    def update_reference_from_subscribers(self, time, period):
        msg = self._ref_msg
        if msg is not None:
            self.reference_interfaces[:self.dof] = msg.values
            if len(self.reference_interfaces) == 2 * self.dof and len(msg.values_dot) == self.dof:
                self.reference_interfaces[self.dof:] = msg.values_dot
        return return_type.OK

    def update_and_write_commands(self, time, period):
        if self.param_listener.try_update_params(self.params):
            self.pid.set_gains(*self._gains())
            self._ff[:] = [self.params.gains.get_entry(d).feedforward_gain for d in self.params.dof_names]
        dof, ref, meas = self.dof, self.reference_interfaces, self.measured
        self._states.get(out=meas)
        np.subtract(ref[:dof], meas[:dof], out=self.error)
        if self._wrap.any():
            wrapped = np.remainder(self.error + math.pi, 2.0 * math.pi) - math.pi
            np.copyto(self.error, wrapped, where=self._wrap)
        valid = np.isfinite(self.error)
        if len(ref) == 2 * dof:
            error_dot = ref[dof:] - meas[dof:]
            valid &= np.isfinite(error_dot)
            out = self.pid.compute_command(np.where(valid, self.error, 0.0), np.where(valid, error_dot, 0.0), period)
        else:
            out = self.pid.compute_command_from_error(np.where(valid, self.error, 0.0), period)
        np.add(out, self._ff * np.where(valid, ref[:dof], 0.0), out=self.command)
        if valid.all():
            self._cmd.set(self.command)
        else:
            for k in np.flatnonzero(valid):
                self.command_interfaces[k].set_value(self.command[k])
        pub = self._state_pub
        if pub is not None and pub.get_subscription_count():
            self._publish_state(time, period)
        return return_type.OK

    def _publish_state(self, time: float, period: float) -> None:
        dof, ref, meas = self.dof, self.reference_interfaces, self.measured
        two = len(ref) == 2 * dof
        msg = MultiDOFStateStamped(dof_states=[
            SingleDOFState(name=name, reference=float(ref[k]), feedback=float(meas[k]),
                           feedback_dot=float(meas[dof + k]) if two else 0.0, error=float(self.error[k]),
                           error_dot=float(ref[dof + k] - meas[dof + k]) if two else 0.0, time_step=period,
                           output=float(self.command[k]))
            for k, name in enumerate(self.params.dof_names)])
        ns = int(round(time * 1e9))
        msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
        self._state_pub.publish(msg)


__all__ = ["PidController"]
