"""Chapter 3's answer bank: plausible wrong answers (one per stated property) and correct ones.

Every answer runs in the student's place in the grading sandbox; the reference is the solution
notebook's cell. A wrong answer's ``score`` is what the check must give it: the weights of the
sub-tests it still passes (listed by name), so a regression in either direction shows.
"""

from robocourse.grading.bank import Answer, Exercise

NB = "03_mycar_exercises"

WATCHDOG = Exercise(
    "ch03.watchdog", NB,
    right=[Answer("a deadline instead of the last feed", code='''
class Watchdog:
    def __init__(self, timeout):
        self.timeout = timeout
        self.deadline = math.inf
        self.stopped = False

    def feed(self, t):
        self.deadline = t + self.timeout
        self.stopped = False

    def update(self, t):
        if self.stopped or t <= self.deadline:
            return False
        self.stopped = True
        return True
''')],
    wrong=[
        Answer("armed from the start", replace=[("self.last = None", "self.last = 0.0")],
               score={"trips once, at the first check more than the timeout after the last feed()": 1.0,
                      ".stopped after a trip; feed() re-arms it": 0.75},
               property="nothing trips before the first feed()", says="before any command"),
        Answer("trips at exactly the timeout", replace=[("if t - self.last > self.timeout:",
                                                         "if t - self.last >= self.timeout:")],
               score={"nothing trips before the first feed()": 0.25, ".stopped after a trip; feed() re-arms it": 0.75},
               property="trips when more than the timeout has passed", says="not at exactly the timeout"),
        Answer("reports every check", replace=[("if self.last is None or self.stopped:", "if self.last is None:")],
               score={"nothing trips before the first feed()": 0.25, ".stopped after a trip; feed() re-arms it": 0.75},
               property="trips once", says="report the trip once"),
        Answer("feed does not re-arm", replace=[("        self.last = t\n        self.stopped = False",
                                                 "        self.last = t")],
               score={"nothing trips before the first feed()": 0.25,
                      "trips once, at the first check more than the timeout after the last feed()": 1.0},
               property="feed() re-arms", says="re-arms the watchdog"),
    ])

