"""A Python EtherCAT master following SOEM's bring-up, with pysoem's API.

``Master`` mirrors ``pysoem.Master`` (open, config_init, config_map, config_dc, state_check,
read_state, write_state, send_processdata, receive_processdata -> working counter,
expected_wkc, slaves) and ``Slave`` mirrors ``pysoem.CdefSlave`` (name, man, id, rev,
state, al_status = the AL status code, input, output, write_state, state_check, dc_sync,
sdo_read/sdo_write). The datagrams are SOEM's, in its order (ecx_detect_slaves,
ecx_set_slaves_to_default, the per-slave addressing and SII reads through SOEM's EEPROM
cache, ecx_config_map_group's SM/FMMU writes, ecx_configdc), with AL control written as
2 bytes as the SOEM inside pysoem 1.1.13 does (v1.4.0 wrote 1): a test captures both masters
on the same kind of bus and finds every bring-up datagram equal (DC offsets aside).

CoE: expedited SDO transfers over the mailbox (``sdo_read``/``sdo_write``, SOEM's
ecx_SDOread/ecx_SDOwrite) and the PDO map read by SDO (ecx_readPDOmap) for CoE slaves;
slaves without a mailbox are mapped from their SII (ecx_map_sii) and refuse SDOs with
``MailboxError``. Where we differ: no segmented SDO, no complete access; one group; segments split at slave
boundaries; ``check()`` returns SOEM simple_test's ecatcheck messages instead of printing them.
For a ros2_control adapter: ``Slave.read_object(0x6041)`` / ``write_object(0x6040, cw)`` reach
any mapped object by its CiA index, ``pdo_layout()`` lists them, ``diagnose(wkc)`` says which
slave a short working counter comes from, ``drift_compensation`` switches the DC FRMW.
"""

from __future__ import annotations

import struct
import time
from dataclasses import dataclass, field

from robocourse.rt.loop import PeriodicLoop

from .bus import Bus
from .dc import line_delays
from .eeprom import EepromAccess
from .errors import MasterError
from .esc import (
    AL_ERROR,
    AL_STATUS_TEXT,
    INIT,
    OP,
    PREOP,
    REG_ALCTL,
    REG_ALSTAT,
    REG_DCCYCLE0,
    REG_DCSOF,
    REG_DCSTART0,
    REG_DCSYNCACT,
    REG_DCSYSDELAY,
    REG_DCSYSOFFSET,
    REG_DCSYSTIME,
    REG_DCTIME0,
    REG_DLSTAT,
    REG_EEPCFG,
    REG_EEPCTL,
    REG_ESCSUP,
    REG_FMMU0,
    REG_PDICTL,
    REG_PORTDES,
    REG_SM0,
    REG_STADR,
    SAFEOP,
    STATE_NAMES,
)
from .frames import Command, Datagram, FrameError, datagram, decode_frame, frame_bytes
from .mailbox import MailboxClient
from .sii import SM_TYPE_INPUTS, SM_TYPE_OUTPUTS, Pdo, SiiInfo
from .transport import InProcess, RawSocket

NONE_STATE = 0x00
EC_NODEOFFSET = 0x1000
EC_NOFRAME = -1
MAX_LRW_DATA = 1466  # EC_MAXLRWDATA - EC_FIRSTDCDATAGRAM
_PD_DATA = 14 + 2 + 10  # offset of the LRW's data in a process-data frame
EPOCH_2000_S = 946684800
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")


@dataclass
class Fmmu:
    log_start: int
    log_length: int
    log_startbit: int
    log_endbit: int
    phys_start: int
    fmmu_type: int

    def pack(self) -> bytes:
        return struct.pack("<IHBBHBBBxH", self.log_start, self.log_length, self.log_startbit,
                           self.log_endbit, self.phys_start, 0, self.fmmu_type, 1, 0)


_SIGNED = {0x0002, 0x0003, 0x0004, 0x0010, 0x0015}  # INTEGER8/16/32/24/64


def o_index(key) -> int:
    return key[0] if isinstance(key, tuple) else key


@dataclass(frozen=True)
class MappedObject:
    """Where a PDO entry sits in a slave's process data (SOEM's si_map_sii rows)."""

    direction: str  # "output" (RxPDO) or "input" (TxPDO)
    bit_offset: int
    bitlen: int
    datatype: int
    name: str = ""

    @property
    def byte_offset(self) -> int:
        return self.bit_offset // 8

    def decode(self, data: bytes) -> int:
        nbytes = (self.bit_offset % 8 + self.bitlen + 7) // 8
        raw = int.from_bytes(data[self.byte_offset:self.byte_offset + nbytes], "little")
        v = (raw >> (self.bit_offset % 8)) & ((1 << self.bitlen) - 1)
        if self.datatype in _SIGNED and v >> (self.bitlen - 1):
            v -= 1 << self.bitlen
        return v

    def encode(self, buf: bytearray, value: int) -> None:
        lo = -(1 << (self.bitlen - 1)) if self.datatype in _SIGNED else 0
        hi = (1 << (self.bitlen - 1)) - 1 if self.datatype in _SIGNED else (1 << self.bitlen) - 1
        if not lo <= value <= hi:
            raise ValueError(f"{self.name or 'object'}: {value} does not fit {self.bitlen} bits "
                             f"({lo}..{hi})")
        shift, nbytes = self.bit_offset % 8, (self.bit_offset % 8 + self.bitlen + 7) // 8
        b0 = self.byte_offset
        raw = int.from_bytes(buf[b0:b0 + nbytes], "little")
        mask = ((1 << self.bitlen) - 1) << shift
        raw = (raw & ~mask) | ((value & ((1 << self.bitlen) - 1)) << shift)
        buf[b0:b0 + nbytes] = raw.to_bytes(nbytes, "little")


