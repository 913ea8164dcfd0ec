"""Value semantics: a subscription receives the value as it was at publish time, its own copy.

ROS 2 reference: rclpy serializes on publish and deserializes per subscription; rclcpp
intra-process hands over a unique_ptr or a const shared_ptr. Either way, changing a message
after publishing it, or in a callback, changes nobody else's message.
"""

import threading
import time

from hypothesis import given, settings
from hypothesis import strategies as st

from robocourse.bus import (
    Context,
    DurabilityPolicy,
    HistoryPolicy,
    MultiThreadedExecutor,
    QoSProfile,
    ReentrantCallbackGroup,
    SingleThreadedExecutor,
)
from robocourse.bus.action import ActionClient, ActionServer
from robocourse.bus.recording import record, replay
from robocourse.msgs.example_interfaces import AddTwoInts, Fibonacci
from robocourse.msgs.sensor_msgs import JointState
from robocourse.msgs.std_msgs import Float64, Int64

KEEP_ALL = QoSProfile(history=HistoryPolicy.KEEP_ALL)
LATCHED = QoSProfile(depth=5, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def graph(use_sim_time=True):
    ctx = Context(use_sim_time=use_sim_time)
    ctx.log_to_stderr = False
    return ctx, ctx.create_node("talker"), ctx.create_node("listener")


def publish_reusing_one_float64(pub, n):
    """The rclpy pattern: one message object, changed and published n times."""
    msg = Float64()
    for i in range(n):
        msg.data = float(i)
        pub.publish(msg)
    return msg


def spin(ctx, *nodes, seconds=0.01):
    ex = SingleThreadedExecutor(context=ctx)
    for n in nodes:
        ex.add_node(n)
    ex.spin_for(seconds)
    return ex


def test_reusing_one_message_object_delivers_each_published_value():
    # the reproduction: values 0..4 used to arrive as [4.0, 4.0, 4.0, 4.0, 4.0]
    ctx, a, b = graph()
    pub = a.create_publisher(Float64, "x", 10)
    got = []
    b.create_subscription(Float64, "x", lambda m: got.append(m.data), 10)
    publish_reusing_one_float64(pub, 5)
    spin(ctx, a, b)
    assert got == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_changing_arrays_after_publish_does_not_reach_the_subscription():
    ctx, a, b = graph()
    pub = a.create_publisher(JointState, "js", 10)
    got = []
    b.create_subscription(JointState, "js", got.append, 10)
    js = JointState(name=["j1"], position=[1.0])
    pub.publish(js)
    js.position[0] = 99.0
    js.name.append("j2")
    js.header.frame_id = "changed"
    spin(ctx, a, b)
    assert got[0].position.tolist() == [1.0] and got[0].name == ["j1"]
    assert got[0].header.frame_id == ""
    assert got[0] is not js


def test_a_subscription_changing_its_message_does_not_change_another_subscriptions():
    ctx, a, b = graph()
    pub = a.create_publisher(JointState, "js", 10)
    first, second = [], []

    def vandal(m):
        m.position[0] = -1.0
        m.name[0] = "vandalised"
        first.append(m)

    b.create_subscription(JointState, "js", vandal, 10)
    b.create_subscription(JointState, "js", second.append, 10)
    pub.publish(JointState(name=["j1"], position=[1.0]))
    spin(ctx, a, b)
    assert first[0].position.tolist() == [-1.0]
    assert second[0].position.tolist() == [1.0] and second[0].name == ["j1"]


def test_cross_thread_publisher_reusing_its_message_delivers_every_value():
    ctx, a, b = graph(use_sim_time=False)
    pub = a.create_publisher(Int64, "n", KEEP_ALL)
    got = []
    b.create_subscription(Int64, "n", lambda m: got.append(m.data), KEEP_ALL)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b)

    def talker():
        msg = Int64()
        for i in range(200):
            msg.data = i
            pub.publish(msg)

    t = threading.Thread(target=talker)
    t.start()
    t.join()
    while len(got) < 200:
        ex.spin_once(timeout_sec=1.0)
    assert got == list(range(200))


def test_multi_threaded_executor_delivers_publish_time_values():
    ctx, a, b = graph(use_sim_time=False)
    pub = a.create_publisher(Int64, "n", KEEP_ALL)
    got = []
    lock = threading.Lock()

    def cb(m):
        with lock:
            got.append(m.data)

    group = ReentrantCallbackGroup()
    b.create_subscription(Int64, "n", cb, KEEP_ALL, callback_group=group)
    msg = Int64()
    for i in range(50):
        msg.data = i
        pub.publish(msg)
    ex = MultiThreadedExecutor(num_threads=3, context=ctx)
    ex.add_node(b)
    end = time.monotonic() + 60        # a safety net: a fixed wall-clock window is a timed assertion
    ex.spin_for(0.3)
    while len(got) < 50 and time.monotonic() < end:
        ex.spin_for(0.3)
    assert sorted(got) == list(range(50))


def test_transient_local_late_joiners_get_values_as_published_each_their_own():
    ctx, a, b = graph()
    pub = a.create_publisher(JointState, "latched", LATCHED)
    js = JointState(name=["j"], position=[1.0])
    pub.publish(js)
    js.position[0] = 2.0            # after publishing: must not change the kept sample
    pub.publish(js)
    js.position[0] = 3.0
    first, second = [], []

    def vandal(m):
        first.append(m.position.tolist())
        m.position[0] = -1.0

    b.create_subscription(JointState, "latched", vandal, LATCHED)
    spin(ctx, a, b)
    b.create_subscription(JointState, "latched", lambda m: second.append(m.position.tolist()), LATCHED)
    spin(ctx, a, b)
    assert first == [[1.0], [2.0]]
    assert second == [[1.0], [2.0]]


