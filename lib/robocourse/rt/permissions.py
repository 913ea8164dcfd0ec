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
