"""libfranka's robot server protocol, version 10: the bytes pylibfranka 0.21.3 sends and expects.

Counterpart: ``research_interface/robot/service_types.h`` and ``rbk_types.h`` of libfranka-common
(the wire format of libfranka >= 0.18; libfranka 0.21.x checks ``kVersion`` = 10), as collected
and verified on the wire in shared/reference/arm_drivers.md, sections B and C. Everything is
little-endian and packed.

TCP (port 1337): every message starts with ``uint32 command, uint32 command_id, uint32 size``
(``size`` counts the whole message); the response echoes command and id. UDP: the robot sends a
1377-byte ``RobotState`` every millisecond to the port the client named in Connect; the client
answers each with a 371-byte ``RobotCommand`` carrying the state's ``message_id``.

Also here, because the box enforces them and a chapter quotes them: the FR3's acceleration,
jerk and torque-rate limits (not URDF fields), with their source.
"""

from __future__ import annotations

import struct

import numpy as np

VERSION = 10                 # research_interface::robot::kVersion (libfranka-common d96c221)
COMMAND_PORT = 1337          # research_interface::robot::kCommandPort
HEADER = struct.Struct("<III")   # command, command_id, size (whole message)

# --- TCP commands (research_interface::robot::Command) and their request payloads --------------
CONNECT, MOVE, STOP_MOVE, SET_COLLISION_BEHAVIOR, SET_JOINT_IMPEDANCE, SET_CARTESIAN_IMPEDANCE, \
    SET_GUIDING_MODE, SET_EE_TO_K, SET_NE_TO_EE, SET_LOAD, AUTOMATIC_ERROR_RECOVERY, GET_ROBOT_MODEL = range(12)
COMMAND_NAMES = ("Connect", "Move", "StopMove", "SetCollisionBehavior", "SetJointImpedance",
                 "SetCartesianImpedance", "SetGuidingMode", "SetEEToK", "SetNEToEE", "SetLoad",
                 "AutomaticErrorRecovery", "GetRobotModel")
#: request payload layout per command (after the 12-byte header)
REQUEST = {
    CONNECT: struct.Struct("<HH"),                       # version, udp_port
    MOVE: struct.Struct("<II3d3dB7d"),                   # controller, generator, max path dev, max goal dev, async, max vel
    STOP_MOVE: struct.Struct("<"),
    SET_COLLISION_BEHAVIOR: struct.Struct("<28d24d"),    # 4x7 torque thresholds, 4x6 force thresholds
    SET_JOINT_IMPEDANCE: struct.Struct("<7d"),
    SET_CARTESIAN_IMPEDANCE: struct.Struct("<6d"),
    SET_GUIDING_MODE: struct.Struct("<7?"),
    SET_EE_TO_K: struct.Struct("<16d"),
    SET_NE_TO_EE: struct.Struct("<16d"),
    SET_LOAD: struct.Struct("<d3d9d"),
    AUTOMATIC_ERROR_RECOVERY: struct.Struct("<"),
    GET_ROBOT_MODEL: struct.Struct("<"),
}
CONNECT_REPLY = struct.Struct("<BH")                     # status, version
STATUS = struct.Struct("<B")

# status codes
CONNECT_SUCCESS, CONNECT_INCOMPATIBLE_VERSION = 0, 1
MOVE_SUCCESS, MOVE_MOTION_STARTED, MOVE_PREEMPTED, MOVE_PREEMPTED_DUE_TO_SAFETY, MOVE_REJECTED_DUE_TO_SAFETY, \
    MOVE_COMMAND_NOT_POSSIBLE, MOVE_START_AT_SINGULAR_POSE, MOVE_INVALID_ARGUMENT, MOVE_REFLEX_ABORTED, \
    MOVE_EMERGENCY_ABORTED, MOVE_INPUT_ERROR_ABORTED, MOVE_ABORTED = range(12)
SET_SUCCESS, SET_NOT_POSSIBLE, SET_INVALID_ARGUMENT = 0, 1, 2
STOP_SUCCESS, STOP_NOT_POSSIBLE = 0, 1
RECOVERY_SUCCESS, RECOVERY_NOT_POSSIBLE = 0, 1
MODEL_SUCCESS = 0

