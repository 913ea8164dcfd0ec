"""The CRISP deployment under ros2_control: start-up sequence, reaching, safe mode when the brain dies,
exit damping, clipping counted, bad observations and actions survived."""

import json
from pathlib import Path

import numpy as np
import pytest

from robocourse.control import ACTIVE
from robocourse.rl import (
    UR5E_DEFAULT_POSE,
    ArmReachConfig,
    MLPPolicy,
    NumpyRuntime,
    load_runtime,
    shipped,
)
from robocourse.rl.deployment import (
    EFFORT_CONTROLLER,
    MOVE,
    POSITION_CONTROLLER,
    RUNNING,
    ZERO_TORQUE,
    PolicyDeployment,
)
from robocourse.rl.handover import LatestValue, SharedLatestValue
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
    np.testing.assert_allclose(d.sim.commands[:6], -d.damping_kds * d._dq, atol=1e-9)


def test_exit_damping_after_the_run():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), move_s=0.2)
    tr = d.run_simulated(0.6, exit_damping_s=0.1)
    assert tr.phase[-1] == "damping" and d.cm.controllers[EFFORT_CONTROLLER].state == ACTIVE
    np.testing.assert_allclose(d.sim.commands[:6], -d.damping_kds * d._dq, atol=1e-9)


def test_damping_gain_is_capped_per_joint_where_a_once_per_tick_damping_stays_stable():
    # kd 8 from a velocity sampled at 500 Hz is unstable on the light wrist_3 (M ~ 0.003 kg m^2):
    # its velocity flipped sign on a third of the ticks and reached 31 rad/s before the cap
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), zero_torque_s=0.0, move_s=0.3)
    np.testing.assert_array_equal(d.damping_kds[:4], 8.0)             # the heavy joints keep unitree's kd 8
    assert 0.3 < d.damping_kds[5] < 1.5 and d.damping_kds[4] < 8.0    # wrist_3 and wrist_2 capped at M / (2 dt)
    tr = d.run_simulated(1.0, exit_damping_s=0.3)
    damp = np.array([p == "damping" for p in tr.phase])
    dq = tr.dq[damp]
    flips = (np.sign(dq[1:]) != np.sign(dq[:-1])).mean(axis=0)
    assert flips.max() < 0.1, flips
    assert np.abs(dq[:, 3:]).max() < 1.0                               # wrists: no chatter growing
    with pytest.raises(ValueError, match="damping_kd=-1.0 must be a finite gain >= 0"):
        PolicyDeployment(NumpyRuntime(ik_policy()), CFG, damping_kd=-1.0)


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
    assert r.placement == "thread"
    assert d.cm.controllers[POSITION_CONTROLLER].state == ACTIVE
    assert d.phase_log[0][1] == MOVE and d.phase_log[1][1] == RUNNING
    assert r.control.iterations == 300 and r.stats().iterations == 300   # a run for rt.repeat.measure_rounds
    assert len(r.policy_latency_us) >= 1
    assert r.thread_report.applied_name == "cerebellum"
    assert len(r.inference_us) == d.runtime.calls == r.targets > 0
    assert len(r.age_us) > 0 and np.all(r.age_us >= 0)   # only the brain's targets carry an observation stamp
    assert "observation -> command age" in r.summary()


def test_brain_in_its_own_process_drives_the_arm_through_shared_memory(tmp_path):
    path = ik_policy().save(tmp_path / "ik.npz")
    target = tcp0() + [0.05, 0, 0]
    d = PolicyDeployment(load_runtime(path), CFG, target=target, zero_torque_s=0.0, move_s=0.1, placement="process")
    start = d.tcp_distance()
    r = d.run_realtime(1.2)
    assert r.placement == "process" and d.runtime.calls == 0     # this process never ran the policy
    assert r.targets >= 20 and len(r.inference_us) >= r.targets  # the child's measurements came back
    assert len(r.policy_latency_us) >= 20
    assert r.final_distance < 0.5 * start and d.bridge.safe_entries == 0


def test_a_brain_process_that_stalls_trips_the_timeout():
    d = PolicyDeployment(load_runtime(shipped.paths()["onnx"]), CFG, target=tcp0(), zero_torque_s=0.0, move_s=0.1,
                         placement="process", stall_at=0.3, timeout=0.2)
    r = d.run_realtime(0.9)
    assert 0 < r.targets and d.bridge.safe_entries == 1


