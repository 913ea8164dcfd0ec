"""Policy runtimes with one interface: ``rt(obs) -> actions`` (float32 views, reused buffers).

Counterparts: rl_sar's inference_runtime (ONNX Runtime or LibTorch chosen by file extension,
intra-op threads 1) and unitree's TorchScript ``policy(obs)``.

- :class:`NumpyRuntime`: the MLPPolicy's weights as float32 numpy matmuls into preallocated
  buffers;
- :class:`OnnxRuntime`: ``onnxruntime.InferenceSession`` on the CPU provider with one intra-op
  and one inter-op thread; ``io_binding=True`` binds preallocated input/output buffers once
  (``run_with_iobinding``), ``False`` calls ``session.run`` each time;
- :class:`TorchRuntime`: the same MLP as ``torch.nn.Sequential`` under ``torch.inference_mode``,
  only when torch is installed (it is not a course requirement).

Every runtime checks its input before running: size (``ValueError`` naming expected and got)
and finiteness (``ValueError`` naming the indices of the NaN/inf entries). The returned array is
the runtime's own output buffer, overwritten by the next call: copy it to keep it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .policy import MLPPolicy


class PolicyRuntime:
    """Base: ``obs_size``, ``act_size``, ``name``; ``__call__(obs)`` validates then runs ``_run``."""

    name = "runtime"

    def __init__(self, obs_size: int, act_size: int):
        self.obs_size, self.act_size = int(obs_size), int(act_size)
        self._in = np.zeros((1, self.obs_size), dtype=np.float32)
        self.calls = 0

    def __call__(self, obs) -> np.ndarray:
        obs = np.asarray(obs)
        if obs.size != self.obs_size:
            raise ValueError(f"observation has {obs.size} values; this policy takes {self.obs_size} "
                             "(check the observation layout against the training env)")
        self._in[0] = obs.reshape(-1)
        total = float(self._in.sum())
        bad = np.flatnonzero(~np.isfinite(self._in[0])).tolist() if total - total != 0.0 else None
        if bad:  # (a sum that overflowed on large finite values leaves bad empty: run)
            raise ValueError(f"observation has non-finite values at indices {bad}: refusing to run the policy "
                             "(a sensor failed; hold the last command or enter the safe mode)")
        self.calls += 1
        return self._run()

    def _run(self) -> np.ndarray:
        raise NotImplementedError


class NumpyRuntime(PolicyRuntime):
    """The numpy policy in float32 with preallocated layer buffers (the normalizer applied first)."""

    name = "numpy"

    def __init__(self, policy: MLPPolicy):
        super().__init__(policy.obs_size, policy.act_size)
        n = policy.normalizer
        self._mean = (n.mean if n is not None else np.zeros(policy.obs_size)).astype(np.float32)
        self._den = (n.std + n.eps if n is not None else np.ones(policy.obs_size)).astype(np.float32)
        self._wt = [np.ascontiguousarray(w.T, dtype=np.float32) for w, _ in policy.layers]
        self._b = [b.astype(np.float32) for _, b in policy.layers]
        self._h = [np.zeros((1, w.shape[0]), dtype=np.float32) for w, _ in policy.layers]
        self._act = policy.activation

    def _run(self) -> np.ndarray:
        x = self._in
        np.subtract(x, self._mean, out=x)
        np.divide(x, self._den, out=x)
        last = len(self._wt) - 1
        for i, (wt, b, h) in enumerate(zip(self._wt, self._b, self._h)):
            np.matmul(x, wt, out=h)
            h += b
            if i < last:
                if self._act == "elu":
                    neg = np.minimum(h, 0.0)
                    np.expm1(neg, out=neg)
                    np.maximum(h, 0.0, out=h)
                    h += neg
                elif self._act == "tanh":
                    np.tanh(h, out=h)
                else:
                    np.maximum(h, 0.0, out=h)
            x = h
        return x[0]


class OnnxRuntime(PolicyRuntime):
    """An exported policy (input "obs" [1, n], output "actions" [1, m], float32) in onnxruntime."""

    def __init__(self, path, io_binding: bool = True, input_name: str = "obs", output_name: str = "actions"):
        import onnxruntime as ort

        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such ONNX file (export one with robocourse.rl.export_onnx)")
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = 1
        opts.inter_op_num_threads = 1
        opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
        sess = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
        ins, outs = sess.get_inputs(), sess.get_outputs()
        names = [i.name for i in ins]
        if names != [input_name]:
            raise ValueError(f"{path.name}: inputs {names}, expected exactly [{input_name!r}] (IsaacLab's exporter "
                             f"name); re-export with input_names=[{input_name!r}] or pass input_name={names[0]!r}")
        if [o.name for o in outs][:1] != [output_name]:
            raise ValueError(f"{path.name}: first output {outs[0].name!r}, expected {output_name!r}; re-export with "
                             f"output_names=[{output_name!r}] or pass output_name={outs[0].name!r}")
        shape_in, shape_out = ins[0].shape, outs[0].shape
        if len(shape_in) != 2 or shape_in[0] != 1 or not isinstance(shape_in[1], int):
            raise ValueError(f"{path.name}: input {input_name!r} has shape {shape_in}; expected [1, n] with a fixed n")
        if ins[0].type != "tensor(float)":
            raise ValueError(f"{path.name}: input type {ins[0].type}; expected tensor(float) (float32)")
        if len(shape_out) != 2 or not isinstance(shape_out[1], int):
            raise ValueError(f"{path.name}: output {output_name!r} has shape {shape_out}; expected [1, m]")
        super().__init__(shape_in[1], shape_out[1])
        self.path, self.session, self.io_binding = path, sess, bool(io_binding)
        self.name = "onnxruntime io_binding" if io_binding else "onnxruntime run()"
        self._input_name, self._output_name = input_name, output_name
        self._out = np.zeros((1, self.act_size), dtype=np.float32)
        self._feed = {input_name: self._in}
        if io_binding:
            self._in_value = ort.OrtValue.ortvalue_from_numpy(self._in)    # shares the buffer
            self._out_value = ort.OrtValue.ortvalue_from_numpy(self._out)
            self._binding = sess.io_binding()
            self._binding.bind_ortvalue_input(input_name, self._in_value)
            self._binding.bind_ortvalue_output(output_name, self._out_value)

    def _run(self) -> np.ndarray:
        if self.io_binding:
            self.session.run_with_iobinding(self._binding)
            return self._out[0]
        self._out[:] = self.session.run([self._output_name], self._feed)[0]
        return self._out[0]


def torch_available() -> bool:
    try:
        import torch  # noqa: F401
    except ImportError:
        return False
    return True


class TorchRuntime(PolicyRuntime):
    """The MLP as ``torch.nn.Sequential`` (one thread, inference mode). Needs torch installed."""

    name = "torch"

    def __init__(self, policy: MLPPolicy):
        if not torch_available():
            raise ImportError("torch is not installed (it is optional in this course): use NumpyRuntime or "
                              "OnnxRuntime, or pip install torch to compare")
        import torch

        torch.set_num_threads(1)
        super().__init__(policy.obs_size, policy.act_size)
        act = {"elu": torch.nn.ELU, "tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[policy.activation]
        mods = []
        n = policy.normalizer
        layers = [(w.copy(), b.copy()) for w, b in policy.layers]
        if n is not None:
            from .export import fold_normalizer

            layers[0] = fold_normalizer(*layers[0], n.mean, n.std, n.eps)
        for i, (w, b) in enumerate(layers):
            lin = torch.nn.Linear(w.shape[1], w.shape[0])
            with torch.no_grad():
                lin.weight.copy_(torch.from_numpy(w.astype(np.float32)))
                lin.bias.copy_(torch.from_numpy(b.astype(np.float32)))
            mods.append(lin)
            if i < len(layers) - 1:
                mods.append(act())
        self._torch = torch
        self.model = torch.nn.Sequential(*mods).eval()
        self._tin = torch.from_numpy(self._in)

    def _run(self) -> np.ndarray:
        with self._torch.inference_mode():
            return self.model(self._tin).numpy()[0]


class RecordingRuntime(PolicyRuntime):
    """Another runtime, recording every call: which process and thread ran it, and when.

    For answering "where does my policy run?" (and for graders): one JSON line per call is
    appended to ``call_log`` (``pid``, ``thread`` ident, ``thread_name``, ``t`` = CLOCK_MONOTONIC
    seconds, ``n`` = the call's number). ``stall_after``/``stall_s`` inject a fault: call number
    ``stall_after + 1`` first sleeps ``stall_s`` seconds (a brain that hangs, then recovers).
    """

    def __init__(self, inner: PolicyRuntime, call_log=None, stall_after: int | None = None, stall_s: float = 0.0):
        super().__init__(inner.obs_size, inner.act_size)
        if stall_after is not None and (isinstance(stall_after, bool) or not isinstance(stall_after, int)
                                        or stall_after < 0):
            raise ValueError(f"stall_after={stall_after!r} must be None or an int >= 0 (calls before the stall)")
        if not (isinstance(stall_s, (int, float)) and 0 <= stall_s <= 60):
            raise ValueError(f"stall_s={stall_s!r} must be seconds in [0, 60]")
        self.inner, self.name = inner, inner.name
        self.path = getattr(inner, "path", None)
        self.call_log = None if call_log is None else Path(call_log)
        self.stall_after, self.stall_s = stall_after, float(stall_s)

    def _run(self) -> np.ndarray:
        import json
        import os
        import threading
        import time

        if self.stall_after is not None and self.calls == self.stall_after + 1 and self.stall_s > 0:
            time.sleep(self.stall_s)
        if self.call_log is not None:
            th = threading.current_thread()
            line = json.dumps({"pid": os.getpid(), "thread": threading.get_ident(), "thread_name": th.name,
                               "t": time.monotonic(), "n": self.calls}) + "\n"
            fd = os.open(self.call_log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            try:
                os.write(fd, line.encode())              # one write per line: lines from processes never mix
            finally:
                os.close(fd)
        return self.inner(self._in[0])


def read_call_log(path) -> list[dict]:
    """The records a :class:`RecordingRuntime` appended to ``path`` (empty if there are none). A line still
    being written (no newline yet: another process appends while this one reads) is left for the next read."""
    import json

    path = Path(path)
    if not path.exists():
        return []
    complete = path.read_text().split("\n")[:-1]
    return [json.loads(line) for line in complete if line.strip()]


def load_runtime(path, io_binding: bool = True, call_log=None, stall_after: int | None = None,
                 stall_s: float = 0.0) -> PolicyRuntime:
    """By extension, as rl_sar chooses: ``.onnx`` -> OnnxRuntime, ``.npz`` -> NumpyRuntime.

    ``call_log`` (and ``stall_after``/``stall_s``) wrap it in a :class:`RecordingRuntime`. Every
    argument is plain data, so a process can be told which policy to load with a JSON dict:
    ``load_runtime(**spec["policy"])`` in the process that runs it.
    """
    path = Path(path)
    if path.suffix == ".onnx":
        rt = OnnxRuntime(path, io_binding=io_binding)
    elif path.suffix == ".npz":
        rt = NumpyRuntime(MLPPolicy.load(path))
        rt.path = path
    else:
        raise ValueError(f"{path.name}: unknown policy file type {path.suffix!r}; use .onnx or .npz")
    if call_log is not None or stall_after is not None:
        return RecordingRuntime(rt, call_log, stall_after, stall_s)
    return rt
