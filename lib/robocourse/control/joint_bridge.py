"""JointBridge: the brain/cerebellum bridge with a dimension check, a command timeout and a safe mode.

Counterpart: the bridge article's ``RobotJointBridge`` (rclpy): it publishes ``/joint_states``
(sensor_msgs/JointState) from the robot, subscribes ``/joint_targets``
(std_msgs/Float64MultiArray) with KEEP_LAST 1 (only the newest target matters), rejects a
target whose size differs from the joint count, and when no target has arrived for
``timeout`` (0.5 s) drops the robot into a safe mode: ``"hold"`` (keep the position measured
when the timeout fired) or ``"damping"`` (kp = 0, tau = -kd dq, unitree's damping state). The
warning is throttled (once per ``warn_period``); the bridge leaves the safe mode only on a
target received after it entered it. The same checks serve the in-process hand-off
(:meth:`submit`, thread-safe: the latest-value buffer of unitree's C++ deployment).

The cerebellum calls :meth:`update(now, q)` every control tick and applies the returned
:class:`BridgeCommand`. Times are seconds on the caller's clock (wall or simulated).
Where we differ: the article's message text is not available to us; ours names both sizes.
It lives in ``control``, the chapter package others may build on (DESIGN.md), because the
cerebellum side is the control loop's and any later chapter that feeds it commands may use it.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from robocourse.bus import HistoryPolicy, QoSProfile
from robocourse.msgs.sensor_msgs import JointState
from robocourse.msgs.std_msgs import Float64MultiArray

RUN, HOLD, DAMPING = "run", "hold", "damping"


@dataclass
class BridgeCommand:
    """What the cerebellum applies this tick: ``mode`` and ``targets`` (positions; unused in damping),
    ``stamp`` (the time of the observation the target was computed from, or None)."""

    mode: str
    targets: np.ndarray
    stamp: float | None


class JointBridge:
    """Bridge between a policy (the brain) and a joint servo loop (the cerebellum); see the module docstring."""

    def __init__(self, joint_names, *, context=None, node_name: str = "joint_bridge", timeout: float = 0.5,
                 safe_mode: str = HOLD, warn_period: float = 1.0):
        self.joint_names = list(joint_names)
        if not self.joint_names:
            raise ValueError("JointBridge needs at least one joint name")
        if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"timeout={timeout!r} s must be a finite number > 0, e.g. 0.5")
        if safe_mode not in (HOLD, DAMPING):
            raise ValueError(f"safe_mode={safe_mode!r} must be 'hold' or 'damping'")
        self.n = len(self.joint_names)
        self.timeout, self.safe_mode, self.warn_period = float(timeout), safe_mode, float(warn_period)
        self._lock = threading.Lock()
        self._target = np.zeros(self.n)
        self._stamp: float | None = None      # observation time the target came from
        self._received: float | None = None   # when the bridge got it
        self._seq = 0
        self._now = 0.0
        self.safe = False
        self.safe_since: float | None = None
        self._seq_at_entry = 0
        self._held = np.zeros(self.n)
        self._out = np.zeros(self.n)
        self._last_warn = -math.inf
        self.safe_entries = 0
        self.rejected_dimension = 0
        self.rejected_non_finite = 0
        self.accepted = 0
        self.warnings = 0
        self.warnings_suppressed = 0
        self.log: list[str] = []
        self.node = self.publisher = None
        if context is not None:
            self.node = context.create_node(node_name)
            self.publisher = self.node.create_publisher(JointState, "/joint_states", 10)
            self.node.create_subscription(Float64MultiArray, "/joint_targets", self._on_targets,
                                          QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1))

    # --- brain side ----------------------------------------------------------------------------
    def _on_targets(self, msg) -> None:
        self.submit(msg.data)

    def submit(self, targets, stamp: float | None = None, now: float | None = None) -> bool:
        """Hand over a target vector (thread-safe). Returns False (and counts, logs) when rejected."""
        data = np.asarray(targets, dtype=float).reshape(-1)
        if data.size != self.n:
            self.rejected_dimension += 1
            self._error(f"Dimension mismatch: received {data.size} joint targets, expected {self.n} "
                        f"({', '.join(self.joint_names)}); target ignored")
            return False
        if not np.all(np.isfinite(data)):
            self.rejected_non_finite += 1
            self._error(f"joint target with non-finite values at {np.flatnonzero(~np.isfinite(data)).tolist()}; "
                        "target ignored")
            return False
        with self._lock:
            self._target[:] = data
            self._received = self._now if now is None else float(now)
            self._stamp = None if stamp is None else float(stamp)
            self._seq += 1
            self.accepted += 1
        return True

    def _error(self, text: str) -> None:
        self.log.append(text)
        if self.node is not None:
            self.node.get_logger().error(text)

    @property
    def last_received(self) -> float | None:
        """When the newest accepted target arrived (None before the first)."""
        return self._received

    # --- cerebellum side ---------------------------------------------------------------------------
    def update(self, now: float, q, dq=None) -> BridgeCommand:
        """The command for this control tick at time ``now`` with measured positions ``q``."""
        self._now = now
        with self._lock:
            received, stamp, seq = self._received, self._stamp, self._seq
            np.copyto(self._out, self._target)
        fresh = received is not None and now - received <= self.timeout
        if self.safe:
            if fresh and seq > self._seq_at_entry:
                self.safe = False
                self.log.append(f"[{now:.3f} s] fresh joint target: leaving the safe mode")
            else:
                self._warn(now)
                return BridgeCommand(self.safe_mode, self._held, stamp)
        elif not fresh:
            self.safe, self.safe_since, self._seq_at_entry = True, now, seq
            self.safe_entries += 1
            self._held[:] = np.asarray(q, dtype=float)[:self.n]
            self._last_warn = -math.inf
            self._warn(now)
            return BridgeCommand(self.safe_mode, self._held, stamp)
        return BridgeCommand(RUN, self._out, stamp)

    def _warn(self, now: float) -> None:
        if now - self._last_warn >= self.warn_period:
            self._last_warn = now
            self.warnings += 1
            age = "no target yet" if self._received is None else f"last target {now - self._received:.3f} s ago"
            text = (f"[{now:.3f} s] command timeout ({age}, timeout {self.timeout} s): "
                    f"safe mode '{self.safe_mode}'")
            self.log.append(text)
            if self.node is not None:
                self.node.get_logger().warning(text)
        else:
            self.warnings_suppressed += 1

    def publish_state(self, stamp_ns: int, q, dq=None, effort=None) -> None:
        """Publish /joint_states (needs a context)."""
        if self.publisher is None:
            raise RuntimeError("publish_state needs JointBridge(..., context=ctx)")
        msg = JointState(name=list(self.joint_names), position=[float(v) for v in q[:self.n]],
                         velocity=[] if dq is None else [float(v) for v in dq[:self.n]],
                         effort=[] if effort is None else [float(v) for v in effort[:self.n]])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        self.publisher.publish(msg)
