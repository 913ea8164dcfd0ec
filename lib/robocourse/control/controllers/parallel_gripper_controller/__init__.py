"""ParallelGripperController (ros2_controllers' parallel_gripper_controller).

Counterpart: ``parallel_gripper_action_controller::GripperActionController``: the
``~/gripper_cmd`` action (control_msgs/ParallelGripperCommand: ``command`` is a JointState
with the goal position, and optionally a maximum velocity and effort), the position command
of one joint, ``goal_tolerance``, stall detection (no movement faster than
``stall_velocity_threshold`` for ``stall_timeout`` s: abort, or succeed with ``stalled`` when
``allow_stalling``), ``max_effort`` / ``max_velocity`` defaults written to the optional
``max_effort_interface`` / ``max_velocity_interface`` (a goal's effort / velocity replaces the
default as given, not clamped to it, as upstream's accepted_callback does; a cancel restores the
defaults). Feedback and result carry the joint
state, ``stalled`` and ``reached_goal``. A new goal preempts the active one (aborted: the
action state machine cancels only goals whose cancel was requested); a cancel holds the
current position; on activation the gripper holds where it is.

Differences: a goal outside the joint's URDF limits, without a position or with a
non-finite value is rejected with the reason (upstream accepts it and lets the hardware
clamp); without a ``max_velocity_interface`` the controller itself moves the position
command towards the goal at the maximum velocity (upstream writes the goal at once and leaves
speed to the hardware), and then a goal's positive velocity sets that ramp's speed (upstream
ignores a goal velocity without the interface); deactivation aborts an active goal.
"""

from __future__ import annotations

import math
from pathlib import Path

from robocourse.bus.action import ActionServer, CancelResponse, GoalResponse
from robocourse.msgs.sensor_msgs import JointState

from ...hardware.types import CallbackReturn, return_type
from ...manager.controller_interface import (
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
)
from ...msgs import ParallelGripperCommand
from ...parameters import ParameterSchema
from ..realtime_goal import GoalMonitor

_HERE = Path(__file__).parent
Result = ParallelGripperCommand.Result


