"""``robocourse ethercat slaveinfo`` and ``robocourse ethercat capture``."""

import shutil
import subprocess

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


def test_raw_interface_that_does_not_exist_is_a_clear_error(capsys):
    assert main(["ethercat", "slaveinfo", "--ifname", "rc-no-such-if"]) == 2
    err = capsys.readouterr().err
    assert "rc-no-such-if" in err and ("ip link" in err or "CAP_NET_RAW" in err)


def test_unprivileged_raw_socket_says_how_to_grant_it(monkeypatch):
    import socket

    from robocourse.ethercat import transport

    def refuse(*a, **k):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(socket, "socket", refuse)
    with pytest.raises(PermissionError) as info:
        transport.open_raw("eth0")
    text = str(info.value)
    assert "'eth0' needs CAP_NET_RAW" in text and "run the master as root" in text
    # issue 25: never setcap the base interpreter (every Python script would get the capability):
    # only a copied venv interpreter, as the README and chapter 1 teach
    assert "readlink" not in text and "$(which python3)" not in text
    assert "sudo setcap cap_net_raw+ep .venv-rt/bin/python3" in text or "for this copied venv interpreter" in text


def test_veth_test_reason_names_root_when_unprivileged(monkeypatch):
    import os

    from robocourse.ethercat import netns

    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    assert "needs root" in netns.why_not()
    with pytest.raises(PermissionError, match="needs root"):
        netns.VethPair("x").__enter__()


TSHARK = shutil.which("tshark")


@pytest.mark.skipif(TSHARK is None, reason="tshark not installed (.ci/run installs it: apt-get install tshark)")
def test_tshark_finds_no_malformed_frame_in_a_whole_bring_up(tmp_path, capsys):
    f = tmp_path / "all.pcap"
    assert main(["ethercat", "capture", str(f), "--cycles", "20"]) == 0
    n = len(read_pcap(f))
    run = [TSHARK, "-r", str(f), "-T", "fields", "-e", "frame.number"]
    ecat = subprocess.run(run + ["-Y", "ecat"], capture_output=True, text=True, timeout=120)
    bad = subprocess.run(run + ["-Y", "_ws.malformed"], capture_output=True, text=True, timeout=120)
    warn = subprocess.run([TSHARK, "-r", str(f), "-Y", "_ws.expert.severity >= warning", "-T",
                           "fields", "-e", "_ws.expert.message"], capture_output=True, text=True,
                          timeout=120)
    assert len(ecat.stdout.split()) == n and n > 1000
    assert bad.stdout.split() == []
    # the one warning is about SOEM's own source address 01:01:01:01:01:01 (group bit set);
    # Wireshark says the same of a real SOEM capture
    assert set(warn.stdout.splitlines()) == {
        "Source MAC must not be a group address: IEEE 802.3-2002, Section 3.2.3(b)"}
