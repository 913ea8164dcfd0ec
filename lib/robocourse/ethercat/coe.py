"""CANopen over EtherCAT (CoE): the mailbox frame and expedited SDO upload/download.

Mailbox header (6 bytes): length u16, address u16, channel/priority u8, type (3 = CoE) |
counter << 4. CoE header u16: number | service << 12 (2 SDO request, 3 SDO response).
SDO: command u8, index u16, subindex u8, 4 data bytes. Upload request 0x40; expedited upload
responses 0x4F/0x4B/0x47/0x43 (1/2/3/4 bytes); expedited download 0x23 | ((4 - n) << 2);
download response 0x60; abort 0x80 with a u32 code (sent with CoE service 2, as SOES does). The counterparts are SOEM's
``ecx_SDOread``/``ecx_SDOwrite`` (master) and SOES's CoE handler (slave).

Where we differ: expedited transfers only (objects of at most 4 bytes); a segmented or
complete-access request is aborted with 0x05040001 (command specifier not valid).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

MBX_TYPE_COE = 3
COE_SDO_REQUEST, COE_SDO_RESPONSE = 2, 3
SDO_UPLOAD_REQ, SDO_DOWNLOAD_RESP, SDO_ABORT = 0x40, 0x60, 0x80
ABORT_NOT_VALID = 0x05040001
ABORT_READ_ONLY = 0x06010002
ABORT_NO_OBJECT = 0x06020000
ABORT_NO_SUBINDEX = 0x06090011
ABORT_VALUE_RANGE = 0x06090030
ABORT_TEXT = {ABORT_NOT_VALID: "Client/server command specifier not valid or unknown",
              ABORT_READ_ONLY: "Attempt to write a read only object",
              ABORT_NO_OBJECT: "The object does not exist in the object directory",
              ABORT_NO_SUBINDEX: "Subindex does not exist",
              ABORT_VALUE_RANGE: "Value range of parameter exceeded"}
_MBX = struct.Struct("<HHBB")
_SDO = struct.Struct("<HBHB4s")  # CoE header, command, index, subindex, data


@dataclass
class OdEntry:
    """One object-dictionary entry: its size in bytes, signedness and how to get/set it."""

    size: int
    get: Callable[[], int]
    set: Callable[[int], None] | None = None
    signed: bool = False


def sdo_request(index: int, subindex: int, counter: int, data: bytes | None = None) -> bytes:
    """A master's expedited SDO upload request, or download of ``data`` (1-4 bytes)."""
    if data is None:
        cmd, payload = SDO_UPLOAD_REQ, bytes(4)
    else:
        if not 1 <= len(data) <= 4:
            raise ValueError(f"expedited SDO download carries 1-4 bytes, got {len(data)}; "
                             "larger objects need a segmented transfer, which we do not implement")
        cmd, payload = 0x23 | ((4 - len(data)) << 2), data.ljust(4, b"\x00")
    return _MBX.pack(10, 0, 0, MBX_TYPE_COE | (counter & 7) << 4) + \
        _SDO.pack(COE_SDO_REQUEST << 12, cmd, index, subindex, payload)


def parse_sdo_response(mbx: bytes, index: int, subindex: int) -> tuple[bytes | None, int]:
    """(data, 0) of an upload response, (b'', 0) of a download response, (None, abort code)."""
    _len, _addr, _prio, mtype = _MBX.unpack_from(mbx, 0)
    coe, cmd, idx, sub, data = _SDO.unpack_from(mbx, 6)
    if mtype & 0x0F != MBX_TYPE_COE:
        return None, ABORT_NOT_VALID
    if cmd == SDO_ABORT:  # aborts come with the SDO request service (2)
        return None, struct.unpack("<I", data)[0]
    if coe >> 12 != COE_SDO_RESPONSE:
        return None, ABORT_NOT_VALID
    if (idx, sub) != (index, subindex):
        return None, ABORT_NOT_VALID
    if cmd == SDO_DOWNLOAD_RESP:
        return b"", 0
    if cmd & 0xE3 == 0x43:  # expedited upload with size indicated
        return data[:4 - ((cmd >> 2) & 3)], 0
    return None, ABORT_NOT_VALID


class CoeServer:
    """The slave side: answer one mailbox request from an object dictionary."""

    od: dict[tuple[int, int], OdEntry]
    _mbx_counter = 0

    def coe_reply(self, request: bytes) -> bytes | None:
        if len(request) < 16:
            return None
        _len, _addr, _prio, mtype = _MBX.unpack_from(request, 0)
        if mtype & 0x0F != MBX_TYPE_COE:
            return None
        coe, cmd, index, sub, data = _SDO.unpack_from(request, 6)
        if coe >> 12 != COE_SDO_REQUEST:
            return None
        e = self.od.get((index, sub))
        if cmd == SDO_UPLOAD_REQ:
            if e is None:
                return self._answer(SDO_ABORT, index, sub, self._missing(index))
            raw = (e.get() & ((1 << (8 * e.size)) - 1)).to_bytes(e.size, "little")
            return self._answer(0x43 | ((4 - e.size) << 2), index, sub, raw)
        if cmd & 0xE3 == 0x23:  # expedited download, size indicated
            if e is None:
                return self._answer(SDO_ABORT, index, sub, self._missing(index))
            if e.set is None:
                return self._answer(SDO_ABORT, index, sub, ABORT_READ_ONLY.to_bytes(4, "little"))
            n = 4 - ((cmd >> 2) & 3)
            try:
                e.set(int.from_bytes(data[:n], "little", signed=e.signed))
            except ValueError:  # the object refuses the value (its setter names the range)
                return self._answer(SDO_ABORT, index, sub, ABORT_VALUE_RANGE.to_bytes(4, "little"))
            return self._answer(SDO_DOWNLOAD_RESP, index, sub, bytes(4))
        return self._answer(SDO_ABORT, index, sub, ABORT_NOT_VALID.to_bytes(4, "little"))

    def _missing(self, index: int) -> bytes:
        known = any(i == index for i, _ in self.od)
        return (ABORT_NO_SUBINDEX if known else ABORT_NO_OBJECT).to_bytes(4, "little")

    def _answer(self, cmd: int, index: int, sub: int, data: bytes) -> bytes:
        self._mbx_counter = self._mbx_counter % 7 + 1
        service = COE_SDO_REQUEST if cmd == SDO_ABORT else COE_SDO_RESPONSE  # as SOES sends aborts
        return _MBX.pack(10, 0, 0, MBX_TYPE_COE | self._mbx_counter << 4) + \
            _SDO.pack(service << 12, cmd, index, sub, data.ljust(4, b"\x00"))
