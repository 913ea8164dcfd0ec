"""Chapter 4's wrong-answer bank: for every exercise, plausible wrong answers (one per property the
exercise states, each changing one thing a student gets wrong) and differently written correct answers.

Shared by tests/test_control_checks.py (every entry once, the references on three draws) and
benchmarks/ch04_bank_stability.py (every entry on 20 draws, quiet and under chapter 1's CPU load).
``BANK[check] = [(name, answer, expected_points, fragment), ...]``: ``fragment`` must appear in the
feedback of a wrong answer (the property it breaks); ``None`` for a correct one (expected full marks).
"""

from __future__ import annotations

import math
from pathlib import Path

import nbformat
import numpy as np

from robocourse.control import CallbackReturn, InterfaceConfiguration, return_type
from robocourse.control import interface_configuration_type as ict
from robocourse.control.manager.controller_interface import ControllerInterface

SOL = Path(__file__).resolve().parents[1] / "solutions/04_ros2_control_exercises.ipynb"
ORDER = ["ch04.ros2_control_urdf", "ch04.motor_board", "ch04.controllers_yaml", "ch04.read_error", "ch04.controller",
         "ch04.chainable", "ch04.cubic", "ch04.admittance"]


def solution_namespace() -> dict:
    ns: dict = {}
    for cell in nbformat.read(SOL, as_version=4).cells:
        if cell.cell_type == "code" and cell.source.lstrip().startswith(("def ", "class ", "import ")):
            exec(cell.source.replace("from robocourse.grading import check, score", ""), ns)
    return ns


NS = solution_namespace()
rrbot_ros2_control, BoardSystem, controllers_yaml = NS["rrbot_ros2_control"], NS["BoardSystem"], NS["controllers_yaml"]
after_hardware_error, SlewRateController, JointLimiter = (NS["after_hardware_error"], NS["SlewRateController"],
                                                          NS["JointLimiter"])
cubic_sample, tune_admittance = NS["cubic_sample"], NS["tune_admittance"]
BANK: dict[str, list] = {name: [] for name in ORDER}


def entry(check, expected=0.0, fragment=None, name=None):
    def add(answer):
        BANK[check].append((name or answer.__name__, answer, expected, fragment))
        return answer
    return add


# --- ch04.ros2_control_urdf --------------------------------------------------------------------------------------

def _urdf_edit(name, old, new, fragment):
    def answer(initial_positions):
        text = rrbot_ros2_control(initial_positions)
        assert old in text, old
        return text.replace(old, new)
    answer.__name__ = name
    entry("ch04.ros2_control_urdf", fragment=fragment)(answer)


_urdf_edit("no_initial_value", '<param name="initial_value">', '<param name="start">', "initial_value")
_urdf_edit("no_dynamics", '<param name="calculate_dynamics">true</param>', "", "calculate_dynamics")
_urdf_edit("joint2_takes_position", '<joint name="joint2">', '<joint name="joint2"><command_interface name="position"/>',
           "the driver takes ['velocity']")
_urdf_edit("sensor_names_underscored", "force.x", "force_x", "a force/torque sensor reports")
_urdf_edit("velocity_limits_swapped", '<param name="min">-3</param><param name="max">3</param>',
           '<param name="min">3</param><param name="max">-3</param>', "expected -3 .. 3")
_urdf_edit("an_actuator", 'type="system"', 'type="actuator"', "one system named 'RRBot'")
_urdf_edit("unclosed_sensor", "</sensor>", "", "parser refuses it")
_urdf_edit("no_frame_id", '<param name="frame_id">tool_link</param>', "", "frame_id")


@entry("ch04.ros2_control_urdf", expected=None)
def urdf_written_out(initial_positions):
    j1, j2 = initial_positions["joint1"], initial_positions["joint2"]
    return f"""<ros2_control type="system" name="RRBot">
      <hardware>
        <param name="calculate_dynamics">True</param>
        <plugin>mock_components/GenericSystem</plugin>
      </hardware>
      <joint name="joint1">
        <state_interface name="position"><param name="initial_value">{j1!r}</param></state_interface>
        <state_interface name="velocity"/>
        <command_interface name="velocity"><param name="max">3.0</param><param name="min">-3.0</param></command_interface>
        <command_interface name="position"><param name="max">1.0</param><param name="min">-1.0</param></command_interface>
      </joint>
      <joint name="joint2">
        <command_interface name="velocity"><param name="min">-3</param><param name="max">3</param></command_interface>
        <state_interface name="position"><param name="initial_value">{j2!r}</param></state_interface>
        <state_interface name="velocity"/>
      </joint>
      <sensor name="tool_fts">
        <state_interface name="force.x"/><state_interface name="force.y"/><state_interface name="force.z"/>
        <state_interface name="torque.x"/><state_interface name="torque.y"/><state_interface name="torque.z"/>
        <param name="frame_id">tool_link</param>
      </sensor>
    </ros2_control>"""


