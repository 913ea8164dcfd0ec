"""Checks for chapter 3's exercises (solutions/03_mycar_exercises.ipynb), as probe + judge.

Fresh twists, wheel bases and watchdog timings every run; the judges compare with the
integrated drive formula and with the watchdog's stated rule (trip once, re-arm on feed). The
drive formula itself is derived in the chapter, so it is graded inside the driver node, not as a
function of its own.

The three node checks run the student's node class on the bus, in simulated time, against
scripted peers built inside the probe (a /cmd_vel publisher, a service client, an action
client, and for navigation the library's DriverNode on a kinematic motor driver); the probe
returns what those peers recorded as plain data and the judge decides in the grader.
"""

from __future__ import annotations

import math

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import number, plain

from . import kinematics as kin

QUIZ = {
    "wheel encoder ticks at 100 Hz": ("topic", "a continuous stream that many nodes may read"),
    "set the maximum speed limit": ("service", "a quick request with a definite yes/no answer (or a parameter)"),
    "drive to the charging dock": ("action", "long-running, needs progress feedback and must be cancellable"),
    "camera images": ("topic", "a high-rate stream; late frames are useless, so no request/reply"),
    "take one snapshot and return it": ("service", "one request, one answer, quickly"),
    "map the whole room": ("action", "takes minutes, reports progress, may be cancelled"),
    "battery voltage": ("topic", "a periodic stream for whoever listens (dashboards, loggers)"),
    "reset the odometry to zero": ("service", "a quick command that must confirm it was done"),
    "follow a 20-waypoint path": ("action", "long task with feedback (current waypoint) and cancel"),
    "emergency stop button state": ("topic", "a state everyone must see continuously, no round trip"),
}


def _dog_inputs(rng):
    # binary-exact times (multiples of 1/64 s), so "more than timeout" has no rounding ties
    return {"timeout": float(rng.choice([0.125, 0.25, 0.5])), "feed": float(rng.integers(1, 8)) / 2,
            "step": 1 / 64}


def _dog_probe(inputs, Watchdog):
    timeout, feed, step = inputs["timeout"], inputs["feed"], inputs["step"]
    dog = Watchdog(timeout)
    early = dog.update(0.05)
    dog.feed(feed)
    times = [feed + step * k for k in range(1, int(1.0 / step))]
    trips = [t for t in times if dog.update(t)]
    stopped = getattr(dog, "stopped", None)
    dog.feed(feed + 1.0)
    rearmed = getattr(dog, "stopped", None)
    soon = dog.update(feed + 1.0 + timeout / 2)
    later = dog.update(feed + 1.0 + timeout + 0.05)
    return plain({"early": early, "trips": trips, "stopped": stopped, "rearmed_stopped": rearmed, "soon": soon,
                  "later": later})


@register("ch03.watchdog", weight=2, time_limit=10, uses=("Watchdog",), probe=_dog_probe, inputs=_dog_inputs)
def check_watchdog(inputs, out):
    """Watchdog(timeout): trips once after `timeout` without feed(), re-arms on the next feed()."""
    timeout, feed, step = inputs["timeout"], inputs["feed"], inputs["step"]
    f = Failures()
    if out["early"]:
        f.add("update(0.05) tripped before any command was ever received: only arm after the first feed()")
    trips = [number(t) for t in out["trips"]]
    first_due = next(feed + step * k for k in range(1, 1000) if step * k > timeout)
    if not trips:
        f.add(f"fed at t={feed:.2f} s, then update() every {step * 1e3:g} ms for 1 s never returned True; it must trip once more "
              f"than {timeout:g} s passed without feed()")
    elif len(trips) > 1:
        f.add(f"update() returned True {len(trips)} times (first at {trips[0]:.4f} s): report the trip once, not on "
              "every check (the seed logs the stop once)")
    if trips and trips[0] != first_due:
        f.add(f"tripped at {trips[0]:.4f} s for a feed at {feed:g} s and timeout {timeout:g} s; expected at the "
              f"first check later than {feed + timeout:g} s ({first_due:.4f} s): trip when more than the timeout "
              "passed, not at exactly the timeout")
    if trips and out["stopped"] is not True:
        f.add("after the trip, .stopped must be True")
    if out["rearmed_stopped"] is not False:
        f.add("a new feed() must re-arm the watchdog (.stopped False): motion resumes on the next command")
    if out["soon"]:
        f.add(f"tripped {timeout / 2:g} s after a feed with a {timeout:g} s timeout")
    if not out["later"]:
        f.add(f"did not trip again {timeout + 0.05:g} s after the second feed")
    return f.done(f"trips once at {first_due:.4f} s (timeout {timeout:g} s after a feed at {feed:g} s), re-arms on feed")


