"""Augmented Random Search (Mania, Guy and Recht 2018, "V2-t"): a linear policy, numpy only.

Each iteration draws ``n_directions`` perturbations delta, runs the policy (M +- noise delta)
once each on the same episode (common random numbers: one episode seed per iteration, so
the ranking compares directions, not targets; ``shared_episode=False`` draws one per direction), keeps the ``top`` directions by
max(r+, r-), and steps ``M += step / (top * sigma_R) * sum (r+ - r-) delta``. Observations are
normalised with the running mean and std of every state visited (V2), frozen into the policy
at the end. Seeded: the same seed gives the same weights, bit for bit, on the same machine.

Where we differ from the paper: rollouts run in one process (no Ray workers); the policy is
an :class:`~robocourse.rl.policy.MLPPolicy` with no hidden layer, so it exports like any MLP.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .policy import MLPPolicy, RunningNormalizer


@dataclass(frozen=True)
class ARSConfig:
    n_directions: int = 8
    top: int = 4
    step_size: float = 0.02
    noise: float = 0.03
    max_iterations: int = 200
    eval_every: int = 5
    seed: int = 0
    shared_episode: bool = False  # True: every direction of an iteration sees the same episodes
    episodes: int = 1             # episodes averaged per perturbed rollout

    def __post_init__(self):
        if not 1 <= self.top <= self.n_directions:
            raise ValueError(f"top={self.top} must be in [1, n_directions={self.n_directions}]")
        if not (self.step_size > 0 and self.noise > 0 and self.max_iterations >= 1 and self.eval_every >= 1
                and self.episodes >= 1):
            raise ValueError("step_size and noise must be > 0, max_iterations, eval_every and episodes >= 1")


@dataclass
class TrainResult:
    policy: MLPPolicy
    solved: bool
    iterations: int
    env_steps: int
    seconds: float
    history: list = field(default_factory=list)  # (iteration, env_steps, score)

    def __str__(self) -> str:
        state = "reached the threshold" if self.solved else "did NOT reach the threshold"
        last = self.history[-1][2] if self.history else float("nan")
        return (f"ARS {state} after {self.iterations} iterations, {self.env_steps} env steps, "
                f"{self.seconds:.1f} s (last score {last:.3f})")


def rollout(env, weights: np.ndarray, norm: RunningNormalizer | None, mean, std, seed: int,
            options=None, record: list | None = None) -> tuple[float, int, dict]:
    """One episode of the linear policy ``a = W (obs - mean) / (std + eps)``; returns (return, steps, last info)."""
    obs, _ = env.reset(seed=seed, options=options)
    total, steps, info = 0.0, 0, {}
    eps = 1e-2
    while True:
        if record is not None:
            record.append(obs)
        a = weights @ ((obs - mean) / (std + eps))
        obs, r, term, trunc, info = env.step(a)
        total += r
        steps += 1
        if term or trunc:
            return total, steps, info


def evaluate(env, weights, mean, std, seeds, options_list=None):
    """(mean return, mean final info values, steps) over fixed seeds/options."""
    rets, finals, steps = [], [], 0
    for i, s in enumerate(seeds):
        opt = options_list[i] if options_list is not None else None
        r, n, info = rollout(env, weights, None, mean, std, s, opt)
        rets.append(r)
        finals.append(info.get("distance", np.nan))
        steps += n
    return float(np.mean(rets)), float(np.mean(finals)), steps


def train(env, score, threshold: float, config: ARSConfig | None = None, progress: bool = True,
          meta: dict | None = None) -> TrainResult:
    """Train until ``score(weights, mean, std) -> (value, steps)`` reaches ``threshold``
    (``value >= threshold``) or ``max_iterations`` pass. Use :func:`train_cartpole` /
    :func:`train_arm_reach` for the two course tasks."""
    cfg = config or ARSConfig()
    rng = np.random.default_rng(cfg.seed)
    n_obs, n_act = env.observation_space.shape[0], env.action_space.shape[0]
    w = np.zeros((n_act, n_obs))
    norm = RunningNormalizer(n_obs)
    history, steps, solved, it = [], 0, False, 0
    t0 = time.perf_counter()
    bar = None
    if progress:
        from robocourse.notebook import progress as progress_line

        bar = progress_line(cfg.max_iterations, "ARS iterations")
    try:
        for it in range(1, cfg.max_iterations + 1):
            mean, std = norm.mean.copy(), norm.std
            deltas = rng.standard_normal((cfg.n_directions, n_act, n_obs))
            if cfg.shared_episode:
                seeds = np.tile(rng.integers(0, 2**31 - 1, cfg.episodes), (cfg.n_directions, 1))
            else:
                seeds = rng.integers(0, 2**31 - 1, (cfg.n_directions, cfg.episodes))
            r_pos, r_neg, visited = np.zeros(cfg.n_directions), np.zeros(cfg.n_directions), []
            for k in range(cfg.n_directions):
                for s in seeds[k]:
                    r1, n1, _ = rollout(env, w + cfg.noise * deltas[k], norm, mean, std, int(s), record=visited)
                    r2, n2, _ = rollout(env, w - cfg.noise * deltas[k], norm, mean, std, int(s), record=visited)
                    r_pos[k] += r1 / cfg.episodes
                    r_neg[k] += r2 / cfg.episodes
                    steps += n1 + n2
            norm.update(np.array(visited))
            order = np.argsort(-np.maximum(r_pos, r_neg))[:cfg.top]
            sigma = np.concatenate([r_pos[order], r_neg[order]]).std()
            if sigma > 0:
                w += cfg.step_size / (cfg.top * sigma) * np.tensordot(r_pos[order] - r_neg[order], deltas[order], axes=1)
            if it % cfg.eval_every == 0:
                value, n = score(w, norm.mean, norm.std)
                steps += n
                history.append((it, steps, value))
                if bar is not None:
                    bar.desc = f"ARS iterations (score {value:.3f}, threshold {threshold:g})"
            if bar is not None:
                bar.update(1)
            if history and history[-1][0] == it and history[-1][2] >= threshold:
                solved = True
                break
    finally:
        if bar is not None:
            bar.close()
    policy = MLPPolicy([(w.copy(), np.zeros(n_act))], norm.frozen(), meta=dict(meta or {}))
    return TrainResult(policy, solved, it, steps, time.perf_counter() - t0, history)


def train_cartpole(config: ARSConfig | None = None, progress: bool = True, history: int = 1,
                   history_layout: str = "time", **env_kwargs) -> TrainResult:
    """Balance the cart-pole: solved when the mean return over 5 fixed episodes is >= 475.
    ``history > 1`` trains on the last ``history`` observations stacked by ``history_layout``
    (:class:`~robocourse.rl.envs.StackedObservation`)."""
    from .envs import CartPoleEnv, StackedObservation

    env = CartPoleEnv(**env_kwargs)
    if history > 1:
        env = StackedObservation(env, history, history_layout)
    seeds = list(range(10_000, 10_005))

    def score(w, mean, std):
        value, _, n = evaluate(env, w, mean, std, seeds)
        return value, n

    meta = {"env": "cartpole", "config": env_kwargs}
    if history > 1:
        meta.update(history=history, history_layout=history_layout)
    return train(env, score, CartPoleEnv.threshold, config or ARSConfig(n_directions=4, top=2, step_size=0.1, noise=0.1),
                 progress, meta=meta)


ARM_ARS = ARSConfig(max_iterations=150, episodes=4, shared_episode=True, step_size=0.03)


def train_arm_reach(env_config=None, config: ARSConfig | None = None, progress: bool = True) -> TrainResult:
    """Reach: solved when the mean final TCP distance over 8 fixed targets is below
    ``success_distance`` (score = -distance, threshold = -success_distance)."""
    from .envs import ArmReachEnv, arm_evaluation_targets

    env = ArmReachEnv(env_config)
    targets = arm_evaluation_targets(env)
    options = [{"target": t} for t in targets]
    seeds = list(range(20_000, 20_000 + len(targets)))

    def score(w, mean, std):
        _, dist, n = evaluate(env, w, mean, std, seeds, options)
        return -dist, n

    return train(env, score, -env.config.success_distance, config or ARM_ARS,
                 progress, meta={"env": "arm_reach", "config": env.config.as_dict()})
