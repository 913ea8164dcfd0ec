"""Executors and callback groups, with real threads (counts and overlaps, no timing asserts)."""

import threading
import time

import pytest

from robocourse.bus import (
    Context,
    Future,
    MultiThreadedExecutor,
    MutuallyExclusiveCallbackGroup,
    ReentrantCallbackGroup,
    SingleThreadedExecutor,
)
from robocourse.msgs.std_msgs import Int64


class Overlap:
    """Records how many callbacks run at once; each callback waits for a partner briefly."""

    def __init__(self):
        self.lock = threading.Lock()
        self.active = 0
        self.max_active = 0
        self.calls = 0
        self.both_in = threading.Barrier(2, timeout=None)

    def work(self, wait_for_partner):
        with self.lock:
            self.active += 1
            self.calls += 1
            self.max_active = max(self.max_active, self.active)
        if wait_for_partner:
            try:
                self.both_in.wait(timeout=0.2)   # returns early only if a partner is inside too
            except threading.BrokenBarrierError:
                pass
        else:
            time.sleep(0.02)
        with self.lock:
            self.active -= 1


def spin_until(ex, cond, window=0.5, timeout=60.0):
    """Spin ``ex`` in windows of ``window`` s until ``cond()`` holds (a safety net of ``timeout`` s): a fixed
    window is a timed assertion, and a loaded machine ran no callback at all in one (0.1 s, 2 runs in 10)."""
    end = time.monotonic() + timeout
    ex.spin_for(window)
    while not cond() and time.monotonic() < end:
        ex.spin_for(window)


def two_timer_graph(group_factory, num_threads=2):
    ctx = Context()
    n = ctx.create_node("n")
    rec = Overlap()
    g1 = group_factory()
    g2 = g1 if group_factory is not None else None
    n.create_timer(0.01, lambda: rec.work(True), callback_group=g1)
    n.create_timer(0.01, lambda: rec.work(True), callback_group=g2)
    ex = MultiThreadedExecutor(num_threads=num_threads, context=ctx)
    ex.add_node(n)
    return ctx, ex, rec


def test_reentrant_callbacks_overlap_on_a_multithreaded_executor():
    ctx, ex, rec = two_timer_graph(ReentrantCallbackGroup)
    spin_until(ex, lambda: rec.max_active == 2)
    assert rec.calls >= 2
    assert rec.max_active == 2


def test_mutually_exclusive_callbacks_never_overlap():
    ctx, ex, rec = two_timer_graph(MutuallyExclusiveCallbackGroup)
    spin_until(ex, lambda: rec.calls >= 2)
    assert rec.calls >= 2
    assert rec.max_active == 1


def test_default_group_means_no_parallelism_even_with_many_threads():
    ctx = Context()
    n = ctx.create_node("n")
    rec = Overlap()
    n.create_timer(0.01, lambda: rec.work(True))
    n.create_timer(0.01, lambda: rec.work(True))
    ex = MultiThreadedExecutor(num_threads=4, context=ctx)
    ex.add_node(n)
    spin_until(ex, lambda: rec.calls >= 2)
    assert rec.calls >= 2 and rec.max_active == 1


def test_two_exclusive_groups_run_in_parallel():
    ctx = Context()
    n = ctx.create_node("n")
    rec = Overlap()
    n.create_timer(0.01, lambda: rec.work(True), callback_group=MutuallyExclusiveCallbackGroup())
    n.create_timer(0.01, lambda: rec.work(True), callback_group=MutuallyExclusiveCallbackGroup())
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(n)
    spin_until(ex, lambda: rec.max_active == 2)
    assert rec.max_active == 2


def test_single_threaded_executor_never_overlaps_even_reentrant():
    ctx = Context()
    n = ctx.create_node("n")
    rec = Overlap()
    g = ReentrantCallbackGroup()
    n.create_timer(0.01, lambda: rec.work(False), callback_group=g)
    n.create_timer(0.01, lambda: rec.work(False), callback_group=g)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    spin_until(ex, lambda: rec.calls >= 2, window=0.1)
    assert rec.calls >= 2 and rec.max_active == 1


