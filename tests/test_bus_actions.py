"""Actions: the goal state machine transition by transition, defaults, cancel, abort, timeout."""

import itertools

import pytest

from robocourse.bus import Context, SingleThreadedExecutor
from robocourse.bus import introspection as ros2
from robocourse.bus.action import (
    TRANSITIONS,
    ActionClient,
    ActionServer,
    CancelResponse,
    GoalEvent,
    GoalResponse,
    InvalidGoalTransition,
    goal_transition,
)
from robocourse.msgs.action_msgs import CancelGoal, GoalStatus, GoalStatusArray
from robocourse.msgs.example_interfaces import Fibonacci

S = GoalStatus
ALL_STATES = [S.STATUS_UNKNOWN, S.STATUS_ACCEPTED, S.STATUS_EXECUTING, S.STATUS_CANCELING,
              S.STATUS_SUCCEEDED, S.STATUS_CANCELED, S.STATUS_ABORTED]
VALID = {
    (S.STATUS_ACCEPTED, GoalEvent.EXECUTE): S.STATUS_EXECUTING,
    (S.STATUS_ACCEPTED, GoalEvent.CANCEL_GOAL): S.STATUS_CANCELING,
    (S.STATUS_EXECUTING, GoalEvent.CANCEL_GOAL): S.STATUS_CANCELING,
    (S.STATUS_EXECUTING, GoalEvent.SUCCEED): S.STATUS_SUCCEEDED,
    (S.STATUS_EXECUTING, GoalEvent.ABORT): S.STATUS_ABORTED,
    (S.STATUS_CANCELING, GoalEvent.SUCCEED): S.STATUS_SUCCEEDED,
    (S.STATUS_CANCELING, GoalEvent.ABORT): S.STATUS_ABORTED,
    (S.STATUS_CANCELING, GoalEvent.CANCELED): S.STATUS_CANCELED,
}


@pytest.mark.parametrize("state,event", list(itertools.product(ALL_STATES, list(GoalEvent))))
def test_goal_state_machine_transition(state, event):
    if (state, event) in VALID:
        assert goal_transition(state, event) == VALID[(state, event)]
    else:
        with pytest.raises(InvalidGoalTransition, match="invalid transition"):
            goal_transition(state, event)


def test_transition_table_is_exactly_the_ros_one():
    assert TRANSITIONS == VALID


