"""Introspection calls return data and print ROS-like text; the graph picture."""

from robocourse.bus import Context, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
from robocourse.bus import introspection as ros2
from robocourse.bus.graph_view import graph_picture
from robocourse.msgs.example_interfaces import AddTwoInts
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.std_msgs import Float64


def graph():
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    talker, listener = ctx.create_node("talker"), ctx.create_node("listener", namespace="/ns")
    pub = talker.create_publisher(Twist, "/cmd_vel", 10)
    k = [0]

    def tick():
        k[0] += 1
        t = Twist()
        t.linear.x = float(k[0])
        pub.publish(t)

    talker.create_timer(0.02, tick)
    listener.create_subscription(Twist, "/cmd_vel", lambda m: None, 10)
    talker.create_service(AddTwoInts, "add", lambda q, r: (setattr(r, "sum", q.a + q.b), r)[1])
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(talker)
    ex.add_node(listener)
    return ctx, ex


def test_topic_list_and_info(capsys):
    ctx, ex = graph()
    # as `ros2 topic list -t` on a graph of rclpy nodes: every node publishes /parameter_events
    # and /rosout
    assert ros2.topic_list(ctx) == [("/cmd_vel", ["geometry_msgs/msg/Twist"]),
                                    ("/parameter_events", ["rcl_interfaces/msg/ParameterEvent"]),
                                    ("/rosout", ["rcl_interfaces/msg/Log"])]
    info = ros2.topic_info(ctx, "/cmd_vel", verbose=True)
    out = capsys.readouterr().out
    assert "/cmd_vel [geometry_msgs/msg/Twist]" in out
    assert "Type: geometry_msgs/msg/Twist" in out and "Publisher count: 1" in out
    assert "Subscription count: 1" in out and "Node namespace: /ns" in out
    assert "  Reliability: RELIABLE" in out and "  History (Depth): KEEP_LAST (10)" in out
    assert "Endpoint type: SUBSCRIPTION" in out
    assert info["publishers"][0]["node_name"] == "talker"


def test_echo_hz_bw_on_sim_time(capsys):
    ctx, ex = graph()
    msgs = ros2.topic_echo(ctx, "/cmd_vel", ex, count=2)
    assert [m.linear.x for m in msgs] == [1.0, 2.0]
    out = capsys.readouterr().out
    assert out.count("---") == 2 and "linear:\n  x: 1.0" in out
    hz = ros2.topic_hz(ctx, "/cmd_vel", ex, duration=1.0)
    assert round(hz["rate"], 6) == 50.0 and hz["window"] == 50
    assert "average rate: 50.000" in capsys.readouterr().out
    bw = ros2.topic_bw(ctx, "/cmd_vel", ex, duration=1.0)
    assert bw["mean"] == 52    # CDR: 4-byte header + 6 float64
    assert "B/s from 50 messages" in capsys.readouterr().out
    # hidden helper nodes are gone afterwards
    assert ros2.node_list(ctx, quiet=True) == ["/ns/listener", "/talker"]


def test_node_info_service_list_and_call(capsys):
    ctx, ex = graph()
    info = ros2.node_info(ctx, "/talker")
    # what `ros2 node info /talker` shows for an rclpy node on Jazzy
    assert info["Publishers"] == [("/cmd_vel", "geometry_msgs/msg/Twist"),
                                  ("/parameter_events", "rcl_interfaces/msg/ParameterEvent"),
                                  ("/rosout", "rcl_interfaces/msg/Log")]
    assert info["Service Servers"] == [("/add", "example_interfaces/srv/AddTwoInts")] + [
        (f"/talker/{name}", f"rcl_interfaces/srv/{t}") for name, t in (
            ("describe_parameters", "DescribeParameters"),
            ("get_parameter_types", "GetParameterTypes"), ("get_parameters", "GetParameters"))] + [
        ("/talker/get_type_description", "type_description_interfaces/srv/GetTypeDescription")] + [
        (f"/talker/{name}", f"rcl_interfaces/srv/{t}") for name, t in (
            ("list_parameters", "ListParameters"), ("set_parameters", "SetParameters"),
            ("set_parameters_atomically", "SetParametersAtomically"))]
    out = capsys.readouterr().out
    assert "/talker\n  Subscribers:\n  Publishers:\n    /cmd_vel: geometry_msgs/msg/Twist" in out
    services = ros2.service_list(ctx)
    assert ("/add", ["example_interfaces/srv/AddTwoInts"]) in services
    assert ("/ns/listener/get_parameters", ["rcl_interfaces/srv/GetParameters"]) in services
    assert len(services) == 1 + 2 * 7
    resp = ros2.service_call(ctx, "/add", AddTwoInts, {"a": 2, "b": 40}, ex)
    assert resp.sum == 42
    out = capsys.readouterr().out
    assert "requester: making request:" in out and "response:" in out


