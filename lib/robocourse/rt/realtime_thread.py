"""configure_realtime_thread: name the calling thread, make it real-time, lock memory, verify.

Counterpart: the bridge article's ``configure_realtime_thread`` (pthread_setname_np,
pthread_setschedparam(SCHED_FIFO, prio), mlockall(MCL_CURRENT | MCL_FUTURE), then read back
what the kernel actually applied). The scheduling and memory calls are robocourse.rt's
(``rt.settings.set_scheduling`` / ``lock_memory``); this adds the thread name and the
read-back. Unprivileged, each refused step is reported with the reason and the fix, and the
thread carries on under SCHED_OTHER, as it would on a student's laptop.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading
from dataclasses import dataclass, field
from pathlib import Path

from robocourse.rt import settings

PR_SET_NAME = 15
_LIBC = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)


def thread_name() -> str:
    """The kernel's name of the calling thread (/proc/thread-self/comm; what top -H shows)."""
    try:
        return Path("/proc/thread-self/comm").read_text().strip()
    except OSError:
        return threading.current_thread().name


@dataclass
class RealtimeThreadReport:
    """What was asked, what the kernel reports back, and the reports of each step."""

    name: str
    policy: str
    priority: int
    applied_name: str
    applied_policy: str
    applied_priority: int
    memory_locked: bool
    reports: list = field(default_factory=list)

    @property
    def realtime(self) -> bool:
        """True when the kernel runs this thread under the asked policy and priority."""
        want = settings.POLICIES[self.policy]
        return self.applied_policy == want and (self.policy == "other" or self.applied_priority == self.priority)

    def __str__(self) -> str:
        lines = [f"thread '{self.applied_name}': {self.applied_policy} priority {self.applied_priority}, "
                 f"memory {'locked' if self.memory_locked else 'NOT locked'} "
                 f"(asked: '{self.name}', {settings.POLICIES[self.policy]} {self.priority})"]
        lines += [str(r) for r in self.reports]
        return "\n".join(lines)


def configure_realtime_thread(name: str, policy: str = "fifo", priority: int = 80, lock_memory: bool = True,
                              quiet: bool = True) -> RealtimeThreadReport:
    """Configure the calling thread; return the verified :class:`RealtimeThreadReport`."""
    if not isinstance(name, str) or not name or len(name.encode()) > 15:
        raise ValueError(f"thread name {name!r} must be 1..15 bytes (the kernel's TASK_COMM_LEN 16 with the NUL), "
                         "e.g. 'cerebellum'")
    key = str(policy).lower().replace("sched_", "")
    if key not in settings.POLICIES:
        raise ValueError(f"policy {policy!r}: use 'fifo', 'rr' or 'other'")
    reports = []
    threading.current_thread().name = name
    ok = _LIBC.prctl(PR_SET_NAME, ctypes.c_char_p(name.encode()), 0, 0, 0) == 0
    reports.append(settings.SettingReport("thread name", ok, f"prctl(PR_SET_NAME, {name!r})"
                                          + ("" if ok else " refused")))
    reports.append(settings.set_scheduling(key, priority, quiet=quiet))
    if lock_memory:
        reports.append(settings.lock_memory(quiet=quiet))
    got_policy, got_prio = settings.current_scheduling()
    return RealtimeThreadReport(name, key, int(priority), thread_name(), got_policy, got_prio,
                                settings.memory_locked(), reports)


def release_realtime_thread(report: RealtimeThreadReport) -> None:
    """Back to SCHED_OTHER and unlocked memory (what the deployment does when it stops)."""
    settings.reset_scheduling()
    if report.memory_locked:
        settings.unlock_memory()
