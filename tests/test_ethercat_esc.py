"""The slave controller: addressing modes and working-counter rules, FMMUs, SyncManagers,
the AL state machine, the SII EEPROM and its interface."""

import struct

import pytest

from robocourse.ethercat.bus import Bus
from robocourse.ethercat.devices import (
    DIGITAL_INPUTS,
    Cia402Drive,
    Coupler,
    DigitalInputs,
    DigitalOutputs,
)
from robocourse.ethercat.esc import (
    AL_INVALID_INPUT_CONFIG,
    AL_INVALID_OUTPUT_CONFIG,
    AL_INVALID_STATE_CHANGE,
    AL_UNKNOWN_STATE,
    BOOT,
    INIT,
    OP,
    PREOP,
    SAFEOP,
    Esc,
)
from robocourse.ethercat.frames import Command, Datagram, datagram, decode_frame, frame_bytes
from robocourse.ethercat.sii import (
    SM_TYPE_INPUTS,
    SM_TYPE_OUTPUTS,
    DescriptionError,
    DeviceDescription,
    Pdo,
    PdoEntry,
    SyncManagerConfig,
    build_sii,
    crc8,
    parse_sii,
)


def send(bus, *dgs):
    reply = bus.process(frame_bytes(list(dgs)))
    return decode_frame(reply).datagrams


def one(bus, cmd, adp, ado, data):
    return send(bus, datagram(cmd, adp, ado, data))[0]


def addressed_bus():
    bus = Bus([Coupler(), DigitalInputs(), DigitalOutputs()])
    for pos in range(3):
        one(bus, Command.APWR, -pos, 0x0010, struct.pack("<H", 0x1001 + pos))
    return bus


def test_auto_increment_addresses_the_slave_that_sees_zero_and_every_slave_increments():
    bus = Bus([Coupler(), DigitalInputs(), DigitalOutputs()])
    d = one(bus, Command.APRD, -1, 0x0000, 1)  # slave 2 (position 1 counting from 0)
    assert (bytes(d.data), d.wkc, d.adp) == (b"\x12", 1, 2)  # 0xFFFF + 3 slaves = 2


def test_apwr_writes_only_the_addressed_slave():
    bus = Bus([Coupler(), DigitalInputs(), DigitalOutputs()])
    d = one(bus, Command.APWR, -2, 0x0010, b"\x34\x12")
    assert d.wkc == 1
    assert [s.station_address for s in bus.slaves] == [0, 0, 0x1234]


def test_configured_address_reads_and_alias_needs_activation():
    bus = addressed_bus()
    assert one(bus, Command.FPRD, 0x1002, 0x0000, 1).data == b"\x12"
    bus.slaves[1].mem[0x0012:0x0014] = b"\x07\x00"
    assert one(bus, Command.FPRD, 0x0007, 0x0000, 1).wkc == 0  # alias not activated (0x0103)
    one(bus, Command.BWR, 0, 0x0103, b"\x01")
    assert one(bus, Command.FPRD, 0x0007, 0x0000, 1).wkc == 1


def test_datagrams_addressed_to_nothing_get_wkc_0_and_write_nothing():
    bus = addressed_bus()
    before = [bytes(s.mem) for s in bus.slaves]
    for cmd, adp in ((Command.FPWR, 0x9999), (Command.APWR, -5), (Command.FPRW, 0x2000)):
        d = one(bus, cmd, adp, 0x0200, b"\xff\xff")
        assert d.wkc == 0 and bytes(d.data) == b"\xff\xff"
    d = one(bus, Command.FPRD, 0x9999, 0x0000, 2)
    assert d.wkc == 0 and bytes(d.data) == b"\x00\x00"
    d = send(bus, Datagram.logical_cmd(Command.LRW, 0x5000, b"\xaa\xbb"))[0]
    assert d.wkc == 0 and bytes(d.data) == b"\xaa\xbb"
    assert [bytes(s.mem) for s in bus.slaves] == before


def test_broadcast_read_ors_all_slaves_and_write_counts_every_slave():
    bus = addressed_bus()
    d = one(bus, Command.BRD, 0, 0x0010, 2)
    assert d.wkc == 3 and struct.unpack("<H", d.data)[0] == 0x1001 | 0x1002 | 0x1003
    assert one(bus, Command.BWR, 0, 0x0200, b"\x04\x00").wkc == 3


