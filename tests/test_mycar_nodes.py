"""MyCar on the bus: driver + watchdog, LED service, navigation action, launch file, mission, MCAP."""

from __future__ import annotations

import math

import pytest

from robocourse.bus import Context, Parameter, SingleThreadedExecutor
from robocourse.bus.action import ActionClient
from robocourse.launch import LaunchError
from robocourse.msgs.action_msgs import GoalStatus
from robocourse.msgs.geometry_msgs import Twist
from robocourse.mycar.launch import launch, load_parameters
from robocourse.mycar.mission import goal_for, run_mission
from robocourse.mycar.msgs import NavigateToPose, SetLed
from robocourse.mycar.nodes import DriverNode


@pytest.fixture
def car():
    c = launch()
    c.client = c.context.create_node("test_client")
    c.executor.add_node(c.client)
    yield c
    c.context.try_shutdown()


def drive(car, v, w, seconds, rate=10):
    pub = car.client.create_publisher(Twist, "/cmd_vel", 10)
    tw = Twist()
    tw.linear.x, tw.angular.z = v, w
    for _ in range(int(seconds * rate)):
        pub.publish(tw)
        car.executor.spin_for(1.0 / rate)


def test_driver_turns_cmd_vel_into_motion_and_odometry(car):
    drive(car, 0.2, 0.0, 2.0)
    x, y, yaw = car.driver.pose
    tx, ty, _ = car.simulator.car.pose()
    assert 0.25 < x < 0.45 and abs(y) < 0.02 and abs(yaw) < 0.05  # about 0.2 m/s after spin-up
    assert math.hypot(x - tx, y - ty) < 0.03
    assert car.driver.odom_published == pytest.approx(100, abs=1)  # 50 Hz for 2 s


def test_watchdog_stops_within_one_period_of_200_ms_and_resumes(car):
    drive(car, 0.2, 0.0, 0.5)
    last_cmd = car.driver.last_cmd_ns
    car.executor.spin_for(0.4)
    assert car.driver.watchdog_trips == 1 and car.driver.driver.stopped
    assert 0.2 < car.driver.tripped_at_age <= 0.2 + 0.01 + 1e-9  # watchdog timer period: 10 ms
    car.executor.spin_for(1.0)
    assert car.driver.watchdog_trips == 1  # logged once, not every period
    warnings = [r for r in car.context.log_records if "emergency stop" in str(r)]
    assert len(warnings) == 1
    drive(car, 0.2, 0.0, 0.2)
    assert not car.driver.driver.stopped and car.driver.last_cmd_ns > last_cmd


def test_led_service_valid_and_invalid_ids(car):
    cli = car.client.create_client(SetLed, "/set_led")
    for led_id, want in ((1, True), (2, True), (0, False), (3, False), (-1, False)):
        fut = cli.call_async(SetLed.Request(led_id=led_id, state=True))
        car.executor.spin_until_future_complete(fut, 1.0)
        assert fut.result().success is want, led_id
    assert car.led.leds == {1: True, 2: True}
    assert sum("Invalid LED ID" in str(r) for r in car.context.log_records) == 3


def _navigate(car, goal, timeout=60.0, cancel_after=None):
    client = ActionClient(car.client, NavigateToPose, "/navigate_to_pose")
    feedback = []
    fut = client.send_goal_async(goal, feedback_callback=lambda m: feedback.append(m.feedback.percent_complete))
    car.executor.spin_until_future_complete(fut, 5.0)
    handle = fut.result()
    if not handle.accepted:
        return handle, None, feedback
    if cancel_after is not None:
        car.executor.spin_for(cancel_after)
        cf = handle.cancel_goal_async()
        car.executor.spin_until_future_complete(cf, 5.0)
    rf = handle.get_result_async()
    car.executor.spin_until_future_complete(rf, timeout)
    return handle, rf.result(), feedback


