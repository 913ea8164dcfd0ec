"""The master: SOEM's bring-up order, process data and working counters, every injected
fault seen and recovered, distributed clocks, the CiA 402 drive, the 1 kHz rt loop."""

import pytest

from robocourse.ethercat import demo_bus
from robocourse.ethercat.bus import Bus
from robocourse.ethercat.devices import (
    FAULT,
    OPERATION_ENABLED,
    READY_TO_SWITCH_ON,
    SWITCH_ON_DISABLED,
    SWITCHED_ON,
    Cia402Drive,
    Coupler,
    DigitalInputs,
    DigitalOutputs,
    cia402_state,
    drive_inputs,
    drive_outputs,
)
from robocourse.ethercat.errors import MailboxError, SiiError
from robocourse.ethercat.esc import AL_SM_WATCHDOG, AL_SYNC_ERROR, OP, SAFEOP, SOF_DELAY_NS
from robocourse.ethercat.frames import Command, datagram, decode_frame
from robocourse.ethercat.master import EC_NOFRAME, MappedObject, Master
from robocourse.ethercat.pcap import PcapWriter, read_pcap
from robocourse.ethercat.ros2_control import next_controlword


class SimClock:
    def __init__(self) -> None:
        self.now = 1_000_000_000

    def __call__(self) -> int:
        return self.now

    def advance(self, ns: int) -> None:
        self.now += ns


def up(bus, dc=True):
    m = Master()
    m.open(bus)
    m.bring_up(dc=dc)
    return m


def cycle(m, clock=None, n=1, period=1_000_000):
    wkc = None
    for _ in range(n):
        if clock is not None:
            clock.advance(period)
        m.send_processdata()
        wkc = m.receive_processdata()
    return wkc


def test_config_init_finds_every_slave_with_identity_from_sii():
    m = Master()
    m.open(demo_bus())
    assert m.config_init() == 4
    assert [(s.name, s.man, s.id, s.rev) for s in m.slaves] == [
        ("RC1100", 0xA5C, 0x044C2C52, 0x00110000), ("RC1008", 0xA5C, 0x03F03052, 0x00100000),
        ("RC2008", 0xA5C, 0x07D83052, 0x00100000), ("RC-Servo", 0xA5C, 0x00402001, 0x00010000)]
    assert [s.config_address for s in m.slaves] == [0x1001, 0x1002, 0x1003, 0x1004]
    assert [s.has_dc for s in m.slaves] == [True, False, False, True]
    assert [s.topology for s in m.slaves] == [2, 2, 2, 1]  # the last slave's port 1 is closed


def test_config_map_sizes_image_and_expected_wkc_like_soem():
    m = Master()
    m.open(demo_bus())
    m.config_init()
    assert m.config_map() == 28  # outputs 1 (DO) + 13 (drive), inputs 1 (DI) + 13 (drive)
    assert (m.obytes, m.ibytes, m.outputs_wkc, m.inputs_wkc, m.expected_wkc) == (14, 14, 2, 2, 6)
    assert [(s.out_offset, s.obytes, s.in_offset, s.ibytes) for s in m.slaves[1:]] == [
        (0, 0, 14, 1), (0, 1, 0, 0), (1, 13, 15, 13)]
    assert m.slaves[3].pdo_layout()[0x6041] == MappedObject("input", 0, 16, 0x0006, "Statusword")
    assert m.slaves[3].pdo_layout()[0x607A] == MappedObject("output", 16, 32, 0x0004,
                                                            "Target position")
    assert m.slaves[2].pdo_layout()[(0x7010, 1)] == MappedObject("output", 1, 1, 0x0001, "Output")


