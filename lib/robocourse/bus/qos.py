"""Quality of service: profiles, presets, the offered-vs-requested compatibility check, events.

rclpy counterparts: ``rclpy.qos`` (``QoSProfile``, ``HistoryPolicy``, ``ReliabilityPolicy``,
``DurabilityPolicy``, ``LivelinessPolicy``, ``qos_profile_sensor_data``, ``QoSPresetProfiles``,
``qos_check_compatible``) and ``rclpy.event_handler`` (``SubscriptionEventCallbacks``,
``PublisherEventCallbacks`` and the ``QoS*Info`` event payloads).

In-process delivery never loses a sample unless a link model says so: ``ctx.set_link(topic=...,
loss=..., delay=..., seed=...)`` (see :mod:`robocourse.bus.transport`) makes BEST_EFFORT pairs
lose samples (``message_lost`` events) while RELIABLE pairs resend them late and in order.
KEEP_LAST overflow and lifespan expiry are counted on the subscription (``sub.counts``).

Durations are given in seconds (float) or as :class:`robocourse.bus.clock.Duration`; ``None``
or 0 means "infinite/unset" like ``Duration()`` in rclpy.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum

from robocourse.bus import _args
from robocourse.bus.clock import Duration

INFINITE = math.inf


class HistoryPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2
    UNKNOWN = 3


class ReliabilityPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class DurabilityPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class LivelinessPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    AUTOMATIC = 1
    MANUAL_BY_TOPIC = 3
    UNKNOWN = 4
    BEST_AVAILABLE = 5


class QoSPolicyKind(IntEnum):
    """rmw_qos_policy_kind_t: which policy made a pair incompatible."""

    INVALID = 1 << 0
    DURABILITY = 1 << 1
    DEADLINE = 1 << 2
    LIVELINESS = 1 << 3
    RELIABILITY = 1 << 4
    HISTORY = 1 << 5
    LIFESPAN = 1 << 6
    DEPTH = 1 << 7
    LIVELINESS_LEASE_DURATION = 1 << 8
    AVOID_ROS_NAMESPACE_CONVENTIONS = 1 << 9


class QoSCompatibility(IntEnum):
    OK = 0
    WARNING = 1
    ERROR = 2


class InvalidQoSProfileException(ValueError):
    """A QoS profile that cannot work (e.g. KEEP_LAST with depth 0)."""


def _seconds(value, name: str = "duration") -> float:
    if value is None:
        return INFINITE
    if isinstance(value, Duration):
        ns = value.nanoseconds
        return INFINITE if ns == 0 else ns * 1e-9
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise InvalidQoSProfileException(
            f"QoSProfile: {name}={value!r} must be seconds (a float such as 0.1), a Duration, or "
            f"None for infinite")
    value = float(value)
    if value < 0:
        raise InvalidQoSProfileException(
            f"QoSProfile: {name}={value!r} must be >= 0 s (0 or None mean infinite); e.g. "
            f"{name}=0.1")
    return INFINITE if value == 0 else value


def _fmt_dur(s: float) -> str:
    if s == INFINITE:
        return "Infinite"
    return f"{int(round(s * 1e9))} nanoseconds"


class QoSProfile:
    """rclpy.qos.QoSProfile. ``QoSProfile(depth=10)`` is KEEP_LAST 10, RELIABLE, VOLATILE.

    Differences: deadline/lifespan/liveliness_lease_duration are stored as float seconds
    (``math.inf`` = unset) and accept floats, ``Duration`` or ``None``.
    """

    __slots__ = ("history", "depth", "reliability", "durability", "lifespan", "deadline",
                 "liveliness", "liveliness_lease_duration", "avoid_ros_namespace_conventions")

    def __init__(self, *, history=None, depth=None, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE, lifespan=None, deadline=None,
                 liveliness=LivelinessPolicy.SYSTEM_DEFAULT, liveliness_lease_duration=None,
                 avoid_ros_namespace_conventions=False):
        what = "QoSProfile"
        if depth is not None and (isinstance(depth, bool) or not isinstance(depth, int) or depth < 0):
            raise InvalidQoSProfileException(
                f"{what}: depth={depth!r} must be an int >= 0 (how many samples KEEP_LAST keeps); "
                f"e.g. QoSProfile(depth=10)")
        if history is None:
            if depth is None:
                raise InvalidQoSProfileException(
                    "QoSProfile needs a history policy or a depth: QoSProfile(depth=10) for "
                    "KEEP_LAST 10, or QoSProfile(history=HistoryPolicy.KEEP_ALL)")
            history = HistoryPolicy.KEEP_LAST
        self.history = _args.policy(history, HistoryPolicy, what, "history")
        if self.history == HistoryPolicy.KEEP_LAST:
            if depth is None:
                raise InvalidQoSProfileException(
                    "History set to KEEP_LAST without a depth setting: use e.g. "
                    "QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10), or KEEP_ALL to keep "
                    "every sample")
            if depth == 0:      # rclpy (Jazzy+) warns and keeps the profile
                warnings.warn(
                    f"A zero depth with KEEP_LAST doesn't make sense; no data could be stored. "
                    f"This will be interpreted as SYSTEM_DEFAULT (rmw_zenoh's depth "
                    f"{SYSTEM_DEFAULT_DEPTH}). Give a depth >= 1, e.g. QoSProfile(depth=10)",
                    stacklevel=2)
        self.depth = int(depth) if depth is not None else 0
        self.reliability = _args.policy(reliability, ReliabilityPolicy, what, "reliability")
        self.durability = _args.policy(durability, DurabilityPolicy, what, "durability")
        self.liveliness = _args.policy(liveliness, LivelinessPolicy, what, "liveliness")
        self.lifespan = _seconds(lifespan, "lifespan")
        self.deadline = _seconds(deadline, "deadline")
        self.liveliness_lease_duration = _seconds(liveliness_lease_duration,
                                                  "liveliness_lease_duration")
        if not isinstance(avoid_ros_namespace_conventions, bool):
            raise TypeError(f"{what}: avoid_ros_namespace_conventions="
                            f"{avoid_ros_namespace_conventions!r} must be True or False")
        self.avoid_ros_namespace_conventions = avoid_ros_namespace_conventions

    def copy(self, **changes) -> QoSProfile:
        kw = {k: getattr(self, k) for k in self.__slots__}
        kw.update(changes)
        return QoSProfile(**kw)

    def __eq__(self, other):
        return isinstance(other, QoSProfile) and all(
            getattr(self, k) == getattr(other, k) for k in self.__slots__)

    def __repr__(self):
        return (f"QoSProfile(history={self.history.name}, depth={self.depth}, "
                f"reliability={self.reliability.name}, durability={self.durability.name}, "
                f"deadline={self.deadline}, lifespan={self.lifespan}, "
                f"liveliness={self.liveliness.name}, "
                f"liveliness_lease_duration={self.liveliness_lease_duration})")

    def ros_text(self, indent: str = "  ") -> str:
        """The QoS block ``ros2 topic info -v`` prints."""
        return "\n".join([
            f"{indent}Reliability: {self.reliability.name}",
            f"{indent}History (Depth): {self.history.name} ({self.depth})",
            f"{indent}Durability: {self.durability.name}",
            f"{indent}Lifespan: {_fmt_dur(self.lifespan)}",
            f"{indent}Deadline: {_fmt_dur(self.deadline)}",
            f"{indent}Liveliness: {self.liveliness.name}",
            f"{indent}Liveliness lease duration: {_fmt_dur(self.liveliness_lease_duration)}",
        ])


#: the depth a KEEP_LAST profile with depth 0 ("system default") gets: rmw_zenoh's default
#: (``qos.cpp``: ``best_available_qos`` turns depth 0 into 42)
SYSTEM_DEFAULT_DEPTH = 42


def effective_depth(qos: QoSProfile) -> int | None:
    """How many samples a queue with this profile keeps: ``depth`` for KEEP_LAST (a zero depth
    means the middleware's default, :data:`SYSTEM_DEFAULT_DEPTH`), None (unbounded) otherwise."""
    if qos.history != HistoryPolicy.KEEP_LAST:
        return None
    return qos.depth or SYSTEM_DEFAULT_DEPTH


def qos_from_arg(qos) -> QoSProfile:
    """rclpy accepts a QoSProfile or an int depth (KEEP_LAST depth)."""
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, bool) or not isinstance(qos, int):
        raise TypeError(f"qos_profile must be a QoSProfile or an int depth, got {qos!r}")
    return QoSProfile(depth=qos)


