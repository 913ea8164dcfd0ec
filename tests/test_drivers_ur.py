"""The UR-style box (RTDE-like stream + servoj script channel) and its ur_rtde-like clients, over real TCP."""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from robocourse.drivers import BoxStartError, start_ur_box
from robocourse.drivers import ur_protocol as up
from robocourse.drivers.ur_client import RTDEControlInterface, RTDEError, RTDEReceiveInterface

# the box streams RTDE at 500 Hz and stops on a keepalive lapse: these run alone (tests/conftest.py)
pytestmark = pytest.mark.serial


@pytest.fixture
def box():
    b = start_ur_box(keepalive=0.1)
    yield b
    b.stop()


def test_handshake_negotiates_recipe_types_and_streams_packages(box):
    r = RTDEReceiveInterface(port=box.ports["rtde"], frequency=500,
                             variables=("timestamp", "actual_q", "robot_mode", "runtime_state"))
    assert r.controller_version == up.URCONTROL_VERSION
    assert r.types == ["DOUBLE", "VECTOR6D", "INT32", "UINT32"]
    assert r.receive(2.0) >= 1
    t1 = r.getTimestamp()
    np.testing.assert_allclose(r.getActualQ(), [0, -np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0], atol=1e-3)
    assert r.get("robot_mode") == up.ROBOT_MODE_RUNNING
    assert r.getRuntimeState() == up.RUNTIME_STOPPED
    time.sleep(0.05)
    assert r.receive(2.0) >= 1 and r.getTimestamp() > t1
    r.close()


def test_recipe_with_unknown_field_or_bad_frequency_is_refused_with_reason(box):
    s = socket.create_connection(("127.0.0.1", box.ports["rtde"]), timeout=2)
    s.sendall(up.package(up.SETUP_OUTPUTS, struct.pack(">d", 500.0) + b"actual_q,actual_TCP_force"))
    time.sleep(0.1)
    data = s.recv(4096)
    msg = up.package(up.TEXT_MESSAGE, b"unknown fields ['actual_TCP_force']")
    assert data == msg + up.package(up.SETUP_OUTPUTS, b"\x00VECTOR6D,NOT_FOUND")
    s.sendall(up.package(up.START))                     # no accepted recipe: START is refused
    assert s.recv(64) == up.package(up.START, b"\x00")
    s.close()
    time.sleep(0.05)
    with pytest.raises(ValueError, match="unknown RTDE output"):
        RTDEReceiveInterface(port=box.ports["rtde"], variables=("actual_TCP_force",))
    with pytest.raises(RTDEError, match=r"frequency 900.0 Hz must be in \(0, 500\]"):
        RTDEReceiveInterface(port=box.ports["rtde"], frequency=900)


def test_servoj_stream_is_followed_then_keepalive_lapse_stops_and_holds():
    box = start_ur_box(keepalive=0.4)        # generous: a loaded machine may pause this test's loop
    r = RTDEReceiveInterface(port=box.ports["rtde"])
    c = RTDEControlInterface(port=box.ports["script"])
    r.receive(2.0)
    q0 = r.getActualQ()
    target = q0.copy()
    target[0] += 0.25
    for _ in range(400):                                   # ~0.8 s of 2 ms targets
        c.servoJ(target, time=0.002, lookahead_time=0.05, gain=300)
        r.receive(0.002)
    assert r.getRuntimeState() == up.RUNTIME_PLAYING
    time.sleep(0.8)                                        # no line for > keepalive (0.4 s)
    r.receive(2.0)
    stats = c.box_stats()                                  # stats() is not a servoj: stays stopped
    assert stats["keepalive_lapsed"] == 1 and stats["playing"] is False and stats["servoj"] == 400
    r.receive(0.1)
    assert r.getRuntimeState() == up.RUNTIME_STOPPED
    assert abs(r.getActualQ()[0] - target[0]) < 0.01       # it got there, and holds
    held = r.getActualQ()
    time.sleep(0.2)
    r.receive(2.0)
    assert np.max(np.abs(r.getActualQ() - held)) < 1e-3
    r.close()
    c.close()
    box.stop()


def test_servoj_out_of_range_is_refused_by_the_client_and_counted_by_the_box(box):
    c = RTDEControlInterface(port=box.ports["script"])
    with pytest.raises(ValueError, match=r"lookahead_time=0.5 must be in \[0.03, 0.2\]"):
        c.servoJ(np.zeros(6), lookahead_time=0.5)
    c.send_line(b"servoj([0,0,0,0,0,0],0,0,0.002,0.1,5000)\n")      # gain 5000 > 2000
    c.send_line(b"servoj([nan,0,0,0,0,0],0,0,0.002,0.1,300)\n")     # non-finite target
    c.send_line(b"movej(nothing)\n")
    stats = c.box_stats()
    assert stats["rx_out_of_range"] == 2 and stats["rx_bad_line"] == 1 and stats.get("servoj", 0) == 0
    c.close()


