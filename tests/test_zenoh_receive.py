"""The zenoh transport under a burst (issue 31's throughput work must not change this): every
sample of a flood arrives, in order, each a value of its own, whatever the executor and the
receive path do to go faster."""

import time

from test_zenoh_qos import _spin

from robocourse.bus.qos import HistoryPolicy, QoSProfile
from robocourse.msgs.std_msgs import Int32

KEEP_ALL = QoSProfile(depth=10, history=HistoryPolicy.KEEP_ALL)


def _matched(a, topic):
    assert a.transport.wait_for(
        lambda t: [e for e in t.remote_entities("MS") if e.topic == topic], 10)
    time.sleep(0.2)


def test_a_burst_arrives_whole_in_order_and_each_sample_is_its_own_value(zenoh_pair):
    a, b = zenoh_pair
    nb = b.create_node("listener")
    got = []
    nb.create_subscription(Int32, "/burst", got.append, KEEP_ALL)
    pub = a.create_node("talker").create_publisher(Int32, "/burst", KEEP_ALL)
    _matched(a, "/burst")
    msg = Int32()
    for i in range(2000):           # one object, changed after each publish
        msg.data = i
        pub.publish(msg)
    assert _spin(b, nb, lambda: len(got) == 2000, timeout=20.0)
    assert [m.data for m in got] == list(range(2000))
    assert len({id(m) for m in got}) == 2000
    got[0].data = -1                # a received message is the subscriber's own
    assert got[1].data == 1
