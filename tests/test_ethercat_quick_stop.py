"""CiA 402 Quick stop on the simulated drive: Operation enabled -> Quick stop active (sw & 0x6F == 0x07)
for as long as the drive decelerates, then Switch on disabled for quick_stop_option_code 0..4 (default 2:
quick-stop ramp), or stay in Quick stop active for 5..8, where enable operation returns to Operation
enabled. Statuswords are exact (0x0200 is 'remote', 0x0400 'target reached')."""

import math

import pytest

from robocourse.ethercat.bus import Bus
from robocourse.ethercat.devices import (
    MODE_CSP,
    MODE_CSV,
    OPERATION_ENABLED,
    QUICK_STOP_ACTIVE,
    SWITCH_ON_DISABLED,
    Cia402Drive,
    Coupler,
    cia402_state,
    drive_inputs,
    drive_outputs,
)
from robocourse.ethercat.master import Master

OE_CSP = 0x0637     # operation enabled + remote + target reached (CSP, at rest on target)
OE = 0x0237         # operation enabled + remote
QSA = 0x0217        # quick stop active + remote
SOD = 0x0240        # switch on disabled + remote


class Rig:
    """A drive in OP behind a coupler; ``step(cw, ...)`` runs one 1 ms exchange, returns the statusword."""

    def __init__(self, **drive_kw):
        self.now = 1_000_000_000
        self.drive = Cia402Drive(**drive_kw)
        self.m = Master()
        self.m.open(Bus([Coupler(), self.drive], clock=lambda: self.now))
        self.m.bring_up(dc=False)
        self.slave = self.m.slaves[1]

    def step(self, cw, target_position=None, target_velocity=0, mode=MODE_CSP):
        pos = drive_inputs(self.slave.input)[1] if target_position is None else target_position
        self.slave.output = drive_outputs(cw, pos, target_velocity, 0, mode)
        self.now += 1_000_000
        self.m.send_processdata()
        self.m.receive_processdata()
        return drive_inputs(self.slave.input)[0]

    def enable(self, mode=MODE_CSP, target_velocity=0):
        for cw in (0x06, 0x06, 0x07, 0x07, 0x0F, 0x0F):
            self.step(cw, target_velocity=target_velocity, mode=mode)
        assert cia402_state(self.step(0x0F, target_velocity=target_velocity, mode=mode)) == OPERATION_ENABLED


def test_quick_stop_at_rest_shows_quick_stop_active_for_a_cycle_then_switch_on_disabled():
    rig = Rig()
    rig.enable()
    seq = [rig.step(0x0F)] + [rig.step(0x02) for _ in range(5)]
    # the process data is one exchange behind: the first 0x02 shows up one cycle later
    assert seq == [OE_CSP, OE_CSP, QSA, SOD, SOD, SOD]
    assert rig.drive.quick_stop_option_code == 2                           # the CiA 402 default


def test_quick_stop_while_moving_holds_quick_stop_active_while_it_decelerates_on_the_ramp():
    rig = Rig(quick_stop_deceleration=500.0)                                 # rad/s^2
    v = 10.0                                                                 # rad/s
    counts_per_s = int(round(v / (2 * math.pi) * rig.drive.motor.counts_per_rev))
    rig.enable(MODE_CSV, counts_per_s)
    for _ in range(300):
        rig.step(0x0F, target_velocity=counts_per_s, mode=MODE_CSV)
    assert abs(rig.drive.motor.velocity - v) < 0.5
    seq, speeds = [], []
    for _ in range(80):
        seq.append(rig.step(0x02, target_velocity=counts_per_s, mode=MODE_CSV))
        speeds.append(abs(rig.drive.motor.velocity))
    n_qsa = seq.count(QSA)
    first = seq.index(QSA)
    # exactly: operation enabled, then quick stop active while it brakes, then switch on disabled for good
    assert seq == [OE] * first + [QSA] * n_qsa + [SOD] * (len(seq) - first - n_qsa)
    assert first == 1
    ramp_cycles = v / 500.0 / 1e-3                                           # 20 cycles of 1 ms on the ramp
    assert ramp_cycles - 2 <= n_qsa <= ramp_cycles + 10
    during = speeds[first:first + n_qsa]
    assert all(b <= a + 1e-9 for a, b in zip(during, during[1:]))           # it slows down, never speeds up
    # on the ramp, not a crash stop: at the middle of the ramp it still runs at about half speed
    assert 0.3 * v < speeds[first + 10] < 0.7 * v
    assert speeds[-1] < 1e-3