def test_process_placement_needs_a_policy_file():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, placement="process")
    with pytest.raises(ValueError, match="runtime made from a file"):
        d.run_realtime(0.1)


def test_joint_states_come_in_the_broadcasters_sorted_order_and_index_order_reads_the_wrong_joints():
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0(), move_s=0.1)
    d.run_simulated(0.2)
    assert d.state_names == sorted(d.state_names) and d.state_names[0] == "elbow_joint"
    msg = d.joint_states()
    assert msg.name == d.state_names and len(msg.position) == len(d.state_names) == 8   # the gripper's joints too
    right = d.brain.observation(msg.name, msg.position, msg.velocity)
    np.testing.assert_allclose(right[:6], d._q - Q0, atol=1e-12)
    wrong = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, obs_by_name=False).brain.observation(
        msg.name, msg.position, msg.velocity)
    np.testing.assert_allclose(wrong[:6], np.array(msg.position[:6]) - Q0, atol=1e-12)   # elbow read as pan
    with pytest.raises(ValueError, match="has no \\['wrist_3_joint'\\]"):
        d.brain.observation(msg.name[:-1], msg.position[:-1], msg.velocity[:-1])


def test_index_order_deployment_misses_the_target_that_by_name_reaches():
    target = tcp0() + [0.08, 0.05, -0.05]
    policy = shipped.load()                               # reads q and dq, unlike ik_policy
    runs = {}
    for by_name in (True, False):
        d = PolicyDeployment(NumpyRuntime(policy), shipped.env_config(policy), target=target, move_s=0.2,
                             obs_by_name=by_name)
        runs[by_name] = d.run_simulated(2.0).tcp_distance[-1]
    assert runs[True] < 0.06 and runs[False] > 2 * runs[True]


def test_softer_servo_gains_than_training_change_the_reach():
    from robocourse.sim.robots import ServoGains

    soft = {j: ServoGains(kp=80.0, kd=8.0, kv=150.0) for j in ("shoulder_pan_joint", "shoulder_lift_joint",
                                                              "elbow_joint")}
    d = PolicyDeployment(NumpyRuntime(ik_policy()), CFG, target=tcp0() + [0.08, 0.05, -0.05], move_s=0.2,
                         servo_gains=soft)
    assert d.sim.gains["elbow_joint"].kp == 80.0 and d.processor.kp[2] == 80.0
    d.run_simulated(0.5)


def test_latest_value_copies_in_and_out_and_counts_writes():
    lv = LatestValue(3)
    assert lv.read()[1] == 0
    buf = np.array([1.0, 2.0, 3.0])
    assert lv.write(buf, 0.5) == 1
    buf[:] = 9.0                                          # the writer reuses its buffer
    value, seq, stamp = lv.read()
    assert value.tolist() == [1.0, 2.0, 3.0] and (seq, stamp) == (1, 0.5)
    value[:] = 7.0
    assert lv.read()[0].tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="wrote 2 values to a LatestValue of size 3"):
        lv.write([1.0, 2.0], 0.0)


def test_shared_latest_value_try_calls_never_wait_for_the_lock():
    sv = SharedLatestValue(2)
    try:
        assert sv.write([1.0, 2.0], 3.0) == 1
        out = np.zeros(2)
        assert sv.try_read_into(out) == (1, 3.0) and out.tolist() == [1.0, 2.0]
        other = SharedLatestValue.attach(sv.spec())
        with sv.locked():                                 # the other side is mid-copy
            assert other.try_read_into(out) is None and other.try_write([5.0, 5.0], 4.0) == 0
        assert other.try_write([5.0, 6.0], 4.0) == 2
        assert sv.read_into(out) == (2, 4.0) and out.tolist() == [5.0, 6.0]
        other.close()
        assert SharedLatestValue.attach(json.loads(json.dumps(sv.spec()))).read()[1] == 2   # plain data travels
    finally:
        sv.close()
    assert not Path(sv.lock_path).exists()


def test_widened_policy_gives_the_same_actions_at_a_bigger_cost():
    from robocourse.rl.policy import widened

    base = ik_policy()
    big = widened(base, (64, 48))
    assert big.sizes == [21, 64, 48, 6]
    x = np.random.default_rng(0).normal(size=(50, 21))
    np.testing.assert_allclose(big(x), base(x), atol=1e-12)
    with pytest.raises(ValueError, match="at least 12 units"):
        widened(base, (8,))
