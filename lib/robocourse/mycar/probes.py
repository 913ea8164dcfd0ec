"""The student-side half of chapter 3's checks: probes that run the student's code on the bus.

A probe runs where the student's code runs (their kernel, or the grading sandbox): it builds
the scripted peers (a teleop publishing /cmd_vel, a service client, an action client beside the
library's driver node, a /cmd_vel listener standing in for the driver), runs the student's
node with them in simulated time, and returns what the peers saw as plain data. It decides
nothing: the judges, with the quiz's key, live in :mod:`robocourse.mycar.checks`, which the
grading sandbox hides. No peer does the student's job: the driver the navigation probe runs
has a 10 s watchdog, so only the student's own zero Twist stops the car in time.
"""

from __future__ import annotations

import math

from robocourse.grading.probes import call, plain

#: the teleop exercise's keys: key -> (linear sign, angular sign), scaled by the node's parameters
TELEOP_KEYS = {"w": (1, 0), "s": (-1, 0), "a": (0, 1), "d": (0, -1), "q": (1, 1), "e": (1, -1), "x": (0, 0)}
GRADER_WATCHDOG_S = 10.0   # the navigation probe's driver: long enough never to stop the car for the server


def _context():
    from robocourse.bus import Context

    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False  # the student's logs go to ctx.log_records, which the probe returns
    return ctx


def _logs(ctx, skip=()):
    return [{"severity": r.severity.name, "node": r.name, "msg": r.msg[:200]}
            for r in ctx.log_records[:200] if r.name not in skip]


def _incompatible(ctx):
    return [f"{i.topic}: {i.reason}"[:200] for i in ctx.incompatibilities[:20]]


def _now(node) -> float:
    return node.get_clock().now().nanoseconds * 1e-9


def _built(factory):
    """(node, None) or (None, 'ExceptionName: message') when the student's constructor raised."""
    try:
        return factory(), None
    except NotImplementedError:
        raise
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"[:400]


# ------------------------------------------------------------------ ch03.watchdog

def dog_probe(inputs, Watchdog):
    timeout, feed, step = inputs["timeout"], inputs["feed"], inputs["step"]
    dog = Watchdog(timeout)
    early = call(dog.update, inputs["early_t"])
    dog.feed(feed)
    times = [feed + step * k for k in range(1, int(1.0 / step))]
    trips = [t for t in times if dog.update(t)]
    stopped = getattr(dog, "stopped", None)
    dog.feed(feed + 1.0)
    rearmed = getattr(dog, "stopped", None)
    soon = dog.update(feed + 1.0 + timeout / 2)
    later = dog.update(feed + 1.0 + timeout + 0.05)
    return plain({"early": early, "trips": trips, "stopped": stopped, "rearmed_stopped": rearmed,
                  "soon": soon, "later": later})


# ------------------------------------------------------------------ ch03.quiz

def quiz_probe(inputs, quiz_answers):
    answers = quiz_answers() if callable(quiz_answers) else quiz_answers
    if not isinstance(answers, dict):
        return {"answers": None, "given": type(answers).__name__}
    return {"answers": {str(k)[:100]: str(v)[:40] for k, v in list(answers.items())[:50]}, "given": "dict"}


# ------------------------------------------------------------------ ch03.drive_node

