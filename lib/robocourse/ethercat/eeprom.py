"""A master's access to slave SII EEPROMs through the ESC's EEPROM interface, as SOEM does it.

Counterparts in SOEM (ethercatmain.c / ec_main.c): ``ecx_eeprom2master``/``ecx_eeprom2pdi``
(0x0500), ``ecx_eeprom_waitnotbusyFP`` (poll 0x0502), ``ecx_readeeprom1`` (start a read:
FPWR 0x0502 of 6 bytes = command + word address), ``ecx_readeeprom2`` (finish it: 4 bytes
from 0x0508), ``ecx_readeepromFP`` (both, 8 bytes when the ESC reports R64), and
``ecx_siigetbyte``/``ecx_siifind``/``ecx_siistring``/``ecx_siiPDO``: byte access through a
one-slave cache that fills 8 bytes from the missed byte's word on. Same datagrams, same order,
so a capture of our master's scan reads like one of SOEM's.
"""

from __future__ import annotations

import struct

from .errors import SiiError
from .esc import REG_EEPCFG, REG_EEPCTL, REG_EEPDAT
from .frames import Command
from .sii import SII_START_WORD, Pdo, PdoEntry

EC_ECMD_READ, EC_ESTAT_R64, EC_ESTAT_BUSY = 0x0100, 0x0040, 0x8000
EC_ESTAT_NACK, EC_ESTAT_EMASK = 0x2000, 0x7800
_U16, _U32 = struct.Struct("<H"), struct.Struct("<I")