def _quiz_probe(inputs, quiz_answers):
    return plain(quiz_answers() if callable(quiz_answers) else quiz_answers)


QUIZ_QUESTIONS = ("a stream whoever listens reads (topic)", "one request, one quick definite answer (service)",
                  "a long task with feedback that must be cancellable (action)?")


@register("ch03.quiz", weight=2, time_limit=5, uses=("quiz_answers",), probe=_quiz_probe)
def check_quiz(inputs, answers):
    """Topic, service or action for the ten robot features listed in the exercise.

    The feedback names which features to reconsider and the questions to ask, never the answers.
    """
    if not isinstance(answers, dict):
        raise CheckFailed("quiz_answers() must return a dict feature -> 'topic' | 'service' | 'action'")
    missing = [f for f in QUIZ if f not in answers]
    if missing:
        raise CheckFailed(f"answer every feature listed in the exercise; missing: {missing}")
    unknown = [f for f in answers if f not in QUIZ]
    wrong, bad = [], []
    for feature in QUIZ:
        given = str(answers[feature]).strip().lower()
        if given not in ("topic", "service", "action"):
            bad.append(f"{feature!r}: answer 'topic', 'service' or 'action', not {answers[feature]!r}")
        elif given != QUIZ[feature][0]:
            wrong.append(feature)
    if wrong or bad or unknown:
        lines = [f"{len(QUIZ) - len(wrong) - len(bad)}/{len(QUIZ)} right.", *bad]
        if wrong:
            lines.append(f"reconsider: {', '.join(wrong)}")
            lines.append("ask of each: is it " + " or ".join(QUIZ_QUESTIONS))
        if unknown:
            lines.append(f"not features of the exercise (copy the names exactly): {unknown}")
        raise CheckFailed(*lines)
    return "10/10"


# ------------------------------------------------------------------ the nodes, run on the bus

def _context():
    from robocourse.bus import Context

    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False  # the student's logs go to ctx.log_records, which the probe returns
    return ctx


def _logs(ctx, skip=()):
    return [{"severity": r.severity.name, "node": r.name, "msg": r.msg[:200]}
            for r in ctx.log_records if r.name not in skip]


def _incompatible(ctx):
    return [f"{i.topic}: {i.reason}" for i in ctx.incompatibilities]


def _qos_hint(out, f) -> None:
    for text in out.get("incompatible", []):
        f.add(f"QoS mismatch, no messages flow on {text}: subscribe with the publisher's reliability "
              "(the driver's /odom is BEST_EFFORT)")


def _yaw(qz, qw):
    return 2.0 * math.atan2(qz, qw)  # planar quaternion (x = y = 0)


def _drive_inputs(rng):
    segments = []
    for _ in range(3):
        sign = 1.0 if rng.random() < 0.5 else -1.0
        segments.append([round(float(rng.uniform(0.15, 0.3)), 3), round(sign * float(rng.uniform(0.6, 1.2)), 3),
                         float(rng.choice([1.5, 2.0]))])
    return {"wheel_base": round(float(rng.uniform(0.1, 0.3)), 3), "publish_rate": float(rng.choice([50.0, 100.0])),
            "segments": segments, "cmd_rate": 10.0, "stop_s": 0.5}


