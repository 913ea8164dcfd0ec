"""Slaves from the user's own device files: an SII image or a vendor ESI XML.

Counterparts: the EEPROM image a master reads from a real device (SOEM's ``ec_readeeprom``,
``ethercat sii_read`` of the IgH master, TwinCAT's "EEPROM upload"; a ``.bin``) and the
EtherCAT Slave Information file a vendor ships (ETG.2000 ``EtherCATInfo`` XML, e.g. Beckhoff's
``Beckhoff EL1xxx.xml``). Both become a :class:`~robocourse.ethercat.sii.DeviceDescription`
and then an :class:`~robocourse.ethercat.esc.Esc` whose SII is that image (for an ESI file: the
image built from it, or the file's own ``<Eeprom><Data>`` when it carries one).

Device emulation comes from the PDI control word (SII word 0, loaded into register 0x0140 at
power-on): bit 8 set means the ESC itself echoes AL control into AL status (a simple terminal
such as an EK1100 or EL1004 without a microcontroller); clear means firmware runs the state
machine (the SyncManager checks of :class:`~robocourse.ethercat.esc.Esc`).

ESI elements read: ``Vendor/Id``; per ``Descriptions/Devices/Device``: ``Type`` (ProductCode,
RevisionNo, its text = the name SOEM shows), ``Name`` (English first), ``GroupType``, ``Sm``
(StartAddress, ControlByte, DefaultSize, Enable; the type from its text MBoxOut / MBoxIn /
Outputs / Inputs, or from the control byte), ``Fmmu``, ``RxPdo`` / ``TxPdo`` (a PDO without an
``Sm`` attribute is assigned to none, SM byte 0xFF), ``Mailbox`` (CoE with SdoInfo /
PdoAssign / PdoConfig / CompleteAccess, EoE, FoE, SoE, AoE, VoE), ``Eeprom`` (ByteSize,
ConfigData = SII words 0..6, Data = a whole image), ``Info/Electrical/EBusCurrent``.
Not read: DC operation modes (``Dc``), the object dictionary (``Profile/Dictionary``: a CoE
device built from an ESI file answers no SDO), ``Exclude``/alternative PDO sets, vendor
specific ``Info`` blocks.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from .esc import ET1100, Esc, EscModel
from .sii import (
    FMMU_INPUTS,
    FMMU_OUTPUTS,
    FMMU_SYNCM_STATUS,
    FMMU_UNUSED,
    SM_TYPE_INPUTS,
    SM_TYPE_MBX_IN,
    SM_TYPE_MBX_OUT,
    SM_TYPE_OUTPUTS,
    UNASSIGNED,
    DescriptionError,
    DeviceDescription,
    Pdo,
    PdoEntry,
    SyncManagerConfig,
    description_from_sii,
)

#: PDI control bit 8 (register 0x0140-0x0141): "emulated device", AL status follows AL control
PDI_DEVICE_EMULATION = 0x0100

_SM_TYPES = {"mboxout": SM_TYPE_MBX_OUT, "mboxin": SM_TYPE_MBX_IN, "outputs": SM_TYPE_OUTPUTS,
             "inputs": SM_TYPE_INPUTS}
_FMMU_TYPES = {"outputs": FMMU_OUTPUTS, "inputs": FMMU_INPUTS, "mboxstate": FMMU_SYNCM_STATUS,
               "": FMMU_UNUSED}
#: CiA 301 / ETG.1000.6 base data type codes as the SII PDO categories carry them
_DATATYPES = {"BOOL": 0x0001, "BIT": 0x0001, "SINT": 0x0002, "INT": 0x0003, "DINT": 0x0004,
              "USINT": 0x0005, "UINT": 0x0006, "UDINT": 0x0007, "REAL": 0x0008, "LREAL": 0x0011,
              "LINT": 0x0015, "ULINT": 0x001B, "BYTE": 0x001E, "WORD": 0x001F, "DWORD": 0x0020}
_MBX_BITS = {"AoE": 0x0001, "EoE": 0x0002, "CoE": 0x0004, "FoE": 0x0008, "SoE": 0x0010, "VoE": 0x0020}
_COE_BITS = {"SdoInfo": 0x02, "PdoAssign": 0x04, "PdoConfig": 0x08, "PdoUpload": 0x10, "CompleteAccess": 0x20}


def device_emulation(pdi_control: int) -> bool:
    """Whether an ESC with this PDI control word echoes AL control into AL status itself."""
    return bool(pdi_control & PDI_DEVICE_EMULATION)


def _read(source) -> bytes:
    if isinstance(source, (bytes, bytearray, memoryview)):
        return bytes(source)
    path = Path(source)
    if not path.is_file():
        raise FileNotFoundError(f"device file {str(source)!r} not found: pass the path of a .bin SII image or "
                                "an ESI .xml file, or its bytes")
    return path.read_bytes()


def _num(text: str | None, what: str) -> int:
    """An ESI number: ``#x1A00`` (hex), ``0x1A00`` or decimal."""
    t = (text or "").strip()
    try:
        if t[:2] in ("#x", "#X", "0x", "0X"):
            return int(t[2:], 16)
        return int(t)
    except ValueError:
        raise DescriptionError(f"ESI: {what} is {text!r}, not a number (ESI numbers are decimal or '#x' hex, "
                               "e.g. '#x1a00')") from None


