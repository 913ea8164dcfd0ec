"""robocourse.rt.disturb: each disturbance does what it says (counted, not timed)."""

import gc
import logging
import os
import time

import pytest

from robocourse.rt import STOP, FakeClock, PeriodicLoop, Sleep
from robocourse.rt.disturb import (
    AllocationStorm,
    CpuLoad,
    FreshMemory,
    GcPauses,
    GcPressure,
    HeapGrowth,
    LogEveryIteration,
    chain,
)


def test_cpu_load_pins_busy_processes_and_cleans_up():
    cpu = sorted(os.sched_getaffinity(0))[0]
    with CpuLoad(cpu=cpu, processes=2) as load:
        pids = load.pids
        assert len(pids) == 2
        # each child pins itself as it starts: wait for that (a loaded machine starts them late)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and any(os.sched_getaffinity(p) != {cpu} for p in pids):
            time.sleep(0.05)
        for pid in pids:
            assert os.sched_getaffinity(pid) == {cpu}
            with open(f"/proc/{pid}/stat") as fh:
                assert fh.read().split(")")[1].split()[0] in "RS"
    for pid in pids:
        assert not os.path.exists(f"/proc/{pid}") or open(f"/proc/{pid}/stat").read().split(")")[1].split()[0] == "Z"
    with pytest.raises(ValueError, match="pick one of them"):
        CpuLoad(cpu=4096)


def test_cpu_load_left_on_another_thread_while_it_still_starts_ends_every_process(monkeypatch):
    # chapter 1 switches the load on and off from two threads; on a loaded machine the "off" came
    # while "on" was still starting its processes: the second was never killed, and "off" waited
    # for it forever (the notebook hung). Leaving now waits for entering, then ends them all.
    import subprocess
    import threading

    import robocourse.rt.disturb as disturb

    started, real_popen = [], subprocess.Popen

    def slow_popen(*args, **kwargs):     # a slow fork/exec, as on a machine at load average 25
        time.sleep(0.3)
        started.append(real_popen(*args, **kwargs))
        return started[-1]

    monkeypatch.setattr(disturb.subprocess, "Popen", slow_popen)
    load = CpuLoad(processes=2)
    on = threading.Thread(target=load.__enter__)
    on.start()
    time.sleep(0.1)                       # "off" arrives while the first process is still being started
    off = threading.Thread(target=load.__exit__, args=(None, None, None))
    off.start()
    on.join(timeout=30)
    off.join(timeout=30)
    assert not on.is_alive() and not off.is_alive(), "leaving the load hung"
    assert len(started) == 2 and all(p.poll() is not None for p in started) and load.pids == []


def test_gc_pressure_survivors_reach_the_oldest_generation_and_pauses_are_recorded():
    pressure = GcPressure(live=1000, per_iteration=50, window=10)
    with GcPauses() as pauses:
        for _ in range(200):  # 51 new cyclic containers each: > 14 x the young threshold of 700
            pressure()
        young = [g for g, _ in pauses.pauses]
        gc.collect()
    assert len(pressure.recent) == 10 and len(pressure.live) == 1000
    assert young.count(0) >= 5  # dropped cycles are not freed at once, so young collections must run
    assert len(pauses.full()) >= 1 and all(d >= 0 for d in pauses.full())
    assert GcPressure.time_full_collection() > 0


def test_fresh_memory_faults_every_page_and_heap_growth_grows():
    r = PeriodicLoop(1_000_000, 5, wait=Sleep()).run(FreshMemory(64 * 4096))
    assert (r.minor_pagefaults >= 64).all()
    h = HeapGrowth(chunk=4096, keep=3)
    for _ in range(5):
        h()
    assert len(h._held) == 2  # cleared after 3, then 2 more
    AllocationStorm(objects=10, nbytes=10)()


def test_logging_in_the_loop_writes_one_line_per_iteration(tmp_path):
    path = tmp_path / "loop.log"
    with LogEveryIteration(path, level=logging.INFO) as log:
        PeriodicLoop(1_000_000, 25, wait=Sleep(), clock=FakeClock(), pagefaults=False).run(log)
    lines = path.read_text().splitlines()
    assert len(lines) == 25 and "iteration 24 latency" in lines[-1]


def test_chain_calls_all_and_passes_stop():
    calls = []
    cb = chain(lambda t: calls.append(1), lambda t: STOP if t.iteration == 2 else None)
    r = PeriodicLoop(1_000_000, 10, wait=Sleep(), clock=FakeClock(), pagefaults=False).run(cb)
    assert r.iterations == 3 and len(calls) == 3


@pytest.mark.skipif(os.geteuid() != 0, reason="needs SCHED_FIFO (root or rtprio in limits.conf) to start from an RT parent")
def test_cpu_load_started_from_a_fifo_process_runs_sched_other(tmp_path):
    # A benchmark with its RT settings on (SCHED_FIFO) starts CpuLoad: the busy children must not
    # inherit FIFO, or they starve every other process on their CPU (seen: two FIFO 99 hogs).
    import subprocess
    import sys

    script = (
        "import os, time\n"
        "from robocourse.rt.disturb import CpuLoad\n"
        "os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))\n"
        "with CpuLoad(processes=1) as load:\n"
        "    time.sleep(0.3)\n"
        "    print(os.sched_getscheduler(load.pids[0]) == os.SCHED_OTHER, os.sched_getscheduler(0) == os.SCHED_FIFO)\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=30)
    assert out.stdout.split() == ["True", "True"], out.stderr


def test_busy_children_end_when_their_parent_is_killed():
    """A parent killed by a signal never runs CpuLoad.__exit__: its busy children must not spin on as orphans."""
    import signal
    import subprocess
    import sys
    import time

    import psutil

    code = ("import sys, time\nsys.path.insert(0, sys.argv[1])\nfrom robocourse.rt.disturb import CpuLoad\n"
            "with CpuLoad(processes=2) as load:\n    print(*load.pids, flush=True)\n    time.sleep(60)\n")
    lib = str(__import__("pathlib").Path(__file__).resolve().parents[1] / "lib")
    parent = subprocess.Popen([sys.executable, "-c", code, lib], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in parent.stdout.readline().split()]
        assert len(pids) == 2
        parent.send_signal(signal.SIGKILL)
        parent.wait(10)
        deadline = time.monotonic() + 20
        alive = pids
        while alive and time.monotonic() < deadline:
            alive = [p for p in pids if psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE]
            time.sleep(0.1)
        assert not alive, f"busy children {alive} outlived their killed parent"
    finally:
        if parent.poll() is None:
            parent.kill()
