"""What this machine lets a process do for real-time work, each item with its exact fix.

No ROS 2 counterpart as one call: it gathers what rttest and the ROS 2 real-time docs tell you
to check by hand (RLIMIT_RTPRIO, RLIMIT_MEMLOCK, the kernel's preemption model, timer slack,
RT throttling, cyclictest). Every probe *tries* rather than guesses: scheduling is attempted
and reverted in this thread; mlockall is attempted in a throw-away subprocess.
"""

from __future__ import annotations

import getpass
import os
import platform
import resource
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

RT_PRIORITY = 98  # the seed's priority; never 99, the kernel's watchdogs live there
CAP_IPC_LOCK = 14
CAP_SYS_NICE = 23


@dataclass
class Finding:
    """One line of the report: what, what we found, is it good for RT work, and the fix."""

    name: str
    value: str
    ok: bool
    fix: str = ""

    def line(self) -> str:
        mark = "ok " if self.ok else "-- "
        text = f"{mark}{self.name:<28} {self.value}"
        if not self.ok and self.fix:
            first, *rest = self.fix.splitlines()
            text += "\n      fix: " + first + "".join("\n           " + r for r in rest)
        return text


def _user() -> str:
    try:
        return getpass.getuser()
    except Exception:
        return str(os.geteuid())


def interpreter_is_copy() -> bool:
    """True when this Python is a venv's own copy (``python -m venv --copies``), not a symlink.

    A venv made the default way links ``bin/python`` to the base interpreter; ``setcap`` follows
    the link and marks the base binary, which every Python script on the machine runs.
    """
    exe = sys.executable
    # os.path answers False where it may not look (an unprivileged child cannot read root's venv)
    return sys.prefix != sys.base_prefix and os.path.isfile(exe) and not os.path.islink(exe)


def setcap_advice(caps: str, lead: str = "or, without a new login,") -> str:
    """The capability route, only ever on a copied interpreter (``caps`` e.g. "cap_sys_nice").

    ``lead`` joins it to the advice before it: after limits.conf, "or, without a new login,"; after
    "run it as root (sudo)", where no limits.conf route exists, e.g. "or, without sudo, set it"."""
    if interpreter_is_copy():
        return (f"{lead} for this copied venv interpreter only:\n"
                f"  sudo setcap {caps}+ep {sys.executable}")
    base = os.path.realpath(sys.executable)
    return (f"{lead} on a COPIED interpreter only; never setcap\n"
            f"  {base}\n"
            "itself: that grants it to every Python script on the machine:\n"
            "  python3 -m venv --copies .venv-rt && .venv-rt/bin/pip install -r requirements.txt -e .\n"
            f"  sudo setcap {caps}+ep .venv-rt/bin/python3")


def rtprio_fix(priority: int = RT_PRIORITY) -> str:
    """limits.conf first (never 99), then the copied-interpreter setcap route."""
    return (f"add to /etc/security/limits.conf:  {_user()} - rtprio {min(max(priority, 1), 98)}\n"
            "then log out and in again (never 99: the kernel's watchdog threads run there);\n"
            + setcap_advice("cap_sys_nice"))


def memlock_fix() -> str:
    """limits.conf first, then the copied-interpreter setcap route."""
    return (f"add to /etc/security/limits.conf:  {_user()} - memlock -1   (or a size in kB, e.g. 1048576)\n"
            "then log out and in again;\n" + setcap_advice("cap_ipc_lock"))


def _limit_text(value: int) -> str:
    return "unlimited" if value == resource.RLIM_INFINITY else str(value)


def effective_capabilities() -> int:
    """Bitmask of this process's effective Linux capabilities (CapEff in /proc/self/status)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("CapEff:"):
                return int(line.split()[1], 16)
    except OSError:
        pass
    return 0


def preemption_model() -> str:
    """'PREEMPT_RT', 'PREEMPT', 'PREEMPT_DYNAMIC (mode)', 'VOLUNTARY' or 'NONE' from the running kernel."""
    version = platform.version()
    if Path("/sys/kernel/realtime").exists() and Path("/sys/kernel/realtime").read_text().strip() == "1":
        return "PREEMPT_RT"
    if "PREEMPT_RT" in version:
        return "PREEMPT_RT"
    if "PREEMPT_DYNAMIC" in version:
        mode = ""
        try:
            text = Path("/sys/kernel/debug/sched/preempt").read_text()
            mode = next((w.strip("()") for w in text.split() if w.startswith("(")), "")
        except OSError:
            pass
        return f"PREEMPT_DYNAMIC ({mode})" if mode else "PREEMPT_DYNAMIC"
    if "PREEMPT" in version:
        return "PREEMPT"
    return "VOLUNTARY or NONE"


def timer_slack_ns() -> int | None:
    try:
        return int(Path("/proc/self/timerslack_ns").read_text())
    except (OSError, ValueError):
        return None


def try_rt_scheduling(priority: int = RT_PRIORITY) -> tuple[bool, str]:
    """Try SCHED_FIFO at ``priority`` for the calling thread, then restore its old policy."""
    if not hasattr(os, "sched_setscheduler"):
        return False, "this OS has no sched_setscheduler (not Linux)"
    old_policy = os.sched_getscheduler(0)
    old_param = os.sched_getparam(0)
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as exc:
        return False, f"Couldn't set scheduling priority and policy: {exc.strerror}"
    os.sched_setscheduler(0, old_policy, old_param)
    return True, f"SCHED_FIFO priority {priority} accepted (then restored)"


_MLOCK_PROBE = r"""
import ctypes, ctypes.util, os, sys
libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
rc = libc.mlockall(1 | 2)  # MCL_CURRENT | MCL_FUTURE
if rc != 0:
    print("mlockall failed: " + os.strerror(ctypes.get_errno())); sys.exit(1)
