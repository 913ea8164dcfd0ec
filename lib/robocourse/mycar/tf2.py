"""A planar tf2: transforms by time from /tf and /tf_static, looked up along chains.

Counterpart: tf2's ``BufferCore`` with ``tf2_ros.TransformListener``. Kept from tf2: one time
cache per child frame holding ``cache_time`` (10 s) of history behind its newest stamp; a
transform older than that is refused with tf2's ``TF_OLD_DATA`` warning (logged once per frame
and counted); a lookup at time 0 uses the latest time every edge of the chain has; a lookup at
a time between two stamps interpolates (translation linearly, yaw along the shorter arc); a time
outside an edge's history raises ``ExtrapolationException`` with tf2's text ("Lookup would
require extrapolation into the past/future ..."); static transforms hold at every time. Cut:
only x, y and yaw are kept (MyCar drives on a floor); no waiting for transforms (``can_transform``
answers at once).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from robocourse.bus import DurabilityPolicy, QoSProfile

from . import kinematics as kin


class TransformException(Exception):
    """tf2.TransformException."""


class LookupException(TransformException):
    """A frame that does not exist (tf2.LookupException)."""


class ConnectivityException(TransformException):
    """Two frames in different trees (tf2.ConnectivityException)."""


class ExtrapolationException(TransformException):
    """A time outside a transform's history (tf2.ExtrapolationException)."""


def compose(a, b):
    """2D transform a * b: (x, y, yaw) of frame c in frame p, from a = T_p_q and b = T_q_c."""
    ax, ay, ayaw = a
    bx, by, byaw = b
    c, s = math.cos(ayaw), math.sin(ayaw)
    return ax + c * bx - s * by, ay + s * bx + c * by, kin.wrap_angle(ayaw + byaw)


def invert(a):
    """The 2D transform T_q_p from a = T_p_q."""
    x, y, yaw = a
    c, s = math.cos(yaw), math.sin(yaw)
    return -c * x - s * y, s * x - c * y, kin.wrap_angle(-yaw)


def stamp_seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


@dataclass
class _Cache:
    """One child frame's history: stamps ascending, (parent, x, y, yaw) per stamp."""

    static: bool = False
    stamps: list = field(default_factory=list)
    values: list = field(default_factory=list)

    def latest(self) -> float:
        return self.stamps[-1]

    def at(self, t: float, child: str):
        """(parent, (x, y, yaw)) at time t (0: the newest)."""
        if self.static or t == 0.0:
            return self.values[-1][0], self.values[-1][1:]
        if len(self.stamps) == 1:
            if self.stamps[0] == t:
                return self.values[0][0], self.values[0][1:]
            raise ExtrapolationException(f"Lookup would require extrapolation at time {t:.6f}, but only time "
                                         f"{self.stamps[0]:.6f} is in the buffer")
        if t > self.stamps[-1]:
            raise ExtrapolationException(f"Lookup would require extrapolation into the future.  Requested time "
                                         f"{t:.6f} but the latest data is at time {self.stamps[-1]:.6f}")
        if t < self.stamps[0]:
            raise ExtrapolationException(f"Lookup would require extrapolation into the past.  Requested time "
                                         f"{t:.6f} but the earliest data is at time {self.stamps[0]:.6f}")
        k = bisect.bisect_left(self.stamps, t)
        if self.stamps[k] == t:
            return self.values[k][0], self.values[k][1:]
        (p0, x0, y0, w0), (_, x1, y1, w1) = self.values[k - 1], self.values[k]
        r = (t - self.stamps[k - 1]) / (self.stamps[k] - self.stamps[k - 1])
        return p0, (x0 + r * (x1 - x0), y0 + r * (y1 - y0), kin.wrap_angle(w0 + r * kin.wrap_angle(w1 - w0)))


