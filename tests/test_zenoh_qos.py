"""QoS across the wire as rmw_zenoh maps it, and the in-process path kept (two contexts =
two zenoh sessions, in one test process)."""

import socket
import time

import pytest

from robocourse.bus.context import Context
from robocourse.bus.executors import SingleThreadedExecutor
from robocourse.bus.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from robocourse.bus.zenoh.transport import router
from robocourse.msgs.std_msgs import Int32


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


def _spin(ctx, node, cond, timeout=10.0):
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    end = time.monotonic() + timeout
    while time.monotonic() < end and not cond():
        ex.spin_once(timeout_sec=0.02)
    ex.remove_node(node)
    return cond()


def test_transient_local_late_joiner_gets_the_last_depth_samples_across_the_wire(two):
    a, b = two
    latched = QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = a.create_node("map_server").create_publisher(Int32, "/map", latched)
    for i in range(5):
        pub.publish(Int32(data=i))
    time.sleep(0.3)
    node = b.create_node("late")
    got = []
    node.create_subscription(Int32, "/map", lambda m: got.append(m.data), latched)
    assert _spin(b, node, lambda: len(got) >= 2)
    _spin(b, node, lambda: False, 0.3)
    assert got == [3, 4]


def test_local_subscription_gets_each_sample_once_and_the_remote_one_too(two):
    a, b = two
    na, nb = a.create_node("talker"), b.create_node("remote")
    local, remote = [], []
    na.create_subscription(Int32, "/n", lambda m: local.append(m.data), 100)
    nb.create_subscription(Int32, "/n", lambda m: remote.append(m.data), 100)
    pub = na.create_publisher(Int32, "/n", 100)
    assert a.transport.wait_for(lambda t: len(t.remote_entities("MS")) == 1)
    time.sleep(0.2)
    for i in range(20):
        pub.publish(Int32(data=i))
    assert _spin(b, nb, lambda: len(remote) == 20)
    _spin(a, na, lambda: len(local) >= 20)
    _spin(a, na, lambda: False, 0.2)
    assert local == list(range(20)) and remote == list(range(20))   # not doubled by zenoh


def test_best_effort_and_depth_travel_in_the_token(two):
    a, b = two
    be = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    a.create_node("sensor").create_publisher(Int32, "/scan", be)
    assert b.transport.wait_for(lambda t: t.remote_entities("MP"))
    [e] = b.transport.remote_entities("MP")
    assert e.key.endswith("/2::,5:,:,:,,")
    assert (e.qos.reliability, e.qos.depth) == (ReliabilityPolicy.BEST_EFFORT, 5)


def test_destroyed_publisher_token_is_withdrawn_and_sends_nothing(two):
    a, b = two
    na, nb = a.create_node("talker"), b.create_node("listener")
    pub = na.create_publisher(Int32, "/n", 10)
    got = []
    nb.create_subscription(Int32, "/n", lambda m: got.append(m.data), 10)
    assert b.transport.wait_for(lambda t: t.remote_entities("MP"))
    na.destroy_publisher(pub)
    assert b.transport.wait_for(lambda t: not t.remote_entities("MP"))
    assert pub._remote is None and pub._deliver == ()
