"""Classic pcap files (linktype 1, Ethernet, no FCS): what Wireshark and tshark open.

The counterpart of Wireshark's capture on the master's interface: every frame that crosses the
wire, with its time stamp. Microsecond time stamps (magic 0xA1B2C3D4), snap length 65535.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import BinaryIO

PCAP_MAGIC = 0xA1B2C3D4
LINKTYPE_ETHERNET = 1
_GLOBAL = struct.Struct("<IHHiIII")
_RECORD = struct.Struct("<IIII")


class PcapWriter:
    """Write frames to a classic pcap file. Use as a context manager or call ``close``."""

    def __init__(self, path: str | Path | BinaryIO, snaplen: int = 65535) -> None:
        self._own = not hasattr(path, "write")
        self._f: BinaryIO = open(path, "wb") if self._own else path  # noqa: SIM115
        self._f.write(_GLOBAL.pack(PCAP_MAGIC, 2, 4, 0, 0, snaplen, LINKTYPE_ETHERNET))
        self.count = 0

    def write(self, frame: bytes, t_ns: int | None = None) -> None:
        """Append one frame, stamped ``t_ns`` (Unix ns; now when omitted)."""
        if t_ns is None:
            t_ns = time.time_ns()
        sec, rest = divmod(t_ns, 1_000_000_000)
        self._f.write(_RECORD.pack(sec, rest // 1000, len(frame), len(frame)))
        self._f.write(frame)
        self.count += 1

    def close(self) -> None:
        if self._own:
            self._f.close()
        else:
            self._f.flush()

    def __enter__(self) -> PcapWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_pcap(path: str | Path) -> list[tuple[int, bytes]]:
    """(time stamp in ns, frame bytes) for every record of a classic little-endian pcap file."""
    data = Path(path).read_bytes()
    if len(data) < _GLOBAL.size:
        raise ValueError(f"{path}: {len(data)} bytes is shorter than a pcap header (24)")
    magic, _, _, _, _, _, linktype = _GLOBAL.unpack_from(data)
    if magic != PCAP_MAGIC:
        raise ValueError(f"{path}: magic 0x{magic:08X} is not a little-endian microsecond pcap "
                         f"(0x{PCAP_MAGIC:08X}); convert pcapng with: editcap -F pcap in out")
    if linktype != LINKTYPE_ETHERNET:
        raise ValueError(f"{path}: linktype {linktype}, expected {LINKTYPE_ETHERNET} (Ethernet)")
    out, pos = [], _GLOBAL.size
    while pos + _RECORD.size <= len(data):
        sec, usec, incl, _orig = _RECORD.unpack_from(data, pos)
        pos += _RECORD.size
        out.append((sec * 1_000_000_000 + usec * 1000, data[pos:pos + incl]))
        pos += incl
    return out
