"""Chapter 4's contact experiment: the UR5e pushes its gripper into a table, with or without admittance.

Counterpart: ros2_controllers' admittance demo (a JointTrajectoryController chained into an
AdmittanceController, the F/T sensor on the flange) with the contact made in MuJoCo. The table
is a :class:`robocourse.sim.robots.Wall` facing up, ``gap`` m below the gripper's tool centre
point; the trajectory asks the tool centre point to go ``gap + depth`` m down in ``move_s``
seconds, so a position-controlled arm tries to go ``depth`` m *into* the table. With
``admittance`` (the AdmittanceController's ``admittance.*`` values) the JTC's commands pass
through the admittance rule, which yields to the measured force.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
JTC = "joint_trajectory_controller"
ADMITTANCE = "admittance_controller"


@dataclass
class WallPush:
    """What a run measured, per cycle: time (s), contact force on the table (N, +z = the arm pushing
    down), tool centre point height (m), the tool's tilt (deg between its axis and straight down),
    and at the end which robot geoms touch the table."""

    t: np.ndarray
    force: np.ndarray
    tip_z: np.ndarray
    table_z: float
    cm: object
    sim: object
    params: dict
    tilt_deg: np.ndarray
    touching: list

    @property
    def peak(self) -> float:
        return float(self.force.max())

    def steady(self, last_s: float = 0.5) -> float:
        """Mean force over the last ``last_s`` seconds."""
        return float(self.force[self.t >= self.t[-1] - last_s].mean())


def joints_moving_tool(q0, offset, steps: int = 8) -> np.ndarray:
    """UR5e joint positions that move the flange by ``offset`` (m, world) from ``q0`` keeping its
    orientation: Newton steps on the flange position through the Jacobian (the admittance
    controller's kinematics interface, ``convert_cartesian_deltas_to_joint_deltas``)."""
    from robocourse.sim.robots import Kinematics

    kin = Kinematics("ur5e")
    q = np.array(q0, dtype=float)
    target = kin.calculate_link_transform(q)[:3, 3] + np.asarray(offset, dtype=float)
    for _ in range(steps):
        q = q + kin.convert_cartesian_deltas_to_joint_deltas(
            q, np.r_[target - kin.calculate_link_transform(q)[:3, 3], 0.0, 0.0, 0.0])
    return q


def wall_push_params(admittance: dict | None, gravity: tuple[float, list[float]] | None = None) -> dict:
    """The manager's parameters: a JTC alone, or a JTC chained into an admittance controller."""
    jtc = {"joints": list(ARM), "command_interfaces": ["position"], "state_interfaces": ["position", "velocity"]}
    cm = {"update_rate": 500, f"{JTC}.type": "joint_trajectory_controller/JointTrajectoryController"}
    params = {"controller_manager": cm, JTC: jtc}
    if admittance is not None:
        weight, cog = gravity if gravity is not None else (0.0, [0.0, 0.0, 0.0])
        jtc["command_joints"] = [f"{ADMITTANCE}/{j}" for j in ARM]
        jtc["command_interfaces"] = ["position", "velocity"]
        cm[f"{ADMITTANCE}.type"] = "admittance_controller/AdmittanceController"
        params[ADMITTANCE] = {
            "joints": list(ARM), "command_interfaces": ["position"], "state_interfaces": ["position", "velocity"],
            "chainable_command_interfaces": ["position", "velocity"], "ft_sensor.name": "tcp_fts_sensor",
            "ft_sensor.filter_coefficient": 0.1, "gravity_compensation.CoG.pos": list(cog),
            "gravity_compensation.CoG.force": float(weight),
            **{f"admittance.{k}": [float(x) for x in v] for k, v in admittance.items()}}
    return params


def wall_push(admittance: dict | None = None, *, depth: float = 0.04, gap: float = 0.04, move_s: float = 2.0,
              seconds: float = 3.0, on_cycle=None, log=None) -> WallPush:
    """Run the push; ``admittance`` like ``{"mass": [3]*3 + [0.5]*3, "damping_ratio": [1]*6, "stiffness": [300]*3 + [50]*3}``.

    Raises ``ValueError`` with the controller's message when the admittance values are refused.
    ``on_cycle(cm, sim)`` runs after every manager cycle (drawing, recording).
    """
    from robocourse.control import STRICT, ControllerManager, return_type
    from robocourse.control.hardware.mujoco_system import MujocoSystem
    from robocourse.control.log import LogSink
    from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
    from robocourse.sim.robots import RobotSim, Wall, urdf_text

    free = RobotSim("ur5e")
    tip = free.link_pose("tool_center_point")[0]
    table_z = float(tip[2] - gap)
    sim = RobotSim("ur5e", wall=Wall(point=(float(tip[0]), float(tip[1]), table_z), normal=(0.0, 0.0, 1.0),
                                     half_size=(0.02, 0.2, 0.2)))
    mass, cog = sim.tool_mass_properties()
    params = wall_push_params(admittance, (mass * 9.81, [float(c) for c in cog]))
    log = log if log is not None else LogSink(log_to_stderr=False)
    cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem"), params=params, log=log,
                           components={"UR5e": MujocoSystem(sim=sim)})
    names = ([ADMITTANCE] if admittance is not None else []) + [JTC]
    for name in names:
        if cm.load_controller(name) is None or cm.configure_controller(name) != return_type.OK:
            raise ValueError(f"{name} refused its parameters: {getattr(cm, 'last_error', '') or log.records[-1].msg}")
    if cm.switch_controller(names, [], STRICT) != return_type.OK:
        raise RuntimeError(cm.last_switch_message)
    q = joints_moving_tool(sim.positions[:6], (0.0, 0.0, -(gap + depth)))
    node = cm.context.create_node("commander")
    cm.executor.add_node(node)
    msg = JointTrajectory(joint_names=list(ARM))
    point = JointTrajectoryPoint(positions=q.tolist(), velocities=[0.0] * 6)
    point.time_from_start.sec, point.time_from_start.nanosec = int(move_s), int(round((move_s % 1) * 1e9))
    msg.points.append(point)
    node.create_publisher(JointTrajectory, f"/{JTC}/joint_trajectory", 10).publish(msg)
    n = int(round(seconds * cm.update_rate))
    t, force, tip_z, tilt = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    t0 = cm.time
    for k in range(n):
        cm.step()
        t[k] = cm.time - t0
        force[k] = -sim.contact_force("wall")[2]          # what the arm exerts on the table, downwards
        where, rot = sim.link_pose("tool_center_point")
        tip_z[k] = where[2]
        tilt[k] = np.degrees(np.arccos(np.clip(-rot[2, 2], -1.0, 1.0)))   # tool z axis vs straight down
        if on_cycle is not None:
            on_cycle(cm, sim)
    return WallPush(t, force, tip_z, table_z, cm, sim, params, tilt, sim.touching("wall"))


__all__ = ["ARM", "WallPush", "joints_moving_tool", "wall_push", "wall_push_params"]
