"""MCAP recording checked with the mcap library itself; read back as numpy; replay."""

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from robocourse.bus import Context, DurabilityPolicy, QoSProfile, SingleThreadedExecutor
from robocourse.bus.recording import read_recording, record, replay
from robocourse.msgs import full_definition
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.sensor_msgs import JointState
from robocourse.msgs.std_msgs import String


def sim_graph():
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    n = ctx.create_node("robot")
    cmd = n.create_publisher(Twist, "/cmd_vel", 10)
    js = n.create_publisher(JointState, "/joint_states", 10)
    latched = n.create_publisher(String, "/robot_description", QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    latched.publish(String(data="<robot name='r'/>"))
    k = [0]

    def tick():
        k[0] += 1
        t = Twist()
        t.linear.x = 0.1 * k[0]
        t.angular.z = -k[0]
        cmd.publish(t)
        m = JointState(name=["left", "right"], position=[float(k[0]), 2.0 * k[0]])
        m.header.stamp = n.get_clock().now().to_msg()
        js.publish(m)

    n.create_timer(0.01, tick)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    return ctx, ex


def test_mcap_file_read_with_the_mcap_library_every_message_checked(tmp_path):
    ctx, ex = sim_graph()
    path = tmp_path / "run.mcap"
    rec = record(ctx, path, executor=ex)
    ex.spin_for(1.0)
    rec.close()
    assert rec.counts == {"/cmd_vel": 100, "/joint_states": 100, "/robot_description": 1}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        schemas = {s.name: s for s in summary.schemas.values()}
        assert schemas["geometry_msgs/msg/Twist"].encoding == "ros2msg"
        assert schemas["geometry_msgs/msg/Twist"].data.decode() == full_definition(Twist)
        assert {c.topic: c.message_encoding for c in summary.channels.values()} == {
            "/cmd_vel": "cdr", "/joint_states": "cdr", "/robot_description": "cdr"}
        cmd, joints, desc = [], [], []
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            if channel.topic == "/cmd_vel":
                cmd.append((message.log_time, decoded.linear.x, decoded.angular.z))
            elif channel.topic == "/joint_states":
                joints.append((message.log_time, list(decoded.name), list(decoded.position),
                               decoded.header.stamp.sec * 10**9 + decoded.header.stamp.nanosec))
            else:
                desc.append(decoded.data)
    assert desc == ["<robot name='r'/>"]
    back = read_recording(path)
    assert len(back) == 201 and back.messages("/robot_description")[0][1].data == desc[0]
    assert len(cmd) == 100 and len(joints) == 100
    for i, (t, x, z) in enumerate(cmd, start=1):
        assert t == i * 10_000_000 and x == 0.1 * i and z == -i
    for i, (t, names, pos, stamp) in enumerate(joints, start=1):
        assert t == stamp == i * 10_000_000 and names == ["left", "right"]
        assert pos == [float(i), 2.0 * i]


def test_read_back_as_numpy_and_replay(tmp_path):
    ctx, ex = sim_graph()
    rec = record(ctx, tmp_path / "a.mcap", ["/cmd_vel", "/joint_states"], executor=ex)
    ex.spin_for(0.5)
    r = rec.read()                      # close + read back in one call
    assert r.path == str(tmp_path / "a.mcap") and rec.read().topics == r.topics
    assert r.topics == ["/cmd_vel", "/joint_states"] and len(r) == 100
    d = r.to_numpy("/cmd_vel")
    np.testing.assert_allclose(d["t"], np.arange(1, 51) * 0.01)
    np.testing.assert_allclose(d["linear.x"], 0.1 * np.arange(1, 51))
    j = r.to_numpy("/joint_states")
    assert j["position"].shape == (50, 2)
    np.testing.assert_allclose(j["header.stamp"], d["t"])

    ctx2 = Context(use_sim_time=True)
    sink = ctx2.create_node("sink")
    got = []
    sink.create_subscription(Twist, "/replayed", lambda m: got.append((ctx2.sim.ns, m.linear.x)), 100)
    ex2 = SingleThreadedExecutor(context=ctx2)
    ex2.add_node(sink)
    player = replay(r, ctx2, topics=["/cmd_vel"], remap={"/cmd_vel": "/replayed"}, executor=ex2)
    ex2.spin_for(1.0)
    assert player.done and player.published == 50
    assert [x for _, x in got] == list(d["linear.x"])
    assert [t for t, _ in got] == [k * 10_000_000 for k in range(50)]


def test_record_and_replay_refuse_bad_arguments(tmp_path):
    import pytest

    ctx = Context(use_sim_time=True)
    with pytest.raises(TypeError, match="record needs a Context or a Node"):
        record("ctx", tmp_path / "r.mcap")
    with pytest.raises(TypeError, match=r"topics='/x' must be a list of topic names"):
        record(ctx, tmp_path / "r.mcap", "/x")
    with pytest.raises(TypeError, match="path=3 must be a file path"):
        record(ctx, 3)
    with pytest.raises(ValueError, match="rate=0 must be a number > 0"):
        replay(tmp_path / "missing.mcap", ctx, rate=0)


def test_record_a_topic_that_has_only_subscriptions_then_a_publisher_appears(tmp_path):
    # the recorder's graph listener runs again inside its own create_subscription; it once
    # subscribed the same topic recursively until the stack ran out
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    n = ctx.create_node("n")
    n.create_subscription(Twist, "/cmd_vel", lambda m: None, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(n)
    rec = record(ctx, tmp_path / "late.mcap", ["/cmd_vel"], executor=ex)
    pub = n.create_publisher(Twist, "/cmd_vel", 10)
    for k in range(3):
        t = Twist()
        t.linear.x = float(k)
        pub.publish(t)
    ex.spin_for(0.1)
    r = rec.read()
    assert r.topics == ["/cmd_vel"] and list(r.to_numpy("/cmd_vel")["linear.x"]) == [0.0, 1.0, 2.0]