def _drive_probe(inputs, DriveNode):
    """Run the student's DriveNode; a scripted teleop publishes /cmd_vel at 10 Hz (and one NaN)."""
    from robocourse.bus import Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
    from robocourse.msgs.geometry_msgs import Twist
    from robocourse.msgs.nav_msgs import Odometry
    from robocourse.msgs.std_msgs import Float64MultiArray

    ctx = _context()
    try:
        node = DriveNode(context=ctx, parameter_overrides=[Parameter("wheel_base", value=inputs["wheel_base"]),
                                                            Parameter("publish_rate", value=inputs["publish_rate"])])
        peer = ctx.create_node("grader_teleop")
        clock = peer.get_clock()
        pub = peer.create_publisher(Twist, "/cmd_vel", 10)
        wheels, odom = [], []
        any_qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)  # matches either offer
        peer.create_subscription(Float64MultiArray, "/wheel_speeds", lambda m: wheels.append(
            {"t": clock.now().nanoseconds * 1e-9, "data": list(m.data)}), any_qos)

        def on_odom(m):
            p, q = m.pose.pose.position, m.pose.pose.orientation
            odom.append({"stamp": m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, "frame": m.header.frame_id,
                         "child": m.child_frame_id, "x": p.x, "y": p.y, "qz": q.z, "qw": q.w, "qx": q.x, "qy": q.y,
                         "v": m.twist.twist.linear.x, "w": m.twist.twist.angular.z})

        peer.create_subscription(Odometry, "/odom", on_odom, any_qos)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        ex.add_node(peer)
        period = 1.0 / inputs["cmd_rate"]
        sent = []

        def send(v, w):
            tw = Twist()
            tw.linear.x, tw.angular.z = v, w
            sent.append({"t": clock.now().nanoseconds * 1e-9, "v": v, "w": w})
            pub.publish(tw)
            ex.spin_for(period)

        for v, w, dur in inputs["segments"]:
            for _ in range(int(round(dur / period))):
                send(v, w)
        send(math.nan, 0.0)  # a broken teleop: must be ignored
        for _ in range(int(round(inputs["stop_s"] / period))):
            send(0.0, 0.0)
        return plain({"sent": sent, "wheels": wheels, "odom": odom, "end": clock.now().nanoseconds * 1e-9,
                      "logs": _logs(ctx, skip=("grader_teleop",)), "incompatible": _incompatible(ctx)})
    finally:
        ctx.try_shutdown()


def _reference_path(sent, t_end, start_pose=(0.0, 0.0, 0.0)):
    """Exact arc integration of the held commands (NaN commands ignored): [(t, x, y, yaw)] at each change."""
    x, y, yaw = start_pose
    out = []
    held = (0.0, 0.0)
    times = [c["t"] for c in sent] + [t_end]
    t_prev = times[0]
    for c, t_next in zip(sent, times[1:], strict=True):
        v, w = number(c["v"]), number(c["w"])
        if math.isfinite(v) and math.isfinite(w):
            held = (v, w)
        x, y, yaw = kin.integrate_pose(x, y, yaw, held[0], held[1], t_next - t_prev)
        out.append((t_next, x, y, yaw))
        t_prev = t_next
    return out


@register("ch03.drive_node", weight=4, time_limit=20, uses=("DriveNode",), probe=_drive_probe, inputs=_drive_inputs,
          references=("robocourse.mycar.nodes:DriverNode", "robocourse.mycar.kinematics:twist_to_wheel_speeds"))
