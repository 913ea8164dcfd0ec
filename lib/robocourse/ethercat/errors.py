"""The master's errors (pysoem raises its own; ours name the slave, the step and the value)."""


class MasterError(RuntimeError):
    """A bring-up step that failed; the message names the slave, the step and the value."""


class MailboxError(MasterError):
    """An SDO request to a slave without a mailbox (SII word 0x0019 mailbox size 0)."""


class SiiError(MasterError):
    """The SII EEPROM refused a read (word out of range, or the interface stayed busy)."""


class SdoError(MasterError):
    """A slave aborted an SDO transfer (pysoem.SdoError: slave, index, subindex, abort code)."""

    def __init__(self, slave: int, index: int, subindex: int, abort_code: int, desc: str) -> None:
        super().__init__(f"slave {slave}: SDO 0x{index:04X}:{subindex:02X} aborted with "
                         f"0x{abort_code:08X} ({desc})")
        self.slave_pos, self.index, self.subindex = slave, index, subindex
        self.abort_code, self.desc = abort_code, desc