@pytest.mark.parametrize("x, y, yaw", [(1.0, 0.0, 0.0), (0.5, 0.8, 1.0), (-0.6, 0.3, math.pi)])
def test_navigation_reaches_reachable_poses(car, x, y, yaw):
    from robocourse.msgs.action_msgs import GoalStatus

    handle, res, feedback = _navigate(car, goal_for(x, y, yaw))
    assert handle.accepted and res.status == GoalStatus.STATUS_SUCCEEDED and res.result.success
    ox, oy, oyaw = car.driver.pose
    assert math.hypot(ox - x, oy - y) <= 0.05 + 1e-6
    assert abs(math.remainder(oyaw - yaw, 2 * math.pi)) <= 0.1 + 1e-6
    assert feedback[-1] == 100.0 and all(0.0 <= f <= 100.0 for f in feedback)
    tx, ty, _ = car.simulator.car.pose()
    assert math.hypot(tx - x, ty - y) < 0.2  # the physical car is there too, up to odometry drift


@pytest.mark.parametrize("bad", [(math.nan, 0.0), (0.0, math.inf), (10.0, 0.0)])
def test_navigation_rejects_nan_and_unreachable_goals(car, bad):
    handle, res, _ = _navigate(car, goal_for(*bad))
    assert not handle.accepted
    assert ("NaN or inf" in car.navigation.rejections[-1]) or ("unreachable" in car.navigation.rejections[-1])


def test_navigation_cancel_stops_the_car(car):
    from robocourse.msgs.action_msgs import GoalStatus

    _, res, _ = _navigate(car, goal_for(2.0, 0.0), cancel_after=1.0)
    assert res.status == GoalStatus.STATUS_CANCELED and res.result.message == "canceled"
    car.executor.spin_for(0.5)
    assert (car.driver.driver.left, car.driver.driver.right) == (0.0, 0.0)
    assert car.simulator.car.speed() < 0.02


def test_navigation_aborts_on_timeout():
    from robocourse.msgs.action_msgs import GoalStatus

    c = launch(overrides={"navigation_server": {"timeout": 1.0}})
    c.client = c.context.create_node("test_client")
    c.executor.add_node(c.client)
    _, res, _ = _navigate(c, goal_for(3.0, 0.0))
    assert res.status == GoalStatus.STATUS_ABORTED and res.result.message.startswith("timeout")
    c.context.try_shutdown()


def test_parameters_are_validated():
    ctx = Context(use_sim_time=True)
    with pytest.raises(Exception, match="wheel_base"):
        DriverNode(context=ctx, parameter_overrides=[Parameter("wheel_base", value=-0.1)])
    node = DriverNode(context=ctx, name="driver_ok")
    assert not node.set_parameters([Parameter("wheel_radius", value=0.0)])[0].successful
    assert node.set_parameters([Parameter("wheel_base", value=0.2)])[0].successful
    assert node.geometry.wheel_base == 0.2
    with pytest.raises(ValueError, match="no SimulatorNode runs in this context"):
        DriverNode(context=ctx, name="driver_mj", parameter_overrides=[Parameter("driver", value="mujoco")])
    ctx.shutdown()