DRIVE = Exercise(
    "ch03.drive_node", NB,
    right=[Answer("exact arc integration, BEST_EFFORT odometry", code='''
from robocourse.bus import QoSProfile, ReliabilityPolicy


class DriveNode(Node):
    def __init__(self, **kwargs):
        super().__init__("drive_node", **kwargs)
        self.declare_parameter("wheel_base", 0.15)
        self.declare_parameter("publish_rate", 50.0)
        self.cmd = (0.0, 0.0)
        self.pose = [0.0, 0.0, 0.0]
        self.wheels = self.create_publisher(Float64MultiArray, "/wheel_speeds", 10)
        self.odom = self.create_publisher(Odometry, "/odom", QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.create_subscription(Twist, "/cmd_vel", self.on_cmd_vel, 10)
        self.last = self.get_clock().now()
        self.create_timer(1.0 / self.get_parameter("publish_rate").value, self.on_timer)

    def on_cmd_vel(self, msg):
        v, w = msg.linear.x, msg.angular.z
        if math.isnan(v) or math.isnan(w) or math.isinf(v) or math.isinf(w):
            self.get_logger().error("non-finite /cmd_vel ignored")
            return
        self.cmd = (v, w)
        b = self.get_parameter("wheel_base").value
        self.wheels.publish(Float64MultiArray(data=[v - w * b / 2.0, v + w * b / 2.0]))

    def on_timer(self):
        now = self.get_clock().now()
        dt = (now - self.last).nanoseconds / 1e9
        self.last = now
        v, w = self.cmd
        x, y, th = self.pose
        if abs(w) < 1e-12:
            x, y = x + v * dt * math.cos(th), y + v * dt * math.sin(th)
        else:
            x += v / w * (math.sin(th + w * dt) - math.sin(th))
            y -= v / w * (math.cos(th + w * dt) - math.cos(th))
            th += w * dt
        self.pose = [x, y, th]
        msg = Odometry()
        msg.header.stamp = now.to_msg()
        msg.header.frame_id = "odom"
        msg.child_frame_id = "base_link"
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(th / 2), math.cos(th / 2)
        msg.twist.twist.linear.x, msg.twist.twist.angular.z = v, w
        self.odom.publish(msg)
''')],
    wrong=[
        Answer("left and right swapped", replace=[("[lin - ang * half, lin + ang * half]",
                                                   "[lin + ang * half, lin - ang * half]")],
               score=3.0, property="/wheel_speeds = [v - w*b/2, v + w*b/2]", says="swapped"),
        Answer("the default wheel base", replace=[('half = self.get_parameter("wheel_base").value / 2', "half = 0.15 / 2")],
               score=3.0, property="b from the wheel_base parameter", says="read the parameter"),
        Answer("NaN passed on", replace=[('''        if not all(map(math.isfinite, (lin, ang))):
            self.get_logger().error(f"ignoring /cmd_vel with v={lin}, w={ang}")
            return
''', "")],
               score={"/wheel_speeds = [v - w*b/2, v + w*b/2] per command, b from the wheel_base parameter": 1.0,
                      "/odom at the publish_rate parameter": 0.75,
                      "/odom header: the node clock's stamp, frame 'odom', child 'base_link'": 0.5},
               property="NaN or inf commands ignored", says="ignore such a command"),
        Answer("a 50 Hz timer", replace=[('1.0 / self.get_parameter("publish_rate").value', "1.0 / 50.0")],
               score=3.25, property="/odom at the publish_rate parameter", says="default 50 Hz"),
        Answer("odometry in the map frame", replace=[('"odom", "base_link"', '"map", "base_link"')],
               score=3.5, property="frame 'odom', child 'base_link'", says="use 'odom' and 'base_link'"),
        Answer("yaw straight into the quaternion", replace=[("math.sin(self.yaw / 2)", "math.sin(self.yaw)"),
                                                             ("math.cos(self.yaw / 2)", "math.cos(self.yaw)")],
               score=3.25, property="yaw as the quaternion z = sin(yaw/2), w = cos(yaw/2)", says="quaternion"),
        Answer("no twist in /odom", replace=[("        out.twist.twist.linear.x, out.twist.twist.angular.z = self.v, self.w\n",
                                              "")],
               score=3.5, property="the twist is the current command", says="report the current command"),
        Answer("an integer publish_rate", replace=[('self.declare_parameter("publish_rate", 50.0)',
                                                    'self.declare_parameter("publish_rate", 50)')],
               property="publish_rate is a float parameter", says="expecting type 'INTEGER'"),
    ])

LED = Exercise(
    "ch03.led_service", NB,
    right=[Answer("a range check and a list", code='''
class LedServer(Node):
    def __init__(self, **kwargs):
        super().__init__("led_server", **kwargs)
        count = self.declare_parameter("led_count", 2).value
        self.leds = {i + 1: False for i in range(count)}
        self.srv = self.create_service(SetLed, "/set_led", self.on_set_led)

    def on_set_led(self, request, response):
        if 1 <= request.led_id <= len(self.leds):
            self.leds[request.led_id] = bool(request.state)
            response.success = True
        else:
            self.get_logger().warning("led %d does not exist" % request.led_id)
            response.success = False
        return response
''')],
    wrong=[
        Answer("always two LEDs", replace=[('n = self.get_parameter("led_count").value', "n = 2")],
               score={"any other id: success=False, no exception, a warning naming it": 1.0},
               property="LEDs 1..led_count", says="read the led_count parameter"),
        Answer("ids from 0", replace=[("range(1, n + 1)", "range(n)")], score=0,
               property="ids count from 1", says="ids count from 1"),
        Answer("raises for an unknown id", code='''
class LedServer(Node):
    def __init__(self, **kwargs):
        super().__init__("led_server", **kwargs)
        self.declare_parameter("led_count", 2)
        self.leds = dict.fromkeys(range(1, self.get_parameter("led_count").value + 1), False)
        self.create_service(SetLed, "/set_led", self.on_set_led)

    def on_set_led(self, request, response):
        if request.led_id not in self.leds:
            raise KeyError(f"no LED {request.led_id}")
        self.leds[request.led_id] = request.state
        response.success = True
        return response
''', score=2.0, property="an unknown id answers success=False, no exception", says="answer success=False instead"),
        Answer("no warning", replace=[('            self.get_logger().warning(f"no LED {request.led_id}: this car has LEDs '
                                       '1..{len(self.leds)}")\n', "            pass\n")],
               score=2.0, property="a warning naming the bad id", says="warning"),
    ])

