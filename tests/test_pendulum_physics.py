"""The seed's pendulum and PID, the textbook PID, the cart-pole, LQR and the delay margin."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robocourse.pendulum import analysis, cartpole
from robocourse.pendulum.physics import GRAVITY, PendulumPhysics, PendulumProperties, PendulumState
from robocourse.pendulum.pid import INVALID_DT, NAN_RESULT, NAN_SENSOR, SeedPID, TextbookPID


def test_growth_rate_near_upright_is_sqrt_g_over_l():
    """A small deviation d from upright grows like d0 cosh(sqrt(g/L) t) (linearized solution)."""
    sim = PendulumPhysics(state=PendulumState(position=math.pi / 2 + 1e-6))
    dt, n = 1e-4, 5000  # 0.5 s, still tiny
    for _ in range(n):
        sim.step(dt)
    lam = math.sqrt(GRAVITY / 0.5)
    predicted = 1e-6 * math.cosh(lam * n * dt)
    assert sim.state.position - math.pi / 2 == pytest.approx(predicted, rel=2e-3)
    assert analysis.growth_rate() == pytest.approx(lam)


def test_semi_implicit_euler_step_by_hand():
    sim = PendulumPhysics(state=PendulumState(position=1.0, velocity=0.5))
    a = GRAVITY * math.sin(1.0 - math.pi / 2) / 0.5
    v = 0.5 + a * 0.001
    sim.step(0.001)
    assert sim.state.acceleration == pytest.approx(a) and sim.state.velocity == pytest.approx(v)
    assert sim.state.position == pytest.approx(1.0 + v * 0.001)  # uses the NEW velocity


def test_angle_is_clamped_and_velocity_kept():
    sim = PendulumPhysics(state=PendulumState(position=0.001, velocity=-5.0))
    sim.step(0.001)
    assert sim.state.position == 0.0 and sim.state.velocity < -5.0
    sim.command(4.0)
    assert sim.state.position == math.pi
    sim.command(-1.0)
    assert sim.state.position == 0.0


def test_nan_errors_are_the_seeds():
    sim = PendulumPhysics()
    with pytest.raises(RuntimeError, match="^Tried to set state to NaN in on_command_message callback$"):
        sim.command(float("nan"))
    sim.state.velocity = float("nan")
    with pytest.raises(RuntimeError, match="Tried to set state to NaN"):
        sim.step(0.001)
    with pytest.raises(ValueError, match="length must be a positive"):
        PendulumProperties(length=0)


def test_seed_pid_defaults_and_hand_computed_steps():
    pid = SeedPID(0.00096)
    assert (pid.p, pid.i, pid.d, pid.command) == (1.0, 0.0, 0.0, math.pi / 2)
    assert pid.update(1.0) == pytest.approx(math.pi / 2)  # p = 1: command = position + (setpoint - position)
    pid = SeedPID(0.5, p=0.5, i=2.0, d=0.1, command=1.5)
    # step 1: e = 0.5; p = 0.25; i = 2 * (0 + 0.5 * 0.5) = 0.5; d = 0.1 * (0.5 - 0) / 0.5 = 0.1
    assert pid.update(1.0) == pytest.approx(1.0 + 0.25 + 0.5 + 0.1)
    # step 2: e = 0.3; p = 0.15; i = 2 * (0.5 + 0.3 * 0.5) = 1.3 (compounding); d = 0.1 * (0.3 - 0.5) / 0.5 = -0.04
    assert pid.update(1.2) == pytest.approx(min(math.pi, 1.2 + 0.15 + 1.3 - 0.04))
    assert pid.i_term == pytest.approx(1.3)


def test_textbook_integral_sums_where_the_seed_compounds():
    seed, book = SeedPID(0.1, p=0.0, i=0.5, command=1.0), TextbookPID(0.0, ki=0.5, setpoint=1.0)
    for _ in range(3):
        seed.update(0.5)
        book.update(0.5, 0.1)
    # seed: i_k = 0.5 * (i_{k-1} + 0.05) -> 0.025, 0.025, 0.03125... textbook: ki * sum(e dt) = 0.5 * 0.15
    assert seed.i_term == pytest.approx(0.5 * (0.5 * (0.5 * 0.05 + 0.05) + 0.05))
    assert book.ki * book.integral == pytest.approx(0.075)


def test_seed_pid_errors():
    for bad in (0, float("nan")):
        with pytest.raises(RuntimeError, match=f"^{INVALID_DT}$"):
            SeedPID(bad)
    pid = SeedPID(0.001)
    with pytest.raises(RuntimeError, match=f"^{NAN_SENSOR}$"):
        pid.update(float("nan"))
    pid = SeedPID(0.001, p=float("inf"))
    with pytest.raises(RuntimeError, match=f"^{NAN_RESULT}$"):
        pid.update(math.pi / 2)  # inf * 0 = NaN


def test_anti_windup_stops_integrating_in_saturation():
    windup, guarded = (TextbookPID(1.0, ki=5.0, setpoint=10.0, u_min=-1, u_max=1, anti_windup=w) for w in (False, True))
    for _ in range(100):
        windup.update(0.0, 0.01)
        guarded.update(0.0, 0.01)
    assert windup.integral == pytest.approx(10.0) and guarded.integral == 0.0
    # the target is reached: the guarded controller releases at once, the wound-up one stays saturated
    assert guarded.update(10.0, 0.01) == pytest.approx(0.0) and windup.update(10.0, 0.01) == 1.0


def test_linearization_matches_finite_differences():
    A, B = cartpole.linearize()
    An, Bn = cartpole.numeric_jacobian()
    np.testing.assert_allclose(A, An, atol=1e-6)
    np.testing.assert_allclose(B, Bn, atol=1e-6)


def test_lqr_gain_matches_the_issue_and_its_poles():
    K = cartpole.lqr_gain()
    np.testing.assert_allclose(K, [-10.0, -53.68, 369.55, 162.70], atol=0.01)
    poles = cartpole.closed_loop_poles(K)
    assert np.all(poles.real < 0)
    import control

    A, B = cartpole.linearize()
    _, _, E = control.lqr(A, B, np.eye(4), 0.01)
    np.testing.assert_allclose(np.sort_complex(poles), np.sort_complex(E), atol=1e-8)
    assert np.all(cartpole.closed_loop_poles(cartpole.DEMO_K).real < 0)


@pytest.mark.parametrize("K", [cartpole.DEMO_K, None], ids=["demo_K", "lqr_K"])
def test_controller_recovers_from_0_2_rad_in_the_nonlinear_model(K):
    K = cartpole.lqr_gain() if K is None else K
    run = cartpole.simulate(K, x0=(0.0, 0.0, math.pi - 0.2, 0.0), duration=8.0)
    assert not run.fell
    assert abs(run.states[-1, 2] - math.pi) < 0.02 and abs(run.states[-1, 0]) < 0.3


def test_delay_margin_prediction_matches_simulation():
    dm = analysis.delay_margin()
    assert 0.2 < dm < 0.26  # about 0.229 s for the demo's gain
    crit = analysis.critical_delay(tol=0.01)
    # the sampled loop adds about half a period of delay: the two agree within 5 %
    assert crit == pytest.approx(dm, rel=0.05)
    assert not cartpole.simulate(latencies_ns=[0.8 * dm * 1e9], duration=10, period=0.002, seed=None,
                                 x0=(0, 0, math.pi - 0.05, 0)).fell


def test_overruns_delay_every_later_write():
    run = cartpole.simulate(duration=0.01, period=0.001, latencies_ns=[0, 2_500_000, 0, 0, 0], seed=None)
    # k=1 writes at 3.5 ms; k=2 and k=3 cannot write before it
    np.testing.assert_allclose(run.applied_at[:5], [0.0, 0.0035, 0.0035, 0.0035, 0.004])


def test_bad_simulation_input_is_clear():
    with pytest.raises(ValueError, match="latencies_ns"):
        cartpole.simulate(latencies_ns=[np.nan])
    with pytest.raises(ValueError, match="period"):
        cartpole.simulate(period=0)
    with pytest.raises(ValueError, match="pole_mass"):
        cartpole.CartPoleParams(pole_mass=-1)


def test_pendulum_plant_has_the_unstable_pole():
    G = analysis.pendulum_plant()
    assert max(np.real(G.poles())) == pytest.approx(analysis.growth_rate())


def test_jitter_settled_start_with_noise_and_perfect_timing_never_falls():
    from robocourse.pendulum import jitter

    r = jitter.trials(np.zeros((6, 400)), seeds=range(6), duration=0.4, substeps=5)
    assert r.falls == 0 and r.n == 6
    assert 0 < r.max_error_after_settle.max() < 1e-3  # the noise moves it, a little


def test_jitter_sustained_delay_over_margin_topples_a_short_stall_does_not():
    from robocourse.pendulum import analysis, jitter

    p, K = jitter.fast_design()
    dm = analysis.delay_margin(K, p)
    assert dm == pytest.approx(3.37e-3, abs=2e-5)
    n = 700
    stretch = np.stack([jitter.stretch_trace(n, 100, 400, 2 * dm * 1e9)] * 3)
    spike = np.stack([jitter.spike_trace(n, 100, 30e6)] * 3)
    r = jitter.trials(np.vstack([stretch, spike]), seeds=range(6), duration=0.7, substeps=5)
    assert r.fell.tolist() == [True, True, True, False, False, False]
    assert np.all(r.fell_at[:3] > 0.1)  # during the stretch, not in a start-up transient


def test_jitter_trials_are_reproducible_per_seed():
    from robocourse.pendulum import jitter

    lat = np.stack([jitter.stretch_trace(300, 50, 100, 5e6)] * 2)
    a = jitter.trials(lat, seeds=[7, 8], duration=0.3, substeps=4)
    b = jitter.trials(lat, seeds=[7, 8], duration=0.3, substeps=4)
    assert np.array_equal(a.max_error_after_settle, b.max_error_after_settle)
    assert a.max_error_after_settle[0] != a.max_error_after_settle[1]


def test_wilson_interval_matches_the_formula():
    from robocourse.pendulum.jitter import wilson

    lo, hi = wilson(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson(5, 10)
    assert (lo, hi) == (pytest.approx(0.2366, abs=1e-4), pytest.approx(0.7634, abs=1e-4))
    with pytest.raises(ValueError, match="0 <= k <= n"):
        wilson(3, 2)


def test_windows_keep_measured_order_and_tile_short_traces():
    from robocourse.pendulum.jitter import windows

    w = windows(np.arange(10) * 1000, n=25, count=4, rng=np.random.default_rng(0))
    assert w.shape == (4, 25)
    steps = np.diff(w, axis=1)
    assert set(np.unique(steps)) <= {1000.0, -9000.0}  # consecutive samples, wrapping at the trace's end


@pytest.mark.parametrize("kwargs,fragment", [
    ({"latencies_ns": np.zeros((2, 100)), "seeds": [1]}, "one seed per trial: 2 traces but 1 seeds"),
    ({"latencies_ns": np.zeros((1, 50)), "seeds": [1]}, "needs 100: pass longer traces"),
    ({"latencies_ns": -np.ones((1, 100)), "seeds": [1]}, "finite and >= 0"),
    ({"latencies_ns": np.zeros((1, 100)), "seeds": [1], "substeps": 0}, "substeps=0"),
])
def test_jitter_trials_refuse_bad_input(kwargs, fragment):
    from robocourse.pendulum import jitter

    with pytest.raises(ValueError, match=fragment):
        jitter.trials(duration=0.1, **kwargs)


@pytest.mark.parametrize("kwargs,fragment", [
    ({"period_s": -0.001}, r"SeedPID\(period_s=-0.001\): the controller period is a positive"),
    ({"period_s": float("inf")}, "positive, finite"),
    ({"period_s": 0.001, "p": float("nan")}, r"SeedPID\(p=nan\)"),
])
def test_seed_pid_refuses_bad_values_with_the_rule(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        SeedPID(**kwargs)


@pytest.mark.parametrize("kwargs,fragment", [
    ({"Q": np.eye(3)}, r"Q with shape \(3, 3\).*has 4 entries, so Q is 4x4"),
    ({"Q": -np.eye(4)}, "positive semi-definite"),
    ({"Q": np.triu(np.ones((4, 4)))}, "symmetric"),
    ({"R": 0}, r"R=0.0\): the cart-pole has one input, so R is one positive, finite number"),
    ({"R": -1.0}, "one positive, finite number"),
    ({"R": [[1, 0], [0, 1]]}, "one positive"),
])
def test_lqr_gain_refuses_bad_weights_before_calling_python_control(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        cartpole.lqr_gain(**kwargs)


@pytest.mark.parametrize("kwargs,fragment", [
    ({"K": [1, 2, 3]}, r"K=\[1, 2, 3\]: need 4 finite numbers, one per state"),
    ({"K": [1, 2, 3, float("nan")]}, "need 4 finite numbers"),
    ({"x0": (0, 0, 3.0)}, "x0=.*need 4 finite numbers"),
    ({"duration": -1.0}, r"simulate\(duration=-1.0\): a positive, finite number of seconds"),
    ({"period": 0.0}, r"simulate\(period=0.0\)"),
])
def test_simulate_refuses_bad_arguments_with_the_rule(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        cartpole.simulate(**kwargs)
