"""The brain of a deployment: /joint_states -> observation (by joint name) -> policy -> joint targets.

Counterparts: the policy node of a ROS 2 deployment (the M12.9 seed's CRISP policy, unitree's
deploy_real, rl_sar's ``RunModel``): it reads the newest ``sensor_msgs/JointState``, builds the
observation the policy was trained on, runs the network and hands the joint targets to the
control loop. Everything here runs outside the real-time loop: in a thread of the control
process, or in a process of its own (:func:`brain_process_main`, started by
:class:`~robocourse.rl.deployment.PolicyDeployment` with ``placement="process"``).

``/joint_states`` does not promise an order: a ``joint_state_broadcaster`` configured without
a ``joints`` list publishes the joints in the order the resource manager holds them (ours:
sorted by name, as UR's ROS driver did: ``elbow_joint`` first), while the policy was trained
in the robot description's order. :meth:`Brain.observation` looks every joint up by name
(``by_name=False`` reproduces the bug of reading the message's arrays in their own order).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .postprocess import ActionProcessor
from .reach_config import ARM_JOINTS, ArmReachConfig


class Brain:
    """Observation by name, inference, post-processing; see the module docstring.

    ``joint_order``: the policy's joint order (its observation and action); ``robot_joints``:
    the order of the targets handed to the controller (the ForwardCommandController's
    ``joints``); ``obs_fn(q_rel, dq_scaled, target_rel, last_action)`` replaces the layout.
    """

    def __init__(self, runtime, config: ArmReachConfig, processor: ActionProcessor, *, target, tcp_default,
                 joint_order=None, robot_joints=ARM_JOINTS, obs_fn=None, by_name: bool = True):
        self.runtime, self.config, self.processor = runtime, config, processor
        self.robot_joints = list(robot_joints)
        order = list(self.robot_joints) if joint_order is None else list(joint_order)
        if sorted(order) != sorted(self.robot_joints):
            raise ValueError(f"joint_order {order} must be a permutation of {self.robot_joints}")
        self.joint_order = order
        self.perm = np.array([self.robot_joints.index(j) for j in order])  # policy index i -> robot joint perm[i]
        self.default_policy = np.asarray(config.default_pose, dtype=float)[self.perm]
        self.target = np.asarray(target, dtype=float)
        self.tcp_default = np.asarray(tcp_default, dtype=float)
        self.obs_fn, self.by_name = obs_fn, bool(by_name)
        self.last_action = np.zeros(len(order))
        self._names: tuple | None = None
        self._policy_idx = self._robot_idx = None
        self.inference_ns = np.zeros(100_000, dtype=np.int64)
        self.n_inference = 0
        self.nan_observations = 0
        self.policy_errors: list[str] = []

    def _index(self, names) -> None:
        names = tuple(names)
        if names == self._names:
            return
        missing = [j for j in self.robot_joints if j not in names]
        if missing:
            raise ValueError(f"/joint_states has no {missing} (it names {list(names)}); the policy needs "
                             f"{self.joint_order}")
        self._names = names
        self._policy_idx = np.array([names.index(j) for j in self.joint_order])
        self._robot_idx = np.array([names.index(j) for j in self.robot_joints])

    def robot_state(self, names, position, velocity) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities in the controller's joint order (always by name)."""
        self._index(names)
        return np.asarray(position)[self._robot_idx], np.asarray(velocity)[self._robot_idx]

    def observation(self, names, position, velocity) -> np.ndarray:
        """The reach observation from a /joint_states message's names, positions and velocities."""
        c = self.config
        position, velocity = np.asarray(position, dtype=float), np.asarray(velocity, dtype=float)
        if self.by_name:
            self._index(names)
            q, dq = position[self._policy_idx], velocity[self._policy_idx]
        else:  # the bug: the message's first joints, in the message's order
            n = len(self.joint_order)
            q, dq = position[:n], velocity[:n]
        q_rel, dq_s = q - self.default_policy, dq * c.dof_vel_scale
        target_rel = self.target - self.tcp_default
        if self.obs_fn is not None:
            return np.asarray(self.obs_fn(q_rel, dq_s, target_rel, self.last_action), dtype=float)
        return np.concatenate([q_rel, dq_s, target_rel, self.last_action])

    def step(self, names, position, velocity) -> np.ndarray | None:
        """One policy step from one /joint_states sample; the targets in ``robot_joints`` order, or None."""
        obs = self.observation(names, position, velocity)
        t0 = time.perf_counter_ns()
        try:
            raw = self.runtime(obs)
        except ValueError as exc:
            self.nan_observations += "non-finite" in str(exc)
            self.policy_errors.append(str(exc))
            return None
        dt = time.perf_counter_ns() - t0
        if self.n_inference < len(self.inference_ns):
            self.inference_ns[self.n_inference] = dt
            self.n_inference += 1
        a = np.clip(raw, -self.config.clip_actions, self.config.clip_actions)
        self.last_action = a.copy()
        robot_action = np.empty_like(a)
        robot_action[self.perm] = a
        q, dq = self.robot_state(names, position, velocity)
        return self.processor(robot_action, q, dq)