def test_objects_are_read_and_written_by_cia_index_for_an_adapter():
    clock = SimClock()    # the SM watchdog counts simulated time: a stalled (loaded) machine cannot trip it
    bus = demo_bus(clock=clock)
    m = up(bus)
    drive, do = m.slaves[3], m.slaves[2]
    drive.write_object(0x6040, 0x0006)
    drive.write_object(0x607A, -5000)
    drive.write_object(0x6060, 8)
    assert drive.output == drive_outputs(0x0006, -5000, 0, 0, 8)
    do.write_object(0x7010, 1, subindex=1)
    do.write_object(0x7070, 1, subindex=1)
    assert do.output == b"\x82"
    cycle(m, clock, n=2)
    assert bus.slaves[2].outputs == 0x82
    assert drive.read_object(0x6041) == bus.slaves[3].statusword
    assert cia402_state(drive.read_object(0x6041)) == READY_TO_SWITCH_ON
    assert drive.read_object(0x6061) == 8
    with pytest.raises(ValueError, match="is an input"):
        drive.write_object(0x6041, 1)
    with pytest.raises(KeyError, match="maps no object 0x6098"):
        drive.read_object(0x6098)
    with pytest.raises(ValueError, match="does not fit 16 bits"):
        drive.write_object(0x6040, 70000)


def test_expected_wkc_for_8_io_pairs_is_2_outputs_plus_inputs():
    m = up(demo_bus(n_io=8, drives=0), dc=False)
    assert m.expected_wkc == 2 * 8 + 8
    assert cycle(m) == 24


def test_bring_up_datagrams_follow_soem_detect_and_defaults_order(tmp_path):
    with PcapWriter(tmp_path / "up.pcap") as w:
        bus = demo_bus(capture=w)
        m = Master()
        m.open(bus)
        m.config_init()
    frames = [decode_frame(f) for _, f in read_pcap(tmp_path / "up.pcap")]
    requests = [f.datagrams[0] for f in frames if not f.src[0] & 0x02]
    rows = [(d.cmd, d.ado, len(d.data), bytes(d.data)) for d in requests[:17]]
    assert rows == [
        (Command.BWR, 0x0103, 1, b"\x00"), (Command.BWR, 0x0120, 2, b"\x11\x00"),
        (Command.BWR, 0x0120, 2, b"\x11\x00"), (Command.BRD, 0x0000, 2, b"\x00\x00"),
        (Command.BWR, 0x0101, 1, b"\x00"), (Command.BWR, 0x0200, 2, b"\x04\x00"),
        (Command.BWR, 0x0300, 8, bytes(8)), (Command.BWR, 0x0600, 48, bytes(48)),
        (Command.BWR, 0x0800, 32, bytes(32)), (Command.BWR, 0x0981, 1, b"\x00"),
        (Command.BWR, 0x0910, 4, bytes(4)), (Command.BWR, 0x0930, 2, b"\x00\x10"),
        (Command.BWR, 0x0934, 2, b"\x00\x0c"), (Command.BWR, 0x0103, 1, b"\x00"),
        (Command.BWR, 0x0120, 2, b"\x11\x00"), (Command.BWR, 0x0500, 1, b"\x02"),
        (Command.BWR, 0x0500, 1, b"\x00")]
    replies = [f.datagrams[0] for f in frames if f.src[0] & 0x02]
    # the DC writes (rows 10..13) are acknowledged only by the two DC slaves (coupler, drive)
    assert [d.wkc for d in replies[9:13]] == [2, 2, 2, 2]
    assert replies[3].wkc == 4 and replies[4].wkc == 4
    first = [(d.cmd, d.adp, d.ado) for d in requests[17:21]]
    assert first == [(Command.APRD, 0, 0x0140), (Command.APWR, 0, 0x0010),
                     (Command.APWR, 0, 0x0100), (Command.APRD, 0, 0x0010)]


def test_process_data_outputs_reach_devices_and_inputs_reach_master():
    bus = demo_bus()
    m = up(bus)
    bus.slaves[1].inputs = 0xA5
    m.slaves[2].output = b"\x3c"
    assert cycle(m, n=2) == m.expected_wkc
    assert m.slaves[1].input == b"\xa5" and bus.slaves[2].outputs == 0x3C
    with pytest.raises(ValueError, match="has 1 output bytes; got 2"):
        m.slaves[2].output = b"\x00\x00"


def test_lost_frame_returns_no_frame_then_the_next_cycle_is_whole():
    bus = demo_bus()
    m = up(bus)
    bus.lose_frames(1)
    assert cycle(m) == EC_NOFRAME
    assert cycle(m) == m.expected_wkc and bus.dropped["lost"] == 1


