"""Actions: long-running goals with feedback, a result, cancellation and a status topic.

rclpy counterparts: ``rclpy.action.ActionServer`` / ``ActionClient``, ``GoalResponse``,
``CancelResponse``, ``ServerGoalHandle``, ``ClientGoalHandle``. Like ROS 2 an action is built
from three services (``<name>/_action/send_goal``, ``cancel_goal``, ``get_result``) and two
topics (``<name>/_action/feedback``, ``<name>/_action/status`` with KEEP_LAST 1, RELIABLE,
TRANSIENT_LOCAL), so introspection shows them.

Defaults as in rclpy: every goal is accepted, ``handle_accepted_callback`` calls
``goal_handle.execute()``, every cancel request is REJECTED. A goal callback that returns
anything but a ``GoalResponse`` rejects the goal with a warning (the client just sees it
rejected); a cancel callback that returns anything but ``CancelResponse.ACCEPT`` rejects the
cancel. A deferred goal (its ``handle_accepted_callback`` keeps the handle) whose cancel is
accepted before ``execute()`` still executes: it stays CANCELING and its execute callback
ends it (``canceled()``), as rclpy. The goal state machine allows only
ACCEPTED -execute-> EXECUTING; ACCEPTED/EXECUTING -cancel-> CANCELING; EXECUTING/CANCELING
-succeed-> SUCCEEDED, -abort-> ABORTED; CANCELING -canceled-> CANCELED. Anything else raises
:class:`InvalidGoalTransition`. An execute callback that returns while the goal is still active
aborts it ("Goal state not set, assuming aborted"); one that raises aborts it too. Results are
kept ``result_timeout`` seconds (node clock) after the goal finishes, then forgotten.

Execute callbacks may be plain functions (they block the executor thread while running, as in
rclpy) or ``async def`` coroutines that ``await node.sleep_async(dt)`` between steps, which
keeps a single-threaded executor (and simulated time) responsive.
"""

from __future__ import annotations

import inspect
import random
from enum import IntEnum

from robocourse.bus.clock import Time
from robocourse.bus.publisher import InvalidHandle
from robocourse.bus.qos import qos_profile_action_status_default, qos_profile_services_default
from robocourse.bus.task import Future
from robocourse.msgs.action_msgs import CancelGoal, GoalInfo, GoalStatus, GoalStatusArray
from robocourse.msgs.unique_identifier_msgs import UUID


class GoalResponse(IntEnum):
    REJECT = 1
    ACCEPT = 2


class CancelResponse(IntEnum):
    REJECT = 1
    ACCEPT = 2


class GoalEvent(IntEnum):
    EXECUTE = 0
    CANCEL_GOAL = 1
    SUCCEED = 2
    ABORT = 3
    CANCELED = 4


STATUS_NAMES = {GoalStatus.STATUS_UNKNOWN: "UNKNOWN", GoalStatus.STATUS_ACCEPTED: "ACCEPTED",
                GoalStatus.STATUS_EXECUTING: "EXECUTING", GoalStatus.STATUS_CANCELING: "CANCELING",
                GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED", GoalStatus.STATUS_CANCELED: "CANCELED",
                GoalStatus.STATUS_ABORTED: "ABORTED"}

TRANSITIONS = {
    (GoalStatus.STATUS_ACCEPTED, GoalEvent.EXECUTE): GoalStatus.STATUS_EXECUTING,
    (GoalStatus.STATUS_ACCEPTED, GoalEvent.CANCEL_GOAL): GoalStatus.STATUS_CANCELING,
    (GoalStatus.STATUS_EXECUTING, GoalEvent.CANCEL_GOAL): GoalStatus.STATUS_CANCELING,
    (GoalStatus.STATUS_EXECUTING, GoalEvent.SUCCEED): GoalStatus.STATUS_SUCCEEDED,
    (GoalStatus.STATUS_EXECUTING, GoalEvent.ABORT): GoalStatus.STATUS_ABORTED,
    (GoalStatus.STATUS_CANCELING, GoalEvent.SUCCEED): GoalStatus.STATUS_SUCCEEDED,
    (GoalStatus.STATUS_CANCELING, GoalEvent.ABORT): GoalStatus.STATUS_ABORTED,
    (GoalStatus.STATUS_CANCELING, GoalEvent.CANCELED): GoalStatus.STATUS_CANCELED,
}
TERMINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)


