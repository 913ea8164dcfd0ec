"""The arm inside a simulated controller box: the UR5e's six arm joints in MuJoCo.

Counterpart: the joint servos and brakes inside a real arm's controller cabinet. A thin layer
over :class:`robocourse.sim.robots.RobotSim` (1 ms physics steps): position servo (with the
simulation's gravity feed-forward), torque mode (the command plus the model's gravity torque,
as Franka's torque interface adds gravity itself), and ``hold()`` (brakes: position servo on the
position where the arm is now). The gripper finger is held where it starts; the boxes do not
drive it.
"""

from __future__ import annotations

import numpy as np

ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
              "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


class BoxArm:
    """The six arm joints of a ``RobotSim("ur5e")``, stepped ``timestep`` s per :meth:`step`."""

    def __init__(self, timestep: float = 0.001, initial_positions=None):
        from robocourse.sim.robots import RobotSim

        self.sim = RobotSim("ur5e", timestep=timestep)
        if initial_positions is not None:
            self.sim.reset(dict(zip(ARM_JOINTS, initial_positions)))
        names = self.sim.joint_names
        self.idx = np.array([names.index(j) for j in ARM_JOINTS], dtype=np.intp)
        assert list(self.idx) == list(range(6)), "the arm joints come first in the UR5e URDF"
        self.n = 6
        self.q = self.sim.positions[:6]
        self.dq = self.sim.velocities[:6]
        self.tau = self.sim.efforts[:6]
        self.cmd = self.sim.commands[:6]
        self.mode = "position"
        self.tau_ext = np.zeros(6)
        self._g = np.zeros(self.sim.velocities.shape[0])
        self.limits_low = np.array([self.sim.limits[j].lower for j in ARM_JOINTS])
        self.limits_high = np.array([self.sim.limits[j].upper for j in ARM_JOINTS])
        self.velocity_limits = np.array([self.sim.limits[j].velocity for j in ARM_JOINTS])

    def set_mode(self, mode: str) -> None:
        """"position" or "effort" for the six arm joints (no-op if unchanged)."""
        if mode != self.mode:
            self.sim.set_mode(list(ARM_JOINTS), mode)
            self.mode = mode

    def hold(self) -> None:
        """Brakes: hold the arm at its current position."""
        self.set_mode("position")
        self.cmd[:] = self.q

    def gravity(self) -> np.ndarray:
        return self.sim.gravity_torques(self._g)[:6]

    def step(self, n: int = 1) -> None:
        self.sim.step(n)

    def estimate_external_torque(self, alpha: float = 0.1) -> np.ndarray:
        """tau_ext_hat: gravity model minus measured joint torque, low-pass filtered (quasi-static:
        no inertial terms, so it reads non-zero while accelerating)."""
        self.tau_ext += alpha * ((self.gravity() - self.tau) - self.tau_ext)
        return self.tau_ext


class NullArm:
    """No physics: the same packets and timing with nothing behind them (the round-trip floor)."""

    n = 6

    def __init__(self, timestep: float = 0.001, initial_positions=None):
        self.q = np.array(initial_positions if initial_positions is not None else np.zeros(6), dtype=float)
        self.dq, self.tau, self.cmd, self.tau_ext = np.zeros(6), np.zeros(6), self.q.copy(), np.zeros(6)
        self.limits_low, self.limits_high = np.full(6, -2 * np.pi), np.full(6, 2 * np.pi)
        self.velocity_limits = np.full(6, np.pi)
        self.mode = "position"

    def set_mode(self, mode: str) -> None:
        self.mode = mode

    def hold(self) -> None:
        self.cmd[:] = self.q

    def gravity(self) -> np.ndarray:
        return np.zeros(6)

    def step(self, n: int = 1) -> None:
        pass

    def estimate_external_torque(self, alpha: float = 0.1) -> np.ndarray:
        return self.tau_ext
