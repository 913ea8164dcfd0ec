"""Slaves from device files (issue 30): an SII image (.bin) and a vendor ESI XML become slaves a
SOEM-shaped master brings up; device emulation from the PDI control word; PDOs on SM 0xFF kept.

The ESI text below is written for these tests in the ETG.2000 EtherCATInfo layout. The identities
are Beckhoff's published ones (vendor 0x2; EK1100 0x044C2C52, EL1004 0x03EC3052, as EtherCAT
configurations such as IgH master examples list them); the ConfigData words are illustrative,
not copied from Beckhoff's files.
"""

from __future__ import annotations

import pytest

from robocourse.ethercat import OP, Bus, Esc, Master, demo_bus
from robocourse.ethercat.device_files import (
    description_from_esi,
    device_emulation,
    esi_devices,
    slave_from_esi,
    slave_from_sii,
)
from robocourse.ethercat.devices import COUPLER, DIGITAL_INPUTS, DRIVE
from robocourse.ethercat.sii import (
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
    build_sii,
    description_from_sii,
)

ESI = """<?xml version="1.0" encoding="ISO8859-1"?>
<EtherCATInfo Version="1.6">
  <Vendor><Id>#x00000002</Id><Name>Beckhoff Automation GmbH &amp; Co. KG</Name></Vendor>
  <Descriptions>
    <Groups><Group><Type>SystemBk</Type><Name LcId="1033">System Couplers</Name></Group></Groups>
    <Devices>
      <Device Physics="YY">
        <Type ProductCode="#x044c2c52" RevisionNo="#x00110000">EK1100</Type>
        <Name LcId="1031">EK1100 EtherCAT-Koppler</Name>
        <Name LcId="1033">EK1100 EtherCAT Coupler (2A E-Bus)</Name>
        <GroupType>SystemBk</GroupType>
        <Info><Electrical><EBusCurrent>-2000</EBusCurrent></Electrical></Info>
        <Eeprom><ByteSize>256</ByteSize><ConfigData>000D00000000000000000000</ConfigData></Eeprom>
      </Device>
      <Device Physics="YY">
        <Type ProductCode="#x03ec3052" RevisionNo="#x00100000">EL1004</Type>
        <Name LcId="1033">EL1004 4Ch. Dig. Input 24V, 3ms</Name>
        <GroupType>DigIn</GroupType>
        <Fmmu>Inputs</Fmmu>
        <Sm ControlByte="#x00" Enable="1" StartAddress="#x1000">Inputs</Sm>
        <TxPdo Fixed="1" Mandatory="1" Sm="0"><Index>#x1a00</Index><Name>Channel 1</Name>
          <Entry><Index>#x6000</Index><SubIndex>1</SubIndex><BitLen>1</BitLen><Name>Input</Name><DataType>BOOL</DataType></Entry></TxPdo>
        <TxPdo Fixed="1" Mandatory="1" Sm="0"><Index>#x1a01</Index><Name>Channel 2</Name>
          <Entry><Index>#x6010</Index><SubIndex>1</SubIndex><BitLen>1</BitLen><Name>Input</Name><DataType>BOOL</DataType></Entry></TxPdo>
        <TxPdo Fixed="1" Mandatory="1" Sm="0"><Index>#x1a02</Index><Name>Channel 3</Name>
          <Entry><Index>#x6020</Index><SubIndex>1</SubIndex><BitLen>1</BitLen><Name>Input</Name><DataType>BOOL</DataType></Entry></TxPdo>
        <TxPdo Fixed="1" Mandatory="1" Sm="0"><Index>#x1a03</Index><Name>Channel 4</Name>
          <Entry><Index>#x6030</Index><SubIndex>1</SubIndex><BitLen>1</BitLen><Name>Input</Name><DataType>BOOL</DataType></Entry></TxPdo>
        <Info><Electrical><EBusCurrent>90</EBusCurrent></Electrical></Info>
        <Eeprom><ByteSize>2048</ByteSize><ConfigData>04010000000000000000</ConfigData></Eeprom>
      </Device>
    </Devices>
  </Descriptions>
</EtherCATInfo>
"""

