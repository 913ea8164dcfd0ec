"""An action goal shared between a controller's update() and its node (realtime_tools' goal handle).

Counterpart: ``realtime_tools::RealtimeServerGoalHandle`` with the controller's goal-handle
timer (``action_monitor_rate``): the real-time side only records what should happen
(``set_succeeded`` / ``set_aborted`` / ``set_canceled``, and that feedback is due); the timer
on the controller's node calls :meth:`GoalMonitor.run_non_realtime`, which publishes feedback
and finishes goals through the bus. A controller's ``async`` execute callback awaits
:meth:`RealtimeServerGoalHandle.wait` for the result it returns.
"""

from __future__ import annotations

from robocourse.bus.task import Future


class RealtimeServerGoalHandle:
    """One accepted goal: the bus handle, the result future, what the real-time side decided."""

    def __init__(self, handle):
        self.handle = handle
        self.future = Future()
        self.feedback_due = None     # set by update(): whatever the feedback builder needs
        self.outcome = None          # ("succeed" | "abort" | "canceled", Result)

    def set_succeeded(self, result) -> None:
        self.outcome = ("succeed", result)

    def set_aborted(self, result) -> None:
        self.outcome = ("abort", result)

    def set_canceled(self, result) -> None:
        self.outcome = ("canceled", result)

    async def wait(self):
        return await self.future


class GoalMonitor:
    """The active goal and the finished ones awaiting their result on the bus."""

    def __init__(self, make_feedback):
        self.active: RealtimeServerGoalHandle | None = None
        self.finished: list[RealtimeServerGoalHandle] = []
        self._make_feedback = make_feedback       # (goal) -> Feedback message

    def start(self, handle) -> RealtimeServerGoalHandle:
        goal = RealtimeServerGoalHandle(handle)
        self.active = goal
        return goal

    def finish(self, how: str, result) -> RealtimeServerGoalHandle | None:
        """End the active goal (``succeed``, ``abort`` or ``canceled``); the timer reports it."""
        goal = self.active
        if goal is not None:
            self.active = None
            goal.outcome = (how, result)
            self.finished.append(goal)
        return goal

    def find(self, handle) -> RealtimeServerGoalHandle | None:
        if self.active is not None and self.active.handle is handle:
            return self.active
        return next((g for g in self.finished if g.handle is handle), None)

    async def execute(self, handle, untracked_result):
        """The action server's execute callback: wait for the real-time side's decision."""
        goal = self.find(handle)
        if goal is None:
            handle.abort()
            return untracked_result
        return await goal.wait()

    def run_non_realtime(self) -> None:
        """Feedback of the active goal; status and result of every finished goal."""
        goal = self.active
        if goal is not None and goal.feedback_due is not None and goal.handle.is_active:
            goal.handle.publish_feedback(self._make_feedback(goal))
        while self.finished:
            g = self.finished.pop(0)
            if g.feedback_due is not None and g.handle.is_active:
                g.handle.publish_feedback(self._make_feedback(g))
            how, result = g.outcome
            if how == "canceled" and not g.handle.is_cancel_requested:
                how = "abort"       # the action state machine cancels only a goal whose cancel was requested
            if g.handle.is_active:
                {"succeed": g.handle.succeed, "abort": g.handle.abort, "canceled": g.handle.canceled}[how]()
            g.future.set_result(result)


__all__ = ["GoalMonitor", "RealtimeServerGoalHandle"]
