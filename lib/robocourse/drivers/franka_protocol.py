"""The Franka-style box's UDP protocol, version 1: byte layouts shared by box and client.

Counterpart: libfranka's research interface (the robot streams ``franka::RobotState`` every
1 ms over UDP; the client answers each with a command carrying the state's ``message_id``).
Ours is one UDP socket for everything (libfranka also keeps a TCP channel for Move/Stop and
error recovery; we send those as UDP messages too, with an acknowledgement).

Every datagram starts with the 16-byte header, little-endian::

    struct Header { char magic[4] = "RCFR"; uint8 version = 1; uint8 type;
                    uint16 n;           // number of joints (6 for the UR5e arm)
                    uint64 seq; }       // "<4sBBHQ"

Types and payloads after the header (float64 = little-endian IEEE 754 double):

====  ==============  =====================  ========================================================
type  name            direction              payload
====  ==============  =====================  ========================================================
1     CONNECT         client -> box          none (n = 0, seq = 0)
2     CONNECT_ACK     box -> client          uint32 period_us, uint32 max_missed ("<II")
3     CONNECT_REJECT  box -> client          UTF-8 reason
4     STATE           box -> client          q[n], dq[n], tau_J[n], tau_ext_hat[n] (float64),
                                             float64 control_command_success_rate (last 100 ticks),
                                             uint8 robot_mode, uint8 pad[3], uint32 errors
                                             ("<{4n+1}dBxxxI"); seq = this state's sequence number
5     COMMAND         client -> box          uint8 mode (1 position, 2 torque), uint8 motion_finished,
                                             uint8 pad[6], values[n] float64 ("<BB6x{n}d");
                                             seq = the seq of the STATE it answers
6     RECOVER         client -> box          none: automatic_error_recovery
7     RECOVER_ACK     box -> client          uint32 errors after recovery ("<I")
8     DISCONNECT      client -> box          none
9     STATS           client -> box / reply  request: none; reply: UTF-8 JSON of the box's counters
====  ==============  =====================  ========================================================

Timing rule: the box sends STATE ``k`` at tick k; a COMMAND with seq ``k`` received before tick
k+1 is applied at tick k+1. At tick k+1 with no such command the tick is *missed*; a command
arriving afterwards is *late* (counted, discarded). More than ``max_missed`` missed ticks in a
row while moving trigger the ``communication_constraints_violation`` reflex: the brakes close
(the arm holds where it is), commands are ignored, and only RECOVER clears it. Torque commands
exclude gravity: the box adds its gravity model (as the real robot does).

Malformed datagrams (shorter than their layout, wrong magic, wrong version, unknown type, a
joint count other than the box's, a command for a state never sent, from a second client) are
counted by reason and ignored; the box keeps running.
"""

from __future__ import annotations

import struct

MAGIC = b"RCFR"
VERSION = 1
HEADER = struct.Struct("<4sBBHQ")

CONNECT, CONNECT_ACK, CONNECT_REJECT, STATE, COMMAND, RECOVER, RECOVER_ACK, DISCONNECT, STATS = range(1, 10)
TYPE_NAMES = {CONNECT: "CONNECT", CONNECT_ACK: "CONNECT_ACK", CONNECT_REJECT: "CONNECT_REJECT", STATE: "STATE",
              COMMAND: "COMMAND", RECOVER: "RECOVER", RECOVER_ACK: "RECOVER_ACK", DISCONNECT: "DISCONNECT",
              STATS: "STATS"}
ACK = struct.Struct("<II")
RECOVER_REPLY = struct.Struct("<I")

MODE_POSITION, MODE_TORQUE = 1, 2
MODE_NAMES = {MODE_POSITION: "position", MODE_TORQUE: "torque"}

#: robot_mode values (franka::RobotMode: kIdle, kMove, kReflex)
ROBOT_IDLE, ROBOT_MOVE, ROBOT_REFLEX = 0, 1, 2
ROBOT_MODE_NAMES = {ROBOT_IDLE: "idle", ROBOT_MOVE: "move", ROBOT_REFLEX: "reflex"}

#: errors bitmask (franka::Errors field names)
ERR_COMMUNICATION_CONSTRAINTS_VIOLATION = 1 << 0
ERROR_NAMES = {ERR_COMMUNICATION_CONSTRAINTS_VIOLATION: "communication_constraints_violation"}

SUCCESS_WINDOW = 100
#: missed ticks in a row the box tolerates before the communication reflex (a box option)
DEFAULT_MAX_MISSED = 20


def state_struct(n: int) -> struct.Struct:
    return struct.Struct(f"<{4 * n + 1}dBxxxI")


def command_struct(n: int) -> struct.Struct:
    return struct.Struct(f"<BB6x{n}d")


def header(msg_type: int, n: int = 0, seq: int = 0) -> bytes:
    return HEADER.pack(MAGIC, VERSION, msg_type, n, seq)


def error_names(errors: int) -> list[str]:
    return [name for bit, name in ERROR_NAMES.items() if errors & bit]


def encode_command(n: int, seq: int, mode: int, values, motion_finished: bool = False) -> bytes:
    return header(COMMAND, n, seq) + command_struct(n).pack(mode, int(bool(motion_finished)), *values)
