"""Graded checks of chapter 3 (MyCar): inputs, schemas, sub-tests. Registered as ``ch03.*``.

The judge side only: the grading sandbox hides this module (the quiz's key and the expected
values live here); the probes that run the student's nodes on the bus are in
:mod:`robocourse.mycar.probes`. Each check is split into sub-tests, one per property the
exercise states, with its share of the points; every record is validated against the check's
schema first. Everything the grader draws (a wheel base, rates, goals) is stated as a range in
the exercise text, drawn from the per-submission seed and shown in the feedback; a property a
parameter controls is probed with a value other than its default, so an answer that ignores the
parameter fails that sub-test every time, not one run in two. The peers never do the student's
job (the navigation probe's driver has a 10 s watchdog; the teleop probe only listens).
"""

from __future__ import annotations

import bisect
import math

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Any, Bool, Call, Dict, List, Map, Null, Number, OneOf, Str

from . import kinematics as kin
from . import probes
from .probes import TELEOP_KEYS

# ================================================================== ch03.watchdog

def _dog_inputs(rng):
    # binary-exact times (multiples of 1/64 s), so "more than timeout" has no rounding ties
    timeout = float(rng.choice([0.125, 0.25, 0.5]))
    return {"timeout": timeout, "early_t": timeout + 0.0625, "feed": float(rng.integers(2, 8)) / 2, "step": 1 / 64}


def _first_due(inputs):
    feed, step, timeout = inputs["feed"], inputs["step"], inputs["timeout"]
    return next(feed + step * k for k in range(1, 1000) if step * k > timeout)


def _dog_early(inputs, out):
    early = out["early"]
    if "raised" in early:
        raise CheckFailed(f"update({inputs['early_t']:g}) before any feed() raised {early['raised']}: "
                          f"{early['message']}; before the first command there is nothing to guard: return False")
    if early["value"] is True:
        raise CheckFailed(f"update({inputs['early_t']:g}) tripped (timeout {inputs['timeout']:g} s) before any command "
                          "was ever received: only arm after the first feed()")
    return "no trip before the first feed()"


def _dog_trip(inputs, out):
    timeout, feed, step = inputs["timeout"], inputs["feed"], inputs["step"]
    trips, due = out["trips"], _first_due(inputs)
    where = f"(timeout {timeout:g} s, fed at t={feed:g} s, update() every {step * 1e3:g} ms)"
    if not trips:
        raise CheckFailed(f"update() never returned True in the second after the feed {where}: it must trip once more "
                          "than the timeout passed without feed()")
    f = Failures()
    f.expect(len(trips) == 1, f"update() returned True {len(trips)} times (first at {trips[0]:.4f} s) {where}: report "
                              "the trip once, not on every check (the seed logs the stop once)")
    if trips[0] != due:
        rule = ("trip when *more* than the timeout has passed, not at exactly the timeout" if trips[0] < due else
                "trip at the first check later than feed + timeout")
        f.add(f"tripped at {trips[0]:.4f} s {where}; expected at {due:.4f} s, the first check later than "
              f"{feed + timeout:g} s: {rule}")
    return f.done(f"trips once at {due:.4f} s")


def _dog_rearm(inputs, out):
    timeout = inputs["timeout"]
    f = Failures()
    f.expect(out["stopped"] is True, f"after the trip .stopped is {out['stopped']!r}; it must be True")
    f.expect(out["rearmed_stopped"] is False, f"after a new feed() .stopped is {out['rearmed_stopped']!r}: a feed() "
                                              "re-arms the watchdog (.stopped False), motion resumes on the next command")
    f.expect(out["soon"] is not True, f"tripped {timeout / 2:g} s after a new feed with a {timeout:g} s timeout")
    f.expect(out["later"] is True, f"did not trip again {timeout + 0.05:g} s after the second feed (timeout "
                                   f"{timeout:g} s): a feed() must re-arm it")
    return f.done("stopped after the trip, re-armed by feed()")


register("ch03.watchdog", uses=("Watchdog",), probe=probes.dog_probe, inputs=_dog_inputs, time_limit=10,
         schema=Dict(early=Call(Any(max_items=10)), trips=List(Number(), max_len=200), stopped=Any(max_items=10),
                     rearmed_stopped=Any(max_items=10), soon=Any(max_items=10), later=Any(max_items=10)),
         subtests=[SubTest("nothing trips before the first feed()", 0.25, _dog_early, reads="early"),
                   SubTest("trips once, at the first check more than the timeout after the last feed()", 1.0,
                           _dog_trip, reads="trips"),
                   SubTest(".stopped after a trip; feed() re-arms it", 0.75, _dog_rearm)])


# ================================================================== ch03.quiz

#: the key, by kind (features as the exercise lists them)
_KINDS = {
    "topic": ("wheel encoder ticks at 100 Hz", "camera images", "battery voltage", "emergency stop button state"),
    "service": ("set the maximum speed limit", "take one snapshot and return it", "reset the odometry to zero"),
    "action": ("drive to the charging dock", "map the whole room", "follow a 20-waypoint path"),
}
QUIZ = {feature: kind for kind, features in _KINDS.items() for feature in features}
QUIZ_QUESTIONS = ("a stream whoever listens reads (topic)", "one request with one quick, definite answer (service)",
                  "a long task with feedback that must be cancellable (action)")


def _quiz_item(feature):
    def judge(inputs, out):
        answers = out["answers"]
        if answers is None:
            raise CheckFailed(f"quiz_answers() returned a {out['given']}, not a dict feature -> 'topic' | 'service' | "
                              "'action'")
        if feature not in answers:
            near = [k for k in answers if k.strip().lower() == feature.lower()]
            raise CheckFailed(f"no answer for {feature!r}" + (f" (you wrote {near[0]!r}: copy the name exactly)" if near
                                                               else ": answer every feature listed in the exercise"))
        given = answers[feature].strip().lower()
        if given not in ("topic", "service", "action"):
            raise CheckFailed(f"{feature!r}: answer 'topic', 'service' or 'action', not {answers[feature]!r}")
        if given != QUIZ[feature]:
            raise CheckFailed(f"reconsider {feature!r}: is it " + ", or ".join(QUIZ_QUESTIONS) + "?")
        return "right"
    return judge


