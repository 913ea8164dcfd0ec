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
    assert ros2.param_list(ctx, "/ctl") == ["kp", "use_sim_time"]
    assert ros2.param_get(ctx, "/ctl", "kp") == 2.0
    assert ros2.param_set(ctx, "/ctl", "kp", 3.0).successful
    out = capsys.readouterr().out
    assert "Double value is: 2.0" in out and "Set parameter successful" in out
