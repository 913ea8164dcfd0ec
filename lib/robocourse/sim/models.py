"""MuJoCo models of the course's plants, built from the same parameters as the demos.

- ``pendulum``: the seed's pendulum (point mass 0.01 kg at 0.5 m on a hinge, a torque motor).
  MuJoCo's hinge angle q is 0 upright and positive towards the seed's angle 0, so the seed's
  angle from the ground is ``theta = pi/2 - q`` (see ``seed_angle``).
- ``cartpole``: the newer demo's cart-pole (cart 5 kg with damping 20 N s/m on a rail, pole
  mass 1 kg at 2 m on a massless rod, force motor +-1000 N). MuJoCo's hinge angle phi is 0
  upright; the demo's theta = pi + phi (see ``cartpole_state``).
"""

from __future__ import annotations

import math

import numpy as np

from .params import GRAVITY, CartPoleParams, PendulumProperties

_POINT = 'diaginertia="1e-9 1e-9 1e-9"'  # a point mass, as in the demos' equations


def pendulum_xml(props: PendulumProperties | None = None, timestep: float = 0.001) -> str:
    p = props or PendulumProperties()
    return f"""
<mujoco model="seed_pendulum">
  <option timestep="{timestep}" gravity="0 0 -{GRAVITY}" integrator="RK4"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.01" rgba="0.85 0.85 0.85 1"/>
    <geom name="post" type="cylinder" fromto="0 -0.05 0 0 -0.05 0.1" size="0.02" rgba="0.3 0.3 0.3 1"/>
    <body name="arm" pos="0 0 0.1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0"/>
      <inertial pos="0 0 {p.length}" mass="{p.mass}" {_POINT}/>
      <geom name="rod" type="capsule" fromto="0 0 0 0 0 {p.length}" size="0.006" contype="0" conaffinity="0" rgba="0.2 0.4 0.8 1"/>
      <geom name="bob" type="sphere" pos="0 0 {p.length}" size="0.03" contype="0" conaffinity="0" rgba="0.9 0.3 0.1 1"/>
    </body>
  </worldbody>
  <actuator><motor name="torque" joint="hinge" gear="1"/></actuator>
</mujoco>"""


def cartpole_xml(params: CartPoleParams | None = None, timestep: float = 0.001) -> str:
    p = params or CartPoleParams()
    return f"""
<mujoco model="demo_cartpole">
  <option timestep="{timestep}" gravity="0 0 {p.gravity}" integrator="RK4"/>
  <worldbody>
    <geom name="rail" type="box" size="6 0.02 0.02" rgba="0.5 0.5 0.5 1" contype="0" conaffinity="0"/>
    <body name="cart" pos="0 0 0">
      <joint name="slider" type="slide" axis="1 0 0" damping="{p.damping}"/>
      <inertial pos="0 0 0" mass="{p.cart_mass}" {_POINT}/>
      <geom name="cart" type="box" size="0.4 0.25 0.15" rgba="0.2 0.5 0.9 1" contype="0" conaffinity="0"/>
      <body name="pole" pos="0 0 0">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 {p.length}" mass="{p.pole_mass}" {_POINT}/>
        <geom name="rod" type="capsule" fromto="0 0 0 0 0 {p.length}" size="0.03" contype="0" conaffinity="0" rgba="0.9 0.5 0.1 1"/>
        <geom name="bob" type="sphere" pos="0 0 {p.length}" size="0.12" contype="0" conaffinity="0" rgba="0.9 0.2 0.1 1"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor name="force" joint="slider" gear="1" ctrllimited="true" ctrlrange="-{p.max_force} {p.max_force}"/></actuator>
</mujoco>"""


def pendulum(props: PendulumProperties | None = None, timestep: float = 0.001):
    import mujoco

    return mujoco.MjModel.from_xml_string(pendulum_xml(props, timestep))


def cartpole(params: CartPoleParams | None = None, timestep: float = 0.001):
    import mujoco

    return mujoco.MjModel.from_xml_string(cartpole_xml(params, timestep))


def seed_angle(q: float) -> float:
    """The seed's angle from the ground (pi/2 upright) for MuJoCo's hinge angle q (0 upright)."""
    return math.pi / 2 - q


def cartpole_state(data) -> np.ndarray:
    """The demo's state [x, x_dot, theta, theta_dot] (theta = pi upright) from MuJoCo's data.

    MuJoCo's hinge about +y tips the pole towards +x for positive angles; the demo's theta grows
    the other way (a pole leaning to +x has theta < pi), hence the sign.
    """
    return np.array([data.qpos[0], data.qvel[0], math.pi - data.qpos[1], -data.qvel[1]])


def set_cartpole_state(model, data, state) -> None:
    import mujoco

    x, xd, th, thd = (float(v) for v in state)
    data.qpos[:] = (x, math.pi - th)
    data.qvel[:] = (xd, -thd)
    mujoco.mj_forward(model, data)
