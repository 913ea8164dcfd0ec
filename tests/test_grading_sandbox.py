"""The sandbox on its own: no network, an allow-listed environment, limits that end the whole run."""

from __future__ import annotations

import os
import socket
import sys
import threading

import pytest

from robocourse.grading import sandbox

BWRAP = sandbox.bwrap_works()
needs_bwrap = pytest.mark.skipif(not BWRAP, reason="bubblewrap (bwrap) is missing or cannot create namespaces "
                                                   "here: network and file-system isolation need it")
MODES = ["process"] + (["bwrap"] if BWRAP else [])


def _run(tmp_path, code, mode, **limits):
    work = tmp_path / f"w-{mode}"
    work.mkdir()
    return sandbox.run([sys.executable, "-c", code], work, sandbox.Limits(**{"time_s": 30, **limits}), mode)


@needs_bwrap
def test_no_network_inside_the_sandbox(tmp_path):
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]
    try:
        out = _run(tmp_path, f"import socket\ntry:\n    socket.create_connection(('127.0.0.1', {port}), timeout=3)\n"
                             "    print('connected')\nexcept OSError as exc:\n    print('refused', type(exc).__name__)",
                   "bwrap")
        # the run is over: a connection that had reached the server would wait in its accept queue (the kernel
        # completes the handshake without accept()); none may be there
        server.setblocking(False)
        with pytest.raises(BlockingIOError):
            server.accept()
    finally:
        server.close()
    assert "refused" in out.log


@pytest.mark.parametrize("mode", MODES)
def test_environment_is_an_allow_list(tmp_path, mode, monkeypatch):
    monkeypatch.setenv("COURSE_LMS_TOKEN", "secret-123")
    out = _run(tmp_path, "import os; print(sorted(os.environ))", mode)
    names = eval(out.log)  # noqa: S307 - our own child's printed list
    assert "COURSE_LMS_TOKEN" not in names and "ROBOCOURSE_GRADING" in names and "HOME" in names
    assert "secret-123" not in out.log


@pytest.mark.parametrize("mode", MODES)
def test_time_limit_kills_the_whole_group_including_setsid_children(tmp_path, mode):
    code = ("import subprocess, time\nsubprocess.Popen(['setsid', 'sleep', '984.25'])\n"
            "subprocess.Popen(['sleep', '984.5'])\ntime.sleep(600)")
    out = _run(tmp_path, code, mode, time_s=2)
    assert out.stopped == "time" and out.leftover == 0
    import psutil

    alive = [p for p in psutil.process_iter(["cmdline"]) if "984." in " ".join(p.info["cmdline"] or [])]
    assert alive == []


@pytest.mark.parametrize("mode", MODES)
def test_output_is_bounded_and_the_file_size_capped(tmp_path, mode):
    code = ("import os\nchunk = b'y' * (1 << 20)\nwritten = 0\ntry:\n    for _ in range(200):\n"
            "        written += os.write(1, chunk)\nexcept OSError as exc:\n"
            "    open('count.txt', 'w').write(f'{written} {exc.errno}')\n")
    out = _run(tmp_path, code, mode, output_bytes=1000, file_bytes=8 * 1024 * 1024)
    assert out.log_truncated and len(out.log) == 1000 and out.stopped == ""
    assert (tmp_path / f"w-{mode}" / "count.txt").read_text() == f"{8 * 1024 * 1024} 27"  # EFBIG at the cap


@needs_bwrap
def test_sandbox_sees_only_its_folder_and_read_only_library(tmp_path):
    import robocourse

    lib = os.path.dirname(robocourse.__file__)
    code = (f"import os\nprint(sorted(os.listdir('/submission')))\nprint(os.path.exists({str(tmp_path)!r}))\n"
            f"print(os.path.exists({os.getcwd()!r} + '/solutions'))\n"
            f"try:\n    open({lib!r} + '/x.py', 'w')\nexcept OSError as exc:\n    print(type(exc).__name__, exc.errno)\n"
            "print(len([p for p in os.listdir('/proc') if p.isdigit()]))")
    out = _run(tmp_path, code, "bwrap")
    lines = out.log.split("\n")
    assert lines[0] == "['tmp']" and lines[1] == "False" and lines[2] == "False"
    assert lines[3] == "OSError 30"  # EROFS: read-only file system
    assert int(lines[4]) <= 3  # bwrap's init and this process: nothing else is visible