class Buffer:
    """tf2_ros.Buffer(cache_time=10 s), planar: ``set_transform``, ``lookup_transform``, ``can_transform``."""

    def __init__(self, cache_time: float = 10.0, logger=None):
        if not (isinstance(cache_time, (int, float)) and math.isfinite(cache_time) and cache_time > 0):
            raise ValueError(f"Buffer(cache_time={cache_time!r}): a positive number of seconds, e.g. 10.0")
        self.cache_time = float(cache_time)
        self.logger = logger
        self._frames: dict[str, _Cache] = {}
        self.old_data: dict[str, int] = {}        # child frame -> transforms refused as TF_OLD_DATA
        self._warned: set[str] = set()

    def set_transform(self, transform, authority: str, *, static: bool = False) -> bool:
        """Insert one geometry_msgs/TransformStamped; False when it is refused (TF_OLD_DATA)."""
        parent, child = transform.header.frame_id.lstrip("/"), transform.child_frame_id.lstrip("/")
        if not parent or not child or parent == child:
            raise ValueError(f"transform {parent!r} -> {child!r}: frame ids must be non-empty and different")
        r, p = transform.transform.rotation, transform.transform.translation
        value = (parent, p.x, p.y, kin.quaternion_to_yaw(r.x, r.y, r.z, r.w))
        cache = self._frames.get(child)
        if cache is None or cache.static != static:
            cache = self._frames[child] = _Cache(static=static)
        if static:
            cache.stamps, cache.values = [0.0], [value]
            return True
        t = stamp_seconds(transform.header.stamp)
        if cache.stamps and t < cache.latest() - self.cache_time:
            self.old_data[child] = self.old_data.get(child, 0) + 1
            if self.logger is not None and child not in self._warned:
                self._warned.add(child)
                self.logger.warning(f"TF_OLD_DATA ignoring data from the past for frame {child} at time {t:g} "
                                    f"according to authority {authority}")
            return False
        k = bisect.bisect_right(cache.stamps, t)
        if k > 0 and cache.stamps[k - 1] == t:
            cache.values[k - 1] = value          # same stamp: the newer message wins
        else:
            cache.stamps.insert(k, t)
            cache.values.insert(k, value)
        while cache.stamps and cache.stamps[0] < cache.latest() - self.cache_time:
            cache.stamps.pop(0)
            cache.values.pop(0)
        return True

    def all_frames(self) -> list[str]:
        frames = set(self._frames)
        frames.update(c.values[-1][0] for c in self._frames.values())
        return sorted(frames)

    def _path_to_root(self, frame: str, t: float):
        """[(frame, parent, T_parent_frame)] up to the root, at time t."""
        out, seen = [], {frame}
        while frame in self._frames:
            parent, tf = self._frames[frame].at(t, frame)
            out.append((frame, parent, tf))
            if parent in seen:
                break
            seen.add(parent)
            frame = parent
        return out

    def _latest_common_time(self, frames: list[str]) -> float:
        times = [self._frames[f].latest() for f in frames if f in self._frames and not self._frames[f].static]
        return min(times) if times else 0.0

    def lookup_transform(self, target_frame: str, source_frame: str, time: float = 0.0):
        """(x, y, yaw) of ``source_frame`` in ``target_frame`` at ``time`` (seconds; 0 = latest common)."""
        target, source = target_frame.lstrip("/"), source_frame.lstrip("/")
        for f in (target, source):
            if f not in self.all_frames():
                raise LookupException(f'"{f}" passed to lookupTransform argument '
                                      f'{"target_frame" if f == target else "source_frame"} does not exist. ')
        if target == source:
            return (0.0, 0.0, 0.0)
        chain_frames = [f for f, _, _ in self._path_to_root(source, 0.0) + self._path_to_root(target, 0.0)]
        t = self._latest_common_time(chain_frames) if time == 0.0 else float(time)
        try:
            up_source = self._path_to_root(source, t)
            up_target = self._path_to_root(target, t)
        except ExtrapolationException as err:
            raise ExtrapolationException(f"{err}, when looking up transform from frame [{source}] to frame "
                                         f"[{target}]") from None
        root_s = up_source[-1][1] if up_source else source
        root_t = up_target[-1][1] if up_target else target
        if root_s != root_t:
            raise ConnectivityException(f"Could not find a connection between '{target}' and '{source}' because "
                                        "they are not part of the same tree. Tf has two or more unconnected trees.")
        t_root_source = (0.0, 0.0, 0.0)
        for _, _, tf in reversed(up_source):
            t_root_source = compose(t_root_source, tf)
        t_root_target = (0.0, 0.0, 0.0)
        for _, _, tf in reversed(up_target):
            t_root_target = compose(t_root_target, tf)
        return compose(invert(t_root_target), t_root_source)

    def can_transform(self, target_frame: str, source_frame: str, time: float = 0.0) -> bool:
        try:
            self.lookup_transform(target_frame, source_frame, time)
            return True
        except TransformException:
            return False


class TransformListener:
    """tf2_ros.TransformListener(buffer, node): fills ``buffer`` from /tf and /tf_static."""

    def __init__(self, buffer: Buffer, node):
        self.buffer = buffer
        if buffer.logger is None:
            buffer.logger = node.get_logger()
        node.create_subscription(_tf_type(), "/tf", self._on_tf, 100)
        node.create_subscription(_tf_type(), "/tf_static", self._on_static,
                                 QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL))

    def _on_tf(self, msg) -> None:
        for t in msg.transforms:
            self.buffer.set_transform(t, "default_authority")

    def _on_static(self, msg) -> None:
        for t in msg.transforms:
            self.buffer.set_transform(t, "default_authority", static=True)


def _tf_type():
    from robocourse.msgs.tf2_msgs import TFMessage

    return TFMessage
