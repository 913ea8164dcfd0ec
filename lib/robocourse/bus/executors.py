"""Executors: who runs the callbacks, on which thread, and when time moves.

rclpy counterparts: ``rclpy.executors.SingleThreadedExecutor`` and ``MultiThreadedExecutor``
with ``add_node``, ``spin``, ``spin_once(timeout_sec)``, ``spin_until_future_complete``,
``create_task`` and ``shutdown``. Additions: ``spin_for(seconds)`` and ``spin_until(t)``
(measured on the simulated clock when the context uses sim time, else on the wall clock), and
``callback_errors`` (what went wrong in callbacks, with topic and node).

How it works: publishing puts the message in each matched subscription's queue and, if the
subscription was idle, appends the subscription to its executor's ready queue (no lock in the
single-threaded case). Each spin iteration runs the earliest due timer, else the next ready
entity (one message per subscription per turn, round robin). In simulated time, when nothing
is ready the executor jumps the context's clock to the next timer deadline.

One thread spins an executor at a time (rclpy >= PR #1510, rclcpp's ``spinning`` flag): any
spin call while another thread is inside one raises ``RuntimeError("Executor is already
spinning ...")``; the claim is released on every exit, exceptions included.

A callback that raises, as in rclpy: the exception propagates out of the spin call that ran
it (``spin``, ``spin_once``, ``spin_until_future_complete``, ``spin_for``, ...); the executor
stays usable and the next spin call goes on with the remaining work. This holds for timer,
subscription, service and event callbacks, tasks (``create_task``, a future's done callback)
and ``async def`` callbacks, whenever their coroutine fails. Nothing is lost either way: each
one is also recorded in ``executor.callback_errors`` (and ``context.callback_errors``) with
its topic and node. Action execute callbacks are the exception, as in rclpy: a raising execute
callback aborts the goal and the server logs it.

``Executor(on_callback_error="log")`` is the one documented choice otherwise (a robocourse
addition, for long demos that must outlive a faulty callback): the error is logged with its
topic and node, recorded, and spinning goes on. A service callback that raises also fails the
waiting client's future with a ServiceCallbackError (rclpy leaves the client waiting).
A MultiThreadedExecutor stops its pool at the first failure and re-raises it from the spin
call once the callbacks still running have finished (rclpy raises it from a later
``spin_once``).
"""

from __future__ import annotations

import math
import threading
import time as _time
import traceback
from collections import deque

from robocourse.bus import _args
from robocourse.bus.task import Future, Task

_tls = threading.local()


def current_callback():
    """(executor, entity) of the callback running on this thread, or None."""
    return getattr(_tls, "current", None)


def _check_timeout(timeout_sec, what):
    """rclpy: None or a negative timeout blocks forever; anything else must be seconds."""
    if isinstance(timeout_sec, (int, float)) and not isinstance(timeout_sec, bool) \
            and timeout_sec < 0:
        return None
    _args.seconds(timeout_sec, f"{what}(timeout_sec)", allow_none=True)
    return timeout_sec


def _check_future(future):
    if not isinstance(future, Future):
        raise TypeError(f"spin_until_future_complete needs a Future (from client.call_async, "
                        f"send_goal_async or executor.create_task), got {future!r:.80}")


class CallbackError:
    """One exception raised by a callback, with where it happened."""

    def __init__(self, where: str, exception: BaseException, text: str):
        self.where = where
        self.exception = exception
        self.traceback = text

    def __repr__(self):
        return f"CallbackError({self.where}: {self.exception!r})"


