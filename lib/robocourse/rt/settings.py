"""Real-time settings, each trying for real and reporting honestly what took effect.

Counterparts: rttest's ``rttest_set_sched_priority`` (sched_setscheduler), ``rttest_lock_memory``
(mlockall(MCL_CURRENT | MCL_FUTURE)), ``rttest_prefault_stack`` and
``rttest_lock_and_prefault_dynamic`` (mallopt(M_TRIM_THRESHOLD, -1), mallopt(M_MMAP_MAX, 0),
touch 64-page chunks until getrusage shows no new faults, free them: they stay in the heap),
plus CPU affinity (the newer pendulum demo's --cpu-affinity) and Python's own knob, the gc.

On failure each function prints the seed's text (e.g. "Couldn't set scheduling priority and
policy: Operation not permitted") and the exact fix to stderr, returns a report with
``ok=False`` and lets the program carry on, as the ROS 2 demo does. Nothing needs root.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import gc
import numbers
import os
import resource
import sys
from dataclasses import dataclass
from pathlib import Path

from .capabilities import RT_PRIORITY, memlock_fix, rtprio_fix

MCL_CURRENT = 1
MCL_FUTURE = 2
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
DEFAULT_TRIM_THRESHOLD = 128 * 1024
DEFAULT_MMAP_MAX = 65536
PAGE_SIZE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
_RUSAGE_THREAD = getattr(resource, "RUSAGE_THREAD", resource.RUSAGE_SELF)

POLICIES = {"fifo": "SCHED_FIFO", "rr": "SCHED_RR", "other": "SCHED_OTHER"}


def _libc():
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:
        return None


_LIBC = _libc()


@dataclass
class SettingReport:
    """What one setting asked for, whether it took effect, what happened, and the fix."""

    name: str
    ok: bool
    detail: str
    message: str = ""
    fix: str = ""

    def __str__(self) -> str:
        mark = "ok " if self.ok else "-- "
        text = f"{mark}{self.name:<16} {self.detail}"
        if not self.ok and self.fix:
            first, *rest = self.fix.splitlines()
            text += "\n      fix: " + first + "".join("\n           " + r for r in rest)
        return text


def _fail(report: SettingReport, quiet: bool) -> SettingReport:
    if not quiet:
        print(report.message, file=sys.stderr)
        if report.fix:
            print("  fix: " + report.fix.replace("\n", "\n       "), file=sys.stderr)
    return report


# -- scheduling -------------------------------------------------------------------------------

def allowed_cpus() -> list[int]:
    """The CPUs this thread may run on (all CPUs where the OS cannot say)."""
    if hasattr(os, "sched_getaffinity"):
        return sorted(os.sched_getaffinity(0))
    return list(range(os.cpu_count() or 1))


def current_scheduling() -> tuple[str, int]:
    """(policy name, priority) of the calling thread ("unknown" off Linux)."""
    if not hasattr(os, "sched_getscheduler"):
        return "unknown", 0
    policy = os.sched_getscheduler(0)
    names = {os.SCHED_FIFO: "SCHED_FIFO", os.SCHED_RR: "SCHED_RR", os.SCHED_OTHER: "SCHED_OTHER"}
    for attr in ("SCHED_BATCH", "SCHED_IDLE"):
        if hasattr(os, attr):
            names[getattr(os, attr)] = attr
    return names.get(policy, str(policy)), os.sched_getparam(0).sched_priority


def set_scheduling(policy: str = "rr", priority: int = RT_PRIORITY, quiet: bool = False) -> SettingReport:
    """sched_setscheduler(0, policy, priority) for the calling thread (rttest -s / -t)."""
    key = str(policy).lower().replace("sched_", "")
    if key not in POLICIES:
        raise ValueError(f"policy {policy!r}: use 'fifo', 'rr' or 'other'")
    if key != "other" and not (isinstance(priority, int) and 1 <= priority <= 99):
        raise ValueError(f"priority {priority!r}: real-time priorities are 1..99 (use <= 98)")
    name = f"{POLICIES[key]} {priority}" if key != "other" else "SCHED_OTHER"
    if not hasattr(os, "sched_setscheduler"):
        return _fail(SettingReport("scheduling", False, "this OS has no sched_setscheduler",
                                   "Couldn't set scheduling priority and policy: not supported on this OS"), quiet)
    pol = {"fifo": os.SCHED_FIFO, "rr": os.SCHED_RR, "other": os.SCHED_OTHER}[key]
    try:
        os.sched_setscheduler(0, pol, os.sched_param(priority if key != "other" else 0))
    except OSError as exc:
        return _fail(SettingReport("scheduling", False, f"{name} refused: {exc.strerror}",
                                   f"Couldn't set scheduling priority and policy: {exc.strerror}",
                                   rtprio_fix(priority)), quiet)
    got, prio = current_scheduling()
    slack = _timer_slack()
    extra = f", timer slack now {slack} ns" if slack is not None else ""
    return SettingReport("scheduling", True, f"{got} priority {prio}{extra}")


def _timer_slack() -> int | None:
    try:
        return int(Path("/proc/thread-self/timerslack_ns").read_text())
    except (OSError, ValueError):
        try:
            return int(Path("/proc/self/timerslack_ns").read_text())
        except (OSError, ValueError):
            return None


def reset_scheduling(policy: str = "SCHED_OTHER", priority: int = 0) -> None:
    """Back to SCHED_OTHER (or a saved policy); always allowed when lowering."""
    if not hasattr(os, "sched_setscheduler"):
        return
    pol = {"SCHED_FIFO": os.SCHED_FIFO, "SCHED_RR": os.SCHED_RR}.get(policy, os.SCHED_OTHER)
    with contextlib.suppress(OSError):
        os.sched_setscheduler(0, pol, os.sched_param(priority if pol != os.SCHED_OTHER else 0))


@contextlib.contextmanager
def scheduling_kept():
    """Give the calling thread its policy and priority back after the block; say what the block set.

    For client libraries that raise the thread themselves: libfranka's ``Robot`` constructor (and
    pylibfranka's) asks SCHED_FIFO at the highest priority, 99, for the thread that constructs it,
    whatever its RealtimeConfig (kIgnore only means a refusal is not an error), and never gives it
    back. Yields a dict; on exit it holds ``before`` and ``set`` ((policy, priority) pairs) and
    ``changed`` (bool). Lowering a thread's priority is always allowed, so this needs no privilege.
    """
    seen: dict = {"before": current_scheduling()}
    try:
        yield seen
    finally:
        seen["set"] = current_scheduling()
        seen["changed"] = seen["set"] != seen["before"]
        if seen["changed"]:
            reset_scheduling(*seen["before"])


# -- affinity ---------------------------------------------------------------------------------

def set_affinity(cpus, quiet: bool = False) -> SettingReport:
    """sched_setaffinity for the calling thread; ``cpus`` an int or a set of CPU numbers."""
    def cpu_number(c) -> bool:
        return isinstance(c, numbers.Integral) and not isinstance(c, bool)

    if not isinstance(cpus, (str, bytes)) and not cpu_number(cpus) and hasattr(cpus, "__iter__"):
        cpus = list(cpus)   # a generator is read once
    if isinstance(cpus, (str, bytes)) or not (
            cpu_number(cpus) or (hasattr(cpus, "__iter__") and all(cpu_number(c) for c in cpus))):
        hint = f" (int({cpus!r}) if it came from text)" if isinstance(cpus, str) and cpus.strip().isdigit() else ""
        raise ValueError(f"set_affinity(cpus={cpus!r}): CPU numbers are ints, one or a set of them, e.g. "
                         f"set_affinity(1) or set_affinity({{0, 1}}){hint}")
    wanted = {int(cpus)} if cpu_number(cpus) else {int(c) for c in cpus}
    if not hasattr(os, "sched_setaffinity"):
        return _fail(SettingReport("affinity", False, "not supported on this OS",
                                   "Couldn't set CPU affinity: not supported on this OS"), quiet)
    allowed = os.sched_getaffinity(0)
    try:
        os.sched_setaffinity(0, wanted)
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        return _fail(SettingReport("affinity", False, f"CPUs {sorted(wanted)} refused: {why}",
                                   f"Couldn't set CPU affinity: {why}",
                                   f"pick CPUs from {sorted(allowed)} (os.sched_getaffinity(0))"), quiet)
    return SettingReport("affinity", True, f"pinned to CPU(s) {sorted(os.sched_getaffinity(0))}")


# -- memory -----------------------------------------------------------------------------------

def _faults_thread() -> tuple[int, int]:
    ru = resource.getrusage(_RUSAGE_THREAD)
    return ru.ru_minflt, ru.ru_majflt


def _faults_self() -> tuple[int, int]:
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_minflt, ru.ru_majflt


def lock_memory(quiet: bool = False) -> SettingReport:
    """mlockall(MCL_CURRENT | MCL_FUTURE): no page of this process may be swapped out."""
    if _LIBC is None:
        return _fail(SettingReport("mlockall", False, "libc not found",
                                   "mlockall failed: libc not found\nCouldn't lock all cached virtual memory."), quiet)
    if _LIBC.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        err = os.strerror(ctypes.get_errno())
        soft, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
        limit = "unlimited" if soft == resource.RLIM_INFINITY else f"{soft // 1024} kB"
        return _fail(SettingReport(
            "mlockall", False, f"refused: {err} (RLIMIT_MEMLOCK {limit})",
            f"mlockall failed: {err}\nCouldn't lock all cached virtual memory.\n"
            "Pagefaults from reading pages not yet mapped into RAM will be recorded.",
            memlock_fix()), quiet)
    return SettingReport("mlockall", True, "MCL_CURRENT | MCL_FUTURE: all pages locked in RAM")


def unlock_memory() -> None:
    """munlockall() and glibc's default trim/mmap settings (rttest_finish does munlockall)."""
    if _LIBC is not None:
        _LIBC.munlockall()
        if hasattr(_LIBC, "mallopt"):
            _LIBC.mallopt(M_TRIM_THRESHOLD, DEFAULT_TRIM_THRESHOLD)
            _LIBC.mallopt(M_MMAP_MAX, DEFAULT_MMAP_MAX)


