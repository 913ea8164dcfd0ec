"""Checks for chapter 5's EtherCAT exercises (solutions/05_hardware_drivers_exercises.ipynb), as probe + judge.

- ``ch05.fprd_frame``: an FPRD frame built by hand, byte for byte, for fresh station addresses,
  registers, lengths and indexes; the judge decodes it with :func:`frames.decode_frame` and
  compares every field with the reference's layout, then sends it through a simulated bus.
- ``ch05.expected_wkc``: the working counter of datagrams over random bus layouts (some with a
  cut cable); the judge builds each bus, brings it to OP with the SOEM-shaped master and sends
  the datagrams, so the truth is what the simulated slaves count.
- ``ch05.cia402_enable``: a controlword rule run cycle by cycle against a :class:`Cia402Drive`
  in OP on a simulated bus, from Switch on disabled, from Fault and from Quick stop active,
  with manufacturer bits set in the statusword; the judge reads the drive's states.
"""

from __future__ import annotations

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import number

# --- ch05.fprd_frame -------------------------------------------------------------------------------


def _fprd_inputs(rng):
    cases = [[0x1001, 0x0130, 2, 0]]       # AL status of the first slave, as SOEM reads it
    for _ in range(11):
        cases.append([int(rng.integers(0x1000, 0x10000)), int(rng.integers(0, 0x1000)),
                      int(rng.integers(1, 61)), int(rng.integers(0, 256))])
    return {"cases": cases}


def _fprd_probe(inputs, fprd_frame):
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
            out.append({"hex": bytes(value).hex()})
        else:
            out.append({"type": type(value).__name__})
    return out


def _field_diffs(got: bytes, want: bytes) -> list[str]:
    """Which fields of an FPRD frame differ, named as Wireshark names them."""
    fields = [("destination MAC", 0, 6), ("source MAC", 6, 12), ("EtherType", 12, 14),
              ("EtherCAT header (length | type << 12)", 14, 16), ("ecat.cmd", 16, 17), ("ecat.idx", 17, 18),
              ("ecat.adp (station address)", 18, 20), ("ecat.ado (register)", 20, 22),
              ("ecat.len (length | flags)", 22, 24), ("ecat.int (IRQ)", 24, 26)]
    n = int.from_bytes(want[22:24], "little") & 0x07FF
    fields += [("data (zeros for a read)", 26, 26 + n), ("ecat.cnt (working counter)", 26 + n, 28 + n),
               ("padding", 28 + n, len(want))]
    out = []
    for name, lo, hi in fields:
        if got[lo:hi] != want[lo:hi]:
            out.append(f"{name} at bytes {lo}..{hi - 1}: got {got[lo:hi].hex(' ') or 'nothing'}, "
                       f"expected {want[lo:hi].hex(' ')}")
    return out


@register("ch05.fprd_frame", weight=2, time_limit=20, uses=("fprd_frame",), probe=_fprd_probe, inputs=_fprd_inputs,
          references=("robocourse.ethercat.frames:encode_frame", "robocourse.ethercat.frames:frame_bytes",
                      "robocourse.ethercat.frames:datagram"))
