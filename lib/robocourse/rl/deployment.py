"""The CRISP deployment: a 50 Hz policy thread, a 500 Hz ros2_control loop, a bridge between them.

Counterparts: the M12.9 seed's deployment (policy inference outside the real-time thread, a
``ForwardCommandController`` at 500-1000 Hz repeating the newest action), unitree's
deploy_mujoco loop and its C++ latest-value buffer, rl_sar's two threads, and unitree's state
sequence (zero torque -> slow move to the default pose -> run; damping kp 0, kd 8 on exit).

Pieces: the controller manager runs the UR5e's ``robocourse/MujocoSystem`` with a
``joint_state_broadcaster``, a ``ForwardCommandController`` on the six arm joints' position
interfaces (``policy_position_controller``) and a ``JointGroupEffortController``
(``damping_effort_controller``) for zero torque and damping. Each control tick the
cerebellum (:meth:`PolicyDeployment.control_tick`) publishes the measured state to the brain's
latest-value buffer, asks the :class:`~robocourse.control.joint_bridge.JointBridge` for this tick's command
(the newest target, or the safe mode after a timeout), writes it to the controller and runs one
read -> update -> write cycle. The brain (:meth:`policy_tick`) builds the observation exactly as
:class:`~robocourse.rl.ArmReachEnv` does, runs the policy runtime, post-processes the action
(scale, EMA, clipping) and submits the target with the observation's time.

Where the pieces live (DESIGN.md's layering): the deployment is chapter 6's, here in ``rl``; the
joint bridge is the shared chapter package's (:mod:`robocourse.control.joint_bridge`) and the
thread set-up a foundation's (:mod:`robocourse.rt.realtime_thread`), so rl imports no other chapter.

``run_simulated`` steps both on simulated time in one thread (deterministic: the policy every
``decimation`` ticks, as in training); ``run_realtime`` runs them on the wall clock in two
threads (the cerebellum configured by :func:`~robocourse.rt.realtime_thread.configure_realtime_thread`) and measures per-thread
loop latency, inference time and the observation -> command age.
"""

from __future__ import annotations

import math
import threading
import time as _time
from dataclasses import dataclass

import numpy as np

from robocourse.control.joint_bridge import DAMPING, HOLD, RUN, JointBridge
from robocourse.rt.realtime_thread import configure_realtime_thread, release_realtime_thread

from .envs import ARM_JOINTS, ArmReachConfig
from .postprocess import ActionProcessor

POSITION_CONTROLLER = "policy_position_controller"
EFFORT_CONTROLLER = "damping_effort_controller"
ZERO_TORQUE, MOVE, RUNNING, EXIT_DAMPING = "zero_torque", "move_to_default", "run", "damping"


def controllers_yaml(update_rate: int, joints=ARM_JOINTS) -> str:
    """The deployment's controller manager parameters (a ROS 2 parameter file as text)."""
    j = "[" + ", ".join(joints) + "]"
    return f"""
controller_manager:
  ros__parameters:
    update_rate: {int(update_rate)}
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    {POSITION_CONTROLLER}:
      type: forward_command_controller/ForwardCommandController
    {EFFORT_CONTROLLER}:
      type: effort_controllers/JointGroupEffortController
{POSITION_CONTROLLER}:
  ros__parameters:
    joints: {j}
    interface_name: position
{EFFORT_CONTROLLER}:
  ros__parameters:
    joints: {j}
"""


@dataclass
class Trace:
    """What a simulated run recorded, one row per control tick (numpy arrays): ``q``, ``dq`` (rad, rad/s),
    ``target`` (the joint commands the servo saw: positions in rad, or torques in N m while an effort
    phase runs), ``tcp_distance`` (m), ``phase`` and ``mode`` ("position", "effort" or "safe")."""

    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    target: np.ndarray
    tcp_distance: np.ndarray
    phase: list
    mode: list

    def joint_acceleration(self) -> np.ndarray:
        """Finite-difference joint acceleration (rad/s^2), one row per tick after the first."""
        return np.diff(self.dq, axis=0) / np.diff(self.t)[:, None]


