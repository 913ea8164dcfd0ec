"""Chapter 6's graded checks: the solution notebook's code scores full marks, typical mistakes score zero."""

from pathlib import Path

import nbformat
import numpy as np
import pytest

from robocourse.grading import discover, exercises
from robocourse.grading.checks import get, run_check

ROOT = Path(__file__).resolve().parents[1]
SOL = ROOT / "solutions/06_policy_deployment_exercises.ipynb"


@pytest.fixture(scope="module")
def solution():
    discover()
    ns = {"np": np}
    for cell in nbformat.read(SOL, as_version=4).cells:
        if cell.cell_type == "code" and cell.source.lstrip().startswith(("def ", "class ")):
            exec(cell.source, ns)
    return ns


def test_every_check_of_ch06_is_called_in_the_exercises():
    assert exercises.checks_in(nbformat.read(SOL, as_version=4)) == ["ch06.fold_normalizer", "ch06.ema_clip",
                                                                    "ch06.bridge_timeout", "ch06.observation"]


@pytest.mark.parametrize("name,obj", [("ch06.fold_normalizer", "fold_normalizer"), ("ch06.ema_clip", "ema_clip"),
                                      ("ch06.bridge_timeout", "MiniBridge"), ("ch06.observation", "reach_observation")])
def test_solutions_score_full_marks(solution, name, obj):
    for seed in range(3):
        r = run_check(get(name), solution[obj], rng=np.random.default_rng(seed))
        assert r.passed and r.points == r.weight, r.message


def test_fold_dividing_rows_or_forgetting_the_bias_scores_zero(solution):
    def forgot_bias(W, b, mean, std, eps):
        return W / (std + eps), b

    r = run_check(get("ch06.fold_normalizer"), forgot_bias, rng=np.random.default_rng(0))
    assert not r.passed and r.points == 0 and "b - W' @ mean" in r.message


def test_ema_with_alpha_on_the_new_value_or_clipped_state_scores_zero(solution):
    def swapped(action, y_prev, default, scale, alpha, lower, upper):
        return solution["ema_clip"](action, y_prev, default, scale, 1 - alpha, lower, upper)

    def clipped_state(action, y_prev, default, scale, alpha, lower, upper):
        y, target, n = solution["ema_clip"](action, y_prev, default, scale, alpha, lower, upper)
        return target, target, n

    for wrong in (swapped, clipped_state):
        r = run_check(get("ch06.ema_clip"), wrong, rng=np.random.default_rng(1))
        assert not r.passed and r.points == 0, wrong.__name__


def test_bridge_without_recovery_rule_or_dimension_check_scores_zero(solution):
    Good = solution["MiniBridge"]

    class NoDimensionCheck(Good):
        def submit(self, targets, now):
            self.target, self.received = np.resize(np.asarray(targets, dtype=float), self.n), now
            self.n_accepted += 1
            return True

    class NeverTimesOut(Good):
        def update(self, now, q):
            return ("run", self.target) if self.target is not None else ("hold", np.asarray(q))

    for wrong in (NoDimensionCheck, NeverTimesOut):
        r = run_check(get("ch06.bridge_timeout"), wrong, rng=np.random.default_rng(2))
        assert not r.passed and r.points == 0, wrong.__name__


def test_delegating_to_the_library_scores_zero():
    from robocourse.rl.export import fold_normalizer

    discover()
    r = run_check(get("ch06.fold_normalizer"), fold_normalizer, rng=np.random.default_rng(0))
    assert not r.passed and r.points == 0


def test_observation_with_swapped_blocks_scores_zero_naming_the_block(solution):
    def swapped(q, dq, target, last_action, default_pose, tcp_default, dof_vel_scale):
        return np.concatenate([np.asarray(dq) * dof_vel_scale, np.asarray(q) - default_pose,
                               np.asarray(target) - tcp_default, last_action])

    r = run_check(get("ch06.observation"), swapped, rng=np.random.default_rng(0))
    assert not r.passed and r.points == 0 and "entries 0..5 should be q - default_pose" in r.message
