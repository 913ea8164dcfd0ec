"""Publishers and subscriptions: delivery, faults and the 1M-message burst."""

import struct

import pytest

from robocourse.bus import (
    Context,
    HistoryPolicy,
    InvalidHandle,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
)
from robocourse.bus import introspection as ros2
from robocourse.msgs.example_interfaces import AddTwoInts as AddTwoIntsSrv
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.std_msgs import Float64, Int64


def make(sim=True):
    ctx = Context(use_sim_time=sim)
    ctx.log_to_stderr = False
    ex = SingleThreadedExecutor(context=ctx)
    return ctx, ex


def test_publish_subscribe_in_order_with_namespaces():
    ctx, ex = make()
    a = ctx.create_node("talker", namespace="/robot")
    b = ctx.create_node("listener", namespace="/robot")
    pub = a.create_publisher(Float64, "x", 10)
    got = []
    b.create_subscription(Float64, "/robot/x", lambda m: got.append(m.data), 10)
    ex.add_node(a)
    ex.add_node(b)
    for i in range(5):
        pub.publish(Float64(data=float(i)))
    ex.spin_for(0.1)
    assert got == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_wrong_message_type_published_raises():
    ctx, ex = make()
    pub = ctx.create_node("n").create_publisher(Float64, "x", 10)
    with pytest.raises(TypeError, match=r"publishes std_msgs/msg/Float64, got geometry_msgs/msg/Twist"):
        pub.publish(Twist())
    with pytest.raises(TypeError, match="got float"):
        pub.publish(1.0)
    assert pub.publish_count == 0


def test_type_mismatch_on_a_topic_raises():
    ctx, ex = make()
    n = ctx.create_node("n")
    n.create_publisher(Float64, "x", 10)
    with pytest.raises(TypeError, match=r"carries std_msgs/msg/Float64.*Twist"):
        n.create_subscription(Twist, "x", lambda m: None, 10)
    with pytest.raises(TypeError, match="carries"):
        ctx.create_node("m").create_publisher(Int64, "/x", 10)
    with pytest.raises(TypeError, match="message class"):
        n.create_publisher("std_msgs/Float64", "y", 10)


def test_calling_a_destroyed_publisher_raises():
    ctx, ex = make()
    n = ctx.create_node("n")
    pub = n.create_publisher(Float64, "x", 10)
    pub.destroy()
    with pytest.raises(InvalidHandle, match="destroyed"):
        pub.publish(Float64())
    pub2 = n.create_publisher(Float64, "y", 10)
    n.destroy_node()
    with pytest.raises(InvalidHandle):
        pub2.publish(Float64())
    with pytest.raises(InvalidHandle):
        n.create_publisher(Float64, "z", 10)


def _raising_graph(ex_kwargs=None):
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    ex = SingleThreadedExecutor(context=ctx, **(ex_kwargs or {}))
    a, b = ctx.create_node("talker"), ctx.create_node("listener")
    pub = a.create_publisher(Int64, "numbers", 10)
    got = []

    def cb(m):
        if m.data == 2:
            raise ValueError("two is bad")
        got.append(m.data)

    b.create_subscription(Int64, "numbers", cb, 10)
    ex.add_node(a)
    ex.add_node(b)
    for i in range(5):
        pub.publish(Int64(data=i))
    return ctx, ex, got


def test_subscriber_callback_raising_leaves_spin_like_rclpy():
    # rclpy's executor re-raises a callback's exception out of spin_once / spin; the executor
    # stays usable and the next spin call takes the remaining messages
    ctx, ex, got = _raising_graph()
    with pytest.raises(ValueError, match="two is bad"):
        ex.spin_for(0.1)
    assert got == [0, 1]
    assert not ex.is_spinning()
    ex.spin_for(0.1)
    assert got == [0, 1, 3, 4]
    assert len(ex.callback_errors) == 1             # recorded as well, nothing is lost
    err = ex.callback_errors[0]
    assert "topic '/numbers'" in err.where and "node '/listener'" in err.where
    assert isinstance(err.exception, ValueError) and ctx.callback_errors == [err]
    assert not [r for r in ctx.log_records if r.severity.name == "ERROR"]


