"""QoS: the compatibility table row by row, events on both sides, history, durability, lifespan,
deadline, liveliness and matched events."""

import math

import pytest

from robocourse.bus import (
    Context,
    DurabilityPolicy,
    HistoryPolicy,
    InvalidQoSProfileException,
    LivelinessPolicy,
    PublisherEventCallbacks,
    QoSCompatibility,
    QoSPolicyKind,
    QoSPresetProfiles,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
    SubscriptionEventCallbacks,
    qos_check_compatible,
    qos_profile_sensor_data,
)
from robocourse.bus.qos import qos_profile_action_status_default, qos_profile_parameters
from robocourse.msgs.std_msgs import Int64

R, BE = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT
V, TL = DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL
AUTO, MANUAL = LivelinessPolicy.AUTOMATIC, LivelinessPolicy.MANUAL_BY_TOPIC


def q(**kw):
    kw.setdefault("depth", 10)
    return QoSProfile(**kw)


# (publisher offers, subscription requests, incompatible policy or None, reason fragment)
TABLE = [
    (q(reliability=BE), q(reliability=R), QoSPolicyKind.RELIABILITY,
     "Best effort publisher and reliable subscription"),
    (q(durability=V), q(durability=TL), QoSPolicyKind.DURABILITY,
     "Volatile publisher and transient local subscription"),
    (q(), q(deadline=0.1), QoSPolicyKind.DEADLINE,
     "Subscription has a deadline, but publisher does not"),
    (q(deadline=0.2), q(deadline=0.1), QoSPolicyKind.DEADLINE,
     "Subscription deadline is less than publisher deadline"),
    (q(liveliness=AUTO), q(liveliness=MANUAL), QoSPolicyKind.LIVELINESS,
     "Publisher's liveliness is automatic and subscription's is manual by topic"),
    (q(liveliness=AUTO), q(liveliness=AUTO, liveliness_lease_duration=1.0),
     QoSPolicyKind.LIVELINESS_LEASE_DURATION,
     "Subscription has a liveliness lease duration, but publisher does not"),
    (q(liveliness=AUTO, liveliness_lease_duration=2.0), q(liveliness=AUTO, liveliness_lease_duration=1.0),
     QoSPolicyKind.LIVELINESS_LEASE_DURATION,
     "Subscription liveliness lease duration is less than publisher"),
    # compatible counterparts of each row
    (q(reliability=R), q(reliability=BE), None, ""),
    (q(reliability=R), q(reliability=R), None, ""),
    (q(reliability=BE), q(reliability=BE), None, ""),
    (q(durability=TL), q(durability=V), None, ""),
    (q(durability=TL), q(durability=TL), None, ""),
    (q(deadline=0.1), q(), None, ""),
    (q(deadline=0.1), q(deadline=0.2), None, ""),
    (q(deadline=0.1), q(deadline=0.1), None, ""),
    (q(liveliness=MANUAL), q(liveliness=AUTO), None, ""),
    (q(liveliness=MANUAL), q(liveliness=MANUAL), None, ""),
    (q(liveliness=AUTO, liveliness_lease_duration=1.0), q(liveliness=AUTO), None, ""),
    (q(liveliness=AUTO, liveliness_lease_duration=1.0), q(liveliness=AUTO, liveliness_lease_duration=2.0), None, ""),
    # history, depth and lifespan never affect matching
    (q(history=HistoryPolicy.KEEP_ALL), q(depth=5), None, ""),
    (q(depth=1), QoSProfile(history=HistoryPolicy.KEEP_ALL), None, ""),
    (q(depth=1, lifespan=0.001), q(depth=100), None, ""),
    # a BEST_AVAILABLE subscription adapts to anything
    (q(reliability=BE, durability=V), q(reliability=ReliabilityPolicy.BEST_AVAILABLE,
                                        durability=DurabilityPolicy.BEST_AVAILABLE), None, ""),
]


@pytest.mark.parametrize("pub_qos,sub_qos,policy,reason", TABLE)
def test_compatibility_table_row(pub_qos, sub_qos, policy, reason):
    res = qos_check_compatible(pub_qos, sub_qos)
    if policy is None:
        assert res.compatibility != QoSCompatibility.ERROR
        return
    assert res.compatibility == QoSCompatibility.ERROR
    assert res.policy == policy
    assert reason in res.reason