# a drive whose ESI lists alternative PDOs without an Sm (assigned later over CoE, as the
# Kollmorgen AKD's file does) next to the default ones, SyncManagers typed by control byte only
DRIVE_ESI = """<EtherCATInfo><Vendor><Id>106</Id></Vendor><Descriptions><Devices><Device>
  <Type ProductCode="#x00414b44" RevisionNo="#x00000002">DRIVE</Type><Name>Drive with CoE</Name>
  <Sm Enable="1" StartAddress="#x1800" ControlByte="#x26" DefaultSize="128"/>
  <Sm Enable="1" StartAddress="#x1c00" ControlByte="#x22" DefaultSize="128"/>
  <Sm Enable="1" StartAddress="#x1100" ControlByte="#x64" DefaultSize="0"/>
  <Sm Enable="1" StartAddress="#x1140" ControlByte="#x20" DefaultSize="0"/>
  <Fmmu>Outputs</Fmmu><Fmmu>Inputs</Fmmu><Fmmu>MBoxState</Fmmu>
  <RxPdo Sm="2"><Index>#x1600</Index><Name>RxPDO 1</Name>
    <Entry><Index>#x6040</Index><SubIndex>0</SubIndex><BitLen>16</BitLen><Name>Controlword</Name><DataType>UINT</DataType></Entry>
    <Entry><Index>#x607a</Index><SubIndex>0</SubIndex><BitLen>32</BitLen><Name>Target position</Name><DataType>DINT</DataType></Entry></RxPdo>
  <RxPdo><Index>#x1601</Index><Name>RxPDO 2 (alternative)</Name>
    <Entry><Index>#x60ff</Index><SubIndex>0</SubIndex><BitLen>32</BitLen><Name>Target velocity</Name><DataType>DINT</DataType></Entry></RxPdo>
  <TxPdo Sm="3"><Index>#x1a00</Index><Name>TxPDO 1</Name>
    <Entry><Index>#x6041</Index><SubIndex>0</SubIndex><BitLen>16</BitLen><Name>Statusword</Name><DataType>UINT</DataType></Entry>
    <Entry><Index>#x0</Index><BitLen>16</BitLen></Entry></TxPdo>
  <Mailbox><CoE SdoInfo="true" PdoAssign="true" PdoConfig="false" CompleteAccess="1"/><FoE/></Mailbox>
  <Eeprom><ByteSize>4096</ByteSize><ConfigData>080C0000000000000000</ConfigData></Eeprom>
</Device></Devices></Descriptions></EtherCATInfo>"""


def test_an_sii_image_round_trips_into_the_same_description():
    for desc in (COUPLER, DIGITAL_INPUTS, DRIVE):
        image = build_sii(desc)
        back = description_from_sii(image)
        assert (back.vendor_id, back.product_code, back.revision, back.name) == (
            desc.vendor_id, desc.product_code, desc.revision, desc.name)
        assert back.sms == desc.sms or [s.sm_type for s in back.sms] == [s.sm_type for s in desc.sms]
        assert back.txpdos == desc.txpdos and back.rxpdos == desc.rxpdos
        assert (back.pdi_control, back.ebus_current_ma, back.output_bits, back.input_bits) == (
            desc.pdi_control, desc.ebus_current_ma, desc.output_bits, desc.input_bits)