def check_fprd_frame(inputs, outputs):
    """fprd_frame(station, register, length, idx) -> the Ethernet frame's bytes, exactly."""
    from .bus import Bus
    from .devices import Coupler, DigitalInputs
    from .frames import Command, Frame, FrameError, decode_frame, encode_frame, frame_bytes
    from .frames import datagram as make_datagram

    f = Failures()
    cases = inputs["cases"]
    if not isinstance(outputs, list) or len(outputs) != len(cases):
        raise CheckFailed(f"the probe expected {len(cases)} results, got {str(outputs)[:80]}")
    good = 0
    for (station, reg, length, idx), got in zip(cases, outputs):
        call = f"fprd_frame(0x{station:04X}, 0x{reg:04X}, {length}, {idx})"
        if not isinstance(got, dict) or "hex" not in got:
            if isinstance(got, dict) and "raised" in got:
                f.add(f"{call} raised {got['raised']}: {got.get('message', '')}")
            else:
                shown = got.get("type") if isinstance(got, dict) else repr(got)
                f.add(f"{call} must return bytes, got {shown}")
            continue
        try:
            raw = bytes.fromhex(str(got["hex"]))
        except ValueError:
            f.add(f"{call}: unreadable result")
            continue
        want = encode_frame(Frame([make_datagram(Command.FPRD, station, reg, length, idx)]), pad=True)
        if raw == want:
            good += 1
            continue
        try:
            decode_frame(raw)
            decoded = ""
        except FrameError as exc:
            decoded = f"; our decoder refuses it: {exc}"
        if len(raw) != len(want):
            f.add(f"{call} is {len(raw)} bytes, expected {len(want)} (14 Ethernet + 2 EtherCAT header + 10 "
                  f"datagram header + {length} data + 2 WKC, padded with zeros to 60){decoded}")
        else:
            f.add(f"{call}: " + "; ".join(_field_diffs(raw, want)) + decoded)
        if len(f.messages) >= 4:
            break
    if good == len(cases):
        # the first case on a wire: a coupler and a terminal at 0x1001, 0x1002 answer one FPRD
        bus = Bus([Coupler(), DigitalInputs()], clock=lambda: 0)
        for k in range(len(bus.slaves)):
            bus.process(frame_bytes([make_datagram(Command.APWR, -k, 0x0010, (0x1001 + k).to_bytes(2, "little"))]))
        reply = decode_frame(bus.process(bytes.fromhex(outputs[0]["hex"])))
        if reply.datagrams[0].wkc != 1:
            f.add(f"the FPRD to 0x1001 came back from a two-slave bus with WKC {reply.datagrams[0].wkc}, not 1")
    return f.done(f"{good} frames byte-exact (random stations, registers, lengths 1..60, padding); the bus "
                  "answered the first with WKC 1")


# --- ch05.expected_wkc -----------------------------------------------------------------------------

#: the devices a layout draws from: name, inputs bytes, outputs bytes, DC unit (ET1100) or not (ET1200)
DEVICES = {"RC1100": (0, 0, True), "RC1008": (1, 0, False), "RC2008": (0, 1, False), "RC-Servo": (13, 13, True)}


def _wkc_inputs(rng):
    buses = []
    for b in range(6):
        n = int(rng.integers(3, 8))
        names = ["RC1100"] + [str(rng.choice(["RC1008", "RC2008", "RC-Servo", "RC1008", "RC2008"]))
                              for _ in range(n - 1)]
        connected = n if b % 2 == 0 else int(rng.integers(1, n))
        slaves = [{"position": k, "name": name, "station": 0x1001 + k, "inputs": DEVICES[name][0],
                   "outputs": DEVICES[name][1], "dc": DEVICES[name][2]} for k, name in enumerate(names)]
        image = sum(s["outputs"] + s["inputs"] for s in slaves)
        dc_station = next((s["station"] for s in slaves[::-1] if s["dc"]), 0x1001)
        no_dc = next((s["station"] for s in slaves if not s["dc"]), None)
        dgs = [{"cmd": "BRD", "adp": 0, "ado": 0x0130, "length": 2},
               {"cmd": "BWR", "adp": 0, "ado": 0x0012, "length": 2},
               {"cmd": "BRW", "adp": 0, "ado": 0x0012, "length": 2},
               {"cmd": "BRD", "adp": 0, "ado": 0x0910, "length": 4},
               {"cmd": "APRD", "adp": (-int(rng.integers(0, n + 1))) & 0xFFFF, "ado": 0x0130, "length": 2},
               {"cmd": "FPRD", "adp": int(rng.choice([s["station"] for s in slaves])), "ado": 0x0130, "length": 2},
               {"cmd": "FPWR", "adp": 0x1001 + n + int(rng.integers(0, 5)), "ado": 0x0012, "length": 2},
               {"cmd": "FPRW", "adp": int(rng.choice([s["station"] for s in slaves])), "ado": 0x0012, "length": 2},
               {"cmd": "FPRD", "adp": dc_station, "ado": 0x0910, "length": 4},
               {"cmd": "LRW", "logical": 0, "length": image},
               {"cmd": "LRD", "logical": 0, "length": image},
               {"cmd": "LWR", "logical": 0, "length": image}]
        if no_dc is not None:
            dgs.append({"cmd": "FPRD", "adp": no_dc, "ado": 0x0910, "length": 4})
        buses.append({"slaves": slaves, "connected": connected, "datagrams": dgs})
    return {"buses": buses}


def _wkc_probe(inputs, expected_wkc):
    from robocourse.grading.probes import call

    out = []
    for bus in inputs["buses"]:
        view = {"slaves": bus["slaves"], "connected": bus["connected"]}
        out.append([call(expected_wkc, view, dict(d)) for d in bus["datagrams"]])
    return out


