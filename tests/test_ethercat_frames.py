"""EtherCAT frames byte by byte: hand-derived vectors from the reference, malformed frames,
pcap files, and tshark's decode of what we write."""

import shutil
import struct
import subprocess

import pytest

from robocourse.ethercat.bus import Bus
from robocourse.ethercat.devices import Coupler, DigitalInputs
from robocourse.ethercat.frames import (
    Command,
    Datagram,
    Frame,
    FrameError,
    datagram,
    decode_frame,
    encode_frame,
    frame_bytes,
)
from robocourse.ethercat.master import Fmmu
from robocourse.ethercat.pcap import PcapWriter, read_pcap

# The reference's golden pair, a real SOEM capture: BRD of register 0x0000, 2 bytes, 2 slaves.
GOLDEN_TX = bytes.fromhex("ffffffffffff" "010101010101" "88a4" "0e10" "07" "04" "0000" "0000"
                          "0200" "0000" "0000" "0000")
GOLDEN_RX = bytes.fromhex("ffffffffffff" "030101010101" "88a4" "0e10" "07" "04" "0200" "0000"
                          "0200" "0000" "1301" "0200")


def test_golden_brd_request_encodes_to_the_captured_bytes():
    raw = frame_bytes([datagram(Command.BRD, 0, 0x0000, 2, idx=4)])
    assert raw == GOLDEN_TX  # SOEM's own frames leave the host unpadded (30 bytes)


def test_golden_brd_reply_from_coupler_and_terminal_matches_capture_then_padding():
    bus = Bus([Coupler(), DigitalInputs()])  # ET1100 type 0x11 rev 0, ET1200 type 0x12 rev 1
    rx = bus.process(GOLDEN_TX)
    assert rx[:len(GOLDEN_RX)] == GOLDEN_RX
    assert len(rx) == 60 and rx[len(GOLDEN_RX):] == bytes(60 - len(GOLDEN_RX))
    d = decode_frame(rx).datagrams[0]
    assert (d.adp, d.wkc, bytes(d.data)) == (2, 2, b"\x13\x01")


def test_two_datagrams_set_more_bit_on_first_only_and_header_sums_lengths():
    raw = frame_bytes([Datagram.logical_cmd(Command.LRW, 0x00010000, 3, idx=5),
                       datagram(Command.FRMW, 0x1001, 0x0910, 8, idx=5)])
    expected = bytes.fromhex(
        "ffffffffffff010101010101" "88a4" "2310"  # 35 bytes of datagrams, type 1
        "0c05" "00000100" "0380" "0000" "000000" "0000"  # LRW log 0x00010000, len 3 | M
        "0e05" "0110" "1009" "0800" "0000" "0000000000000000" "0000")  # FRMW 0x1001:0x0910
    assert raw == expected
    f = decode_frame(raw)
    assert [d.cmd for d in f.datagrams] == [Command.LRW, Command.FRMW]
    assert f.datagrams[0].logical == 0x00010000 and f.datagrams[1].adp == 0x1001


def test_circulating_bit_round_trips_and_lands_in_bit_14():
    raw = frame_bytes([Datagram(Command.NOP, 1, 0, 0, bytearray(2), circulating=True)])
    assert struct.unpack_from("<H", raw, 22)[0] == 0x4002
    assert decode_frame(raw).datagrams[0].circulating is True


@pytest.mark.parametrize("cmd", list(Command))
def test_every_command_round_trips_byte_exactly(cmd):
    d = Datagram(cmd, 0x7F, 0xFFFE, 0x0130, bytearray(b"\x01\x02\x03"), wkc=0x0102, irq=0x0004)
    raw = encode_frame(Frame([d]), pad=False)
    assert raw[16] == int(cmd) and raw[17] == 0x7F
    assert raw[18:22] == bytes.fromhex("feff3001")
    back = decode_frame(raw).datagrams[0]
    assert (back.cmd, back.idx, back.adp, back.ado, bytes(back.data), back.wkc, back.irq) == \
        (cmd, 0x7F, 0xFFFE, 0x0130, b"\x01\x02\x03", 0x0102, 0x0004)
    assert encode_frame(decode_frame(raw), pad=False) == raw


