"""ARS training time and environment steps to each task's threshold, on this machine, same run.

    python benchmarks/policy_training.py [--seeds 3] [--skip-arm]

Rows: cart-pole (chapter 2's plant, solved at a mean return of 475 over 5 fixed episodes) for
seeds 0..N-1, and the UR5e reach (solved when the mean final TCP distance over 8 fixed targets is
below 5 cm) with the shipped policy's settings (seed 0). Each row: solved or not, iterations, env
steps, wall seconds, and the goal (cart-pole < 10 s, reach < 60 s). Beside them, the figures
measured elsewhere (shared/reference/rl_deploy.md: ARS on gymnasium InvertedPendulum-v5 in
1-3 s, SB3 PPO 100k steps in ~106 s), labelled as such; stable-baselines3 PPO runs here only
when it is installed (it is not a course requirement). Wall times depend on the load from other
processes: the load average is printed with the table.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))

from robocourse.rl import ArmReachConfig, ARSConfig, train_arm_reach, train_cartpole  # noqa: E402
from robocourse.rl.ars import ARM_ARS  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--skip-arm", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    for seed in range(args.seeds):
        r = train_cartpole(ARSConfig(n_directions=4, top=2, step_size=0.1, noise=0.1, seed=seed), progress=False)
        rows.append((f"cart-pole ARS seed {seed}", r, 10.0))
    if not args.skip_arm:
        r = train_arm_reach(ArmReachConfig(), ARM_ARS, progress=False)
        rows.append(("UR5e reach ARS seed 0", r, 60.0))
    print(f"\nARS to threshold; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs "
          "(shared machine: wall times move with other processes' load)")
    print(f"{'task':<26}{'solved':>7}{'iters':>7}{'env steps':>11}{'seconds':>9}{'goal s':>8}  goal")
    for name, r, goal in rows:
        met = "met" if r.solved and r.seconds < goal else "NOT met"
        print(f"{name:<26}{str(r.solved):>7}{r.iterations:>7}{r.env_steps:>11}{r.seconds:9.1f}{goal:8.0f}  {met}")
    print("measured elsewhere (rl_deploy.md, 2-vCPU VM): ARS InvertedPendulum-v5 1-3 s (8k-41k steps, 4 of 5 seeds); "
          "SB3 PPO InvertedPendulum-v5 100k steps ~106 s")
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        print("stable-baselines3: not installed (optional), PPO row omitted")
    return 0


if __name__ == "__main__":
    sys.exit(main())