def check_drive_node(inputs, out):
    """DriveNode: /cmd_vel in, /wheel_speeds and /odom out, on the bus against a scripted teleop."""
    f = Failures()
    _qos_hint(out, f)
    b, rate = inputs["wheel_base"], inputs["publish_rate"]
    sent, wheels, odom = out["sent"], out["wheels"], out["odom"]
    finite = [c for c in sent if all(isinstance(c[k], (int, float)) for k in ("v", "w"))]
    if not wheels:
        f.add("nothing arrived on /wheel_speeds: publish a std_msgs/Float64MultiArray [left, right] (m/s) from the "
              "/cmd_vel callback, on the topic '/wheel_speeds'")
    else:
        bad = [w for w in wheels if not all(isinstance(d, (int, float)) for d in w["data"])]
        f.expect(not bad, f"/wheel_speeds carried non-finite values {bad[0]['data'] if bad else ''}: a /cmd_vel with "
                          "NaN must be ignored (log an error, publish nothing, keep the last command)")
        f.expect(len(wheels) == len(finite), f"{len(wheels)} /wheel_speeds messages for {len(finite)} valid /cmd_vel "
                                             f"(and 1 with NaN): publish one per valid command, none for the NaN one")
        for c, w in zip(finite, wheels):
            v, om = c["v"], c["w"]
            want = [v - om * b / 2, v + om * b / 2]
            data = [number(d) for d in w["data"]] if len(w["data"]) == 2 and not bad else None
            if data is None or not all(math.isclose(a, e, abs_tol=1e-9) for a, e in zip(data, want)):
                hint = ""
                if data and math.isclose(data[0], want[1], abs_tol=1e-9) and math.isclose(data[1], want[0], abs_tol=1e-9):
                    hint = " (left and right swapped: turning left, the left wheel is the inner, slower one)"
                elif data and all(math.isclose(a, e, abs_tol=1e-9) for a, e in zip(data, [v - om * b, v + om * b])):
                    hint = " (each wheel sits wheel_base / 2 from the centre, not wheel_base)"
                f.add(f"/cmd_vel v={v:.3f} m/s, w={om:.3f} rad/s with wheel_base={b} gave /wheel_speeds {w['data']}, "
                      f"expected [{want[0]:.4f}, {want[1]:.4f}] = [v - w*b/2, v + w*b/2]{hint}; did you read the "
                      "wheel_base parameter?")
                break
    if not odom:
        f.add("nothing arrived on /odom: publish nav_msgs/Odometry from a timer at the publish_rate parameter")
        return f.done("")
    span = number(out["end"]) - number(sent[0]["t"])
    expected_n = rate * span
    f.expect(abs(len(odom) - expected_n) <= 2 + 0.02 * expected_n,
             f"{len(odom)} /odom messages in {span:.1f} s; publish_rate={rate:g} Hz means about {expected_n:.0f}: "
             "create the timer with period 1 / publish_rate")
    o = odom[-1]
    f.expect(o["frame"] == "odom" and o["child"] == "base_link",
             f"/odom header.frame_id={o['frame']!r}, child_frame_id={o['child']!r}: use 'odom' and 'base_link'")
    stamps = [number(m["stamp"]) for m in odom]
    f.expect(all(b2 > a for a, b2 in zip(stamps, stamps[1:])) and stamps[-1] > 0,
             "/odom header.stamp must be the node clock's time, increasing (get_clock().now())")
    vals = [number(m[k]) for m in odom for k in ("x", "y", "qz", "qw")]
    if not all(math.isfinite(v) for v in vals):
        f.add("/odom carries NaN or inf: a /cmd_vel with NaN must be ignored, not integrated")
        return f.done("")
    path = _reference_path(sent, number(out["end"]))
    worst = (0.0, None)
    for t, rx, ry, ryaw in path:
        m = min(odom, key=lambda m, t=t: abs(number(m["stamp"]) - t))
        if abs(number(m["stamp"]) - t) > 1.5 / rate:
            continue
        yaw = _yaw(number(m["qz"]), number(m["qw"]))
        err = math.hypot(number(m["x"]) - rx, number(m["y"]) - ry)
        if err > worst[0]:
            worst = (err, (t, rx, ry, ryaw, m, yaw))
    err, where = worst
    if where is not None and (err > 0.05 or abs(math.remainder(where[5] - where[3], 2 * math.pi)) > 0.15):
        t, rx, ry, ryaw, m, yaw = where
        f.add(f"at t={t:.2f} s /odom says x={number(m['x']):.3f}, y={number(m['y']):.3f} m, yaw={yaw:.3f} rad; "
              f"integrating the commands gives ({rx:.3f}, {ry:.3f}, {ryaw:.3f}): each tick add v*cos(yaw)*dt, "
              "v*sin(yaw)*dt and w*dt with dt the time since the last tick, yaw as quaternion z=sin(yaw/2), w=cos(yaw/2)")
    last = odom[-1]
    f.expect(abs(number(last["v"])) < 1e-9 and abs(number(last["w"])) < 1e-9,
             f"after the stop command /odom twist is v={last['v']}, w={last['w']}: report the current twist")
    return f.done(f"{len(wheels)} wheel commands exact, {len(odom)} odometry messages within {err * 1000:.1f} mm "
                  "of the integrated path, the NaN command ignored")


