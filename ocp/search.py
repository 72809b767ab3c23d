"""Cheap global search over low-dimensional speed profiles: the starts of the spin-up OCP.

Many candidate profiles are integrated at once by a fixed-step exponential integrator of the rotor
in the fixed frame, where the deflection obeys a linear time-invariant equation driven by the
unbalance force that rotates with the shaft angle beta (Pashkov (2010), Eq. (2) in the fixed frame,
the ``ode_fixed`` Function of :mod:`autobal.models.rotor`).  The system matrix and the force are
taken from that Function (no second copy of the equation): within a step the state is advanced
exactly by the modal exponentials, the force is frozen in amplitude and rotates at the speed of
the step's midpoint, so a step of one dimensionless time unit (about 10 ms for Omega0 = 105 rad/s)
keeps the peak within a fraction of a per cent.

The profile family (:func:`three_phase`): full acceleration up to a speed ``w1``, a constant
acceleration ``u_b`` (over alpha_max, -1 brakes, 0 holds) for a time ``d``, then full acceleration
to the final speed (held, capped at ``max_speed``): the structure of the optimum that accelerates
towards the critical speed, backs off, and passes.  :func:`grid_search` evaluates a grid of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from autobal.models.rotor import FIXED_STATES, rotor_model

if TYPE_CHECKING:
    from autobal.ocp.problem import SpinupOcp

STEP = 1.0  # dimensionless time step of the search integrator (tau = Omega0 t)
FAST_STEP = 0.5  # step of the validation and ranking integrator (peak within 1e-4 of CVODES, tested)


@dataclass(frozen=True)
class FixedFrameModes:
    """The Jeffcott rotor in the fixed frame, z' = A z + b(t), in modal form (the exponential integrator's
    eigen-decomposition; not the multi-mode rotor of :mod:`autobal.models.ross_rotor`), z = (X, Y, X', Y') over
    e; the force (X'' + i Y'' at beta = 0) is f0 + f_nu2 nu^2 + f_a a* (checked at a random point when built)."""

    lam: np.ndarray  # (4,) eigenvalues of A
    V: np.ndarray  # eigenvectors
    W: np.ndarray  # V^-1
    f: tuple  # complex (f0, f_nu2, f_a)

    @classmethod
    def of(cls, ocp: SpinupOcp) -> FixedFrameModes:
        m, nq = rotor_model(), len(FIXED_STATES)
        nz = FIXED_STATES.index("nu")  # the deflection states come first
        Q, a = ca.SX.sym("Q", nq), ca.SX.sym("a")
        rhs = m.ode_fixed(Q, a, ocp.params.p)
        A = np.array(ca.Function("A", [Q, a], [ca.jacobian(rhs[:nz], Q[:nz])])(np.zeros(nq), 0.0))
        lam, V = np.linalg.eig(A)

        def force(nu, acc):
            b = np.array(m.ode_fixed([0, 0, 0, 0, nu, 0], acc, ocp.params.p)).ravel()
            return b[2] + 1j * b[3]

        f0 = force(0.0, 0.0)
        f = (f0, force(1.0, 0.0) - f0, force(0.0, 1.0) - f0)
        if abs(force(1.7, 0.3) - (f[0] + f[1] * 1.7**2 + f[2] * 0.3)) > 1e-12 * (1 + abs(f[1])):
            raise ValueError("the search integrator needs a force affine in nu^2 and a*")
        return cls(lam, V, np.linalg.inv(V), f)


def simulate_steps(ocp: SpinupOcp, u: np.ndarray, dt: float = STEP, rotor: FixedFrameModes | None = None,
                   block: int = 64, states: bool = False):
    """Peak deflection delta/e of many piecewise-constant profiles at once.

    Parameters
    ----------
    ocp : SpinupOcp
        The problem (rotor, start state, alpha_max).
    u : ndarray, shape (C, S)
        Acceleration over alpha_max on each of S steps of length ``dt`` for C candidates.
    dt : float
        Step, dimensionless time (tau = Omega0 t).
    block : int
        Steps advanced at once (the modal recursion is summed in closed form within a block).
    states : bool
        Also return the fixed-frame states.

    Returns
    -------
    ndarray, shape (C,)
        The largest delta/e at the step ends; with ``states`` also (X, Y, X', Y') over e at the step starts and
        ends, ndarray (4, C, S + 1), the speed nu and the rotation angle beta there, each (C, S + 1).
    """
    rotor = rotor or FixedFrameModes.of(ocp)
    C, S = u.shape
    a = u * ocp.a_max
    nu = ocp.nu0 + np.concatenate([np.zeros((C, 1)), np.cumsum(a * dt, axis=1)], axis=1)
    num = 0.5 * (nu[:, 1:] + nu[:, :-1])  # rotation rate of the force on each step
    beta = np.concatenate([np.zeros((C, 1)), np.cumsum(num * dt, axis=1)], axis=1)
    f0, f2, fa = rotor.f
    c = (f0 + f2 * num**2 + fa * a) * np.exp(1j * beta[:, :-1])  # force at each step start
    lam, W, V = rotor.lam, rotor.W, rotor.V
    # z is real: the modal coordinates of a complex-conjugate pair of eigenvalues are conjugate, so one mode of
    # each pair is advanced and the deflection is twice its real part (every mode when some are real)
    upper = np.flatnonzero(lam.imag > 0)
    half = 2 * upper.size == lam.size
    if half:
        lam, W, V = lam[upper], W[upper], V[:, upper]
    gp = W[:, 2] - 1j * W[:, 3]  # W [0, 0, 1, -i]
    gm = W[:, 2] + 1j * W[:, 3]
    E = np.exp(lam * dt)
    x, y, vx, vy, nu0 = ocp.q0
    z0 = np.array([x, y, vx - nu0 * y, vy + nu0 * x])  # rotating -> fixed frame at beta = 0
    mdl = np.tile(W @ z0, (C, 1)).astype(complex)  # (C, modes)
    vx_, vy_ = V[0] * (2 if half else 1), V[1] * (2 if half else 1)
    best = np.full(C, np.hypot(x, y))
    out = [np.repeat(np.array(z0, float)[:, None, None], C, axis=1)] if states else None
    vvx, vvy = V[2] * (2 if half else 1), V[3] * (2 if half else 1)
    for k0 in range(0, S, block):
        k1 = min(S, k0 + block)
        sp = 1j * num[:, k0:k1, None]  # (C, B, 1)
        ck = c[:, k0:k1, None]
        ep = np.exp(sp * dt)
        inc = 0.5 * (ck * gp * (ep - E) / (sp - lam)
                     + np.conj(ck) * gm * (np.conj(ep) - E) / (-sp - lam))  # (C, B, modes)
        # m_{j+1} = E m_j + inc_j  =>  m_j = E^j (m_0 + sum_{i<j} E^{-(i+1)} inc_i) within the block
        j = np.arange(1, k1 - k0 + 1)[:, None]
        Ej = E[None, :] ** j  # (B, modes)
        m = Ej[None] * (mdl[:, None, :] + np.cumsum(inc / Ej[None], axis=1))
        X, Y = (m @ vx_).real, (m @ vy_).real
        best = np.maximum(best, np.hypot(X, Y).max(axis=1))
        if states:
            out.append(np.array([X, Y, (m @ vvx).real, (m @ vvy).real]))
        mdl = m[:, -1]
    return (best, np.concatenate(out, axis=2), nu, beta) if states else best


def three_phase(ocp: SpinupOcp, u1, w1, u_b, d, steps: int, dt: float = STEP) -> np.ndarray:
    """Controls (over alpha_max) on ``steps`` steps of the three-phase profile, for arrays of
    parameters ``u1`` (the first phase's acceleration over alpha_max), ``w1`` (the speed at its end,
    rad/s), ``u_b`` (the middle phase's acceleration over alpha_max) and ``d`` (its duration, s); the
    last phase accelerates fully to omega_final and holds (never above it)."""
    u1, w1, u_b, d = (np.atleast_1d(np.asarray(v, float))[:, None] for v in (u1, w1, u_b, d))
    t = (np.arange(steps) + 0.5) * dt / ocp.Om  # step midpoints, s
    t1 = (w1 - ocp.omega_start) / (u1 * ocp.alpha_max)
    u = np.where(t < t1, u1, np.where(t < t1 + d, u_b, 1.0))
    # integrate the speed and clip the profile at omega_final (hold from there on)
    nu = ocp.nu0 + np.cumsum(u * ocp.a_max * dt, axis=1)
    cap = ocp.nuf
    over = nu > cap
    first = np.where(over.any(axis=1), over.argmax(axis=1), steps)
    for i, k in enumerate(first):
        if k < steps:
            prev = ocp.nu0 + (np.sum(u[i, :k]) * ocp.a_max * dt)
            u[i, k] = (cap - prev) / (ocp.a_max * dt)
            u[i, k + 1:] = 0.0
    return u


@dataclass
class SearchResult:
    """The best profiles of a grid search over a profile family, distinct basins first (the Jeffcott rotor's
    three-phase family here, the modal rotor's four-phase family in :mod:`autobal.ocp.modal`)."""

    params: np.ndarray  # (k, 4): the family's parameters (here u1, w1 (rad/s), u_b, d (s))
    peaks: np.ndarray  # (k,) peaks by the search integrator (here delta/e)
    evaluated: int


def horizon_steps(ocp: SpinupOcp, dt: float = STEP) -> int:
    return int(np.ceil((ocp.tau_h + ocp.tau_s) / dt))


def feasible(ocp: SpinupOcp, u1, w1, u_b, d) -> np.ndarray:
    """Whether the three-phase profile reaches omega_final by the horizon."""
    t1 = (w1 - ocp.omega_start) / (u1 * ocp.alpha_max)
    w2 = w1 + u_b * ocp.alpha_max * d
    t3 = (ocp.omega_final - w2) / ocp.alpha_max
    return (w2 >= 0) & (t1 + d + np.maximum(t3, 0) <= ocp.horizon * (1 - 1e-9)) & (w2 <= ocp.omega_final)


def grid_search(ocp: SpinupOcp, n_w: int = 16, n_u: int = 5, n_d: int = 8, levels=(1.0,),
                keep: int = 2, dt: float = STEP) -> SearchResult:
    """Evaluate the three-phase family on a grid (first-phase acceleration ``levels``, w1 between the
    start and the final speed, u_b in [u_min, 0.5] (-1 unless the drive sets a minimum acceleration), d up to
    what the horizon leaves) and return the ``keep`` best profiles whose first phases differ by more than a grid
    cell (distinct basins)."""
    if ocp.free_time or ocp.horizon * ocp.alpha_max <= ocp.omega_final - ocp.omega_start:
        return SearchResult(np.empty((0, 4)), np.empty(0), 0)
    U1, W1, UB, D = np.meshgrid(levels, np.linspace(ocp.omega_start, ocp.omega_final, n_w + 1)[1:],
                                np.linspace(ocp.u_min, 0.5, n_u), np.linspace(0, 1, n_d + 1)[1:], indexing="ij")
    U1, W1, UB, D = U1.ravel(), W1.ravel(), UB.ravel(), D.ravel()
    slack = ocp.horizon - (W1 - ocp.omega_start) / (U1 * ocp.alpha_max) - (ocp.omega_final - W1) / ocp.alpha_max
    D = D * np.maximum(slack, 0) / (1 - UB)  # the middle phase lasts at most what the horizon leaves
    ok = feasible(ocp, U1, W1, UB, D) & (D > 0)
    U1, W1, UB, D = U1[ok], W1[ok], UB[ok], D[ok]
    steps = horizon_steps(ocp, dt)
    peaks = simulate_steps(ocp, three_phase(ocp, U1, W1, UB, D, steps, dt), dt)
    order = np.argsort(peaks)
    cell = (ocp.omega_final - ocp.omega_start) / n_w
    chosen = []
    for i in order:
        if all(abs(W1[i] - W1[j]) > 1.5 * cell or U1[i] != U1[j] for j in chosen):
            chosen.append(i)
        if len(chosen) == keep:
            break
    idx = np.array(chosen, int)
    return SearchResult(np.column_stack([U1[idx], W1[idx], UB[idx], D[idx]]), peaks[idx], int(ok.sum()))


def controls_on_mesh(ocp: SpinupOcp, params, n: int) -> np.ndarray:
    """The three-phase profile ``params`` = (w1, u_b, d) averaged onto n equal control intervals."""
    sub = 16
    u = three_phase(ocp, *params, n * sub, ocp.tau_h / (n * sub))[0]
    return u.reshape(n, sub).mean(axis=1)


def averaged(u: np.ndarray, duration: float, edges: np.ndarray) -> np.ndarray:
    """The piecewise-constant profile u (equal intervals over ``duration``, zero after) averaged over the
    steps between ``edges`` (same time unit as ``duration``): the speed at every edge is kept exactly."""
    n = u.size
    cum = np.concatenate([[0.0], np.cumsum(u)])
    U = np.interp(np.asarray(edges) / duration * n, np.arange(n + 1), cum, right=cum[-1])
    return np.diff(U) / (np.diff(edges) / duration * n)


def steps_of(ocp: SpinupOcp, u: np.ndarray, dt: float) -> np.ndarray:
    """The piecewise-constant profile u (n control intervals of the horizon, then held) averaged over steps
    of ``dt`` (dimensionless time of ``ocp``'s rotor), horizon and settling window covered."""
    steps = int(np.ceil((ocp.tau_h + ocp.tau_s) / dt))
    return averaged(u, ocp.tau_h, np.arange(steps + 1) * dt)


def profile_peak(ocp: SpinupOcp, u: np.ndarray, dt: float = FAST_STEP, rotor: FixedFrameModes | None = None) -> float:
    """Peak delta/e of one profile by the exponential integrator (:func:`simulate_steps`).

    Parameters
    ----------
    ocp : SpinupOcp
        The problem.
    u : ndarray, shape (n,)
        Acceleration over alpha_max on n equal control intervals of the horizon (held at zero after it).
    dt : float
        Step, dimensionless time (tau = Omega0 t).

    Returns
    -------
    float
        The largest delta/e at the step ends, horizon and settling window.
    """
    return float(simulate_steps(ocp, steps_of(ocp, np.asarray(u, float), dt)[None, :], dt, rotor)[0])


def drive_rates(ocp: SpinupOcp) -> tuple[float, float]:
    """The accelerations (rad/s^2) the back-off family runs at: the full rate, alpha_max or what the torque and
    power limits leave at the final speed after the drag (the lowest along a spin-up whose limits fall with the
    speed), and the back-off rate, -alpha_max, u_min alpha_max, or what the braking-torque limit and the drag give
    at the start speed (0 without braking: the back-off is a hold)."""
    up, down = ocp.alpha_max, ocp.u_min * ocp.alpha_max
    J, w, b = ocp.inertia, ocp.omega_final, ocp.drag
    if J > 0:
        limits = [m for m in (ocp.torque_max, ocp.power_max / w if ocp.power_max else None) if m is not None]
        up = min([up] + [(m - b * w) / J for m in limits])
        if ocp.braking_torque_max is not None:
            down = max(down, -(ocp.braking_torque_max + b * ocp.omega_start) / J)
    return up, min(down, 0.0)


def backoff_breakpoints(ocp: SpinupOcp, x: np.ndarray, backoffs: int) -> tuple[np.ndarray, np.ndarray]:
    """Instants (s) and speeds (rad/s) at the corners of the back-off family for the points ``x`` of the unit box
    (C, 2 ``backoffs`` + 1): the full rate to a speed a_1, the back-off rate (full braking, or a hold without
    braking; both rates from :func:`drive_rates`) for a time d_1, the full rate to a_2, ...,
    then a last leg at a constant rate to omega_final that arrives by the deadline (a partial rate when it uses
    the slack left), and the hold.  Every point of the box is feasible: a_(k+1) lies between the speed before it
    and omega_final (a_1 from the start), each d_k takes a fraction of the deadline's slack that is left (the time
    the ramp at the full rate does not need), the last leg's extra time the rest's fraction x_last."""
    x = np.atleast_2d(np.asarray(x, float))
    a, down = drive_rates(ocp)
    ub = down / a
    top = ocp.omega_final if ocp.omega_max is None else min(ocp.omega_final, ocp.omega_max)
    slack = np.full(len(x), ocp.horizon - (ocp.omega_final - ocp.omega_start) / a)
    t, w = [np.zeros(len(x))], [np.full(len(x), ocp.omega_start)]
    for k in range(backoffs):
        wk = w[-1] + x[:, 2 * k] * (top - w[-1])  # the top of the excursion
        t.append(t[-1] + (wk - w[-1]) / a)
        w.append(wk)
        # the back-off: u_min alpha_max for d; the time it costs (d, and the climb back) within the slack left
        d = x[:, 2 * k + 1] * slack / (1 - ub)
        d = np.minimum(d, wk / (-ub * a)) if ub < 0 else d  # never below standstill
        t.append(t[-1] + d)
        w.append(np.maximum(wk + ub * a * d, 0.0))  # standstill to rounding
        slack = slack - d * (1 - ub)
    extra = x[:, -1] * slack  # the last leg's time beyond the full-rate ramp's
    t.append(t[-1] + (ocp.omega_final - w[-1]) / a + extra)
    w.append(np.full(len(x), float(ocp.omega_final)))
    return np.column_stack(t), np.column_stack(w)


def backoff_controls(ocp: SpinupOcp, x: np.ndarray, backoffs: int, edges: np.ndarray) -> np.ndarray:
    """The back-off family's profiles (:func:`backoff_breakpoints`) as mean accelerations over alpha_max on the
    steps between ``edges`` (s): the speed, linear between the corners and held after the last, is exact at every
    edge."""
    t, w = backoff_breakpoints(ocp, x, backoffs)
    nu = np.array([np.interp(edges, ti, wi) for ti, wi in zip(t, w, strict=True)])
    return np.diff(nu, axis=1) / (np.diff(edges) * ocp.alpha_max)


#: the cross-entropy search over the back-off family (:func:`backoff_search`): candidates per generation, elite kept,
#: generations
POPULATION, ELITE, GENERATIONS = 64, 8, 8


def backoff_search(ocp: SpinupOcp, backoffs: int, above: bool | None, seed: int = 0, dt: float = STEP,
                   rotor: FixedFrameModes | None = None) -> tuple[np.ndarray, float, int]:
    """The best profile of the back-off family with ``backoffs`` back-offs whose first excursion ends below
    (``above`` False) or above (True) the critical speed (None: anywhere), by a cross-entropy search over its unit
    box (a Gaussian of diagonal covariance refitted to the ELITE best of each generation) judged by the
    exponential integrator (:func:`simulate_steps`).  Returns (x, its peak, evaluations)."""
    rng = np.random.default_rng(seed)
    dim = 2 * backoffs + 1
    lo, hi = np.zeros(dim), np.ones(dim)
    span = max(ocp.omega_final if ocp.omega_max is None else min(ocp.omega_final, ocp.omega_max), ocp.omega_start) \
        - ocp.omega_start
    if above is not None and span > 0:
        split = np.clip((ocp.params.omega_cr - ocp.omega_start) / span, 0.0, 1.0)
        lo[0], hi[0] = (split, 1.0) if above else (0.0, split)
    mean, std = 0.5 * (lo + hi), 0.5 * (hi - lo)
    steps = horizon_steps(ocp, dt)
    edges = np.arange(steps + 1) * dt / ocp.Om
    rotor = rotor or FixedFrameModes.of(ocp)
    best_x, best = None, np.inf
    for g in range(GENERATIONS):
        x = rng.uniform(lo, hi, (POPULATION, dim)) if g == 0 else np.clip(
            mean + std * rng.standard_normal((POPULATION, dim)), lo, hi)
        if best_x is not None:
            x[0] = best_x
        peaks = simulate_steps(ocp, backoff_controls(ocp, x, backoffs, edges), dt, rotor)
        order = np.argsort(peaks)
        if peaks[order[0]] < best:
            best, best_x = float(peaks[order[0]]), x[order[0]].copy()
        elite = x[order[:ELITE]]
        mean, std = elite.mean(axis=0), np.maximum(elite.std(axis=0), 0.01 * (hi - lo))
    return best_x, best, POPULATION * GENERATIONS
