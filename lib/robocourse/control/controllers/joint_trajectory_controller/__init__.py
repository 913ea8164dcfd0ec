"""JointTrajectoryController (ros2_controllers' joint_trajectory_controller).

Counterpart: ``joint_trajectory_controller::JointTrajectoryController`` (newest upstream, see
shared/reference/ros2_control.md section 1). Trajectories arrive on ``~/joint_trajectory``
(trajectory_msgs/JointTrajectory) or as ``~/follow_joint_trajectory`` goals
(control_msgs/FollowJointTrajectory, feedback desired/actual/error); they are validated with
upstream's rules and texts, re-ordered to the controller's joint order (partial goals filled
with the held position when ``allow_partial_joints_goal``), and sampled with linear / cubic /
quintic splines (:mod:`.trajectory`). Like jazzy and later, the reference is sampled at the
trajectory time and the command one controller period ahead. Command interface sets: position,
position+velocity, position+velocity+acceleration, position+effort, velocity, effort; velocity-
or effort-only (without position) close the loop with a per-joint PID (``gains.<joint>.*``).
Path/goal tolerances, goal_time, stopped_velocity_tolerance and cmd_timeout as upstream (a goal
with an illegal tolerance, a negative other than -1 or an unknown joint, runs with the
controller's defaults and an error in the log); the action result codes and strings are
upstream's. On deactivate the active goal is aborted, position commands stay where they are and
velocity / acceleration / effort commands become 0. ``~/controller_state`` publishes reference,
feedback, error and output each update.

Differences: the action goal is finished by a timer at ``action_monitor_rate`` on the
controller's node (upstream's goal handle timer) so a result can lag the cycle that decided it
by up to one monitor period, as upstream's does; ``~/controller_state`` is skipped while nobody
subscribes (saves the message build in the real-time loop); ``command_joints`` must name as
many joints as ``joints`` (upstream also maps a shorter list); no speed scaling, no
``allow_trajectory_replacement`` blending (rolling's new default), no ``decelerate_on_cancel``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robocourse.bus.action import ActionServer, CancelResponse, GoalResponse
from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...manager.loaned import InterfaceGroup
from ...msgs import FollowJointTrajectory, JointTrajectoryControllerState
from ...parameters import ParameterSchema
from ..control_toolbox import Pid
from ..realtime_goal import GoalMonitor
from .trajectory import Sample, Trajectory

_HERE = Path(__file__).parent
FLT_EPSILON = 1.1920928955078125e-07
Result = FollowJointTrajectory.Result

_ALLOWED_COMMANDS = ({"position"}, {"position", "velocity"}, {"position", "velocity", "acceleration"},
                     {"position", "effort"}, {"velocity"}, {"effort"})


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def _stamp(t: float):
    from robocourse.msgs.builtin_interfaces import Time

    ns = int(round(t * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class _Tolerances:
    """Per-joint state (path) and goal tolerances, goal_time (upstream's SegmentTolerances)."""

    def __init__(self, dof: int):
        self.state_position = np.zeros(dof)
        self.state_velocity = np.zeros(dof)
        self.state_acceleration = np.zeros(dof)
        self.goal_position = np.zeros(dof)
        self.goal_velocity = np.zeros(dof)
        self.goal_acceleration = np.zeros(dof)
        self.goal_time = 0.0
        self.seal()

    def seal(self) -> None:
        """Note which tolerance vectors check anything (the real-time side skips the rest)."""
        self.state_checks = [(f, t) for f, t in (("positions", self.state_position), ("velocities", self.state_velocity),
                                                 ("accelerations", self.state_acceleration)) if t.any()]
        self.goal_checks = [(f, t) for f, t in (("positions", self.goal_position), ("velocities", self.goal_velocity),
                                                ("accelerations", self.goal_acceleration)) if t.any()]

    def copy(self) -> _Tolerances:
        out = _Tolerances(len(self.state_position))
        for k, v in vars(self).items():
            if isinstance(v, np.ndarray):
                setattr(out, k, v.copy())
            elif not isinstance(v, list):
                setattr(out, k, v)
        out.seal()
        return out


def _violates(err, checks) -> bool:
    """check_state_tolerance_per_joint for all joints: a tolerance of 0 is not checked."""
    for field, tol in checks:
        e = getattr(err, field)
        if np.any((np.abs(e) > tol) & (tol > 0.0)):
            return True
    return False


class JointTrajectoryController(ControllerInterface):
    """``joint_trajectory_controller/JointTrajectoryController``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("parameters.yaml").read_text())

    def __init__(self):
        super().__init__()
        self.dof = 0
        self._joints: list[str] = []
        self._traj: Trajectory | None = None
        self._new_traj: Trajectory | None = None   # the real-time buffer a callback writes
        self._hold_requested = False
        self._is_holding = False
        self.goals = GoalMonitor(self._feedback)
        self.subscriber_is_active = False
        self.use_closed_loop_pid = False
        self._action_server = None
        self._state_pub = None
        self.rejections: list[str] = []              # why each incoming trajectory/goal was refused

    # --- configuration -------------------------------------------------------------------------------
    def on_init(self):
        p = self.params
        cmd, state = list(p.command_interfaces), list(p.state_interfaces)
        if set(cmd) not in _ALLOWED_COMMANDS:
            self.get_logger().error(f"Invalid combination of command interfaces {cmd}: allowed are position, "
                                    "position+velocity, position+velocity+acceleration, position+effort, velocity, "
                                    "effort (e.g. command_interfaces: [position, velocity])")
            return CallbackReturn.ERROR
        if "position" not in state or ("acceleration" in state and "velocity" not in state):
            self.get_logger().error(f"Invalid combination of state interfaces {state}: 'position' is required and "
                                    "'acceleration' needs 'velocity' (e.g. state_interfaces: [position, velocity])")
            return CallbackReturn.ERROR
        return CallbackReturn.SUCCESS

    def on_configure(self, previous_state):
        p = self.params
        self._joints = list(p.joints)
        self.dof = len(self._joints)
        cmd_joints = list(p.command_joints) or self._joints
        if len(cmd_joints) != self.dof:
            self.get_logger().error(f"'command_joints' ({len(cmd_joints)}) must name as many joints as 'joints' "
                                    f"({self.dof}) or be empty")
            return CallbackReturn.ERROR
        self._command_joints = cmd_joints
        self._cmd_ifaces = list(p.command_interfaces)
        self._state_ifaces = list(p.state_interfaces)
        self.has_velocity_state = "velocity" in self._state_ifaces
        self.has_acceleration_state = "acceleration" in self._state_ifaces
        cmd = set(self._cmd_ifaces)
        self.use_closed_loop_pid = cmd == {"velocity"} or ("effort" in cmd and "position" not in cmd)
        if (cmd == {"velocity"} or cmd == {"effort"} or cmd == {"position", "effort"}) and not self.has_velocity_state:
            self.get_logger().error(f"'{'+'.join(self._cmd_ifaces)}' command interfaces need the 'velocity' state "
                                    "interface (add velocity to state_interfaces)")
            return CallbackReturn.ERROR
        dof = self.dof
        self.state_current, self.state_desired = Sample(dof), Sample(dof)
        self.command_next, self.state_error = Sample(dof), Sample(dof)
        self.last_commanded = Sample(dof)
        self.last_commanded_time = 0.0
        self._traj_time = 0.0
        self.interpolate = p.interpolation_method == "splines"
        self._wrap = np.array([p.gains.get_entry(j).angle_wraparound for j in self._joints], dtype=bool)
        self._read_dynamic_params()
        self.pid = Pid(*self._gains()) if self.use_closed_loop_pid else None
        self._tmp = np.zeros(dof)
        self.active_tolerances = self.default_tolerances.copy()
        if self._node is None:
            node = self.get_node()
            node.create_subscription(JointTrajectory, "~/joint_trajectory", self._topic_callback, 10)
            self._state_pub = node.create_publisher(JointTrajectoryControllerState, "~/controller_state", 10)
            self._action_server = ActionServer(
                node, FollowJointTrajectory, "~/follow_joint_trajectory", self._execute,
                goal_callback=self._goal_received, handle_accepted_callback=self._goal_accepted,
                cancel_callback=self._goal_cancelled)
            node.create_timer(1.0 / p.action_monitor_rate, self._monitor_goal)
        return CallbackReturn.SUCCESS

    def _gains(self):
        g = [self.params.gains.get_entry(j) for j in self._joints]
        return ([x.p for x in g], [x.i for x in g], [x.d for x in g], [x.i_clamp for x in g])

    def _read_dynamic_params(self) -> None:
        """Tolerances, goal_time and gains from the parameters (dynamic, like upstream)."""
        p = self.params
        tol = _Tolerances(self.dof)
        c = p.constraints
        tol.state_position[:] = [c.get_entry(j).trajectory for j in self._joints]
        tol.goal_position[:] = [c.get_entry(j).goal for j in self._joints]
        tol.goal_velocity[:] = c.stopped_velocity_tolerance
        tol.goal_time = c.goal_time
        tol.seal()
        self.default_tolerances = tol
        self.ff_velocity_scale = np.array([p.gains.get_entry(j).ff_velocity_scale for j in self._joints])
        self.cmd_timeout = p.cmd_timeout
        if self.cmd_timeout > 0.0 and self.cmd_timeout <= tol.goal_time:
            self.get_logger().warning("Command timeout must be higher than goal_time tolerance "
                                      f"({self.cmd_timeout} vs. {tol.goal_time}); cmd_timeout disabled")
            self.cmd_timeout = 0.0

    def command_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{j}/{i}" for i in self._cmd_ifaces for j in self._command_joints])

    def state_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{j}/{i}" for i in self._state_ifaces for j in self._joints])

    # --- lifecycle ----------------------------------------------------------------------------------
    def on_activate(self, previous_state):
        dof = self.dof
        self.update_period = 1.0 / self.update_rate   # the rate the manager settled on at configure
        self._cmd = {iface: InterfaceGroup(self.command_interfaces[k * dof:(k + 1) * dof])
                     for k, iface in enumerate(self._cmd_ifaces)}
        self._state = {iface: InterfaceGroup(self.state_interfaces[k * dof:(k + 1) * dof])
                       for k, iface in enumerate(self._state_ifaces)}
        self._read_state(self.state_current)
        self.last_commanded.copy_from(self.state_current)
        self.state_desired.copy_from(self.state_current)
        if self.params.set_last_command_interface_value_as_state_on_activation and "position" in self._cmd:
            last = self._cmd["position"].get()
            if np.all(np.isfinite(last)):
                self.state_current.positions[:] = last
                self.last_commanded.positions[:] = last
        if self.pid is not None:
            self.pid.reset()
        self._traj = None
        self._new_traj = self._hold_trajectory()
        self._hold_requested = False
        self._is_holding = True
        self.subscriber_is_active = True
        self.last_commanded_time = 0.0
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state):
        self.goals.finish("abort", Result(error_code=Result.INVALID_GOAL,
                                          error_string="Current goal cancelled during deactivate transition."))
        # upstream writes each position command back to itself (it stays where the last
        # update() left it) and zeroes velocity, acceleration and effort commands
        for iface in ("velocity", "acceleration", "effort"):
            if iface in self._cmd:
                self._cmd[iface].set(np.zeros(self.dof))
        self.subscriber_is_active = False
        self._traj = self._new_traj = None
        return CallbackReturn.SUCCESS

    # --- real-time side ---------------------------------------------------------------------------------
    def _read_state(self, out: Sample) -> None:
        st = self._state
        st["position"].get(out=out.positions)
        if self.has_velocity_state:
            st["velocity"].get(out=out.velocities)
        if self.has_acceleration_state:
            st["acceleration"].get(out=out.accelerations)
        out.has_velocities = self.has_velocity_state
        out.has_accelerations = self.has_acceleration_state

    def _hold_trajectory(self) -> Trajectory:
        """set_hold_position(): one point at the current position, zero velocity and acceleration."""
        z = np.zeros((1, self.dof))
        return Trajectory([0.0], self.state_current.positions.reshape(1, -1).copy(), z, z.copy())

    def _hold(self) -> None:
        """Hold position from the next update on, at the state that update reads."""
        self._hold_requested = True
        self._is_holding = True

    def update(self, time, period):
        if self.param_listener.try_update_params(self.params):
            self._read_dynamic_params()
            if self.goals.active is None:
                self.active_tolerances = self.default_tolerances.copy()
            if self.pid is not None:
                self.pid.set_gains(*self._gains())
        self._read_state(self.state_current)
        if self._hold_requested:
            self._hold_requested = False
            self._new_traj = None
            self._traj = self._hold_trajectory()
        else:
            new = self._new_traj
            if new is not None:
                self._new_traj = None
                self._traj = new
        traj = self._traj
        if traj is None:
            return return_type.OK
        first_sample = False
        if not traj.sampled_already:
            first_sample = True
            if not self.params.interpolate_from_desired_state or self.last_commanded_time == 0.0:
                self.last_commanded.copy_from(self.state_current)
            self.last_commanded_time = time
            traj.set_point_before_trajectory(time, self.last_commanded)
            self._traj_time = time
        else:
            self._traj_time += period
        t = self._traj_time
        idx = traj.sample(t, self.state_desired, self.interpolate)
        if idx < 0:
            return return_type.OK
        traj.sample(t + self.update_period, self.command_next, self.interpolate)
        n = len(traj)
        before_last_point = idx < n
        seg = 0 if idx == 0 else idx - 1
        time_difference = t - (traj.start_time + traj.times[min(seg, n - 1)])
        holding = self._is_holding
        if not before_last_point and not holding and self.cmd_timeout > 0.0 and time_difference > self.cmd_timeout:
            self.get_logger().warning("Aborted due to command timeout")
            self._hold()
        err = self.state_error
        cur, des = self.state_current, self.state_desired
        np.subtract(des.positions, cur.positions, out=err.positions)
        if self._wrap.any():
            wrapped = np.remainder(err.positions + math.pi, 2 * math.pi) - math.pi
            np.copyto(err.positions, wrapped, where=self._wrap)
        if self.has_velocity_state:
            np.subtract(des.velocities, cur.velocities, out=err.velocities)
        else:
            err.velocities.fill(0.0)
        if self.has_acceleration_state:
            np.subtract(des.accelerations, cur.accelerations, out=err.accelerations)
        else:
            err.accelerations.fill(0.0)
        tol = self.active_tolerances
        violated = outside_goal = False
        within_goal_time = True
        if not holding:
            if before_last_point or first_sample:
                violated = _violates(err, tol.state_checks)
            if not before_last_point:
                outside_goal = _violates(err, tol.goal_checks)
                if outside_goal and tol.goal_time > 0.0 and time_difference > tol.goal_time:
                    within_goal_time = False
        self._write_commands(period)
        self.last_commanded.copy_from(self.command_next)
        self.last_commanded_time = time
        goal = self.goals.active
        if goal is not None:
            goal.feedback_due = (t, idx)
            if violated:
                self.get_logger().warning("Aborted due to state tolerance violation")
                self._finish_goal(goal, "abort", Result.PATH_TOLERANCE_VIOLATED,
                                  "Aborted due to path tolerance violation")
                self._hold()
            elif not before_last_point:
                if not outside_goal:
                    self.get_logger().info("Goal reached, success!")
                    self._finish_goal(goal, "succeed", Result.SUCCESSFUL, "Goal successfully reached!")
                elif not within_goal_time:
                    msg = f"Aborted due to goal_time_tolerance exceeding by {time_difference:f} seconds"
                    self.get_logger().warning(msg)
                    self._finish_goal(goal, "abort", Result.GOAL_TOLERANCE_VIOLATED, msg)
                    self._hold()
        elif violated and not holding:
            self.get_logger().error("Holding position due to state tolerance violation")
            self._hold()
        elif not before_last_point and not within_goal_time and not holding:
            self.get_logger().error("Exceeded goal_time_tolerance: holding position...")
            self._hold()
        pub = self._state_pub
        if pub is not None and pub.get_subscription_count():
            self._publish_state(time)
        return return_type.OK

    def _write_commands(self, period: float) -> None:
        c, cmd = self.command_next, self._cmd
        if self.use_closed_loop_pid:
            out = self.pid.compute_command(self.state_error.positions, self.state_error.velocities, period)
            np.multiply(c.velocities, self.ff_velocity_scale, out=self._tmp)
            self._tmp += out
            cmd["velocity" if "velocity" in cmd else "effort"].set(self._tmp)
            return
        if "position" in cmd:
            cmd["position"].set(c.positions)
        if "velocity" in cmd:
            cmd["velocity"].set(c.velocities)
        if "acceleration" in cmd:
            cmd["acceleration"].set(c.accelerations)
        if "effort" in cmd:
            cmd["effort"].set(c.effort)

    def _finish_goal(self, goal, how: str, code: int, text: str) -> None:
        self.goals.finish(how, Result(error_code=code, error_string=text))
        self.active_tolerances = self.default_tolerances.copy()

    def _point(self, s: Sample) -> JointTrajectoryPoint:
        return JointTrajectoryPoint(positions=s.positions.tolist(), velocities=s.velocities.tolist(),
                                    accelerations=s.accelerations.tolist())

    def _publish_state(self, time: float) -> None:
        msg = JointTrajectoryControllerState(joint_names=list(self._joints), reference=self._point(self.state_desired),
                                             feedback=self._point(self.state_current),
                                             error=self._point(self.state_error),
                                             output=self._point(self.command_next), speed_scaling_factor=1.0)
        msg.header.stamp = _stamp(time)
        self._state_pub.publish(msg)

    # --- non-real-time side: validation, topic, action ------------------------------------------------
    def validate_trajectory_msg(self, traj) -> str | None:
        """upstream's validate_trajectory_msg(): None if valid, else the (logged) reason."""
        names = list(traj.joint_names)
        if not self.params.allow_partial_joints_goal and len(names) != self.dof:
            return "Joints on incoming trajectory don't match the controller joints."
        if not names:
            return "Empty joint names on incoming trajectory."
        if not traj.points:
            return "Empty trajectory received."
        for name in names:
            if name not in self._joints:
                return f"Incoming joint {name} doesn't match the controller's joints."
        if len(set(names)) != len(names):
            return f"Incoming trajectory names a joint twice: {names}"
        last = traj.points[-1]
        if not self.params.allow_nonzero_velocity_at_trajectory_end:
            for name, v in zip(names, last.velocities):
                if abs(v) > FLT_EPSILON:
                    return f"Velocity of last trajectory point of joint {name} is not zero: {v:.15f}"
        start = _seconds(traj.header.stamp)
        end = start + _seconds(last.time_from_start)
        if start != 0.0 and end < self.get_node().get_clock().now().nanoseconds * 1e-9:
            return f"Received trajectory with non-zero start time ({start:f}) that ends in the past ({end:f})"
        for i in range(1, len(traj.points)):
            a, b = _seconds(traj.points[i - 1].time_from_start), _seconds(traj.points[i].time_from_start)
            if b <= a:
                return (f"Time between points {i - 1} and {i} is not strictly increasing, it is {a:f} and {b:f} "
                        "respectively")
        n = len(names)
        for i, pt in enumerate(traj.points):
            for field in ("positions", "velocities", "accelerations", "effort"):
                values = getattr(pt, field)
                if (field == "positions" or values) and len(values) != n:
                    return (f"Mismatch between joint_names size ({n}) and {field} ({len(values)}) at point "
                            f"#{i}.")
                if not all(math.isfinite(v) for v in values):
                    return f"Non-finite value in {field} at point #{i}: {list(values)} (every value must be finite)"
            if pt.effort and "effort" not in self._cmd_ifaces:
                return ("Trajectories with effort fields are only supported for controllers using the 'effort' "
                        "command interface.")
        return None

    def _reject(self, why: str) -> None:
        self.rejections.append(why)
        self.get_logger().error(why)

    def _to_trajectory(self, msg) -> Trajectory:
        """Sort the message's joints to the controller's order; fill missing joints with the held position."""
        order = [list(msg.joint_names).index(j) if j in msg.joint_names else -1 for j in self._joints]
        pts = msg.points
        times = [_seconds(p.time_from_start) for p in pts]
        hold = self.last_commanded.positions if self.last_commanded_time else self.state_current.positions

        def table(field, fill):
            if not all(getattr(p, field) for p in pts):
                return None
            out = np.empty((len(pts), self.dof))
            for r, p in enumerate(pts):
                vals = getattr(p, field)
                out[r] = [vals[k] if k >= 0 else fill[c] for c, k in enumerate(order)]
            return out

        zeros = np.zeros(self.dof)
        return Trajectory(times, table("positions", hold), table("velocities", zeros),
                          table("accelerations", zeros), table("effort", zeros), _seconds(msg.header.stamp))

    def _topic_callback(self, msg) -> None:
        why = self.validate_trajectory_msg(msg)
        if why is not None:
            self._reject(why)
            return
        if not self.subscriber_is_active:
            self._reject("Can't accept new commands. subscriber is inactive")
            return
        self._new_traj = self._to_trajectory(msg)
        self._hold_requested = False
        self._is_holding = False

    def _goal_tolerances(self, goal) -> _Tolerances:
        """get_segment_tolerances(): the goal's path/goal tolerances over the defaults.

        As upstream (tolerances.hpp ``resolve_tolerance_source``): > 0 replaces the default, 0
        keeps it, -1 erases it (not checked); any other negative value, or a joint the controller
        does not have, is logged and the whole goal runs with the controller's defaults (the goal
        is not rejected)."""
        default = self.default_tolerances
        tol = default.copy()
        log = self.get_logger()

        def resolve(default_value: float, value: float) -> float:
            if value > 0.0:
                return value
            if abs(value + 1.0) < 1.1920929e-07:     # FLT_EPSILON, as upstream
                return 0.0
            if value < 0.0:
                raise ValueError(value)
            return default_value

        try:
            tol.goal_time = resolve(default.goal_time, _seconds(goal.goal_time_tolerance))
        except ValueError:
            log.error(f"Specified illegal goal_time_tolerance: {_seconds(goal.goal_time_tolerance):f}. "
                      "Using default tolerances")
            return default.copy()
        for kind, where, entries in (("state", "path_tolerance", goal.path_tolerance),
                                     ("goal", "goal_tolerance", goal.goal_tolerance)):
            for jt in entries:
                if jt.name not in self._joints:
                    log.error(f"joint '{jt.name}' specified in goal.{where} does not exist. Using default tolerances.")
                    return default.copy()
                k = self._joints.index(jt.name)
                for field in ("position", "velocity", "acceleration"):
                    arr = getattr(tol, f"{kind}_{field}")
                    try:
                        arr[k] = resolve(arr[k], getattr(jt, field))
                    except ValueError:
                        log.error(f"joint '{jt.name}' specified in goal.{where} has a invalid {field} tolerance. "
                                  "Using default tolerances.")
                        return default.copy()
        tol.seal()
        return tol

    def _goal_received(self, goal):
        self.get_logger().info("Received new action goal")
        if not self.subscriber_is_active:
            self._reject("Can't accept new action goals. Controller is not running.")
            return GoalResponse.REJECT
        why = self.validate_trajectory_msg(goal.trajectory)
        if why is not None:
            self._reject(why)
            return GoalResponse.REJECT
        self.get_logger().info("Accepted new action goal")
        return GoalResponse.ACCEPT

    def _goal_accepted(self, handle) -> None:
        self.goals.finish("abort", Result(error_code=Result.INVALID_GOAL,   # preempt_active_goal()
                                          error_string="Current goal preempted by new incoming action."))
        self.active_tolerances = self._goal_tolerances(handle.request)
        self._new_traj = self._to_trajectory(handle.request.trajectory)
        self._hold_requested = False
        self._is_holding = False
        self.goals.start(handle)
        handle.execute()
        self._monitor_goal()

    def _goal_cancelled(self, handle):
        goal = self.goals.active
        if goal is not None and goal.handle is handle:
            self.get_logger().info("Got request to cancel goal")
            self.goals.finish("canceled", Result())
            self._hold()
        return CancelResponse.ACCEPT

    def _execute(self, handle):
        return self.goals.execute(handle, Result(error_code=Result.INVALID_GOAL,
                                                 error_string="goal was not tracked by the controller"))

    def _monitor_goal(self) -> None:
        """The goal handle timer (action_monitor_rate): feedback of the active goal, results of finished ones."""
        self.goals.run_non_realtime()

    def _feedback(self, goal):
        t, idx = goal.feedback_due
        fb = FollowJointTrajectory.Feedback(joint_names=list(self._joints), desired=self._point(self.state_desired),
                                            actual=self._point(self.state_current),
                                            error=self._point(self.state_error), index=int(idx))
        fb.header.stamp = _stamp(t)
        return fb


__all__ = ["JointTrajectoryController"]
