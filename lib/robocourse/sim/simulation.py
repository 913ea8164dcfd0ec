"""A fixed-step MuJoCo simulation with a controller called every ``control_period``.

Counterpart of a ros2_control loop around a simulator (gz_ros2_control / mujoco_ros2_control):
read state, call the controller, write the actuator, step physics ``substeps`` times. Returns
numpy arrays ready for plotting, and can draw each control step into a recording.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Trace:
    t: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray


def run(model, data, controller, duration: float, control_period: float | None = None, drawer=None,
        draw_every: int = 1) -> Trace:
    """Simulate ``duration`` seconds; ``controller(t, data) -> ctrl array`` (or None to keep ctrl)."""
    import mujoco

    dt = model.opt.timestep
    period = control_period or dt
    substeps = int(round(period / dt))
    if substeps < 1 or abs(substeps * dt - period) > 1e-9:
        raise ValueError(f"control_period {period} must be a whole multiple of the model timestep {dt}")
    n = int(round(duration / period))
    t, qpos, qvel, ctrl = np.empty(n), np.empty((n, model.nq)), np.empty((n, model.nv)), np.empty((n, model.nu))
    mujoco.mj_forward(model, data)
    for k in range(n):
        u = controller(data.time, data)
        if u is not None:
            u = np.asarray(u, dtype=float).reshape(model.nu)
            if not np.all(np.isfinite(u)):
                raise ValueError(f"controller returned a non-finite command {u.tolist()} at t={data.time:.4f} s")
            data.ctrl[:] = u
        t[k], qpos[k], qvel[k], ctrl[k] = data.time, data.qpos, data.qvel, data.ctrl
        if drawer is not None and k % draw_every == 0:
            drawer.scene.set_time(data.time)
            drawer.update(data)
        for _ in range(substeps):
            mujoco.mj_step(model, data)
    return Trace(t, qpos, qvel, ctrl)