class Executor:
    """Base class; use :class:`SingleThreadedExecutor` or :class:`MultiThreadedExecutor`."""

    def __init__(self, *, context=None, on_callback_error: str = "raise"):
        from robocourse.bus.context import get_default_context

        if on_callback_error not in ("raise", "log"):
            raise ValueError(f"on_callback_error={on_callback_error!r} must be 'raise' (rclpy: the "
                             f"exception leaves spin) or 'log' (log it, keep spinning)")
        self.on_callback_error = on_callback_error
        self._context = context if context is not None else get_default_context(create=False)
        self._nodes = []
        self._timers = []
        self._ready = deque()
        self._sleeping = 0
        self._is_shutdown = False
        self._spin_lock = threading.Lock()
        self._spin_owner: tuple[int, str] | None = None   # (thread id, thread name) of the spinning thread
        self.callback_errors: list[CallbackError] = []
        self._running = 0
        self._nodes_lock = threading.Lock()
        self._done_flag = None
        self._after_timer = False
        self._budget = 0

    # ------------------------------------------------------------------ nodes & entities
    @property
    def context(self):
        return self._context

    def add_node(self, node) -> bool:
        if not hasattr(node, "_entities") or not hasattr(node, "get_fully_qualified_name"):
            raise TypeError(f"add_node needs a Node (ctx.create_node('name')), got {node!r:.80}")
        if self._context is None:
            self._context = node.context
        elif node.context is not self._context:
            raise ValueError(
                f"node {node.get_fully_qualified_name()!r} belongs to another context than this "
                f"executor; create the executor with context=node.context")
        with self._nodes_lock:
            if node in self._nodes:
                return False
            if node._executor is not None and node._executor is not self:
                node._executor.remove_node(node)
            self._nodes.append(node)
            node._executor = self
        self._context._executors.add(self)
        for ent in node._entities():
            self._attach(ent)
        pending, node._pending_tasks = node._pending_tasks, []
        for task in pending:
            task._executor = self
            self._schedule(task)
        return True

    def remove_node(self, node) -> None:
        with self._nodes_lock:
            if node not in self._nodes:
                return
            self._nodes.remove(node)
            node._executor = None
        for ent in node._entities():
            self._detach(ent)

    def get_nodes(self):
        return list(self._nodes)

    def _attach(self, ent) -> None:
        ent._executor = self
        if getattr(ent, "_is_timer", False):
            if ent not in self._timers:
                self._timers.append(ent)
            self._wake()
            return
        if ent._take_check():
            self._schedule(ent)

    def _detach(self, ent) -> None:
        ent._executor = None
        if getattr(ent, "_is_timer", False):
            if ent in self._timers:
                self._timers.remove(ent)
        else:
            try:
                while True:
                    self._ready.remove(ent)
            except ValueError:
                pass
            ent._scheduled = False

    def _schedule(self, ent) -> None:
        """Put an entity with work on the ready queue (any thread)."""
        ent._scheduled = True
        self._ready.append(ent)
        if self._sleeping:
            self._wake()

    def create_task(self, callback, *args, **kwargs) -> Task:
        """rclpy Executor.create_task: run ``callback(*args)`` (function or coroutine) soon."""
        task = Task(callback, args, kwargs, executor=self)
        self._schedule(task)
        return task

    # ------------------------------------------------------------------ time
    def _sim(self):
        ctx = self._context
        return ctx.sim if ctx is not None else None

    def _now_base(self) -> int:
        """The executor's time base: simulated ns in sim time, else monotonic ns."""
        sim = self._sim()
        return sim.ns if sim is not None else _time.monotonic_ns()

    # ------------------------------------------------------------------ polling
    def _due_timer(self):
        best = None
        best_ns = None
        for t in self._timers:
            nxt = t._next_ns
            if nxt is None or (best_ns is not None and nxt >= best_ns):
                continue
            if nxt <= t._clock._now_ns() and self._group_free(t):
                best, best_ns = t, nxt
        return best

    def _group_free(self, ent) -> bool:
        return True

    def _next_deadlines(self):
        """(ns until the next wall-clock timer or None, absolute ns of next sim timer or None)."""
        wall = None
        sim_next = None
        for t in self._timers:
            nxt = t._next_ns
            if nxt is None:
                continue
            clock = t._clock
            if clock.is_simulated:
                if sim_next is None or nxt < sim_next:
                    sim_next = nxt
            else:
                d = nxt - clock._now_ns()
                if wall is None or d < wall:
                    wall = d
        return wall, sim_next

    def _pop_ready(self):
        ready = self._ready
        while ready:
            ent = ready.popleft()
            ent._scheduled = False
            work = ent._take()
            if ent._take_check() and not ent._scheduled:
                ent._scheduled = True
                ready.append(ent)
            if work is not None:
                return ent, work
        return None

    def _poll(self):
        # Fairness like rclpy's wait set: after a timer ran, the entities that are ready at
        # that point (e.g. the subscriptions it just published to) run before the next timer.
        if self._after_timer:
            self._after_timer = False
            self._budget = len(self._ready)
        if self._budget > 0:
            self._budget -= 1
            item = self._pop_ready()
            if item is not None:
                return item
            self._budget = 0
        if self._timers:
            t = self._due_timer()
            if t is not None:
                self._after_timer = True
                return t, t._take()
        if self._ready:
            return self._pop_ready()
        return None

    # ------------------------------------------------------------------ waiting
    def _wait_for_work(self, timeout_ns=None, until_ns=None):
        """Return (entity, work) or None when the timeout/until passes or on shutdown.

        ``timeout_ns`` and ``until_ns`` are on the executor's time base (sim ns in sim time).
        """
        ctx = self._context
        sim = ctx.sim if ctx is not None else None
        end = None
        if timeout_ns is not None:
            end = (sim.ns if sim is not None else _time.monotonic_ns()) + max(0, int(timeout_ns))
        if until_ns is not None:
            end = until_ns if end is None else min(end, until_ns)
        done_flag = self._done_flag
        # spin_once(timeout) polls at least once even with a zero timeout; spin loops stop
        # at their end time before polling (so always-due work cannot keep them running)
        first = until_ns is None
        while True:
            if self._is_shutdown or (ctx is not None and not ctx._ok):
                return None
            if done_flag is not None and done_flag():
                return None
            if end is not None and not first:
                # wall time moves while callbacks run: stop at the end even if work remains;
                # simulated time only moves here, so work due exactly at `end` still runs
                now = sim.ns if sim is not None else _time.monotonic_ns()
                if now > end or (sim is None and now >= end):
                    return None
            first = False
            item = self._poll()
            if item is not None:
                return item
            wall_wait, sim_next = self._next_deadlines()
            if sim is not None:
                if self._running:
                    self._sleep(None)       # another thread is busy: it may publish
                    continue
                now = sim.ns
                if end is not None and now >= end:
                    return None
                if sim.driver is not None:
                    self._sleep(0.001)      # another loop drives the sim clock: follow it
                    continue
                if sim_next is not None and (end is None or sim_next <= end):
                    sim.advance_to(sim_next)
                    continue
                if end is not None and wall_wait is None:
                    # nothing is scheduled before `end`: in simulated time the executor is the
                    # clock, so it jumps there (another thread's publish would not wait for it)
                    sim.advance_to(end)
                    return None
                wait = None if wall_wait is None else max(0, wall_wait) / 1e9
                self._sleep(wait)
                continue
            now = _time.monotonic_ns()
            if end is not None and now >= end:
                return None
            wait = None if wall_wait is None else max(0, wall_wait)
            if end is not None:
                rem = end - now
                wait = rem if wait is None else min(wait, rem)
            self._sleep(None if wait is None else wait / 1e9)

    # ------------------------------------------------------------------ running
    def _run(self, ent, work):
        prev = getattr(_tls, "current", None)
        _tls.current = (self, ent)
        failed = None
        try:
            out = ent._execute(work)
            if out is not None and hasattr(out, "send") and hasattr(out, "throw"):
                # an `async def` callback: run it as a task, like rclpy's executor does; its
                # later steps come back here as the task itself
                task = Task(lambda c=out: c, executor=self, callback_group=ent.callback_group)
                task._node = getattr(ent, "_node", None)
                task._origin = ent
                task()
                ent = task
            if isinstance(ent, Task) and ent.done() and ent._exception is not None \
                    and not ent._reported:
                ent._reported = True
                failed = (getattr(ent, "_origin", ent), ent._exception, False)
        except Exception as exc:  # noqa: BLE001 - recorded, then raised (or logged) by _report
            failed = (ent, exc, True)
        finally:
            _tls.current = prev
        if failed is not None:
            self._report(*failed)

    def _report(self, ent, exc, tb=True):
        """Record a callback's exception; raise it (rclpy) or log it (``on_callback_error="log"``)."""
        where = ent._describe() if hasattr(ent, "_describe") else repr(ent)
        text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
        err = CallbackError(where, exc, text)
        self.callback_errors.append(err)
        if self._context is not None:
            self._context.callback_errors.append(err)
        if self.on_callback_error == "raise":
            raise exc
        node = getattr(ent, "_node", None)
        msg = f"Exception in {where}: {type(exc).__name__}: {exc}\n{text.rstrip()}"
        if node is not None:
            node.get_logger().error(msg)
        elif self._context is not None:
            from robocourse.bus.logging import RcutilsLogger

            RcutilsLogger("executor", self._context).error(msg)

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run at most one callback, waiting up to ``timeout_sec`` (None: until work)."""
        timeout_sec = _check_timeout(timeout_sec, "spin_once")
        self._enter("spin_once")
        try:
            item = self._wait_for_work(None if timeout_sec is None else int(timeout_sec * 1e9))
            if item is not None:
                self._run(*item)
        finally:
            self._leave()

    def spin_some(self, max_callbacks: int = 1000) -> int:
        """rclcpp ``Executor::spin_some``: run the callbacks ready now, never wait; return how many.

        Due timers and queued messages run, including messages that those callbacks publish;
        simulated time does not advance. ``max_callbacks`` bounds one call (a zero-period timer
        is always due). The real-time executor of chapter 2 calls this once per loop iteration.
        """
        _args.integer(max_callbacks, "spin_some", "max_callbacks", 1)
        self._enter("spin_some")
        try:
            n = 0
            while n < max_callbacks:
                if self._is_shutdown or (self._context is not None and not self._context.ok()):
                    break
                item = self._poll()
                if item is None:
                    break
                self._run(*item)
                n += 1
            return n
        finally:
            self._leave()

    def spin(self) -> None:
        """Run callbacks until the context is shut down or ``shutdown()`` is called."""
        self._spin_loop(None)

    def spin_for(self, seconds: float) -> None:
        """Spin for ``seconds`` of executor time (simulated time if the context uses it).

        In simulated time all callbacks due in the window run, in deadline order, and the
        clock ends exactly ``seconds`` later; this takes as long as the callbacks, not longer.
        """
        _args.seconds(seconds, "spin_for(seconds)", name="seconds")
        self.spin_until(self._now_base() + int(round(seconds * 1e9)))

    def spin_until(self, t_ns: int) -> None:
        """Spin until the executor time base reaches ``t_ns`` (sim ns or monotonic ns)."""
        if isinstance(t_ns, bool) or not isinstance(t_ns, (int, float)) or not math.isfinite(t_ns):
            raise TypeError(f"spin_until: t_ns={t_ns!r} must be a time in integer nanoseconds on "
                            f"the executor's time base; to spin for a duration use "
                            f"spin_for(seconds)")
        self._spin_loop(int(t_ns))

    def _spin_loop(self, until_ns):
        self._enter("spin" if until_ns is None else "spin_for/spin_until")
        try:
            while True:
                item = self._wait_for_work(None, until_ns)
                if item is None:
                    return
                self._run(*item)
        finally:
            self._leave()

    def _arm_future(self, future, timeout_sec):
        """Wake this executor when ``future`` completes; return the end time of the wait (or None)."""

        def wake(_f, ex=self):
            ex._wake()

        wake._immediate = True
        future.add_done_callback(wake)
        return None if timeout_sec is None else self._now_base() + int(timeout_sec * 1e9)

    def spin_until_future_complete(self, future, timeout_sec: float | None = None) -> None:
        """Spin until ``future`` is done or ``timeout_sec`` (executor time) passes."""
        _check_future(future)
        timeout_sec = _check_timeout(timeout_sec, "spin_until_future_complete")
        self._enter("spin_until_future_complete")
        try:
            end = self._arm_future(future, timeout_sec)
            self._future_waiting = True
            self._done_flag = future.done
            while not future.done():
                item = self._wait_for_work(None, end)
                if item is None:
                    if future.done() or self._is_shutdown or not self._context.ok():
                        return
                    if end is not None and self._now_base() >= end:
                        return
                    continue
                self._run(*item)
        finally:
            self._future_waiting = False
            self._done_flag = None
            self._leave()

    def _enter(self, what: str = "spin"):
        """Claim the executor for this thread (rclpy's ``_enter_spin``); refuse a second spinner.

        Pair every successful call with :meth:`_leave` in a ``finally``; a refused call claims nothing.
        """
        me = threading.current_thread()
        tid = me.ident
        with self._spin_lock:
            owner = self._spin_owner
            if owner is None:
                self._spin_owner = (tid, me.name)
                return
        cur = current_callback()
        if owner[0] == tid or (cur is not None and cur[0] is self):
            raise RuntimeError(
                f"{what}(): this executor is already spinning on this thread: do not call spin*() from "
                "inside a callback; use call_async / futures instead")
        raise RuntimeError(
            f"Executor is already spinning on another thread ('{owner[1]}'): {what}() from thread "
            f"'{me.name}' refused, as in rclpy. One thread spins an executor; from other threads "
            "publish, use client.call_async / send_goal_async and wait on the future (or its done "
            "callback), or give this thread another executor with its own nodes.")

    def _leave(self):
        with self._spin_lock:
            if self._spin_owner is not None and self._spin_owner[0] == threading.get_ident():
                self._spin_owner = None

    def is_spinning(self) -> bool:
        """rclcpp ``Executor::is_spinning``: True while some thread is inside a spin call."""
        return self._spin_owner is not None

    def is_spinning_elsewhere(self) -> bool:
        """True while a thread other than the caller is inside a spin call."""
        owner = self._spin_owner
        return owner is not None and owner[0] != threading.get_ident()

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        """Stop spinning (after the running callbacks finish) and detach all nodes."""
        self._is_shutdown = True
        self._wake()
        for node in list(self._nodes):
            self.remove_node(node)
        return True

    # per subclass
    def _sleep(self, seconds):
        raise NotImplementedError

    def _wake(self):
        raise NotImplementedError

    @property
    def num_threads(self) -> int:
        return 1


class SingleThreadedExecutor(Executor):
    """rclpy.executors.SingleThreadedExecutor: callbacks run one at a time on the spinning thread."""

    def __init__(self, *, context=None, on_callback_error: str = "raise"):
        super().__init__(context=context, on_callback_error=on_callback_error)
        # the wake-up signal: a plain lock held while unsignalled (release = set, a
        # successful acquire = wait + clear). Same semantics as threading.Event's
        # set/wait/clear, but one C call on each side instead of a Condition's Python code:
        # samples from the zenoh transport's threads reach the spinning thread sooner.
        self._signal = threading.Lock()
        self._signal.acquire()

    def _sleep(self, seconds):
        self._sleeping += 1
        try:
            if self._ready or self._is_shutdown:
                return
            if seconds is None:
                self._signal.acquire()
            else:
                self._signal.acquire(True, min(max(seconds, 0.0), threading.TIMEOUT_MAX))
        finally:
            self._sleeping -= 1

    def _wake(self):
        try:
            self._signal.release()
        except RuntimeError:        # already signalled (not yet consumed): nothing to add
            pass


class MultiThreadedExecutor(Executor):
    """rclpy.executors.MultiThreadedExecutor(num_threads): a thread pool runs callbacks.

    Callbacks of one MutuallyExclusiveCallbackGroup (every node's default group) never run
    at the same time, so parallelism needs ReentrantCallbackGroup or several groups.
    """

    def __init__(self, num_threads: int | None = None, *, context=None,
                 on_callback_error: str = "raise"):
        if num_threads is not None:
            _args.integer(num_threads, "MultiThreadedExecutor", "num_threads", 1)
        super().__init__(context=context, on_callback_error=on_callback_error)
        import os

        self._num_threads = num_threads or max(2, os.cpu_count() or 2)
        self._cond = threading.Condition()
        self._workers = []
        self._stop = False
        self._session = None
        self._failure = None        # the first callback exception of a pool run, re-raised by spin

    @property
    def num_threads(self) -> int:
        return self._num_threads

    def _group_free(self, ent) -> bool:
        g = ent.callback_group
        return g is None or g.can_execute(ent)

    def _pop_ready(self):
        ready = self._ready
        n = len(ready)
        for _ in range(n):
            ent = ready.popleft()
            ent._scheduled = False
            g = ent.callback_group
            if g is not None and not g.can_execute(ent):
                if ent._take_check():
                    ent._scheduled = True
                    ready.append(ent)
                continue
            work = ent._take()
            if ent._take_check() and not ent._scheduled:
                ent._scheduled = True
                ready.append(ent)
            if work is not None:
                if g is not None:
                    g.beginning_execution(ent)
                return ent, work
        return None

    def _poll(self):
        t = self._due_timer()
        if t is not None:
            work = t._take()
            g = t.callback_group
            if g is not None:
                g.beginning_execution(t)
            return t, work
        if self._ready:
            return self._pop_ready()
        return None

    def _sleep(self, seconds):
        # called with self._cond held
        self._sleeping += 1
        try:
            self._cond.wait(seconds if seconds is not None else 0.05)
        finally:
            self._sleeping -= 1

    def _wake(self):
        with self._cond:
            self._cond.notify_all()

    def _worker(self, until_ns, done_flag, session):
        # a worker of an earlier spin call (still finishing a callback when that call returned)
        # leaves as soon as it sees another session, without touching the new one's state
        while not self._stop and self._session is session:
            with self._cond:
                if self._session is not session:
                    return
                if done_flag():
                    self._stop = True
                    self._cond.notify_all()
                    return
                item = self._wait_for_work(50_000_000 if self._sim() is None else None, until_ns)
                if item is None:
                    if self._session is not session:
                        return
                    if self._sim() is not None or until_ns is not None and self._now_base() >= until_ns:
                        if self._running == 0:
                            self._stop = True
                            self._cond.notify_all()
                            return
                    if self._is_shutdown or not self._context.ok() or done_flag():
                        self._stop = True
                        self._cond.notify_all()
                        return
                    if self._running:
                        self._cond.wait(0.01)
                    continue
                self._running += 1
            try:
                self._run_claimed(*item)
            except Exception as exc:  # noqa: BLE001 - handed to the spinning thread
                with self._cond:
                    if self._failure is None:
                        self._failure = exc
                    self._stop = True
                    self._cond.notify_all()
                return

    def _run_claimed(self, ent, work):
        """Run one item taken under the lock (counted in ``_running``), then release its group."""
        try:
            self._run(ent, work)
        finally:
            with self._cond:
                self._running -= 1
                g = ent.callback_group
                if g is not None:
                    g.ending_execution(ent)
                self._cond.notify_all()

    def _spin_loop(self, until_ns, done_flag=lambda: False, return_when_done=False, claimed=False):
        if not claimed:
            self._enter("spin" if until_ns is None else "spin_for/spin_until")
        try:
            session = object()
            with self._cond:
                self._session = session
                self._stop = False
                self._failure = None
            self._done_flag = done_flag
            threads = [threading.Thread(target=self._worker, args=(until_ns, done_flag, session),
                                        name=f"robocourse-executor-{i}", daemon=True)
                       for i in range(self._num_threads)]
            for t in threads:
                t.start()
            if return_when_done:
                # rclpy returns from spin_until_future_complete as soon as the future is done;
                # callbacks still running on the pool finish on their own threads
                with self._cond:
                    while not done_flag() and self._failure is None \
                            and any(t.is_alive() for t in threads):
                        self._cond.wait(0.05)
                    self._stop = True
                    self._cond.notify_all()
                if self._failure is not None:
                    for t in threads:       # the callbacks still running finish first
                        t.join()
                    self._raise_failure()
                return
            for t in threads:
                t.join()
            self._raise_failure()
        finally:
            self._done_flag = None
            if not claimed:
                self._leave()

    def _raise_failure(self):
        exc, self._failure = self._failure, None
        if exc is not None:
            raise exc

    def spin_once(self, timeout_sec: float | None = None) -> None:
        timeout_sec = _check_timeout(timeout_sec, "spin_once")
        self._enter("spin_once")
        try:
            with self._cond:
                item = self._wait_for_work(None if timeout_sec is None else int(timeout_sec * 1e9))
                if item is None:
                    return
                self._running += 1
            self._run_claimed(*item)
        finally:
            self._leave()

    def spin_until_future_complete(self, future, timeout_sec: float | None = None) -> None:
        """Return as soon as ``future`` is done (or ``timeout_sec`` passes), like rclpy: callbacks
        already running on other pool threads keep running and finish on their own."""
        _check_future(future)
        timeout_sec = _check_timeout(timeout_sec, "spin_until_future_complete")
        self._enter("spin_until_future_complete")   # before touching shared state: a refusal changes nothing
        try:
            end = self._arm_future(future, timeout_sec)
            self._future_waiting = True
            self._spin_loop(end, done_flag=future.done, return_when_done=True, claimed=True)
        finally:
            self._future_waiting = False
            self._leave()

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        self._stop = True
        return super().shutdown(timeout_sec)
