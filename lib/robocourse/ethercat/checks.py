"""Checks for chapter 5's EtherCAT exercises (solutions/05_hardware_drivers_exercises.ipynb): inputs,
schemas, sub-tests. The judge side only (hidden from the grading sandbox); the probes are in
:mod:`robocourse.ethercat.probes`.

- ``ch05.fprd_frame``: an FPRD frame built by hand, byte for byte, for fresh station addresses,
  registers, lengths and indexes; each layer (Ethernet header, EtherCAT header, the datagram,
  the padding) is a sub-test, compared with the reference's layout field by field, named as
  Wireshark names them.
- ``ch05.expected_wkc``: the working counter of datagrams over random bus layouts (half with a
  cut cable); the truth is what the simulated slaves count once the SOEM-shaped master brought
  the bus to OP. Broadcast, addressed and logical commands and registers a slave lacks are
  scored apart.
- ``ch05.cia402_enable``: a controlword rule run cycle by cycle against a :class:`Cia402Drive`
  in OP on a simulated bus, from Switch on disabled, Ready to switch on, Switched on and
  Fault, each once with a plain statusword and once with manufacturer bits set; a stuck run
  is reported with the state, the controlword written there and the command that was needed.
"""

from __future__ import annotations

import json

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import Any, Call, Dict, Hex, Int, List, Number, OneOf, Str

from . import probes

# --- ch05.fprd_frame -------------------------------------------------------------------------------


def _fprd_inputs(rng):
    cases = [[0x1001, 0x0130, 2, 0]]       # AL status of the first slave, as SOEM reads it
    for _ in range(9):
        cases.append([int(rng.integers(0x1000, 0x10000)), int(rng.integers(0, 0x1000)),
                      int(rng.integers(1, 61)), int(rng.integers(0, 256))])
    cases.append([int(rng.integers(0x1000, 0x10000)), int(rng.integers(0, 0x1000)), 40, int(rng.integers(0, 256))])
    return {"cases": cases}


def _want(case) -> bytes:
    from .frames import Command, Frame, datagram, encode_frame

    station, reg, length, idx = case
    return encode_frame(Frame([datagram(Command.FPRD, station, reg, length, idx)]), pad=True)


def _frames(inputs, outputs):
    """(call text, the student's bytes, the reference's bytes) per case; the rest as problems."""
    f = Failures()
    frames = []
    for case, got in zip(inputs["cases"], outputs["frames"], strict=True):
        station, reg, length, idx = case
        text = f"fprd_frame(0x{station:04X}, 0x{reg:04X}, {length}, {idx})"
        if "raised" in got:
            f.add(f"{text} raised {got['raised']}: {got['message']}")
        elif "hex" not in got:
            f.add(f"{text} must return bytes, got {got['type']}")
        else:
            frames.append((text, got["hex"], _want(case), length))
    return f, frames


def _diff(raw: bytes, want: bytes, fields) -> list[str]:
    return [f"{name} at bytes {lo}..{hi - 1}: got {raw[lo:hi].hex(' ') or 'nothing'}, expected {want[lo:hi].hex(' ')}"
            for name, lo, hi in fields if raw[lo:hi] != want[lo:hi]]


def _fprd_layer(fields_of, rule: str):
    def judge(inputs, outputs):
        f, frames = _frames(inputs, outputs)
        for text, raw, want, _length in frames:
            wrong = _diff(raw, want, fields_of(want))
            if wrong:
                f.add(f"{text}: " + "; ".join(wrong) + f" ({rule})")
        return f.done("")
    return judge


def _eth_fields(want):
    return [("destination MAC", 0, 6), ("source MAC", 6, 12), ("EtherType", 12, 14)]


def _ecat_fields(want):
    return [("EtherCAT header (length | type << 12)", 14, 16)]


def _datagram_fields(want):
    n = int.from_bytes(want[22:24], "little") & 0x07FF
    return [("ecat.cmd", 16, 17), ("ecat.idx", 17, 18), ("ecat.adp (station address)", 18, 20),
            ("ecat.ado (register)", 20, 22), ("ecat.len (length | flags)", 22, 24), ("ecat.int (IRQ)", 24, 26),
            ("data (zeros for a read)", 26, 26 + n), ("ecat.cnt (working counter)", 26 + n, 28 + n)]


