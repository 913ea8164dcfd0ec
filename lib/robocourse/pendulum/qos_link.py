"""How old is the newest angle a 1 kHz controller sees over a lossy link: BEST_EFFORT vs RELIABLE.

The seed keeps its real-time topics KEEP_LAST 1, BEST_EFFORT and quotes the ROS 2 QoS docs for
why: a RELIABLE reader waits for lost samples to be resent. This runs that argument on the
bus's seeded link model (:meth:`robocourse.bus.Context.set_link`): a sensor publishes a stamped
angle every ``period``; one controller node has a BEST_EFFORT and a RELIABLE KEEP_LAST 1
subscription to it, and at each of its own ``period`` ticks records how old the newest sample
of each is (now minus the sample's stamp). A BEST_EFFORT loss costs one period; a RELIABLE loss
holds back every newer sample until the resend gets through (in-order delivery), so its cost
grows with ``retransmit_delay`` (in DDS set by the heartbeat/NACK timing of the vendor's
configuration; here a parameter). Simulated time: the figures are the model's, exact and
repeatable for a seed, not a measurement of any middleware.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocourse.bus import Context, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
from robocourse.msgs.sensor_msgs import JointState


@dataclass(frozen=True)
class LinkRun:
    """Ages (ms) of the newest sample at each controller tick, per reliability, plus link counters."""

    ages_ms: dict[str, np.ndarray]
    sent: int
    lost: int
    retransmitted: int

    def stale_fraction(self, kind: str, period_ms: float) -> float:
        """Fraction of ticks whose newest sample is older than one period."""
        return float(np.mean(self.ages_ms[kind] > period_ms + 1e-9))


def newest_sample_ages(*, loss: float, delay: float, retransmit_delay: float, seed: int,
                       seconds: float = 2.0, period: float = 0.001, warmup: int = 10) -> LinkRun:
    """Run the sensor -> controller pair for ``seconds`` of simulated time over one lossy link."""
    if not (isinstance(seconds, (int, float)) and seconds > 0 and isinstance(period, (int, float)) and period > 0):
        raise ValueError(f"seconds={seconds!r} and period={period!r} must be > 0 (e.g. seconds=2.0, period=0.001)")
    if warmup * period >= seconds:
        raise ValueError(f"warmup={warmup} ticks of {period} s leave nothing of seconds={seconds}: run longer")
    ctx = Context(use_sim_time=True)
    ctx.log_to_stderr = False
    sensor, controller = ctx.create_node("sensor"), ctx.create_node("controller")
    pub = sensor.create_publisher(JointState, "/pendulum_sensor",
                                  QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
    newest: dict[str, int] = {}
    kinds = {"BEST_EFFORT": ReliabilityPolicy.BEST_EFFORT, "RELIABLE": ReliabilityPolicy.RELIABLE}
    for kind, policy in kinds.items():
        def keep(msg, kind=kind):
            newest[kind] = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        controller.create_subscription(JointState, "/pendulum_sensor", keep, QoSProfile(depth=1, reliability=policy))
    link = ctx.set_link(topic="/pendulum_sensor", loss=loss, delay=delay, retransmit_delay=retransmit_delay,
                        seed=seed)
    clock = sensor.get_clock()

    def publish():
        msg = JointState(name=["theta"], position=[0.0])
        msg.header.stamp = clock.now().to_msg()
        pub.publish(msg)

    ages: dict[str, list[float]] = {k: [] for k in kinds}

    def control():
        now = clock.now().nanoseconds
        for kind in kinds:
            ages[kind].append((now - newest[kind]) / 1e6 if kind in newest else np.nan)

    sensor.create_timer(period, publish)
    controller.create_timer(period, control)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(sensor)
    ex.add_node(controller)
    ex.spin_for(seconds)
    ctx.shutdown()
    return LinkRun({k: np.asarray(v[warmup:], dtype=np.float64) for k, v in ages.items()},
                   link.sent, link.lost, link.retransmitted)


__all__ = ["LinkRun", "newest_sample_ages"]
