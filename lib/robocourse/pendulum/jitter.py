"""What wake-up latency does to balance: many seeded trials of a stiff cart-pole loop.

The demo's cart-pole loop is slow (delay margin about 229 ms): no kernel's jitter touches it.
``fast_design`` is the same cart-pole with a 0.2 m pole, an idealised actuator (no force limit)
and an aggressive LQR (Q = diag(1, 1, 1e4, 1), R = 1e-5): a delay margin of a few
milliseconds, the regime of stiff balance and force loops where a loop's tail matters.

``trials`` runs a whole batch of trials at once (numpy over trials, RK4 on a fixed substep):
each trial starts settled (upright, at rest), has the demo's uniform noise on the pole's
acceleration drawn from its own seed, and gets its own latency trace (ns per iteration, rttest
semantics). Timing model as :func:`robocourse.pendulum.cartpole.simulate`: the state is sampled
at each deadline ``k * period``, the force computed from it is written at
``max(previous write, k * period + latency[k])`` and holds until the next write. Writes take
effect at the next substep boundary (``period / substeps``; 50 us by default), which is the
resolution of the experiment. A trial *falls* when the pole leaves ``fall_angle`` of upright.

The experiment's traces: ``spike_trace`` (one stall of S: the loop wakes S late once, then
catches up, as chapter 1's catch-up ramps) and ``stretch_trace`` (every write late by ``delay``
for a stretch of L), and windows of a measured trace (``windows``). ``wilson`` gives the 95 %
interval of a fall probability from k falls in n trials.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import cartpole

FAST_PARAMS = cartpole.CartPoleParams(length=0.2, max_force=1e9)
FAST_Q = np.diag([1.0, 1.0, 1e4, 1.0])
FAST_R = 1e-5


def fast_design() -> tuple[cartpole.CartPoleParams, np.ndarray]:
    """(params, K) of the high-bandwidth cart-pole loop described above."""
    return FAST_PARAMS, cartpole.lqr_gain(FAST_Q, FAST_R, FAST_PARAMS)


@dataclass
class Trials:
    """Outcome of a batch: one entry per trial."""

    fell: np.ndarray  # bool
    fell_at: np.ndarray  # s, NaN where it did not fall
    max_error_after_settle: np.ndarray  # rad, |theta - pi| after ``settle`` (to the fall, if it fell)

    @property
    def n(self) -> int:
        return int(self.fell.size)

    @property
    def falls(self) -> int:
        return int(self.fell.sum())


def _check_positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not (
            math.isfinite(value) and value > 0):
        raise ValueError(f"{name}={value!r}: a positive, finite number")
    return float(value)


def trials(latencies_ns, seeds, K=None, p: cartpole.CartPoleParams | None = None, period: float = 0.001,
           duration: float = 1.0, settle: float = 0.2, substeps: int = 20, fall_angle: float = 0.5,
           x0=cartpole.UPRIGHT) -> Trials:
    """Run one trial per row of ``latencies_ns`` (shape (trials, iterations), ns) with its own noise seed.

    Rows shorter than ``duration / period`` are an error (a trial must have a latency for every
    iteration). ``seeds`` is one int per trial. Default plant and gain: :func:`fast_design`.
    """
    if p is None and K is None:
        p, K = fast_design()
    p = p or cartpole.CartPoleParams()
    K = cartpole.DEMO_K if K is None else np.asarray(K, dtype=float).reshape(4)
    period, duration = _check_positive("period", period), _check_positive("duration", duration)
    fall_angle = _check_positive("fall_angle", fall_angle)
    if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"substeps={substeps!r}: a positive int (substeps per period), e.g. 20")
    n = int(round(duration / period))
    lat = np.atleast_2d(np.asarray(latencies_ns, dtype=float)) * 1e-9
    seeds = np.asarray(seeds).reshape(-1)
    if lat.shape[1] < n:
        raise ValueError(f"latencies_ns has {lat.shape[1]} iterations per trial; {duration} s at {period} s "
                         f"needs {n}: pass longer traces or a shorter duration")
    if seeds.size != lat.shape[0]:
        raise ValueError(f"one seed per trial: {lat.shape[0]} traces but {seeds.size} seeds")
    if not np.all(np.isfinite(lat)) or np.any(lat < 0):
        raise ValueError("latencies_ns must be finite and >= 0 (a write never happens before its sample)")
    T = lat.shape[0]
    rngs = [np.random.default_rng(int(s)) for s in seeds]
    # one noise value per period, held over its substeps (the demo draws it once per physics step)
    noise = np.stack([r.uniform(-p.noise, p.noise, n) for r in rngs]) if p.noise > 0 else None
    deadlines = np.arange(n) * period
    writes = np.maximum.accumulate(deadlines[None, :] + lat[:, :n], axis=1)
    state = np.repeat(np.asarray(x0, dtype=float).reshape(4, 1), T, axis=1)
    ref = cartpole.UPRIGHT.reshape(4, 1)
    forces = np.zeros((T, n))
    applied = np.full(T, -1)
    rows = np.arange(T)
    fell_at = np.full(T, np.nan)
    worst = np.zeros(T)
    alive = np.ones(T, dtype=bool)
    h = period / substeps
    for k in range(n):
        forces[:, k] = np.clip(-(K @ (state - ref)), -p.max_force, p.max_force)
        d = noise[:, k] if noise is not None else 0.0
        for j in range(substeps):
            t = k * period + j * h
            while True:  # writes due by now (several at once after a stall: the newest wins)
                nxt = np.minimum(applied + 1, k)
                due = (applied < k) & (writes[rows, nxt] <= t + 1e-12)
                if not due.any():
                    break
                applied[due] += 1
            u = np.where(applied >= 0, forces[rows, np.maximum(applied, 0)], 0.0)
            state = cartpole.rk4_step(state, u, h, p, d)
        err = np.abs(state[2] - math.pi)
        t_end = (k + 1) * period
        bad = alive & ((err > fall_angle) | ~np.all(np.isfinite(state), axis=0))
        fell_at[bad] = t_end
        if t_end > settle:
            worst = np.where(alive, np.maximum(worst, np.nan_to_num(err, nan=np.inf)), worst)
        alive &= ~bad
        if not alive.any():
            break
        state[:, ~alive] = ref[:, 0:1]  # park fallen trials upright so they cannot overflow
    return Trials(~np.isnan(fell_at), fell_at, worst)


def spike_trace(n: int, at: int, stall_ns: float) -> np.ndarray:
    """All iterations on time except one that wakes ``stall_ns`` late (the loop then catches up)."""
    lat = np.zeros(n)
    lat[at] = stall_ns
    return lat


def stretch_trace(n: int, at: int, length: int, delay_ns: float) -> np.ndarray:
    """Every write of iterations ``at .. at + length - 1`` late by ``delay_ns`` (a loaded core)."""
    lat = np.zeros(n)
    lat[at:at + length] = delay_ns
    return lat


def windows(trace_ns, n: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` windows of ``n`` consecutive samples from a measured trace, at random starts, in order.

    A trace shorter than ``n`` is repeated (its bursts stay bursts).
    """
    trace = np.asarray(trace_ns, dtype=float).reshape(-1)
    if trace.size == 0:
        raise ValueError("the measured latency trace is empty")
    trace = np.clip(trace, 0, None)
    reps = int(np.ceil((2 * n) / trace.size))
    tiled = np.tile(trace, reps)
    starts = rng.integers(0, tiled.size - n + 1, count)
    return np.stack([tiled[s:s + n] for s in starts])


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval (95 % by default) for a probability from ``k`` successes in ``n`` trials."""
    if n <= 0 or not 0 <= k <= n:
        raise ValueError(f"need 0 <= k <= n and n > 0, got k={k}, n={n}")
    phat = k / n
    denom = 1 + z * z / n
    centre = (phat + z * z / (2 * n)) / denom
    half = z * math.sqrt(phat * (1 - phat) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def first_reaching(xs, falls, n: int, level: float = 0.5):
    """Smallest x whose fall fraction reaches ``level`` (None if none does), xs sorted ascending."""
    for x, k in sorted(zip(xs, falls, strict=True)):
        if k / n >= level:
            return x
    return None