def _fprd_padding(inputs, outputs):
    f, frames = _frames(inputs, outputs)
    for text, raw, want, length in frames:
        end = 28 + length
        if len(raw) != len(want):
            f.add(f"{text} is {len(raw)} bytes, expected {len(want)}: 14 Ethernet + 2 EtherCAT header + 10 datagram "
                  f"header + {length} data + 2 WKC = {end}" + (", padded with zeros to the 60-byte Ethernet minimum"
                                                              if end < 60 else ", no padding needed past 60 bytes"))
        elif raw[end:] != want[end:]:
            f.add(f"{text}: the padding after byte {end - 1} must be zeros, got {raw[end:end + 8].hex(' ')}...")
    return f.done("")


register("ch05.fprd_frame", uses=("fprd_frame",), probe=probes.fprd_probe, inputs=_fprd_inputs, time_limit=20,
         references=("robocourse.ethercat.frames:encode_frame", "robocourse.ethercat.frames:frame_bytes",
                     "robocourse.ethercat.frames:datagram"),
         schema=Dict(frames=List(OneOf(Dict(hex=Hex(max_bytes=4096)), Dict(raised=Str(), message=Str()),
                                       Dict(type=Str(max_len=200))), length="cases")),
         subtests=[SubTest("Ethernet header: ff:ff:ff:ff:ff:ff, 01:01:01:01:01:01, EtherType 0x88A4 big-endian", 0.5,
                           _fprd_layer(_eth_fields, "EtherType is big-endian, as every EtherType")),
                   SubTest("EtherCAT header: datagrams' length | type 1 << 12, little-endian", 0.5,
                           _fprd_layer(_ecat_fields, "the length of all datagrams: 10 header + data + 2 WKC")),
                   SubTest("the datagram: cmd 4, idx, ADP, ADO, len (more bit clear), IRQ 0, zero data, WKC 0", 0.5,
                           _fprd_layer(_datagram_fields, "every field little-endian; one datagram: bit 15 of len "
                                                         "clear")),
                   SubTest("padded with zeros to the 60-byte Ethernet minimum", 0.5, _fprd_padding)])


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
        if connected < n:
            # the first slave past the cut has a DC unit and process data: every kind of datagram
            # (broadcast, addressed, logical, DC registers) then counts differently with the cut
            names[connected] = "RC-Servo"
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
               {"cmd": "APRW", "adp": (-int(rng.integers(0, n))) & 0xFFFF, "ado": 0x0012, "length": 2},
               {"cmd": "FPRD", "adp": int(rng.choice([s["station"] for s in slaves])), "ado": 0x0130, "length": 2},
               {"cmd": "FPWR", "adp": 0x1001 + n + int(rng.integers(0, 5)), "ado": 0x0012, "length": 2},
               {"cmd": "FPRW", "adp": int(rng.choice([s["station"] for s in slaves])), "ado": 0x0012, "length": 2},
               {"cmd": "FPRD", "adp": dc_station, "ado": 0x0910, "length": 4},
               {"cmd": "LRW", "logical": 0, "length": image},
               {"cmd": "LRD", "logical": 0, "length": image},
               {"cmd": "LWR", "logical": 0, "length": image}]
        if no_dc is not None:
            dgs.append({"cmd": "FPRD", "adp": no_dc, "ado": 0x0910, "length": 4})
        if connected < n:  # the slave just past the cut, addressed and asked for its DC time
            past = 0x1001 + connected
            dgs += [{"cmd": "FPRD", "adp": past, "ado": 0x0130, "length": 2},
                    {"cmd": "FPRD", "adp": past, "ado": 0x0910, "length": 4}]
        buses.append({"slaves": slaves, "connected": connected, "datagrams": dgs})
    return {"buses": buses}


_TRUTH: dict[str, list[int]] = {}


