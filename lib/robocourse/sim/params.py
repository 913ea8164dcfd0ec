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


def _require_positive(params, names, rule: str) -> None:
    """Refuse a parameter that is not a positive finite number (``rule`` names it)."""
    for name in names:
        v = getattr(params, name)
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{rule.format(name)}, got {v!r}")


@dataclass
class PendulumProperties:
    """``PendulumProperties``: mass of the weight (kg) and length (m), the seed's defaults."""

    mass: float = 0.01
    length: float = 0.5

    def __post_init__(self):
        _require_positive(self, ("mass", "length"), "pendulum {} must be a positive finite number")


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
        _require_positive(self, ("pole_mass", "cart_mass", "length", "max_force"),
                          "cart-pole {} must be positive")
        if not (math.isfinite(self.damping) and self.damping >= 0 and self.noise >= 0):
            raise ValueError(f"damping and noise must be >= 0, got {self.damping!r}, {self.noise!r}")


@dataclass(frozen=True)
class DiffDriveGeometry:
    """The seed's car: wheel base 0.15 m, wheel radius 0.0325 m, 0.5 m/s at full motor command."""

    wheel_base: float = 0.15
    wheel_radius: float = 0.0325
    max_linear_speed: float = 0.5

    def __post_init__(self):
        _require_positive(self, ("wheel_base", "wheel_radius", "max_linear_speed"),
                          "{} must be a positive number of metres (per second)")


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
