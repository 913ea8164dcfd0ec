"""Chapter 5's EtherCAT answer bank (solutions/05_hardware_drivers_exercises.ipynb, exercises 1-3)."""

from robocourse.grading.bank import Answer, Exercise

NB = "05_hardware_drivers_exercises"

FPRD = Exercise(
    "ch05.fprd_frame", NB,
    right=[Answer("int.to_bytes into a bytearray", code='''
def fprd_frame(station, register, length, idx):
    out = bytearray(b"\\xff" * 6 + b"\\x01" * 6)
    out += (0x88A4).to_bytes(2, "big")
    out += (10 + length + 2 | 0x1000).to_bytes(2, "little")
    out += bytes([0x04, idx])
    for value in (station, register, length, 0):
        out += value.to_bytes(2, "little")
    out += bytes(length) + bytes(2)
    while len(out) < 60:
        out.append(0)
    return bytes(out)
''')],
    wrong=[
        Answer("EtherType little-endian", replace=[('(0x88A4).to_bytes(2, "big")', '(0x88A4).to_bytes(2, "little")')],
               score=1.5, property="EtherType 0x88A4 big-endian", says="EtherType at bytes 12..13"),
        Answer("header length counts itself", replace=[("(len(datagram) | 1 << 12)", "(len(datagram) + 2 | 1 << 12)")],
               score=1.5, property="the EtherCAT header holds the datagrams' length",
               says="EtherCAT header (length | type << 12)"),
        Answer("datagram fields big-endian", replace=[('struct.pack("<BBHHHH"', 'struct.pack(">BBHHHH"')],
               score=1.5, property="datagram fields little-endian", says="ecat.adp (station address)"),
        Answer("no padding", replace=[("    return frame + bytes(max(0, 60 - len(frame)))", "    return frame")],
               score=1.5, property="padded to 60 bytes", says="padded with zeros to the 60-byte Ethernet minimum"),
        Answer("the more-datagrams bit set", replace=[("idx, station, register, length, 0)",
                                                       "idx, station, register, length | 0x8000, 0)")],
               score=1.5, property="len's bit 15 clear for the only datagram", says="ecat.len (length | flags)"),
        Answer("APRD's command number", replace=[('struct.pack("<BBHHHH", 4,', 'struct.pack("<BBHHHH", 1,')],
               score=1.5, property="cmd 4 (FPRD)", says="ecat.cmd"),
        Answer("the library's encoder", code='''
from robocourse.ethercat.frames import Command, Frame, datagram, encode_frame


def fprd_frame(station, register, length, idx):
    return encode_frame(Frame([datagram(Command.FPRD, station, register, length, idx)]), pad=True)
''', property="written by the student", says="write it yourself"),
    ])

_WKC_PER = 'per = {"RD": 1, "WR": 1, "RW": 3}[cmd[-2:]]'