@dataclass
class Slave:
    """One slave as the master knows it (SOEM's ``ec_slavet``; pysoem's ``CdefSlave``)."""

    master: Master = field(repr=False)
    position: int
    config_address: int = 0
    alias: int = 0
    itype: int = 0
    sii: SiiInfo = field(default_factory=SiiInfo)
    eep_8byte: bool = False
    eep_pdi: bool = False
    has_dc: bool = False
    dl_status: int = 0
    ptype: int = 0
    topology: int = 0
    active_ports: int = 0
    parent: int = 0
    state: int = NONE_STATE
    al_status_code: int = 0
    sm: list[tuple[int, int, int]] = field(default_factory=list)  # start, length, flags
    sm_type: list[int] = field(default_factory=list)
    obits: int = 0
    ibits: int = 0
    obytes: int = 0
    ibytes: int = 0
    out_offset: int = 0
    in_offset: int = 0
    fmmus: list[Fmmu] = field(default_factory=list)
    is_lost: bool = False
    mbx_l: int = 0  # write mailbox (SM0) length, SOEM's mbx_l
    mbx_wo: int = 0
    mbx_rl: int = 0
    mbx_ro: int = 0
    mbx_cnt: int = 0
    _pdo_detail: tuple[list[Pdo], list[Pdo]] | None = field(default=None, repr=False)
    dc_delay: int = 0
    dc_port_times: tuple[int, int | None] = (0, None)

    # identity, as pysoem names it
    @property
    def name(self) -> str:
        return self.sii.name

    @property
    def man(self) -> int:
        return self.sii.vendor_id

    @property
    def id(self) -> int:
        return self.sii.product_code

    @property
    def rev(self) -> int:
        return self.sii.revision

    @property
    def al_status(self) -> int:
        """pysoem's name for the AL status code (0x0134) read with the state."""
        return self.al_status_code

    @property
    def output(self) -> bytes:
        return bytes(self.master.io_map[self.out_offset:self.out_offset + self.obytes])

    @output.setter
    def output(self, value: bytes) -> None:
        if len(value) != self.obytes:
            raise ValueError(f"slave {self.position} ({self.name}) has {self.obytes} output bytes; "
                             f"got {len(value)}: pass exactly {self.obytes} bytes")
        self.master.io_map[self.out_offset:self.out_offset + self.obytes] = value

    @property
    def input(self) -> bytes:
        return bytes(self.master.io_map[self.in_offset:self.in_offset + self.ibytes])

    def pdo_layout(self) -> dict[int, MappedObject]:
        """Every mapped object of this slave, by CiA index (0x6040, 0x6041, 0x7000...), with
        its direction and bit offset in this slave's ``output``/``input`` bytes."""
        out: dict[int, MappedObject] = {}
        for kind, pdos in (("output", self.detailed_pdos(True)), ("input", self.detailed_pdos(False))):
            bit = 0
            for p in pdos:
                for e in p.entries:
                    key = e.index if e.subindex == 0 else (e.index, e.subindex)
                    out.setdefault(key, MappedObject(kind, bit, e.bitlen, e.datatype, e.name))
                    bit += e.bitlen
        return out

    def detailed_pdos(self, rx: bool) -> list[Pdo]:
        """RxPDOs (``rx``) or TxPDOs with entry indices, types and names: read from the SII
        once (acyclic EEPROM traffic, as SOEM's slaveinfo -map does) and kept."""
        if self._pdo_detail is None:
            m = self.master
            self._pdo_detail = (m.sii_pdos(self, rx=False, detail=True),
                                m.sii_pdos(self, rx=True, detail=True))
        return self._pdo_detail[1 if rx else 0]

    def read_object(self, index, subindex: int = 0) -> int:
        """A mapped object's value from the process image (e.g. 0x6041 statusword, 0x6064
        position); after ``receive_processdata`` it is what the slave sent this cycle."""
        o = self._object(index, subindex)
        data = self.input if o.direction == "input" else self.output
        return o.decode(data)

    def write_object(self, index, value: int, subindex: int = 0) -> None:
        """Set an output object (e.g. 0x6040 controlword, 0x607A target position) in the image;
        the next ``send_processdata`` carries it."""
        o = self._object(index, subindex)
        if o.direction != "output":
            raise ValueError(f"slave {self.position} ({self.name}): 0x{o_index(index):04X} is an "
                             "input (TxPDO); only outputs (RxPDO objects) can be written")
        buf = bytearray(self.output)
        o.encode(buf, value)
        self.output = bytes(buf)

    def _object(self, index, subindex: int) -> MappedObject:
        layout = self.pdo_layout()
        key = index if subindex == 0 else (index, subindex)
        if key not in layout:
            names = ", ".join(f"0x{o_index(k):04X}" for k in layout)
            raise KeyError(f"slave {self.position} ({self.name}) maps no object 0x{o_index(index):04X}:"
                           f"{subindex:02X}; it maps: {names}")
        return layout[key]

    def write_state(self) -> int:
        """FPWR AL control = ``self.state`` (pysoem: slave.state = OP_STATE; slave.write_state())."""
        return self.master._fp(Command.FPWR, self.config_address, REG_ALCTL,
                               _U16.pack(self.state))[0]

    def state_check(self, expected: int, timeout: int = 2000) -> int:
        return self.master._statecheck_slave(self, expected, timeout)

    def dc_sync(self, act: bool, sync0_cycle_time: int, sync0_shift_time: int = 0) -> None:
        """SOEM's ecx_dcsync0: SYNC0 every ``sync0_cycle_time`` ns, starting 100 ms from now."""
        m, adr = self.master, self.config_address
        m._fp(Command.FPWR, adr, REG_DCSYNCACT, b"\x00")
        wkc, raw = m._fp(Command.FPRD, adr, REG_DCSYSTIME, 8)
        if wkc != 1:
            raise MasterError(f"slave {self.position} ({self.name}): reading DC system time "
                              "0x0910 got no answer; does it support DC? (config_dc first)")
        t1 = _U64.unpack(raw)[0]
        start = ((t1 + 100_000_000) // sync0_cycle_time) * sync0_cycle_time + sync0_cycle_time \
            + sync0_shift_time if sync0_cycle_time else 0
        m._fp(Command.FPWR, adr, REG_DCSTART0, _U64.pack(start))
        m._fp(Command.FPWR, adr, REG_DCCYCLE0, _U32.pack(sync0_cycle_time))
        m._fp(Command.FPWR, adr, REG_DCSYNCACT, b"\x03" if act else b"\x00")

    def sdo_read(self, index: int, subindex: int, size: int = 0) -> bytes:
        """Expedited SDO upload over the CoE mailbox; ``SdoError`` carries the abort code."""
        return self.master.sdo_upload(self, index, subindex)

    def sdo_write(self, index: int, subindex: int, data: bytes) -> None:
        """Expedited SDO download (1-4 bytes) over the CoE mailbox."""
        self.master.sdo_download(self, index, subindex, data)

    def _no_mailbox(self, what: str) -> str:
        return (f"{what}: slave {self.position} ({self.name}) has no mailbox (SII mailbox size "
                f"{self.sii.mbx_rx_size}, protocols 0x{self.sii.mbx_protocols:04X}), so it has no "
                "CoE object dictionary; its PDO layout is in the SII (see pdo_layout())")


@dataclass(frozen=True)
class WkcDiagnosis:
    """Why a cycle's working counter differs from the expected one."""

    wkc: int
    expected: int
    missing: tuple[int, ...]  # positions not answering
    not_op: tuple[tuple[int, int, int], ...]  # (position, AL status, AL status code)

    def __str__(self) -> str:
        parts = [f"working counter {self.wkc}, expected {self.expected}"]
        for p in self.missing:
            parts.append(f"slave {p} not responding (lost)")
        for p, st, code in self.not_op:
            parts.append(f"slave {p} in {state_name(st)} (AL status 0x{st:02X}, code "
                         f"0x{code:04X} {AL_STATUS_TEXT.get(code, 'unknown')})")
        return "; ".join(parts)


def state_name(al_status: int) -> str:
    name = STATE_NAMES.get(al_status & 0x0F, f"state 0x{al_status & 0x0F:X}")
    return name + (" + ERROR" if al_status & AL_ERROR else "")


class Master(EepromAccess, MailboxClient):
    """An EtherCAT master with pysoem's interface. ``open(bus)`` in-process, ``open('veth0')`` raw."""

    def __init__(self, retries: int = 3, timeout_us: int = 2000) -> None:
        self.slaves: list[Slave] = []
        self.transport = None
        self.retries = retries
        self.timeout_us = timeout_us
        self.io_map = bytearray()
        self.expected_wkc = 0
        self.outputs_wkc = 0
        self.inputs_wkc = 0
        self.obytes = self.ibytes = 0
        self.state = NONE_STATE
        self.dc_time = 0
        self.dc_ref: Slave | None = None
        self.drift_compensation = True  # FRMW of the reference clock's 0x0910 every cycle
        self.frames_sent = 0
        self.frames_lost = 0
        self._idx = 0
        self._pending: list[tuple[bytes, bytes | None]] = []
        self._segs: list[tuple[int, int]] = []
        self._pd_key: tuple | None = None
        self._pd: list[tuple[int, int, bytearray, int]] = []

    # ---- transport ------------------------------------------------------------------------
    def open(self, where: Bus | str) -> None:
        """``open(bus)`` talks to a simulated bus in-process; ``open('eth0')`` to an interface."""
        if isinstance(where, Bus):
            self.transport = InProcess(where)
        elif isinstance(where, str):
            self.transport = RawSocket(where)
        else:
            raise TypeError(f"open() takes a Bus or an interface name, got {where!r}")

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()
            self.transport = None

    def _next_idx(self) -> int:
        self._idx = (self._idx + 1) & 0xFF
        return self._idx

    def exchange(self, dgs: list[Datagram], retries: int | None = None) -> list[Datagram] | None:
        """Send one frame holding ``dgs``; the reply's datagrams, or None after all retries."""
        if self.transport is None:
            raise MasterError("the master is not open: call master.open(bus) or open('eth0') first")
        idx = self._next_idx()
        for d in dgs:
            d.idx = idx
        raw = frame_bytes(dgs)
        for _ in range(1 + (self.retries if retries is None else retries)):
            self.frames_sent += 1
            reply = self.transport.exchange(raw, self.timeout_us * 1e-6)
            if reply is None:
                self.frames_lost += 1
                continue
            try:
                out = decode_frame(reply).datagrams
            except FrameError:
                self.frames_lost += 1
                continue
            if len(out) == len(dgs) and all(a.cmd == b.cmd for a, b in zip(out, dgs)):
                return out
            self.frames_lost += 1
        return None

    def _one(self, cmd: Command, adp: int, ado: int, data: bytes | int) -> tuple[int, bytes]:
        out = self.exchange([datagram(cmd, adp, ado, data)])
        if out is None:
            return EC_NOFRAME, b""
        return out[0].wkc, bytes(out[0].data)

    def _ap(self, cmd: Command, position: int, ado: int, data: bytes | int) -> tuple[int, bytes]:
        return self._one(cmd, (1 - position) & 0xFFFF, ado, data)

    def _fp(self, cmd: Command, adr: int, ado: int, data: bytes | int) -> tuple[int, bytes]:
        return self._one(cmd, adr, ado, data)

    def _bwr(self, ado: int, data: bytes) -> int:
        return self._one(Command.BWR, 0, ado, data)[0]

    # ---- 3.1 ecx_config_init --------------------------------------------------------------
    def config_init(self) -> int:
        """Find the slaves, address them, read their SII; returns the slave count (0: none).

        SOEM's ecx_config_init datagram for datagram: detect, defaults, then per slave its
        address and the first EEPROM read, the identity words read slave after slave
        (vendor, serial, product, revision, mailbox), and per slave the ESC features, DL
        status, port types, INIT check, the SII general/strings/SM/FMMU categories, PRE_OP.
        """
        self.slaves = []
        self._esi_slave = None
        init_ack = _U16.pack(INIT | AL_ERROR)  # 2 bytes, as SOEM 2.x (the one in pysoem) writes
        self._bwr(0x0103, b"\x00")
        self._bwr(REG_ALCTL, init_ack)
        self._bwr(REG_ALCTL, init_ack)
        n, _ = self._one(Command.BRD, 0, 0x0000, 2)
        if n <= 0:
            return 0
        for ado, data in ((0x0101, b"\x00"), (0x0200, _U16.pack(0x0004)), (0x0300, bytes(8)),
                          (REG_FMMU0, bytes(48)), (REG_SM0, bytes(32)), (REG_DCSYNCACT, b"\x00"),
                          (REG_DCSYSTIME, bytes(4)), (0x0930, _U16.pack(0x1000)),
                          (0x0934, _U16.pack(0x0C00)), (0x0103, b"\x00"),
                          (REG_ALCTL, init_ack), (REG_EEPCFG, b"\x02"),
                          (REG_EEPCFG, b"\x00")):
            self._bwr(ado, data)
        self.slaves = [Slave(self, i) for i in range(1, n + 1)]
        for s in self.slaves:
            wkc, raw = self._ap(Command.APRD, s.position, REG_PDICTL, 2)
            if wkc != 1:
                raise MasterError(f"slave {s.position}: APRD 0x0140 got WKC {wkc}, expected 1 "
                                  "(did the bus change during the scan?)")
            s.itype = _U16.unpack(raw)[0]
            self._ap(Command.APWR, s.position, REG_STADR, _U16.pack(EC_NODEOFFSET + s.position))
            self._ap(Command.APWR, s.position, 0x0100, _U16.pack(1 if s.position == 1 else 0))
            s.config_address = _U16.unpack(self._ap(Command.APRD, s.position, REG_STADR, 2)[1])[0]
            s.alias = _U16.unpack(self._fp(Command.FPRD, s.config_address, 0x0012, 2)[1])[0]
            estat = _U16.unpack(self._fp(Command.FPRD, s.config_address, REG_EEPCTL, 2)[1])[0]
            s.eep_8byte = bool(estat & 0x0040)
            self._readeeprom1(s, 0x0008)
        for field_name, next_word in (("vendor_id", 0x000E), ("serial", 0x000A),
                                      ("product_code", 0x000C), ("revision", 0x0018)):
            for s in self.slaves:
                setattr(s.sii, field_name, self._readeeprom2(s))
                self._readeeprom1(s, next_word)
        for s in self.slaves:
            mbx = self._readeeprom2(s)
            s.mbx_wo, s.mbx_l = mbx & 0xFFFF, mbx >> 16
            s.sii.mbx_rx_offset, s.sii.mbx_rx_size = s.mbx_wo, s.mbx_l
            if s.mbx_l:
                self._readeeprom1(s, 0x001A)
        for s in self.slaves:
            adr = s.config_address
            if s.mbx_l:
                mbx = self._readeeprom2(s)
                s.mbx_ro, s.mbx_rl = mbx & 0xFFFF, (mbx >> 16) or s.mbx_l
                s.sii.mbx_tx_offset, s.sii.mbx_tx_size = s.mbx_ro, s.mbx_rl
                self._readeeprom1(s, 0x001C)
            s.has_dc = bool(_U16.unpack(self._fp(Command.FPRD, adr, REG_ESCSUP, 2)[1])[0] & 0x04)
            s.dl_status = _U16.unpack(self._fp(Command.FPRD, adr, REG_DLSTAT, 2)[1])[0]
            s.topology, s.active_ports = 0, 0
            for p in range(4):
                if (s.dl_status >> (8 + 2 * p)) & 0x3 == 0x2:
                    s.topology += 1
                    s.active_ports |= 1 << p
            s.ptype = self._fp(Command.FPRD, adr, REG_PORTDES, 2)[1][0]
            s.parent = s.position - 1 if s.position > 1 else 0
            self._statecheck_slave(s, INIT, 2000)
            if s.mbx_l:
                s.sii.mbx_protocols = self._readeeprom2(s) & 0xFFFF
            prev = next((p for p in self.slaves[:s.position - 1]
                         if (p.man, p.id, p.rev) == (s.man, s.id, s.rev)), None)
            if prev is not None:  # ecx_lookup_prev_sii: same identity, copy instead of reading
                s.sii.general, s.sii.strings = prev.sii.general, prev.sii.strings
                s.sii.sms, s.sii.fmmus = list(prev.sii.sms), list(prev.sii.fmmus)
            else:
                self._read_sii_config(s)
            s.sm = [(start, length, ctl | (en << 16)) for start, length, ctl, en, _t in s.sii.sms]
            s.sm += [(0, 0, 0)] * (8 - len(s.sm))
            s.sm_type = [0] * len(s.sm)
            if s.mbx_l:  # SM0 + SM1 in one datagram (SOEM: "solves timing issue in old NETX")
                if not s.sm[0][0]:
                    s.sm[0] = (s.mbx_wo, s.mbx_l, 0x00010026)
                    s.sm[1] = (s.mbx_ro, s.mbx_rl, 0x00010022)
                s.sm_type[0:4] = [1, 2, 3, 4]
                self._fp(Command.FPWR, adr, REG_SM0,
                         b"".join(struct.pack("<HHI", *s.sm[i]) for i in (0, 1)))
            self._eeprom_to_pdi(s)
            self._fp(Command.FPWR, adr, REG_ALCTL, _U16.pack(PREOP | AL_ERROR))
        self.dc_ref = next((s for s in self.slaves if s.has_dc), None)
        return n

    def _read_sii_config(self, s: Slave) -> None:
        """General (CoE/FoE/EoE/SoE details, flags, E-bus current), name, SMs, FMMU usage."""
        g = self.sii_find(s, 30)
        general = bytearray(16)
        if g:
            for off in (0x07, 0x08, 0x09, 0x0A, 0x0D, 0x0E, 0x0F):
                general[off - 2] = self.sii_byte(s, g + off)
        s.sii.general = bytes(general)
        s.sii.strings = [self.sii_string(s, 1)] if self.sii_find(s, 10) else []
        s.sii.sms = self.sii_sms(s)
        s.sii.fmmus = self.sii_fmmus(s)

    # ---- 3.2 ecx_config_map_group ------------------------------------------------------------
    def config_map(self) -> int:
        """Map every slave's PDOs into one process image; request SAFE_OP. Returns its size."""
        if not self.slaves:
            raise MasterError("config_map() before config_init() found any slave")
        for s in self.slaves:
            self._map_coe(s)
        for s in self.slaves:
            self._map_sii(s)
            self._map_sm(s)
        log, bit = 0, 0
        self.outputs_wkc = self.inputs_wkc = 0
        for s in self.slaves:
            s.fmmus = []
            if s.obits:
                s.out_offset = log
                log, bit = self._create_mapping(s, s.obits, s.obytes, SM_TYPE_OUTPUTS, 2, log, bit)
                self.outputs_wkc += 1
        if bit:
            log, bit = log + 1, 0
        self.obytes = log
        for s in self.slaves:
            if s.ibits:
                s.in_offset = log
                log, bit = self._create_mapping(s, s.ibits, s.ibytes, SM_TYPE_INPUTS, 1, log, bit)
                self.inputs_wkc += 1
            self._eeprom_to_pdi(s)
            self._fp(Command.FPWR, s.config_address, REG_ALCTL, _U16.pack(SAFEOP))
        if bit:
            log += 1
        self.ibytes = log - self.obytes
        self.io_map = bytearray(log)
        self.expected_wkc = 2 * self.outputs_wkc + self.inputs_wkc
        self._segs = self._segments()
        return log

    def _map_coe(self, s: Slave) -> None:
        """ecx_map_coe_soe: PRE_OP check, then the PDO map by SDO for a CoE slave."""
        self._statecheck_slave(s, PREOP, 2000)
        s.obits = s.ibits = 0
        if s.mbx_l and s.sii.mbx_protocols & 0x0004:
            s.obits, s.ibits = self.read_pdo_map(s)

    def _map_sii(self, s: Slave) -> None:
        if s.obits or s.ibits:  # the CoE map counted already
            s.ibytes = (s.ibits + 7) // 8 if s.ibits > 7 else 0
            s.obytes = (s.obits + 7) // 8 if s.obits > 7 else 0
            s._pdo_detail = None
            return
        prev = next((p for p in self.slaves[:s.position - 1] if (p.man, p.id, p.rev) ==
                     (s.man, s.id, s.rev) and (p.ibits or p.obits)), None)
        if prev is not None:  # ecx_lookup_mapping: a previous slave of the same kind
            s.sii.txpdos, s.sii.rxpdos = prev.sii.txpdos, prev.sii.rxpdos
        else:
            s.sii.txpdos = self.sii_pdos(s, rx=False)
            s.sii.rxpdos = self.sii_pdos(s, rx=True)
        s._pdo_detail = None
        bits = {}
        for kind, pdos in ((SM_TYPE_INPUTS, s.sii.txpdos), (SM_TYPE_OUTPUTS, s.sii.rxpdos)):
            per_sm: dict[int, int] = {}
            for p in pdos:
                if p.sm < 8:
                    per_sm[p.sm] = per_sm.get(p.sm, 0) + p.bits
            for sm, b in per_sm.items():
                if sm >= len(s.sm):
                    raise MasterError(f"slave {s.position} ({s.name}): a PDO is assigned to SM{sm} "
                                      f"but the SII lists only {len(s.sm)} SyncManagers")
                start, _len, flags = s.sm[sm]
                s.sm[sm] = (start, (b + 7) // 8, flags)
                s.sm_type[sm] = kind
            bits[kind] = sum(per_sm.values())
        s.ibits, s.obits = bits.get(SM_TYPE_INPUTS, 0), bits.get(SM_TYPE_OUTPUTS, 0)
        s.ibytes = (s.ibits + 7) // 8 if s.ibits > 7 else 0
        s.obytes = (s.obits + 7) // 8 if s.obits > 7 else 0

    def _map_sm(self, s: Slave) -> None:
        for i, (start, length, flags) in enumerate(s.sm):
            if not start or (i < 2 and s.mbx_l):
                continue
            if i >= 2:
                flags = flags | 0x10000 if length else flags & ~0x10000
                s.sm[i] = (start, length, flags)
            self._fp(Command.FPWR, s.config_address, REG_SM0 + 8 * i,
                     struct.pack("<HHI", start, length, flags))

    def _create_mapping(self, s: Slave, bits: int, nbytes: int, sm_type: int, fmmu_type: int,
                        log: int, bit: int) -> tuple[int, int]:
        sm = next((i for i, t in enumerate(s.sm_type) if t == sm_type), None)
        if sm is None:
            raise MasterError(f"slave {s.position} ({s.name}): {bits} bits of "
                              f"{'outputs' if sm_type == SM_TYPE_OUTPUTS else 'inputs'} but no SM of type {sm_type}")
        phys = s.sm[sm][0]
        if nbytes == 0:  # bit-oriented slave: pack bit by bit (SOEM's LogStartbit/LogEndbit)
            f = Fmmu(log, 0, bit, 0, phys, fmmu_type)
            bit += bits - 1
            if bit > 7:
                log, bit = log + 1, bit - 8
            f.log_length = log - f.log_start + 1
            f.log_endbit = bit
            bit += 1
            if bit > 7:
                log, bit = log + 1, bit - 8
        else:
            if bit:
                log, bit = log + 1, 0
            f = Fmmu(log, nbytes, 0, 7, phys, fmmu_type)
            log += nbytes
        if sm_type == SM_TYPE_OUTPUTS:
            s.out_offset = f.log_start
        else:
            s.in_offset = f.log_start
        idx = len(s.fmmus)
        s.fmmus.append(f)
        self._fp(Command.FPWR, s.config_address, REG_FMMU0 + 16 * idx, f.pack())
        return log, bit

    # ---- 3.3 ecx_configdc --------------------------------------------------------------
    def config_dc(self) -> bool:
        """Latch port times, set each DC slave's offset and propagation delay; True if any DC."""
        dc = [s for s in self.slaves if s.has_dc]
        if not dc:
            return False
        self._bwr(REG_DCTIME0, bytes(4))
        master_time = time.time_ns() - EPOCH_2000_S * 1_000_000_000
        for k, s in enumerate(dc):
            adr = s.config_address
            t0 = _U32.unpack(self._fp(Command.FPRD, adr, REG_DCTIME0, 4)[1])[0]
            wkc, raw = self._fp(Command.FPRD, adr, REG_DCSOF, 8)
            sof = _U64.unpack(raw)[0] if wkc == 1 else 0
            self._fp(Command.FPWR, adr, REG_DCSYSOFFSET,
                     _U64.pack((master_time - sof) & 0xFFFFFFFFFFFFFFFF))
            ports = [_U32.unpack(self._fp(Command.FPRD, adr, REG_DCTIME0 + 4 * p, 4)[1])[0]
                     for p in (1, 2, 3)]
            s.dc_port_times = (t0, ports[0] if s.active_ports & 0x2 else None)
            if k:  # every DC slave after the reference gets its propagation delay at once
                s.dc_delay = line_delays([d.dc_port_times for d in dc[:k + 1]])[-1]
                self._fp(Command.FPWR, adr, REG_DCSYSDELAY, _U32.pack(s.dc_delay))
        self.dc_ref = dc[0]
        return True

    # ---- states -----------------------------------------------------------------------
    def _statecheck_slave(self, s: Slave, expected: int, timeout_us: int) -> int:
        deadline = time.monotonic() + timeout_us * 1e-6
        while True:
            wkc, raw = self._fp(Command.FPRD, s.config_address, REG_ALSTAT, 6)
            if wkc == 1:
                status, _, s.al_status_code = struct.unpack("<HHH", raw)
                s.state = status & 0x1F
                s.is_lost = False
            else:
                s.state = NONE_STATE
            if s.state & 0x0F == expected or time.monotonic() >= deadline:
                return s.state & 0x0F
            time.sleep(0.0002)

    def state_check(self, expected: int, timeout: int = 50_000) -> int:
        """Poll BRD AL status until every slave reports ``expected`` (OR of all) or timeout (us)."""
        deadline = time.monotonic() + timeout * 1e-6
        while True:
            wkc, raw = self._one(Command.BRD, 0, REG_ALSTAT, 2)
            state = _U16.unpack(raw)[0] & 0x0F if wkc > 0 else NONE_STATE
            if state == expected or time.monotonic() >= deadline:
                break
            time.sleep(0.0002)
        if state != expected or wkc < len(self.slaves):
            self.read_state()
            return self._lowest()
        for s in self.slaves:
            s.state = expected
        return state

    def _lowest(self) -> int:
        states = [s.state & 0x0F for s in self.slaves]
        return min(states) if states else NONE_STATE

    def read_state(self) -> int:
        """BRD AL status; if not one clean state, FPRD every slave's status and code."""
        wkc, raw = self._one(Command.BRD, 0, REG_ALSTAT, 2)
        if wkc >= len(self.slaves) and wkc > 0:
            st = _U16.unpack(raw)[0]
            if st & 0x0F in STATE_NAMES and not st & AL_ERROR and bin(st & 0x0F).count("1") == 1:
                for s in self.slaves:
                    s.state = st
                    s.al_status_code = 0
                return st & 0x0F
        for s in self.slaves:
            wkc, raw = self._fp(Command.FPRD, s.config_address, REG_ALSTAT, 6)
            if wkc == 1:
                status, _, s.al_status_code = struct.unpack("<HHH", raw)
                s.state = status & 0x1F
            else:
                s.state = NONE_STATE
        return self._lowest()

    def write_state(self) -> int:
        """BWR AL control = ``self.state`` (pysoem: master.state = OP_STATE; master.write_state())."""
        return self._bwr(REG_ALCTL, _U16.pack(self.state))

    # ---- 4 process data ----------------------------------------------------------------
    def _segments(self) -> list[tuple[int, int]]:
        blocks = sorted((f.log_start, f.log_start + f.log_length) for s in self.slaves for f in s.fmmus)
        segs: list[tuple[int, int]] = []
        start = 0
        for lo, hi in blocks:
            if hi - start > MAX_LRW_DATA and lo > start:
                segs.append((start, lo))
                start = lo
        if len(self.io_map) > start:
            segs.append((start, len(self.io_map)))
        return segs

    def _pd_frames(self) -> list[tuple[int, int, bytearray, int]]:
        """Per segment (logical start, length, frame template, FRMW data offset or 0): the
        process-data frames are built once and only their data is refreshed each cycle."""
        frmw = self.dc_ref.config_address if self.dc_ref is not None and self.drift_compensation \
            else None
        key = (tuple(self._segs), frmw)
        if key != self._pd_key:
            frames = []
            for i, (lo, hi) in enumerate(self._segs):
                dgs = [Datagram.logical_cmd(Command.LRW, lo, hi - lo)]
                if i == 0 and frmw is not None:
                    dgs.append(datagram(Command.FRMW, frmw, REG_DCSYSTIME, 8))
                frames.append((lo, hi - lo, bytearray(frame_bytes(dgs)),
                               _PD_DATA + (hi - lo) + 2 + 10 if len(dgs) > 1 else 0))
            self._pd_key, self._pd = key, frames
        return self._pd

    def send_processdata(self) -> None:
        """One LRW per segment of the image (+ FRMW of the DC reference's 0x0910 in the first,
        carrying the last DC time as SOEM's does)."""
        if self.transport is None:
            raise MasterError("the master is not open: call master.open(bus) or open('eth0') first")
        pending = []
        for lo, n, buf, frmw in self._pd_frames():
            idx = self._next_idx()
            buf[17] = idx
            buf[_PD_DATA:_PD_DATA + n] = self.io_map[lo:lo + n]
            buf[_PD_DATA + n:_PD_DATA + n + 2] = b"\x00\x00"
            if frmw:
                buf[frmw - 9] = idx
                buf[frmw:frmw + 10] = _U64.pack(self.dc_time) + b"\x00\x00"
            self.frames_sent += 1
            reply = self.transport.exchange(bytes(buf), self.timeout_us * 1e-6)
            if reply is None or len(reply) < len(buf) or reply[17] != idx or reply[16] != Command.LRW:
                self.frames_lost += 1
                reply = None
            pending.append((lo, n, frmw, reply))
        self._pending = pending

    def receive_processdata(self, timeout: int = 2000) -> int:
        """The LRW working counters summed, or -1 (EC_NOFRAME) when a reply never came."""
        pending, self._pending = self._pending, []
        if not pending:
            return EC_NOFRAME
        wkc = 0
        for lo, n, frmw, reply in pending:
            if reply is None:
                return EC_NOFRAME
            self.io_map[lo:lo + n] = reply[_PD_DATA:_PD_DATA + n]
            wkc += reply[_PD_DATA + n] | reply[_PD_DATA + n + 1] << 8
            if frmw:
                self.dc_time = _U64.unpack_from(reply, frmw)[0]
        return wkc

    # ---- 4 supervision: SOEM simple_test's ecatcheck -------------------------------------
    def diagnose(self, wkc: int) -> WkcDiagnosis:
        """Which slaves explain a working counter below ``expected_wkc``."""
        self.read_state()
        missing = tuple(s.position for s in self.slaves if s.state == NONE_STATE)
        bad = tuple((s.position, s.state, s.al_status_code) for s in self.slaves
                    if s.state != NONE_STATE and s.state != OP)
        return WkcDiagnosis(wkc, self.expected_wkc, missing, bad)

    def check(self) -> list[str]:
        """One pass of simple_test's ecatcheck: ack errors, ask SAFE_OP slaves for OP, find lost
        slaves again. Returns the messages it would print."""
        msgs: list[str] = []
        self.read_state()
        all_op = True
        for s in self.slaves:
            if s.state == OP and not s.is_lost:
                continue
            all_op = all_op and s.state == OP
            if s.state == SAFEOP | AL_ERROR:
                msgs.append(f"ERROR : slave {s.position} is in SAFE_OP + ERROR, attempting ack.")
                s.state = SAFEOP | AL_ERROR
                s.write_state()
            elif s.state == SAFEOP:
                msgs.append(f"WARNING : slave {s.position} is in SAFE_OP, change to OPERATIONAL.")
                s.state = OP
                s.write_state()
            elif s.state > NONE_STATE:
                if self.reconfig_slave(s):
                    msgs.append(f"MESSAGE : slave {s.position} reconfigured")
            elif not s.is_lost:
                s.is_lost = True
                msgs.append(f"ERROR : slave {s.position} lost")
            if s.is_lost:
                if s.state != NONE_STATE:
                    s.is_lost = False
                    msgs.append(f"MESSAGE : slave {s.position} found")
                elif self.recover_slave(s):
                    msgs.append(f"MESSAGE : slave {s.position} recovered")
        if all_op:
            msgs.append("OK : all slaves resumed OPERATIONAL.")
        return msgs

    def recover_slave(self, s: Slave) -> bool:
        """A lost slave answers again at its position: re-address it if it lost its address."""
        wkc, raw = self._ap(Command.APRD, s.position, REG_STADR, 2)
        if wkc != 1:
            return False
        if _U16.unpack(raw)[0] != s.config_address:
            self._ap(Command.APWR, s.position, REG_STADR, _U16.pack(s.config_address))
        s.is_lost = False
        self._statecheck_slave(s, s.state, 0)
        return True

    def reconfig_slave(self, s: Slave) -> bool:
        """Back to INIT, SMs and FMMUs rewritten, up to SAFE_OP (SOEM's ecx_reconfig_slave)."""
        adr = s.config_address
        self._fp(Command.FPWR, adr, REG_ALCTL, _U16.pack(INIT | AL_ERROR))
        if self._statecheck_slave(s, INIT, 2000) != INIT:
            return False
        self._fp(Command.FPWR, adr, REG_ALCTL, _U16.pack(PREOP | AL_ERROR))
        if self._statecheck_slave(s, PREOP, 2000) != PREOP:
            return False
        self._map_sm(s)
        for i, f in enumerate(s.fmmus):
            self._fp(Command.FPWR, adr, REG_FMMU0 + 16 * i, f.pack())
        self._fp(Command.FPWR, adr, REG_ALCTL, _U16.pack(SAFEOP))
        return self._statecheck_slave(s, SAFEOP, 2000) == SAFEOP

    # ---- convenience: the whole bring-up -------------------------------------------------
    def bring_up(self, dc: bool = True, cycles_to_op: int = 20) -> int:
        """config_init, config_map, config_dc, SAFE_OP, then OP while exchanging process data
        (simple_test's sequence). Returns the IO map size; raises with the state of every slave
        that did not make it."""
        if self.config_init() <= 0:
            raise MasterError("no slaves found: BRD 0x0000 returned working counter 0")
        size = self.config_map()
        if dc:
            self.config_dc()
        if self.state_check(SAFEOP, 50_000) != SAFEOP:
            raise MasterError("not every slave reached SAFE_OP: " + self._states_text())
        self.state = OP
        self.send_processdata()
        self.receive_processdata()
        self.write_state()
        for _ in range(cycles_to_op):
            self.send_processdata()
            self.receive_processdata()
            if self.state_check(OP, 5_000) == OP:
                return size
        raise MasterError("not every slave reached OP: " + self._states_text())

    def _states_text(self) -> str:
        return ", ".join(f"slave {s.position} ({s.name}) {state_name(s.state)} code "
                         f"0x{s.al_status_code:04X}" for s in self.slaves)

    def run_cyclic(self, cycles: int, period_ns: int = 1_000_000, on_cycle=None, wait=None):
        """Exchange process data every ``period_ns`` inside robocourse.rt's periodic loop.

        ``on_cycle(master, k, wkc)`` runs after each exchange (write outputs there). Returns
        (LoopResult with latency statistics, list of (cycle, WkcDiagnosis) for short cycles).
        """
        faults: list[tuple[int, WkcDiagnosis]] = []

        def cycle(tick) -> None:
            self.send_processdata()
            wkc = self.receive_processdata()
            if wkc < self.expected_wkc:
                faults.append((tick.iteration,
                               self.diagnose(wkc)))
            if on_cycle is not None:
                on_cycle(self, tick.iteration, wkc)

        result = PeriodicLoop(period_ns, cycles, wait).run(cycle)
        return result, faults