def test_malformed_rtde_packages_are_counted_and_the_box_keeps_streaming(box):
    s = socket.create_connection(("127.0.0.1", box.ports["rtde"]), timeout=2)
    s.sendall(up.package(up.REQUEST_PROTOCOL_VERSION, struct.pack(">H", 3)))    # wrong version
    assert s.recv(64) == up.package(up.REQUEST_PROTOCOL_VERSION, b"\x00")
    s.sendall(up.package(ord("X")))                                            # unknown type
    s.sendall(up.package(up.REQUEST_PROTOCOL_VERSION, b"\x02"))                # payload too short
    s.sendall(struct.pack(">HB", 1, ord("V")))                                 # size below the header
    time.sleep(0.1)
    c = RTDEControlInterface(port=box.ports["script"])
    stats = c.box_stats()
    assert (stats["rx_bad_version"], stats["rx_bad_type"], stats["rx_bad_size"]) == (1, 1, 2)
    s.close()
    time.sleep(0.1)
    r = RTDEReceiveInterface(port=box.ports["rtde"])     # the box still serves a well-behaved client
    assert r.receive(2.0) >= 1
    r.close()
    c.close()


def test_second_client_on_each_channel_is_refused(box):
    r = RTDEReceiveInterface(port=box.ports["rtde"])
    c = RTDEControlInterface(port=box.ports["script"])
    with pytest.raises(RTDEError, match="busy: another RTDE client"):
        RTDEReceiveInterface(port=box.ports["rtde"])
    with pytest.raises(RTDEError, match="busy: another script client"):
        RTDEControlInterface(port=box.ports["script"])
    assert c.box_stats()["rejected_connects"] == 2
    assert r.receive(2.0) >= 1
    r.close()
    c.close()


def test_port_in_use_refuses_to_start_with_the_port_named():
    taken = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    port = taken.getsockname()[1]
    try:
        with pytest.raises(BoxStartError, match=rf"port {port}.*Address already in use"):
            start_ur_box(rtde_port=port)
    finally:
        taken.close()


def test_killed_box_closes_the_stream():
    b = start_ur_box()
    r = RTDEReceiveInterface(port=b.ports["rtde"])
    r.receive(2.0)
    b.kill()
    deadline = time.monotonic() + 5
    while not r.closed_by_peer and time.monotonic() < deadline:
        r.receive(0.05)
    assert r.closed_by_peer
    r.close()
    b.stop()


def test_stats_line_is_json(box):
    c = RTDEControlInterface(port=box.ports["script"])
    c.send_line(b"stats()\n")
    line = c.sock.recv(65536).decode()
    assert json.loads(line)["ticks"] >= 0
    c.close()


# a client in its own process: RTDE stream + servoj toward joint 0 + 0.3 rad, forever; says STREAMING
_CHILD = """
import sys, time
from robocourse.drivers.ur_client import RTDEControlInterface, RTDEReceiveInterface
r = RTDEReceiveInterface(port=int(sys.argv[1]))
c = RTDEControlInterface(port=int(sys.argv[2]))
r.receive(2.0)
q = r.getActualQ()
q[0] += 0.3
k = 0
while True:
    r.receive(0.0)
    c.servoJ(q, time=0.002, lookahead_time=0.1)
    k += 1
    if k == 100:
        print("STREAMING", flush=True)
    time.sleep(0.002)
"""


def _retry(make, seconds=10.0):
    deadline = time.monotonic() + seconds
    while True:
        try:
            return make()
        except RTDEError as exc:
            if "busy" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.02)


def test_client_process_killed_frees_both_channels_and_the_next_client_moves_the_arm():
    box = start_ur_box(keepalive=0.4)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    child = subprocess.Popen([sys.executable, "-c", _CHILD, str(box.ports["rtde"]), str(box.ports["script"])],
                             stdout=subprocess.PIPE, env=env)
    try:
        assert child.stdout.readline() == b"STREAMING\n"
        os.kill(child.pid, signal.SIGKILL)             # no goodbye: the kernel closes its sockets
        assert child.wait(5) == -signal.SIGKILL
        r = _retry(lambda: RTDEReceiveInterface(port=box.ports["rtde"]))
        c = _retry(lambda: RTDEControlInterface(port=box.ports["script"]))
        stats = c.box_stats()
        assert stats["connects"] == 4 and stats["disconnects"] == 2      # two channels, twice
        assert r.receive(2.0) >= 1
        goal = r.getActualQ()
        goal[1] += 0.2
        deadline = time.monotonic() + 10
        while abs(r.getActualQ()[1] - goal[1]) > 0.01 and time.monotonic() < deadline:
            c.servoJ(goal, time=0.002, lookahead_time=0.05)
            r.receive(0.01)
        assert abs(r.getActualQ()[1] - goal[1]) < 0.01       # the new client controls the arm
        assert c.box_stats()["servoj"] > stats["servoj"]
        r.close()
        c.close()
    finally:
        child.kill()
        child.wait()
        box.stop()


def test_a_hung_script_client_is_replaced_once_silent_longer_than_the_keepalive():
    box = start_ur_box(keepalive=0.2)
    try:
        hung = socket.create_connection(("127.0.0.1", box.ports["script"]), timeout=2)   # connects, never writes
        c = _retry(lambda: RTDEControlInterface(port=box.ports["script"]))
        stats = c.box_stats()
        assert stats["released_silent_clients"] == 1 and stats["connects"] == 2 and stats["disconnects"] == 1
        hung.settimeout(2)
        assert hung.recv(64) == b""                   # the box closed the hung connection
        hung.close()
        c.close()
    finally:
        box.stop()
