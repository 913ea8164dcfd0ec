"""The master's errors (pysoem raises its own; ours name the slave, the step and the value)."""


class MasterError(RuntimeError):
    """A bring-up step that failed; the message names the slave, the step and the value."""


class MailboxError(MasterError):
    """An SDO request to a slave without a mailbox (SII word 0x0019 mailbox size 0)."""


class SiiError(MasterError):
    """The SII EEPROM refused a read (word out of range, or the interface stayed busy)."""