def test_registers_an_esc_model_lacks_give_wkc_0():
    bus = addressed_bus()  # coupler: ET1100 with DC; terminals: ET1200 without DC unit
    assert one(bus, Command.BWR, 0, 0x0910, bytes(4)).wkc == 1
    assert one(bus, Command.FPRD, 0x1002, 0x0918, 8).wkc == 0
    assert one(bus, Command.FPRD, 0x1001, 0x0918, 8).wkc == 1
    assert one(bus, Command.FPRD, 0x1002, 0x0630, 16).wkc == 0  # FMMU3: an ET1200 has 3
    assert one(bus, Command.FPRD, 0x1002, 0x1400, 1).wkc == 0  # beyond 1 KB of RAM


def test_read_write_command_exchanges_and_counts_three():
    bus = addressed_bus()
    one(bus, Command.FPWR, 0x1001, 0x0200, b"\x11\x22")
    d = one(bus, Command.FPRW, 0x1001, 0x0200, b"\x33\x44")
    assert (d.wkc, bytes(d.data)) == (3, b"\x11\x22")
    assert bytes(bus.slaves[0].mem[0x0200:0x0202]) == b"\x33\x44"


def test_armw_addressed_slave_reads_others_write():
    bus = addressed_bus()
    for s in bus.slaves:
        s.mem[0x0400:0x0402] = bytes([0x10 + s.station_address - 0x1000, 0])
    d = one(bus, Command.ARMW, -1, 0x0400, 2)  # slave 2 reads, 1 and 3 write
    assert (d.wkc, d.data[0], d.adp) == (3, 0x12, 2)
    assert [s.mem[0x0400] for s in bus.slaves] == [0x00, 0x12, 0x12]


def test_frmw_distributes_reference_clock_time_to_every_other_dc_slave():
    bus = Bus([Coupler(), Cia402Drive(), Cia402Drive()])
    for pos in range(3):
        one(bus, Command.APWR, -pos, 0x0010, struct.pack("<H", 0x1001 + pos))
    d = one(bus, Command.FRMW, 0x1001, 0x0910, 8)
    assert d.wkc == 3  # reference reads (+1), two others write (+1 each)
    assert struct.unpack("<Q", d.data)[0] == bus.slaves[0].system_time(bus.slaves[0].t_port0 + 40)


def map_outputs(bus, station, sm_start, log, n, fmmu=0, fmmu_type=2, startbit=0, endbit=7):
    one(bus, Command.FPWR, station, 0x0600 + 16 * fmmu,
        struct.pack("<IHBBHBBBxH", log, n, startbit, endbit, sm_start, 0, fmmu_type, 1, 0))


def bring_terminals_to(bus, state):
    """Program SMs as the SII says, then walk the AL state machine up to ``state``."""
    one(bus, Command.FPWR, 0x1002, 0x0800, struct.pack("<HHI", 0x1000, 1, 0x00010000))
    one(bus, Command.FPWR, 0x1003, 0x0800, struct.pack("<HHI", 0x0F00, 1, 0x00010044))
    for st in (PREOP, SAFEOP, OP):
        one(bus, Command.BWR, 0, 0x0120, struct.pack("<H", st))
        if st == state:
            break


def test_lrw_counts_read_1_write_2_per_slave_and_sm_state_gates_it():
    bus = addressed_bus()
    map_outputs(bus, 0x1003, 0x0F00, 0, 1)  # DO: write FMMU at logical 0
    map_outputs(bus, 0x1002, 0x1000, 1, 1, fmmu_type=1)  # DI: read FMMU at logical 1
    bus.slaves[1].inputs = 0x5A
    bring_terminals_to(bus, SAFEOP)
    d = send(bus, Datagram.logical_cmd(Command.LRW, 0, b"\xc3\x00"))[0]
    assert d.wkc == 1 and d.data[1] == 0x5A  # SAFE_OP: inputs valid, output SM deactivated
    one(bus, Command.BWR, 0, 0x0120, struct.pack("<H", OP))
    d = send(bus, Datagram.logical_cmd(Command.LRW, 0, b"\xc3\x00"))[0]
    assert d.wkc == 3 and bus.slaves[2].outputs == 0xC3
    assert send(bus, Datagram.logical_cmd(Command.LRD, 0, 2))[0].wkc == 1
    assert send(bus, Datagram.logical_cmd(Command.LWR, 0, b"\x01\x00"))[0].wkc == 1
    assert bus.slaves[2].outputs == 0x01


def test_bit_granular_fmmu_maps_logical_bits_to_physical_bits():
    bus = addressed_bus()
    bring_terminals_to(bus, OP)
    map_outputs(bus, 0x1003, 0x0F00, 0, 1, startbit=4, endbit=7)  # logical 0.4..0.7 -> 0x0F00.0..3
    send(bus, Datagram.logical_cmd(Command.LWR, 0, b"\xa0"))
    assert bus.slaves[2].mem[0x0F00] & 0x0F == 0x0A


