"""Actions across processes over zenoh, as rmw_zenoh maps them: three services and two topics
under ``<action>/_action/`` with their own type names and RIHS01 hashes. The server runs in
another process (``python -m robocourse.bus.zenoh.peer fibonacci``); one test kills it
mid-goal and checks the client fails clearly instead of hanging."""


import pytest
from test_zenoh_processes import _peer, _spin_until, endpoint, spawn  # noqa: F401

from robocourse.bus.action import ActionClient
from robocourse.bus.context import Context
from robocourse.bus.executors import SingleThreadedExecutor
from robocourse.bus.service import ServerGoneError
from robocourse.bus.zenoh import wire
from robocourse.msgs.action_msgs import CancelGoal, GoalStatus, GoalStatusArray
from robocourse.msgs.example_interfaces import Fibonacci

# Hashes from rosidl-generated headers/ros-z-style locked tables (CancelGoal, GoalStatusArray)
# and, for the tutorial's action, a third-party implementation's locked Jazzy values.
CANCEL_GOAL = "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a"
STATUS_ARRAY = "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e"
TUTORIAL = {"Fibonacci_SendGoal": "a0603060ed69fe2dfbd1a6f3b982a1749957ef346e4a4d2b311a05e305ec37bb",
            "Fibonacci_GetResult": "8b47e383f1e31f6d8df6417ab54957e7d5ea24dad315646ad711ac3fdea81d58",
            "Fibonacci_FeedbackMessage":
                "50fc26b9cac313652ecbeab3adf9b5414d59fd4d4d5f9058ddcc7525169927f1"}


def test_action_type_hashes_match_the_rosidl_values():
    assert wire.type_hash(CancelGoal) == CANCEL_GOAL
    assert wire.type_hash(GoalStatusArray) == STATUS_ARRAY
    from robocourse.msgs import REGISTRY
    from robocourse.msgs._core import action

    tut = REGISTRY.get("action_tutorials_interfaces/action/Fibonacci") or action(
        "action_tutorials_interfaces/action/Fibonacci",
        "int32 order\n---\nint32[] sequence\n---\nint32[] partial_sequence\n")
    impl = tut.Impl
    for t in (impl.SendGoalService, impl.GetResultService, impl.FeedbackMessage):
        assert wire.type_hash(t) == "RIHS01_" + TUTORIAL[t._type.rsplit("/", 1)[1]], t._type


def test_action_keys_are_rmw_zenohs():
    impl = Fibonacci.Impl
    base = "/fibonacci/_action/"
    assert wire.data_key(0, base + "send_goal", impl.SendGoalService).startswith(
        "0/fibonacci/_action/send_goal/example_interfaces::action::dds_::Fibonacci_SendGoal_/RIHS01_")
    assert wire.data_key(0, base + "get_result", impl.GetResultService).startswith(
        "0/fibonacci/_action/get_result/example_interfaces::action::dds_::Fibonacci_GetResult_/")
    assert wire.data_key(0, base + "cancel_goal", CancelGoal) == \
        f"0/fibonacci/_action/cancel_goal/action_msgs::srv::dds_::CancelGoal_/{CANCEL_GOAL}"
    assert wire.data_key(0, base + "status", GoalStatusArray) == \
        f"0/fibonacci/_action/status/action_msgs::msg::dds_::GoalStatusArray_/{STATUS_ARRAY}"
    assert wire.data_key(0, base + "feedback", impl.FeedbackMessage).startswith(
        "0/fibonacci/_action/feedback/example_interfaces::action::dds_::"
        "Fibonacci_FeedbackMessage_/RIHS01_")


@pytest.fixture
def client_side(endpoint):  # noqa: F811
    ctx = Context(transport="zenoh", connect=[endpoint])
    node = ctx.create_node("fibonacci_client")
    client = ActionClient(node, Fibonacci, "/fibonacci")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    yield ctx, client, ex
    ctx.try_shutdown()


def _server(spawn, endpoint, period):  # noqa: F811
    return spawn(*_peer("fibonacci", endpoint), "--period", str(period))


