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


def test_shipped_pins_equal_requirements_txt(root):
    """doctor needs no requirements.txt, so the package ships the pins; they must not drift apart."""
    from robocourse.setup_check.pins import PINS

    from_file = setup_check.pinned_versions(root / "requirements.txt")
    shipped = setup_check.shipped_pins()
    assert shipped == {name: from_file[name] for name in shipped}
    assert {name for name, _, _ in PINS} == set(setup_check.PACKAGES) - {"robocourse"}


def test_missing_requirements_file_is_an_error_not_any_version_is_fine(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such requirements file"):
        setup_check.pinned_versions(tmp_path / "requirements.txt")


def test_doctor_flags_a_version_other_than_the_shipped_pin(monkeypatch):
    from importlib import metadata

    real = metadata.version
    monkeypatch.setattr(metadata, "version", lambda name: "0.0.1" if name == "numpy" else real(name))
    found = {f.name: f for f in setup_check.versions()}
    assert not found["numpy"].ok and found["numpy"].value == f"0.0.1 (course pins {setup_check.shipped_pins()['numpy']})"
    found = {f.name: f for f in setup_check.versions(pins={})}  # a package without a pin is never "ok"
    assert not found["scipy"].ok and "no pin known" in found["scipy"].value


def test_setcap_advice_never_targets_a_symlinked_base_interpreter(monkeypatch, tmp_path):
    base = tmp_path / "base" / "python3.11"
    base.parent.mkdir()
    base.write_text("")
    link = tmp_path / "venv" / "bin" / "python3"
    link.parent.mkdir(parents=True)
    link.symlink_to(base)
    monkeypatch.setattr(sys, "executable", str(link))
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "venv"))
    text = capabilities.rtprio_fix()
    assert text.splitlines()[0].startswith("add to /etc/security/limits.conf:")  # limits.conf first
    assert f"never setcap\n  {base}\nitself: that grants it to every Python script on the machine" in text
    assert "python3 -m venv --copies .venv-rt" in text and "sudo setcap cap_sys_nice+ep .venv-rt/bin/python3" in text
    assert f"setcap cap_sys_nice+ep {base}" not in text and f"setcap cap_sys_nice+ep {link}" not in text


def test_setcap_advice_on_a_copied_venv_interpreter_names_it(monkeypatch, tmp_path):
    copy = tmp_path / "venv-rt" / "bin" / "python3"
    copy.parent.mkdir(parents=True)
    copy.write_text("")
    monkeypatch.setattr(sys, "executable", str(copy))
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "venv-rt"))
    assert capabilities.memlock_fix().endswith(f"copied venv interpreter only:\n  sudo setcap cap_ipc_lock+ep {copy}")


def test_without_linux_scheduling_the_report_and_the_demo_say_so_and_carry_on(monkeypatch):
    """What a macOS student gets: no sched_* calls and no RLIMIT_RTPRIO; nothing crashes."""
    import resource

    from robocourse.pendulum import demo

    for name in ("sched_setscheduler", "sched_getscheduler", "sched_getparam", "sched_setaffinity", "sched_getaffinity"):
        monkeypatch.delattr(os, name, raising=False)
    monkeypatch.delattr(resource, "RLIMIT_RTPRIO", raising=False)
    found = {f.name: f for f in capabilities.probe(try_calls=True)}
    assert not found["real-time scheduling"].ok and "not available on" in found["real-time scheduling"].value
    assert not found["SCHED_FIFO (tried)"].ok and "not Linux" in found["SCHED_FIFO (tried)"].value
    run = demo.run_realtime(30, quiet=True, lock_memory=False)
    assert run.loop.iterations == 30 and not run.settings[0].ok
    assert run.settings[0].detail == "this OS has no sched_setscheduler"