def test_padding_to_60_bytes_is_ignored_by_decode():
    raw = encode_frame(Frame([datagram(Command.APRD, 0, 0x0130, 2)]))
    assert len(raw) == 60
    assert len(decode_frame(raw).datagrams) == 1


@pytest.mark.parametrize("raw, words", [
    (GOLDEN_TX[:15], "shorter than the Ethernet"),
    (GOLDEN_TX[:12] + b"\x08\x00" + GOLDEN_TX[14:], "EtherType 0x0800"),
    (GOLDEN_TX[:14] + b"\x0e\x20" + GOLDEN_TX[16:], "type 2"),
    (GOLDEN_TX[:14] + b"\x20\x10" + GOLDEN_TX[16:], "says 32 bytes"),
    (GOLDEN_TX[:14] + b"\x08\x10" + GOLDEN_TX[16:24] + bytes(6), "truncated datagram"),
    (GOLDEN_TX[:16] + b"\x0f" + GOLDEN_TX[17:], "unknown command 15"),
    (GOLDEN_TX[:22] + b"\x10\x00" + GOLDEN_TX[24:], "says len 16"),
    (GOLDEN_TX[:22] + b"\x02\x80" + GOLDEN_TX[24:], "truncated datagram at offset 30"),
])
def test_malformed_frames_are_refused_naming_the_rule(raw, words):
    with pytest.raises(FrameError, match=words):
        decode_frame(raw)


def test_header_longer_than_last_datagram_is_refused():
    raw = bytearray(GOLDEN_TX + bytes(4))
    raw[14:16] = (0x1000 | 18).to_bytes(2, "little")
    with pytest.raises(FrameError, match="ends at offset 30"):
        decode_frame(bytes(raw))


def test_oversized_datagram_and_empty_frame_are_refused_before_encoding():
    with pytest.raises(FrameError, match="outside 0..1486"):
        datagram(Command.LRW, 0, 0, 1487)
    with pytest.raises(FrameError, match="at least one datagram"):
        encode_frame(Frame([]))
    with pytest.raises(FrameError, match="split"):
        encode_frame(Frame([datagram(Command.LRW, 0, 0, 1400), datagram(Command.LRW, 0, 0, 100)]))


def test_malformed_frame_reaching_the_bus_gets_no_reply_and_is_counted():
    bus = Bus([Coupler()])
    assert bus.process(GOLDEN_TX[:16] + b"\x0f" + GOLDEN_TX[17:]) is None
    assert bus.dropped["malformed"] == 1 and "unknown command 15" in bus.last_error


def test_fmmu_and_sm_entries_pack_like_the_captured_ones():
    # captured: 4 input bits at logical 0.0..0.3 mapped to 0x1000.0, type 1 (read), active
    f = Fmmu(0, 1, 0, 3, 0x1000, 1)
    assert f.pack() == bytes.fromhex("00000000" "0100" "00" "03" "0010" "00" "01" "01" "000000")
    assert struct.pack("<HHI", 0x1000, 1, 0x00010000) == bytes.fromhex("0010010000000100")


def test_pcap_file_has_linktype_1_and_reads_back(tmp_path):
    p = tmp_path / "x.pcap"
    with PcapWriter(p) as w:
        w.write(GOLDEN_TX, 1_700_000_000_123_456_000)
        w.write(GOLDEN_RX, 1_700_000_000_123_457_000)
    data = p.read_bytes()
    assert data[:4] == bytes.fromhex("d4c3b2a1") and struct.unpack_from("<I", data, 20)[0] == 1
    recs = read_pcap(p)
    assert recs == [(1_700_000_000_123_456_000, GOLDEN_TX), (1_700_000_000_123_457_000, GOLDEN_RX)]


