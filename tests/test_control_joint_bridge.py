"""JointBridge: KEEP_LAST 1 targets, dimension check, 500 ms timeout into the safe mode, throttled warning,
leaving only on fresh targets; configure_realtime_thread verified, privileged and not."""

import numpy as np
import pytest

from robocourse.bus import Context, HistoryPolicy, SingleThreadedExecutor
from robocourse.control.joint_bridge import DAMPING, HOLD, RUN, JointBridge
from robocourse.msgs.sensor_msgs import JointState
from robocourse.msgs.std_msgs import Float64MultiArray
from robocourse.rt.realtime_thread import configure_realtime_thread

J = ["a", "b", "c"]


def test_fresh_target_is_passed_through_in_run_mode():
    b = JointBridge(J)
    assert b.timeout == 0.5
    b.submit([0.1, 0.2, 0.3], stamp=0.99, now=1.0)
    cmd = b.update(1.2, np.zeros(3))
    assert cmd.mode == RUN and cmd.stamp == 0.99
    np.testing.assert_array_equal(cmd.targets, [0.1, 0.2, 0.3])


def test_dimension_mismatch_is_rejected_and_the_previous_target_kept():
    b = JointBridge(J)
    b.submit([1.0, 2.0, 3.0], now=0.0)
    assert b.submit([9.0, 9.0], now=0.01) is False
    assert b.rejected_dimension == 1
    assert b.log[-1].startswith("Dimension mismatch: received 2 joint targets, expected 3")
    np.testing.assert_array_equal(b.update(0.02, np.zeros(3)).targets, [1.0, 2.0, 3.0])


def test_non_finite_target_is_rejected():
    b = JointBridge(J)
    assert b.submit([0.0, np.nan, 0.0], now=0.0) is False
    assert b.rejected_non_finite == 1 and b.accepted == 0


def test_timeout_enters_hold_at_the_measured_position_and_warns_throttled():
    b = JointBridge(J, timeout=0.5, warn_period=1.0)
    b.submit([1.0, 1.0, 1.0], now=0.0)
    assert b.update(0.5, np.zeros(3)).mode == RUN           # exactly the timeout: still fresh
    q = np.array([0.4, 0.5, 0.6])
    cmd = b.update(0.502, q)
    assert cmd.mode == HOLD and b.safe and b.safe_entries == 1
    np.testing.assert_array_equal(cmd.targets, q)
    for k in range(1, 1000):                                  # 2 s more at 500 Hz
        cmd = b.update(0.502 + 0.002 * k, q + 1.0)            # hold stays where it was entered
    np.testing.assert_array_equal(cmd.targets, q)
    assert b.warnings == 2                                    # at 0.502 s and 1.502 s: once per second
    assert b.warnings_suppressed == 999 - 1


def test_safe_mode_is_left_only_on_a_target_received_after_entering_it():
    b = JointBridge(J, timeout=0.5, safe_mode=DAMPING)
    b.submit([1.0, 1.0, 1.0], now=0.0)
    assert b.update(0.6, np.zeros(3)).mode == DAMPING
    assert b.update(0.7, np.zeros(3)).mode == DAMPING         # the old target is not fresh
    b.submit([2.0, 2.0, 2.0], now=0.71)
    cmd = b.update(0.72, np.zeros(3))
    assert cmd.mode == RUN and not b.safe
    np.testing.assert_array_equal(cmd.targets, [2.0, 2.0, 2.0])


def test_no_target_at_all_trips_the_timeout_at_the_first_update():
    b = JointBridge(J)
    assert b.update(0.0, np.zeros(3)).mode == HOLD
    assert "no target yet" in b.log[-1]


def test_bus_bridge_keeps_only_the_newest_target_and_publishes_joint_states():
    ctx = Context(use_sim_time=True)
    b = JointBridge(J, context=ctx)
    sub = ctx.create_node("brain")
    pub = sub.create_publisher(Float64MultiArray, "/joint_targets", 10)
    got = []
    sub.create_subscription(JointState, "/joint_states", got.append, 10)
    (s,) = b.node.subscriptions
    assert s.qos_profile.history == HistoryPolicy.KEEP_LAST and s.qos_profile.depth == 1
    for v in (1.0, 2.0, 3.0):                                  # three before the bridge runs
        pub.publish(Float64MultiArray(data=[v, v, v]))
    pub.publish(Float64MultiArray(data=[7.0, 7.0]))            # wrong size: rejected
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b.node)
    ex.add_node(sub)
    ex.spin_some()
    assert b.accepted == 0 and b.rejected_dimension == 1       # KEEP_LAST 1: only the newest was delivered
    for v in (1.0, 2.0, 3.0):
        pub.publish(Float64MultiArray(data=[v, v, v]))
    ex.spin_some()
    assert b.accepted == 1
    np.testing.assert_array_equal(b.update(0.0, np.zeros(3)).targets, [3.0, 3.0, 3.0])
    b.publish_state(1_500_000_000, [0.1, 0.2, 0.3], [0.0, 0.0, 0.0])
    ex.spin_some()
    assert got[-1].name == J and list(got[-1].position) == [0.1, 0.2, 0.3]
    assert (got[-1].header.stamp.sec, got[-1].header.stamp.nanosec) == (1, 500_000_000)


def test_bad_bridge_arguments_are_refused():
    with pytest.raises(ValueError, match="timeout=0 s must be a finite number > 0"):
        JointBridge(J, timeout=0)
    with pytest.raises(ValueError, match="safe_mode='off' must be 'hold' or 'damping'"):
        JointBridge(J, safe_mode="off")


def test_configure_realtime_thread_names_the_thread_and_reads_back_what_took_effect():
    import threading

    out = {}

    def body():
        out["r"] = configure_realtime_thread("cerebellum", "other", 0, lock_memory=False)

    th = threading.Thread(target=body)
    th.start()
    th.join()
    r = out["r"]
    assert r.applied_name == "cerebellum"
    assert r.applied_policy == "SCHED_OTHER" and r.realtime
    with pytest.raises(ValueError, match="1..15 bytes"):
        configure_realtime_thread("a_name_that_is_far_too_long")


def test_configure_realtime_thread_unprivileged_reports_the_refusal_and_carries_on():
    from pathlib import Path

    import robocourse.rt.realtime_thread as module
    from robocourse.rt.permissions import run_unprivileged

    # as 'nobody' the interpreter's files may be unreadable: the module's source travels in the code
    source = Path(module.__file__).read_text()
    proc = run_unprivileged(f"""
        import threading, types
        mod = sys.modules["realtime_thread"] = types.ModuleType("realtime_thread")
        exec({source!r}, mod.__dict__)
        configure_realtime_thread = mod.configure_realtime_thread
        out = {{}}
        def body():
            out["r"] = configure_realtime_thread("cerebellum", "fifo", 80)
        t = threading.Thread(target=body); t.start(); t.join()
        r = out["r"]
        print("RESULT", r.applied_name, r.applied_policy, r.applied_priority, r.realtime, r.memory_locked,
              [x.ok for x in r.reports])
    """)
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT")]
    assert line, proc.stderr
    assert line[0] == "RESULT cerebellum SCHED_OTHER 0 False False [True, False, False]"
