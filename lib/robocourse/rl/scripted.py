"""A scripted arm to test a deployment loop against: /joint_states on a known trajectory, commands recorded.

Counterpart: ros2_control's ``mock_components/GenericSystem`` seen through a
``joint_state_broadcaster`` and a ``ForwardCommandController``: a loop reads
``sensor_msgs/JointState`` every control period and writes one position command per tick in the
controller's joint order. Here the joints move on a fixed trajectory whatever is commanded (each
tick's state is known exactly, so a test can tell which tick an observation was built from), the
ticks are paced on the wall clock with absolute deadlines (a late loop catches up, and the
lateness is recorded), and everything the loop did is kept: when each tick was served, from
which process and thread, and the command of each tick.

``/joint_states`` lists the joints in ``state_names`` order, which need not be the command order
or a policy's order, and may carry extra joints (a gripper's), as real ones do.
"""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np


class ScriptedArm:
    """``wait_for_tick()`` -> the tick's JointState (None when the run is over); ``command(positions)``.

    ``joints``: the arm's joints; ``state_names``: /joint_states' order (a permutation of
    ``joints`` plus extra joints, which stay still); ``command_joints``: the controller's order
    (a permutation of ``joints``); ``rate_hz``; the run ends after ``max_ticks`` ticks or when
    ``stop_when(arm)`` returns True (asked every ``check_every`` ticks). ``seed`` draws the
    trajectory ``q_j(t) = q0_j + a_j sin(2 pi f_j t + phi_j)`` (t = tick / rate, the header stamp).
    """

    def __init__(self, joints, state_names, command_joints, rate_hz: float = 100.0, max_ticks: int = 1000,
                 seed: int = 0, stop_when=None, check_every: int = 10):
        self.joints = list(joints)
        self.state_names = list(state_names)
        self.command_joints = list(command_joints)
        if sorted(self.command_joints) != sorted(self.joints):
            raise ValueError(f"command_joints {self.command_joints} must be a permutation of the joints {self.joints}")
        if not set(self.joints) <= set(self.state_names) or len(set(self.state_names)) != len(self.state_names):
            raise ValueError(f"state_names {self.state_names} must name every joint of {self.joints} once")
        if not (isinstance(rate_hz, (int, float)) and 1 <= rate_hz <= 2000):
            raise ValueError(f"rate_hz={rate_hz!r} must be in [1, 2000]")
        self.rate_hz, self.period = float(rate_hz), 1.0 / float(rate_hz)
        self.max_ticks, self.stop_when, self.check_every = int(max_ticks), stop_when, int(check_every)
        rng = np.random.default_rng(seed)
        n = len(self.state_names)
        self._q0 = rng.uniform(-2.0, 2.0, n)
        self._amp = np.where(np.isin(self.state_names, self.joints), rng.uniform(0.2, 0.6, n), 0.0)
        self._freq = rng.uniform(0.3, 1.1, n)
        self._phase = rng.uniform(0.0, 2 * math.pi, n)
        self.k = -1
        self.start: float | None = None
        self.served: list[tuple[int, float, int, int]] = []   # (tick, wall time it was returned, pid, thread)
        self.commands: dict[int, list[float]] = {}            # tick -> command (the last one written in that tick)
        self.bad_commands: list[str] = []
        self.late_ticks = 0
        self.stopped_early = False

    # --- the trajectory (also what a test uses to know each tick's state) ---------------------------
    def state(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities) of tick ``k`` in ``state_names`` order."""
        t = k * self.period
        w = 2 * math.pi * self._freq
        return self._q0 + self._amp * np.sin(w * t + self._phase), self._amp * w * np.cos(w * t + self._phase)

    def joint_positions(self, k: int, order) -> np.ndarray:
        """Positions of tick ``k`` in ``order`` (joint names)."""
        q, _ = self.state(k)
        idx = [self.state_names.index(j) for j in order]
        return q[idx]

    # --- the loop's side -----------------------------------------------------------------------
    def wait_for_tick(self):
        """Wait for the next control period; its /joint_states (sensor_msgs/JointState), or None at the end."""
        from robocourse.msgs.sensor_msgs import JointState

        nxt = self.k + 1
        if nxt >= self.max_ticks or self.stopped_early:
            return None
        if self.stop_when is not None and nxt > 0 and nxt % self.check_every == 0 and self.stop_when(self):
            self.stopped_early = True
            return None
        now = time.monotonic()
        if self.start is None:
            self.start = now
        deadline = self.start + nxt * self.period
        if deadline > now:
            time.sleep(deadline - now)
        elif now - deadline > self.period:
            self.late_ticks += 1
        self.k = nxt
        self.served.append((nxt, time.monotonic(), os.getpid(), threading.get_ident()))
        q, dq = self.state(nxt)
        msg = JointState(name=list(self.state_names), position=q.tolist(), velocity=dq.tolist(),
                         effort=[0.0] * len(q))
        t = nxt * self.period
        msg.header.stamp.sec = int(t)
        msg.header.stamp.nanosec = int(round((t - int(t)) * 1e9))
        return msg

    def command(self, positions) -> None:
        """This tick's position command, in ``command_joints`` order (a ForwardCommandController's)."""
        if self.k < 0:
            self.bad_commands.append("command() before the first wait_for_tick()")
            return
        try:
            values = [float(v) for v in np.asarray(positions, dtype=float).reshape(-1)]
        except (TypeError, ValueError):
            self.bad_commands.append(f"tick {self.k}: command {positions!r} is not a list of numbers")
            return
        if len(values) != len(self.command_joints) or not all(math.isfinite(v) for v in values):
            self.bad_commands.append(f"tick {self.k}: command of {len(values)} values {values[:8]} "
                                     f"(expected {len(self.command_joints)} finite numbers)")
            return
        self.commands[self.k] = values

    def record(self) -> dict:
        """Everything the run recorded, as plain data."""
        return {"rate_hz": self.rate_hz, "ticks": self.k + 1, "served": [list(s) for s in self.served],
                "commands": {str(k): v for k, v in self.commands.items()}, "bad_commands": self.bad_commands[:20],
                "late_ticks": self.late_ticks, "stopped_early": self.stopped_early}
