"""ros2 control verbs (layout and service round trip), the spawner, bring-up, the CLI and the picture."""

from __future__ import annotations

import xml.dom.minidom

import pytest
from control_robots import TestChainable, TestController

from robocourse.control import STRICT
from robocourse.control import introspection as ic
from robocourse.control.bringup import bringup
from robocourse.control.log import LogSink
from robocourse.control.msgs import ControllerState, HardwareInterface
from robocourse.control.picture import system_picture


def rrbot(**kw):
    return bringup("rrbot", log=LogSink(log_to_stderr=False), **kw)


def test_list_controllers_layout_matches_ros2controlcli(capsys):
    cm = rrbot(spawn=["joint_state_broadcaster"], inactive=["forward_position_controller"])
    data = ic.list_controllers(cm)
    assert capsys.readouterr().out.splitlines() == [
        "joint_state_broadcaster     joint_state_broadcaster/JointStateBroadcaster        active  ",
        "forward_position_controller forward_command_controller/ForwardCommandController  inactive",
    ]
    assert [(c.name, c.state) for c in data] == [("joint_state_broadcaster", "active"),
                                                ("forward_position_controller", "inactive")]
    assert ic.format_controllers([]) == "No controllers are currently loaded!"


def test_list_controllers_verbose_blocks():
    c = ControllerState(name="fwd", type="t", state="active", update_rate=100, claimed_interfaces=["j1/position"],
                        required_command_interfaces=["j1/position"], required_state_interfaces=[])
    assert ic.format_controllers([c], verbose=True).splitlines() == [
        "fwd t  active", "\tupdate_rate: 100 Hz", "\tis_async: False", "\tclaimed interfaces:", "\t\tj1/position",
        "\trequired command interfaces:", "\t\tj1/position", "\trequired state interfaces:"]


def test_list_hardware_interfaces_marks_claimed_available(capsys):
    cm = rrbot(spawn=["forward_position_controller"])
    cm.set_hardware_component_state("RRBot", "unconfigured")
    cmds, states = ic.list_hardware_interfaces(cm)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "command interfaces" and out[1] == "\tjoint1/effort [unavailable] [unclaimed]"
    assert "state interfaces" in out and out[-1] == "\tjoint2/velocity"
    assert ic.format_hardware_interfaces([HardwareInterface(name="a/x", data_type="double", is_available=True,
                                                            is_claimed=True)], [], verbose=True) == \
        "command interfaces\n\ta/x [double] [available] [claimed]\nstate interfaces"
    assert len(cmds) == 6 and len(states) == 6


def test_list_hardware_components_layout(capsys):
    cm = rrbot(spawn=["forward_position_controller"])
    ic.list_hardware_components(cm)
    assert capsys.readouterr().out.splitlines()[:10] == [
        "Hardware Component 1", "\tname: RRBot", "\ttype: system", "\tplugin name: mock_components/GenericSystem",
        "\tstate: id=3 label=active", "\tread/write rate: 100 Hz", "\tis_async: False", "\tcommand interfaces",
        "\t\tjoint1/position [available] [claimed]", "\t\tjoint1/velocity [available] [unclaimed]"]


def test_verbs_change_the_system_through_the_services(capsys):
    cm = rrbot(spawn=["joint_state_broadcaster"])
    assert ic.load_controller(cm, "forward_position_controller", set_state="active")
    assert cm.controllers["forward_position_controller"].state.label == "active"
    assert not ic.switch_controllers(cm, activate=["ghost"], strict=True)
    assert ic.set_hardware_component_state(cm, "RRBot", "inactive")
    assert cm.controllers["forward_position_controller"].state.label == "inactive"
    assert capsys.readouterr().out.splitlines() == [
        "Successfully loaded controller forward_position_controller",
        "Successfully loaded controller forward_position_controller into state active",
        "Error switching controllers, check controller_manager logs",
        "Successfully set RRBot to state inactive"]


def test_spawner_inactive_and_param_file(tmp_path):
    cm = rrbot()
    f = tmp_path / "extra.yaml"
    f.write_text("my_fwd:\n  ros__parameters:\n    type: forward_command_controller/ForwardCommandController\n"
                 "    joints: [joint2]\n    interface_name: velocity\n")
    assert ic.spawner(cm, ["my_fwd"], inactive=True, param_file=f, quiet=True)
    spec = cm.controllers["my_fwd"]
    assert spec.state.label == "inactive" and spec.c.command_interface_names == ["joint2/velocity"]
    assert ic.spawner(cm, ["joint_state_broadcaster", "forward_position_controller"], activate_as_group=True,
                      quiet=True)
    assert {c.name: c.state for c in ic.list_controllers(cm, quiet=True)} == {
        "my_fwd": "inactive", "joint_state_broadcaster": "active", "forward_position_controller": "active"}
    assert not ic.spawner(cm, ["not_in_any_file"], quiet=True)


def test_cli_prints_ros2_control_layout(capsys):
    from robocourse.cli import main

    assert main(["control", "list_controllers", "--spawn", "joint_state_broadcaster"]) == 0
    assert capsys.readouterr().out == \
        "joint_state_broadcaster joint_state_broadcaster/JointStateBroadcaster  active\n"
    assert main(["control", "load_controller", "nope"]) == 1
    captured = capsys.readouterr()
    assert captured.out == "Error loading controller nope, check controller_manager logs\n"
    assert "The 'type' param was not defined for 'nope'." in captured.err
    assert main(["control", "spawner", "forward_position_controller", "--inactive"]) == 0
    assert capsys.readouterr().out == "Loaded forward_position_controller\nConfigured forward_position_controller\n"


