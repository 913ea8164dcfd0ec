"""Futures and tasks.

rclpy counterparts: ``rclpy.task.Future`` and ``rclpy.task.Task``. A Future is awaitable
inside coroutine callbacks (``result = await client.call_async(req)``); done callbacks are
scheduled on the future's executor when it has one, otherwise called immediately.
"""

from __future__ import annotations

import threading

_PENDING, _CANCELLED, _FINISHED = 0, 1, 2


class Future:
    """rclpy.task.Future: done(), result(), exception(), add_done_callback(), cancel()."""

    def __init__(self, *, executor=None):
        self._state = _PENDING
        self._result = None
        self._exception = None
        self._callbacks = []
        self._lock = threading.Lock()
        self._executor = executor

    def done(self) -> bool:
        return self._state != _PENDING

    def cancelled(self) -> bool:
        return self._state == _CANCELLED

    def cancel(self) -> None:
        with self._lock:
            if self._state != _PENDING:
                return
            self._state = _CANCELLED
        self._schedule_callbacks()

    def result(self):
        """The result, or None while pending (rclpy); raises the stored exception if any."""
        if self._exception is not None:
            raise self._exception
        return self._result

    def exception(self):
        return self._exception

    def set_result(self, result) -> None:
        with self._lock:
            if self._state != _PENDING:
                return
            self._result = result
            self._state = _FINISHED
        self._schedule_callbacks()

    def set_exception(self, exception: BaseException) -> None:
        with self._lock:
            if self._state != _PENDING:
                return
            self._exception = exception
            self._state = _FINISHED
        self._schedule_callbacks()

    def add_done_callback(self, callback) -> None:
        with self._lock:
            if self._state == _PENDING:
                self._callbacks.append(callback)
                return
        self._run_callback(callback)

    def _schedule_callbacks(self):
        callbacks, self._callbacks = self._callbacks, []
        for cb in callbacks:
            self._run_callback(cb)

    def _run_callback(self, cb):
        ex = self._executor
        if ex is not None and not getattr(cb, "_immediate", False):
            ex.create_task(cb, self)
        else:
            cb(self)

    def _set_executor(self, executor):
        self._executor = executor

    def __await__(self):
        while not self.done():
            yield self
        return self.result()


def _immediate(cb):
    """Mark a done-callback to run in the completing thread (internal wake-ups)."""
    cb._immediate = True
    return cb


class Task(Future):
    """rclpy.task.Task: runs a function or coroutine on an executor; is a Future of its result."""

    def __init__(self, handler, args=(), kwargs=None, executor=None, callback_group=None):
        super().__init__(executor=executor)
        self._handler = handler
        self._args = args
        self._kwargs = kwargs or {}
        self._coro = None
        self._running = False
        self.callback_group = callback_group
        self._scheduled = False
        self._waiting_on = None
        self._reported = False      # the executor has reported this task's exception

    # -- executor entity protocol --------------------------------------------------------
    def _take_check(self) -> bool:
        return False

    def _take(self):
        return None if self.done() or self._waiting_on is not None else True

    def _execute(self, _work):
        self()

    def _describe(self) -> str:
        origin = getattr(self, "_origin", None)
        if origin is not None and hasattr(origin, "_describe"):
            return origin._describe()
        return f"task {getattr(self._handler, '__qualname__', self._handler)!r}"

    def executing(self) -> bool:
        return self._running

    def __call__(self):
        if self.done() or self._running:
            return
        self._running = True
        try:
            if self._coro is None:
                try:
                    out = self._handler(*self._args, **self._kwargs)
                except Exception as exc:  # noqa: BLE001 - kept on the task, as rclpy's Task
                    self.set_exception(exc)
                    return
                if hasattr(out, "send") and hasattr(out, "throw"):
                    self._coro = out
                else:
                    self.set_result(out)
                    return
            self._step()
        finally:
            self._running = False

    def _step(self):
        try:
            awaited = self._coro.send(None)
        except StopIteration as stop:
            self.set_result(stop.value)
            return
        except Exception as exc:  # noqa: BLE001 - delivered through the future like rclpy
            self.set_exception(exc)
            return
        if isinstance(awaited, Future):
            self._waiting_on = awaited

            def resume(_f, task=self):
                task._waiting_on = None
                ex = task._executor
                if ex is not None:
                    ex._schedule(task)

            resume._immediate = True
            awaited.add_done_callback(resume)
        else:
            # a bare `yield`: run again on the next executor iteration
            if self._executor is not None:
                self._executor._schedule(self)
