"""libfranka's Robot() raises the thread that constructs it to SCHED_FIFO 99 when the kernel allows
(root here; an rtprio limit of 99 elsewhere), with RealtimeConfig.kIgnore too, and never gives it
back: upstream's behaviour, kept. Our own code that constructs one (the round-trip measurement,
franka_hardware's SystemInterface) gives the caller its scheduling back, so a notebook kernel or
a benchmark row "without RT" does not run at 99. rt.settings.scheduling_kept() is the tool.
Without privilege (a student's laptop) the request is refused: kIgnore carries on, kEnforce raises.
Each case runs in a child process, so this worker's own scheduling is never touched."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.timeout(180)

may_raise = pytest.mark.skipif(
    os.geteuid() != 0 and resource.getrlimit(resource.RLIMIT_RTPRIO)[0] < 99,
    reason="raising a thread to SCHED_FIFO 99 needs root or an rtprio limit of 99")


def run(code: str) -> str:
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=150)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def test_scheduling_kept_gives_back_what_the_block_set_without_privilege():
    # SCHED_BATCH and back to SCHED_OTHER are allowed to every user
    out = run("""
        import os
        from robocourse.rt import settings
        with settings.scheduling_kept() as seen:
            os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
        print(seen["before"], seen["set"], seen["changed"], settings.current_scheduling())
        with settings.scheduling_kept() as same:
            pass
        print(same["changed"], same["set"] == same["before"])
    """)
    assert out.splitlines() == ["('SCHED_OTHER', 0) ('SCHED_BATCH', 0) True ('SCHED_OTHER', 0)", "False True"]


@may_raise
def test_scheduling_kept_lowers_a_real_time_thread_back():
    out = run("""
        import os
        from robocourse.rt import settings
        with settings.scheduling_kept() as seen:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(99))
        print(seen["set"], settings.current_scheduling())
    """)
    assert out.strip() == "('SCHED_FIFO', 99) ('SCHED_OTHER', 0)"


@may_raise
def test_libfranka_raises_the_constructing_thread_and_our_code_gives_it_back():
    pytest.importorskip("pylibfranka", reason="pylibfranka (PyPI, Linux x86_64) is not installed")
    out = run("""
        import pylibfranka
        import robocourse.drivers as drivers
        from robocourse.control.bringup import bringup
        from robocourse.drivers.measure import franka_roundtrip
        from robocourse.rt import settings
        box = drivers.start_franka_box()
        try:
            robot = pylibfranka.Robot(box.host, pylibfranka.RealtimeConfig.kIgnore)
            print("plain", settings.current_scheduling())          # upstream: raised, and kept
            del robot
        finally:
            box.stop()
        settings.reset_scheduling()
        r = franka_roundtrip(0.2, physics=False)
        print("roundtrip", settings.current_scheduling(), r.client_cycles > 0)
        urdf = drivers.fr3_urdf("robocourse/FrankaStyleSystem", {"max_lost": 100000}, command_interfaces=("position",))
        cm = bringup(urdf=urdf, param_file=drivers.FR3_CONTROLLERS_YAML, spawn=["joint_state_broadcaster"])
        try:
            (comp,) = cm.rm.components.values()
            print("system", settings.current_scheduling(), comp.impl.robot is not None)
        finally:
            cm.shutdown()
    """)
    lines = out.splitlines()
    assert "plain ('SCHED_FIFO', 99)" in lines, out
    assert "roundtrip ('SCHED_OTHER', 0) True" in lines, out
    assert "system ('SCHED_OTHER', 0) True" in lines, out


def test_unprivileged_libfranka_leaves_the_thread_and_only_kenforce_raises():
    # the student's path: no rtprio. As root, the child drops to nobody (and an rtprio limit of 0)
    # after its imports; the box runs in this process's child, as the robot would, untouched
    pytest.importorskip("pylibfranka", reason="pylibfranka (PyPI, Linux x86_64) is not installed")
    import robocourse.drivers as drivers

    box = drivers.start_franka_box()
    try:
        out = run(f"""
            import os, resource
            import pylibfranka
            from robocourse.rt import settings
            resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
            if os.geteuid() == 0:
                os.setgid(65534)
                os.setuid(65534)
            with settings.scheduling_kept() as seen:
                robot = pylibfranka.Robot({box.host!r}, pylibfranka.RealtimeConfig.kIgnore)
            print("kIgnore", seen["changed"], settings.current_scheduling(), robot.read_once().robot_mode.name)
            del robot
            try:
                pylibfranka.Robot({box.host!r}, pylibfranka.RealtimeConfig.kEnforce)
                print("kEnforce connected")
            except pylibfranka.RealtimeException as exc:
                print("kEnforce RealtimeException", "Operation not permitted" in str(exc))
        """)
    finally:
        box.stop()
    assert out.splitlines() == ["kIgnore False ('SCHED_OTHER', 0) Idle", "kEnforce RealtimeException True"], out