register("ch03.quiz", uses=("quiz_answers",), probe=probes.quiz_probe, time_limit=5,
         schema=Dict(answers=OneOf(Map(Str(max_len=40), max_items=50), Null()), given=Str(max_len=40)),
         subtests=[SubTest(feature, 0.25, _quiz_item(feature)) for feature in (
             "wheel encoder ticks at 100 Hz", "set the maximum speed limit", "drive to the charging dock", "camera images",
             "take one snapshot and return it", "map the whole room", "battery voltage", "reset the odometry to zero",
             "follow a 20-waypoint path", "emergency stop button state")])


# ================================================================== the nodes: shared pieces

_BUILT = Dict(built=Bool(), error=Str(max_len=1000))
_LOGS = List(Dict(severity=Str(max_len=20), node=Str(max_len=200), msg=Str(max_len=400)), max_len=200)


def _built(out):
    if not out.get("built"):
        raise CheckFailed(f"your node could not be created: {out.get('error', '?')}")


def _qos_hint(out, f) -> None:
    for text in out.get("incompatible", []):
        f.add(f"QoS mismatch, no messages flow on {text}: match the other side's reliability")


def _yaw(qz, qw):
    return 2.0 * math.atan2(qz, qw)  # planar quaternion (x = y = 0)


# ================================================================== ch03.drive_node

DRIVE_RATES = (20.0, 40.0, 100.0)   # never the default 50: a timer that ignores publish_rate shows


def _drive_inputs(rng):
    segments = []
    for _ in range(3):
        sign = 1.0 if rng.random() < 0.5 else -1.0
        segments.append([round(float(rng.uniform(0.15, 0.3)), 3), round(sign * float(rng.uniform(0.6, 1.2)), 3),
                         float(rng.choice([1.5, 2.0]))])
    return {"wheel_base": round(float(rng.uniform(0.1, 0.3)), 3), "publish_rate": float(rng.choice(DRIVE_RATES)),
            "segments": segments, "bad": [["nan", 0.0], [0.2, "inf"]], "cmd_rate": 10.0, "stop_s": 0.5}


def _valid(sent):
    return [c for c in sent if math.isfinite(c["v"]) and math.isfinite(c["w"])]


def _drive_wheels(inputs, out):
    _built(out)
    b = inputs["wheel_base"]
    f = Failures()
    _qos_hint(out, f)
    wheels, valid = out["wheels"], _valid(out["sent"])
    if not wheels:
        raise CheckFailed("nothing arrived on /wheel_speeds: publish a std_msgs/Float64MultiArray [left, right] (m/s) "
                          "from the /cmd_vel callback, on the topic '/wheel_speeds'")
    by_time = {round(w["t"], 6): w for w in wheels}
    pairs = [(c, by_time.get(round(c["t"], 6))) for c in valid]
    missing = [c for c, w in pairs if w is None]
    for c, w in pairs:
        if w is None:
            continue
        v, om = c["v"], c["w"]
        want = [v - om * b / 2, v + om * b / 2]
        data = w["data"]
        if len(data) != 2 or not all(isinstance(d, float) and math.isclose(d, e, abs_tol=1e-9) for d, e in zip(data, want)):
            hint = ""
            if len(data) == 2 and all(math.isclose(d, e, abs_tol=1e-9) for d, e in zip(data, want[::-1])):
                hint = " (left and right swapped: turning left, the left wheel is the inner, slower one)"
            elif len(data) == 2 and all(math.isclose(d, e, abs_tol=1e-9) for d, e in zip(data, [v - om * b, v + om * b])):
                hint = " (each wheel sits wheel_base / 2 from the centre, not wheel_base)"
            elif len(data) == 2 and all(math.isclose(d, e, abs_tol=1e-9) for d, e in zip(
                    data, [v - om * 0.075, v + om * 0.075])):
                hint = " (that is the default wheel_base 0.15: read the parameter, the grader sets it)"
            f.add(f"/cmd_vel v={v:.3f} m/s, w={om:.3f} rad/s with wheel_base={b} gave /wheel_speeds {data}, expected "
                  f"[{want[0]:.4f}, {want[1]:.4f}] = [v - w*b/2, v + w*b/2]{hint}")
            break
    f.expect(not missing, f"no /wheel_speeds for {len(missing)} of {len(valid)} valid /cmd_vel (first: v="
                          f"{missing[0]['v'] if missing else ''}): publish one per command")
    return f.done(f"{len(valid)} commands, each [v - w*b/2, v + w*b/2] with wheel_base {b}")


def _drive_bad(inputs, out):
    _built(out)
    f = Failures()
    bad_times = {round(c["t"], 6) for c in out["sent"] if not (math.isfinite(c["v"]) and math.isfinite(c["w"]))}
    answered = [w for w in out["wheels"] if round(w["t"], 6) in bad_times]
    f.expect(not answered, f"a /cmd_vel with NaN or inf got /wheel_speeds {answered[0]['data'] if answered else ''}: "
                           "ignore such a command (publish nothing, keep the last command)")
    errors = [r for r in out["logs"] if r["severity"] in ("ERROR", "WARN")]
    f.expect(bool(errors), "a /cmd_vel with NaN or inf was ignored silently: log an error naming the values "
                           "(get_logger().error(...))")
    return f.done("NaN and inf commands ignored and logged")


def _drive_rate(inputs, out):
    odom, rate = _odom(out), inputs["publish_rate"]
    span = out["end"] - out["sent"][0]["t"]
    expected = rate * span
    if abs(len(odom) - expected) > 2 + 0.02 * expected:
        seen = len(odom) / span
        hint = " (that is the default 50 Hz: create the timer from the parameter's value)" if abs(seen - 50) < 2 else ""
        raise CheckFailed(f"{len(odom)} /odom messages in {span:.1f} s is {seen:.1f} Hz; the grader set publish_rate = "
                          f"{rate:g} Hz{hint}: create_timer(1.0 / publish_rate, ...)")
    return f"/odom at {rate:g} Hz"


