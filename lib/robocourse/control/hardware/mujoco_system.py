"""``robocourse/MujocoSystem``: a SystemInterface whose write() steps a MuJoCo robot.

Counterpart: mujoco_ros2_control's ``MujocoSystem`` / gz_ros2_control's ``GazeboSimSystem``:
the simulated arm behind the same interfaces a real driver exports. A thin layer over
:class:`robocourse.sim.robots.RobotSim` (per-joint PD position servo, velocity servo or direct
torque, chosen by which command interface a controller claims).

Hardware ``<param>``s (all optional):

- ``robot``: ``ur5e`` or ``rrbot`` (default: the shipped robot whose joints match the URDF);
- ``timestep``: physics step in s (0.001); each write() steps ``round(period / timestep)``
  times, so the physics advances exactly as fast as the manager's clock.

Interfaces: joints ``position`` / ``velocity`` / ``effort`` (commands and states), the mimic
finger's position/velocity states, and the flange F/T sensor's ``force.x`` .. ``torque.z``.
Command modes (``prepare_command_mode_switch``): exactly one of position/velocity/effort per
joint; on activation every position command is set to the measured position and velocity and
effort commands to 0, so nothing jumps. A NaN command keeps the joint's previous command; a
non-finite value the simulation refuses makes write() return ERROR.

Pass a ready simulation (with a wall, an object, a payload) as
``components={"UR5e": MujocoSystem(sim=RobotSim("ur5e", wall=Wall()))}``.
"""

from __future__ import annotations

import math

import numpy as np

from .component import SystemInterface
from .types import CallbackReturn, return_type

_MODES = ("position", "velocity", "effort")
_FT = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")