def drive_probe(inputs, DriveNode):
    """Run the student's DriveNode; a scripted teleop publishes /cmd_vel at 10 Hz (and one NaN)."""
    from robocourse.bus import Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
    from robocourse.msgs.geometry_msgs import Twist
    from robocourse.msgs.nav_msgs import Odometry
    from robocourse.msgs.std_msgs import Float64MultiArray

    ctx = _context()
    try:
        node, error = _built(lambda: DriveNode(context=ctx, parameter_overrides=[
            Parameter("wheel_base", value=inputs["wheel_base"]), Parameter("publish_rate", value=inputs["publish_rate"])]))
        if node is None:
            return {"built": False, "error": error}
        peer = ctx.create_node("grader_teleop")
        pub = peer.create_publisher(Twist, "/cmd_vel", 10)
        wheels, odom = [], []
        any_qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)  # matches either offer
        peer.create_subscription(Float64MultiArray, "/wheel_speeds", lambda m: wheels.append(
            {"t": _now(peer), "data": list(m.data)[:4]}), any_qos)

        def on_odom(m):
            p, q = m.pose.pose.position, m.pose.pose.orientation
            odom.append({"stamp": m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, "frame": m.header.frame_id[:40],
                         "child": m.child_frame_id[:40], "x": p.x, "y": p.y, "qz": q.z, "qw": q.w,
                         "v": m.twist.twist.linear.x, "w": m.twist.twist.angular.z})

        peer.create_subscription(Odometry, "/odom", on_odom, any_qos)
        ex = SingleThreadedExecutor(context=ctx, on_callback_error="log")   # survive the student's raise, report it
        ex.add_node(node)
        ex.add_node(peer)
        period = 1.0 / inputs["cmd_rate"]
        sent = []

        def send(v, w):
            tw = Twist()
            tw.linear.x, tw.angular.z = v, w
            sent.append({"t": _now(peer), "v": v, "w": w})
            pub.publish(tw)
            ex.spin_for(period)

        for v, w, dur in inputs["segments"]:
            for _ in range(int(round(dur / period))):
                send(v, w)
        for v, w in inputs["bad"]:                  # a broken teleop ("nan", "inf" as JSON sends them): ignored
            send(float(v), float(w))
        for _ in range(int(round(inputs["stop_s"] / period))):
            send(0.0, 0.0)
        return plain({"built": True, "sent": sent, "wheels": wheels[:2000], "odom": odom[:5000], "end": _now(peer),
                      "logs": _logs(ctx, skip=("grader_teleop",)), "incompatible": _incompatible(ctx)})
    finally:
        ctx.try_shutdown()


# ------------------------------------------------------------------ ch03.led_service

def led_probe(inputs, LedServer):
    """Run the student's LedServer; a scripted client calls /set_led with valid and invalid ids."""
    from robocourse.bus import Parameter, SingleThreadedExecutor

    from .msgs import SetLed

    ctx = _context()
    try:
        node, error = _built(lambda: LedServer(context=ctx, parameter_overrides=[
            Parameter("led_count", value=inputs["led_count"])]))
        if node is None:
            return {"built": False, "error": error}
        initial = {str(k): v for k, v in list(dict(getattr(node, "leds", {}) or {}).items())[:100]}
        peer = ctx.create_node("grader_client")
        ex = SingleThreadedExecutor(context=ctx, on_callback_error="log")   # survive the student's raise, report it
        ex.add_node(node)
        ex.add_node(peer)
        cli = peer.create_client(SetLed, "/set_led")
        ready = cli.wait_for_service(timeout_sec=1.0)
        answers = []
        for led_id, state in inputs["requests"]:
            if not ready:
                break
            logs_before = len(ctx.log_records)
            fut = cli.call_async(SetLed.Request(led_id=led_id, state=state))
            ex.spin_until_future_complete(fut, 1.0)
            said = [r.msg[:200] for r in ctx.log_records[logs_before:logs_before + 5]
                    if r.name != "grader_client" and r.severity.name in ("WARN", "ERROR")]
            if not fut.done():
                answers.append({"answered": False, "warned": said})
            elif fut.exception() is not None:
                answers.append({"answered": True, "raised": repr(fut.exception())[:200], "warned": said})
            else:
                answers.append({"answered": True, "success": bool(fut.result().success), "warned": said})
        final = {str(k): v for k, v in list(dict(getattr(node, "leds", {}) or {}).items())[:100]}
        return plain({"built": True, "ready": ready, "answers": answers, "initial": initial, "final": final})
    finally:
        ctx.try_shutdown()


# ------------------------------------------------------------------ ch03.navigation_action

