"""Policy inference latency per runtime for the seed's 48-256-256-12 MLP, batch 1, same run.

    python benchmarks/policy_inference.py [--calls 5000] [--repeats 5] [--loop-seconds 3] [--loop-repeats 3]

Rows: numpy (float32 matmuls into preallocated buffers), onnxruntime ``run()``, onnxruntime
``io_binding`` (preallocated, bound once), torch eager (only when torch is installed; it is not a
course requirement). One intra-op thread everywhere. Each repeat times ``calls`` calls of every
runtime, interleaved runtime by runtime so a burst of load from other processes hits all rows;
the table shows the median over repeats of each repeat's p50 and p99 (min..max of the p99 in
brackets) and the ratio of each p50 to numpy's. The "reference VM" columns are figures measured
elsewhere (a 2-vCPU VM, shared/reference/rl_deploy.md), printed beside ours as a label, not as
a baseline: the seed's own LibTorch-vs-ONNX-Runtime table is not available to us.

Second table: the CRISP deployment's 500 Hz control loop (``PolicyDeployment.run_realtime``),
wake-up latency with no policy (the baseline), with the policy in its own 50 Hz thread, and with
inference inside the control loop; medians over repeats, interleaved, ratios to the baseline.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one thread for numpy's matmul too (before numpy loads)
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))

from robocourse.rl import (  # noqa: E402
    MLPPolicy,
    Normalizer,
    NumpyRuntime,
    OnnxRuntime,
    TorchRuntime,
    export_onnx,
    torch_available,
)

REFERENCE_VM = {"numpy": (16.8, 38.6), "onnxruntime run()": (18.6, 53.5), "onnxruntime io_binding": (14.5, 43.0),
                "torch": (49.0, 109.0)}  # us, p50/p99 (ranges in the reference: midpoints)


def runtimes(directory: Path) -> list:
    rng = np.random.default_rng(0)
    policy = MLPPolicy.random((48, 256, 256, 12), seed=0)
    policy.normalizer = Normalizer(rng.normal(0, 1, 48), rng.uniform(0.1, 2, 48))
    check = export_onnx(policy, directory / "mlp.onnx")
    print(check)
    rts = [NumpyRuntime(policy), OnnxRuntime(directory / "mlp.onnx", io_binding=False),
           OnnxRuntime(directory / "mlp.onnx", io_binding=True)]
    if torch_available():
        rts.append(TorchRuntime(policy))
    return rts


def time_calls(rt, obs: np.ndarray, calls: int) -> np.ndarray:
    out = np.empty(calls, dtype=np.int64)
    clock = time.perf_counter_ns
    for i in range(calls):
        t0 = clock()
        rt(obs)
        out[i] = clock() - t0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=5000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--loop-seconds", type=float, default=3.0, help="per deployment-loop run (0: skip)")
    ap.add_argument("--loop-repeats", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as d:
        rts = runtimes(Path(d))
        obs = np.random.default_rng(1).normal(size=48).astype(np.float32)
        for rt in rts:
            time_calls(rt, obs, 500)  # warm-up
        p50 = {rt.name: [] for rt in rts}
        p99 = {rt.name: [] for rt in rts}
        for _ in range(args.repeats):
            for rt in rts:
                ns = time_calls(rt, obs, args.calls) / 1e3
                p50[rt.name].append(float(np.percentile(ns, 50)))
                p99[rt.name].append(float(np.percentile(ns, 99)))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"\npolicy inference, MLP 48-256-256-12, batch 1, {args.calls} calls x {args.repeats} repeats; "
          f"load average {load:.1f} on {os.cpu_count()} CPUs (shared machine: tails move run to run)")
    print(f"{'runtime':<24}{'p50 us':>9}{'p99 us':>9}{'  p99 min..max':<20}{'p50/numpy':>10}"
          f"{'ref VM p50':>12}{'ref VM p99':>12}")
    base = statistics.median(p50["numpy"])
    for name in p50:
        m50, m99 = statistics.median(p50[name]), statistics.median(p99[name])
        ref = REFERENCE_VM.get(name, (float("nan"), float("nan")))
        print(f"{name:<24}{m50:9.1f}{m99:9.1f}  {min(p99[name]):7.1f}..{max(p99[name]):<9.1f}{m50 / base:10.2f}"
              f"{ref[0]:12.1f}{ref[1]:12.1f}")
    if not torch_available():
        print("torch: not installed (optional), row omitted")
    goal = statistics.median(p99["onnxruntime io_binding"])
    print(f"goal p99 < 100 us with io_binding: {'met' if goal < 100 else 'NOT met'} ({goal:.1f} us)")
    if args.loop_seconds > 0:
        deployment_loop(args.loop_seconds, args.loop_repeats)
    return 0


def deployment_loop(seconds: float, repeats: int) -> None:
    """The 500 Hz control loop's wake-up latency: no policy / policy thread at 50 Hz / inference in the loop."""
    from robocourse.rl import shipped
    from robocourse.rl.deployment import PolicyDeployment

    policy = shipped.load()
    cfg = shipped.env_config(policy)
    onnx_path = shipped.paths()["onnx"]
    rows = {"no policy (baseline)": dict(with_policy=False), "policy thread 50 Hz": dict(with_policy=True),
            "inference in the RT loop": dict(with_policy=True, inference_in_rt=True)}
    res = {k: [] for k in rows}
    for _ in range(repeats):
        for name, kw in rows.items():
            d = PolicyDeployment(OnnxRuntime(onnx_path), cfg, zero_torque_s=0.0, move_s=0.2,
                                 inference_in_rt=kw.get("inference_in_rt", False))
            r = d.run_realtime(seconds, with_policy=kw["with_policy"])
            lat = np.asarray(r.control.latency_ns, dtype=float) / 1e3
            busy = np.asarray(r.control.busy_ns, dtype=float) / 1e3
            res[name].append((float(np.percentile(lat, 50)), float(np.percentile(lat, 99)), r.control.overruns,
                              r.thread_report.applied_policy, float(np.percentile(busy, 99))))
    print(f"\ndeployment loop at 500 Hz (UR5e MujocoSystem + controller manager), {seconds} s x {repeats} repeats, "
          f"shipped reach policy in onnxruntime io_binding")
    print(f"{'row':<28}{'p50 us':>9}{'p99 us':>10}{'  p99 min..max':<22}{'overruns':>9}{'p99/baseline':>14}"
          f"{'tick p99 us':>13}  sched")
    base = statistics.median([x[1] for x in res["no policy (baseline)"]])
    for name, xs in res.items():
        m50, m99 = statistics.median([x[0] for x in xs]), statistics.median([x[1] for x in xs])
        lo, hi = min(x[1] for x in xs), max(x[1] for x in xs)
        print(f"{name:<28}{m50:9.1f}{m99:10.1f}  {lo:8.1f}..{hi:<10.1f}{statistics.median([x[2] for x in xs]):9.0f}"
              f"{m99 / base:14.2f}{statistics.median([x[4] for x in xs]):13.1f}  {xs[0][3]}")
    ratio = statistics.median([x[1] for x in res["policy thread 50 Hz"]]) / base
    print(f"goal: policy thread keeps p99 within 2x of the baseline: {'met' if ratio <= 2 else 'NOT met'} "
          f"({ratio:.2f}x); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


if __name__ == "__main__":
    sys.exit(main())