def test_multithreaded_executor_in_sim_time_delivers_everything():
    ctx = Context(use_sim_time=True)
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", 100)
    k = [0]

    def tick():
        k[0] += 1
        pub.publish(Int64(data=k[0]))

    a.create_timer(0.01, tick)
    got = []
    lock = threading.Lock()

    def cb(m):
        with lock:
            got.append(m.data)

    b.create_subscription(Int64, "t", cb, 100, callback_group=ReentrantCallbackGroup())
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    ex.spin_for(1.0)
    assert ctx.now() == 1.0
    assert sorted(got) == list(range(1, 101))


def test_spin_once_runs_one_callback():
    ctx = Context(use_sim_time=True)
    n = ctx.create_node("n")
    pub = n.create_publisher(Int64, "t", 10)
    got = []
    n.create_subscription(Int64, "t", got.append, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    pub.publish(Int64(data=1))
    pub.publish(Int64(data=2))
    ex.spin_once(timeout_sec=0)
    assert len(got) == 1
    ex.spin_once(timeout_sec=0)
    assert len(got) == 2
    ex.spin_once(timeout_sec=0.5)    # nothing to do: sim time advances by the timeout
    assert ctx.now() == 0.5


def test_spin_until_future_complete_with_timeout_and_cross_thread_completion():
    ctx = Context(use_sim_time=True)
    n = ctx.create_node("n")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    never = Future()
    ex.spin_until_future_complete(never, timeout_sec=2.0)
    assert not never.done() and ctx.now() == 2.0
    f = Future()
    n.create_timer(0.3, lambda: f.set_result(ctx.now()))
    ex.spin_until_future_complete(f)
    assert f.result() == pytest.approx(2.3)
    wall = Context()
    wn = wall.create_node("w")
    wex = SingleThreadedExecutor(context=wall)
    wex.add_node(wn)
    g = Future()
    threading.Timer(0.02, lambda: g.set_result(42)).start()
    wex.spin_until_future_complete(g, timeout_sec=5)
    assert g.result() == 42


def test_cross_thread_publisher_wakes_a_sleeping_executor():
    ctx = Context()
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", 1000)
    got = []
    done = Future()

    def cb(m):
        got.append(m.data)
        if len(got) == 500:
            done.set_result(True)

    b.create_subscription(Int64, "t", cb, 1000)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b)

    def producer():
        for i in range(500):
            pub.publish(Int64(data=i))
            if i % 50 == 0:
                time.sleep(0.001)

    th = threading.Thread(target=producer)
    th.start()
    ex.spin_until_future_complete(done, timeout_sec=10)
    th.join()
    assert got == list(range(500))


def test_shutdown_while_callbacks_run():
    ctx = Context()
    n = ctx.create_node("n")
    started, release = threading.Event(), threading.Event()
    finished = []

    def slow():
        started.set()
        release.wait(5)
        finished.append(1)

    n.create_timer(0.001, slow, callback_group=ReentrantCallbackGroup())
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(n)
    th = threading.Thread(target=ex.spin)
    th.start()
    assert started.wait(5)
    ctx.shutdown()                   # while a callback is running
    release.set()
    th.join(5)
    assert not th.is_alive()         # spin returned
    count = len(finished)
    assert count >= 1                # the running callback completed
    ex2 = SingleThreadedExecutor(context=ctx)
    ex2.add_node(n)
    ex2.spin_for(0.05)               # a shut-down context runs nothing more
    assert len(finished) == count
    with pytest.raises(RuntimeError, match="twice"):
        ctx.shutdown()
    with pytest.raises(RuntimeError, match="shut down"):
        ctx.create_node("late")


def test_spinning_from_inside_a_callback_is_refused():
    ctx = Context(use_sim_time=True)
    n = ctx.create_node("n")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    n.create_timer(0.1, lambda: ex.spin_once(0))
    with pytest.raises(RuntimeError, match="already spinning on this thread"):
        ex.spin_for(0.5)
    assert len(ex.callback_errors) == 1 and not ex.is_spinning()
    log_mode = SingleThreadedExecutor(context=ctx, on_callback_error="log")
    log_mode.add_node(n)
    n.create_timer(0.1, lambda: log_mode.spin_once(0))
    log_mode.spin_for(0.5)      # keeps going: 5 ticks, each refused (the first timer spins `ex`)
    assert len(log_mode.callback_errors) == 5
    assert all("already spinning" in str(e.exception) for e in log_mode.callback_errors)