def test_corrupted_frame_is_destroyed_and_counted_in_the_slave_rx_error_counter():
    bus = demo_bus()
    m = up(bus)
    bus.corrupt(3)
    assert cycle(m) == EC_NOFRAME
    assert cycle(m) == m.expected_wkc
    wkc, raw = m._fp(Command.FPRD, 0x1003, 0x0300, 1)
    assert (wkc, raw) == (1, b"\x01")


def test_slave_dropping_to_safeop_with_error_is_named_and_recovered():
    clock = SimClock()
    bus = demo_bus(clock=clock)
    m = up(bus)
    bus.slave_error(3, AL_SYNC_ERROR)  # the DO terminal
    wkc = cycle(m, clock)
    assert wkc == m.expected_wkc - 2  # its output SM is deactivated in SAFE_OP
    diag = m.diagnose(wkc)
    assert diag.missing == () and diag.not_op == ((3, SAFEOP | 0x10, 0x001A),)
    assert "slave 3 in SAFE_OP + ERROR" in str(diag) and "Synchronization error" in str(diag)
    assert m.check() == ["ERROR : slave 3 is in SAFE_OP + ERROR, attempting ack."]
    assert m.check() == ["WARNING : slave 3 is in SAFE_OP, change to OPERATIONAL."]
    assert cycle(m, clock) == m.expected_wkc
    assert m.check() == ["OK : all slaves resumed OPERATIONAL."]


def test_sm_watchdog_expiry_drops_outputs_and_state_until_acknowledged():
    clock = SimClock()
    bus = demo_bus(clock=clock)
    m = up(bus)
    m.slaves[2].output = b"\xff"
    cycle(m, clock, n=3)
    assert bus.slaves[2].outputs == 0xFF
    clock.advance(150_000_000)  # 150 ms without process data; the watchdog is 100 ms
    wkc = cycle(m, clock)
    assert bus.slaves[2].outputs == 0x00 and bus.slaves[2].wd_expired
    assert wkc == m.expected_wkc - 2 - 2  # DO and drive outputs refused
    diag = m.diagnose(wkc)
    assert {p for p, _st, code in diag.not_op if code == AL_SM_WATCHDOG} == {3, 4}
    m.check()
    m.check()
    assert cycle(m, clock) == m.expected_wkc and bus.slaves[2].outputs == 0xFF


def test_cable_cut_names_the_lost_slaves_and_they_come_back_after_reconnect():
    clock = SimClock()
    bus = demo_bus(clock=clock)
    m = up(bus)
    bus.cut_after(2)
    wkc = cycle(m, clock)
    assert wkc == 1  # only the DI's read is left: DO and drive are beyond the cut
    diag = m.diagnose(wkc)
    assert diag.missing == (3, 4)
    assert "slave 3 not responding (lost)" in str(diag)
    assert m.check() == ["ERROR : slave 3 lost", "ERROR : slave 4 lost"]
    clock.advance(200_000_000)
    bus.reconnect()
    # the watchdog expired while they were cut off: they answer in SAFE_OP + ERROR
    assert m.check() == ["ERROR : slave 3 is in SAFE_OP + ERROR, attempting ack.",
                         "MESSAGE : slave 3 found",
                         "ERROR : slave 4 is in SAFE_OP + ERROR, attempting ack.",
                         "MESSAGE : slave 4 found"]
    assert m.check() == ["WARNING : slave 3 is in SAFE_OP, change to OPERATIONAL.",
                         "WARNING : slave 4 is in SAFE_OP, change to OPERATIONAL."]
    assert cycle(m, clock) == m.expected_wkc
    assert m.check() == ["OK : all slaves resumed OPERATIONAL."]


def test_power_cycled_slave_is_lost_readdressed_and_reconfigured_to_op():
    clock = SimClock()
    bus = demo_bus(clock=clock)
    m = up(bus)
    bus.power_cycle(3)
    assert bus.slaves[2].station_address == 0 and bus.slaves[2].state == 1
    assert cycle(m, clock) == m.expected_wkc - 2
    assert m.check() == ["ERROR : slave 3 lost", "MESSAGE : slave 3 recovered"]  # one pass
    assert bus.slaves[2].station_address == 0x1003
    assert m.check() == ["MESSAGE : slave 3 reconfigured"]
    assert m.check() == ["WARNING : slave 3 is in SAFE_OP, change to OPERATIONAL."]
    m.slaves[2].output = b"\x81"
    assert cycle(m, clock, n=2) == m.expected_wkc and bus.slaves[2].outputs == 0x81