def fib_execute(node, steps_log=None):
    async def execute(goal_handle):
        seq = [0, 1]
        for i in range(1, goal_handle.request.order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                return Fibonacci.Result(sequence=seq)
            seq.append(seq[i] + seq[i - 1])
            goal_handle.publish_feedback(Fibonacci.Feedback(sequence=list(seq)))
            await node.sleep_async(0.1)
        goal_handle.succeed()
        return Fibonacci.Result(sequence=seq)
    return execute


def setup(execute=None, **server_kw):
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    s, c = ctx.create_node("fib_server"), ctx.create_node("fib_client")
    server = ActionServer(s, Fibonacci, "fibonacci", execute or fib_execute(s), **server_kw)
    client = ActionClient(c, Fibonacci, "fibonacci")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(s)
    ex.add_node(c)
    return ctx, s, c, server, client, ex


def send(ex, client, order, feedback=None):
    f = client.send_goal_async(Fibonacci.Goal(order=order), feedback_callback=feedback)
    ex.spin_until_future_complete(f)
    return f.result()


def result(ex, handle):
    f = handle.get_result_async()
    ex.spin_until_future_complete(f)
    return f.result()


def test_goal_succeeds_with_feedback_and_status_topic():
    ctx, s, c, server, client, ex = setup()
    statuses = []
    c.create_subscription(GoalStatusArray, "/fibonacci/_action/status",
                          lambda m: statuses.append([st.status for st in m.status_list]),
                          server._status_pub.qos_profile)
    assert client.wait_for_server(timeout_sec=1) and client.server_is_ready()
    fb = []
    h = send(ex, client, 5, lambda m: fb.append(list(m.feedback.sequence)))
    assert h.accepted
    r = result(ex, h)
    assert r.status == S.STATUS_SUCCEEDED and r.result.sequence.tolist() == [0, 1, 1, 2, 3, 5]
    assert fb == [[0, 1, 1], [0, 1, 1, 2], [0, 1, 1, 2, 3], [0, 1, 1, 2, 3, 5]]
    assert h.status == S.STATUS_SUCCEEDED
    assert statuses[0] == [S.STATUS_ACCEPTED] and [S.STATUS_EXECUTING] in statuses
    assert statuses[-1] == [S.STATUS_SUCCEEDED]
    assert ctx.now() == pytest.approx(0.4)


def test_goal_rejected_by_goal_callback():
    ctx, s, c, server, client, ex = setup(goal_callback=lambda g: GoalResponse.REJECT if g.order > 10 else GoalResponse.ACCEPT)
    assert not send(ex, client, 50).accepted
    assert send(ex, client, 3).accepted


@pytest.mark.parametrize("answer", [True, 2, None, "ACCEPT", CancelResponse.ACCEPT])
def test_goal_callback_returning_no_goal_response_rejects_the_goal(answer):
    # rclpy _execute_goal_request: "Goal request callback did not return a GoalResponse type.
    # Rejecting goal." -- a warning on the server, a plain rejection on the client
    ctx, s, c, server, client, ex = setup(goal_callback=lambda g: answer)
    h = send(ex, client, 3)
    assert not h.accepted and h.status == S.STATUS_UNKNOWN
    assert ex.callback_errors == [] and server._goals == {}
    warned = [r.msg for r in ctx.log_records if r.severity.name == "WARN"]
    assert len(warned) == 1 and warned[0].startswith(
        "Goal request callback did not return a GoalResponse type. Rejecting goal.")


def test_cancel_callback_returning_no_cancel_response_rejects_the_cancel():
    ctx, s, c, server, client, ex = setup(cancel_callback=lambda gh: 2)   # the value, not the enum
    h = send(ex, client, 10)
    cf = h.cancel_goal_async()
    ex.spin_until_future_complete(cf)
    assert cf.result().return_code == CancelGoal.Response.ERROR_REJECTED
    assert result(ex, h).status == S.STATUS_SUCCEEDED


def test_deferred_goal_cancelled_before_execute_still_executes_and_ends_canceled():
    # rclpy ServerGoalHandle.execute(): a goal whose cancel was accepted before execute() skips
    # the EXECUTE transition (CANCELING -> EXECUTING is illegal) but the execute callback runs
    deferred, ran = [], []

    def execute(goal_handle):
        ran.append(goal_handle.status)
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
            return Fibonacci.Result(sequence=[0])
        goal_handle.succeed()
        return Fibonacci.Result(sequence=[0, 1])

    ctx, s, c, server, client, ex = setup(execute, handle_accepted_callback=deferred.append,
                                          cancel_callback=lambda gh: CancelResponse.ACCEPT)
    h = send(ex, client, 4)
    ex.spin_for(0.1)
    assert len(deferred) == 1 and deferred[0].status == S.STATUS_ACCEPTED and ran == []
    cf = h.cancel_goal_async()
    ex.spin_until_future_complete(cf)
    assert cf.result().return_code == CancelGoal.Response.ERROR_NONE
    assert deferred[0].status == S.STATUS_CANCELING
    deferred[0].execute()
    r = result(ex, h)
    assert ran == [S.STATUS_CANCELING]
    assert r.status == S.STATUS_CANCELED and r.result.sequence.tolist() == [0]
    assert ex.callback_errors == []


def test_cancel_is_rejected_by_default():
    ctx, s, c, server, client, ex = setup()
    h = send(ex, client, 10)
    cf = h.cancel_goal_async()
    ex.spin_until_future_complete(cf)
    assert cf.result().return_code == CancelGoal.Response.ERROR_REJECTED
    assert cf.result().goals_canceling == []
    assert result(ex, h).status == S.STATUS_SUCCEEDED


def test_accepted_cancel_needs_the_execute_loop_to_call_canceled():
    ctx, s, c, server, client, ex = setup(cancel_callback=lambda gh: CancelResponse.ACCEPT)
    h = send(ex, client, 10)
    ex.spin_for(0.25)
    cf = h.cancel_goal_async()
    ex.spin_until_future_complete(cf)
    assert cf.result().return_code == CancelGoal.Response.ERROR_NONE
    assert len(cf.result().goals_canceling) == 1
    r = result(ex, h)
    assert r.status == S.STATUS_CANCELED and len(r.result.sequence) < 11
    # cancelling a finished goal
    cf2 = h.cancel_goal_async()
    ex.spin_until_future_complete(cf2)
    assert cf2.result().return_code == CancelGoal.Response.ERROR_GOAL_TERMINATED


def test_cancel_unknown_goal_and_cancel_all():
    ctx, s, c, server, client, ex = setup(cancel_callback=lambda gh: CancelResponse.ACCEPT)
    from robocourse.msgs.action_msgs import GoalInfo
    from robocourse.msgs.unique_identifier_msgs import UUID

    f = client._cancel_goal_client.call_async(CancelGoal.Request(goal_info=GoalInfo(goal_id=UUID(uuid=[7] * 16))))
    ex.spin_until_future_complete(f)
    assert f.result().return_code == CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID
    h1, h2 = send(ex, client, 10), send(ex, client, 10)
    f = client._cancel_goal_client.call_async(CancelGoal.Request())   # zero id + zero stamp: all
    ex.spin_until_future_complete(f)
    assert f.result().return_code == CancelGoal.Response.ERROR_NONE
    assert len(f.result().goals_canceling) == 2
    assert result(ex, h1).status == result(ex, h2).status == S.STATUS_CANCELED


def test_execute_returning_without_terminal_state_aborts():
    def execute(goal_handle):
        return Fibonacci.Result(sequence=[1])

    ctx, s, c, server, client, ex = setup(execute)
    r = result(ex, send(ex, client, 3))
    assert r.status == S.STATUS_ABORTED and r.result.sequence.tolist() == [1]
    assert any("Goal state not set, assuming aborted" in rec.msg for rec in ctx.log_records)


def test_execute_raising_aborts_and_server_survives():
    calls = []

    def execute(goal_handle):
        calls.append(goal_handle.request.order)
        if goal_handle.request.order == 13:
            raise RuntimeError("unlucky")
        goal_handle.succeed()
        return Fibonacci.Result(sequence=[goal_handle.request.order])

    ctx, s, c, server, client, ex = setup(execute)
    r = result(ex, send(ex, client, 13))
    assert r.status == S.STATUS_ABORTED and r.result.sequence.tolist() == []
    assert any("unlucky" in rec.msg for rec in ctx.log_records)
    r2 = result(ex, send(ex, client, 2))
    assert r2.status == S.STATUS_SUCCEEDED and calls == [13, 2]


def test_invalid_transition_inside_execute_aborts_the_goal():
    def execute(goal_handle):
        goal_handle.succeed()
        goal_handle.abort()          # SUCCEEDED -> ABORTED is not allowed

    ctx, s, c, server, client, ex = setup(execute)
    r = result(ex, send(ex, client, 2))
    assert r.status == S.STATUS_SUCCEEDED
    assert any("invalid transition from state SUCCEEDED with event ABORT" in rec.msg
               for rec in ctx.log_records)


def test_result_timeout_forgets_results():
    ctx, s, c, server, client, ex = setup(result_timeout=2.0)
    h = send(ex, client, 2)
    assert result(ex, h).status == S.STATUS_SUCCEEDED
    ex.spin_for(1.0)
    assert result(ex, h).status == S.STATUS_SUCCEEDED
    ex.spin_for(2.0)
    r = result(ex, h)
    assert r.status == S.STATUS_UNKNOWN and r.result.sequence.tolist() == []
    assert server._goals == {}


def test_default_result_timeout_is_ten_seconds():
    ctx, s, c, server, client, ex = setup()
    assert server.result_timeout == 10


def test_wrong_goal_type_and_goal_ids_are_reproducible():
    ctx, s, c, server, client, ex = setup()
    with pytest.raises(TypeError, match="Fibonacci_Goal"):
        client.send_goal_async(Fibonacci.Result())
    ids = [bytes(send(ex, client, 1).goal_id.uuid) for _ in range(2)]
    ctx2, *_rest, client2, ex2 = setup()
    ids2 = [bytes(send(ex2, client2, 1).goal_id.uuid) for _ in range(2)]
    assert ids == ids2 and ids[0] != ids[1]


def test_action_cli_send_goal_prints_ros_text(capsys):
    ctx, s, c, server, client, ex = setup()
    status, res, fbs = ros2.action_send_goal(ctx, "/fibonacci", Fibonacci, {"order": 3}, ex)
    out = capsys.readouterr().out
    assert status == S.STATUS_SUCCEEDED and res.sequence.tolist() == [0, 1, 1, 2] and len(fbs) == 2
    for line in ("Waiting for an action server to become available...", "Sending goal:",
                 "Goal accepted with ID: ", "Feedback:", "Result:",
                 "Goal finished with status: SUCCEEDED"):
        assert line in out
    assert ros2.action_list(ctx) == [("/fibonacci", ["example_interfaces/action/Fibonacci"])]
    info = ros2.action_info(ctx, "/fibonacci")
    assert info["servers"] == ["/fib_server"] and info["clients"] == ["/fib_client"]
    assert "Action servers: 1" in capsys.readouterr().out
