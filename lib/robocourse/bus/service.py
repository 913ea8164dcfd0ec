"""Services and clients: request/response between nodes.

rclpy counterparts: ``rclpy.service.Service`` (``node.create_service(srv_type, name,
callback)``, ``callback(request, response) -> response``) and ``rclpy.client.Client``
(``call_async(request) -> Future``, ``call(request, timeout_sec)``, ``wait_for_service``,
``service_is_ready``, ``remove_pending_request``).

Differences, on purpose:
- If the service callback raises or returns something that is not a Response, the exception
  leaves the server's spin call as in rclpy (see :mod:`robocourse.bus.executors`), and the
  client's future also gets a :class:`ServiceCallbackError` (rclpy leaves the client waiting
  forever). The service keeps serving the next requests.
- ``call()`` where ROS would deadlock silently raises :class:`DeadlockError` explaining why:
  inside a callback on a single-threaded executor, inside a callback of the client's own
  mutually exclusive group, or when no executor spins the client's node on another thread.
- Value semantics as in ROS 2: the server gets a copy of the request as it was at
  ``call_async`` and the client a copy of the response as it was when the callback returned.
- A request sent while no server exists is not silently lost: the client logs a warning
  (call ``wait_for_service`` first) and the future stays pending, as in ROS.
"""

from __future__ import annotations

import threading
from collections import deque

from robocourse.bus.callback_groups import MutuallyExclusiveCallbackGroup
from robocourse.bus.executors import current_callback
from robocourse.bus.publisher import InvalidHandle
from robocourse.bus.task import Future


class ServiceCallbackError(RuntimeError):
    """The server's callback failed; carried to the client's future."""


class DeadlockError(RuntimeError):
    """A synchronous call that could never complete."""


class ServerGoneError(ConnectionError):
    """A request sent to a server in another process got no response: the server went away
    (killed, crashed, shut down) or the query timed out. rclpy's future would stay pending
    forever; here it fails so nothing hangs."""


class _Queued:
    """Work queued for an executor: ``_enqueue`` schedules, the executor ``_take``s (shared by
    Service requests and Client responses)."""

    def _init_endpoint(self, node, srv_type, srv_name, qos_profile, callback_group) -> None:
        self._node = node
        self.srv_type = srv_type
        self.srv_name = srv_name
        self.qos_profile = qos_profile
        self.callback_group = callback_group
        self._queue = deque()
        self._scheduled = False
        self._executor = None
        self._destroyed = False

    def _enqueue(self, item) -> None:
        self._queue.append(item)
        if not self._scheduled:
            ex = self._executor
            if ex is not None:
                ex._schedule(self)

    def _take_check(self):
        return bool(self._queue)

    def _take(self):
        return self._queue.popleft() if self._queue else None


class Service(_Queued):
    def __init__(self, node, srv_type, srv_name, callback, qos_profile, callback_group):
        if not (isinstance(srv_type, type) and hasattr(srv_type, "Request") and hasattr(srv_type, "Response")):
            raise TypeError(f"create_service needs a service type (e.g. std_srvs.Trigger), got {srv_type!r}")
        if not callable(callback):
            raise TypeError(f"service callback must be callable, got {callback!r}")
        self._init_endpoint(node, srv_type, srv_name, qos_profile, callback_group)
        self.callback = callback
        self.request_count = 0
        self.error_count = 0
        self._raw = False
        self._builtin = False

    @property
    def service_name(self) -> str:
        return self.srv_name

    def _receive(self, request, client, future):
        self._enqueue((request, client, future))

    def _execute(self, work):
        request, client, future = work
        self.request_count += 1
        if self._raw:
            # internal deferred-response mode (action servers answer get_result later)
            self.callback(request, lambda resp, err=None: client._respond(
                future, None if resp is None else resp._copy(), err))
            return
        try:
            response = self.callback(request, self.srv_type.Response())
            if type(response) is not self.srv_type.Response:
                raise TypeError(
                    f"service callback returned {response!r:.80}; it must return the response "
                    f"object ({self.srv_type._type} Response), e.g. 'return response'")
        except Exception as exc:  # noqa: BLE001 - reported to the client, server survives
            self.error_count += 1
            self._node.get_logger().error(
                f"Exception in service callback of '{self.srv_name}' (node "
                f"'{self._node.get_fully_qualified_name()}'): {type(exc).__name__}: {exc}")
            err = ServiceCallbackError(
                f"service '{self.srv_name}' failed while handling the request: "
                f"{type(exc).__name__}: {exc}")
            err.__cause__ = exc
            client._respond(future, None, err)
            raise       # as rclpy, the exception also leaves the server's spin
        client._respond(future, response._copy(), None)   # the client's own value

    def _describe(self):
        return f"service callback of '{self.srv_name}' in node '{self._node.get_fully_qualified_name()}'"

    def destroy(self):
        self._node.destroy_service(self)

    def __repr__(self):
        return f"<Service {self.srv_name} [{self.srv_type._type}]>"


