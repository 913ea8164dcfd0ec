"""What every node brings, as an rclpy node on Jazzy: /rosout, /parameter_events, the six
parameter services and ~/get_type_description; in-process and, over the zenoh transport, as a
plain zenoh peer sees them (rmw_zenoh's keys and tokens, CDR decoded with mcap_ros2's codec,
independently of robocourse)."""

import hashlib
import json
import struct
import threading
import time

import pytest

from robocourse.bus import Context, Parameter, SingleThreadedExecutor
from robocourse.bus import introspection as ros2
from robocourse.bus.node import ROSOUT_QOS
from robocourse.bus.zenoh import wire
from robocourse.msgs import rcl_interfaces as rcl
from robocourse.msgs.std_msgs import String
from robocourse.msgs.type_description_interfaces import GetTypeDescription

# Type hashes of a real Jazzy graph: Log and ParameterEvent appear in liveliness tokens
# captured from rmw_zenoh nodes (e.g. `@ros2_lv/0/<zid>/0/1/MP/%/%/talker/%rosout/
# rcl_interfaces::msg::dds_::Log_/RIHS01_e28c.../:1:,1000:,:10,0:,,`); the service ones are
# the values other rmw_zenoh client libraries hold for Jazzy (ros-z-style locked tables), and
# GetTypeDescription's is quoted as Jazzy's by two independent projects.
JAZZY = {
    "rcl_interfaces/msg/Log":
        "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac",
    "rcl_interfaces/msg/ParameterEvent":
        "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204",
    "rcl_interfaces/srv/GetParameters":
        "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc",
    "rcl_interfaces/srv/GetParameterTypes":
        "RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca",
    "rcl_interfaces/srv/SetParameters":
        "RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0",
    "rcl_interfaces/srv/SetParametersAtomically":
        "RIHS01_0e192ef259c07fc3c07a13191d27002222e65e00ccec653ca05e856f79285fcd",
    "rcl_interfaces/srv/ListParameters":
        "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d",
    "rcl_interfaces/srv/DescribeParameters":
        "RIHS01_845b484d71eb0673dae682f2e3ba3c4851a65a3dcfb97bddd82c5b57e91e4cff",
    "type_description_interfaces/srv/GetTypeDescription":
        "RIHS01_69b9c19c1021405984cc60dbbb1edceb147a6538b411d812ba6afabeed962cd5",
}


@pytest.mark.parametrize("name", sorted(JAZZY))
def test_node_interface_types_hash_as_on_jazzy(name):
    from robocourse.msgs import REGISTRY

    assert wire.type_hash(REGISTRY[name]) == JAZZY[name]


def graph():
    ctx = Context()
    ctx.log_to_stderr = False
    node = ctx.create_node("arm_driver", namespace="/robot")
    node.declare_parameter("kp", 2.5)
    node.declare_parameter("joints", ["j1", "j2"])
    node.declare_parameter("limits.max_velocity", 1.0)
    node.declare_parameter("robot_ip", Parameter.Type.STRING)     # uninitialized
    tool = ctx.create_node("tool")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    ex.add_node(tool)
    return ctx, node, tool, ex


def call(ex, tool, srv_type, name, **fields):
    cli = tool.create_client(srv_type, name)
    f = cli.call_async(srv_type.Request(**fields))
    ex.spin_until_future_complete(f, timeout_sec=5)
    tool.destroy_client(cli)
    return f.result()


