"""The planar tf2 buffer: tf2's BufferCore rules on x, y, yaw (time cache, interpolation,
extrapolation errors, TF_OLD_DATA, static transforms, chains, latest common time)."""

import math

import pytest

from robocourse.bus import Context
from robocourse.msgs.geometry_msgs import TransformStamped
from robocourse.mycar.tf2 import (
    Buffer,
    ConnectivityException,
    ExtrapolationException,
    LookupException,
    compose,
    invert,
)


def tf(parent, child, t, x=0.0, y=0.0, yaw=0.0):
    m = TransformStamped()
    m.header.frame_id, m.child_frame_id = parent, child
    m.header.stamp.sec, m.header.stamp.nanosec = int(t), round((t - int(t)) * 1e9)
    m.transform.translation.x, m.transform.translation.y = x, y
    m.transform.rotation.z, m.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return m


def test_compose_and_invert():
    a = (1.0, 2.0, 0.7)
    assert compose(a, invert(a)) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)


def test_interpolates_between_stamps_and_refuses_outside():
    b = Buffer()
    b.set_transform(tf("odom", "base_link", 1.0, x=0.0, yaw=0.0), "a")
    b.set_transform(tf("odom", "base_link", 2.0, x=1.0, yaw=0.4), "a")
    assert b.lookup_transform("odom", "base_link", 1.5) == pytest.approx((0.5, 0.0, 0.2))
    assert b.lookup_transform("odom", "base_link", 0.0) == pytest.approx((1.0, 0.0, 0.4))   # 0 = latest
    with pytest.raises(ExtrapolationException, match=r"extrapolation into the future.  Requested time 2.500000 but the "
                                                     r"latest data is at time 2.000000, when looking up transform from "
                                                     r"frame \[base_link\] to frame \[odom\]"):
        b.lookup_transform("odom", "base_link", 2.5)
    with pytest.raises(ExtrapolationException, match="extrapolation into the past.  Requested time 0.500000 but the "
                                                     "earliest data is at time 1.000000"):
        b.lookup_transform("odom", "base_link", 0.5)


def test_old_data_is_refused_once_warned_and_counted():
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    b = Buffer(cache_time=10.0, logger=ctx.create_node("listener").get_logger())
    assert b.set_transform(tf("odom", "base_link", 100.0), "driver")
    assert not b.set_transform(tf("odom", "base_link", 80.0), "driver")
    assert not b.set_transform(tf("odom", "base_link", 85.0), "driver")
    assert b.set_transform(tf("odom", "base_link", 95.0), "driver")       # within 10 s of the newest: kept
    assert b.old_data == {"base_link": 2}
    warns = [r.msg for r in ctx.log_records if "TF_OLD_DATA" in r.msg]
    assert warns == ["TF_OLD_DATA ignoring data from the past for frame base_link at time 80 according to authority driver"]


def test_history_is_pruned_to_cache_time():
    b = Buffer(cache_time=1.0)
    for k in range(30):
        b.set_transform(tf("odom", "base_link", 0.1 * k + 0.1, x=k), "a")
    with pytest.raises(ExtrapolationException, match="into the past"):
        b.lookup_transform("odom", "base_link", 1.0)
    assert b.lookup_transform("odom", "base_link", 2.5)[0] == pytest.approx(24.0)


def test_chain_through_a_static_transform_at_the_latest_common_time():
    b = Buffer()
    b.set_transform(tf("map", "odom", 0.0, x=1.0, yaw=math.pi / 2), "loc", static=True)
    b.set_transform(tf("odom", "base_link", 3.0, x=0.5), "drv")
    b.set_transform(tf("odom", "base_link", 4.0, x=0.7), "drv")
    assert b.lookup_transform("map", "base_link") == pytest.approx((1.0, 0.7, math.pi / 2))
    assert b.lookup_transform("map", "base_link", 3.0) == pytest.approx((1.0, 0.5, math.pi / 2))
    assert b.lookup_transform("base_link", "map", 3.0) == pytest.approx(invert((1.0, 0.5, math.pi / 2)))


def test_unknown_and_unconnected_frames():
    b = Buffer()
    b.set_transform(tf("odom", "base_link", 1.0), "a")
    b.set_transform(tf("world", "marker", 1.0), "a")
    with pytest.raises(LookupException, match='"camera" passed to lookupTransform argument source_frame does not exist'):
        b.lookup_transform("odom", "camera")
    with pytest.raises(ConnectivityException, match="not part of the same tree"):
        b.lookup_transform("odom", "marker")
    assert not b.can_transform("odom", "marker") and b.can_transform("odom", "base_link")