def test_slave_from_an_sii_image_keeps_the_devices_bytes(tmp_path):
    image = bytearray(build_sii(COUPLER))
    image[-4:] = b"\xde\xad\xbe\xef"               # vendor bytes past the end marker stay as they were
    path = tmp_path / "ek1100.bin"
    path.write_bytes(bytes(image))
    esc = slave_from_sii(path)
    assert bytes(esc.sii) == bytes(image)
    assert esc.device_emulation is True           # COUPLER's PDI control 0x0D00: bit 8 set
    assert esc.mem[0x0140:0x0142] == b"\x00\x0d"  # loaded into the PDI control register at power-on
    damaged = bytes(image[:14]) + bytes([image[14] ^ 0xFF]) + bytes(image[15:])
    with pytest.raises(DescriptionError, match="SII checksum: byte 14 is .* CRC-8 over bytes 0..13"):
        slave_from_sii(damaged)
    with pytest.raises(FileNotFoundError, match="not found: pass the path of a .bin SII image"):
        slave_from_sii(tmp_path / "missing.bin")


@pytest.mark.parametrize("pdi, emulated", [(0x0D00, True), (0x0104, True), (0x0C08, False), (0x0008, False)])
def test_device_emulation_is_bit_8_of_the_pdi_control_word(pdi, emulated):
    assert device_emulation(pdi) is emulated
    desc = DeviceDescription(0x2, 0x1, 0x1, "X", pdi_control=pdi, fmmus=())
    assert slave_from_sii(build_sii(desc)).device_emulation is emulated
    assert Esc(desc).device_emulation is emulated              # every ESC, as the hardware does


def test_the_simulated_devices_pdi_words_say_how_they_run_their_state_machine():
    assert [type(s).__name__ for s in demo_bus().slaves if s.device_emulation] == ["Coupler"]


def test_pdos_on_no_syncmanager_are_kept_and_take_no_process_data():
    # SOEM ecx_siiPDO: "PDO deactivated because SM is 0xff or > EC_MAXSM"; the AKD lists such PDOs
    spare = Pdo(0x1601, UNASSIGNED, (PdoEntry(0x60FF, 0, 32, "Target velocity", 0x0004),), "alt")
    desc = DeviceDescription(
        0x6A, 0x414B44, 2, "AKD-like", sms=(SyncManagerConfig(0x1100, 0x64, SM_TYPE_OUTPUTS),),
        fmmus=(1,), rxpdos=(Pdo(0x1600, 0, (PdoEntry(0x6040, 0, 16, "Controlword", 0x0006),), "rx"), spare))
    assert desc.output_bits == 16
    back = description_from_sii(build_sii(desc))
    assert [(p.index, p.sm) for p in back.rxpdos] == [(0x1600, 0), (0x1601, UNASSIGNED)]
    with pytest.raises(DescriptionError, match=r"or to none \(sm=0xFF\)"):
        DeviceDescription(0x6A, 1, 1, "bad", sms=(SyncManagerConfig(0x1100, 0x64, SM_TYPE_OUTPUTS),),
                          rxpdos=(Pdo(0x1600, 3, (PdoEntry(0x6040, 0, 16),)),))


def test_an_esi_file_gives_identity_syncmanagers_pdos_and_the_pdi_word():
    assert esi_devices(ESI) == [("EK1100", 0x044C2C52, 0x00110000), ("EL1004", 0x03EC3052, 0x00100000)]
    el = description_from_esi(ESI, "EL1004")
    assert (el.vendor_id, el.product_code, el.revision, el.name) == (2, 0x03EC3052, 0x00100000, "EL1004")
    assert (el.long_name, el.group, el.ebus_current_ma, el.eeprom_bytes) == (
        "EL1004 4Ch. Dig. Input 24V, 3ms", "DigIn", 90, 2048)
    assert el.sms == (SyncManagerConfig(0x1000, 0x00, SM_TYPE_INPUTS, None, 1),)
    assert [(p.index, p.sm, [(e.index, e.subindex, e.bitlen, e.datatype) for e in p.entries]) for p in el.txpdos] == [
        (0x1A00 + ch, 0, [(0x6000 + 0x10 * ch, 1, 1, 0x0001)]) for ch in range(4)]
    assert (el.pdi_control, el.input_bits, el.output_bits) == (0x0104, 4, 0)
    ek = description_from_esi(ESI, 0x044C2C52)
    assert (ek.long_name, ek.pdi_control, ek.ebus_current_ma, ek.sms) == (
        "EK1100 EtherCAT Coupler (2A E-Bus)", 0x0D00, -2000, ())