def _bool(text: str | None) -> bool:
    return (text or "").strip().lower() in ("1", "true")


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _child(el, name: str):
    for c in el:
        if _local(c.tag) == name:
            return c
    return None


def _children(el, name: str):
    return [c for c in el if _local(c.tag) == name]


def _text(el, name: str, default: str = "") -> str:
    c = _child(el, name)
    return (c.text or "").strip() if c is not None and c.text else default


def _sm(el, i: int) -> SyncManagerConfig:
    control = _num(el.get("ControlByte", "0"), f"Sm[{i}] ControlByte")
    kind = (el.text or "").strip().lower()
    if kind in _SM_TYPES:
        sm_type = _SM_TYPES[kind]
    elif kind:
        raise DescriptionError(f"ESI: Sm[{i}] is {el.text!r}; expected MBoxOut, MBoxIn, Outputs or Inputs")
    else:   # no text: mode bits 0-1 (10 = mailbox), direction bits 2-3 (01 = written by the master)
        mailbox, written = control & 0x03 == 0x02, control & 0x0C == 0x04
        sm_type = (SM_TYPE_MBX_OUT if written else SM_TYPE_MBX_IN) if mailbox else (
            SM_TYPE_OUTPUTS if written else SM_TYPE_INPUTS)
    size = el.get("DefaultSize")
    length = _num(size, f"Sm[{i}] DefaultSize") if size is not None else None
    if length == 0 and sm_type in (SM_TYPE_OUTPUTS, SM_TYPE_INPUTS):
        length = None       # process-data SMs sized by their PDOs
    return SyncManagerConfig(start=_num(el.get("StartAddress", "0"), f"Sm[{i}] StartAddress"), control=control,
                             sm_type=sm_type, length=length, enable=1 if _bool(el.get("Enable", "1")) else 0)


def _pdo(el, kind: str) -> Pdo:
    index = _num(_text(el, "Index"), f"{kind} Index")
    entries = []
    for e in _children(el, "Entry"):
        sub = _text(e, "SubIndex", "0")
        entries.append(PdoEntry(_num(_text(e, "Index"), f"{kind} 0x{index:04X} Entry Index"),
                                _num(sub, f"{kind} 0x{index:04X} Entry SubIndex"),
                                _num(_text(e, "BitLen"), f"{kind} 0x{index:04X} Entry BitLen"),
                                _text(e, "Name"), _DATATYPES.get(_text(e, "DataType").upper(), 0)))
    sm = el.get("Sm")
    return Pdo(index, _num(sm, f"{kind} 0x{index:04X} Sm") if sm is not None else UNASSIGNED, tuple(entries),
               _text(el, "Name"))


def _name(dev) -> str:
    names = _children(dev, "Name")
    for n in names:
        if n.get("LcId") in (None, "1033"):
            return (n.text or "").strip()
    return (names[0].text or "").strip() if names else ""


def _devices(root):
    descs = _child(root, "Descriptions")
    devs = _child(descs, "Devices") if descs is not None else None
    return _children(devs, "Device") if devs is not None else []


def _identity(dev) -> tuple[str, int, int]:
    t = _child(dev, "Type")
    if t is None:
        raise DescriptionError("ESI: a Device has no <Type> element (it carries ProductCode and RevisionNo)")
    return ((t.text or "").strip(), _num(t.get("ProductCode", "0"), "Type ProductCode"),
            _num(t.get("RevisionNo", "0"), "Type RevisionNo"))


def esi_devices(source) -> list[tuple[str, int, int]]:
    """(type name, product code, revision) of every device in an ESI file."""
    return [_identity(d) for d in _devices(_parse(source))]


def _parse(source):
    data = _read(source) if not (isinstance(source, str) and source.lstrip().startswith("<")) else source.encode()
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise DescriptionError(f"ESI: not well-formed XML ({exc}); pass a vendor's EtherCATInfo file") from None
    if _local(root.tag) != "EtherCATInfo":
        raise DescriptionError(f"ESI: the root element is <{_local(root.tag)}>, an ESI file's is <EtherCATInfo>")
    return root