# --- ch04.motor_board ----------------------------------------------------------------------------------------------

@entry("ch04.motor_board", fragment="activation jump")
class Forgetful(BoardSystem):
    def on_activate(self, previous_state):
        return CallbackReturn.SUCCESS


@entry("ch04.motor_board", fragment="not swallow it and return OK")
class Swallows(BoardSystem):
    def read(self, time, period):
        self.board.read(time, self.q, self.dq)
        self.state_values[self.p_idx] = self.q
        self.state_values[self.v_idx] = self.dq
        return return_type.OK


@entry("ch04.motor_board", fragment="never raise in the loop")
class Raises(BoardSystem):
    def read(self, time, period):
        if not self.board.read(time, self.q, self.dq):
            raise OSError("board not answering")
        self.state_values[self.p_idx] = self.q
        self.state_values[self.v_idx] = self.dq
        return return_type.OK


@entry("ch04.motor_board", fragment="board.write() returned False) but write() returned OK")
class IgnoresWrite(BoardSystem):
    def write(self, time, period):
        np.take(self.command_values, self.c_idx, out=self.out, mode="clip")
        self.board.write(self.out)
        return return_type.OK


@entry("ch04.motor_board", fragment="must not log")
class Chatty(BoardSystem):
    def write(self, time, period):
        self.get_logger().info("writing targets")
        return super().write(time, period)


@entry("ch04.motor_board", fragment="on_init must compare len(info.joints)")
class Trusting(BoardSystem):
    def on_init(self, info):
        return super(BoardSystem, self).on_init(info)


@entry("ch04.motor_board", fragment="read() must copy")
class NoStates(BoardSystem):
    def read(self, time, period):
        return return_type.OK if self.board.read(time, self.q, self.dq) else return_type.ERROR


@entry("ch04.motor_board", fragment="velocity state interfaces did not follow")
class NoVelocities(BoardSystem):
    def read(self, time, period):
        if not self.board.read(time, self.q, self.dq):
            return return_type.ERROR
        self.state_values[self.p_idx] = self.q
        return return_type.OK


@entry("ch04.motor_board", fragment="read() allocates a buffer every cycle")
class AllocatesInRead(BoardSystem):
    def read(self, time, period):
        q, dq = np.zeros(len(self.q)), np.zeros(len(self.dq))
        if not self.board.read(time, q, dq):
            return return_type.ERROR
        self.state_values[self.p_idx] = q
        self.state_values[self.v_idx] = dq
        return return_type.OK


@entry("ch04.motor_board", fragment="write() allocates a buffer every cycle")
class FancyIndexWrite(BoardSystem):
    def write(self, time, period):
        return return_type.OK if self.board.write(self.command_values[self.c_idx]) else return_type.ERROR


@entry("ch04.motor_board", fragment="every time, not only the first")
class ActivatesOnce(BoardSystem):
    def on_activate(self, previous_state):
        if getattr(self, "_activated", False):
            return CallbackReturn.SUCCESS
        self._activated = True
        return super().on_activate(previous_state)


