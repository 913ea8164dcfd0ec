"""QoS across the wire as rmw_zenoh maps it, and the in-process path kept (two contexts =
two zenoh sessions, in one test process)."""

import struct
import time

import pytest
import zenoh

from robocourse.bus.executors import SingleThreadedExecutor
from robocourse.bus.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from robocourse.bus.zenoh import wire
from robocourse.bus.zenoh.transport import HEARTBEAT_PERIOD, ZenohQoS, zenoh_qos
from robocourse.msgs.std_msgs import Int32, String


def _remote(transport, kind, topic):
    """The other context's endpoints of ``kind`` on ``topic`` (every node also has its
    /rosout and /parameter_events publishers and its parameter services, as in ROS 2)."""
    return [e for e in transport.remote_entities(kind) if e.topic == topic]


def _spin(ctx, node, cond, timeout=10.0):
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    end = time.monotonic() + timeout
    while time.monotonic() < end and not cond():
        ex.spin_once(timeout_sec=0.02)
    ex.remove_node(node)
    return cond()


@pytest.mark.parametrize("pub_qos, sub_qos, want", [
    # RELIABLE on both sides: the subscriber also recovers by heartbeat
    (QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL),
     QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL), [3, 4]),
    # a BEST_EFFORT cache (no heartbeat) still serves a RELIABLE subscriber's history query
    (QoSProfile(depth=3, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                reliability=ReliabilityPolicy.BEST_EFFORT),
     QoSProfile(depth=3, durability=DurabilityPolicy.TRANSIENT_LOCAL), [2, 3, 4]),
])
def test_transient_local_late_joiner_gets_the_last_depth_samples_across_the_wire(
        zenoh_pair, pub_qos, sub_qos, want):
    a, b = zenoh_pair
    pub = a.create_node("map_server").create_publisher(Int32, "/map", pub_qos)
    for i in range(5):
        pub.publish(Int32(data=i))
    time.sleep(0.3)
    node = b.create_node("late")
    got = []
    node.create_subscription(Int32, "/map", lambda m: got.append(m.data), sub_qos)
    assert _spin(b, node, lambda: len(got) >= len(want))
    _spin(b, node, lambda: False, 0.3)
    assert got == want


def test_local_subscription_gets_each_sample_once_and_the_remote_one_too(zenoh_pair):
    a, b = zenoh_pair
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


def test_best_effort_and_depth_travel_in_the_token(zenoh_pair):
    a, b = zenoh_pair
    be = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    a.create_node("sensor").create_publisher(Int32, "/scan", be)
    assert b.transport.wait_for(lambda t: _remote(t, "MP", "/scan"))
    [e] = _remote(b.transport, "MP", "/scan")
    assert e.key.endswith("/2::,5:,:,:,,")
    assert (e.qos.reliability, e.qos.depth) == (ReliabilityPolicy.BEST_EFFORT, 5)


def test_destroyed_publisher_token_is_withdrawn_and_sends_nothing(zenoh_pair):
    a, b = zenoh_pair
    na, nb = a.create_node("talker"), b.create_node("listener")
    pub = na.create_publisher(Int32, "/n", 10)
    got = []
    nb.create_subscription(Int32, "/n", lambda m: got.append(m.data), 10)
    assert b.transport.wait_for(lambda t: _remote(t, "MP", "/n"))
    na.destroy_publisher(pub)
    assert b.transport.wait_for(lambda t: not _remote(t, "MP", "/n"))
    assert pub._remote is None and pub._deliver == ()


KEEP_ALL, KEEP_LAST = HistoryPolicy.KEEP_ALL, HistoryPolicy.KEEP_LAST
RELIABLE, BEST_EFFORT = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT
VOLATILE, TRANSIENT_LOCAL = DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL


@pytest.mark.parametrize("history, reliability, durability, depth, want", [
    (KEEP_ALL, RELIABLE, VOLATILE, 5, ZenohQoS(True, True, None, None, False)),
    (KEEP_LAST, RELIABLE, VOLATILE, 5, ZenohQoS(True, False, None, None, False)),
    (KEEP_ALL, BEST_EFFORT, VOLATILE, 5, ZenohQoS(False, False, None, None, False)),
    (KEEP_LAST, BEST_EFFORT, VOLATILE, 5, ZenohQoS(False, False, None, None, False)),
    (KEEP_LAST, RELIABLE, TRANSIENT_LOCAL, 3, ZenohQoS(True, False, 3, 0.5, True)),
    (KEEP_ALL, RELIABLE, TRANSIENT_LOCAL, 3, ZenohQoS(True, True, 3, 0.5, True)),
    (KEEP_LAST, BEST_EFFORT, TRANSIENT_LOCAL, 4, ZenohQoS(False, False, 4, None, False)),
    (KEEP_ALL, RELIABLE, TRANSIENT_LOCAL, 0, ZenohQoS(True, True, 1, 0.5, True)),
])
def test_qos_maps_to_zenoh_as_rmw_zenoh_does(history, reliability, durability, depth, want):
    """KEEP_ALL + RELIABLE -> BLOCK, otherwise DROP; TRANSIENT_LOCAL -> cache/history of depth;
    RELIABLE + TRANSIENT_LOCAL -> 0.5 s sporadic heartbeat and recovery by heartbeat."""
    qos = QoSProfile(history=history, depth=depth, reliability=reliability, durability=durability)
    assert zenoh_qos(qos) == want
    assert HEARTBEAT_PERIOD == 0.5


