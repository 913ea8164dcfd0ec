"""RTDE, protocol version 2, on the wire: framing, types, and the controller's variable table.

Counterpart: Universal Robots' Real-Time Data Exchange (TCP port 30004) as UR's RTDE guide
documents it for the e-Series, and as ur_rtde 1.6.5 and ur_client_library speak it (facts in
shared/reference/arm_drivers.md, section A2). Everything is big-endian::

    struct Package { uint16 size;    // the whole package, these 3 bytes included
                     uint8  type;    // an ASCII letter (below)
                     uint8  payload[size - 3]; }

====  ==============================  ==================================  ==================================
type  name                            client -> controller                controller -> client
====  ==============================  ==================================  ==================================
'V'   REQUEST_PROTOCOL_VERSION        uint16 version                      uint8 accepted (only 2 here)
'v'   GET_URCONTROL_VERSION           (empty)                             uint32 major, minor, bugfix, build
'O'   CONTROL_PACKAGE_SETUP_OUTPUTS   float64 frequency + names joined    uint8 recipe id + the names' types
                                      by ',' (ur_rtde adds a trailing     joined by ','; ``NOT_FOUND`` for
                                      comma)                              an unknown name
'I'   CONTROL_PACKAGE_SETUP_INPUTS    names joined by ','                 uint8 recipe id + types;
                                                                          ``IN_USE`` for an input another
                                                                          connection already writes
'S'   CONTROL_PACKAGE_START           (empty)                             uint8 success
'P'   CONTROL_PACKAGE_PAUSE           (empty)                             uint8 success
'U'   DATA_PACKAGE                    uint8 input recipe id + values      uint8 output recipe id + values
'M'   TEXT_MESSAGE                    --                                  uint8 length, text, uint8 length,
                                                                          source, uint8 warning level
====  ==============================  ==================================  ==================================

Types (:data:`TYPES`): BOOL, UINT8, UINT32, UINT64, INT32, DOUBLE, VECTOR3D, VECTOR6D,
VECTOR6INT32, VECTOR6UINT32. :data:`OUTPUTS` and :data:`INPUTS` are the e-Series variables of
the guide with their types (the names ur_rtde's own type table decodes; it ignores the types in
our reply, so these must be right). What each output carries in our box is documented in
:mod:`robocourse.drivers.ur_state`.
"""

from __future__ import annotations

import struct

PROTOCOL_VERSION = 2
HEADER = struct.Struct(">HB")
MAX_PACKAGE = 0xFFFF

REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
TEXT_MESSAGE = ord("M")
DATA_PACKAGE = ord("U")
SETUP_OUTPUTS = ord("O")
SETUP_INPUTS = ord("I")
START = ord("S")
PAUSE = ord("P")
PACKAGE_NAMES = {REQUEST_PROTOCOL_VERSION: "REQUEST_PROTOCOL_VERSION", GET_URCONTROL_VERSION: "GET_URCONTROL_VERSION",
                 TEXT_MESSAGE: "TEXT_MESSAGE", DATA_PACKAGE: "DATA_PACKAGE", SETUP_OUTPUTS: "CONTROL_PACKAGE_SETUP_OUTPUTS",
                 SETUP_INPUTS: "CONTROL_PACKAGE_SETUP_INPUTS", START: "CONTROL_PACKAGE_START",
                 PAUSE: "CONTROL_PACKAGE_PAUSE"}

NOT_FOUND = "NOT_FOUND"
IN_USE = "IN_USE"

#: RTDE type -> (struct format, number of values)
TYPES = {
    "BOOL": ("?", 1), "UINT8": ("B", 1), "UINT32": ("I", 1), "UINT64": ("Q", 1), "INT32": ("i", 1),
    "DOUBLE": ("d", 1), "VECTOR3D": ("3d", 3), "VECTOR6D": ("6d", 6), "VECTOR6INT32": ("6i", 6),
    "VECTOR6UINT32": ("6I", 6),
}

#: text message warning levels (v2)
EXCEPTION_MESSAGE, ERROR_MESSAGE, WARNING_MESSAGE, INFO_MESSAGE = 0, 1, 2, 3


def _registers(prefix: str, kind: str, numbers) -> dict[str, str]:
    return {f"{prefix}_{i}": kind for i in numbers}


