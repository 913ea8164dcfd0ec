"""CoE: mailbox SyncManagers in 1-buffer mode, expedited SDO bytes, the drive's object
dictionary, aborts, and the master reading the PDO map by SDO as SOEM's ecx_readPDOmap does."""

import shutil
import struct
import subprocess

import pytest

from robocourse.ethercat.bus import Bus
from robocourse.ethercat.coe import (
    ABORT_NO_OBJECT,
    ABORT_NO_SUBINDEX,
    ABORT_NOT_VALID,
    ABORT_READ_ONLY,
    parse_sdo_response,
    sdo_request,
)
from robocourse.ethercat.devices import Cia402Drive, Coupler, DigitalInputs, DigitalOutputs
from robocourse.ethercat.errors import SdoError
from robocourse.ethercat.esc import AL_INVALID_MBX_CONFIG, INIT, PREOP
from robocourse.ethercat.frames import Command, datagram, decode_frame, frame_bytes
from robocourse.ethercat.master import Master
from robocourse.ethercat.pcap import PcapWriter, read_pcap


def one(bus, cmd, adp, ado, data):
    return decode_frame(bus.process(frame_bytes([datagram(cmd, adp, ado, data)]))).datagrams[0]


def mailbox_drive_asked_for_preop(write_mailbox_len=128):
    """A CoE drive at 0x1001 with SM0/SM1 programmed as SOEM does, then PRE_OP requested."""
    bus = Bus([Cia402Drive(mailbox=True)])
    one(bus, Command.APWR, 0, 0x0010, b"\x01\x10")
    one(bus, Command.FPWR, 0x1001, 0x0800, struct.pack(
        "<HHIHHI", 0x1000, write_mailbox_len, 0x00010026, 0x1080, 128, 0x00010022))
    one(bus, Command.FPWR, 0x1001, 0x0120, b"\x02\x00")
    return bus


def drive_in_preop():
    bus = mailbox_drive_asked_for_preop()
    assert bus.slaves[0].state == PREOP
    return bus


def sdo(bus, request):
    assert one(bus, Command.FPWR, 0x1001, 0x1000, request.ljust(128, b"\x00")).wkc == 1
    assert one(bus, Command.FPRD, 0x1001, 0x080D, 2).data[0] & 0x08  # read mailbox full
    reply = one(bus, Command.FPRD, 0x1001, 0x1080, 128)
    assert reply.wkc == 1
    return bytes(reply.data)


def test_sdo_upload_request_and_response_bytes_match_the_captured_akd_exchange():
    # captured: request 0a00 0000 00 13 | 0020 | 40 001c 00 00000000 (upload 0x1C00:00)
    req = sdo_request(0x1C00, 0, counter=1)
    assert req == bytes.fromhex("0a00" "0000" "00" "13" "0020" "40" "001c" "00" "00000000")
    # captured response: ... | 0030 | 4f 001c 00 04000000 (expedited, 1 byte, value 4)
    reply = sdo(drive_in_preop(), req)
    assert reply[6:16] == bytes.fromhex("0030" "4f" "001c" "00" "04000000")
    assert reply[:2] == b"\x0a\x00" and reply[5] & 0x0F == 3
    assert parse_sdo_response(reply, 0x1C00, 0) == (b"\x04", 0)


def test_object_dictionary_holds_identity_sm_types_and_the_pdo_mapping():
    bus = drive_in_preop()

    def up(index, sub):
        value, abort = parse_sdo_response(sdo(bus, sdo_request(index, sub, 1)), index, sub)
        assert abort == 0
        return int.from_bytes(value, "little")

    assert up(0x1000, 0) == 0x00020192
    assert [up(0x1018, k) for k in (1, 2, 3)] == [0x00000A5C, 0x00402002, 0x00010000]
    assert [up(0x1C00, k) for k in range(5)] == [4, 1, 2, 3, 4]
    assert (up(0x1C12, 1), up(0x1C13, 1)) == (0x1600, 0x1A00)
    assert up(0x1600, 0) == 5 and up(0x1600, 1) == 0x60400010  # controlword, 16 bits
    assert up(0x1A00, 2) == 0x60640020  # position actual, 32 bits


