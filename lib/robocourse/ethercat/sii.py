"""SII EEPROM images (ETG.2010 layout) built from a device description, and their parser.

Mirrors what SOEM reads in ``ecx_config_init``/``ecx_siiPDO``: identity words 0x0008-0x000F,
mailbox words 0x0018-0x001C, then categories from word 0x0040 (10 strings, 30 general, 40 FMMU,
41 SyncManager, 50 TxPDO, 51 RxPDO, 0xFFFF end). SOEM takes a slave's name from string 1.
The checksum in word 7 is CRC-8 (poly 0x07, init 0xFF) over bytes 0..13.

A PDO layout that cannot work (a PDO on a SyncManager that is not a process-data SM of its
direction, a map larger than the SM it is assigned to, SM areas overlapping) is refused when
the description is built, naming the numbers. A PDO assigned to no SyncManager (SM byte 0xFF,
:data:`UNASSIGNED`: the alternative PDOs a drive such as the Kollmorgen AKD lists, assigned
later over CoE) is kept, takes no process data and is skipped by masters, as SOEM's
``ecx_siiPDO`` does ("PDO deactivated because SM is 0xff or > EC_MAXSM").

:func:`description_from_sii` reads a whole image (a ``.bin`` dumped from a device) back into a
:class:`DeviceDescription`; :mod:`robocourse.ethercat.device_files` builds slaves from it.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

CAT_STRINGS, CAT_GENERAL, CAT_FMMU, CAT_SM = 10, 30, 40, 41
CAT_TXPDO, CAT_RXPDO, CAT_END = 50, 51, 0xFFFF
SII_START_WORD = 0x0040
#: the SM byte of a PDO that no SyncManager carries (SII TxPDO/RxPDO categories, ETG.2010)
UNASSIGNED = 0xFF
SM_TYPE_MBX_OUT, SM_TYPE_MBX_IN, SM_TYPE_OUTPUTS, SM_TYPE_INPUTS = 1, 2, 3, 4
FMMU_UNUSED, FMMU_OUTPUTS, FMMU_INPUTS, FMMU_SYNCM_STATUS = 0, 1, 2, 3


class DescriptionError(ValueError):
    """A device description that no master could map."""


def crc8(data: bytes) -> int:
    """SII checksum: CRC-8, polynomial 0x07, init 0xFF, no reflection, no final XOR."""
    crc = 0xFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


@dataclass(frozen=True)
class PdoEntry:
    """One mapped object: CiA index:subindex and its bit length (0x6040:00, 16 bits...)."""

    index: int
    subindex: int
    bitlen: int
    name: str = ""
    datatype: int = 0


@dataclass(frozen=True)
class Pdo:
    """A PDO (0x1600.. receive / 0x1A00.. transmit) assigned to SyncManager ``sm``."""

    index: int
    sm: int
    entries: tuple[PdoEntry, ...]
    name: str = ""

    @property
    def bits(self) -> int:
        return sum(e.bitlen for e in self.entries)


@dataclass(frozen=True)
class SyncManagerConfig:
    """A SyncManager as the SII SM category lists it. ``length`` None = sized by its PDOs."""

    start: int
    control: int
    sm_type: int
    length: int | None = None
    enable: int = 1


@dataclass(frozen=True)
class DeviceDescription:
    """What an ESI file says about a slave, reduced to what the SII carries."""

    vendor_id: int
    product_code: int
    revision: int
    name: str
    long_name: str = ""
    group: str = ""
    serial: int = 0
    alias: int = 0
    sms: tuple[SyncManagerConfig, ...] = ()
    fmmus: tuple[int, ...] = (FMMU_OUTPUTS, FMMU_INPUTS)
    rxpdos: tuple[Pdo, ...] = ()
    txpdos: tuple[Pdo, ...] = ()
    ebus_current_ma: int = 0
    pdi_control: int = 0x0000
    eeprom_bytes: int = 2048
    mbx_protocols: int = 0  # SII word 0x001C: 0x0004 = CoE (needs mailbox SMs of type 1 and 2)
    coe_details: int = 0  # general category byte 5: 0x01 SDO, 0x04 PDO assign, 0x20 complete access
    #: SII words 0..6 (PDI control, PDI configuration, sync impulse, extended PDI configuration,
    #: alias, reserved) as a device file gives them; empty = from pdi_control and alias
    config_data: bytes = b""

    def __post_init__(self) -> None:
        for what, pdos, want in (("RxPDO", self.rxpdos, SM_TYPE_OUTPUTS),
                                 ("TxPDO", self.txpdos, SM_TYPE_INPUTS)):
            for p in pdos:
                if p.sm == UNASSIGNED:
                    continue
                if not 0 <= p.sm < len(self.sms) or self.sms[p.sm].sm_type != want:
                    raise DescriptionError(
                        f"{self.name}: {what} 0x{p.index:04X} is assigned to SM{p.sm}, which is "
                        f"not an {'output' if want == SM_TYPE_OUTPUTS else 'input'} SyncManager "
                        f"(type {want}); assign it to one of "
                        f"{[i for i, s in enumerate(self.sms) if s.sm_type == want]}, or to "
                        f"none (sm=0xFF) for a PDO assigned later over CoE")
        for i, sm in enumerate(self.sms):
            need = self.sm_pdo_bytes(i)
            if sm.length is not None and need > sm.length:
                raise DescriptionError(
                    f"{self.name}: the PDO map of SM{i} takes {need} bytes but SM{i} is "
                    f"{sm.length} bytes long; remove entries or enlarge the SyncManager")
        spans = sorted((sm.start, sm.start + self.sm_length(i), i) for i, sm in enumerate(self.sms)
                       if self.sm_length(i))
        for (s0, e0, i0), (s1, _e1, i1) in zip(spans, spans[1:]):
            if s1 < e0:
                raise DescriptionError(f"{self.name}: SM{i0} 0x{s0:04X}..0x{e0 - 1:04X} overlaps "
                                       f"SM{i1} at 0x{s1:04X}; move one of them")

    def mailbox(self, sm_type: int) -> tuple[int, int]:
        """(start, length) of the enabled mailbox SM of ``sm_type`` (1 out, 2 in), or (0, 0)."""
        for i, sm in enumerate(self.sms):
            if sm.sm_type == sm_type and sm.enable:
                return sm.start, self.sm_length(i)
        return 0, 0

    def sm_pdo_bytes(self, sm: int) -> int:
        bits = sum(p.bits for p in self.rxpdos + self.txpdos if p.sm == sm)
        return (bits + 7) // 8

    def sm_length(self, sm: int) -> int:
        s = self.sms[sm]
        return s.length if s.length is not None else self.sm_pdo_bytes(sm)

    @property
    def output_bits(self) -> int:
        """Bits of the RxPDOs a SyncManager carries (unassigned ones take none)."""
        return sum(p.bits for p in self.rxpdos if p.sm != UNASSIGNED)

    @property
    def input_bits(self) -> int:
        return sum(p.bits for p in self.txpdos if p.sm != UNASSIGNED)


def _category(cat: int, payload: bytes) -> bytes:
    if len(payload) % 2:
        payload += b"\x00"
    return struct.pack("<HH", cat, len(payload) // 2) + payload


def _pdo_category(pdos: tuple[Pdo, ...], name_idx: dict[str, int]) -> bytes:
    out = bytearray()
    for p in pdos:
        out += struct.pack("<HBBBBH", p.index, len(p.entries), p.sm, 0, name_idx.get(p.name, 0), 0)
        for e in p.entries:
            out += struct.pack("<HBBBBH", e.index, e.subindex, name_idx.get(e.name, 0),
                               e.datatype, e.bitlen, 0)
    return bytes(out)


def build_sii(desc: DeviceDescription) -> bytes:
    """The EEPROM image of ``desc``, padded with 0xFF to ``desc.eeprom_bytes``."""
    strings: list[str] = []

    def sidx(s: str) -> int:
        if not s:
            return 0
        if s not in strings:
            strings.append(s)
        return strings.index(s) + 1

    sidx(desc.name)  # string 1: SOEM's slave name
    group_i, long_i = sidx(desc.group), sidx(desc.long_name or desc.name)
    names = {s: sidx(s) for p in desc.rxpdos + desc.txpdos for s in
             (p.name, *(e.name for e in p.entries)) if s}
    head = bytearray(128)
    if desc.config_data:
        head[:14] = desc.config_data[:14].ljust(14, b"\x00")
    else:
        struct.pack_into("<HH", head, 0, desc.pdi_control, 0)
        struct.pack_into("<H", head, 8, desc.alias)
    head[14] = crc8(bytes(head[:14]))
    struct.pack_into("<IIII", head, 16, desc.vendor_id, desc.product_code, desc.revision,
                     desc.serial)
    struct.pack_into("<HH", head, 0x3E * 2, desc.eeprom_bytes * 8 // 1024 - 1, 1)
    struct.pack_into("<HHHHH", head, 0x18 * 2, *desc.mailbox(SM_TYPE_MBX_OUT),
                     *desc.mailbox(SM_TYPE_MBX_IN), desc.mbx_protocols)

    general = bytearray(32)
    general[0], general[2], general[3] = group_i, sidx(desc.name), long_i
    general[5] = desc.coe_details
    struct.pack_into("<h", general, 12, desc.ebus_current_ma)
    general[14] = group_i
    string_blob = bytes([len(strings)]) + b"".join(
        bytes([len(s.encode("ascii"))]) + s.encode("ascii") for s in strings)
    sms = b"".join(struct.pack("<HHBBBB", sm.start, desc.sm_length(i), sm.control, 0,
                               sm.enable, sm.sm_type) for i, sm in enumerate(desc.sms))
    image = bytearray(head)
    image += _category(CAT_STRINGS, string_blob)
    image += _category(CAT_GENERAL, bytes(general))
    image += _category(CAT_FMMU, bytes(desc.fmmus))
    if sms:
        image += _category(CAT_SM, sms)
    if desc.txpdos:
        image += _category(CAT_TXPDO, _pdo_category(desc.txpdos, names))
    if desc.rxpdos:
        image += _category(CAT_RXPDO, _pdo_category(desc.rxpdos, names))
    image += struct.pack("<H", CAT_END)
    if len(image) > desc.eeprom_bytes:
        raise DescriptionError(f"{desc.name}: SII image of {len(image)} bytes does not fit the "
                               f"{desc.eeprom_bytes}-byte EEPROM; raise eeprom_bytes")
    return bytes(image + b"\xff" * (desc.eeprom_bytes - len(image)))


@dataclass
class SiiInfo:
    """What a master learns from a slave's SII (the fields SOEM's ``ec_slavet`` keeps)."""

    vendor_id: int = 0
    product_code: int = 0
    revision: int = 0
    serial: int = 0
    alias: int = 0
    mbx_rx_offset: int = 0
    mbx_rx_size: int = 0
    mbx_tx_offset: int = 0
    mbx_tx_size: int = 0
    mbx_protocols: int = 0
    strings: list[str] = field(default_factory=list)
    general: bytes = b""
    fmmus: list[int] = field(default_factory=list)
    sms: list[tuple[int, int, int, int, int]] = field(default_factory=list)  # start,len,ctl,en,type
    txpdos: list[Pdo] = field(default_factory=list)
    rxpdos: list[Pdo] = field(default_factory=list)

    @property
    def name(self) -> str:
        if self.strings:
            return self.strings[0]
        return f"? M:{self.vendor_id:08x} I:{self.product_code:08x}"

    @property
    def ebus_current_ma(self) -> int:
        return struct.unpack_from("<h", self.general, 12)[0] if len(self.general) >= 14 else 0


def parse_header(words: bytes) -> SiiInfo:
    """Identity and mailbox fields from the first 0x40 words (128 bytes) of an image."""
    if len(words) < 0x3A:
        raise ValueError(f"SII header needs 58 bytes, got {len(words)}")
    info = SiiInfo()
    info.alias = struct.unpack_from("<H", words, 8)[0]
    info.vendor_id, info.product_code, info.revision, info.serial = struct.unpack_from(
        "<IIII", words, 16)
    (info.mbx_rx_offset, info.mbx_rx_size, info.mbx_tx_offset, info.mbx_tx_size,
     info.mbx_protocols) = struct.unpack_from("<HHHHH", words, 0x18 * 2)
    return info


def _parse_pdos(data: bytes, strings: list[str]) -> list[Pdo]:
    def name(i: int) -> str:
        return strings[i - 1] if 0 < i <= len(strings) else ""

    pdos, pos = [], 0
    while pos + 8 <= len(data):
        index, n, sm, _sync, name_i, _flags = struct.unpack_from("<HBBBBH", data, pos)
        pos += 8
        entries = []
        for _ in range(n):
            e_index, e_sub, e_name, e_type, e_bits, _ = struct.unpack_from("<HBBBBH", data, pos)
            entries.append(PdoEntry(e_index, e_sub, e_bits, name(e_name), e_type))
            pos += 8
        pdos.append(Pdo(index, sm, tuple(entries), name(name_i)))
    return pdos


def parse_categories(image: bytes, info: SiiInfo) -> SiiInfo:
    """Walk the categories from word 0x40 to 0xFFFF, filling ``info``."""
    pos = SII_START_WORD * 2
    while pos + 2 <= len(image):
        cat = struct.unpack_from("<H", image, pos)[0]
        if cat == CAT_END:
            break
        if pos + 4 > len(image):
            raise ValueError(f"SII category 0x{cat:04X} at byte {pos} has no length word")
        words = struct.unpack_from("<H", image, pos + 2)[0]
        data = image[pos + 4:pos + 4 + 2 * words]
        if len(data) < 2 * words:
            raise ValueError(f"SII category {cat} at byte {pos} says {words} words but the image "
                             f"ends after {len(data) // 2}")
        if cat == CAT_STRINGS and data:
            p, out = 1, []
            for _ in range(data[0]):
                n = data[p]
                out.append(data[p + 1:p + 1 + n].decode("ascii", "replace"))
                p += 1 + n
            info.strings = out
        elif cat == CAT_GENERAL:
            info.general = bytes(data)
        elif cat == CAT_FMMU:
            info.fmmus = list(data)
        elif cat == CAT_SM:
            info.sms = [struct.unpack_from("<HHBxBB", data, o) for o in range(0, len(data) - 7, 8)]
        elif cat == CAT_TXPDO:
            info.txpdos = _parse_pdos(data, info.strings)
        elif cat == CAT_RXPDO:
            info.rxpdos = _parse_pdos(data, info.strings)
        pos += 4 + 2 * words
    return info


def parse_sii(image: bytes) -> SiiInfo:
    """Everything in an SII image."""
    return parse_categories(image, parse_header(image[:128]))


def description_from_sii(image: bytes, *, check_crc: bool = True) -> DeviceDescription:
    """A whole SII image (as dumped from a device, e.g. by ``ec_sii`` / TwinCAT's "EEPROM
    upload") as a :class:`DeviceDescription`: identity, strings (1 = the name SOEM shows, the
    general category's group and name indices), SyncManagers, FMMUs, PDOs (an SM byte of 0xFF or
    above 7 = unassigned), the PDI control word (word 0: the ESC loads it into 0x0140/0x0141),
    the configured alias, the mailbox protocols and CoE details and the EEPROM size (word 0x3E,
    KBit - 1). ``check_crc`` refuses an image whose word-7 checksum is wrong (an ESC would flag
    "checksum error" in 0x0502 and not load its configuration area)."""
    image = bytes(image)
    if len(image) < 0x80 + 2:
        raise DescriptionError(f"an SII image has at least the 64-word header and an end marker "
                               f"(130 bytes); this one has {len(image)} bytes")
    if check_crc and image[14] != crc8(image[:14]):
        raise DescriptionError(
            f"SII checksum: byte 14 is 0x{image[14]:02X} but CRC-8 over bytes 0..13 is "
            f"0x{crc8(image[:14]):02X}; the image is damaged or not an SII image (pass "
            f"check_crc=False to use it anyway, as a master would read it)")
    info = parse_sii(image)

    def string(i: int) -> str:
        return info.strings[i - 1] if 0 < i <= len(info.strings) else ""

    gen = info.general
    name = string(1) or f"0x{info.vendor_id:08X}:0x{info.product_code:08X}"
    group = string(gen[0]) if len(gen) > 0 else ""
    long_name = string(gen[3]) if len(gen) > 3 else ""
    sms = tuple(SyncManagerConfig(start=start, control=ctl, length=length, enable=enable,
                                  sm_type=sm_type if sm_type in (1, 2, 3, 4) else 0)
                for start, length, ctl, enable, sm_type in info.sms)

    def assigned(p: Pdo) -> Pdo:
        return p if p.sm < 8 and p.sm < len(sms) else Pdo(p.index, UNASSIGNED, p.entries, p.name)

    size_kbit = struct.unpack_from("<H", image, 0x3E * 2)[0] + 1
    eeprom_bytes = size_kbit * 128 if 0 < size_kbit <= 0x1000 else len(image)
    return DeviceDescription(
        info.vendor_id, info.product_code, info.revision, name, long_name, group,
        serial=info.serial, alias=info.alias, sms=sms, fmmus=tuple(info.fmmus),
        rxpdos=tuple(assigned(p) for p in info.rxpdos),
        txpdos=tuple(assigned(p) for p in info.txpdos),
        ebus_current_ma=info.ebus_current_ma,
        pdi_control=struct.unpack_from("<H", image, 0)[0],
        eeprom_bytes=max(eeprom_bytes, len(image)),
        mbx_protocols=info.mbx_protocols, coe_details=gen[5] if len(gen) > 5 else 0,
        config_data=image[:14])