@entry("ch04.motor_board", expected=None)
class LoopBoard(BoardSystem):
    """Written with Python loops over preallocated storage instead of numpy index arrays."""

    def on_configure(self, previous_state):
        names = [j.name for j in self.info.joints]
        self.slots = [(self.state_index[f"{n}/position"], self.state_index[f"{n}/velocity"],
                       self.command_index[f"{n}/position"]) for n in names]
        self.q, self.dq, self.out = np.zeros(len(names)), np.zeros(len(names)), np.zeros(len(names))
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        if not self.board.read(self.board.time or 0.0, self.q, self.dq):
            return CallbackReturn.ERROR
        for k, (_, _, c) in enumerate(self.slots):
            self.command_values[c] = self.q[k]
        return CallbackReturn.SUCCESS

    def read(self, time, period):
        if not self.board.read(time, self.q, self.dq):
            return return_type.ERROR
        for k, (p, v, _) in enumerate(self.slots):
            self.state_values[p] = self.q[k]
            self.state_values[v] = self.dq[k]
        return return_type.OK

    def write(self, time, period):
        for k, (_, _, c) in enumerate(self.slots):
            self.out[k] = self.command_values[c]
        return return_type.OK if self.board.write(self.out) else return_type.ERROR


# --- ch04.controllers_yaml -------------------------------------------------------------------------------------------

def _yaml_edit(name, old, new, fragment):
    def answer():
        text = controllers_yaml()
        assert old in text, old
        return text.replace(old, new)
    answer.__name__ = name
    entry("ch04.controllers_yaml", fragment=fragment)(answer)


_yaml_edit("rate_100", "update_rate: 200", "update_rate: 100", "update_rate is 100 Hz")
_yaml_edit("type_typo", "joint_trajectory_controller/JointTrajectoryController", "joint_trajectory_controller/JTC",
           "'arm_controller' could not be loaded")
_yaml_edit("wrist_without_joints", "{joints: [joint3]}", "{interface_name: position}", "'wrist_controller' was loaded but ended")
_yaml_edit("negative_goal_time", "goal_time: 1.0", "goal_time: -1.0", "must be")
_yaml_edit("loose_goal", "joint2: {goal: 0.01}", "joint2: {goal: 0.1}", "constraints.joint2.goal is 0.1")
_yaml_edit("no_velocity_state", "state_interfaces: [position, velocity]", "state_interfaces: [position]",
           "state_interfaces ['position']")


@entry("ch04.controllers_yaml", expected=None)
def yaml_block_style():
    return """
# block style, the order of a typical ros2_control_demos file
arm_controller:
  ros__parameters:
    joints:
      - joint1
      - joint2
    command_interfaces:
      - position
    state_interfaces:
      - velocity
      - position
    constraints:
      joint1:
        goal: 0.01
      joint2:
        goal: 0.01
      goal_time: 1.0
wrist_controller:
  ros__parameters:
    joints: [joint3]
controller_manager:
  ros__parameters:
    update_rate: 200  # Hz
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    arm_controller:
      type: joint_trajectory_controller/JointTrajectoryController
    wrist_controller:
      type: position_controllers/JointGroupPositionController
"""


# --- ch04.read_error -------------------------------------------------------------------------------------------------

@entry("ch04.read_error", fragment="command OR state interfaces")
def commands_only(controllers, hardware, failed, stage, result):
    mine = set(hardware[failed])
    hit = [n for n, c in controllers.items() if mine & set(c["command"])]
    return {"deactivated": hit, "hardware_state": "inactive" if result == "DEACTIVATE" else "unconfigured"}


@entry("ch04.read_error", fragment="DEACTIVATE only stops the controllers holding")
def deactivate_like_error(controllers, hardware, failed, stage, result):
    mine = set(hardware[failed])
    hit = [n for n, c in controllers.items() if mine & (set(c["command"]) | set(c["state"]))]
    return {"deactivated": hit, "hardware_state": "inactive" if result == "DEACTIVATE" else "unconfigured"}


@entry("ch04.read_error", fragment="the component ends")
def error_finalizes(controllers, hardware, failed, stage, result):
    ans = after_hardware_error(controllers, hardware, failed, stage, result)
    return {**ans, "hardware_state": "finalized" if result == "ERROR" else ans["hardware_state"]}


@entry("ch04.read_error", fragment="they use no interface of the failed component")
def everyone_stops(controllers, hardware, failed, stage, result):
    return {"deactivated": sorted(controllers), "hardware_state": after_hardware_error(
        controllers, hardware, failed, stage, result)["hardware_state"]}


@entry("ch04.read_error", expected=None)
def read_error_by_loops(controllers, hardware, failed, stage, result):
    stopped = []
    for name, used in controllers.items():
        watched = used["command"] if result == "DEACTIVATE" else used["command"] + used["state"]
        if any(itf in hardware[failed] for itf in watched):
            stopped.append(name)
    return {"deactivated": stopped, "hardware_state": {"DEACTIVATE": "inactive"}.get(result, "unconfigured")}