def simulated_wkcs(layout) -> list[int]:
    """The working counters our simulated slaves return for a layout's datagrams (grader side).

    The bus is brought to OP by the master (stations 0x1001.., outputs then inputs in the
    logical image from 0, as SOEM maps them); then the cable is cut after ``connected`` slaves
    and each datagram is sent in a frame of its own. Memoised: the sub-tests share one run.
    """
    key = json.dumps(layout, sort_keys=True)
    if key in _TRUTH:
        return _TRUTH[key]
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
            if d["ado"] == 0x0012 and cmd in (Command.BWR, Command.BRW, Command.FPWR, Command.FPRW, Command.APRW):
                dg.data[:] = bytes(2)          # alias 0: harmless (the alias is not activated)
        reply = bus.process(frame_bytes([dg]))
        out.append(decode_frame(reply).datagrams[0].wkc if reply is not None else 0)
    if len(_TRUTH) > 64:
        _TRUTH.clear()
    _TRUTH[key] = out
    return out


def _describe(d) -> str:
    if "logical" in d:
        return f"{d['cmd']} of the whole process image ({d['length']} bytes from logical 0)"
    return f"{d['cmd']} adp=0x{d['adp']:04X} ado=0x{d['ado']:04X} len {d['length']}"


def _kind(d) -> str:
    if "logical" in d:
        return "logical"
    if 0x0900 <= d["ado"] < 0x0A00:
        return "dc"
    return "broadcast" if d["cmd"].startswith("B") else "addressed"


def _wkc_kind(kind: str, rule: str):
    def judge(inputs, outputs):
        f = Failures()
        right = total = 0
        for b, (layout, got) in enumerate(zip(inputs["buses"], outputs["buses"], strict=True)):
            if len(got) != len(layout["datagrams"]):
                raise CheckFailed(f"bus {b}: {len(layout['datagrams'])} datagrams were asked, {len(got)} answers came "
                                  "back")
            truth = simulated_wkcs(layout)
            names = " - ".join(s["name"] for s in layout["slaves"])
            cut = "" if layout["connected"] == len(layout["slaves"]) else \
                f", cable cut after slave {layout['connected']}"
            for d, want, rec in zip(layout["datagrams"], truth, got, strict=True):
                if _kind(d) != kind:
                    continue
                total += 1
                if "raised" in rec:
                    f.add(f"bus {b} ({names}{cut}): {_describe(d)} raised {rec['raised']}: {rec['message']}")
                elif rec["value"] != want:
                    f.add(f"bus {b} ({names}{cut}): {_describe(d)} -> {rec['value']!r}, the slaves count {want} ({rule})")
                else:
                    right += 1
        return f.done(f"{right}/{total} match the simulated slaves")
    return judge


register("ch05.expected_wkc", uses=("expected_wkc",), probe=probes.wkc_probe, inputs=_wkc_inputs, time_limit=30,
         schema=Dict(buses=List(List(Call(Number(finite=False)), max_len=50), length="buses")),
         subtests=[SubTest("broadcast commands: every connected slave counts (read 1, write 1, read-write 3)", 0.5,
                           _wkc_kind("broadcast", "Bxx reach every slave before the cut; RD 1, WR 1, RW 1 + 2")),
                   SubTest("addressed commands: the one slave at that position or station, 0 if none", 0.5,
                           _wkc_kind("addressed", "APxx: position (-adp) & 0xFFFF; FPxx: the configured station; "
                                                  "none there or past the cut: 0")),
                   SubTest("logical commands: per slave whose mapped data they read or write", 0.5,
                           _wkc_kind("logical", "LRD: 1 per slave with inputs; LWR: 1 per slave with outputs; "
                                                "LRW: 2 per slave with outputs + 1 per slave with inputs")),
                   SubTest("registers a slave lacks count nothing (DC registers on an ESC without DC)", 0.5,
                           _wkc_kind("dc", "0x0900-0x09FF exist only on an ESC with a DC unit"))])


# --- ch05.cia402_enable ----------------------------------------------------------------------------

#: manufacturer-specific / warning bits a real drive may set (outside every state mask 0x6F)
NOISE_BITS = (0x0080, 0x0100, 0x0800, 0x1000, 0x4000, 0x8000)
STARTS = ("switch on disabled", "ready to switch on", "switched on", "fault")
#: what each state needs written to move on toward Operation enabled (the judge's key)
_NEEDED = {"switch on disabled": "shutdown (0x0006)", "ready to switch on": "switch on (0x0007)",
           "switched on": "enable operation (0x000F)", "operation enabled": "enable operation (0x000F), held",
           "fault": "a fault reset: 0x0080 after a controlword without bit 7 (a rising edge of bit 7)",
           "quick stop active": "disable voltage (0x0000), then shutdown",
           "fault reaction active": "nothing new: the drive is reacting; it reports Fault next",
           "not ready": "nothing new: the drive is starting"}


