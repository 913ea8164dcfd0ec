"""robocourse.rt.settings: both privilege paths, for real.

The unprivileged path runs in a child process that lowers RLIMIT_RTPRIO / RLIMIT_MEMLOCK and,
when started as root, drops to uid/gid 65534 (nobody) before touching any setting. It must
print the seed's messages with the fix, and still complete its loop. The privileged path
runs as root (or with the limits granted) and must report every setting as in effect.
"""

import os
import resource
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from robocourse.rt import settings

LIB = str(Path(__file__).resolve().parents[1] / "lib")

UNPRIVILEGED = textwrap.dedent("""
    import ctypes, os, resource, sys
    sys.path.insert(0, LIB)
    import robocourse.rt as rt
    from robocourse.rt import settings
    from robocourse.cli import build_parser, main
    build_parser()  # import every module now: after dropping root the interpreter's files may be unreadable
    resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
    resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))
    if os.geteuid() == 0:
        os.setgroups([])
        os.setgid(65534)
        os.setuid(65534)
        ctypes.CDLL(None).prctl(4, 1, 0, 0, 0)  # PR_SET_DUMPABLE, as for any ordinary user process
    print("uid", os.geteuid())
    with settings.realtime("rr", 98, lock=True, heap_size=8 << 20) as reports:
        print(settings.describe(reports))
        print("policy during run:", settings.current_scheduling()[0])
        r = rt.PeriodicLoop(1_000_000, 200, wait=rt.Hybrid(spin_ns=100_000)).run()
    print("completed", r.iterations)
    print(r.stats().format())
    sys.stdout.flush()
    sys.exit(main(["rttest", "-i", "100", "-s", "fifo", "-t", "98", "-d", "8mb"]))
""").replace("LIB", repr(LIB))


def test_unprivileged_path_prints_the_seed_messages_and_carries_on():
    proc = subprocess.run([sys.executable, "-c", UNPRIVILEGED], capture_output=True, text=True, timeout=120)
    out, err = proc.stdout, proc.stderr
    assert proc.returncode == 0, err
    assert "uid 0" not in out
    # the seed's exact messages ...
    assert err.count("Couldn't set scheduling priority and policy: Operation not permitted") == 2
    assert err.count("mlockall failed: Cannot allocate memory") == 2
    assert err.count("Couldn't lock all cached virtual memory.") == 2
    assert "Pagefaults from reading pages not yet mapped into RAM will be recorded." in err
    # ... with the exact fix
    assert "/etc/security/limits.conf:" in err and " - rtprio 98" in err and " - memlock -1" in err
    assert "setcap cap_sys_nice+ep" in err and "setcap cap_ipc_lock+ep" in err
    # honest reports, and the program carried on
    assert "-- scheduling       SCHED_RR 98 refused: Operation not permitted" in out
    assert "-- mlockall         refused: Cannot allocate memory" in out
    assert "ok heap prefault" in out  # prefaulting needs no privilege
    assert "policy during run: SCHED_OTHER" in out
    assert "completed 200" in out
    assert out.count("rttest statistics") == 2 and "- Minor pagefaults:" in out


needs_privilege = pytest.mark.skipif(
    os.geteuid() != 0 and resource.getrlimit(resource.RLIMIT_RTPRIO)[0] < 80,
    reason="the privileged path needs root or rtprio/memlock granted in limits.conf")

PRIVILEGED = textwrap.dedent("""
    import gc, os, sys
    sys.path.insert(0, LIB)
    import robocourse.rt as rt
    from robocourse.rt import settings
    with settings.realtime("fifo", 80, cpus={0}, lock=True, heap_size=8 << 20) as reports:
        print(settings.describe(reports))
        print("during", settings.current_scheduling(), sorted(os.sched_getaffinity(0)),
              settings.memory_locked(), gc.get_freeze_count() > 0)
        print("slack", open("/proc/self/timerslack_ns").read().strip())
        r = rt.PeriodicLoop(1_000_000, 200, wait=rt.Sleep()).run()
    print("completed", r.iterations, int(r.stats().minor_pagefaults))
    print("after", settings.current_scheduling(), settings.memory_locked(), gc.get_freeze_count())
""").replace("LIB", repr(LIB))