def _odom(out):
    """The /odom messages the grader received, or the failure when there are none."""
    _built(out)
    if not out["odom"]:
        raise CheckFailed("nothing arrived on /odom: publish nav_msgs/Odometry from a timer at the publish_rate parameter")
    return out["odom"]


def _drive_header(inputs, out):
    odom = _odom(out)
    f = Failures()
    o = odom[-1]
    f.expect(o["frame"] == "odom" and o["child"] == "base_link",
             f"/odom header.frame_id={o['frame']!r}, child_frame_id={o['child']!r}: use 'odom' and 'base_link'")
    stamps = [m["stamp"] for m in odom]
    ok = all(b > a for a, b in zip(stamps, stamps[1:])) and stamps[0] > 0 and stamps[-1] <= out["end"] + 1e-6
    f.expect(ok, f"/odom header.stamp ran {stamps[0]:.3f} .. {stamps[-1]:.3f} s (simulated time ended at "
                 f"{out['end']:.3f} s): stamp each message with the node clock's now(), increasing")
    return f.done("stamped with the node clock, frames odom -> base_link")


def _reference_path(sent, t_end):
    """Exact arc integration of the held commands (NaN/inf ignored): [(t, x, y, yaw)] at each change."""
    x = y = yaw = 0.0
    out, held = [], (0.0, 0.0)
    times = [c["t"] for c in sent] + [t_end]
    for c, t_prev, t_next in zip(sent, times, times[1:]):
        if math.isfinite(c["v"]) and math.isfinite(c["w"]):
            held = (c["v"], c["w"])
        x, y, yaw = kin.integrate_pose(x, y, yaw, held[0], held[1], t_next - t_prev)
        out.append((t_next, x, y, yaw))
    return out


def _drive_pose(inputs, out):
    odom, rate = _odom(out), inputs["publish_rate"]
    if not all(math.isfinite(m[k]) for m in odom for k in ("x", "y", "qz", "qw")):
        raise CheckFailed("/odom carries NaN or inf: a /cmd_vel with NaN must be ignored, not integrated")
    worst = (0.0, None)
    for t, rx, ry, ryaw in _reference_path(out["sent"], out["end"]):
        m = min(odom, key=lambda m, t=t: abs(m["stamp"] - t))
        if abs(m["stamp"] - t) > 1.5 / rate:
            continue
        yaw = _yaw(m["qz"], m["qw"])
        err = math.hypot(m["x"] - rx, m["y"] - ry) + 0.05 * abs(math.remainder(yaw - ryaw, 2 * math.pi))
        if err >= worst[0]:
            worst = (err, (t, rx, ry, ryaw, m, yaw))
    err, where = worst
    if where is None:
        raise CheckFailed("no /odom message was stamped near the times the commands changed: stamp with the node clock")
    t, rx, ry, ryaw, m, yaw = where
    if math.hypot(m["x"] - rx, m["y"] - ry) > 0.05 or abs(math.remainder(yaw - ryaw, 2 * math.pi)) > 0.15:
        raise CheckFailed(f"at t={t:.2f} s /odom says x={m['x']:.3f}, y={m['y']:.3f} m, yaw={yaw:.3f} rad; integrating "
                          f"the commands gives ({rx:.3f}, {ry:.3f}, {ryaw:.3f}): each tick add v*cos(yaw)*dt, "
                          "v*sin(yaw)*dt and w*dt with dt the time since the last tick, yaw as the quaternion "
                          "z = sin(yaw/2), w = cos(yaw/2)")
    return "the pose follows the integrated commands"


def _drive_twist(inputs, out):
    odom = _odom(out)
    sent = out["sent"]
    times = [c["t"] for c in sent]
    held, checked = None, 0
    for m in odom:
        k = bisect.bisect_left(times, m["stamp"] - 1e-6) - 1      # the last command sent before this message
        if k < 0 or any(abs(m["stamp"] - t) < 1e-6 for t in times[k:k + 2]):
            continue                                               # at a command's instant: either answer is right
        held = next((c for c in reversed(sent[:k + 1]) if math.isfinite(c["v"]) and math.isfinite(c["w"])), None)
        if held is None:
            continue
        checked += 1
        if not (math.isclose(m["v"], held["v"], abs_tol=1e-9) and math.isclose(m["w"], held["w"], abs_tol=1e-9)):
            raise CheckFailed(f"at t={m['stamp']:.2f} s /odom's twist is v={m['v']}, w={m['w']} while the command held "
                              f"since t={held['t']:.2f} s is v={held['v']}, w={held['w']}: report the current command as "
                              "twist.twist.linear.x and twist.twist.angular.z")
    if not checked:
        raise CheckFailed("no /odom message fell between two commands: stamp /odom with the node clock")
    return f"the twist is the current command ({checked} messages)"


_ODOM = Dict(stamp=Number(), frame=Str(max_len=100), child=Str(max_len=100), x=Number(finite=False),
             y=Number(finite=False), qz=Number(finite=False), qw=Number(finite=False), v=Number(finite=False),
             w=Number(finite=False))
register("ch03.drive_node", uses=("DriveNode",), probe=probes.drive_probe, inputs=_drive_inputs, time_limit=30,
         references=("robocourse.mycar.nodes:DriverNode", "robocourse.mycar.kinematics:twist_to_wheel_speeds"),
         schema=OneOf(_BUILT, Dict(
             built=Bool(), end=Number(),
             sent=List(Dict(t=Number(), v=Number(finite=False), w=Number(finite=False)), max_len=200),
             wheels=List(Dict(t=Number(), data=List(Number(finite=False), max_len=4)), max_len=2000),
             odom=List(_ODOM, max_len=5000), logs=_LOGS, incompatible=List(Str(max_len=300), max_len=20))),
         subtests=[SubTest("/wheel_speeds = [v - w*b/2, v + w*b/2] per command, b from the wheel_base parameter", 1.0,
                           _drive_wheels),
                   SubTest("NaN or inf commands: nothing published, the last command kept, an error logged", 0.5,
                           _drive_bad),
                   SubTest("/odom at the publish_rate parameter", 0.75, _drive_rate),
                   SubTest("/odom header: the node clock's stamp, frame 'odom', child 'base_link'", 0.5, _drive_header),
                   SubTest("/odom pose: the commands integrated, yaw as a quaternion", 0.75, _drive_pose),
                   SubTest("/odom twist: the current command", 0.5, _drive_twist)])


