"""A master's mailbox and CoE SDO client, as SOEM 1.4's ecx_mbxsend/ecx_mbxreceive/ecx_SDOread/
ecx_SDOwrite/ecx_readPDOmap do it.

Send: wait until the slave's write mailbox (SM0) is empty (FPRD 0x0805), write the whole
mailbox area (FPWR mbx_wo, mbx_l bytes). Receive: poll SM1's status (FPRD 0x080D, 2 bytes)
until bit 3 (mailbox full), read the whole area (FPRD mbx_ro, mbx_rl bytes). An SDO read first
empties the slave's read mailbox of anything stale (a receive with timeout 0).
``read_pdo_map`` uploads 0x1C00 (SM types), 0x1C12/0x1C13 (PDO assignment) and each
0x16xx/0x1Axx entry, summing the bit lengths per SyncManager, like ecx_readPDOmap.
"""

from __future__ import annotations

import struct
import time

from .coe import ABORT_TEXT, parse_sdo_response, sdo_request
from .errors import MailboxError, SdoError
from .frames import Command

REG_SM0STAT, REG_SM1STAT = 0x0805, 0x080D
EC_TIMEOUTRXM_US = 700_000


def next_mbx_count(cnt: int) -> int:
    """SOEM's ec_nextmbxcnt: 1..7, then 1 again."""
    cnt = (cnt + 1) & 7
    return cnt or 1


class MailboxClient:
    """Mixed into the master: needs ``_fp(cmd, adr, ado, data) -> (wkc, bytes)``."""

    def _mbx_empty(self, s, timeout_us: int) -> bool:
        deadline = time.monotonic() + timeout_us * 1e-6
        while True:
            wkc, raw = self._fp(Command.FPRD, s.config_address, REG_SM0STAT, 1)
            if wkc > 0 and not raw[0] & 0x08:
                return True
            if time.monotonic() >= deadline:
                return False

    def mbx_send(self, s, mbx: bytes, timeout_us: int = 20_000) -> int:
        if not s.mbx_l:
            raise MailboxError(s._no_mailbox("mailbox send"))
        if not self._mbx_empty(s, timeout_us):
            return 0
        return self._fp(Command.FPWR, s.config_address, s.mbx_wo, mbx.ljust(s.mbx_l, b"\x00"))[0]

    def mbx_receive(self, s, timeout_us: int) -> bytes | None:
        deadline = time.monotonic() + timeout_us * 1e-6
        while True:
            wkc, raw = self._fp(Command.FPRD, s.config_address, REG_SM1STAT, 2)
            if wkc > 0 and raw[0] & 0x08:
                break
            if time.monotonic() >= deadline:
                return None
        for _ in range(3):
            wkc, data = self._fp(Command.FPRD, s.config_address, s.mbx_ro, s.mbx_rl)
            if wkc > 0:
                return data
        return None

    def _sdo(self, s, index: int, subindex: int, data: bytes | None) -> bytes:
        if not s.mbx_l or not s.sii.mbx_protocols & 0x0004:
            raise MailboxError(s._no_mailbox(f"SDO 0x{index:04X}:{subindex:02X}"))
        self.mbx_receive(s, 0)  # empty the slave's out mailbox of anything stale
        s.mbx_cnt = next_mbx_count(s.mbx_cnt)
        if self.mbx_send(s, sdo_request(index, subindex, s.mbx_cnt, data)) <= 0:
            raise MailboxError(f"slave {s.position} ({s.name}): its write mailbox stayed full")
        reply = self.mbx_receive(s, EC_TIMEOUTRXM_US)
        if reply is None:
            raise MailboxError(f"slave {s.position} ({s.name}): no SDO answer for "
                               f"0x{index:04X}:{subindex:02X} within {EC_TIMEOUTRXM_US} us")
        value, abort = parse_sdo_response(reply, index, subindex)
        if value is None:
            raise SdoError(s.position, index, subindex, abort, ABORT_TEXT.get(abort, "unknown"))
        return value

    def sdo_upload(self, s, index: int, subindex: int) -> bytes:
        """An expedited SDO upload (pysoem's slave.sdo_read)."""
        return self._sdo(s, index, subindex, None)

    def sdo_download(self, s, index: int, subindex: int, data: bytes) -> None:
        """An expedited SDO download (pysoem's slave.sdo_write), 1-4 bytes."""
        self._sdo(s, index, subindex, bytes(data))

    def read_pdo_map(self, s) -> tuple[int, int]:
        """SOEM's ecx_readPDOmap: (output bits, input bits); sets SM types and lengths."""
        obits = ibits = 0
        try:
            n_sm = self.sdo_upload(s, 0x1C00, 0)[0]
        except (SdoError, MailboxError):
            return 0, 0
        for i in range(2, min(n_sm, 8)):
            sm_type = self.sdo_upload(s, 0x1C00, i + 1)[0]
            if i == 2 and sm_type == 0:
                sm_type = 3
            if i == 3 and sm_type == 0:
                sm_type = 4
            s.sm_type[i] = sm_type
            if sm_type not in (3, 4):
                continue
            bits = 0
            count = int.from_bytes(self.sdo_upload(s, 0x1C10 + i, 0), "little")
            for k in range(1, count + 1):
                pdo = int.from_bytes(self.sdo_upload(s, 0x1C10 + i, k), "little")
                if not pdo:
                    continue
                entries = self.sdo_upload(s, pdo, 0)[0]
                for j in range(1, entries + 1):
                    bits += struct.unpack("<I", self.sdo_upload(s, pdo, j).ljust(4, b"\x00"))[0] & 0xFF
            if bits:
                start, _len, flags = s.sm[i]
                s.sm[i] = (start, (bits + 7) // 8, flags)
                if sm_type == 3:
                    obits += bits
                else:
                    ibits += bits
        return obits, ibits
