"""robocourse.bus.zenoh.processes: a function runs in a child process by source, on the zenoh graph, stops by
itself, reports back, and is never left behind (crash, close, bad input)."""

from __future__ import annotations

import re
import time

import pytest

from robocourse.bus import introspection
from robocourse.bus.context import Context
from robocourse.bus.zenoh.processes import _CHILDREN, free_router, start_child


@pytest.fixture
def ep():
    r, e = free_router()
    yield e
    r.close()


def named_node(ctx, name, value):
    ctx.create_node(name)
    return lambda: {"value": value * 2, "nodes": [n.get_name() for n in ctx.nodes]}


def fails_at_start(ctx):
    raise KeyError("no such thing")


def no_context(duration, n):
    return {"duration": duration, "n": n}


def test_child_runs_the_function_by_source_reports_and_stops_by_itself(ep):
    t0 = time.monotonic()
    c = start_child(named_node, connect=[ep], duration=1.0, args={"name": "kid", "value": 21})
    # zenoh prints a ZenohId as lowercase hex without leading zeros: up to 32 digits, and one
    # time in sixteen 31 or fewer (a fixed length here failed a CI run).
    assert re.fullmatch(r"[0-9a-f]{1,32}", c.zid) and c.alive()
    assert c.result(timeout=30) == {"value": 42, "nodes": ["kid"]}
    assert c.proc.returncode == 0 and time.monotonic() - t0 >= 1.0
    c.close()
    assert c not in _CHILDREN


def test_the_child_node_is_in_the_graph_and_leaves_it_when_killed(ep):
    ctx = Context(transport="zenoh", connect=[ep])
    try:
        c = start_child(named_node, connect=[ep], duration=30.0, args={"name": "kid", "value": 1})
        assert ctx.transport.wait_for(lambda t: "/kid" in introspection.node_list(ctx, quiet=True), 10)
        c.kill()
        assert c.proc.returncode == -9 and not c.alive()
        assert ctx.transport.wait_for(lambda t: "/kid" not in introspection.node_list(ctx, quiet=True), 15)
        c.close()
        c.close()                                   # idempotent
    finally:
        ctx.try_shutdown()


def test_close_stops_a_long_running_child_at_once(ep):
    c = start_child(named_node, connect=[ep], duration=600.0, args={"name": "long", "value": 0})
    # "at once" = the child exits by itself when its stdin closes (exit code 0), long before its
    # 600 s; close() kills (a negative code) only a child that ignores the closed pipe. The
    # generous wait keeps a loaded machine from turning a slow exit into a kill.
    c.close(timeout=60.0)
    assert not c.alive() and c.proc.returncode == 0


def test_an_exception_in_the_child_is_raised_here_with_its_text(ep):
    before = list(_CHILDREN)
    with pytest.raises(RuntimeError, match="KeyError: 'no such thing'"):
        start_child(fails_at_start, connect=[ep])
    assert _CHILDREN == before                      # the failed child is not kept


def test_import_target_and_a_child_without_context(ep):
    c = start_child(no_context, connect=[ep], duration=0.5, with_context=False, args={"n": 3})
    assert c.result(timeout=30) == {"duration": 0.5, "n": 3}
    c.close()
    c = start_child("json:dumps", connect=[ep], duration=0.5, with_context=False, args={"obj": None})
    with pytest.raises(RuntimeError, match="TypeError"):    # dumps() got the unexpected keyword 'duration'
        c.result(timeout=30)
    c.close()


@pytest.mark.parametrize("target, kwargs, exc, match", [
    (lambda ctx: None, {}, ValueError, "define it with def"),
    ("no_colon", {}, ValueError, "'module:function'"),
    (42, {}, TypeError, "must be a function"),
    (named_node, {"duration": 0}, ValueError, "duration=0"),
    (named_node, {"args": {"x": object()}}, TypeError, "JSON-able"),
    (named_node, {"connect": "tcp/127.0.0.1:7447"}, ValueError, "list of locators"),
    (named_node, {"ready_timeout": -1}, ValueError, "ready_timeout=-1"),
])
def test_bad_arguments_are_refused_before_a_process_starts(target, kwargs, exc, match):
    before = len(_CHILDREN)
    with pytest.raises(exc, match=match):
        start_child(target, **{"connect": ["tcp/127.0.0.1:1"], **kwargs})
    assert len(_CHILDREN) == before


def test_a_child_whose_parent_is_killed_exits_too(ep, tmp_path):
    import subprocess
    import sys

    import psutil

    script = tmp_path / "parent.py"
    script.write_text(
        "import sys, time\n"
        "from robocourse.bus.zenoh.processes import start_child\n"
        "def idle(ctx):\n    ctx.create_node('orphan_candidate')\n"
        f"c = start_child(idle, connect=[{ep!r}], duration=600.0)\n"
        "print(c.pid, flush=True)\n"
        "time.sleep(600)\n")
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    try:
        child_pid = int(parent.stdout.readline())
        assert psutil.pid_exists(child_pid)
        parent.kill()                                  # SIGKILL: no atexit, no cleanup in the parent
        parent.wait(timeout=10)
        end = time.monotonic() + 15
        while time.monotonic() < end and psutil.pid_exists(child_pid) and \
                psutil.Process(child_pid).status() != psutil.STATUS_ZOMBIE:
            time.sleep(0.05)
        gone = not psutil.pid_exists(child_pid) or psutil.Process(child_pid).status() == psutil.STATUS_ZOMBIE
        assert gone, f"child {child_pid} outlived its killed parent"
    finally:
        if parent.poll() is None:
            parent.kill()
        parent.stdout.close()


def test_free_router_picks_another_port_when_its_first_is_taken_meanwhile(monkeypatch):
    import robocourse.bus.zenoh.processes as processes

    holder, taken = free_router()            # another process took the port free_endpoint just picked
    picks = iter([taken])
    real = processes.free_endpoint
    monkeypatch.setattr(processes, "free_endpoint", lambda host="127.0.0.1": next(picks, None) or real(host))
    try:
        r, ep = processes.free_router()
        assert ep != taken and ep.startswith("tcp/127.0.0.1:")
        r.close()
    finally:
        holder.close()


def test_free_router_refuses_attempts_that_cannot_try_before_any_router_starts():
    import robocourse.bus.zenoh.processes as processes

    for bad in (0, -1, 2.5, True, "3"):
        with pytest.raises(ValueError, match=r"attempts=.*at least 1, e\.g\. 5"):
            processes.free_router(attempts=bad)


def test_free_router_raises_the_last_tries_error_when_every_port_is_taken(monkeypatch):
    import robocourse.bus.zenoh.processes as processes

    holder, taken = free_router()
    monkeypatch.setattr(processes, "free_endpoint", lambda host="127.0.0.1": taken)
    try:
        with pytest.raises(OSError):
            processes.free_router(attempts=2)
    finally:
        holder.close()
