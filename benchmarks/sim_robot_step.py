"""The cost of one RobotSim.step() for the UR5e + gripper beside a bare mujoco.mj_step.

Same run, same process, rounds interleaved so machine load hits every variant alike. Each
physics step is timed on its own (perf_counter_ns around the call); figures are the median and
p99 over all steps of all rounds, in microseconds, and the ratio to the bare mj_step on the
same compiled model (same actuators, sensors and contacts, no Python around it).

Variants:
- ``mj_step (URDF only)``: MuJoCo's model straight from ur5e.urdf, no actuators or floor.
- ``mj_step (same model)``: bare mujoco.mj_step on RobotSim's compiled model and a copy of its data.
- ``RobotSim.step() position``: all joints in position mode, gravity feed-forward on (the default).
- ``RobotSim.step() effort``: all joints in effort mode at zero command (no feed-forward copy),
  gravity switched off in its model so the arm stays at the same pose without contacts, as the
  other variants do.

    .venv/bin/python benchmarks/sim_robot_step.py [--rounds 10] [--steps 2000]
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from robocourse.sim.robots import RobotSim, urdf_path


def timed(call, steps: int) -> np.ndarray:
    out = np.empty(steps)
    clock = time.perf_counter_ns
    for k in range(steps):
        t0 = clock()
        call()
        out[k] = clock() - t0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--steps", type=int, default=2000)
    args = ap.parse_args(argv)

    urdf_model = mujoco.MjModel.from_xml_path(str(urdf_path("ur5e")))
    urdf_data = mujoco.MjData(urdf_model)
    pos = RobotSim("ur5e")
    eff = RobotSim("ur5e")
    eff.set_mode(eff.joint_names, "effort")
    eff.model.opt.gravity[:] = 0.0
    same_model, same_data = pos.model, mujoco.MjData(pos.model)
    same_data.qpos[:] = pos.data.qpos
    same_data.ctrl[:] = pos.data.ctrl
    urdf_data.qpos[:] = pos.data.qpos[:urdf_model.nq]

    variants = {
        "mj_step (URDF only)": lambda: mujoco.mj_step(urdf_model, urdf_data),
        "mj_step (same model)": lambda: mujoco.mj_step(same_model, same_data),
        "RobotSim.step() position": pos.step,
        "RobotSim.step() effort": eff.step,
    }
    samples: dict[str, list[np.ndarray]] = {k: [] for k in variants}
    for _ in range(args.rounds):
        for name, call in variants.items():
            samples[name].append(timed(call, args.steps))
    base = np.median(np.concatenate(samples["mj_step (same model)"])) / 1e3
    print(f"UR5e + gripper, timestep {pos.model.opt.timestep * 1e3:g} ms, {args.rounds} rounds x {args.steps} "
          f"steps, each step timed alone (machine shared and noisy: compare ratios, not absolutes)")
    print(f"{'variant':28s} {'median us':>10s} {'p99 us':>10s} {'ratio':>7s}")
    for name, chunks in samples.items():
        us = np.concatenate(chunks) / 1e3
        med = np.median(us)
        print(f"{name:28s} {med:10.1f} {np.percentile(us, 99):10.1f} {med / base:7.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
