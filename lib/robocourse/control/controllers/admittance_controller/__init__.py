"""AdmittanceController (ros2_controllers' admittance_controller), chainable.

Counterpart: ``admittance_controller::AdmittanceController`` with its ``AdmittanceRule``. Each
update reads the joint states and the flange force/torque sensor (``<ft_sensor.name>/force.x``
.. ``torque.z``), rotates the wrench into the world, removes the tool's weight (gravity
compensation: ``gravity_compensation.CoG.force`` N at ``CoG.pos``), smooths it
(``ft_sensor.filter_coefficient``), and integrates the Cartesian admittance

    M xdd + D xd + K x = F_ext,     D = 2 zeta sqrt(M K)

per axis in the control frame (``admittance.selected_axes`` masks axes), where x is the tip's
offset from where the reference joint positions put it. The Cartesian acceleration becomes a
joint acceleration through the Jacobian's damped least-squares inverse minus
``joint_damping`` times the offset velocity; the commands are reference + offset. References
come from a preceding controller through the exported reference interfaces
``<name>/<joint>/position|velocity`` (chained mode: a JointTrajectoryController with
``command_joints: [<name>/<joint>, ...]``), or from ``~/joint_references``
(trajectory_msgs/JointTrajectoryPoint) when not chained; a NaN reference keeps the last one.
``~/status`` publishes control_msgs/AdmittanceControllerState.

Differences: kinematics are :class:`robocourse.sim.robots.Kinematics` of a shipped robot
(``kinematics.robot``) rather than a kinematics_interface plugin on robot_description; the
world frame is the model's base_link (gravity along -z); the control frame is base_link or a
link of the chain; the orientation offset is the rotation vector of R R_ref^T.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robocourse.msgs.trajectory_msgs import JointTrajectoryPoint

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ChainableControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...manager.loaned import InterfaceGroup
from ...msgs import AdmittanceControllerState
from ...parameters import ParameterSchema

_HERE = Path(__file__).parent
FT_INTERFACES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The axis * angle of rotation matrix ``R`` (log map), robust near 0 and pi."""
    c = (np.trace(R) - 1.0) * 0.5
    angle = math.acos(min(1.0, max(-1.0, c)))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * w
    if math.pi - angle < 1e-6:
        axis = np.sqrt(np.maximum((np.diag(R) + 1.0) * 0.5, 0.0))
        k = int(np.argmax(axis))
        axis[:] = [axis[k] if i == k else (R[k, i] + R[i, k]) / (4.0 * axis[k]) for i in range(3)]
        return axis * angle
    return w * (angle / (2.0 * math.sin(angle)))


