"""Physical parameters of the course's plants (the numbers a simulation model is built from).

They live in ``robocourse.sim`` (a foundation package) so that the MuJoCo models in
``sim.models``/``sim.car`` take plain parameters and import no chapter package; the chapter
packages re-export them (``robocourse.pendulum.PendulumProperties``,
``robocourse.mycar.DiffDriveGeometry``, ``robocourse.pendulum.CartPoleParams``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

GRAVITY = 9.80665  # the pendulum seed's constant


@dataclass
class PendulumProperties:
    """``PendulumProperties``: mass of the weight (kg) and length (m), the seed's defaults."""

    mass: float = 0.01
    length: float = 0.5

    def __post_init__(self):
        for name in ("mass", "length"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"pendulum {name} must be a positive finite number, got {value!r}")


@dataclass(frozen=True)
class CartPoleParams:
    """``PendulumDriverConfig`` defaults of the demo."""

    pole_mass: float = 1.0
    cart_mass: float = 5.0
    length: float = 2.0
    damping: float = 20.0
    gravity: float = -9.8
    max_force: float = 1000.0
    noise: float = 1.0

    def __post_init__(self):
        for name in ("pole_mass", "cart_mass", "length", "max_force"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"cart-pole {name} must be positive, got {v!r}")
        if not (math.isfinite(self.damping) and self.damping >= 0 and self.noise >= 0):
            raise ValueError(f"damping and noise must be >= 0, got {self.damping!r}, {self.noise!r}")


@dataclass(frozen=True)
class DiffDriveGeometry:
    """The seed's car: wheel base 0.15 m, wheel radius 0.0325 m, 0.5 m/s at full motor command."""

    wheel_base: float = 0.15
    wheel_radius: float = 0.0325
    max_linear_speed: float = 0.5

    def __post_init__(self):
        for name in ("wheel_base", "wheel_radius", "max_linear_speed"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number of metres (per second), got {v!r}")


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
