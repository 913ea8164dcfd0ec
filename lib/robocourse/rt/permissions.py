"""See what an unprivileged student sees: run code in a child without real-time permissions.

The child lowers RLIMIT_RTPRIO to 0 and RLIMIT_MEMLOCK to 64 KiB (the usual desktop limits)
and, when started as root, also drops to the ``nobody`` user, because root ignores those
limits. Everything it needs is imported before dropping root, so the interpreter's own
files may stay unreadable to ``nobody``. No ROS 2 counterpart: it replays what the pendulum
demo prints on a machine without the limits.conf lines.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

_LIB = str(Path(__file__).resolve().parents[2])

_PRELUDE = textwrap.dedent("""
    import ctypes, os, resource, sys
    sys.path.insert(0, {lib!r})
    import numpy as np
    import robocourse.rt as rt
    from robocourse.rt import settings
    resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
    resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))
    if os.geteuid() == 0:
        os.setgroups([])
        os.setgid(65534)
        os.setuid(65534)
        ctypes.CDLL(None).prctl(4, 1, 0, 0, 0)  # PR_SET_DUMPABLE: like any ordinary user process
""")


def run_unprivileged(code: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run ``code`` (Python source using ``rt`` and ``settings``) without RT privileges."""
    script = _PRELUDE.format(lib=_LIB) + textwrap.dedent(code)
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=timeout,
                          cwd="/", env=env)


_LOCKED_ALLOCATION = textwrap.dedent("""
    import ctypes, os, resource
    def vm_kb():
        return int(next(line for line in open("/proc/self/status") if line.startswith("VmSize")).split()[1])
    soft, hard = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    if os.geteuid() == 0:  # root ignores RLIMIT_MEMLOCK (CAP_IPC_LOCK): become an ordinary user first
        os.setgroups([])
        os.setgid(65534)
        os.setuid(65534)
    limit = "unlimited" if soft == resource.RLIM_INFINITY else f"{soft // 1024} kB"
    print(f"ulimit -l (RLIMIT_MEMLOCK): {limit}; this process maps {vm_kb()} kB")
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.mlockall(2) != 0:  # MCL_FUTURE: every page mapped from now on is locked
        print("mlockall(MCL_FUTURE) failed:", os.strerror(ctypes.get_errno()))
        raise SystemExit(0)
    print("mlockall(MCL_FUTURE) ok: every new page must now be locked in RAM, within that limit")
    held = []
    try:
        while len(held) < CAP_MB:
            held.append(bytearray(1 << 20))
        print(f"allocated {len(held)} MiB without an error (the limit is larger; stopped there)")
    except MemoryError:
        print(f"MemoryError after {len(held)} MiB of new allocations: malloc returned NULL "
              "(C++ would throw std::bad_alloc)")
""")


def locked_allocation_demo(cap_mb: int = 256, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """In a child without CAP_IPC_LOCK: mlockall(MCL_FUTURE), then allocate 1 MiB blocks until it fails.

    With ``RLIMIT_MEMLOCK`` (``ulimit -l``) as the cap on locked memory, the allocation that
    crosses it fails: the C library's malloc returns NULL, which C++ reports as std::bad_alloc and
    Python as MemoryError. Stops after ``cap_mb`` MiB when the limit is larger than that.
    """
    if isinstance(cap_mb, bool) or not isinstance(cap_mb, int) or cap_mb < 1:
        raise ValueError(f"cap_mb={cap_mb!r}: a positive number of MiB, e.g. 256")
    script = _LOCKED_ALLOCATION.replace("CAP_MB", str(cap_mb))
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=timeout, cwd="/")