def test_rescan_after_cut_finds_fewer_slaves():
    bus = demo_bus()
    m = Master()
    m.open(bus)
    bus.cut_after(2)
    assert m.config_init() == 2
    bus.cut_after(0)
    assert m.config_init() == 0


def test_sdo_to_a_slave_without_mailbox_is_refused_naming_it():
    m = up(demo_bus())
    with pytest.raises(MailboxError, match=r"slave 4 \(RC-Servo\) has no mailbox"):
        m.slaves[3].sdo_read(0x6041, 0)


def test_sii_word_out_of_range_raises_with_the_word():
    m = Master()
    m.open(demo_bus())
    m.config_init()
    with pytest.raises(SiiError, match="SII word 0x0400 could not be read"):
        m.sii_read(m.slaves[1], 0x0400, 1)


def dc_bus(clock, drifts=(40.0, -30.0, 25.0, -45.0)):
    return Bus([Cia402Drive(drift_ppm=d, power_on_ns=i * 3e6) for i, d in enumerate(drifts)],
               clock=clock)


def test_dc_delays_match_the_chain_and_frmw_keeps_clocks_within_100_ns():
    clock = SimClock()
    bus = dc_bus(clock)
    m = up(bus)
    assert [s.dc_delay for s in m.slaves] == [0, 500, 1000, 1500]  # 500 ns out, 500 back
    cycle(m, clock, n=3000)
    assert bus.sync_error_ns() < 100.0


def test_without_drift_compensation_the_clocks_drift_apart():
    clock = SimClock()
    bus = dc_bus(clock)
    m = Master()
    m.open(bus)
    m.drift_compensation = False  # no FRMW in any cycle
    m.bring_up()
    start = bus.sync_error_ns()
    cycle(m, clock, n=3000)
    # +40 and -45 ppm drift apart by 85 ppm: 255 us in 3 s, on top of the delays at the start
    assert start < 2000.0
    assert 250_000.0 < bus.sync_error_ns() < 260_000.0 + start


def test_armw_of_four_bytes_as_twincat_sends_it_also_keeps_clocks_within_100_ns():
    """TwinCAT's drift compensation: ARMW ADP 0, 0x0910, 4 bytes (32-bit system time) in every
    cycle instead of SOEM's 8-byte FRMW (reference, distributed clocks at runtime)."""
    clock = SimClock()
    bus = dc_bus(clock)
    m = Master()
    m.open(bus)
    m.drift_compensation = False  # no FRMW: the ARMW below is the only 0x0910 write
    m.bring_up()
    ref = bus.slaves[0]
    for _ in range(3000):
        clock.advance(1_000_000)
        (d,) = m.exchange([datagram(Command.ARMW, 0, 0x0910, 4)])
        ref_time = ref.system_time(ref.t_port0 + SOF_DELAY_NS)  # what position 0 put in
        m.send_processdata()
        m.receive_processdata()
    # position 0 read (+1), the three after it wrote (+1 each); every slave incremented ADP
    assert (d.adp, d.wkc) == (4, 4)
    assert int.from_bytes(d.data, "little") == ref_time & 0xFFFFFFFF  # the low 32 bits
    assert bus.sync_error_ns() < 100.0
    # each follower's last system time difference 0x092C (bit 31 = sign) is under 100 ns too
    assert all(int.from_bytes(e.mem[0x092C:0x0930], "little") & 0x7FFFFFFF < 100 for e in bus.slaves[1:])


