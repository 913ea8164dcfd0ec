"""The cart-pole of the newer ROS 2 real-time demo (ros2-realtime-demo/pendulum), with LQR.

State ``[x, x_dot, theta, theta_dot]``, theta = pi upright, equations from Brunton's control
bootcamp with the demo's defaults: pole mass m = 1, cart mass M = 5, length L = 2, cart
damping d = 20, g = -9.8, force limit 1000 N, uniform noise +-1 on the pole's angular
acceleration; RK4 integration. The demo's controller is full-state feedback
``u = -K (x - ref)`` with K = [-10.0000, -51.5393, 356.8637, 154.4146], ref = [0, 0, pi, 0].

``simulate`` runs that controller as a real loop does: the controller wakes at
``k * period + latency[k]`` (never before its previous wake-up), reads the state then, and the
force it computes holds until the next wake-up (zero-order hold). Feed it latencies measured
by ``robocourse.rt`` to see what jitter does to balance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robocourse.sim.params import CartPoleParams  # noqa: F401  (re-exported)

DEMO_K = np.array([-10.0000, -51.5393, 356.8637, 154.4146])
UPRIGHT = np.array([0.0, 0.0, math.pi, 0.0])


def derivatives(state, force, p: CartPoleParams, disturbance=0.0):
    """d/dt [x, x_dot, theta, theta_dot] (works elementwise on arrays of states, shape (4, N))."""
    x_dot, theta, theta_dot = state[1], state[2], state[3]
    m, M, L, g, d = p.pole_mass, p.cart_mass, p.length, p.gravity, p.damping
    s, c = np.sin(theta), np.cos(theta)
    D = m * L * L * (M + m * (1.0 - c * c))
    coupling = m * L * theta_dot * theta_dot * s - d * x_dot
    x_ddot = (-m * m * L * L * g * c * s + m * L * L * coupling + m * L * L * force) / D
    theta_ddot = ((m + M) * m * g * L * s - m * L * c * coupling - m * L * c * force) / D + disturbance
    return np.array([x_dot, x_ddot, theta_dot, theta_ddot])


def rk4_step(state, force, dt, p: CartPoleParams, disturbance=0.0):
    k1 = derivatives(state, force, p, disturbance)
    k2 = derivatives(state + 0.5 * dt * k1, force, p, disturbance)
    k3 = derivatives(state + 0.5 * dt * k2, force, p, disturbance)
    k4 = derivatives(state + dt * k3, force, p, disturbance)
    return state + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def linearize(p: CartPoleParams | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the cart-pole linearized about upright (theta = pi), in closed form."""
    p = p or CartPoleParams()
    m, M, L, g, d = p.pole_mass, p.cart_mass, p.length, p.gravity, p.damping
    A = np.array([[0.0, 1.0, 0.0, 0.0],
                  [0.0, -d / M, -m * g / M, 0.0],
                  [0.0, 0.0, 0.0, 1.0],
                  [0.0, -d / (M * L), -(m + M) * g / (M * L), 0.0]])
    B = np.array([[0.0], [1.0 / M], [0.0], [1.0 / (M * L)]])
    return A, B


def numeric_jacobian(p: CartPoleParams | None = None, eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) by central differences of :func:`derivatives` at upright (checks :func:`linearize`)."""
    p = p or CartPoleParams()
    A = np.zeros((4, 4))
    for j in range(4):
        dx = np.zeros(4)
        dx[j] = eps
        A[:, j] = (derivatives(UPRIGHT + dx, 0.0, p) - derivatives(UPRIGHT - dx, 0.0, p)) / (2 * eps)
    B = ((derivatives(UPRIGHT, eps, p) - derivatives(UPRIGHT, -eps, p)) / (2 * eps)).reshape(4, 1)
    return A, B


def lqr_gain(Q=None, R=0.01, p: CartPoleParams | None = None) -> np.ndarray:
    """LQR gain K (u = -K (x - ref)) from python-control's ``lqr`` on the linearized model."""
    import control

    Q = np.eye(4) if Q is None else _weight_matrix(Q)
    R = _input_weight(R)
    A, B = linearize(p)
    K, _, _ = control.lqr(A, B, Q, R)
    return np.asarray(K).reshape(4)


def _weight_matrix(Q) -> np.ndarray:
    """Q as a 4x4 symmetric positive semi-definite float matrix, or a ValueError saying why not."""
    try:
        Q = np.asarray(Q, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"lqr_gain(Q={Q!r}): Q is a 4x4 matrix of numbers, e.g. np.eye(4)") from None
    if Q.shape != (4, 4):
        raise ValueError(f"lqr_gain(Q with shape {Q.shape}): the cart-pole state [x, x_dot, theta, theta_dot] "
                         "has 4 entries, so Q is 4x4, e.g. np.diag([1, 1, 10, 1])")
    if not np.all(np.isfinite(Q)):
        raise ValueError("lqr_gain(Q): Q holds NaN or inf; use finite weights, e.g. np.eye(4)")
    if not np.allclose(Q, Q.T):
        raise ValueError("lqr_gain(Q): Q must be symmetric (Q == Q.T); use (Q + Q.T) / 2 or a diagonal matrix")
    if np.linalg.eigvalsh(Q).min() < -1e-12 * max(1.0, np.abs(Q).max()):
        raise ValueError(f"lqr_gain(Q): Q must be positive semi-definite (eigenvalues {np.linalg.eigvalsh(Q)}); "
                         "a cost weights errors with non-negative values, e.g. np.diag([1, 1, 10, 1])")
    return Q


