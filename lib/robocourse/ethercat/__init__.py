"""robocourse.ethercat: a byte-exact simulated EtherCAT bus, a SOEM-shaped master, pcap.

Layers, bottom up: ``frames`` (the wire format), ``pcap`` (Wireshark files), ``sii`` (EEPROM
images), ``esc`` (a slave controller: registers, FMMUs, SyncManagers, AL state machine),
``dc`` (distributed clocks), ``devices`` (coupler, digital IO, CiA 402 drive), ``bus`` (the
chain with delays and injected faults), ``transport`` (in-process or raw Ethernet),
``master`` (SOEM's bring-up with pysoem's API), ``device_files`` (a slave from the user's own SII
image or vendor ESI XML), ``ros2_control`` (the
``robocourse/EthercatSystem`` hardware plugin in ethercat_driver_ros2's shape; importing this
package declares it with :mod:`robocourse.control.pluginlib`, as a plugin description would).

Two ways a drive tells a master its PDO layout, both mapped by a real SOEM (pysoem) in the
tests: ``Cia402Drive()`` has no mailbox and lists its PDOs in the SII TxPDO/RxPDO categories
(SOEM's ``ecx_map_sii``; real EL1008/EL2008 terminals work that way too), and
``Cia402Drive(mailbox=True)`` has a CoE mailbox with an object dictionary (expedited SDO
upload/download, aborts) whose 0x1C12/0x1C13 assignment SOEM reads by SDO
(``ecx_readPDOmap``), as it does on a real servo drive.
"""

from robocourse.control import pluginlib as _pluginlib

from .bus import Bus
from .devices import Cia402Drive, Coupler, DigitalInputs, DigitalOutputs
from .esc import BOOT, INIT, OP, PREOP, SAFEOP, Esc
from .frames import Command, Datagram, Frame, FrameError, decode_frame, encode_frame
from .master import Master, MasterError, Slave

__all__ = ["BOOT", "INIT", "OP", "PREOP", "SAFEOP", "Bus", "Cia402Drive", "Command", "Coupler",
           "Datagram", "DigitalInputs", "DigitalOutputs", "Esc", "Frame", "FrameError", "Master",
           "MasterError", "Slave", "decode_frame", "encode_frame"]

_pluginlib.register("robocourse/EthercatSystem", "robocourse.ethercat.ros2_control:EthercatSystem",
                    _pluginlib.HARDWARE_BASE)


def demo_bus(n_io: int = 1, drives: int = 1, coe: bool = False, **bus_kw) -> Bus:
    """Coupler, ``n_io`` pairs of digital input/output terminals, ``drives`` CiA 402 drives
    (with a CoE mailbox when ``coe``)."""
    slaves = [Coupler()]
    for _ in range(n_io):
        slaves += [DigitalInputs(), DigitalOutputs()]
    slaves += [Cia402Drive(mailbox=coe) for _ in range(drives)]
    return Bus(slaves, **bus_kw)