#: controller -> client variables (e-Series, UR's RTDE guide), name -> type
OUTPUTS: dict[str, str] = {
    "timestamp": "DOUBLE",
    "target_q": "VECTOR6D", "target_qd": "VECTOR6D", "target_qdd": "VECTOR6D",
    "target_current": "VECTOR6D", "target_moment": "VECTOR6D",
    "actual_q": "VECTOR6D", "actual_qd": "VECTOR6D", "actual_current": "VECTOR6D",
    "actual_current_window": "VECTOR6D", "actual_current_as_torque": "VECTOR6D",
    "joint_control_output": "VECTOR6D",
    "actual_TCP_pose": "VECTOR6D", "actual_TCP_speed": "VECTOR6D", "actual_TCP_force": "VECTOR6D",
    "target_TCP_pose": "VECTOR6D", "target_TCP_speed": "VECTOR6D",
    "actual_digital_input_bits": "UINT64", "joint_temperatures": "VECTOR6D",
    "actual_execution_time": "DOUBLE", "robot_mode": "INT32", "joint_mode": "VECTOR6INT32",
    "safety_mode": "INT32", "safety_status": "INT32", "actual_tool_accelerometer": "VECTOR3D",
    "speed_scaling": "DOUBLE", "target_speed_fraction": "DOUBLE", "actual_momentum": "DOUBLE",
    "actual_main_voltage": "DOUBLE", "actual_robot_voltage": "DOUBLE", "actual_robot_current": "DOUBLE",
    "actual_joint_voltage": "VECTOR6D", "actual_digital_output_bits": "UINT64", "runtime_state": "UINT32",
    "elbow_position": "VECTOR3D", "elbow_velocity": "VECTOR3D",
    "robot_status_bits": "UINT32", "safety_status_bits": "UINT32", "analog_io_types": "UINT32",
    "standard_analog_input0": "DOUBLE", "standard_analog_input1": "DOUBLE",
    "standard_analog_output0": "DOUBLE", "standard_analog_output1": "DOUBLE", "io_current": "DOUBLE",
    "euromap67_input_bits": "UINT32", "euromap67_output_bits": "UINT32",
    "euromap67_24V_voltage": "DOUBLE", "euromap67_24V_current": "DOUBLE",
    "tool_mode": "UINT32", "tool_analog_input_types": "UINT32",
    "tool_analog_input0": "DOUBLE", "tool_analog_input1": "DOUBLE",
    "tool_output_voltage": "INT32", "tool_output_current": "DOUBLE", "tool_temperature": "DOUBLE",
    "tcp_force_scalar": "DOUBLE", "tool_output_mode": "UINT8",
    "tool_digital_output0_mode": "UINT8", "tool_digital_output1_mode": "UINT8",
    "payload": "DOUBLE", "payload_cog": "VECTOR3D", "payload_inertia": "VECTOR6D",
    "script_control_line": "UINT32", "ft_raw_wrench": "VECTOR6D",
    "joint_position_deviation_ratio": "DOUBLE", "collision_detection_ratio": "DOUBLE",
    "time_scale_source": "INT32", "tcp_offset": "VECTOR6D",
    "output_bit_registers0_to_31": "UINT32", "output_bit_registers32_to_63": "UINT32",
    **_registers("output_bit_register", "BOOL", range(64, 128)),
    **_registers("output_int_register", "INT32", range(48)),
    **_registers("output_double_register", "DOUBLE", range(48)),
    # the inputs, read back (the last value any client wrote)
    "input_bit_registers0_to_31": "UINT32", "input_bit_registers32_to_63": "UINT32",
    **_registers("input_bit_register", "BOOL", range(64, 128)),
    **_registers("input_int_register", "INT32", range(48)),
    **_registers("input_double_register", "DOUBLE", range(48)),
}

#: client -> controller variables (e-Series, UR's RTDE guide), name -> type
INPUTS: dict[str, str] = {
    "speed_slider_mask": "UINT32", "speed_slider_fraction": "DOUBLE",
    "standard_digital_output_mask": "UINT8", "standard_digital_output": "UINT8",
    "configurable_digital_output_mask": "UINT8", "configurable_digital_output": "UINT8",
    "tool_digital_output_mask": "UINT8", "tool_digital_output": "UINT8",
    "standard_analog_output_mask": "UINT8", "standard_analog_output_type": "UINT8",
    "standard_analog_output_0": "DOUBLE", "standard_analog_output_1": "DOUBLE",
    "input_bit_registers0_to_31": "UINT32", "input_bit_registers32_to_63": "UINT32",
    **_registers("input_bit_register", "BOOL", range(64, 128)),
    **_registers("input_int_register", "INT32", range(48)),
    **_registers("input_double_register", "DOUBLE", range(48)),
    "external_force_torque": "VECTOR6D",
}


class ProtocolError(ValueError):
    """A package that cannot be what its header says (the message names the value and the rule)."""


def package(ptype: int, payload: bytes = b"") -> bytes:
    """One RTDE package: header + payload."""
    size = HEADER.size + len(payload)
    if size > MAX_PACKAGE:
        raise ProtocolError(f"an RTDE package is at most {MAX_PACKAGE} bytes (uint16 size); this one would be {size}")
    return HEADER.pack(size, ptype) + payload


def text_message(text: str, source: str = "robocourse", level: int = WARNING_MESSAGE) -> bytes:
    """An 'M' package, protocol version 2 layout."""
    t, s = text.encode()[:255], source.encode()[:255]
    return package(TEXT_MESSAGE, bytes([len(t)]) + t + bytes([len(s)]) + s + bytes([level]))


def decode_text_message(payload: bytes) -> tuple[str, str, int]:
    """(text, source, level) of a v2 'M' payload."""
    n = payload[0]
    text = payload[1:1 + n]
    m = payload[1 + n]
    source = payload[2 + n:2 + n + m]
    return text.decode(errors="replace"), source.decode(errors="replace"), payload[2 + n + m]


def split_names(text: bytes) -> list[str]:
    """The variable names of a setup request: comma-separated, a trailing comma (ur_rtde's) and
    spaces ignored."""
    names = [n.strip() for n in text.decode(errors="replace").split(",")]
    if names and names[-1] == "":
        names.pop()
    return names


def recipe_struct(types) -> struct.Struct:
    """The struct of a data package body for ``types`` (the recipe id byte first)."""
    return struct.Struct(">B" + "".join(TYPES[t][0] for t in types))