class InvalidGoalTransition(RuntimeError):
    """A goal handle asked for a transition the action state machine does not allow."""


def goal_transition(state: int, event: GoalEvent) -> int:
    """Next state for ``event`` from ``state``; raises InvalidGoalTransition if not allowed."""
    try:
        return TRANSITIONS[(state, event)]
    except KeyError:
        allowed = [e.name for (s, e) in TRANSITIONS if s == state]
        raise InvalidGoalTransition(
            f"goal_handle attempted invalid transition from state {STATUS_NAMES.get(state, state)} "
            f"with event {GoalEvent(event).name}; allowed events from this state: "
            f"{allowed or 'none (terminal state)'}") from None


def _uuid_key(uuid_msg) -> bytes:
    return bytes(uuid_msg.uuid)


def default_goal_callback(goal_request):
    return GoalResponse.ACCEPT


def default_handle_accepted_callback(goal_handle):
    goal_handle.execute()


def default_cancel_callback(cancel_request):
    return CancelResponse.REJECT


class ServerGoalHandle:
    """rclpy.action.server.ServerGoalHandle."""

    def __init__(self, server, goal_id, request, stamp):
        self._server = server
        self._goal_id = goal_id
        self._request = request
        self._stamp = stamp
        self._status = GoalStatus.STATUS_ACCEPTED
        self._result = None

    @property
    def request(self):
        return self._request

    @property
    def goal_id(self):
        return self._goal_id

    @property
    def status(self) -> int:
        return self._status

    @property
    def is_active(self) -> bool:
        return self._status in (GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING,
                                GoalStatus.STATUS_CANCELING)

    @property
    def is_cancel_requested(self) -> bool:
        return self._status == GoalStatus.STATUS_CANCELING

    def _update_state(self, event: GoalEvent) -> None:
        self._status = goal_transition(self._status, event)
        self._server._on_state_change(self)

    def execute(self, execute_callback=None) -> None:
        """Run the execute callback. As rclpy: a goal whose cancel was accepted before
        ``execute()`` stays CANCELING (no EXECUTE transition) and the callback still runs, so
        it can see ``is_cancel_requested`` and call ``canceled()``."""
        if not self.is_cancel_requested:
            self._update_state(GoalEvent.EXECUTE)
        self._server._start_execute(self, execute_callback or self._server._execute_callback)

    def publish_feedback(self, feedback) -> None:
        srv = self._server
        if type(feedback) is not srv._action_type.Feedback:
            raise TypeError(f"publish_feedback needs a {srv._action_type.Feedback._type}, got "
                            f"{type(feedback).__name__}")
        if not self.is_active:
            raise InvalidGoalTransition("cannot publish feedback for a goal that is not active")
        srv._feedback_pub.publish(srv._action_type.Impl.FeedbackMessage(
            goal_id=self._goal_id, feedback=feedback))

    def succeed(self) -> None:
        self._update_state(GoalEvent.SUCCEED)

    def abort(self) -> None:
        self._update_state(GoalEvent.ABORT)

    def canceled(self) -> None:
        self._update_state(GoalEvent.CANCELED)

    def destroy(self) -> None:
        pass

    def __repr__(self):
        return f"<ServerGoalHandle {_uuid_key(self._goal_id).hex()} {STATUS_NAMES[self._status]}>"


