"""EtherCAT frames and datagrams, byte-exact (SOEM's ethercattype.h / Wireshark's ecat dissector).

An EtherCAT frame is an Ethernet II frame with EtherType 0x88A4, a 2-byte EtherCAT header
(bits 0-10 length of all datagrams, bits 12-15 type, 1 = datagrams) and one or more datagrams:

    cmd u8 | idx u8 | address u32 (ADP u16 + ADO u16, or a logical address) |
    len u16 (bits 0-10 length, 14 circulating, 15 more datagrams follow) | irq u16 |
    data (len bytes) | working counter u16

Every field is little-endian. ``encode_frame`` sets the more-datagrams bit itself (the master
never chooses it by hand) and pads to the 60-byte minimum Ethernet frame unless told not to
(SOEM's own frames leave the host unpadded; a slave's reply is always at least 60 bytes).
``decode_frame`` refuses malformed frames with a ``FrameError`` that names the offset and the
rule; it never guesses.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from enum import IntEnum

ETHERTYPE_ECAT = 0x88A4
BROADCAST_MAC = b"\xff\xff\xff\xff\xff\xff"
MASTER_MAC = b"\x01\x01\x01\x01\x01\x01"  # SOEM's primary source address
ETH_HEADER_LEN = 14
ECAT_HEADER_LEN = 2
DATAGRAM_OVERHEAD = 12  # 10-byte header + 2-byte working counter
MIN_FRAME_LEN = 60  # without FCS
MAX_FRAME_LEN = 1514  # without FCS
MAX_DATAGRAM_DATA = 1486  # largest data field of a single datagram in one frame
ECAT_TYPE_DATAGRAMS = 1
SLAVE_SOURCE_BIT = 0x02  # a slave that processed the frame sets bit 1 of the first source byte

_LEN_MASK = 0x07FF
_CIRCULATING = 0x4000
_MORE = 0x8000
_DGRAM_HEAD = struct.Struct("<BBIHH")  # cmd, idx, address, len/flags, irq
_ADDR = struct.Struct("<HH")


class Command(IntEnum):
    """Datagram commands (SOEM ``ec_cmdtype``), numbered as on the wire."""

    NOP = 0
    APRD = 1
    APWR = 2
    APRW = 3
    FPRD = 4
    FPWR = 5
    FPRW = 6
    BRD = 7
    BWR = 8
    BRW = 9
    LRD = 10
    LWR = 11
    LRW = 12
    ARMW = 13
    FRMW = 14


_COMMANDS = tuple(Command)
LOGICAL_COMMANDS = frozenset({Command.LRD, Command.LWR, Command.LRW})


class FrameError(ValueError):
    """A frame that breaks an EtherCAT framing rule; the message names the offset and the rule."""


@dataclass(slots=True)
class Datagram:
    """One EtherCAT datagram. ``adp``/``ado`` for positional/configured/broadcast commands,
    ``logical`` for LRD/LWR/LRW (they share the same 4 address bytes on the wire)."""

    cmd: Command
    idx: int = 0
    adp: int = 0
    ado: int = 0
    data: bytearray = field(default_factory=bytearray)
    wkc: int = 0
    irq: int = 0
    circulating: bool = False

    @property
    def logical(self) -> int:
        return self.adp | (self.ado << 16)

    @logical.setter
    def logical(self, value: int) -> None:
        self.adp = value & 0xFFFF
        self.ado = (value >> 16) & 0xFFFF

    @classmethod
    def logical_cmd(cls, cmd: Command, address: int, data: bytes | int, idx: int = 0) -> Datagram:
        d = cls(cmd, idx, 0, 0, _as_data(data))
        d.logical = address
        return d

    @property
    def size(self) -> int:
        return DATAGRAM_OVERHEAD + len(self.data)


def datagram(cmd: Command | int, adp: int, ado: int, data: bytes | int, idx: int = 0) -> Datagram:
    """A datagram with ``data`` bytes, or ``data`` zero bytes when it is an int (a read)."""
    return Datagram(Command(cmd), idx, adp & 0xFFFF, ado & 0xFFFF, _as_data(data))


def _as_data(data: bytes | int) -> bytearray:
    if isinstance(data, int):
        if not 0 <= data <= MAX_DATAGRAM_DATA:
            raise FrameError(f"datagram length {data} is outside 0..{MAX_DATAGRAM_DATA}: "
                             "split the transfer into several datagrams")
        return bytearray(data)
    return bytearray(data)


@dataclass(slots=True)
class Frame:
    """An Ethernet II frame carrying EtherCAT datagrams."""

    datagrams: list[Datagram]
    dst: bytes = BROADCAST_MAC
    src: bytes = MASTER_MAC
    ecat_type: int = ECAT_TYPE_DATAGRAMS


def encode_frame(frame: Frame, *, pad: bool = True) -> bytes:
    """Bytes on the wire (no FCS). The M bit is set on every datagram but the last."""
    dgs = frame.datagrams
    if not dgs:
        raise FrameError("a frame needs at least one datagram: add e.g. a NOP")
    if len(frame.dst) != 6 or len(frame.src) != 6:
        raise FrameError(f"MAC addresses are 6 bytes; got dst {frame.dst!r}, src {frame.src!r}")
    total = sum(DATAGRAM_OVERHEAD + len(d.data) for d in dgs)
    if total > _LEN_MASK or ETH_HEADER_LEN + ECAT_HEADER_LEN + total > MAX_FRAME_LEN:
        raise FrameError(f"datagrams take {total} bytes; one frame carries at most "
                         f"{MAX_FRAME_LEN - ETH_HEADER_LEN - ECAT_HEADER_LEN}: split them")
    out = bytearray(frame.dst)
    out += frame.src
    out += ETHERTYPE_ECAT.to_bytes(2, "big")
    out += (total | (frame.ecat_type << 12)).to_bytes(2, "little")
    last = len(dgs) - 1
    for i, d in enumerate(dgs):
        n = len(d.data)
        flags = n | (_MORE if i < last else 0) | (_CIRCULATING if d.circulating else 0)
        out += _DGRAM_HEAD.pack(d.cmd, d.idx, d.adp | (d.ado << 16), flags, d.irq)
        out += d.data
        out += d.wkc.to_bytes(2, "little")
    if pad and len(out) < MIN_FRAME_LEN:
        out += bytes(MIN_FRAME_LEN - len(out))
    return bytes(out)


def decode_frame(raw: bytes | bytearray | memoryview) -> Frame:
    """Parse a frame; raise ``FrameError`` for anything that is not a well-formed EtherCAT frame."""
    raw = bytes(raw)
    if len(raw) < ETH_HEADER_LEN + ECAT_HEADER_LEN:
        raise FrameError(f"frame of {len(raw)} bytes is shorter than the Ethernet + EtherCAT "
                         f"headers ({ETH_HEADER_LEN + ECAT_HEADER_LEN} bytes)")
    ethertype = int.from_bytes(raw[12:14], "big")
    if ethertype != ETHERTYPE_ECAT:
        raise FrameError(f"EtherType 0x{ethertype:04X} is not EtherCAT (0x{ETHERTYPE_ECAT:04X})")
    header = int.from_bytes(raw[14:16], "little")
    length, ecat_type = header & _LEN_MASK, header >> 12
    if ecat_type != ECAT_TYPE_DATAGRAMS:
        raise FrameError(f"EtherCAT header type {ecat_type} at offset 14: slaves process only "
                         f"type {ECAT_TYPE_DATAGRAMS} (datagrams)")
    end = ETH_HEADER_LEN + ECAT_HEADER_LEN + length
    if end > len(raw):
        raise FrameError(f"EtherCAT header says {length} bytes of datagrams but the frame holds "
                         f"only {len(raw) - ETH_HEADER_LEN - ECAT_HEADER_LEN} after offset 16")
    dgs: list[Datagram] = []
    pos = ETH_HEADER_LEN + ECAT_HEADER_LEN
    more = True
    while more:
        if pos + 10 > end:
            raise FrameError(f"truncated datagram at offset {pos}: {end - pos} bytes left, "
                             "a datagram header needs 10")
        cmd, idx, address, flags, irq = _DGRAM_HEAD.unpack_from(raw, pos)
        if cmd >= len(_COMMANDS):
            raise FrameError(f"unknown command {cmd} in datagram at offset {pos}: valid commands "
                             "are 0 (NOP) to 14 (FRMW)")
        command = _COMMANDS[cmd]
        n = flags & _LEN_MASK
        data_end = pos + 10 + n
        if data_end + 2 > end:
            raise FrameError(f"datagram at offset {pos} says len {n}, which runs to offset "
                             f"{data_end + 2} beyond the datagrams' end at {end}")
        dgs.append(Datagram(command, idx, address & 0xFFFF, address >> 16,
                            bytearray(raw[pos + 10:data_end]),
                            int.from_bytes(raw[data_end:data_end + 2], "little"), irq,
                            bool(flags & _CIRCULATING)))
        pos = data_end + 2
        more = bool(flags & _MORE)
    if pos != end:
        raise FrameError(f"the last datagram (M bit clear) ends at offset {pos} but the "
                         f"EtherCAT header length says the datagrams end at {end}")
    return Frame(dgs, raw[0:6], raw[6:12], ecat_type)


def frame_bytes(datagrams: list[Datagram], *, pad: bool = False) -> bytes:
    """A master frame as SOEM sends it: broadcast destination, source 01:01:01:01:01:01, unpadded."""
    return encode_frame(Frame(datagrams), pad=pad)