class AdmittanceRule:
    """The admittance arithmetic, independent of interfaces (upstream's AdmittanceRule)."""

    def __init__(self, params, kinematics, joints: int):
        self.kin = kinematics
        self.n = joints
        self.joint_pos = np.zeros(joints)
        self.joint_vel = np.zeros(joints)
        self.joint_acc = np.zeros(joints)
        self.wrench_world = np.zeros(6)
        self.wrench_base = np.zeros(6)
        self.x = np.zeros(6)
        self.xd = np.zeros(6)
        self.apply_parameters(params)

    def apply_parameters(self, p) -> None:
        a = p.admittance
        self.mass = np.array(a.mass, dtype=float)
        self.stiffness = np.array(a.stiffness, dtype=float)
        self.damping = 2.0 * np.array(a.damping_ratio, dtype=float) * np.sqrt(self.mass * self.stiffness)
        self.selected = np.array(a.selected_axes, dtype=float)
        self.joint_damping = a.joint_damping
        self.alpha = p.kinematics.alpha
        self.cog = np.array(p.gravity_compensation.CoG.pos, dtype=float)
        self.weight = np.array([0.0, 0.0, -p.gravity_compensation.CoG.force])
        self.filter = p.ft_sensor.filter_coefficient
        self.sensor_frame = p.ft_sensor.frame.id
        self.cog_frame = p.gravity_compensation.frame.id
        self.control_frame = p.control.frame.id
        self.base = p.kinematics.base

    def reset(self) -> None:
        for v in (self.joint_pos, self.joint_vel, self.joint_acc, self.wrench_world, self.x, self.xd):
            v.fill(0.0)

    def _rotation(self, q, frame: str) -> np.ndarray:
        if frame == self.base:
            return np.eye(3)
        return self.kin.calculate_link_transform(q, frame)[:3, :3]

    def process_wrench(self, q, measured) -> np.ndarray:
        """Sensor wrench -> world, minus the tool's weight, exponentially filtered (``wrench_world``)."""
        R_s = self._rotation(q, self.sensor_frame)
        f = R_s @ measured[:3] - self.weight
        r = self._rotation(q, self.cog_frame) @ self.cog
        t = R_s @ measured[3:] - np.cross(r, self.weight)
        c = self.filter
        self.wrench_world[:3] = (1.0 - c) * self.wrench_world[:3] + c * f
        self.wrench_world[3:] = (1.0 - c) * self.wrench_world[3:] + c * t
        return self.wrench_world

    def update(self, q, measured, ref_pos, ref_vel, dt: float, out_pos, out_vel) -> None:
        """One step: desired joint positions/velocities = reference + admittance offset."""
        kin = self.kin
        self.wrench_base[:] = self.process_wrench(q, measured)   # world == base here
        T_ref = kin.calculate_link_transform(ref_pos)
        q_adm = ref_pos + self.joint_pos
        T_adm = kin.calculate_link_transform(q_adm)
        J = kin.calculate_jacobian(q_adm)
        self.x[:3] = T_adm[:3, 3] - T_ref[:3, 3]
        self.x[3:] = rotation_vector(T_adm[:3, :3] @ T_ref[:3, :3].T)
        self.xd[:] = J @ self.joint_vel
        R = self._rotation(q, self.control_frame)
        # to the control frame, M^-1 (F - D xd - K x) per axis, back to the base frame
        F_c = np.concatenate((R.T @ self.wrench_base[:3], R.T @ self.wrench_base[3:]))
        x_c = np.concatenate((R.T @ self.x[:3], R.T @ self.x[3:]))
        xd_c = np.concatenate((R.T @ self.xd[:3], R.T @ self.xd[3:]))
        acc_c = self.selected * (F_c - self.damping * xd_c - self.stiffness * x_c) / self.mass
        acc = np.concatenate((R @ acc_c[:3], R @ acc_c[3:]))
        JJt = J @ J.T + self.alpha * np.eye(6)
        self.joint_acc[:] = J.T @ np.linalg.solve(JJt, acc) - self.joint_damping * self.joint_vel
        self.joint_vel += self.joint_acc * dt
        self.joint_pos += self.joint_vel * dt
        np.add(ref_pos, self.joint_pos, out=out_pos)
        np.add(ref_vel, self.joint_vel, out=out_vel)