def test_rclpy_style_globals_init_spin_once_spin_until_future_complete_shutdown():
    import robocourse.bus as rclpy

    ctx = rclpy.init(use_sim_time=True)
    try:
        with pytest.raises(RuntimeError, match="twice"):
            rclpy.init()
        node = rclpy.create_node("solo")
        assert node.context is ctx and rclpy.ok()
        pub = node.create_publisher(Int64, "t", 10)
        got = []
        node.create_subscription(Int64, "t", got.append, 10)
        pub.publish(Int64(data=3))
        rclpy.spin_once(node, timeout_sec=0)
        assert [m.data for m in got] == [3]
        f = Future()
        node.create_timer(1.5, lambda: f.set_result("tick"))
        rclpy.spin_until_future_complete(node, f, timeout_sec=5)
        assert f.result() == "tick" and ctx.now() == 1.5
    finally:
        rclpy.shutdown()
    assert not rclpy.ok()
    with pytest.raises(RuntimeError, match="init"):
        rclpy.create_node("after")


def test_multi_threaded_spin_until_future_complete_returns_while_another_callback_runs():
    # rclpy returns as soon as the future is done; the old executor waited for every running
    # callback. The slow callback blocks until the test releases it, after spin returned.
    ctx = Context()
    ctx.log_to_stderr = False
    node = ctx.create_node("n")
    release, slow_started, slow_done = threading.Event(), threading.Event(), threading.Event()

    def slow():
        slow_started.set()
        release.wait(timeout=10.0)
        slow_done.set()

    # the timer has a group of its own, so at most one `finish` holds a thread while it waits:
    # the other thread is free for `slow` however late the machine lets it start (with a
    # reentrant group both threads could sit in `finish` and `slow` would never run)
    group = MutuallyExclusiveCallbackGroup()
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(node)
    ex.create_task(slow)
    future = Future()

    def finish():
        if slow_started.wait(timeout=30.0) and not future.done():
            future.set_result(42)

    t = node.create_timer(0.001, finish, callback_group=group)
    ex.spin_until_future_complete(future, timeout_sec=60.0)
    returned_while_running = not slow_done.is_set()
    t.cancel()
    release.set()
    assert future.result() == 42
    assert returned_while_running
    assert slow_done.wait(timeout=10.0)        # the slow callback still finishes on its thread


def test_multi_threaded_executor_spins_again_after_an_early_return():
    ctx = Context()
    ctx.log_to_stderr = False
    node = ctx.create_node("n")
    pub = node.create_publisher(Int64, "t", 10)
    got, all_three = [], Future()

    def on_msg(m):
        got.append(m.data)
        if len(got) == 3:
            all_three.set_result(True)

    node.create_subscription(Int64, "t", on_msg, 10)
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(node)
    for k in range(3):
        f = Future()
        ex.create_task(lambda f=f, k=k: (pub.publish(Int64(data=k)), f.set_result(k)))
        ex.spin_until_future_complete(f, timeout_sec=5.0)
        assert f.result() == k
    ex.spin_until_future_complete(all_three, timeout_sec=10.0)   # no fixed wall-time window to miss
    assert got == [0, 1, 2]


@pytest.mark.parametrize("call, exc, match", [
    (lambda ex: ex.spin_for("1"), TypeError, r"spin_for\(seconds\): seconds='1' must be a finite number of seconds"),
    (lambda ex: ex.spin_for(-1.0), ValueError, "seconds=-1.0 must be a finite number of seconds >= 0"),
    (lambda ex: ex.spin_for(float("nan")), ValueError, "seconds=nan"),
    (lambda ex: ex.spin_once("0.1"), TypeError, "timeout_sec='0.1'"),
    (lambda ex: ex.spin_until_future_complete(3), TypeError, "needs a Future"),
    (lambda ex: ex.spin_until_future_complete(Future(), timeout_sec="1"), TypeError, "timeout_sec='1'"),
    (lambda ex: ex.spin_some(0), ValueError, "max_callbacks=0 must be an int >= 1"),
    (lambda ex: ex.spin_until("soon"), TypeError, "t_ns='soon'"),
    (lambda ex: ex.add_node("talker"), TypeError, "add_node needs a Node"),
    (lambda ex: MultiThreadedExecutor(num_threads=0), ValueError, "num_threads=0 must be an int >= 1"),
])
def test_executor_entry_points_refuse_bad_arguments_before_spinning(call, exc, match):
    ex = SingleThreadedExecutor(context=Context(use_sim_time=True))
    with pytest.raises(exc, match=match):
        call(ex)


