"""Gymnasium environments: chapter 2's cart-pole, and a reach task on chapter 4's UR5e.

Counterparts: gymnasium's ``CartPole-v1`` (reward +1 per step while upright, 500 steps,
solved at 475) on the course's MuJoCo cart-pole (``robocourse.sim.models.cartpole``), and
IsaacLab's ``Isaac-Reach-Franka-v0`` done on the UR5e of ``robocourse.sim.robots``: joint
position targets ``default_pose + action_scale * action`` go to a PD servo that runs at the
physics rate inside ``mj_step``; the policy acts every ``decimation`` physics steps and holds
its target in between (zero-order hold, unitree's deploy_mujoco loop); the observation is
``[q - default_pose, dq * dof_vel_scale, target - tcp_default, last action]`` (21 numbers).

Where we differ: IsaacLab also asks for an orientation and trains with PPO on thousands of
parallel envs; here the target is a TCP position and ARS trains a linear policy in seconds.
The randomisation knobs a sim-to-real recipe turns are parameters: ``obs_noise`` (uniform,
added to the joint terms), ``actuator_delay`` (physics steps between the policy's output and
the servo seeing it).
"""

from __future__ import annotations

from collections import deque

import gymnasium as gym
import numpy as np

from .reach_config import ARM_JOINTS, UR5E_DEFAULT_POSE, ArmReachConfig  # noqa: F401  (re-exported)


class CartPoleEnv(gym.Env):
    """Balance chapter 2's cart-pole (5 kg cart, 1 kg bob on a 2 m rod) with a force on the cart.

    obs ``[x (m), phi (rad, 0 upright), x_dot (m/s), phi_dot (rad/s)]``; action in [-1, 1]
    times ``force_scale`` N; ``dt`` 0.02 s (4 RK4 steps of 5 ms); reward +1 per step while
    |phi| <= 0.2 rad and |x| <= 2.4 m (else the episode terminates); 500 steps; solved at 475.
    """

    metadata = {"render_modes": []}
    threshold = 475.0

    def __init__(self, force_scale: float = 100.0, max_steps: int = 500, frame_skip: int = 4,
                 timestep: float = 0.005):
        import mujoco

        from robocourse.sim.models import cartpole

        self._mj = mujoco
        self.model = cartpole(timestep=timestep)
        self.data = mujoco.MjData(self.model)
        self.force_scale, self.max_steps, self.frame_skip = float(force_scale), int(max_steps), int(frame_skip)
        self.dt = self.frame_skip * self.model.opt.timestep
        self.observation_space = gym.spaces.Box(-100.0, 100.0, (4,), np.float64)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float64)
        self._steps = 0

    def _obs(self) -> np.ndarray:
        d = self.data
        return np.array([d.qpos[0], d.qpos[1], d.qvel[0], d.qvel[1]])

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._mj.mj_resetData(self.model, self.data)
        s = self.np_random.uniform(-0.05, 0.05, 4)
        self.data.qpos[:] = s[:2]
        self.data.qvel[:] = s[2:]
        self._steps = 0
        return self._obs(), {}

    def step(self, action):
        a = float(np.clip(np.asarray(action, dtype=float).reshape(-1)[0], -1.0, 1.0))
        self.data.ctrl[0] = a * self.force_scale
        self._mj.mj_step(self.model, self.data, self.frame_skip)
        self._steps += 1
        obs = self._obs()
        fell = abs(obs[1]) > 0.2 or abs(obs[0]) > 2.4
        return obs, 0.0 if fell else 1.0, bool(fell), self._steps >= self.max_steps, {}


