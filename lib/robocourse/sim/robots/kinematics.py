"""Kinematics of a shipped robot from its URDF: link transforms, Jacobians, delta conversions.

Counterpart of ros2_control's ``kinematics_interface::KinematicsInterface`` as implemented by
kinematics_interface_kdl (what the AdmittanceController loads): the same four calls
``calculate_link_transform``, ``calculate_jacobian``, ``convert_cartesian_deltas_to_joint_deltas``,
``convert_joint_deltas_to_cartesian_deltas``, computed by MuJoCo on a private MjData from the
same URDF file the simulation uses. Differences: joint vectors are over the chain's joints only
(base_link to the tip link, URDF order: the 6 arm joints for the ur5e), Cartesian vectors are
[vx, vy, vz, wx, wy, wz] in the base frame (base_link is the world frame of the model), taken at
the link frame's origin, as KDL does.
"""

from __future__ import annotations

import numpy as np

from .description import joint_limits, urdf_path


class Kinematics:
    """Forward kinematics and Jacobians of robot ``name`` for the chain from base_link to ``tip``."""

    def __init__(self, name: str = "ur5e", tip: str | None = None):
        import mujoco

        limits = joint_limits(name)  # validates the name
        self._mj = mujoco
        self.model = mujoco.MjModel.from_xml_path(str(urdf_path(name)))
        self._data = mujoco.MjData(self.model)
        m = self.model
        self.tip = tip or {"ur5e": "tool0", "rrbot": "tool_link", "fr3": "link8"}[name]
        self._tip_id = self._body(self.tip)
        chain, b = [], self._tip_id
        while b != 0:
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
                chain.append(j)
            b = m.body_parentid[b]
        chain.reverse()
        self.joint_names: tuple[str, ...] = tuple(m.joint(j).name for j in chain)
        if any(limits[j].mimic for j in self.joint_names):
            raise ValueError(f"the chain to {self.tip!r} holds a mimic joint; pick a tip on the arm")
        self._qadr = np.array([m.jnt_qposadr[j] for j in chain])
        self._dofs = np.array([m.jnt_dofadr[j] for j in chain])
        self._jacp, self._jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))

    def _body(self, link: str) -> int:
        try:
            return self.model.body(link).id
        except KeyError:
            raise ValueError(f"{link!r} is not a link of this robot") from None

    def _set(self, q) -> None:
        q = np.asarray(q, dtype=float)
        if q.shape != (len(self.joint_names),) or not np.all(np.isfinite(q)):
            raise ValueError(f"joint positions {q.tolist()} must be {len(self.joint_names)} finite numbers, "
                             f"for {', '.join(self.joint_names)}")
        self._data.qpos[self._qadr] = q
        self._mj.mj_kinematics(self.model, self._data)
        self._mj.mj_comPos(self.model, self._data)

    def calculate_link_transform(self, q, link: str | None = None) -> np.ndarray:
        """4x4 pose of ``link`` (default: the tip) in the base frame at joint positions ``q``."""
        b = self._tip_id if link is None else self._body(link)
        self._set(q)
        T = np.eye(4)
        T[:3, :3] = self._data.xmat[b].reshape(3, 3)
        T[:3, 3] = self._data.xpos[b]
        return T

    def calculate_jacobian(self, q, link: str | None = None) -> np.ndarray:
        """6 x n Jacobian [linear; angular] of ``link``'s origin in the base frame over the chain."""
        b = self._tip_id if link is None else self._body(link)
        self._set(q)
        self._mj.mj_jacBody(self.model, self._data, self._jacp, self._jacr, b)
        return np.vstack([self._jacp[:, self._dofs], self._jacr[:, self._dofs]])

    def convert_cartesian_deltas_to_joint_deltas(self, q, delta_x, link: str | None = None) -> np.ndarray:
        """Joint deltas that move ``link`` by the twist ``delta_x`` (least squares: J^+ dx)."""
        dx = np.asarray(delta_x, dtype=float)
        if dx.shape != (6,) or not np.all(np.isfinite(dx)):
            raise ValueError(f"delta_x {dx.tolist()} must be 6 finite numbers [vx, vy, vz, wx, wy, wz]")
        return np.linalg.pinv(self.calculate_jacobian(q, link)) @ dx

    def convert_joint_deltas_to_cartesian_deltas(self, q, delta_theta, link: str | None = None) -> np.ndarray:
        """The twist of ``link`` produced by joint deltas ``delta_theta`` (J dq)."""
        dq = np.asarray(delta_theta, dtype=float)
        if dq.shape != (len(self.joint_names),) or not np.all(np.isfinite(dq)):
            raise ValueError(f"delta_theta {dq.tolist()} must be {len(self.joint_names)} finite numbers")
        return self.calculate_jacobian(q, link) @ dq