def simulated_wkcs(layout) -> list[int]:
    """The working counters our simulated slaves return for a layout's datagrams (grader side).

    The bus is brought to OP by the master (stations 0x1001.., outputs then inputs in the
    logical image from 0, as SOEM maps them); then the cable is cut after ``connected`` slaves
    and each datagram is sent in a frame of its own.
    """
    from .bus import Bus
    from .devices import Cia402Drive, Coupler, DigitalInputs, DigitalOutputs
    from .frames import Command, Datagram, datagram, decode_frame, frame_bytes
    from .master import Master

    make = {"RC1100": Coupler, "RC1008": DigitalInputs, "RC2008": DigitalOutputs, "RC-Servo": Cia402Drive}
    clock = [0]

    def now():
        clock[0] += 1_000_000
        return clock[0]

    bus = Bus([make[s["name"]]() for s in layout["slaves"]], clock=now)
    master = Master()
    master.open(bus)
    master.bring_up(dc=False)
    bus.cut_after(layout["connected"])
    out = []
    for d in layout["datagrams"]:
        cmd = Command[d["cmd"]]
        if "logical" in d:
            dg = Datagram.logical_cmd(cmd, d["logical"], d["length"])
            if cmd != Command.LRD:
                dg.data[:] = bytes(d["length"])
        else:
            dg = datagram(cmd, d["adp"], d["ado"], d["length"])
            if d["ado"] == 0x0012 and cmd in (Command.BWR, Command.BRW, Command.FPWR, Command.FPRW):
                dg.data[:] = bytes(2)          # alias 0: harmless (the alias is not activated)
        reply = bus.process(frame_bytes([dg]))
        out.append(decode_frame(reply).datagrams[0].wkc if reply is not None else 0)
    return out


def _describe(d) -> str:
    if "logical" in d:
        return f"{d['cmd']} of the whole process image ({d['length']} bytes from logical 0)"
    return f"{d['cmd']} adp=0x{d['adp']:04X} ado=0x{d['ado']:04X} len {d['length']}"


@register("ch05.expected_wkc", weight=2, time_limit=30, uses=("expected_wkc",), probe=_wkc_probe,
          inputs=_wkc_inputs)
def check_expected_wkc(inputs, outputs):
    """expected_wkc(bus, datagram) -> the working counter the datagram comes back with."""
    f = Failures()
    total = right = 0
    for b, (layout, got) in enumerate(zip(inputs["buses"], outputs)):
        truth = simulated_wkcs(layout)
        names = " - ".join(s["name"] for s in layout["slaves"])
        cut = "" if layout["connected"] == len(layout["slaves"]) else \
            f", cable cut after slave {layout['connected']}"
        for d, want, rec in zip(layout["datagrams"], truth, got):
            total += 1
            if "raised" in rec:
                f.add(f"bus {b} ({names}{cut}): {_describe(d)} raised {rec['raised']}: {rec.get('message', '')}")
                continue
            try:
                value = number(rec.get("value"))
            except TypeError:
                f.add(f"bus {b}: {_describe(d)} returned {str(rec.get('value'))[:40]!r}, not a number")
                continue
            if value != want:
                f.add(f"bus {b} ({names}{cut}): {_describe(d)} -> {value:g}, the slaves count {want}")
            else:
                right += 1
        if len(f.messages) >= 6:
            break
    return f.done(f"{right}/{total} working counters match the simulated slaves (6 random buses, 3 with a cut)")


# --- ch05.cia402_enable ----------------------------------------------------------------------------

#: manufacturer-specific / warning bits a real drive may set (outside every state mask 0x6F)
NOISE_BITS = (0x0080, 0x0100, 0x0800, 0x1000, 0x4000, 0x8000)
CYCLES = 40


def _cia_inputs(rng):
    starts = ["switch on disabled", "fault", "ready to switch on", "switched on", "fault"]
    noise = [int(sum(b for b in NOISE_BITS if rng.random() < 0.5)) for _ in starts]
    return {"starts": starts, "noise": noise, "error_codes": [int(rng.choice([0x2310, 0x3220, 0x4310, 0x7305]))
                                                                for _ in starts]}