class ArmReachEnv(gym.Env):
    """Move the UR5e's TCP (tool0) to a target position (see the module docstring).

    Reward per policy step: ``-|tcp - target|`` (m) ``- 0.01 |a - a_prev|^2`` (action rate).
    ``info["distance"]`` is the TCP distance in m after the step.
    """

    metadata = {"render_modes": []}
    OBS_SIZE, ACT_SIZE = 21, 6

    def __init__(self, config: ArmReachConfig | None = None, sim=None):
        from robocourse.sim.robots import RobotSim

        self.config = c = config or ArmReachConfig()
        self.sim = sim if sim is not None else RobotSim("ur5e", timestep=c.timestep, floor=False)
        self.default_pose = np.array(c.default_pose, dtype=float)
        self.sim.reset(list(self.default_pose) + [0.04])
        self.tcp_default = self.sim.link_pose("tool0")[0]
        self._tool = self.sim.model.body("tool0").id
        self.max_steps = int(round(c.episode_s / c.policy_dt))
        self.observation_space = gym.spaces.Box(-100.0, 100.0, (self.OBS_SIZE,), np.float64)
        self.action_space = gym.spaces.Box(-c.clip_actions, c.clip_actions, (self.ACT_SIZE,), np.float64)
        self.target = self.tcp_default.copy()
        self.last_action = np.zeros(6)
        self._pending: deque = deque()
        self._phys = 0
        self._steps = 0

    @property
    def tcp(self) -> np.ndarray:
        return self.sim.data.xpos[self._tool]

    def observation(self) -> np.ndarray:
        c, s = self.config, self.sim
        obs = np.concatenate([s.positions[:6] - self.default_pose, s.velocities[:6] * c.dof_vel_scale,
                              self.target - self.tcp_default, self.last_action])
        if c.obs_noise:
            obs[:12] += self.np_random.uniform(-c.obs_noise, c.obs_noise, 12)
        return obs

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        c, rng = self.config, self.np_random
        q0 = self.default_pose + rng.uniform(-0.05, 0.05, 6)
        self.sim.reset(list(q0) + [0.04])
        if options and "target" in options:
            self.target = np.asarray(options["target"], dtype=float).copy()
        else:
            self.target = self.tcp_default + rng.uniform(-c.target_range, c.target_range, 3)
        self.last_action = np.zeros(6)
        self._pending.clear()
        self._phys = self._steps = 0
        return self.observation(), {}

    def step(self, action):
        c, s = self.config, self.sim
        a = np.clip(np.asarray(action, dtype=float).reshape(6), -c.clip_actions, c.clip_actions)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action {a} has a non-finite value")
        target_q = self.default_pose + c.action_scale * a
        end = self._phys + c.decimation
        if c.actuator_delay == 0:
            s.commands[:6] = target_q
            s.step(c.decimation)
        else:  # the servo sees the target actuator_delay physics steps later
            self._pending.append((self._phys + c.actuator_delay, target_q))
            while self._phys < end:
                nxt = end
                if self._pending and self._pending[0][0] <= self._phys:
                    s.commands[:6] = self._pending.popleft()[1]
                    continue
                if self._pending:
                    nxt = min(end, self._pending[0][0])
                s.step(nxt - self._phys)
                self._phys = nxt
        self._phys = end
        rate = float(np.sum((a - self.last_action) ** 2))
        self.last_action = a
        self._steps += 1
        dist = float(np.linalg.norm(self.tcp - self.target))
        reward = -dist - 0.01 * rate
        return self.observation(), reward, False, self._steps >= self.max_steps, {"distance": dist}


HISTORY_LAYOUTS = ("time", "time_oldest_first", "term")


class StackedObservation(gym.ObservationWrapper):
    """The last ``frames`` observations of ``env`` as one vector, laid out by ``layout``.

    ``"time"``: whole frames, newest first ``[o_t, o_t-1, ...]``; ``"time_oldest_first"``: whole
    frames, oldest first; ``"term"``: each term's history together ``[x_t, x_t-1, ..., phi_t, ...]``
    (rl_sar's ``observations_history_priority`` "time" / "term"). At reset the history is the first
    observation repeated. A policy trained on one layout and fed another gets the same numbers in
    other places, and nothing raises.
    """

    def __init__(self, env, frames: int = 3, layout: str = "time"):
        super().__init__(env)
        if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
            raise ValueError(f"frames={frames!r} must be an int >= 1, e.g. 3")
        if layout not in HISTORY_LAYOUTS:
            raise ValueError(f"layout={layout!r} must be one of {', '.join(HISTORY_LAYOUTS)}")
        self.frames, self.layout = frames, layout
        n = env.observation_space.shape[0]
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (n * frames,), np.float64)
        self._hist: deque = deque(maxlen=frames)

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self._hist.clear()
        for _ in range(self.frames):
            self._hist.append(np.asarray(obs, dtype=float))
        return self._stack(), info

    def observation(self, observation):
        self._hist.append(np.asarray(observation, dtype=float))
        return self._stack()

    def _stack(self) -> np.ndarray:
        newest_first = np.array(list(self._hist)[::-1])          # frames x terms
        if self.layout == "time":
            return newest_first.reshape(-1)
        if self.layout == "time_oldest_first":
            return newest_first[::-1].reshape(-1)
        return newest_first.T.reshape(-1)


def make_env(name: str, **kwargs):
    """``"cartpole"`` or ``"arm_reach"`` (kwargs: the env's constructor arguments / ArmReachConfig fields)."""
    if name == "cartpole":
        return CartPoleEnv(**kwargs)
    if name == "arm_reach":
        return ArmReachEnv(ArmReachConfig(**kwargs))
    raise ValueError(f"env {name!r} is not one of 'cartpole', 'arm_reach'")


def arm_evaluation_targets(env: ArmReachEnv, n: int = 8, seed: int = 1234) -> np.ndarray:
    """``n`` fixed targets for evaluating a reach policy (seeded, the same on every machine)."""
    rng = np.random.default_rng(seed)
    r = env.config.target_range
    return env.tcp_default + rng.uniform(-r, r, (n, 3))
