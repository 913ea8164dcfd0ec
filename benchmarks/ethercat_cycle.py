"""Cost of one EtherCAT process-data cycle through the simulated bus, beside the wire.

    PYTHONPATH=lib python benchmarks/ethercat_cycle.py [--quick] [--no-veth]

Rows:
- in-process, N slaves (N = 1, 8, 64): one master cycle as ``send_processdata`` +
  ``receive_processdata`` does it: encode the LRW (+ FRMW of 0x0910 when the bus has a DC
  slave), pass the frame through every slave (FMMU mapping, working counter, application:
  IO bytes, CiA 402 state machine + motor model), encode the reply, decode it, copy the image
  back. The buses: N=1 one DO terminal; N=8 coupler, 3 DI, 3 DO, 1 drive; N=64 coupler,
  31 DI, 31 DO, 1 drive.
- veth + pysoem: SOEM's ``send_processdata`` + ``receive_processdata`` round trip in a
  network namespace, through a veth pair to our bus answering on an AF_PACKET socket in
  another process (coupler, DI, DO, drive). Root only; skipped otherwise.
- physical: the same frame on a real 100 Mbit/s line: wire time (frame + 24 bytes of
  preamble, FCS and inter-frame gap, 80 ns per byte) + about 1 us per slave (forwarding
  through each ESC and back). This is a formula, not a measurement.
Wall time includes the moments the scheduler gives the CPU to other processes; CPU time
(``time.thread_time_ns``) is what the cycle itself costs. Medians and 99th percentiles over
the cycles of one run; repeated ``--repeats`` times and
the median of each figure reported with its spread. The machine is shared and noisy: ratios
in the same run matter more than absolute figures.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "lib"))

from robocourse.ethercat.bus import Bus, wire_time_ns  # noqa: E402
from robocourse.ethercat.devices import (  # noqa: E402
    Cia402Drive,
    Coupler,
    DigitalInputs,
    DigitalOutputs,
)
from robocourse.ethercat.frames import DATAGRAM_OVERHEAD  # noqa: E402
from robocourse.ethercat.master import Master  # noqa: E402

PER_SLAVE_NS = 1000


class CycleClock:
    """The bus's time: 1 ms per cycle, so a stall of this shared machine cannot trip the
    slaves' 100 ms SM watchdog in the middle of a cost measurement."""

    def __init__(self) -> None:
        self.now = 1_000_000_000

    def __call__(self) -> int:
        return self.now


def make_bus(n: int, clock=time.monotonic_ns) -> Bus:
    if n == 1:
        return Bus([DigitalOutputs()], clock=clock)
    io = n - 2
    slaves = [Coupler()]
    slaves += [DigitalInputs() if i % 2 == 0 else DigitalOutputs() for i in range(io)]
    slaves.append(Cia402Drive())
    return Bus(slaves, clock=clock)


def frame_len(m: Master) -> int:
    n = 14 + 2 + DATAGRAM_OVERHEAD + len(m.io_map)
    if m.dc_ref is not None:
        n += DATAGRAM_OVERHEAD + 8
    return max(n, 60)


def in_process(n: int, cycles: int) -> tuple[float, float, float, int, int]:
    """(wall p50, wall p99, CPU-time p99) in us, frame bytes, slave count."""
    bus_clock = CycleClock()
    bus = make_bus(n, bus_clock)
    m = Master()
    m.open(bus)
    m.bring_up()
    lat = np.empty(cycles, dtype=np.int64)
    cpu = np.empty(cycles, dtype=np.int64)
    clock, cpu_clock = time.perf_counter_ns, time.thread_time_ns
    for k in range(cycles):
        bus_clock.now += 1_000_000
        c0 = cpu_clock()
        t0 = clock()
        m.send_processdata()
        w = m.receive_processdata()
        lat[k] = clock() - t0
        cpu[k] = cpu_clock() - c0
        if w != m.expected_wkc:
            raise RuntimeError(f"cycle {k}: wkc {w}, expected {m.expected_wkc}")
    us = lat / 1000.0
    return (float(np.percentile(us, 50)), float(np.percentile(us, 99)),
            float(np.percentile(cpu / 1000.0, 99)), frame_len(m), len(bus.slaves))


def veth(cycles: int) -> tuple[float, float, int] | str:
    from robocourse.ethercat import demo_bus
    from robocourse.ethercat.netns import run_pysoem, why_not

    reason = why_not()
    if reason:
        return reason
    try:
        import pysoem  # noqa: F401
    except ImportError:
        return "pysoem not installed"
    rep = run_pysoem(demo_bus(), cycles=cycles)
    us = np.asarray(rep["rtt_ns"], dtype=np.float64) / 1000.0
    return float(np.percentile(us, 50)), float(np.percentile(us, 99)), rep["config_map"]


def physical_us(frame_bytes: int, slaves: int) -> float:
    return (wire_time_ns(frame_bytes) + PER_SLAVE_NS * slaves) / 1000.0


def med(values) -> str:
    v = sorted(values)
    return f"{statistics.median(v):8.1f} [{v[0]:.1f}..{v[-1]:.1f}]"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer cycles and repeats")
    ap.add_argument("--no-veth", action="store_true", help="skip the pysoem/veth row")
    ap.add_argument("--repeats", type=int, default=None)
    a = ap.parse_args()
    cycles = 1000 if a.quick else 5000
    repeats = a.repeats or (2 if a.quick else 5)
    print(f"EtherCAT cycle cost; {cycles} cycles x {repeats} repeats; shared noisy machine "
          f"(load average {os.getloadavg()[0]:.1f}); medians over repeats [min..max]\n")
    print(f"{'row':<26}{'frame B':>8}{'p50 us (wall)':>26}{'p99 us (wall)':>26}"
          f"{'p99 us (CPU)':>26}{'physical us':>13}{'p50/phys':>10}")
    for n in (1, 8, 64):
        runs = [in_process(n, cycles) for _ in range(repeats)]
        p50s, p99s, cpus = [r[0] for r in runs], [r[1] for r in runs], [r[2] for r in runs]
        fb, ns = runs[0][3], runs[0][4]
        phys = physical_us(fb, ns)
        print(f"{f'in-process, {ns} slaves':<26}{fb:>8}{med(p50s):>26}{med(p99s):>26}{med(cpus):>26}"
              f"{phys:>13.1f}{statistics.median(p50s) / phys:>10.1f}")
    if not a.no_veth:
        res = [veth(cycles) for _ in range(max(1, repeats // 2))]
        if isinstance(res[0], str):
            print(f"{'veth + pysoem, 4 slaves':<26} skipped: {res[0]}")
        else:
            p50s, p99s = [r[0] for r in res], [r[1] for r in res]
            fb = 14 + 2 + DATAGRAM_OVERHEAD + res[0][2] + DATAGRAM_OVERHEAD + 8
            phys = physical_us(fb, 4)
            print(f"{'veth + pysoem, 4 slaves':<26}{fb:>8}{med(p50s):>26}{med(p99s):>26}"
                  f"{'-':>26}{phys:>13.1f}{statistics.median(p50s) / phys:>10.1f}")
    print(f"\nphysical = (max(frame, 60) + 24 B) x 80 ns/B on 100 Mbit/s + {PER_SLAVE_NS} ns per slave;"
          "\ngoal: 8 slaves in-process p99 <= 100 us (a 1 kHz cycle fits in Python)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
