"""Services: call_async, wait_for_service, failures and deadlock detection."""

import threading

import pytest

from robocourse.bus import (
    Context,
    DeadlockError,
    MultiThreadedExecutor,
    ReentrantCallbackGroup,
    ServiceCallbackError,
    SingleThreadedExecutor,
)
from robocourse.msgs.example_interfaces import AddTwoInts
from robocourse.msgs.std_srvs import Trigger


def add(req, resp):
    resp.sum = req.a + req.b
    return resp


def graph(sim=True):
    ctx = Context(use_sim_time=sim)
    ctx.log_to_stderr = False
    server, client = ctx.create_node("server"), ctx.create_node("client")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(server)
    ex.add_node(client)
    return ctx, server, client, ex


def test_call_async_returns_the_response():
    ctx, server, client, ex = graph()
    srv = server.create_service(AddTwoInts, "add_two_ints", add)
    cli = client.create_client(AddTwoInts, "add_two_ints")
    assert cli.wait_for_service(timeout_sec=1.0) and cli.service_is_ready()
    futures = [cli.call_async(AddTwoInts.Request(a=i, b=10)) for i in range(5)]
    ex.spin_until_future_complete(futures[-1])
    assert [f.result().sum for f in futures] == [10, 11, 12, 13, 14]
    assert srv.request_count == 5


def test_wait_for_service_false_without_server_and_request_warns():
    ctx, server, client, ex = graph()
    cli = client.create_client(Trigger, "nobody")
    assert not cli.wait_for_service(timeout_sec=0.5)
    assert not cli.service_is_ready()
    f = cli.call_async(Trigger.Request())
    ex.spin_until_future_complete(f, timeout_sec=1.0)
    assert not f.done()
    assert any("no server exists" in r.msg for r in ctx.log_records)


def test_wrong_request_type_raises():
    ctx, server, client, ex = graph()
    cli = client.create_client(AddTwoInts, "x")
    with pytest.raises(TypeError, match="AddTwoInts"):
        cli.call_async(Trigger.Request())
    server.create_service(AddTwoInts, "x", add)
    with pytest.raises(TypeError, match="has type"):
        server.create_client(Trigger, "x")


def test_service_callback_raising_gives_the_client_an_error_and_server_survives():
    ctx, server, client, ex = graph()

    def fragile(req, resp):
        if req.a < 0:
            raise ValueError("negative input")
        return add(req, resp)

    srv = server.create_service(AddTwoInts, "add", fragile)
    cli = client.create_client(AddTwoInts, "add")
    bad = cli.call_async(AddTwoInts.Request(a=-1, b=0))
    # rclpy: the exception leaves the server's spin; here the client also learns why
    with pytest.raises(ValueError, match="negative input"):
        ex.spin_until_future_complete(bad)
    ex.spin_until_future_complete(bad)      # the executor goes on: the client gets its answer
    assert isinstance(bad.exception(), ServiceCallbackError)
    assert "negative input" in str(bad.exception())
    with pytest.raises(ServiceCallbackError):
        bad.result()
    good = cli.call_async(AddTwoInts.Request(a=1, b=2))
    ex.spin_until_future_complete(good)
    assert good.result().sum == 3
    assert srv.error_count == 1 and srv.request_count == 2


def test_service_callback_returning_nothing_is_an_error():
    ctx, server, client, ex = graph()
    server.create_service(AddTwoInts, "add", lambda req, resp: None)
    cli = client.create_client(AddTwoInts, "add")
    f = cli.call_async(AddTwoInts.Request())
    with pytest.raises(TypeError, match="return the response"):   # out of spin, as rclpy
        ex.spin_until_future_complete(f)
    ex.spin_until_future_complete(f)
    assert "return the response" in str(f.exception())