def test_invalid_state_request_sets_error_and_0x0011_until_acknowledged():
    bus = addressed_bus()
    di = bus.slaves[1]
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", OP))  # INIT -> OP is not allowed
    assert (di.al_status, di.al_status_code) == (INIT | 0x10, AL_INVALID_STATE_CHANGE)
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", PREOP))  # no ack: ignored
    assert (di.al_status, di.al_status_code) == (INIT | 0x10, AL_INVALID_STATE_CHANGE)
    d = one(bus, Command.FPRD, 0x1002, 0x0130, 6)
    assert struct.unpack("<HHH", d.data) == (0x11, 0, 0x0011)
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", PREOP | 0x10))  # ack + request
    assert (di.al_status, di.al_status_code) == (PREOP, 0)


def test_unknown_state_gives_0x0012_and_boot_only_returns_to_init():
    bus = addressed_bus()
    di = bus.slaves[1]
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", 0x07))
    assert (di.al_status, di.al_status_code) == (INIT | 0x10, AL_UNKNOWN_STATE)
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", BOOT | 0x10))
    assert di.al_status == BOOT
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", PREOP))
    assert (di.al_status, di.al_status_code) == (BOOT | 0x10, AL_INVALID_STATE_CHANGE)
    one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", INIT | 0x10))
    assert di.al_status == INIT


@pytest.mark.parametrize("path, allowed", [
    ((PREOP,), True), ((BOOT,), True), ((SAFEOP,), False), ((PREOP, OP), False),
    ((PREOP, SAFEOP, OP, PREOP), True), ((PREOP, SAFEOP, OP, INIT), True),
    ((PREOP, SAFEOP, OP, SAFEOP), True), ((PREOP, SAFEOP, PREOP, OP), False),
])
def test_allowed_transitions_follow_the_reference(path, allowed):
    bus = addressed_bus()
    bring_terminals_to(bus, INIT)
    one(bus, Command.BWR, 0, 0x0120, struct.pack("<H", INIT | 0x10))
    di = bus.slaves[1]
    for st in path:
        one(bus, Command.FPWR, 0x1002, 0x0120, struct.pack("<H", st))
    assert (di.al_status == path[-1]) is allowed
    assert bool(di.al_status & 0x10) is not allowed


def test_coupler_with_device_emulation_echoes_al_control_including_ack_bit():
    bus = addressed_bus()
    one(bus, Command.BWR, 0, 0x0120, b"\x11")
    assert bus.slaves[0].al_status == 0x11
    one(bus, Command.FPWR, 0x1001, 0x0120, b"\x12\x00")
    assert bus.slaves[0].al_status == 0x12


def test_sm_not_matching_the_pdo_map_refuses_safeop_with_0x001d_and_0x001e():
    bus = addressed_bus()
    one(bus, Command.FPWR, 0x1003, 0x0800, struct.pack("<HHI", 0x0F00, 2, 0x00010044))  # 2 != 1
    one(bus, Command.FPWR, 0x1002, 0x0800, struct.pack("<HHI", 0x1000, 1, 0x00000000))  # disabled
    one(bus, Command.BWR, 0, 0x0120, struct.pack("<H", PREOP))
    one(bus, Command.BWR, 0, 0x0120, struct.pack("<H", SAFEOP))
    assert (bus.slaves[2].al_status, bus.slaves[2].al_status_code) == \
        (PREOP | 0x10, AL_INVALID_OUTPUT_CONFIG)
    assert (bus.slaves[1].al_status, bus.slaves[1].al_status_code) == \
        (PREOP | 0x10, AL_INVALID_INPUT_CONFIG)


def test_sii_image_holds_identity_crc_and_categories():
    img = build_sii(DIGITAL_INPUTS)
    assert img[14] == crc8(img[:14])
    assert struct.unpack_from("<IIII", img, 16) == (0x00000A5C, 0x03F03052, 0x00100000, 0)
    info = parse_sii(img)
    assert info.name == "RC1008" and info.strings[0] == "RC1008"
    assert info.sms == [(0x1000, 1, 0x00, 1, SM_TYPE_INPUTS)]
    assert [p.index for p in info.txpdos] == list(range(0x1A00, 0x1A08))
    assert [e.index for p in info.txpdos for e in p.entries] == [0x6000 + 0x10 * c for c in range(8)]
    assert sum(p.bits for p in info.txpdos) == 8 and info.rxpdos == []
    assert info.mbx_rx_size == 0  # no mailbox: SOEM maps it from these categories
    assert struct.unpack_from("<H", img, 0x40 * 2)[0] == 10  # first category: strings