qos_profile_system_default = QoSProfile(history=HistoryPolicy.SYSTEM_DEFAULT, depth=0,
                                        reliability=ReliabilityPolicy.SYSTEM_DEFAULT,
                                        durability=DurabilityPolicy.SYSTEM_DEFAULT)
qos_profile_default = QoSProfile(depth=10)
qos_profile_sensor_data = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
qos_profile_services_default = QoSProfile(depth=10)
qos_profile_parameters = QoSProfile(depth=1000)
qos_profile_parameter_events = QoSProfile(depth=1000)
qos_profile_action_status_default = QoSProfile(depth=1,
                                               durability=DurabilityPolicy.TRANSIENT_LOCAL)
qos_profile_best_available = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_AVAILABLE,
                                        durability=DurabilityPolicy.BEST_AVAILABLE,
                                        liveliness=LivelinessPolicy.BEST_AVAILABLE)


class QoSPresetProfiles:
    """rclpy.qos.QoSPresetProfiles: ``QoSPresetProfiles.SENSOR_DATA.value``."""

    class _P:
        def __init__(self, v):
            self.value = v

    SYSTEM_DEFAULT = _P(qos_profile_system_default)
    DEFAULT = _P(qos_profile_default)
    SENSOR_DATA = _P(qos_profile_sensor_data)
    SERVICES_DEFAULT = _P(qos_profile_services_default)
    PARAMETERS = _P(qos_profile_parameters)
    PARAMETER_EVENTS = _P(qos_profile_parameter_events)
    ACTION_STATUS_DEFAULT = _P(qos_profile_action_status_default)
    BEST_AVAILABLE = _P(qos_profile_best_available)

    @classmethod
    def get_from_short_key(cls, name: str) -> QoSProfile:
        return getattr(cls, name.upper()).value


