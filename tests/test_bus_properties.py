"""Property tests (hypothesis): history depth and QoS matching on live graphs."""

from hypothesis import given, settings
from hypothesis import strategies as st

from robocourse.bus import (
    Context,
    DurabilityPolicy,
    LivelinessPolicy,
    QoSCompatibility,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
    qos_check_compatible,
)
from robocourse.msgs.std_msgs import Int64


@settings(max_examples=40, deadline=None)
@given(depth=st.integers(1, 20), n=st.integers(0, 60))
def test_keep_last_keeps_the_newest_depth_messages_in_order(depth, n):
    ctx = Context(use_sim_time=True)
    a = ctx.create_node("a")
    pub = a.create_publisher(Int64, "t", 100)
    got = []
    a.create_subscription(Int64, "t", lambda m: got.append(m.data), depth)
    for i in range(n):
        pub.publish(Int64(data=i))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.spin_for(0.001)
    assert got == list(range(max(0, n - depth), n))


durations = st.sampled_from([None, 0.1, 0.5, 1.0])
profiles = st.builds(
    lambda r, d, dl, lv, lease: QoSProfile(depth=5, reliability=r, durability=d, deadline=dl,
                                           liveliness=lv, liveliness_lease_duration=lease),
    st.sampled_from([ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT]),
    st.sampled_from([DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL]),
    durations,
    st.sampled_from([LivelinessPolicy.AUTOMATIC, LivelinessPolicy.MANUAL_BY_TOPIC]),
    durations)


@settings(max_examples=60, deadline=None)
@given(pub_qos=profiles, sub_qos=profiles)
def test_live_graph_delivers_exactly_when_the_check_says_compatible(pub_qos, sub_qos):
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", pub_qos)
    got = []
    sub = b.create_subscription(Int64, "t", got.append, sub_qos)
    pub.publish(Int64(data=1))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b)
    ex.spin_once(timeout_sec=0)
    compatible = qos_check_compatible(pub_qos, sub_qos).compatibility != QoSCompatibility.ERROR
    assert (len(got) == 1) == compatible
    assert sub.counts.incompatible_qos == (0 if compatible else 1)
    assert pub.counts.incompatible_qos == (0 if compatible else 1)
    # the rules in words: reliability, durability, deadline, liveliness kind, lease
    expected = not (
        (pub_qos.reliability == ReliabilityPolicy.BEST_EFFORT and sub_qos.reliability == ReliabilityPolicy.RELIABLE)
        or (pub_qos.durability == DurabilityPolicy.VOLATILE and sub_qos.durability == DurabilityPolicy.TRANSIENT_LOCAL)
        or (sub_qos.deadline < pub_qos.deadline)
        or (pub_qos.liveliness == LivelinessPolicy.AUTOMATIC and sub_qos.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC)
        or (sub_qos.liveliness_lease_duration < pub_qos.liveliness_lease_duration))
    assert compatible == expected
