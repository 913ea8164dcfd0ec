"""A simulated motor board and the SystemInterface that drives it (chapter 4's hardware exercise).

Counterpart: what a ros2_control hardware plugin talks to on a real robot (a serial or CAN motor
board, ros2_control_demos' example 1 "RRBot" behind its fake board): the board runs position
servos by itself; the host reads encoders and sends targets once per cycle. Here the board is a
small deterministic simulation: each motor moves toward its target with a first-order lag
(``time_constant``) and a speed limit (``max_velocity``), integrated in 1 ms steps up to the time
of each :meth:`MotorBoard.read`. The C-style API returns ``True``/``False`` instead of raising,
as a driver's ``read()`` must not throw in the real-time loop.

:class:`MotorBoardSystem` is the reference component (what the exercise asks students to write):
read() copies encoder positions and velocities into the state interfaces, write() sends the
position commands, on_activate() copies the measured positions into the commands so nothing
jumps. ``motor_board_urdf()`` is the matching ``<ros2_control>`` description, with command
``initial_value`` 0.0 as many real URDFs have: forgetting the copy sends every motor to 0 rad.
"""

from __future__ import annotations

import math

import numpy as np

from .hardware.component import SystemInterface
from .hardware.types import CallbackReturn, return_type

_SUBSTEP = 0.001


class MotorBoard:
    """``MotorBoard(positions=[0.8, -0.5])``: len(positions) motors, at rest at those angles (rad).

    ``read(time, positions_out, velocities_out) -> bool`` advances the motors to ``time`` (s) and
    fills the two arrays (the board allocates no array per call: what a driver measures is its own); ``write(targets) -> bool`` sets the targets (rad) and
    refuses (False, nothing changed) a frame of the wrong size or with a non-finite value.
    ``unplug()`` / ``plug_in()`` inject a cable fault: while unplugged both calls return False.
    """

    def __init__(self, positions, max_velocity: float = 2.0, time_constant: float = 0.05):
        p = np.array(positions, dtype=np.float64)
        if p.ndim != 1 or len(p) == 0 or not np.all(np.isfinite(p)):
            raise ValueError(f"positions={positions!r} must be a non-empty list of finite angles in rad, "
                             "e.g. MotorBoard([0.8, -0.5])")
        for name, v in (("max_velocity", max_velocity), ("time_constant", time_constant)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}={v!r} must be a finite number > 0, e.g. MotorBoard([0.8], {name}=0.05)")
        self.n = len(p)
        self.positions = p
        self.velocities = np.zeros(self.n)
        self.targets = p.copy()               # at power-up the servos hold where they are
        self.max_velocity = float(max_velocity)
        self.time_constant = float(time_constant)
        self.time: float | None = None
        self._v = np.zeros(self.n)            # scratch for _advance: the board itself allocates nothing per cycle
        self.connected = True
        self.frames_refused = 0
        self.targets_received = 0

    def unplug(self) -> None:
        self.connected = False

    def plug_in(self) -> None:
        self.connected = True

    def _advance(self, time: float) -> None:
        if self.time is None:
            self.time = time
            return
        while time - self.time > 1e-12:
            dt = min(_SUBSTEP, time - self.time)
            v = self._v
            np.subtract(self.targets, self.positions, out=v)
            np.divide(v, self.time_constant, out=v)
            np.clip(v, -self.max_velocity, self.max_velocity, out=v)
            self.velocities[:] = v
            np.multiply(v, dt, out=v)
            np.add(self.positions, v, out=self.positions)
            self.time += dt

    def read(self, time: float, positions_out, velocities_out) -> bool:
        """Advance to ``time`` (s) and copy encoder positions (rad) and velocities (rad/s) out."""
        if not self.connected:
            return False
        self._advance(float(time))
        positions_out[:] = self.positions
        velocities_out[:] = self.velocities
        return True

    def write(self, targets) -> bool:
        """Set every motor's target (rad); a wrong-size or non-finite frame is refused."""
        if not self.connected or len(targets) != self.n:
            self.frames_refused += 1
            return False
        for v in targets:
            if not math.isfinite(v):
                self.frames_refused += 1
                return False
        self.targets[:] = targets
        self.targets_received += 1
        return True


