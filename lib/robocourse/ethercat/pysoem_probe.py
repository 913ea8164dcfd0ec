"""Run a real SOEM master (pysoem) against a bus on an interface; print one JSON report.

``python -m robocourse.ethercat.pysoem_probe IFNAME --cycles 1000`` does what SOEM's
simple_test does (config_init, config_map, config_dc, SAFE_OP, OP while exchanging process
data), then exchanges until ``--cycles`` of them were answered, counting the working counters,
writing a counter to the first 1-byte output slave and walking the first CiA 402 drive (13
output bytes) to Operation enabled with ethercat_driver_ros2's automatic transitions. It times
every round trip. A frame not back within ``--ret-timeout-us`` (SOEM's EC_NOFRAME, -1: the bus's
process did not run in time) is counted in ``wkc_lost`` and the exchange
repeated, as a cyclic application carries on after a lost frame; at most ``max(cycles, 1000)``
of them, so a dead bus ends the run. A frame that came back with a wrong working counter counts
in ``wkc_values``, never as lost.
It is a separate process so a hang in SOEM cannot block the caller (run it with a timeout).
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
import time

#: SOEM's return for a frame that did not come back within the timeout (ethercattype.h)
EC_NOFRAME = -1


def _auto_cw(sw: int, cw: int) -> int:
    if sw & 0x4F == 0x40:
        return (cw & 0x7E) | 0x06
    if sw & 0x6F == 0x21:
        return (cw & 0x77) | 0x07
    if sw & 0x6F in (0x23, 0x07):
        return (cw & 0x7F) | 0x0F
    return cw


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ifname")
    ap.add_argument("--cycles", type=int, default=1000)
    ap.add_argument("--ret-timeout-us", type=int, default=1_000_000,
                    help="SOEM's EC_TIMEOUTRET, and the floor of its EEPROM, SAFE and mailbox timeouts (SOEM's "
                    "defaults: 2, 20, 20, 20 and 700 ms); a safety net of 1 s here: our bus is a process on a loaded "
                    "machine, and an answer SOEM gave up on changes the bring-up it sends (a status read that timed "
                    "out made it read the EEPROM 4 bytes at a time instead of 8)")
    ap.add_argument("--sdo-slave", type=int, default=0,
                    help="1-based slave to read 0x1018:01 and 0x6061 from by SDO, and to ask for "
                    "a missing object 0x2000 (its abort)")
    a = ap.parse_args(argv)
    import pysoem

    t = pysoem.settings.timeouts
    t.ret = a.ret_timeout_us
    for name in ("safe", "eeprom", "tx_mailbox", "rx_mailbox"):
        setattr(t, name, max(getattr(t, name), a.ret_timeout_us))
    rep: dict = {"pysoem": pysoem.__version__}
    m = pysoem.Master()
    m.open(a.ifname)
    try:
        rep["config_init"] = m.config_init()
        rep["slaves"] = [{"name": s.name, "man": s.man, "id": s.id, "rev": s.rev}
                         for s in m.slaves]
        rep["config_map"] = m.config_map()
        rep["expected_wkc"] = m.expected_wkc
        rep["config_dc"] = bool(m.config_dc())
        rep["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 50000)
        if a.sdo_slave:
            s = m.slaves[a.sdo_slave - 1]
            rep["sdo_1018_01"] = s.sdo_read(0x1018, 1).hex()
            s.sdo_write(0x6060, 0, bytes([9]))
            rep["sdo_6061"] = s.sdo_read(0x6061, 0).hex()
            try:
                s.sdo_read(0x2000, 0)
                rep["sdo_missing"] = "no error"
            except pysoem.SdoError as e:
                rep["sdo_missing"] = f"SdoError abort 0x{e.abort_code:08X}: {e.desc}"
            except Exception as e:  # noqa: BLE001 - report whatever pysoem raised
                rep["sdo_missing"] = f"{type(e).__name__}: {e}"
        m.state = pysoem.OP_STATE
        m.send_processdata()
        m.receive_processdata(a.ret_timeout_us)
        m.write_state()
        for _ in range(100):
            m.send_processdata()
            m.receive_processdata(a.ret_timeout_us)
            if m.state_check(pysoem.OP_STATE, 5000) == pysoem.OP_STATE:
                break
        rep["op"] = m.state_check(pysoem.OP_STATE, 5000)
        m.read_state()
        rep["states"] = [s.state for s in m.slaves]
        rep["al_status_codes"] = [s.al_status for s in m.slaves]
        do = next((s for s in m.slaves if len(s.output) == 1), None)
        drive = next((s for s in m.slaves if len(s.output) == 13), None)
        wkcs, rtt, cw, k, lost = [], [], 0, 0, 0
        while len(wkcs) < a.cycles and lost < max(a.cycles, 1000):
            if do is not None:
                do.output = bytes([k & 0xFF])
            if drive is not None:
                sw, pos = struct.unpack_from("<Hi", drive.input)
                cw = _auto_cw(sw, cw)
                drive.output = struct.pack("<HiihB", cw, pos, 0, 0, 8)
            t0 = time.perf_counter_ns()
            m.send_processdata()
            wkc = m.receive_processdata(a.ret_timeout_us)
            rtt.append(time.perf_counter_ns() - t0)
            k += 1
            if wkc == EC_NOFRAME:
                lost += 1
            else:
                wkcs.append(wkc)
        rep["wkc_lost"] = lost
        rep["wkc_ok"] = sum(w == m.expected_wkc for w in wkcs)
        rep["wkc_values"] = sorted(set(wkcs))
        rep["rtt_ns"] = rtt
        rep["inputs"] = [s.input.hex() for s in m.slaves]
        rep["drive_statusword"] = struct.unpack_from("<H", drive.input)[0] if drive else None
        m.state = pysoem.INIT_STATE
        m.write_state()
    finally:
        m.close()
    json.dump(rep, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
