"""The zenoh transport's receive side: one thread per subscription takes every sample zenoh
has queued in one go (subscriber-side batching, issue 31). What must not change with it: every
sample arrives, in order, each a value of its own; a fault in delivery is counted, logged once
and survived; the thread ends with its subscription and with the context."""

import socket
import threading
import time

import pytest

from robocourse.bus.context import Context
from robocourse.bus.executors import SingleThreadedExecutor
from robocourse.bus.qos import HistoryPolicy, QoSProfile
from robocourse.bus.zenoh.transport import router
from robocourse.msgs.std_msgs import Int32

KEEP_ALL = QoSProfile(depth=10, history=HistoryPolicy.KEEP_ALL)


@pytest.fixture
def two():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        ep = f"tcp/127.0.0.1:{s.getsockname()[1]}"
    r = router([ep])
    a = Context(transport="zenoh", connect=[ep])
    b = Context(transport="zenoh", connect=[ep])
    yield a, b
    a.try_shutdown()
    b.try_shutdown()
    r.close()


def _receivers(topic):
    return [t for t in threading.enumerate() if t.name == f"zenoh-sub {topic}"]


def _spin(ctx, node, cond, timeout=20.0):
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    end = time.monotonic() + timeout
    while time.monotonic() < end and not cond():
        ex.spin_once(timeout_sec=0.02)
    ex.remove_node(node)
    return cond()


def _matched(a, topic):
    assert a.transport.wait_for(
        lambda t: [e for e in t.remote_entities("MS") if e.topic == topic], 10)
    time.sleep(0.2)


def test_a_burst_arrives_whole_in_order_and_each_sample_is_its_own_value(two):
    a, b = two
    nb = b.create_node("listener")
    got = []
    nb.create_subscription(Int32, "/burst", got.append, KEEP_ALL)
    pub = a.create_node("talker").create_publisher(Int32, "/burst", KEEP_ALL)
    _matched(a, "/burst")
    msg = Int32()
    for i in range(2000):           # one object, changed after each publish
        msg.data = i
        pub.publish(msg)
    assert _spin(b, nb, lambda: len(got) == 2000)
    assert [m.data for m in got] == list(range(2000))
    assert len({id(m) for m in got}) == 2000
    got[0].data = -1                # a received message is the subscriber's own
    assert got[1].data == 1
    assert b.transport.receive_errors == 0


def test_a_delivery_fault_is_counted_logged_once_and_survived(two):
    a, b = two
    nb = b.create_node("listener")
    got = []
    sub = nb.create_subscription(Int32, "/faulty", lambda m: got.append(m.data), KEEP_ALL)
    deliver, calls = sub._deliver, []

    def flaky(msg):                 # the first two deliveries fail (a bug, not bad data)
        calls.append(msg.data)
        if len(calls) <= 2:
            raise RuntimeError("injected delivery fault")
        deliver(msg)
    sub._deliver = flaky
    pub = a.create_node("talker").create_publisher(Int32, "/faulty", KEEP_ALL)
    _matched(a, "/faulty")
    for i in range(5):
        pub.publish(Int32(data=i))
    assert _spin(b, nb, lambda: len(got) == 3)
    assert got == [2, 3, 4] and b.transport.receive_errors == 2
    logged = [r.msg for r in b.log_records if "transport.receive_errors" in r.msg]
    assert len(logged) == 1 and "injected delivery fault" in logged[0] and "/faulty" in logged[0]
    assert len(_receivers("/faulty")) == 1      # the thread lived on


def test_the_receive_thread_ends_with_its_subscription_and_with_the_context(two):
    _a, b = two
    node = b.create_node("listener")
    sub = node.create_subscription(Int32, "/gone", lambda m: None, 10)
    node.create_subscription(Int32, "/kept", lambda m: None, 10)
    assert len(_receivers("/gone")) == 1 and len(_receivers("/kept")) == 1
    node.destroy_subscription(sub)
    end = time.monotonic() + 10
    while _receivers("/gone") and time.monotonic() < end:
        time.sleep(0.01)
    assert _receivers("/gone") == [] and len(_receivers("/kept")) == 1
    b.try_shutdown()
    end = time.monotonic() + 10
    while _receivers("/kept") and time.monotonic() < end:
        time.sleep(0.01)
    assert _receivers("/kept") == []