def test_lifespan_path_copies_too():
    ctx, a, b = graph()
    pub = a.create_publisher(Float64, "x", QoSProfile(depth=10, lifespan=1.0))
    got = []
    b.create_subscription(Float64, "x", lambda m: got.append(m.data), 10)
    publish_reusing_one_float64(pub, 3)
    spin(ctx, a, b)
    assert got == [0.0, 1.0, 2.0]


def recorded_talker(tmp_path):
    """A talker on /x being recorded: (ctx, publisher, executor, recorder)."""
    ctx, a, _ = graph()
    pub = a.create_publisher(Float64, "/x", 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    return ctx, pub, ex, record(ctx, tmp_path / "r.mcap", ["/x"], executor=ex)


def test_recording_stores_the_values_as_published(tmp_path):
    ctx, pub, ex, rec = recorded_talker(tmp_path)
    msg = publish_reusing_one_float64(pub, 4)
    msg.data = 100.0                        # after publishing: not in the recording
    ex.spin_for(0.01)
    data = rec.read().to_numpy("/x")
    assert data["data"].tolist() == [0.0, 1.0, 2.0, 3.0]


def test_replay_gives_each_subscriber_its_own_copy_and_leaves_the_recording_intact(tmp_path):
    ctx, pub, ex, rec = recorded_talker(tmp_path)
    for i in range(3):
        pub.publish(Float64(data=float(i)))
    ex.spin_for(0.01)
    recording = rec.read()
    ctx2, _, listener = graph()
    got = []

    def vandal(m):
        got.append(m.data)
        m.data = -1.0

    listener.create_subscription(Float64, "/x", vandal, 10)
    ex2 = SingleThreadedExecutor(context=ctx2)
    ex2.add_node(listener)
    replay(recording, ctx2, executor=ex2)
    ex2.spin_for(0.1)
    assert got == [0.0, 1.0, 2.0]
    assert [m.data for _, m in recording.messages("/x")] == [0.0, 1.0, 2.0]


def test_service_request_and_response_are_copies():
    ctx, a, b = graph()
    seen = []
    shared = AddTwoInts.Response()

    def add(req, _resp):
        seen.append((req.a, req.b))
        shared.sum = req.a + req.b      # a server that reuses one response object
        return shared

    b.create_service(AddTwoInts, "add", add)
    cli = a.create_client(AddTwoInts, "add")
    req = AddTwoInts.Request(a=1, b=2)
    f1 = cli.call_async(req)
    req.a = 10                          # after call_async: the server still sees a=1
    f2 = cli.call_async(req)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    ex.spin_until_future_complete(f2, timeout_sec=1.0)
    assert seen == [(1, 2), (10, 2)]
    assert f1.result().sum == 3 and f2.result().sum == 12
    assert f1.result() is not shared


def test_action_feedback_reused_by_the_server_reaches_the_client_value_by_value():
    ctx, a, b = graph()

    async def execute(handle):
        fb = Fibonacci.Feedback()
        for k in range(3):
            fb.sequence.append(k)
            handle.publish_feedback(fb)   # one object, changed between publishes
            await b.sleep_async(0.01)
        handle.succeed()
        return Fibonacci.Result(sequence=fb.sequence)

    ActionServer(b, Fibonacci, "fib", execute)
    client = ActionClient(a, Fibonacci, "fib")
    feedback = []
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    goal_f = client.send_goal_async(Fibonacci.Goal(order=3),
                                    feedback_callback=lambda m: feedback.append(m.feedback.sequence))
    ex.spin_until_future_complete(goal_f, timeout_sec=1.0)
    res_f = goal_f.result().get_result_async()
    ex.spin_until_future_complete(res_f, timeout_sec=1.0)
    assert [s.tolist() for s in feedback] == [[0], [0, 1], [0, 1, 2]]
    assert res_f.result().result.sequence.tolist() == [0, 1, 2]


# ------------------------------------------------------------------------- property test

ops = st.lists(st.one_of(
    st.tuples(st.just("publish"), st.floats(-1e6, 1e6, allow_nan=False)),
    st.tuples(st.just("mutate"), st.floats(-1e6, 1e6, allow_nan=False)),
    st.tuples(st.just("spin"), st.just(0.0)),
), max_size=40)


@settings(max_examples=60, deadline=None)
@given(ops=ops, latched=st.booleans())
def test_every_subscription_sees_exactly_the_published_values(ops, latched):
    """For any sequence of publishes, publisher-side mutations and spins, each of two
    subscriptions (one of them vandalising what it gets) receives exactly the published
    values in order; a late TRANSIENT_LOCAL joiner receives the kept ones."""
    ctx, a, b = graph()
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
    pub = a.create_publisher(JointState, "js", qos)
    clean, vandal = [], []

    def vandalise(m):
        vandal.append((m.position[0], m.name[0]))
        m.position[0] = float("nan")
        m.name[0] = "x"

    b.create_subscription(JointState, "js", lambda m: clean.append((m.position[0], m.name[0])), qos)
    b.create_subscription(JointState, "js", vandalise, qos)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b)
    msg = JointState(name=["j"], position=[0.0])
    published = []
    for op, v in ops:
        if op == "publish":
            msg.position[0] = v
            msg.name[0] = f"v{len(published)}"
            pub.publish(msg)
            published.append((v, msg.name[0]))
        elif op == "mutate":
            msg.position[0] = v
            msg.name[0] = "mutated"
        else:
            ex.spin_for(0.001)
    ex.spin_for(0.001)
    assert clean == published
    assert vandal == published
    if latched:
        late = []
        b.create_subscription(JointState, "js", lambda m: late.append((m.position[0], m.name[0])), qos)
        ex.spin_for(0.001)
        assert late == published
