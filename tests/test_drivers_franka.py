"""The Franka-style box and its libfranka-like client over real loopback UDP (no timed assertions:
the machine is shared, so the reflex tests stop answering on purpose and the others allow many misses)."""

from __future__ import annotations

import os
import signal
import socket
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from robocourse.drivers import BoxStartError, start_franka_box
from robocourse.drivers import franka_protocol as fp
from robocourse.drivers.franka_client import (
    ControlException,
    JointPositions,
    NetworkException,
    Robot,
    Torques,
)

# the box runs libfranka's 1 kHz protocol: a missed tick is a communication reflex, so these
# run alone (tests/conftest.py: serial)
pytestmark = pytest.mark.serial

LENIENT = 100_000   # missed ticks in a row before the reflex, when a test is not about the reflex


@pytest.fixture
def box():
    b = start_franka_box(max_missed=LENIENT, client_timeout=LENIENT)
    yield b
    b.stop()


def wait_for(cond, seconds=5.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.01)
    return False


def ramp_callback(q0, joint, delta, ramp_ticks, ticks):
    """A Robot.control callback: move ``joint`` by ``delta`` rad over ``ramp_ticks``, finish after ``ticks``."""
    def ramp(state, period):
        ramp.k += 1
        q = q0.copy()
        q[joint] += delta * min(1.0, ramp.k / ramp_ticks)
        return JointPositions(q, motion_finished=ramp.k >= ticks)

    ramp.k = 0
    return ramp


def test_state_carries_six_joints_and_increasing_sequence_numbers(box):
    with Robot(port=box.ports["udp"]) as robot:
        assert (robot.n, robot.period_us, robot.max_missed) == (6, 1000, LENIENT)
        s1 = robot.read_once()
        s2 = robot.read_once()
        assert s2.seq > s1.seq >= 1
        np.testing.assert_allclose(s1.q, [0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0], atol=1e-3)
        assert s1.robot_mode == "idle" and s1.current_errors == []
        assert s1.tau_J.shape == (6,) and abs(s1.tau_J[1]) > 1.0   # the shoulder holds the arm up


def test_position_control_moves_joint_to_the_commanded_ramp_end(box):
    with Robot(port=box.ports["udp"]) as robot:
        q0 = robot.read_once().q

        ramp = ramp_callback(q0, joint=0, delta=0.3, ramp_ticks=500, ticks=1500)
        last = robot.control(ramp)
        assert ramp.k == 1500
        assert abs(last.q[0] - (q0[0] + 0.3)) < 0.01
        assert wait_for(lambda: robot.read_once().robot_mode == "idle")   # motion_finished ended the motion
        stats = robot.box_stats()
        assert stats["commands_ok"] + stats.get("missed", 0) == stats["ticks_moving"]  # a zero counter is absent
        # every command sent is accounted for: applied, late (after the next tick) or replaced by a later one
        assert stats["commands_ok"] + stats.get("late", 0) + stats.get("duplicates", 0) == 1500


def test_zero_torque_command_holds_because_the_box_adds_gravity(box):
    with Robot(port=box.ports["udp"]) as robot:
        q0 = robot.read_once().q

        def zero(state, period):
            zero.k += 1
            return Torques(np.zeros(6), motion_finished=zero.k >= 500)

        zero.k = 0
        last = robot.control(zero, mode="torque")
        assert np.max(np.abs(last.q - q0)) < 0.02


def test_missing_commands_trigger_reflex_arm_holds_until_recovery():
    box = start_franka_box(max_missed=5)
    try:
        with Robot(port=box.ports["udp"]) as robot:
            robot.read_latest()
            robot.write_command(robot.q.copy())        # one command: the robot is moving
            assert wait_for(lambda: robot.read_latest(0.1) and robot.errors != 0)
            assert fp.error_names(robot.errors) == ["communication_constraints_violation"]
            assert robot.robot_mode == fp.ROBOT_REFLEX
            q_reflex = robot.q.copy()
            for _ in range(20):                        # commands are ignored while in reflex
                robot.read_latest()
                target = q_reflex.copy()
                target[0] += 0.5
                robot.write_command(target)
            robot.read_latest()
            assert np.max(np.abs(robot.q - q_reflex)) < 1e-3       # brakes: the arm holds
            stats = robot.box_stats()
            assert stats["reflexes"] == 1 and stats["missed"] >= 6 and stats["ignored_in_reflex"] >= 1
            with pytest.raises(ControlException, match="communication_constraints_violation"):
                robot.control(lambda s, p: JointPositions(s.q))
            assert robot.automatic_error_recovery() == []
            robot.read_latest()
            assert robot.errors == 0 and robot.robot_mode == fp.ROBOT_IDLE
            assert robot.box_stats()["recoveries"] == 1
    finally:
        box.stop()


def raw_socket(box):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.connect(("127.0.0.1", box.ports["udp"]))
    s.settimeout(2.0)
    return s