def test_sdo_download_changes_the_drive_and_aborts_name_the_reason():
    bus = drive_in_preop()
    reply = sdo(bus, sdo_request(0x6060, 0, 2, bytes([9])))
    assert reply[8] == 0x60 and bus.slaves[0].mode_display == 9
    assert parse_sdo_response(sdo(bus, sdo_request(0x6061, 0, 3)), 0x6061, 0) == (b"\x09", 0)
    for request, code in ((sdo_request(0x2000, 0, 4), ABORT_NO_OBJECT),
                          (sdo_request(0x1018, 9, 5), ABORT_NO_SUBINDEX),
                          (sdo_request(0x6041, 0, 6, b"\x00\x00"), ABORT_READ_ONLY),
                          (sdo_request(0x1018, 1, 7)[:8] + b"\x21" + sdo_request(0x1018, 1, 7)[9:],
                           ABORT_NOT_VALID)):  # a segmented download: not implemented
        reply = sdo(bus, request)
        assert reply[8] == 0x80 and struct.unpack_from("<H", reply, 6)[0] >> 12 == 2
        assert parse_sdo_response(reply, 0, 0) == (None, code)


def test_mailbox_syncmanagers_refuse_a_second_write_and_an_empty_read():
    bus = drive_in_preop()
    assert one(bus, Command.FPRD, 0x1001, 0x1080, 128).wkc == 0  # nothing to read yet
    esc = bus.slaves[0]
    esc.mailbox_received = lambda data: None  # an application that does not take the mailbox
    assert one(bus, Command.FPWR, 0x1001, 0x1000, bytes(128)).wkc == 1
    assert one(bus, Command.FPRD, 0x1001, 0x0805, 1).data[0] & 0x08  # write mailbox full
    assert one(bus, Command.FPWR, 0x1001, 0x1000, bytes(128)).wkc == 0


def test_mailbox_sm_config_unlike_the_sii_refuses_preop_with_0x0016():
    esc = mailbox_drive_asked_for_preop(write_mailbox_len=64).slaves[0]
    assert (esc.al_status, esc.al_status_code) == (INIT | 0x10, AL_INVALID_MBX_CONFIG)


def coe_bus(**kw):
    return Bus([Coupler(), DigitalInputs(), DigitalOutputs(), Cia402Drive(mailbox=True)], **kw)


def test_master_maps_a_coe_drive_by_sdo_and_reads_writes_objects(tmp_path):
    with PcapWriter(tmp_path / "coe.pcap") as w:
        bus = coe_bus(capture=w)
        m = Master()
        m.open(bus)
        m.config_init()
        assert m.config_map() == 28 and m.expected_wkc == 6
    bus.capture = None
    uploads = []
    for _, raw in read_pcap(tmp_path / "coe.pcap"):
        f = decode_frame(raw)
        for d in f.datagrams:
            if not f.src[0] & 2 and d.cmd == Command.FPWR and d.ado == 0x1000:
                uploads.append(struct.unpack_from("<HB", d.data, 9))
    assert uploads[:4] == [(0x1C00, 0), (0x1C00, 3), (0x1C12, 0), (0x1C12, 1)]  # ecx_readPDOmap
    drive = m.slaves[3]
    assert drive.sdo_read(0x1018, 1) == struct.pack("<I", 0x00000A5C)
    drive.sdo_write(0x6065, 0, struct.pack("<I", 5000))
    assert bus.slaves[3].following_error_window == 5000
    with pytest.raises(SdoError, match="0x2000:00 aborted with 0x06020000") as e:
        drive.sdo_read(0x2000, 0)
    assert e.value.abort_code == ABORT_NO_OBJECT
    m.bring_up()
    assert m.state_check(8, 1000) == 8


TSHARK = shutil.which("tshark")


@pytest.mark.skipif(TSHARK is None, reason="tshark not installed (.ci/run installs it: apt-get install tshark)")
def test_tshark_decodes_our_coe_mailbox_traffic(tmp_path):
    with PcapWriter(tmp_path / "coe.pcap") as w:
        m = Master()
        m.open(coe_bus(capture=w))
        m.config_init()
        m.config_map()
    out = subprocess.run([TSHARK, "-r", str(tmp_path / "coe.pcap"), "-Y", "ecat_mailbox.coe",
                          "-T", "fields", "-e", "ecat_mailbox.coe.sdoidx", "-e",
                          "ecat_mailbox.coe.sdosub"], capture_output=True, text=True, timeout=120)
    rows = [tuple(line.split("\t")) for line in out.stdout.splitlines()]
    assert ("0x1c12", "0x01") in rows and ("0x1600", "0x05") in rows
