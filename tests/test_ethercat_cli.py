"""``robocourse ethercat slaveinfo`` and ``robocourse ethercat capture``."""

import pytest

from robocourse.cli import main
from robocourse.ethercat.frames import Command, decode_frame
from robocourse.ethercat.pcap import read_pcap


def test_slaveinfo_prints_soem_slaveinfo_for_the_demo_bus(capsys):
    assert main(["ethercat", "slaveinfo"]) == 0
    out = capsys.readouterr().out
    assert "4 slaves found and configured.\nCalculated workcounter 6\n" in out
    assert "\nSlave:4\n Name:RC-Servo\n Output size: 104bits\n Input size: 104bits\n State: 4\n" in out
    assert " Man: 00000a5c ID: 00402001 Rev: 00010000\n" in out
    assert " SM2 A:1100 L:  13 F:00010064 Type:3\n SM3 A:1180 L:  13 F:00010020 Type:4\n" in out
    assert " FMMU0 Ls:00000001 Ll:  13 Lsb:0 Leb:7 Ps:1100 Psb:0 Ty:02 Act:01\n" in out
    assert "PDO mapping" not in out and out.endswith("End slaveinfo, close socket\n")


def test_slaveinfo_map_prints_the_sii_pdo_mapping_at_image_offsets(capsys):
    assert main(["ethercat", "slaveinfo", "--map", "--io-pairs", "0"]) == 0
    out = capsys.readouterr().out
    assert " SM2 RXPDO 0x1600 RxPDO\n" in out
    assert "  [0x0000.0] 0x6040:0x00 0x10 UNSIGNED16   Controlword\n" in out
    assert "  [0x0002.0] 0x607A:0x00 0x20 INTEGER32    Target position\n" in out
    assert "  [0x000D.0] 0x6041:0x00 0x10 UNSIGNED16   Statusword\n" in out
    assert "Calculated workcounter 3\n" in out


def test_capture_writes_bring_up_and_cycles_to_pcap(tmp_path, capsys):
    f = tmp_path / "bus.pcap"
    assert main(["ethercat", "capture", str(f), "--cycles", "10"]) == 0
    recs = read_pcap(f)
    frames = [decode_frame(raw) for _, raw in recs]
    lrw = [fr for fr in frames if fr.datagrams[0].cmd == Command.LRW]
    assert len(lrw) >= 20  # 10 cycles + the exchanges to OP, requests and replies
    replies = [fr for fr in lrw if fr.src[0] & 0x02]
    assert [fr.datagrams[0].wkc for fr in replies[-10:]] == [6] * 10
    assert f"wrote {len(recs)} frames" in capsys.readouterr().out


def test_negative_counts_are_refused(capsys):
    assert main(["ethercat", "capture", "x.pcap", "--cycles", "-1"]) == 2
    assert "--cycles must be 0 or more, got -1" in capsys.readouterr().err


def test_raw_interface_that_does_not_exist_is_a_clear_error():
    from robocourse.ethercat.transport import open_raw

    with pytest.raises((OSError, PermissionError), match="rc-no-such-if"):
        open_raw("rc-no-such-if")
