"""The zenoh transport under a burst (issue 31's throughput work must not change this): every
sample of a flood arrives, in order, each a value of its own, whatever the executor and the
receive path do to go faster."""

import socket
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