NAV = Exercise(
    "ch03.navigation_action", NB,
    right=[Answer("phases and a helper per ending", code='''
class NavigationServer(Node):
    def __init__(self, **kwargs):
        super().__init__("navigation_server", **kwargs)
        self.declare_parameter("timeout", 30.0)
        self.xyyaw = None
        self.create_subscription(Odometry, "/odom", self.keep, QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.pub = self.create_publisher(Twist, "/cmd_vel", 10)
        self.server = ActionServer(self, NavigateToPose, "/navigate_to_pose", self.execute,
                                   goal_callback=self.judge, cancel_callback=self.allow)

    def keep(self, msg):
        q = msg.pose.pose.orientation
        self.xyyaw = (msg.pose.pose.position.x, msg.pose.pose.position.y, math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z))

    def judge(self, request):
        p = request.target_pose.pose.position
        if request.target_pose.header.frame_id != "odom" or math.isnan(p.x) or math.isnan(p.y) \\
                or math.isinf(p.x) or math.isinf(p.y):
            self.get_logger().error(f"refusing goal in frame '{request.target_pose.header.frame_id}' at ({p.x}, {p.y})")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def allow(self, request):
        return CancelResponse.ACCEPT

    def stop(self):
        self.pub.publish(Twist())

    async def execute(self, handle):
        goal = handle.request.target_pose.pose.position
        t0 = self.get_clock().now()
        first = None
        while True:
            if handle.is_cancel_requested:
                self.stop()
                handle.canceled()
                return NavigateToPose.Result(success=False, message="canceled")
            if (self.get_clock().now() - t0).nanoseconds / 1e9 > self.get_parameter("timeout").value:
                self.stop()
                handle.abort()
                return NavigateToPose.Result(success=False, message="timeout")
            if self.xyyaw is not None:
                x, y, yaw = self.xyyaw
                d = math.hypot(goal.x - x, goal.y - y)
                first = first or d
                fb = NavigateToPose.Feedback()
                fb.percent_complete = float(max(0.0, min(100.0, 100.0 * (1.0 - d / first))))
                handle.publish_feedback(fb)
                if d < 0.03:
                    self.stop()
                    handle.succeed()
                    return NavigateToPose.Result(success=True, position_error=d, message="there")
                err = math.atan2(math.sin(math.atan2(goal.y - y, goal.x - x) - yaw), math.cos(math.atan2(goal.y - y, goal.x - x) - yaw))
                cmd = Twist()
                cmd.angular.z = max(-1.5, min(1.5, 3.0 * err))
                cmd.linear.x = 0.0 if abs(err) > 0.3 else min(0.25, d)
                self.pub.publish(cmd)
            await self.sleep_async(0.05)
''')],
    wrong=[
        Answer("the default cancel callback", replace=[(", cancel_callback=lambda request: CancelResponse.ACCEPT", "")],
               score=3.0, property="cancel accepted", says="CancelResponse.ACCEPT"),
        Answer("cancel leaves the car running", replace=[(
            'return finish(goal_handle.canceled, success=False, message="cancelled by the client")',
            'goal_handle.canceled()\n                return NavigateToPose.Result(success=False)')],
               score=3.0, property="the car stopped by the server on cancel", says="watchdog is not yours"),
        Answer("accepts any frame", replace=[('if frame != "odom":', 'if False:')],
               score=3.25, property="goals in another frame rejected", says="'map'"),
        Answer("no abort path", replace=[(
            '''            if (self.get_clock().now().nanoseconds - started) * 1e-9 > self.get_parameter("timeout").value:
                return finish(goal_handle.abort, success=False, message="timeout: not there in time")
''', "")],
               score=3.5, property="aborted after the timeout", says="timeout"),
        Answer("feedback counts down", replace=[("100.0 * max(0.0, 1.0 - left / start)", "100.0 * min(1.0, left / start)")],
               score=3.5, property="percent_complete from 0 to 100", says="percent_complete"),
        Answer("success without stopping", replace=[(
            '''return finish(goal_handle.succeed, success=True, message=f"{left * 100:.1f} cm from the goal",
                                  position_error=left)''',
            '''goal_handle.succeed()
                    return NavigateToPose.Result(success=True, position_error=left)''')],
               score=2.75, property="the car stopped on success", says="zero Twist"),
    ])

