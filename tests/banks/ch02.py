"""Chapter 2's answer bank (solutions/02_pendulum_exercises.ipynb): one wrong answer per stated property."""

from robocourse.grading.bank import Answer, Exercise

NB = "02_pendulum_exercises"

_D_MEASUREMENT = "        d = 0.0 if self.previous is None else -(measurement - self.previous) / dt\n"
_ANTI_WINDUP = ("        pushing_up, pushing_down = u > self.u_max and e > 0, u < self.u_min and e < 0\n"
                "        if not (pushing_up or pushing_down):\n            self.integral = candidate\n")

PID = Exercise(
    "ch02.textbook_pid", NB,
    right=[Answer("state in a dict, saturation tested on the output", code='''
class PID:
    def __init__(self, kp, ki, kd, setpoint=0.0, u_min=-math.inf, u_max=math.inf):
        self.gains = (kp, ki, kd)
        self.setpoint = setpoint
        self.limits = (u_min, u_max)
        self.state = {"sum": 0.0, "last": None}

    def update(self, measurement, dt):
        kp, ki, kd = self.gains
        lo, hi = self.limits
        error = self.setpoint - measurement
        trial = self.state["sum"] + error * dt
        rate = 0.0
        if self.state["last"] is not None:
            rate = (measurement - self.state["last"]) / dt
        self.state["last"] = measurement
        raw = kp * error + ki * trial - kd * rate
        out = hi if raw > hi else lo if raw < lo else raw
        if out == raw or (raw > hi) != (error > 0):
            self.state["sum"] = trial
        return out
''')],
    wrong=[
        Answer("no anti-windup", replace=[(_ANTI_WINDUP, "        self.integral = candidate\n")],
               score={"the law: kp*e + ki*sum(e*dt) - kd*d(measurement)/dt, integral first": 1.0,
                      "no derivative kick when the setpoint jumps": 0.5, "the output clamped to [u_min, u_max]": 0.5},
               property="anti-windup", says="wound up"),
        Answer("derivative of the error", replace=[
            (_D_MEASUREMENT, "        d = 0.0 if self.previous is None else (e - self.previous) / dt\n"),
            ("        self.previous = measurement\n", "        self.previous = e\n")],
               score=2.5, property="the derivative of the measurement (no kick)", says="derivative kick"),
        Answer("derivative with the wrong sign", replace=[
            (_D_MEASUREMENT, "        d = 0.0 if self.previous is None else (measurement - self.previous) / dt\n")],
               score=1.5, property="u = ... - kd * d(measurement)/dt", says="wrong sign"),
        Answer("derivative on the first call", replace=[("        self.previous = None\n", "        self.previous = 0.0\n")],
               score=2.0, property="no derivative on the first call", says="no derivative on the first call"),
        Answer("integral after the output", replace=[
            ("        u = self.kp * e + self.ki * candidate + self.kd * d\n",
             "        u = self.kp * e + self.ki * self.integral + self.kd * d\n")],
               score=2.0, property="the integral is updated before the output", says="integral"),
        Answer("the seed's compounding integral", replace=[
            ("        candidate = self.integral + e * dt\n", "        candidate = self.ki * (self.integral + e * dt)\n"),
            ("        u = self.kp * e + self.ki * candidate + self.kd * d\n",
             "        u = self.kp * e + candidate + self.kd * d\n")],
               score=1.5, property="the integral is a sum of e*dt", says="compounding"),
        Answer("no clamp", replace=[("        return min(self.u_max, max(self.u_min, u))\n", "        return u\n")],
               score=2.5, property="the output clamped to [u_min, u_max]", says="clamp the output"),
        Answer("the library's TextbookPID", code='''
from robocourse.pendulum.pid import TextbookPID


class PID(TextbookPID):
    pass
''', property="written by the student", says="write it yourself"),
    ])

MARGIN = Exercise(
    "ch02.delay_margin", NB,
    right=[Answer("stability_margins", code='''
def delay_margin(loop):
    gm, pm, sm, w_pc, w_gc, w_ms = control.stability_margins(loop)
    return pm * math.pi / 180 / w_gc
''')],
    wrong=[
        Answer("degrees", replace=[("return math.radians(pm_deg) / w_gc", "return pm_deg / w_gc")],
               property="the phase margin in radians", says="convert it to radians first"),
        Answer("the phase crossover", replace=[("return math.radians(pm_deg) / w_gc", "return math.radians(pm_deg) / w_pc")],
               property="divided by the gain crossover", says="phase-crossover frequency"),
        Answer("the crossover in Hz", replace=[("return math.radians(pm_deg) / w_gc",
                                                "return math.radians(pm_deg) / (w_gc / (2 * math.pi))")],
               property="the crossover in rad/s", says="keep it in rad/s"),
        Answer("a product", replace=[("return math.radians(pm_deg) / w_gc", "return math.radians(pm_deg) * w_gc")],
               property="PM / w_c, in seconds", says="not PM * w_c"),
        Answer("the library's analysis.margins", code='''
from robocourse.pendulum import analysis


def delay_margin(loop):
    return analysis.margins(loop)["delay_margin_s"]
''', property="written by the student", says="write it yourself"),
    ])

QOS = Exercise(
    "ch02.qos_choice", NB,
    right=[Answer("presets and KEEP_ALL", code='''
from robocourse.bus import qos_profile_sensor_data


def choose_qos():
    return {
        "battery_state": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                                    durability=DurabilityPolicy.TRANSIENT_LOCAL),  # RELIABLE by default
        "imu": qos_profile_sensor_data,                                            # BEST_EFFORT, depth 5
        "emergency_stop": QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1),     # RELIABLE, VOLATILE
    }
''')],
    wrong=[
        Answer("battery not latched", replace=[(
            "\"battery_state\": QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,\n"
            "                                    durability=DurabilityPolicy.TRANSIENT_LOCAL)",
            "\"battery_state\": QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)")],
               score=1.25, property="battery_state reaches a dashboard started later", says="incompatible"),
        Answer("a reliable imu queue", replace=[(
            "\"imu\": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)",
            "\"imu\": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)")],
               score=1.5, property="imu: newest sample, no retransmission, no queue", says="BEST_EFFORT"),
        Answer("a latched e-stop", replace=[("durability=DurabilityPolicy.VOLATILE)",
                                             "durability=DurabilityPolicy.TRANSIENT_LOCAL)")],
               score=1.25, property="the e-stop is never replayed", says="stale stop"),
        Answer("a best-effort e-stop", replace=[(
            "\"emergency_stop\": QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,",
            "\"emergency_stop\": QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT,")],
               score=1.25, property="the e-stop is never lost", says="must be RELIABLE"),
        Answer("defaults everywhere", code='''
def choose_qos():
    return {topic: QoSProfile(depth=10) for topic in ("battery_state", "imu", "emergency_stop")}
''', score=0.75, property="a QoS chosen per topic", says="incompatible"),
        Answer("a list instead of a dict", code='''
def choose_qos():
    return [QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
            QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT), QoSProfile(depth=10)]
''', property="a dict keyed by topic", says="must return a dict"),
    ])

EXERCISES = [PID, MARGIN, QOS]