TSHARK = shutil.which("tshark")


@pytest.mark.skipif(TSHARK is None, reason="tshark not installed (.ci/run installs it: apt-get install tshark)")
def test_tshark_decodes_our_frames_with_the_right_field_values(tmp_path):
    bus = Bus([Coupler(), DigitalInputs()])
    p = tmp_path / "c.pcap"
    two = frame_bytes([Datagram.logical_cmd(Command.LRW, 0x00010000, 3, idx=5),
                       datagram(Command.FRMW, 0x1001, 0x0910, 8, idx=5)])
    with PcapWriter(p) as w:
        w.write(GOLDEN_TX)
        w.write(bus.process(GOLDEN_TX))
        w.write(two)
    fields = ["ecatf.length", "ecatf.type", "ecat.cmd", "ecat.idx", "ecat.adp", "ecat.ado",
              "ecat.lad", "ecat.subframe.length", "ecat.subframe.more", "ecat.cnt", "eth.src"]
    cmd = [TSHARK, "-r", str(p), "-T", "fields", "-E", "separator=|"]
    for f in fields:
        cmd += ["-e", f]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=True).stdout
    rows = [dict(zip(fields, line.split("|"))) for line in out.strip().splitlines()]
    assert rows[0] == {"ecatf.length": "0x000e", "ecatf.type": "0x0001", "ecat.cmd": "0x07",
                       "ecat.idx": "0x04", "ecat.adp": "0x0000", "ecat.ado": "0x0000",
                       "ecat.lad": "", "ecat.subframe.length": "2", "ecat.subframe.more": "0",
                       "ecat.cnt": "0", "eth.src": "01:01:01:01:01:01"}
    assert (rows[1]["ecat.adp"], rows[1]["ecat.cnt"], rows[1]["eth.src"]) == \
        ("0x0002", "2", "03:01:01:01:01:01")
    assert rows[2]["ecat.cmd"] == "0x0c,0x0e" and rows[2]["ecat.lad"] == "0x00010000"
    assert rows[2]["ecat.adp"] == "0x1001" and rows[2]["ecat.ado"] == "0x0910"
    assert rows[2]["ecat.subframe.length"] == "3,8" and rows[2]["ecat.subframe.more"] == "1,0"
    assert rows[2]["ecatf.length"] == "0x0023"
    # the reply carries the OR of both type bytes, which Wireshark labels "revision" (0x0000)
    reg = subprocess.run([TSHARK, "-r", str(p), "-Y", "frame.number == 2", "-T", "fields",
                          "-e", "ecat.reg.revision"], capture_output=True, text=True, timeout=60)
    assert reg.stdout.strip() == "0x13"


# ---- one hand-derived frame per command ---------------------------------------------------
# Every vector below is written out from the reference's field layout, not from our encoder:
#   Ethernet II: dst 6 | src 6 | EtherType 0x88A4 big-endian ("88a4")
#   EtherCAT header u16 LE: bits 0-10 length of all datagrams, bits 12-15 type 1
#     -> a length L < 256 is written "LL10" (e.g. 14 = 0x0e -> "0e10")
#   datagram: cmd u8 | idx u8 | ADP u16 LE + ADO u16 LE (or logical u32 LE) |
#             len u16 LE (bits 0-10 len, 14 C, 15 M) | IRQ u16 LE | data | WKC u16 LE
#   one datagram of n data bytes is 10 + n + 2 bytes, so L = 12 + n; frames under 60 bytes
#   (no FCS) end with zero padding up to 60.
REQ = "ffffffffffff" "010101010101" "88a4"  # broadcast dst, SOEM's source, EtherType
REP = "ffffffffffff" "030101010101" "88a4"  # a reply: a slave set bit 1 of the first src byte


def _pad(hexstr: str) -> bytes:
    raw = bytes.fromhex(hexstr)
    return raw + bytes(max(0, 60 - len(raw)))