TELEOP = Exercise(
    "ch03.teleop_node", NB,
    right=[Answer("one timer, a deadline, state in a dict", code='''
KEYS = {"w": (1, 0), "s": (-1, 0), "a": (0, 1), "d": (0, -1), "q": (1, 1), "e": (1, -1), "x": (0, 0)}


class TeleopNode(Node):
    def __init__(self, **kwargs):
        super().__init__("teleop", **kwargs)
        self.declare_parameters("", [("rate_hz", 10.0), ("hold_s", 0.5), ("linear_speed", 0.2),
                                     ("angular_speed", 1.0)])
        self.pub = self.create_publisher(Twist, "/cmd_vel", QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self.state = {"twist": None, "until": None}
        self.create_timer(1.0 / self.get_parameter("rate_hz").value, self.on_timer)

    def press(self, key):
        if key not in KEYS:
            raise ValueError("no such key: " + key)
        msg = Twist()
        msg.linear.x = KEYS[key][0] * self.get_parameter("linear_speed").value
        msg.angular.z = KEYS[key][1] * self.get_parameter("angular_speed").value
        self.pub.publish(msg)
        if key == "x":
            self.state = {"twist": None, "until": None}
        else:
            hold = Duration(seconds=self.get_parameter("hold_s").value)
            self.state = {"twist": msg, "until": self.get_clock().now() + hold}

    def on_timer(self):
        if self.state["twist"] is None:
            return
        if self.get_clock().now() > self.state["until"]:
            self.state = {"twist": None, "until": None}
            self.pub.publish(Twist())
        else:
            self.pub.publish(self.state["twist"])

    def send(self, v, w):
        pass
''', setup="from robocourse.bus import Duration")],
    wrong=[
        Answer("a 10 Hz timer", replace=[('1.0 / self.get_parameter("rate_hz").value', "0.1")],
               score=2.25, property="repeated every 1 / rate_hz", says="repeat it every 1 / rate_hz"),
        Answer("no zero at the end of a hold", replace=[(
            "            self.command = None\n            self.send(0.0, 0.0)", "            self.command = None")],
               score=2.5, property="one zero Twist when a hold ends", says="no zero Twist"),
        Answer("held forever", replace=[("        if self.get_clock().now().nanoseconds > self.until_ns:",
                                         "        if False:")],
               score={"each key's Twist at once, from linear_speed and angular_speed": 0.75,
                      "a new press replaces the command; x stops at once and ends the hold": 0.5,
                      "an unknown key: ValueError naming it, nothing published": 0.25,
                      "the node 'teleop' publishes /cmd_vel RELIABLE": 0.25},
               property="the hold ends after hold_s", says="stop repeating"),
        Answer("x repeats zeros", replace=[('        if key == "x":\n            self.command = None\n            return\n',
                                            "")],
               score=2.5, property="x ends the hold", says="x ends the hold"),
        Answer("an unknown key stops the car", replace=[(
            '            raise ValueError(f"unknown key {key!r}: use one of {\'\'.join(KEYS)}")', '            key = "x"')],
               score=2.75, property="an unknown key raises ValueError", says="raise ValueError"),
        Answer("a and d swapped", replace=[('"a": (0, 1), "d": (0, -1)', '"a": (0, -1), "d": (0, 1)')],
               score=2.25, property="each key's Twist", says="left is +angular.z"),
        Answer("the default speeds", replace=[('lin * self.get_parameter("linear_speed").value', "lin * 0.2")],
               score=2.25, property="speeds from the parameters", says="linear_speed"),
        Answer("BEST_EFFORT", replace=[("reliability=ReliabilityPolicy.RELIABLE", "reliability=ReliabilityPolicy.BEST_EFFORT")],
               property="published RELIABLE", says="RELIABLE"),
    ])

