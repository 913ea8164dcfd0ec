"""The UR-style box's two channels: an RTDE-like state stream and a servo script channel.

Counterpart: Universal Robots' RTDE (TCP 30004) as ur_rtde's RTDEReceiveInterface and
ur_robot_driver use it, and URScript ``servoj(q, a, v, t, lookahead_time, gain)`` sent on a
separate channel (ur_robot_driver streams its targets over the "reverse interface" to a
script running on the robot; ur_rtde's RTDEControlInterface does the same through
registers). Ours keeps RTDE's framing and package types; the script channel is a line of text
per command.

RTDE channel (TCP, big-endian like real RTDE), protocol version 2::

    struct Package { uint16 size;   // whole package, header included
                     uint8  type;   // ASCII letter below
                     uint8  payload[size - 3]; }            // ">HB"

====  ===========================  =================================  ==================================
type  name                         client payload                     box reply payload
====  ===========================  =================================  ==================================
'V'   REQUEST_PROTOCOL_VERSION     uint16 version (">H")              uint8 accepted (1 only for 2)
'v'   GET_URCONTROL_VERSION        none                               uint32 major, minor, bugfix, build
'O'   CONTROL_PACKAGE_SETUP_OUTPUTS  float64 frequency + ASCII         uint8 recipe_id + ASCII types,
                                   comma-separated field names        comma-separated ("NOT_FOUND" for
                                                                      an unknown name: recipe refused)
'S'   CONTROL_PACKAGE_START        none                               uint8 accepted
'P'   CONTROL_PACKAGE_PAUSE        none                               uint8 accepted
'U'   DATA_PACKAGE                 (box -> client only)               uint8 recipe_id + the fields in
                                                                      recipe order, big-endian
'M'   TEXT_MESSAGE                 (box -> client)                    ASCII: why a package was refused
====  ===========================  =================================  ==================================

Output fields (RTDE names and types): ``timestamp`` DOUBLE (s since the box started),
``target_q``, ``actual_q``, ``actual_qd``, ``target_qd`` VECTOR6D (rad, rad/s),
``actual_joint_torques`` VECTOR6D (N m; real RTDE offers currents instead), ``robot_mode``
INT32 (7 = RUNNING), ``runtime_state`` UINT32 (1 STOPPED, 2 PLAYING: a servo script is
active), ``speed_scaling`` DOUBLE. The frequency must be in (0, 500] Hz; the box sends at 500
Hz divided by an integer, like the real controller (a frequency 500 does not divide is rounded
to the nearest divisor).

Script channel (TCP, ASCII lines ending in ``\\n``)::

    servoj([q1,q2,q3,q4,q5,q6], a, v, t, lookahead_time, gain)   # a, v ignored (as on UR)
    stopj(a)                                                     # decelerate to a stop
    stats()                                                      # reply: one JSON line of counters

``t`` in (0, 0.1] s, ``lookahead_time`` in [0.03, 0.2] s, ``gain`` in [100, 2000] (URScript's
ranges; out-of-range commands are refused and counted). Every accepted line is also the
keepalive: when no line arrives for ``keepalive`` seconds (0.1 by default) the servo program
stops and the arm decelerates and holds (runtime_state STOPPED) until the next servoj.

One client per channel: a second connection while one is open is closed at once with a text
message (RTDE 'M' / a script line starting ``error:``) and counted. Malformed packages
(wrong size, unknown type, wrong version, a line that does not parse) are counted and ignored.

The servo model (ours, not UR's internals): every 2 ms the reference moves toward the latest
target, reaching it in ``t`` (linear interpolation), then passes through a first-order filter
with time constant ``lookahead_time`` (more lookahead: smoother, more lag), clipped to the
joint velocity limits; ``gain`` is range-checked but not modelled.
"""

from __future__ import annotations

import re
import struct

RTDE_PROTOCOL_VERSION = 2
HEADER = struct.Struct(">HB")
REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
SETUP_OUTPUTS = ord("O")
START = ord("S")
PAUSE = ord("P")
DATA_PACKAGE = ord("U")
TEXT_MESSAGE = ord("M")
URCONTROL_VERSION = (5, 11, 0, 0)

CONTROL_HZ = 500
KEEPALIVE_S = 0.1

#: field name -> (RTDE type, struct format)
FIELDS = {
    "timestamp": ("DOUBLE", "d"),
    "target_q": ("VECTOR6D", "6d"),
    "actual_q": ("VECTOR6D", "6d"),
    "actual_qd": ("VECTOR6D", "6d"),
    "target_qd": ("VECTOR6D", "6d"),
    "actual_joint_torques": ("VECTOR6D", "6d"),
    "robot_mode": ("INT32", "i"),
    "runtime_state": ("UINT32", "I"),
    "speed_scaling": ("DOUBLE", "d"),
}
ROBOT_MODE_RUNNING = 7
RUNTIME_STOPPED, RUNTIME_PLAYING = 1, 2

SERVOJ_T = (1e-3, 0.1)
LOOKAHEAD = (0.03, 0.2)
GAIN = (100.0, 2000.0)

_NUM = r"\s*([-+0-9.eE]+|nan|inf)\s*"
SERVOJ_RE = re.compile(r"\s*servoj\(\s*\[" + ",".join([_NUM] * 6) + r"\]\s*," + ",".join([_NUM] * 5) + r"\)\s*")
STOPJ_RE = re.compile(r"\s*stopj\(" + _NUM + r"\)\s*")


def package(ptype: int, payload: bytes = b"") -> bytes:
    return HEADER.pack(HEADER.size + len(payload), ptype) + payload


def recipe_struct(names) -> struct.Struct:
    return struct.Struct(">B" + "".join(FIELDS[n][1] for n in names))


def servoj_line(q, t: float = 0.002, lookahead_time: float = 0.1, gain: float = 300.0) -> bytes:
    qs = ",".join(repr(float(x)) for x in q)
    return f"servoj([{qs}],0,0,{t!r},{lookahead_time!r},{gain!r})\n".encode()
