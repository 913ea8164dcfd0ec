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
