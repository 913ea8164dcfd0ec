"""A network namespace with a veth pair: the wire between a real master and our bus.

``with VethPair() as v:`` creates namespace ``v.ns`` holding interface ``v.master_if`` and
leaves its peer ``v.bus_if`` in this namespace, both up; on exit both are deleted, always.
The master runs inside the namespace (``v.run([...])`` = ``ip netns exec``), the bus here.
Needs root (CAP_NET_ADMIN) and iproute2; ``why_not()`` says in one sentence what is missing.
"""

from __future__ import annotations

import os
import shutil
import subprocess


def why_not() -> str | None:
    """None when a veth pair can be made here, else the reason."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return "needs root to create a network namespace and a veth pair (run as root, as CI does)"
    if shutil.which("ip") is None:
        return "needs iproute2's `ip` (apt-get install iproute2)"
    return None


class VethPair:
    """Namespace ``ns`` with ``master_if``; ``bus_if`` stays in the caller's namespace."""

    def __init__(self, tag: str | None = None) -> None:
        # the pid, whole: names are machine-wide, and two runs on one machine must never share one
        # (a pair found with this name is a leftover of a killed run of this pid, and __enter__ removes it)
        tag = tag or f"{os.getpid()}"
        self.ns = f"rcecat{tag}"
        self.master_if = f"rcm{tag}"[:15]
        self.bus_if = f"rcs{tag}"[:15]

    def _ip(self, *args: str) -> None:
        r = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)
        if r.returncode:
            raise OSError(f"ip {' '.join(args)} failed: {r.stderr.strip()}")

    def __enter__(self) -> VethPair:
        reason = why_not()
        if reason:
            raise PermissionError(reason)
        self.close()  # a leftover from a killed run
        try:
            self._ip("netns", "add", self.ns)
            self._ip("link", "add", self.master_if, "type", "veth", "peer", "name", self.bus_if)
            self._ip("link", "set", self.master_if, "netns", self.ns)
            self._ip("link", "set", self.bus_if, "up")
            self._ip("netns", "exec", self.ns, "ip", "link", "set", self.master_if, "up")
        except Exception:
            self.close()
            raise
        return self

    def run(self, argv: list[str], timeout: float) -> subprocess.CompletedProcess:
        """Run ``argv`` inside the namespace; killed after ``timeout`` seconds."""
        return subprocess.run(["ip", "netns", "exec", self.ns, *argv], capture_output=True,
                              text=True, timeout=timeout)

    def close(self) -> None:
        subprocess.run(["ip", "link", "del", self.bus_if], capture_output=True, timeout=20)
        subprocess.run(["ip", "netns", "del", self.ns], capture_output=True, timeout=20)

    def __exit__(self, *exc: object) -> None:
        self.close()


def run_pysoem(bus, cycles: int = 1000, timeout: float = 180.0, sdo_slave: int = 0) -> dict:
    """Serve ``bus`` on a fresh veth pair and run ``pysoem_probe`` against it in the namespace.

    Returns the probe's JSON report plus ``bus_replies``; raises with the probe's stderr when
    it fails or times out. Everything is torn down on the way out.
    """
    import json
    import sys

    from .transport import serve

    with VethPair() as v:
        server = serve(bus, v.bus_if)
        try:
            r = v.run([sys.executable, "-m", "robocourse.ethercat.pysoem_probe", v.master_if,
                       "--cycles", str(cycles), "--sdo-slave", str(sdo_slave)], timeout=timeout)
        finally:
            server.stop()
        if r.returncode:
            raise RuntimeError(f"pysoem probe exited {r.returncode}: {r.stderr.strip()[-2000:]}")
        rep = json.loads(r.stdout.strip().splitlines()[-1])
        rep["bus_replies"] = server.replies
        return rep