class QoSCheckResult(tuple):
    """``(compatibility, reason)``, the tuple rclpy's ``qos_check_compatible`` returns
    (``compat, reason = qos_check_compatible(p, s)``), also readable by name:
    ``.compatibility``, ``.reason`` and ``.policy`` (the :class:`QoSPolicyKind` that made the
    pair incompatible, or None; a robocourse addition, rmw reports it in the events)."""

    def __new__(cls, compatibility: QoSCompatibility, reason: str,
                policy: QoSPolicyKind | None = None):
        self = super().__new__(cls, (compatibility, reason))
        self.policy = policy
        return self

    def __getnewargs__(self):
        return (self[0], self[1], self.policy)

    @property
    def compatibility(self) -> QoSCompatibility:
        return self[0]

    @property
    def reason(self) -> str:
        return self[1]


def qos_check_compatible(publisher_qos: QoSProfile, subscription_qos: QoSProfile) -> QoSCheckResult:
    """rclpy.qos.qos_check_compatible: the rmw_dds_common table, first mismatch wins.

    Returns ``(QoSCompatibility, reason)`` like rclpy: ERROR with the ROS reason text for an
    incompatible pair, WARNING when a SYSTEM_DEFAULT/UNKNOWN value makes the answer depend on
    the middleware, else OK with an empty reason. The result also has ``.compatibility``,
    ``.reason`` and ``.policy``. A subscription's BEST_AVAILABLE policy adapts to the
    publisher (always compatible).
    """
    p, s = publisher_qos, subscription_qos
    if p.reliability == ReliabilityPolicy.BEST_EFFORT and s.reliability == ReliabilityPolicy.RELIABLE:
        return QoSCheckResult(QoSCompatibility.ERROR,
                              "ERROR: Best effort publisher and reliable subscription;",
                              QoSPolicyKind.RELIABILITY)
    if p.durability == DurabilityPolicy.VOLATILE and s.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        return QoSCheckResult(QoSCompatibility.ERROR,
                              "ERROR: Volatile publisher and transient local subscription;",
                              QoSPolicyKind.DURABILITY)
    if s.deadline != INFINITE:
        if p.deadline == INFINITE:
            return QoSCheckResult(QoSCompatibility.ERROR,
                                  "ERROR: Subscription has a deadline, but publisher does not;",
                                  QoSPolicyKind.DEADLINE)
        if s.deadline < p.deadline:
            return QoSCheckResult(QoSCompatibility.ERROR,
                                  "ERROR: Subscription deadline is less than publisher deadline;",
                                  QoSPolicyKind.DEADLINE)
    if p.liveliness == LivelinessPolicy.AUTOMATIC and s.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC:
        return QoSCheckResult(QoSCompatibility.ERROR,
                              "ERROR: Publisher's liveliness is automatic and subscription's is "
                              "manual by topic;", QoSPolicyKind.LIVELINESS)
    if s.liveliness_lease_duration != INFINITE:
        if p.liveliness_lease_duration == INFINITE:
            return QoSCheckResult(QoSCompatibility.ERROR,
                                  "ERROR: Subscription has a liveliness lease duration, but "
                                  "publisher does not;", QoSPolicyKind.LIVELINESS_LEASE_DURATION)
        if s.liveliness_lease_duration < p.liveliness_lease_duration:
            return QoSCheckResult(QoSCompatibility.ERROR,
                                  "ERROR: Subscription liveliness lease duration is less than "
                                  "publisher;", QoSPolicyKind.LIVELINESS_LEASE_DURATION)
    warnings = []
    unknown_r = (ReliabilityPolicy.SYSTEM_DEFAULT, ReliabilityPolicy.UNKNOWN)
    unknown_d = (DurabilityPolicy.SYSTEM_DEFAULT, DurabilityPolicy.UNKNOWN)
    unknown_l = (LivelinessPolicy.SYSTEM_DEFAULT, LivelinessPolicy.UNKNOWN)
    if p.reliability in unknown_r and s.reliability == ReliabilityPolicy.RELIABLE:
        warnings.append("WARNING: Publisher reliability is SYSTEM_DEFAULT and subscription is RELIABLE;")
    if p.reliability == ReliabilityPolicy.BEST_EFFORT and s.reliability in unknown_r:
        warnings.append("WARNING: Publisher reliability is BEST_EFFORT and subscription is SYSTEM_DEFAULT;")
    if p.durability in unknown_d and s.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        warnings.append("WARNING: Publisher durability is SYSTEM_DEFAULT and subscription is TRANSIENT_LOCAL;")
    if p.durability == DurabilityPolicy.VOLATILE and s.durability in unknown_d:
        warnings.append("WARNING: Publisher durability is VOLATILE and subscription is SYSTEM_DEFAULT;")
    if p.liveliness in unknown_l and s.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC:
        warnings.append("WARNING: Publisher liveliness is SYSTEM_DEFAULT and subscription is MANUAL_BY_TOPIC;")
    if p.liveliness == LivelinessPolicy.AUTOMATIC and s.liveliness in unknown_l:
        warnings.append("WARNING: Publisher liveliness is AUTOMATIC and subscription is SYSTEM_DEFAULT;")
    if warnings:
        return QoSCheckResult(QoSCompatibility.WARNING, " ".join(warnings))
    return QoSCheckResult(QoSCompatibility.OK, "")