# Move request enums (u32) -> the RobotState enums (u8) they show as
MOVE_CONTROLLERS = {0: "JointImpedance", 1: "CartesianImpedance", 2: "ExternalController"}
MOVE_GENERATORS = {0: "JointPosition", 1: "JointVelocity", 2: "CartesianPosition", 3: "CartesianVelocity", 4: "None"}
STATE_GENERATOR_OF_MOVE = {0: 1, 1: 2, 2: 3, 3: 4, 4: 5}     # state: 0 Idle, 1 JointPosition, 2 JointVelocity, ...
STATE_CONTROLLER_OF_MOVE = {0: 0, 1: 1, 2: 2}                # state: 0 JointImpedance, 1 Cartesian, 2 External, 3 Other
GEN_IDLE, GEN_JOINT_POSITION, GEN_JOINT_VELOCITY, GEN_NONE = 0, 1, 2, 5
CTRL_JOINT_IMPEDANCE, CTRL_EXTERNAL = 0, 2
# robot_mode (franka::RobotMode)
MODE_OTHER, MODE_IDLE, MODE_MOVE, MODE_GUIDING, MODE_REFLEX, MODE_USER_STOPPED, MODE_AUTOMATIC_ERROR_RECOVERY = range(7)

# --- UDP -----------------------------------------------------------------------------------------
#: RobotState fields in wire order: (name, struct code, count); f = float32, byte offsets in B3
STATE_FIELDS = (
    ("message_id", "Q", 1), ("O_T_EE", "f", 16), ("O_T_EE_d", "f", 16), ("F_T_EE", "f", 16), ("EE_T_K", "f", 16),
    ("F_T_NE", "f", 16), ("NE_T_EE", "f", 16), ("m_ee", "f", 1), ("I_ee", "f", 9), ("F_x_Cee", "f", 3),
    ("m_load", "f", 1), ("I_load", "f", 9), ("F_x_Cload", "f", 3), ("elbow", "f", 2), ("elbow_d", "f", 2),
    ("tau_J", "f", 7), ("tau_J_d", "f", 7), ("dtau_J", "f", 7), ("q", "f", 7), ("q_d", "f", 7), ("dq", "f", 7),
    ("dq_d", "f", 7), ("ddq_d", "f", 7), ("joint_contact", "f", 7), ("cartesian_contact", "f", 6),
    ("joint_collision", "f", 7), ("cartesian_collision", "f", 6), ("tau_ext_hat_filtered", "f", 7),
    ("O_F_ext_hat_K", "f", 6), ("K_F_ext_hat_K", "f", 6), ("O_dP_EE_d", "f", 6), ("O_ddP_O", "f", 3),
    ("elbow_c", "f", 2), ("delbow_c", "f", 2), ("ddelbow_c", "f", 2), ("O_T_EE_c", "f", 16), ("O_dP_EE_c", "f", 6),
    ("O_ddP_EE_c", "f", 6), ("theta", "f", 7), ("dtheta", "f", 7), ("accelerometer_top", "f", 18),
    ("accelerometer_bottom", "f", 18), ("motion_generator_mode", "B", 1), ("controller_mode", "B", 1),
    ("errors", "?", 41), ("reflex_reason", "?", 41), ("robot_mode", "B", 1), ("control_command_success_rate", "f", 1),
)
STATE = struct.Struct("<" + "".join(f"{n}{c}" for _, c, n in STATE_FIELDS))
#: the same layout as a packed numpy record: fill fields by name, send ``.tobytes()``
STATE_DTYPE = np.dtype([(name, {"Q": "<u8", "f": "<f4", "B": "u1", "?": "?"}[code], (count,) if count > 1 else ())
                        for name, code, count in STATE_FIELDS])
#: byte offset of each state field
STATE_OFFSETS = {}
_off = 0
for _name, _code, _n in STATE_FIELDS:
    STATE_OFFSETS[_name] = _off
    _off += struct.calcsize("<" + _code) * _n
assert STATE.size == _off == STATE_DTYPE.itemsize == 1377, STATE.size
#: RobotCommand: message_id, q_c, dq_c, O_T_EE_c, O_dP_EE_c, elbow_c, valid_elbow, motion_generation_finished,
#: tau_J_d, torque_command_finished
COMMAND = struct.Struct("<Q7d7d16d6d2d??7d?")
assert COMMAND.size == 371
#: indices into ``COMMAND.unpack(...)``
CMD_Q, CMD_DQ, CMD_MOTION_FINISHED, CMD_TAU, CMD_TORQUE_FINISHED = slice(1, 8), slice(8, 15), 40, slice(41, 48), 48