def _cia_inputs(rng):
    runs = []
    for noisy in (False, True):
        for start in STARTS:
            noise = int(sum(b for b in NOISE_BITS if rng.random() < 0.5)) | NOISE_BITS[int(rng.integers(0, 6))] \
                if noisy else 0
            runs.append({"start": start, "noise": noise,
                         "error_code": int(rng.choice([0x2310, 0x3220, 0x4310, 0x7305]))})
    return {"runs": runs}


_WORD = Int(lo=0, hi=0xFFFF)
_CIA_SCHEMA = Dict(runs=List(Dict(start=Str(choices=STARTS), noise=_WORD,
                                  trace=List(Dict(statusword=_WORD, shown=_WORD, controlword=Call(Any(max_items=50))),
                                             min_len=1, max_len=probes.CYCLES),
                                  final_statusword=_WORD, error_code=_WORD), length="runs"))


def _cw(rec) -> int | None:
    v = rec.get("value")
    return v if isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 0xFFFF else None


def _path(states, cws, most: int = 5) -> str:
    """The run as 'state, you wrote 0x...' steps, repeats folded: 'fault, you wrote 0x000F (x40)'."""
    steps: list[list] = []
    for state, cw in zip(states, cws):
        if steps and steps[-1][:2] == [state, cw]:
            steps[-1][2] += 1
        else:
            steps.append([state, cw, 1])
    shown = [f"{st}, you wrote 0x{cw:04X}" + (f" (x{n})" if n > 1 else "") for st, cw, n in steps[:most]]
    return " -> ".join(shown) + (" -> ..." if len(steps) > most else "")


def _run_problem(run) -> tuple[str, int | None]:
    """(what went wrong in this run or "", the cycle operation enabled was first reported)."""
    from .devices import FAULT, OPERATION_ENABLED, cia402_state

    start, trace = run["start"], run["trace"]
    label = f"from {start}" + (f" (manufacturer bits 0x{run['noise']:04X} set in the statusword)" if run["noise"] else "")
    last = trace[-1]
    if "raised" in last["controlword"]:
        return (f"{label}: controlword_for(0x{last['shown']:04X}) raised {last['controlword']['raised']}: "
                f"{last['controlword']['message']}", None)
    if _cw(last["controlword"]) is None:
        return (f"{label}: controlword_for(0x{last['shown']:04X}) returned {last['controlword'].get('value')!r}; a "
                "controlword is an int 0..0xFFFF", None)
    states = [cia402_state(t["statusword"]) for t in trace]
    cws = [_cw(t["controlword"]) for t in trace]
    first = states.index(OPERATION_ENABLED) if OPERATION_ENABLED in states else None
    path = _path(states, cws)
    if first is None:
        stuck = states[-1]
        n = next((k for k in range(len(states)) if all(s == stuck for s in states[k:])), 0)
        written = sorted({c for s, c in zip(states[n:], cws[n:])})
        shown = ", ".join(f"0x{c:04X}" for c in written)
        why = ""
        if stuck == FAULT and all(c & 0x80 for c in written) and n > 0 and cws[n - 1] is not None and cws[n - 1] & 0x80:
            why = "; bit 7 was already set in your previous controlword, so there was no rising edge"
        elif stuck == FAULT and written and all(c & 0x80 for c in written):
            why = "; bit 7 stayed set in every controlword, so only the first could be a rising edge"
        return (f"{label}: stuck in {stuck} (statusword 0x{trace[-1]['statusword']:04X}, shown to you as "
                f"0x{trace[-1]['shown']:04X}) for the last {len(states) - n} cycles; you wrote {shown} there{why}. "
                f"{stuck.capitalize()} needs {_NEEDED.get(stuck, '?')}. Path: {path}", None)
    if first > 12:
        return (f"{label}: operation enabled only after {first} cycles; each transition takes one cycle (at most 4, "
                f"plus the fault reset): {path}", first)
    later = states[first:] + [cia402_state(run["final_statusword"])]
    if any(s != OPERATION_ENABLED for s in later):
        k = first + next(i for i, s in enumerate(later) if s != OPERATION_ENABLED)
        fell_to = later[k - first]
        written = cws[k - 1] if k - 1 < len(cws) else cws[-1]
        return (f"{label}: reached operation enabled, then you wrote 0x{written:04X} and the drive fell to {fell_to}: "
                "in operation enabled keep writing enable operation (0x000F)", first)
    if start == "fault" and run["error_code"] != 0:
        return (f"{label}: the drive's error code is still 0x{run['error_code']:04X}: a fault reset is a rising edge "
                "of bit 7 (0x0080)", first)
    return "", first


