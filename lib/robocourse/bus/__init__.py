"""robocourse.bus: an in-process ROS 2 graph with rclpy's names and semantics.

Quick start (a notebook cell)::

    from robocourse.bus import Context, SingleThreadedExecutor, QoSProfile
    from robocourse.msgs.std_msgs import Float64

    ctx = Context(use_sim_time=True)               # deterministic simulated time
    talker, listener = ctx.create_node("talker"), ctx.create_node("listener")
    pub = talker.create_publisher(Float64, "x", 10)
    talker.create_timer(0.01, lambda: pub.publish(Float64(data=talker.get_clock().now().nanoseconds * 1e-9)))
    got = []
    listener.create_subscription(Float64, "x", got.append, 10)
    ex = SingleThreadedExecutor(context=ctx); ex.add_node(talker); ex.add_node(listener)
    ex.spin_for(10.0)                               # 10 s of sim time, in a fraction of a second

Modules (one idea each): ``names``, ``qos``, ``clock``, ``node``, ``publisher``,
``subscription``, ``timer``, ``service``, ``action``, ``executors``, ``callback_groups``,
``parameters``, ``context``, ``introspection`` (the ros2 CLI as calls), ``graph_view`` (the
rqt_graph-like picture), ``recording`` (MCAP), ``deadline`` (the deadline QoS from the last
sample per pair), ``transport`` (``ctx.set_link``: seeded loss and delay, what RELIABLE buys).

Messages are values, as in ROS 2: each subscription gets its own copy of the message as it was
at ``publish`` (the same for services, actions, recording and replay). rclpy-style globals: ``init``, ``shutdown``,
``ok``, ``spin``, ``spin_once``, ``spin_until_future_complete``, ``create_node``.
"""

from robocourse.bus.callback_groups import (
    CallbackGroup,
    MutuallyExclusiveCallbackGroup,
    ReentrantCallbackGroup,
)
from robocourse.bus.clock import Clock, ClockType, Duration, ROSClock, SimTime, Time
from robocourse.bus.context import Context, get_default_context, init, ok, shutdown
from robocourse.bus.executors import (
    CallbackError,
    Executor,
    MultiThreadedExecutor,
    SingleThreadedExecutor,
)
from robocourse.bus.names import InvalidNameError
from robocourse.bus.node import Node
from robocourse.bus.parameters import (
    FloatingPointRange,
    IntegerRange,
    InvalidParameterTypeException,
    InvalidParameterValueException,
    Parameter,
    ParameterAlreadyDeclaredException,
    ParameterDescriptor,
    ParameterImmutableException,
    ParameterNotDeclaredException,
    SetParametersResult,
)
from robocourse.bus.publisher import InvalidHandle, Publisher
from robocourse.bus.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    InvalidQoSProfileException,
    LivelinessPolicy,
    PublisherEventCallbacks,
    QoSCompatibility,
    QoSPolicyKind,
    QoSPresetProfiles,
    QoSProfile,
    ReliabilityPolicy,
    SubscriptionEventCallbacks,
    qos_check_compatible,
    qos_profile_action_status_default,
    qos_profile_sensor_data,
    qos_profile_services_default,
    qos_profile_system_default,
)
from robocourse.bus.service import (
    Client,
    DeadlockError,
    ServerGoneError,
    Service,
    ServiceCallbackError,
)
from robocourse.bus.subscription import Subscription
from robocourse.bus.task import Future, Task
from robocourse.bus.timer import Rate, Timer


def create_node(node_name: str, *, context=None, **kwargs) -> Node:
    """rclpy.create_node."""
    return Node(node_name, context=context, **kwargs)


_global_executor = None


def get_global_executor(context=None) -> SingleThreadedExecutor:
    global _global_executor
    ctx = context or get_default_context()
    if _global_executor is None or _global_executor.context is not ctx:
        _global_executor = SingleThreadedExecutor(context=ctx)
    return _global_executor


def spin(node: Node, executor=None) -> None:
    """rclpy.spin(node)."""
    ex = executor or get_global_executor(node.context)
    ex.add_node(node)
    try:
        ex.spin()
    finally:
        ex.remove_node(node)


def spin_once(node: Node, *, executor=None, timeout_sec=None) -> None:
    """rclpy.spin_once(node, timeout_sec=...)."""
    ex = executor or get_global_executor(node.context)
    ex.add_node(node)
    try:
        ex.spin_once(timeout_sec)
    finally:
        ex.remove_node(node)


def spin_until_future_complete(node: Node, future, executor=None, timeout_sec=None) -> None:
    """rclpy.spin_until_future_complete(node, future, timeout_sec=...)."""
    ex = executor or get_global_executor(node.context)
    ex.add_node(node)
    try:
        ex.spin_until_future_complete(future, timeout_sec)
    finally:
        ex.remove_node(node)


__all__ = [
    "CallbackError", "CallbackGroup", "Client", "Clock", "ClockType", "Context", "DeadlockError",
    "DurabilityPolicy", "Duration", "Executor",
    "FloatingPointRange", "Future", "HistoryPolicy", "IntegerRange", "InvalidHandle",
    "InvalidNameError", "InvalidParameterTypeException", "InvalidParameterValueException",
    "InvalidQoSProfileException", "LivelinessPolicy", "MultiThreadedExecutor",
    "MutuallyExclusiveCallbackGroup", "Node", "Parameter", "ParameterAlreadyDeclaredException",
    "ParameterDescriptor", "ParameterImmutableException", "ParameterNotDeclaredException",
    "Publisher", "PublisherEventCallbacks", "QoSCompatibility", "QoSPolicyKind",
    "QoSPresetProfiles", "QoSProfile", "ROSClock", "Rate", "ReentrantCallbackGroup",
    "ReliabilityPolicy", "ServerGoneError", "Service", "ServiceCallbackError", "SetParametersResult", "SimTime",
    "SingleThreadedExecutor", "Subscription", "SubscriptionEventCallbacks", "Task", "Time",
    "Timer", "create_node", "get_default_context", "get_global_executor", "init", "ok",
    "qos_check_compatible", "qos_profile_action_status_default", "qos_profile_sensor_data",
    "qos_profile_services_default", "qos_profile_system_default", "shutdown", "spin",
    "spin_once", "spin_until_future_complete",
]
