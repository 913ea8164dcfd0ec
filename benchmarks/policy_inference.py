"""Policy inference latency per runtime for the seed's 48-256-256-12 MLP, batch 1, same run.

    python benchmarks/policy_inference.py [--calls 5000] [--repeats 5] [--loop-seconds 3] [--loop-repeats 5]
                                          [--load] [--no-wide]

Rows: numpy (float32 matmuls into preallocated buffers), onnxruntime ``run()``, onnxruntime
``io_binding`` (preallocated, bound once), torch eager (only when torch is installed; it is not a
course requirement). One intra-op thread everywhere. Each repeat times ``calls`` calls of every
runtime, interleaved runtime by runtime so a burst of load from other processes hits all rows;
the table shows the median over repeats of each repeat's p50 and p99 (min..max of the p99 in
brackets) and the ratio of each p50 to numpy's. The "reference VM" columns are figures measured
elsewhere (a 2-vCPU VM, shared/reference/rl_deploy.md), printed beside ours as a label, not as
a baseline: the seed's own LibTorch-vs-ONNX-Runtime table is not available to us.

Second table: the CRISP deployment's 500 Hz control loop (``PolicyDeployment.run_realtime``)
with no policy (the baseline) and with the brain in each placement: inside the control loop,
in a thread of the same process, in a process of its own; for the shipped reach policy and
for the same policy computed by a 2048-2048 ReLU network (``rl.policy.widened``: same
actions, about a third of the period per inference). ``robocourse.rt.repeat.measure_rounds``
runs every row once per round in alternating order; cells are median [lowest-highest] over
the rounds; the sentences below the table are ``Repeated.claim``'s verdicts against the
baseline of the same run. ``--load`` runs everything under chapter 1's CPU load (two busy
processes pinned to one CPU).

Example (2 CPUs shared with other jobs, root so the control thread is SCHED_FIFO 80, 3 s x 5
rounds): quiet, every placement of the shipped policy stays near the baseline's wake-up p99
(about 1 us) but the brain thread gave 17 overruns in one round; under load the brain thread's
wake-up p99 was 1626 us (median; 1.7 to 95075 us) with 15 overruns (1 to 147) against the
baseline's 1.1 us and 2, while in the loop (1.1 us, 0) and in its own process (2.3 us, 0)
stayed at the baseline: the GIL, held by a brain thread the scheduler had preempted, made the
FIFO control thread wait.
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
    ap.add_argument("--loop-repeats", type=int, default=5)
    ap.add_argument("--load", action="store_true", help="run under chapter 1's CPU load (2 busy processes)")
    ap.add_argument("--no-wide", action="store_true", help="skip the 2048-2048 network rows")
    args = ap.parse_args(argv)
    if args.load:
        from robocourse.rt.disturb import CpuLoad

        with CpuLoad(processes=2):
            return _run(args)
    return _run(args)


def _run(args) -> int:
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
        deployment_loop(args.loop_seconds, args.loop_repeats, wide=not args.no_wide)
    return 0


def deployment_loop(seconds: float, repeats: int, wide: bool = True) -> None:
    """The 500 Hz control loop with no brain / the brain in the loop, in a thread, in a process."""
    from robocourse.rl import shipped
    from robocourse.rl.deployment import PolicyDeployment
    from robocourse.rl.policy import widened
    from robocourse.rt.repeat import measure_rounds

    policy = shipped.load()
    cfg = shipped.env_config(policy)
    files = {"shipped": shipped.paths()["onnx"]}
    tmp = tempfile.TemporaryDirectory()
    if wide:
        files["2048-2048"] = Path(tmp.name) / "wide.onnx"
        export_onnx(widened(policy, (2048, 2048)), files["2048-2048"])

    def experiment(path, placement):
        def run():
            d = PolicyDeployment(OnnxRuntime(path), cfg, zero_torque_s=0.0, move_s=0.2,
                                 placement=placement or "thread")
            return d.run_realtime(seconds, with_policy=placement is not None)
        return run

    rows = {"no policy (baseline)": experiment(files["shipped"], None)}
    for label, path in files.items():
        for placement in ("in_loop", "thread", "process"):
            rows[f"{label}: {placement}"] = experiment(path, placement)
    inference = {}

    def keep(name, run):
        if len(run.inference_us):
            inference.setdefault(name, []).append(float(np.median(run.inference_us)))

    rep = measure_rounds(rows, rounds=repeats, between=keep)
    print(f"\ndeployment loop at 500 Hz (UR5e MujocoSystem + controller manager), {seconds} s x {repeats} rounds, "
          f"policy in onnxruntime io_binding; control thread: {rep.last('no policy (baseline)').thread_report.applied_policy}")
    print(rep.table(("p50", "p99", "max", "busy p99")))
    print(rep.table(("overruns",), scale=1.0, unit="", digits=0))
    print("inference p50 (us, median over rounds): " + ", ".join(f"{k} {statistics.median(v):.0f}"
                                                                  for k, v in inference.items()))
    for name in rows:
        if name != "no policy (baseline)":
            for metric in ("p99", "overruns"):
                c = rep.claim(name, "no policy (baseline)", metric, scale=1e-3 if metric == "p99" else 1.0,
                              unit="us" if metric == "p99" else "", digits=1 if metric == "p99" else 0)
                print(" -", c.text.replace("**", ""))
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    tmp.cleanup()


if __name__ == "__main__":
    sys.exit(main())
