"""robocourse.rt: timing a periodic loop the way rttest and cyclictest do.

- ``loop``: :class:`PeriodicLoop` with absolute deadlines and a wait strategy (``wait``:
  :class:`Sleep`, :class:`Hybrid`, :class:`Adaptive`, :class:`Spin`); latency per iteration, page faults, overruns.
- ``stats``: rttest's statistics (population stddev) plus percentiles and a histogram.
- ``options``: rttest's -i -u -t -s -m -d -f with clear usage errors.
- ``results_file`` / ``plot``: rttest's results file and rttest_plot's four figures.
- ``settings``: scheduling, affinity, mlockall, prefaulting, gc, each with an honest report.
- ``disturb``: CPU load, allocation storms, gc pressure, fresh memory, logging in the loop.
- ``cyclictest``: the C reference on the same machine.
- ``repeat``: interleaved rounds of several settings, medians with their range, worded comparisons.
- ``inversion``: priority inversion measured (mutex, PI mutex, lock-free hand-off).
- ``capabilities``: what this machine allows (and how to fix it).
- ``realtime_thread``: :func:`configure_realtime_thread` (name, policy, mlockall, read back) for one thread.
"""

from . import (
    capabilities,
    clock,
    cyclictest,
    disturb,
    inversion,
    loop,
    options,
    permissions,
    plot,
    realtime_thread,
    repeat,
    results_file,
    settings,
    stats,
    wait,
)
from .capabilities import Finding, probe, report
from .clock import FakeClock, MonotonicClock
from .cyclictest import CyclictestMissing, run_cyclictest
from .loop import STOP, LoopResult, PeriodicLoop, Tick, run_loop
from .options import RttestOptions, RttestUsageError, parse_duration, parse_rttest_args, parse_size
from .realtime_thread import (
    RealtimeThreadReport,
    configure_realtime_thread,
    release_realtime_thread,
)
from .results_file import ResultsData, read_results, write_results
from .settings import SettingReport, lock_and_prefault, realtime, set_affinity, set_scheduling
from .stats import RttestStats, compute_stats, format_rttest, histogram
from .wait import Adaptive, Hybrid, Sleep, Spin, WaitStrategy

__all__ = [
    "capabilities", "clock", "cyclictest", "disturb", "inversion", "loop", "options", "permissions", "plot",
    "realtime_thread", "repeat", "results_file", "settings", "stats", "wait",
    "STOP", "Adaptive", "CyclictestMissing", "FakeClock", "Finding", "Hybrid", "LoopResult", "MonotonicClock",
    "PeriodicLoop", "RealtimeThreadReport", "ResultsData", "RttestOptions", "RttestStats", "RttestUsageError",
    "SettingReport",
    "Sleep", "Spin", "Tick", "WaitStrategy", "compute_stats", "format_rttest", "histogram",
    "lock_and_prefault", "parse_duration", "parse_rttest_args", "parse_size", "probe", "read_results",
    "configure_realtime_thread", "realtime", "release_realtime_thread", "report", "run_cyclictest", "run_loop",
    "set_affinity", "set_scheduling", "write_results",
]