@pytest.mark.parametrize("pub_qos,sub_qos,policy,reason", TABLE)
def test_table_row_on_a_live_graph(pub_qos, sub_qos, policy, reason):
    """Incompatible pairs exchange nothing and raise the event on both sides; compatible ones
    exchange every message."""
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    a, b = ctx.create_node("pub_node"), ctx.create_node("sub_node")
    pub_events, sub_events, got = [], [], []
    pub = a.create_publisher(Int64, "t", pub_qos,
                             event_callbacks=PublisherEventCallbacks(incompatible_qos=pub_events.append))
    sub = b.create_subscription(Int64, "t", got.append, sub_qos,
                                event_callbacks=SubscriptionEventCallbacks(incompatible_qos=sub_events.append))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    for i in range(3):
        pub.publish(Int64(data=i))
    ex.spin_for(0.0001)   # shorter than any lifespan/deadline in the table
    if policy is None:
        assert [m.data for m in got] == [0, 1, 2]
        assert pub_events == sub_events == []
        assert pub.get_subscription_count() == 1 and sub.get_publisher_count() == 1
    else:
        assert got == []
        assert len(pub_events) == 1 and len(sub_events) == 1
        assert pub_events[0].last_policy_kind == policy == sub_events[0].last_policy_kind
        assert pub_events[0].total_count == 1 and sub_events[0].total_count_change == 1
        assert pub.get_subscription_count() == 0
        assert len(ctx.incompatibilities) == 1 and reason in ctx.incompatibilities[0].reason


def test_default_handlers_log_the_ros_warning_on_both_sides():
    ctx = Context()
    ctx.log_to_stderr = False
    a, b = ctx.create_node("talker"), ctx.create_node("listener")
    a.create_publisher(Int64, "/chatter", q(reliability=BE))
    b.create_subscription(Int64, "/chatter", lambda m: None, q(reliability=R))
    texts = [(r.name, r.severity.name, r.msg) for r in ctx.log_records]
    assert ("listener", "WARN",
            "New publisher discovered on topic '/chatter', offering incompatible QoS. No messages "
            "will be received from it. Last incompatible policy: RELIABILITY_QOS_POLICY") in texts
    assert ("talker", "WARN",
            "New subscription discovered on topic '/chatter', requesting incompatible QoS. No "
            "messages will be sent to it. Last incompatible policy: RELIABILITY_QOS_POLICY") in texts


def test_one_publisher_serves_compatible_and_incompatible_subscriptions_per_pair():
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", q(reliability=BE))
    ok, bad = [], []
    b.create_subscription(Int64, "t", ok.append, q(reliability=BE))
    b.create_subscription(Int64, "t", bad.append, q(reliability=R))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    pub.publish(Int64(data=7))
    ex.spin_for(0.01)
    assert [m.data for m in ok] == [7] and bad == []


def test_check_compatible_returns_rclpys_tuple():
    # rclpy: `compatibility, reason = qos_check_compatible(publisher_qos, subscription_qos)`
    compatibility, reason = qos_check_compatible(q(reliability=BE), q(reliability=R))
    assert compatibility == QoSCompatibility.ERROR
    assert reason == "ERROR: Best effort publisher and reliable subscription;"
    res = qos_check_compatible(q(), q())
    assert tuple(res) == (QoSCompatibility.OK, "") and len(res) == 2
    assert res == (QoSCompatibility.OK, "") and res.compatibility == QoSCompatibility.OK
    assert res.policy is None


def test_system_default_gives_a_warning_not_an_error():
    res = qos_check_compatible(QoSProfile(depth=1, reliability=ReliabilityPolicy.SYSTEM_DEFAULT), q())
    assert res.compatibility == QoSCompatibility.WARNING and "SYSTEM_DEFAULT" in res.reason


def test_keep_last_depth_zero_warns_and_keeps_the_system_default_depth():
    # rclpy (Jazzy+): "A zero depth with KEEP_LAST doesn't make sense; no data could be stored.
    # This will be interpreted as SYSTEM_DEFAULT" -- a warning, the profile keeps depth 0
    with pytest.warns(UserWarning, match="zero depth with KEEP_LAST.*SYSTEM_DEFAULT"):
        q = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=0)
    assert q.depth == 0 and q.history == HistoryPolicy.KEEP_LAST
    with pytest.raises(InvalidQoSProfileException, match="history policy or a depth"):
        QoSProfile()
    with pytest.raises(InvalidQoSProfileException, match="KEEP_LAST without a depth"):
        QoSProfile(history=HistoryPolicy.KEEP_LAST)
    with pytest.raises(InvalidQoSProfileException):
        QoSProfile(depth=1, deadline=-1.0)
    ctx = Context()
    node = ctx.create_node("n")
    with pytest.warns(UserWarning, match="zero depth"):
        pub = node.create_publisher(Int64, "t", 0)     # an int is KEEP_LAST depth, like rclpy
        got = []
        node.create_subscription(Int64, "t", lambda m: got.append(m.data), 0)
    for i in range(50):
        pub.publish(Int64(data=i))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    ex.spin_some()
    # depth 0 = the middleware's default: rmw_zenoh's 42 (qos.cpp best_available_qos)
    assert got == list(range(8, 50))
    with pytest.raises(TypeError):
        node.create_publisher(Int64, "t", "reliable")