def _input_weight(R) -> np.ndarray:
    """R as a 1x1 positive float matrix (one input: the force), or a ValueError saying why not."""
    try:
        R = np.atleast_2d(np.asarray(R, dtype=float))
    except (TypeError, ValueError):
        raise ValueError(f"lqr_gain(R={R!r}): R is one positive number (the force's weight), e.g. R=0.01") from None
    if R.shape != (1, 1) or not np.isfinite(R[0, 0]) or R[0, 0] <= 0:
        raise ValueError(f"lqr_gain(R={R.tolist() if R.size > 1 else R.item()!r}): the cart-pole has one input, "
                         "so R is one positive, finite number (R = 0 would make force free), e.g. R=0.01")
    return R


def _vector4(value, what: str, example: str) -> np.ndarray:
    """A length-4 finite float vector, or a ValueError naming the value, the rule and an example."""
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{what}={value!r}: need 4 numbers, e.g. {what}={example}") from None
    if v.size != 4 or not np.all(np.isfinite(v)):
        raise ValueError(f"{what}={value!r}: need 4 finite numbers, one per state [x, x_dot, theta, theta_dot], "
                         f"e.g. {what}={example}")
    return v


def closed_loop_poles(K, p: CartPoleParams | None = None) -> np.ndarray:
    A, B = linearize(p)
    return np.linalg.eigvals(A - B @ np.asarray(K, dtype=float).reshape(1, 4))


@dataclass
class Run:
    """A simulated run: sample times, states sampled, forces computed and when they took effect."""

    t: np.ndarray  # sample instants k * period
    states: np.ndarray  # (n, 4) state sampled at each deadline
    forces: np.ndarray  # force computed from that sample
    applied_at: np.ndarray  # when that force reached the cart (deadline + latency, in order)
    fell: bool
    fell_at: float | None = None

    @property
    def max_angle_error(self) -> float:
        return float(np.max(np.abs(self.states[:, 2] - math.pi)))

    @property
    def delays(self) -> np.ndarray:
        return self.applied_at - self.t


def simulate(K=DEMO_K, x0=(0.0, 0.0, math.pi - 0.2, 0.0), duration=5.0, period=0.001, latencies_ns=None,
             p: CartPoleParams | None = None, ref=UPRIGHT, seed: int | None = 0,
             fall_angle=math.pi / 2) -> Run:
    """Run the demo's controller on the nonlinear cart-pole for ``duration`` seconds.

    Timing model (a cyclic controller with hardware-timed sensing, as with EtherCAT DC or a
    ros2_control read/update/write loop): the state is sampled at each deadline ``k * period``;
    the loop wakes ``latencies_ns[k]`` late (rttest semantics), computes the force and writes it
    at once, never before the previous write (an overrun delays everything behind it); the
    force holds until the next write. Shorter latency arrays are repeated; ``None`` means a
    perfect clock. ``seed=None`` turns the noise off. The run stops when the pole leaves
    ``fall_angle`` of upright.
    """
    p = p or CartPoleParams()
    K = _vector4(K, "K", "DEMO_K")
    x0 = _vector4(x0, "x0", "(0, 0, math.pi - 0.2, 0)")
    ref = _vector4(ref, "ref", "UPRIGHT")
    for name, value in (("duration", duration), ("period", period), ("fall_angle", fall_angle)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not (
                math.isfinite(value) and value > 0):
            raise ValueError(f"simulate({name}={value!r}): a positive, finite number of "
                             f"{'radians' if name == 'fall_angle' else 'seconds'}, e.g. duration=5.0, period=0.001")
    n = int(round(duration / period))
    if n < 1:
        raise ValueError(f"need duration >= period, got period={period}, duration={duration}")
    lat = np.zeros(1) if latencies_ns is None else np.asarray(latencies_ns, dtype=float).reshape(-1) * 1e-9
    if lat.size == 0 or not np.all(np.isfinite(lat)) or np.any(lat < -period):
        raise ValueError("latencies_ns must be finite ns values, none earlier than one period")
    rng = np.random.default_rng(seed) if seed is not None and p.noise > 0 else None
    state = np.asarray(x0, dtype=float).copy()
    t_now, force, last_write = 0.0, 0.0, -math.inf
    pending: list[tuple[float, float]] = []  # (write time, force), in time order
    ts, seen, computed, writes = np.empty(n), np.empty((n, 4)), np.empty(n), np.empty(n)
    fell_at = None

    def advance(until):
        nonlocal state, t_now, force
        while t_now < until - 1e-15:
            nxt = min(until, pending[0][0]) if pending else until
            if nxt > t_now:
                disturbance = rng.uniform(-p.noise, p.noise) if rng is not None else 0.0
                state = rk4_step(state, force, nxt - t_now, p, disturbance)
                t_now = nxt
            while pending and pending[0][0] <= t_now + 1e-15:
                force = pending.pop(0)[1]

    for k in range(n):
        advance(k * period)
        sample = state.copy()
        u = float(np.clip(-K @ (sample - ref), -p.max_force, p.max_force))
        write = max(last_write, k * period + max(0.0, lat[k % lat.size]))
        last_write = write
        pending.append((write, u))
        if write <= t_now:  # zero latency: the force takes effect at the sample instant
            advance(t_now)
        ts[k], seen[k], computed[k], writes[k] = k * period, sample, u, write
        if abs(sample[2] - math.pi) > fall_angle or not np.all(np.isfinite(sample)):
            fell_at, n = k * period, k + 1
            break
    return Run(ts[:n], seen[:n], computed[:n], writes[:n], fell_at is not None, fell_at)
