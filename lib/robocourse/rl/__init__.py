"""robocourse.rl: train a policy in seconds, export it to ONNX, run it with one interface.

- ``envs``: gymnasium environments: :class:`CartPoleEnv` (chapter 2's plant) and
  :class:`ArmReachEnv` (IsaacLab's Franka reach, done on chapter 4's UR5e);
- ``policy``: :class:`Normalizer`, :class:`MLPPolicy` (numpy);
- ``ars``: Augmented Random Search with running observation normalisation;
- ``export``: ONNX with the normalizer folded in (IsaacLab's exporter, by hand with onnx.helper);
- ``runtime``: numpy / onnxruntime (io_binding) / torch (if installed) behind ``rt(obs)``;
- ``postprocess``: scale, EMA, clipping to joint and torque limits, counted;
- ``shipped``: the small policy shipped with the course and the one command that retrains it;
- ``deployment``: :class:`PolicyDeployment`, the CRISP deployment under ros2_control (50 Hz policy
  thread, 500 Hz ForwardCommandController, MujocoSystem) through the joint bridge of
  :mod:`robocourse.control.joint_bridge`, the cerebellum set up by :mod:`robocourse.rt.realtime_thread`.
"""

from .ars import ARSConfig, TrainResult, train_arm_reach, train_cartpole
from .envs import ARM_JOINTS, UR5E_DEFAULT_POSE, ArmReachConfig, ArmReachEnv, CartPoleEnv, make_env
from .export import ExportCheck, export_onnx, fold_normalizer, to_onnx
from .policy import MLPPolicy, Normalizer, RunningNormalizer
from .postprocess import ActionProcessor, ema_alpha
from .runtime import (
           NumpyRuntime,
           OnnxRuntime,
           PolicyRuntime,
           TorchRuntime,
           load_runtime,
           torch_available,
)

__all__ = ["ARM_JOINTS", "ARSConfig", "ActionProcessor", "ArmReachConfig", "ArmReachEnv", "CartPoleEnv", "ExportCheck",
           "MLPPolicy", "Normalizer", "NumpyRuntime", "OnnxRuntime", "PolicyRuntime", "RunningNormalizer",
           "TorchRuntime", "TrainResult", "UR5E_DEFAULT_POSE", "ema_alpha", "export_onnx", "fold_normalizer",
           "load_runtime", "make_env", "to_onnx", "torch_available", "train_arm_reach", "train_cartpole",
           "PolicyDeployment"]


def __getattr__(name):  # the deployment pulls in MuJoCo and the controller manager: import it on use
    if name == "PolicyDeployment":
        from .deployment import PolicyDeployment

        return PolicyDeployment
    raise AttributeError(f"module 'robocourse.rl' has no attribute {name!r}")
