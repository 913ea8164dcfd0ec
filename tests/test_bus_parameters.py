"""Parameters: declare/get/set, types, descriptors, ranges, read-only, callbacks, overrides."""

import pytest

from robocourse.bus import (
    Context,
    FloatingPointRange,
    IntegerRange,
    InvalidParameterValueException,
    Parameter,
    ParameterAlreadyDeclaredException,
    ParameterDescriptor,
    ParameterNotDeclaredException,
    SetParametersResult,
)
from robocourse.bus import introspection as ros2
from robocourse.bus.parameters import ParameterImmutableException


def node(**kw):
    return Context().create_node("controller", **kw)


def test_declare_get_set_with_types():
    n = node()
    p = n.declare_parameter("kp", 2.0)
    assert p.type_ == Parameter.Type.DOUBLE and n.get_parameter("kp").value == 2.0
    n.declare_parameter("joints", ["a", "b"])
    assert n.get_parameter("joints").type_ == Parameter.Type.STRING_ARRAY
    res = n.set_parameters([Parameter("kp", value=3.5)])
    assert res[0].successful and n.get_parameter("kp").value == 3.5
    res = n.set_parameters([Parameter("kp", value="high")])
    assert not res[0].successful
    assert res[0].reason == ("Wrong parameter type, parameter {kp} is of type {DOUBLE}, setting it "
                             "to {STRING} is not allowed.")
    assert n.get_parameter("kp").value == 3.5


def test_undeclared_names_and_double_declaration():
    n = node()
    with pytest.raises(ParameterNotDeclaredException, match="undeclared"):
        n.get_parameter("nope")
    with pytest.raises(ParameterNotDeclaredException):
        n.set_parameters([Parameter("nope", value=1)])
    n.declare_parameter("a", 1)
    with pytest.raises(ParameterAlreadyDeclaredException):
        n.declare_parameter("a", 2)
    assert n.get_parameter_or("nope", Parameter("nope", value=5)).value == 5
    loose = Context().create_node("loose", allow_undeclared_parameters=True)
    assert loose.set_parameters([Parameter("x", value=1)])[0].successful
    assert loose.get_parameter("x").value == 1


def test_read_only_and_ranges():
    n = node()
    n.declare_parameter("rate_hz", 100, ParameterDescriptor(read_only=True, description="loop rate"))
    r = n.set_parameters([Parameter("rate_hz", value=200)])[0]
    assert not r.successful and "read-only" in r.reason
    assert n.describe_parameter("rate_hz").description == "loop rate"
    with pytest.raises(ParameterImmutableException):
        n.undeclare_parameter("rate_hz")
    n.declare_parameter("gain", 0.5, ParameterDescriptor(
        floating_point_range=[FloatingPointRange(from_value=0.0, to_value=1.0, step=0.0)]))
    assert n.set_parameters([Parameter("gain", value=0.9)])[0].successful
    bad = n.set_parameters([Parameter("gain", value=1.5)])[0]
    assert not bad.successful and "floating point range" in bad.reason
    n.declare_parameter("n", 4, ParameterDescriptor(integer_range=[IntegerRange(from_value=0, to_value=10, step=2)]))
    assert not n.set_parameters([Parameter("n", value=5)])[0].successful
    assert n.set_parameters([Parameter("n", value=6)])[0].successful
    with pytest.raises(InvalidParameterValueException):
        n.declare_parameter("m", 11, ParameterDescriptor(integer_range=[IntegerRange(0, 10, 1)]))


def test_on_set_callback_can_reject():
    n = node()
    n.declare_parameter("max_speed", 1.0)
    seen = []

    def check(params):
        seen.append([(p.name, p.value) for p in params])
        for p in params:
            if p.name == "max_speed" and p.value > 2.0:
                return SetParametersResult(successful=False, reason="too fast for the lab")
        return SetParametersResult(successful=True)

    n.add_on_set_parameters_callback(check)
    assert n.set_parameters([Parameter("max_speed", value=1.5)])[0].successful
    r = n.set_parameters([Parameter("max_speed", value=5.0)])[0]
    assert not r.successful and r.reason == "too fast for the lab"
    assert n.get_parameter("max_speed").value == 1.5
    assert seen == [[("max_speed", 1.5)], [("max_speed", 5.0)]]
    atomic = n.set_parameters_atomically([Parameter("max_speed", value=1.0), Parameter("max_speed", value=9.0)])
    assert not atomic.successful and n.get_parameter("max_speed").value == 1.5


def test_overrides_at_node_creation():
    n = node(parameter_overrides=[Parameter("kp", value=7.0)])
    assert n.declare_parameter("kp", 1.0).value == 7.0
    assert n.declare_parameter("ki", 0.1).value == 0.1
    auto = Context().create_node("auto", parameter_overrides=[Parameter("kd", value=0.2)],
                                 automatically_declare_parameters_from_overrides=True)
    assert auto.get_parameter("kd").value == 0.2


def test_param_cli(capsys):
    ctx = Context()
    n = ctx.create_node("ctl")
    n.declare_parameter("kp", 2.0)
    # an rclpy node on Jazzy also lists its read-only start_type_description_service
    assert ros2.param_list(ctx, "/ctl") == ["kp", "start_type_description_service", "use_sim_time"]
    assert ros2.param_get(ctx, "/ctl", "kp") == 2.0
    assert ros2.param_set(ctx, "/ctl", "kp", 3.0).successful
    out = capsys.readouterr().out
    assert "Double value is: 2.0" in out and "Set parameter successful" in out