def test_topic_pub_once():
    ctx, ex = graph()
    got = []
    ctx.nodes[1].create_subscription(Float64, "/x", got.append, 10)
    ros2.topic_pub(ctx, "/x", Float64, {"data": 3.5}, quiet=True)
    ex.spin_for(0.001)
    assert [m.data for m in got] == [3.5]


def test_doctor_and_graph_picture_mark_incompatible_qos(capsys):
    ctx, ex = graph()
    n = ctx.create_node("fast_sensor")
    n.create_publisher(Float64, "/imu", QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
    ctx.nodes[1].create_subscription(Float64, "/imu", lambda m: None, 10)   # RELIABLE
    rows = ros2.doctor_report(ctx)
    assert rows == [{"topic": "/imu", "publisher": "/fast_sensor", "subscription": "/ns/listener",
                     "policy": "RELIABILITY",
                     "reason": "ERROR: Best effort publisher and reliable subscription;"}]
    assert "QOS COMPATIBILITY LIST" in capsys.readouterr().out
    pic = graph_picture(ctx)
    svg = pic._repr_svg_()
    assert svg.startswith("<svg") and svg.rstrip().endswith("</svg>")
    assert set(pic.nodes) == {"/talker", "/ns/listener", "/fast_sensor"}
    assert set(pic.topics) == {"/cmd_vel", "/imu"}
    assert ("/imu", "/ns/listener", "incompatible", "QoS RELIABILITY") in pic.edges
    assert ("/talker", "/cmd_vel", "pub", "") in pic.edges
    assert "QoS RELIABILITY" in svg and "stroke-dasharray" in svg
    assert repr(pic) == "<rqt_graph picture: 3 nodes, 2 topics, 4 arrows (SVG)>"   # a saved notebook's text: no address


def test_cli_calls_wait_on_an_executor_another_thread_spins():
    # one thread spins an executor (rclpy): a ros2 CLI call joins it and waits for the answer there
    import threading

    from robocourse.bus import Future

    ctx = Context()
    ctx.log_to_stderr = False
    talker = ctx.create_node("talker")
    pub = talker.create_publisher(Float64, "/x", 10)
    talker.create_timer(0.005, lambda: pub.publish(Float64(data=1.5)))
    talker.create_service(AddTwoInts, "add", lambda q, r: (setattr(r, "sum", q.a + q.b), r)[1])
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(talker)
    stop = Future()
    th = threading.Thread(target=ex.spin_until_future_complete, args=(stop,), daemon=True)
    th.start()
    try:
        while not ex.is_spinning_elsewhere():
            pass
        resp = ros2.service_call(ctx, "/add", AddTwoInts, {"a": 2, "b": 40}, ex, quiet=True)
        assert resp is not None and resp.sum == 42
        msgs = ros2.topic_echo(ctx, "/x", ex, count=3, duration=10.0, quiet=True)
        assert [m.data for m in msgs] == [1.5, 1.5, 1.5]
        assert th.is_alive()                       # the spinning thread kept spinning throughout
    finally:
        stop.set_result(True)
        ex._wake()
        th.join(10)
