"""robocourse.rl environments, ARS and action post-processing: behaviour with numbers."""

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from robocourse.rl import (
    ActionProcessor,
    ArmReachConfig,
    ArmReachEnv,
    ARSConfig,
    CartPoleEnv,
    RunningNormalizer,
    ema_alpha,
    train_cartpole,
)


def test_envs_pass_gymnasiums_checker():
    check_env(CartPoleEnv(), skip_render_check=True)
    check_env(ArmReachEnv(ArmReachConfig(episode_s=0.2)), skip_render_check=True)


def test_cartpole_reward_is_one_per_upright_step_and_terminates_when_the_pole_falls():
    env = CartPoleEnv()
    obs, _ = env.reset(seed=0)
    assert obs.shape == (4,) and np.all(np.abs(obs) <= 0.05)
    total, steps = 0.0, 0
    while True:
        obs, r, term, trunc, _ = env.step([0.0])
        total += r
        steps += 1
        if term or trunc:
            break
    assert term and not trunc
    assert abs(obs[1]) > 0.2
    assert total == steps - 1  # every step but the falling one
    assert env.dt == pytest.approx(0.02)


def test_arm_reach_observation_layout_is_q_rel_scaled_velocity_target_last_action():
    env = ArmReachEnv(ArmReachConfig(episode_s=0.2))
    obs, _ = env.reset(seed=3, options={"target": env.tcp_default + [0.1, 0.0, 0.0]})
    np.testing.assert_allclose(obs[:6], env.sim.positions[:6] - env.default_pose)
    np.testing.assert_allclose(obs[12:15], [0.1, 0.0, 0.0])
    np.testing.assert_array_equal(obs[15:], np.zeros(6))
    obs, *_ = env.step(np.full(6, 0.2))
    np.testing.assert_allclose(obs[6:12], env.sim.velocities[:6] * 0.05)
    np.testing.assert_allclose(obs[15:], np.full(6, 0.2))
    assert env.max_steps == 10  # 0.2 s at 50 Hz (0.002 s x decimation 10)


def test_arm_reach_target_reaches_the_pd_servo_action_scale_times_action_plus_default():
    env = ArmReachEnv(ArmReachConfig(episode_s=0.2, action_scale=0.25))
    env.reset(seed=0)
    env.step(np.array([1.0, -1.0, 0.5, 0, 0, 3.0]))  # 3.0 clipped to clip_actions 1.0
    np.testing.assert_allclose(env.sim.commands[:6], env.default_pose + 0.25 * np.array([1, -1, 0.5, 0, 0, 1.0]))


def test_actuator_delay_holds_the_old_target_for_the_delay():
    env = ArmReachEnv(ArmReachConfig(episode_s=0.2, actuator_delay=15))
    env.reset(seed=0)
    q_start = env.sim.commands[:6].copy()
    env.step(np.full(6, 0.4))          # due at physics step 15, after this policy step (10)
    np.testing.assert_array_equal(env.sim.commands[:6], q_start)
    env.step(np.zeros(6))
    np.testing.assert_allclose(env.sim.commands[:6], env.default_pose + 0.5 * 0.4)


def test_bad_config_is_refused_with_the_rule():
    with pytest.raises(ValueError, match="decimation=0 must be an int >= 1"):
        ArmReachConfig(decimation=0)
    with pytest.raises(ValueError, match="default_pose has 5 values"):
        ArmReachConfig(default_pose=(0, 0, 0, 0, 0))


def test_running_normalizer_matches_numpy_mean_and_std():
    rng = np.random.default_rng(0)
    data = rng.normal(3.0, 2.0, (1000, 4))
    n = RunningNormalizer(4)
    for chunk in np.array_split(data, 7):
        n.update(chunk)
    np.testing.assert_allclose(n.mean, data.mean(axis=0), atol=1e-12)
    np.testing.assert_allclose(n.std, data.std(axis=0), atol=1e-12)


def test_ars_is_reproducible_with_the_same_seed():
    cfg = ARSConfig(n_directions=2, top=1, max_iterations=3, eval_every=3, seed=5)
    a = train_cartpole(cfg, progress=False, max_steps=50)
    b = train_cartpole(cfg, progress=False, max_steps=50)
    np.testing.assert_array_equal(a.policy.layers[0][0], b.policy.layers[0][0])
    assert a.env_steps == b.env_steps and a.history == b.history


def test_ars_balances_the_cartpole_in_a_short_budget():
    r = train_cartpole(progress=False)  # seed 0: solved in 15 iterations on any machine
    assert r.solved and r.history[-1][2] >= 475
    assert r.policy.layers[0][0].shape == (1, 4) and r.policy.normalizer is not None


def test_ema_alpha_from_cutoff_and_rate():
    assert ema_alpha(10.0, 500.0) == pytest.approx((1 / 10) / (1 / 500 + 1 / 10))


def test_action_processor_scales_filters_and_counts_clipped_targets():
    p = ActionProcessor([0.0, 0.0], 0.5, [-0.3, -1.0], [0.3, 1.0], alpha=0.5)
    out = p(np.array([1.0, 1.0]))           # x = [0.5, 0.5]; y = 0.5*0 + 0.5*x = [0.25, 0.25]
    np.testing.assert_allclose(out, [0.25, 0.25])
    out = p(np.array([1.0, 1.0]))           # y = [0.375, 0.375]; joint 0 clipped to 0.3
    np.testing.assert_allclose(out, [0.3, 0.375])
    assert p.clipped_joint == 1 and p.processed == 2