def _cia_starts(starts, *, hold: bool = False):
    """Judge the plain-statusword runs from ``starts`` (reaching operation enabled, or with
    ``hold`` only staying there once reached)."""
    def judge(inputs, outputs):
        f = Failures()
        summary = []
        reached = 0
        for run in outputs["runs"]:
            if run["start"] not in starts or run["noise"]:
                continue
            problem, first = _run_problem(run)
            reached += first is not None
            fell = "then you wrote" in problem
            if hold:
                if fell:
                    f.add(problem)
            elif problem and not fell:
                f.add(problem)
            elif first is not None:
                summary.append(f"{run['start']}: {first} cycles")
        if hold and not reached:
            f.add("no run reached operation enabled, so holding it was never shown; fix the transitions first")
        return f.done(", ".join(summary))
    return judge


def _cia_masks(inputs, outputs):
    """A run with manufacturer bits set must go exactly as its plain twin went: a rule that reads
    the state through the masks writes the same controlwords."""
    f = Failures()
    plain = {run["start"]: run for run in outputs["runs"] if not run["noise"]}
    shown = 0
    for run in outputs["runs"]:
        twin = plain.get(run["start"])
        if not run["noise"] or twin is None or _run_problem(twin)[1] is None:
            continue  # only where the plain run reached operation enabled: there the rule is shown to work
        shown += 1
        for a, b in zip(twin["trace"], run["trace"], strict=False):
            if _cw(a["controlword"]) != _cw(b["controlword"]) or "raised" in b["controlword"]:
                got = b["controlword"].get("raised") or (f"0x{_cw(b['controlword']):04X}" if _cw(b["controlword"])
                                                        is not None else repr(b["controlword"].get("value")))
                f.add(f"from {run['start']}: for statusword 0x{a['shown']:04X} ({cia402_name(a['statusword'])}) you "
                      f"wrote 0x{_cw(a['controlword']):04X}, but for 0x{b['shown']:04X}, the same state with "
                      f"manufacturer bits 0x{run['noise']:04X} set, you wrote {got}: decode the state with the masks "
                      "(sw & 0x4F, sw & 0x6F); real drives set other bits too")
                break
        else:
            if len(run["trace"]) != len(twin["trace"]):
                f.add(f"from {run['start']}: with manufacturer bits 0x{run['noise']:04X} set the run stopped after "
                      f"{len(run['trace'])} cycles: decode the state with the masks")
    if not shown:
        f.add("no run reached operation enabled, so nothing shows that your rule reads the state through the masks; "
              "fix the transitions first")
    return f.done("")


def cia402_name(statusword: int) -> str:
    from .devices import cia402_state

    return cia402_state(statusword)


register("ch05.cia402_enable", uses=("controlword_for",), probe=probes.cia_probe, inputs=_cia_inputs, time_limit=30,
         references=("robocourse.ethercat.ros2_control:next_controlword",), schema=_CIA_SCHEMA,
         subtests=[SubTest("from switch on disabled: shutdown, switch on, enable operation", 0.5,
                           _cia_starts(("switch on disabled",))),
                   SubTest("from ready to switch on and from switched on", 0.25,
                           _cia_starts(("ready to switch on", "switched on"))),
                   SubTest("from fault: a fault reset (rising edge of bit 7), then on to operation enabled", 0.5,
                           _cia_starts(("fault",))),
                   SubTest("holds operation enabled (keeps writing 0x000F)", 0.25,
                           _cia_starts(STARTS, hold=True)),
                   SubTest("decodes the state with the masks (manufacturer bits set)", 0.5,
                           _cia_masks)])
