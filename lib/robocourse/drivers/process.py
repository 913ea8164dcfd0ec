"""Run a simulated controller box in its own process: start, wait until it listens, stop, clean up.

Counterpart: the robot's controller is another computer; here it is another process on the
same machine, so a driver sees real socket timing (the kernel's loopback, the scheduler) and a
box crash looks like a robot that went silent.

- The box binds its ports itself (port 0 = a free one chosen by the kernel; the UR box: UR's
  fixed ports on a free loopback address, :mod:`robocourse.drivers.loopback`; no race either
  way) and prints one line ``READY [host=<address>] <name>=<port> ...`` on stdout;
  :meth:`BoxProcess.start` waits for it.
- The child starts under SCHED_OTHER whatever its parent runs at (a real-time parent's policy
  is not inherited); a box asked for real-time settings (``--rt``) takes its own.
- No leftovers: the child asks the kernel for SIGKILL when its parent dies
  (``prctl(PR_SET_PDEATHSIG)``), runs in its own session (a Ctrl-C in the notebook does not
  reach it; :meth:`stop` does), and also exits when it sees it was re-parented.
- A box that fails to start (a port in use, a bad argument) exits non-zero with its reason on
  stderr; :meth:`start` raises :class:`BoxStartError` quoting it.
"""

from __future__ import annotations

import ctypes
import os
import select
import signal
import subprocess
import sys
import time

_PR_SET_PDEATHSIG = 1


class BoxStartError(RuntimeError):
    """The box process did not come up; the message quotes its stderr."""


def _die_with_parent() -> None:  # runs in the child between fork and exec
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        pass
    # a child inherits its parent's policy: started from a SCHED_FIFO thread (a benchmark's loop)
    # the box's Python start-up would run as a real-time hog. It starts ordinary; ``--rt`` asks
    # for its own priority once it is up.
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (OSError, AttributeError):
        pass


class BoxProcess:
    """A box process started from ``python -m robocourse.drivers.box KIND ARGS``.

    ``ports``: {"command": 1337, "udp": ..., "monitor": ...} (Franka) or {"rtde": 30004,
    "dashboard": 29999, ...} (UR style) once started; ``host``: the address it listens on (each
    box its own 127.0.0.x). Use as a context manager or call :meth:`stop`.
    """

    def __init__(self, kind: str, args: list[str], startup_timeout: float = 60.0):
        if kind not in ("franka", "ur"):
            raise ValueError(f"box kind {kind!r} must be 'franka' or 'ur'")
        self.kind = kind
        self.args = [str(a) for a in args]
        self.startup_timeout = float(startup_timeout)
        self.proc: subprocess.Popen | None = None
        self.ports: dict[str, int] = {}
        self.host = "127.0.0.1"

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc is not None else None

    def start(self) -> BoxProcess:
        if self.proc is not None:
            raise RuntimeError(f"{self.kind} box already started (pid {self.proc.pid})")
        env = dict(os.environ)
        lib = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        env["PYTHONPATH"] = lib + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        env.setdefault("MUJOCO_GL", "disable")     # a box never renders: skip loading GLFW (~0.2 s of start-up)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "robocourse.drivers.box", self.kind, *self.args],
            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            preexec_fn=_die_with_parent, start_new_session=True, env=env)
        deadline = time.monotonic() + self.startup_timeout
        line = b""
        while not line.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or self.proc.poll() is not None:
                break
            ready, _, _ = select.select([self.proc.stdout], [], [], min(left, 0.2))
            if ready:
                ch = os.read(self.proc.stdout.fileno(), 1)
                if not ch:
                    break
                line += ch
        if not line.startswith(b"READY"):
            self._reap()
            err = self.proc.stderr.read().decode(errors="replace").strip() if self.proc.stderr else ""
            code = self.proc.returncode
            self.proc = None
            why = err.splitlines()[-1] if err else f"no message, timed out after {self.startup_timeout:.0f} s"
            raise BoxStartError(f"the {self.kind} box did not start (exit code {code}): {why}")
        fields = dict(kv.split("=", 1) for kv in line.decode().split()[1:])
        self.host = fields.pop("host", "127.0.0.1")
        self.ports = {k: int(v) for k, v in fields.items()}
        return self

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def kill(self) -> None:
        """SIGKILL the box (a crash, as a test injects it)."""
        if self.alive():
            self.proc.kill()
            self.proc.wait(5)

    def _reap(self) -> None:
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(3)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(3)

    def stop(self) -> int | None:
        """Terminate (then kill) the box; returns its exit code."""
        if self.proc is None:
            return None
        self._reap()
        for f in (self.proc.stdout, self.proc.stderr):
            if f:
                f.close()
        code = self.proc.returncode
        self.proc = None
        return code

    def __enter__(self) -> BoxProcess:
        return self.start() if self.proc is None else self

    def __exit__(self, *exc) -> None:
        self.stop()

    def __del__(self):
        try:
            self.stop()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass

    def __repr__(self) -> str:
        return f"BoxProcess({self.kind!r}, pid={self.pid}, host={self.host!r}, ports={self.ports})"