def brain_process_main(spec: dict, state_spec: tuple, target_spec: tuple, conn) -> None:
    """The brain in a process of its own (started with multiprocessing's spawn by PolicyDeployment).

    Protocol on ``conn`` (a Pipe end): sends ``"ready"`` once the runtime is loaded, receives
    ``(start_ns, start_t)`` (CLOCK_MONOTONIC ns and the deployment's time at that instant),
    runs at ``spec["policy_rate"]`` until it receives ``"stop"``, then sends its measurements.
    The state comes from, and the targets go to, :class:`~robocourse.rl.handover.SharedLatestValue`.
    """
    from robocourse.rt import PeriodicLoop, Sleep

    from .handover import SharedLatestValue
    from .runtime import load_runtime

    runtime = load_runtime(spec["policy_path"], io_binding=spec.get("io_binding", True))
    config = ArmReachConfig(**spec["config"])
    processor = ActionProcessor(**spec["processor"])
    processor.reset(spec["q_start"])
    brain = Brain(runtime, config, processor, target=spec["target"], tcp_default=spec["tcp_default"],
                  joint_order=spec["joint_order"], robot_joints=spec["robot_joints"], obs_fn=spec.get("obs_fn"),
                  by_name=spec.get("by_name", True))
    names = list(spec["state_names"])
    n = len(names)
    observed = SharedLatestValue.attach(state_spec)
    commanded = SharedLatestValue.attach(target_spec)
    buf = np.zeros(2 * n)
    conn.send("ready")
    start_ns, start_t = conn.recv()
    stall_at = spec.get("stall_at")
    period_ns = int(round(1e9 / spec["policy_rate"]))
    loop = PeriodicLoop(period_ns, 0, Sleep())
    sent = [0]

    def tick(t):
        if conn.poll():
            conn.recv()
            loop.stop()
            return
        now = start_t + (t.wake_ns - start_ns) * 1e-9
        if stall_at is not None and now >= stall_at:
            return
        seq, stamp = observed.read_into(buf)
        if seq == 0 or not math.isfinite(stamp):
            return
        out = brain.step(names, buf[:n], buf[n:])
        if out is not None:
            commanded.write(out, stamp)
            sent[0] += 1

    result = loop.run(tick, start_ns=start_ns)
    conn.send({"latency_ns": np.asarray(result.latency_ns), "busy_ns": np.asarray(result.busy_ns),
               "inference_ns": brain.inference_ns[:brain.n_inference].copy(), "sent": sent[0],
               "errors": brain.policy_errors[:5], "clipped": (processor.clipped_joint, processor.clipped_torque)})
    observed.close()
    commanded.close()