class ActionServer:
    """rclpy.action.ActionServer(node, action_type, action_name, execute_callback, ...)."""

    def __init__(self, node, action_type, action_name, execute_callback, *, callback_group=None,
                 goal_callback=default_goal_callback,
                 handle_accepted_callback=default_handle_accepted_callback,
                 cancel_callback=default_cancel_callback,
                 goal_service_qos_profile=qos_profile_services_default,
                 result_service_qos_profile=qos_profile_services_default,
                 cancel_service_qos_profile=qos_profile_services_default,
                 feedback_pub_qos_profile=10,
                 status_pub_qos_profile=qos_profile_action_status_default,
                 result_timeout: float = 10):
        if not (isinstance(action_type, type) and hasattr(action_type, "Goal") and hasattr(action_type, "Impl")):
            raise TypeError(f"ActionServer needs an action type (e.g. Fibonacci), got {action_type!r}")
        self._node = node
        self._action_type = action_type
        self._action_name = node.resolve_service_name(action_name)
        self._execute_callback = execute_callback
        self._goal_callback = goal_callback
        self._handle_accepted_callback = handle_accepted_callback
        self._cancel_callback = cancel_callback
        self.result_timeout = float(result_timeout)
        self.callback_group = callback_group or node.default_callback_group
        self._goals: dict[bytes, ServerGoalHandle] = {}
        self._results: dict[bytes, object] = {}      # goal key -> GetResult.Response
        self._waiting: dict[bytes, list] = {}        # goal key -> respond functions
        self._expiry_timers = {}
        impl = action_type.Impl
        base = self._action_name + "/_action/"
        g = self.callback_group
        self._goal_srv = node.create_service(impl.SendGoalService, base + "send_goal",
                                             self._handle_goal, callback_group=g)
        self._cancel_srv = node.create_service(CancelGoal, base + "cancel_goal",
                                               self._handle_cancel, callback_group=g)
        self._result_srv = node.create_service(impl.GetResultService, base + "get_result",
                                               self._handle_get_result, callback_group=g)
        self._result_srv._raw = True
        self._feedback_pub = node.create_publisher(impl.FeedbackMessage, base + "feedback",
                                                   feedback_pub_qos_profile)
        self._status_pub = node.create_publisher(GoalStatusArray, base + "status",
                                                 status_pub_qos_profile)
        self._destroyed = False
        node.waitables.append(self)

    @property
    def action_name(self) -> str:
        return self._action_name

    @property
    def action_type(self):
        return self._action_type

    # -- services ------------------------------------------------------------------------
    def _handle_goal(self, request, response):
        key = _uuid_key(request.goal_id)
        if key in self._goals:
            self._node.get_logger().error(f"Received goal request with an existing goal id {key.hex()}; rejected")
            response.accepted = False
            return response
        decision = self._goal_callback(request.goal)
        if not isinstance(decision, GoalResponse):
            # rclpy: anything but a GoalResponse rejects the goal (a warning, no error)
            self._node.get_logger().warning(
                f"Goal request callback did not return a GoalResponse type. Rejecting goal. "
                f"(action '{self._action_name}': it returned {decision!r:.60}; return "
                f"GoalResponse.ACCEPT or GoalResponse.REJECT)")
            response.accepted = False
            return response
        if decision != GoalResponse.ACCEPT:
            response.accepted = False
            return response
        stamp = self._node.get_clock().now()
        handle = ServerGoalHandle(self, request.goal_id, request.goal, stamp)
        self._goals[key] = handle
        response.accepted = True
        response.stamp = stamp.to_msg()
        self._publish_status()
        # rclpy calls handle_accepted after the response is sent: run it as the next task
        self._node.create_task(self._handle_accepted_callback, handle)
        return response

    def _handle_cancel(self, request, response):
        gid = _uuid_key(request.goal_info.goal_id)
        zero_id = not any(gid)
        stamp_ns = request.goal_info.stamp.sec * 1_000_000_000 + request.goal_info.stamp.nanosec
        candidates = []
        if not zero_id:
            h = self._goals.get(gid)
            if h is None:
                response.return_code = CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID
                return response
            candidates.append(h)
        for h in self._goals.values():
            if h in candidates:
                continue
            if zero_id and stamp_ns == 0:
                candidates.append(h)
            elif stamp_ns and h._stamp.nanoseconds <= stamp_ns:
                candidates.append(h)
        active = [h for h in candidates if h.is_active]
        if candidates and not active:
            response.return_code = CancelGoal.Response.ERROR_GOAL_TERMINATED
            return response
        for h in active:
            if h.status == GoalStatus.STATUS_CANCELING:
                response.goals_canceling.append(GoalInfo(goal_id=h.goal_id, stamp=h._stamp.to_msg()))
                continue
            decision = self._cancel_callback(h)
            # rclpy: only CancelResponse.ACCEPT accepts; anything else is a rejection
            if isinstance(decision, CancelResponse) and decision == CancelResponse.ACCEPT:
                h._update_state(GoalEvent.CANCEL_GOAL)
                response.goals_canceling.append(GoalInfo(goal_id=h.goal_id, stamp=h._stamp.to_msg()))
        response.return_code = (CancelGoal.Response.ERROR_NONE if response.goals_canceling
                                else CancelGoal.Response.ERROR_REJECTED)
        return response

    def _handle_get_result(self, request, respond):
        key = _uuid_key(request.goal_id)
        Resp = self._action_type.Impl.GetResultService.Response
        if key in self._results:
            respond(self._results[key])
        elif key in self._goals:
            self._waiting.setdefault(key, []).append(respond)
        else:
            respond(Resp(status=GoalStatus.STATUS_UNKNOWN, result=self._action_type.Result()))

    # -- execution -----------------------------------------------------------------------
    def _start_execute(self, handle, execute_callback):
        self._node.create_task(self._execute_goal, execute_callback, handle)

    async def _execute_goal(self, execute_callback, handle):
        result = None
        try:
            out = execute_callback(handle)
            if inspect.isawaitable(out):
                out = await out
            result = out
        except Exception as exc:  # noqa: BLE001 - the goal aborts, the server survives
            self._node.get_logger().error(
                f"Error raised in execute callback of action '{self._action_name}': "
                f"{type(exc).__name__}: {exc}")
            if handle.is_active:
                if handle.status == GoalStatus.STATUS_ACCEPTED:
                    handle._status = GoalStatus.STATUS_EXECUTING
                handle._update_state(GoalEvent.ABORT)
            result = None
        if handle.is_active:
            self._node.get_logger().warning(
                f"Goal state not set, assuming aborted. Goal ID: {_uuid_key(handle.goal_id).hex()}")
            handle._update_state(GoalEvent.ABORT)
        if result is None or type(result) is not self._action_type.Result:
            if result is not None:
                self._node.get_logger().error(
                    f"execute callback of '{self._action_name}' returned {type(result).__name__}, "
                    f"not {self._action_type.Result._type}; sending an empty result")
            result = self._action_type.Result()
        self._finish(handle, result)

    def _finish(self, handle, result):
        key = _uuid_key(handle.goal_id)
        resp = self._action_type.Impl.GetResultService.Response(status=handle.status, result=result)
        self._results[key] = resp
        for respond in self._waiting.pop(key, []):
            respond(resp)
        timer = self._node.create_timer(self.result_timeout, lambda k=key: self._expire(k))
        self._expiry_timers[key] = timer

    def _expire(self, key):
        t = self._expiry_timers.pop(key, None)
        if t is not None:
            self._node.destroy_timer(t)
        self._results.pop(key, None)
        self._goals.pop(key, None)
        self._publish_status()

    def _on_state_change(self, handle):
        self._publish_status()

    def _publish_status(self):
        if self._destroyed:
            return
        arr = GoalStatusArray(status_list=[
            GoalStatus(goal_info=GoalInfo(goal_id=h.goal_id, stamp=h._stamp.to_msg()), status=h.status)
            for h in self._goals.values()])
        self._status_pub.publish(arr)

    def destroy(self):
        if self._destroyed:
            return
        self._destroyed = True
        n = self._node
        for s in (self._goal_srv, self._cancel_srv, self._result_srv):
            n.destroy_service(s)
        n.destroy_publisher(self._feedback_pub)
        n.destroy_publisher(self._status_pub)
        for t in self._expiry_timers.values():
            n.destroy_timer(t)
        if self in n.waitables:
            n.waitables.remove(self)


