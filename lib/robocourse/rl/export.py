"""Export an :class:`~robocourse.rl.policy.MLPPolicy` to ONNX, with the normalizer inside.

Counterpart: IsaacLab's ``export_policy_as_onnx`` (rsl_rl exporter): ``forward(x) =
actor(normalizer(x))``, input ``"obs"``, output ``"actions"``, batch fixed at 1, float32. Built
by hand with ``onnx.helper`` (Gemm + activation nodes), because torch is not a course
requirement. ``normalizer="fold"`` (default) folds ``(x - mean) / (std + eps)`` into the first
layer (``W' = W / (std + eps)`` column-wise, ``b' = b - W' mean``); ``"graph"`` prepends Sub and
Div nodes as IsaacLab does; ``None`` leaves it out (the classic deployment bug, chapter 6).

IR version 10 and opset 17: onnx 1.23's ``make_model`` writes an IR version newer than some
onnxruntime releases accept, so it is set explicitly; every initializer is float32.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .policy import MLPPolicy

IR_VERSION = 10
OPSET = 17
_ONNX_ACT = {"elu": "Elu", "tanh": "Tanh", "relu": "Relu"}


def fold_normalizer(w: np.ndarray, b: np.ndarray, mean: np.ndarray, std: np.ndarray, eps: float = 1e-2):
    """The first layer with the normalizer folded in: ``W' x + b' == W (x - mean)/(std + eps) + b``."""
    w2 = np.asarray(w, dtype=float) / (np.asarray(std, dtype=float) + eps)
    return w2, np.asarray(b, dtype=float) - w2 @ np.asarray(mean, dtype=float)


def to_onnx(policy: MLPPolicy, normalizer: str | None = "fold"):
    """The policy as an ``onnx.ModelProto`` (checked with ``onnx.checker``)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    if normalizer not in ("fold", "graph", None):
        raise ValueError(f"normalizer={normalizer!r}: use 'fold', 'graph' or None")
    layers = [(w.copy(), b.copy()) for w, b in policy.layers]
    nodes, inits = [], []
    x = "obs"
    norm = policy.normalizer
    if norm is not None and normalizer == "fold":
        layers[0] = fold_normalizer(*layers[0], norm.mean, norm.std, norm.eps)
    elif norm is not None and normalizer == "graph":
        inits += [numpy_helper.from_array(norm.mean.astype(np.float32)[None], "norm_mean"),
                  numpy_helper.from_array((norm.std + norm.eps).astype(np.float32)[None], "norm_den")]
        nodes += [helper.make_node("Sub", ["obs", "norm_mean"], ["obs_centred"]),
                  helper.make_node("Div", ["obs_centred", "norm_den"], ["obs_normalized"])]
        x = "obs_normalized"
    last = len(layers) - 1
    for i, (w, b) in enumerate(layers):
        inits += [numpy_helper.from_array(w.astype(np.float32), f"W{i}"),
                  numpy_helper.from_array(b.astype(np.float32), f"b{i}")]
        y = "actions" if i == last else f"h{i}"
        nodes.append(helper.make_node("Gemm", [x, f"W{i}", f"b{i}"], [y if i == last else f"z{i}"], transB=1))
        if i < last:
            nodes.append(helper.make_node(_ONNX_ACT[policy.activation], [f"z{i}"], [y]))
        x = y
    graph = helper.make_graph(
        nodes, "policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, policy.obs_size])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, policy.act_size])], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="robocourse.rl")
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model)
    return model


@dataclass
class ExportCheck:
    """What :func:`export_onnx` verified: the largest |onnx - numpy| over the probe observations."""

    path: Path
    normalizer_path: Path | None
    max_abs_diff: float
    samples: int

    def __str__(self) -> str:
        return (f"{self.path.name}: onnx.checker ok; onnxruntime vs numpy over {self.samples} observations: "
                f"max |diff| = {self.max_abs_diff:.2e}")


def export_onnx(policy: MLPPolicy, path, normalizer: str | None = "fold", samples: int = 256,
                seed: int = 0, save_normalizer: bool = True) -> ExportCheck:
    """Write ``path`` (.onnx), check it, compare it with the numpy policy; save the normalizer
    statistics beside it (``<stem>_normalizer.npz``) unless ``save_normalizer=False``."""
    import onnx

    from .runtime import OnnxRuntime

    path = Path(path)
    model = to_onnx(policy, normalizer)
    onnx.save(model, str(path))
    norm_path = None
    if save_normalizer and policy.normalizer is not None:
        norm_path = policy.normalizer.save(path.with_name(path.stem + "_normalizer.npz"))
    rt = OnnxRuntime(path)
    rng = np.random.default_rng(seed)
    n = policy.normalizer
    scale = (n.std + n.eps) if n is not None else np.ones(policy.obs_size)
    centre = n.mean if n is not None else np.zeros(policy.obs_size)
    obs = (centre + scale * rng.standard_normal((samples, policy.obs_size))).astype(np.float32)
    reference = policy if normalizer is not None else MLPPolicy(policy.layers, None, policy.activation)
    diff = max(float(np.max(np.abs(rt(o) - reference(o.astype(float))))) for o in obs)
    return ExportCheck(path, norm_path, diff, samples)
