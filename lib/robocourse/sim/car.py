"""A differential-drive car in MuJoCo: chassis on a free joint, two driven wheels, a caster.

Wheel base and radius come from :class:`robocourse.sim.params.DiffDriveGeometry`; the wheels
are velocity servos with a torque limit, so wheels can slip and the car's true motion differs
from what wheel odometry integrates: the ground truth is the chassis pose.
"""

from __future__ import annotations

import math

import numpy as np

from .params import DiffDriveGeometry, quaternion_to_yaw


def car_xml(g: DiffDriveGeometry, timestep: float = 0.001, wheel_torque: float = 0.3) -> str:
    r, half = g.wheel_radius, g.wheel_base / 2
    return f"""
<mujoco model="mycar">
  <option timestep="{timestep}" integrator="implicitfast"/>
  <default><geom friction="1.0 0.005 0.0001"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.01" rgba="0.85 0.85 0.85 1"/>
    <body name="base_link" pos="0 0 {r + 0.001}">
      <freejoint name="root"/>
      <geom name="chassis" type="box" size="0.09 {half - 0.02} 0.02" pos="0 0 0.01" mass="0.6" rgba="0.2 0.5 0.9 1"/>
      <geom name="caster_front" type="sphere" size="{r * 0.5}" pos="0.075 0 {-r * 0.5}" mass="0.02" priority="1" condim="1" rgba="0.3 0.3 0.3 1"/>
      <geom name="caster_rear" type="sphere" size="{r * 0.5}" pos="-0.075 0 {-r * 0.5}" mass="0.02" priority="1" condim="1" rgba="0.3 0.3 0.3 1"/>
      <body name="left_wheel" pos="0 {half} 0">
        <joint name="left_wheel_joint" type="hinge" axis="0 1 0" damping="0.0005"/>
        <geom name="left_wheel" type="cylinder" size="{r} 0.01" euler="90 0 0" mass="0.05" rgba="0.1 0.1 0.1 1"/>
      </body>
      <body name="right_wheel" pos="0 {-half} 0">
        <joint name="right_wheel_joint" type="hinge" axis="0 1 0" damping="0.0005"/>
        <geom name="right_wheel" type="cylinder" size="{r} 0.01" euler="90 0 0" mass="0.05" rgba="0.1 0.1 0.1 1"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity name="left_motor" joint="left_wheel_joint" kv="0.2" forcelimited="true" forcerange="-{wheel_torque} {wheel_torque}"/>
    <velocity name="right_motor" joint="right_wheel_joint" kv="0.2" forcelimited="true" forcerange="-{wheel_torque} {wheel_torque}"/>
  </actuator>
</mujoco>"""


class MujocoCar:
    """The physical car: ``set_wheel_speeds`` (rad/s targets), ``step(dt)``, ground-truth ``pose()``."""

    def __init__(self, geometry: DiffDriveGeometry | None = None, timestep: float = 0.001):
        import mujoco

        self.geometry = geometry or DiffDriveGeometry()
        self.model = mujoco.MjModel.from_xml_string(car_xml(self.geometry, timestep))
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)
        self._body = self.model.body("base_link").id
        self._lw = self.model.joint("left_wheel_joint").dofadr[0]
        self._rw = self.model.joint("right_wheel_joint").dofadr[0]

    @property
    def time(self) -> float:
        return float(self.data.time)

    def set_wheel_speeds(self, left_rad_s: float, right_rad_s: float) -> None:
        # both hinges turn about +y: rolling towards +x is a positive rotation
        self.data.ctrl[0] = float(left_rad_s)
        self.data.ctrl[1] = float(right_rad_s)

    def wheel_speeds(self) -> tuple[float, float]:
        """Measured wheel angular speeds (rad/s, forward positive): what the encoders would report."""
        return float(self.data.qvel[self._lw]), float(self.data.qvel[self._rw])

    def step(self, dt: float) -> None:
        import mujoco

        n = int(round(dt / self.model.opt.timestep))
        if n < 1:
            raise ValueError(f"dt {dt} is shorter than the physics timestep {self.model.opt.timestep}")
        for _ in range(n):
            mujoco.mj_step(self.model, self.data)

    def pose(self) -> tuple[float, float, float]:
        """Ground truth (x, y, yaw) of base_link in the world."""
        x, y, _ = self.data.xpos[self._body]
        w, qx, qy, qz = self.data.xquat[self._body]
        return float(x), float(y), quaternion_to_yaw(qx, qy, qz, w)

    def speed(self) -> float:
        v = np.asarray(self.data.qvel[:2])
        return float(math.hypot(*v))