def test_parameter_services_answer_as_rclpys():
    ctx, node, tool, ex = graph()
    base = "/robot/arm_driver/"
    listed = call(ex, tool, rcl.ListParameters, base + "list_parameters")
    assert sorted(listed.result.names) == ["joints", "kp", "limits.max_velocity", "robot_ip",
                                           "start_type_description_service", "use_sim_time"]
    assert list(listed.result.prefixes) == ["limits"]
    shallow = call(ex, tool, rcl.ListParameters, base + "list_parameters", prefixes=["limits"],
                   depth=1)
    assert list(shallow.result.names) == ["limits.max_velocity"]

    got = call(ex, tool, rcl.GetParameters, base + "get_parameters", names=["kp", "joints"])
    assert [v.type for v in got.values] == [rcl.ParameterType.PARAMETER_DOUBLE,
                                            rcl.ParameterType.PARAMETER_STRING_ARRAY]
    assert got.values[0].double_value == 2.5 and list(got.values[1].string_array_value) == ["j1", "j2"]
    # rclpy: one unknown or uninitialized name -> an empty list
    assert list(call(ex, tool, rcl.GetParameters, base + "get_parameters",
                     names=["kp", "nope"]).values) == []
    assert list(call(ex, tool, rcl.GetParameters, base + "get_parameters",
                     names=["robot_ip"]).values) == []
    types = call(ex, tool, rcl.GetParameterTypes, base + "get_parameter_types",
                 names=["kp", "robot_ip"])
    assert list(types.types) == [rcl.ParameterType.PARAMETER_DOUBLE,
                                 rcl.ParameterType.PARAMETER_NOT_SET]
    described = call(ex, tool, rcl.DescribeParameters, base + "describe_parameters",
                     names=["start_type_description_service"])
    [d] = described.descriptors
    assert d.read_only and d.type == rcl.ParameterType.PARAMETER_BOOL
    assert list(call(ex, tool, rcl.DescribeParameters, base + "describe_parameters",
                     names=["nope"]).descriptors) == []

    value = rcl.ParameterValue(type=rcl.ParameterType.PARAMETER_DOUBLE, double_value=4.0)
    bad = rcl.ParameterValue(type=rcl.ParameterType.PARAMETER_STRING, string_value="fast")
    res = call(ex, tool, rcl.SetParameters, base + "set_parameters", parameters=[
        rcl.Parameter(name="kp", value=value), rcl.Parameter(name="limits.max_velocity", value=bad),
        rcl.Parameter(name="nope", value=value)])
    assert [r.successful for r in res.results] == [True, False, False]
    assert "undeclared" in res.results[2].reason
    assert node.get_parameter("kp").value == 4.0 and node.get_parameter("limits.max_velocity").value == 1.0
    ip = rcl.ParameterValue(type=rcl.ParameterType.PARAMETER_STRING, string_value="10.0.0.2")
    atomic = call(ex, tool, rcl.SetParametersAtomically, base + "set_parameters_atomically",
                  parameters=[rcl.Parameter(name="robot_ip", value=ip),
                              rcl.Parameter(name="kp", value=bad)])
    assert not atomic.result.successful
    with pytest.raises(Exception, match="not initialized"):
        node.get_parameter("robot_ip")          # all or nothing
    atomic = call(ex, tool, rcl.SetParametersAtomically, base + "set_parameters_atomically",
                  parameters=[rcl.Parameter(name="robot_ip", value=ip)])
    assert atomic.result.successful and node.get_parameter("robot_ip").value == "10.0.0.2"


def test_rosout_carries_every_emitted_log_line_with_its_caller():
    ctx, node, tool, ex = graph()
    node.get_logger().info("ignored before anyone listens")   # kept: TRANSIENT_LOCAL
    got = []
    tool.create_subscription(rcl.Log, "/rosout", got.append, ROSOUT_QOS)
    node.get_logger().warning("joint 2 near its limit")
    node.get_logger().debug("below the logger's level: not emitted, not published")
    node.get_logger().get_child("io").error("bus lost")
    ex.spin_some()
    mine = [m for m in got if m.name.startswith("robot.arm_driver")]
    assert [(m.level, m.name, m.msg) for m in mine] == [
        (rcl.Log.INFO, "robot.arm_driver", "ignored before anyone listens"),
        (rcl.Log.WARN, "robot.arm_driver", "joint 2 near its limit"),
        (rcl.Log.ERROR, "robot.arm_driver.io", "bus lost")]
    assert mine[1].file == __file__ and mine[1].function == \
        "test_rosout_carries_every_emitted_log_line_with_its_caller" and mine[1].line > 0
    assert (mine[1].stamp.sec, mine[1].stamp.nanosec) == divmod(
        [r for r in ctx.log_records if r.msg == "joint 2 near its limit"][0].stamp_ns, 10**9)
    assert ROSOUT_QOS.depth == 1000 and ROSOUT_QOS.lifespan == 10.0
    assert wire.qos_to_keyexpr(ROSOUT_QOS) == ":1:,1000:,:10,0:,,"   # as a real node's token