@needs_bwrap
def test_a_course_living_under_tmp_keeps_its_read_only_binds_and_a_private_tmp(tmp_path):
    # a clone (and its venv) under /tmp: bwrap failed with "Can't make symlink at /tmp: File exists"
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory(dir="/tmp") as course:
        with open(os.path.join(course, "lib.txt"), "w") as f:
            f.write("library")
        work = tmp_path / "w"
        (work / "tmp").mkdir(parents=True)
        code = (f"import os\nprint(open({course!r} + '/lib.txt').read())\n"
                f"try:\n    open({course!r} + '/x', 'w')\nexcept OSError as exc:\n    print('OSError', exc.errno)\n"
                "open('/tmp/scratch.txt', 'w').write('mine')\nprint(sorted(os.listdir('/submission')))")
        cmd = sandbox.bwrap_command(work, [sys.executable, "-c", code], sandbox.clean_env(sandbox.SANDBOX_ROOT, "t"),
                                    read_only=[*sandbox._read_only_paths(), course])
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        assert out.stdout.splitlines() == ["library", "OSError 30", "['tmp']"]
        assert (work / "tmp" / "scratch.txt").read_text() == "mine"   # /tmp is the submission's own tmp
        assert not os.path.exists(os.path.join(course, "x"))


def test_a_cgroup_that_cannot_be_made_falls_back_to_polling_and_says_why(monkeypatch):
    from robocourse.grading import resources

    monkeypatch.setattr(resources, "_own_v1_path", lambda controller: resources.Path("/proc/no-such-cgroup"))
    with resources.Box(512, 64, None, mode="cgroup-v1") as box:
        assert box.mode == "polling" and box.dirs == {}
        assert "the cgroup could not be made" in box.describe()


def test_the_delegated_cgroup_v2_scope_carries_every_limit():
    """The systemd-run line of the delegated cgroup v2 way (a non-root grader on a systemd desktop); the
    scope itself is not started here: this machine has no systemd user session (see the next test)."""
    from robocourse.grading import resources

    with resources.Box(512, 64, (1,), mode="cgroup-v2-delegated") as box:
        cmd = box.wrap(["python3", "-m", "robocourse.grading.runner"])
    assert cmd[:4] == ["systemd-run", "--user", "--scope", "--quiet"] and cmd[4] == f"--unit={box.unit}"
    props = [cmd[i + 1] for i, x in enumerate(cmd) if x == "-p"]
    assert props == ["MemoryMax=512M", "MemorySwapMax=0", "TasksMax=64", "CPUQuota=100%", "AllowedCPUs=1",
                     f"CPUWeight={100 * resources.TIMING_WEIGHT}"]
    assert cmd[cmd.index("--") + 1:] == ["python3", "-m", "robocourse.grading.runner"]


def test_without_a_cgroup_the_grader_says_why_and_what_the_instructor_needs(monkeypatch):
    """A non-root grader: cgroup v1 is refused, and the delegated v2 trial really runs systemd-run where it
    exists (on a machine without a systemd user session it fails: "Failed to connect to bus")."""
    import shutil

    from robocourse.grading import resources

    monkeypatch.setattr(resources, "_MODE", [])
    monkeypatch.setattr(resources, "WHY_NOT", {})
    monkeypatch.delenv("ROBOCOURSE_GRADE_RESOURCES", raising=False)
    monkeypatch.setattr(resources.os, "geteuid", lambda: 1000)
    works = resources._v2_delegated_usable()
    if works:
        pytest.skip("the delegated cgroup v2 works here: the fallback is not taken")
    resources.WHY_NOT.clear()
    assert resources.mode() == "polling"
    hint = resources.fallback_hint()
    assert "cgroup-v1: the grader is not root" in hint
    if shutil.which("systemd-run"):
        assert "`systemd-run --user --scope --quiet -p MemoryMax=64M -p TasksMax=16 -p CPUQuota=100% true` failed" in hint
    else:
        assert "systemd-run is not installed" in hint
    assert "as root with the cgroup v1 memory, pids, cpu and cpuset controllers mounted" in hint
    assert "Delegate=yes" in hint