def _led_inputs(rng):
    count = int(rng.integers(2, 7))
    ids = [1, count, int(rng.integers(1, count + 1)), 0, count + 1, -1, 1]
    states = [True, True, bool(rng.random() < 0.5), True, True, True, False]
    return {"led_count": count, "requests": [[i, s] for i, s in zip(ids, states)]}


def _led_probe(inputs, LedServer):
    """Run the student's LedServer; a scripted client calls /set_led with valid and invalid ids."""
    from robocourse.bus import Parameter, SingleThreadedExecutor

    from .msgs import SetLed

    ctx = _context()
    try:
        node = LedServer(context=ctx, parameter_overrides=[Parameter("led_count", value=inputs["led_count"])])
        initial = {str(k): v for k, v in dict(getattr(node, "leds", {}) or {}).items()}
        peer = ctx.create_node("grader_client")
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        ex.add_node(peer)
        cli = peer.create_client(SetLed, "/set_led")
        ready = cli.wait_for_service(timeout_sec=1.0)
        answers = []
        for led_id, state in inputs["requests"]:
            if not ready:
                break
            fut = cli.call_async(SetLed.Request(led_id=led_id, state=state))
            try:
                ex.spin_until_future_complete(fut, 1.0)
            except Exception:  # noqa: BLE001 - the server's callback raised; as in rclpy it
                ex.spin_until_future_complete(fut, 1.0)   # leaves spin: the client hears why
            if not fut.done():
                answers.append({"answered": False})
            elif fut.exception() is not None:
                answers.append({"answered": True, "raised": repr(fut.exception())[:200]})
            else:
                answers.append({"answered": True, "success": fut.result().success})
        final = {str(k): v for k, v in dict(getattr(node, "leds", {}) or {}).items()}
        return plain({"ready": ready, "answers": answers, "initial": initial, "final": final,
                      "logs": _logs(ctx, skip=("grader_client",))})
    finally:
        ctx.try_shutdown()


@register("ch03.led_service", weight=3, time_limit=10, uses=("LedServer",), probe=_led_probe, inputs=_led_inputs,
          references=("robocourse.mycar.nodes:LedServiceServer",))
