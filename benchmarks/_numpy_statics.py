"""The peers of the statics benchmarks, written as a competent numpy user would: the pump device's
balances (2.19) with the regulator, their analytic Jacobian, a vectorised Newton over many points
(the hand-written limit) and scipy fsolve with the analytic Jacobian.

Unknowns ``[psi2, psi3, u, psi_e, psi_cam, z]``: z is the valve opening xi while the regulator
regulates, or the stem's reaction r_valve with xi = xi_max on its open stop (``on_stop``); the face
contact reaction is zero (no contact in these sweeps).  The same equations as models/device.py,
including the smoothed signed root x / (x^2 + eps^2)^(1/4) and the opening u^(3/2).
Every group may be a scalar or an array over points (Monte Carlo samples).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import fsolve

from autobal.models.throttles import SQRT_SMOOTHING

NAMES = ("psi2", "psi3", "u", "psi_e", "psi_cam", "xi")  # autobal's names of the columns (z = xi)
EPS2 = SQRT_SMOOTHING**2


def _ss(x):
    """Smoothed signed square root and its derivative."""
    d = x * x + EPS2
    return x * d**-0.25, (0.5 * x * x + EPS2) * d**-1.25


def residual_jacobian(x, psi1, dpsi, g, on_stop: bool = False):
    """Balances F (points x 6) and Jacobian J (points x 6 x 6) at rows ``x``; ``g``: a namespace with
    sigma, chi, b, psi4, alpha_e1, alpha_TB1, alpha_31 and regulator (sigma_m, psi_in, alpha_in1,
    alpha_B1, xi_max), scalars or arrays over points."""
    r = g.regulator
    p2, p3, u, pe, pc, z = x.T
    xi, rv = (r.xi_max, z) if on_stop else (z, 0.0)
    ae, aT, a3 = g.alpha_e1, g.alpha_TB1, g.alpha_31
    s23, d23 = _ss(p2 - p3)
    s34, d34 = _ss(p3 - g.psi4)
    scv, dcv = _ss(pc - pe)
    up = np.maximum(u, 0.0)
    o, do = up**1.5, 1.5 * np.sqrt(up)
    qT = o * aT * s23
    qv = xi * r.alpha_B1 * scv
    qe = ae * (pe - p2)
    F = np.stack([g.sigma * (p2 - p3) + g.chi - g.b * psi1,
                  qe - (p2 - psi1) - qT,
                  qT - a3 * s34,
                  r.sigma_m * (pe - psi1 - dpsi) + rv,
                  r.alpha_in1 * (r.psi_in - pc) - qv,
                  qv - qe], axis=1)
    n = len(F)
    J = np.zeros((n, 6, 6))
    dT2, dTu = o * aT * d23, do * aT * s23
    dv = xi * r.alpha_B1 * dcv
    J[:, 0, 0], J[:, 0, 1] = g.sigma, -g.sigma
    J[:, 1, 0], J[:, 1, 1], J[:, 1, 2], J[:, 1, 3] = -ae - 1 - dT2, dT2, -dTu, ae
    J[:, 2, 0], J[:, 2, 1], J[:, 2, 2] = dT2, -dT2 - a3 * d34, dTu
    J[:, 3, 3] = r.sigma_m
    J[:, 4, 3], J[:, 4, 4] = dv, -r.alpha_in1 - dv
    J[:, 5, 0], J[:, 5, 3], J[:, 5, 4] = ae, -dv - ae, dv
    if on_stop:
        J[:, 3, 5] = 1.0
    else:
        J[:, 4, 5], J[:, 5, 5] = -r.alpha_B1 * scv, r.alpha_B1 * scv
    return F, J


def newton(x0, psi1, dpsi, g, on_stop: bool = False, tol: float = 1e-14, max_iter: int = 50):
    """Vectorised Newton, point by point as CasADi's rootfinder stops (|F| <= ``tol`` on the point, at
    most ``max_iter`` steps): every step evaluates F and J of the points still iterating at once and
    takes one batched LAPACK solve.  Points whose F is not finite stop (NaN).  Returns rows, steps."""
    x = np.array(x0, float)
    rows = np.arange(len(x))
    for it in range(max_iter):
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            part = len(rows) < len(x)
            F, J = residual_jacobian(x[rows], take_array(psi1, rows) if part else psi1,
                                     take_array(dpsi, rows) if part else dpsi, take(g, rows) if part else g, on_stop)
            size = np.abs(F).max(axis=1)
            go = size > tol  # NaN: stops
            rows, F, J = rows[go], F[go], J[go]
            if rows.size == 0:
                return x, it
            x[rows] -= np.linalg.solve(J, F[..., None])[..., 0]
    return x, max_iter


def scalar_functions(psi1, dpsi, g):
    """The balances and their Jacobian at one point in plain Python floats (what fsolve calls best)."""
    r = g.regulator
    sig, chi, b, p4, ae, aT, a3 = g.sigma, g.chi, g.b, g.psi4, g.alpha_e1, g.alpha_TB1, g.alpha_31
    sm, pin, ain, aB = r.sigma_m, r.psi_in, r.alpha_in1, r.alpha_B1

    def ss(x):
        d = x * x + EPS2
        return x * d**-0.25, (0.5 * x * x + EPS2) * d**-1.25

    def f(v):
        p2, p3, u, pe, pc, xi = v
        o = max(u, 0.0) ** 1.5
        qT = o * aT * ss(p2 - p3)[0]
        qv = xi * aB * ss(pc - pe)[0]
        qe = ae * (pe - p2)
        return [sig * (p2 - p3) + chi - b * psi1, qe - (p2 - psi1) - qT, qT - a3 * ss(p3 - p4)[0],
                sm * (pe - psi1 - dpsi), ain * (pin - pc) - qv, qv - qe]

    def jac(v):
        p2, p3, u, pe, pc, xi = v
        up = max(u, 0.0)
        s23, d23 = ss(p2 - p3)
        scv, dcv = ss(pc - pe)
        dT2, dTu = up**1.5 * aT * d23, 1.5 * up**0.5 * aT * s23
        dv, sv = xi * aB * dcv, aB * scv
        return [[sig, -sig, 0, 0, 0, 0],
                [-ae - 1 - dT2, dT2, -dTu, ae, 0, 0],
                [dT2, -dT2 - a3 * ss(p3 - p4)[1], dTu, 0, 0, 0],
                [0, 0, 0, sm, 0, 0],
                [0, 0, 0, dv, -ain - dv, -sv],
                [ae, 0, 0, -dv - ae, dv, sv]]

    return f, jac


def fsolve_rows(x0, psi1, dpsi, g, continuation: bool = True, jacobian: bool = True):
    """scipy fsolve point by point (regulator regulating), xtol 1e-13, with the analytic Jacobian
    (``fprime``) or finite differences; with ``continuation`` each point starts from the previous
    root (a sweep), otherwise from its row of x0."""
    n = len(x0)
    out = np.empty_like(np.asarray(x0, float))
    psi1 = np.broadcast_to(psi1, (n,))
    dpsi = np.broadcast_to(dpsi, (n,))
    x = x0[0]
    with warnings.catch_warnings():  # fsolve warns when xtol is below what it can still improve
        warnings.simplefilter("ignore", RuntimeWarning)
        for i in range(n):
            f, jac = scalar_functions(float(psi1[i]), float(dpsi[i]), point(g, i))
            x = out[i] = fsolve(f, x if continuation else x0[i], fprime=jac if jacobian else None, xtol=1e-13)
    return out


class _NS:
    def __init__(self, **kw):
        self.__dict__.update(kw)


def point(g, i):
    """The groups of point i (arrays indexed, scalars kept)."""
    def at(v):
        return float(v[i]) if np.ndim(v) else float(v)

    keys = ("sigma", "chi", "b", "psi4", "alpha_e1", "alpha_TB1", "alpha_31")
    r = g.regulator
    reg = _NS(**{k: at(getattr(r, k)) for k in ("sigma_m", "psi_in", "alpha_in1", "alpha_B1", "xi_max")})
    return _NS(regulator=reg, **{k: at(getattr(g, k)) for k in keys})


def take(g, rows):
    """The groups of the points ``rows`` (arrays indexed, scalars kept)."""
    def at(v):
        return v[rows] if np.ndim(v) else v

    keys = ("sigma", "chi", "b", "psi4", "alpha_e1", "alpha_TB1", "alpha_31")
    r = g.regulator
    reg = _NS(**{k: at(getattr(r, k)) for k in ("sigma_m", "psi_in", "alpha_in1", "alpha_B1", "xi_max")})
    return _NS(regulator=reg, **{k: at(getattr(g, k)) for k in keys})


def solve_with_stop(x0, psi1, dpsi, g):
    """The Monte Carlo's hand-written limit: vectorised Newton with the regulator regulating, then,
    for the rows outside the bounds (valve opening above xi_max), with the valve on its open stop.
    Returns rows [psi2, psi3, u, psi_e, psi_cam, xi], the rows on the stop, the largest |F|."""
    x, _ = newton(x0, psi1, dpsi, g)
    xi_max = g.regulator.xi_max
    with np.errstate(invalid="ignore"):
        bad = ~(np.all(np.isfinite(x) & (x >= 0), axis=1) & (x[:, 5] <= xi_max))
    F = residual_jacobian(x[~bad], psi1, take_array(dpsi, ~bad), take(g, ~bad))[0]
    worst = float(np.abs(F).max()) if F.size else 0.0
    if bad.any():
        gb, db = take(g, bad), take_array(dpsi, bad)
        s0 = np.array(x0[bad], float)
        s0[:, 5] = 0.0  # the stem's reaction
        xs, _ = newton(s0, psi1, db, gb, on_stop=True)
        worst = max(worst, float(np.abs(residual_jacobian(xs, psi1, db, gb, on_stop=True)[0]).max()))
        xs[:, 5] = np.broadcast_to(gb.regulator.xi_max, len(xs))
        x[bad] = xs
    return x, bad, worst


def take_array(v, rows):
    return v[rows] if np.ndim(v) else v