# (cmd, src, idx, adp, ado, data, circulating, irq, wkc, expected frame on the wire)
ONE_PER_COMMAND = [
    # NOP, idx 0x01, address 0:0, 2 data bytes -> L = 14; 30 bytes + 30 bytes padding
    (Command.NOP, REQ, 0x01, 0x0000, 0x0000, "0000", False, 0, 0, _pad(
        REQ + "0e10" + "00" "01" "0000" "0000" "0200" "0000" + "0000" + "0000")),
    # APRD of AL status 0x0130 at position 2: ADP = -2 = 0xFFFE -> "feff", ADO "3001", len 2
    (Command.APRD, REQ, 0x02, 0xFFFE, 0x0130, "0000", False, 0, 0, _pad(
        REQ + "0e10" + "01" "02" "feff" "3001" "0200" "0000" + "0000" + "0000")),
    # APWR station address 0x0010 = 0x1002 to position 1 (ADP -1 = 0xFFFF): data "0210"
    (Command.APWR, REQ, 0x03, 0xFFFF, 0x0010, "0210", False, 0, 0, _pad(
        REQ + "0e10" + "02" "03" "ffff" "1000" "0200" "0000" + "0210" + "0000")),
    # APRW reply after 3 slaves: ADP 0 came back as 3 ("0300"), ADO 0x0120 "2001", old value
    # 0x0001 read back, IRQ 0x0004 (SOEM's event mask 0x0004), WKC 3 = read + write
    (Command.APRW, REP, 0x04, 0x0003, 0x0120, "0100", False, 0x0004, 3, _pad(
        REP + "0e10" + "03" "04" "0300" "2001" "0200" "0400" + "0100" + "0300")),
    # FPRD of EEPROM status 0x0502 from station 0x1001: ADP "0110", ADO "0205"
    (Command.FPRD, REQ, 0x05, 0x1001, 0x0502, "0000", False, 0, 0, _pad(
        REQ + "0e10" + "04" "05" "0110" "0205" "0200" "0000" + "0000" + "0000")),
    # FPWR 0x0502 len 6 = {u16 0x0100 read command, u32 word 0x000A product} -> L = 18 "1210"
    (Command.FPWR, REQ, 0x06, 0x1002, 0x0502, "0001" "0a000000", False, 0, 0, _pad(
        REQ + "1210" + "05" "06" "0210" "0205" "0600" "0000" + "00010a000000" + "0000")),
    # FPRW AL control 0x0120 = 0x0004 at 0x1003 with C set: len field 0x4002 -> "0240"
    (Command.FPRW, REQ, 0x07, 0x1003, 0x0120, "0400", True, 0, 0, _pad(
        REQ + "0e10" + "06" "07" "0310" "2001" "0240" "0000" + "0400" + "0000")),
    # BRD reply of the golden pair (2 slaves): ADP 2, data = type bytes OR'ed 0x13 0x01, WKC 2
    (Command.BRD, REP, 0x04, 0x0002, 0x0000, "1301", False, 0, 2, _pad(
        REP + "0e10" + "07" "04" "0200" "0000" "0200" "0000" + "1301" + "0200")),
    # BWR AL control 0x0120 = 0x11 (INIT | ACK), 1 byte as SOEM v1.4.0 -> L = 13 "0d10"
    (Command.BWR, REQ, 0x09, 0x0000, 0x0120, "11", False, 0, 0, _pad(
        REQ + "0d10" + "08" "09" "0000" "2001" "0100" "0000" + "11" + "0000")),
    # BRW reply of 0x0981 (1 byte) after 2 slaves: ADP 2, WKC 6 = 2 x (read 1 + write 2)
    (Command.BRW, REP, 0x0A, 0x0002, 0x0981, "00", False, 0, 6, _pad(
        REP + "0d10" + "09" "0a" "0200" "8109" "0100" "0000" + "00" + "0600")),
    # LRD of 4 bytes at logical 0x00010000 (group 1's start): address bytes "00000100"
    (Command.LRD, REQ, 0x0B, 0x0000, 0x0001, "00000000", False, 0, 0, _pad(
        REQ + "1010" + "0a" "0b" "00000100" "0400" "0000" + "00000000" + "0000")),
    # LWR of 2 output bytes 0xA5 0x5A at logical 0x00000004: "04000000", L = 14
    (Command.LWR, REQ, 0x0C, 0x0004, 0x0000, "a55a", False, 0, 0, _pad(
        REQ + "0e10" + "0b" "0c" "04000000" "0200" "0000" + "a55a" + "0000")),
    # LRW reply at logical 0: 3 bytes (1 output byte 0x05, 2 input bytes), WKC 3 = 2 x 1 + 1
    (Command.LRW, REP, 0x0D, 0x0000, 0x0000, "053412", False, 0, 3, _pad(
        REP + "0f10" + "0c" "0d" "00000000" "0300" "0000" + "053412" + "0300")),
    # ARMW reply as TwinCAT's: ADP 0 came back as 1 from one slave, 0x0910 "1009", 4 bytes of
    # system time 0x12345678 -> "78563412", WKC 1 -> L = 16 "1010"
    (Command.ARMW, REP, 0x0E, 0x0001, 0x0910, "78563412", False, 0, 1, _pad(
        REP + "1010" + "0d" "0e" "0100" "1009" "0400" "0000" + "78563412" + "0100")),
    # FRMW of the reference clock 0x1001's 0x0910, 8 bytes as SOEM -> L = 20 "1410"
    (Command.FRMW, REQ, 0x0F, 0x1001, 0x0910, "00" * 8, False, 0, 0, _pad(
        REQ + "1410" + "0e" "0f" "0110" "1009" "0800" "0000" + "00" * 8 + "0000")),
]