#: research_interface::robot::Error, in index order (41 entries; franka::Errors names). Indices
#: 0-32 from libfranka-common's error.h; 33-40 are the names libfranka 0.21 added after them,
#: checked by reading each bit back through pylibfranka (tests/test_drivers_franka.py).
ERROR_NAMES = (
    "joint_position_limits_violation", "cartesian_position_limits_violation", "self_collision_avoidance_violation",
    "joint_velocity_violation", "cartesian_velocity_violation", "force_control_safety_violation", "joint_reflex",
    "cartesian_reflex", "max_goal_pose_deviation_violation", "max_path_pose_deviation_violation",
    "cartesian_velocity_profile_safety_violation", "joint_position_motion_generator_start_pose_invalid",
    "joint_motion_generator_position_limits_violation", "joint_motion_generator_velocity_limits_violation",
    "joint_motion_generator_velocity_discontinuity", "joint_motion_generator_acceleration_discontinuity",
    "cartesian_position_motion_generator_start_pose_invalid", "cartesian_motion_generator_elbow_limit_violation",
    "cartesian_motion_generator_velocity_limits_violation", "cartesian_motion_generator_velocity_discontinuity",
    "cartesian_motion_generator_acceleration_discontinuity", "cartesian_motion_generator_elbow_sign_inconsistent",
    "cartesian_motion_generator_start_elbow_invalid", "force_controller_desired_force_tolerance_violation",
    "start_elbow_sign_inconsistent", "communication_constraints_violation", "power_limit_violation",
    "cartesian_motion_generator_joint_position_limits_violation",
    "cartesian_motion_generator_joint_velocity_limits_violation",
    "cartesian_motion_generator_joint_velocity_discontinuity",
    "cartesian_motion_generator_joint_acceleration_discontinuity",
    "cartesian_position_motion_generator_invalid_frame", "controller_torque_discontinuity",
)
ERR_JOINT_MG_POSITION_LIMITS, ERR_JOINT_MG_VELOCITY_LIMITS, ERR_JOINT_MG_VELOCITY_DISCONTINUITY, \
    ERR_JOINT_MG_ACCELERATION_DISCONTINUITY = 12, 13, 14, 15
ERR_COMMUNICATION_CONSTRAINTS_VIOLATION = 25
ERR_CONTROLLER_TORQUE_DISCONTINUITY = 32

#: consecutive lost command packets after which the robot stops with
#: communication_constraints_violation (libfranka docs/system_requirements.rst@0.21.2: "20
#: consecutively dropped packets")
MAX_LOST_IN_ROW = 20
#: control_command_success_rate: the share of the last 100 commands received (robot_state.h@0.21.2)
SUCCESS_WINDOW = 100

# --- FR3 limits that are not URDF fields (frankarobotics/docs source/control-parameters-joint-fr3.csv
# @73f863b and libfranka include/franka/rate_limiting.h@0.21.2): per joint, every joint alike
MAX_JOINT_ACCELERATION = 10.0      # rad/s^2
MAX_JOINT_JERK = 5000.0            # rad/s^3
MAX_TORQUE_RATE = 1000.0           # N m/s
#: ours, not Franka's: the multiple of the published acceleration and jerk limits above which the
#: box raises the joint motion generator discontinuity reflexes; infinite (off) by default.
#: libfranka stamps a command with the newest state it has received, so a command computed from
#: one state and sent after the next one arrived lands a millisecond late: at 0.2 rad/s that is
#: 200 rad/s^2 of apparent acceleration, far above the published 10. The robot evidently
#: tolerates it (its detection thresholds are not published); a box flagging it would stop every
#: correct Python loop on a busy machine. Position and velocity limits are always checked.
DISCONTINUITY_MARGIN = float("inf")
#: the same for the torque rate (controller_torque_discontinuity): checked, at twice 1000 N m/s
TORQUE_RATE_MARGIN = 2.0


def error_names(flags) -> list[str]:
    """The franka::Errors names of the set flags (a 41-bool sequence)."""
    return [ERROR_NAMES[i] if i < len(ERROR_NAMES) else f"error_{i}" for i, f in enumerate(flags) if f]
