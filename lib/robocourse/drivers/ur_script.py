"""The URScript programs the UR-style box runs: ur_rtde's control script, recognised and carried out in Python.

Counterpart: a UR controller's script ports (30001 primary, 30002 secondary, 30003 real-time):
a client writes a URScript program and the controller compiles and runs it. ur_rtde's
``RTDEControlInterface`` uploads ``rtde_control.script`` (its ``def rtde_control():`` program,
printing ``RTDE Control Script Loaded``) and then talks to it through RTDE registers. We do not
interpret URScript: the box recognises that program (:func:`parse_program`) and runs its
register protocol itself (:class:`robocourse.drivers.ur_controller.URController`). Any other
program is refused with a text message and counted (``scripts_refused``).

The register protocol (read from the script ur_rtde 1.6.5 uploads; offsets 0, or 24 with
``FLAG_UPPER_RANGE_REGISTERS``, added to every register number):

- ``input_int_register_0``: the command (:data:`COMMANDS`); 0 = none.
- ``output_int_register_0``: 1 = ready for a command, 2 = done with the command. Real-time
  commands (:data:`REALTIME`) are applied every cycle while the register holds them and leave
  1; any other command runs once, then 2 stays until the client writes 0, which gives 1.
- ``output_int_register_1``: an int/bool result; ``output_int_register_2``: async progress
  (bit 15 running, bits 24-30 operation id, bits 16-22 a write counter);
  ``output_double_register_0..5``: a vector result.
- Parameters arrive in ``input_double_register_0..`` and ``input_int_register_1..``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: command number -> ur_rtde's name for it (include/ur_rtde/rtde.h, RobotCommand::Type)
COMMANDS = {
    0: "NO_CMD", 1: "MOVEJ", 2: "MOVEJ_IK", 3: "MOVEL", 4: "MOVEL_FK", 6: "FORCE_MODE", 7: "FORCE_MODE_STOP",
    8: "ZERO_FT_SENSOR", 9: "SPEEDJ", 10: "SPEEDL", 11: "SERVOJ", 12: "SERVOC", 15: "SPEED_STOP",
    16: "SERVO_STOP", 17: "SET_PAYLOAD", 18: "TEACH_MODE", 19: "END_TEACH_MODE", 20: "FORCE_MODE_SET_DAMPING",
    21: "FORCE_MODE_SET_GAIN_SCALING", 24: "SERVOL", 25: "TOOL_CONTACT", 26: "GET_STEPTIME",
    27: "GET_ACTUAL_JOINT_POSITIONS_HISTORY", 28: "GET_TARGET_WAYPOINT", 29: "SET_TCP",
    30: "GET_INVERSE_KINEMATICS_ARGS", 31: "PROTECTIVE_STOP", 33: "STOPL", 34: "STOPJ", 35: "SET_WATCHDOG",
    36: "IS_POSE_WITHIN_SAFETY_LIMITS", 37: "IS_JOINTS_WITHIN_SAFETY_LIMITS", 38: "GET_JOINT_TORQUES",
    39: "POSE_TRANS", 40: "GET_TCP_OFFSET", 41: "JOG_START", 42: "JOG_STOP", 43: "GET_FORWARD_KINEMATICS_DEFAULT",
    44: "GET_FORWARD_KINEMATICS_ARGS", 45: "MOVE_PATH", 46: "GET_INVERSE_KINEMATICS_DEFAULT", 47: "IS_STEADY",
    51: "MOVE_UNTIL_CONTACT", 52: "FREEDRIVE_MODE", 53: "END_FREEDRIVE_MODE", 54: "GET_FREEDRIVE_STATUS",
    55: "SET_EXTERNAL_FORCE_TORQUE", 56: "FT_RTDE_INPUT_ENABLE", 57: "ENABLE_EXTERNAL_FT_SENSOR",
    58: "GET_ACTUAL_TOOL_FLANGE_POSE", 59: "SET_GRAVITY", 60: "GET_INVERSE_KINEMATICS_HAS_SOLUTION_DEFAULT",
    61: "GET_INVERSE_KINEMATICS_HAS_SOLUTION_ARGS", 62: "START_CONTACT_DETECTION", 63: "STOP_CONTACT_DETECTION",
    64: "READ_CONTACT_DETECTION", 65: "SET_TARGET_PAYLOAD", 66: "DIRECT_TORQUE", 67: "GET_MASS_MATRIX",
    68: "GET_CORIOLIS_AND_CENTRIFUGAL_TORQUES", 69: "GET_TARGET_JOINT_ACCELERATIONS", 70: "GET_JACOBIAN",
    71: "GET_JACOBIAN_TIME_DERIVATIVE", 255: "STOP_SCRIPT",
}

#: the commands the script applies every cycle and answers with "ready" (its main loop's list in 1.6.5)
REALTIME = frozenset({24, 11, 9, 10, 6, 25, 26, 27, 38, 58, 66, 67, 68, 69, 70, 71})

#: the commands this box carries out; any other makes the program stop with a runtime error
SUPPORTED = frozenset({1, 8, 9, 11, 15, 16, 17, 26, 29, 31, 33, 34, 35, 37, 38, 40, 43, 44, 47, 58, 255})

READY, DONE = 1, 2

MARKER = 'textmsg("RTDE Control Script Loaded'
_DEF = re.compile(r"^def\s+(\w+)\s*\(\s*\)\s*:\s*$", re.M)
# ur_rtde injects the offset right after the comment, so the number starts the next line
_OFFSET_FLOAT = re.compile(r"reg_offset_float\s*=\s*(?:#[^\n]*\n)?\s*(\d+)")
_OFFSET_INT = re.compile(r"reg_offset_int\s*=\s*(?:#[^\n]*\n)?\s*(\d+)")


class ScriptRefused(ValueError):
    """A program this box does not run; the message says why (it goes to the clients as a text message)."""


@dataclass(frozen=True)
class ControlProgram:
    """ur_rtde's control script as uploaded: its name and the register offsets injected into it."""

    name: str
    offset_float: int
    offset_int: int
    size: int