class ClientGoalHandle:
    """rclpy.action.client.ClientGoalHandle."""

    def __init__(self, action_client, goal_id, goal_response):
        self._client = action_client
        self._goal_id = goal_id
        self._accepted = bool(goal_response.accepted)
        self._stamp = goal_response.stamp
        self._status = GoalStatus.STATUS_ACCEPTED if self._accepted else GoalStatus.STATUS_UNKNOWN

    @property
    def goal_id(self):
        return self._goal_id

    @property
    def stamp(self):
        return self._stamp

    @property
    def accepted(self) -> bool:
        return self._accepted

    @property
    def status(self) -> int:
        return self._status

    def cancel_goal_async(self) -> Future:
        return self._client._cancel_goal_async(self)

    def get_result_async(self) -> Future:
        return self._client._get_result_async(self)

    def cancel_goal(self):
        return self._client._cancel_goal_client.call(self._cancel_request())

    def get_result(self):
        return self._client._result_client.call(
            self._client._action_type.Impl.GetResultService.Request(goal_id=self._goal_id))

    def _cancel_request(self):
        return CancelGoal.Request(goal_info=GoalInfo(goal_id=self._goal_id))

    def __repr__(self):
        return (f"<ClientGoalHandle {_uuid_key(self._goal_id).hex()} accepted={self._accepted} "
                f"status={STATUS_NAMES.get(self._status, self._status)}>")