@needs_privilege
def test_privileged_path_takes_effect_and_is_undone():
    proc = subprocess.run([sys.executable, "-c", PRIVILEGED], capture_output=True, text=True, timeout=120)
    out = proc.stdout
    assert proc.returncode == 0, proc.stderr
    assert "Couldn't" not in proc.stderr
    for line in ("ok affinity         pinned to CPU(s) [0]", "ok mlockall", "ok heap prefault",
                 "ok stack prefault", "ok gc", "ok scheduling       SCHED_FIFO priority 80, timer slack now 0 ns"):
        assert line in out, out
    assert "during ('SCHED_FIFO', 80) [0] True True" in out
    assert "slack 0" in out
    assert "completed 200 0" in out  # locked and prefaulted: an empty loop takes no page fault
    assert "after ('SCHED_OTHER', 0) False 0" in out


def test_bad_setting_values_are_clear_errors():
    from robocourse.rt import settings

    with pytest.raises(ValueError, match="use 'fifo', 'rr' or 'other'"):
        settings.set_scheduling("deadline", 10)
    with pytest.raises(ValueError, match="1..99"):
        settings.set_scheduling("fifo", 0)
    with pytest.raises(ValueError, match="gc_mode"):
        with settings.realtime(gc_mode="off"):
            pass


def test_affinity_refusal_is_reported_not_raised(capsys):
    from robocourse.rt import settings

    r = settings.set_affinity({4096})
    assert not r.ok and "Couldn't set CPU affinity" in capsys.readouterr().err
    assert "pick CPUs from" in r.fix


def test_report_line_shows_fix_only_on_failure():
    from robocourse.rt.settings import SettingReport

    assert "fix" not in str(SettingReport("x", True, "fine", fix="do this"))
    assert "fix: do this" in str(SettingReport("x", False, "bad", fix="do this"))


PREFAULT = textwrap.dedent("""
    import sys
    sys.path.insert(0, LIB)
    import robocourse.rt as rt
    from robocourse.rt import settings
    from robocourse.rt.disturb import HeapGrowth
    before = rt.PeriodicLoop(1_000_000, 300, wait=rt.Sleep()).run(HeapGrowth(64 * 1024, keep=100))
    report = settings.prefault_heap(32 << 20)
    after = rt.PeriodicLoop(1_000_000, 300, wait=rt.Sleep()).run(HeapGrowth(64 * 1024, keep=100))
    print(report.ok, before.stats().minor_pagefaults, after.stats().minor_pagefaults)
""").replace("LIB", repr(LIB))


def test_heap_prefault_takes_the_growing_heaps_faults_out_of_the_loop():
    # a fresh process, so glibc's heap and settings are the defaults; no privilege needed
    proc = subprocess.run([sys.executable, "-c", PREFAULT], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    ok, before, after = proc.stdout.split()
    assert ok == "True"
    assert int(before) >= 1000  # 100 x 64 KiB of new heap = 1600 pages first touched in the loop
    assert int(after) <= 50  # the same allocations now reuse prefaulted, still-mapped heap


@pytest.mark.parametrize("bad", ["64mb", 1.5, -1, True])
def test_prefault_heap_refuses_a_size_that_is_not_whole_bytes(bad):
    with pytest.raises(ValueError, match=r"prefault_heap\(size=.*\): the size is a whole number of bytes >= 0"):
        settings.prefault_heap(bad)


def test_prefault_report_never_claims_faulting_in_memory_that_took_no_fault():
    text = settings._prefault_text(64 << 20, 256 << 10, 0, True, True)
    assert text.startswith("touched 256 KiB of heap (asked for up to 65536 KiB), 0 page faults taken now: "
                           "the first chunk took no new fault")
    assert "faulted in" not in text
    full = settings._prefault_text(8 << 20, 8 << 20, 2048, False, False)
    assert full.startswith("touched 8192 KiB of heap (asked for up to 8192 KiB), 2048 page faults taken now: all of it")


def test_locked_allocation_fails_at_the_memlock_limit_like_bad_alloc():
    import re

    from robocourse.rt.permissions import locked_allocation_demo

    out = locked_allocation_demo(cap_mb=64).stdout
    m = re.search(r"ulimit -l \(RLIMIT_MEMLOCK\): (\d+) kB", out)
    if m is None or "mlockall(MCL_FUTURE) failed" in out:
        pytest.skip(f"no finite memlock limit to run into here: {out!r}")
    limit_mib = int(m.group(1)) / 1024
    if limit_mib >= 64:
        assert "allocated 64 MiB without an error" in out
    else:
        got = int(re.search(r"MemoryError after (\d+) MiB", out).group(1))
        assert got <= limit_mib and "std::bad_alloc" in out


def test_locked_allocation_demo_refuses_a_bad_cap():
    from robocourse.rt.permissions import locked_allocation_demo

    with pytest.raises(ValueError, match="cap_mb=0: a positive number of MiB"):
        locked_allocation_demo(cap_mb=0)
