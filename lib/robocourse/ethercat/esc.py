"""An EtherCAT Slave Controller (ESC): register space, process RAM, FMMUs, SyncManagers,
the AL state machine, the SII EEPROM interface and the DC unit.

The counterpart of a Beckhoff ET1100/ET1200 as described in the ESC datasheets (Section II)
and as SOEM drives it. A frame's datagram reaches ``access`` (physical addressing) or
``logical`` (through the FMMUs); each returns the working-counter increment this ESC adds:
+1 for a read, +2 for a write, +3 for both, 0 when the memory does not exist in this ESC model
(e.g. DC registers on an ET1200-like terminal), when a SyncManager blocks the access (wrong
direction, disabled, or deactivated by the application because of its AL state), or when
nothing matched.

Where we differ: one flat ``bytearray`` holds registers and RAM; the 3-buffer mode of a
process-data SyncManager is not modelled (the application sees the newest write at once);
the EEPROM takes one status read to finish a command (the busy phase SOEM polls through).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from .dc import LocalClock, encode_diff
from .sii import (
    SM_TYPE_INPUTS,
    SM_TYPE_MBX_IN,
    SM_TYPE_MBX_OUT,
    SM_TYPE_OUTPUTS,
    DeviceDescription,
    build_sii,
)

# AL states (ec_state)
INIT, PREOP, BOOT, SAFEOP, OP = 0x01, 0x02, 0x03, 0x04, 0x08
AL_ERROR = 0x10  # error flag in AL status = acknowledge bit in AL control
VALID_STATES = (INIT, PREOP, BOOT, SAFEOP, OP)
STATE_NAMES = {INIT: "INIT", PREOP: "PRE_OP", BOOT: "BOOT", SAFEOP: "SAFE_OP", OP: "OP"}
_RANK = {INIT: 0, PREOP: 1, BOOT: 1, SAFEOP: 2, OP: 3}

# AL status codes (ETG.1000.6 / SOEM ec_ALstatuscode)
AL_UNSPECIFIED = 0x0001
AL_INVALID_STATE_CHANGE = 0x0011
AL_UNKNOWN_STATE = 0x0012
AL_INVALID_MBX_CONFIG = 0x0016
AL_INVALID_SM_CONFIG = 0x0017
AL_SYNC_ERROR = 0x001A
AL_SM_WATCHDOG = 0x001B
AL_INVALID_OUTPUT_CONFIG = 0x001D
AL_INVALID_INPUT_CONFIG = 0x001E
AL_STATUS_TEXT = {
    0x0000: "No error", AL_UNSPECIFIED: "Unspecified error",
    AL_INVALID_STATE_CHANGE: "Invalid requested state change",
    AL_UNKNOWN_STATE: "Unknown requested state", AL_INVALID_MBX_CONFIG: "Invalid mailbox configuration",
    AL_INVALID_SM_CONFIG: "Invalid sync manager configuration", 0x0018: "No valid inputs available",
    0x0019: "No valid outputs", AL_SYNC_ERROR: "Synchronization error",
    AL_SM_WATCHDOG: "Sync manager watchdog", AL_INVALID_OUTPUT_CONFIG: "Invalid output configuration",
    AL_INVALID_INPUT_CONFIG: "Invalid input configuration", 0x002C: "Fatal sync error",
    0x0030: "Invalid DC SYNC configuration",
}

# registers
REG_TYPE, REG_PORTDES, REG_ESCSUP = 0x0000, 0x0007, 0x0008
REG_STADR, REG_ALIAS = 0x0010, 0x0012
REG_DLCTL, REG_DLSTAT = 0x0100, 0x0110
REG_ALCTL, REG_ALSTAT, REG_ALSTATCODE = 0x0120, 0x0130, 0x0134
REG_PDICTL = 0x0140
REG_IRQMASK, REG_IRQ = 0x0200, 0x0210
REG_WD_DIV, REG_WD_TIME_PD, REG_WD_STAT_PD = 0x0400, 0x0420, 0x0440
REG_EEPCFG, REG_EEPCTL, REG_EEPADR, REG_EEPDAT = 0x0500, 0x0502, 0x0504, 0x0508
REG_FMMU0, REG_SM0 = 0x0600, 0x0800
REG_DCTIME0, REG_DCSYSTIME, REG_DCSOF = 0x0900, 0x0910, 0x0918
REG_DCSYSOFFSET, REG_DCSYSDELAY, REG_DCSYSDIFF = 0x0920, 0x0928, 0x092C
REG_DCSPEEDCNT, REG_DCSYNCACT, REG_DCSTART0, REG_DCCYCLE0 = 0x0930, 0x0981, 0x0990, 0x09A0

EEP_CMD_READ, EEP_CMD_WRITE, EEP_CMD_RELOAD = 1, 2, 3
EEP_R64, EEP_NACK, EEP_BUSY = 0x0040, 0x2000, 0x8000
EVENT_DL_STATUS, EVENT_AL_STATUS = 0x0004, 0x0008
SOF_DELAY_NS = 40  # port 0 -> ECAT processing unit

_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")
_FMMU = struct.Struct("<IHBBHBBB")
_SM = struct.Struct("<HHBBBB")


@dataclass(frozen=True)
class EscModel:
    """What differs between ESC chips: type byte, FMMU/SM count, RAM, DC, missing registers."""

    esc_type: int
    revision: int
    build: int
    fmmus: int
    sms: int
    ram_kb: int
    features: int
    dc: bool

    @property
    def size(self) -> int:
        return 0x1000 + self.ram_kb * 1024


ET1100 = EscModel(0x11, 0x00, 3, 8, 8, 8, 0x01FC, True)  # couplers, drives: full DC
ET1200 = EscModel(0x12, 0x01, 1, 3, 4, 1, 0x01F8, False)  # simple terminals: no DC unit


class Esc:
    """One ESC with its SII image. Devices subclass it and override ``application``."""

    __slots__ = ("desc", "model", "mem", "sii", "clock", "device_emulation", "ports",
                 "link", "t_port0", "t_port1", "now_ns", "_fmmus", "_sms", "_holes",
                 "_ro", "_eep_busy", "_eep_err", "_eep_cmd", "_out_write_ns", "_sm_blocked",
                 "_sm_roles", "wd_expired", "_has_outputs", "_wd_ns", "station", "alias_active",
                 "_mbx_full", "_has_mbx", "_emulation_from_pdi")

    def __init__(self, desc: DeviceDescription, model: EscModel = ET1100, *,
                 device_emulation: bool | None = None, port_descriptor: int = 0x0F,
                 drift_ppm: float = 0.0, power_on_ns: float = 0.0) -> None:
        self.desc = desc
        self.model = model
        # None: as the ESC itself, from the PDI control word the SII loads into 0x0140 (bit 8,
        # "emulated device"), at every power-on
        self._emulation_from_pdi = device_emulation is None
        self.device_emulation = bool(device_emulation)
        self.mem = bytearray(model.size)
        self.sii = bytearray(build_sii(desc))
        self.clock = LocalClock(drift_ppm, power_on_ns) if model.dc else None
        self.ports = port_descriptor
        self.link = [True, False, False, False]  # port 0 towards the master; bus sets port 1
        self.t_port0 = self.t_port1 = self.now_ns = 0.0
        self._fmmus: list[tuple] = []
        self._sms: list[tuple[int, int, bool, int]] = []
        self._holes = [] if model.dc else [(0x0900, 0x0A00)]
        self._holes += [(REG_FMMU0 + 16 * model.fmmus, 0x0700), (REG_SM0 + 8 * model.sms, 0x0880)]
        self._ro = [(0x0000, 0x0010), (REG_DLSTAT, REG_DLSTAT + 2), (REG_ALSTAT, REG_ALSTAT + 6),
                    (REG_PDICTL, REG_PDICTL + 2), (REG_IRQ, REG_IRQ + 4),
                    (REG_WD_STAT_PD, REG_WD_STAT_PD + 2), (REG_EEPCTL, REG_EEPADR),
                    (0x0900, 0x0910), (0x0918, 0x0920), (REG_DCSYSDIFF, REG_DCSYSDIFF + 4)]
        self._eep_busy = 0
        self._eep_err = 0
        self._eep_cmd = 0
        self._out_write_ns = 0.0
        self._sm_blocked: set[int] = set()
        self._sm_roles = {i: sm.sm_type for i, sm in enumerate(desc.sms)}
        self.wd_expired = False
        self._has_outputs = desc.output_bits > 0
        self._wd_ns = 0.0
        self._mbx_full = [False] * model.sms  # 1-buffer (mailbox) SMs: buffer full (status bit 3)
        self._has_mbx = False
        self.station = 0  # 0x0010, cached for configured addressing
        self.alias_active: int | None = None  # 0x0012 when DL control 0x0103 bit 0 is set
        self.power_on()

    # ---- power-on defaults -------------------------------------------------------------
    def power_on(self) -> None:
        m, mem = self.model, self.mem
        mem[:] = bytes(len(mem))
        mem[0], mem[1] = m.esc_type, m.revision
        _U16.pack_into(mem, 2, m.build)
        mem[4], mem[5], mem[6], mem[7] = m.fmmus, m.sms, m.ram_kb, self.ports
        _U16.pack_into(mem, REG_ESCSUP, m.features)
        _U16.pack_into(mem, REG_ALIAS, _U16.unpack_from(self.sii, 8)[0])
        _U16.pack_into(mem, REG_PDICTL, _U16.unpack_from(self.sii, 0)[0])
        if self._emulation_from_pdi:
            self.device_emulation = bool(mem[REG_PDICTL + 1] & 0x01)
        _U16.pack_into(mem, REG_WD_DIV, 0x09C2)  # 2498 -> (2498 + 2) * 40 ns = 100 us
        _U16.pack_into(mem, REG_WD_TIME_PD, 1000)  # x 100 us = 100 ms
        self._wd_ns = self._watchdog_from_registers()
        _U16.pack_into(mem, REG_ALSTAT, INIT)
        _U16.pack_into(mem, REG_ALCTL, INIT)
        _U16.pack_into(mem, REG_EEPCTL, EEP_R64)
        self._fmmus, self._sms = [], []
        self.station, self.alias_active = 0, None
        self._apply_state(INIT)
        self._update_dl_status()

    # ---- link / DL status ----------------------------------------------------------------
    def set_port_link(self, port: int, up: bool) -> None:
        if self.link[port] != up:
            self.link[port] = up
            self._update_dl_status()
            _U16.pack_into(self.mem, REG_IRQ, _U16.unpack_from(self.mem, REG_IRQ)[0] | EVENT_DL_STATUS)

    def _update_dl_status(self) -> None:
        v = 0x0001  # PDI operational
        for p in range(4):
            if self.link[p]:
                v |= (0x10 << p) | (0x2 << (8 + 2 * p))  # link, loop open + communication
            else:
                v |= 0x1 << (8 + 2 * p)  # loop closed, no communication
        _U16.pack_into(self.mem, REG_DLSTAT, v)

    @property
    def irq(self) -> int:
        return _U16.unpack_from(self.mem, REG_IRQ)[0] & _U16.unpack_from(self.mem, REG_IRQMASK)[0]

    # ---- physical access (APxx, FPxx, Bxx, ARMW/FRMW) -------------------------------------
    def exists(self, ado: int, end: int) -> bool:
        """Whether this ESC model has memory at ``ado..end`` (no WKC otherwise)."""
        if end > len(self.mem):
            return False
        if ado >= 0x1000:  # process RAM: every model has it up to its size
            return True
        for lo, hi in self._holes:
            if ado < hi and lo < end:
                return False
        return True

    def readable(self, ado: int, n: int) -> bool:
        end = ado + n
        return self.exists(ado, end) and self._sm_allows(ado, end, False)

    def read(self, ado: int, n: int) -> bytes | None:
        """Bytes at ``ado`` as an ECAT read sees them, or None (no working counter)."""
        if not self.readable(ado, n):
            return None
        end = ado + n
        if ado < 0x0A00:
            self._refresh(ado, end)
        out = bytes(self.mem[ado:end])
        if self._has_mbx:
            self._mailbox_access(ado, end, False)
        return out

    def write(self, ado: int, data: bytes | bytearray) -> bool:
        """An ECAT write; False (no working counter) when this ESC has no such memory."""
        end = ado + len(data)
        if not self.exists(ado, end) or not self._sm_allows(ado, end, True):
            return False
        mem = self.mem
        if ado == REG_DCSYSTIME and self.clock is not None and end - ado in (4, 8):
            self._dc_write(ado, end, data)  # the FRMW/ARMW of every cycle: its own fast path
            return True
        if ado >= 0x1000:
            mem[ado:end] = data
            if self._sms:
                self._note_output_write(ado, end)
                if self._has_mbx:
                    self._mailbox_access(ado, end, True)
            return True
        saved = [(lo, bytes(mem[lo:hi])) for lo, hi in self._ro if ado < hi and lo < end]
        mem[ado:end] = data
        for lo, b in saved:
            mem[lo:lo + len(b)] = b
        self._on_register_write(ado, end, data)
        if self._sms:
            self._note_output_write(ado, end)
        return True

    # ---- logical access through the FMMUs (LRD/LWR/LRW) -----------------------------------
    def logical(self, read: bool, write: bool, laddr: int, data: bytearray) -> int:
        """Apply one logical datagram; returns the WKC increment (+1 read, +2 write)."""
        lend = laddr + len(data)
        did_r = did_w = False
        mem = self.mem
        for ls, ll, sb, eb, ps, psb, typ in self._fmmus:
            lo = ls if ls > laddr else laddr
            hi = ls + ll if ls + ll < lend else lend
            if lo >= hi:
                continue
            p0 = ps + lo - ls
            p1 = p0 + hi - lo
            d0 = lo - laddr
            plain = sb == 0 and eb == 7 and psb == 0
            exists = p1 <= len(mem) if p0 >= 0x1000 else self.exists(p0, p1)
            if write and typ & 2 and exists and self._sm_allows(p0, p1, True):
                if plain:
                    mem[p0:p1] = data[d0:d0 + hi - lo]
                else:
                    self._copy_bits(data, mem, ls, sb, ll, eb, ps, psb, lo, hi, laddr, True)
                if p0 < 0x1000:
                    self._on_register_write(p0, p1, mem[p0:p1])
                self._note_output_write(p0, p1)
                did_w = True
            if read and typ & 1 and exists and self._sm_allows(p0, p1, False):
                if p0 < 0x0A00:
                    self._refresh(p0, p1)
                if plain:
                    data[d0:d0 + hi - lo] = mem[p0:p1]
                else:
                    self._copy_bits(data, mem, ls, sb, ll, eb, ps, psb, lo, hi, laddr, False)
                did_r = True
        return (1 if did_r else 0) + (2 if did_w else 0)

    @staticmethod
    def _copy_bits(data, mem, ls, sb, ll, eb, ps, psb, lo, hi, laddr, to_mem) -> None:
        first = ls * 8 + sb
        last = (ls + ll - 1) * 8 + eb
        for lbit in range(max(first, lo * 8), min(last, hi * 8 - 1) + 1):
            pbit = ps * 8 + psb + (lbit - first)
            dbit = lbit - laddr * 8
            if to_mem:
                v = (data[dbit >> 3] >> (dbit & 7)) & 1
                mem[pbit >> 3] = (mem[pbit >> 3] & ~(1 << (pbit & 7))) | (v << (pbit & 7))
            else:
                v = (mem[pbit >> 3] >> (pbit & 7)) & 1
                data[dbit >> 3] = (data[dbit >> 3] & ~(1 << (dbit & 7))) | (v << (dbit & 7))

    # ---- SyncManagers -----------------------------------------------------------------
    def _sm_allows(self, ado: int, end: int, write: bool) -> bool:
        for start, stop, ecat_writes, i in self._sms:
            if ado < stop and start < end:
                if i in self._sm_blocked or ecat_writes != write:
                    return False
                if self._has_mbx and self._is_mailbox(i) and self._mbx_full[i] == write:
                    return False  # a full write mailbox takes nothing, an empty read one gives nothing
        return True

    def _is_mailbox(self, i: int) -> bool:
        return self.mem[REG_SM0 + 8 * i + 4] & 0x03 == 0x02

    def _mailbox_access(self, ado: int, end: int, write: bool) -> None:
        """After an ECAT access: writing a mailbox's last byte fills it (the application gets
        it), reading a mailbox's last byte empties it (SyncManager 1-buffer mode)."""
        for start, stop, _w, i in self._sms:
            if ado < stop and start < end and end >= stop and self._is_mailbox(i):
                self._set_mbx_full(i, write)
                if write:
                    self.mailbox_received(bytes(self.mem[start:stop]))

    def _set_mbx_full(self, i: int, full: bool) -> None:
        self._mbx_full[i] = full
        reg = REG_SM0 + 8 * i + 5
        self.mem[reg] = (self.mem[reg] | 0x08) if full else (self.mem[reg] & ~0x08)

    def mailbox_send(self, data: bytes) -> bool:
        """The application puts a reply in the read mailbox (the first SM of type 2)."""
        for start, stop, ecat_writes, i in self._sms:
            if not ecat_writes and self._is_mailbox(i):
                if self._mbx_full[i]:
                    return False
                self.mem[start:stop] = data[:stop - start].ljust(stop - start, b"\x00")
                self._set_mbx_full(i, True)
                return True
        return False

    def mailbox_received(self, data: bytes) -> None:
        """The application reads a mailbox the master wrote; devices with a mailbox override it.
        The write mailbox is free again once the application has taken the data."""
        self._release_write_mailbox()

    def _release_write_mailbox(self) -> None:
        for _s, _e, ecat_writes, i in self._sms:
            if ecat_writes and self._is_mailbox(i):
                self._set_mbx_full(i, False)

    def _note_output_write(self, ado: int, end: int) -> None:
        for start, stop, ecat_writes, i in self._sms:
            if ecat_writes and ado < stop and start < end and self._sm_roles.get(i) == SM_TYPE_OUTPUTS:
                self._out_write_ns = self.now_ns
                _U16.pack_into(self.mem, REG_WD_STAT_PD, 1)

    def _reload_sms(self) -> None:
        sms = []
        for i in range(self.model.sms):
            start, length, ctl, _st, act, _pdi = _SM.unpack_from(self.mem, REG_SM0 + 8 * i)
            if act & 1 and length:
                sms.append((start, start + length, bool(ctl & 0x04), i))
        self._sms = sms
        self._has_mbx = any(self._is_mailbox(i) for *_x, i in sms)

    def _reload_fmmus(self) -> None:
        out = []
        for i in range(self.model.fmmus):
            ls, ll, sb, eb, ps, psb, typ, act = _FMMU.unpack_from(self.mem, REG_FMMU0 + 16 * i)
            if act & 1 and ll and typ & 3:
                out.append((ls, ll, sb & 7, eb & 7, ps, psb & 7, typ & 3))
        self._fmmus = out

    def sm_registers(self, i: int) -> tuple[int, int, int, int]:
        """(start, length, control, activate) of SM ``i`` as the master programmed it."""
        start, length, ctl, _st, act, _pdi = _SM.unpack_from(self.mem, REG_SM0 + 8 * i)
        return start, length, ctl, act

    # ---- registers with side effects ----------------------------------------------------
    def _on_register_write(self, ado: int, end: int, data) -> None:
        if ado >= 0x0A00:  # nothing above the DC block has a side effect (0x0F00 is plain I/O)
            return
        if ado < 0x0014 and REG_STADR < end or ado <= 0x0103 < end:
            self.station = _U16.unpack_from(self.mem, REG_STADR)[0]
            self.alias_active = _U16.unpack_from(self.mem, REG_ALIAS)[0] \
                if self.mem[0x0103] & 1 else None
        if ado < REG_ALCTL + 1 and REG_ALCTL < end:
            self.al_control(_U16.unpack_from(self.mem, REG_ALCTL)[0])
        if ado <= REG_EEPCFG < end and self.mem[REG_EEPCFG] & 0x02:
            self.mem[REG_EEPCFG + 1] = 0  # force ECAT access: the PDI lets go
        if ado <= REG_EEPCTL + 1 < end:  # the command byte (bits 8-10) was written
            off = REG_EEPCTL - ado
            ctl = data[off + 1] << 8 | (data[off] if off >= 0 else self.mem[REG_EEPCTL])
            self._eeprom_command(ctl)
        if ado < REG_WD_TIME_PD + 2 and REG_WD_DIV < end:
            self._wd_ns = self._watchdog_from_registers()
        if ado < 0x0700 and REG_FMMU0 < end:
            self._reload_fmmus()
        if ado < 0x0880 and REG_SM0 < end:
            for i in range(self.model.sms):
                if ado <= REG_SM0 + 8 * i + 5 < end:  # (re)programmed: the buffer is empty
                    self._mbx_full[i] = False
                self.mem[REG_SM0 + 8 * i + 5] = 0x08 if self._mbx_full[i] else 0
                self.mem[REG_SM0 + 8 * i + 7] = 1 if i in self._sm_blocked else 0
            self._reload_sms()
        if self.clock is not None and ado < 0x0940 and REG_DCTIME0 < end:
            self._dc_write(ado, end, data)

    def _refresh(self, ado: int, end: int) -> None:
        mem = self.mem
        if ado < REG_EEPCTL + 2 and REG_EEPCTL < end:
            v = EEP_R64 | self._eep_err
            if self._eep_busy:
                self._eep_busy -= 1
                v |= EEP_BUSY | (self._eep_cmd << 8) | 0x0010
            _U16.pack_into(mem, REG_EEPCTL, v)
        if ado < REG_ALSTAT + 2 and REG_ALSTAT < end:
            _U16.pack_into(mem, REG_IRQ, _U16.unpack_from(mem, REG_IRQ)[0] & ~EVENT_AL_STATUS)
        if ado < REG_DLSTAT + 2 and REG_DLSTAT < end:
            _U16.pack_into(mem, REG_IRQ, _U16.unpack_from(mem, REG_IRQ)[0] & ~EVENT_DL_STATUS)
        if self.clock is not None and ado < REG_DCSYSTIME + 8 and REG_DCSYSTIME < end:
            _U64.pack_into(mem, REG_DCSYSTIME, self.system_time(self.t_port0 + SOF_DELAY_NS))

    # ---- EEPROM (SII) interface ---------------------------------------------------------
    def _eeprom_command(self, ctl: int) -> None:
        ecat_owns = not (self.mem[REG_EEPCFG] & 1) and not (self.mem[REG_EEPCFG + 1] & 1)
        cmd = (ctl >> 8) & 0x07
        if not ecat_owns:
            return
        if cmd == 0:
            self._eep_err = 0
            return
        word = _U32.unpack_from(self.mem, REG_EEPADR)[0]
        self._eep_cmd = cmd
        self._eep_busy = 1
        if cmd == EEP_CMD_READ:
            if word * 2 >= len(self.sii):
                self._eep_err = EEP_NACK
                return
            chunk = bytes(self.sii[word * 2:word * 2 + 8])
            self.mem[REG_EEPDAT:REG_EEPDAT + 8] = chunk + b"\xff" * (8 - len(chunk))
        elif cmd == EEP_CMD_WRITE:
            if not ctl & 1 or word * 2 + 2 > len(self.sii):
                self._eep_err = EEP_NACK
                return
            self.sii[word * 2:word * 2 + 2] = self.mem[REG_EEPDAT:REG_EEPDAT + 2]
        elif cmd == EEP_CMD_RELOAD:
            _U16.pack_into(self.mem, REG_ALIAS, _U16.unpack_from(self.sii, 8)[0])
            self._on_register_write(REG_ALIAS, REG_ALIAS + 2, b"")
        else:
            self._eep_err = EEP_NACK

    # ---- AL state machine (ESM) ---------------------------------------------------------
    @property
    def al_status(self) -> int:
        return _U16.unpack_from(self.mem, REG_ALSTAT)[0]

    @property
    def state(self) -> int:
        return self.al_status & 0x0F

    @property
    def al_status_code(self) -> int:
        return _U16.unpack_from(self.mem, REG_ALSTATCODE)[0]

    def al_control(self, value: int) -> None:
        """A master write of AL control: request ``value & 0x0F``, acknowledge with 0x10."""
        req, ack = value & 0x0F, bool(value & AL_ERROR)
        cur = self.al_status
        state, err = cur & 0x0F, cur & AL_ERROR
        if self.device_emulation:  # simple terminals: AL status echoes AL control
            self._set_status(value & 0x1F, 0)
            self._apply_state(req if req in VALID_STATES else state)
            return
        if err and not ack:
            if req in VALID_STATES and self._allowed(state, req) and _RANK[req] < _RANK[state]:
                self._enter(req, err=True)
            return
        if req not in VALID_STATES:
            self._set_status(state | AL_ERROR, AL_UNKNOWN_STATE)
            return
        if req == state:
            self._set_status(state, 0)
            return
        if not self._allowed(state, req):
            self._set_status(state | AL_ERROR, AL_INVALID_STATE_CHANGE)
            return
        code = self.check_transition(state, req)
        if code:
            self._set_status(state | AL_ERROR, code)
            return
        self._enter(req)

    @staticmethod
    def _allowed(state: int, req: int) -> bool:
        if state == BOOT:
            return req == INIT
        if (state, req) in ((INIT, PREOP), (INIT, BOOT), (PREOP, SAFEOP), (SAFEOP, OP)):
            return True
        return req in (INIT, PREOP, SAFEOP) and _RANK[req] < _RANK[state]

    def check_transition(self, state: int, req: int) -> int:
        """The application's checks before going up: PREOP->SAFEOP needs SM2/SM3 as the
        PDO map says (0x001D outputs, 0x001E inputs). Devices may add their own."""
        if state == INIT and req == PREOP:
            for i, sm in enumerate(self.desc.sms):
                if sm.sm_type in (SM_TYPE_MBX_OUT, SM_TYPE_MBX_IN) and sm.enable:
                    start, length, ctl, act = self.sm_registers(i)
                    if (start, length, ctl & 0x0F, act & 1) != (sm.start, self.desc.sm_length(i),
                                                                 sm.control & 0x0F, 1):
                        return AL_INVALID_MBX_CONFIG
        if state == PREOP and req == SAFEOP:
            for i, sm in enumerate(self.desc.sms):
                if sm.sm_type not in (SM_TYPE_OUTPUTS, SM_TYPE_INPUTS):
                    continue
                need = self.desc.sm_pdo_bytes(i)
                if not need:
                    continue
                start, length, ctl, act = self.sm_registers(i)
                writes = bool(ctl & 0x04)
                if (start != sm.start or length != need or not act & 1
                        or writes != (sm.sm_type == SM_TYPE_OUTPUTS)):
                    return (AL_INVALID_OUTPUT_CONFIG if sm.sm_type == SM_TYPE_OUTPUTS
                            else AL_INVALID_INPUT_CONFIG)
        return 0

    def _enter(self, new: int, err: bool = False) -> None:
        old = self.state
        self._set_status(new | (AL_ERROR if err else 0), self.al_status_code if err else 0)
        self._apply_state(new)
        if new == OP:
            self._out_write_ns = self.now_ns
            self.wd_expired = False
        if old == OP and new != OP:
            self.safe_outputs()

    def _set_status(self, status: int, code: int) -> None:
        if status != self.al_status:
            _U16.pack_into(self.mem, REG_IRQ, _U16.unpack_from(self.mem, REG_IRQ)[0] | EVENT_AL_STATUS)
        _U16.pack_into(self.mem, REG_ALSTAT, status)
        _U16.pack_into(self.mem, REG_ALSTATCODE, code)

    def _apply_state(self, state: int) -> None:
        """The application (de)activates its process-data SyncManagers by state, as SOES does:
        inputs from SAFE_OP, outputs only in OP."""
        blocked = set()
        for i, role in self._sm_roles.items():
            if role in (SM_TYPE_MBX_OUT, SM_TYPE_MBX_IN) and state in (INIT, BOOT):
                blocked.add(i)
            if role == SM_TYPE_INPUTS and _RANK.get(state, 0) < _RANK[SAFEOP]:
                blocked.add(i)
            if role == SM_TYPE_OUTPUTS and state != OP:
                blocked.add(i)
        self._sm_blocked = blocked
        for i in range(self.model.sms):
            self.mem[REG_SM0 + 8 * i + 7] = 1 if i in blocked else 0

    def fail(self, code: int, state: int = SAFEOP) -> None:
        """The application reports an error: drop to ``state`` (if lower) with the error flag."""
        target = state if _RANK[state] < _RANK[self.state] else self.state
        old = self.state
        self._set_status(target | AL_ERROR, code)
        self._apply_state(target)
        if old == OP and target != OP:
            self.safe_outputs()

    # ---- SM watchdog ---------------------------------------------------------------------
    @property
    def watchdog_ns(self) -> float:
        """SM watchdog time: (divider 0x0400 + 2) x 40 ns x process-data count 0x0420."""
        return self._wd_ns

    def _watchdog_from_registers(self) -> float:
        div = _U16.unpack_from(self.mem, REG_WD_DIV)[0]
        return (div + 2) * 40.0 * _U16.unpack_from(self.mem, REG_WD_TIME_PD)[0]

    def poll(self, now_ns: float) -> None:
        """Time passes: an output SM not written for the watchdog time drops OP to SAFE_OP."""
        self.now_ns = now_ns
        if (self._has_outputs and self.mem[REG_ALSTAT] & 0x0F == OP and self._wd_ns > 0
                and now_ns - self._out_write_ns > self._wd_ns):
            self.wd_expired = True
            _U16.pack_into(self.mem, REG_WD_STAT_PD, 0)
            self.fail(AL_SM_WATCHDOG, SAFEOP)

    # ---- distributed clock ----------------------------------------------------------------
    def system_time(self, bus_ns: float) -> int:
        offset = _U64.unpack_from(self.mem, REG_DCSYSOFFSET)[0]
        return (self.local_ticks(bus_ns) + offset) & 0xFFFFFFFFFFFFFFFF

    def local_ticks(self, bus_ns: float) -> int:
        """The local clock as its register shows it: a counter in 10-ns ticks."""
        return int(self.clock.local(bus_ns)) // 10 * 10

    def _dc_write(self, ado: int, end: int, data) -> None:
        clock, mem = self.clock, self.mem
        if ado < REG_DCTIME0 + 4 and REG_DCTIME0 < end:  # latch receive times on all ports
            _U32.pack_into(mem, REG_DCTIME0, self.local_ticks(self.t_port0) & 0xFFFFFFFF)
            t1 = self.local_ticks(self.t_port1) & 0xFFFFFFFF if self.link[1] else 0
            _U32.pack_into(mem, REG_DCTIME0 + 4, t1)
            _U64.pack_into(mem, REG_DCSOF, self.local_ticks(self.t_port0 + SOF_DELAY_NS))
        if ado < REG_DCSYSTIME + 8 and REG_DCSYSTIME < end:
            raw = bytes(data[REG_DCSYSTIME - ado:REG_DCSYSTIME - ado + 8]) if ado <= REG_DCSYSTIME \
                else b""
            if len(raw) in (4, 8):
                t = self.t_port0 + SOF_DELAY_NS
                own = self.system_time(t)
                delay = _U32.unpack_from(mem, REG_DCSYSDELAY)[0]
                got = int.from_bytes(raw, "little") + delay
                if len(raw) == 4:
                    diff = ((got - own + 0x80000000) & 0xFFFFFFFF) - 0x80000000
                else:
                    diff = ((got - own + (1 << 63)) & 0xFFFFFFFFFFFFFFFF) - (1 << 63)
                _U32.pack_into(mem, REG_DCSYSDIFF, encode_diff(diff))
                clock.control(float(diff), t)
        if ado < REG_DCSPEEDCNT + 2 and REG_DCSPEEDCNT < end:
            clock.reset_filter()

    def sync0_active(self) -> bool:
        return self.clock is not None and self.mem[REG_DCSYNCACT] & 0x03 == 0x03 and \
            _U32.unpack_from(self.mem, REG_DCCYCLE0)[0] > 0

    def sync0_bus_time(self, k: int) -> float:
        """Bus time of this slave's k-th SYNC0 event (start time 0x0990 + k x cycle 0x09A0)."""
        start = _U64.unpack_from(self.mem, REG_DCSTART0)[0]
        cycle = _U32.unpack_from(self.mem, REG_DCCYCLE0)[0]
        offset = _U64.unpack_from(self.mem, REG_DCSYSOFFSET)[0]
        local = (start + k * cycle - offset) & 0xFFFFFFFFFFFFFFFF
        if local >= 1 << 63:
            local -= 1 << 64
        return self.clock.bus_time_of_local(float(local))

    def next_sync0(self, bus_ns: float) -> float:
        """Bus time of this slave's first SYNC0 event at or after ``bus_ns``."""
        start = _U64.unpack_from(self.mem, REG_DCSTART0)[0]
        cycle = _U32.unpack_from(self.mem, REG_DCCYCLE0)[0]
        k = max(0, -(-(self.system_time(bus_ns) - start) // cycle))
        return self.sync0_bus_time(k)

    # ---- the application (devices override) ---------------------------------------------
    def application(self, now_ns: float) -> None:
        """Runs after every frame: read outputs, compute, write inputs. Nothing by default."""

    def safe_outputs(self) -> None:
        """Put outputs in their safe state (leaving OP)."""

    def pdi_read(self, ado: int, n: int) -> bytes:
        return bytes(self.mem[ado:ado + n])

    def pdi_write(self, ado: int, data: bytes) -> None:
        self.mem[ado:ado + len(data)] = data

    @property
    def station_address(self) -> int:
        return _U16.unpack_from(self.mem, REG_STADR)[0]

    @property
    def alias(self) -> int:
        return _U16.unpack_from(self.mem, REG_ALIAS)[0]