@dataclass
class RealtimeResult:
    """What :meth:`PolicyDeployment.run_realtime` measured (times in microseconds where named ``_us``)."""

    control: object                     # robocourse.rt LoopResult of the 500 Hz thread
    policy: object | None               # LoopResult of the policy thread (None without a policy)
    inference_us: np.ndarray
    age_us: np.ndarray
    thread_report: object
    final_distance: float
    safe_entries: int

    def summary(self) -> str:
        def pct(a):
            return (f"p50 {np.percentile(a, 50):8.1f}  p99 {np.percentile(a, 99):8.1f}  max {a.max():8.1f}"
                    if len(a) else "(none)")

        c = np.asarray(self.control.latency_ns, dtype=float) / 1e3
        rows = [f"control loop wake-up latency (us): {pct(c)}  overruns {self.control.overruns}",
                f"control tick duration (us):        {pct(np.asarray(self.control.busy_ns, dtype=float) / 1e3)}"]
        if self.policy is not None:
            p = np.asarray(self.policy.latency_ns, dtype=float) / 1e3
            rows.append(f"policy loop wake-up latency (us):  {pct(p)}")
        rows.append(f"inference (us):                    {pct(self.inference_us)}")
        rows.append(f"observation -> command age (us):   {pct(self.age_us)}")
        rows.append(f"final TCP distance {100 * self.final_distance:.1f} cm; safe-mode entries {self.safe_entries}")
        return "\n".join(rows)


