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

The brain reads what ``/joint_states`` carries: the joint_state_broadcaster's joints in its
order (the resource manager's, sorted by name here), and looks each joint up by name
(:class:`~robocourse.rl.brain.Brain`; ``obs_by_name=False`` is the index-order bug).

``run_simulated`` steps both on simulated time in one thread (deterministic: the policy every
``decimation`` ticks, as in training); ``run_realtime`` runs them on the wall clock with the
brain placed by ``placement``: ``"in_loop"`` (inside the control thread, every ``decimation``
ticks), ``"thread"`` (a 'brain' thread of this process, handing over through the bridge's
lock) or ``"process"`` (a process of its own, handing over through shared-memory latest-value
buffers the control thread only ever try-locks). The control thread is configured by
:func:`~robocourse.rt.realtime_thread.configure_realtime_thread`; each run measures loop
latency, tick durations, inference time and the observation -> command age.

The control stack's log lines (controller manager, resource manager) are kept in
``self.cm.log`` and not printed unless ``log=LogSink()`` is passed.
"""

from __future__ import annotations

import math
import threading
import time as _time
from dataclasses import dataclass

import numpy as np

from robocourse.control.joint_bridge import DAMPING, HOLD, RUN, JointBridge
from robocourse.rt.realtime_thread import configure_realtime_thread, release_realtime_thread

from .brain import Brain
from .envs import ARM_JOINTS, ArmReachConfig
from .handover import LatestValue, SharedLatestValue
from .postprocess import ActionProcessor

PLACEMENTS = ("in_loop", "thread", "process")

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
    """What :meth:`PolicyDeployment.run_realtime` measured (times in microseconds where named ``_us``).

    ``stats()``, ``latency_ns`` and ``busy_ns`` are the control loop's, so a result is a run for
    :func:`robocourse.rt.repeat.measure_rounds` (metrics "p99", "max", "overruns", "busy p99" ...).
    """

    placement: str                      # "none" (no brain), "in_loop", "thread" or "process"
    control: object                     # robocourse.rt LoopResult of the 500 Hz thread
    policy_latency_us: np.ndarray       # wake-up latency of the brain's own loop (empty in the loop / none)
    inference_us: np.ndarray
    age_us: np.ndarray
    thread_report: object
    final_distance: float
    safe_entries: int
    targets: int                        # new targets that reached the control loop

    def stats(self):
        return self.control.stats()

    @property
    def latency_ns(self) -> np.ndarray:
        return self.control.latency_ns

    @property
    def busy_ns(self) -> np.ndarray:
        return self.control.busy_ns

    def summary(self) -> str:
        def pct(a):
            return (f"p50 {np.percentile(a, 50):8.1f}  p99 {np.percentile(a, 99):8.1f}  max {a.max():8.1f}"
                    if len(a) else "(none)")

        c = np.asarray(self.control.latency_ns, dtype=float) / 1e3
        rows = [f"brain placement: {self.placement}",
                f"control loop wake-up latency (us): {pct(c)}  overruns {self.control.overruns}",
                f"control tick duration (us):        {pct(np.asarray(self.control.busy_ns, dtype=float) / 1e3)}"]
        if len(self.policy_latency_us):
            rows.append(f"policy loop wake-up latency (us):  {pct(self.policy_latency_us)}")
        rows.append(f"inference (us):                    {pct(self.inference_us)}")
        rows.append(f"observation -> command age (us):   {pct(self.age_us)}")
        rows.append(f"final TCP distance {100 * self.final_distance:.1f} cm; targets received {self.targets}; "
                    f"safe-mode entries {self.safe_entries}")
        return "\n".join(rows)


class PolicyDeployment:
    """Deploy ``runtime`` (a :class:`~robocourse.rl.PolicyRuntime`) trained on ``env_config``.

    ``update_rate``: the controller manager's rate (Hz); ``policy_rate``: the brain's rate
    (default: the training rate ``1 / (timestep * decimation)``); ``alpha``: EMA weight of the
    previous target; ``joint_order``: the order the policy's observation/action use (default:
    the robot's, :data:`ARM_JOINTS`); ``obs_by_name=False`` reads /joint_states in its own
    order (the joint-order bug); ``obs_fn(q_rel, dq_scaled, target_rel, last_action)``
    replaces the observation layout (for the pitfall demonstrations); ``placement`` where
    ``run_realtime`` runs the brain (:data:`PLACEMENTS`); ``servo_gains`` replaces the robot's
    servo gains (``{joint: ServoGains}``: a robot tuned differently from the training sim);
    ``stall_at`` (s) stops the brain (a dying policy); ``zero_torque_s``/``move_s`` the start-up
    phases, ``damping_kd`` the damping gain (exit and safe mode; per joint capped where a damping
    computed once per tick stays stable: ``damping_kds``); ``log`` the control stack's
    :class:`~robocourse.control.log.LogSink` (default: records kept, nothing printed).
    """

    def __init__(self, runtime, env_config: ArmReachConfig | None = None, *, update_rate: int = 500,
                 policy_rate: float | None = None, alpha: float = 0.0, target=None, joint_order=None,
                 obs_by_name: bool = True, obs_fn=None, timeout: float = 0.5, safe_mode: str = HOLD,
                 placement: str = "thread", servo_gains=None, stall_at: float | None = None,
                 zero_torque_s: float = 0.05, move_s: float = 1.0, damping_kd: float = 8.0, context=None, log=None):
        from robocourse.control import ControllerManager
        from robocourse.control.hardware.mujoco_system import MujocoSystem
        from robocourse.control.introspection import spawner
        from robocourse.control.log import LogSink
        from robocourse.sim.robots import Kinematics, RobotSim, urdf_text

        self.config = c = env_config or ArmReachConfig()
        n = len(ARM_JOINTS)
        if placement not in PLACEMENTS:
            raise ValueError(f"placement={placement!r} must be one of {', '.join(PLACEMENTS)}")
        if runtime.obs_size != 21 and obs_fn is None:
            raise ValueError(f"the policy takes {runtime.obs_size} observations; the reach task's layout has 21 "
                             "(pass obs_fn to build another layout)")
        if runtime.act_size != n:
            raise ValueError(f"the policy outputs {runtime.act_size} actions; the UR5e arm has {n} joints")
        self.runtime = runtime
        self.placement = placement
        self.update_rate = int(update_rate)
        self.period = 1.0 / self.update_rate
        self.policy_rate = 1.0 / c.policy_dt if policy_rate is None else float(policy_rate)
        self.decimation = self.update_rate / self.policy_rate
        if abs(self.decimation - round(self.decimation)) > 1e-9 or self.decimation < 1:
            raise ValueError(f"update_rate {self.update_rate} Hz / policy_rate {self.policy_rate} Hz must be an "
                             "integer >= 1 (the controller repeats each target a whole number of ticks)")
        self.decimation = int(round(self.decimation))
        self.sim = RobotSim("ur5e", timestep=self.period if self.period <= 0.005 else 0.001, gains=servo_gains)
        self.sim.reset(list(c.default_pose) + [0.04])
        params = {"timestep": str(self.sim.model.opt.timestep)}
        self.cm = ControllerManager(urdf_text("ur5e", plugin="robocourse/MujocoSystem", params=params),
                                    params=controllers_yaml(self.update_rate),
                                    components={"UR5e": MujocoSystem(sim=self.sim)}, context=context,
                                    log=log if log is not None else LogSink(log_to_stderr=False))
        if not spawner(self.cm, ["joint_state_broadcaster"], quiet=True) or \
                not spawner(self.cm, [POSITION_CONTROLLER, EFFORT_CONTROLLER], inactive=True, quiet=True):
            raise RuntimeError(f"spawning the deployment's controllers failed: {self.cm.log.records[-1].msg}")
        self.position = self.cm.controllers[POSITION_CONTROLLER].c
        self.effort = self.cm.controllers[EFFORT_CONTROLLER].c
        self._keys = [(f"{j}/position", f"{j}/velocity") for j in ARM_JOINTS]
        # what /joint_states carries: the broadcaster's joints, in its order
        self.state_names = list(self.cm.controllers["joint_state_broadcaster"].c.joint_names)
        self._state_keys = [(f"{j}/position", f"{j}/velocity") for j in self.state_names]
        ns = len(self.state_names)
        self._state = np.zeros(2 * ns)
        self.default = np.array(c.default_pose, dtype=float)
        self.tcp_default = Kinematics("ur5e").calculate_link_transform(np.r_[self.default])[:3, 3]
        self.target = self.tcp_default.copy() if target is None else np.asarray(target, dtype=float)
        lims = self.sim.limits
        self._processor_args = dict(
            default_pose=self.default.tolist(), action_scale=c.action_scale,
            lower=[lims[j].lower for j in ARM_JOINTS], upper=[lims[j].upper for j in ARM_JOINTS], alpha=alpha,
            clip_actions=c.clip_actions, torque_limit=[lims[j].effort for j in ARM_JOINTS],
            kp=[self.sim.gains[j].kp for j in ARM_JOINTS], kd=[self.sim.gains[j].kd for j in ARM_JOINTS])
        self.processor = ActionProcessor(**self._processor_args)
        self.brain = Brain(runtime, c, self.processor, target=self.target, tcp_default=self.tcp_default,
                           joint_order=joint_order, obs_fn=obs_fn, by_name=obs_by_name)
        self._brain_args = dict(joint_order=self.brain.joint_order, obs_fn=obs_fn, by_name=bool(obs_by_name))
        self.perm = self.brain.perm
        self.bridge = JointBridge(ARM_JOINTS, timeout=timeout, safe_mode=safe_mode)
        self.stall_at = stall_at
        self.zero_torque_s, self.move_s, self.damping_kd = float(zero_torque_s), float(move_s), float(damping_kd)
        self.damping_kds = self._sampled_damping_gains(self.damping_kd)
        # the latest-value buffer of /joint_states between the cerebellum and a brain in this process
        self._shared = LatestValue(2 * ns)
        self._brain_buf = np.zeros(2 * ns)
        self._q, self._dq = np.zeros(n), np.zeros(n)
        self._effort_cmd = np.zeros(n)
        self.phase, self._phase_t0, self._move_from = None, 0.0, np.zeros(n)
        self._mode = None  # no command controller active yet: the first phase activates one
        self.ages_ns = np.zeros(200_000, dtype=np.int64)
        self.n_ages = 0
        self.phase_log: list[tuple[float, str]] = []

    # --- what the brain measured (kept on the brain; here for the notebook's convenience) ---------------
    @property
    def nan_observations(self) -> int:
        return self.brain.nan_observations

    @property
    def policy_errors(self) -> list[str]:
        return self.brain.policy_errors

    @property
    def last_action(self) -> np.ndarray:
        return self.brain.last_action

    # --- helpers ---------------------------------------------------------------------------------------
    def _read_state(self) -> None:
        rm = self.cm.rm
        for i, (kp, kv) in enumerate(self._keys):
            self._q[i] = rm.value(kp)
            self._dq[i] = rm.value(kv)
        st, ns = self._state, len(self._state_keys)
        for i, (kp, kv) in enumerate(self._state_keys):
            st[i] = rm.value(kp)
            st[ns + i] = rm.value(kv)

    def joint_states(self):
        """This tick's /joint_states as the broadcaster builds it (sensor_msgs/JointState, its joint order)."""
        from robocourse.msgs.sensor_msgs import JointState

        ns = len(self.state_names)
        return JointState(name=list(self.state_names), position=self._state[:ns].tolist(),
                          velocity=self._state[ns:].tolist())

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
        self.cm.switch_controller([on], [off], strictness=1, timeout=1.0)
        self._mode = mode

    def build_observation(self, q, dq) -> np.ndarray:
        """The reach observation from positions/velocities in the robot's order (:data:`ARM_JOINTS`)."""
        return self.brain.observation(ARM_JOINTS, q, dq)

    # --- the brain ------------------------------------------------------------------------------------
    def policy_tick(self, now: float) -> bool:
        """One inference from the newest /joint_states; submit the target. False when nothing was sent."""
        seq, t_obs = self._shared.read_into(self._brain_buf)
        if seq == 0 or self.phase != RUNNING:
            return False
        ns = len(self.state_names)
        targets = self.brain.step(self.state_names, self._brain_buf[:ns], self._brain_buf[ns:])
        if targets is None:
            return False
        return self.bridge.submit(targets, stamp=t_obs, now=now)

    # --- the cerebellum -------------------------------------------------------------------------------
    def control_tick(self, now: float, share=None) -> None:
        """Read state, share it, apply this tick's command, run one controller manager cycle.

        ``share(state, now)`` hands /joint_states to the brain (default: this process's latest-value buffer).
        """
        self._read_state()
        if share is None:
            self._shared.write(self._state, now)
        else:
            share(self._state, now)
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

    def _sampled_damping_gains(self, kd: float) -> np.ndarray:
        """Per joint: ``kd``, capped at half of M_jj / period. The damping torque is computed once per
        control tick from the measured velocity and held for the tick; above about M_jj / period the
        sampled loop overshoots (the velocity changes sign every tick and grows): the UR5e's wrist_3
        (M_jj ~ 0.003 kg m^2) at ``kd`` 8 and 500 Hz would chatter. A drive's own damping runs at its
        current-loop rate, far above ours; on real arms the rotor inertia behind the gearbox adds to M_jj."""
        import mujoco

        if not (math.isfinite(kd) and kd >= 0):
            raise ValueError(f"damping_kd={kd!r} must be a finite gain >= 0 (N m s/rad), e.g. 8.0")
        m, d = self.sim.model, self.sim.data
        mujoco.mj_forward(m, d)
        out = np.empty(len(ARM_JOINTS))
        unit, res = np.zeros(m.nv), np.zeros(m.nv)
        for i, j in enumerate(ARM_JOINTS):
            dof = int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)])
            unit[:] = 0.0
            unit[dof] = 1.0
            mujoco.mj_mulM(m, d, res, unit)
            out[i] = min(kd, 0.5 * float(res[dof]) / self.period)
        return out

    def _damp(self) -> None:
        np.multiply(self._dq, -1.0, out=self._effort_cmd)
        self._effort_cmd *= self.damping_kds
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
                self._read_state()                    # the brain sees the state at `now`, as the env's step does
                self._shared.write(self._state, now)
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

    def _process_spec(self) -> dict:
        path = getattr(self.runtime, "path", None)
        if path is None:
            raise ValueError("placement='process' loads the policy again in the brain's process: use a runtime "
                             "made from a file (OnnxRuntime(path) or load_runtime(path))")
        q_start = self._q.copy()
        return {"policy_path": str(path), "io_binding": getattr(self.runtime, "io_binding", True),
                "config": self.config.as_dict(), "processor": self._processor_args, "q_start": q_start.tolist(),
                "target": self.target.tolist(), "tcp_default": self.tcp_default.tolist(),
                "robot_joints": list(ARM_JOINTS), "state_names": list(self.state_names),
                "policy_rate": self.policy_rate, "stall_at": self.stall_at, **self._brain_args}

    def run_realtime(self, seconds: float, with_policy: bool = True, priority: int = 80,
                     wait=None, placement: str | None = None) -> RealtimeResult:
        """Wall clock: the control loop in a thread named 'cerebellum' (SCHED_FIFO ``priority`` when
        allowed), the brain placed by ``placement`` (default: the constructor's): inside the control
        loop every ``decimation`` ticks, in a thread named 'brain' at ``policy_rate``, or in a process
        of its own at ``policy_rate``. ``with_policy=False`` runs the same control loop with no brain
        (the baseline: the bridge holds the start-up pose)."""
        from robocourse.rt import Hybrid, PeriodicLoop, Sleep

        placement = self.placement if placement is None else placement
        if placement not in PLACEMENTS:
            raise ValueError(f"placement={placement!r} must be one of {', '.join(PLACEMENTS)}")
        if not with_policy:
            placement = "none"
        ticks = max(1, int(round(seconds * self.update_rate)))
        period_ns = int(round(1e9 / self.update_rate))
        out: dict = {}
        stop, started = threading.Event(), threading.Event()
        start_t = self.cm.time
        policy_every = self.decimation
        proc = conn = state_shm = target_shm = None
        share = None
        targets_in = [0]
        if placement == "process":
            import multiprocessing as mp

            from .brain import brain_process_main

            self._read_state()
            ns = len(self.state_names)
            state_shm, target_shm = SharedLatestValue(2 * ns), SharedLatestValue(len(ARM_JOINTS))
            ctx = mp.get_context("spawn")
            conn, child_conn = ctx.Pipe()
            proc = ctx.Process(target=brain_process_main, name="brain",
                               args=(self._process_spec(), state_shm.spec(), target_shm.spec(), child_conn),
                               daemon=True)
            proc.start()
            if not conn.poll(60.0) or conn.recv() != "ready":
                proc.kill()
                raise RuntimeError("the brain process did not start within 60 s")
            tbuf, last_seq = np.zeros(len(ARM_JOINTS)), [0]

            def share(state, now):
                # never waits: skipped when the brain holds the lock; stamped NaN until the run phase
                state_shm.try_write(state, now if self.phase == RUNNING else math.nan)
                got = target_shm.try_read_into(tbuf)
                if got is not None and got[0] != last_seq[0] and self.phase == RUNNING:
                    last_seq[0] = got[0]
                    targets_in[0] += self.bridge.submit(tbuf, stamp=got[1], now=now)

        def cerebellum():
            report = configure_realtime_thread("cerebellum", "fifo", priority)
            out["report"] = report
            # the clock starts after the configuration: mlockall of a large process takes a while
            start = out["start"] = _time.monotonic_ns()
            if conn is not None:
                conn.send((start, start_t))
            started.set()

            def cb(tick):
                now = start_t + (tick.deadline_ns - start) * 1e-9
                if placement == "in_loop" and tick.iteration % policy_every == 0 and self._brain_due(now):
                    self._read_state()
                    self._shared.write(self._state, now)
                    targets_in[0] += self.policy_tick(now)
                self.control_tick(now, share)

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
                    targets_in[0] += self.policy_tick(now)

            out["policy"] = loop.run(cb, start_ns=start)

        threads = [threading.Thread(target=cerebellum, name="cerebellum", daemon=True)]
        if placement == "thread":
            threads.append(threading.Thread(target=brain, name="brain", daemon=True))
        try:
            for th in threads:
                th.start()
            for th in threads:
                th.join(seconds + 30.0)
        finally:
            child = {}
            if proc is not None:
                try:
                    conn.send("stop")
                    if conn.poll(10.0):
                        child = conn.recv()
                finally:
                    proc.join(5.0)
                    if proc.is_alive():
                        proc.kill()
                    state_shm.close()
                    target_shm.close()
        if "control" not in out:
            raise RuntimeError("the control thread did not finish")
        if placement == "process":
            policy_lat = np.asarray(child.get("latency_ns", []), dtype=float) / 1e3
            inference = np.asarray(child.get("inference_ns", []), dtype=float) / 1e3
            self.brain.policy_errors.extend(child.get("errors", []))
        else:
            pol = out.get("policy")
            policy_lat = np.asarray(pol.latency_ns, dtype=float) / 1e3 if pol is not None else np.zeros(0)
            inference = self.brain.inference_ns[:self.brain.n_inference] / 1e3
        return RealtimeResult(placement, out["control"], policy_lat, inference, self.ages_ns[:self.n_ages] / 1e3,
                              out.get("report"), self.tcp_distance(), self.bridge.safe_entries, targets_in[0])
