"""RobotSim: one shipped robot in MuJoCo with per-joint position / velocity / effort servos.

What a simulated robot offers a ros2_control hardware component (mujoco_ros2_control's
MujocoSystem, gz_ros2_control's GazeboSimSystem): joint positions, velocities and measured
efforts, and per-joint command modes. Each commanded joint has one MuJoCo ``general`` actuator
whose gains are rewritten when its mode changes, so the servo law runs inside ``mj_step`` at
the physics rate (with implicit damping) and costs Python nothing per physics step:

- position: ``tau = kp (q_cmd - q) - kd qd + ff``
- velocity: ``tau = kv (qd_cmd - qd) + ff``
- effort:   ``tau = effort_cmd``

``tau`` is clipped to the URDF effort limit; ``ff`` is MuJoCo's bias force (gravity, Coriolis)
of the previous physics step when ``gravity_feedforward`` is on (a real arm's joint servos
compensate gravity too), and 0 in effort mode: an effort-mode arm falls unless its controller
adds ``gravity_torques()``. Commands are clamped to the joint's range (position), velocity limit
(velocity) or effort limit (effort), as ``ctrlrange`` does.

Around the URDF, the simulation adds (MJCF additions through MjSpec): a floor, two lights, the
actuators, a force + torque sensor pair at tool0 (ur5e), optionally a ``Wall``, a free
``GraspObject`` and a payload at the TCP. Robot geoms touch the environment but not each other;
the fingers, the object and the mimic coupling use stiff constraints (time constant two
physics steps) and elliptic friction cones, so a squeezed object neither sinks in nor slips.
A non-finite command is refused by ``step()`` (ValueError) before MuJoCo would zero every
control; a ros2_control component turns that into return_type ERROR.

Units: rad, rad/s, N m for revolute joints; m, m/s, N for the gripper finger; wrench in N and
N m in the flange frame ``tool0``; time in s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .description import joint_limits, urdf_path

MODES = ("position", "velocity", "effort")


@dataclass(frozen=True)
class ServoGains:
    """Gains of one joint's servo: kp in N m/rad (N/m), kd and kv in N m s/rad (N s/m)."""

    kp: float
    kd: float
    kv: float

    def __post_init__(self):
        for k in ("kp", "kd", "kv"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"ServoGains {k}={v!r} must be a finite number >= 0, "
                                 "e.g. ServoGains(kp=800.0, kd=80.0, kv=100.0)")


@dataclass(frozen=True)
class Wall:
    """A fixed box whose face passes through ``point`` (m, world) facing ``normal``.

    ``half_size`` (m) is (thickness/2, width/2, height/2); contacts use MuJoCo's soft contact
    with ``solref`` = (time constant s, damping ratio): smaller time constant, stiffer wall.
    """

    point: tuple[float, float, float] = (0.5, 0.0, 0.4)
    normal: tuple[float, float, float] = (-1.0, 0.0, 0.0)
    half_size: tuple[float, float, float] = (0.02, 0.5, 0.4)
    solref: tuple[float, float] = (0.02, 1.0)


@dataclass(frozen=True)
class GraspObject:
    """A free box (half sizes in m, mass in kg) that starts at ``position`` (m, world)."""

    position: tuple[float, float, float] = (0.5, 0.0, 0.025)
    half_size: tuple[float, float, float] = (0.02, 0.02, 0.025)
    mass: float = 0.1
    friction: float = 1.0


@dataclass(frozen=True)
class _Spec:
    ft_body: str | None
    tcp_body: str
    gains: Mapping[str, ServoGains]
    finger_bodies: tuple[str, ...] = ()
    armature: Mapping[str, float] | None = None   # rotor inertia (kg m^2) added per joint


