"""The reach task's joints, default pose and knobs, with no dependency beyond the standard library.

Kept apart from :mod:`robocourse.rl.envs` (which needs gymnasium and MuJoCo) so the brain's own
process can read a configuration without importing either. ``envs`` re-exports every name.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint")
UR5E_DEFAULT_POSE = (0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0)


@dataclass(frozen=True)
class ArmReachConfig:
    """The reach task's knobs (defaults: unitree deploy_mujoco's 500 Hz physics, 50 Hz policy)."""

    timestep: float = 0.002          # s, physics (and PD) step
    decimation: int = 10             # physics steps per policy step -> policy at 50 Hz
    action_scale: float = 0.5        # rad per unit action
    clip_actions: float = 1.0        # |action| limit before scaling
    default_pose: tuple = UR5E_DEFAULT_POSE
    dof_vel_scale: float = 0.05
    obs_noise: float = 0.0           # uniform +- on the joint position (rad) and scaled velocity terms
    actuator_delay: int = 0          # physics steps between a new target and the servo using it
    episode_s: float = 1.0
    target_range: float = 0.15       # m, targets uniform in a cube of +- this around the default TCP
    success_distance: float = 0.05   # m, the threshold: mean final TCP distance over evaluation targets

    def __post_init__(self):
        if not (isinstance(self.decimation, int) and self.decimation >= 1):
            raise ValueError(f"decimation={self.decimation!r} must be an int >= 1, e.g. 10 (500 Hz / 50 Hz)")
        if not (isinstance(self.actuator_delay, int) and 0 <= self.actuator_delay <= 4 * self.decimation):
            raise ValueError(f"actuator_delay={self.actuator_delay!r} physics steps must be an int in "
                             f"[0, {4 * self.decimation}] (at most 4 policy steps)")
        if len(self.default_pose) != 6:
            raise ValueError(f"default_pose has {len(self.default_pose)} values; the UR5e arm has 6 joints")
        if not (self.action_scale > 0 and self.obs_noise >= 0 and self.episode_s > 0 and self.target_range >= 0):
            raise ValueError("action_scale and episode_s must be > 0, obs_noise and target_range >= 0")

    @property
    def policy_dt(self) -> float:
        return self.timestep * self.decimation

    def as_dict(self) -> dict:
        return asdict(self)