class ActionClient:
    """rclpy.action.ActionClient(node, action_type, action_name, ...).

    Goal ids are random UUIDs drawn from a generator seeded by the node and action names, so
    a simulated run is reproducible (rclpy uses uuid4).
    """

    def __init__(self, node, action_type, action_name, *, callback_group=None,
                 goal_service_qos_profile=qos_profile_services_default,
                 result_service_qos_profile=qos_profile_services_default,
                 cancel_service_qos_profile=qos_profile_services_default,
                 feedback_sub_qos_profile=10,
                 status_sub_qos_profile=qos_profile_action_status_default):
        if not (isinstance(action_type, type) and hasattr(action_type, "Goal") and hasattr(action_type, "Impl")):
            raise TypeError(f"ActionClient needs an action type (e.g. Fibonacci), got {action_type!r}")
        self._node = node
        self._action_type = action_type
        self._action_name = node.resolve_service_name(action_name)
        self.callback_group = callback_group or node.default_callback_group
        impl = action_type.Impl
        base = self._action_name + "/_action/"
        g = self.callback_group
        self._goal_client = node.create_client(impl.SendGoalService, base + "send_goal", callback_group=g)
        self._cancel_goal_client = node.create_client(CancelGoal, base + "cancel_goal", callback_group=g)
        self._result_client = node.create_client(impl.GetResultService, base + "get_result", callback_group=g)
        self._feedback_sub = node.create_subscription(impl.FeedbackMessage, base + "feedback",
                                                      self._on_feedback, feedback_sub_qos_profile,
                                                      callback_group=g)
        self._status_sub = node.create_subscription(GoalStatusArray, base + "status",
                                                    self._on_status, status_sub_qos_profile,
                                                    callback_group=g)
        self._feedback_callbacks: dict[bytes, object] = {}
        self._handles: dict[bytes, ClientGoalHandle] = {}
        self._rng = random.Random(f"{node.get_fully_qualified_name()}|{self._action_name}")
        self._destroyed = False
        node.waitables.append(self)

    @property
    def action_name(self) -> str:
        return self._action_name

    def server_is_ready(self) -> bool:
        return (self._goal_client.service_is_ready() and self._cancel_goal_client.service_is_ready()
                and self._result_client.service_is_ready())

    def wait_for_server(self, timeout_sec: float | None = None) -> bool:
        return self._goal_client.wait_for_service(timeout_sec) and self.server_is_ready()

    def _new_uuid(self) -> UUID:
        return UUID(uuid=[self._rng.randrange(256) for _ in range(16)])

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None) -> Future:
        """Send a goal; the future's result is a ClientGoalHandle (check ``.accepted``)."""
        if self._destroyed:
            raise InvalidHandle(f"action client {self._action_name!r} was destroyed")
        if type(goal) is not self._action_type.Goal:
            raise TypeError(f"action {self._action_name!r} takes {self._action_type.Goal._type} goals, "
                            f"got {type(goal).__name__}; use {self._action_type.__name__}.Goal(...)")
        goal_id = goal_uuid or self._new_uuid()
        key = _uuid_key(goal_id)
        if feedback_callback is not None:
            self._feedback_callbacks[key] = feedback_callback
        req = self._action_type.Impl.SendGoalService.Request(goal_id=goal_id, goal=goal)
        inner = self._goal_client.call_async(req)
        outer = Future(executor=self._node.executor)

        def on_response(f, key=key, goal_id=goal_id):
            if f.exception() is not None:
                outer.set_exception(f.exception())
                return
            handle = ClientGoalHandle(self, goal_id, f.result())
            if handle.accepted:
                self._handles[key] = handle
            else:
                self._feedback_callbacks.pop(key, None)
            outer.set_result(handle)

        on_response._immediate = True
        inner.add_done_callback(on_response)
        return outer

    def send_goal(self, goal, feedback_callback=None, goal_uuid=None):
        """Synchronous: send, wait for acceptance and for the result (GetResult response).
        Raises what the goal or result request failed with (e.g. ServerGoneError when the
        server's process dies mid-goal) instead of blocking forever."""
        self._goal_client._check_deadlock()
        import threading

        ev = threading.Event()
        fut = self.send_goal_async(goal, feedback_callback, goal_uuid)
        box = {}

        def got_handle(f):
            if f.exception() is not None:
                box["e"] = f.exception()
                ev.set()
                return
            h = f.result()
            if not h.accepted:
                box["r"] = None
                ev.set()
                return
            r = h.get_result_async()

            def got_result(rf):
                if rf.exception() is not None:
                    box["e"] = rf.exception()
                else:
                    box["r"] = rf.result()
                ev.set()

            got_result._immediate = True
            r.add_done_callback(got_result)

        got_handle._immediate = True
        fut.add_done_callback(got_handle)
        ev.wait()
        if "e" in box:
            raise box["e"]
        return box["r"]

    def _get_result_async(self, handle) -> Future:
        req = self._action_type.Impl.GetResultService.Request(goal_id=handle.goal_id)
        fut = self._result_client.call_async(req)

        def done(f, handle=handle):
            if f.exception() is None:
                handle._status = f.result().status
                self._feedback_callbacks.pop(_uuid_key(handle.goal_id), None)

        done._immediate = True
        fut.add_done_callback(done)
        return fut

    def _cancel_goal_async(self, handle) -> Future:
        return self._cancel_goal_client.call_async(handle._cancel_request())

    def _on_feedback(self, msg):
        cb = self._feedback_callbacks.get(_uuid_key(msg.goal_id))
        if cb is not None:
            cb(msg)

    def _on_status(self, msg):
        for st in msg.status_list:
            h = self._handles.get(_uuid_key(st.goal_info.goal_id))
            if h is not None:
                h._status = st.status

    def destroy(self):
        if self._destroyed:
            return
        self._destroyed = True
        n = self._node
        for c in (self._goal_client, self._cancel_goal_client, self._result_client):
            n.destroy_client(c)
        n.destroy_subscription(self._feedback_sub)
        n.destroy_subscription(self._status_sub)
        if self in n.waitables:
            n.waitables.remove(self)


def stamp_to_time(stamp) -> Time:
    return Time.from_msg(stamp)


__all__ = ["ActionServer", "ActionClient", "GoalResponse", "CancelResponse", "ServerGoalHandle",
           "ClientGoalHandle", "GoalEvent", "InvalidGoalTransition", "goal_transition",
           "TRANSITIONS", "STATUS_NAMES"]