def description_from_esi(source, device: str | int | None = None, revision: int | None = None) -> DeviceDescription:
    """The :class:`DeviceDescription` of one device of an ESI file (path, bytes or XML text).

    ``device`` picks it by type name (``"EL1004"``) or product code when the file lists several;
    ``revision`` picks among revisions (default: the highest)."""
    root = _parse(source)
    devs = _devices(root)
    if not devs:
        raise DescriptionError("ESI: no Descriptions/Devices/Device in this file")
    found = [d for d in devs if device is None or _identity(d)[0] == device or _identity(d)[1] == device]
    if revision is not None:
        found = [d for d in found if _identity(d)[2] == revision]
    listed = ", ".join(f"{n} (product 0x{p:08X}, revision 0x{r:08X})" for n, p, r in map(_identity, devs))
    if not found:
        raise DescriptionError(f"ESI: no device {device!r}" + (f" revision 0x{revision:08X}" if revision else "")
                               + f" in this file; it lists {listed}")
    names = {_identity(d)[:2] for d in found}
    if len(names) > 1:
        raise DescriptionError(f"ESI: the file lists several devices ({listed}); pick one with device='<type>'")
    dev = max(found, key=lambda d: _identity(d)[2])
    name, product, rev = _identity(dev)
    vendor = _child(root, "Vendor")
    vendor_id = _num(_text(vendor, "Id"), "Vendor Id") if vendor is not None else 0
    eeprom = _child(dev, "Eeprom")
    if eeprom is not None and _text(eeprom, "Data"):
        image = bytes.fromhex(_text(eeprom, "Data"))
        desc = description_from_sii(image)
        if (desc.vendor_id, desc.product_code) != (vendor_id, product):
            raise DescriptionError(f"ESI: {name}'s <Eeprom><Data> says vendor 0x{desc.vendor_id:08X} product "
                                   f"0x{desc.product_code:08X}, its <Type> 0x{vendor_id:08X} / 0x{product:08X}")
        return desc
    config = bytes.fromhex(_text(eeprom, "ConfigData")) if eeprom is not None and _text(eeprom, "ConfigData") else b""
    byte_size = _num(_text(eeprom, "ByteSize"), "Eeprom ByteSize") if eeprom is not None and _text(
        eeprom, "ByteSize") else 2048
    sms = tuple(_sm(el, i) for i, el in enumerate(_children(dev, "Sm")))
    fmmus = []
    for el in _children(dev, "Fmmu"):
        kind = (el.text or "").strip().lower()
        if kind not in _FMMU_TYPES:
            raise DescriptionError(f"ESI: Fmmu {el.text!r}; expected Outputs, Inputs or MBoxState")
        fmmus.append(_FMMU_TYPES[kind])
    mbx, coe = 0, 0
    mailbox = _child(dev, "Mailbox")
    if mailbox is not None:
        for proto, bit in _MBX_BITS.items():
            el = _child(mailbox, proto)
            if el is not None:
                mbx |= bit
                if proto == "CoE":
                    coe = 0x01 | sum(b for attr, b in _COE_BITS.items() if _bool(el.get(attr)))
    info = _child(dev, "Info")
    electrical = _child(info, "Electrical") if info is not None else None
    ebus = _num(_text(electrical, "EBusCurrent", "0"), "EBusCurrent") if electrical is not None else 0
    pdi = int.from_bytes(config[:2], "little") if len(config) >= 2 else 0
    alias = int.from_bytes(config[8:10], "little") if len(config) >= 10 else 0
    return DeviceDescription(
        vendor_id, product, rev, name, _name(dev), _text(dev, "GroupType"), alias=alias, sms=sms,
        fmmus=tuple(fmmus), rxpdos=tuple(_pdo(el, "RxPdo") for el in _children(dev, "RxPdo")),
        txpdos=tuple(_pdo(el, "TxPdo") for el in _children(dev, "TxPdo")), ebus_current_ma=ebus,
        pdi_control=pdi, eeprom_bytes=byte_size, mbx_protocols=mbx, coe_details=coe, config_data=config[:14])


def slave_from_sii(source, *, model: EscModel = ET1100, port_descriptor: int = 0x0F, check_crc: bool = True,
                   **esc_kw) -> Esc:
    """A simulated slave whose EEPROM is exactly this SII image (path or bytes), as dumped from a
    device; device emulation from its PDI control word."""
    image = _read(source)
    desc = description_from_sii(image, check_crc=check_crc)
    return _slave(desc, image, model, port_descriptor, esc_kw)


def slave_from_esi(source, device: str | int | None = None, revision: int | None = None, *,
                   model: EscModel = ET1100, port_descriptor: int = 0x0F, **esc_kw) -> Esc:
    """A simulated slave for one device of an ESI file; its SII is built from the file (or is the
    file's own ``<Eeprom><Data>``); device emulation from the PDI control word it gives."""
    desc = description_from_esi(source, device, revision)
    return _slave(desc, None, model, port_descriptor, esc_kw)


def _slave(desc: DeviceDescription, image: bytes | None, model, port_descriptor, esc_kw) -> Esc:
    esc = Esc(desc, model, port_descriptor=port_descriptor, **esc_kw)   # emulation: from the PDI word
    if image is not None:
        esc.sii = bytearray(image)   # the device's own bytes, not our rebuild (vendor categories included)
        esc.power_on()
    return esc


__all__ = ["PDI_DEVICE_EMULATION", "description_from_esi", "device_emulation", "esi_devices", "slave_from_esi",
           "slave_from_sii"]
