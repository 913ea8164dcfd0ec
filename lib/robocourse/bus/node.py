"""Node: the unit that owns publishers, subscriptions, timers, services, clients, parameters.

rclpy counterpart: ``rclpy.node.Node(node_name, *, context, cli_args, namespace,
parameter_overrides, allow_undeclared_parameters, automatically_declare_parameters_from_overrides)``
(``cli_args``: ``--ros-args`` remaps, ``__node``/``__ns``, ``-p`` and ``--params-file``, see
:mod:`robocourse.bus.arguments`) with the same
``create_*``/``destroy_*``, graph queries and parameter methods. Additions: ``create_task``,
``sleep_async(seconds)`` (an awaitable sleep on the node's clock, handy in coroutine callbacks
under simulated time) and ``context`` defaulting to the one from :func:`robocourse.bus.init`.

What every node brings, as an rclpy node on Jazzy does (so ``ros2 param``, ``ros2 node info``
and rqt_console on a real ROS 2 machine see it over the zenoh transport):

- a ``/rosout`` publisher (``rcl_interfaces/msg/Log``, rcl's ``rcl_qos_profile_rosout_default``:
  KEEP_LAST 1000, RELIABLE, TRANSIENT_LOCAL, lifespan 10 s) carrying every line the node's
  logger emits (``enable_rosout=False`` turns it off);
- a ``/parameter_events`` publisher (``rcl_interfaces/msg/ParameterEvent``) announcing every
  declaration and successful set;
- the six parameter services (:mod:`robocourse.bus.parameter_service`;
  ``start_parameter_services=False`` turns them off) and ``~/get_type_description``
  (:mod:`robocourse.bus.type_description_service`; the read-only parameter
  ``start_type_description_service`` turns it off).

As in rclpy, ``node.publishers`` lists the /parameter_events publisher but not the /rosout one
(rcl owns that; ``node_info`` shows both, as ``ros2 node info`` does), and ``node.services``
lists the built-in services. Differences: the Log message's stamp is the node's clock (rcl
stamps with system time); no ``/clock`` subscription is made (simulated time is the context's).

Accepted for signature compatibility and ignored (nothing here needs them):
``use_global_arguments``, ``qos_overriding_options``, ``publisher_class``.

Duplicate node names: like ROS 2 we allow them and log a warning (ROS warns about the rosout
logger publisher; ``ros2 node list`` warns about duplicates). Both nodes work; graph queries
list both.
"""

from __future__ import annotations

from robocourse.bus import _args
from robocourse.bus import arguments as _arguments
from robocourse.bus import names as _names
from robocourse.bus.callback_groups import MutuallyExclusiveCallbackGroup
from robocourse.bus.clock import ClockType, ROSClock
from robocourse.bus.context import get_default_context
from robocourse.bus.deadline import DeadlineWatch
from robocourse.bus.logging import RcutilsLogger
from robocourse.bus.parameter_service import ParameterService
from robocourse.bus.parameters import Parameter, ParameterDescriptor, ParameterMixin
from robocourse.bus.publisher import InvalidHandle, Publisher
from robocourse.bus.qos import (
    INFINITE,
    DurabilityPolicy,
    LivelinessPolicy,
    QoSLivelinessChangedInfo,
    QoSLivelinessLostInfo,
    QoSProfile,
    qos_from_arg,
    qos_profile_parameter_events,
    qos_profile_services_default,
)
from robocourse.bus.subscription import Subscription
from robocourse.bus.task import Future, Task
from robocourse.bus.timer import Rate, Timer
from robocourse.bus.type_description_service import TypeDescriptionService
from robocourse.msgs.rcl_interfaces import Log, ParameterEvent

#: rcl's ``rcl_qos_profile_rosout_default`` (rcl/logging_rosout.h)
ROSOUT_QOS = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL, lifespan=10.0)


class TopicEndpointInfo:
    """rclpy.topic_endpoint_info.TopicEndpointInfo."""

    def __init__(self, node_name, node_namespace, topic_type, endpoint_type, qos_profile, entity):
        self.node_name = node_name
        self.node_namespace = node_namespace
        self.topic_type = topic_type
        self.endpoint_type = endpoint_type
        self.qos_profile = qos_profile
        self._entity = entity

    def __repr__(self):
        return (f"TopicEndpointInfo(node_name={self.node_name!r}, node_namespace="
                f"{self.node_namespace!r}, topic_type={self.topic_type!r}, endpoint_type="
                f"{self.endpoint_type!r})")