def memory_locked() -> bool:
    """True when this process has locked pages (VmLck in /proc/self/status > 0)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmLck:"):
                return int(line.split()[1]) > 0
    except (OSError, ValueError):
        pass
    return False


def _stack_pointer() -> int | None:
    """The calling thread's user stack pointer, read from /proc/thread-self/syscall."""
    try:
        fields = Path("/proc/thread-self/syscall").read_text().split()
    except OSError:
        return None
    if len(fields) < 3 or fields[0] in ("running", "-1"):
        return None
    try:
        return int(fields[-2], 16)
    except ValueError:
        return None


def _stack_bounds() -> tuple[int, int] | None:
    """(lowest address, size) of the calling thread's stack via pthread_getattr_np."""
    if _LIBC is None or not hasattr(_LIBC, "pthread_getattr_np"):
        return None
    attr = ctypes.create_string_buffer(256)  # larger than any pthread_attr_t
    if _LIBC.pthread_getattr_np(ctypes.c_ulong(_LIBC.pthread_self()), attr) != 0:
        return None
    addr, size = ctypes.c_void_p(), ctypes.c_size_t()
    try:
        if _LIBC.pthread_attr_getstack(attr, ctypes.byref(addr), ctypes.byref(size)) != 0:
            return None
    finally:
        _LIBC.pthread_attr_destroy(attr)
    return int(addr.value or 0), int(size.value)