def test_presets_match_ros():
    assert (qos_profile_sensor_data.depth, qos_profile_sensor_data.reliability,
            qos_profile_sensor_data.durability) == (5, BE, V)
    d = QoSPresetProfiles.DEFAULT.value
    assert (d.history, d.depth, d.reliability, d.durability) == (HistoryPolicy.KEEP_LAST, 10, R, V)
    assert qos_profile_parameters.depth == 1000
    s = qos_profile_action_status_default
    assert (s.depth, s.reliability, s.durability) == (1, R, TL)
    assert math.isinf(d.deadline) and math.isinf(d.lifespan)
    assert QoSPresetProfiles.get_from_short_key("sensor_data") is qos_profile_sensor_data


def _graph(pub_qos, sub_qos=None):
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", pub_qos)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    return ctx, a, b, pub, ex


def test_keep_last_drops_oldest_and_keep_all_keeps_all():
    ctx, a, b, pub, ex = _graph(q(depth=10))
    last, every = [], []
    s_last = b.create_subscription(Int64, "t", lambda m: last.append(m.data), q(depth=3))
    b.create_subscription(Int64, "t", lambda m: every.append(m.data), QoSProfile(history=HistoryPolicy.KEEP_ALL))
    for i in range(10):
        pub.publish(Int64(data=i))
    ex.spin_for(0.01)
    assert last == [7, 8, 9]
    assert s_last.counts.dropped_keep_last == 7
    assert every == list(range(10))


def test_transient_local_late_joiner_gets_last_depth_samples():
    ctx, a, b, pub, ex = _graph(q(depth=3, durability=TL))
    for i in range(5):
        pub.publish(Int64(data=i))
    late_tl, late_v = [], []
    b.create_subscription(Int64, "t", lambda m: late_tl.append(m.data), q(depth=10, durability=TL))
    b.create_subscription(Int64, "t", lambda m: late_v.append(m.data), q(depth=10, durability=V))
    ex.spin_for(0.01)
    assert late_tl == [2, 3, 4]
    assert late_v == []
    pub.publish(Int64(data=5))
    ex.spin_for(0.01)
    assert late_tl == [2, 3, 4, 5] and late_v == [5]


def test_each_publisher_replays_its_own_history():
    ctx, a, b, pub, ex = _graph(q(depth=2, durability=TL))
    pub2 = a.create_publisher(Int64, "t", q(depth=1, durability=TL))
    for i in range(3):
        pub.publish(Int64(data=i))
        pub2.publish(Int64(data=100 + i))
    got = []
    b.create_subscription(Int64, "t", lambda m: got.append(m.data), q(depth=10, durability=TL))
    ex.spin_for(0.01)
    assert got == [1, 2, 102]


def test_lifespan_expired_messages_are_dropped_and_counted():
    ctx, a, b, pub, ex = _graph(q(depth=10, lifespan=0.5, durability=TL))
    pub.publish(Int64(data=1))
    ex.spin_for(1.0)                       # the sample is now 1 s old
    pub.publish(Int64(data=2))
    got = []
    sub = b.create_subscription(Int64, "t", lambda m: got.append(m.data), q(depth=10, durability=TL))
    ex.spin_for(0.1)
    assert got == [2]
    assert sub.counts.lifespan_expired == 1
    # queued in a subscription but not taken before expiry
    pub.publish(Int64(data=3))
    ctx.sim.advance(0.6)
    ex.spin_for(0.01)
    assert got == [2] and sub.counts.lifespan_expired == 2