def test_crc8_matches_the_sii_checksum_rule():
    # poly 0x07, init 0xFF over an all-zero 14-byte header
    crc = 0xFF
    for b in bytes(14):
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    assert crc8(bytes(14)) == crc


def eeprom_read(bus, station, word):
    one(bus, Command.FPWR, station, 0x0502, struct.pack("<HI", 0x0100, word))
    busy = struct.unpack("<H", one(bus, Command.FPRD, station, 0x0502, 2).data)[0]
    status = struct.unpack("<H", one(bus, Command.FPRD, station, 0x0502, 2).data)[0]
    return busy, status, bytes(one(bus, Command.FPRD, station, 0x0508, 8).data)


def test_eeprom_interface_reads_8_bytes_after_one_busy_status():
    bus = addressed_bus()
    busy, status, data = eeprom_read(bus, 0x1002, 0x0008)
    assert busy == 0x8150 and status == 0x0040
    assert struct.unpack("<II", data) == (0x00000A5C, 0x03F03052)


def test_eeprom_word_out_of_range_sets_the_error_bit_and_leaves_data():
    bus = addressed_bus()
    _, _, before = eeprom_read(bus, 0x1002, 0x0008)
    _, status, data = eeprom_read(bus, 0x1002, 0x0400)  # 2 KB EEPROM = words 0..0x3FF
    assert status & 0x2000 and data == before
    one(bus, Command.FPWR, 0x1002, 0x0502, b"\x00\x00")  # clear the error as SOEM does
    _, status, _ = eeprom_read(bus, 0x1002, 0x000A)
    assert status == 0x0040


def test_eeprom_owned_by_pdi_ignores_master_commands():
    bus = addressed_bus()
    one(bus, Command.FPWR, 0x1002, 0x0500, b"\x01")
    one(bus, Command.FPWR, 0x1002, 0x0502, struct.pack("<HI", 0x0100, 0x0008))
    assert struct.unpack("<H", one(bus, Command.FPRD, 0x1002, 0x0502, 2).data)[0] == 0x0040
    assert bytes(bus.slaves[1].mem[0x0508:0x0510]) == bytes(8)


def _pdo(index, sm, bits):
    return Pdo(index, sm, (PdoEntry(0x7000, 1, bits),))


def test_pdo_map_that_does_not_fit_its_syncmanager_is_refused():
    with pytest.raises(DescriptionError, match="takes 3 bytes but SM0 is 2 bytes"):
        DeviceDescription(1, 2, 3, "X", sms=(SyncManagerConfig(0x1000, 0x64, SM_TYPE_OUTPUTS, 2),),
                          rxpdos=(_pdo(0x1600, 0, 24),))
    with pytest.raises(DescriptionError, match="not an output SyncManager"):
        DeviceDescription(1, 2, 3, "X", sms=(SyncManagerConfig(0x1000, 0x20, SM_TYPE_INPUTS),),
                          rxpdos=(_pdo(0x1600, 0, 8),))
    with pytest.raises(DescriptionError, match="overlaps"):
        DeviceDescription(1, 2, 3, "X", sms=(SyncManagerConfig(0x1000, 0x64, SM_TYPE_OUTPUTS),
                                             SyncManagerConfig(0x1001, 0x20, SM_TYPE_INPUTS)),
                          rxpdos=(_pdo(0x1600, 0, 16),), txpdos=(_pdo(0x1A00, 1, 8),))


def test_dl_status_change_raises_the_irq_field_under_mask_0x0004():
    bus = addressed_bus()
    one(bus, Command.BWR, 0, 0x0110, b"\x00\x00")  # reading 0x0110 clears; a write is ignored
    one(bus, Command.BRD, 0, 0x0110, 2)
    one(bus, Command.BWR, 0, 0x0200, b"\x04\x00")
    assert one(bus, Command.BRD, 0, 0x0000, 1).irq == 0
    bus.cut_after(2)
    d = one(bus, Command.BRD, 0, 0x0000, 1)
    assert d.irq == 0x0004 and d.wkc == 2
    dl = struct.unpack("<H", one(bus, Command.FPRD, 0x1002, 0x0110, 2).data)[0]
    assert dl & 0x0300 == 0x0200 and dl & 0x0C00 == 0x0400  # port 0 open, port 1 closed


def test_plain_esc_without_application_has_the_reference_registers():
    esc = Esc(DIGITAL_INPUTS)
    assert esc.read(0x0000, 4) == bytes([0x11, 0x00, 0x03, 0x00])
    assert esc.read(0x0130, 2) == b"\x01\x00"
    assert esc.read(0x0502, 2) == b"\x40\x00"
    assert esc.watchdog_ns == pytest.approx(100e6)