if _LIBC is not None:
    _LIBC.pthread_self.restype = ctypes.c_ulong


def prefault_stack(size: int = 1024 * 1024, quiet: bool = False) -> SettingReport:
    """Touch ``size`` bytes of this thread's stack below the current frame (rttest -m).

    rttest does ``memset(alloca(size), 0, size)``. Python cannot alloca, so this reads the
    stack pointer from /proc/thread-self/syscall and writes zeros to the pages below it,
    keeping a 64 KiB margin for the frames of the call itself and staying inside the
    stack's bounds (pthread_getattr_np). Pages below the stack pointer hold no live data.
    """
    margin = 64 * 1024
    if size <= 0:
        return SettingReport("stack prefault", True, "nothing to do (size 0)")
    sp, bounds = _stack_pointer(), _stack_bounds()
    if sp is None or bounds is None:
        return _fail(SettingReport("stack prefault", False, "cannot locate this thread's stack here",
                                   "Couldn't prefault the stack: /proc/thread-self/syscall or "
                                   "pthread_getattr_np unavailable"), quiet)
    low, stack_size = bounds
    top = sp - margin
    bottom = max(top - size, low + 16 * PAGE_SIZE)
    bottom -= bottom % PAGE_SIZE
    if top <= bottom or not (low <= bottom < low + stack_size):
        return _fail(SettingReport("stack prefault", False, f"only {max(0, top - low)} B of stack below here",
                                   "Couldn't prefault the stack: not enough stack left below the caller"), quiet)
    before = _faults_thread()
    ctypes.memset(bottom, 0, top - bottom)
    after = _faults_thread()
    return SettingReport("stack prefault", True,
                         f"touched {(top - bottom) // 1024} KiB below the stack pointer "
                         f"({after[0] - before[0]} minor faults taken now, not in the loop)")


