"""robocourse.processes: a function runs in a child process by source, on the zenoh graph, stops by
itself, reports back, and is never left behind (crash, close, bad input)."""

from __future__ import annotations

import time

import pytest

from robocourse.bus import introspection
from robocourse.bus.context import Context
from robocourse.bus.zenoh.transport import router
from robocourse.processes import _CHILDREN, free_endpoint, start_child


@pytest.fixture
def ep():
    e = free_endpoint()
    r = router([e])
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
    assert len(c.zid) == 32 and c.alive()
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
    t0 = time.monotonic()
    c.close()
    assert not c.alive() and time.monotonic() - t0 < 5.0


def test_an_exception_in_the_child_is_raised_here_with_its_text(ep):
    with pytest.raises(RuntimeError, match="KeyError: 'no such thing'"):
        start_child(fails_at_start, connect=[ep])
    assert all(c.alive() for c in _CHILDREN)        # the failed child is not kept


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
])
def test_bad_arguments_are_refused_before_a_process_starts(target, kwargs, exc, match):
    before = len(_CHILDREN)
    with pytest.raises(exc, match=match):
        start_child(target, **{"connect": ["tcp/127.0.0.1:1"], **kwargs})
    assert len(_CHILDREN) == before
