"""robocourse.rl: train a policy in seconds, export it to ONNX, run it with one interface.

- ``envs``: gymnasium environments: :class:`CartPoleEnv` (chapter 2's plant) and
  :class:`ArmReachEnv` (IsaacLab's Franka reach, done on chapter 4's UR5e);
- ``policy``: :class:`Normalizer`, :class:`MLPPolicy` (numpy);
- ``ars``: Augmented Random Search with running observation normalisation;
- ``export``: ONNX with the normalizer folded in (IsaacLab's exporter, by hand with onnx.helper);
- ``runtime``: numpy / onnxruntime (io_binding) / torch (if installed) behind ``rt(obs)``;
- ``postprocess``: scale, EMA, clipping to joint and torque limits, counted;
- ``shipped``: the small policies shipped with the course and the one command that retrains them;
- ``brain``: the policy side of a deployment (observation from /joint_states by name);
- ``handover``: latest-value buffers between threads (:class:`LatestValue`) and processes;
- ``frames``: projected gravity, quaternion orders, UR's ``base`` vs ``base_link``;
- ``deployment``: :class:`PolicyDeployment`, the CRISP deployment under ros2_control (the brain in
  the loop, in a thread or in a process; a 500 Hz ForwardCommandController, MujocoSystem) through
  the joint bridge of :mod:`robocourse.control.joint_bridge`, the cerebellum set up by
  :mod:`robocourse.rt.realtime_thread`.

Names are imported on first use (PEP 562), so a process that needs only the runtime (the brain's
own process) does not pay for gymnasium, onnx and MuJoCo.
"""

import importlib

_WHERE = {
    "ARSConfig": "ars", "TrainResult": "ars", "train_arm_reach": "ars", "train_cartpole": "ars",
    "ARM_JOINTS": "envs", "UR5E_DEFAULT_POSE": "envs", "ArmReachConfig": "envs", "ArmReachEnv": "envs",
    "CartPoleEnv": "envs", "make_env": "envs",
    "ExportCheck": "export", "export_onnx": "export", "fold_normalizer": "export", "to_onnx": "export",
    "MLPPolicy": "policy", "Normalizer": "policy", "RunningNormalizer": "policy",
    "ActionProcessor": "postprocess", "ema_alpha": "postprocess",
    "NumpyRuntime": "runtime", "OnnxRuntime": "runtime", "PolicyRuntime": "runtime", "TorchRuntime": "runtime",
    "load_runtime": "runtime", "torch_available": "runtime", "RecordingRuntime": "runtime",
    "read_call_log": "runtime",
    "LatestValue": "handover", "SharedLatestValue": "handover",
    "PolicyDeployment": "deployment",
}

__all__ = sorted(_WHERE)


def __getattr__(name):
    if name in _WHERE:
        value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'robocourse.rl' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