def test_the_table_has_one_vector_per_command():
    assert [v[0] for v in ONE_PER_COMMAND] == list(Command)


@pytest.mark.parametrize("cmd, src, idx, adp, ado, data, circ, irq, wkc, expected", ONE_PER_COMMAND,
                         ids=[v[0].name for v in ONE_PER_COMMAND])
def test_each_command_encodes_to_and_decodes_from_its_hand_derived_frame(
        cmd, src, idx, adp, ado, data, circ, irq, wkc, expected):
    d = Datagram(cmd, idx, adp, ado, bytearray.fromhex(data), wkc, irq, circ)
    sent = encode_frame(Frame([d], src=bytes.fromhex(src[12:24])))
    assert len(expected) == 60 and sent == expected
    f = decode_frame(expected)
    assert (f.dst, f.src, f.ecat_type) == (b"\xff" * 6, bytes.fromhex(src[12:24]), 1)
    (back,) = f.datagrams
    assert (back.cmd, back.idx, back.adp, back.ado, back.data.hex(), back.circulating, back.irq,
            back.wkc) == (cmd, idx, adp, ado, data, circ, irq, wkc)
    if cmd in (Command.LRD, Command.LWR, Command.LRW):
        assert back.logical == int.from_bytes(expected[18:22], "little") == adp | ado << 16


# SOEM's ecx_FPRD_multi: AL status (0x0130, 6 bytes) of three stations in one frame. Each
# datagram is 10 + 6 + 2 = 18 bytes, so L = 54 = 0x36 -> "3610"; the first two carry M:
# len field 6 | 0x8000 = 0x8006 -> "0680", the last one "0600". 16 + 54 = 70 bytes: no padding.
MULTI_FPRD = bytes.fromhex(
    REQ + "3610"
    + "04" "21" "0110" "3001" "0680" "0000" + "000000000000" + "0000"  # FPRD 0x1001:0x0130, M
    + "04" "21" "0210" "3001" "0680" "0000" + "000000000000" + "0000"  # FPRD 0x1002:0x0130, M
    + "04" "21" "0310" "3001" "0600" "0000" + "000000000000" + "0000")  # FPRD 0x1003, last