def program_complete(text: str) -> bool:
    """Whether ``text`` holds a whole top-level program (``def name():`` ... a line ``end`` at
    column 0), or a single line that is not the start of one (which the box then judges)."""
    lines = text.split("\n")
    if len(lines) < 2:
        return False                           # no newline yet
    first = next((ln for ln in lines if ln.strip()), "")
    if not first.startswith(("def ", "sec ")):
        return True                            # a one-line statement
    return any(ln.rstrip() == "end" for ln in lines[1:])


def parse_program(text: str) -> ControlProgram:
    """Recognise ur_rtde's control script, or raise :class:`ScriptRefused` saying what it is."""
    m = _DEF.search(text)
    head = text.strip().splitlines()[0][:60] if text.strip() else "(empty)"
    if m is None:
        raise ScriptRefused(f"script refused: this UR-style box runs only ur_rtde's control script "
                            f"(def rtde_control(): ...), got a statement starting {head!r}")
    if m.group(1) != "rtde_control" or MARKER not in text:
        raise ScriptRefused(f"script refused: program {m.group(1)!r} is not ur_rtde's control script "
                            "(def rtde_control(): ... with its 'RTDE Control Script Loaded' marker); this box "
                            "carries out only that script's register protocol")
    fo, io = _OFFSET_FLOAT.search(text), _OFFSET_INT.search(text)
    if fo is None or io is None or int(fo.group(1)) not in (0, 24) or int(io.group(1)) not in (0, 24):
        raise ScriptRefused("script refused: ur_rtde's control script without register offsets 0 or 24 "
                            "(reg_offset_float / reg_offset_int); was it edited?")
    return ControlProgram(m.group(1), int(fo.group(1)), int(io.group(1)), len(text))


def command_name(cmd: int) -> str:
    return COMMANDS.get(cmd, f"command {cmd}")