def nav_probe(inputs, NavigationServer):
    """Run the student's NavigationServer beside the library's DriverNode (kinematic motors, a 10 s
    watchdog) with a scripted action client: a reachable goal, a goal in 'map', a NaN goal, a far
    goal cancelled after a while, and a goal sent after the driver has gone (it must be aborted)."""
    from robocourse.bus import Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
    from robocourse.bus.action import ActionClient
    from robocourse.msgs.geometry_msgs import Twist

    from .msgs import NavigateToPose
    from .nodes import DriverNode

    ctx = _context()

    def goal(x, y, frame="odom"):
        g = NavigateToPose.Goal()
        g.target_pose.header.frame_id = frame
        g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
        g.target_pose.pose.orientation.w = 1.0
        return g

    try:
        server, error = _built(lambda: NavigationServer(context=ctx))
        if server is None:
            return {"built": False, "error": error}
        driver = DriverNode(context=ctx, name="grader_driver", parameter_overrides=[
            Parameter("watchdog_timeout", value=GRADER_WATCHDOG_S)])
        peer = ctx.create_node("grader_client")
        cmds = []   # what the server published on /cmd_vel: (t, v, w)
        peer.create_subscription(Twist, "/cmd_vel", lambda m: cmds.append((_now(peer), m.linear.x, m.angular.z)),
                                 QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        ex = SingleThreadedExecutor(context=ctx, on_callback_error="log")   # survive the student's raise, report it
        for n in (server, driver, peer):
            ex.add_node(n)
        client = ActionClient(peer, NavigateToPose, "/navigate_to_pose")
        ex.spin_for(0.1)
        if not client.server_is_ready():
            return {"built": True, "ready": False}
        runs = {}

        def send(name, g, cancel_after=None, limit=30.0):
            fb = []
            before = len(cmds)
            fut = client.send_goal_async(g, feedback_callback=lambda m: fb.append(m.feedback.percent_complete))
            ex.spin_until_future_complete(fut, 2.0)
            t0 = _now(peer)
            rec = {"answered": fut.done(), "accepted": bool(fut.done() and fut.result().accepted), "feedback": fb}
            runs[name] = rec
            if not rec["accepted"]:
                return
            handle = fut.result()
            if cancel_after is not None:
                ex.spin_for(cancel_after)
                cf = handle.cancel_goal_async()
                ex.spin_until_future_complete(cf, 2.0)
                rec["cancel_code"] = cf.result().return_code if cf.done() else None
            rf = handle.get_result_async()
            ex.spin_until_future_complete(rf, limit)
            rec["finished"] = rf.done()
            rec["took"] = _now(peer) - t0
            if rf.done():
                res = rf.result()
                rec.update(status=res.status, success=res.result.success, message=res.result.message[:200])
            rec["pose"] = list(driver.pose)
            rec["last_cmd"] = list(cmds[-1][1:]) if len(cmds) > before else None
            ex.spin_for(0.05)
            rec["motors_after"] = [driver.driver.left, driver.driver.right]
            ex.spin_for(0.25)
            rec["pose_after"] = list(driver.pose)
            fb[:] = fb[:2000]

        send("reach", goal(*inputs["reach"]))
        send("map", goal(0.3, 0.0, frame="map"))
        send("nan", goal(math.nan, 0.0))
        send("cancel", goal(*inputs["far"]), cancel_after=inputs["cancel_after"])
        # `ros2 param set /navigation_server timeout ...`, then the driver dies: no /odom, the car cannot move
        timeout_set = call(lambda: server.set_parameters([Parameter("timeout", value=inputs["timeout"])])[0].successful)
        ex.remove_node(driver)
        send("abort", goal(*inputs["lost"]), limit=inputs["timeout"] + 5.0)
        return plain({"built": True, "ready": True, "runs": runs, "timeout_set": timeout_set,
                      "logs": _logs(ctx, skip=("grader_client", "grader_driver")), "incompatible": _incompatible(ctx)})
    finally:
        ctx.try_shutdown()


# ------------------------------------------------------------------ ch03.teleop_node

def teleop_probe(inputs, TeleopNode):
    """Run the student's TeleopNode with the grader's parameters; press keys between spins (the
    script comes from the inputs) and record every /cmd_vel message with its simulated time, as a
    RELIABLE subscriber (the driver's QoS) sees it."""
    from robocourse.bus import Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
    from robocourse.msgs.geometry_msgs import Twist

    ctx = _context()
    try:
        node, error = _built(lambda: TeleopNode(context=ctx, parameter_overrides=[
            Parameter(k, value=float(inputs["params"][k])) for k in ("rate_hz", "hold_s", "linear_speed",
                                                                      "angular_speed")]))
        if node is None:
            return {"built": False, "error": error}
        peer = ctx.create_node("grader_driver")
        got = []
        peer.create_subscription(Twist, "/cmd_vel", lambda m: got.append([_now(peer), m.linear.x, m.angular.z]),
                                 QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        ex = SingleThreadedExecutor(context=ctx, on_callback_error="log")   # survive the student's raise, report it
        ex.add_node(node)
        ex.add_node(peer)
        events = []
        for action, arg in inputs["script"]:
            if action == "spin":
                ex.spin_for(arg)
            else:
                ex.spin_for(0.0)                    # deliver everything due now (a timer tick at this instant)
                t, before = _now(peer), len(got)
                record = call(node.press, arg)
                ex.spin_for(0.0)                    # deliver what press() published, at the press's time
                events.append({"t": t, "key": arg, "sent": [m[1:] for m in got[before:before + 5]], **record})
        name = node.get_name()
        return plain({"built": True, "name": name, "messages": got[:5000], "events": events,
                      "incompatible": _incompatible(ctx), "end": _now(peer)})
    finally:
        ctx.try_shutdown()


# ------------------------------------------------------------------ ch03.launch_file

def launch_probe(inputs, params_yaml, generate_launch_description):
    """Write params_yaml()'s text to a file, launch the student's description with params_file
    pointing at it, once per use_sim value, and return the graph and the nodes' parameters."""
    import os
    import tempfile

    from robocourse.launch import LaunchDescription, launch

    text = params_yaml()
    if not isinstance(text, str):
        return {"runs": {}, "problem": f"params_yaml() returned a {type(text).__name__}, not the text of a file"}
    fd, path = tempfile.mkstemp(suffix=".yaml", prefix="mycar_params_")
    with os.fdopen(fd, "w") as f:
        f.write(text[:100_000])
    runs = {}
    try:
        for use_sim in inputs["use_sim"]:
            ctx = _context()
            try:
                try:
                    desc = generate_launch_description()
                    if not isinstance(desc, LaunchDescription):
                        runs[use_sim] = {"error": f"generate_launch_description() returned {type(desc).__name__}, "
                                                  "not a LaunchDescription"}
                        continue
                    system = launch(desc, context=ctx, launch_arguments={"params_file": path, "use_sim": use_sim})
                except NotImplementedError:
                    raise
                except Exception as exc:
                    runs[use_sim] = {"error": f"{type(exc).__name__}: {exc}"[:600]}
                    continue
                nodes = []
                for n in system.nodes[:20]:
                    params = {k: p.value for k, p in list(n.get_parameters_by_prefix("").items())[:60]}
                    nodes.append({"fqn": n.get_fully_qualified_name()[:100], "kind": type(n).__name__[:60],
                                  "motors": type(getattr(n, "driver", None)).__name__[:60], "params": params})
                names = system.nodes[0] if system.nodes else None
                services = sorted(s for s, _ in names.get_service_names_and_types())[:100] if names else []
                topics = sorted(t for t, _ in names.get_topic_names_and_types())[:100] if names else []
                runs[use_sim] = {"nodes": nodes, "services": services, "topics": topics,
                                 "warnings": [w[:200] for w in system.warnings[:10]]}
                system.shutdown()
            finally:
                ctx.try_shutdown()
        return plain({"runs": runs})
    finally:
        os.unlink(path)
