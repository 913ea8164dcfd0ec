"""A PID over several degrees of freedom at once (control_toolbox::Pid, vectorised).

Counterpart: ``control_toolbox::Pid::compute_command(error, error_dot, dt)`` as the
JointTrajectoryController and the PidController use it: ``p*e + i_term + d*e_dot`` with
``i_term += i*dt*e`` clamped to ``[-i_clamp, i_clamp]`` (0 = no clamp). Differences: one
object holds the gains of every joint (numpy vectors) and computes all of them in one call;
anti-windup strategies other than the clamp are not modelled.
"""

from __future__ import annotations

import numpy as np


class Pid:
    """``Pid(p, i, d, i_clamp)`` with one entry per degree of freedom."""

    def __init__(self, p, i, d, i_clamp=None):
        self.p = np.array(p, dtype=float)
        self.i = np.array(i, dtype=float)
        self.d = np.array(d, dtype=float)
        self.i_clamp = np.zeros_like(self.p) if i_clamp is None else np.array(i_clamp, dtype=float)
        self.i_term = np.zeros_like(self.p)
        self.out = np.zeros_like(self.p)
        self.prev_error = np.full_like(self.p, np.nan)

    def set_gains(self, p, i, d, i_clamp) -> None:
        self.p[:], self.i[:], self.d[:], self.i_clamp[:] = p, i, d, i_clamp

    def reset(self) -> None:
        self.i_term.fill(0.0)
        self.prev_error.fill(np.nan)

    def compute_command(self, error, error_dot, dt: float) -> np.ndarray:
        """The command for ``error`` and ``error_dot`` over ``dt`` seconds (the internal buffer)."""
        if dt > 0.0:
            self.i_term += self.i * dt * error
            clamp = self.i_clamp
            if clamp.any():
                limited = clamp > 0.0
                np.clip(self.i_term, -clamp, clamp, out=self.i_term, where=limited)
        np.multiply(self.p, error, out=self.out)
        self.out += self.i_term
        self.out += self.d * error_dot
        self.prev_error[:] = error
        return self.out

    def compute_command_from_error(self, error, dt: float) -> np.ndarray:
        """``compute_command(error, dt)``: the error's derivative from the previous call (0 on the first)."""
        if dt > 0.0:
            d = (error - self.prev_error) / dt
            d[np.isnan(d)] = 0.0
        else:
            d = np.zeros_like(self.p)
        return self.compute_command(error, d, dt)


__all__ = ["Pid"]
