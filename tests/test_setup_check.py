"""Chapter 0's report: honest as root here and as an unprivileged user (run for real)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from robocourse import setup_check
from robocourse.rt import capabilities


def test_pins_are_read_from_requirements(root):
    pins = setup_check.pinned_versions(root / "requirements.txt")
    assert pins["meshcat"] == "0.3.2" and "numpy" in pins and "jupyterlab" in pins


def test_report_sections():
    text = setup_check.report(try_calls=False)
    for part in ("== Python and packages ==", "== 3D viewer ==", "RLIMIT_RTPRIO", "RLIMIT_MEMLOCK",
                 "kernel preemption", "timer slack", "cyclictest"):
        assert part in text


@pytest.mark.skipif(os.geteuid() != 0, reason="the privileged path needs root (CI runs as root)")
def test_root_is_told_it_may_do_everything():
    found = {f.name: f for f in capabilities.probe()}
    assert found["SCHED_FIFO (tried)"].ok and found["mlockall (tried)"].ok
    assert "CAP_SYS_NICE overrides" in found["RLIMIT_RTPRIO"].value


PROBE = "from robocourse.rt import capabilities as c; print(c.report())"


def _laptop_limits():
    # a normal laptop user's limits: no real-time priority, 64 kB of lockable memory
    import resource
    resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
    resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))


SETPRIV = shutil.which("setpriv")


@pytest.mark.skipif(os.geteuid() != 0 or SETPRIV is None,
                    reason="needs root and setpriv (util-linux) to drop CAP_SYS_NICE and CAP_IPC_LOCK for real")
def test_unprivileged_user_gets_the_seed_messages_and_fixes():
    # The process keeps uid 0 (the venv's Python lives in /root, unreadable to 'nobody') but loses the
    # two capabilities that let root ignore RLIMIT_RTPRIO and RLIMIT_MEMLOCK: the kernel then treats it
    # exactly like a laptop user with those limits.
    cmd = [SETPRIV, "--bounding-set=-sys_nice,-ipc_lock", "--inh-caps=-sys_nice,-ipc_lock", "--",
           sys.executable, "-c", PROBE]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60, preexec_fn=_laptop_limits)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "-- SCHED_FIFO (tried)" in out and "Couldn't set scheduling priority and policy: Operation not permitted" in out
    assert "-- mlockall (tried)" in out and "Couldn't lock all cached virtual memory." in out
    assert "rtprio 98" in out and "memlock -1" in out and "setcap cap_sys_nice+ep" in out
    assert "-- RLIMIT_RTPRIO" in out and "CAP_SYS_NICE no" in out


def test_doctor_command_runs():
    proc = subprocess.run([sys.executable, "-m", "robocourse.cli", "doctor", "--no-try"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "RLIMIT_MEMLOCK" in proc.stdout
