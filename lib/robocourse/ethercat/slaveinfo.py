"""What SOEM's ``slaveinfo`` example prints, for a bus our master has brought to SAFE_OP.

Counterpart: SOEM v1.4.0 ``test/linux/slaveinfo/slaveinfo.c`` (``slaveinfo IFNAME [-map]``):
ec_config + ec_configdc, the calculated working counter, then per slave its name, I/O bits,
state, DC delay, active ports, configured address, identity, SyncManagers, FMMUs, mailbox,
SII general details and, with ``-map``, the PDO mapping from the SII (``si_map_sii``).
Where we differ: the layout is written from slaveinfo.c's printf formats as we know them;
"FMMUfunc" comes from the SII FMMU category.
"""

from __future__ import annotations

from .esc import AL_STATUS_TEXT, SAFEOP
from .master import Master, Slave

DTYPES = {0x0001: "BOOLEAN", 0x0002: "INTEGER8", 0x0003: "INTEGER16", 0x0004: "INTEGER32",
          0x0005: "UNSIGNED8", 0x0006: "UNSIGNED16", 0x0007: "UNSIGNED32", 0x0008: "REAL32",
          0x0015: "INTEGER64", 0x001B: "UNSIGNED64"}


def _dtype(dtype: int, bitlen: int) -> str:
    if dtype in DTYPES:
        return DTYPES[dtype]
    return f"BIT{bitlen}" if bitlen < 8 else f"Type 0x{dtype:04X}"


def _map_sii(s: Slave) -> list[str]:
    out = ["PDO mapping according to SII :"]
    for rx, base in ((1, s.out_offset), (0, s.in_offset)):
        pdos = s.detailed_pdos(bool(rx))
        bit = 0
        for p in pdos:
            out.append(f" SM{p.sm} {'RXPDO' if rx else 'TXPDO'} 0x{p.index:04X} {p.name}")
            out.append("     addr b   index: sub bitl data_type    name")
            for e in p.entries:
                if e.index or e.subindex:
                    out.append(f"  [0x{base + bit // 8:04X}.{bit % 8}] 0x{e.index:04X}:0x{e.subindex:02X} "
                               f"0x{e.bitlen:02X} {_dtype(e.datatype, e.bitlen):<12} {e.name}")
                bit += e.bitlen
    return out


def slaveinfo_text(master: Master, ifname: str, show_map: bool = False) -> str:
    """Bring the bus to SAFE_OP (config_init, config_map, config_dc) and describe it."""
    lines = ["SOEM (Simple Open EtherCAT Master)", "Slaveinfo", "Starting slaveinfo",
             f"ec_init on {ifname} succeeded."]
    if master.config_init() <= 0:
        lines += ["No slaves found!", "End slaveinfo, close socket"]
        return "\n".join(lines) + "\n"
    master.config_map()
    master.config_dc()
    lines.append(f"{len(master.slaves)} slaves found and configured.")
    lines.append(f"Calculated workcounter {master.expected_wkc}")
    if master.state_check(SAFEOP, 150_000) != SAFEOP:
        lines.append("Not all slaves reached safe operational state.")
        for s in master.slaves:
            if s.state != SAFEOP:
                lines.append(f"Slave {s.position} State={s.state:2x} StatusCode={s.al_status_code:4x} : "
                             f"{AL_STATUS_TEXT.get(s.al_status_code, 'Unknown error')}")
    master.read_state()
    for s in master.slaves:
        g = s.sii.general
        det = [g[i] if len(g) > i else 0 for i in (5, 6, 7, 8)]
        lines += ["", f"Slave:{s.position}", f" Name:{s.name}", f" Output size: {s.obits}bits",
                  f" Input size: {s.ibits}bits", f" State: {s.state}", f" Delay: {s.dc_delay}[ns]",
                  f" Has DC: {int(s.has_dc)}"]
        if s.has_dc:
            lines.append(f" DCParentport:{0 if s.parent == 0 else 1}")
        ports = ".".join(str(int(bool(s.active_ports & (1 << p)))) for p in range(4))
        lines += [f" Activeports:{ports}", f" Configured address: {s.config_address:04x}",
                  f" Man: {s.man:08x} ID: {s.id:08x} Rev: {s.rev:08x}"]
        for i, (start, length, flags) in enumerate(s.sm):
            if start > 0:
                lines.append(f" SM{i} A:{start:04x} L:{length:4d} F:{flags:08x} Type:{s.sm_type[i]}")
        for i, f in enumerate(s.fmmus):
            lines.append(f" FMMU{i} Ls:{f.log_start:08x} Ll:{f.log_length:4d} Lsb:{f.log_startbit} "
                         f"Leb:{f.log_endbit} Ps:{f.phys_start:04x} Psb:0 Ty:{f.fmmu_type:02x} Act:01")
        func = (list(s.sii.fmmus) + [0, 0, 0, 0])[:4]
        lines.append(" FMMUfunc " + " ".join(f"{i}:{v}" for i, v in enumerate(func)))
        lines.append(f" MBX length wr: {s.sii.mbx_rx_size} rd: {s.sii.mbx_tx_size} "
                     f"MBX protocols : {s.sii.mbx_protocols:02x}")
        lines.append(f" CoE details: {det[0]:02x} FoE details: {det[1]:02x} "
                     f"EoE details: {det[2]:02x} SoE details: {det[3]:02x}")
        lines += [f" Ebus current: {s.sii.ebus_current_ma}[mA]", " only LRD/LWR:0"]
        if show_map:
            lines += _map_sii(s)
    lines.append("End slaveinfo, close socket")
    return "\n".join(lines) + "\n"