_BIG, _WRIST = ServoGains(kp=800.0, kd=80.0, kv=150.0), ServoGains(kp=80.0, kd=4.0, kv=6.0)
_SPECS = {
    "rrbot": _Spec(ft_body=None, tcp_body="tool_link",
                   gains={"joint1": ServoGains(300.0, 40.0, 40.0), "joint2": ServoGains(300.0, 40.0, 40.0)}),
    "ur5e": _Spec(ft_body="tool0", tcp_body="tool_center_point",
                  gains={"shoulder_pan_joint": _BIG, "shoulder_lift_joint": _BIG, "elbow_joint": _BIG,
                         "wrist_1_joint": _WRIST, "wrist_2_joint": _WRIST, "wrist_3_joint": _WRIST,
                         "finger_joint": ServoGains(kp=2000.0, kd=100.0, kv=100.0)},
                  finger_bodies=("left_finger", "right_finger")),
    # FR3: kp = libfranka's examples' default joint impedance (setDefaultBehavior: 3000, 3000, 3000,
    # 2500, 2500, 2000, 2000 N m/rad); kd and the armature are ours (Franka publishes neither the
    # robot's internal damping nor its reflected rotor inertia): the armature (0.3 / 0.1 kg m^2)
    # keeps those stiffnesses stable at a 1 ms physics step, kd damps them to about 0.7 of critical
    "fr3": _Spec(ft_body=None, tcp_body="link8",
                 gains={f"fr3_joint{i + 1}": ServoGains(kp=kp, kd=kd, kv=kv) for i, (kp, kd, kv) in enumerate(
                     [(3000.0, 60.0, 60.0)] * 3 + [(2500.0, 55.0, 55.0), (2500.0, 25.0, 25.0),
                                                   (2000.0, 22.0, 22.0), (2000.0, 20.0, 20.0)])},
                 armature={**{f"fr3_joint{i}": 0.3 for i in (1, 2, 3, 4)}, **{f"fr3_joint{i}": 0.1 for i in (5, 6, 7)}}),
}

_ROBOT_CONTYPE, _ROBOT_CONAFFINITY = 1, 2  # robot geoms touch the environment, never each other
_ENV = 3


def _vec(value, n, what):
    a = np.asarray(value, dtype=float)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} = {value!r} must be {n} finite numbers")
    return a


