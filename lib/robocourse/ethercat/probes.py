"""The student-side half of chapter 5's EtherCAT checks: the probes that call the exercise's functions.

They run where the student's code runs (their kernel, or the grading sandbox) and return only
what came out; the expected frames, the working counters the simulated slaves return and the
state-machine judge are in :mod:`robocourse.ethercat.checks`, which the grading sandbox hides.
The CiA 402 probe runs the student's rule against a drive in OP on a simulated bus here, since
the rule is called once per cycle with the statusword the drive reported.
"""

from __future__ import annotations

from robocourse.grading.probes import call

CYCLES = 40  # cycles the CiA 402 rule is run for, from each start state


def fprd_probe(inputs, fprd_frame):
    """ch05.fprd_frame: each frame as hex (or what came instead)."""
    out = []
    for case in inputs["cases"]:
        try:
            value = fprd_frame(*case)
        except NotImplementedError:
            raise
        except Exception as exc:
            out.append({"raised": type(exc).__name__, "message": str(exc)[:300]})
            continue
        if isinstance(value, (bytes, bytearray, memoryview)):
            out.append({"hex": bytes(value)[:4096].hex()})
        else:
            out.append({"type": type(value).__name__})
    return {"frames": out}


def wkc_probe(inputs, expected_wkc):
    """ch05.expected_wkc: one call per datagram of each bus layout."""
    out = []
    for bus in inputs["buses"]:
        view = {"slaves": [dict(s) for s in bus["slaves"]], "connected": bus["connected"]}
        out.append([call(expected_wkc, view, dict(d)) for d in bus["datagrams"]])
    return {"buses": out}


def _drive_in_start_state(start: str, code: int):
    """A bus (coupler + CiA 402 drive) brought to OP, the drive in ``start``; (cycle, slave, drive)."""
    from .bus import Bus
    from .devices import (
        READY_TO_SWITCH_ON,
        SWITCHED_ON,
        Cia402Drive,
        Coupler,
        cia402_state,
        drive_inputs,
        drive_outputs,
    )
    from .master import Master

    clock = [0]
    drive = Cia402Drive()
    bus = Bus([Coupler(), drive], clock=lambda: clock[0])
    m = Master()
    m.open(bus)
    m.bring_up(dc=False)
    slave = m.slaves[1]

    def cycle(cw):
        pos = drive_inputs(slave.input)[1]
        slave.output = drive_outputs(cw, pos)
        clock[0] += 1_000_000
        m.send_processdata()
        return m.receive_processdata()

    # the start state is reached with the controlwords a master would write, each held until the
    # statusword (one cycle behind, as process data is) shows its state
    steps = {"switch on disabled": [], "ready to switch on": [(0x06, READY_TO_SWITCH_ON)],
             "switched on": [(0x06, READY_TO_SWITCH_ON), (0x07, SWITCHED_ON)],
             "fault": [(0x06, READY_TO_SWITCH_ON), (0x07, SWITCHED_ON), (0x0F, None)]}[start]
    cycle(0x00)
    cycle(0x00)
    for cw, want in steps:
        for _ in range(10):
            cycle(cw)
            if want is None or cia402_state(drive_inputs(slave.input)[0]) == want:
                break
    if start == "fault":
        drive.inject_fault(code)
        for _ in range(3):
            cycle(0x0F)
    return cycle, slave, drive


def cia_probe(inputs, controlword_for):
    """ch05.cia402_enable: ``controlword_for(statusword)`` each cycle against a drive in OP."""
    from .devices import drive_inputs

    runs = []
    for run in inputs["runs"]:
        cycle, slave, drive = _drive_in_start_state(run["start"], run["error_code"])
        trace = []
        for _ in range(CYCLES):
            sw = drive_inputs(slave.input)[0]
            rec = call(controlword_for, sw | run["noise"])
            trace.append({"statusword": sw, "shown": sw | run["noise"], "controlword": rec})
            value = rec.get("value")
            if "raised" in rec or not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 0xFFFF:
                break
            cycle(value)
        runs.append({"start": run["start"], "noise": run["noise"], "trace": trace,
                     "final_statusword": drive_inputs(slave.input)[0], "error_code": drive.error_code})
    return {"runs": runs}
