"""Simulated slaves: a bus coupler, 8-channel digital input/output terminals, a CiA 402 drive.

They mirror Beckhoff's EK1100 (coupler, no process data, device emulation: AL status echoes
AL control), EL1008 and EL2008 (one 1-bit PDO per channel, one byte of process data on SM0)
and a servo drive with the CiA 402 profile (controlword/statusword state machine, CSP/CSV/CST
with the position/velocity/torque PDOs of the reference) driving a motor model.

Where we differ from the real terminals: our EL1008/EL2008-likes run a firmware state
machine (checked transitions, SM checks, SM watchdog drops to SAFE_OP) where the real ones use
device emulation; their PDI control word (0x0004: digital I/O, bit 8 clear) says so, and every
ESC takes device emulation from that word as a real one does (the coupler's 0x0D00 sets it). The drive comes in two builds: without a mailbox (its fixed PDO layout
in the SII TxPDO/RxPDO categories, mapped by SOEM's ``ecx_map_sii``) and with a CoE mailbox
(``mailbox=True``: an object dictionary 0x1000-0x1C13 + the 0x6000 objects it uses, expedited
SDO only, mapped by SOEM's SDO reads of 0x1C12/0x1C13). The vendor ID is ours, not Beckhoff's.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from .coe import CoeServer, OdEntry
from .esc import ET1100, ET1200, OP, Esc
from .sii import (
    FMMU_INPUTS,
    FMMU_OUTPUTS,
    SM_TYPE_INPUTS,
    SM_TYPE_MBX_IN,
    SM_TYPE_MBX_OUT,
    SM_TYPE_OUTPUTS,
    DeviceDescription,
    Pdo,
    PdoEntry,
    SyncManagerConfig,
)

VENDOR_ID = 0x00000A5C  # robocourse's simulated devices (not an ETG-assigned vendor)

# CiA 402 statusword states (value, mask) as the reference tests them
NOT_READY, SWITCH_ON_DISABLED, READY_TO_SWITCH_ON = "not ready", "switch on disabled", "ready to switch on"
SWITCHED_ON, OPERATION_ENABLED, QUICK_STOP_ACTIVE = "switched on", "operation enabled", "quick stop active"
FAULT_REACTION_ACTIVE, FAULT = "fault reaction active", "fault"
_SW = {NOT_READY: 0x0000, SWITCH_ON_DISABLED: 0x0040, READY_TO_SWITCH_ON: 0x0031,
       SWITCHED_ON: 0x0033, OPERATION_ENABLED: 0x0037, QUICK_STOP_ACTIVE: 0x0017,
       FAULT_REACTION_ACTIVE: 0x001F, FAULT: 0x0008}
SW_REMOTE = 0x0200
SW_TARGET_REACHED = 0x0400
MODE_CSP, MODE_CSV, MODE_CST = 8, 9, 10


# the reference's statusword tests, in order: (mask, value, state)
_STATE_TESTS = ((0x4F, 0x00, NOT_READY), (0x4F, 0x40, SWITCH_ON_DISABLED),
                (0x6F, 0x21, READY_TO_SWITCH_ON), (0x6F, 0x23, SWITCHED_ON),
                (0x6F, 0x27, OPERATION_ENABLED), (0x6F, 0x07, QUICK_STOP_ACTIVE),
                (0x4F, 0x0F, FAULT_REACTION_ACTIVE), (0x4F, 0x08, FAULT))


def cia402_state(statusword: int) -> str:
    """The CiA 402 state a statusword reports (the reference's masks)."""
    for mask, value, state in _STATE_TESTS:
        if statusword & mask == value:
            return state
    return NOT_READY


def _bit_pdos(base_pdo: int, base_obj: int, sm: int, what: str) -> tuple[Pdo, ...]:
    return tuple(Pdo(base_pdo + ch, sm, (PdoEntry(base_obj + 0x10 * ch, 1, 1, what, 0x0001),),
                     f"Channel {ch + 1}") for ch in range(8))


COUPLER = DeviceDescription(VENDOR_ID, 0x044C2C52, 0x00110000, "RC1100",
                            "RC1100 EtherCAT Coupler (sim)", "SystemBk", fmmus=(),
                            ebus_current_ma=-2000, pdi_control=0x0D00)
DIGITAL_INPUTS = DeviceDescription(
    VENDOR_ID, 0x03F03052, 0x00100000, "RC1008", "RC1008 8Ch. Dig. Input 24V (sim)", "DigIn",
    sms=(SyncManagerConfig(0x1000, 0x00, SM_TYPE_INPUTS),), fmmus=(FMMU_INPUTS,),
    txpdos=_bit_pdos(0x1A00, 0x6000, 0, "Input"), ebus_current_ma=90, pdi_control=0x0004)
DIGITAL_OUTPUTS = DeviceDescription(
    VENDOR_ID, 0x07D83052, 0x00100000, "RC2008", "RC2008 8Ch. Dig. Output 24V (sim)", "DigOut",
    sms=(SyncManagerConfig(0x0F00, 0x44, SM_TYPE_OUTPUTS),), fmmus=(FMMU_OUTPUTS,),
    rxpdos=_bit_pdos(0x1600, 0x7000, 0, "Output"), ebus_current_ma=110, pdi_control=0x0004)
_RX = (PdoEntry(0x6040, 0, 16, "Controlword", 0x0006), PdoEntry(0x607A, 0, 32, "Target position", 0x0004),
       PdoEntry(0x60FF, 0, 32, "Target velocity", 0x0004), PdoEntry(0x6071, 0, 16, "Target torque", 0x0003),
       PdoEntry(0x6060, 0, 8, "Modes of operation", 0x0002))
_TX = (PdoEntry(0x6041, 0, 16, "Statusword", 0x0006), PdoEntry(0x6064, 0, 32, "Position actual value", 0x0004),
       PdoEntry(0x606C, 0, 32, "Velocity actual value", 0x0004), PdoEntry(0x6077, 0, 16, "Torque actual value", 0x0003),
       PdoEntry(0x6061, 0, 8, "Modes of operation display", 0x0002))
DRIVE = DeviceDescription(
    VENDOR_ID, 0x00402001, 0x00010000, "RC-Servo", "RC-Servo CiA 402 drive (sim)", "Drive",
    sms=(SyncManagerConfig(0, 0x26, SM_TYPE_MBX_OUT, 0, 0), SyncManagerConfig(0, 0x22, SM_TYPE_MBX_IN, 0, 0),
         SyncManagerConfig(0x1100, 0x64, SM_TYPE_OUTPUTS), SyncManagerConfig(0x1180, 0x20, SM_TYPE_INPUTS)),
    fmmus=(FMMU_OUTPUTS, FMMU_INPUTS), rxpdos=(Pdo(0x1600, 2, _RX, "RxPDO"),),
    txpdos=(Pdo(0x1A00, 3, _TX, "TxPDO"),), pdi_control=0x0C08)
DRIVE_COE = DeviceDescription(
    VENDOR_ID, 0x00402002, 0x00010000, "RC-Servo-CoE", "RC-Servo CiA 402 drive with CoE (sim)",
    "Drive",
    sms=(SyncManagerConfig(0x1000, 0x26, SM_TYPE_MBX_OUT, 128),
         SyncManagerConfig(0x1080, 0x22, SM_TYPE_MBX_IN, 128),
         SyncManagerConfig(0x1100, 0x64, SM_TYPE_OUTPUTS), SyncManagerConfig(0x1180, 0x20, SM_TYPE_INPUTS)),
    fmmus=(FMMU_OUTPUTS, FMMU_INPUTS), rxpdos=(Pdo(0x1600, 2, _RX, "RxPDO"),),
    txpdos=(Pdo(0x1A00, 3, _TX, "TxPDO"),), pdi_control=0x0C08, mbx_protocols=0x0004,
    coe_details=0x05)
_DRIVE_OUT = struct.Struct("<HiihB")  # controlword, target pos, target vel, target torque, mode
_DRIVE_IN = struct.Struct("<HiihB")  # statusword, position, velocity, torque, mode display


class Coupler(Esc):
    """EK1100-like bus coupler: no process data; AL status echoes AL control."""

    def __init__(self, **kw) -> None:
        super().__init__(COUPLER, ET1100, port_descriptor=0x0B, **kw)   # PDI 0x0D00: bit 8, emulated


class DigitalInputs(Esc):
    """EL1008-like: 8 input channels, one byte at 0x1000 (SM0, read by the master)."""

    def __init__(self, **kw) -> None:
        super().__init__(DIGITAL_INPUTS, ET1200, port_descriptor=0x0A, **kw)
        self.inputs = 0  # bit n = channel n + 1

    def application(self, now_ns: float) -> None:
        self.mem[0x1000] = self.inputs & 0xFF


class DigitalOutputs(Esc):
    """EL2008-like: 8 output channels from one byte at 0x0F00 (SM0, written by the master).
    Outputs follow the process data only in OP; they drop to 0 when the slave leaves OP."""

    def __init__(self, **kw) -> None:
        super().__init__(DIGITAL_OUTPUTS, ET1200, port_descriptor=0x0A, **kw)
        self.outputs = 0
        self.updates = 0  # process-data values applied in OP
        self.values_seen: set[int] = set()

    def application(self, now_ns: float) -> None:
        if self.state == OP:
            self.outputs = self.mem[0x0F00]
            self.values_seen.add(self.outputs)
            self.updates += 1

    def safe_outputs(self) -> None:
        self.outputs = 0


@dataclass
class MotorModel:
    """A rigid motor + load: J dw/dt = tau - b w, position in encoder counts."""

    inertia: float = 2e-4  # kg m^2
    damping: float = 1e-3  # N m s/rad
    rated_torque: float = 1.0  # N m (0x6071/0x6077 are in 0.1 % of it)
    counts_per_rev: int = 1 << 17
    position: float = 0.0  # rad
    velocity: float = 0.0  # rad/s

    def step(self, torque: float, dt: float) -> None:
        acc = (torque - self.damping * self.velocity) / self.inertia
        self.velocity += acc * dt
        self.position += self.velocity * dt

    @property
    def counts(self) -> int:
        return int(round(self.position / (2 * math.pi) * self.counts_per_rev))

    def to_rad(self, counts: float) -> float:
        return counts * 2 * math.pi / self.counts_per_rev


class Cia402Drive(CoeServer, Esc):
    """A CiA 402 servo drive on SM2 (RxPDO 0x1600) / SM3 (TxPDO 0x1A00) with a motor.

    Controlword/statusword follow the CiA 402 state machine of the reference (shutdown 0x06,
    switch on 0x07, enable operation 0x0F, disable voltage, quick stop, fault reset on a rising
    bit 7). Modes 8 CSP (PD position loop), 9 CSV (velocity loop), 10 CST (torque in 0.1 %).
    A following error larger than ``following_error_window`` counts in CSP is a fault (0x8611).

    Quick stop (controlword 0x02 in Operation enabled) enters Quick stop active (sw & 0x6F == 0x07)
    and brakes as ``quick_stop_option_code`` (object 0x605A, CiA 402's values) says: 0 coast
    (disable the drive function), 1/5 the slow-down ramp ``profile_deceleration`` (0x6084),
    2/6 the quick-stop ramp ``quick_stop_deceleration`` (0x6085; rad/s^2 here, counts/s^2 in the
    objects), 3/7 and 4/8 at ``max_torque`` (the current limit; we have no voltage model, so
    4/8 brake like 3/7). With 0..4 the drive transits to Switch on disabled once stopped (at
    the earliest the cycle after it entered, so a master sees the state); with 5..8 it stays
    in Quick stop active, and enable operation (0x0F) returns to Operation enabled (CiA 402
    transition 16). Disable voltage leaves Quick stop active at once (transition 12).
    """

    def __init__(self, motor: MotorModel | None = None, *, kp: float = 40.0, kd: float = 0.6,
                 kv: float = 0.05, max_torque: float = 2.0,
                 following_error_window: int = 1 << 17, mailbox: bool = False,
                 quick_stop_option_code: int = 2, quick_stop_deceleration: float = 1000.0,
                 profile_deceleration: float = 200.0, **kw) -> None:
        for name, value in (("quick_stop_deceleration", quick_stop_deceleration),
                            ("profile_deceleration", profile_deceleration)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    math.isfinite(value) and value > 0):
                raise ValueError(f"{name}={value!r}: a deceleration must be a finite number of rad/s^2 > 0, "
                                 f"e.g. {name}=500.0")
        super().__init__(DRIVE_COE if mailbox else DRIVE, ET1100, port_descriptor=0x0F, **kw)
        self.quick_stop_option_code = 2
        self._set_quick_stop_option_code(quick_stop_option_code)
        self.quick_stop_deceleration = float(quick_stop_deceleration)
        self.profile_deceleration = float(profile_deceleration)
        self._stop_ref = 0.0          # the braking ramp's velocity reference (rad/s) in Quick stop active
        self._stop_entered = False    # True in the cycle Quick stop active was entered
        self._substep_s = 0.0         # the motor model's integration step this cycle (s)
        self.motor = motor or MotorModel()
        self.kp, self.kd, self.kv, self.max_torque = kp, kd, kv, max_torque
        self.following_error_window = following_error_window
        self.cia_state = SWITCH_ON_DISABLED
        self.mode_display = 0
        self.error_code = 0
        self.controlword = 0
        self.target_position = self.target_velocity = self.target_torque = 0
        self.torque = 0.0
        self._last_cw = 0
        self._last_ns: float | None = None
        self.od = self._object_dictionary()

    def _object_dictionary(self) -> dict[tuple[int, int], OdEntry]:
        """0x1000-0x1C13 and the 0x6000 objects this drive uses (CoE builds only)."""
        d = self.desc

        def const(v: int, size: int) -> OdEntry:
            return OdEntry(size, lambda: v)

        def setattr_(name: str):
            return lambda v: setattr(self, name, v)

        od = {(0x1000, 0): const(0x00020192, 4), (0x1018, 0): const(4, 1),
              (0x1018, 1): const(d.vendor_id, 4), (0x1018, 2): const(d.product_code, 4),
              (0x1018, 3): const(d.revision, 4), (0x1018, 4): const(d.serial, 4),
              (0x1C00, 0): const(len(d.sms), 1)}
        for i, sm in enumerate(d.sms):
            od[(0x1C00, i + 1)] = const(sm.sm_type, 1)
        for assign, pdos in ((0x1C12, d.rxpdos), (0x1C13, d.txpdos)):
            od[(assign, 0)] = const(len(pdos), 1)
            for k, p in enumerate(pdos):
                od[(assign, k + 1)] = const(p.index, 2)
                od[(p.index, 0)] = const(len(p.entries), 1)
                for j, e in enumerate(p.entries):
                    od[(p.index, j + 1)] = const(e.index << 16 | e.subindex << 8 | e.bitlen, 4)
        od.update({
            (0x6040, 0): OdEntry(2, lambda: self.controlword),
            (0x6041, 0): OdEntry(2, lambda: self.statusword),
            (0x6060, 0): OdEntry(1, lambda: self.mode_display, setattr_("mode_display"), True),
            (0x6061, 0): OdEntry(1, lambda: self.mode_display, None, True),
            (0x6064, 0): OdEntry(4, lambda: self.motor.counts, None, True),
            (0x6065, 0): OdEntry(4, lambda: self.following_error_window,
                                 setattr_("following_error_window")),
            (0x606C, 0): OdEntry(4, lambda: self._vel_counts(), None, True),
            (0x6077, 0): OdEntry(2, lambda: int(round(self.torque / self.motor.rated_torque * 1000)),
                                 None, True),
            (0x607A, 0): OdEntry(4, lambda: self.target_position, None, True),
            (0x603F, 0): OdEntry(2, lambda: self.error_code),
            (0x605A, 0): OdEntry(2, lambda: self.quick_stop_option_code, self._set_quick_stop_option_code, True),
            (0x6084, 0): OdEntry(4, lambda: self._rad_to_counts(self.profile_deceleration),
                                 self._set_decel("profile_deceleration")),
            (0x6085, 0): OdEntry(4, lambda: self._rad_to_counts(self.quick_stop_deceleration),
                                 self._set_decel("quick_stop_deceleration"))})
        return od

    def _set_quick_stop_option_code(self, code: int) -> None:
        if isinstance(code, bool) or not isinstance(code, int) or not 0 <= code <= 8:
            raise ValueError(f"quick_stop_option_code={code!r}: CiA 402 defines 0..8 (0 coast, 1-4 brake then "
                             "switch on disabled, 5-8 brake and stay in quick stop active); vendor codes < 0 "
                             "are not modelled; e.g. quick_stop_option_code=2 (the default)")
        self.quick_stop_option_code = code

    def _rad_to_counts(self, rad: float) -> int:
        return int(round(rad / (2 * math.pi) * self.motor.counts_per_rev))

    def _set_decel(self, name: str):
        def setter(counts: int) -> None:
            if counts <= 0:
                raise ValueError(f"{name}: {counts} counts/s^2 must be > 0")
            setattr(self, name, self.motor.to_rad(counts))

        return setter

    def _vel_counts(self) -> int:
        return int(round(self.motor.velocity / (2 * math.pi) * self.motor.counts_per_rev))

    def mailbox_received(self, data: bytes) -> None:
        """A CoE request in the write mailbox: take it, answer in the read mailbox."""
        self._release_write_mailbox()
        reply = self.coe_reply(data)
        if reply is not None:
            self.mailbox_send(reply)

    @property
    def statusword(self) -> int:
        sw = _SW[self.cia_state] | SW_REMOTE
        if self.cia_state == OPERATION_ENABLED and self.mode_display == MODE_CSP and \
                abs(self.target_position - self.motor.counts) < 100:
            sw |= SW_TARGET_REACHED
        return sw

    def inject_fault(self, error_code: int = 0x2310) -> None:
        """A drive fault (0x2310 = continuous over-current): fault reaction, then Fault."""
        self.error_code = error_code
        self.cia_state = FAULT_REACTION_ACTIVE

    def safe_outputs(self) -> None:
        if self.cia_state in (OPERATION_ENABLED, SWITCHED_ON, READY_TO_SWITCH_ON, QUICK_STOP_ACTIVE):
            self.cia_state = SWITCH_ON_DISABLED
        self.controlword = 0

    def _command(self, cw: int) -> None:
        s = self.cia_state
        rising_reset = cw & 0x80 and not self._last_cw & 0x80
        self._last_cw = cw
        if s == FAULT:
            if rising_reset:
                self.cia_state, self.error_code = SWITCH_ON_DISABLED, 0
            return
        if s == FAULT_REACTION_ACTIVE:
            return
        if cw & 0x82 == 0x00:  # disable voltage (transition 12 from quick stop active)
            self.cia_state = SWITCH_ON_DISABLED
        elif s == QUICK_STOP_ACTIVE:
            # only enable operation leaves it (transition 16), and only where the option code stays (5..8)
            if cw & 0x8F == 0x0F and self.quick_stop_option_code >= 5:
                if self.mode_display == MODE_CSP:
                    self.target_position = self.motor.counts
                self.cia_state = OPERATION_ENABLED
        elif cw & 0x86 == 0x02:  # quick stop
            if s == OPERATION_ENABLED:
                self.cia_state, self._stop_entered = QUICK_STOP_ACTIVE, True
                self._stop_ref = self.motor.velocity
            else:
                self.cia_state = SWITCH_ON_DISABLED
        elif cw & 0x87 == 0x06:  # shutdown
            if s in (SWITCH_ON_DISABLED, SWITCHED_ON, OPERATION_ENABLED, READY_TO_SWITCH_ON):
                self.cia_state = READY_TO_SWITCH_ON
        elif cw & 0x8F == 0x07:  # switch on / disable operation
            if s in (READY_TO_SWITCH_ON, OPERATION_ENABLED, SWITCHED_ON):
                self.cia_state = SWITCHED_ON
        elif cw & 0x8F == 0x0F:  # enable operation (from switched on; 3+4 from ready)
            if s in (SWITCHED_ON, READY_TO_SWITCH_ON, OPERATION_ENABLED):
                if s != OPERATION_ENABLED and self.mode_display == MODE_CSP:
                    self.target_position = self.motor.counts
                self.cia_state = OPERATION_ENABLED

    def _torque(self) -> float:
        m = self.motor
        if self.cia_state == QUICK_STOP_ACTIVE:
            return self._quick_stop_torque()
        if self.cia_state != OPERATION_ENABLED:
            return 0.0
        if self.mode_display == MODE_CSP:
            err = m.to_rad(self.target_position) - m.position
            t = self.kp * err - self.kd * m.velocity
        elif self.mode_display == MODE_CSV:
            t = self.kv * (m.to_rad(self.target_velocity) - m.velocity)
        elif self.mode_display == MODE_CST:
            t = self.target_torque / 1000.0 * m.rated_torque
        else:
            t = 0.0
        return max(-self.max_torque, min(self.max_torque, t))

    def _quick_stop_torque(self) -> float:
        """Braking torque in Quick stop active: follow a velocity ramp to 0, or brake at the torque limit."""
        m, code = self.motor, self.quick_stop_option_code
        if code == 0:
            return 0.0
        ref = 0.0 if code in (3, 4, 7, 8) else self._stop_ref
        # the torque that puts the velocity on the reference within this sub-step (a stiff velocity
        # loop), limited to max_torque: the current limit is what codes 3/4/7/8 brake with
        h = self._substep_s
        if h <= 0:
            return 0.0
        t = m.inertia * (ref - m.velocity) / h + m.damping * m.velocity
        return max(-self.max_torque, min(self.max_torque, t))

    def _advance_stop_ramp(self, dt: float) -> None:
        if self.quick_stop_option_code in (1, 5, 2, 6):
            decel = self.profile_deceleration if self.quick_stop_option_code in (1, 5) else \
                self.quick_stop_deceleration
            step = decel * dt
            r = self._stop_ref
            self._stop_ref = 0.0 if abs(r) <= step else r - math.copysign(step, r)
        else:
            self._stop_ref = 0.0

    def _quick_stop_done(self) -> bool:
        if self.quick_stop_option_code == 0:
            return True
        return self._stop_ref == 0.0 and abs(self.motor.velocity) < 1e-3

    def application(self, now_ns: float) -> None:
        if self.state == OP:
            cw, tp, tv, tt, mode = _DRIVE_OUT.unpack_from(self.mem, 0x1100)
            self.controlword = cw
            self.target_velocity, self.target_torque = tv, tt
            if mode in (MODE_CSP, MODE_CSV, MODE_CST):
                self.mode_display = mode
            self._command(cw)
            if self.cia_state == OPERATION_ENABLED:
                self.target_position = tp
        dt_total = 0.0 if self._last_ns is None else min((now_ns - self._last_ns) * 1e-9, 0.01)
        self._last_ns = now_ns
        m = self.motor
        steps = max(1, math.ceil(dt_total / 2.5e-4)) if dt_total > 0 else 0
        self._substep_s = dt_total / steps if steps else 0.0
        for _ in range(steps):
            if self.cia_state == QUICK_STOP_ACTIVE:
                self._advance_stop_ramp(dt_total / steps)
            self.torque = self._torque()
            m.step(self.torque, dt_total / steps)
        if self.cia_state == FAULT_REACTION_ACTIVE:
            self.cia_state = FAULT
            self.torque = 0.0
        elif self.cia_state == QUICK_STOP_ACTIVE:
            # the cycle it entered reports Quick stop active; after that, a completed stop transits to
            # Switch on disabled (option codes 0..4) or holds the state (5..8: the drive stays stopped)
            if not self._stop_entered and self.quick_stop_option_code <= 4 and self._quick_stop_done():
                self.cia_state = SWITCH_ON_DISABLED
                self.torque = 0.0
            self._stop_entered = False
        if (self.cia_state == OPERATION_ENABLED and self.mode_display == MODE_CSP
                and abs(self.target_position - m.counts) > self.following_error_window):
            self.inject_fault(0x8611)
        vel_counts = int(round(m.velocity / (2 * math.pi) * m.counts_per_rev))
        torque_pm = int(round(self.torque / m.rated_torque * 1000))
        _DRIVE_IN.pack_into(self.mem, 0x1180, self.statusword, _i32(m.counts), _i32(vel_counts),
                            max(-32768, min(32767, torque_pm)), self.mode_display)


def _i32(v: int) -> int:
    return max(-(1 << 31), min((1 << 31) - 1, v))


def drive_outputs(controlword: int, target_position: int = 0, target_velocity: int = 0,
                  target_torque: int = 0, mode: int = MODE_CSP) -> bytes:
    """The 13 RxPDO bytes of ``Cia402Drive`` (what a master writes in its output image)."""
    return _DRIVE_OUT.pack(controlword, target_position, target_velocity, target_torque, mode)


def drive_inputs(data: bytes) -> tuple[int, int, int, int, int]:
    """(statusword, position, velocity, torque, mode display) from the 13 TxPDO bytes."""
    return _DRIVE_IN.unpack_from(data, 0)