class RobotSim:
    """A shipped robot (``"rrbot"`` or ``"ur5e"``) in MuJoCo, stepped at ``timestep`` seconds.

    ``joint_names``: the commanded joints in URDF order (mimic joints excluded).
    ``positions``, ``velocities``, ``efforts``: read-only float64 views into MuJoCo's state,
    always current, never reallocated (keep a reference). ``commands``: a writable float64
    view; element i is read in joint i's mode. ``step(n)`` advances n physics steps.
    """

    def __init__(self, name: str = "ur5e", timestep: float = 0.001, *,
                 gains: Mapping[str, ServoGains] | None = None, gravity_feedforward: bool = True,
                 wall: Wall | None = None, grasp_object: GraspObject | None = None,
                 payload_mass: float = 0.0, floor: bool = True):
        import mujoco

        if isinstance(timestep, bool) or not isinstance(timestep, (int, float)) or not 0 < timestep <= 0.005:
            raise ValueError(f"timestep={timestep!r} s must be in (0, 0.005] (the servos and grasp contacts "
                             "are checked from 0.5 to 5 ms), e.g. 0.001 for 1 kHz physics")
        if isinstance(payload_mass, bool) or not isinstance(payload_mass, (int, float)) \
                or not 0 <= payload_mass <= 50 or not math.isfinite(payload_mass):
            raise ValueError(f"payload_mass={payload_mass!r} kg must be in [0, 50]")
        self.name = name
        limits = joint_limits(name)  # also validates the name
        spec_info = _SPECS[name]
        if payload_mass and spec_info.ft_body is None:
            raise ValueError(f"{name} has no flange to carry a payload; use RobotSim('ur5e', payload_mass=...)")
        self.joint_names: tuple[str, ...] = tuple(j for j, lim in limits.items() if lim.mimic is None)
        self.mimic_joint_names: tuple[str, ...] = tuple(j for j, lim in limits.items() if lim.mimic is not None)
        self.limits = {j: limits[j] for j in self.joint_names}
        self.gains = dict(spec_info.gains)
        for j, g in (gains or {}).items():
            if j not in self.gains:
                raise ValueError(f"gains for unknown joint {j!r}; the joints are {', '.join(self.joint_names)}")
            if not isinstance(g, ServoGains):
                raise ValueError(f"gains[{j!r}] = {g!r} must be a ServoGains(kp=..., kd=..., kv=...)")
            self.gains[j] = g
        self.gravity_feedforward = bool(gravity_feedforward)

        spec = mujoco.MjSpec.from_file(str(urdf_path(name)))
        spec.option.timestep = float(timestep)
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        # grasping: elliptic friction cones with impratio 10 (MuJoCo's advice against slip), and
        # the stiffest stable constraints (time constant 2 steps) on the fingers and the mimic
        # coupling: MuJoCo's default 0.02 s lets a 20 N squeeze sink a centimetre into the object
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = 10.0
        self._stiff = [2 * float(timestep), 1.0]
        for eq in spec.equalities:
            eq.solref, eq.solimp = self._stiff, [0.95, 0.99, 0.001, 0.5, 2.0]
        for j, a in (spec_info.armature or {}).items():
            spec.joint(j).armature = float(a)
        for body in spec.bodies:  # name geoms "<link>/<k>" so drawings and contacts name the link
            for k, geom in enumerate(body.geoms):
                geom.name = f"{body.name}/{k}"
                geom.contype, geom.conaffinity = _ROBOT_CONTYPE, _ROBOT_CONAFFINITY
                if body.name in spec_info.finger_bodies:
                    geom.solref = self._stiff
        world = spec.worldbody
        if floor:
            world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2.5, 2.5, 0.01],
                           rgba=[0.85, 0.85, 0.85, 1], contype=_ENV, conaffinity=_ENV)
        world.add_light(name="key", pos=[1.5, -1.5, 3.0], dir=[-0.4, 0.4, -1.0])
        world.add_light(name="fill", pos=[-1.5, 1.5, 3.0], dir=[0.4, -0.4, -1.0])
        if wall is not None:
            self._add_wall(spec, wall)
        if grasp_object is not None:
            self._add_object(spec, grasp_object, self._stiff)
        if payload_mass:  # a solid sphere r = 3 cm centred on the TCP, rigidly held
            i = 0.4 * payload_mass * 0.03 ** 2
            payload = spec.body(spec_info.tcp_body).add_body(name="payload", mass=float(payload_mass),
                                                             inertia=[i, i, i])
            payload.add_geom(name="payload", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.03, 0, 0],
                             rgba=[0.9, 0.6, 0.1, 1], contype=_ROBOT_CONTYPE, conaffinity=_ROBOT_CONAFFINITY)
        if spec_info.ft_body is not None:
            spec.body(spec_info.ft_body).add_site(name="ft_sensor")
            spec.add_sensor(name="ft_force", type=mujoco.mjtSensor.mjSENS_FORCE,
                            objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft_sensor")
            spec.add_sensor(name="ft_torque", type=mujoco.mjtSensor.mjSENS_TORQUE,
                            objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft_sensor")
        for j in self.joint_names:
            lim = self.limits[j]
            spec.add_actuator(name=j, target=j, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              gaintype=mujoco.mjtGain.mjGAIN_FIXED, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                              forcelimited=True, forcerange=[-lim.effort, lim.effort],
                              ctrllimited=True, ctrlrange=[-lim.effort, lim.effort])
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self._mj = mujoco
        m, d = self.model, self.data

        n = len(self.joint_names)
        qpos, self._dofs = self._spans(self.joint_names)
        self.positions, self.velocities, self.efforts = d.qpos[qpos], d.qvel[self._dofs], d.actuator_force[0:n]
        mimic_qpos, mimic_dofs = self._spans(self.mimic_joint_names)
        self.mimic_positions, self.mimic_velocities = d.qpos[mimic_qpos], d.qvel[mimic_dofs]
        for view in (self.positions, self.velocities, self.efforts, self.mimic_positions, self.mimic_velocities):
            view.flags.writeable = False
        self.commands = d.ctrl[0:n]
        self._bias0 = m.actuator_biasprm[0:n, 0]  # the feed-forward slot, a strided view
        self._qfrc_bias = d.qfrc_bias[self._dofs]
        self._ff_mask = np.zeros(n, dtype=bool)
        self._ff_all = self._ff_any = False
        self._ones = np.ones(n)
        self._modes = ["position"] * n
        self._index = {j: i for i, j in enumerate(self.joint_names)}
        # URDF <mimic> became joint equalities q1 = c0 + c1 q2 (+ c2 q2^2 ..., zero here)
        self._mimic = [(int(m.jnt_qposadr[m.eq_obj1id[e]]), int(m.jnt_qposadr[m.eq_obj2id[e]]), m.eq_data[e, :5].copy())
                       for e in range(m.neq) if m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT]
        self._contact_wrench = np.zeros(6)
        if spec_info.ft_body is not None:
            fa, ta = m.sensor("ft_force").adr[0], m.sensor("ft_torque").adr[0]
            assert ta == fa + 3
            self._ft = d.sensordata[fa:fa + 6]
            self._ft_body = m.body(spec_info.ft_body).id
            self._wrench = np.zeros(6)
        else:
            self._ft = None
        self._scratch = mujoco.MjData(m)
        self._rne = np.zeros(m.nv)
        self._gravity = np.zeros(n)
        self.initial_positions = self._initial_positions_from_urdf()
        for i in range(n):
            self._apply_mode(i, "position")
        self.reset()

    # --- construction helpers ---------------------------------------------------------
    def _spans(self, joints) -> tuple[slice, slice]:
        """The qpos and qvel slices of ``joints`` (1-DOF each), which must be consecutive."""
        m = self.model
        spans = []
        for table in (m.jnt_qposadr, m.jnt_dofadr):
            adr = [int(table[m.joint(j).id]) for j in joints]
            start = adr[0] if adr else 0
            if adr != list(range(start, start + len(adr))):
                raise RuntimeError(f"{self.name}: joints {joints} are not consecutive in MuJoCo's state")
            spans.append(slice(start, start + len(adr)))
        return spans[0], spans[1]

    def _initial_positions_from_urdf(self) -> np.ndarray:
        import xml.etree.ElementTree as ET

        root = ET.parse(urdf_path(self.name)).getroot()
        values = {}
        for joint in root.find("ros2_control").findall("joint"):
            p = joint.find("state_interface[@name='position']/param[@name='initial_value']")
            if p is not None:
                values[joint.get("name")] = float(p.text)
        return np.array([values.get(j, 0.0) for j in self.joint_names])

    @staticmethod
    def _add_wall(spec, wall: Wall) -> None:
        import mujoco

        point, normal = _vec(wall.point, 3, "Wall.point"), _vec(wall.normal, 3, "Wall.normal")
        half = _vec(wall.half_size, 3, "Wall.half_size")
        if np.linalg.norm(normal) < 1e-9 or np.any(half <= 0):
            raise ValueError(f"{wall!r}: normal must be non-zero and half_size > 0")
        nrm = normal / np.linalg.norm(normal)
        # box x axis along the normal; its centre sits half a thickness behind the face
        x = nrm
        helper = np.array([0.0, 0.0, 1.0]) if abs(nrm[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        y = np.cross(helper, x)
        y /= np.linalg.norm(y)
        z = np.cross(x, y)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.column_stack([x, y, z]).ravel())
        spec.worldbody.add_geom(name="wall", type=mujoco.mjtGeom.mjGEOM_BOX, size=half,
                                pos=point - nrm * half[0], quat=quat, rgba=[0.6, 0.45, 0.35, 1],
                                contype=_ENV, conaffinity=_ENV, solref=list(wall.solref))

    @staticmethod
    def _add_object(spec, obj: GraspObject, solref) -> None:
        import mujoco

        pos, half = _vec(obj.position, 3, "GraspObject.position"), _vec(obj.half_size, 3, "GraspObject.half_size")
        if np.any(half <= 0) or not 0 < obj.mass < 100:
            raise ValueError(f"{obj!r}: half_size must be > 0 and mass in (0, 100) kg")
        m, (a, b, c) = float(obj.mass), 2 * half  # the URDF turns inertiafromgeom off: give it here
        # ipos/iquat explicitly: left unset (MjSpec's NaN "unspecified"), the compiled centre of mass
        # landed at twice ``pos`` from the origin, and the box hopped and spun on a table by itself
        body = spec.worldbody.add_body(name="object", pos=pos, mass=m, ipos=[0.0, 0.0, 0.0], iquat=[1.0, 0.0, 0.0, 0.0],
                                       explicitinertial=True,
                                       inertia=[m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12])
        body.add_freejoint(name="object")
        body.add_geom(name="object", type=mujoco.mjtGeom.mjGEOM_BOX, size=half,
                      rgba=[0.85, 0.2, 0.15, 1], contype=_ENV, conaffinity=_ENV, solref=solref,
                      friction=[float(obj.friction), 0.005, 0.0001])

    # --- modes -----------------------------------------------------------------------
    def _joint_index(self, joint: str) -> int:
        try:
            return self._index[joint]
        except KeyError:
            raise ValueError(f"{joint!r} is not a commanded joint of {self.name}; "
                             f"the joints are {', '.join(self.joint_names)}") from None

    def _apply_mode(self, i: int, mode: str) -> None:
        m, lim, g = self.model, self.limits[self.joint_names[i]], self.gains[self.joint_names[i]]
        gain, bias, ff = {"position": (g.kp, (0.0, -g.kp, -g.kd), True),
                          "velocity": (g.kv, (0.0, 0.0, -g.kv), True),
                          "effort": (1.0, (0.0, 0.0, 0.0), False)}[mode]
        m.actuator_gainprm[i, :] = 0.0
        m.actuator_gainprm[i, 0] = gain
        m.actuator_biasprm[i, :] = 0.0
        m.actuator_biasprm[i, :3] = bias
        lo, hi = {"position": (lim.lower, lim.upper), "velocity": (-lim.velocity, lim.velocity),
                  "effort": (-lim.effort, lim.effort)}[mode]
        m.actuator_ctrlrange[i] = (max(lo, -1e10), min(hi, 1e10))
        self._ff_mask[i] = ff and self.gravity_feedforward
        self._ff_all, self._ff_any = bool(self._ff_mask.all()), bool(self._ff_mask.any())
        self._modes[i] = mode

    def set_mode(self, joints: str | Sequence[str], mode: str) -> None:
        """Put ``joints`` (one name or several) in ``mode`` ("position", "velocity", "effort").

        The joint's command becomes a hold: its current position in position mode, 0 otherwise,
        so a switch never makes the arm jump (as a ros2_control on_activate should).
        """
        if mode not in MODES:
            raise ValueError(f"mode {mode!r} is not one of {', '.join(MODES)}")
        names = [joints] if isinstance(joints, str) else list(joints)
        idx = [self._joint_index(j) for j in names]
        for i in idx:
            self._apply_mode(i, mode)
            self.commands[i] = self.positions[i] if mode == "position" else 0.0

    def mode(self, joint: str) -> str:
        """The command mode of ``joint``."""
        return self._modes[self._joint_index(joint)]

    @property
    def modes(self) -> dict[str, str]:
        return dict(zip(self.joint_names, self._modes))

    # --- stepping --------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps with the current commands (hot path: no allocation)."""
        if n.__class__ is not int or n < 1:
            raise ValueError(f"step(n={n!r}): n must be an int >= 1")
        total = self.commands.dot(self._ones)  # NaN or inf anywhere makes the sum non-finite
        if not math.isfinite(total):  # a float test: no numpy inf - inf RuntimeWarning
            bad = [(j, float(c)) for j, c in zip(self.joint_names, self.commands) if not math.isfinite(c)]
            raise ValueError(f"non-finite command {bad} at t={self.data.time:.4f} s: MuJoCo would zero "
                             "every control; write finite values to sim.commands")
        m, d, mj_step = self.model, self.data, self._mj.mj_step
        if self._ff_all:  # the feed-forward of each physics step is the previous step's bias force
            bias0, qfrc = self._bias0, self._qfrc_bias
            for _ in range(n):
                bias0[:] = qfrc
                mj_step(m, d)
        elif self._ff_any:
            bias0, qfrc, mask = self._bias0, self._qfrc_bias, self._ff_mask
            for _ in range(n):
                np.copyto(bias0, qfrc, where=mask)
                mj_step(m, d)
        else:
            mj_step(m, d, n)

    @property
    def time(self) -> float:
        """Simulated time in s since the last reset."""
        return self.data.time

    def reset(self, positions: Mapping[str, float] | Sequence[float] | None = None) -> None:
        """Zero time and velocities, put the joints at ``positions`` (default: the URDF's
        initial_value), hold them (position commands = positions; other modes command 0)."""
        q = self.initial_positions.copy()
        if positions is not None:
            if isinstance(positions, Mapping):
                for j, v in positions.items():
                    q[self._joint_index(j)] = v
            else:
                q = _vec(positions, len(self.joint_names), "reset positions").copy()
        for j, v in zip(self.joint_names, q):
            lim = self.limits[j]
            if not math.isfinite(v) or not lim.lower <= v <= lim.upper:
                raise ValueError(f"reset: {j} = {v} is outside its limits [{lim.lower}, {lim.upper}] "
                                 "or not finite")
        m, d = self.model, self.data
        self._mj.mj_resetData(m, d)
        d.qpos[self._spans(self.joint_names)[0]] = q
        for qa, qsrc, c in self._mimic:  # start with every mimic coupling satisfied
            x = d.qpos[qsrc]
            d.qpos[qa] = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * c[4])))
        for i, mode in enumerate(self._modes):
            self.commands[i] = q[i] if mode == "position" else 0.0
        self._bias0[:] = 0.0
        self._mj.mj_forward(m, d)
        np.copyto(self._bias0, self._qfrc_bias, where=self._ff_mask)

    # --- derived quantities --------------------------------------------------------------
    def gravity_torques(self, out: np.ndarray | None = None) -> np.ndarray:
        """Joint torques (N m, N) that hold the robot (and payload) still against gravity at its
        current positions: the rigid-body model's g(q), computed with mj_rne at zero velocity.
        Returns ``out`` or an internal buffer overwritten by the next call. Objects held only by
        contact are not included."""
        mj, m, s = self._mj, self.model, self._scratch
        s.qpos[:] = self.data.qpos
        s.qvel[:] = 0.0
        mj.mj_kinematics(m, s)
        mj.mj_comPos(m, s)
        mj.mj_comVel(m, s)
        mj.mj_rne(m, s, 0, self._rne)
        target = self._gravity if out is None else out
        target[:] = self._rne[self._dofs]
        return target

    @property
    def wrench(self) -> np.ndarray:
        """The force (N) and torque (N m) the tool side (gripper, payload, whatever they touch)
        exerts on the arm at the flange, in the flange frame tool0: [fx, fy, fz, tx, ty, tz].
        A hanging 1 kg payload reads about 9.81 N along world -z. Internal buffer, overwritten."""
        if self._ft is None:
            raise AttributeError(f"{self.name} has no force/torque sensor (the ur5e has one at tool0)")
        np.negative(self._ft, out=self._wrench)
        return self._wrench

    def tool_mass_properties(self) -> tuple[float, np.ndarray]:
        """Mass (kg) and centre of mass (m, in tool0) of everything the F/T sensor carries:
        gripper, fingers at their current opening, payload. What an admittance controller's
        ``gravity_compensation.CoG`` parameters describe."""
        if self._ft is None:
            raise AttributeError(f"{self.name} has no force/torque sensor (the ur5e has one at tool0)")
        b = self._ft_body
        rot = self.data.xmat[b].reshape(3, 3)
        return float(self.model.body_subtreemass[b]), rot.T @ (self.data.subtree_com[b] - self.data.xpos[b])

    def _geom_id(self, geom: str) -> int:
        try:
            return self.model.geom(geom).id
        except KeyError:
            raise ValueError(f"no geom {geom!r} in this simulation (a Wall is named 'wall', "
                             "a GraspObject 'object')") from None

    def contact_force(self, geom: str = "wall") -> np.ndarray:
        """Total contact force (N, world frame) that everything touching ``geom`` exerts on it,
        e.g. how hard the gripper pushes on the wall. A new array."""
        mj, m, d = self._mj, self.model, self.data
        gid = self._geom_id(geom)
        total = np.zeros(3)
        for k in range(d.ncon):
            c = d.contact[k]
            if gid not in (c.geom1, c.geom2):
                continue
            mj.mj_contactForce(m, d, k, self._contact_wrench)
            f = c.frame.reshape(3, 3).T @ self._contact_wrench[:3]  # force on geom2, world frame
            total += f if c.geom2 == gid else -f
        return total

    def touching(self, geom: str = "wall") -> list[str]:
        """Names of the geoms in contact with ``geom`` now ("left_finger/0", ...), sorted, each once."""
        mj, m, d = self._mj, self.model, self.data
        gid = self._geom_id(geom)
        names = set()
        for k in range(d.ncon):
            c = d.contact[k]
            if gid in (c.geom1, c.geom2):
                other = c.geom2 if c.geom1 == gid else c.geom1
                names.add(mj.mj_id2name(m, mj.mjtObj.mjOBJ_GEOM, other) or f"geom{other}")
        return sorted(names)

    def link_pose(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """World position (m) and 3x3 rotation of a URDF link's frame (copies)."""
        try:
            b = self.model.body(link).id
        except KeyError:
            raise ValueError(f"{link!r} is not a link of {self.name}") from None
        return self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()
