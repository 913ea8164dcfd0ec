"""The seed demo's pendulum physics (ros2/demos pendulum_control ``PendulumMotor``), in Python.

Angle is measured from the ground: 0 and pi lie flat, pi/2 is upright (the unstable
equilibrium). Each physics step: ``a = g sin(theta - pi/2) / L + tau / (m L^2)``, then
semi-implicit Euler ``v += a dt; theta += v dt``, then theta is clamped to [0, pi] (velocity is
left as it is, as in the seed). A position command sets theta directly (the seed's "direct,
instantaneous position control"). NaN raises the seed's exact errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from robocourse.sim.params import GRAVITY, PendulumProperties  # noqa: F401  (re-exported)

PI = math.pi

NAN_COMMAND = "Tried to set state to NaN in on_command_message callback"


@dataclass
class PendulumState:
    """``PendulumState``: angle from the ground (rad), angular velocity, acceleration, torque."""

    position: float = 0.0
    velocity: float = 0.0
    acceleration: float = 0.0
    torque: float = 0.0


def _clamp(theta: float) -> float:
    if theta > PI:
        return PI
    if theta < 0.0:
        return 0.0
    return theta


class PendulumPhysics:
    """One pendulum and its ideal position motor; ``step(dt)`` is one pass of the seed's loop."""

    def __init__(self, properties: PendulumProperties | None = None, state: PendulumState | None = None):
        self.properties = properties or PendulumProperties()
        self.state = state or PendulumState()

    def acceleration(self, position: float, torque: float = 0.0) -> float:
        p = self.properties
        return GRAVITY * math.sin(position - PI / 2.0) / p.length + torque / (p.mass * p.length * p.length)

    def step(self, dt: float) -> PendulumState:
        s = self.state
        s.acceleration = self.acceleration(s.position, s.torque)
        s.velocity += s.acceleration * dt
        s.position = _clamp(s.position + s.velocity * dt)
        if math.isnan(s.position):
            raise RuntimeError(NAN_COMMAND)  # the seed reuses this text in its physics loop
        return s

    def command(self, position: float) -> None:
        """Apply a ``JointCommand``: set the angle directly, clamped to [0, pi]."""
        self.state.position = _clamp(position)
        if math.isnan(self.state.position):
            raise RuntimeError(NAN_COMMAND)