# --- ch04.controller -------------------------------------------------------------------------------------------------

@entry("ch04.controller", fragment="the activation jump")
class ForgetsState(SlewRateController):
    def on_activate(self, previous_state):
        self.target[:] = self.command
        self.newest = None
        return CallbackReturn.SUCCESS


@entry("ch04.controller", fragment="next to a controller on the other joints")
class ClaimsAll(SlewRateController):
    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.ALL)


@entry("ch04.controller", fragment="in the order of the 'joints' parameter")
class SortedJoints(SlewRateController):
    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [f"{j}/position" for j in sorted(self.params.joints)])

    def state_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [f"{j}/position" for j in sorted(self.params.joints)])


@entry("ch04.controller", fragment="moves every command toward the newest target by at most")
class NoSlew(SlewRateController):
    def update(self, time, period):
        newest, self.newest = self.newest, None
        if newest is not None:
            self.target[:] = newest
        for k, loan in enumerate(self.command_interfaces):
            loan.set_value(self.target[k])
        return return_type.OK


@entry("ch04.controller", fragment="Use the period argument")
class FixedStep(SlewRateController):
    def update(self, time, period):
        return super().update(time, 0.01)


@entry("ch04.controller", fragment="must be ignored")
class TakesNaN(SlewRateController):
    def on_commands(self, msg):
        if len(msg.data) == len(self.target):
            self.newest = np.array(msg.data, dtype=float)


@entry("ch04.controller", fragment="not once in on_configure")
class CopiesOnce(SlewRateController):
    def on_configure(self, previous_state):
        self._copied = False
        return super().on_configure(previous_state)

    def on_activate(self, previous_state):
        if not self._copied:
            self._copied = True
            return super().on_activate(previous_state)
        return CallbackReturn.SUCCESS


@entry("ch04.controller", fragment="update() allocates a buffer every cycle")
class AllocatingUpdate(SlewRateController):
    def update(self, time, period):
        newest, self.newest = self.newest, None
        if newest is not None:
            self.target[:] = newest
        limit = self.params.max_velocity * period
        self.command = self.command + np.clip(self.target - self.command, -limit, limit)
        for k, loan in enumerate(self.command_interfaces):
            loan.set_value(self.command[k])
        return return_type.OK


@entry("ch04.controller", expected=None)
class SlewWithLoops(ControllerInterface):
    """Written without numpy: plain floats per joint, a list as the hand-over from the callback."""

    PARAMS = SlewRateController.PARAMS

    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [j + "/position" for j in self.params.joints])

    state_interface_configuration = command_interface_configuration

    def on_configure(self, previous_state):
        from robocourse.msgs.std_msgs import Float64MultiArray

        self.cmd = [0.0] * len(self.params.joints)
        self.goal = [0.0] * len(self.params.joints)
        self.mailbox = []
        if self._node is None:
            self.get_node().create_subscription(Float64MultiArray, "~/commands", self.receive, 10)
        return CallbackReturn.SUCCESS

    def receive(self, msg):
        values = [float(v) for v in msg.data]
        if len(values) == len(self.goal) and not any(math.isnan(v) or math.isinf(v) for v in values):
            self.mailbox = values

    def on_activate(self, previous_state):
        for i, loan in enumerate(self.state_interfaces):
            self.cmd[i] = self.goal[i] = float(loan.get_value())
        self.mailbox = []
        return CallbackReturn.SUCCESS

    def update(self, time, period):
        box = self.mailbox
        if box:
            self.mailbox = []
            for i, v in enumerate(box):
                self.goal[i] = v
        limit = self.params.max_velocity * period
        for i, loan in enumerate(self.command_interfaces):
            d = self.goal[i] - self.cmd[i]
            self.cmd[i] += limit if d > limit else (-limit if d < -limit else d)
            loan.set_value(self.cmd[i])
        return return_type.OK


# --- ch04.chainable --------------------------------------------------------------------------------------------------