class Client(_Queued):
    def __init__(self, node, srv_type, srv_name, qos_profile, callback_group):
        if not (isinstance(srv_type, type) and hasattr(srv_type, "Request")):
            raise TypeError(f"create_client needs a service type (e.g. std_srvs.Trigger), got {srv_type!r}")
        self._init_endpoint(node, srv_type, srv_name, qos_profile, callback_group)
        self._pending = set()

    @property
    def service_name(self) -> str:
        return self.srv_name

    def service_is_ready(self) -> bool:
        ctx = self._node.context
        return ctx._server_for(self.srv_name) is not None or (
            ctx.transport is not None and ctx.transport.has_server(self.srv_name, self.srv_type))

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        """True once a server exists. In-process discovery is instant, so this only waits if
        another thread may create the server; in simulated time it never blocks."""
        import time

        if self.service_is_ready():
            return True
        if timeout_sec is not None and timeout_sec <= 0:
            return False
        if self._node.context.sim is not None:
            return False
        end = None if timeout_sec is None else time.monotonic() + timeout_sec
        while end is None or time.monotonic() < end:
            time.sleep(0.001)
            if self.service_is_ready():
                return True
        return False

    def call_async(self, request) -> Future:
        if self._destroyed:
            raise InvalidHandle(f"client of {self.srv_name!r} was destroyed")
        if type(request) is not self.srv_type.Request:
            raise TypeError(f"client of {self.srv_name!r} sends {self.srv_type._type} requests, got "
                            f"{type(request).__name__}; use {self.srv_type.__name__}.Request(...)")
        future = Future(executor=self._executor)
        ctx = self._node.context
        server = ctx._server_for(self.srv_name)
        if server is None and ctx.transport is not None and \
                ctx.transport.has_server(self.srv_name, self.srv_type):
            self._pending.add(future)
            ctx.transport.call(self, request, future)     # another process answers
            return future
        if server is None:
            self._node.get_logger().warning(
                f"request to service '{self.srv_name}' sent while no server exists: it will not "
                f"be answered (ROS drops it too). Call client.wait_for_service() first.")
            return future
        self._pending.add(future)
        server._receive(request._copy(), self, future)   # the value at call time
        return future

    def call(self, request, timeout_sec: float | None = None):
        """Synchronous call: blocks until the response arrives (raises on server error)."""
        self._check_deadlock()
        future = self.call_async(request)
        event = threading.Event()

        def done(_f):
            event.set()

        done._immediate = True
        future.add_done_callback(done)
        if not event.wait(timeout_sec):
            self.remove_pending_request(future)
            return None
        return future.result()

    def _check_deadlock(self):
        cur = current_callback()
        ex = self._executor
        if cur is not None:
            cur_ex, ent = cur
            if cur_ex is ex and ex is not None:
                if ex.num_threads == 1:
                    raise DeadlockError(
                        f"Client.call() on '{self.srv_name}' from inside {ent._describe()} on a "
                        f"single-threaded executor would deadlock: the response can only be "
                        f"processed by this same executor, which is blocked in your callback "
                        f"(in ROS 2 this hangs forever without an error). Fix: use "
                        f"'future = client.call_async(req)' and handle the result in "
                        f"future.add_done_callback(...) or make the callback 'async' and "
                        f"'await client.call_async(req)'; or use a MultiThreadedExecutor and put "
                        f"the client in another callback group (e.g. ReentrantCallbackGroup).")
                g = self.callback_group
                if isinstance(g, MutuallyExclusiveCallbackGroup) and g is getattr(ent, "callback_group", None):
                    raise DeadlockError(
                        f"Client.call() on '{self.srv_name}' from inside {ent._describe()} would "
                        f"deadlock: the client is in the same MutuallyExclusiveCallbackGroup as "
                        f"the running callback, so its response can never be processed. Fix: "
                        f"create the client with callback_group=ReentrantCallbackGroup() (or "
                        f"another group), or use call_async.")
            return
        if ex is None or not ex.is_spinning_elsewhere():
            raise DeadlockError(
                f"Client.call() on '{self.srv_name}' would block forever: no executor is spinning "
                f"node '{self._node.get_fully_qualified_name()}' on another thread, so the "
                f"response would never be processed. Fix: 'future = client.call_async(req)' then "
                f"'executor.spin_until_future_complete(future)', or spin the node in a "
                f"background thread before calling call().")

    def _respond(self, future, response, error):
        self._enqueue((future, response, error))

    def _execute(self, work):
        future, response, error = work
        if future not in self._pending:
            return   # removed by remove_pending_request (e.g. timed out)
        self._pending.discard(future)
        if future._executor is None:
            future._set_executor(self._executor)
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(response)

    def remove_pending_request(self, future) -> None:
        self._pending.discard(future)

    def _describe(self):
        return f"client response of '{self.srv_name}' in node '{self._node.get_fully_qualified_name()}'"

    def destroy(self):
        self._node.destroy_client(self)

    def __repr__(self):
        return f"<Client {self.srv_name} [{self.srv_type._type}]>"
