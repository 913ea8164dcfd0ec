"""Distributed clocks: an ESC's local clock, its system time and its time control loop.

The ESC counterpart of Beckhoff's DC unit (registers 0x0900-0x09A7): a free-running local
clock in ns since power-on with its own drift, the system time = local time + offset (0x0920),
and a control loop that nudges the clock's rate whenever the master writes the reference
clock's system time into 0x0910 (ARMW/FRMW): the difference (received time + propagation delay
0x0928) - own system time lands in 0x092C and feeds the rate correction.

Where we differ: a real ESC corrects in 10-ns ticks (adding 9 or 11 ns every speed-counter
period); we model the same effect as a PI controller on the clock rate, clamped to the
+-500 ppm a real ESC can slew. Time is continuous (float ns), so the measured sync error is
the model's, not a crystal's.
"""

from __future__ import annotations

MAX_CORRECTION = 500e-6  # rate correction limit (dimensionless, 500 ppm)
KP = 0.2  # fraction of the phase error corrected per write, through the rate
KI = 0.02
DIFF_CLAMP_NS = 10_000.0  # a single write moves the loop by at most this much error
MIN_PERIOD_NS = 100_000.0


class LocalClock:
    """An ESC's DC clock. ``bus_ns`` is the simulation's true time in ns."""

    __slots__ = ("drift", "_t_ref", "_local_ref", "_rate", "_integral", "_last_write")

    def __init__(self, drift_ppm: float = 0.0, power_on_ns: float = 0.0) -> None:
        self.drift = drift_ppm * 1e-6
        self._t_ref = float(power_on_ns)
        self._local_ref = 0.0
        self._rate = 1.0 + self.drift
        self._integral = 0.0
        self._last_write: float | None = None

    def local(self, bus_ns: float) -> float:
        """Local time (ns since this ESC powered on) at bus time ``bus_ns``."""
        return self._local_ref + (bus_ns - self._t_ref) * self._rate

    def bus_time_of_local(self, local_ns: float) -> float:
        """The bus time at which the local clock reads ``local_ns`` (for SYNC0 events)."""
        return self._t_ref + (local_ns - self._local_ref) / self._rate

    def reset_filter(self) -> None:
        """What a write of the speed counter start (0x0930) does: the loop starts afresh."""
        self._integral = 0.0
        self._last_write = None
        self._set_correction(0.0, None)

    def control(self, diff_ns: float, bus_ns: float) -> None:
        """One 0x0910 write: ``diff_ns`` = (received + delay) - own system time."""
        e = max(-DIFF_CLAMP_NS, min(DIFF_CLAMP_NS, diff_ns))
        if self._last_write is None:
            period = None
        else:  # writes closer than MIN_PERIOD_NS (bring-up bursts) count as that far apart
            period = max(bus_ns - self._last_write, MIN_PERIOD_NS)
        self._last_write = bus_ns
        if period is None:
            return
        self._integral = max(-MAX_CORRECTION, min(MAX_CORRECTION, self._integral + KI * e / period))
        self._set_correction(self._integral + KP * e / period, bus_ns)

    def _set_correction(self, c: float, bus_ns: float | None) -> None:
        c = max(-MAX_CORRECTION, min(MAX_CORRECTION, c))
        if bus_ns is not None:
            self._local_ref = self.local(bus_ns)
            self._t_ref = bus_ns
        self._rate = (1.0 + self.drift) * (1.0 + c)

    @property
    def correction_ppm(self) -> float:
        return (self._rate / (1.0 + self.drift) - 1.0) * 1e6


def encode_diff(diff_ns: float) -> int:
    """0x092C format: bit 31 = sign (1 = own time larger), bits 0-30 magnitude in ns."""
    mag = min(int(abs(diff_ns)), 0x7FFFFFFF)
    return mag | (0x80000000 if diff_ns < 0 else 0)


def line_delays(port_times: list[tuple[int, int | None]]) -> list[int]:
    """SOEM's propagation delays for a line topology from latched port 0/1 receive times.

    ``port_times[i]`` = (port 0 time, port 1 time or None when port 1 is closed) of the i-th
    DC slave in the line, 32-bit ns values. The delay of slave i is its parent's delay plus half
    the difference between the parent's round trip (port 1 - port 0) and its own; the last
    slave's own round trip is 0 (its port 1 is closed). The first DC slave (reference) gets 0.
    """
    delays = [0]
    for i in range(1, len(port_times)):
        p0, p1 = port_times[i - 1]
        c0, c1 = port_times[i]
        parent_rt = ((p1 - p0) & 0xFFFFFFFF) if p1 is not None else 0
        own_rt = ((c1 - c0) & 0xFFFFFFFF) if c1 is not None else 0
        delays.append(delays[-1] + (parent_rt - own_rt) // 2)
    return delays