@entry("ch04.chainable", fragment="ramp at max_velocity")
class ClampOnly(JointLimiter):
    def update_and_write_commands(self, time, period):
        np.copyto(self.wanted, self.reference_interfaces)
        np.copyto(self.wanted, self.command, where=~np.isfinite(self.wanted))
        np.clip(self.wanted, self.lo, self.hi, out=self.command)
        for k, loan in enumerate(self.command_interfaces):
            loan.set_value(self.command[k])
        return return_type.OK


@entry("ch04.chainable", fragment="ramp at max_velocity")
class FixedPeriod(JointLimiter):
    def update_and_write_commands(self, time, period):
        return super().update_and_write_commands(time, 0.01)


@entry("ch04.chainable", fragment="a NaN reference: that joint holds")
class PassesNaN(JointLimiter):
    def update_and_write_commands(self, time, period):
        step = self.params.max_velocity * period
        np.clip(self.reference_interfaces, self.lo, self.hi, out=self.wanted)
        np.subtract(self.wanted, self.command, out=self.wanted)
        np.clip(self.wanted, -step, step, out=self.wanted)
        np.add(self.command, self.wanted, out=self.command)
        for k, loan in enumerate(self.command_interfaces):
            loan.set_value(self.command[k])
        return return_type.OK


@entry("ch04.chainable", fragment="activated before any reference was written")
class StartsAtZero(JointLimiter):
    def on_activate(self, previous_state):
        return CallbackReturn.SUCCESS


@entry("ch04.chainable", fragment="the manager adds the controller's name")
class PrefixedNames(JointLimiter):
    def on_export_reference_interfaces(self):
        return [f"{self.name}/{j}/position" for j in self.params.joints]


@entry("ch04.chainable", fragment="on_set_chained_mode must accept")
class RefusesChaining(JointLimiter):
    def on_set_chained_mode(self, chained_mode):
        return False


@entry("ch04.chainable", fragment="clamp each reference to [min_position, max_position]")
class NoPositionLimits(JointLimiter):
    def on_configure(self, previous_state):
        ret = super().on_configure(previous_state)
        self.lo[:], self.hi[:] = -np.inf, np.inf
        return ret


@entry("ch04.chainable", fragment="update() allocates a buffer every cycle")
class AllocatingLimiter(JointLimiter):
    def update_and_write_commands(self, time, period):
        step = self.params.max_velocity * period
        wanted = np.where(np.isfinite(self.reference_interfaces), self.reference_interfaces, self.command)
        self.command = self.command + np.clip(np.clip(wanted, self.lo, self.hi) - self.command, -step, step)
        for k, loan in enumerate(self.command_interfaces):
            loan.set_value(self.command[k])
        return return_type.OK


@entry("ch04.chainable", expected=None)
class LimiterWithLoops(JointLimiter):
    """Per joint with Python floats (min/max first, then the rate), no numpy in the loop."""

    def on_configure(self, previous_state):
        p = self.params
        if len(p.min_position) != len(p.joints) or len(p.max_position) != len(p.joints):
            return CallbackReturn.ERROR
        self.bounds = list(zip(p.min_position, p.max_position))
        self.out = [0.0] * len(p.joints)
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        for i, loan in enumerate(self.state_interfaces):
            self.out[i] = float(loan.get_value())
            self.reference_interfaces[i] = self.out[i]
        return CallbackReturn.SUCCESS

    def update_and_write_commands(self, time, period):
        step = self.params.max_velocity * period
        for i, loan in enumerate(self.command_interfaces):
            ref = self.reference_interfaces[i]
            if ref == ref:                               # not NaN
                lo, hi = self.bounds[i]
                goal = min(max(float(ref), lo), hi)
                self.out[i] += min(max(goal - self.out[i], -step), step)
            loan.set_value(self.out[i])
        return return_type.OK


# --- ch04.cubic ------------------------------------------------------------------------------------------------------

@entry("ch04.cubic", fragment="position")
def wrong_a3(p0, v0, p1, v1, T, t):
    p, v, a = cubic_sample(p0, v0, p1, v1, T, t)
    err = (np.asarray(v0) * T) / T**3
    return p - err * t**3, v - 3 * err * t**2, a - 6 * err * t


@entry("ch04.cubic", fragment="acceleration wrong")
def no_acceleration(p0, v0, p1, v1, T, t):
    p, v, _ = cubic_sample(p0, v0, p1, v1, T, t)
    return p, v, np.zeros_like(p)