@pytest.mark.parametrize("code", [5, 6, 7, 8])
def test_option_codes_5_to_8_stay_in_quick_stop_active_and_enable_operation_returns(code):
    rig = Rig(quick_stop_option_code=code)
    rig.enable()
    seq = [rig.step(0x02) for _ in range(6)]
    assert seq == [OE_CSP, QSA, QSA, QSA, QSA, QSA]                          # stopped, and it stays there
    back = [rig.step(0x0F) for _ in range(3)]
    assert back == [QSA, OE_CSP, OE_CSP]                                     # transition 16
    assert rig.drive.target_position == rig.drive.motor.counts             # CSP resumes from where it stopped


@pytest.mark.parametrize("code", [0, 1, 2, 3, 4])
def test_option_codes_0_to_4_refuse_enable_operation_and_end_in_switch_on_disabled(code):
    rig = Rig(quick_stop_option_code=code)
    rig.enable()
    rig.step(0x02)
    seq = [rig.step(0x0F) for _ in range(4)]
    # enable operation is not a way out: the quick stop completes, then switch on disabled
    assert seq[0] == QSA and seq[1:] == [SOD, SOD, SOD]


def test_disable_voltage_leaves_quick_stop_active_at_once():
    rig = Rig(quick_stop_option_code=6)
    rig.enable()
    rig.step(0x02)
    assert rig.step(0x02) == QSA
    assert [rig.step(0x00) for _ in range(2)] == [QSA, SOD]                   # transition 12


def test_the_automatic_transitions_re_enable_after_a_quick_stop():
    # ethercat_driver_ros2 writes enable operation in quick stop active; with the default option code the
    # drive finishes the stop, falls to switch on disabled, and the usual path brings it back
    from robocourse.ethercat.ros2_control import next_controlword

    rig = Rig()
    rig.enable()
    rig.step(0x02)
    sw, cw = rig.step(0x02), 0x02
    states = [cia402_state(sw)]
    for _ in range(12):
        cw = next_controlword(sw, cw, False)
        sw = rig.step(cw)
        if not states or states[-1] != cia402_state(sw):
            states.append(cia402_state(sw))
    assert states[0] == QUICK_STOP_ACTIVE and SWITCH_ON_DISABLED in states and states[-1] == OPERATION_ENABLED


def test_the_option_code_is_object_0x605a_and_bad_values_are_refused():
    with pytest.raises(ValueError, match="quick_stop_option_code"):
        Cia402Drive(quick_stop_option_code=9)
    with pytest.raises(ValueError, match="quick_stop_deceleration"):
        Cia402Drive(quick_stop_deceleration=0.0)
    d = Cia402Drive(mailbox=True)
    assert d.od[(0x605A, 0)].get() == 2
    d.od[(0x605A, 0)].set(6)
    assert d.quick_stop_option_code == 6


def test_an_sdo_write_out_of_range_aborts_and_changes_nothing():
    from robocourse.ethercat.coe import ABORT_VALUE_RANGE, parse_sdo_response, sdo_request

    d = Cia402Drive(mailbox=True)
    reply = d.coe_reply(sdo_request(0x605A, 0, 1, (9).to_bytes(2, "little")))
    assert parse_sdo_response(reply, 0x605A, 0) == (None, ABORT_VALUE_RANGE)
    assert d.quick_stop_option_code == 2
    reply = d.coe_reply(sdo_request(0x605A, 0, 2, (6).to_bytes(2, "little")))
    assert parse_sdo_response(reply, 0x605A, 0) == (b"", 0) and d.quick_stop_option_code == 6