class EepromAccess:
    """Mixed into the master: needs ``_fp(cmd, adr, ado, data) -> (wkc, bytes)``."""

    _esi_slave = None
    _esi_map: set[int]
    _esi_buf: bytearray

    def _eeprom_to_master(self, s) -> None:
        if s.eep_pdi:
            self._fp(Command.FPWR, s.config_address, REG_EEPCFG, b"\x02")
            self._fp(Command.FPWR, s.config_address, REG_EEPCFG, b"\x00")
            s.eep_pdi = False

    def _eeprom_to_pdi(self, s) -> None:
        if not s.eep_pdi:
            self._fp(Command.FPWR, s.config_address, REG_EEPCFG, b"\x01")
            s.eep_pdi = True

    def _eeprom_wait(self, s, polls: int = 100) -> int:
        for _ in range(polls):
            wkc, raw = self._fp(Command.FPRD, s.config_address, REG_EEPCTL, 2)
            if wkc == 1:
                st = _U16.unpack(raw)[0]
                if not st & EC_ESTAT_BUSY:
                    return st
        raise SiiError(f"slave {s.position}: the EEPROM interface (0x0502) stayed busy or silent "
                       f"for {polls} polls")

    def _readeeprom1(self, s, word: int) -> None:
        """Start reading SII ``word`` (SOEM's ecx_readeeprom1)."""
        self._eeprom_to_master(s)
        if self._eeprom_wait(s) & EC_ESTAT_EMASK:
            self._fp(Command.FPWR, s.config_address, REG_EEPCTL, _U16.pack(0))
        self._fp(Command.FPWR, s.config_address, REG_EEPCTL, struct.pack("<HHH", EC_ECMD_READ, word, 0))

    def _readeeprom2(self, s) -> int:
        """Finish the read ``_readeeprom1`` started: 32 bits (SOEM's ecx_readeeprom2)."""
        self._eeprom_wait(s)
        wkc, raw = self._fp(Command.FPRD, s.config_address, REG_EEPDAT, 4)
        return _U32.unpack(raw)[0] if wkc == 1 else 0

    def _readeeprom_fp(self, s, word: int) -> bytes:
        """One whole read of 8 (R64) or 4 bytes from ``word`` (SOEM's ecx_readeepromFP)."""
        self._eeprom_to_master(s)
        adr = s.config_address
        if self._eeprom_wait(s) & EC_ESTAT_EMASK:
            self._fp(Command.FPWR, adr, REG_EEPCTL, _U16.pack(0))
        for _ in range(3):  # SOEM retries a NACK up to 3 times
            self._fp(Command.FPWR, adr, REG_EEPCTL, struct.pack("<HHH", EC_ECMD_READ, word, 0))
            st = self._eeprom_wait(s)
            if st & EC_ESTAT_NACK:
                continue
            n = 8 if st & EC_ESTAT_R64 else 4
            wkc, raw = self._fp(Command.FPRD, adr, REG_EEPDAT, n)
            if wkc != 1:
                raise SiiError(f"slave {s.position}: reading EEPROM data 0x0508 got WKC {wkc}")
            return raw
        self._fp(Command.FPWR, adr, REG_EEPCTL, _U16.pack(0))
        raise SiiError(f"slave {s.position}: SII word 0x{word:04X} could not be read (the EEPROM "
                       "answered NACK 3 times): the word is beyond this slave's EEPROM; SII "
                       "categories end at the 0xFFFF marker")

    def sii_read(self, s, word: int, nwords: int) -> bytes:
        """``nwords`` words of slave ``s``'s SII from ``word`` on, through the byte cache."""
        return bytes(self.sii_byte(s, 2 * word + i) for i in range(2 * nwords))

    def sii_byte(self, s, address: int) -> int:
        """SOEM's ecx_siigetbyte: a miss reads 8 bytes from the missed byte's word on."""
        if self._esi_slave is not s:
            self._esi_slave, self._esi_map, self._esi_buf = s, set(), bytearray(8192)
        if address not in self._esi_map:
            word = address >> 1
            data = self._readeeprom_fp(s, word)
            self._esi_buf[2 * word:2 * word + len(data)] = data
            self._esi_map.update(range(2 * word, 2 * word + len(data)))
        return self._esi_buf[address]

    def _sii_u16(self, s, address: int) -> int:
        return self.sii_byte(s, address) | self.sii_byte(s, address + 1) << 8

    def sii_find(self, s, cat: int) -> int:
        """Byte address of category ``cat``'s length word, 0 if absent (SOEM's ecx_siifind)."""
        eectl = s.eep_pdi
        a = SII_START_WORD * 2
        p = self._sii_u16(s, a)
        a += 2
        while p not in (cat, 0xFFFF):
            a += 2 + 2 * self._sii_u16(s, a)
            p = self._sii_u16(s, a)
            a += 2
        if eectl:
            self._eeprom_to_pdi(s)
        return a if p == cat else 0

    def sii_string(self, s, n: int) -> str:
        """String ``n`` (1-based) of the strings category (SOEM's ecx_siistring)."""
        a = self.sii_find(s, 10)
        if not a or n <= 0:
            return ""
        a += 2
        count = self.sii_byte(s, a)
        a += 1
        if n > count:
            return ""
        for _ in range(n - 1):
            a += 1 + self.sii_byte(s, a)
        length = self.sii_byte(s, a)
        return bytes(self.sii_byte(s, a + 1 + i) for i in range(length)).decode("ascii", "replace")

    def sii_pdos(self, s, rx: bool, detail: bool = False) -> list[Pdo]:
        """The TxPDO (``rx`` False) or RxPDO category as SOEM's ecx_siiPDO walks it: PDO index,
        entry count and SM of each PDO and the bit length of each entry, touching the same
        bytes in the same order. ``detail`` also reads each entry's index, subindex, data type
        and name (SOEM's slaveinfo does that when it prints the map)."""
        eectl = s.eep_pdi
        start = self.sii_find(s, 51 if rx else 50)
        pdos: list[Pdo] = []
        if start:
            words = self._sii_u16(s, start)
            a, c = start + 2, 1
            while c < words:
                index = self._sii_u16(s, a)
                n = self.sii_byte(s, a + 2)
                sm = self.sii_byte(s, a + 3)
                name = self.sii_string(s, self.sii_byte(s, a + 5)) if detail else ""
                a, c = a + 8, c + 3
                entries = []
                for _ in range(n):
                    if sm >= 8:  # deactivated PDO: SOEM skips its entries unread
                        a, c = a + 8, c + 4
                        continue
                    bitlen = self.sii_byte(s, a + 5)
                    if detail:
                        entries.append(PdoEntry(self._sii_u16(s, a), self.sii_byte(s, a + 2), bitlen,
                                                self.sii_string(s, self.sii_byte(s, a + 3)),
                                                self.sii_byte(s, a + 4)))
                    else:
                        entries.append(PdoEntry(0, 0, bitlen))
                    a, c = a + 8, c + 4
                c += 1
                pdos.append(Pdo(index, sm, tuple(entries), name))
        if eectl:
            self._eeprom_to_pdi(s)
        return pdos

    def sii_sms(self, s) -> list[tuple[int, int, int, int, int]]:
        """The SM category: (start, length, control, activate, type) per SM (ecx_siiSM/next)."""
        a = self.sii_find(s, 41)
        if not a:
            return []
        n = self._sii_u16(s, a) // 4
        out = []
        for i in range(n):
            e = bytes(self.sii_byte(s, a + 2 + 8 * i + k) for k in range(8))  # in SOEM's order
            start, length, ctl, _status, act, sm_type = struct.unpack("<HHBBBB", e)
            out.append((start, length, ctl, act, sm_type))
        return out

    def sii_fmmus(self, s) -> list[int]:
        """FMMU usage bytes (ecx_siiFMMU: FMMU0/1 always, FMMU2/3 when the category has them)."""
        a = self.sii_find(s, 40)
        if not a:
            return []
        n = self._sii_u16(s, a) * 2
        return [self.sii_byte(s, a + 2 + i) for i in range(4 if n > 2 else 2)]