@entry("ch04.cubic", fragment="one value per joint")
def first_joint_only(p0, v0, p1, v1, T, t):
    p, v, a = cubic_sample(p0, v0, p1, v1, T, t)
    return float(p[0]), float(v[0]), float(a[0])


@entry("ch04.cubic", fragment="wrong")
def linear(p0, v0, p1, v1, T, t):
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    return p0 + (p1 - p0) * t / T, (p1 - p0) / T, np.zeros_like(p0)


@entry("ch04.cubic", fragment="q'(0) = v0")
def velocities_swapped(p0, v0, p1, v1, T, t):
    return cubic_sample(p0, v1, p1, v0, T, t)


@entry("ch04.cubic", expected=None)
def hermite(p0, v0, p1, v1, T, t):
    s = t / T                                      # the Hermite basis on [0, 1]
    h = np.array([2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2])
    dh = np.array([6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s]) / T
    ddh = np.array([12 * s - 6, 6 * s - 4, -12 * s + 6, 6 * s - 2]) / T**2
    cols = np.array([np.asarray(p0, float), np.asarray(v0, float) * T, np.asarray(p1, float), np.asarray(v1, float) * T])
    return h @ cols, dh @ cols, ddh @ cols


# --- ch04.admittance -------------------------------------------------------------------------------------------------

def _tuning(name, zeta=1.0, multiple=5.8335, spring=lambda f, x: f / x, damping=None, mass=None, speed=1.0,
            fragment=""):
    def answer(force, deflection, settle):
        k = spring(force, deflection)
        m = mass if mass is not None else k * (settle * speed / multiple) ** 2
        d = damping(m, k, zeta) if damping else 2 * zeta * math.sqrt(m * k)
        return {"mass": m, "stiffness": k, "damping_ratio": zeta, "damping": d}
    answer.__name__ = name
    entry("ch04.admittance", fragment=fragment)(answer)


_tuning("slightly_underdamped", zeta=0.95, fragment="overshoots the rest point")
_tuning("spring_times_deflection", spring=lambda f, x: f * x, fragment="F / K")
_tuning("rule_of_thumb_4", multiple=4.0, fragment="later than")
_tuning("unit_mass", mass=1.0, fragment="settles after")
_tuning("damping_without_mass", damping=lambda m, k, z: 2 * z * math.sqrt(k / m), fragment="D = 2 zeta sqrt(M K)")
_tuning("overdamped", zeta=1.5, fragment="later than")
_tuning("too_fast", speed=0.6, fragment="sooner than")


@entry("ch04.admittance", expected=None)
def tuned_by_newton(force, deflection, settle):
    u = 6.0                                         # (1 + u) e^-u = 0.02 by Newton's method
    for _ in range(50):
        u -= ((1 + u) * math.exp(-u) - 0.02) / (-u * math.exp(-u))
    stiffness = force / deflection
    mass = stiffness * settle**2 / u**2
    return {"stiffness": stiffness, "mass": mass, "damping_ratio": 1.0, "damping": 2.0 * math.sqrt(mass * stiffness)}


@entry("ch04.admittance", expected=None)
def slightly_overdamped(force, deflection, settle):
    """zeta 1.05 with the mass that settles in the time asked, the overdamped closed form solved numerically."""
    from scipy.optimize import brentq

    zeta, k = 1.05, force / deflection
    r = math.sqrt(zeta**2 - 1)

    def error(u):                   # |x / x_rest - 1| at w t = u, overdamped: two real poles
        a, b = -(zeta - r), -(zeta + r)
        return abs((b * math.exp(a * u) - a * math.exp(b * u)) / (a - b))

    u = brentq(lambda u: error(u) - 0.02, 1.0, 40.0)           # monotone for zeta >= 1
    mass = k * (0.97 * settle / u) ** 2
    return {"mass": mass, "stiffness": k, "damping_ratio": zeta, "damping": 2 * zeta * math.sqrt(mass * k)}


def references() -> dict:
    return {"ch04.ros2_control_urdf": rrbot_ros2_control, "ch04.motor_board": BoardSystem,
            "ch04.controllers_yaml": controllers_yaml, "ch04.read_error": after_hardware_error,
            "ch04.controller": SlewRateController, "ch04.chainable": JointLimiter, "ch04.cubic": cubic_sample,
            "ch04.admittance": tune_admittance}