# ================================================================== ch03.led_service

def _led_inputs(rng):
    count = int(rng.integers(3, 8))   # never the default 2
    ids = [1, count, int(rng.integers(2, count)), 0, count + 1, -1, 1]
    states = [True, True, bool(rng.random() < 0.5), True, True, True, False]
    return {"led_count": count, "requests": [[i, s] for i, s in zip(ids, states)]}


def _led_ready(out):
    _built(out)
    if not out["ready"]:
        raise CheckFailed("no /set_led service appeared: create_service(SetLed, '/set_led', self.on_set_led) in __init__")


def _led_initial(inputs, out):
    _led_ready(out)
    count = inputs["led_count"]
    want = {str(i): False for i in range(1, count + 1)}
    if out["initial"] != want:
        raise CheckFailed(f"with led_count={count} (the grader's), .leds started as {out['initial']}, expected "
                          f"{{1: False, ..., {count}: False}}: read the led_count parameter, ids count from 1")
    return f"{count} LEDs, all off"


def _led_valid(inputs, out):
    _led_ready(out)
    count = inputs["led_count"]
    f = Failures()
    state = {str(i): False for i in range(1, count + 1)}
    for (led_id, want_state), got in zip(inputs["requests"], out["answers"]):
        if not 1 <= led_id <= count:
            continue
        if not got["answered"] or "raised" in got:
            f.add(f"request led_id={led_id} got no response" + (f" (the server raised {got['raised']})" if "raised" in
                                                                 got else ": the callback must return the response"))
            continue
        f.expect(got.get("success") is True, f"led_id={led_id} with led_count={count} answered success="
                                             f"{got.get('success')}: ids 1..{count} exist")
        state[str(led_id)] = want_state
    f.expect(out["final"] == state, f".leds after the calls is {out['final']}, expected {state}: store each valid "
                                    "request's state")
    return f.done("valid ids stored and answered success=True")


def _led_invalid(inputs, out):
    _led_ready(out)
    count = inputs["led_count"]
    f = Failures()
    for (led_id, _), got in zip(inputs["requests"], out["answers"]):
        if 1 <= led_id <= count:
            continue
        if not got["answered"] or "raised" in got:
            f.add(f"request led_id={led_id} (no such LED) got no answer" + (
                f": the server raised {got['raised']}; answer success=False instead" if "raised" in got else ""))
            continue
        f.expect(got.get("success") is False, f"led_id={led_id} with led_count={count} answered success="
                                              f"{got.get('success')}: anything outside 1..{count} fails")
        f.expect(any(str(led_id) in w for w in got["warned"]),
                 f"led_id={led_id} was refused without a warning naming it: get_logger().warning(...) with the id")
    return f.done("invalid ids answered success=False, each warned by id")


register("ch03.led_service", uses=("LedServer",), probe=probes.led_probe, inputs=_led_inputs, time_limit=15,
         references=("robocourse.mycar.nodes:LedServiceServer",),
         schema=OneOf(_BUILT, Dict(
             built=Bool(), ready=Bool(), initial=Map(Any(max_items=5), max_items=100),
             final=Map(Any(max_items=5), max_items=100),
             answers=List(Dict(answered=Bool(), warned=List(Str(max_len=400), max_len=5),
                               optional={"success": Bool(), "raised": Str(max_len=300)}), max_len=20))),
         subtests=[SubTest("LEDs 1..led_count, all off at the start", 0.75, _led_initial),
                   SubTest("a valid id: its state stored, success=True", 1.25, _led_valid),
                   SubTest("any other id: success=False, no exception, a warning naming it", 1.0, _led_invalid)])


# ================================================================== ch03.navigation_action

def _nav_inputs(rng):
    ang = float(rng.uniform(-math.pi, math.pi))
    dist = float(rng.uniform(0.4, 0.8))
    return {"reach": [round(dist * math.cos(ang), 3), round(dist * math.sin(ang), 3)],
            "far": [0.0, -2.5 if rng.random() < 0.5 else 2.5], "lost": [-2.0, 0.0], "cancel_after": 1.0,
            "tolerance": 0.05,
            "timeout": float(rng.choice([1.5, 2.0, 2.5, 3.0]))}


_NAMES = {4: "SUCCEEDED", 5: "CANCELED", 6: "ABORTED"}


def _nav_ready(out):
    _built(out)
    if not out["ready"]:
        raise CheckFailed("no action server on /navigate_to_pose: ActionServer(self, NavigateToPose, "
                          "'/navigate_to_pose', self.execute, goal_callback=..., cancel_callback=...)")


def _stopped(rec, what):
    """Problems with how the server stopped the car after ``what``."""
    out = []
    if rec.get("last_cmd") is None or any(abs(v) > 1e-9 for v in rec["last_cmd"]):
        out.append(f"after {what} the last /cmd_vel your server published was {rec.get('last_cmd')}: publish a zero "
                   "Twist before ending the goal (the driver's watchdog is not yours to rely on)")
    if any(abs(v) > 1e-9 for v in rec["motors_after"]):
        out.append(f"0.05 s after {what} the motors still ran at {rec['motors_after']}")
    return out