def test_negative_timeout_blocks_like_none_as_in_rclpy():
    ctx = Context(use_sim_time=True)
    node = ctx.create_node("n")
    got = []
    node.create_timer(0.5, lambda: got.append(1))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    ex.spin_once(timeout_sec=-1)          # rclpy: negative = wait until work
    assert got == [1]


def test_single_threaded_wake_signal_keeps_event_semantics():
    """The lock-based wake-up of SingleThreadedExecutor behaves like Event set/wait/clear:
    a wake before the sleep is consumed by it (no lost wake-up), repeated wakes collapse into
    one, and a wake from another thread ends an untimed sleep."""
    from robocourse.bus import SingleThreadedExecutor

    ex = SingleThreadedExecutor()
    assert ex._signal.locked()                  # unsignalled
    ex._wake()
    ex._wake()                                  # already signalled: no error, still one
    assert not ex._signal.locked()
    ex._sleep(60.0)                             # returns on the pending wake...
    assert ex._signal.locked()                  # ...and consumed it (wait + clear)
    sleeper = threading.Thread(target=ex._sleep, args=(None,), daemon=True)
    sleeper.start()
    while not ex._sleeping and sleeper.is_alive():
        time.sleep(0.001)
    ex._wake()                                  # another thread's wake ends an untimed sleep
    sleeper.join(30)
    assert not sleeper.is_alive()
    assert ex._sleeping == 0


def test_callback_exceptions_leave_spin_once_like_rclpy():
    # rclpy SingleThreadedExecutor._spin_once_impl: handler(); if handler.exception(): raise it
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    n = ctx.create_node("n")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    ticks = []

    def tick():
        ticks.append(len(ticks))
        if len(ticks) == 2:
            raise KeyError("second tick")

    n.create_timer(0.1, tick)
    ex.spin_once(timeout_sec=1.0)
    with pytest.raises(KeyError, match="second tick"):
        ex.spin_once(timeout_sec=1.0)
    ex.spin_once(timeout_sec=1.0)
    assert ticks == [0, 1, 2] and [type(e.exception) for e in ex.callback_errors] == [KeyError]

    # an async callback that fails after an await: raised by the spin call that ran that step
    async def later():
        await n.sleep_async(0.05)
        raise ValueError("after the await")

    t2 = n.create_timer(0.1, later)
    t_ticks = ticks.copy()
    with pytest.raises(ValueError, match="after the await"):
        ex.spin_for(0.5)
    n.destroy_timer(t2)
    assert len(ticks) > len(t_ticks)
    assert "timer callback of node '/n'" in ex.callback_errors[-1].where

    # a task: its exception is kept on the task and leaves spin, as rclpy's Task
    task = ex.create_task(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        ex.spin_until_future_complete(task)
    assert task.done() and isinstance(task.exception(), ZeroDivisionError)


def test_multithreaded_executor_reraises_a_callback_exception_from_spin():
    ctx = Context()
    ctx.log_to_stderr = False
    n = ctx.create_node("n")
    n.create_timer(0.01, lambda: (_ for _ in ()).throw(RuntimeError("pool callback failed")))
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(n)
    with pytest.raises(RuntimeError, match="pool callback failed"):
        ex.spin()
    assert not ex.is_spinning() and len(ex.callback_errors) >= 1
    log_mode = MultiThreadedExecutor(num_threads=2, context=ctx, on_callback_error="log")
    log_mode.add_node(n)
    spin_until(log_mode, lambda: len(log_mode.callback_errors) >= 2, window=0.1)  # keeps going, logs, records each
    assert len(log_mode.callback_errors) >= 2