class MujocoSystem(SystemInterface):
    """robocourse/MujocoSystem (see the module docstring)."""

    SUPPORTED_COMMAND_INTERFACES = _MODES
    SUPPORTED_STATE_INTERFACES = _MODES

    def __init__(self, sim=None):
        super().__init__()
        self.sim = sim

    def on_init(self, info):
        super().on_init(info)
        p = info.hardware_parameters
        try:
            self.timestep = float(p.get("timestep", "0.001"))
        except ValueError:
            self.get_logger().error(f"timestep must be a number of seconds, got {p['timestep']!r}")
            return CallbackReturn.ERROR
        self.robot = p.get("robot") or (self.sim.name if self.sim is not None else self._guess_robot(info))
        if self.robot is None:
            self.get_logger().error(f"MujocoSystem '{info.name}': no shipped robot has the joints "
                                    f"{[j.name for j in info.joints]}; add <param name=\"robot\">ur5e</param>")
            return CallbackReturn.ERROR
        return CallbackReturn.SUCCESS

    @staticmethod
    def _guess_robot(info):
        from robocourse.sim.robots import ROBOTS, joint_limits

        names = {j.name for j in info.joints}
        for robot in ROBOTS:
            if names <= set(joint_limits(robot)):
                return robot
        return None

    def on_configure(self, previous_state):
        if self.sim is None:
            from robocourse.sim.robots import RobotSim

            self.sim = RobotSim(self.robot, timestep=self.timestep)
        sim = self.sim
        self.timestep = sim.model.opt.timestep
        commanded, mimics = list(sim.joint_names), list(sim.mimic_joint_names)
        self._cmd_slots = np.full((3, len(commanded)), -1, dtype=np.intp)
        pairs = {m: ([], []) for m in _MODES}
        mimic_pairs = {m: ([], []) for m in _MODES[:2]}
        for j in self.info.joints:
            if j.name in commanded:
                k = commanded.index(j.name)
                for m_i, m in enumerate(_MODES):
                    key = f"{j.name}/{m}"
                    if key in self.command_index:
                        self._cmd_slots[m_i, k] = self.command_index[key]
                    if key in self.state_index:
                        pairs[m][0].append(self.state_index[key])
                        pairs[m][1].append(k)
            elif j.name in mimics:
                k = mimics.index(j.name)
                for m in _MODES[:2]:
                    key = f"{j.name}/{m}"
                    if key in self.state_index:
                        mimic_pairs[m][0].append(self.state_index[key])
                        mimic_pairs[m][1].append(k)
            else:
                self.get_logger().error(f"joint '{j.name}' is not a joint of the MuJoCo model '{sim.name}' "
                                        f"(its joints: {commanded + mimics})")
                return CallbackReturn.ERROR
        self._state_src = [(np.array(pairs[m][0], dtype=np.intp), np.array(pairs[m][1], dtype=np.intp))
                           for m in _MODES]
        self._mimic_src = [(np.array(mimic_pairs[m][0], dtype=np.intp), np.array(mimic_pairs[m][1], dtype=np.intp))
                           for m in _MODES[:2]]
        self._sources = (sim.positions, sim.velocities, sim.efforts)
        self._mimic_sources = (sim.mimic_positions, sim.mimic_velocities)
        self._ft_slots = None
        for s in self.info.sensors:
            keys = [f"{s.name}/{i}" for i in _FT]
            if all(k in self.state_index for k in keys):
                self._ft_slots = np.array([self.state_index[k] for k in keys], dtype=np.intp)
        self.modes = dict(sim.modes)
        self._started: set[str] = set()
        self._rebuild_command_map()
        self.read(0.0, 0.0)
        return CallbackReturn.SUCCESS

    def _rebuild_command_map(self) -> None:
        src, dst = [], []
        for k, j in enumerate(self.sim.joint_names):
            slot = self._cmd_slots[_MODES.index(self.modes[j]), k]
            if slot >= 0:
                src.append(slot)
                dst.append(k)
        self._src = np.array(src, dtype=np.intp)
        self._dst = np.array(dst, dtype=np.intp)
        self._all = len(dst) == len(self.sim.joint_names) and dst == list(range(len(dst)))
        self._buf = np.zeros(len(src))
        self._old = np.zeros(len(src))
        self._nan = np.zeros(len(src), dtype=bool)

    def on_activate(self, previous_state):
        sim = self.sim
        for k, j in enumerate(sim.joint_names):
            for m_i, m in enumerate(_MODES):
                slot = self._cmd_slots[m_i, k]
                if slot >= 0:
                    self.command_values[slot] = sim.positions[k] if m == "position" else 0.0
            sim.commands[k] = sim.positions[k] if self.modes[j] == "position" else 0.0
        return CallbackReturn.SUCCESS

    def prepare_command_mode_switch(self, start_interfaces, stop_interfaces):
        """Refuse a joint that would end up with zero or several of position/velocity/effort.

        Like a real driver (and unlike GenericSystem) the check counts the interfaces already
        in use by running controllers that this switch does not stop.
        """
        joints = set(self.sim.joint_names)
        per_joint: dict[str, list[str]] = {}
        for key in sorted((self._started - set(stop_interfaces)) | set(start_interfaces)):
            prefix, _, itf = key.rpartition("/")
            if prefix in joints:
                per_joint.setdefault(prefix, []).append(itf)
        for joint, itfs in per_joint.items():
            modes = [i for i in itfs if i in _MODES]
            if len(modes) != 1:
                self.get_logger().error(f"Joint '{joint}' needs exactly one of 'position', 'velocity', 'effort' "
                                        f"among the started interfaces, got {itfs}")
                return return_type.ERROR
        return return_type.OK

    def perform_command_mode_switch(self, start_interfaces, stop_interfaces):
        self._started = (self._started - set(stop_interfaces)) | set(start_interfaces)
        joints = set(self.sim.joint_names)
        for key in start_interfaces:
            prefix, _, itf = key.rpartition("/")
            if prefix in joints and itf in _MODES and self.modes[prefix] != itf:
                self.sim.set_mode(prefix, itf)
                self.modes[prefix] = itf
                k = self.sim.joint_names.index(prefix)
                slot = self._cmd_slots[_MODES.index(itf), k]
                if slot >= 0:   # the new mode starts from a hold, not from a stale command
                    self.command_values[slot] = self.sim.commands[k]
        self._rebuild_command_map()
        return return_type.OK

    # --- cyclic (hot path) ---------------------------------------------------------------------------
    def read(self, time, period):
        st = self.state_values
        for (slots, idx), source in zip(self._state_src, self._sources):
            if len(slots):
                st[slots] = source[idx]
        for (slots, idx), source in zip(self._mimic_src, self._mimic_sources):
            if len(slots):
                st[slots] = source[idx]
        if self._ft_slots is not None:
            st[self._ft_slots] = self.sim.wrench
        return return_type.OK

    def write(self, time, period):
        buf = self._buf
        if len(buf):
            np.take(self.command_values, self._src, out=buf)
            np.isnan(buf, out=self._nan)
            cmds = self.sim.commands
            if self._nan.any():
                np.take(cmds, self._dst, out=self._old)
                np.copyto(buf, self._old, where=self._nan)
            energy = float(buf.dot(buf))     # inf if any command is infinite (NaN were replaced above)
            if energy == math.inf:
                bad = [(self.sim.joint_names[k], float(v)) for k, v in zip(self._dst, buf) if not math.isfinite(v)]
                self.get_logger().error(f"MujocoSystem '{self.info.name}': non-finite command {bad} at "
                                        f"t={self.sim.time:.4f} s; the joints keep their previous commands")
                return return_type.ERROR
            if self._all:
                cmds[:] = buf
            else:
                cmds[self._dst] = buf
        n = int(round(period / self.timestep))
        if n >= 1:
            try:
                self.sim.step(n)
            except ValueError as exc:
                self.get_logger().error(f"MujocoSystem '{self.info.name}': {exc}")
                return return_type.ERROR
        return return_type.OK