def test_picture_shows_components_controllers_claims_and_chains(tmp_path):
    cm = rrbot(spawn=["joint_state_broadcaster"])
    follower = TestChainable(["joint1/position"], ["joint1/position"], ["joint1/position"])
    assert cm.load_controller("follower", controller=follower) is follower
    cm.configure_controller("follower")
    cm.load_controller("preceding", controller=TestController(["follower/joint1/position"]))
    cm.configure_controller("preceding")
    assert cm.switch_controller(["preceding", "follower"], [], STRICT) == 0
    pic = system_picture(cm)
    doc = xml.dom.minidom.parseString(pic.svg)
    texts = [t.firstChild.data for t in doc.getElementsByTagName("text")]
    assert "RRBot [active]" in texts and "preceding [active]" in texts and "follower [active]" in texts
    assert "joint1/position  <- follower" in texts and "follower/joint1/position  <- preceding" in texts
    assert "6 state interfaces (6 available)" in texts
    blue = [e for e in doc.getElementsByTagName("line") + doc.getElementsByTagName("path")
            if e.getAttribute("stroke") == "#1f5fbf"]
    assert len(blue) == 2                                   # two command claims, one of them chained
    assert pic._repr_svg_() == pic.svg
    pic.save(tmp_path / "s.svg")
    assert (tmp_path / "s.svg").read_text() == pic.svg


def test_bringup_refuses_plugin_with_own_urdf():
    with pytest.raises(ValueError, match="plugin= applies to a shipped robot"):
        bringup(urdf="<robot/>", plugin="x/y")


def test_ros2_control_verbs_wait_on_the_managers_executor_when_a_thread_spins_it():
    # one thread spins an executor (rclpy): the verb joins that thread's spinning instead of spinning too
    import threading

    from robocourse.bus import Future

    cm = rrbot(spawn=["joint_state_broadcaster"], inactive=["forward_position_controller"])
    cm.node  # noqa: B018  (the manager's services exist before the thread spins)
    stop = Future()
    th = threading.Thread(target=cm.executor.spin_until_future_complete, args=(stop,), daemon=True)
    th.start()
    try:
        while not cm.executor.is_spinning_elsewhere():
            pass
        data = ic.list_controllers(cm, quiet=True)
        assert [(c.name, c.state) for c in data] == [("joint_state_broadcaster", "active"),
                                                    ("forward_position_controller", "inactive")]
        assert th.is_alive()
    finally:
        stop.set_result(True)
        cm.executor._wake()
        th.join(10)


def test_a_quiet_log_shows_only_the_lines_asked_for(capsys, monkeypatch):
    from robocourse.bus.logging import LoggingSeverity

    monkeypatch.setenv("RCUTILS_LOGGING_USE_STDOUT", "1")
    monkeypatch.setenv("RCUTILS_COLORIZED_OUTPUT", "0")
    log = LogSink(log_to_stderr=False)
    cm = bringup("rrbot", log=log, spawn=["joint_state_broadcaster"])
    assert capsys.readouterr().out.count("[INFO]") == 0          # nothing printed while bringing up
    mark = log.mark()
    assert cm.switch_controller(["no_such"], []).name == "ERROR"
    assert log.show(mark, LoggingSeverity.WARN) >= 1
    out = capsys.readouterr().out
    assert "[ERROR]" in out and "no_such" in out and "[INFO]" not in out
    assert log.show(mark, contains="nothing like this") == 0 and capsys.readouterr().out == ""


def test_lifecycle_picture_draws_every_transition_and_marks_the_ones_taken():
    from robocourse.control.lifecycle import Transition
    from robocourse.control.picture import lifecycle_picture

    history = [Transition("unknown", "on_init", "SUCCESS", "unconfigured"),
               Transition("unconfigured", "on_configure", "FAILURE", "unconfigured"),
               Transition("unconfigured", "on_configure", "SUCCESS", "inactive"),
               Transition("inactive", "on_activate", "SUCCESS", "active"),
               Transition("active", "on_error", "SUCCESS", "unconfigured")]
    svg = lifecycle_picture(history).svg
    assert svg.count("<path d=") == 13 + 1 + 3          # every transition, one FAILURE loop, three markers
    assert "on_configure SUCCESS x1" in svg and "on_configure FAILURE x1 (stays)" in svg
    assert "on_error SUCCESS x1" in svg and ">on_shutdown<" in svg      # taken with counts; never taken, plain
    assert repr(lifecycle_picture(history)) == "<picture: SVG 920 x 470 px>"


def test_a_component_records_every_lifecycle_callback_it_ran():
    from robocourse.control import ControllerManager
    from robocourse.control.motor_board import MotorBoard, MotorBoardSystem, motor_board_urdf

    board = MotorBoard([0.1, 0.2])
    cm = ControllerManager(motor_board_urdf(), components={"MotorBoard": MotorBoardSystem(board)},
                           log=LogSink(log_to_stderr=False))
    board.unplug()
    cm.step()
    steps = [(t.start, t.callback, t.result, t.goal) for t in cm.rm.components["MotorBoard"].wrapper.history]
    assert steps == [("unknown", "on_init", "SUCCESS", "unconfigured"),
                     ("unconfigured", "on_configure", "SUCCESS", "inactive"),
                     ("inactive", "on_activate", "SUCCESS", "active"),
                     ("active", "on_error", "SUCCESS", "unconfigured")]
