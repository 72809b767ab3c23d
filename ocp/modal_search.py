"""The starts of the modal (ROSS) rotor's spin-up (:class:`autobal.ocp.modal.ModalSpinupOcp`): a cheap global search
over four-phase speed profiles (full acceleration to w1, a middle phase, full acceleration to w3, then the constant
acceleration that arrives at the deadline), screened by a fixed-step Runge-Kutta integration of the same envelope
equation (:func:`screen`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from autobal.ocp.search import SearchResult
from autobal.ocp.simulation import ramp_profile
from autobal.ocp.solve import AHEAD, coarse_intervals

if TYPE_CHECKING:
    from autobal.ocp.modal import ModalSpinupOcp

# the screening integrator: RK4 steps of at most RK4_STEP / (largest |eigenvalue| of the envelope equation), at
# least SAMPLES per control interval (on the shipped scene 20 per 50 ms: the peak within 1e-5 of 40 per interval
# and 0.3 % of CVODES; 10 per interval is unstable), the envelope sampled SAMPLES times per interval
RK4_STEP = 1.5  # |lambda| dt; RK4 is stable on the imaginary axis up to 2.83
SAMPLES = 10
KEEP = 2  # distinct search profiles solved by IPOPT
TIE = 2e-3  # relative: screened peaks this close tie (broken by the peak of the last phase)


@dataclass(frozen=True)
class LinearEnvelope:
    """The scaled envelope equation of :meth:`ModalSpinupOcp.envelope_rhs` as it is: affine in the modal
    part y of the state for a given speed and control, y' = (M0 + nu M1 + u M2) y + b0 + nu^2 b2 + u bu,
    nu' = u c.  Taken from the CasADi Function by differentiation (no second copy of the equation) and
    checked at a random point when built."""

    M: tuple  # M0, M1, M2 (m x m)
    b: tuple  # b0, b2, bu (m,)
    c: float  # nu' per unit u

    @classmethod
    def of(cls, ocp: ModalSpinupOcp) -> LinearEnvelope:
        f = ocp.envelope_rhs()
        nx = f.size1_in(0)
        m = nx - 1
        x, u = ca.SX.sym("x", nx), ca.SX.sym("u")
        fx = ca.Function("envelope_jacobian", [x, u], [ca.jacobian(f(x, u)[:m], x[:m])])

        def at(nu, uu, y=None):
            z = np.concatenate([np.zeros(m) if y is None else y, [nu]])
            return np.array(fx(z, uu)), np.array(f(z, uu)).ravel()

        (A0, b0), (A1, b1), (A2, b2) = at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0)
        lin = cls((A0, A1 - A0, A2 - A0), (b0[:m], b1[:m] - b0[:m], b2[:m] - b0[:m]), float(b2[m] - b0[m]))
        y = np.random.default_rng(0).standard_normal(m)
        _, exact = at(0.7, -0.4, y)
        if np.abs(lin.rhs(y[None], np.array([0.7]), np.array([-0.4]))[0] - exact[:m]).max() > 1e-9 * (
                1 + np.abs(exact).max()):
            raise ValueError("the screening integrator needs an envelope equation affine in the state")
        return lin

    def rhs(self, y: np.ndarray, nu: np.ndarray, u: np.ndarray) -> np.ndarray:
        (M0, M1, M2), (b0, b2, bu) = self.M, self.b
        return (y @ M0.T + nu[:, None] * (y @ M1.T) + u[:, None] * (y @ M2.T) + b0
                + (nu**2)[:, None] * b2 + u[:, None] * bu)


def screen(ocp: ModalSpinupOcp, u: np.ndarray, substeps: int | None = None, samples: int = SAMPLES,
           lin: LinearEnvelope | None = None, by_interval: bool = False) -> np.ndarray:
    """Peak deflection (m) of many control profiles at once: classical Runge-Kutta (fixed step) of the
    envelope equation on the control mesh, the deflection envelope (:meth:`ModalSpinupOcp.envelope2`)
    sampled ``samples`` times per interval.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem.
    u : ndarray, shape (C, n)
        Acceleration over alpha_max on the n <= intervals + settling intervals control intervals of C
        candidates (zero after them).
    substeps : int, optional
        Runge-Kutta steps per interval (by default the fewest multiple of ``samples`` that keeps |lambda| dt
        below RK4_STEP).
    samples : int
        Envelope samples per interval (divides ``substeps``).
    by_interval : bool
        Return the largest deflection of every interval instead of the peak.

    Returns
    -------
    ndarray, shape (C,) or (C, intervals + settling intervals)
        Largest deflection over the nodes of interest (over the run or in each interval), m.
    """
    lin = lin or LinearEnvelope.of(ocp)
    env = ocp.envelope2()
    u = np.atleast_2d(u)
    Cn, n = u.shape
    K = ocp.intervals + ocp.settling_intervals
    u = np.concatenate([u, np.zeros((Cn, K - n))], axis=1)
    x0 = ocp.q0
    y, nu = np.tile(x0[:-1], (Cn, 1)), np.full(Cn, x0[-1])
    if substeps is None:
        top = (ocp.omega_max or ocp.omega_final) / ocp.omega_final
        rho = max(np.abs(np.linalg.eigvals(lin.M[0] + nu * lin.M[1] + a * lin.M[2])).max()
                  for nu in (0.0, top) for a in (-1.0, 1.0))
        substeps = samples * int(np.ceil(ocp.h * rho / RK4_STEP / samples))
    dt = ocp.h / substeps
    envm = env.map(Cn)
    best = np.zeros((Cn, K))
    for k in range(K):
        uk = u[:, k]
        dnu = uk * lin.c
        for s in range(substeps):
            k1 = lin.rhs(y, nu, uk)
            k2 = lin.rhs(y + 0.5 * dt * k1, nu + 0.5 * dt * dnu, uk)
            k3 = lin.rhs(y + 0.5 * dt * k2, nu + 0.5 * dt * dnu, uk)
            k4 = lin.rhs(y + dt * k3, nu + dt * dnu, uk)
            y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            nu = nu + dt * dnu
            if (s + 1) % (substeps // samples) == 0:
                r2 = np.array(envm(np.vstack([y.T, nu[None]])))
                best[:, k] = np.maximum(best[:, k], r2.max(axis=0))
    out = np.sqrt(best) * ocp.amplitude_scale
    return out if by_interval else out.max(axis=1)


def phase_profiles(ocp: ModalSpinupOcp, w1, u_b, d, w3) -> np.ndarray:
    """Controls (over alpha_max, averaged exactly onto the control intervals of the horizon) of the
    four-phase profiles: full acceleration to ``w1`` (rad/s), acceleration ``u_b`` alpha_max for ``d`` (s),
    full acceleration to ``w3`` (rad/s), then the constant acceleration that reaches omega_final at the
    deadline (``w3`` = omega_final: full acceleration and hold).

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem (speeds, alpha_max, horizon, control intervals).
    w1, u_b, d, w3 : array_like
        Speed at the end of the first phase (rad/s), acceleration of the middle phase over alpha_max, its
        duration (s), speed at the end of the third phase (rad/s); one profile per element.

    Returns
    -------
    ndarray, shape (profiles, intervals)
        alpha/alpha_max on each control interval of the horizon.
    """
    w1, u_b, d, w3 = (np.atleast_1d(np.asarray(v, float)) for v in (w1, u_b, d, w3))
    a, w0, wf, T = ocp.alpha_max, ocp.omega_start, ocp.omega_final, ocp.horizon
    t1 = (w1 - w0) / a
    w2 = w1 + u_b * a * d
    t3 = t1 + d + (w3 - w2) / a
    tk = np.arange(ocp.intervals + 1) * ocp.h
    out = np.empty((w1.size, tk.size - 1))
    for i in range(w1.size):
        bt = [0.0, t1[i], t1[i] + d[i], t3[i], T if w3[i] < wf else t3[i], T + 1.0]
        bw = [w0, w1[i], w2[i], w3[i], wf, wf]
        out[i] = np.diff(np.interp(tk, bt, bw)) / (ocp.h * a)
    return out


def grid_search(ocp: ModalSpinupOcp, n_w: int = 12, n_u: int = 4, n_d: int = 6, n_w3: int = 6,
                keep: int = KEEP) -> SearchResult:
    """Screen the four-phase family (:func:`phase_profiles`) on a grid: w1 between the start and the final
    speed or 1.25 x the first critical speed above the start (the passage of the first critical group), u_b in
    [u_min, 0.5] (u_min = -1 unless a minimum acceleration is set), d up to what the horizon leaves, w3 between
    the speed after the middle phase and omega_final; return the ``keep`` best whose first phases differ by more
    than a grid cell, the best first phase with each w3 that ties with it (the later passage is multimodal: they
    lead IPOPT to different optima); none when the horizon leaves no time for a middle phase.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem.
    n_w, n_u, n_d, n_w3 : int
        Grid points of w1, u_b, d and w3.
    keep : int
        Distinct first phases returned.

    Returns
    -------
    SearchResult
        Parameters (w1 rad/s, u_b, d s, w3 rad/s) and screened peaks (m), best first.
    """
    w0, wf, a, T = ocp.omega_start, ocp.omega_final, ocp.alpha_max, ocp.horizon
    wc = [w for w in ocp.rotor.critical_speeds(wf)["wd"] if w > w0]
    top = min(wf, 1.25 * wc[0]) if wc else wf  # the first phase ends near the first critical speed above the start
    W1, UB, D, F3 = np.meshgrid(np.linspace(w0, top, n_w + 1)[1:], np.linspace(ocp.u_min, 0.5, n_u),
                                np.linspace(0, 1, n_d + 1)[1:], np.linspace(0, 1, n_w3 + 1)[1:], indexing="ij")
    W1, UB, D, F3 = W1.ravel(), UB.ravel(), D.ravel(), F3.ravel()
    slack = T - (wf - w0) / a
    D = D * slack / (1 - UB)  # the middle phase lasts at most what the horizon leaves
    W2 = W1 + UB * a * D
    W3 = W2 + F3 * (wf - W2)
    ok = (W2 >= 0) & (W2 <= wf) & (D > 0) & ((W1 - w0) / a + D + (wf - W2) / a <= T * (1 + 1e-9))
    if ocp.omega_max is not None:
        ok &= W1 <= ocp.omega_max
    W1, UB, D, W3 = W1[ok], UB[ok], D[ok], W3[ok]
    if not ok.any():
        return SearchResult(np.empty((0, 4)), np.empty(0), 0)
    U = phase_profiles(ocp, W1, UB, D, W3)
    E = screen(ocp, U, by_interval=True)
    peaks = E.max(axis=1)
    # the peak past the first passage (after the middle phase, above ``top``): the first passage usually sets
    # the peak, so profiles that differ in w3 only tie; among ties (TIE) the lower later peak wins
    K = E.shape[1]
    speed = np.concatenate([w0 + np.cumsum(U * a * ocp.h, axis=1) - U * a * ocp.h,
                            np.full((U.shape[0], K - U.shape[1]), wf)], axis=1)  # at each interval start
    t2 = (W1 - w0) / a + D
    past = (speed >= top) & (np.arange(K)[None, :] * ocp.h >= t2[:, None] - 1e-12)
    # to 1e-9 of the largest: the screening's rounding (its sums' order varies between runs with the BLAS threads)
    # must not reorder ties, so that a scene gives the same starts in every run
    late = np.round(np.where(past, E, 0.0).max(axis=1) / E.max(), 9)
    peaks = np.round(peaks / E.max(), 9) * E.max()
    cell = (top - w0) / n_w
    chosen = []
    free = np.ones(peaks.size, bool)
    picks = 0
    while picks < keep and free.any():
        low = peaks[free].min()
        pool = np.flatnonzero(free & (peaks <= low * (1 + TIE)))
        i = pool[np.argmin(late[pool])]
        if picks == 0:  # the best first phase with every w3 of the grid: the later passage is multimodal
            same = pool[(W1[pool] == W1[i]) & (UB[pool] == UB[i]) & (D[pool] == D[i])]
            chosen += list(same[np.argsort(late[same], kind="stable")])
        else:
            chosen.append(i)
        picks += 1
        free &= np.abs(W1 - W1[i]) > 1.5 * cell
    idx = np.array(chosen, int)
    return SearchResult(np.column_stack([W1[idx], UB[idx], D[idx], W3[idx]]), peaks[idx], int(ok.sum()))


def starts(ocp: ModalSpinupOcp, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
    """Initial profiles (the starts of :func:`autobal.ocp.solve.optimize`): the ``KEEP`` best four-phase profiles of
    the screening (:func:`grid_search`), then the constant ramp to the deadline and the maximum-acceleration ramp
    with hold unless the search's best is AHEAD below both of their (screened) peaks.  They are screened on the
    coarse mesh of the mesh continuation (:func:`autobal.ocp.solve.coarse_intervals` of n), where they are
    solved, and each of its intervals' values is repeated onto the n: on the shipped scene the screening on 160
    intervals takes 1.5 x the CPU time of 80 and orders the tied profiles otherwise.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem.
    n : int
        Control intervals of the horizon.
    multistart : bool
        All starts; otherwise the first only.

    Returns
    -------
    list of (str, ndarray)
        Label and alpha/alpha_max on each of the n control intervals of the horizon.
    """
    nc = coarse_intervals(n)
    o = ocp.on_intervals(nc)
    const = abs(o.omega_final - o.omega_start) / o.horizon
    out = [("constant ramp", ramp_profile(o, nc, const)),
           ("maximum-acceleration ramp", ramp_profile(o, nc, o.alpha_max))]
    if o.omega_final > o.omega_start:
        found, a = grid_search(o), o.alpha_max
        search = [(f"search: {a:.3g} rad/s^2 to {p[0]:.4g} rad/s, {p[1] * a:.3g} rad/s^2 for {p[2]:.3g} s, {a:.3g} "
                   f"rad/s^2 to {p[3]:.4g} rad/s, then constant (screened peak {pk * 1e6:.4g} um)",
                   phase_profiles(o, *p)[0]) for p, pk in zip(found.params, found.peaks, strict=True)]
        ahead = found.peaks.size and screen(o, np.array([u for _, u in out])).min() * (1 - AHEAD) >= found.peaks[0]
        out = search + ([] if ahead else out)
    return [(label, np.repeat(u, n // nc)) for label, u in out[:None if multistart else 1]]