def test_goal_feedback_and_result_across_processes(client_side, endpoint, spawn):  # noqa: F811
    ctx, client, ex = client_side
    _server(spawn, endpoint, 0.02)
    assert _spin_until(ex, lambda: client.server_is_ready())
    want = {("SS", "/fibonacci/_action/send_goal"), ("SS", "/fibonacci/_action/cancel_goal"),
            ("SS", "/fibonacci/_action/get_result"), ("MP", "/fibonacci/_action/feedback"),
            ("MP", "/fibonacci/_action/status")}
    assert ctx.transport.wait_for(
        lambda t: want <= {(e.kind, e.topic) for e in t.remote_entities()}, 20)
    feedback = []
    goal = client.send_goal_async(Fibonacci.Goal(order=8),
                                  feedback_callback=lambda m: feedback.append(list(m.feedback.sequence)))
    assert _spin_until(ex, goal.done)
    handle = goal.result()
    assert handle.accepted
    result = handle.get_result_async()
    assert _spin_until(ex, result.done)
    assert result.result().status == GoalStatus.STATUS_SUCCEEDED
    assert list(result.result().result.sequence) == [0, 1, 1, 2, 3, 5, 8, 13, 21]
    assert feedback and feedback[-1] == [0, 1, 1, 2, 3, 5, 8, 13, 21]
    assert all(len(b) == len(a) + 1 for a, b in zip(feedback, feedback[1:]))   # in order


def test_cancel_across_processes(client_side, endpoint, spawn):  # noqa: F811
    ctx, client, ex = client_side
    _server(spawn, endpoint, 0.05)
    assert _spin_until(ex, lambda: client.server_is_ready())
    feedback = []
    goal = client.send_goal_async(Fibonacci.Goal(order=1000), feedback_callback=feedback.append)
    assert _spin_until(ex, goal.done) and goal.result().accepted
    handle = goal.result()
    assert _spin_until(ex, lambda: len(feedback) >= 2)
    cancel = handle.cancel_goal_async()
    assert _spin_until(ex, cancel.done)
    assert cancel.result().return_code == CancelGoal.Response.ERROR_NONE
    assert len(cancel.result().goals_canceling) == 1
    result = handle.get_result_async()
    assert _spin_until(ex, result.done)
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert 2 <= len(result.result().result.sequence) < 1000
    # the status topic (TRANSIENT_LOCAL) told the handle too
    assert _spin_until(ex, lambda: handle.status == GoalStatus.STATUS_CANCELED)


def test_server_killed_mid_goal_fails_the_result_request_without_hanging(
        client_side, endpoint, spawn):  # noqa: F811
    ctx, client, ex = client_side
    proc = _server(spawn, endpoint, 0.05)
    assert _spin_until(ex, lambda: client.server_is_ready())
    feedback = []
    goal = client.send_goal_async(Fibonacci.Goal(order=1000), feedback_callback=feedback.append)
    assert _spin_until(ex, goal.done) and goal.result().accepted
    result = goal.result().get_result_async()
    assert _spin_until(ex, lambda: len(feedback) >= 2)
    proc.kill()                                         # mid-goal, no cleanup
    assert _spin_until(ex, result.done, timeout=60)     # ends by itself: the server is gone
    with pytest.raises(ServerGoneError, match="get_result.*went away"):
        result.result()
    assert ctx.transport.wait_for(lambda t: not t.remote_entities(), 20)
    assert not client.server_is_ready()
    # a new goal is refused up front instead of waiting on nobody
    late = client.send_goal_async(Fibonacci.Goal(order=3))
    _spin_until(ex, late.done, timeout=0.3)
    assert not late.done()
    assert any("no server exists" in r.msg for r in ctx.log_records)


def test_synchronous_send_goal_raises_when_the_server_dies(client_side, endpoint, spawn):  # noqa: F811
    import threading

    ctx, client, ex = client_side
    proc = _server(spawn, endpoint, 0.05)
    assert _spin_until(ex, lambda: client.server_is_ready())
    spinner = threading.Thread(target=ex.spin, daemon=True)
    spinner.start()
    killer = threading.Timer(0.5, proc.kill)
    killer.start()
    with pytest.raises(ServerGoneError):
        client.send_goal(Fibonacci.Goal(order=1000))     # blocks until the kill ends it
    ex.shutdown()
    spinner.join(timeout=5)
