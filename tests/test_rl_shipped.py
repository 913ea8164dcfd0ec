"""The shipped reach policy: loads, matches its ONNX export, reaches its training threshold, names its recipe."""

import numpy as np

from robocourse.rl import ArmReachEnv, Normalizer, OnnxRuntime, shipped
from robocourse.rl.ars import ARM_ARS, evaluate
from robocourse.rl.envs import arm_evaluation_targets


def test_shipped_files_exist_and_the_onnx_export_equals_the_numpy_policy():
    p = shipped.paths()
    assert all(path.exists() for path in p.values())
    policy = shipped.load()
    rt = OnnxRuntime(p["onnx"])
    norm = Normalizer.load(p["normalizer"])
    np.testing.assert_array_equal(norm.mean, policy.normalizer.mean)
    rng = np.random.default_rng(0)
    for _ in range(20):
        obs = norm.mean + norm.std * rng.standard_normal(21)
        np.testing.assert_allclose(rt(obs), policy(obs), atol=1e-4)


def test_shipped_policy_records_its_recipe_and_reaches_its_threshold():
    policy = shipped.load()
    assert policy.meta["env"] == "arm_reach" and policy.meta["ars"]["seed"] == ARM_ARS.seed
    assert policy.meta["ars"]["solved"] is True
    cfg = shipped.env_config(policy)
    env = ArmReachEnv(cfg)
    targets = arm_evaluation_targets(env)
    (w, _), = policy.layers
    _, dist, steps = evaluate(env, w, policy.normalizer.mean, policy.normalizer.std, range(len(targets)),
                              [{"target": t} for t in targets])
    assert dist < cfg.success_distance
    assert steps == len(targets) * env.max_steps
