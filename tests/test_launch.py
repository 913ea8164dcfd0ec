"""robocourse.launch: launch / launch_ros semantics on the bus (mycar's executables as the package)."""

import pytest

from robocourse.bus import Context
from robocourse.launch import (
    DeclareLaunchArgument,
    IfCondition,
    LaunchConfiguration,
    LaunchDescription,
    LaunchError,
    Node,
    UnlessCondition,
    executables,
    launch,
)
from robocourse.launch.runner import show_args


def led(**kw):
    return Node(package="mycar", executable="led_service", **kw)


def test_name_namespace_remapping_and_parameters_reach_the_node(tmp_path):
    params = tmp_path / "p.yaml"
    params.write_text("/**:\n  ros__parameters:\n    led_count: 3\n")
    system = launch(LaunchDescription([
        led(name="lights", namespace="car", parameters=[str(params)], remappings=[("/set_led", "set_lights")]),
    ]))
    node = system.node("/car/lights")
    assert node.get_fully_qualified_name() == "/car/lights"
    assert node.get_parameter("led_count").value == 3
    # the remapped service, beside the node's own ~/ services every rclpy node has (parameters, type description)
    names = [s.srv_name for s in node.services]
    assert [n for n in names if not n.startswith("/car/lights/")] == ["/car/set_lights"]
    assert "/car/lights/get_parameters" in names and "/set_led" not in names


def test_parameters_apply_in_order_and_a_substitution_is_read_as_yaml(tmp_path):
    params = tmp_path / "p.yaml"
    params.write_text("led_service_server:\n  ros__parameters:\n    led_count: 3\n")
    system = launch(LaunchDescription([
        DeclareLaunchArgument("leds", default_value="5"),
        led(parameters=[str(params), {"led_count": LaunchConfiguration("leds")}]),
        led(name="second", parameters=[{"led_count": 4}, str(tmp_path / "p.yaml")]),
    ]), launch_arguments={"leds": "6"})
    assert system.node("led_service_server").get_parameter("led_count").value == 6   # '6' read as YAML: an int
    assert system.node("second").get_parameter("led_count").value == 4   # the file names another node


def test_arguments_defaults_choices_and_required():
    desc = LaunchDescription([
        DeclareLaunchArgument("use_sim", choices=["true", "false"], default_value="true"),
        DeclareLaunchArgument("name", default_value=["led_", LaunchConfiguration("use_sim")]),
        led(name=LaunchConfiguration("name")),
    ])
    assert launch(desc).nodes[0].get_name() == "led_true"
    with pytest.raises(LaunchError, match=r"Argument 'use_sim' provided value 'yes' is not valid. Valid options are: "
                                          r"\['true', 'false'\]"):
        launch(desc, launch_arguments={"use_sim": "yes"})
    required = LaunchDescription([DeclareLaunchArgument("params_file", description="the car's parameters")])
    with pytest.raises(LaunchError, match="launch argument 'params_file' is required"):
        launch(required)
    with pytest.raises(TypeError, match="launch arguments are text"):
        launch(desc, launch_arguments={"use_sim": True})
    system = launch(desc, launch_arguments={"use_sm": "false"})
    assert system.warnings == ["launch argument 'use_sm' is not declared by this description (ros2 launch accepts it "
                               "silently; a typo?)"]


def test_conditions():
    desc = LaunchDescription([
        DeclareLaunchArgument("sim", default_value="true"),
        led(name="a", condition=IfCondition(LaunchConfiguration("sim"))),
        led(name="b", condition=UnlessCondition(LaunchConfiguration("sim"))),
    ])
    assert [n.get_name() for n in launch(desc).nodes] == ["a"]
    system = launch(desc, launch_arguments={"sim": "0"})
    assert [n.get_name() for n in system.nodes] == ["b"] and system.skipped == ["a-1"]
    with pytest.raises(LaunchError, match="a condition takes 'true', 'false', '1' or '0'"):
        launch(desc, launch_arguments={"sim": "maybe"})


def test_a_node_that_cannot_start_names_the_action_and_nothing_is_left_running(tmp_path):
    ctx = Context(use_sim_time=True)
    desc = LaunchDescription([led(name="ok"), led(name="bad", parameters=[{"led_count": 2.5}])])
    with pytest.raises(LaunchError, match=r"\[bad-2\] mycar/led_service failed to start: InvalidParameterTypeException"):
        launch(desc, context=ctx)
    assert ctx.nodes == []   # the started one and the half-built one are gone
    with pytest.raises(LaunchError, match="package 'mycar' has no executable 'driver'; its executables: driver_node"):
        launch(LaunchDescription([Node(package="mycar", executable="driver")]))
    with pytest.raises(LaunchError, match="package 'my_car' not found; packages with executables: mycar"):
        launch(LaunchDescription([Node(package="my_car", executable="driver_node")]))
    with pytest.raises(LaunchError, match="parameter file '.*nope.yaml' not found"):
        launch(LaunchDescription([led(parameters=[str(tmp_path / "nope.yaml")])]))


def test_descriptions_refuse_bad_pieces_where_they_are_written():
    with pytest.raises(TypeError, match="unknown keyword"):
        Node(package="mycar", executable="led_service", parameter=[{}])
    with pytest.raises(TypeError, match="parameters is a list"):
        led(parameters={"led_count": 2})
    with pytest.raises(TypeError, match=r"\(from, to\) pairs"):
        led(remappings=["a:=b"])
    with pytest.raises(TypeError, match="launch arguments are text"):
        DeclareLaunchArgument("rate", default_value=50.0)
    with pytest.raises(TypeError, match="call your function"):
        launch(lambda: LaunchDescription([]))


def test_show_args_and_the_package_table():
    text = show_args(LaunchDescription([DeclareLaunchArgument("use_sim", default_value="true",
                                                              description="MuJoCo or not", choices=["true", "false"])]))
    assert text == ("Arguments (pass arguments as '<name>:=<value>'):\n\n    'use_sim':\n        MuJoCo or not\n"
                    "        Valid choices are: ['true', 'false']\n        (default: 'true')")
    assert {"simulator", "driver_node", "led_service", "navigation_server", "teleop"} <= set(executables("mycar"))