def test_an_esi_drive_with_a_mailbox_and_unassigned_pdos():
    d = description_from_esi(DRIVE_ESI)
    assert [s.sm_type for s in d.sms] == [SM_TYPE_MBX_OUT, SM_TYPE_MBX_IN, SM_TYPE_OUTPUTS, SM_TYPE_INPUTS]
    assert [s.length for s in d.sms] == [128, 128, None, None]
    assert [(p.index, p.sm) for p in d.rxpdos] == [(0x1600, 2), (0x1601, UNASSIGNED)]
    assert d.txpdos[0].entries[1] == PdoEntry(0, 0, 16, "", 0)        # a padding entry
    assert (d.output_bits, d.input_bits) == (48, 32)
    assert d.mbx_protocols == 0x0004 | 0x0008                         # CoE + FoE
    assert d.coe_details == 0x01 | 0x02 | 0x04 | 0x20                 # SDO, SDO info, PDO assign, complete access
    assert d.fmmus == (1, 2, 3) and d.pdi_control == 0x0C08
    assert slave_from_esi(DRIVE_ESI).device_emulation is False


@pytest.mark.parametrize("text, words", [
    ("<Foo/>", "the root element is <Foo>"),
    ("<EtherCATInfo><Descriptions><Devices/></Descriptions></EtherCATInfo>", "no Descriptions/Devices/Device"),
    ("not xml", "not well-formed XML"),
])
def test_bad_esi_files_are_refused_with_the_reason(text, words):
    with pytest.raises(DescriptionError, match=words):
        description_from_esi(text.encode())


def test_a_file_with_several_devices_needs_one_named():
    with pytest.raises(DescriptionError, match="lists several devices .*EK1100.*EL1004.*pick one with device="):
        description_from_esi(ESI)
    with pytest.raises(DescriptionError, match="no device 'EL2008' in this file; it lists EK1100"):
        description_from_esi(ESI, "EL2008")


def test_our_master_brings_a_bus_of_file_slaves_to_op_and_reads_their_inputs(tmp_path):
    (tmp_path / "Beckhoff EL1xxx.xml").write_text(ESI, encoding="iso-8859-1")
    (tmp_path / "ek1100.bin").write_bytes(build_sii(description_from_esi(ESI, "EK1100")))
    coupler = slave_from_sii(tmp_path / "ek1100.bin")
    terminal = slave_from_esi(tmp_path / "Beckhoff EL1xxx.xml", "EL1004")
    bus = Bus([coupler, terminal])
    m = Master()
    m.open(bus)
    assert m.config_init() == 2
    assert [(s.name, s.man, s.id, s.rev) for s in m.slaves] == [
        ("EK1100", 2, 0x044C2C52, 0x00110000), ("EL1004", 2, 0x03EC3052, 0x00100000)]
    assert m.config_map() == 1
    m.config_dc()
    assert m.state_check(4, 50_000) == 4
    m.state = OP
    m.write_state()
    assert m.state_check(OP, 50_000) == OP
    terminal.mem[0x1000] = 0b1010                  # the application's input bits, as the PDI would put them
    m.send_processdata()
    m.receive_processdata()
    m.send_processdata()
    assert m.receive_processdata() == m.expected_wkc
    t = m.slaves[1]
    assert (t.ibits, t.ibytes) == (4, 0)               # SOEM's rule: under 8 bits, bit-addressed (Ibytes 0)
    assert m.io_map[t.in_offset] & 0x0F == 0x0A