def test_subscriber_callback_raising_in_log_mode_is_reported_and_executor_keeps_running():
    ctx, ex, got = _raising_graph({"on_callback_error": "log"})
    ex.spin_for(0.1)
    assert got == [0, 1, 3, 4]
    assert len(ex.callback_errors) == 1
    err = ex.callback_errors[0]
    assert "topic '/numbers'" in err.where and "node '/listener'" in err.where
    assert isinstance(err.exception, ValueError)
    logged = [r for r in ctx.log_records if r.severity.name == "ERROR"]
    assert len(logged) == 1 and "two is bad" in logged[0].msg and logged[0].name == "listener"
    with pytest.raises(ValueError, match="'raise'.*'log'"):
        SingleThreadedExecutor(context=ctx, on_callback_error="ignore")


def test_duplicate_node_names_warn_and_both_work(capsys):
    ctx, ex = make()
    a1 = ctx.create_node("twin")
    a2 = ctx.create_node("twin")
    warnings = [r.msg for r in ctx.log_records if r.severity.name == "WARN"]
    assert len(warnings) == 1 and "already exists" in warnings[0]
    p = a1.create_publisher(Int64, "t", 10)
    got = []
    a2.create_subscription(Int64, "t", got.append, 10)
    ex.add_node(a1)
    ex.add_node(a2)
    p.publish(Int64(data=1))
    ex.spin_for(0.01)
    assert len(got) == 1
    names = ros2.node_list(ctx)
    assert names == ["/twin", "/twin"]
    assert "share an exact name" in capsys.readouterr().out


def test_messages_published_before_the_node_is_added_are_kept():
    ctx, ex = make()
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", 10)
    got = []
    b.create_subscription(Int64, "t", lambda m: got.append(m.data), 10)
    pub.publish(Int64(data=1))
    ex.add_node(b)
    ex.spin_for(0.01)
    assert got == [1]


def test_reliable_keep_all_delivers_a_million_messages_in_order():
    ctx, ex = make()
    a, b = ctx.create_node("burst_pub"), ctx.create_node("burst_sub")
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    pub = a.create_publisher(Int64, "burst", qos)
    n = 1_000_000
    state = {"next": 0, "bad": 0}

    def cb(m):
        if m.data != state["next"]:
            state["bad"] += 1
        state["next"] += 1

    sub = b.create_subscription(Int64, "burst", cb, qos)
    ex.add_node(a)
    ex.add_node(b)
    msg = [Int64(data=i) for i in range(n)]
    publish = pub.publish
    for m in msg:
        publish(m)
    assert len(sub._queue) == n          # nothing dropped while the executor was not spinning
    ex.spin_for(0.001)
    assert state == {"next": n, "bad": 0}
    assert sub.receive_count == n and sub.counts.dropped_keep_last == 0


def test_raw_subscription_gets_cdr_bytes():
    ctx, ex = make()
    n = ctx.create_node("n")
    pub = n.create_publisher(Float64, "x", 10)
    got = []
    n.create_subscription(Float64, "x", got.append, 10, raw=True)
    ex.add_node(n)
    pub.publish(Float64(data=1.0))
    ex.spin_for(0.001)
    # CDR: little-endian encapsulation header 00 01 00 00, then the float64
    assert got == [bytes.fromhex("00010000") + struct.pack("<d", 1.0)]


@pytest.mark.parametrize("call, exc, match", [
    (lambda n: n.create_publisher(Int64, 5, 10), TypeError, "create_publisher: topic=5 must be a non-empty str"),
    (lambda n: n.create_subscription(Int64, "t", "print", 10), TypeError,
     "create_subscription: callback='print' must be callable"),
    (lambda n: n.create_timer("0.1", lambda: None), TypeError,
     r"create_timer\(timer_period_sec\): timer_period_sec='0.1' must be a finite number of seconds"),
    (lambda n: n.create_timer(-0.1, lambda: None), ValueError, "timer_period_sec=-0.1"),
    (lambda n: n.create_publisher(Int64, "t", "10"), TypeError, "qos_profile must be a QoSProfile or an int depth"),
    (lambda n: n.create_client(AddTwoIntsSrv, None), TypeError, "srv_name=None must be a non-empty str"),
])
def test_node_entry_points_refuse_bad_arguments(call, exc, match):
    node = Context().create_node("n")
    with pytest.raises(exc, match=match):
        call(node)


def test_context_refuses_bad_arguments():
    with pytest.raises(TypeError, match="use_sim_time='yes' must be True or False"):
        Context(use_sim_time="yes")
    with pytest.raises(ValueError, match="start_time=-1"):
        Context(use_sim_time=True, start_time=-1)