def check_led_service(inputs, out):
    """LedServer: the /set_led service for led_count LEDs, called by a scripted client."""
    f = Failures()
    count = inputs["led_count"]
    if not out["ready"]:
        raise CheckFailed("no /set_led service appeared: create_service(SetLed, '/set_led', self.on_set_led) in __init__")
    f.expect(out["initial"] == {str(i): False for i in range(1, count + 1)},
             f"with led_count={count}, .leds must start as {{1: False, ..., {count}: False}}, got {out['initial']}: "
             "read the led_count parameter")
    state = {str(i): False for i in range(1, count + 1)}
    invalid = 0
    for (led_id, want_state), got in zip(inputs["requests"], out["answers"], strict=False):
        valid = 1 <= led_id <= count
        invalid += not valid
        if not got.get("answered"):
            f.add(f"request led_id={led_id} got no response within 1 s: the callback must return the response")
            continue
        if "raised" in got:
            f.add(f"request led_id={led_id} raised {got['raised']} in the server: answer success=False instead")
            continue
        if got.get("success") is not valid:
            f.add(f"led_id={led_id} with led_count={count} answered success={got.get('success')}, expected {valid}: "
                  f"ids 1..{count} exist, anything else fails")
        if valid:
            state[str(led_id)] = want_state
    f.expect(len(out["answers"]) == len(inputs["requests"]), "not every request was answered")
    f.expect(out["final"] == state, f".leds after the calls is {out['final']}, expected {state}: store each valid "
                                    "request's state")
    warns = [r for r in out["logs"] if r["severity"] in ("WARN", "ERROR")]
    f.expect(len(warns) >= invalid, f"{invalid} invalid ids were requested but the server logged {len(warns)} "
                                    "warnings: get_logger().warning(...) names the bad id, as the seed does")
    return f.done(f"{len(out['answers'])} calls answered right for led_count={count}, {invalid} invalid ids warned")


def _nav_inputs(rng):
    ang = float(rng.uniform(-math.pi, math.pi))
    dist = float(rng.uniform(0.4, 0.8))
    return {"reach": [round(dist * math.cos(ang), 3), round(dist * math.sin(ang), 3)],
            "far": [0.0, -2.5 if rng.random() < 0.5 else 2.5], "cancel_after": 1.0, "tolerance": 0.05}


def _nav_probe(inputs, NavigationServer):
    """Run the student's NavigationServer with the library's DriverNode on a kinematic motor driver,
    and a scripted action client: a reachable goal, a goal in 'map', a NaN goal, a cancelled goal."""
    from robocourse.bus import SingleThreadedExecutor
    from robocourse.bus.action import ActionClient

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
        server = NavigationServer(context=ctx)
        driver = DriverNode(context=ctx, name="grader_driver")
        peer = ctx.create_node("grader_client")
        ex = SingleThreadedExecutor(context=ctx)
        for n in (server, driver, peer):
            ex.add_node(n)
        client = ActionClient(peer, NavigateToPose, "/navigate_to_pose")
        ex.spin_for(0.1)
        if not client.server_is_ready():
            return {"ready": False}
        runs = {}

        def send(name, g, cancel_after=None, limit=30.0):
            fb = []
            fut = client.send_goal_async(g, feedback_callback=lambda m: fb.append(m.feedback.percent_complete))
            ex.spin_until_future_complete(fut, 2.0)
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
            if rf.done():
                res = rf.result()
                rec.update(status=res.status, success=res.result.success, message=res.result.message[:200])
            rec["pose"] = list(driver.pose)
            ex.spin_for(0.3)
            rec["motors_after"] = [driver.driver.left, driver.driver.right]
            rec["pose_after"] = list(driver.pose)

        send("reach", goal(*inputs["reach"]))
        send("map", goal(0.3, 0.0, frame="map"))
        send("nan", goal(math.nan, 0.0))
        send("cancel", goal(*inputs["far"]), cancel_after=inputs["cancel_after"])
        return plain({"ready": True, "runs": runs, "logs": _logs(ctx, skip=("grader_client", "grader_driver")),
                      "incompatible": _incompatible(ctx)})
    finally:
        ctx.try_shutdown()


@register("ch03.navigation_action", weight=4, time_limit=30, uses=("NavigationServer",), probe=_nav_probe,
          inputs=_nav_inputs, references=("robocourse.mycar.navigation:NavigationActionServer",))
