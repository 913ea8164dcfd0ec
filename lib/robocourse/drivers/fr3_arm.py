"""The FR3 inside the simulated Franka box: MuJoCo joints, the robot's own controllers, its kinematics.

Counterpart: what runs inside Franka's Control box below libfranka: the joint impedance
controller that tracks a motion generator's ``q_c`` (or ``dq_c``), the gravity model added to an
external controller's ``tau_J_d`` ("the robot compensates gravity itself"), and the forward
kinematics that fill ``O_T_EE``. Built on :class:`robocourse.sim.robots.RobotSim` ("fr3", 1 ms
steps). Where we differ: the impedance controller is MuJoCo's position servo with a gravity
feed-forward (kp = the joint impedance set with SetJointImpedance, default libfranka's examples'
3000..2000 N m/rad; kd ours); no friction compensation, no collision detection.
"""

from __future__ import annotations

import numpy as np

FR3_JOINTS = tuple(f"fr3_joint{i}" for i in range(1, 8))
#: libfranka's examples' home pose (rad)
HOME = (0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4)


class FR3Arm:
    """The seven FR3 joints, stepped ``timestep`` s per :meth:`step`; modes position/velocity/effort."""

    n = 7

    def __init__(self, timestep: float = 0.001, initial_positions=None):
        import mujoco

        from robocourse.sim.robots import RobotSim

        self._mj = mujoco
        self.sim = RobotSim("fr3", timestep=timestep, floor=False)
        if initial_positions is not None:
            self.sim.reset(list(initial_positions))
        assert self.sim.joint_names == FR3_JOINTS
        self.q, self.dq, self.tau, self.cmd = self.sim.positions, self.sim.velocities, self.sim.efforts, self.sim.commands
        self.mode = "position"
        self.limits_low = np.array([self.sim.limits[j].lower for j in FR3_JOINTS])
        self.limits_high = np.array([self.sim.limits[j].upper for j in FR3_JOINTS])
        self.velocity_limits = np.array([self.sim.limits[j].velocity for j in FR3_JOINTS])
        self.effort_limits = np.array([self.sim.limits[j].effort for j in FR3_JOINTS])
        self._flange = self.sim.model.body("link8").id
        self._g = np.zeros(7)
        self._default_kp = np.array([self.sim.gains[j].kp for j in FR3_JOINTS])

    def set_mode(self, mode: str) -> None:
        if mode != self.mode:
            self.sim.set_mode(list(FR3_JOINTS), mode)
            self.mode = mode

    def hold(self, q=None) -> None:
        """The brakes' stand-in: position servo on ``q`` (default: where the arm is now)."""
        self.set_mode("position")
        self.cmd[:] = self.q if q is None else q

    def gravity(self) -> np.ndarray:
        return self.sim.gravity_torques(self._g)

    def set_stiffness(self, k) -> None:
        """SetJointImpedance: the servo stiffness per joint (N m/rad); damping scales with sqrt(k)."""
        from robocourse.sim.robots import ServoGains

        for j, kj, k0 in zip(FR3_JOINTS, k, self._default_kp):
            g0 = self.sim.gains[j]
            scale = float(np.sqrt(kj / k0)) if k0 > 0 else 1.0
            self.sim.gains[j] = ServoGains(kp=float(kj), kd=g0.kd * scale if g0.kp else g0.kd, kv=g0.kv)
        for i in range(7):
            self.sim._apply_mode(i, self.sim._modes[i])

    def step(self, n: int = 1) -> None:
        self.sim.step(n)

    def flange_pose(self, out: np.ndarray) -> None:
        """O_T_F (4x4, column-major flattened into ``out[16]``) of the flange at the current q."""
        d = self.sim.data
        self._mj.mj_kinematics(self.sim.model, d)
        r = d.xmat[self._flange].reshape(3, 3)
        out[0:3], out[4:7], out[8:11] = r[:, 0], r[:, 1], r[:, 2]
        out[12:15] = d.xpos[self._flange]
        out[3] = out[7] = out[11] = 0.0
        out[15] = 1.0


class NullArm:
    """No physics: the same packets and timing with nothing behind them (the round-trip floor)."""

    n = 7

    def __init__(self, timestep: float = 0.001, initial_positions=None):
        self.q = np.array(initial_positions if initial_positions is not None else HOME, dtype=float)
        self.dq, self.tau, self.cmd = np.zeros(7), np.zeros(7), self.q.copy()
        self.limits_low, self.limits_high = np.full(7, -2 * np.pi), np.full(7, 2 * np.pi)
        self.velocity_limits, self.effort_limits = np.full(7, 10.0), np.full(7, 100.0)
        self.mode = "position"

    def set_mode(self, mode: str) -> None:
        self.mode = mode

    def hold(self, q=None) -> None:
        self.cmd[:] = self.q if q is None else q

    def gravity(self) -> np.ndarray:
        return np.zeros(7)

    def set_stiffness(self, k) -> None:
        pass

    def step(self, n: int = 1) -> None:
        pass

    def flange_pose(self, out: np.ndarray) -> None:
        out[:] = np.eye(4).ravel()