class PolicyDeployment:
    """Deploy ``runtime`` (a :class:`~robocourse.rl.PolicyRuntime`) trained on ``env_config``.

    ``update_rate``: the controller manager's rate (Hz); ``policy_rate``: the brain's rate
    (default: the training rate ``1 / (timestep * decimation)``); ``alpha``: EMA weight of the
    previous target; ``joint_order``: the order the policy's observation/action use (default:
    the robot's, :data:`ARM_JOINTS`); ``obs_fn(q_rel, dq_scaled, target_rel, last_action)``
    replaces the observation layout (for the pitfall demonstrations); ``inference_in_rt`` runs
    the policy inside the control thread; ``stall_at`` (s) stops the brain (a dying policy
    thread); ``zero_torque_s``/``move_s`` the start-up phases, ``damping_kd`` the exit damping.
    """

    def __init__(self, runtime, env_config: ArmReachConfig | None = None, *, update_rate: int = 500,
                 policy_rate: float | None = None, alpha: float = 0.0, target=None, joint_order=None,
                 obs_fn=None, timeout: float = 0.5, safe_mode: str = HOLD, inference_in_rt: bool = False,
                 stall_at: float | None = None, zero_torque_s: float = 0.05, move_s: float = 1.0,
                 damping_kd: float = 8.0, context=None):
        from robocourse.control import ControllerManager
        from robocourse.control.hardware.mujoco_system import MujocoSystem
        from robocourse.control.introspection import spawner
        from robocourse.sim.robots import Kinematics, RobotSim, urdf_text

        self.config = c = env_config or ArmReachConfig()
        n = len(ARM_JOINTS)
        if runtime.obs_size != 21 and obs_fn is None:
            raise ValueError(f"the policy takes {runtime.obs_size} observations; the reach task's layout has 21 "
                             "(pass obs_fn to build another layout)")
        if runtime.act_size != n:
            raise ValueError(f"the policy outputs {runtime.act_size} actions; the UR5e arm has {n} joints")
        self.runtime = runtime
        self.update_rate = int(update_rate)
        self.period = 1.0 / self.update_rate
        self.policy_rate = 1.0 / c.policy_dt if policy_rate is None else float(policy_rate)
        self.decimation = self.update_rate / self.policy_rate
        if abs(self.decimation - round(self.decimation)) > 1e-9 or self.decimation < 1:
            raise ValueError(f"update_rate {self.update_rate} Hz / policy_rate {self.policy_rate} Hz must be an "
                             "integer >= 1 (the controller repeats each target a whole number of ticks)")
        self.decimation = int(round(self.decimation))
        self.sim = RobotSim("ur5e", timestep=self.period if self.period <= 0.005 else 0.001)
        self.sim.reset(list(c.default_pose) + [0.04])
        params = {"timestep": str(self.sim.model.opt.timestep)}
        self.cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem", params=params),
                                    params=controllers_yaml(self.update_rate),
                                    components={"UR5e": MujocoSystem(sim=self.sim)}, context=context)
        if not spawner(self.cm, ["joint_state_broadcaster"], quiet=True) or \
                not spawner(self.cm, [POSITION_CONTROLLER, EFFORT_CONTROLLER], inactive=True, quiet=True):
            raise RuntimeError(f"spawning the deployment's controllers failed: {self.cm.log.records[-1].msg}")
        self.position = self.cm.controllers[POSITION_CONTROLLER].c
        self.effort = self.cm.controllers[EFFORT_CONTROLLER].c
        self._keys = [(f"{j}/position", f"{j}/velocity") for j in ARM_JOINTS]
        self.default = np.array(c.default_pose, dtype=float)
        self.tcp_default = Kinematics("ur5e").calculate_link_transform(np.r_[self.default])[:3, 3]
        self.target = self.tcp_default.copy() if target is None else np.asarray(target, dtype=float)
        order = list(ARM_JOINTS) if joint_order is None else list(joint_order)
        if sorted(order) != sorted(ARM_JOINTS):
            raise ValueError(f"joint_order {order} must be a permutation of {list(ARM_JOINTS)}")
        self.perm = np.array([ARM_JOINTS.index(j) for j in order])  # policy index i -> robot joint perm[i]
        self.obs_fn = obs_fn
        lims = self.sim.limits
        self.processor = ActionProcessor(
            self.default, c.action_scale, [lims[j].lower for j in ARM_JOINTS], [lims[j].upper for j in ARM_JOINTS],
            alpha=alpha, clip_actions=c.clip_actions, torque_limit=[lims[j].effort for j in ARM_JOINTS],
            kp=[self.sim.gains[j].kp for j in ARM_JOINTS], kd=[self.sim.gains[j].kd for j in ARM_JOINTS])
        self.bridge = JointBridge(ARM_JOINTS, timeout=timeout, safe_mode=safe_mode)
        self.inference_in_rt, self.stall_at = bool(inference_in_rt), stall_at
        self.zero_torque_s, self.move_s, self.damping_kd = float(zero_torque_s), float(move_s), float(damping_kd)
        # state shared between the threads (the latest-value buffer of observations)
        self._obs_lock = threading.Lock()
        self._q, self._dq = np.zeros(n), np.zeros(n)
        self._q_shared, self._dq_shared, self._t_shared = np.zeros(n), np.zeros(n), -1.0
        self.last_action = np.zeros(n)
        self._effort_cmd = np.zeros(n)
        self.phase, self._phase_t0, self._move_from = None, 0.0, np.zeros(n)
        self._mode = None  # no command controller active yet: the first phase activates one
        self.nan_observations = 0
        self.policy_errors: list[str] = []
        self.inference_ns = np.zeros(200_000, dtype=np.int64)
        self.ages_ns = np.zeros(200_000, dtype=np.int64)
        self.n_inference = self.n_ages = 0
        self.phase_log: list[tuple[float, str]] = []

    # --- helpers ---------------------------------------------------------------------------------------
    def _read_state(self) -> None:
        rm = self.cm.rm
        for i, (kp, kv) in enumerate(self._keys):
            self._q[i] = rm.value(kp)
            self._dq[i] = rm.value(kv)

    def _set_phase(self, phase: str, now: float) -> None:
        self.phase, self._phase_t0 = phase, now
        self.phase_log.append((now, phase))
        if phase in (ZERO_TORQUE, EXIT_DAMPING):
            self._use("effort")
        else:
            self._use("position")
        if phase == MOVE:
            self._move_from = self._q.copy()
        if phase == RUNNING:
            self.processor.reset(self._q)
            self.bridge.submit(self._q, now=now)  # hold here until the brain's first target (no stamp: no age)

    def _use(self, mode: str) -> None:
        if mode == self._mode:
            return
        on, off = (EFFORT_CONTROLLER, POSITION_CONTROLLER) if mode == "effort" else (POSITION_CONTROLLER,
                                                                                      EFFORT_CONTROLLER)
        self.cm.switch_controller([on], [off], strictness=1)
        self._mode = mode

    def build_observation(self, q, dq) -> np.ndarray:
        """The reach task's observation in the policy's joint order (or ``obs_fn``'s layout)."""
        c, p = self.config, self.perm
        q_rel, dq_s = (q - self.default)[p], (dq * c.dof_vel_scale)[p]
        target_rel = self.target - self.tcp_default
        if self.obs_fn is not None:
            return np.asarray(self.obs_fn(q_rel, dq_s, target_rel, self.last_action), dtype=float)
        return np.concatenate([q_rel, dq_s, target_rel, self.last_action])

    # --- the brain ------------------------------------------------------------------------------------
    def policy_tick(self, now: float) -> bool:
        """One inference from the newest observation; submit the target. False when nothing was sent."""
        with self._obs_lock:
            q, dq, t_obs = self._q_shared.copy(), self._dq_shared.copy(), self._t_shared
        if t_obs < 0 or self.phase != RUNNING:
            return False
        obs = self.build_observation(q, dq)
        t0 = _time.perf_counter_ns()
        try:
            raw = self.runtime(obs)
        except ValueError as exc:
            self.nan_observations += "non-finite" in str(exc)
            self.policy_errors.append(str(exc))
            return False
        dt = _time.perf_counter_ns() - t0
        if self.n_inference < len(self.inference_ns):
            self.inference_ns[self.n_inference] = dt
            self.n_inference += 1
        a = np.clip(raw, -self.config.clip_actions, self.config.clip_actions)
        self.last_action = a.copy()
        robot_action = np.empty_like(a)
        robot_action[self.perm] = a
        targets = self.processor(robot_action, q, dq)
        return self.bridge.submit(targets, stamp=t_obs, now=now)

    # --- the cerebellum -------------------------------------------------------------------------------
    def control_tick(self, now: float, wall_ns: int | None = None) -> None:
        """Read state, share it, apply this tick's command, run one controller manager cycle."""
        self._read_state()
        with self._obs_lock:
            self._q_shared[:] = self._q
            self._dq_shared[:] = self._dq
            self._t_shared = now
        if self.phase is None:
            self._set_phase(ZERO_TORQUE if self.zero_torque_s > 0 else MOVE, now)
        elif self.phase == ZERO_TORQUE and now - self._phase_t0 >= self.zero_torque_s:
            self._set_phase(MOVE, now)
        elif self.phase == MOVE and now - self._phase_t0 >= self.move_s:
            self._set_phase(RUNNING, now)
        if self.phase == ZERO_TORQUE:
            self._effort_cmd[:] = 0.0
            self.effort.set_command(self._effort_cmd)
        elif self.phase == MOVE:
            s = min(1.0, (now - self._phase_t0) / self.move_s) if self.move_s > 0 else 1.0
            self.position.set_command(self._move_from + s * (self.default - self._move_from))
        elif self.phase == EXIT_DAMPING:
            self._damp()
        else:
            cmd = self.bridge.update(now, self._q, self._dq)
            if cmd.mode == DAMPING:
                self._use("effort")
                self._damp()
            else:
                self._use("position")
                self.position.set_command(cmd.targets)
                if cmd.mode == RUN and cmd.stamp is not None and self.n_ages < len(self.ages_ns):
                    self.ages_ns[self.n_ages] = int((now - cmd.stamp) * 1e9)
                    self.n_ages += 1
        self.cm.cycle(now, self.period)

    def _damp(self) -> None:
        np.multiply(self._dq, -self.damping_kd, out=self._effort_cmd)
        self.effort.set_command(self._effort_cmd)

    def tcp_distance(self) -> float:
        return float(np.linalg.norm(self.sim.link_pose("tool0")[0] - self.target))

    def _brain_due(self, now: float) -> bool:
        return self.stall_at is None or now < self.stall_at

    # --- runs ---------------------------------------------------------------------------------------
    def run_simulated(self, seconds: float, exit_damping_s: float = 0.0, drawer=None, draw_every: int = 17) -> Trace:
        """Deterministic: ``seconds`` of control ticks on simulated time, the policy every decimation ticks.
        ``drawer``: a :class:`robocourse.viz.MujocoDrawer` of ``self.sim.model`` updated every ``draw_every`` ticks."""
        if not (math.isfinite(seconds) and seconds > 0):
            raise ValueError(f"seconds={seconds!r} must be > 0")
        ticks = int(round(seconds * self.update_rate))
        damp = int(round(exit_damping_s * self.update_rate))
        n = ticks + damp
        t, q, dq, tg, dist = np.zeros(n), np.zeros((n, 6)), np.zeros((n, 6)), np.zeros((n, 6)), np.zeros(n)
        phases, modes = [], []
        t0 = self.cm.time
        for k in range(n):
            now = t0 + (k + 1) * self.period
            if k == ticks and damp:
                self._set_phase(EXIT_DAMPING, now)
            if self.phase == RUNNING and (k % self.decimation == 0) and self._brain_due(now):
                self._share_now(now)
                self.policy_tick(now)
            self.control_tick(now)
            t[k], q[k], dq[k], dist[k] = now, self._q, self._dq, self.tcp_distance()
            tg[k] = self.sim.commands[:6]
            phases.append(self.phase)
            modes.append("safe" if self.bridge.safe else self._mode)
            if drawer is not None and k % draw_every == 0:
                drawer.scene.set_time(now)
                drawer.update(self.sim.data)
        return Trace(t, q, dq, tg, dist, phases, modes)

    def _share_now(self, now: float) -> None:
        """Deterministic path: the brain sees the state at ``now`` (as the env's policy step does)."""
        self._read_state()
        with self._obs_lock:
            self._q_shared[:] = self._q
            self._dq_shared[:] = self._dq
            self._t_shared = now

    def run_realtime(self, seconds: float, with_policy: bool = True, priority: int = 80,
                     wait=None) -> RealtimeResult:
        """Wall clock: the control loop in a thread named 'cerebellum' (SCHED_FIFO ``priority`` when
        allowed), the policy in a thread named 'brain' at ``policy_rate`` (or inside the control
        loop with ``inference_in_rt``). ``with_policy=False`` runs the same control loop with no
        brain (the baseline: the bridge holds the start-up pose)."""
        from robocourse.rt import Hybrid, PeriodicLoop, Sleep

        ticks = max(1, int(round(seconds * self.update_rate)))
        period_ns = int(round(1e9 / self.update_rate))
        out: dict = {}
        stop, started = threading.Event(), threading.Event()
        start_t = self.cm.time
        policy_every = self.decimation

        def cerebellum():
            report = configure_realtime_thread("cerebellum", "fifo", priority)
            out["report"] = report
            # the clock starts after the configuration: mlockall of a large process takes a while
            start = out["start"] = _time.monotonic_ns()
            started.set()

            def cb(tick):
                now = start_t + (tick.deadline_ns - start) * 1e-9
                if with_policy and self.inference_in_rt and tick.iteration % policy_every == 0 \
                        and self._brain_due(now):
                    self.policy_tick(now)
                self.control_tick(now)

            try:
                out["control"] = PeriodicLoop(period_ns, ticks, wait or Hybrid()).run(cb, start_ns=start)
            finally:
                stop.set()
                release_realtime_thread(report)

        def brain():
            threading.current_thread().name = "brain"
            started.wait()
            start = out["start"]
            ppn = int(round(1e9 / self.policy_rate))
            loop = PeriodicLoop(ppn, 0, Sleep())

            def cb(tick):
                if stop.is_set():
                    loop.stop()
                    return
                now = start_t + (tick.wake_ns - start) * 1e-9
                if self._brain_due(now):
                    self.policy_tick(now)

            out["policy"] = loop.run(cb, start_ns=start)

        threads = [threading.Thread(target=cerebellum, name="cerebellum", daemon=True)]
        if with_policy and not self.inference_in_rt:
            threads.append(threading.Thread(target=brain, name="brain", daemon=True))
        for th in threads:
            th.start()
        for th in threads:
            th.join(seconds + 30.0)
        if "control" not in out:
            raise RuntimeError("the control thread did not finish")
        return RealtimeResult(out["control"], out.get("policy"), self.inference_ns[:self.n_inference] / 1e3,
                              self.ages_ns[:self.n_ages] / 1e3, out.get("report"), self.tcp_distance(),
                              self.bridge.safe_entries)