def test_launch_file_errors_are_clear(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        load_parameters(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("driver_node:\n  wheel_base: 0.2\n")
    with pytest.raises(ValueError, match="ros__parameters"):
        load_parameters(bad)
    with pytest.raises(LaunchError, match=r"\[driver_node-2\] mycar/driver_node failed to start: ValueError: driver "
                                          r"parameter 'pwm': use 'simulated'"):
        launch(overrides={"driver_node": {"driver": "pwm"}})


def test_mission_recording_holds_every_odom_message(tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path = tmp_path / "mission.mcap"
    rep = run_mission(str(path), quiet=True)
    assert rep.led_ok and not rep.led_invalid_ok
    assert [g[1] for g in rep.goals] == ["SUCCEEDED", "CANCELED"]
    xs = []
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for schema, _channel, _message, decoded in reader.iter_decoded_messages(topics=["/odom"]):
            assert schema.name == "nav_msgs/msg/Odometry"
            xs.append(decoded.pose.pose.position.x)
    assert len(xs) == rep.odom_published
    assert max(xs) > 0.8  # the car really went to x = 1.0


def test_blocking_execute_swallows_cancel_until_a_multithreaded_executor_fixes_it():
    from robocourse.mycar.experiments import blocking_action

    single = blocking_action(False, work_s=1.0, cancel_after_s=0.2)
    multi = blocking_action(True, work_s=1.0, cancel_after_s=0.2)
    assert single["status"] == "SUCCEEDED" and single["cancel_answered_s"] >= 1.0
    assert multi["status"] == "CANCELED" and multi["cancel_answered_s"] < 1.0


def test_terminal_teleop_from_a_pipe():
    import io

    from robocourse.mycar.teleop import TeleopNode, run_terminal

    ctx = Context(use_sim_time=True)
    node = TeleopNode(context=ctx)
    out = io.StringIO()
    assert run_terminal(node, io.StringIO("wwa?d\n"), out=out) == 5  # 4 known keys + the final stop
    assert node.sent == [(0.2, 0.0), (0.2, 0.0), (0.0, 1.5), (0.0, -1.5), (0.0, 0.0)]
    assert "w forward" in out.getvalue()
    with pytest.raises(ValueError, match="unknown teleop key"):
        node.press("z")
    ctx.shutdown()


def _static_tf(node, parent, child, x, y, yaw):
    from robocourse.bus import DurabilityPolicy, QoSProfile
    from robocourse.msgs.geometry_msgs import TransformStamped
    from robocourse.msgs.tf2_msgs import TFMessage

    pub = node.create_publisher(TFMessage, "/tf_static", QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y = x, y
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    pub.publish(TFMessage(transforms=[t]))
    return pub


@pytest.mark.parametrize("frame, words", [("map", "no transform odom <- map"), ("", "frame_id is empty")])
def test_navigation_rejects_a_goal_in_a_frame_it_cannot_transform(car, frame, words):
    goal = goal_for(0.5, 0.0)
    goal.target_pose.header.frame_id = frame
    handle, _, _ = _navigate(car, goal)
    assert not handle.accepted and words in car.navigation.rejections[-1]
    assert car.driver.commands_received == 0  # nothing was driven


def test_navigation_transforms_a_map_goal_through_tf_static(car):
    from robocourse.msgs.action_msgs import GoalStatus

    # map -> odom: odom's origin sits at (1, 0) in map, turned 90 degrees; map (1, 0.6) is odom (0.6, 0)
    _static_tf(car.client, "map", "odom", 1.0, 0.0, math.pi / 2)
    car.executor.spin_for(0.1)
    goal = goal_for(1.0, 0.6, math.pi / 2)
    goal.target_pose.header.frame_id = "map"
    handle, res, _ = _navigate(car, goal)
    assert handle.accepted and res.status == GoalStatus.STATUS_SUCCEEDED
    x, y, yaw = car.driver.pose
    assert math.hypot(x - 0.6, y - 0.0) <= 0.05 + 1e-6 and abs(math.remainder(yaw, 2 * math.pi)) <= 0.1 + 1e-6


def test_navigation_goal_relative_to_base_link_uses_the_driver_tf(car):
    drive(car, 0.0, 1.5, 1.0)  # turn left about 1 rad first
    car.executor.spin_for(0.5)
    x0, y0, yaw0 = car.driver.pose
    goal = goal_for(0.4, 0.0)  # 40 cm straight ahead of the car, wherever it points
    goal.target_pose.header.frame_id = "base_link"
    _, res, _ = _navigate(car, goal)
    assert res.result.success
    x, y, _ = car.driver.pose
    assert math.hypot(x - (x0 + 0.4 * math.cos(yaw0)), y - (y0 + 0.4 * math.sin(yaw0))) < 0.06


def test_navigation_reports_the_true_error_beside_the_odometry_one(car):
    _, res, _ = _navigate(car, goal_for(1.0, 0.5))
    r = res.result
    tx, ty, _ = car.simulator.car.pose()
    ox, oy, _ = car.driver.pose
    assert r.success and r.position_error == pytest.approx(math.hypot(ox - 1.0, oy - 0.5), abs=1e-9)
    # /ground_truth is published every 4th 5 ms simulator step: at most 20 ms old, the car stopped meanwhile
    assert r.true_position_error == pytest.approx(math.hypot(tx - 1.0, ty - 0.5), abs=0.01)
    assert r.true_position_error > r.position_error  # drift: the car is not where odometry says
    assert "by odometry" in r.message and "true pose" in r.message


def test_navigation_without_ground_truth_says_so():
    c = launch(use_sim=False)
    c.client = c.context.create_node("test_client")
    c.executor.add_node(c.client)
    _, res, _ = _navigate(c, goal_for(0.3, 0.0))
    assert res.result.success and math.isnan(res.result.true_position_error)
    assert "no /ground_truth" in res.result.message
    c.context.try_shutdown()


def test_the_shipped_calibration_is_what_the_spin_test_measures():
    from robocourse.mycar import calibration

    ratios = {}
    for mult in (1.0, None):   # uncalibrated, then the parameter file's multiplier
        car = launch(overrides={"driver_node": {"wheel_separation_multiplier": mult}} if mult else None)
        node = car.context.create_node("calibrator")
        car.executor.add_node(node)
        runs = calibration.measure(node, car.executor, [(0.0, 0.5), (0.0, 1.0), (0.0, 2.0)], seconds=2.0)
        ratios[mult] = [r.yaw_ratio for r in runs]
        car.context.try_shutdown()
    # the same ratio at every turn rate: a calibration error, and the file's multiplier undoes it
    assert max(ratios[1.0]) - min(ratios[1.0]) < 0.01 and 0.96 < min(ratios[1.0]) < 0.99
    assert all(abs(r - 1.0) < 0.006 for r in ratios[None]), ratios


def test_acceleration_limits_ramp_commands_and_the_watchdog_still_stops_at_once():
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    node = DriverNode(context=ctx, parameter_overrides=[Parameter("max_linear_acceleration", value=0.5)])
    teleop = ctx.create_node("teleop")
    pub = teleop.create_publisher(Twist, "/cmd_vel", 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    ex.add_node(teleop)
    cmd = Twist()
    cmd.linear.x = 0.2
    seen = []
    for _ in range(6):
        pub.publish(cmd)
        ex.spin_for(0.1)
        seen.append(round(node.applied[0], 6))
    assert seen == [0.05, 0.1, 0.15, 0.2, 0.2, 0.2]     # 0.5 m/s^2: 0.05 m/s per 0.1 s
    ex.spin_for(0.25)                                 # silence: the watchdog stops without a ramp
    assert node.applied == (0.0, 0.0) and node.driver.left == node.driver.right == 0.0


def test_a_goal_the_car_cannot_reach_is_aborted_not_looped():
    car = launch(overrides={"navigation_server": {"stall_timeout": 1.0}})
    car.context.log_to_stderr = False
    car.executor.remove_node(car.driver)              # the driver died: no /odom, motors never move
    car.client = car.context.create_node("test_client")
    car.executor.add_node(car.client)
    start = car.client.get_clock().now().nanoseconds
    _, res, _ = _navigate(car, goal_for(1.0, 0.0))
    took = (car.client.get_clock().now().nanoseconds - start) * 1e-9
    assert res.status == GoalStatus.STATUS_ABORTED and not res.result.success
    assert res.result.message.startswith("stalled: odometry shows no motion for 1 s")
    assert 1.0 < took < 1.5
    car.context.try_shutdown()