def test_the_library_is_compiled_outside_the_sandbox_and_its_judges_are_not():
    import importlib.util
    import time
    from pathlib import Path

    import robocourse
    from robocourse.grading import checks

    judges = checks.judge_side_modules(checks.discover())
    assert judges
    started = time.time()
    said = sandbox.compile_library(judges)
    if "read-only" in said:
        pytest.skip(said)
    root = Path(robocourse.__file__).resolve().parent
    assert list((root / "grading" / "__pycache__").glob("runner.*.pyc")), said
    for name in judges:
        origin = Path(importlib.util.find_spec(name).origin)
        fresh = [p for p in (origin.parent / "__pycache__").glob(f"{origin.stem}.*.pyc") if p.stat().st_mtime >= started]
        assert not fresh, f"a judge module was compiled for the sandbox: {fresh}"
        assert all(str(p) in sandbox.hidden_files([name])       # bytecode left by an unsandboxed run stays hidden
                   for p in (origin.parent / "__pycache__").glob(f"{origin.stem}.*.pyc"))


def test_the_private_dev_shm_is_size_limited(tmp_path):
    if not BWRAP:
        pytest.skip("bubblewrap is missing: /dev/shm cannot be private")
    code = ("import os\nchunk = b'x' * (1 << 20)\nn = 0\ntry:\n    with open('/dev/shm/fill', 'wb') as fh:\n"
            "        for _ in range(64):\n            fh.write(chunk)\n            fh.flush()\n            n += 1\n"
            "except OSError as exc:\n    print('full at', n, exc.errno)\n")
    out = _run(tmp_path, code, "bwrap", shm_mb=16)
    assert out.log.strip().startswith("full at") and out.log.split()[2] in ("15", "16"), out.log


