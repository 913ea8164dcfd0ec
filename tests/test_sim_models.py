"""MuJoCo models agree with the demos' equations; the fixed-step loop validates its input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robocourse.pendulum import cartpole
from robocourse.pendulum.physics import GRAVITY
from robocourse.sim import models, run

mujoco = pytest.importorskip("mujoco")


def _demo_derivatives_from_mujoco(model, data, x, u):
    models.set_cartpole_state(model, data, x)
    data.ctrl[0] = u
    mujoco.mj_forward(model, data)
    return np.array([data.qvel[0], data.qacc[0], -data.qvel[1], -data.qacc[1]])


@pytest.mark.parametrize("x, u", [(cartpole.UPRIGHT, 0.0), ((0.3, 0.1, math.pi - 0.2, 0.5), 5.0), ((-1, 2, 2.0, -1), -40.0)])
def test_mujoco_cartpole_matches_brunton_equations(x, u):
    m = models.cartpole()
    d = mujoco.MjData(m)
    np.testing.assert_allclose(_demo_derivatives_from_mujoco(m, d, np.array(x, float), u),
                               cartpole.derivatives(np.array(x, float), u, cartpole.CartPoleParams()), atol=1e-8)


def test_mujoco_pendulum_falls_at_g_over_l():
    m = models.pendulum()
    d = mujoco.MjData(m)
    d.qpos[0] = 1e-3
    mujoco.mj_forward(m, d)
    assert d.qacc[0] / 1e-3 == pytest.approx(GRAVITY / 0.5, rel=1e-4)
    assert models.seed_angle(0.0) == math.pi / 2


def test_lqr_balances_the_mujoco_cartpole():
    m = models.cartpole(timestep=0.001)
    d = mujoco.MjData(m)
    models.set_cartpole_state(m, d, (0.0, 0.0, math.pi - 0.2, 0.0))
    K = cartpole.lqr_gain()
    trace = run(m, d, lambda t, data: -K @ (models.cartpole_state(data) - cartpole.UPRIGHT), duration=6.0,
                control_period=0.001)
    assert abs(models.cartpole_state(d)[2] - math.pi) < 0.02
    assert np.max(np.abs(trace.ctrl)) <= 1000.0 and len(trace.t) == 6000


def test_run_rejects_bad_periods_and_commands():
    m = models.cartpole(timestep=0.001)
    d = mujoco.MjData(m)
    with pytest.raises(ValueError, match="whole multiple"):
        run(m, d, lambda t, data: None, 0.01, control_period=0.0015)
    with pytest.raises(ValueError, match="non-finite command"):
        run(m, d, lambda t, data: [float("nan")], 0.01)