def test_malformed_datagrams_are_counted_by_reason_and_ignored(box):
    with Robot(port=box.ports["udp"]) as robot:
        robot.read_latest()
        seq = robot.last_seq
        n = robot.n
        bad = robot.sock                     # the connected client's socket: not "foreign"
        bad.send(b"RCF")                                                             # short
        bad.send(struct.pack("<4sBBHQ", b"RCFR", 2, fp.COMMAND, n, seq) + bytes(56))  # version 2
        bad.send(struct.pack("<4sBBHQ", b"XXXX", 1, fp.COMMAND, n, seq) + bytes(56))  # magic
        bad.send(fp.header(42))                                                      # unknown type
        bad.send(fp.encode_command(n, seq + 10_000, fp.MODE_POSITION, robot.q))      # future seq
        bad.send(fp.encode_command(n, 0, fp.MODE_POSITION, robot.q))                 # old seq
        bad.send(fp.header(fp.COMMAND, 7, seq) + bytes(64))                          # 7 joints
        bad.send(fp.encode_command(n, seq, fp.MODE_POSITION, robot.q)[:-8])           # cut short
        stats = robot.box_stats()
        assert stats["rx_short"] == 1
        assert stats["rx_bad_version"] == 1
        assert stats["rx_bad_magic"] == 1
        assert stats["rx_bad_type"] == 1
        assert stats["rx_bad_seq"] == 1
        assert stats["late"] >= 1
        assert stats["rx_bad_length"] == 2
        before = robot.read_once().seq
        assert robot.read_once().seq > before            # the box keeps streaming
    assert box.alive()


def test_second_client_is_refused_while_the_first_keeps_its_stream(box):
    with Robot(port=box.ports["udp"]) as first:
        with pytest.raises(NetworkException, match="busy: another client"):
            Robot(port=box.ports["udp"])
        assert first.read_once().seq > 0
        assert first.box_stats()["rejected_connects"] == 1
    with Robot(port=box.ports["udp"]) as again:      # after DISCONNECT a new client is welcome
        assert again.read_once().seq > 0


def test_port_in_use_refuses_to_start_with_the_port_named():
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", 0))
    port = taken.getsockname()[1]
    try:
        with pytest.raises(BoxStartError, match=rf"port {port}.*Address already in use.*pass 0 for a free one"):
            start_franka_box(port=port)
    finally:
        taken.close()


def test_client_refuses_port_zero_and_reports_a_silent_box():
    with pytest.raises(ValueError, match="port=0"):
        Robot(port=0)
    silent = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    silent.bind(("127.0.0.1", 0))
    try:
        with pytest.raises(NetworkException, match="within 0.3 s"):
            Robot(port=silent.getsockname()[1], timeout=0.3)
    finally:
        silent.close()


def test_killed_box_makes_the_client_raise_network_exception():
    box = start_franka_box(max_missed=LENIENT)
    robot = Robot(port=box.ports["udp"], timeout=0.3)
    robot.read_once()
    box.kill()
    with pytest.raises(NetworkException):
        for _ in range(1000):
            robot.read_once()
    robot.close()
    box.stop()


# a client in its own process: connects, moves joint 0 slowly forever, says MOVING once it is in control
_CHILD = """
import sys
from robocourse.drivers.franka_client import JointPositions, Robot
robot = Robot(port=int(sys.argv[1]))
q0 = robot.read_once().q.copy()
k = 0
def creep(state, period):
    global k
    k += 1
    if k == 200:
        print("MOVING", flush=True)
    q = q0.copy()
    q[0] += 1e-4 * k
    return JointPositions(q)
robot.control(creep)
"""


def _connect_when_free(port, seconds=10.0):
    deadline = time.monotonic() + seconds
    while True:
        try:
            return Robot(port=port)
        except NetworkException as exc:
            if "busy" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.02)


def test_client_process_killed_mid_motion_frees_the_slot_and_the_next_client_recovers_and_moves():
    box = start_franka_box(max_missed=1000, client_timeout=50)   # lenient: a loaded machine must not end the motion early
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    child = subprocess.Popen([sys.executable, "-c", _CHILD, str(box.ports["udp"])], stdout=subprocess.PIPE, env=env)
    try:
        assert child.stdout.readline() == b"MOVING\n"
        os.kill(child.pid, signal.SIGKILL)            # no DISCONNECT: the socket just closes
        assert child.wait(5) == -signal.SIGKILL
        with _connect_when_free(box.ports["udp"]) as robot:
            state = robot.read_once()
            assert state.robot_mode == "reflex"              # the motion died with its client
            assert state.current_errors == ["communication_constraints_violation"]
            stats = robot.box_stats()
            assert stats["connects"] == 2 and stats["released_silent_clients"] == 1 and stats["reflexes"] == 1
            assert stats["client"][1] == robot.sock.getsockname()[1]
            assert robot.automatic_error_recovery() == []
            q0 = robot.read_once().q.copy()

            last = robot.control(ramp_callback(q0, joint=1, delta=0.2, ramp_ticks=400, ticks=1000))
            assert abs(last.q[1] - (q0[1] + 0.2)) < 0.01     # the new client controls the arm
            assert robot.box_stats()["recoveries"] == 1
    finally:
        child.kill()
        child.wait()
        box.stop()