def test_a_grader_at_a_real_time_priority_still_confines_its_submissions_in_cgroups():
    """The CI failure's root cause: a forked child inherits SCHED_FIFO, and a fresh v1 cpu cgroup has no
    real-time budget (cpu.rt_runtime_us = 0), so the kernel refused it (EINVAL in preexec_fn). The grader
    runs here at SCHED_FIFO in its own process; the submission must start in its cgroups at SCHED_OTHER."""
    import subprocess

    from robocourse.grading import resources

    if resources.mode() != "cgroup-v1":
        pytest.skip(f"cgroup v1 is not writable here (mode {resources.mode()})")
    code = (
        "import os, subprocess, sys\n"
        "from robocourse.grading import resources\n"
        "os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))\n"
        "with resources.Box(256, 32, None) as box:\n"
        "    out = subprocess.run([sys.executable, '-c', 'import os; print(os.sched_getscheduler(0)); "
        "print(open(\"/proc/self/cgroup\").read())'], preexec_fn=box.join, capture_output=True, text=True, timeout=60)\n"
        "    print(box.mode, box.fallback or '-', box.dirs['cpu'].name)\n"
        "    print(out.stdout, out.stderr)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    head, policy, *cgroups = proc.stdout.split("\n")
    mode, fallback, name = head.split(" ", 2)
    assert (mode, fallback) == ("cgroup-v1", "-"), proc.stdout
    assert int(policy) == os.SCHED_OTHER
    assert any(line.split(":")[1] == "cpu" and line.endswith(name) for line in cgroups if line.count(":") == 2), \
        proc.stdout


def test_cgroups_left_by_a_killed_grader_are_swept_and_live_ones_kept():
    from robocourse.grading import resources

    if resources.mode() != "cgroup-v1":
        pytest.skip(f"cgroup v1 is not writable here (mode {resources.mode()})")
    import subprocess

    dead = subprocess.Popen(["true"])
    dead.wait()
    base = resources._own_v1_path("pids")
    stale, live = base / f"robocourse-sub-{dead.pid}-test{os.getpid()}", base / f"robocourse-sub-{os.getpid()}-test"
    stale.mkdir()
    live.mkdir()
    try:
        assert resources.sweep_stale_v1(min_age_s=60) == []  # too young: a grader may be joining it now
        assert stale in resources.sweep_stale_v1(min_age_s=0) and not stale.exists() and live.exists()
    finally:
        for d in (stale, live):
            if d.exists():
                d.rmdir()


def test_a_timing_submission_runs_alone_and_one_waiting_goes_before_later_plain_ones():
    """The CPU gate behind 'a timing check gets the machine to itself': a spinner beside an honest timing
    check slowed it from 9/9 to 6/9 (issue 26). Plain A runs; timing T waits for A; plain B, asking after T,
    waits for T; T holds every allowed CPU, the plain ones none in particular."""
    import time

    from robocourse.grading import resources

    gate = resources.CpuGate()
    log: list = []
    release = {k: threading.Event() for k in "ATB"}
    started = {k: threading.Event() for k in "ATB"}

    def run(name, exclusive):
        with gate.hold(exclusive) as cpus:
            log.append(("start", name, cpus))
            started[name].set()
            release[name].wait(10)
            # logged while the gate is still held: appended after leaving it, the next holder's "start"
            # could come first whenever the machine preempts this thread in between
            log.append(("end", name))

    def until(cond):
        deadline = time.monotonic() + 10
        while not cond():
            assert time.monotonic() < deadline, log
            time.sleep(0.01)

    threads = {"A": threading.Thread(target=run, args=("A", False))}
    threads["A"].start()
    started["A"].wait(10)
    threads["T"] = threading.Thread(target=run, args=("T", True))
    threads["T"].start()
    until(lambda: gate._waiting == 1)
    threads["B"] = threading.Thread(target=run, args=("B", False))
    threads["B"].start()
    time.sleep(0.2)
    assert [e[:2] for e in log] == [("start", "A")]  # neither T nor B beside A's run... B waits behind T
    release["A"].set()
    started["T"].wait(10)
    time.sleep(0.2)
    assert not started["B"].is_set()  # nothing beside the timing submission
    release["T"].set()
    release["B"].set()
    for t in threads.values():
        t.join(10)
    assert [e[:2] for e in log] == [("start", "A"), ("end", "A"), ("start", "T"), ("end", "T"), ("start", "B"),
                                    ("end", "B")]
    assert log[2][2] == tuple(resources.allowed_cpus()) and log[0][2] is None and log[4][2] is None


def test_a_cgroup_that_refuses_a_process_falls_back_to_polling_before_the_submission_starts(monkeypatch):
    from robocourse.grading import resources

    if resources.mode() != "cgroup-v1":
        pytest.skip(f"cgroup v1 is not writable here (mode {resources.mode()})")

    real = resources.Path.write_text

    def refuse_cpuset(path, text, *args, **kwargs):
        if path.name == "cgroup.procs" and "cpuset" in path.parts:
            raise OSError(28, "No space left on device", str(path))
        return real(path, text, *args, **kwargs)

    monkeypatch.setattr(resources.Path, "write_text", refuse_cpuset)
    with resources.Box(512, 64, None, mode="cgroup-v1") as box:
        assert box.mode == "polling" and box.dirs == {}
        # the parent saw the errno and names the controller (preexec_fn would have said only "an exception")
        assert "the cgroup refused a process (its cpuset cgroup: No space left on device)" in box.describe()


def test_a_timing_slot_weighs_as_many_processes_as_its_cpus_times_the_timing_weight():
    """Issue 26: a cgroup is one scheduling entity; at the default weight a timing submission's loop and
    the simulated robot it talks to shared one process's turn against every busy process beside the grader."""
    from robocourse.grading import resources

    if resources.mode() != "cgroup-v1":
        pytest.skip(f"cgroup v1 is not writable here (mode {resources.mode()})")
    cpus = tuple(resources.allowed_cpus())
    with resources.Box(512, 64, cpus, mode="cgroup-v1") as slot, resources.Box(512, 64, None, mode="cgroup-v1") as plain:
        if "polling" in (slot.mode, plain.mode):
            pytest.skip(f"the cgroups could not be made here: {slot.fallback or plain.fallback}")
        shares = int((slot.dirs["cpu"] / "cpu.shares").read_text())
        assert shares == 1024 * resources.TIMING_WEIGHT * len(cpus)
        assert int((plain.dirs["cpu"] / "cpu.shares").read_text()) == 1024      # a plain submission: one process
    systemd = resources.Box(512, 64, cpus, mode="cgroup-v2-delegated", unit="u").wrap(["true"])
    assert f"CPUWeight={min(10000, 100 * resources.TIMING_WEIGHT * len(cpus))}" in systemd