class Node(ParameterMixin):
    def __init__(self, node_name: str, *, context=None, cli_args=None, namespace: str | None = None,
                 parameter_overrides=None, allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False,
                 start_parameter_services: bool = True, use_global_arguments: bool = True,
                 enable_rosout: bool = True):
        self._context = context if context is not None else get_default_context()
        if not self._context.ok():
            raise RuntimeError("cannot create a node on a context that was shut down")
        _names.validate_node_name(node_name)
        self._ros_args = _arguments.parse_ros_args(cli_args)
        self._name = _names.validate_node_name(self._ros_args.node_name(node_name) or node_name)
        self._namespace = _names.normalize_namespace(self._ros_args.namespace(node_name) or namespace)
        self._executor = None
        self._destroyed = False
        self.default_callback_group = MutuallyExclusiveCallbackGroup()
        self._clock = ROSClock(self._context.sim)
        self._logger = RcutilsLogger(self._name if self._namespace == "/" else
                                     f"{self._namespace[1:].replace('/', '.')}.{self._name}",
                                     self._context, self._clock)
        self.publishers = []
        self.subscriptions = []
        self.timers = []
        self.services = []
        self.clients = []
        self.waitables = []
        self.guards = []
        self._pending_tasks = []
        fq = self.get_fully_qualified_name()
        if any(n.get_fully_qualified_name() == fq for n in self._context.nodes):
            self._logger.warning(
                f"a node named '{fq}' already exists in this context. ROS 2 allows this but it "
                f"confuses tools (ros2 node list warns, logs and parameters get mixed up); "
                f"both nodes keep working here. Give each node a unique name or namespace.")
        self._context.nodes.append(self)
        self._parameter_event_publisher = None
        self._rosout_publisher = None
        self._parameter_service = None
        self._type_description_service = None
        with self._context._graph_batch():
            if enable_rosout:     # rcl makes it first, before the node's other entities
                self._rosout_publisher = self._create_rosout_publisher()
                self._logger._rosout = self._rosout_publisher
            self._parameter_event_publisher = self.create_publisher(
                ParameterEvent, "/parameter_events", qos_profile_parameter_events)
            from_args = _arguments.parameters_for(self._ros_args, fq)
            if from_args:   # files and -p first; parameter_overrides win (rclpy's order)
                given = {p.name for p in parameter_overrides or [] if isinstance(p, Parameter)}
                parameter_overrides = [Parameter(k, value=v) for k, v in from_args.items()
                                       if k not in given] + list(parameter_overrides or [])
            self._init_parameters(parameter_overrides, allow_undeclared_parameters,
                                  automatically_declare_parameters_from_overrides)
            self.declare_parameter("use_sim_time", self._context.use_sim_time,
                                   ParameterDescriptor(description="use simulated time from the context"))
            if start_parameter_services:
                self._parameter_service = ParameterService(self)
            self._type_description_service = TypeDescriptionService(self)
            self._context._changed()

    def _create_rosout_publisher(self):
        """rcl's per-node /rosout publisher (not in ``self.publishers``, as in rclpy)."""
        pub = Publisher(self, Log, "/rosout", ROSOUT_QOS, None, self.default_callback_group)
        self._context._add_publisher(pub)
        return pub

    # ------------------------------------------------------------------ identity
    @property
    def context(self):
        return self._context

    @property
    def executor(self):
        return self._executor

    @executor.setter
    def executor(self, new_executor):
        if new_executor is None:
            if self._executor is not None:
                self._executor.remove_node(self)
        else:
            new_executor.add_node(self)

    def get_name(self) -> str:
        return self._name

    def get_namespace(self) -> str:
        return self._namespace

    def get_fully_qualified_name(self) -> str:
        return _names.fully_qualified_node_name(self._name, self._namespace)

    def get_logger(self) -> RcutilsLogger:
        return self._logger

    def get_clock(self) -> ROSClock:
        return self._clock

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        """Expanded and (unless ``only_expand``) remapped by the node's ``-r`` rules, as rclpy."""
        name = _names.expand_topic_name(topic, self._name, self._namespace)
        if only_expand or not self._ros_args.remaps:
            return name
        return _arguments.remap_name(self._ros_args.remaps, name, self._name, self._namespace, is_service=False)

    def resolve_service_name(self, service: str, *, only_expand: bool = False) -> str:
        name = _names.expand_topic_name(service, self._name, self._namespace, is_service=True)
        if only_expand or not self._ros_args.remaps:
            return name
        return _arguments.remap_name(self._ros_args.remaps, name, self._name, self._namespace, is_service=True)

    def _check_alive(self):
        if self._destroyed:
            raise InvalidHandle(f"node {self.get_fully_qualified_name()!r} was destroyed")

    def _entities(self):
        return (self.subscriptions + self.timers + self.services + self.clients
                + [w for w in self.waitables if hasattr(w, "_take")])

    def _add_entity(self, ent, lst):
        lst.append(ent)
        ex = self._executor
        if ex is not None:
            ex._attach(ent)

    def _remove_entity(self, ent, lst):
        if ent in lst:
            lst.remove(ent)
        ex = self._executor
        if ex is not None:
            ex._detach(ent)

    # ------------------------------------------------------------------ tasks
    def create_task(self, callback, *args, **kwargs) -> Task:
        """Run ``callback(*args)`` on the node's executor (queued until the node is added)."""
        ex = self._executor
        if ex is not None:
            return ex.create_task(callback, *args, **kwargs)
        task = Task(callback, args, kwargs)
        self._pending_tasks.append(task)
        return task

    def sleep_async(self, seconds: float) -> Future:
        """A future done after ``seconds`` on the node's clock: ``await node.sleep_async(0.1)``.

        robocourse addition (rclpy has no awaitable sleep); works in simulated time.
        """
        fut = Future(executor=None)
        holder = []

        def fire():
            fut.set_result(None)
            self.destroy_timer(holder[0])

        holder.append(self.create_timer(seconds, fire))
        holder[0]._oneshot = True
        return fut

    # ------------------------------------------------------------------ pub/sub
    def create_publisher(self, msg_type, topic: str, qos_profile, *, callback_group=None,
                         event_callbacks=None, qos_overriding_options=None, publisher_class=None):
        """rclpy Node.create_publisher; ``qos_profile`` may be an int depth (KEEP_LAST)."""
        self._check_alive()
        _check_msg_type(msg_type, "create_publisher")
        _args.topic_name(topic, "create_publisher")
        qos = qos_from_arg(qos_profile)
        name = self.resolve_topic_name(topic)
        pub = Publisher(self, msg_type, name, qos, event_callbacks,
                        callback_group or self.default_callback_group)
        self._context._add_publisher(pub)
        self.publishers.append(pub)
        self._setup_qos_timers(pub, is_pub=True)
        return pub

    def create_subscription(self, msg_type, topic: str, callback, qos_profile, *,
                            callback_group=None, event_callbacks=None,
                            qos_overriding_options=None, raw=False):
        """rclpy Node.create_subscription; ``callback(msg)`` runs on the node's executor."""
        self._check_alive()
        _check_msg_type(msg_type, "create_subscription")
        _args.topic_name(topic, "create_subscription")
        _args.callable_(callback, "create_subscription")
        qos = qos_from_arg(qos_profile)
        name = self.resolve_topic_name(topic)
        group = callback_group or self.default_callback_group
        if raw:   # rclpy raw=True: the callback gets the CDR-serialized bytes
            from robocourse.bus.recording import _encoder

            user_cb, encode = callback, _encoder(msg_type)

            def callback(msg, user_cb=user_cb, encode=encode):
                return user_cb(bytes(encode(msg)))

        sub = Subscription(self, msg_type, name, callback, qos, event_callbacks, group)
        group.add_entity(sub)
        self.subscriptions.append(sub)
        self._context._add_subscription(sub)
        ex = self._executor
        if ex is not None:
            ex._attach(sub)
        self._setup_qos_timers(sub, is_pub=False)
        return sub

    def _setup_qos_timers(self, ent, is_pub):
        qos = ent.qos_profile
        if qos.deadline != INFINITE:
            ent._deadline = DeadlineWatch(ent, is_pub)
            if is_pub:
                ent._slow = True
                ent._deadline.start(None)
            else:
                for pub in ent._pubs:          # matched before the watch existed
                    ent._deadline.start(pub)
                    self._context._rewire(pub)
        if is_pub and qos.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC and \
                qos.liveliness_lease_duration != INFINITE:
            state = {"last": 0, "lost": 0}

            def check_lease():
                if ent._destroyed:
                    return
                now = ent.publish_count + ent._asserted
                alive = now != state["last"]
                state["last"] = now
                if alive == ent._alive:
                    return
                ent._alive = alive
                if not alive:
                    state["lost"] += 1
                    ent.counts.liveliness_changes += 1
                    cbs = ent.event_callbacks
                    if cbs is not None and cbs.liveliness is not None:
                        cbs.liveliness(QoSLivelinessLostInfo(state["lost"], 1))
                for sub in ent._subs:
                    n_alive = sum(1 for p in sub._pubs if p._alive)
                    sub.counts.liveliness_changes += 1
                    cbs = sub.event_callbacks
                    if cbs is not None and cbs.liveliness is not None:
                        d = 1 if alive else -1
                        cbs.liveliness(QoSLivelinessChangedInfo(
                            n_alive, len(sub._pubs) - n_alive, d, -d))

            t = Timer(self, qos.liveliness_lease_duration, check_lease, ent.callback_group,
                      self._clock, hidden=True)
            ent._lease_timer = t
            self._add_entity(t, self.timers)

    def destroy_publisher(self, publisher) -> bool:
        if publisher not in self.publishers:
            return False
        publisher._destroyed = True
        self.publishers.remove(publisher)
        self._context._remove_publisher(publisher)
        if publisher._deadline is not None:
            publisher._deadline.close()
        t = getattr(publisher, "_lease_timer", None)
        if t is not None:
            self._remove_entity(t, self.timers)
        return True

    def destroy_subscription(self, subscription) -> bool:
        if subscription not in self.subscriptions:
            return False
        subscription._destroyed = True
        self._remove_entity(subscription, self.subscriptions)
        self._context._remove_subscription(subscription)
        if subscription._deadline is not None:
            subscription._deadline.close()
        return True

    # ------------------------------------------------------------------ timers
    def create_timer(self, timer_period_sec: float, callback, callback_group=None, clock=None,
                     autostart: bool = True) -> Timer:
        """rclpy Node.create_timer: ``callback()`` every ``timer_period_sec`` on the node clock."""
        self._check_alive()
        _args.seconds(timer_period_sec, "create_timer(timer_period_sec)", name="timer_period_sec")
        _args.callable_(callback, "create_timer")
        group = callback_group or self.default_callback_group
        t = Timer(self, timer_period_sec, callback, group, clock or self._clock, autostart)
        group.add_entity(t)
        self._add_entity(t, self.timers)
        return t

    def create_rate(self, frequency: float, clock=None) -> Rate:
        if frequency <= 0:
            raise ValueError(f"rate frequency must be > 0 Hz, got {frequency}")
        t = Timer(self, 1.0 / frequency, lambda: None, self.default_callback_group,
                  clock or self._clock, hidden=True)
        self._add_entity(t, self.timers)
        return Rate(t)

    def destroy_timer(self, timer) -> bool:
        if timer not in self.timers:
            return False
        timer._destroyed = True
        timer.cancel()
        self._remove_entity(timer, self.timers)
        return True

    def destroy_rate(self, rate) -> bool:
        return self.destroy_timer(rate._timer)

    # ------------------------------------------------------------------ services
    def create_service(self, srv_type, srv_name: str, callback, *, qos_profile=qos_profile_services_default,
                       callback_group=None, _builtin=False):
        from robocourse.bus.service import Service

        self._check_alive()
        _args.topic_name(srv_name, "create_service/create_client", "srv_name")
        name = self.resolve_service_name(srv_name)
        group = callback_group or self.default_callback_group
        srv = Service(self, srv_type, name, callback, qos_profile, group)
        srv._builtin = _builtin     # a node's own parameter / type description service
        self._context._add_service(srv)
        group.add_entity(srv)
        self._add_entity(srv, self.services)
        return srv

    def create_client(self, srv_type, srv_name: str, *, qos_profile=qos_profile_services_default,
                      callback_group=None):
        from robocourse.bus.service import Client

        self._check_alive()
        _args.topic_name(srv_name, "create_service/create_client", "srv_name")
        name = self.resolve_service_name(srv_name)
        group = callback_group or self.default_callback_group
        cli = Client(self, srv_type, name, qos_profile, group)
        self._context._add_client(cli)
        group.add_entity(cli)
        self._add_entity(cli, self.clients)
        return cli

    def destroy_service(self, service) -> bool:
        if service not in self.services:
            return False
        service._destroyed = True
        self._remove_entity(service, self.services)
        self._context._remove_service(service)
        return True

    def destroy_client(self, client) -> bool:
        if client not in self.clients:
            return False
        client._destroyed = True
        self._remove_entity(client, self.clients)
        self._context._remove_client(client)
        return True

    # ------------------------------------------------------------------ lifetime
    def destroy_node(self) -> None:
        if self._destroyed:
            return
        rosout, self._rosout_publisher = self._rosout_publisher, None
        self._logger._rosout = None
        if rosout is not None:
            rosout._destroyed = True
            self._context._remove_publisher(rosout)
        for w in list(self.waitables):
            if hasattr(w, "destroy"):
                w.destroy()
        for p in list(self.publishers):
            self.destroy_publisher(p)
        for s in list(self.subscriptions):
            self.destroy_subscription(s)
        for t in list(self.timers):
            self.destroy_timer(t)
        for s in list(self.services):
            self.destroy_service(s)
        for c in list(self.clients):
            self.destroy_client(c)
        if self._executor is not None:
            self._executor.remove_node(self)
        self._destroyed = True
        if self in self._context.nodes:
            self._context.nodes.remove(self)
        self._context._changed()

    # ------------------------------------------------------------------ graph queries
    def get_node_names(self) -> list[str]:
        return [n.get_name() for n in self._context.nodes]

    def get_node_names_and_namespaces(self) -> list[tuple[str, str]]:
        return [(n.get_name(), n.get_namespace()) for n in self._context.nodes]

    def get_fully_qualified_node_names(self) -> list[str]:
        return [n.get_fully_qualified_name() for n in self._context.nodes]

    def get_topic_names_and_types(self, no_demangle: bool = False) -> list[tuple[str, list[str]]]:
        return sorted((t.name, [t.msg_type._type]) for t in self._context._topics.values()
                      if t.pubs or t.subs)

    def get_service_names_and_types(self) -> list[tuple[str, list[str]]]:
        return sorted((s.name, [s.srv_type._type]) for s in self._context._services.values()
                      if s.servers)

    def count_publishers(self, topic_name: str) -> int:
        t = self._context._topics.get(self.resolve_topic_name(topic_name))
        return len(t.pubs) if t else 0

    def count_subscribers(self, topic_name: str) -> int:
        t = self._context._topics.get(self.resolve_topic_name(topic_name))
        return len(t.subs) if t else 0

    def count_services(self, service_name: str) -> int:
        e = self._context._services.get(self.resolve_service_name(service_name))
        return len(e.servers) if e else 0

    def count_clients(self, service_name: str) -> int:
        e = self._context._services.get(self.resolve_service_name(service_name))
        return len(e.clients) if e else 0

    def _endpoint_infos(self, topic_name, which):
        t = self._context._topics.get(self.resolve_topic_name(topic_name))
        if t is None:
            return []
        ents = t.pubs if which == "PUBLISHER" else t.subs
        return [TopicEndpointInfo(e._node.get_name(), e._node.get_namespace(), e.msg_type._type,
                                  which, e.qos_profile, e) for e in ents]

    def get_publishers_info_by_topic(self, topic_name: str, no_mangle: bool = False):
        return self._endpoint_infos(topic_name, "PUBLISHER")

    def get_subscriptions_info_by_topic(self, topic_name: str, no_mangle: bool = False):
        return self._endpoint_infos(topic_name, "SUBSCRIPTION")

    # parameters: use_sim_time switches the clock like rclpy's TimeSource
    def _on_parameter_changed(self, param: Parameter) -> None:
        if param.name == "use_sim_time":
            if param.value and self._context.sim is None:
                self._logger.warning(
                    "use_sim_time=True but the context has no simulated time; create the "
                    "context with Context(use_sim_time=True)")
            self._clock._set_ros_time_override(self._context.sim if param.value else None)

    def __repr__(self):
        return f"<Node {self.get_fully_qualified_name()}>"


def _check_msg_type(msg_type, what):
    if not (isinstance(msg_type, type) and hasattr(msg_type, "_type") and hasattr(msg_type, "_fields")):
        raise TypeError(f"{what} needs a message class such as std_msgs.Float64 (from "
                        f"robocourse.msgs), got {msg_type!r}")


__all__ = ["Node", "TopicEndpointInfo", "ClockType"]
