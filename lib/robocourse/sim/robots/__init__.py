"""robocourse.sim.robots: the course's robots as URDF files, and a MuJoCo simulation of each.

Counterpart of a ROS ``*_description`` package (URDF + xacro) plus a simulator plugin such as
mujoco_ros2_control. Robots (``ROBOTS``):

- ``"rrbot"``: ros2_control_demos' RRBot, joints ``joint1``, ``joint2`` (continuous, about +y).
- ``"ur5e"``: a UR5e from Universal Robots' published DH table (d1 0.1625, a2 -0.425,
  a3 -0.3922, d4 0.1333, d5 0.0997, d6 0.0996 m), link masses (3.761, 8.058, 2.846, 1.37, 1.3,
  0.365 kg) and centres of mass, UR's joint names and limits (ur_description's
  joint_limits.yaml), primitive shapes; inertias are those of solid cylinders (approximated),
  plus a 1-DOF parallel gripper (``finger_joint``, 0..0.04 m per finger; ``right_finger_joint``
  mimics it) whose limits and masses follow the Franka Hand's URDF. The URDF file's header
  lists every figure and its source.

One URDF file per robot serves both MuJoCo (which loads URDF and ignores ``<ros2_control>``)
and a ros2_control parser (which reads the ``<ros2_control name=... type="system">`` element:
hardware plugin ``mock_components/GenericSystem`` by default, every commanded joint with
position/velocity/effort command interfaces (min/max from the limits) and state interfaces
(position with initial_value), the mimic finger as ``mimic="true"`` with position/velocity
states, and on the ur5e a ``tcp_fts_sensor`` with force.x..torque.z states).

API (stable; other packages build on it):

- ``urdf_path(name) -> Path``; ``urdf_text(name, plugin=None, params=None,
  initial_positions=None, variant=None) -> str``: the URDF with the hardware plugin/params
  substituted, like a xacro argument, or with a variant's ``<ros2_control>`` elements
  (``VARIANTS``: RRBot's ``"modular_fts"``, an actuator per joint and an external F/T sensor);
  ``joint_limits(name) -> {joint: JointLimits}``.
- ``RobotSim(name, timestep=0.001, gains=None, gravity_feedforward=True, wall=None,
  grasp_object=None, payload_mass=0.0, floor=True)``:
  ``joint_names`` (commanded joints, URDF order); ``positions``/``velocities``/``efforts``
  (read-only float64 views, always current); ``commands`` (writable float64 view, read in each
  joint's mode); ``set_mode(joints, "position"|"velocity"|"effort")``; ``step(n=1)``; ``time``;
  ``reset(positions=None)``; ``gravity_torques(out=None)``; ``wrench`` (ur5e: flange F/T, N and
  N m in tool0); ``mimic_joint_names``/``mimic_positions``/``mimic_velocities``;
  ``tool_mass_properties()``; ``contact_force(geom)``; ``link_pose(link)``; ``model``/``data``
  (MuJoCo, e.g. for ``robocourse.viz.MujocoDrawer(scene, sim.model)``).
- ``Kinematics(name, tip=None)``: kinematics_interface's ``calculate_link_transform``,
  ``calculate_jacobian``, ``convert_cartesian_deltas_to_joint_deltas`` and
  ``convert_joint_deltas_to_cartesian_deltas`` over the chain base_link -> tip (tool0 on the ur5e).

Units: rad, rad/s, N m (revolute); m, m/s, N (prismatic finger); s.

    sim = RobotSim("ur5e")
    sim.set_mode(sim.joint_names[:6], "effort")
    for _ in range(1000):  # 1 s at 1 kHz: the arm floats, held by its gravity torques
        sim.commands[:6] = sim.gravity_torques()[:6]
        sim.step()

Where we differ from mujoco_ros2_control: no ROS node or plugin loading here (the
ros2_control component in robocourse.control wraps RobotSim); the servo gains live in Python
(``ServoGains``), not in the MJCF; position and velocity servos add a gravity feed-forward.
"""

from .description import ROBOTS, VARIANTS, JointLimits, joint_limits, urdf_path, urdf_text
from .kinematics import Kinematics
from .simulation import MODES, GraspObject, RobotSim, ServoGains, Wall

__all__ = ["ROBOTS", "VARIANTS", "MODES", "JointLimits", "joint_limits", "urdf_path", "urdf_text", "Kinematics", "RobotSim",
           "ServoGains", "Wall", "GraspObject"]