def _cia_probe(inputs, controlword_for):
    """Run ``controlword_for(statusword)`` each cycle against a drive in OP (a simulated bus)."""
    from robocourse.grading.probes import call

    from .bus import Bus
    from .devices import Cia402Drive, Coupler, drive_inputs, drive_outputs
    from .master import Master

    runs = []
    for start, noise, code in zip(inputs["starts"], inputs["noise"], inputs["error_codes"]):
        clock = [0]

        def now(clock=clock):
            return clock[0]

        drive = Cia402Drive()
        bus = Bus([Coupler(), drive], clock=now)
        m = Master()
        m.open(bus)
        m.bring_up(dc=False)
        slave = m.slaves[1]

        def cycle(cw, slave=slave, clock=clock, m=m):
            pos = drive_inputs(slave.input)[1]
            slave.output = drive_outputs(cw, pos)
            clock[0] += 1_000_000
            m.send_processdata()
            return m.receive_processdata()

        # bring the drive to its start state with the controlwords a master would write, each
        # held until the statusword (one cycle behind, as process data is) shows its state
        from .devices import READY_TO_SWITCH_ON, SWITCHED_ON, cia402_state

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
        trace = []
        for _ in range(CYCLES):
            sw = drive_inputs(slave.input)[0]
            rec = call(controlword_for, sw | noise)
            trace.append({"statusword": sw, "shown": sw | noise, "controlword": rec})
            if "raised" in rec or not isinstance(rec.get("value"), int) or isinstance(rec.get("value"), bool):
                break
            cw = rec["value"]
            if not 0 <= cw <= 0xFFFF:
                break
            cycle(cw)
        runs.append({"start": start, "start_statusword": trace[0]["statusword"] if trace else None,
                     "trace": trace, "final_statusword": drive_inputs(slave.input)[0], "error_code": drive.error_code})
    return runs


@register("ch05.cia402_enable", weight=2, time_limit=30, uses=("controlword_for",), probe=_cia_probe,
          inputs=_cia_inputs, references=("robocourse.ethercat.ros2_control:next_controlword",))
def check_cia402_enable(inputs, runs):
    """controlword_for(statusword) takes a drive to Operation enabled (fault reset included) and keeps it there."""
    from .devices import FAULT, OPERATION_ENABLED, cia402_state

    f = Failures()
    summary = []
    for run in runs:
        start = run["start"]
        trace = run["trace"]
        if trace and start != "fault" and cia402_state(trace[0]["statusword"]) != start:
            raise RuntimeError(f"check error: the drive was set up in {cia402_state(trace[0]['statusword'])}, "
                               f"not {start}")
        if not trace:
            f.add(f"from {start}: no cycle ran")
            continue
        last = trace[-1]["controlword"]
        if "raised" in last:
            f.add(f"from {start}: controlword_for(0x{trace[-1]['shown']:04X}) raised {last['raised']}: "
                  f"{last.get('message', '')}")
            continue
        value = last.get("value")
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 0xFFFF:
            f.add(f"from {start}: controlword_for(0x{trace[-1]['shown']:04X}) returned {value!r}; a controlword is "
                  "an int 0..0xFFFF")
            continue
        states = [cia402_state(t["statusword"]) for t in trace]
        first = states.index(OPERATION_ENABLED) if OPERATION_ENABLED in states else None
        path = " -> ".join(f"{s} (cw 0x{t['controlword']['value']:04X})" for s, t in zip(states[:8], trace[:8]))
        if first is None:
            f.add(f"from {start} (statusword shown 0x{trace[0]['shown']:04X}, manufacturer bits set): never reached "
                  f"operation enabled in {len(trace)} cycles: {path}")
            continue
        if first > 12:
            f.add(f"from {start}: operation enabled only after {first} cycles; the transitions take one cycle each "
                  f"(at most 4, plus the fault reset): {path}")
        later = states[first:]
        if any(s != OPERATION_ENABLED for s in later) or cia402_state(run["final_statusword"]) != OPERATION_ENABLED:
            drop = next((s for s in later if s != OPERATION_ENABLED), cia402_state(run["final_statusword"]))
            f.add(f"from {start}: reached operation enabled, then fell to {drop}: in operation enabled keep "
                  "writing enable operation (0x000F)")
        if start == "fault" and FAULT in states[:1] and run["error_code"] != 0:
            f.add(f"from fault: the drive's error code is still 0x{run['error_code']:04X}: a fault reset is a rising "
                  "edge of bit 7 (0x0080)")
        summary.append(f"{start}: {first}")
    return f.done("operation enabled after " + ", ".join(summary) + " cycles, and held")