def _nav_reach(inputs, out):
    _nav_ready(out)
    f = Failures()
    _qos_hint(out, f)
    gx, gy = inputs["reach"]
    r = out["runs"]["reach"]
    if not r["accepted"]:
        raise CheckFailed(f"the goal ({gx}, {gy}) in 'odom' was rejected: accept finite goals in the odom frame")
    if not r.get("finished"):
        raise CheckFailed(f"the goal ({gx}, {gy}) did not finish within 30 s of simulated time: drive towards it from "
                          "/odom each step, `await self.sleep_async(...)` between steps, succeed() once within 5 cm")
    x, y, _ = r["pose"]
    err = math.hypot(x - gx, y - gy)
    f.expect(r["status"] == 4 and r["success"] is True,
             f"goal ({gx}, {gy}) ended {_NAMES.get(r['status'], r['status'])} with success={r['success']}: call "
             "goal_handle.succeed() and return a Result with success=True")
    f.expect(err <= inputs["tolerance"] + 1e-6, f"the goal ({gx}, {gy}) finished with the car at ({x:.3f}, {y:.3f}) by "
                                               f"odometry, {err * 100:.1f} cm away: succeed only within 5 cm")
    for p in _stopped(r, "success"):
        f.add(p)
    return f.done(f"reached ({gx}, {gy}) within 5 cm and stopped")


def _nav_reject(inputs, out):
    _nav_ready(out)
    f = Failures()
    runs = out["runs"]
    for name, what in (("map", "a goal with header.frame_id 'map' (the server only knows 'odom')"),
                       ("nan", "a goal with x = NaN")):
        f.expect(runs[name]["answered"] and not runs[name]["accepted"],
                 f"{what} was accepted: reject it in goal_callback (return GoalResponse.REJECT) and log the reason")
    warns = [rec for rec in out["logs"] if rec["severity"] in ("WARN", "ERROR", "INFO")]
    f.expect(any("map" in rec["msg"] for rec in warns), "the rejection of the 'map' goal was not logged with its "
                                                       "reason: say which frame you expected")
    return f.done("rejected the 'map' and NaN goals, with the reason logged")


def _nav_feedback(inputs, out):
    _nav_ready(out)
    r = out["runs"]["reach"]
    fb = r.get("feedback", [])
    f = Failures()
    f.expect(len(fb) >= 5, f"only {len(fb)} feedback messages on the way to the goal: publish_feedback every step")
    if fb:
        f.expect(all(0.0 <= v <= 100.0 for v in fb) and fb[-1] >= 90.0 and fb[0] <= 20.0,
                 f"percent_complete must run from near 0 to near 100 within [0, 100]; got first {fb[0]:.1f}, last "
                 f"{fb[-1]:.1f}, range {min(fb):.1f}..{max(fb):.1f}")
    return f.done(f"{len(fb)} feedback messages from {fb[0]:.0f} to {fb[-1]:.0f} %" if fb else "")


def _nav_cancel(inputs, out):
    _nav_ready(out)
    c = out["runs"]["cancel"]
    if not c["accepted"]:
        raise CheckFailed(f"the goal {inputs['far']} was rejected; it is 2.5 m away in 'odom' and must be accepted")
    f = Failures()
    f.expect(c.get("cancel_code") == 0, f"the cancel request was answered {c.get('cancel_code')} (0 = accepted): the "
                                       "default cancel_callback rejects cancels; pass one returning CancelResponse.ACCEPT")
    f.expect(c.get("status") == 5, f"after the cancel the goal ended {_NAMES.get(c.get('status'), c.get('status'))}: "
                                   "poll goal_handle.is_cancel_requested each step, then goal_handle.canceled() and return")
    f.expect(c.get("success") is False, "a canceled goal's result must have success=False")
    for p in _stopped(c, "the cancel"):
        f.add(p)
    return f.done("cancel accepted, the car stopped, CANCELED")


def _nav_abort(inputs, out):
    _nav_ready(out)
    a = out["runs"]["abort"]
    limit = inputs["timeout"]
    ts = out.get("timeout_set", {})
    if ts.get("value") is not True:
        raise CheckFailed(f"`ros2 param set /navigation_server timeout {limit:g}` failed ("
                          + (f"{ts['raised']}: {ts['message']}" if "raised" in ts else f"answered {ts.get('value')!r}")
                          + "): declare a float parameter timeout (default 30.0)")
    if not a["accepted"]:
        raise CheckFailed(f"the goal {inputs['lost']} was rejected; it must be accepted (and then given up on)")
    if not a.get("finished"):
        raise CheckFailed(f"with the driver gone the goal {inputs['lost']} was still running {limit + 5:g} s after it "
                          f"started; the grader set timeout = {limit:g} s: abort a goal not reached within timeout "
                          "(declare the parameter, compare the elapsed time each step, goal_handle.abort())")
    f = Failures()
    f.expect(a["status"] == 6 and a.get("success") is False,
             f"the unreachable goal ended {_NAMES.get(a['status'], a['status'])} with success={a.get('success')}: call "
             "goal_handle.abort() and return success=False")
    f.expect(limit - 0.1 <= a["took"] <= limit + 0.5,
             f"the goal ended {a['took']:.2f} s after it was accepted; the grader set timeout = {limit:g} s: abort once "
             "the timeout has passed, not before")
    if a.get("last_cmd") is None or any(abs(v) > 1e-9 for v in a["last_cmd"]):
        f.add(f"when giving up the last /cmd_vel your server published was {a.get('last_cmd')}: publish a zero Twist "
              "before abort()")
    return f.done(f"aborted after the {limit:g} s timeout, the car told to stop")


_RUN = Dict(answered=Bool(), accepted=Bool(), feedback=List(Number(finite=False), max_len=2000),
            optional={"cancel_code": OneOf(Number(integer=True), Any(max_items=1)), "finished": Bool(),
                      "took": Number(), "status": Number(integer=True), "success": Any(max_items=2),
                      "message": Str(max_len=300), "pose": List(Number(), length=3),
                      "last_cmd": OneOf(List(Number(finite=False), length=2), Any(max_items=1)),
                      "motors_after": List(Number(), length=2), "pose_after": List(Number(), length=3)})