def prefault_heap(size: int = 64 * 1024 * 1024, until_no_faults: bool = False,
                  quiet: bool = False) -> SettingReport:
    """Fault in ``size`` bytes of malloc heap and keep it mapped (rttest's dynamic prefault).

    mallopt(M_TRIM_THRESHOLD, -1) and mallopt(M_MMAP_MAX, 0) make glibc serve big blocks from
    the heap and never give freed memory back; then 64-page chunks are malloc'ed and zeroed,
    and finally all freed: they stay mapped for later malloc()s (numpy arrays, bytes, big
    lists). Works without privileges; only mlockall needs memlock.

    ``until_no_faults=True`` is rttest's exact rule: stop at the first chunk that costs no new
    page fault, with ``size`` as the cap (-d). It stops at once when the heap already holds
    free pages, and after mlockall(MCL_FUTURE) it never stops before the cap (the kernel
    populates each new locked chunk, and that counts as faults: measured on Linux 6.18). So by
    default robocourse faults in exactly ``size``, independent of what ran before.
    """
    if isinstance(size, bool) or not isinstance(size, int) or size < 0:
        raise ValueError(f"prefault_heap(size={size!r}): the size is a whole number of bytes >= 0; "
                         "e.g. prefault_heap(64 << 20) or prefault_heap(parse_size('64mb', '-d'))")
    if _LIBC is None or not hasattr(_LIBC, "mallopt"):
        return _fail(SettingReport("heap prefault", False, "glibc's mallopt is not available here",
                                   "Couldn't prefault the heap: this C library has no mallopt (not glibc)"), quiet)
    if _LIBC.mallopt(M_TRIM_THRESHOLD, -1) == 0:
        return _fail(SettingReport("heap prefault", False, "mallopt(M_TRIM_THRESHOLD) refused",
                                   "mallopt for trim threshold failed"), quiet)
    if _LIBC.mallopt(M_MMAP_MAX, 0) == 0:
        _LIBC.mallopt(M_TRIM_THRESHOLD, DEFAULT_TRIM_THRESHOLD)
        return _fail(SettingReport("heap prefault", False, "mallopt(M_MMAP_MAX) refused",
                                   "mallopt for mmap failed"), quiet)
    malloc, free = _LIBC.malloc, _LIBC.free
    malloc.restype = ctypes.c_void_p
    malloc.argtypes = [ctypes.c_size_t]
    free.argtypes = [ctypes.c_void_p]
    chunk = 64 * PAGE_SIZE
    kept: list[int] = []
    total = 0
    faults = 0
    clean = False
    prev = _faults_self()
    try:
        while total < size:
            ptr = malloc(chunk)
            if not ptr:
                for p in kept:
                    free(p)
                kept.clear()
                unlock_memory()
                return _fail(SettingReport("heap prefault", False, f"malloc failed after {total // 1024} KiB",
                                           "malloc failed while prefaulting the heap.\n"
                                           "Unlocking memory and continuing."), quiet)
            ctypes.memset(ptr, 0, chunk)
            total += chunk
            kept.append(ptr)
            cur = _faults_self()
            new = (cur[0] - prev[0]) + (cur[1] - prev[1])
            faults += new
            prev = cur
            if until_no_faults and new == 0:
                clean = True
                break
    finally:
        for p in kept:
            free(p)
    return SettingReport("heap prefault", True, _prefault_text(size, total, faults, until_no_faults, clean))


