"""JointStateBroadcaster: state interfaces -> /joint_states and /dynamic_joint_states.

Counterpart: ``joint_state_broadcaster::JointStateBroadcaster`` (ros2_controllers). Rules kept:

- ``joints`` and ``interfaces`` both empty: every available state interface (ALL), joints in
  the resource manager's sorted order; both set: INDIVIDUAL ``joint/interface`` in the order of
  ``joints``; only one of them set is refused at configure (upstream warns and uses ALL);
- a joint goes into JointState when it has a position, velocity or effort interface (after
  ``map_interface_to_joint_state``); a missing one of the three is published as NaN;
  every interface (joints and sensors) goes into DynamicJointState;
- ``extra_joints`` are appended with 0.0; ``use_local_topics`` publishes under ``~/``;
  ``header.stamp`` is the update time, ``frame_id`` from the parameter.

Differs: /dynamic_joint_states is built only while it has a subscriber (upstream always
publishes it; building it costs tens of microseconds in Python).

Not implemented: ``use_urdf_to_filter`` (upstream drops joints not in robot_description).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robocourse.msgs.sensor_msgs import JointState

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...msgs import DynamicJointState, InterfaceValue
from ...parameters import ParameterSchema

_FIELDS = ("position", "velocity", "effort")


class JointStateBroadcaster(ControllerInterface):
    """Publishes every claimed state interface; see the module docstring for the rules."""

    PARAMS = ParameterSchema.from_yaml(Path(__file__).with_name("parameters.yaml").read_text())

    def __init__(self):
        super().__init__()
        self.joint_names: list[str] = []
        self.published = 0

    def _use_all(self) -> bool:
        return not self.params.joints and not self.params.interfaces

    def on_configure(self, previous_state):
        p = self.params
        if bool(p.joints) != bool(p.interfaces):
            self.get_logger().error("'joints' and 'interfaces' parameters have to be both specified or both empty "
                                    f"(got joints={p.joints}, interfaces={p.interfaces})")
            return CallbackReturn.ERROR
        if self._node is None:
            node = self.get_node()
            prefix = "~/" if p.use_local_topics else "/"
            self.joint_state_publisher = node.create_publisher(JointState, prefix + "joint_states", 10)
            self.dynamic_publisher = node.create_publisher(DynamicJointState, prefix + "dynamic_joint_states", 10)
        return CallbackReturn.SUCCESS

    def command_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.NONE)

    def state_interface_configuration(self):
        if self._use_all():
            return InterfaceConfiguration(interface_configuration_type.ALL)
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{j}/{i}" for j in self.params.joints for i in self.params.interfaces])

    def on_activate(self, previous_state):
        mapping = self.params.map_interface_to_joint_state
        rename = {getattr(mapping, f): f for f in reversed(_FIELDS)}   # position wins, then velocity
        loans = self.state_interfaces
        if self._use_all():
            loans = sorted(loans, key=lambda loan: loan.name)
        order: list[str] = []
        per: dict[str, dict[str, object]] = {}
        for loan in loans:
            prefix, itf = loan.get_prefix_name(), loan.get_interface_name()
            if prefix not in per:
                per[prefix] = {}
                order.append(prefix)
            per[prefix][itf] = loan
        self.joint_names = [j for j in order if any(i in rename for i in per[j])]
        n = len(self.joint_names)
        # one gather index per field: slot k of the state array, or -1 for "publish NaN"
        self._arrays = {id(loan.array): loan.array for loan in loans}
        self._gather = []
        for f in _FIELDS:
            src = []
            for j in self.joint_names:
                loan = next((per[j][i] for i in per[j] if rename.get(i) == f), None)
                src.append(loan)
            self._gather.append(src)
        self._single = len(self._arrays) == 1 and all(loan is not None for src in self._gather for loan in src)
        if self._single:
            self._array = next(iter(self._arrays.values()))
            self._idx = [np.array([loan.index for loan in src], dtype=np.intp) for src in self._gather]
        self._buf = [np.full(n, math.nan) for _ in _FIELDS]
        self._dyn_joints = order
        self._dyn = [(list(per[j]), list(per[j].values())) for j in order]
        self._extra = list(self.params.extra_joints)
        return CallbackReturn.SUCCESS

    def _collect(self) -> None:
        if self._single:
            for k in range(3):
                np.take(self._array, self._idx[k], out=self._buf[k])
            return
        for k in range(3):
            buf = self._buf[k]
            for i, loan in enumerate(self._gather[k]):
                buf[i] = loan.array[loan.index] if loan is not None else math.nan

    def update(self, time, period):
        self._collect()
        sec = int(time)
        stamp_ns = int(round((time - sec) * 1e9))
        extra = self._extra
        msg = JointState(name=self.joint_names + extra,
                         position=self._buf[0].tolist() + [0.0] * len(extra),
                         velocity=self._buf[1].tolist() + [0.0] * len(extra),
                         effort=self._buf[2].tolist() + [0.0] * len(extra))
        msg.header.stamp.sec, msg.header.stamp.nanosec = sec, stamp_ns
        msg.header.frame_id = self.params.frame_id
        self.joint_state_publisher.publish(msg)
        if self.dynamic_publisher.get_subscription_count():
            dyn = DynamicJointState(joint_names=list(self._dyn_joints), interface_values=[
                InterfaceValue(interface_names=list(names), values=[float(loan.array[loan.index]) for loan in loans])
                for names, loans in self._dyn])
            dyn.header.stamp.sec, dyn.header.stamp.nanosec = sec, stamp_ns
            dyn.header.frame_id = self.params.frame_id
            self.dynamic_publisher.publish(dyn)
        self.published += 1
        return return_type.OK


__all__ = ["JointStateBroadcaster"]
