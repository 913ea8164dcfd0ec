"""Control analysis with python-control: transfer functions, margins, and the delay margin.

The link the chapter makes: a loop with phase margin PM (rad) at gain crossover wc tolerates a
pure delay of PM / wc seconds before it goes unstable (a delay e^{-s tau} leaves the gain alone
and subtracts wc * tau of phase at crossover). ``delay_margin`` computes it from the loop
transfer; the cart-pole simulation with a constant actuation delay checks it.
"""

from __future__ import annotations

import math

import numpy as np

from . import cartpole
from .physics import GRAVITY, PendulumProperties


def pendulum_plant(props: PendulumProperties | None = None):
    """Torque -> angle deviation of the seed's pendulum linearized upright: 1/(m L^2) / (s^2 - g/L)."""
    import control

    p = props or PendulumProperties()
    return control.tf([1.0 / (p.mass * p.length**2)], [1.0, 0.0, -GRAVITY / p.length])


def growth_rate(props: PendulumProperties | None = None) -> float:
    """sqrt(g / L): how fast a deviation from upright grows (1/s), the unstable pole."""
    p = props or PendulumProperties()
    return math.sqrt(GRAVITY / p.length)


def cartpole_loop(K=cartpole.DEMO_K, p: cartpole.CartPoleParams | None = None):
    """Loop transfer broken at the force input: L(s) = K (sI - A)^-1 B (a SISO transfer function)."""
    import control

    A, B = cartpole.linearize(p)
    K = np.asarray(K, dtype=float).reshape(1, 4)
    return control.ss2tf(control.ss(A, B, K, np.zeros((1, 1))))


def margins(loop) -> dict:
    """Gain margin, phase margin (deg), their frequencies (rad/s) and the delay margin (s)."""
    import control

    gm, pm, wcg, wcp = control.margin(loop)
    dm = math.radians(pm) / wcp if np.isfinite(pm) and wcp and np.isfinite(wcp) and pm > 0 else float("nan")
    return {"gain_margin": float(gm), "phase_margin_deg": float(pm), "phase_crossover": float(wcg),
            "gain_crossover": float(wcp), "delay_margin_s": float(dm)}


def delay_margin(K=cartpole.DEMO_K, p: cartpole.CartPoleParams | None = None) -> float:
    """Largest pure actuation delay (s) the linearized cart-pole loop tolerates with gain K."""
    return margins(cartpole_loop(K, p))["delay_margin_s"]


def critical_delay(K=cartpole.DEMO_K, p: cartpole.CartPoleParams | None = None, period=0.002, duration=20.0,
                   x0=(0.0, 0.0, math.pi - 0.05, 0.0), lo=0.0, hi=1.0, tol=0.005) -> float:
    """Smallest constant actuation delay (s) at which the nonlinear simulation loses balance (bisection)."""

    def falls(delay):
        run = cartpole.simulate(K, x0=x0, duration=duration, period=period, latencies_ns=[delay * 1e9],
                                p=p, seed=None)
        # unstable even if it has not fallen yet: the oscillation grows
        tail = np.abs(run.states[-len(run.states) // 4:, 2] - math.pi)
        return run.fell or tail.max() > abs(x0[2] - math.pi)

    if not falls(hi):
        raise ValueError(f"still balanced with a {hi} s delay; raise hi")
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if falls(mid) else (mid, hi)
    return 0.5 * (lo + hi)
