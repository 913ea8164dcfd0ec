"""Odometry calibration against a reference: how far the car really turns and drives per unit of odometry.

The procedure of UMBmark-style calibration (Borenstein & Feng, 1996), done with the simulator's
``/ground_truth`` as the reference a real lab gets from a tape measure, a motion-capture system
or a gyro: command a constant twist over the bus, wait until the wheels reach speed (``settle_s``),
then compare the change of odometry's pose with the change of the true pose over ``seconds``.
A ratio that is the same at every speed is a calibration error (an effective wheel base or
radius that is not the nominal one): ``wheel_separation_multiplier = 1 / yaw ratio`` fixes it.
A ratio that changes with speed or acceleration is slip, which no constant fixes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.nav_msgs import Odometry

from . import kinematics as kin
from .nodes import QOS_CMD_VEL, QOS_ODOM


@dataclass(frozen=True)
class Run:
    """One constant-twist run: what odometry and the truth saw after the settling time."""

    v: float                 # commanded linear.x [m/s]
    w: float                 # commanded angular.z [rad/s]
    odom_yaw: float          # yaw change by odometry [rad], unwrapped
    true_yaw: float          # yaw change of the true pose [rad], unwrapped
    odom_path: float         # path length by odometry [m]
    true_path: float         # path length of the true pose [m]

    @property
    def yaw_ratio(self) -> float:
        return self.true_yaw / self.odom_yaw if abs(self.odom_yaw) > 1e-9 else math.nan

    @property
    def path_ratio(self) -> float:
        return self.true_path / self.odom_path if self.odom_path > 1e-9 else math.nan


def measure(node, executor, twists, seconds: float = 3.0, settle_s: float = 1.5, rest_s: float = 1.0) -> list[Run]:
    """Drive each (v, w) of ``twists`` for ``settle_s + seconds`` and measure it; ``node`` publishes
    /cmd_vel at 20 Hz and listens to /odom and /ground_truth (it must be on ``executor``)."""
    for name, value in (("seconds", seconds), ("settle_s", settle_s), ("rest_s", rest_s)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise ValueError(f"calibration.measure({name}={value!r}): a number of seconds >= 0")
    latest = {}
    subs = [node.create_subscription(Odometry, topic, lambda m, topic=topic: latest.__setitem__(topic, m), QOS_ODOM)
            for topic in ("/odom", "/ground_truth")]
    pub = node.create_publisher(Twist, "/cmd_vel", QOS_CMD_VEL)
    period = 0.05
    runs = []
    try:
        for v, w in twists:
            cmd = Twist()
            cmd.linear.x, cmd.angular.z = float(v), float(w)
            track = {"/odom": [0.0, 0.0, None], "/ground_truth": [0.0, 0.0, None]}   # yaw sum, path sum, last pose
            for k in range(round((settle_s + seconds) / period)):
                pub.publish(cmd)
                executor.spin_for(period)
                if k * period < settle_s:
                    continue
                for topic, acc in track.items():
                    if topic not in latest:
                        raise RuntimeError(f"no {topic} arrived while calibrating: is the driver (and the simulator) "
                                           "on this executor?")
                    p = latest[topic].pose.pose
                    pose = (p.position.x, p.position.y, kin.quaternion_to_yaw(p.orientation.x, p.orientation.y,
                                                                               p.orientation.z, p.orientation.w))
                    if acc[2] is not None:
                        acc[0] += kin.wrap_angle(pose[2] - acc[2][2])
                        acc[1] += math.hypot(pose[0] - acc[2][0], pose[1] - acc[2][1])
                    acc[2] = pose
            pub.publish(Twist())
            executor.spin_for(rest_s)
            (oy, od, _), (ty, td, _) = track["/odom"], track["/ground_truth"]
            runs.append(Run(float(v), float(w), oy, ty, od, td))
    finally:
        for sub in subs:
            node.destroy_subscription(sub)
        node.destroy_publisher(pub)
    return runs
