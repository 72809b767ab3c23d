"""Transcriptions of the declared spin-up problem into an NLP (rockit's ``method`` role).

* :class:`DirectCollocation` (Legendre or Radau points, degree and number of intervals; CasADi SX);
* :class:`MultipleShooting` (CVODES over each interval, the path constraints at the same interior
  instants as the collocation points, so both methods solve the same discrete problem).

The variables are ordered stage by stage (state, collocation states, control), the form a
structure-exploiting solver needs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import casadi as ca
import numpy as np

from autobal.models.rotor import rotor_model
from autobal.ocp.problem import SpinupOcp


@dataclass(frozen=True)
class DirectCollocation:
    """Direct collocation on ``intervals`` equal intervals, ``degree`` Legendre or Radau points each."""

    intervals: int = 200
    degree: int = 3
    scheme: str = "radau"

    @property
    def label(self) -> str:
        return f"direct collocation ({self.scheme}, degree {self.degree}, {self.intervals} intervals)"


@dataclass(frozen=True)
class MultipleShooting:
    """Multiple shooting with CVODES; path constraints at the collocation instants of ``scheme``/``degree``."""

    intervals: int = 200
    degree: int = 3
    scheme: str = "radau"
    tol: float = 1e-10
    hessian: str = "limited-memory"  # the exact Hessian through CVODES costs ~5x more per iteration

    @property
    def label(self) -> str:
        return f"multiple shooting (CVODES, {self.intervals} intervals)"


@cache
def collocation_data(degree: int, scheme: str):
    tau = ca.collocation_points(degree, scheme)
    C, D, B = ca.collocation_coeff(tau)
    return list(tau), np.array(C), np.array(D).ravel(), np.array(B).ravel()


def path_fractions(degree: int, scheme: str) -> list[float]:
    """Instants (fractions of an interval) where path constraints are imposed: the collocation
    points, and the interval end when it is not one of them (Legendre)."""
    tau = collocation_data(degree, scheme)[0]
    return tau if abs(tau[-1] - 1) < 1e-12 else [*tau, 1.0]


@cache
def interval_integrator(fractions: tuple, tol: float) -> ca.Function:
    """CVODES over one interval in s in [0, 1]: dq/ds = h f(q, a*, p), outputs at ``fractions``.
    Parameters [a*, h, p(4)]."""
    m = rotor_model()
    q, par = ca.SX.sym("q", 5), ca.SX.sym("par", 6)
    return ca.integrator("spinup_interval", "cvodes", {"x": q, "p": par, "ode": par[1] * m.ode(q, par[0], par[2:])},
                         0, list(fractions), {"abstol": tol, "reltol": tol, "max_num_steps": 20000})


@dataclass
class Mesh:
    """Interval lengths (tau): ``n`` control intervals of the horizon, then ``ns`` settling intervals."""

    n: int
    ns: int
    h: float  # control interval length at the horizon (guess, when the time is free)
    hs: float


def mesh(ocp: SpinupOcp, n: int) -> Mesh:
    h = ocp.tau_h / n
    ns = int(math.ceil(ocp.tau_s / h - 1e-9)) if ocp.tau_s > 0 else 0
    return Mesh(n, ns, h, ocp.tau_s / ns if ns else 0.0)


@dataclass
class Nlp:
    """A transcribed problem: IPOPT data, the named constraint blocks and how to read a solution."""

    x: ca.SX | ca.MX
    f: ca.SX | ca.MX
    g: ca.SX | ca.MX
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    blocks: list  # (name, start, stop) rows of g
    index: dict  # "X" (n+ns+1, 5), "Xc" (n+ns, d, 5) or None, "u" (n+ns,), "v" list of indices
    mesh: Mesh
    fractions: list
    method: object
    ref: float


def transcribe(ocp: SpinupOcp, method, ref: float) -> Nlp:
    """The NLP of ``ocp`` by ``method`` (DirectCollocation or MultipleShooting)."""
    collocation = isinstance(method, DirectCollocation)
    ms = mesh(ocp, method.intervals)
    K = ms.n + ms.ns
    d = method.degree
    tau, C, D, B = collocation_data(d, method.scheme)
    frac = path_fractions(d, method.scheme)
    Sym = ca.SX if collocation else ca.MX
    nv = ocp.n_extra
    # variables: per interval [X_k (5), Xc_k (d*5, collocation only), u_k], then X_K, then v
    per = 5 + (5 * d if collocation else 0) + 1
    w = Sym.sym("w", K * per + 5 + nv)
    X = [w[k * per:k * per + 5] for k in range(K)] + [w[K * per:K * per + 5]]
    Xc = [[w[k * per + 5 + 5 * j:k * per + 10 + 5 * j] for j in range(d)] for k in range(K)] if collocation else None
    U = [w[k * per + per - 1] for k in range(K)]
    v = w[K * per + 5:]
    idx_X = np.array([[k * per + i for i in range(5)] for k in range(K)] + [[K * per + i for i in range(5)]])
    idx_Xc = (np.array([[[k * per + 5 + 5 * j + i for i in range(5)] for j in range(d)] for k in range(K)])
              if collocation else None)
    idx_u = np.array([k * per + per - 1 for k in range(K)])
    idx_v = list(range(K * per + 5, K * per + 5 + nv))

    lbx, ubx = np.full(w.numel(), -np.inf), np.full(w.numel(), np.inf)
    # speed bounds on the horizon only: at its end omega_final is imposed, and over the settling window
    # the speed is held by the dynamics (a bound there would duplicate an equality: degenerate multipliers)
    nlo, nhi = ocp.nu_bounds()
    for rows in (idx_X[1:ms.n], idx_Xc[:ms.n].reshape(-1, 5) if collocation else idx_X[1:ms.n]):
        lbx[rows[:, 4]], ubx[rows[:, 4]] = nlo, nhi
    lbx[idx_X[0]] = ubx[idx_X[0]] = ocp.q0
    lbx[idx_u[:ms.n]], ubx[idx_u[:ms.n]] = -1.0, 1.0
    lbx[idx_u[ms.n:]] = ubx[idx_u[ms.n:]] = 0.0  # settling window: held speed
    if nv:
        lbx[idx_v[0]], ubx[idx_v[0]] = (0.0, 1.0) if ocp.free_time else (0.0, np.inf)

    def h_of(k):
        if k >= ms.n:
            return ms.hs
        return v[0] * ocp.tau_h / ms.n if ocp.free_time else ms.h

    f = ocp.dynamics()
    paths = ocp.path_constraints(ref)
    rows: dict[str, list] = {"dynamics": []}
    rows |= {pc.name: [] for pc in paths}
    bounds: dict[str, tuple] = {pc.name: (pc.lb, pc.ub) for pc in paths}
    quad = 0
    m = rotor_model()
    if collocation:
        for k in range(K):
            h, Z = h_of(k), [X[k], *Xc[k]]
            for j in range(d):
                dx = sum(C[r, j] * Z[r] for r in range(d + 1))
                rows["dynamics"].append(dx - f(Xc[k][j], U[k], h))
                quad = quad + h * B[j] * m.delta2(Xc[k][j])
            rows["dynamics"].append(X[k + 1] - sum(D[r] * Z[r] for r in range(d + 1)))
            pts = list(Xc[k]) + ([X[k + 1]] if len(frac) > d else [])
            for pc in paths:
                rows[pc.name] += [pc.expr(qj, U[k] * ocp.a_max, v) for qj in ([X[k]] if pc.uses_control else []) + pts]
    else:
        F = interval_integrator(tuple(frac), method.tol)
        for k in range(K):
            h = h_of(k)
            out = F(x0=X[k], p=ca.vertcat(U[k] * ocp.a_max, h, *ocp.params.p))["xf"]
            rows["dynamics"].append(X[k + 1] - out[:, -1])
            for pc in paths:
                rows[pc.name] += [pc.expr(qj, U[k] * ocp.a_max, v) for qj in ([X[k]] if pc.uses_control else [])
                                  + [out[:, j] for j in range(len(frac))]]
        if ocp.objective == "integrated_deflection":
            raise ValueError("multiple shooting supports the peak and min_time objectives (no quadrature)")
    rows["final speed omega(T) = omega_final"] = [X[ms.n][4] - ocp.nuf]
    du = [U[k + 1] - U[k] for k in range(ms.n - 1)]
    if ocp.jerk_max is not None:
        name = f"jerk limit |d alpha/dt| <= {ocp.jerk_max:g} rad/s^3"
        step = ocp.jerk_max / ocp.alpha_max / ocp.Om * (ocp.tau_h / ms.n if not ocp.free_time else 1.0)
        rows[name] = [d / step for d in du] if not ocp.free_time else [d / (step * v[0] * ocp.tau_h / ms.n)
                                                                       for d in du]
        bounds[name] = (-1.0, 1.0)
    bounds["dynamics"] = (0.0, 0.0)
    bounds["final speed omega(T) = omega_final"] = (0.0, 0.0)

    g, lbg, ubg, blocks, start = [], [], [], [], 0
    for name, r in rows.items():
        if not r:
            continue
        e = ca.vertcat(*r)
        n = e.numel()
        g.append(e)
        lbg.append(np.full(n, bounds[name][0]))
        ubg.append(np.full(n, bounds[name][1]))
        blocks.append((name, start, start + n))
        start += n
    if ocp.objective in ("peak_deflection", "peak_unbalance", "min_time"):
        obj = v[0]
    else:
        obj = quad / ref
    if ocp.jerk_penalty and du:
        obj = obj + ocp.jerk_penalty * ca.sumsqr(ca.vertcat(*du))
    index = {"X": idx_X, "Xc": idx_Xc, "u": idx_u, "v": idx_v}
    return Nlp(w, obj, ca.vertcat(*g), lbx, ubx, np.concatenate(lbg), np.concatenate(ubg), blocks, index, ms,
               frac, method, ref)
