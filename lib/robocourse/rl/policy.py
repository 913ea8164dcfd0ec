"""A policy as numbers: an observation normalizer and an MLP, evaluated with numpy.

Counterparts: rsl_rl's ``EmpiricalNormalization`` ((x - mean) / (std + eps), eps 1e-2) and
its ``ActorCritic.actor`` (Linear layers with ELU between them, a linear output). A policy
with no hidden layer is the linear policy Augmented Random Search trains. Everything here
is float64; the exported ONNX model and the runtimes are float32.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ACTIVATIONS = ("elu", "tanh", "relu")
EPS = 1e-2  # rsl_rl's normalizer eps


def _act(name: str, x: np.ndarray) -> np.ndarray:
    if name == "elu":
        return np.where(x > 0, x, np.expm1(np.minimum(x, 0)))
    if name == "tanh":
        return np.tanh(x)
    return np.maximum(x, 0)


@dataclass
class Normalizer:
    """Frozen observation statistics: ``normalize(x) = (x - mean) / (std + eps)``."""

    mean: np.ndarray
    std: np.ndarray
    eps: float = EPS

    def __post_init__(self):
        self.mean = np.asarray(self.mean, dtype=float).copy()
        self.std = np.asarray(self.std, dtype=float).copy()
        if self.mean.shape != self.std.shape or self.mean.ndim != 1:
            raise ValueError(f"Normalizer mean {self.mean.shape} and std {self.std.shape} must be equal 1-D shapes")
        if not (np.all(np.isfinite(self.mean)) and np.all(np.isfinite(self.std)) and np.all(self.std >= 0)):
            raise ValueError("Normalizer mean/std must be finite and std >= 0")

    def normalize(self, x) -> np.ndarray:
        return (np.asarray(x, dtype=float) - self.mean) / (self.std + self.eps)

    @classmethod
    def identity(cls, n: int) -> Normalizer:
        """The normalizer that changes nothing (mean 0, std + eps = 1)."""
        return cls(np.zeros(n), np.full(n, 1.0 - EPS))

    def save(self, path) -> Path:
        """The statistics alone (what SB3's VecNormalize keeps outside the policy)."""
        path = Path(path)
        np.savez(path, mean=self.mean, std=self.std, eps=np.array(self.eps))
        return path

    @classmethod
    def load(cls, path) -> Normalizer:
        with np.load(path) as f:
            return cls(f["mean"], f["std"], float(f["eps"]))


class RunningNormalizer:
    """Running mean and variance of every observation seen (Welford, batched), as ARS V2 keeps."""

    def __init__(self, n: int):
        self.n = int(n)
        self.count = 0
        self.mean = np.zeros(self.n)
        self._m2 = np.zeros(self.n)

    def update(self, batch) -> None:
        batch = np.asarray(batch, dtype=float).reshape(-1, self.n)
        k = len(batch)
        if k == 0:
            return
        bmean = batch.mean(axis=0)
        bm2 = ((batch - bmean) ** 2).sum(axis=0)
        delta = bmean - self.mean
        total = self.count + k
        self.mean = self.mean + delta * (k / total)
        self._m2 = self._m2 + bm2 + delta ** 2 * (self.count * k / total)
        self.count = total

    @property
    def std(self) -> np.ndarray:
        if self.count < 2:
            return np.full(self.n, 1.0 - EPS)
        return np.sqrt(self._m2 / self.count)

    def frozen(self) -> Normalizer:
        return Normalizer(self.mean, self.std)


@dataclass
class MLPPolicy:
    """``actions = MLP(normalizer(obs))``: ``layers`` is [(W (out x in), b (out,)), ...],
    ``activation`` between layers (none after the last). ``meta`` carries the training setup
    (env name and config) so a deployment can check it matches."""

    layers: list
    normalizer: Normalizer | None = None
    activation: str = "elu"
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.activation not in ACTIVATIONS:
            raise ValueError(f"activation {self.activation!r} is not one of {ACTIVATIONS}")
        if not self.layers:
            raise ValueError("an MLPPolicy needs at least one (W, b) layer")
        self.layers = [(np.asarray(w, dtype=float), np.asarray(b, dtype=float)) for w, b in self.layers]
        for i, (w, b) in enumerate(self.layers):
            if w.ndim != 2 or b.shape != (w.shape[0],):
                raise ValueError(f"layer {i}: W {w.shape} must be (out, in) and b {b.shape} must be (out,)")
            if i and w.shape[1] != self.layers[i - 1][0].shape[0]:
                raise ValueError(f"layer {i} takes {w.shape[1]} inputs but layer {i - 1} gives "
                                 f"{self.layers[i - 1][0].shape[0]}")
        if self.normalizer is not None and self.normalizer.mean.shape != (self.obs_size,):
            raise ValueError(f"normalizer has {self.normalizer.mean.shape[0]} entries; the policy takes {self.obs_size}")

    @property
    def obs_size(self) -> int:
        return self.layers[0][0].shape[1]

    @property
    def act_size(self) -> int:
        return self.layers[-1][0].shape[0]

    @property
    def sizes(self) -> list[int]:
        return [self.obs_size] + [w.shape[0] for w, _ in self.layers]

    def __call__(self, obs) -> np.ndarray:
        x = np.asarray(obs, dtype=float)
        if self.normalizer is not None:
            x = self.normalizer.normalize(x)
        last = len(self.layers) - 1
        for i, (w, b) in enumerate(self.layers):
            x = x @ w.T + b
            if i < last:
                x = _act(self.activation, x)
        return x

    @classmethod
    def random(cls, sizes=(48, 256, 256, 12), activation: str = "elu", seed: int = 0) -> MLPPolicy:
        """A randomly initialised MLP (PyTorch's default uniform(+-1/sqrt(fan_in)))."""
        rng = np.random.default_rng(seed)
        layers = []
        for n_in, n_out in zip(sizes[:-1], sizes[1:]):
            k = 1.0 / np.sqrt(n_in)
            layers.append((rng.uniform(-k, k, (n_out, n_in)), rng.uniform(-k, k, n_out)))
        return cls(layers, activation=activation)

    def save(self, path) -> Path:
        path = Path(path)
        arrays = {f"W{i}": w for i, (w, _) in enumerate(self.layers)}
        arrays.update({f"b{i}": b for i, (_, b) in enumerate(self.layers)})
        if self.normalizer is not None:
            arrays.update(norm_mean=self.normalizer.mean, norm_std=self.normalizer.std,
                          norm_eps=np.array(self.normalizer.eps))
        arrays["info"] = np.array(json.dumps({"activation": self.activation, "meta": self.meta}))
        np.savez(path, **arrays)
        return path

    @classmethod
    def load(cls, path) -> MLPPolicy:
        with np.load(path) as f:
            info = json.loads(str(f["info"]))
            n = sum(1 for k in f.files if k.startswith("W"))
            layers = [(f[f"W{i}"], f[f"b{i}"]) for i in range(n)]
            norm = Normalizer(f["norm_mean"], f["norm_std"], float(f["norm_eps"])) if "norm_mean" in f.files else None
        return cls(layers, norm, info["activation"], info.get("meta", {}))


def widened(policy: MLPPolicy, hidden=(1024, 1024), seed: int = 0) -> MLPPolicy:
    """The same linear policy computed by a ReLU MLP with ``hidden`` layers: same outputs, a bigger bill.

    For measuring what inference *cost* does to a deployment without training a bigger network:
    ``relu(z) - relu(-z) = z`` carries the linear policy's ``z = W x + b`` through every hidden
    layer in 2 x act_size units (identity blocks); the other units get random weights, are
    computed like any network's and never reach the output. The outputs equal the original's
    up to float rounding; the cost is that of an MLP of these sizes (legged robots' actors are
    512-256-128, rsl_rl's defaults).
    """
    if len(policy.layers) != 1:
        raise ValueError(f"widened() takes a linear policy (one layer); this one has {len(policy.layers)}")
    (w, b), = policy.layers
    m, n_in = w.shape
    sizes = [int(h) for h in hidden]
    if not sizes or min(sizes) < 2 * m:
        raise ValueError(f"hidden={hidden!r}: every hidden layer needs at least {2 * m} units (2 x the actions)")
    rng = np.random.default_rng(seed)
    layers = []
    prev = n_in
    for k, h in enumerate(sizes):
        s = 1.0 / np.sqrt(prev)
        wk, bk = rng.uniform(-s, s, (h, prev)), rng.uniform(-s, s, h)
        wk[:2 * m] = 0.0
        bk[:2 * m] = 0.0
        if k == 0:
            wk[:m], bk[:m] = w, b
            wk[m:2 * m], bk[m:2 * m] = -w, -b
        else:
            wk[:2 * m, :2 * m] = np.eye(2 * m)
        layers.append((wk, bk))
        prev = h
    out = np.zeros((m, prev))
    out[:, :m], out[:, m:2 * m] = np.eye(m), -np.eye(m)
    layers.append((out, np.zeros(m)))
    return MLPPolicy(layers, policy.normalizer, "relu", dict(policy.meta, widened_from=[n_in, m], hidden=sizes))