def test_congestion_control_and_reliability_on_the_wire(zenoh_pair):
    a, b = zenoh_pair
    seen = {}
    raw = b.transport.session.declare_subscriber(
        "0/**", lambda s: seen.setdefault(str(s.key_expr).split("/")[1], s.congestion_control))
    node = a.create_node("qos_talker")
    cases = {"ka_rel": (KEEP_ALL, RELIABLE), "kl_rel": (KEEP_LAST, RELIABLE),
             "ka_be": (KEEP_ALL, BEST_EFFORT), "kl_be": (KEEP_LAST, BEST_EFFORT)}
    pubs = {k: node.create_publisher(Int32, f"/{k}", QoSProfile(depth=5, history=h, reliability=r))
            for k, (h, r) in cases.items()}
    assert b.transport.wait_for(lambda t: sum(len(_remote(t, "MP", f"/{k}")) for k in cases) == 4)
    deadline = time.monotonic() + 10
    while len(seen) < 4 and time.monotonic() < deadline:
        for p in pubs.values():
            p.publish(Int32(data=1))
        time.sleep(0.05)
    raw.undeclare()
    cc = zenoh.CongestionControl
    assert seen == {"ka_rel": cc.BLOCK, "kl_rel": cc.DROP, "ka_be": cc.DROP, "kl_be": cc.DROP}
    # reliability is a property of the zenoh publisher the samples leave through
    rel = {k: a.transport._local[p].zobj.reliability for k, p in pubs.items()}
    assert rel == {"ka_rel": zenoh.Reliability.RELIABLE, "kl_rel": zenoh.Reliability.RELIABLE,
                   "ka_be": zenoh.Reliability.BEST_EFFORT, "kl_be": zenoh.Reliability.BEST_EFFORT}


def test_reliable_transient_local_publisher_sends_sporadic_miss_detection_heartbeats(zenoh_pair):
    """zenoh-ext's heartbeat travels on ``<key>/@adv/pub/<zid>/<eid>/...`` carrying the last
    sequence number; sporadic: once per 0.5 s period, and only after a publication."""
    a, b = zenoh_pair
    node = a.create_node("latched")
    rel = node.create_publisher(Int32, "/rel_tl", QoSProfile(depth=2, durability=TRANSIENT_LOCAL))
    be = node.create_publisher(Int32, "/be_tl", QoSProfile(depth=2, durability=TRANSIENT_LOCAL,
                                                           reliability=BEST_EFFORT))
    beats = []
    for key in (wire.data_key(0, "/rel_tl", Int32), wire.data_key(0, "/be_tl", Int32)):
        b.transport.session.declare_subscriber(
            f"{key}/@adv/pub/**", lambda s: beats.append((str(s.key_expr), s.payload.to_bytes())))
    time.sleep(3 * HEARTBEAT_PERIOD)
    assert beats == []                        # sporadic: nothing published, nothing to report
    rel.publish(Int32(data=1))
    be.publish(Int32(data=1))
    deadline = time.monotonic() + 10
    while not beats and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(3 * HEARTBEAT_PERIOD)
    assert len(beats) == 1, beats             # one heartbeat: the sequence number changed once
    key, payload = beats[0]
    assert key.startswith(wire.data_key(0, "/rel_tl", Int32) + f"/@adv/pub/{a.transport.zid}/")
    assert struct.unpack("<I", payload) == (0,)   # the first sample's sequence number


def test_a_peer_with_another_type_on_our_name_never_communicates_and_is_named(zenoh_pair):
    a, b = zenoh_pair
    pub = a.create_node("int_talker").create_publisher(Int32, "/chatter", 10)
    listener = b.create_node("listener")
    got = []
    listener.create_subscription(String, "/chatter", got.append, 10)
    t = b.transport
    assert t.wait_for(lambda t: t.mismatches, 10)
    for i in range(20):
        pub.publish(Int32(data=i))
    _spin(b, listener, lambda: False, 0.5)
    assert got == []
    [text] = t.mismatches
    assert "std_msgs/msg/Int32" in text and "std_msgs/msg/String" in text
    assert "publisher of remote node '/int_talker'" in text and "never communicate" in text
    assert wire.type_hash(Int32) in text and wire.type_hash(String) in text
    warned = [r for r in b.log_records if "never communicate" in r.msg]
    assert len(warned) == 1 and warned[0].name == "listener"
    # and the other side warns too, about our subscription
    assert a.transport.wait_for(lambda t: len(t.mismatches) == 1, 10)
    assert "subscription of remote node '/listener'" in a.transport.mismatches[0]
