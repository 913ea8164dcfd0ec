"""What measured wake-up latency does to balance: replay rt measurements into the cart-pole.

The demo's cart-pole loop is slow (delay margin about 229 ms): no kernel's jitter touches it.
``fast_design`` is the same cart-pole with a 0.2 m pole, an idealised actuator (no force limit)
and an aggressive LQR (Q = diag(1, 1, 1e4, 1), R = 1e-5): gain crossover about 410 rad/s and a
delay margin of about 3.4 ms, the regime of stiff balance and force loops, where a sleeping
Python loop's tail matters. ``replay`` feeds latency samples (ns, in measured order) into the
nonlinear simulation, scaled by factors, and reports when the pole falls next to the delay
margin python-control predicts and to the longest stretch of consecutive writes that came
later than that margin (a loaded core delays many iterations in a row).
"""

from __future__ import annotations

import math

import numpy as np

from . import analysis, cartpole

FAST_PARAMS = cartpole.CartPoleParams(length=0.2, max_force=1e9)
FAST_Q = np.diag([1.0, 1.0, 1e4, 1.0])
FAST_R = 1e-5


def fast_design() -> tuple[cartpole.CartPoleParams, np.ndarray]:
    """(params, K) of the high-bandwidth cart-pole loop described above."""
    return FAST_PARAMS, cartpole.lqr_gain(FAST_Q, FAST_R, FAST_PARAMS)


def replay(latencies: dict[str, np.ndarray], scales=(1.0,), K=None, p: cartpole.CartPoleParams | None = None,
           period: float = 0.001, duration: float = 2.0, x0=(0.0, 0.0, math.pi - 0.01, 0.0)) -> list[dict]:
    """One row per (distribution, scale): latency figures, whether it fell, worst angle error.

    Latencies are replayed in their measured order (bursts stay bursts) and repeated if shorter
    than the run. Noise is off so rows differ only by timing.
    """
    if p is None and K is None:
        p, K = fast_design()
    p = p or cartpole.CartPoleParams()
    K = cartpole.DEMO_K if K is None else np.asarray(K, dtype=float)
    dm = analysis.delay_margin(K, p)
    rows = []
    for name, lat in latencies.items():
        lat = np.asarray(lat, dtype=float).reshape(-1)
        if lat.size == 0:
            raise ValueError(f"latency sample {name!r} is empty")
        for s in scales:
            scaled = np.clip(lat * s, 0, None)
            run = cartpole.simulate(K, x0=x0, duration=duration, period=period, latencies_ns=scaled, p=p, seed=None)
            over = run.delays > dm
            rows.append({
                "latencies": name, "scale": float(s),
                "p50_ms": float(np.percentile(scaled, 50) / 1e6), "p99_ms": float(np.percentile(scaled, 99) / 1e6),
                "max_ms": float(scaled.max() / 1e6), "delay_margin_ms": dm * 1e3,
                "over_margin_fraction": float(over.mean()),
                "longest_over_margin_ms": longest_run(over) * period * 1e3,
                "fell": run.fell, "fell_at_s": run.fell_at,
                "max_angle_error_rad": run.max_angle_error,
            })
    return rows


def longest_run(flags) -> int:
    """Length of the longest stretch of consecutive True values."""
    best = cur = 0
    for f in np.asarray(flags, dtype=bool):
        cur = cur + 1 if f else 0
        best = max(best, cur)
    return best


def format_rows(rows: list[dict]) -> str:
    head = (f"{'latencies':<18}{'scale':>6}{'p50 ms':>8}{'p99 ms':>9}{'max ms':>9}{'DM ms':>7}"
            f"{'>DM for':>10}  outcome")
    lines = [head, "-" * len(head)]
    for r in rows:
        outcome = f"FELL at {r['fell_at_s']:.2f} s" if r["fell"] else f"balanced (worst {math.degrees(r['max_angle_error_rad']):.2f} deg)"
        lines.append(f"{r['latencies']:<18}{r['scale']:>6g}{r['p50_ms']:>8.3f}{r['p99_ms']:>9.3f}{r['max_ms']:>9.2f}"
                     f"{r['delay_margin_ms']:>7.2f}{r['longest_over_margin_ms']:>7.0f} ms  {outcome}")
    return "\n".join(lines)