register("ch03.navigation_action", uses=("NavigationServer",), probe=probes.nav_probe, inputs=_nav_inputs,
         time_limit=40, references=("robocourse.mycar.navigation:NavigationActionServer",),
         schema=OneOf(_BUILT, Dict(built=Bool(), ready=Bool(), optional={
             "runs": Dict(reach=_RUN, map=_RUN, nan=_RUN, cancel=_RUN, abort=_RUN), "logs": _LOGS,
             "timeout_set": Call(Any(max_items=2)),
             "incompatible": List(Str(max_len=300), max_len=20)})),
         subtests=[SubTest("a reachable goal: driven to within 5 cm, SUCCEEDED, the car stopped", 1.25, _nav_reach),
                   SubTest("goals in another frame or with NaN: rejected, the reason logged", 0.75, _nav_reject),
                   SubTest("feedback: percent_complete from 0 to 100", 0.5, _nav_feedback),
                   SubTest("cancel: accepted, the car stopped, CANCELED", 1.0, _nav_cancel),
                   SubTest("a goal not reached within the timeout parameter: aborted, the car told to stop", 0.5,
                           _nav_abort)])


# ================================================================== ch03.teleop_node

TELEOP_RATES = (8.0, 12.5, 20.0, 25.0)   # never the default 10 Hz
TELEOP_HOLDS = (0.4, 0.6, 0.8)           # never the default 0.5 s
_EPS = 1e-6


def _teleop_inputs(rng):
    hold = float(rng.choice(TELEOP_HOLDS))
    keys = [str(k) for k in rng.permutation(list("wsadqe"))]
    script = [["spin", 0.33]]
    for k in keys[:3]:
        script += [["press", k], ["spin", round(hold + 0.5, 3)]]
    script += [["press", keys[3]], ["spin", round(hold * 0.4, 3)], ["press", keys[4]], ["spin", round(hold + 0.5, 3)]]
    script += [["press", keys[5]], ["spin", round(hold * 0.3, 3)], ["press", "x"], ["spin", round(hold + 0.5, 3)]]
    script += [["press", str(rng.choice(list("zjk")))], ["spin", 0.3]]
    return {"params": {"rate_hz": float(rng.choice(TELEOP_RATES)), "hold_s": hold,
                       "linear_speed": round(float(rng.uniform(0.1, 0.3)), 3),
                       "angular_speed": round(float(rng.uniform(0.5, 1.5)), 3)},
            "script": script}


RELEASE_S = 0.2   # the zero must come before the driver's watchdog (0.2 s in mycar.yaml) would stop the car


def _want(inputs, key):
    lin, ang = TELEOP_KEYS[key]
    return lin * inputs["params"]["linear_speed"], ang * inputs["params"]["angular_speed"]


def _zero(m) -> bool:
    return m[1] == 0.0 and m[2] == 0.0


def _presses(out):
    """[(t, key, t_next, sent)] per press that did not raise: its time, the next press's time, and
    the Twist the student's press() published at once (None if nothing)."""
    ev = out["events"]
    rows = []
    for i, e in enumerate(ev):
        if "raised" in e or e["key"] not in TELEOP_KEYS:
            continue   # an unknown key that did not raise is the unknown-key sub-test's
        t_next = ev[i + 1]["t"] if i + 1 < len(ev) else out["end"] + 1.0
        rows.append((e["t"], e["key"], t_next, tuple(e["sent"][0]) if e["sent"] else None))
    return rows


def _between(out, t0, t1):
    """Messages strictly after t0 and strictly before t1."""
    return [m for m in out["messages"] if t0 + _EPS < m[0] < t1 - _EPS]


def _teleop_heard(out):
    _built(out)
    if not out["messages"]:
        raise CheckFailed("nothing arrived on /cmd_vel (the grader listens RELIABLE, as the driver does): "
                          "create_publisher(Twist, '/cmd_vel', QoSProfile(depth=10, reliability=RELIABLE))")


def _teleop_keys(inputs, out):
    _teleop_heard(out)
    f = Failures()
    p = inputs["params"]
    for t, key, _, sent in _presses(out):
        want = _want(inputs, key)
        if sent is None:
            f.add(f"press('{key}') at t={t:.2f} s published nothing at once: publish the key's Twist in press()")
        elif abs(sent[0] - want[0]) > 1e-9 or abs(sent[1] - want[1]) > 1e-9:
            f.add(f"press('{key}') published linear.x={sent[0]:.3f}, angular.z={sent[1]:.3f}; with linear_speed "
                  f"{p['linear_speed']} and angular_speed {p['angular_speed']} (the grader's) '{key}' is "
                  f"({want[0]:.3f}, {want[1]:.3f}): w/s forward/back, a/d turn left/right (left is +angular.z), q/e "
                  "forward turning left/right, x stop")
    return f.done("every key's Twist, from the speed parameters, at once")


def _holds(inputs, out):
    """(t, key, t_next, sent) per movement press that published something."""
    return [row for row in _presses(out) if row[1] != "x" and row[3] is not None]


def _teleop_repeat(inputs, out):
    _teleop_heard(out)
    rate, hold = inputs["params"]["rate_hz"], inputs["params"]["hold_s"]
    period = 1.0 / rate
    f = Failures()
    for t, key, t_next, sent in _holds(inputs, out):
        end = min(t + hold, t_next)
        same = [m for m in _between(out, t, t_next) if (m[1], m[2]) == sent]
        held = [m[0] for m in same if m[0] <= end + _EPS]
        gaps = [b - a for a, b in zip(held, held[1:])]
        if not held or held[0] - t > period + _EPS or any(abs(g - period) > 1e-4 for g in gaps) or (
                t_next >= t + hold and t + hold - held[-1] > period + _EPS):
            f.add(f"'{key}' held from t={t:.2f} s for hold_s = {hold:g} s: repeated at "
                  f"{[round(x, 3) for x in held][:10]}; the grader set rate_hz = {rate:g}: repeat it every "
                  f"1 / rate_hz = {period * 1e3:.0f} ms, from a timer, for the whole hold")
        late = [m[0] for m in same if m[0] > t + hold + _EPS]
        if late:
            f.add(f"'{key}' pressed at t={t:.2f} s was still repeated at t={late[0]:.2f} s, after hold_s = {hold:g} s "
                  "(the grader's): stop repeating once hold_s has passed since the press")
    return f.done(f"repeated every {period * 1e3:.0f} ms for {hold:g} s")


