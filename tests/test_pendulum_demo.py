"""The seed's pendulum graph on the bus: QoS, late-joining setpoint, counts, NaN faults, CLI."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from robocourse.bus import Context, DurabilityPolicy, ReliabilityPolicy, SingleThreadedExecutor
from robocourse.pendulum import demo
from robocourse.pendulum.msgs import JointCommand, RttestResults


def test_graph_has_the_seeds_topics_and_qos():
    ctx = Context(use_sim_time=True)
    g = demo.build_graph(ctx, physics_timer=True)
    topics = dict(g.controller_node.get_topic_names_and_types())
    assert topics["/pendulum_sensor"] == ["pendulum_msgs/msg/JointState"]
    assert topics["/pendulum_command"] == ["pendulum_msgs/msg/JointCommand"]
    assert topics["/pendulum_statistics"] == ["pendulum_msgs/msg/RttestResults"]
    [sensor_pub] = g.motor_node.get_publishers_info_by_topic("/pendulum_sensor")
    assert sensor_pub.node_name == "pendulum_motor"
    assert sensor_pub.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT and sensor_pub.qos_profile.depth == 1
    [setpoint_sub] = g.controller_node.get_subscriptions_info_by_topic("/pendulum_setpoint")
    assert setpoint_sub.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    ctx.shutdown()


def test_setpoint_published_before_the_controller_starts_still_arrives():
    out = demo.run_simulated(0.5, setpoint=1.2, teleop_first=True)
    assert out["setpoints"] == [1.2]
    assert abs(out["angle"][-1] - 1.2) < 0.02  # the pendulum is held near the new setpoint


def test_simulated_run_counts_and_is_deterministic():
    a = demo.run_simulated(1.0, initial_position=math.pi / 2 + 0.1)
    b = demo.run_simulated(1.0, initial_position=math.pi / 2 + 0.1)
    assert a["physics_steps"] == 1000 and len(a["t"]) == 1000
    # the motor publishes every 970 us and the controller every 960 us: about 1031 and 1042 per s
    assert a["controller_received"] == pytest.approx(1000 / 0.97, rel=0.01)
    assert a["motor_received"] == pytest.approx(1000 / 0.96, rel=0.01)
    np.testing.assert_array_equal(a["angle"], b["angle"])
    # p = 1 makes the seed's controller command the setpoint itself: the angle stays near pi/2
    assert np.max(np.abs(a["angle"][10:] - math.pi / 2)) < 0.01


def test_nan_command_raises_the_seeds_error_and_the_executor_survives():
    ctx = Context(use_sim_time=True)
    g = demo.build_graph(ctx, physics_timer=True)
    bad = ctx.create_node("bad_teleop").create_publisher(JointCommand, "pendulum_command", demo.QOS_REALTIME)
    ex = SingleThreadedExecutor(context=ctx)
    for node in list(ctx.nodes):
        ex.add_node(node)
    ex.spin_for(0.01)
    bad.publish(JointCommand(position=float("nan")))
    # the seed throws; as in rclpy the exception leaves spin, and the executor goes on after
    with pytest.raises(RuntimeError, match="Tried to set state to NaN in on_command_message"):
        ex.spin_for(0.01)
    ex.spin_for(0.01)
    errors = [str(e.exception) for e in ctx.callback_errors]
    assert errors == ["Tried to set state to NaN in on_command_message callback"]
    assert g.controller.messages_received > 15  # still spinning after the fault
    ctx.shutdown()


def test_logger_prints_the_seeds_lines(capsys):
    ctx = Context(use_sim_time=True)
    demo.build_graph(ctx, physics_timer=True)
    logger = demo.PendulumLogger(ctx, echo=True)
    ex = SingleThreadedExecutor(context=ctx)
    for node in list(ctx.nodes):
        ex.add_node(node)
    ex.spin_for(0.0105)
    out = capsys.readouterr().out
    assert logger.received == 10
    for line in ("Commanded motor angle: ", "Actual motor angle: ", "Current latency: ", "Mean latency: ",
                 "Min latency: ", "Max latency: ", "Minor pagefaults during execution: ",
                 "Major pagefaults during execution: "):
        assert out.count(line) == 10
    ctx.shutdown()


def test_teleop_default_and_bad_setpoint(capsys):
    ctx = Context(use_sim_time=True)
    demo.teleop(ctx)
    assert demo.TELEOP_DEFAULT_TEXT in capsys.readouterr().out
    with pytest.raises(ValueError, match="setpoint=nan: an angle in radians from the ground, finite"):
        demo.teleop(ctx, float("nan"), verbose=False)
    ctx.shutdown()


def test_realtime_run_delivers_every_published_message_and_runs_every_iteration():
    # Counts per timer depend on the wall clock (a loaded machine catches up late ticks), so
    # the test checks what does not: the loop ran exactly N iterations and, in-process with
    # RELIABLE QoS, every message each node published reached the other node.
    run = demo.run_realtime(1000, quiet=True)
    assert run.loop.iterations == 1000
    published = {p.topic_name: p.publish_count
                 for node in (run.graph.motor_node, run.graph.controller_node) for p in node.publishers}
    assert published["/pendulum_sensor"] > 0 and published["/pendulum_command"] > 0
    assert run.controller_received == published["/pendulum_sensor"]
    assert run.motor_received == published["/pendulum_command"]
    assert run.graph.published_statistics == published["/pendulum_statistics"]
    assert isinstance(RttestResults().cur_latency, int)


def test_cli_prints_what_pendulum_demo_prints(tmp_path):
    out_file = tmp_path / "pendulum.txt"
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "pendulum", "demo", "-i", "500", "-f", str(out_file),
                           "--setpoint", "1.3"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "Pendulum set to: 1.300000" in out and "rttest statistics:" in out
    # the seed's rttest loop sleeps; so does ours unless told --wait hybrid, and the block says which
    assert "Wait strategy: sleep (clock_nanosleep to each absolute deadline, as rttest does)\nrttest statistics:" in out
    assert "Latency (time after deadline was missed):" in out
    assert "PendulumMotor received" in out and "PendulumController received" in out
    lines = out_file.read_text().splitlines()
    assert lines[0] == "iteration timestamp latency minor_pagefaults major_pagefaults" and len(lines) == 501


def test_realtime_run_sleeps_unless_told_otherwise():
    from robocourse.rt import Hybrid

    assert demo.run_realtime(20, quiet=True).loop.strategy == "sleep"
    hybrid = demo.run_realtime(20, quiet=True, wait=Hybrid(spin_ns=100_000))
    assert hybrid.loop.stats().wait == "hybrid(100 us spin)"


def test_cli_usage_errors_are_clear():
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "pendulum", "demo", "-s", "batch"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "robocourse pendulum demo: error:" in proc.stderr and "batch" in proc.stderr


SETPRIV = shutil.which("setpriv")


@pytest.mark.skipif(os.geteuid() != 0 or SETPRIV is None, reason="needs root + setpriv to drop the capabilities for real")
def test_cli_without_privileges_prints_the_seeds_messages_and_carries_on():
    def limits():
        import resource
        resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
        resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))

    cmd = [SETPRIV, "--bounding-set=-sys_nice,-ipc_lock", "--inh-caps=-sys_nice,-ipc_lock", "--",
           sys.executable, "-m", "robocourse.cli", "pendulum", "demo", "-i", "300"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, preexec_fn=limits)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, text
    assert "Couldn't set scheduling priority and policy: Operation not permitted" in text
    assert "Couldn't lock all cached virtual memory." in text
    assert "Pagefaults from reading pages not yet mapped into RAM will be recorded." in text
    assert "PendulumController received" in text


@pytest.mark.parametrize("kwargs,fragment", [
    ({"iterations": 0}, r"run_realtime\(iterations=0\): at least 1"),
    ({"iterations": -5}, r"iterations=-5"),
    ({"period_ns": 0}, r"period_ns=0"),
    ({"priority": 99}, r"priority=99\): a real-time priority 1..98"),
    ({"policy": "batch"}, r"policy='batch'"),
    ({"setpoint": float("nan")}, r"setpoint=nan"),
    ({"wait": "sleep"}, r"wait='sleep'"),
])
def test_run_realtime_refuses_bad_input_before_starting_anything(kwargs, fragment):
    import threading

    before = set(threading.enumerate())
    with pytest.raises(ValueError, match=fragment):
        demo.run_realtime(**kwargs, quiet=True)
    # no physics thread was started (threads new since `before`: a count would also change when a thread an
    # earlier test left behind, e.g. a physics thread its 1 s join gave up on, ends meanwhile)
    assert set(threading.enumerate()) - before == set()


@pytest.mark.parametrize("kwargs,fragment", [
    ({"seconds": -1}, r"run_simulated\(seconds=-1\): spin for a positive, finite number of seconds"),
    ({"seconds": 0.0}, "seconds=0.0"),
    ({"seconds": float("nan")}, "seconds=nan"),
    ({"seconds": 0.1, "initial_position": float("inf")}, "initial_position=inf"),
])
def test_run_simulated_refuses_bad_input(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        demo.run_simulated(**kwargs)