def test_same_client_connecting_twice_is_acknowledged_again_and_keeps_its_slot(box):
    with Robot(port=box.ports["udp"]) as robot:
        robot.read_once()
        robot.sock.send(fp.header(fp.CONNECT))        # a retry: this client's ACK could have been lost
        deadline = time.monotonic() + 5
        acked = False
        while not acked and time.monotonic() < deadline:
            msg = robot._recv(0.1)
            acked = msg is not None and fp.HEADER.unpack_from(msg)[2] == fp.CONNECT_ACK
        assert acked
        stats = robot.box_stats()
        assert (stats["connects"], stats["repeated_connects"], stats.get("rejected_connects", 0)) == (1, 1, 0)
        assert stats["client"][1] == robot.sock.getsockname()[1]
        assert robot.read_once().seq > 0                 # the stream goes on to the same client
        # a second Robot object in the same process is a second socket: refused like any other client
        with pytest.raises(NetworkException, match="busy: another client"):
            Robot(port=box.ports["udp"])


def test_a_silent_live_client_loses_its_slot_to_a_newcomer_after_client_timeout():
    box = start_franka_box(max_missed=LENIENT, client_timeout=30)
    try:
        first = Robot(port=box.ports["udp"], timeout=0.3)
        first.read_once()
        second = _connect_when_free(box.ports["udp"])   # first sends nothing: after 30 ticks it is "gone"
        assert second.read_once().seq > 0
        first.resync()
        assert not first.read_latest(0.2)               # the states now go to the newcomer
        first.write_command(first.q)                    # and the old client's commands are foreign
        assert wait_for(lambda: second.box_stats().get("rx_foreign", 0) == 1)
        stats = second.box_stats()
        assert stats["released_silent_clients"] == 1 and stats.get("reflexes", 0) == 0   # it was not moving
        first.close()
        second.close()
    finally:
        box.stop()


def test_client_timeout_below_one_tick_is_refused_with_the_rule():
    with pytest.raises(BoxStartError, match=r"client_timeout=0 must be a whole number of ticks >= 1"):
        start_franka_box(client_timeout=0)


def test_command_with_a_future_sequence_number_is_refused_and_not_applied(box):
    with Robot(port=box.ports["udp"]) as robot:
        robot.read_latest()
        q = robot.q.copy()
        target = q.copy()
        target[0] += 0.5
        for _ in range(50):                              # a state the box has not sent (and will not for 1000 s)
            robot.read_latest()
            robot.sock.send(fp.encode_command(robot.n, robot.last_seq + 1_000_000, fp.MODE_POSITION, target))
        time.sleep(0.05)
        stats = robot.box_stats()
        assert stats["rx_bad_seq"] == 50
        assert stats.get("commands_ok", 0) == 0 and stats.get("motions", 0) == 0
        state = robot.read_once()
        assert state.robot_mode == "idle"
        assert abs(state.q[0] - q[0]) < 1e-3             # nothing moved


def test_stats_are_answered_to_a_non_client_and_the_histogram_counts_every_round_trip(box):
    from robocourse.drivers.franka_box import RTT_HIST_EDGES_US
    from robocourse.drivers.franka_client import query_box_stats

    with Robot(port=box.ports["udp"]) as robot:
        def hold(state, period):
            hold.k += 1
            return JointPositions(state.q, motion_finished=hold.k >= 300)

        hold.k = 0
        robot.control(hold)
        stats = query_box_stats(port=box.ports["udp"])       # a socket of its own, never CONNECTed
        assert stats["client"][1] == robot.sock.getsockname()[1]   # the holder keeps the slot
        assert stats.get("rejected_connects", 0) == 0 and stats.get("rx_foreign", 0) == 0
        assert len(stats["rtt_hist_counts"]) == len(RTT_HIST_EDGES_US) - 1
        assert sum(stats["rtt_hist_counts"]) == stats["rtt_n"] == 300   # one round trip per command answered
    with pytest.raises(ValueError, match="port=0"):
        query_box_stats(port=0)


def test_roundtrip_state_rate_never_exceeds_the_box_tick_rate_even_after_a_slow_start():
    from robocourse.drivers.measure import franka_roundtrip

    calls = []

    def slow_first():                          # a 50 ms stall at the first state: states pile up meanwhile
        calls.append(1)
        if len(calls) == 1:
            time.sleep(0.05)

    r = franka_roundtrip(0.3, work=slow_first)
    assert r.states_sent >= 1 and r.wall_s > 0
    assert r.states_sent <= r.wall_s * 1000 + 2       # sequence numbers over wall time: at most one per 1 ms tick
    assert sum(r.rtt_hist_counts) >= r.commands_ok    # every command answered in time has its round trip binned