def _teleop_release(inputs, out):
    _teleop_heard(out)
    hold = inputs["params"]["hold_s"]
    f = Failures()
    for t, key, t_next, _sent in _holds(inputs, out):
        if t_next < t + hold + RELEASE_S:
            continue                                       # interrupted: the next press took over
        after = _between(out, t, t_next)
        zeros = [m for m in after if _zero(m)]
        if not zeros:
            f.add(f"'{key}' pressed at t={t:.2f} s: no zero Twist when its hold ended (hold_s = {hold:g} s): publish one "
                  "so the car stops now, not when the driver's watchdog gives up")
            continue
        if not t + hold - _EPS <= zeros[0][0] <= t + hold + RELEASE_S:
            f.add(f"'{key}' pressed at t={t:.2f} s: its zero Twist came at t={zeros[0][0]:.2f} s; the hold ends at "
                  f"{t + hold:.2f} s (hold_s = {hold:g} s): send it then, within {RELEASE_S:g} s (the driver's watchdog)")
        extra = [m for m in after if m[0] > zeros[0][0] + _EPS]
        if extra:
            f.add(f"'{key}' pressed at t={t:.2f} s: after its zero Twist /cmd_vel went on ({len(extra)} more messages, "
                  f"first at t={extra[0][0]:.2f} s): publish one zero, then nothing until the next press")
    return f.done("one zero Twist when each hold ends, then silence")


def _teleop_replace(inputs, out):
    _teleop_heard(out)
    hold = inputs["params"]["hold_s"]
    f = Failures()
    rows = _presses(out)
    for (t_prev, prev, _, prev_sent), (t, key, t_next, sent) in zip(rows, rows[1:]):
        if prev == "x" or prev_sent is None or t - t_prev >= hold - _EPS:
            continue                                       # not a press during another key's hold
        if key == "x":
            f.expect(sent is not None and sent == (0.0, 0.0),
                     f"press('x') at t={t:.2f} s during the hold of '{prev}' published {sent}: one zero Twist at once")
            later = _between(out, t, t_next)
            if later:
                f.add(f"after press('x') at t={t:.2f} s /cmd_vel went on ({len(later)} messages, first at "
                      f"t={later[0][0]:.2f} s): x ends the hold, nothing until the next press")
            continue
        stale = [m for m in _between(out, t, t_next) if (m[1], m[2]) == prev_sent and prev_sent != sent]
        if stale:
            f.add(f"'{key}' pressed at t={t:.2f} s during the hold of '{prev}': '{prev}''s Twist came again at "
                  f"t={stale[0][0]:.2f} s: a new press replaces the command")
        early = [m for m in _between(out, t, t + hold) if _zero(m)]
        if early:
            f.add(f"'{key}' pressed at t={t:.2f} s during the hold of '{prev}': a zero Twist came at "
                  f"t={early[0][0]:.2f} s, before its own hold_s = {hold:g} s had passed: the hold restarts at the "
                  "new press")
    return f.done("a new press replaces the command; x stops at once")


def _teleop_unknown(inputs, out):
    _teleop_heard(out)
    f = Failures()
    for e in [e for e in out["events"] if e["key"] not in TELEOP_KEYS]:
        if e.get("raised") is None:
            f.add(f"press({e['key']!r}) returned normally: raise ValueError naming the key (the grader's unknown key)")
        elif "ValueError" not in e.get("bases", [e.get("raised")]):
            f.add(f"press({e['key']!r}) raised {e['raised']}; raise ValueError for a key you do not know")
        elif e["key"] not in e.get("message", ""):
            f.add(f"press({e['key']!r}) raised ValueError({e['message']!r}): name the key in the message")
        f.expect(not e["sent"], f"press({e['key']!r}) published {e['sent']}: refuse before publishing anything")
    return f.done("unknown keys refused with ValueError, nothing published")


def _teleop_qos(inputs, out):
    _built(out)
    f = Failures()
    for text in out["incompatible"]:
        f.add(f"QoS mismatch on {text}: the driver subscribes RELIABLE; publish /cmd_vel RELIABLE")
    f.expect(bool(out["messages"]), "nothing arrived on /cmd_vel for a RELIABLE subscriber")
    f.expect(out["name"] == "teleop", f"the node is named {out['name']!r}; name it 'teleop'")
    return f.done("'teleop' publishes /cmd_vel RELIABLE")


register("ch03.teleop_node", uses=("TeleopNode",), probe=probes.teleop_probe, inputs=_teleop_inputs, time_limit=20,
         references=("robocourse.mycar.teleop:TeleopNode", "robocourse.mycar.teleop_live:LiveTeleop"),
         schema=OneOf(_BUILT, Dict(
             built=Bool(), name=Str(max_len=200), end=Number(), incompatible=List(Str(max_len=300), max_len=20),
             messages=List(List(Number(finite=False), length=3), max_len=5000),
             events=List(Dict(t=Number(), key=Str(max_len=10), sent=List(List(Number(finite=False), length=2),
                                                                          max_len=5), optional={
                 "value": Any(max_items=10), "type": Str(max_len=200), "raised": Str(max_len=200),
                 "bases": List(Str(max_len=200), max_len=50), "message": Str(max_len=2000)}), max_len=50))),
         subtests=[SubTest("each key's Twist at once, from linear_speed and angular_speed", 0.75, _teleop_keys),
                   SubTest("repeated every 1 / rate_hz while held, for hold_s", 0.75, _teleop_repeat),
                   SubTest("one zero Twist when a hold ends (before the driver's watchdog would), then silence", 0.5,
                           _teleop_release),
                   SubTest("a new press replaces the command; x stops at once and ends the hold", 0.5, _teleop_replace),
                   SubTest("an unknown key: ValueError naming it, nothing published", 0.25, _teleop_unknown),
                   SubTest("the node 'teleop' publishes /cmd_vel RELIABLE", 0.25, _teleop_qos)])