WKC = Exercise(
    "ch05.expected_wkc", NB,
    right=[Answer("a table per command", code='''
def expected_wkc(bus, datagram):
    reached = bus["slaves"][:bus["connected"]]
    cmd = datagram["cmd"]
    if cmd.startswith("L"):
        read = cmd in ("LRD", "LRW")
        write = cmd in ("LWR", "LRW")
        return sum((1 if read and s["inputs"] else 0) + ((2 if cmd == "LRW" else 1) if write and s["outputs"] else 0)
                   for s in reached)
    add = {"RD": 1, "WR": 1, "RW": 3}[cmd[-2:]]
    dc_register = 0x0900 <= datagram["ado"] <= 0x09FF
    if cmd.startswith("B"):
        targets = reached
    elif cmd.startswith("AP"):
        position = (0x10000 - datagram["adp"]) % 0x10000
        targets = reached[position:position + 1]
    else:
        targets = [s for s in reached if s["station"] == datagram["adp"]]
    return sum(add for s in targets if s["dc"] or not dc_register)
''')],
    wrong=[
        Answer("read-write counts 2", replace=[(_WKC_PER, 'per = {"RD": 1, "WR": 1, "RW": 2}[cmd[-2:]]')], score=1.0,
               property="a read-write adds 1 + 2", says="RW 1 + 2"),
        Answer("logical: one per slave with data", replace=[(
            '        reads = sum(1 for s in on if s["inputs"]) if cmd != "LWR" else 0\n'
            '        writes = sum(1 for s in on if s["outputs"]) if cmd != "LRD" else 0\n'
            '        return reads + (2 if cmd == "LRW" else 1) * writes',
            '        return sum(1 for s in on if s["inputs"] or s["outputs"])')],
               score=1.5, property="logical commands count per read and write", says="LRW: 2 per slave with outputs"),
        Answer("every ESC has DC registers", replace=[('        return slave["dc"] or not 0x0900 <= datagram["ado"] < 0x0A00',
                                                       "        return True")],
               score=1.5, property="memory a slave lacks adds nothing", says="exist only on an ESC with a DC unit"),
        Answer("the cut cable ignored", replace=[('    on = bus["slaves"][:bus["connected"]]', '    on = bus["slaves"]')],
               score=0.0, property="only the slaves before the cut see the frame", says="cable cut after slave"),
        Answer("auto-increment address not negated", replace=[('        k = (-datagram["adp"]) & 0xFFFF',
                                                               '        k = datagram["adp"]')],
               score=1.5, property="APxx addresses position (-adp) & 0xFFFF", says="(-adp) & 0xFFFF"),
    ])

_CW = ("    if statusword & 0x4F == 0x08:        # Fault: reset (a rising bit 7: the next state clears it)\n"
       "        return 0x0080\n")

CIA = Exercise(
    "ch05.cia402_enable", NB,
    right=[Answer("a table of masked states", code='''
TRANSITIONS = [(0x4F, 0x08, 0x0080), (0x4F, 0x40, 0x0006), (0x6F, 0x21, 0x0007), (0x6F, 0x23, 0x000F),
               (0x6F, 0x27, 0x000F)]


def controlword_for(statusword):
    for mask, value, controlword in TRANSITIONS:
        if statusword & mask == value:
            return controlword
    return 0x0000
''')],
    wrong=[
        Answer("no fault reset", replace=[(_CW, "")], score=1.5, property="a fault needs a reset (rising bit 7)",
               says="Fault needs a fault reset: 0x0080", never_says="Switch on disabled needs"),
        Answer("exact statuswords", code='''
def controlword_for(statusword):
    return {0x0208: 0x0080, 0x0240: 0x0006, 0x0231: 0x0007}.get(statusword, 0x000F)
''', score=1.5, property="the state decoded through the masks", says="decode the state with the masks"),
        Answer("switch on without shutdown", replace=[("        return 0x0006\n", "        return 0x0007\n")],
               score=1.0, property="Switch on disabled needs shutdown first", says="needs shutdown (0x0006)"),
        Answer("enable operation straight away", code='''
def controlword_for(statusword):
    if statusword & 0x4F == 0x08:
        return 0x0080
    return 0x000F
''', score=1.0, property="one transition per state", says="needs shutdown (0x0006)"),
        Answer("nothing written once enabled", replace=[("    return 0x000F                        # Switched on / "
                                                         "Operation enabled: enable operation",
                                                         "    return 0x000F if statusword & 0x6F == 0x23 else 0x0000")],
               score=1.75, property="operation enabled is held with 0x000F", says="keep writing enable operation"),
        Answer("bit 7 held in every controlword", code='''
def controlword_for(statusword):
    if statusword & 0x4F == 0x08:
        return 0x0080
    if statusword & 0x4F == 0x40:
        return 0x0086
    if statusword & 0x6F == 0x21:
        return 0x0087
    return 0x008F
''', score=0.0, property="a reset is an edge, not a level", says="Switch on disabled needs shutdown (0x0006)"),
        Answer("the library's next_controlword", code='''
from robocourse.ethercat.ros2_control import next_controlword


def controlword_for(statusword):
    return next_controlword(statusword, 0, True)
''', property="written by the student", says="write it yourself"),
    ])

EXERCISES = [FPRD, WKC, CIA]