def check_navigation_action(inputs, out):
    """NavigationServer: goal/cancel callbacks, feedback and result, driving a car on the bus."""
    from robocourse.msgs.action_msgs import GoalStatus

    names = {GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED", GoalStatus.STATUS_CANCELED: "CANCELED",
             GoalStatus.STATUS_ABORTED: "ABORTED"}
    if not out.get("ready"):
        raise CheckFailed("no action server on /navigate_to_pose: ActionServer(self, NavigateToPose, "
                          "'/navigate_to_pose', self.execute, goal_callback=..., cancel_callback=...)")
    f = Failures()
    _qos_hint(out, f)
    runs = out["runs"]
    gx, gy = inputs["reach"]
    r = runs["reach"]
    if not r["accepted"]:
        f.add(f"the goal ({gx}, {gy}) in 'odom' was rejected: accept finite goals in the odom frame")
    elif not r.get("finished"):
        f.add(f"the goal ({gx}, {gy}) did not finish within 30 s of simulated time: drive towards it from /odom each "
              "step, `await self.sleep_async(...)` between steps, succeed() once within 5 cm")
    else:
        x, y, _ = (number(v) for v in r["pose"])
        err = math.hypot(x - gx, y - gy)
        f.expect(r["status"] == GoalStatus.STATUS_SUCCEEDED and r["success"] is True,
                 f"goal ({gx}, {gy}) ended {names.get(r['status'], r['status'])} with success={r['success']}: call "
                 "goal_handle.succeed() and return a Result with success=True")
        f.expect(err <= inputs["tolerance"] + 1e-6,
                 f"the goal ({gx}, {gy}) finished with the car at ({x:.3f}, {y:.3f}) by odometry, {err * 100:.1f} cm "
                 "away: succeed only within 5 cm")
        fb = [number(v) for v in r["feedback"]]
        f.expect(len(fb) >= 5, f"only {len(fb)} feedback messages on the way: publish_feedback every control step")
        if fb:
            f.expect(all(0.0 <= v <= 100.0 for v in fb) and fb[-1] >= 90.0,
                     f"percent_complete must stay in [0, 100] and end near 100; got first {fb[0]:.1f}, last {fb[-1]:.1f}")
        moved = math.hypot(number(r["pose_after"][0]) - x, number(r["pose_after"][1]) - y)
        f.expect(moved < 0.01, f"the car kept moving {moved * 100:.1f} cm after success: publish a zero Twist to stop")
    for name, what in (("map", "a goal with header.frame_id 'map' (the server only knows 'odom')"),
                       ("nan", "a goal with x = NaN")):
        f.expect(runs[name]["answered"] and not runs[name]["accepted"],
                 f"{what} was accepted: reject it in goal_callback (return GoalResponse.REJECT) and log the reason")
    c = runs["cancel"]
    if not c["accepted"]:
        f.add(f"the goal {inputs['far']} was rejected; it is 2.5 m away in 'odom' and must be accepted")
    else:
        f.expect(c.get("cancel_code") == 0, f"the cancel request was answered {c.get('cancel_code')} (0 = accepted): "
                 "the default cancel_callback rejects cancels; pass one returning CancelResponse.ACCEPT")
        f.expect(c.get("status") == GoalStatus.STATUS_CANCELED,
                 f"after the cancel the goal ended {names.get(c.get('status'), c.get('status'))}: poll "
                 "goal_handle.is_cancel_requested each step, then goal_handle.canceled() and return")
        motors = [abs(number(v)) for v in c["motors_after"]]
        f.expect(max(motors) < 1e-9, f"0.3 s after the cancel the motors still run at {c['motors_after']}: publish a "
                                     "zero Twist before returning")
        f.expect(c.get("success") is False, "a canceled goal's result must have success=False")
    warns = [rec for rec in out["logs"] if rec["severity"] in ("WARN", "ERROR", "INFO")]
    f.expect(any("map" in rec["msg"] for rec in warns), "the rejection of the 'map' goal was not logged with its "
                                                       "reason: say which frame you expected")
    return f.done("reached the goal by odometry, rejected the 'map' and NaN goals, and stopped on cancel")
