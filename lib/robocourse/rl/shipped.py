"""The small policies shipped with the course, and the one command that retrains them.

    python -m robocourse.rl.shipped          # ARS on ArmReachEnv (seed 0), then export + check;
                                             # ARS on the cart-pole with 3 stacked frames (seed 1)

writes ``policies/ur5e_reach.npz`` (weights, normalizer, training config),
``policies/ur5e_reach.onnx`` (normalizer folded in) and ``policies/ur5e_reach_normalizer.npz``,
and ``policies/cartpole_history3.npz`` (chapter 6's history-stacking pitfall: a cart-pole
policy trained on ``StackedObservation(frames=3, layout="time")``). Chapter 6 loads these, so
a notebook run does not wait for training.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .ars import ARM_ARS, ARSConfig, train_arm_reach, train_cartpole
from .envs import ArmReachConfig
from .export import export_onnx
from .policy import MLPPolicy

POLICIES = Path(__file__).with_name("policies")
NAME = "ur5e_reach"
HISTORY_NAME = "cartpole_history3"
HISTORY_ARS = ARSConfig(n_directions=4, top=2, step_size=0.1, noise=0.1, seed=1, max_iterations=100)


def paths(directory: Path | None = None) -> dict[str, Path]:
    d = Path(directory) if directory is not None else POLICIES
    return {"npz": d / f"{NAME}.npz", "onnx": d / f"{NAME}.onnx", "normalizer": d / f"{NAME}_normalizer.npz"}


def load() -> MLPPolicy:
    """The shipped policy (numpy); its ``meta["config"]`` is the ArmReachConfig it was trained on."""
    return MLPPolicy.load(paths()["npz"])


def history_policy(directory: Path | None = None) -> MLPPolicy:
    """The cart-pole policy trained on 3 stacked observations, newest frame first (``meta["history"]``)."""
    d = Path(directory) if directory is not None else POLICIES
    return MLPPolicy.load(d / f"{HISTORY_NAME}.npz")


def env_config(policy: MLPPolicy) -> ArmReachConfig:
    cfg = dict(policy.meta["config"])
    cfg["default_pose"] = tuple(cfg["default_pose"])
    return ArmReachConfig(**cfg)


def main(argv=None, directory: Path | None = None) -> int:
    p = paths(directory)
    p["npz"].parent.mkdir(parents=True, exist_ok=True)
    result = train_arm_reach(ArmReachConfig(), ARM_ARS, progress=True)
    print(result)
    result.policy.meta["ars"] = {"iterations": result.iterations, "env_steps": result.env_steps,
                                 "solved": result.solved, "seed": ARM_ARS.seed}
    result.policy.save(p["npz"])
    print(export_onnx(result.policy, p["onnx"]))
    hist = train_cartpole(HISTORY_ARS, progress=True, history=3, history_layout="time")
    print(hist)
    hist.policy.meta["ars"] = {"iterations": hist.iterations, "env_steps": hist.env_steps, "solved": hist.solved,
                               "seed": HISTORY_ARS.seed}
    hist.policy.save(p["npz"].parent / f"{HISTORY_NAME}.npz")
    return 0 if result.solved and hist.solved else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