class AdmittanceController(ChainableControllerInterface):
    """``admittance_controller/AdmittanceController``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("parameters.yaml").read_text())

    def __init__(self):
        super().__init__()
        self.rule: AdmittanceRule | None = None
        self._status_pub = None
        self._joint_ref_msg = None

    def on_configure(self, previous_state):
        from robocourse.sim.robots import Kinematics

        p = self.params
        self.joints = list(p.joints)
        self.n = len(self.joints)
        self.command_joints = list(p.command_joints) or self.joints
        if len(self.command_joints) != self.n:
            self.get_logger().error(f"'command_joints' ({len(self.command_joints)}) must name as many joints as "
                                    f"'joints' ({self.n}) or be empty")
            return CallbackReturn.ERROR
        if "position" not in p.state_interfaces:
            self.get_logger().error("state_interfaces must contain 'position' (e.g. [position, velocity])")
            return CallbackReturn.ERROR
        try:
            kin = Kinematics(p.kinematics.robot, tip=p.kinematics.tip)
        except (ValueError, KeyError) as exc:
            self.get_logger().error(f"Kinematics plugin failed to load for robot '{p.kinematics.robot}' tip "
                                    f"'{p.kinematics.tip}': {exc}")
            return CallbackReturn.ERROR
        if list(kin.joint_names) != self.joints:
            self.get_logger().error(f"'joints' {self.joints} must be the kinematic chain {p.kinematics.base} -> "
                                    f"{p.kinematics.tip} in order: {list(kin.joint_names)}")
            return CallbackReturn.ERROR
        self.rule = AdmittanceRule(p, kin, self.n)
        self._q = np.zeros(self.n)
        self._qd = np.zeros(self.n)
        self._ft = np.zeros(6)
        self.ref_pos = np.zeros(self.n)
        self.ref_vel = np.zeros(self.n)
        self.last_ref_pos = np.zeros(self.n)
        self.cmd_pos = np.zeros(self.n)
        self.cmd_vel = np.zeros(self.n)
        if self._node is None:
            node = self.get_node()
            node.create_subscription(JointTrajectoryPoint, "~/joint_references", self._on_joint_references, 10)
            self._status_pub = node.create_publisher(AdmittanceControllerState, "~/status", 10)
        return CallbackReturn.SUCCESS

    def _on_joint_references(self, msg) -> None:
        if len(msg.positions) != self.n or not all(math.isfinite(v) for v in msg.positions):
            self.get_logger().error(f"joint_references need {self.n} finite positions, got {list(msg.positions)}")
            return
        self._joint_ref_msg = msg

    def command_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{j}/{i}" for i in self.params.command_interfaces for j in self.command_joints])

    def state_interface_configuration(self):
        names = [f"{j}/{i}" for i in self.params.state_interfaces for j in self.joints]
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      names + [f"{self.params.ft_sensor.name}/{i}" for i in FT_INTERFACES])

    def on_export_reference_interfaces(self):
        return [f"{j}/{i}" for i in self.params.chainable_command_interfaces for j in self.params.joints]

    def on_activate(self, previous_state):
        n = self.n
        si = list(self.params.state_interfaces)
        self._state = {iface: InterfaceGroup(self.state_interfaces[k * n:(k + 1) * n]) for k, iface in enumerate(si)}
        self._ft_group = InterfaceGroup(self.state_interfaces[len(si) * n:])
        ci = list(self.params.command_interfaces)
        self._cmd = {iface: InterfaceGroup(self.command_interfaces[k * n:(k + 1) * n]) for k, iface in enumerate(ci)}
        self._state["position"].get(out=self._q)
        self.last_ref_pos[:] = self._q
        self.reference_interfaces[:] = np.nan
        self._joint_ref_msg = None
        self.rule.reset()
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state):
        self._state = self._cmd = {}
        return CallbackReturn.SUCCESS

    def update_reference_from_subscribers(self, time, period):
        msg = self._joint_ref_msg
        if msg is not None:
            chained = self.params.chainable_command_interfaces
            for k, iface in enumerate(chained):
                values = msg.positions if iface == "position" else msg.velocities
                if len(values) == self.n:
                    self.reference_interfaces[k * self.n:(k + 1) * self.n] = values
        return return_type.OK

    def update_and_write_commands(self, time, period):
        if self.param_listener.try_update_params(self.params) and \
                self.params.enable_parameter_update_without_reactivation:
            self.rule.apply_parameters(self.params)
        n, refs = self.n, self.reference_interfaces
        self._state["position"].get(out=self._q)
        self._ft_group.get(out=self._ft)
        if not np.all(np.isfinite(self._ft)):
            self.get_logger().error(f"force/torque reading {self._ft.tolist()} is not finite")
            return return_type.ERROR
        self.ref_pos[:] = self.last_ref_pos
        self.ref_vel.fill(0.0)
        for k, iface in enumerate(self.params.chainable_command_interfaces):
            block = refs[k * n:(k + 1) * n]
            target = self.ref_pos if iface == "position" else self.ref_vel
            np.copyto(target, block, where=np.isfinite(block))
        self.last_ref_pos[:] = self.ref_pos
        self.rule.update(self._q, self._ft, self.ref_pos, self.ref_vel, period, self.cmd_pos, self.cmd_vel)
        if "position" in self._cmd:
            self._cmd["position"].set(self.cmd_pos)
        if "velocity" in self._cmd:
            self._cmd["velocity"].set(self.cmd_vel)
        pub = self._status_pub
        if pub is not None and pub.get_subscription_count():
            self._publish_status()
        return return_type.OK

    def _publish_status(self) -> None:
        r = self.rule
        msg = AdmittanceControllerState(joint_names=list(self.joints), mass=r.mass.tolist(),
                                        damping=r.damping.tolist(), stiffness=r.stiffness.tolist())
        w = r.wrench_base
        msg.wrench_base.force.x, msg.wrench_base.force.y, msg.wrench_base.force.z = (float(v) for v in w[:3])
        msg.wrench_base.torque.x, msg.wrench_base.torque.y, msg.wrench_base.torque.z = (float(v) for v in w[3:])
        p = msg.admittance_position.pose.position
        p.x, p.y, p.z = (float(v) for v in r.x[:3])
        msg.joint_state = JointTrajectoryPoint(positions=self._q.tolist())
        msg.ref_trajectory = JointTrajectoryPoint(positions=self.ref_pos.tolist(), velocities=self.ref_vel.tolist())
        self._status_pub.publish(msg)


__all__ = ["AdmittanceController", "AdmittanceRule", "rotation_vector"]
