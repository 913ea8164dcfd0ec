"""Chapter 5's Franka-style driver check: the solution's read()/write() survive the scripted pauses
against a real box process; a loop that answers stale states, a wrong seq, an undecoded errors
field, delegation to franka_client.Robot, or a crash score zero, and no box process is left."""

from pathlib import Path

import nbformat
import numpy as np
import psutil
import pytest

from robocourse.grading import discover
from robocourse.grading.checks import get, run_check

# a Franka-style link under CpuLoad against the 1 kHz box: run alone (tests/conftest.py: serial)
pytestmark = [pytest.mark.slow, pytest.mark.serial]
SOL = Path(__file__).resolve().parents[1] / "solutions/05_hardware_drivers_exercises.ipynb"


@pytest.fixture(scope="module")
def link_class():
    discover()
    ns: dict = {}
    cell = next(c for c in nbformat.read(SOL, as_version=4).cells if "class FrankaLink" in c.source)
    exec(cell.source, ns)
    return ns["FrankaLink"]


def run(cls, seed=0):
    before = {p.pid for p in psutil.Process().children(recursive=True)}
    r = run_check(get("ch05.franka_link"), cls, rng=np.random.default_rng(seed))
    left = [p for p in psutil.Process().children(recursive=True) if p.pid not in before and p.is_running()
            and p.status() != psutil.STATUS_ZOMBIE]
    assert left == [], f"box processes left behind: {left}"
    return r


def test_the_solution_scores_full_marks_against_the_box(link_class):
    for seed in range(2):
        r = run(link_class, seed)
        assert r.passed and r.points == r.weight == 3, r.message
        assert "no reflex; the deliberate stall's reflex seen in .errors" in r.message


def test_a_loop_that_answers_queued_states_one_by_one_scores_zero(link_class):
    import select

    from robocourse.drivers import franka_protocol as fp

    class OneAtATime(link_class):
        def read(self, timeout=0.1):          # the next datagram, not the newest one
            if not select.select([self.sock], [], [], timeout)[0]:
                return False
            data = self.sock.recv(65536)
            if len(data) != fp.HEADER.size + self.state.size:
                return False
            values = self.state.unpack_from(data, fp.HEADER.size)
            self.q, self.errors, self.seq = np.array(values[:self.n]), values[-1], fp.HEADER.unpack_from(data)[4]
            return True

    r = run(OneAtATime)
    assert not r.passed and r.points == 0 and "drain the socket and keep the newest" in r.message


def test_a_command_for_the_next_state_scores_zero(link_class):
    from robocourse.drivers import franka_protocol as fp

    class AheadByOne(link_class):
        def write(self, q):
            self.sock.send(fp.encode_command(self.n, self.seq + 1, fp.MODE_POSITION, q))
            self.answered = self.seq

    r = run(AheadByOne)
    assert not r.passed and r.points == 0 and "rx_bad_seq" in r.message


def test_errors_never_decoded_scores_zero(link_class):
    class Blind(link_class):
        def read(self, timeout=0.1):
            fresh = super().read(timeout)
            self.errors = 0
            return fresh

    r = run(Blind)
    assert not r.passed and r.points == 0 and "decode the state's errors field" in r.message


def test_delegating_to_franka_client_robot_scores_zero():
    from robocourse.drivers.franka_client import Robot

    class Wrapped:
        def __init__(self, port):
            self.robot = Robot(port=port)

        def read(self, timeout=0.1):
            fresh = self.robot.read_latest(timeout)
            self.q, self.seq, self.errors = self.robot.q.copy(), self.robot.last_seq, self.robot.errors
            return fresh

        def write(self, q):
            self.robot.write_command(q)

        def close(self):
            self.robot.close()

    r = run(Wrapped)
    assert not r.passed and r.points == 0


def test_a_read_that_crashes_mid_run_fails_cleanly_and_stops_the_box(link_class):
    class Crashes(link_class):
        calls = 0

        def read(self, timeout=0.1):
            Crashes.calls += 1
            if Crashes.calls > 200:
                raise OSError("cable pulled")
            return super().read(timeout)

    r = run(Crashes)
    assert not r.passed and r.points == 0 and "OSError: cable pulled" in r.message


def test_a_box_that_never_moved_is_the_students_fault_not_a_check_error():
    # every command ahead by one, none ever accepted: the box stays idle, so the deliberate stall
    # cannot trip a reflex; the judge must say why (not report a broken check)
    from robocourse.drivers.checks import _inputs, check_franka_link
    from robocourse.grading import CheckFailed

    inputs = _inputs(np.random.default_rng(0))
    out = {"error": None, "seqs": list(range(10, 1510)), "read_timeouts": 0, "box_seq_after_pause": [],
           "q0": [0.0] * 6, "q_final": [0.0] * 6, "errors_after_stall": 0,
           "stats": {"rx_bad_seq": 1600, "ticks_moving": 0, "commands_ok": 0, "late": 0, "missed": 0},
           "stats_after_stall": {"reflexes": 0}}
    with pytest.raises(CheckFailed, match="never accepted a command") as err:
        check_franka_link(inputs, out)
    assert "1600 × rx_bad_seq" in str(err.value)
