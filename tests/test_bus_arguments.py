"""``Node(cli_args=...)``: rcl's --ros-args rules (remap, __node/__ns, -p, --params-file).

Scenarios follow rcl's test_remap.cpp / test_arguments.cpp and rclcpp's parameter-file tests:
relative rules expand in the node's namespace, the first matching rule wins, node-specific
rules apply to one node, parameter files match node names with * and **, later sources win.
"""

import pytest

from robocourse.bus import Context, InvalidParameterTypeException, Parameter
from robocourse.bus.arguments import (
    RosArgumentError,
    load_param_file,
    node_pattern_matches,
    parse_ros_args,
    remove_ros_args,
)
from robocourse.msgs.std_msgs import Float64
from robocourse.msgs.std_srvs import SetBool


def node(name, *args, ctx=None, **kw):
    ctx = ctx or Context(use_sim_time=True)
    return ctx.create_node(name, cli_args=["--ros-args", *args], **kw)


def test_relative_rule_expands_in_the_nodes_namespace():
    n = node("driver", "-r", "cmd_vel:=cmd_vel_safe", namespace="/car")
    assert n.create_publisher(Float64, "cmd_vel", 10).topic_name == "/car/cmd_vel_safe"
    assert n.create_publisher(Float64, "/cmd_vel", 10).topic_name == "/cmd_vel"   # absolute /cmd_vel != /car/cmd_vel
    assert n.resolve_topic_name("cmd_vel", only_expand=True) == "/car/cmd_vel"


def test_first_matching_rule_wins_and_private_names_remap():
    n = node("driver", "-r", "/a:=/b", "-r", "/a:=/c", "-r", "~/state:=/status")
    assert n.resolve_topic_name("/a") == "/b"
    assert n.resolve_topic_name("~/state") == "/status"


def test_node_specific_rule_applies_to_that_node_only():
    ctx = Context(use_sim_time=True)
    args = ["-r", "talker:chatter:=loud"]
    assert node("talker", *args, ctx=ctx).resolve_topic_name("chatter") == "/loud"
    assert node("listener", *args, ctx=ctx).resolve_topic_name("chatter") == "/chatter"


def test_node_name_and_namespace_remaps():
    ctx = Context(use_sim_time=True)
    n = node("driver_node", "-r", "__node:=left_driver", "-r", "__ns:=/mycar", ctx=ctx)
    assert n.get_fully_qualified_name() == "/mycar/left_driver"
    assert "/mycar/left_driver" in [m.get_fully_qualified_name() for m in ctx.nodes]
    other = node("x", "-r", "driver_node:__node:=renamed", ctx=ctx)   # rule for another node
    assert other.get_name() == "x"


def test_topic_only_rule_does_not_touch_services():
    n = node("n", "-r", "rostopic://reset:=/other")
    assert n.resolve_topic_name("reset") == "/other"
    assert n.create_service(SetBool, "reset", lambda req, res: res).srv_name == "/reset"


def test_p_values_are_yaml_typed():
    n = node("n", "-p", "rate:=100.0", "-p", "name:=car", "-p", "on:=true", "-p", "ids:=[1, 2]")
    assert n.declare_parameter("rate", 50.0).value == 100.0
    assert n.declare_parameter("name", "x").value == "car"
    assert n.declare_parameter("on", False).value is True
    assert n.declare_parameter("ids", [0]).value == [1, 2]


def test_an_integer_for_a_double_is_refused_with_the_fix():
    n = node("n", "-p", "wheel_base:=1")
    with pytest.raises(InvalidParameterTypeException, match=r"'wheel_base' to '1' of type 'INTEGER', expecting "
                                                           r"type 'DOUBLE'; write 1.0"):
        n.declare_parameter("wheel_base", 0.15)


PARAMS = """
/**:
  ros__parameters:
    shared: 1.0
driver_node:
  ros__parameters:
    wheel_base: 0.2
    pid:
      p: 2.0
      i: 0.5
mycar:
  driver_node:
    ros__parameters:
      wheel_base: 0.3
/*/nav:
  ros__parameters:
    tolerance: 0.02
"""


def test_parameter_file_layout(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text(PARAMS)
    entries = load_param_file(path)
    assert [e[0] for e in entries] == ["/**", "/driver_node", "/mycar/driver_node", "/*/nav"]
    assert entries[1][1] == {"wheel_base": 0.2, "pid.p": 2.0, "pid.i": 0.5}
    ctx = Context(use_sim_time=True)
    root = node("driver_node", "--params-file", str(path), ctx=ctx)
    assert root.declare_parameter("wheel_base", 0.15).value == 0.2
    assert root.declare_parameter("pid.p", 1.0).value == 2.0
    assert root.declare_parameter("shared", 0.0).value == 1.0
    spaced = node("driver_node", "--params-file", str(path), ctx=ctx, namespace="/mycar")
    assert spaced.declare_parameter("wheel_base", 0.15).value == 0.3
    nav = node("nav", "--params-file", str(path), ctx=ctx, namespace="/mycar")
    assert nav.declare_parameter("tolerance", 0.05).value == 0.02
    deep = node("nav", "--params-file", str(path), ctx=ctx, namespace="/a/b")   # * is one token
    assert deep.declare_parameter("tolerance", 0.05).value == 0.05


def test_later_sources_win(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text("n:\n  ros__parameters:\n    x: 1.0\n    y: 1.0\n    z: 1.0\n")
    b.write_text("n:\n  ros__parameters:\n    y: 2.0\n    z: 2.0\n")
    n = node("n", "--params-file", str(a), "--params-file", str(b), "-p", "z:=3.0",
             parameter_overrides=[Parameter("w", value=4.0)])
    assert [n.declare_parameter(k, 0.0).value for k in "xyzw"] == [1.0, 2.0, 3.0, 4.0]
    n2 = node("n", "-p", "x:=3.0", parameter_overrides=[Parameter("x", value=4.0)])
    assert n2.declare_parameter("x", 0.0).value == 4.0   # rclpy: parameter_overrides win over the command line


def test_wildcards():
    assert node_pattern_matches("/**", "/a/b/c")
    assert node_pattern_matches("/**/c", "/c") and node_pattern_matches("/**/c", "/a/b/c")
    assert node_pattern_matches("/*/c", "/a/c") and not node_pattern_matches("/*/c", "/c")
    assert node_pattern_matches("c", "/c") and not node_pattern_matches("c", "/a/c")


@pytest.mark.parametrize("args, words", [
    (["-r", "cmd_vel"], "a rule is 'from:=to'"),
    (["-r"], "needs a value"),
    (["--bogus"], "unknown ROS argument '--bogus'"),
    (["--params-file", "/no/such.yaml"], "no such file"),
    (["-r", "__node:=9lives"], "must not start with a number"),
])
def test_bad_arguments_are_refused_before_the_node_exists(args, words):
    ctx = Context(use_sim_time=True)
    with pytest.raises(ValueError, match=words):
        ctx.create_node("n", cli_args=["--ros-args", *args])
    assert ctx.nodes == []


def test_bad_parameter_file_layout(tmp_path):
    path = tmp_path / "flat.yaml"
    path.write_text("driver_node:\n  wheel_base: 0.2\n")
    with pytest.raises(RosArgumentError, match="not inside a 'ros__parameters:' block"):
        load_param_file(path)


def test_program_arguments_stay_outside_ros_args():
    args = ["prog", "--speed", "2", "--ros-args", "-r", "a:=b", "--", "--verbose"]
    assert remove_ros_args(args) == ["prog", "--speed", "2", "--verbose"]
    assert [str(r) for r in parse_ros_args(args).remaps] == ["a:=b"]