def test_config_dc_writes_offsets_from_the_local_clocks_and_delays_from_the_forwarding_times(monkeypatch):
    """0x0920 = master time - the slave's receive time at its processing unit (0x0918, latched by
    BWR 0x0900); 0x0928 = SOEM's line delay from the port receive times."""
    clock = SimClock()
    power_on = (0, 3_000_000, 7_250_000, 12_345_670)  # each local clock = bus time - power_on
    # forward_ns[i]: port 0 of slave i -> port 0 of slave i+1; return_ns[i]: back through slave i.
    # Chosen symmetric (return_ns[i] == forward_ns[i-1]; the last slave turns the frame round in
    # forward_ns[3] == forward_ns[2]) so SOEM's half-round-trip estimate is exactly the one-way time.
    fwd, ret = (300, 700, 450, 450), (250, 300, 700, 100)
    bus = Bus([Cia402Drive(power_on_ns=p) for p in power_on], clock=clock,
              forward_ns=fwd, return_ns=ret)
    unix_ns = 1_764_115_200_123_456_000
    monkeypatch.setattr("robocourse.ethercat.master.time.time_ns", lambda: unix_ns)
    master_time = unix_ns - 946_684_800 * 1_000_000_000  # EtherCAT's epoch is 2000-01-01
    latched, process = [], bus.process

    def spy(raw):  # the bus time at which the latch frame (BWR 0x0900) left the master
        reply = process(raw)
        d = decode_frame(raw).datagrams[0]
        if (d.cmd, d.ado) == (Command.BWR, 0x0900):
            latched.append(bus.slaves[0].t_port0)
        return reply

    bus.process = spy
    m = Master()
    m.open(bus)
    m.config_init()
    m.config_map()
    assert m.config_dc() is True
    t0 = int(latched[0])
    assert latched == [t0]
    arrival = (0, 300, 1000, 1450)  # cumulative forward_ns: when the frame reaches each port 0
    sof = [(t0 + a + SOF_DELAY_NS - p) // 10 * 10 for a, p in zip(arrival, power_on)]  # 10-ns ticks
    offsets = [int.from_bytes(e.mem[0x0920:0x0928], "little") for e in bus.slaves]
    assert offsets == [(master_time - x) % (1 << 64) for x in sof]
    # SOEM: delay(i) = delay(i-1) + (round trip of i-1 - round trip of i) / 2, the last slave's
    # round trip 0 -> 0, (300 + 300)/2 = 300, + (700 + 700)/2 = 1000, + (450 + 450)/2 = 1450
    delays = [int.from_bytes(e.mem[0x0928:0x092C], "little") for e in bus.slaves]
    assert delays == [s.dc_delay for s in m.slaves] == list(arrival)
    # together: at any instant a slave's system time plus its delay is the reference's system
    # time, i.e. the offsets put every clock on the master's time as the latch frame passed it
    for t in (t0, t0 + 1_000_000, t0 + 123_456_780):
        ref = bus.slaves[0].system_time(t)
        assert [e.system_time(t) + d for e, d in zip(bus.slaves, delays)] == [ref] * 4


def test_sync0_events_fire_together_on_every_drive():
    clock = SimClock()
    bus = dc_bus(clock)
    m = up(bus)
    for s in m.slaves:
        s.dc_sync(True, 1_000_000)
    cycle(m, clock, n=3000)
    assert all(e.sync0_active() for e in bus.slaves)
    times = [e.next_sync0(clock.now) for e in bus.slaves]
    assert max(times) - min(times) < 100.0
    assert 0 <= times[0] - clock.now <= 1_000_000  # the next event is within one cycle
    later = [e.next_sync0(t + 1000) for e, t in zip(bus.slaves, times)]
    assert all(abs(b - a - 1_000_000) < 200.0 for a, b in zip(times, later))  # 1 ms apart


def test_cia402_drive_enables_with_automatic_transitions_and_tracks_csp_target():
    clock = SimClock()
    bus = Bus([Coupler(), Cia402Drive()], clock=clock)
    m = up(bus)
    drive = m.slaves[1]
    cw, seen = 0, []
    for _ in range(12):  # each answer shows up one exchange later, as on a real bus
        sw, pos, *_ = drive_inputs(drive.input)
        if not seen or seen[-1] != cia402_state(sw):
            seen.append(cia402_state(sw))
        cw = next_controlword(sw, cw, reset_edge=False)  # ethercat_driver_ros2's transitions
        drive.output = drive_outputs(cw, pos)
        cycle(m, clock)
    assert seen == [SWITCH_ON_DISABLED, READY_TO_SWITCH_ON, SWITCHED_ON, OPERATION_ENABLED]
    sw = drive_inputs(drive.input)[0]
    assert sw & 0x6F == 0x27
    target = 20_000
    for _ in range(800):
        drive.output = drive_outputs(cw, target)
        cycle(m, clock)
    sw, pos, vel, _tq, mode = drive_inputs(drive.input)
    assert abs(pos - target) < 200 and mode == 8 and sw & 0x0400  # target reached


def test_cia402_fault_needs_a_rising_fault_reset_edge():
    clock = SimClock()
    bus = Bus([Coupler(), Cia402Drive()], clock=clock)
    m = up(bus)
    drive = m.slaves[1]
    drive.output = drive_outputs(0x06)
    cycle(m, clock, n=2)
    bus.slaves[1].inject_fault()
    cycle(m, clock, n=2)
    sw = drive_inputs(drive.input)[0]
    assert sw & 0x4F == 0x08 and cia402_state(sw) == FAULT
    drive.output = drive_outputs(0x80)
    cycle(m, clock, n=2)
    assert cia402_state(drive_inputs(drive.input)[0]) == SWITCH_ON_DISABLED


@pytest.mark.serial     # the wall clock at 1 kHz: a stall past the 100 ms SM watchdog drops a slave to SAFE_OP
def test_cyclic_exchange_in_the_rt_loop_at_1khz_reports_latency_and_no_faults():
    bus = Bus([Coupler(), DigitalInputs(), DigitalOutputs()])
    m = up(bus, dc=False)
    counts = []

    def on_cycle(master, k, wkc):
        master.slaves[2].output = bytes([k & 0xFF])
        counts.append(wkc)

    result, faults = m.run_cyclic(200, 1_000_000, on_cycle)
    assert result.iterations == 200 and len(result.latency_ns) == 200
    assert faults == [] and counts == [m.expected_wkc] * 200
    assert bus.slaves[2].outputs == 198  # the last cycle's value arrives one exchange later
    assert result.stats().p99 >= result.stats().p50


def test_capture_round_trips_through_pcap(tmp_path):
    path = tmp_path / "b.pcap"
    with PcapWriter(path) as w:
        bus = demo_bus(capture=w)
        m = up(bus)
        cycle(m, n=5)
    recs = read_pcap(path)
    assert len(recs) == 2 * bus.frames - 0  # every frame answered: request + reply
    last = decode_frame(recs[-1][1])
    assert last.datagrams[0].cmd == Command.LRW and last.datagrams[0].wkc == 6
    assert last.datagrams[1].cmd == Command.FRMW and last.datagrams[1].wkc == 2
    assert OP == 8


def test_sm_programmed_unlike_the_pdo_map_keeps_the_slave_out_of_safeop_with_0x001d():
    m = Master()
    m.open(demo_bus())
    m.config_init()
    m.config_map()
    do = m.slaves[2]
    start, _length, flags = do.sm[0]
    do.sm[0] = (start, 2, flags)  # 2 bytes where the RxPDOs map 8 bits
    m._fp(Command.FPWR, do.config_address, 0x0120, b"\x02\x00")  # back to PRE_OP
    m._map_sm(do)
    do.state = SAFEOP
    do.write_state()
    assert m.state_check(SAFEOP, 2000) == 2
    assert (do.state, do.al_status) == (0x12, 0x001D)
    assert "slave 3 (RC2008) PRE_OP + ERROR code 0x001D" in m._states_text()


def test_broadcast_read_write_writes_what_arrives_and_ors_in_the_old_contents():
    from robocourse.ethercat.frames import datagram, frame_bytes

    bus = Bus([Coupler(), DigitalInputs()])
    bus.slaves[0].mem[0x0200] = 0x01
    bus.slaves[1].mem[0x0200] = 0x02
    d = decode_frame(bus.process(frame_bytes([datagram(Command.BRW, 0, 0x0200, b"\x40")])))
    assert (d.datagrams[0].wkc, d.datagrams[0].data[0]) == (6, 0x43)
    # each slave writes the data as it reaches it (slave 2 sees slave 1's OR already)
    assert [s.mem[0x0200] for s in bus.slaves] == [0x40, 0x41]