def test_action_processor_clips_to_the_torque_limit():
    p = ActionProcessor([0.0], 1.0, [-3.0], [3.0], torque_limit=[10.0], kp=[100.0], kd=[0.0])
    out = p(np.array([1.0]), q=np.array([0.0]), dq=np.array([0.0]))  # 100 * 1 rad = 100 N m > 10
    np.testing.assert_allclose(out, [0.1])
    assert p.clipped_torque == 1


def test_action_of_wrong_size_or_nan_is_refused():
    p = ActionProcessor(np.zeros(6), 0.5, -np.ones(6), np.ones(6))
    with pytest.raises(ValueError, match=r"action has shape \(12,\); the robot takes 6"):
        p(np.zeros(12))
    with pytest.raises(ValueError, match=r"non-finite values at indices \[2\]"):
        p(np.array([0, 0, np.nan, 0, 0, 0]))
    assert p.processed == 0


def test_stacked_observation_layouts_put_the_same_numbers_in_different_places():
    from robocourse.rl.envs import CartPoleEnv, StackedObservation

    envs = {lay: StackedObservation(CartPoleEnv(), 3, lay) for lay in ("time", "time_oldest_first", "term")}
    obs = {lay: e.reset(seed=4)[0] for lay, e in envs.items()}
    first = obs["time"][:4]
    np.testing.assert_array_equal(obs["time"], np.tile(first, 3))            # reset: the first frame repeated
    for e in envs.values():
        o, *_ = e.step([0.5])
    o1 = {lay: e.observation(e.env._obs()) for lay, e in envs.items()}      # one more frame of the same state
    newest, older = o1["time"][:4], o1["time"][4:8]
    np.testing.assert_array_equal(o1["time_oldest_first"][8:], newest)
    np.testing.assert_array_equal(o1["term"][[0, 3, 6, 9]], newest)         # each term's history together
    np.testing.assert_array_equal(o1["term"][[1, 4, 7, 10]], older)
    with pytest.raises(ValueError, match="layout='frames' must be one of"):
        StackedObservation(CartPoleEnv(), 3, "frames")


def test_shipped_history_policy_balances_only_with_its_training_layout():
    from robocourse.rl import shipped
    from robocourse.rl.ars import evaluate
    from robocourse.rl.envs import CartPoleEnv, StackedObservation

    pol = shipped.history_policy()
    assert pol.meta["history"] == 3 and pol.meta["history_layout"] == "time" and pol.obs_size == 12
    (w, _), = pol.layers
    ret = {lay: evaluate(StackedObservation(CartPoleEnv(), 3, lay), w, pol.normalizer.mean, pol.normalizer.std,
                         range(300, 303))[0] for lay in ("time", "term")}
    assert ret["time"] >= CartPoleEnv.threshold and ret["term"] < 100


def test_projected_gravity_and_the_quaternion_order_mistake():
    import math

    from robocourse.rl.frames import projected_gravity, ur_base_to_base_link, wxyz_from_ros
    from robocourse.viz.transforms import quaternion_from_rotation, rot_y, rot_z

    np.testing.assert_allclose(projected_gravity([1, 0, 0, 0]), [0, 0, -1])
    w, x, y, z = quaternion_from_rotation(rot_y(math.radians(10)))
    np.testing.assert_allclose(projected_gravity(wxyz_from_ros(x, y, z, w)),
                               [math.sin(math.radians(10)), 0, -math.cos(math.radians(10))], atol=1e-12)
    w, x, y, z = quaternion_from_rotation(rot_z(math.radians(90)))
    right, wrong = projected_gravity(wxyz_from_ros(x, y, z, w)), projected_gravity([x, y, z, w])
    np.testing.assert_allclose(right, [0, 0, -1], atol=1e-12)
    assert math.degrees(math.acos(np.clip(right @ wrong, -1, 1))) == pytest.approx(90.0)
    np.testing.assert_allclose(ur_base_to_base_link([0.3, -0.2, 0.5]), [-0.3, 0.2, 0.5], atol=1e-12)
    with pytest.raises(ValueError, match="4 finite numbers"):
        projected_gravity([0, 0, 0, 0])


def test_ars_progress_is_a_line_that_ends_as_its_summary_never_a_frozen_bar(monkeypatch, progress_updates):
    # issue 25: tqdm's notebook widget is saved as "0/15" forever; ARS draws robocourse.notebook.progress
    import sys

    updates = progress_updates
    monkeypatch.delitem(sys.modules, "tqdm", raising=False)
    monkeypatch.delitem(sys.modules, "tqdm.auto", raising=False)
    r = train_cartpole(ARSConfig(n_directions=4, top=2, step_size=0.1, noise=0.1, seed=0, max_iterations=30))
    last = updates[-1]["text/plain"]
    assert last.startswith(f"ARS iterations (score {r.history[-1][2]:.3f}, threshold 475): {r.iterations} of 30 in ")
    assert "<progress" not in updates[-1]["text/html"]
    assert "tqdm" not in sys.modules
