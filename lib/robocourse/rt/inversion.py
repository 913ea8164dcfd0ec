"""Priority inversion, measured: a mutex between a high and a low priority task, and two fixes.

No rttest counterpart; this is the textbook case the ROS 2 real-time docs warn about. Three
actors share one CPU under SCHED_FIFO: the caller's periodic loop (high priority) reads a value
that a *low* priority process updates under a mutex, and a *medium* priority process busy-spins
in bursts. When the loop wants the mutex while the low process holds it, the loop must wait for
the low process, which cannot run while the medium one spins: the high priority loop waits for
the medium one although they share nothing (unbounded priority inversion).

Variants (``mode``):

- ``"mutex"``: a process-shared ``pthread_mutex_t`` with the default protocol (no inheritance);
- ``"pi-mutex"``: the same mutex with ``PTHREAD_PRIO_INHERIT``: while the loop waits, the kernel
  (a PI futex) runs the holder at the loop's priority, so the medium process cannot preempt it.
  Python's own locks (``threading.Lock``, ``multiprocessing.Lock``) offer no such protocol; this
  reaches glibc's pthread mutex through ctypes, on Linux only;
- ``"lock-free"``: no lock at all: the writer fills the spare slot of a double buffer and flips
  an index; the reader takes the slot the index names and never waits (a torn read, detected by
  a sequence number, keeps the previous value).

Needs Linux, glibc, CPU affinity and permission for SCHED_FIFO (rtprio); :func:`measure` says
what is missing instead of measuring something else.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import mmap
import multiprocessing
import os
import struct
import time
from dataclasses import dataclass

import numpy as np

MODES = ("mutex", "pi-mutex", "lock-free")
_MUTEX_SIZE = 64  # >= sizeof(pthread_mutex_t) (40 on x86-64 glibc)
_PTHREAD_PROCESS_SHARED = 1
_PTHREAD_PRIO_INHERIT = 1
_SLOT = struct.Struct("qd")  # sequence number, value
_DATA = _MUTEX_SIZE  # value under the mutex
_INDEX = _DATA + 16  # lock-free: which slot is current
_SLOTS = _INDEX + 16  # two slots
_BURSTS = _SLOTS + 2 * _SLOT.size  # the hog's burst count


def _libc():
    return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)


def _pin_and_prioritise(cpu: int, priority: int) -> None:
    os.sched_setaffinity(0, {cpu})
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))


def _spin(seconds: float) -> None:
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


def _init_mutex(libc, addr: int, inherit: bool) -> None:
    attr = ctypes.create_string_buffer(16)
    if libc.pthread_mutexattr_init(attr) != 0:
        raise OSError("pthread_mutexattr_init failed")
    libc.pthread_mutexattr_setpshared(attr, _PTHREAD_PROCESS_SHARED)
    if inherit and libc.pthread_mutexattr_setprotocol(attr, _PTHREAD_PRIO_INHERIT) != 0:
        raise OSError("pthread_mutexattr_setprotocol(PTHREAD_PRIO_INHERIT) is not supported here")
    rc = libc.pthread_mutex_init(ctypes.c_void_p(addr), attr)
    libc.pthread_mutexattr_destroy(attr)
    if rc != 0:
        raise OSError(f"pthread_mutex_init failed: {os.strerror(rc)}")


def _low(buf, mode: str, cpu: int, priority: int, hold_s: float, rest_s: float, stop) -> None:
    """The low priority writer: update the shared value every ``hold_s + rest_s``."""
    _pin_and_prioritise(cpu, priority)
    libc = _libc()
    addr = ctypes.addressof(ctypes.c_char.from_buffer(buf))
    value = 0.0
    while not stop.is_set():
        value += 1.0
        if mode == "lock-free":
            spare = 1 - struct.unpack_from("q", buf, _INDEX)[0]
            off = _SLOTS + spare * _SLOT.size
            seq = struct.unpack_from("q", buf, off)[0]
            struct.pack_into("q", buf, off, seq + 1)  # odd: being written
            _spin(hold_s)  # the same work, done on the spare copy
            _SLOT.pack_into(buf, off, seq + 2, value)
            struct.pack_into("q", buf, _INDEX, spare)  # publish: one aligned 8-byte store
        else:
            libc.pthread_mutex_lock(ctypes.c_void_p(addr))
            _spin(hold_s)  # the work done while holding the lock
            struct.pack_into("d", buf, _DATA, value)
            libc.pthread_mutex_unlock(ctypes.c_void_p(addr))
        time.sleep(rest_s)


def _medium(buf, cpu: int, priority: int, burst_s: float, gap_s: float, phase_s: float, seed: int, stop) -> None:
    """The medium priority hog: spin ``burst_s``, sleep ``gap_s`` plus a seeded random part of
    ``phase_s``; it shares nothing with the others. Counts its bursts in ``buf``.

    The random part matters: the writer cannot run during a burst, so it restarts its cycle when
    a burst ends; with a fixed gap the hog would wake at the same phase of the writer's cycle
    every time (in lock-step), always inside a hold or never. A gap drawn over one writer cycle
    lands inside a hold with probability hold / (hold + rest) at every burst.
    """
    import random

    _pin_and_prioritise(cpu, priority)
    rng = random.Random(seed)
    while not stop.is_set():
        _spin(burst_s)
        struct.pack_into("q", buf, _BURSTS, struct.unpack_from("q", buf, _BURSTS)[0] + 1)
        time.sleep(gap_s + rng.uniform(0.0, phase_s))


def _progress(cpu: int, priority: int, start: float, end: float, q) -> None:
    _pin_and_prioritise(cpu, priority)
    while time.monotonic() < start:      # both wait for the same window, sleeping (the CPU stays free)
        time.sleep(0.001)
    n = 0
    while time.monotonic() < end:
        n += 1
    q.put((priority, n))


def pinning_confines(cpu: int | None = None, seconds: float = 0.2) -> tuple[bool, float]:
    """Do two SCHED_FIFO processes pinned to one CPU really take turns on it?

    A priority 50 and a priority 10 busy loop, both pinned to ``cpu``, count iterations over the
    *same* ``seconds``-long window of CLOCK_MONOTONIC (both are set up and asleep before it
    opens). On a CPU that confines them the priority 10 one counts nearly nothing while the
    other spins. Returns (confined, the low one's count relative to the high one's). Some
    virtual machines run both in parallel anyway; then no experiment on one "core" can show
    preemption or inversion. (Timing each over its own window, as this function once did, lets
    the low one run after the high one ends and always reads as "not confined".)
    """
    ok, why = available()
    if not ok:
        raise PermissionError(why)
    cpu = sorted(os.sched_getaffinity(0))[-1] if cpu is None else cpu
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    start = time.monotonic() + 0.1     # time for both children to start, pin and sleep
    procs = [ctx.Process(target=_progress, args=(cpu, prio, start, start + seconds, q), daemon=True)
             for prio in (50, 10)]
    for p in procs:
        p.start()
    got = dict(q.get(timeout=30) for _ in procs)
    for p in procs:
        p.join(timeout=5)
    ratio = got[10] / max(got[50], 1)
    return ratio < 0.5, ratio


@dataclass
class InversionRun:
    """One variant: how long each iteration of the high priority loop spent getting the value."""

    mode: str
    medium: bool
    access_ns: np.ndarray
    latency_ns: np.ndarray
    bursts: int = 0        # how many bursts the medium hog spun while the loop ran

    def summary(self) -> str:
        a = self.access_ns / 1e3
        return (f"{self.mode:<10} medium hog {'on ' if self.medium else 'off'}  access p50 {np.percentile(a, 50):8.1f} us"
                f"  p99 {np.percentile(a, 99):9.1f} us  max {a.max():9.1f} us  waits > 1 ms: {int(np.sum(a > 1000))}")


def available(cpu: int | None = None) -> tuple[bool, str]:
    """(True, "") when this process may pin and use SCHED_FIFO on Linux with glibc; else why not."""
    if not hasattr(os, "sched_setscheduler") or not hasattr(os, "sched_setaffinity"):
        return False, "needs Linux (sched_setscheduler, sched_setaffinity)"
    libc = _libc()
    if not hasattr(libc, "pthread_mutexattr_setprotocol"):
        return False, "needs glibc's pthread_mutexattr_setprotocol"
    old = (os.sched_getscheduler(0), os.sched_getparam(0))
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
    except OSError as exc:
        return False, f"SCHED_FIFO refused ({exc.strerror}): grant rtprio (limits.conf) to see the inversion"
    finally:
        os.sched_setscheduler(0, *old)
    return True, ""


def measure(mode: str, medium: bool = True, iterations: int = 1000, cpu: int | None = None,
            hold_s: float = 0.002, rest_s: float = 0.003, burst_s: float = 0.01, gap_s: float = 0.02,
            priorities: tuple[int, int, int] = (10, 50, 80), seed: int = 0) -> InversionRun:
    """Run the high priority 1 kHz loop for ``iterations`` against the low writer (and the medium hog).

    ``access_ns[k]`` is how long iteration k took to get the current value (lock, read, unlock;
    or the lock-free read). All three actors are pinned to ``cpu`` (default: the last allowed).
    The writer holds the value ``hold_s`` then rests ``rest_s``; the hog spins ``burst_s`` then
    sleeps ``gap_s`` plus a random part of one writer cycle (``random.Random(seed)``), so each
    burst starts inside a hold with probability ``hold_s / (hold_s + rest_s)``. The defaults
    keep the three real-time tasks under the kernel's real-time share (``sched_rt_runtime_us``,
    95 % by default), so RT throttling does not stall the experiment.
    """
    from .loop import PeriodicLoop
    from .settings import current_scheduling, reset_scheduling

    if mode not in MODES:
        raise ValueError(f"mode={mode!r}: one of {', '.join(MODES)}")
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations={iterations!r}: a positive int, e.g. 1000")
    low_p, mid_p, high_p = priorities
    if not 1 <= low_p < mid_p < high_p <= 98:
        raise ValueError(f"priorities={priorities!r}: need 1 <= low < medium < high <= 98, e.g. (10, 50, 80)")
    ok, why = available()
    if not ok:
        raise PermissionError(why)
    cpu = sorted(os.sched_getaffinity(0))[-1] if cpu is None else cpu
    buf = mmap.mmap(-1, mmap.PAGESIZE)  # MAP_SHARED | MAP_ANONYMOUS: the children inherit it
    libc = _libc()
    addr = ctypes.addressof(ctypes.c_char.from_buffer(buf))
    if mode != "lock-free":
        _init_mutex(libc, addr, inherit=(mode == "pi-mutex"))
    ctx = multiprocessing.get_context("fork")
    stop = ctx.Event()
    procs = [ctx.Process(target=_low, args=(buf, mode, cpu, low_p, hold_s, rest_s, stop), daemon=True)]
    if medium:
        procs.append(ctx.Process(target=_medium, args=(buf, cpu, mid_p, burst_s, gap_s, hold_s + rest_s, seed, stop),
                                 daemon=True))
    old_aff = os.sched_getaffinity(0)
    old_sched = current_scheduling()
    access = np.zeros(iterations, dtype=np.int64)
    last = [0.0]

    def read(tick):
        t0 = time.perf_counter_ns()
        if mode == "lock-free":
            off = _SLOTS + struct.unpack_from("q", buf, _INDEX)[0] * _SLOT.size
            seq, value = _SLOT.unpack_from(buf, off)
            if seq % 2 == 0 and struct.unpack_from("q", buf, off)[0] == seq:
                last[0] = value  # else torn: keep the previous value, never wait
        else:
            libc.pthread_mutex_lock(ctypes.c_void_p(addr))
            last[0] = struct.unpack_from("d", buf, _DATA)[0]
            libc.pthread_mutex_unlock(ctypes.c_void_p(addr))
        access[tick.iteration] = time.perf_counter_ns() - t0

    try:
        for p in procs:
            p.start()
        _pin_and_prioritise(cpu, high_p)
        time.sleep(0.05)  # let the writer and the hog settle into their pattern
        bursts0 = struct.unpack_from("q", buf, _BURSTS)[0]
        result = PeriodicLoop(1_000_000, iterations).run(read)
        bursts = struct.unpack_from("q", buf, _BURSTS)[0] - bursts0
    finally:
        reset_scheduling(*old_sched)
        os.sched_setaffinity(0, old_aff)
        stop.set()
        for p in procs:
            p.join(timeout=2.0)
            if p.is_alive():
                p.kill()
                p.join(timeout=1.0)
    if last[0] <= 0:
        raise RuntimeError("the high priority loop never saw a value from the writer")
    return InversionRun(mode, medium, access, result.latency_ns, bursts)