libc.munlockall(); print("ok")
"""


def try_mlockall() -> tuple[bool, str]:
    """Try mlockall(MCL_CURRENT | MCL_FUTURE) in a short-lived Python subprocess."""
    proc = subprocess.run([sys.executable, "-c", _MLOCK_PROBE], capture_output=True, text=True, timeout=30)
    text = (proc.stdout or proc.stderr).strip().splitlines()[-1:] or ["no answer"]
    if proc.returncode == 0:
        return True, "mlockall(MCL_CURRENT | MCL_FUTURE) succeeded in a test process"
    return False, f"{text[0]}. Couldn't lock all cached virtual memory."


def probe(try_calls: bool = True) -> list[Finding]:
    """The full report, as a list of findings (see :func:`report` for the printed form)."""
    user = _user()
    caps = effective_capabilities()
    out: list[Finding] = []
    nice, ipc = bool(caps >> CAP_SYS_NICE & 1), bool(caps >> CAP_IPC_LOCK & 1)
    out.append(Finding("user", f"{user} (uid {os.geteuid()}; CAP_SYS_NICE {'yes' if nice else 'no'}, "
                               f"CAP_IPC_LOCK {'yes' if ipc else 'no'})", True))

    if not hasattr(resource, "RLIMIT_RTPRIO") or not hasattr(os, "sched_setscheduler"):
        out.append(Finding("real-time scheduling", f"not available on {platform.system()}", False,
                           "SCHED_FIFO/RR, RLIMIT_RTPRIO and CPU affinity are Linux calls: the chapters\n"
                           "still run and measure here, under the default scheduler; use Linux for RT runs"))
    else:
        soft, hard = resource.getrlimit(resource.RLIMIT_RTPRIO)
        out.append(Finding(
            "RLIMIT_RTPRIO", f"soft {_limit_text(soft)}, hard {_limit_text(hard)}"
            + (" (CAP_SYS_NICE overrides it)" if nice else ""), nice or soft >= 1, rtprio_fix(RT_PRIORITY)))

    soft, hard = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    mem_ok = ipc or soft == resource.RLIM_INFINITY
    out.append(Finding(
        "RLIMIT_MEMLOCK", f"soft {_limit_text(soft)} B, hard {_limit_text(hard)} B"
        + (" (CAP_IPC_LOCK overrides it)" if ipc else ""), mem_ok, memlock_fix()))

    if try_calls:
        ok, text = try_rt_scheduling()
        out.append(Finding("SCHED_FIFO (tried)", text, ok,
                           f"grant rtprio as above (limits.conf: {user} - rtprio {RT_PRIORITY})"))
        ok, text = try_mlockall()
        out.append(Finding("mlockall (tried)", text, ok, f"grant memlock as above (limits.conf: {user} - memlock -1)"))

    model = preemption_model()
    out.append(Finding("kernel preemption", f"{model} ({platform.release()})", model.startswith("PREEMPT_RT"),
                       "a PREEMPT_RT kernel bounds worst-case latency to tens of us; e.g. Ubuntu:\n"
                       "sudo pro enable realtime-kernel, or Debian: sudo apt-get install linux-image-rt-amd64"))

    slack = timer_slack_ns()
    out.append(Finding("timer slack", f"{slack} ns" if slack is not None else "unknown", slack == 0,
                       "plain sleeps may oversleep by this much under SCHED_OTHER; real-time\n"
                       "scheduling (SCHED_FIFO/RR) sets it to 0, or use a hybrid sleep-then-spin wait"))

    try:
        runtime = int(Path("/proc/sys/kernel/sched_rt_runtime_us").read_text())
        period = int(Path("/proc/sys/kernel/sched_rt_period_us").read_text())
        out.append(Finding("RT throttling", f"{runtime} of {period} us" if runtime >= 0 else "off (-1)", True))
    except (OSError, ValueError):
        pass

    isolated = ""
    try:
        isolated = Path("/sys/devices/system/cpu/isolated").read_text().strip()
    except OSError:
        pass
    out.append(Finding("CPUs", f"{os.cpu_count()} online; isolated: {isolated or 'none'}", True))

    cyclictest = shutil.which("cyclictest")
    out.append(Finding("cyclictest", cyclictest or "not installed", cyclictest is not None,
                       "sudo apt-get install rt-tests   (Fedora: sudo dnf install realtime-tests)"))
    return out


def report(findings: list[Finding] | None = None) -> str:
    findings = probe() if findings is None else findings
    return "\n".join(f.line() for f in findings)
