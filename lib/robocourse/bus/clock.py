"""Time, Duration, clocks and simulated time.

rclpy counterparts: ``rclpy.time.Time``, ``rclpy.duration.Duration``, ``rclpy.clock.Clock``,
``ROSClock``, ``ClockType`` and the ``use_sim_time`` parameter. In ROS 2 simulated time comes
from the /clock topic published by a simulator. Here a :class:`SimTime` source lives in the
:class:`~robocourse.bus.context.Context` and the executor is the simulator's clock: whenever
nothing is ready it jumps simulated time straight to the next timer deadline, so spinning
"10 s" takes only as long as the callbacks, and two runs give identical results. Difference:
there is no /clock topic; nodes read the context's simulated time directly
(``rosgraph_msgs/Clock`` exists in robocourse.msgs for code that wants to publish one).
"""

from __future__ import annotations

import threading
import time as _time
from enum import IntEnum

from robocourse.msgs.builtin_interfaces import Duration as DurationMsg
from robocourse.msgs.builtin_interfaces import Time as TimeMsg

S_TO_NS = 1_000_000_000


class ClockType(IntEnum):
    UNINITIALIZED = 0
    ROS_TIME = 1
    SYSTEM_TIME = 2
    STEADY_TIME = 3


class Duration:
    """rclpy.duration.Duration(seconds=0, nanoseconds=0)."""

    __slots__ = ("_ns",)

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0):
        self._ns = int(round(seconds * S_TO_NS)) + int(nanoseconds)

    @property
    def nanoseconds(self) -> int:
        return self._ns

    def to_msg(self) -> DurationMsg:
        sec, nsec = divmod(self._ns, S_TO_NS)
        return DurationMsg(sec=sec, nanosec=nsec)

    @classmethod
    def from_msg(cls, msg) -> Duration:
        return cls(seconds=msg.sec, nanoseconds=msg.nanosec)

    def __float__(self):
        return self._ns / S_TO_NS

    def __eq__(self, o):
        return isinstance(o, Duration) and o._ns == self._ns

    def __lt__(self, o):
        return self._ns < o._ns

    def __le__(self, o):
        return self._ns <= o._ns

    def __hash__(self):
        return hash(self._ns)

    def __add__(self, o):
        return Duration(nanoseconds=self._ns + o._ns)

    def __sub__(self, o):
        return Duration(nanoseconds=self._ns - o._ns)

    def __repr__(self):
        return f"Duration(nanoseconds={self._ns})"


class Time:
    """rclpy.time.Time(seconds=0, nanoseconds=0, clock_type=ClockType.SYSTEM_TIME)."""

    __slots__ = ("_ns", "clock_type")

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0,
                 clock_type: ClockType = ClockType.SYSTEM_TIME):
        ns = int(round(seconds * S_TO_NS)) + int(nanoseconds)
        if ns < 0:
            raise ValueError(f"Time must be >= 0, got {ns} ns")
        self._ns = ns
        self.clock_type = clock_type

    @property
    def nanoseconds(self) -> int:
        return self._ns

    def seconds_nanoseconds(self) -> tuple[int, int]:
        return divmod(self._ns, S_TO_NS)

    def to_msg(self) -> TimeMsg:
        sec, nsec = divmod(self._ns, S_TO_NS)
        return TimeMsg(sec=sec, nanosec=nsec)

    @classmethod
    def from_msg(cls, msg, clock_type: ClockType = ClockType.ROS_TIME) -> Time:
        return cls(seconds=msg.sec, nanoseconds=msg.nanosec, clock_type=clock_type)

    def __sub__(self, other):
        if isinstance(other, Time):
            if other.clock_type != self.clock_type:
                raise TypeError("Can't subtract times with different clock types")
            return Duration(nanoseconds=self._ns - other._ns)
        return Time(nanoseconds=self._ns - other.nanoseconds, clock_type=self.clock_type)

    def __add__(self, other: Duration):
        return Time(nanoseconds=self._ns + other.nanoseconds, clock_type=self.clock_type)

    def _cmp(self, other):
        if not isinstance(other, Time):
            raise TypeError("Can only compare Time with Time")
        if other.clock_type != self.clock_type:
            raise TypeError("Can't compare times with different clock types")
        return self._ns - other._ns

    def __eq__(self, o):
        return isinstance(o, Time) and self._cmp(o) == 0

    def __lt__(self, o):
        return self._cmp(o) < 0

    def __le__(self, o):
        return self._cmp(o) <= 0

    def __gt__(self, o):
        return self._cmp(o) > 0

    def __ge__(self, o):
        return self._cmp(o) >= 0

    def __hash__(self):
        return hash((self._ns, self.clock_type))

    def __repr__(self):
        return f"Time(nanoseconds={self._ns}, clock_type={self.clock_type.name})"


class SimTime:
    """The simulated time source of a context (nanoseconds, only moves forward)."""

    def __init__(self, start_ns: int = 0):
        self.ns = int(start_ns)
        self._lock = threading.Lock()
        # who moves the clock: None means the executors spinning on it do (they jump to the next
        # timer); a loop that owns it (the controller manager's real-time run, like a /clock
        # publisher) sets itself here and executors then only follow
        self.driver = None

    def advance_to(self, ns: int) -> None:
        with self._lock:
            if ns > self.ns:
                self.ns = int(ns)

    def advance(self, seconds: float) -> None:
        self.advance_to(self.ns + int(round(seconds * S_TO_NS)))


class Clock:
    """rclpy.clock.Clock(clock_type=ClockType.SYSTEM_TIME)."""

    def __init__(self, *, clock_type: ClockType = ClockType.SYSTEM_TIME):
        if clock_type == ClockType.ROS_TIME and not isinstance(self, ROSClock):
            raise TypeError("use ROSClock for ROS_TIME")
        self.clock_type = clock_type
        self._now_ns = _time.time_ns if clock_type != ClockType.STEADY_TIME else _time.monotonic_ns

    def now_ns(self) -> int:
        return self._now_ns()

    def now(self) -> Time:
        return Time(nanoseconds=self.now_ns(), clock_type=self.clock_type)

    @property
    def is_simulated(self) -> bool:
        return False

    def sleep_for(self, seconds: float) -> None:
        """Block the calling thread (wall clock only; in sim time use a timer)."""
        if self.is_simulated:
            raise RuntimeError(
                "Clock.sleep_for in simulated time would block the thread that advances the "
                "clock; use a timer (node.create_timer) or 'await node.sleep_async(dt)'")
        _time.sleep(float(seconds))

    def __repr__(self):
        return f"{type(self).__name__}(clock_type={self.clock_type.name})"


class ROSClock(Clock):
    """rclpy.clock.ROSClock: system time, or simulated time when ``use_sim_time`` is on."""

    def __init__(self, sim: SimTime | None = None):
        self.clock_type = ClockType.ROS_TIME
        self._sim = None
        self._now_ns = _time.time_ns
        if sim is not None:
            self._set_ros_time_override(sim)

    def _set_ros_time_override(self, sim: SimTime | None) -> None:
        self._sim = sim
        self._now_ns = (lambda s=sim: s.ns) if sim is not None else _time.time_ns

    @property
    def ros_time_is_active(self) -> bool:
        return self._sim is not None

    @property
    def is_simulated(self) -> bool:
        return self._sim is not None


def to_seconds(value) -> float:
    if isinstance(value, Duration):
        return value.nanoseconds / S_TO_NS
    return float(value)