# ---------------------------------------------------------------------------- event payloads


@dataclass
class QoSRequestedIncompatibleQoSInfo:
    total_count: int = 0
    total_count_change: int = 0
    last_policy_kind: QoSPolicyKind = QoSPolicyKind.INVALID


@dataclass
class QoSOfferedIncompatibleQoSInfo:
    total_count: int = 0
    total_count_change: int = 0
    last_policy_kind: QoSPolicyKind = QoSPolicyKind.INVALID


@dataclass
class QoSRequestedDeadlineMissedInfo:
    total_count: int = 0
    total_count_change: int = 0


@dataclass
class QoSOfferedDeadlineMissedInfo:
    total_count: int = 0
    total_count_change: int = 0


@dataclass
class QoSLivelinessChangedInfo:
    alive_count: int = 0
    not_alive_count: int = 0
    alive_count_change: int = 0
    not_alive_count_change: int = 0


@dataclass
class QoSLivelinessLostInfo:
    total_count: int = 0
    total_count_change: int = 0


@dataclass
class QoSMessageLostInfo:
    total_count: int = 0
    total_count_change: int = 0


@dataclass
class QoSSubscriptionMatchedInfo:
    total_count: int = 0
    total_count_change: int = 0
    current_count: int = 0
    current_count_change: int = 0


@dataclass
class QoSPublisherMatchedInfo:
    total_count: int = 0
    total_count_change: int = 0
    current_count: int = 0
    current_count_change: int = 0


@dataclass
class SubscriptionEventCallbacks:
    """rclpy.event_handler.SubscriptionEventCallbacks (callbacks run on the executor)."""

    deadline: Callable | None = None
    incompatible_qos: Callable | None = None
    liveliness: Callable | None = None
    message_lost: Callable | None = None
    matched: Callable | None = None
    use_default_callbacks: bool = True


@dataclass
class PublisherEventCallbacks:
    """rclpy.event_handler.PublisherEventCallbacks (callbacks run on the executor)."""

    deadline: Callable | None = None
    incompatible_qos: Callable | None = None
    liveliness: Callable | None = None
    matched: Callable | None = None
    use_default_callbacks: bool = True


@dataclass
class _Counts:
    """Running totals of one entity's events (what the bus records, readable in tests)."""

    incompatible_qos: int = 0
    deadline_missed: int = 0
    liveliness_changes: int = 0
    message_lost: int = 0
    matched_total: int = 0
    matched_current: int = 0
    lifespan_expired: int = 0
    dropped_keep_last: int = 0
    last_policy: QoSPolicyKind = QoSPolicyKind.INVALID
    extra: dict = field(default_factory=dict)