# ================================================================== ch03.launch_file

#: the graph and parameter values the exercise states (use_sim true)
LAUNCH_NODES = {"/mycar/sim": "SimulatorNode", "/mycar/base_driver": "DriverNode", "/mycar/lights": "LedServiceServer",
                "/mycar/navigator": "NavigationActionServer"}
LAUNCH_PARAMS = {
    "/mycar/sim": {"wheel_base": 0.16, "wheel_radius": 0.033},
    "/mycar/base_driver": {"wheel_base": 0.16, "wheel_radius": 0.033, "watchdog_timeout": 0.3, "odom_rate_hz": 40.0,
                           "wheel_separation_multiplier": 1.02},
    "/mycar/lights": {"led_count": 4},
    "/mycar/navigator": {"timeout": 15.0, "goal_tolerance": 0.03, "max_linear": 0.25},
}


def _launch_inputs(rng):
    return {"use_sim": ["true", "false"]}


def _run(out, use_sim):
    run = out["runs"].get(use_sim)
    if run is None:
        raise CheckFailed(out.get("problem") or f"not launched with use_sim:={use_sim}")
    if "error" in run:
        raise CheckFailed(f"launching with params_file:=<your params_yaml()> use_sim:={use_sim} failed: {run['error']}")
    return run


def _by_name(run):
    return {n["fqn"]: n for n in run["nodes"]}


def _launch_nodes(inputs, out):
    nodes = _by_name(_run(out, "true"))
    f = Failures()
    for fqn, kind in LAUNCH_NODES.items():
        if fqn not in nodes:
            same = [n for n in nodes if n.rsplit("/", 1)[-1] == fqn.rsplit("/", 1)[-1]]
            f.add(f"no node {fqn} (use_sim:=true); started: {sorted(nodes)}" + (
                f" ({same[0]}: put it in the namespace 'mycar')" if same else ""))
        elif nodes[fqn]["kind"] != kind:
            f.add(f"{fqn} is a {nodes[fqn]['kind']}, expected the {kind} (check its executable)")
    extra = sorted(set(nodes) - set(LAUNCH_NODES))
    f.expect(not extra, f"nodes the exercise does not ask for: {extra}")
    return f.done("sim, base_driver, lights, navigator in /mycar")


def _launch_sim(inputs, out):
    f = Failures()
    on, off = _by_name(_run(out, "true")), _by_name(_run(out, "false"))
    f.expect("/mycar/sim" not in off, "with use_sim:=false the simulator was started: give it "
                                      "condition=IfCondition(LaunchConfiguration('use_sim'))")
    drv_on, drv_off = on.get("/mycar/base_driver"), off.get("/mycar/base_driver")
    f.expect(drv_on is not None and drv_on["motors"] == "MujocoMotorDriver",
             "with use_sim:=true base_driver must drive the simulator's car (driver: mujoco), got "
             f"{drv_on['motors'] if drv_on else 'no base_driver'}")
    f.expect(drv_off is not None and drv_off["motors"] == "SimulatedMotorDriver",
             "with use_sim:=false base_driver must log PWM (driver: simulated), got "
             f"{drv_off['motors'] if drv_off else 'no base_driver'}")
    return f.done("the simulator only with use_sim true; the driver follows it")


def _launch_params(inputs, out):
    f = Failures()
    for use_sim in ("true",):
        nodes = _by_name(_run(out, use_sim))
        for fqn, want in LAUNCH_PARAMS.items():
            if fqn not in nodes:
                f.add(f"no node {fqn} (use_sim:={use_sim}): its parameters ({', '.join(want)}) reached nothing")
                continue
            got = nodes[fqn]["params"]
            for name, value in want.items():
                if got.get(name) != value:
                    f.add(f"{fqn}'s {name} is {got.get(name)!r} (use_sim:={use_sim}), expected {value!r}: the "
                          f"parameter file's entry for this node must be keyed by its full name ({fqn}, or nested "
                          "namespace: node:, or a /** wildcard)")
            if got.get("use_sim_time") is not True:
                f.add(f"{fqn}'s use_sim_time is {got.get('use_sim_time')!r}: set it for every node with one '/**' entry")
    return f.done("every value reached its node, use_sim_time for all")


def _launch_remap(inputs, out):
    run = _run(out, "true")
    f = Failures()
    f.expect("/mycar/set_led" in run["services"], f"no service /mycar/set_led; services: {run['services'][:8]}: remap "
                                                  "the absolute name: remappings=[('/set_led', '/mycar/set_led')]")
    f.expect("/set_led" not in run["services"], "/set_led is still there: the remapping did not apply")
    return f.done("the LED service at /mycar/set_led")


_LNODE = Dict(fqn=Str(max_len=200), kind=Str(max_len=100), motors=Str(max_len=100), params=Map(Any(max_items=20),
                                                                                              max_items=100))
_LRUN = OneOf(Dict(error=Str(max_len=2000)),
              Dict(nodes=List(_LNODE, max_len=20), services=List(Str(max_len=300), max_len=100),
                   topics=List(Str(max_len=300), max_len=100), warnings=List(Str(max_len=300), max_len=10)))
register("ch03.launch_file", uses=("params_yaml", "generate_launch_description"), probe=probes.launch_probe,
         inputs=_launch_inputs, time_limit=30, references=("robocourse.mycar.launch:generate_launch_description",),
         schema=Dict(runs=Map(_LRUN, keys=("true", "false")), optional={"problem": Str(max_len=300)}),
         subtests=[SubTest("the nodes: sim, base_driver, lights and navigator in the namespace mycar", 0.75, _launch_nodes),
                   SubTest("use_sim: the simulator only when true, the driver's motors follow it", 0.75, _launch_sim),
                   SubTest("the parameter file: each value reaches its node, use_sim_time for all", 1.0, _launch_params),
                   SubTest("the LED service remapped to /mycar/set_led", 0.5, _launch_remap)])