def test_get_type_description_answers_for_the_types_the_node_uses():
    ctx, node, tool, ex = graph()
    node.create_publisher(String, "chatter", 10)
    h = wire.type_hash(String)
    r = call(ex, tool, GetTypeDescription, "/robot/arm_driver/get_type_description",
             type_name="std_msgs/msg/String", type_hash=h, include_type_sources=True)
    assert r.successful and r.failure_reason == ""
    td = r.type_description
    assert td.type_description.type_name == "std_msgs/msg/String"
    assert [(f.name, f.type.type_id) for f in td.type_description.fields] == [("data", 17)]
    assert [s.type_name for s in r.type_sources] == ["std_msgs/msg/String"]
    assert "string data" in r.type_sources[0].raw_file_contents
    # the served description hashes to the requested hash (REP-2011: without default values)

    def plain(d):
        return {"type_name": d.type_name, "fields": [
            {"name": f.name, "type": {"type_id": f.type.type_id, "capacity": f.type.capacity,
                                      "string_capacity": f.type.string_capacity,
                                      "nested_type_name": f.type.nested_type_name}}
            for f in d.fields]}
    log = call(ex, tool, GetTypeDescription, "/robot/arm_driver/get_type_description",
               type_hash=JAZZY["rcl_interfaces/msg/Log"], include_type_sources=False)
    text = json.dumps({"type_description": plain(log.type_description.type_description),
                       "referenced_type_descriptions": [
                           plain(x) for x in log.type_description.referenced_type_descriptions]})
    assert "RIHS01_" + hashlib.sha256(text.encode()).hexdigest() == JAZZY["rcl_interfaces/msg/Log"]
    assert log.successful and list(log.type_sources) == []
    # rcl's failure texts
    unused = call(ex, tool, GetTypeDescription, "/robot/arm_driver/get_type_description",
                  type_hash=wire.type_hash(rcl.IntegerRange))
    assert not unused.successful and unused.failure_reason == "Type not currently in use by this node"
    broken = call(ex, tool, GetTypeDescription, "/robot/arm_driver/get_type_description",
                  type_hash="RIHS01_xyz")
    assert not broken.successful and broken.failure_reason == "Failed to parse type hash"


def test_switches_turn_the_builtins_off():
    ctx = Context()
    ctx.log_to_stderr = False
    quiet = ctx.create_node("quiet", start_parameter_services=False, enable_rosout=False,
                            parameter_overrides=[Parameter("start_type_description_service",
                                                           value=False)])
    info = ros2.node_info(ctx, "/quiet", quiet=True)
    assert info["Service Servers"] == []
    assert info["Publishers"] == [("/parameter_events", "rcl_interfaces/msg/ParameterEvent")]
    quiet.get_logger().info("not on /rosout")
    assert quiet.get_parameter("start_type_description_service").value is False


# ------------------------------------------------------------------- over zenoh, plain peer
def _att(seq, gid):
    return struct.pack("<qqB16s", seq, time.time_ns(), 16, gid)


# the .srv / .msg field lists of rcl_interfaces (Jazzy), for mcap_ros2's codec
_VALUE = ("uint8 type\nbool bool_value\nint64 integer_value\nfloat64 double_value\n"
          "string string_value\nbyte[] byte_array_value\nbool[] bool_array_value\n"
          "int64[] integer_array_value\nfloat64[] double_array_value\nstring[] string_array_value\n")
