"""Measure the UR-style box through ur_rtde on this machine: receive rate and jitter, the servoJ round
trip, start-up. The figures benchmarks/driver_roundtrip.py and chapter 5 print.

Counterpart: what ur_rtde's own examples and UR's RTDE guide tell you to check on a real robot
(the receive rate at 500 Hz, how long a servoJ target takes to show up in the state). Each
function starts a fresh box (``physics=False``: the same protocol, timing and processes with no
arm behind them, the floor of the same run) and uses ur_rtde from PyPI as the client.

- :func:`receive_rate`: ur_rtde's ``RTDEReceiveInterface`` records every package its receive
  thread takes in (``startFileRecording``): packages per wall second and the share of the
  controller's ticks received; the arrival jitter is measured beside it by a plain socket
  client on the same box (``recv`` timestamps: ur_rtde does not expose arrival times).
- :func:`servoj_round_trip`: ``servoJ`` with a new target, then poll ``getTargetQ()`` until the
  state reflects it: the time from the call to that state, in this process.
- :func:`startup`: from ``start_ur_box()`` to the constructor of ``RTDEReceiveInterface``
  returning (it returns after the first data package).
"""

from __future__ import annotations

import os
import socket
import struct
import tempfile
import time
from dataclasses import dataclass

import numpy as np

from . import rtde, start_ur_box
from .ur_box import read_stats

PERIOD_S = 0.002
RT_PRIORITY = 80        # ur_rtde's rt_priority for its receive threads when ``realtime`` (SCHED_FIFO; refused quietly
                        # without the permission, as the box's settings are)


@dataclass(frozen=True)
class ReceiveRate:
    """ur_rtde receiving at 500 Hz for ``seconds``: its packages per wall second, the share of the
    box's ticks it got, and the arrival jitter at a socket client (us: |interval - 2 ms|)."""

    physics: bool
    seconds: float
    packages: int
    rate_hz: float
    ticks_share: float
    box_overruns: int
    jitter_p50_us: float
    jitter_p99_us: float
    jitter_max_us: float


@dataclass(frozen=True)
class RoundTrip:
    """servoJ call -> the first state whose target_q reflects it, in us (percentiles over ``n``)."""

    physics: bool
    n: int
    p50_us: float
    p99_us: float
    max_us: float
    lost: int


def _arrivals(host: str, seconds: float) -> np.ndarray:
    """recv times (s) of the data packages a plain RTDE client gets at 500 Hz for ``seconds``."""
    s = socket.create_connection((host, 30004), timeout=3)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    buf = b""

    def ask(ptype, payload=b""):
        nonlocal buf
        s.sendall(rtde.package(ptype, payload))
        while True:
            while len(buf) >= 3 and len(buf) >= rtde.HEADER.unpack_from(buf)[0]:
                size, t = rtde.HEADER.unpack_from(buf)
                body, buf = buf[3:size], buf[size:]
                if t == ptype:
                    return body
            buf += s.recv(65536)

    try:
        ask(rtde.REQUEST_PROTOCOL_VERSION, struct.pack(">H", 2))
        ask(rtde.SETUP_OUTPUTS, struct.pack(">d", 500.0) + b"timestamp")
        ask(rtde.START)
        times = []
        size = 3 + 1 + 8
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            data = s.recv(65536)
            now = time.monotonic()
            if not data:
                break
            buf += data
            while len(buf) >= size:       # several packages in one recv arrived together
                times.append(now)
                buf = buf[size:]
        return np.array(times)
    finally:
        s.close()


def receive_rate(seconds: float = 2.0, physics: bool = True, realtime: bool = False) -> ReceiveRate:
    """``realtime``: the box and ur_rtde's receive thread try SCHED_FIFO (see :data:`RT_PRIORITY`)."""
    import rtde_receive

    box = start_ur_box(physics=physics, realtime=realtime)
    path = os.path.join(tempfile.mkdtemp(prefix="ur_rate_"), "rtde.csv")
    try:
        r = rtde_receive.RTDEReceiveInterface(box.host, 500.0, ["timestamp"], False, False,
                                              RT_PRIORITY if realtime else 0)
        s0 = read_stats(box.host)
        r.startFileRecording(path, ["timestamp"])
        t0 = time.monotonic()
        arrivals = _arrivals(box.host, seconds)
        r.stopFileRecording()
        wall = time.monotonic() - t0
        s1 = read_stats(box.host)
        r.disconnect()
    finally:
        box.stop()
    with open(path) as f:
        stamps = [float(x) for x in f.read().split()[1:]]
    os.remove(path)
    os.rmdir(os.path.dirname(path))
    ticks = round((stamps[-1] - stamps[0]) / PERIOD_S) + 1 if stamps else 0
    jitter = np.abs(np.diff(arrivals) - PERIOD_S) * 1e6 if len(arrivals) > 2 else np.array([np.nan])
    return ReceiveRate(physics, seconds, len(stamps), len(stamps) / wall, len(stamps) / ticks if ticks else 0.0,
                       s1["box_overruns"] - s0["box_overruns"], float(np.percentile(jitter, 50)),
                       float(np.percentile(jitter, 99)), float(jitter.max()))


def servoj_round_trip(n: int = 200, physics: bool = True, realtime: bool = False) -> RoundTrip:
    import rtde_control
    import rtde_receive

    box = start_ur_box(physics=physics, realtime=realtime)
    try:
        prio = RT_PRIORITY if realtime else 0
        r = rtde_receive.RTDEReceiveInterface(box.host, 500.0, ["timestamp", "target_q"], False, False, prio)
        c = rtde_control.RTDEControlInterface(box.host, 500.0, rtde_control.RTDEControlInterface.FLAG_UPLOAD_SCRIPT,
                                              50002, prio)
        q = np.array(r.getTargetQ())
        samples, lost = [], 0
        for k in range(n):
            before = r.getTargetQ()[0]
            target = q.copy()
            target[0] += 0.01 * (1 if k % 2 == 0 else -1)   # a new target every time, back and forth
            t0 = time.perf_counter()
            c.servoJ(list(target), 0.0, 0.0, 0.002, 0.03, 300)
            while r.getTargetQ()[0] == before:
                if time.perf_counter() - t0 > 0.1:
                    lost += 1
                    break
            else:
                samples.append((time.perf_counter() - t0) * 1e6)
            time.sleep(0.004)                               # let the reference settle between trials
        c.servoStop(10.0)
        c.stopScript()
        c.disconnect()
        r.disconnect()
    finally:
        box.stop()
    a = np.array(samples) if samples else np.array([np.nan])
    return RoundTrip(physics, n, float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max()), lost)


def startup(physics: bool = True) -> float:
    """Seconds from ``start_ur_box()`` to ur_rtde's first data package."""
    import rtde_receive

    t0 = time.monotonic()
    box = start_ur_box(physics=physics)
    try:
        r = rtde_receive.RTDEReceiveInterface(box.host, 500.0, ["timestamp"])
        took = time.monotonic() - t0
        r.disconnect()
    finally:
        box.stop()
    return took


def interpreter_startup() -> float:
    """Seconds for a Python process that only imports numpy and MuJoCo (what any box must load): the floor."""
    import subprocess
    import sys

    t0 = time.monotonic()
    subprocess.run([sys.executable, "-c", "import numpy, mujoco"], check=True,
                   env=dict(os.environ, MUJOCO_GL="disable"))
    return time.monotonic() - t0