class ParallelGripperController(ControllerInterface):
    """``parallel_gripper_action_controller/GripperActionController``."""

    PARAMS = ParameterSchema.from_yaml(_HERE.joinpath("parameters.yaml").read_text())

    def __init__(self):
        super().__init__()
        self.goals = GoalMonitor(self._feedback)
        self.rejections: list[str] = []
        self.target = math.nan
        self.command = math.nan
        self.max_velocity = 0.0
        self.max_effort = 0.0
        self.last_movement_time = 0.0
        self.active = False
        self.position = self.velocity = self.effort = 0.0

    def on_configure(self, previous_state):
        p = self.params
        if "position" not in p.state_interfaces or "velocity" not in p.state_interfaces:
            self.get_logger().error("state_interfaces must hold 'position' and 'velocity' (stall detection needs "
                                    "the velocity), e.g. state_interfaces: [position, velocity]")
            return CallbackReturn.ERROR
        self.limits = self.joint_limits.get(p.joint)
        if self._node is None:
            node = self.get_node()
            ActionServer(node, ParallelGripperCommand, "~/gripper_cmd", self._execute,
                         goal_callback=self._goal_received, handle_accepted_callback=self._goal_accepted,
                         cancel_callback=self._goal_cancelled)
            node.create_timer(1.0 / p.action_monitor_rate, self.goals.run_non_realtime)
        return CallbackReturn.SUCCESS

    def command_interface_configuration(self):
        p = self.params
        names = [f"{p.joint}/position"]
        names += [f"{p.joint}/{i}" for i in (p.max_velocity_interface, p.max_effort_interface) if i]
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL, names)

    def state_interface_configuration(self):
        return InterfaceConfiguration(interface_configuration_type.INDIVIDUAL,
                                      [f"{self.params.joint}/{i}" for i in self.params.state_interfaces])

    def on_activate(self, previous_state):
        p = self.params
        self._pos_cmd = self.command_interfaces[0]
        extra = self.command_interfaces[1:]
        self._vel_cmd = extra.pop(0) if p.max_velocity_interface else None
        self._eff_cmd = extra.pop(0) if p.max_effort_interface else None
        states = dict(zip(p.state_interfaces, self.state_interfaces))
        self._pos_state, self._vel_state = states["position"], states["velocity"]
        self._eff_state = states.get("effort")
        self.position = self._pos_state.get_value()
        self.target = self.command = self.position          # hold where it is
        self.max_velocity, self.max_effort = p.max_velocity, p.max_effort
        self.active = True
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state):
        self.active = False
        self.goals.finish("abort", self._result(False, False))
        return CallbackReturn.SUCCESS

    # --- real-time side -------------------------------------------------------------------------------
    def update(self, time, period):
        self.param_listener.try_update_params(self.params)   # goal_tolerance, stall settings are dynamic
        p = self.params
        self.position = self._pos_state.get_value()
        self.velocity = self._vel_state.get_value()
        self.effort = self._eff_state.get_value() if self._eff_state is not None else 0.0
        target = self.target
        if self._vel_cmd is None:     # ramp the position command at the maximum velocity
            step = self.max_velocity * period
            self.command = min(max(target, self.command - step), self.command + step)
        else:
            self.command = target
            self._vel_cmd.set_value(self.max_velocity)
        if self._eff_cmd is not None:
            self._eff_cmd.set_value(self.max_effort)
        self._pos_cmd.set_value(self.command)
        goal = self.goals.active
        if goal is None:
            return return_type.OK
        goal.feedback_due = True
        if abs(target - self.position) < p.goal_tolerance:
            self.goals.finish("succeed", self._result(True, False))
        elif abs(self.velocity) > p.stall_velocity_threshold:
            self.last_movement_time = time
        elif time - self.last_movement_time > p.stall_timeout:
            self.get_logger().info("Gripper stalled" + (" (allowed: success)" if p.allow_stalling else ": aborting"))
            self.goals.finish("succeed" if p.allow_stalling else "abort", self._result(False, True))
        return return_type.OK

    def _state_msg(self) -> JointState:
        return JointState(name=[self.params.joint], position=[self.position], velocity=[self.velocity],
                          effort=[self.effort])

    def _result(self, reached: bool, stalled: bool):
        return Result(state=self._state_msg(), reached_goal=reached, stalled=stalled)

    def _feedback(self, goal):
        return ParallelGripperCommand.Feedback(state=self._state_msg())

    # --- non-real-time side ------------------------------------------------------------------------------
    def validate_goal(self, goal) -> str | None:
        cmd = goal.command
        joint = self.params.joint
        if cmd.name and list(cmd.name) != [joint]:
            return f"Goal names joints {list(cmd.name)}; this gripper controls only '{joint}'"
        if len(cmd.position) != 1:
            return f"Goal needs exactly one position for joint '{joint}', got {list(cmd.position)}"
        values = list(cmd.position) + list(cmd.velocity) + list(cmd.effort)
        if not all(math.isfinite(v) for v in values):
            return f"Goal has a non-finite value: position {list(cmd.position)}, velocity {list(cmd.velocity)}, " \
                   f"effort {list(cmd.effort)}"
        lim = self.limits
        x = cmd.position[0]
        if lim is not None and not lim.min_position <= x <= lim.max_position:
            return (f"Goal position {x:g} of joint '{joint}' is outside its limits [{lim.min_position:g}, "
                    f"{lim.max_position:g}] (URDF <limit>); send a position inside them")
        if any(v < 0.0 for v in list(cmd.velocity) + list(cmd.effort)):
            return "Goal maximum velocity and effort must be >= 0 (0 or empty: the controller's default)"
        return None

    def _goal_received(self, goal):
        if not self.active:
            why = "Can't accept new action goals. Controller is not running."
        else:
            why = self.validate_goal(goal)
        if why is not None:
            self.rejections.append(why)
            self.get_logger().error(why)
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _goal_accepted(self, handle) -> None:
        p = self.params
        cmd = handle.request.command
        self.goals.finish("abort", self._result(False, False))     # preempt_active_goal()
        # upstream's accepted_callback: with the interface configured, a goal's value is used as given
        # (0 included); without it, the default. Without a max_velocity_interface our own position ramp
        # (a difference, see above) takes a positive goal velocity: a ramp at 0 would never move.
        if len(cmd.velocity) and (p.max_velocity_interface or cmd.velocity[0] > 0):
            self.max_velocity = cmd.velocity[0]
        else:
            self.max_velocity = p.max_velocity
        self.max_effort = cmd.effort[0] if p.max_effort_interface and len(cmd.effort) else p.max_effort
        self.last_movement_time = self.get_node().get_clock().now().nanoseconds * 1e-9
        self.command = self.position
        self.target = float(cmd.position[0])
        self.goals.start(handle)
        handle.execute()
        self.goals.run_non_realtime()

    def _goal_cancelled(self, handle):
        goal = self.goals.active
        if goal is not None and goal.handle is handle:
            # upstream's set_hold_position(): hold here with the default max_effort / max_velocity again
            self.target = self.command = self.position
            self.max_velocity, self.max_effort = self.params.max_velocity, self.params.max_effort
            self.goals.finish("canceled", self._result(False, False))
        return CancelResponse.ACCEPT

    def _execute(self, handle):
        return self.goals.execute(handle, self._result(False, False))


__all__ = ["ParallelGripperController"]