def boards_urdf(boards: dict, plugin: str = "robocourse/MotorBoardSystem") -> str:
    """A serial robot whose joints hang on boards: ``{"ArmBoard": ["joint1", "joint2"], "WristBoard": ["joint3"]}``.

    Every joint: a position command (``initial_value`` 0.0) and position + velocity states.
    """
    joints = [j for js in boards.values() for j in js]
    links = "".join(f'<link name="link{i}"/>' for i in range(len(joints) + 1))
    js = "".join(f'<joint name="{j}" type="revolute"><parent link="link{i}"/><child link="link{i + 1}"/>'
                 '<axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="10" velocity="2"/></joint>'
                 for i, j in enumerate(joints))
    blocks = ""
    for name, board_joints in boards.items():
        hw = "".join(f'<joint name="{j}"><command_interface name="position"><param name="initial_value">0.0</param>'
                     '</command_interface><state_interface name="position"/><state_interface name="velocity"/>'
                     '</joint>' for j in board_joints)
        blocks += f'<ros2_control name="{name}" type="system"><hardware><plugin>{plugin}</plugin></hardware>{hw}</ros2_control>'
    return f'<robot name="board_robot">{links}{js}{blocks}</robot>'


def motor_board_urdf(joints=("joint1", "joint2"), name: str = "MotorBoard",
                     plugin: str = "robocourse/MotorBoardSystem") -> str:
    """One board driving ``joints`` (see :func:`boards_urdf`)."""
    return boards_urdf({name: list(joints)}, plugin)


def two_board_urdf() -> str:
    """Chapter 4's failure robot: ``ArmBoard`` (joint1, joint2) and ``WristBoard`` (joint3)."""
    return boards_urdf({"ArmBoard": ["joint1", "joint2"], "WristBoard": ["joint3"]})


class MotorBoardSystem(SystemInterface):
    """The reference SystemInterface for :class:`MotorBoard` (see the module docstring)."""

    SUPPORTED_COMMAND_INTERFACES = ("position",)
    SUPPORTED_STATE_INTERFACES = ("position", "velocity")

    def __init__(self, board: MotorBoard):
        super().__init__()
        self.board = board

    def on_init(self, info):
        super().on_init(info)
        if len(info.joints) != self.board.n:
            self.get_logger().error(f"the board has {self.board.n} motors but the URDF names {len(info.joints)} joints")
            return CallbackReturn.ERROR
        return CallbackReturn.SUCCESS

    def on_configure(self, previous_state):
        names = [j.name for j in self.info.joints]
        self.pos_slots = np.array([self.state_index[f"{j}/position"] for j in names], dtype=np.intp)
        self.vel_slots = np.array([self.state_index[f"{j}/velocity"] for j in names], dtype=np.intp)
        self.cmd_slots = np.array([self.command_index[f"{j}/position"] for j in names], dtype=np.intp)
        self.pos = np.zeros(len(names))      # preallocated: read()/write() allocate nothing
        self.vel = np.zeros(len(names))
        self.cmd = np.zeros(len(names))
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        if not self.board.read(self.board.time or 0.0, self.pos, self.vel):
            self.get_logger().error("board not answering: check the cable")
            return CallbackReturn.ERROR
        self.command_values[self.cmd_slots] = self.pos     # hold where we are: no jump
        return CallbackReturn.SUCCESS

    def read(self, time, period):
        if not self.board.read(time, self.pos, self.vel):
            return return_type.ERROR
        self.state_values[self.pos_slots] = self.pos
        self.state_values[self.vel_slots] = self.vel
        return return_type.OK

    def write(self, time, period):
        # mode="clip": np.take's default mode="raise" buffers `out` in a new array on every call
        np.take(self.command_values, self.cmd_slots, out=self.cmd, mode="clip")
        return return_type.OK if self.board.write(self.cmd) else return_type.ERROR


__all__ = ["MotorBoard", "MotorBoardSystem", "boards_urdf", "motor_board_urdf", "two_board_urdf"]