def test_sync_call_inside_callback_on_single_threaded_executor_raises_deadlock_error():
    ctx, server, client, ex = graph()
    server.create_service(AddTwoInts, "add", add)
    cli = client.create_client(AddTwoInts, "add")
    client.create_timer(0.1, lambda: cli.call(AddTwoInts.Request(a=1, b=2)))
    with pytest.raises(DeadlockError):      # rclpy would hang here; the error leaves spin
        ex.spin_for(0.1)
    assert len(ex.callback_errors) == 1
    err = ex.callback_errors[0].exception
    assert isinstance(err, DeadlockError)
    text = str(err)
    assert "single-threaded executor would deadlock" in text and "call_async" in text


def test_sync_call_with_nobody_spinning_raises_deadlock_error():
    ctx, server, client, ex = graph()
    server.create_service(AddTwoInts, "add", add)
    cli = client.create_client(AddTwoInts, "add")
    with pytest.raises(DeadlockError, match="no executor is spinning"):
        cli.call(AddTwoInts.Request(a=1, b=2))


def test_sync_call_in_same_exclusive_group_on_multithreaded_executor_raises():
    ctx = Context()
    ctx.log_to_stderr = False
    n = ctx.create_node("n")
    n.create_service(AddTwoInts, "add", add, callback_group=ReentrantCallbackGroup())
    cli = n.create_client(AddTwoInts, "add")            # default (exclusive) group
    done = threading.Event()
    results = []

    def tick():
        try:
            results.append(cli.call(AddTwoInts.Request(a=1, b=2)))
        finally:
            done.set()

    n.create_timer(0.01, tick)
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    ex.add_node(n)
    raised = []

    def spin():
        try:
            ex.spin()
        except DeadlockError as exc:      # the callback's exception leaves spin (rclpy)
            raised.append(exc)

    th = threading.Thread(target=spin)
    th.start()
    done.wait(5)
    th.join(5)
    ctx.shutdown()
    assert results == [] and not th.is_alive()
    assert len(raised) == 1 and raised[0] is ex.callback_errors[0].exception
    assert isinstance(ex.callback_errors[0].exception, DeadlockError)
    assert "same MutuallyExclusiveCallbackGroup" in str(ex.callback_errors[0].exception)


def test_sync_call_works_with_the_fix_reentrant_client_on_multithreaded_executor():
    ctx = Context()
    ctx.log_to_stderr = False
    n = ctx.create_node("n")
    n.create_service(AddTwoInts, "add", add, callback_group=ReentrantCallbackGroup())
    cli = n.create_client(AddTwoInts, "add", callback_group=ReentrantCallbackGroup())
    done = threading.Event()
    results = []

    def tick():
        if not done.is_set():
            results.append(cli.call(AddTwoInts.Request(a=20, b=22)).sum)
            done.set()

    n.create_timer(0.01, tick)
    ex = MultiThreadedExecutor(num_threads=3, context=ctx)
    ex.add_node(n)
    th = threading.Thread(target=ex.spin)
    th.start()
    done.wait(5)
    ctx.shutdown()
    th.join(5)
    assert results == [42] and ex.callback_errors == []


def test_sync_call_from_main_thread_while_executor_spins_in_background():
    ctx = Context()
    ctx.log_to_stderr = False
    server, client = ctx.create_node("server"), ctx.create_node("client")
    server.create_service(AddTwoInts, "add", add)
    cli = client.create_client(AddTwoInts, "add")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(server)
    ex.add_node(client)
    th = threading.Thread(target=ex.spin)
    th.start()
    try:
        while not ex.is_spinning_elsewhere():
            threading.Event().wait(0.001)
        assert cli.call(AddTwoInts.Request(a=2, b=3), timeout_sec=5).sum == 5
    finally:
        ctx.shutdown()
        th.join(5)


def test_async_callback_awaiting_a_service_on_single_threaded_executor():
    ctx, server, client, ex = graph()
    server.create_service(AddTwoInts, "add", add)
    cli = client.create_client(AddTwoInts, "add")
    sums = []

    async def tick():
        resp = await cli.call_async(AddTwoInts.Request(a=1, b=1))
        sums.append(resp.sum)

    client.create_timer(0.1, tick)
    ex.spin_for(0.35)
    assert sums == [2, 2, 2] and ex.callback_errors == []
