"""Chapter 3's "break it" experiments that need more than a line: a blocking action execute.

The seed's troubleshooting table: "action does not cancel" -> the execute callback blocks the
only executor thread, so the cancel request waits in the queue until the goal has finished.
The fix: a MultiThreadedExecutor and a ReentrantCallbackGroup for the action server.
"""

from __future__ import annotations

import threading
import time

from robocourse.bus import (
    Context,
    MultiThreadedExecutor,
    ReentrantCallbackGroup,
    SingleThreadedExecutor,
)
from robocourse.bus.action import STATUS_NAMES, ActionClient, ActionServer, CancelResponse

from .msgs import NavigateToPose


def _wait(fut, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while not fut.done() and time.monotonic() < end:
        time.sleep(0.002)
    return fut.done()


def blocking_action(multithreaded: bool, work_s: float = 2.0, cancel_after_s: float = 0.3) -> dict:
    """Send a goal whose execute callback works ``work_s`` seconds (blocking), cancel it after
    ``cancel_after_s``, and measure when the cancel was answered and how the goal ended.

    The executor spins in a background thread (wall clock), as a ROS program's would.
    """
    ctx = Context()
    server_node, client_node = ctx.create_node("slow_server"), ctx.create_node("client")

    def execute(goal_handle):  # a plain function: it blocks its executor thread while it runs
        t0 = time.monotonic()
        while time.monotonic() - t0 < work_s:
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                return NavigateToPose.Result(success=False, message="canceled")
            time.sleep(0.01)
        goal_handle.succeed()
        return NavigateToPose.Result(success=True, message=f"worked {work_s:g} s")

    ActionServer(server_node, NavigateToPose, "/slow_task", execute,
                 cancel_callback=lambda _req: CancelResponse.ACCEPT,
                 callback_group=ReentrantCallbackGroup() if multithreaded else None)
    ex = MultiThreadedExecutor(context=ctx) if multithreaded else SingleThreadedExecutor(context=ctx)
    ex.add_node(server_node)
    ex.add_node(client_node)
    spinner = threading.Thread(target=ex.spin, daemon=True)
    spinner.start()
    try:
        client = ActionClient(client_node, NavigateToPose, "/slow_task")
        t0 = time.monotonic()
        goal = client.send_goal_async(NavigateToPose.Goal())
        if not _wait(goal, 5.0):
            raise RuntimeError("the slow_task server did not answer the goal within 5 s")
        time.sleep(cancel_after_s)
        cancel = goal.result().cancel_goal_async()
        _wait(cancel, work_s + 5.0)
        cancel_s = time.monotonic() - t0
        result = goal.result().get_result_async()
        _wait(result, work_s + 5.0)
        res = result.result()
        return {"executor": type(ex).__name__, "status": STATUS_NAMES.get(res.status, str(res.status)),
                "message": res.result.message, "cancel_answered_s": cancel_s,
                "result_s": time.monotonic() - t0}
    finally:
        ctx.try_shutdown()
        spinner.join(timeout=2.0)
