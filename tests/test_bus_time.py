"""Clocks, timers and simulated time."""

import threading
import time

import pytest

from robocourse.bus import (
    Clock,
    ClockType,
    Context,
    Duration,
    Parameter,
    SingleThreadedExecutor,
    Time,
)
from robocourse.msgs.std_msgs import Float64


def run_sim_graph():
    ctx = Context(use_sim_time=True)
    a, b = ctx.create_node("talker"), ctx.create_node("listener")
    pub = a.create_publisher(Float64, "x", 10)
    clock = a.get_clock()
    a.create_timer(0.001, lambda: pub.publish(Float64(data=clock.now().nanoseconds * 1e-9)))
    got = []
    b.create_subscription(Float64, "x", lambda m: got.append((b.get_clock().now().nanoseconds, m.data)), 10)
    slow = []
    b.create_timer(0.25, lambda: slow.append(b.get_clock().now().nanoseconds))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    ex.spin_for(10.0)
    return ctx, got, slow


def test_ten_simulated_seconds_exact_and_deterministic():
    ctx, got, slow = run_sim_graph()
    assert ctx.now() == 10.0
    assert len(got) == 10_000
    assert got[0] == (1_000_000, 0.001)
    assert got[-1] == (10_000_000_000, 10.0)
    assert slow == [250_000_000 * k for k in range(1, 41)]
    _, got2, slow2 = run_sim_graph()
    assert got2 == got and slow2 == slow


def test_sim_clock_types_and_use_sim_time_parameter():
    ctx = Context(use_sim_time=True, start_time=5.0)
    n = ctx.create_node("n")
    assert n.get_parameter("use_sim_time").value is True
    assert n.get_clock().clock_type == ClockType.ROS_TIME and n.get_clock().ros_time_is_active
    assert n.get_clock().now() == Time(seconds=5.0, clock_type=ClockType.ROS_TIME)
    n.set_parameters([Parameter("use_sim_time", value=False)])
    assert not n.get_clock().ros_time_is_active
    assert abs(n.get_clock().now().nanoseconds * 1e-9 - time.time()) < 5.0
    wall = Context().create_node("w")
    assert wall.get_parameter("use_sim_time").value is False


def test_time_and_duration_arithmetic():
    t = Time(seconds=1, nanoseconds=500)
    d = Duration(seconds=0.5)
    assert (t + d).nanoseconds == 1_500_000_500
    assert (t + d) - t == d
    assert t.to_msg().sec == 1 and t.to_msg().nanosec == 500
    assert Time.from_msg(t.to_msg()).nanoseconds == t.nanoseconds
    with pytest.raises(TypeError):
        _ = Time(clock_type=ClockType.STEADY_TIME) < Time(clock_type=ClockType.SYSTEM_TIME)
    steady = Clock(clock_type=ClockType.STEADY_TIME)
    a = steady.now()
    b = steady.now()
    assert b >= a


def test_timer_cancel_reset_and_info():
    ctx = Context(use_sim_time=True)
    n = ctx.create_node("n")
    calls = []
    t = n.create_timer(0.1, lambda: calls.append(ctx.sim.ns))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    ex.spin_for(0.35)
    assert len(calls) == 3
    assert t.time_until_next_call() == 50_000_000
    t.cancel()
    assert t.is_canceled()
    ex.spin_for(1.0)
    assert len(calls) == 3
    t.reset()
    ex.spin_for(0.1)
    assert len(calls) == 4 and calls[-1] == 1_450_000_000
    off = n.create_timer(0.1, lambda: calls.append(-1), autostart=False)
    ex.spin_for(0.3)
    assert -1 not in calls and off.is_canceled()


def _spin_until_ticks(ex, times, n):
    """Spin until ``times`` holds ``n`` entries (a generous safety net, not a timing)."""
    deadline = time.monotonic() + 60.0
    while len(times) < n and time.monotonic() < deadline:
        ex.spin_once(timeout_sec=0.05)
    return len(times)


def test_wall_clock_timer_fires():
    # load-independent: wait for the callbacks themselves, and check the one timing property a
    # loaded machine cannot break: the k-th call never comes before k periods have passed
    ctx = Context()
    n = ctx.create_node("n")
    times = []
    period_ns = 2_000_000
    created = time.monotonic_ns()
    n.create_timer(period_ns / 1e9, lambda: times.append(time.monotonic_ns()))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    assert _spin_until_ticks(ex, times, 5) >= 5
    assert all(t >= created + k * period_ns for k, t in enumerate(times, start=1))
    assert times == sorted(times)


def test_same_node_code_runs_under_wall_and_sim_clock():
    def build(ctx):
        n = ctx.create_node("counter")
        n.ticks = 0
        n.times = []

        def tick():
            n.ticks += 1
            n.times.append(time.monotonic_ns())

        n.create_timer(0.01, tick)
        return n

    sim_ctx = Context(use_sim_time=True)
    node = build(sim_ctx)
    ex = SingleThreadedExecutor(context=sim_ctx)
    ex.add_node(node)
    ex.spin_for(1.0)
    assert node.ticks == 100
    wall_ctx = Context()
    created = time.monotonic_ns()
    node2 = build(wall_ctx)
    ex2 = SingleThreadedExecutor(context=wall_ctx)
    ex2.add_node(node2)
    assert _spin_until_ticks(ex2, node2.times, 3) >= 3
    assert all(t >= created + k * 10_000_000 for k, t in enumerate(node2.times, start=1))


def test_sleep_async_in_a_coroutine_under_sim_time():
    ctx = Context(use_sim_time=True)
    n = ctx.create_node("n")
    stamps = []

    async def worker():
        for _ in range(3):
            await n.sleep_async(0.5)
            stamps.append(ctx.sim.ns)
        return "done"

    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    task = ex.create_task(worker)
    ex.spin_until_future_complete(task, timeout_sec=10)
    assert task.result() == "done"
    assert stamps == [500_000_000, 1_000_000_000, 1_500_000_000]


def test_clock_sleep_for_refuses_sim_time():
    ctx = Context(use_sim_time=True)
    with pytest.raises(RuntimeError, match="simulated time"):
        ctx.create_node("n").get_clock().sleep_for(0.1)


def test_rate_sleep_needs_a_spinning_executor():
    ctx = Context()
    n = ctx.create_node("n")
    rate = n.create_rate(100)
    with pytest.raises(RuntimeError, match="no executor is spinning"):
        rate.sleep()
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    th = threading.Thread(target=ex.spin, daemon=True)
    th.start()
    while not ex.is_spinning_elsewhere():
        time.sleep(0.001)
    for _ in range(3):
        rate.sleep()
    ex.shutdown()
    th.join(5)
    assert not th.is_alive()
