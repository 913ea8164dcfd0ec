"""From a policy's raw output to joint targets: scale, offset, EMA low-pass, clipping (counted).

Counterparts: unitree deploy_mujoco's ``target_q = action * action_scale + default_angles``,
rl_sar's ``clip_actions`` and ``torque_limits`` clamps, and the EMA low-pass many deployments
add: ``y = alpha * y + (1 - alpha) * x`` with ``alpha = (1/fc) / (1/f + 1/fc)`` for a cutoff
``fc`` at control rate ``f``. Here ``alpha`` weighs the previous output, so ``alpha = 0``
is no filter. Targets are clipped to the joint limits, and to the positions whose PD torque
``kp (q_des - q) - kd dq`` stays within the torque limits; every clipped element is counted.
"""

from __future__ import annotations

import numpy as np


def ema_alpha(cutoff_hz: float, rate_hz: float) -> float:
    """alpha = (1/fc) / (1/f + 1/fc): the weight of the previous output for a cutoff fc at rate f."""
    if not (cutoff_hz > 0 and rate_hz > 0):
        raise ValueError(f"cutoff_hz={cutoff_hz!r} and rate_hz={rate_hz!r} must be > 0")
    return (1.0 / cutoff_hz) / (1.0 / rate_hz + 1.0 / cutoff_hz)


class ActionProcessor:
    """``targets = clip(ema(default + action_scale * clip(action, +-clip_actions)))``.

    ``lower``/``upper``: joint position limits (rad); ``torque_limit``, ``kp``, ``kd``: clip the
    target so the PD torque estimate stays within the limit (omit to skip). ``clipped`` counts
    clipped elements (joint and torque separately), ``reset(q)`` starts the filter at ``q``.
    """

    def __init__(self, default_pose, action_scale: float, lower, upper, alpha: float = 0.0,
                 clip_actions: float = 1.0, torque_limit=None, kp=None, kd=None):
        self.default = np.asarray(default_pose, dtype=float).copy()
        n = len(self.default)
        self.lower, self.upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        if self.lower.shape != (n,) or self.upper.shape != (n,) or np.any(self.lower > self.upper):
            raise ValueError(f"lower/upper must be {n} values with lower <= upper; got {self.lower}, {self.upper}")
        if not 0.0 <= alpha < 1.0:
            raise ValueError(f"alpha={alpha!r} must be in [0, 1): the weight of the previous target "
                             "(0 = no filter; alpha = 1 would never move)")
        self.action_scale, self.alpha, self.clip_actions = float(action_scale), float(alpha), float(clip_actions)
        self.torque_limit = None if torque_limit is None else np.asarray(torque_limit, dtype=float)
        self.kp = None if kp is None else np.asarray(kp, dtype=float)
        self.kd = np.zeros(n) if kd is None else np.asarray(kd, dtype=float)
        if self.torque_limit is not None and self.kp is None:
            raise ValueError("torque_limit needs kp (and kd) to turn a torque bound into a position bound")
        self.y = self.default.copy()
        self.clipped_joint = 0
        self.clipped_torque = 0
        self.processed = 0

    def reset(self, q=None) -> None:
        self.y = self.default.copy() if q is None else np.asarray(q, dtype=float).copy()

    def __call__(self, action, q=None, dq=None) -> np.ndarray:
        a = np.asarray(action, dtype=float)
        if a.shape != self.default.shape:
            raise ValueError(f"action has shape {a.shape}; the robot takes {self.default.shape[0]} joint actions "
                             "(check the policy's output size against the joint list)")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action has non-finite values at indices {np.flatnonzero(~np.isfinite(a)).tolist()}")
        x = self.default + self.action_scale * np.clip(a, -self.clip_actions, self.clip_actions)
        self.y = self.alpha * self.y + (1.0 - self.alpha) * x
        out = np.clip(self.y, self.lower, self.upper)
        self.clipped_joint += int(np.count_nonzero(out != self.y))
        if self.torque_limit is not None and q is not None:
            q = np.asarray(q, dtype=float)
            dq = np.zeros_like(q) if dq is None else np.asarray(dq, dtype=float)
            lo = q + (-self.torque_limit + self.kd * dq) / self.kp
            hi = q + (self.torque_limit + self.kd * dq) / self.kp
            t = np.clip(out, lo, hi)
            self.clipped_torque += int(np.count_nonzero(t != out))
            out = t
        self.processed += 1
        return out