def _prefault_text(size: int, total: int, faults: int, until_no_faults: bool, clean: bool) -> str:
    """What the heap prefault did, in words that match its own numbers."""
    kib = 1024
    head = f"touched {total // kib} KiB of heap (asked for up to {size // kib} KiB), {faults} page faults taken now"
    if not until_no_faults:
        rule = "all of it, not in the loop"
    elif clean and total <= 64 * PAGE_SIZE:
        rule = ("the first chunk took no new fault: the heap already held free, mapped memory "
                "(an earlier prefault or allocations), so rttest's rule stopped at once")
    elif clean:
        rule = "up to the first chunk that took no new fault (rttest's rule); those faults are not in the loop"
    else:
        rule = "every chunk faulted, so up to the cap (rttest's rule); those faults are not in the loop"
    return f"{head}: {rule}; freed memory stays mapped (M_TRIM_THRESHOLD -1, M_MMAP_MAX 0)"


def lock_and_prefault(stack_size: int = 1024 * 1024, heap_size: int = 64 * 1024 * 1024,
                      until_no_faults: bool = False, quiet: bool = False) -> list[SettingReport]:
    """rttest's ``rttest_lock_and_prefault_dynamic`` + ``rttest_prefault_stack``.

    Like the seed: if mlockall fails it prints "Couldn't lock all cached virtual memory." and
    carries on; the heap and stack are still prefaulted (that needs no privilege, and it
    removes the faults from the loop for as long as the pages are not swapped out).
    """
    reports = [lock_memory(quiet=quiet)]
    reports.append(prefault_heap(heap_size, until_no_faults=until_no_faults, quiet=quiet))
    reports.append(prefault_stack(stack_size, quiet=quiet))
    return reports


# -- Python's garbage collector ---------------------------------------------------------------

def gc_freeze() -> SettingReport:
    """gc.collect() now, then gc.freeze(): every live object leaves the collector's reach."""
    gc.collect()
    gc.freeze()
    return SettingReport("gc", True, f"collected, then froze {gc.get_freeze_count()} objects "
                                     "(full collections no longer walk them)")


def gc_disable() -> SettingReport:
    gc.disable()
    return SettingReport("gc", True, "automatic collection disabled (call gc.collect() outside the loop)")


# -- everything at once ----------------------------------------------------------------------

@contextlib.contextmanager
def realtime(policy: str | None = "fifo", priority: int = RT_PRIORITY, cpus=None, lock: bool = True,
             stack_size: int = 1024 * 1024, heap_size: int = 64 * 1024 * 1024, gc_mode: str | None = "freeze",
             quiet: bool = False):
    """Apply the real-time settings for a ``with`` block, yield the reports, undo them after.

    ``policy=None`` keeps SCHED_OTHER; ``cpus`` pins the thread; ``lock`` runs rttest's
    lock-and-prefault; ``gc_mode`` is "freeze", "disable" or None. On exit the thread's old
    policy, affinity, memory locking, malloc settings and gc state are restored.
    """
    if gc_mode not in ("freeze", "disable", None):
        raise ValueError(f"gc_mode {gc_mode!r}: use 'freeze', 'disable' or None")
    old_policy, old_prio = current_scheduling()
    old_affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    was_enabled = gc.isenabled()
    reports: list[SettingReport] = []
    try:
        if cpus is not None:
            reports.append(set_affinity(cpus, quiet=quiet))
        if lock:
            reports += lock_and_prefault(stack_size, heap_size, quiet=quiet)
        if gc_mode == "freeze":
            reports.append(gc_freeze())
        elif gc_mode == "disable":
            reports.append(gc_disable())
        if policy is not None:
            reports.append(set_scheduling(policy, priority, quiet=quiet))
        yield reports
    finally:
        reset_scheduling(old_policy, old_prio)
        if old_affinity is not None:
            with contextlib.suppress(OSError):
                os.sched_setaffinity(0, old_affinity)
        if lock:
            unlock_memory()
        if gc_mode == "freeze":
            gc.unfreeze()
        if was_enabled:
            gc.enable()


def describe(reports) -> str:
    """One line per report (the honest summary a notebook prints)."""
    return "\n".join(str(r) for r in reports)