LAUNCH = Exercise(
    "ch03.launch_file", NB,
    right=[Answer("nested namespaces and a loop", code='''
def params_yaml():
    return """
/**:
  ros__parameters:
    use_sim_time: true
mycar:
  sim:
    ros__parameters: {wheel_base: 0.16, wheel_radius: 0.033}
  base_driver:
    ros__parameters:
      wheel_base: 0.16
      wheel_radius: 0.033
      watchdog_timeout: 0.3
      odom_rate_hz: 40.0
      wheel_separation_multiplier: 1.02
  lights:
    ros__parameters: {led_count: 4}
  navigator:
    ros__parameters: {timeout: 15.0, goal_tolerance: 0.03, max_linear: 0.25}
"""


def generate_launch_description():
    use_sim = LaunchConfiguration("use_sim")
    actions = [DeclareLaunchArgument("params_file"), DeclareLaunchArgument("use_sim", default_value="true")]
    for executable, name, extra, condition in (
            ("simulator", "sim", {}, IfCondition(use_sim)),
            ("driver_node", "base_driver", {"driver": "mujoco"}, IfCondition(use_sim)),
            ("driver_node", "base_driver", {"driver": "simulated"}, UnlessCondition(use_sim)),
            ("led_service", "lights", {}, None),
            ("navigation_server", "navigator", {}, None)):
        actions.append(LaunchNode(package="mycar", executable=executable, name=name, namespace="/mycar",
                                  parameters=[LaunchConfiguration("params_file")] + ([extra] if extra else []),
                                  remappings=[("/set_led", "/mycar/set_led")] if name == "lights" else None,
                                  condition=condition))
    return LaunchDescription(actions)
''')],
    wrong=[
        Answer("parameter file keyed without the namespace", replace=[
            ("/mycar/sim:", "sim:"), ("/mycar/base_driver:", "base_driver:"), ("/mycar/lights:", "lights:"),
            ("/mycar/navigator:", "navigator:")],
               score=2.0, property="each value reaches its node", says="keyed by its full name"),
        Answer("the simulator always", replace=[(
            'parameters=[params], condition=IfCondition(use_sim)),', "parameters=[params]),")],
               score=2.25, property="the simulator only when use_sim is true", says="use_sim:=false"),
        Answer("a relative remapping", replace=[('remappings=[("/set_led", "/mycar/set_led")]',
                                                 'remappings=[("set_led", "/mycar/set_led")]')],
               score=2.5, property="/set_led remapped to /mycar/set_led", says="remap the absolute name"),
        Answer("an integer where a double belongs", replace=[("odom_rate_hz: 40.0", "odom_rate_hz: 40")],
               property="doubles written as doubles", says="expecting type 'DOUBLE'"),
        Answer("no namespace", replace=[('car = {"package": "mycar", "namespace": "mycar"}', 'car = {"package": "mycar"}')],
               score=0.5, property="every node in the namespace mycar", says="namespace 'mycar'"),
    ])

QUIZ = Exercise(
    "ch03.quiz", NB,
    right=[Answer("capitals and spaces", replace=[('"wheel encoder ticks at 100 Hz": "topic"',
                                                   '"wheel encoder ticks at 100 Hz": " Topic "')])],
    wrong=[
        Answer("everything a topic", code='''
def quiz_answers():
    features = ["wheel encoder ticks at 100 Hz", "set the maximum speed limit", "drive to the charging dock",
                "camera images", "take one snapshot and return it", "map the whole room", "battery voltage",
                "reset the odometry to zero", "follow a 20-waypoint path", "emergency stop button state"]
    return {f: "topic" for f in features}
''', score=1.0, property="a request with one quick answer is a service", says="reconsider"),
        Answer("services and actions swapped", replace=[('"service"', '"SWAP"'), ('"action"', '"service"'),
                                                        ('"SWAP"', '"action"')],
               score=1.0, property="a long task with feedback is an action", says="reconsider"),
        Answer("the e-stop as a service", replace=[('"emergency stop button state": "topic"',
                                                    '"emergency stop button state": "service"')],
               score=2.25, property="a state everyone must see is a topic", says="emergency stop button state"),
        Answer("a misspelt feature", replace=[('"battery voltage": "topic"', '"battery level": "topic"')],
               score=2.25, property="every feature answered, names as written", says="battery voltage"),
    ])

EXERCISES = [WATCHDOG, DRIVE, LED, NAV, TELEOP, LAUNCH, QUIZ]