def test_deadline_missed_events_both_sides():
    ctx, a, b, pub, ex = _graph(q(depth=10, deadline=0.1))
    pub_ev, sub_ev = [], []
    pub.event_callbacks = PublisherEventCallbacks(deadline=pub_ev.append)
    b.create_subscription(Int64, "t", lambda m: None, q(depth=10, deadline=0.1),
                          event_callbacks=SubscriptionEventCallbacks(deadline=sub_ev.append))
    tmr = a.create_timer(0.05, lambda: pub.publish(Int64(data=0)))
    ex.spin_for(1.0)                       # publishing every 50 ms: no miss
    assert pub_ev == [] and sub_ev == []
    tmr.cancel()
    ex.spin_for(1.0)
    # the last sample went out at t=1.0 (timers due at the end of a spin_for run), so the
    # 100 ms windows ending at 1.2, 1.3, ..., 2.0 are empty: 9 misses on each side
    assert len(pub_ev) == 9 and len(sub_ev) == 9
    assert sub_ev[-1].total_count == 9 and sub_ev[-1].total_count_change == 1


def test_matched_events_and_counts():
    ctx, a, b, pub, ex = _graph(q())
    pub_ev, sub_ev = [], []
    pub.event_callbacks = PublisherEventCallbacks(matched=pub_ev.append)
    sub = b.create_subscription(Int64, "t", lambda m: None, q(),
                                event_callbacks=SubscriptionEventCallbacks(matched=sub_ev.append))
    sub2 = b.create_subscription(Int64, "t", lambda m: None, q())
    b.destroy_subscription(sub2)
    ex.spin_for(0.01)
    assert [(e.current_count, e.current_count_change) for e in pub_ev] == [(1, 1), (2, 1), (1, -1)]
    assert [(e.total_count, e.current_count) for e in sub_ev] == [(1, 1)]
    assert a.count_subscribers("/t") == 1 and b.count_publishers("t") == 1
    assert sub.get_publisher_count() == 1


def test_manual_liveliness_lost_and_regained():
    ctx, a, b, pub, ex = _graph(q(liveliness=MANUAL, liveliness_lease_duration=0.2))
    sub_ev, pub_ev = [], []
    pub.event_callbacks = PublisherEventCallbacks(liveliness=pub_ev.append)
    b.create_subscription(Int64, "t", lambda m: None, q(liveliness=MANUAL, liveliness_lease_duration=0.5),
                          event_callbacks=SubscriptionEventCallbacks(liveliness=sub_ev.append))
    ex.spin_for(0.01)
    assert sub_ev[-1].alive_count == 1
    ex.spin_for(0.5)        # no publish, no assert: lease runs out
    assert len(pub_ev) == 1 and pub_ev[0].total_count == 1
    assert sub_ev[-1].alive_count == 0 and sub_ev[-1].not_alive_count == 1
    pub.assert_liveliness()
    ex.spin_for(0.15)       # next lease check sees the assertion
    assert sub_ev[-1].alive_count == 1 and sub_ev[-1].alive_count_change == 1
    ex.spin_for(0.2)        # one assertion only covers one lease period
    assert sub_ev[-1].alive_count == 0 and len(pub_ev) == 2


def test_automatic_liveliness_changes_when_a_publisher_goes_away():
    ctx, a, b, pub, ex = _graph(q())
    ev = []
    b.create_subscription(Int64, "t", lambda m: None, q(),
                          event_callbacks=SubscriptionEventCallbacks(liveliness=ev.append))
    a.destroy_publisher(pub)
    ex.spin_for(0.01)
    assert [(e.alive_count, e.alive_count_change) for e in ev] == [(1, 1), (0, -1)]


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(depth=10, reliability="reliable"), TypeError,
     r"reliability='reliable' is not a ReliabilityPolicy \(write ReliabilityPolicy.RELIABLE"),
    (dict(depth=10, durability="transient_local"), TypeError, "DurabilityPolicy.TRANSIENT_LOCAL"),
    (dict(depth=10, history=7), TypeError, "history=7 is not a HistoryPolicy"),
    (dict(depth="10"), InvalidQoSProfileException, r"depth='10' must be an int >= 0"),
    (dict(depth=10, deadline="1"), InvalidQoSProfileException, r"deadline='1' must be seconds"),
    (dict(depth=10, lifespan=-2.0), InvalidQoSProfileException, r"lifespan=-2.0 must be >= 0 s"),
])
def test_qos_profile_refuses_bad_arguments_with_value_rule_and_fix(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        QoSProfile(**kwargs)


def test_qos_profile_accepts_policy_ints_like_rclpy():
    q = QoSProfile(depth=3, reliability=2, durability=1)
    assert q.reliability == ReliabilityPolicy.BEST_EFFORT
    assert q.durability == DurabilityPolicy.TRANSIENT_LOCAL