# SOEM's reset of SM0..3 (BWR 0x0800, 32 zero bytes): 16 + 10 + 32 + 2 = 60 bytes exactly,
# so padding adds nothing. L = 44 = 0x2c -> "2c10", len 32 = 0x20 -> "2000".
BWR_SM_RESET = bytes.fromhex(REQ + "2c10" + "08" "22" "0000" "0008" "2000" "0000" + "00" * 32 + "0000")


def test_multi_datagram_frame_sets_m_on_all_but_the_last_and_needs_no_padding():
    dgs = [datagram(Command.FPRD, adr, 0x0130, 6, idx=0x21) for adr in (0x1001, 0x1002, 0x1003)]
    raw = encode_frame(Frame(dgs))
    assert len(MULTI_FPRD) == 70 and raw == MULTI_FPRD
    back = decode_frame(MULTI_FPRD).datagrams
    assert [(d.cmd, d.idx, d.adp, d.ado, len(d.data), d.wkc) for d in back] == [
        (Command.FPRD, 0x21, adr, 0x0130, 6, 0) for adr in (0x1001, 0x1002, 0x1003)]


def test_a_frame_of_exactly_60_bytes_gets_no_padding():
    raw = encode_frame(Frame([datagram(Command.BWR, 0, 0x0800, bytes(32), idx=0x22)]))
    assert len(BWR_SM_RESET) == 60 and raw == BWR_SM_RESET
    (d,) = decode_frame(BWR_SM_RESET).datagrams
    assert (d.cmd, d.idx, d.adp, d.ado, bytes(d.data), d.wkc) == (Command.BWR, 0x22, 0, 0x0800, bytes(32), 0)


@pytest.mark.skipif(TSHARK is None, reason="tshark not installed (.ci/run installs it: apt-get install tshark)")
def test_tshark_reads_every_hand_derived_vector_with_the_same_fields(tmp_path):
    """An independent decoder (Wireshark's) on the same bytes: a mistake made the same way in
    our encoder and decoder would still show here."""
    p = tmp_path / "vectors.pcap"
    with PcapWriter(p) as w:
        for v in ONE_PER_COMMAND:
            w.write(v[-1])
        w.write(MULTI_FPRD)
    fields = ["ecatf.length", "ecat.cmd", "ecat.idx", "ecat.adp", "ecat.ado", "ecat.lad",
              "ecat.subframe.length", "ecat.subframe.circulating", "ecat.subframe.more",
              "ecat.int", "ecat.cnt"]
    cmd = [TSHARK, "-r", str(p), "-T", "fields", "-E", "separator=|"]
    for f in fields:
        cmd += ["-e", f]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=True).stdout
    rows = [dict(zip(fields, line.split("|"))) for line in out.strip().splitlines()]
    assert len(rows) == 16
    for row, (c, _src, idx, adp, ado, data, circ, irq, wkc, _raw) in zip(rows, ONE_PER_COMMAND):
        logical = c in (Command.LRD, Command.LWR, Command.LRW)
        assert row == {
            "ecatf.length": f"0x{12 + len(data) // 2:04x}", "ecat.cmd": f"0x{int(c):02x}",
            "ecat.idx": f"0x{idx:02x}", "ecat.adp": "" if logical else f"0x{adp:04x}",
            "ecat.ado": "" if logical else f"0x{ado:04x}",
            "ecat.lad": f"0x{adp | ado << 16:08x}" if logical else "",
            "ecat.subframe.length": str(len(data) // 2), "ecat.subframe.circulating": str(int(circ)),
            "ecat.subframe.more": "0", "ecat.int": f"0x{irq:04x}", "ecat.cnt": str(wkc)}, c.name
    assert rows[15]["ecat.subframe.more"] == "1,1,0" and rows[15]["ecat.adp"] == "0x1001,0x1002,0x1003"
    assert rows[15]["ecatf.length"] == "0x0036"