_LOG = ("builtin_interfaces/Time stamp\nuint8 level\nstring name\nstring msg\nstring file\n"
        "string function\nuint32 line\n================================================\n"
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n")


@pytest.mark.serial     # a router on a port and a spinning thread: keep it away from the load
def test_a_plain_zenoh_peer_sees_and_uses_the_node_services():
    zenoh = pytest.importorskip("zenoh")
    from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

    from robocourse.bus.zenoh.processes import free_router

    r, ep = free_router()
    ctx = Context(transport="zenoh", connect=[ep])
    ctx.log_to_stderr = False
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", f'["{ep}"]')
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    peer = zenoh.open(conf)
    ex = SingleThreadedExecutor(context=ctx)
    stop = threading.Event()
    spinner = threading.Thread(target=lambda: [ex.spin_once(0.02) for _ in iter(stop.is_set, True)],
                               daemon=True)
    try:
        node = ctx.create_node("talker")
        node.declare_parameter("kp", 2.5)
        ex.add_node(node)
        spinner.start()
        # 1. the tokens a real node declares: rosout, parameter_events, the seven services
        tokens = set()
        end = time.monotonic() + 30
        while time.monotonic() < end and len(tokens) < 10:
            tokens = {str(x.ok.key_expr) for x in peer.liveliness().get("@ros2_lv/0/**", timeout=2)
                      if x.ok is not None and "/talker" in str(x.ok.key_expr)}
        zid = ctx.transport.zid
        kinds = sorted(t.split("/")[5] for t in tokens)
        assert kinds == ["MP", "MP", "NN"] + ["SS"] * 7, tokens
        ends = {"/".join(t.split("/")[5:]) for t in tokens}
        assert ("MP/%/%/talker/%rosout/rcl_interfaces::msg::dds_::Log_/"
                + JAZZY["rcl_interfaces/msg/Log"] + "/:1:,1000:,:10,0:,,") in ends
        assert ("MP/%/%/talker/%parameter_events/rcl_interfaces::msg::dds_::ParameterEvent_/"
                + JAZZY["rcl_interfaces/msg/ParameterEvent"] + "/::,1000:,:,:,,") in ends
        assert ("SS/%/%/talker/%talker%get_parameters/rcl_interfaces::srv::dds_::GetParameters_/"
                + JAZZY["rcl_interfaces/srv/GetParameters"] + "/::,1000:,:,:,,") in ends
        assert ("SS/%/%/talker/%talker%get_type_description/"
                "type_description_interfaces::srv::dds_::GetTypeDescription_/"
                + JAZZY["type_description_interfaces/srv/GetTypeDescription"] + "/::,10:,:,:,,") in ends
        assert all(t.split("/")[2] == zid for t in tokens)

        # 2. `ros2 param list` / `get` / `set` as queries on the service keys
        gid = bytes(range(16))

        def query(service, srv, seq, req_text, resp_text, request):
            key = f"0/talker/{service}/rcl_interfaces::srv::dds_::{srv}_/{JAZZY['rcl_interfaces/srv/' + srv]}"
            enc = serialize_dynamic(f"rcl_interfaces/{srv}_Request", req_text)[f"rcl_interfaces/{srv}_Request"]
            dec = generate_dynamic(f"rcl_interfaces/{srv}_Response", resp_text)[f"rcl_interfaces/{srv}_Response"]
            replies = [x.ok for x in peer.get(key, payload=enc(request), attachment=_att(seq, gid),
                                               target=zenoh.QueryTarget.ALL_COMPLETE,
                                               consolidation=zenoh.ConsolidationMode.NONE,
                                               timeout=20.0) if x.ok is not None]
            assert len(replies) == 1, (service, replies)
            rseq, _ts, n, rgid = struct.unpack("<qqB16s", replies[0].attachment.to_bytes())
            assert (rseq, n, rgid) == (seq, 16, gid)      # rmw_zenoh pairs replies by seq + GID
            assert str(replies[0].key_expr) == key
            return dec(replies[0].payload.to_bytes())

        listed = query("list_parameters", "ListParameters", 1, "string[] prefixes\nuint64 depth\n",
                       "ListParametersResult result\n====\nMSG: rcl_interfaces/ListParametersResult\n"
                       "string[] names\nstring[] prefixes\n", {"prefixes": [], "depth": 0})
        assert sorted(listed.result.names) == ["kp", "start_type_description_service", "use_sim_time"]
        got = query("get_parameters", "GetParameters", 2, "string[] names\n",
                    "ParameterValue[] values\n====\nMSG: rcl_interfaces/ParameterValue\n" + _VALUE,
                    {"names": ["kp"]})
        assert [(v.type, v.double_value) for v in got.values] == [(3, 2.5)]
        value = {"type": 3, "double_value": 4.0, "bool_value": False, "integer_value": 0,
                 "string_value": "", "byte_array_value": [], "bool_array_value": [],
                 "integer_array_value": [], "double_array_value": [], "string_array_value": []}
        res = query("set_parameters", "SetParameters", 3,
                    "Parameter[] parameters\n====\nMSG: rcl_interfaces/Parameter\nstring name\n"
                    "ParameterValue value\n====\nMSG: rcl_interfaces/ParameterValue\n" + _VALUE,
                    "SetParametersResult[] results\n====\nMSG: rcl_interfaces/SetParametersResult\n"
                    "bool successful\nstring reason\n",
                    {"parameters": [{"name": "kp", "value": value}]})
        assert [(x.successful, x.reason) for x in res.results] == [(True, "")]
        assert node.get_parameter("kp").value == 4.0

        # 3. rqt_console's view: /rosout samples with the 33-byte attachment
        heard = []
        decode_log = generate_dynamic("rcl_interfaces/Log", _LOG)["rcl_interfaces/Log"]
        sub = peer.declare_subscriber(
            f"0/rosout/rcl_interfaces::msg::dds_::Log_/{JAZZY['rcl_interfaces/msg/Log']}",
            lambda s: heard.append((decode_log(s.payload.to_bytes()), len(s.attachment.to_bytes()))))
        end = time.monotonic() + 30
        while time.monotonic() < end and not any(m.msg == "over the wire" for m, _ in heard):
            node.get_logger().info("over the wire")
            time.sleep(0.2)
        m, att_len = next((m, n) for m, n in heard if m.msg == "over the wire")
        assert (m.level, m.name, att_len) == (20, "talker", 33)
        assert m.function == "test_a_plain_zenoh_peer_sees_and_uses_the_node_services"
        sub.undeclare()
    finally:
        stop.set()
        if spinner.is_alive():
            spinner.join(10)
        ctx.try_shutdown()
        peer.close()
        r.close()
