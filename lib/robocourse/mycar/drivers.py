"""MyCar's hardware abstraction: one MotorDriver interface, a logging PWM stand-in, a MuJoCo car.

The seed's advice ("hide the hardware behind an interface so the node does not care") made
real: ``DriverNode`` talks to any ``MotorDriver``; ``SimulatedMotorDriver`` logs what a PWM
board would receive; ``MujocoMotorDriver`` spins the wheels of a physical car model.
"""

from __future__ import annotations

import abc
import logging
import math

from .kinematics import DiffDriveGeometry

log = logging.getLogger("robocourse.mycar.driver")


def _clamp_unit(name: str, value: float) -> float:
    if not isinstance(value, (int, float)) or math.isnan(value):
        raise ValueError(f"{name} motor speed must be a number in [-1, 1], got {value!r}")
    return max(-1.0, min(1.0, float(value)))


class MotorDriver(abc.ABC):
    """The seed's interface: ``init()``, ``set_motor_speeds(left, right)`` in [-1, 1], ``emergency_stop()``."""

    def __init__(self):
        self.left = 0.0
        self.right = 0.0
        self.stopped = False
        self.initialized = False

    def init(self) -> None:
        self.initialized = True
        self._apply(0.0, 0.0)

    def set_motor_speeds(self, left: float, right: float) -> tuple[float, float]:
        """Command both motors; values are clamped to [-1, 1]; returns what was applied."""
        if not self.initialized:
            raise RuntimeError(f"{type(self).__name__}.set_motor_speeds() before init(): call init() first")
        self.left, self.right = _clamp_unit("left", left), _clamp_unit("right", right)
        self.stopped = False
        self._apply(self.left, self.right)
        return self.left, self.right

    def emergency_stop(self) -> None:
        self.left = self.right = 0.0
        self.stopped = True
        self._apply(0.0, 0.0)

    @abc.abstractmethod
    def _apply(self, left: float, right: float) -> None:
        """Send normalised speeds to the hardware."""


class SimulatedMotorDriver(MotorDriver):
    """Logs the PWM duty cycles and direction pins a dual H-bridge board would get (no physics).

    ``pwm_resolution`` is the board's counter range (4096 for a PCA9685); ``history`` keeps every
    command as (left_duty, left_forward, right_duty, right_forward).
    """

    def __init__(self, pwm_resolution: int = 4096):
        super().__init__()
        self.pwm_resolution = int(pwm_resolution)
        self.history: list[tuple[int, bool, int, bool]] = []

    def _apply(self, left, right):
        top = self.pwm_resolution - 1
        entry = (round(abs(left) * top), left >= 0, round(abs(right) * top), right >= 0)
        self.history.append(entry)
        log.info("PWM left=%d/%d %s, right=%d/%d %s", entry[0], top, "fwd" if entry[1] else "rev",
                 entry[2], top, "fwd" if entry[3] else "rev")


class MujocoMotorDriver(MotorDriver):
    """Drives the wheels of a :class:`robocourse.sim.car.MujocoCar` (velocity-controlled motors)."""

    def __init__(self, car, geometry: DiffDriveGeometry | None = None):
        super().__init__()
        self.car = car
        self.geometry = geometry or car.geometry

    def _apply(self, left, right):
        g = self.geometry
        self.car.set_wheel_speeds(left * g.max_linear_speed / g.wheel_radius, right * g.max_linear_speed / g.wheel_radius)