def test_declared_with_a_type_and_no_value_is_uninitialized_until_set():
    # rclpy Node.get_parameter: "ParameterUninitializedException if the parameter is
    # statically typed and uninitialized"
    from robocourse.bus.parameters import ParameterUninitializedException

    n = node()
    p = n.declare_parameter("robot_ip", Parameter.Type.STRING)
    assert p.type_ == Parameter.Type.NOT_SET and p.value is None
    assert n.describe_parameter("robot_ip").type == Parameter.Type.STRING
    with pytest.raises(ParameterUninitializedException, match="'robot_ip' is not initialized"):
        n.get_parameter("robot_ip")
    with pytest.raises(ParameterUninitializedException):
        n.get_parameters(["use_sim_time", "robot_ip"])
    assert n.get_parameter_or("robot_ip", Parameter("robot_ip", value="x")).value == "x"
    assert n.get_parameter_type("robot_ip") == Parameter.Type.NOT_SET
    bad = n.set_parameters([Parameter("robot_ip", value=3)])[0]
    assert not bad.successful and "STRING" in bad.reason
    assert n.set_parameters([Parameter("robot_ip", value="10.0.0.2")])[0].successful
    assert n.get_parameter("robot_ip").value == "10.0.0.2"
    # an override initializes it at declaration
    o = node(parameter_overrides=[Parameter("robot_ip", value="192.168.1.5")])
    assert o.declare_parameter("robot_ip", Parameter.Type.STRING).value == "192.168.1.5"
    with pytest.raises(ValueError, match="statically typed of type NOT_SET"):
        n.declare_parameter("x", Parameter.Type.NOT_SET)


def test_static_parameter_cannot_be_undeclared_by_setting_not_set():
    # rclpy _apply_descriptor: 'Static parameter cannot be undeclared'
    n = node()
    n.declare_parameter("kp", 2.0)
    res = n.set_parameters([Parameter("kp", Parameter.Type.NOT_SET)])[0]
    assert not res.successful and res.reason == "Static parameter cannot be undeclared"
    assert n.has_parameter("kp") and n.get_parameter("kp").value == 2.0
    # a dynamically typed one can be: setting NOT_SET undeclares it
    n.declare_parameter("anything", 1, ParameterDescriptor(dynamic_typing=True))
    assert n.set_parameters([Parameter("anything", value="now a string")])[0].successful
    assert n.describe_parameter("anything").type == Parameter.Type.STRING
    assert n.set_parameters([Parameter("anything", Parameter.Type.NOT_SET)])[0].successful
    assert not n.has_parameter("anything")
    # rclpy's name-only declaration is dynamically typed: get gives NOT_SET, no exception
    p = n.declare_parameter("loose")
    assert p.type_ == Parameter.Type.NOT_SET and n.get_parameter("loose").value is None
    assert n.describe_parameter("loose").dynamic_typing


def test_list_parameters_prefixes_and_depth_like_rclpy():
    n = node()
    for name in ("a.b.c", "a.b.d", "a.e", "f"):
        n.declare_parameter(name, 1)
    everything = n.list_parameters([], 0)
    assert sorted(everything.names) == ["a.b.c", "a.b.d", "a.e", "f",
                                        "start_type_description_service", "use_sim_time"]
    assert sorted(everything.prefixes) == ["a", "a.b"]
    assert sorted(n.list_parameters([], 1).names) == ["f", "start_type_description_service",
                                                      "use_sim_time"]
    assert sorted(n.list_parameters(["a"], 1).names) == ["a.e"]
    assert sorted(n.list_parameters(["a"], 0).names) == ["a.b.c", "a.b.d", "a.e"]
    assert sorted(n.list_parameters(["a.b"], 1).names) == ["a.b.c", "a.b.d"]
    with pytest.raises(ValueError, match="greater than or equal to zero"):
        n.list_parameters([], -1)


def test_every_declaration_and_set_is_a_parameter_event():
    from robocourse.bus import SingleThreadedExecutor
    from robocourse.msgs.rcl_interfaces import ParameterEvent

    ctx = Context()
    watcher = ctx.create_node("watcher")
    events = []
    watcher.create_subscription(ParameterEvent, "/parameter_events", events.append, 1000)
    n = ctx.create_node("ctl", namespace="/arm")
    n.declare_parameter("kp", 2.0)
    n.set_parameters([Parameter("kp", value=3.0)])
    n.set_parameters([Parameter("kp", value="bad")])        # refused: no event
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(watcher)
    ex.spin_some()
    mine = [e for e in events if e.node == "/arm/ctl"]
    # rclpy: use_sim_time, start_type_description_service and kp declared, then kp changed
    assert [[p.name for p in e.new_parameters] for e in mine] == [
        ["use_sim_time"], ["start_type_description_service"], ["kp"], []]
    assert [p.name for p in mine[3].changed_parameters] == ["kp"]
    assert mine[3].changed_parameters[0].value.type == Parameter.Type.DOUBLE
    assert mine[3].changed_parameters[0].value.double_value == 3.0
