"""The CRISP deployment under ros2_control: start-up sequence, reaching, safe mode when the brain dies,
exit damping, clipping counted, bad observations and actions survived."""

import numpy as np
import pytest

from robocourse.control import ACTIVE
from robocourse.rl import UR5E_DEFAULT_POSE, ArmReachConfig, MLPPolicy, NumpyRuntime
from robocourse.rl.deployment import (
    EFFORT_CONTROLLER,
    MOVE,
    POSITION_CONTROLLER,
    RUNNING,
    ZERO_TORQUE,
    PolicyDeployment,
)
from robocourse.sim.robots import Kinematics

CFG = ArmReachConfig()
Q0 = np.array(UR5E_DEFAULT_POSE)


def ik_policy(gain=1.0):
    """A linear policy that is the Jacobian pseudo-inverse at the default pose (what ARS should find)."""
    jac = Kinematics("ur5e").calculate_jacobian(Q0)[:3]
    w = np.zeros((6, 21))
    w[:, 12:15] = gain * np.linalg.pinv(jac) / CFG.action_scale
    return MLPPolicy([(w, np.zeros(6))])


def tcp0():
    return Kinematics("ur5e").calculate_link_transform(Q0)[:3, 3]


def test_start_up_goes_zero_torque_then_move_to_default_then_run():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), zero_torque_s=0.1, move_s=0.5)
    tr = d.run_simulated(1.0)
    assert [p for _, p in d.phase_log] == [ZERO_TORQUE, MOVE, RUNNING]
    assert [round(t, 3) for t, _ in d.phase_log] == [0.002, 0.102, 0.602]
    i_move = tr.phase.index(MOVE)
    assert tr.mode[i_move - 1] == "effort" and np.all(tr.target[:i_move - 1] == 0.0)  # zero torque
    sag = np.abs(tr.q[i_move - 1] - Q0).max()
    assert sag > 0.01                                  # gravity pulled the unpowered arm
    i_run = tr.phase.index(RUNNING)
    assert np.abs(tr.q[i_run] - Q0).max() < 0.05       # still catching up with the ramp's end
    assert np.abs(tr.q[i_run + 100] - Q0).max() < 0.01  # 0.2 s later: at the default pose
    assert d.cm.controllers[POSITION_CONTROLLER].state == ACTIVE


def test_deployed_policy_reaches_its_target_at_500_hz_with_policy_at_50_hz():
    target = tcp0() + [0.08, 0.05, -0.05]
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=target, move_s=0.2)
    assert d.decimation == 10
    tr = d.run_simulated(2.0)
    assert tr.tcp_distance[-1] < 0.03
    assert d.runtime.calls == pytest.approx((2.0 - 0.25) * 50, abs=2)
    assert d.bridge.safe_entries == 0


def test_dead_policy_thread_times_out_into_hold_and_nothing_crashes():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0() + [0.1, 0, 0], move_s=0.2, stall_at=1.0)
    tr = d.run_simulated(2.5)
    assert d.bridge.safe_entries == 1
    t_safe = tr.t[tr.mode.index("safe")]
    assert 1.0 + 0.5 - 0.02 <= t_safe <= 1.0 + 0.5 + 0.02    # the 500 ms timeout after the last target
    held = tr.target[-1]
    np.testing.assert_allclose(tr.target[tr.mode.index("safe"):], np.tile(held, (len(tr.t) - tr.mode.index("safe"), 1)))
    assert any("command timeout" in m for m in d.bridge.log)


def test_dead_policy_with_damping_safe_mode_switches_to_effort_minus_kd_dq():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), move_s=0.2, stall_at=0.5,
                         safe_mode="damping")
    d.run_simulated(1.2)
    assert d.cm.controllers[EFFORT_CONTROLLER].state == ACTIVE
    np.testing.assert_allclose(d.sim.commands[:6], -8.0 * d._dq, atol=1e-9)


def test_exit_damping_after_the_run():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), move_s=0.2)
    tr = d.run_simulated(0.6, exit_damping_s=0.1)
    assert tr.phase[-1] == "damping" and d.cm.controllers[EFFORT_CONTROLLER].state == ACTIVE
    np.testing.assert_allclose(d.sim.commands[:6], -8.0 * d._dq, atol=1e-9)


def test_targets_beyond_the_torque_limit_are_clipped_and_counted():
    w = np.zeros((6, 21))
    big = MLPPolicy([(w, np.full(6, 50.0))])            # every action 50: clipped to 1, then 0.5 rad offsets
    d = PolicyDeployment(NumpyRuntime(big), CFG, target=tcp0(), move_s=0.2)
    d.run_simulated(0.5)
    assert d.processor.processed > 0
    assert d.processor.clipped_torque >= d.processor.processed  # kp 800 x 0.5 rad = 400 N m > 150 N m
    lims = np.array([d.sim.limits[j].effort for j in d.sim.joint_names[:6]])
    kp = np.array([d.sim.gains[j].kp for j in d.sim.joint_names[:6]])
    assert np.all(np.abs(kp * (d.sim.commands[:6] - d._q)) <= lims + 8.0 * np.abs(d._dq) + 1e-6)


def test_nan_observation_is_refused_and_the_bridge_holds():
    def broken(q_rel, dq, target, last):
        obs = np.concatenate([q_rel, dq, target, last])
        obs[3] = np.nan                                   # a dead encoder
        return obs

    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), move_s=0.2, obs_fn=broken)
    tr = d.run_simulated(1.0)
    assert d.nan_observations == len(d.policy_errors) > 0
    assert "non-finite values at indices [3]" in d.policy_errors[0]
    assert d.runtime.calls == 0 and d.bridge.safe_entries == 1 and tr.mode[-1] == "safe"


def test_policy_with_the_wrong_action_size_is_refused_before_running():
    with pytest.raises(ValueError, match="outputs 12 actions; the UR5e arm has 6 joints"):
        PolicyDeployment(NumpyRuntime(MLPPolicy.random((21, 12))), CFG)
    with pytest.raises(ValueError, match="update_rate 500 Hz / policy_rate 30.0 Hz must be an integer"):
        PolicyDeployment(NumpyRuntime(ik_policy()), CFG, policy_rate=30)


def test_realtime_run_measures_both_threads_and_the_observation_to_command_age():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0() + [0.05, 0, 0], zero_torque_s=0.0, move_s=0.1)
    r = d.run_realtime(0.6)
    assert d.cm.controllers[POSITION_CONTROLLER].state == ACTIVE
    assert d.phase_log[0][1] == MOVE and d.phase_log[1][1] == RUNNING
    assert r.control.iterations == 300
    assert r.policy is not None and r.policy.iterations >= 1
    assert r.thread_report.applied_name == "cerebellum"
    assert len(r.inference_us) == d.runtime.calls > 0
    assert len(r.age_us) > 0 and np.all(r.age_us >= 0)   # only the brain's targets carry an observation stamp
    assert "observation -> command age" in r.summary()
