"""Chapter 6's checks in the student's own kernel: what the bank (tests/banks/ch06.py) cannot show.

The bank grades plausible wrong answers through the sandbox with their partial scores. Here: the
notebook calls every check in order; a malformed return fails with the form it needed; an answer
that raises is told once, in every sub-test; the deployment loop's scripted arm and the judge's
reading of it (which state a target came from) are right on their own; the same seed draws the
same inputs.
"""

from pathlib import Path

import nbformat
import numpy as np
import pytest

from robocourse.grading import discover, exercises
from robocourse.grading.checks import get, run_check
from robocourse.rl.scripted import ScriptedArm

ROOT = Path(__file__).resolve().parents[1]
SOL = ROOT / "solutions/06_policy_deployment_exercises.ipynb"
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]


@pytest.fixture(scope="module", autouse=True)
def checks():
    discover()


def test_every_check_of_ch06_is_called_in_the_exercises_in_order():
    assert exercises.checks_in(nbformat.read(SOL, as_version=4)) == [
        "ch06.fold_normalizer", "ch06.ema_clip", "ch06.bridge_timeout", "ch06.observation", "ch06.deployment_loop"]


def test_an_observation_of_the_wrong_form_fails_every_sub_test_with_the_form_needed():
    r = run_check(get("ch06.observation"), lambda *a: {"q": 1}, seed=3)
    assert r.points == 0 and r.reason == "malformed" and "array" in r.message


def test_an_observation_that_raises_is_told_with_the_message():
    def broken(joint_state, joint_order, *rest):
        return np.array([joint_state.position[joint_state.name.index(j)] for j in joint_order] + [None])

    r = run_check(get("ch06.observation"), broken, seed=3)
    assert r.points == 0 and all(not s["passed"] for s in r.subtests)


def test_same_seed_same_draws_and_the_seed_is_shown():
    a, b = (get("ch06.deployment_loop").make_inputs(np.random.default_rng(7)) for _ in range(2))
    assert a == b and a["spec"]["decimation"] in (4, 5) and a["spec"]["timeout"] in (0.2, 0.3)
    assert sorted(a["spec"]["policy_joints"]) == sorted(JOINTS) and len(a["state_names"]) == 8
    assert np.all(np.array(a["W"])[:, 15:] == 0)       # the grader's policy ignores the last action


def test_scripted_arm_serves_ticks_on_its_trajectory_and_records_commands():
    names = sorted(JOINTS + ["finger_joint"])
    arm = ScriptedArm(JOINTS, names, list(reversed(JOINTS)), rate_hz=200.0, max_ticks=5, seed=1)
    got = []
    while (msg := arm.wait_for_tick()) is not None:
        got.append(msg)
        arm.command(arm.joint_positions(arm.k, arm.command_joints))
    assert len(got) == 5 and got[0].name == names and got[3].header.stamp.nanosec == 15_000_000
    q, dq = arm.state(3)
    np.testing.assert_allclose(got[3].position, q)
    assert got[3].position[names.index("finger_joint")] == arm.state(0)[0][names.index("finger_joint")]  # still
    rec = arm.record()
    assert rec["ticks"] == 5 and sorted(rec["commands"]) == ["0", "1", "2", "3", "4"] and rec["bad_commands"] == []
    walls = [r[1] for r in rec["served"]]
    assert rec["served"][0][2] > 0 and walls == sorted(walls)          # when each tick was served, in order
    arm2 = ScriptedArm(JOINTS, names, JOINTS, max_ticks=3)
    arm2.command([0.0] * 6)
    arm2.wait_for_tick()
    arm2.command([0.0] * 5)
    arm2.command([float("nan")] * 6)
    assert len(arm2.bad_commands) == 3 and "before the first" in arm2.bad_commands[0]
    with pytest.raises(ValueError, match="permutation of the joints"):
        ScriptedArm(JOINTS, names, JOINTS[:5])


def test_scripted_arm_stops_when_asked():
    arm = ScriptedArm(JOINTS, JOINTS, JOINTS, rate_hz=500.0, max_ticks=100, stop_when=lambda a: a.k >= 19,
                      check_every=10)
    n = 0
    while arm.wait_for_tick() is not None:
        n += 1
    assert n == 20 and arm.record()["stopped_early"]


def test_the_judge_finds_which_state_each_target_came_from_and_names_an_index_read():
    from robocourse.rl import checks

    inputs = get("ch06.deployment_loop").make_inputs(np.random.default_rng(2))
    arm = ScriptedArm(inputs["joints"], inputs["state_names"], inputs["spec"]["command_joints"], 100.0, 200,
                      seed=inputs["trajectory_seed"])
    out = {"returned": True, "error": None, "arm": {"ticks": 60, "commands": {}, "served": []}, "calls": []}
    d = checks._Deployment(inputs, {**out, "arm": {**out["arm"], "commands": {}}})
    last = np.zeros(6)

    def commands(by_index):                              # hold q(0), then a target every 4 ticks from a state
        cmd, out = arm.joint_positions(0, arm.command_joints), {}   # 2 ticks old, held in between
        for k in range(60):
            if k % 4 == 0 and k:
                cmd = d.targets_of(d.actions(np.array([k - 2]), last, by_index=by_index))[0]
            out[str(k)] = cmd
        return out

    out["arm"]["commands"] = commands(False)
    d = checks._Deployment(inputs, out)
    assert [e[0] for e in d.events][:3] == ["hold", "target", "target"] and {e[2] for e in d.targets()} == {2}
    assert len(d.targets()) == 14 and not d.unexplained and not d.misread
    out["arm"]["commands"] = commands(True)
    d = checks._Deployment(inputs, out)
    assert d.misread and d.misread[0][0] == "index" and not d.unexplained


def test_decimation_discounts_the_machines_stalls_and_their_catch_up_not_the_codes_pace():
    """The steps (ticks between the targets' states) measured sandboxed under CpuLoad(2): a tick-paced brain
    starved for 300 ms keeps its 5s; a time-paced brain's catch-up after a stall is dropped with the stall; a
    brain on every tick stays at 1 however starved; one at twice the decimation keeps nothing."""
    from robocourse.rl.checks import _decimation_steps

    assert _decimation_steps([5, 5, 5, 5, 5, 10, 35, 30, 5, 5, 5], 5, 3) == ([5, 5, 5, 5, 5], 2)
    assert _decimation_steps([4, 4, 4, 35, 1, 1, 1, 1, 1, 1, 1, 1, 4, 4], 4, 3) == ([4, 4, 4, 4, 4], 1)
    kept, _ = _decimation_steps([1, 1, 1, 35] + [1] * 13, 4, 3)
    assert kept and max(kept) == 1
    assert _decimation_steps([8] * 11, 4, 3) == ([], 6)
