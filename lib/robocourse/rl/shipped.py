"""The small reach policy shipped with the course, and the one command that retrains it.

    python -m robocourse.rl.shipped          # ARS on ArmReachEnv (seed 0), then export + check

writes ``policies/ur5e_reach.npz`` (weights, normalizer, training config),
``policies/ur5e_reach.onnx`` (normalizer folded in) and ``policies/ur5e_reach_normalizer.npz``.
Chapter 6 loads these for its full-length path, so a notebook run does not wait for training.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .ars import ARM_ARS, train_arm_reach
from .envs import ArmReachConfig
from .export import export_onnx
from .policy import MLPPolicy

POLICIES = Path(__file__).with_name("policies")
NAME = "ur5e_reach"


def paths(directory: Path | None = None) -> dict[str, Path]:
    d = Path(directory) if directory is not None else POLICIES
    return {"npz": d / f"{NAME}.npz", "onnx": d / f"{NAME}.onnx", "normalizer": d / f"{NAME}_normalizer.npz"}


def load() -> MLPPolicy:
    """The shipped policy (numpy); its ``meta["config"]`` is the ArmReachConfig it was trained on."""
    return MLPPolicy.load(paths()["npz"])


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
    return 0 if result.solved else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
