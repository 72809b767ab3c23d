"""Optimal spin-up of a rotor through its critical speed (spec rotor-liquid-abd-dynamics.md §8.7).

The problem is *declared* once (:class:`SpinupOcp`: states, control, dynamics, named path
constraints, boundary conditions, objective; rockit's style) and *transcribed* by a method:

* :class:`DirectCollocation` (Legendre or Radau points, degree and number of intervals from the
  scene; CasADi SX, IPOPT with the exact Hessian);
* :class:`MultipleShooting` (CVODES over each interval, the path constraints at the same interior
  instants as the collocation points, so both methods solve the same discrete problem).

Variables are the dimensionless ones of spec §3.2: time tau = Omega0 t (the critical period is
2 pi/sqrt(psi) in tau), deflection over e, speed nu = omega/Omega0; the control is the angular
acceleration over its limit, u = alpha/alpha_max in [-1, 1], piecewise constant per interval.
State q = (x, y, x', y', nu) in the rotating frame (Eq. (2)); the system starts from the steady
state (3) at omega_start (rest when omega_start = 0) and ends at omega(T) = omega_final.

Objectives: ``peak_deflection`` (epigraph: delta^2 <= S at every collocation point, minimise S),
``peak_unbalance`` (the same with the system unbalance d of (9')), ``integrated_deflection``
(integral of delta^2 over the horizon plus a settling window at omega_final), ``min_time``
(free final time subject to delta <= deflection_limit).  Limits: |alpha| <= alpha_max,
0 <= omega <= omega_max, |M| <= M_max, M omega <= P_max and the motor characteristic
M <= L_s (1 - omega/omega_nl), with M the drive torque of spec §8.3.

:func:`solve` runs IPOPT from the constant-ramp guess (and from other ramp profiles:
multi-start), and re-simulates every optimum with CVODES at tight tolerance: the reported peak
is the re-simulated one, and the collocation-vs-re-simulation difference is part of the result.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from functools import cache

import casadi as ca
import numpy as np

from autobal.analysis import interrupt, ipopt
from autobal.analysis.rotor import deflection, peak, steady_q, unbalance
from autobal.errors import SolveError
from autobal.models.rotor import RotorParams, rotor_model

OBJECTIVES = ("peak_deflection", "peak_unbalance", "integrated_deflection", "min_time")
IPOPT_OPTIONS = {"tol": 1e-8, "constr_viol_tol": 1e-8, "compl_inf_tol": 1e-8, "acceptable_iter": 0,
                 "max_iter": 300, "mu_strategy": "adaptive", "bound_relax_factor": 1e-10}
INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed")
TIE = 1e-4  # relative: optima closer than this are equal, the first start (constant ramp) is kept
RESIM_TOL = 1e-12  # CVODES tolerance of the re-simulation
RESIM_POINTS = 24  # re-simulation samples per interval


# ---- declaration ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class PathConstraint:
    """lb <= expr(q, a*, v) <= ub at every path point; ``name`` names it in messages."""

    name: str
    expr: ca.Function  # (q, a_star, v) -> scalar, already scaled to O(1)
    lb: float
    ub: float
    uses_control: bool = False  # then also imposed at each interval start, where the control jumps


@dataclass
class SpinupOcp:
    """Declaration of the spin-up problem in SI (converted to the dimensionless form inside)."""

    params: RotorParams
    omega_start: float  # rad/s
    omega_final: float  # rad/s
    horizon: float  # s (the upper bound of the final time when it is free)
    alpha_max: float  # rad/s^2
    objective: str = "peak_deflection"
    settling_time: float = 0.0  # s, window held at omega_final after the horizon
    omega_max: float | None = None  # rad/s
    torque_max: float | None = None  # N m
    power_max: float | None = None  # W
    motor_stall_torque: float | None = None  # N m, L_s
    motor_no_load_speed: float | None = None  # rad/s, omega_nl
    deflection_limit: float | None = None  # delta/e (min_time, or an extra limit for any objective)

    def __post_init__(self):
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}")
        if self.objective == "min_time" and self.deflection_limit is None:
            raise ValueError("the min_time objective needs a deflection_limit")
        if (self.torque_max or self.power_max or self.motor_stall_torque) and \
                self.params.J_p + self.params.m1 * self.params.e**2 * (1 - self.params.psi) <= 0:
            raise ValueError("torque and power limits need the drive's polar inertia J_p > 0")

    # dimensionless data (spec §3.2)
    @property
    def free_time(self) -> bool:
        return self.objective == "min_time"

    @property
    def Om(self) -> float:
        return self.params.Omega0

    @property
    def nu0(self) -> float:
        return self.omega_start / self.Om

    @property
    def nuf(self) -> float:
        return self.omega_final / self.Om

    @property
    def tau_h(self) -> float:
        return self.horizon * self.Om

    @property
    def tau_s(self) -> float:
        return self.settling_time * self.Om

    @property
    def a_max(self) -> float:
        return self.alpha_max / self.Om**2

    @property
    def q0(self) -> list[float]:
        return steady_q(self.params, self.nu0) if self.nu0 > 0 else [0.0, 0.0, 0.0, 0.0, 0.0]

    @property
    def n_extra(self) -> int:
        """Extra decision variables v: the epigraph level (peak objectives) or the final time."""
        return 1 if self.objective != "integrated_deflection" else 0

    def dynamics(self) -> ca.Function:
        """(q, u, h) -> h f(q, u a*_max): the rotating-frame model over an interval of length h."""
        m = rotor_model()
        q, u, h = ca.SX.sym("q", 5), ca.SX.sym("u"), ca.SX.sym("h")
        return ca.Function("spinup_f", [q, u, h], [h * m.ode(q, u * self.a_max, self.params.p)])

    def path_constraints(self, ref: float) -> list[PathConstraint]:
        """Named path constraints; ``ref`` is the scale of the epigraph level (delta^2 or d^2)."""
        m, P = rotor_model(), self.params
        q, a, v = ca.SX.sym("q", 5), ca.SX.sym("a"), ca.SX.sym("v", self.n_extra)
        out = []

        def add(name, expr, lb, ub):
            out.append(PathConstraint(name, ca.Function(f"path{len(out)}", [q, a, v], [expr]), lb, ub,
                                      ca.depends_on(expr, a)))

        if self.objective == "peak_deflection":
            add("deflection epigraph delta^2 <= S", (m.delta2(q) - v[0] * ref) / ref, -ca.inf, 0.0)
        elif self.objective == "peak_unbalance":
            add("unbalance epigraph d^2 <= S", (m.unbalance2(q, P.p) - v[0] * ref) / ref, -ca.inf, 0.0)
        if self.deflection_limit is not None:
            add(f"deflection limit delta/e <= {self.deflection_limit:g}", m.delta2(q) / self.deflection_limit**2,
                -ca.inf, 1.0)
        M = m.torque(q, a, P.p)  # over m1 e^2 Omega0^2
        if self.torque_max is not None:
            add(f"torque limit |M| <= {self.torque_max:g} N m", M * P.torque_scale / self.torque_max, -1.0, 1.0)
        if self.power_max is not None:
            add(f"power limit M omega <= {self.power_max:g} W",
                M * P.torque_scale * q[4] * self.Om / self.power_max, -ca.inf, 1.0)
        if self.motor_stall_torque is not None:
            L = self.motor_stall_torque * (1 - q[4] * self.Om / self.motor_no_load_speed)
            add("motor characteristic M <= L_s (1 - omega/omega_nl)",
                (M * P.torque_scale - L) / self.motor_stall_torque, -ca.inf, 0.0)
        return out

    def nu_bounds(self) -> tuple[float, float]:
        return 0.0, (self.omega_max / self.Om if self.omega_max is not None else ca.inf)


# ---- transcriptions ---------------------------------------------------------------------------------

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
def _collocation(degree: int, scheme: str):
    tau = ca.collocation_points(degree, scheme)
    C, D, B = ca.collocation_coeff(tau)
    return list(tau), np.array(C), np.array(D).ravel(), np.array(B).ravel()


def path_fractions(degree: int, scheme: str) -> list[float]:
    """Instants (fractions of an interval) where path constraints are imposed: the collocation
    points, and the interval end when it is not one of them (Legendre)."""
    tau = _collocation(degree, scheme)[0]
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
    tau, C, D, B = _collocation(d, method.scheme)
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
    nlo, nhi = ocp.nu_bounds()
    for rows in (idx_X, idx_Xc.reshape(-1, 5) if collocation else idx_X):
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
    index = {"X": idx_X, "Xc": idx_Xc, "u": idx_u, "v": idx_v}
    return Nlp(w, obj, ca.vertcat(*g), lbx, ubx, np.concatenate(lbg), np.concatenate(ubg), blocks, index, ms,
               frac, method, ref)


# ---- guesses, simulation --------------------------------------------------------------------------

def simulate_profile(ocp: SpinupOcp, u, h, fractions, tol: float = RESIM_TOL) -> np.ndarray:
    """CVODES run of piecewise-constant u (over alpha_max) on intervals of lengths h (tau):
    states (K, len(fractions), 5) at the fractions of each interval."""
    if abs(fractions[-1] - 1) > 1e-14:
        raise ValueError("the last output fraction must be the interval end (1)")
    F = interval_integrator(tuple(fractions), tol)
    q, out = np.asarray(ocp.q0, float), []
    for uk, hk in zip(u, h, strict=True):
        xf = np.array(interrupt.call(F, x0=q, p=[uk * ocp.a_max, hk, *ocp.params.p])["xf"])
        out.append(xf.T)
        q = xf[:, -1]
    return np.array(out)


def ramp_profile(ocp: SpinupOcp, n: int, alpha: float, hold_at: float | None = None,
                 accel2: float | None = None) -> np.ndarray:
    """Piecewise-constant u on the n control intervals of a ramp: constant acceleration ``alpha``
    until omega_final (then hold), or, with ``hold_at``, ramp to hold_at, hold, and ramp at
    ``accel2`` so as to reach omega_final at the horizon (a piecewise profile for multi-start)."""
    h = ocp.tau_h / n
    nu = np.empty(n + 1)
    nu[0] = ocp.nu0
    a, a_cap = alpha / ocp.Om**2, ocp.a_max
    if hold_at is None:
        for k in range(n):
            nu[k + 1] = min(ocp.nuf, nu[k] + a * h) if ocp.nuf >= ocp.nu0 else max(ocp.nuf, nu[k] - a * h)
    else:
        a2 = (accel2 or ocp.alpha_max) / ocp.Om**2
        t2 = ocp.tau_h - (ocp.nuf - hold_at / ocp.Om) / a2  # start of the second ramp
        for k in range(n):
            t1 = (k + 1) * h
            nu[k + 1] = min(hold_at / ocp.Om, ocp.nu0 + a * t1)
            if t1 > t2:
                nu[k + 1] = min(ocp.nuf, max(nu[k + 1], hold_at / ocp.Om + a2 * (t1 - t2)))
    return np.clip(np.diff(nu) / h / a_cap, -1, 1)


def initial_guess(ocp: SpinupOcp, nlp: Nlp, u: np.ndarray) -> np.ndarray:
    """Fill all NLP variables by simulating the control profile u (n control intervals)."""
    ms = nlp.mesh
    uu = np.concatenate([u, np.zeros(ms.ns)])
    h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])
    w0 = np.zeros(nlp.x.numel())
    if nlp.index["Xc"] is not None:
        sim = simulate_profile(ocp, uu, h, path_fractions(nlp.method.degree, nlp.method.scheme), tol=1e-8)
        d = nlp.method.degree
        w0[nlp.index["Xc"]] = sim[:, :d, :]
        w0[nlp.index["X"][1:]] = sim[:, -1, :]
    else:
        sim = simulate_profile(ocp, uu, h, [1.0], tol=1e-8)
        w0[nlp.index["X"][1:]] = sim[:, -1, :]
    w0[nlp.index["X"][0]] = ocp.q0
    w0[nlp.index["u"]] = uu
    if ocp.free_time:
        w0[nlp.index["v"][0]] = 1.0
    elif nlp.index["v"]:
        pts = np.array(w0[nlp.index["Xc"]] if nlp.index["Xc"] is not None else w0[nlp.index["X"]]).reshape(-1, 5)
        if ocp.objective == "peak_deflection":
            level = np.max(pts[:, 0] ** 2 + pts[:, 1] ** 2)
        else:
            level = np.max(unbalance(pts.T, ocp.params.psi) ** 2)
        w0[nlp.index["v"][0]] = 1.05 * level / nlp.ref
    return w0


# ---- results --------------------------------------------------------------------------------------

@dataclass
class Trajectory:
    """A speed profile and the rotor's response, in SI (deflection over e)."""

    label: str
    t: np.ndarray  # s
    omega: np.ndarray  # rad/s
    delta: np.ndarray  # delta/e
    d: np.ndarray  # system unbalance d (9')
    torque: np.ndarray  # N m (nan without drive data)
    t_u: np.ndarray  # interval starts, s
    alpha: np.ndarray  # rad/s^2 on each interval
    peak_delta: float
    peak_d: float
    t_peak: float
    integral_delta2: float  # integral of (delta/e)^2 dt, s

    def to_dict(self) -> dict:
        return {"label": self.label, "peak_deflection_over_e": self.peak_delta, "peak_unbalance": self.peak_d,
                "time_of_peak_s": self.t_peak, "integral_deflection2_s": self.integral_delta2}


def resimulate(ocp: SpinupOcp, u, h, label: str, points: int = RESIM_POINTS, tol: float = RESIM_TOL) -> Trajectory:
    """CVODES at tight tolerance with the piecewise-constant profile u (over alpha_max) on intervals h."""
    frac = list(np.linspace(0, 1, points + 1)[1:])
    sim = simulate_profile(ocp, u, h, frac, tol=tol)
    K = len(u)
    t0 = np.concatenate([[0.0], np.cumsum(h)[:-1]])
    tau = np.concatenate([[0.0], (t0[:, None] + np.asarray(h)[:, None] * np.array(frac)[None, :]).ravel()])
    q = np.vstack([np.asarray(ocp.q0, float)[None, :], sim.reshape(K * points, 5)]).T
    a = np.concatenate([np.repeat(np.asarray(u) * ocp.a_max, points)[:1], np.repeat(np.asarray(u) * ocp.a_max,
                                                                                     points)])
    dl, dd = deflection(q), unbalance(q, ocp.params.psi)
    pk, tpk = peak(tau, dl)
    m = rotor_model()
    P = ocp.params
    # the drive torque of spec §8.3 (without drive data J_p = b = 0: the unbalance reaction alone)
    torque = np.array(m.torque.map(q.shape[1])(q, a[None, :], ca.repmat(ca.DM(P.p), 1, q.shape[1]))).ravel() \
        * P.torque_scale
    Om = ocp.Om
    integral = float(np.trapezoid(dl**2, tau) / Om)
    return Trajectory(label, tau / Om, q[4] * Om, dl, dd, torque, t0 / Om, np.asarray(u) * ocp.alpha_max,
                      pk, peak(tau, dd)[0], tpk / Om, integral)


@dataclass
class SpinupSolution:
    """One IPOPT solve of one transcription."""

    method: str
    status: str
    success: bool
    iterations: int
    solve_time_s: float
    build_time_s: float
    objective: float  # the NLP's objective in problem units (delta/e, d, integral (s), or T (s))
    final_time_s: float
    u: np.ndarray  # control intervals (over alpha_max), settling window included (zeros)
    h: np.ndarray  # interval lengths, tau
    points: np.ndarray  # (K, npath, 5) states at the path points (collocation or shooting outputs)
    peak_collocation: float  # largest delta/e at the path points (or d for peak_unbalance)
    w: np.ndarray = field(repr=False, default=None)


def _objective_value(ocp: SpinupOcp, nlp: Nlp, wopt: np.ndarray, f: float) -> float:
    if ocp.objective in ("peak_deflection", "peak_unbalance"):
        return math.sqrt(max(f, 0.0) * nlp.ref)
    if ocp.objective == "min_time":
        return f * ocp.horizon
    return f * nlp.ref / ocp.Om


def _points(nlp: Nlp, wopt: np.ndarray, ocp: SpinupOcp) -> np.ndarray:
    if nlp.index["Xc"] is not None:
        pts = wopt[nlp.index["Xc"]]
        if len(nlp.fractions) > nlp.method.degree:
            pts = np.concatenate([pts, wopt[nlp.index["X"][1:]][:, None, :]], axis=1)
        return pts
    u, h = _controls(nlp, wopt, ocp)
    return simulate_profile(ocp, u, h, nlp.fractions, tol=nlp.method.tol)  # = the shooting outputs


def _controls(nlp: Nlp, wopt: np.ndarray, ocp: SpinupOcp) -> tuple[np.ndarray, np.ndarray]:
    ms = nlp.mesh
    hn = wopt[nlp.index["v"][0]] * ocp.tau_h / ms.n if ocp.free_time else ms.h
    return wopt[nlp.index["u"]], np.concatenate([np.full(ms.n, hn), np.full(ms.ns, ms.hs)])


class Solver:
    """The NLP of one (problem, method) pair, built once and solved from any guess."""

    def __init__(self, ocp: SpinupOcp, method, ref: float | None = None):
        t0 = time.perf_counter()
        self.ocp, self.method = ocp, method
        if ref is None:
            ref = 1.0
            if ocp.objective in ("peak_deflection", "peak_unbalance", "integrated_deflection"):
                base = resimulate(ocp, ramp_profile(ocp, 50, ocp.alpha_max), np.full(50, ocp.tau_h / 50), "ref", 8,
                                  1e-8)
                ref = {"peak_deflection": base.peak_delta**2, "peak_unbalance": base.peak_d**2,
                       "integrated_deflection": base.integral_delta2 * ocp.Om}[ocp.objective]
        self.nlp = transcribe(ocp, method, ref)
        nlp = self.nlp
        extra = dict(IPOPT_OPTIONS)
        if isinstance(method, MultipleShooting):
            extra["hessian_approximation"] = method.hessian
        self.solver = ipopt.nlpsol("spinup", nlp.x, ca.SX.sym("p", 0) if isinstance(nlp.x, ca.SX) else ca.MX.sym(
            "p", 0), nlp.f, nlp.g, **extra)
        self.build_time_s = time.perf_counter() - t0

    def solve(self, u_guess: np.ndarray | None = None, w0: np.ndarray | None = None, raise_on_failure=True
              ) -> SpinupSolution:
        ocp, nlp = self.ocp, self.nlp
        if w0 is None:
            if u_guess is None:
                u_guess = ramp_profile(ocp, nlp.mesh.n, ocp.alpha_max if ocp.free_time else
                                       (ocp.omega_final - ocp.omega_start) / ocp.horizon)
            w0 = initial_guess(ocp, nlp, u_guess)
        t0 = time.perf_counter()
        r = ipopt.solve(self.solver, x0=w0, lbx=nlp.lbx, ubx=nlp.ubx, lbg=nlp.lbg, ubg=nlp.ubg)
        dt = time.perf_counter() - t0
        wopt = r["x"]
        if not r["success"] and raise_on_failure:
            raise infeasibility_error(ocp, nlp, wopt, r)
        u, h = _controls(nlp, wopt, ocp)
        pts = _points(nlp, wopt, ocp)
        if ocp.objective == "peak_unbalance":
            pk = float(np.max(unbalance(pts.reshape(-1, 5).T, ocp.params.psi)))
        else:
            pk = float(np.max(np.hypot(pts[..., 0], pts[..., 1])))
        return SpinupSolution(self.method.label, r["status"], r["success"], r["iterations"], dt, self.build_time_s,
                              _objective_value(ocp, nlp, wopt, float(r["f"][0])), float(np.sum(h[:nlp.mesh.n]))
                              / ocp.Om, u, h, pts, pk, wopt)


def infeasibility_error(ocp: SpinupOcp, nlp: Nlp, wopt: np.ndarray, r: dict) -> SolveError:
    """A SolveError naming the binding constraint: the drive limit that is active on most of the
    horizon at the last iterate (acceleration bound, torque, power, motor, speed limit), the final-speed
    condition it prevents, and the constraint blocks the last iterate violates; the last iterate goes
    with it (the CLI saves it)."""
    g = np.asarray(r["g"]).ravel()
    viol = np.maximum(np.maximum(nlp.lbg - g, g - nlp.ubg), 0.0)
    u, h = _controls(nlp, wopt, ocp)
    n = nlp.mesh.n
    X = wopt[nlp.index["X"]]
    active = {f"acceleration limit |alpha| <= {ocp.alpha_max:g} rad/s^2": float(np.mean(np.abs(u[:n]) > 1 - 1e-6))}
    if ocp.omega_max is not None:
        active[f"speed limit omega <= {ocp.omega_max:g} rad/s"] = float(np.mean(X[1:, 4] * ocp.Om >
                                                                              ocp.omega_max * (1 - 1e-6)))
    for name, a, b in nlp.blocks:
        if "limit" in name or "characteristic" in name:
            gap = np.minimum(g[a:b] - nlp.lbg[a:b], nlp.ubg[a:b] - g[a:b])
            active[name] = float(np.mean(gap < 1e-6))
    binding = max(active, key=active.get)
    parts = [f"spin-up OCP infeasible or not solved ({nlp.method.label})"]
    if active[binding] > 0.5:
        parts.append(f"binding constraint: {binding}, active on {100 * active[binding]:.0f} % of the horizon, "
                     f"prevents the final speed omega(T) = {ocp.omega_final:g} rad/s")
    if binding.startswith("acceleration") and active[binding] > 0.5:
        parts.append(f"alpha_max x horizon = {ocp.alpha_max * ocp.horizon:.4g} rad/s of speed change, "
                     f"{abs(ocp.omega_final - ocp.omega_start):.4g} rad/s needed")
    elif active[binding] > 0.5:
        parts.append(f"the last iterate ends at omega = {X[n, 4] * ocp.Om:.4g} rad/s")
    bad = [(name, float(viol[a:b].max(initial=0.0))) for name, a, b in nlp.blocks]
    bad = [f"'{k}' by {v:.3g}" for k, v in bad if v > 1e-6]
    if bad:
        parts.append("the last iterate violates " + ", ".join(bad))
    last = {"t_s": list(np.concatenate([[0.0], np.cumsum(h)]) / ocp.Om), "omega_rad_s": list(X[:, 4] * ocp.Om),
            "deflection_over_e": list(np.hypot(X[:, 0], X[:, 1])), "alpha_rad_s2": list(u * ocp.alpha_max),
            "constraint_violation": {b[0]: float(viol[b[1]:b[2]].max(initial=0.0)) for b in nlp.blocks},
            "active_fraction": active}
    return SolveError("; ".join(parts), r["status"], last)


# ---- multi-start optimisation -----------------------------------------------------------------------

def starts(ocp: SpinupOcp, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
    """Initial control profiles: the constant ramp first, then (multi-start) the maximum-acceleration
    ramp with hold, a faster constant ramp, and a piecewise ramp that holds below the critical speed."""
    const = abs(ocp.omega_final - ocp.omega_start) / ocp.horizon
    out = [("constant ramp", ramp_profile(ocp, n, min(const, ocp.alpha_max) if not ocp.free_time else ocp.alpha_max))]
    if not multistart:
        return out
    out.append(("maximum-acceleration ramp and hold", ramp_profile(ocp, n, ocp.alpha_max)))
    if not ocp.free_time:
        out.append(("ramp at the mean of both", ramp_profile(ocp, n, 0.5 * (const + ocp.alpha_max))))
        w_hold = 0.8 * ocp.params.omega_cr
        t_need = (w_hold - ocp.omega_start + ocp.omega_final - w_hold) / ocp.alpha_max
        if ocp.omega_start < w_hold < ocp.omega_final and t_need < 0.9 * ocp.horizon:
            out.append(("ramp, hold at 0.8 omega_cr, ramp", ramp_profile(ocp, n, ocp.alpha_max, hold_at=w_hold)))
    return out


@dataclass
class Optimum:
    """The best of the multi-start solves, judged by its CVODES re-simulation."""

    ocp: SpinupOcp
    solution: SpinupSolution
    trajectory: Trajectory  # the re-simulation of the optimal profile
    score: float  # the re-simulated objective (delta/e, d, integral (s) or T (s))
    starts: list  # one dict per start
    collocation_value: float  # the transcription's own value of the same measure
    build_time_s: float

    @property
    def resimulation_rel_error(self) -> float:
        return abs(self.collocation_value - self.score) / abs(self.score)


def resimulated_scores(ocp: SpinupOcp, sol: SpinupSolution, tr: Trajectory) -> tuple[float, float]:
    """(re-simulated measure, the transcription's value of the same measure)."""
    if ocp.objective == "peak_unbalance":
        return tr.peak_d, sol.peak_collocation
    if ocp.objective == "integrated_deflection":
        return tr.integral_delta2, sol.objective
    if ocp.objective == "min_time":
        return sol.final_time_s, sol.final_time_s
    return tr.peak_delta, sol.peak_collocation


def optimize(ocp: SpinupOcp, method, multistart: bool = True) -> Optimum:
    """Solve from every start; keep the best optimum by its re-simulated objective (for min_time: the
    shortest time whose re-simulated peak keeps the deflection limit within 1 %).

    min_time is solved by continuation: first the smallest peak over the full horizon (if even that
    exceeds the deflection limit, the limit is the binding constraint and no time is feasible), then
    the minimum time started from that profile."""
    solver = Solver(ocp, method)
    rows, best, first_error = [], None, None
    start_list = starts(ocp, solver.nlp.mesh.n, multistart)
    if ocp.free_time:
        peak_ocp = dataclasses.replace(ocp, objective="peak_deflection", deflection_limit=None)
        pk = optimize(peak_ocp, method, multistart)
        if pk.score > ocp.deflection_limit:
            raise SolveError(f"spin-up OCP infeasible: binding constraint: deflection limit delta/e <= "
                             f"{ocp.deflection_limit:g}; the smallest peak reachable within the horizon "
                             f"{ocp.horizon:g} s is {pk.score:.4g} e", "Infeasible_Problem_Detected",
                             {"smallest_peak_over_e": pk.score, "t_s": list(pk.trajectory.t),
                              "omega_rad_s": list(pk.trajectory.omega)})
        start_list = [("minimum-peak profile over the horizon", pk.solution.u[:solver.nlp.mesh.n])]
    for label, u in start_list:
        try:
            sol = solver.solve(u)
        except SolveError as exc:
            if exc.status in INFEASIBLE:  # no other start can fix the limits
                raise
            first_error = first_error or exc
            rows.append({"start": label, "status": exc.status, "success": False})
            continue
        tr = resimulate(ocp, sol.u, sol.h, "optimum")
        score, own = resimulated_scores(ocp, sol, tr)
        ok = ocp.deflection_limit is None or tr.peak_delta <= 1.01 * ocp.deflection_limit
        rows.append({"start": label, "status": sol.status, "success": True, "iterations": sol.iterations,
                     "solve_time_s": sol.solve_time_s, "objective": score, "resimulated_peak_over_e": tr.peak_delta,
                     "keeps_limit": ok})
        if ok and (best is None or score < best[0] * (1 - TIE)):  # ties go to the earlier start
            best = (score, own, sol, tr)
    if best is None:
        raise first_error or SolveError("no start keeps the deflection limit after re-simulation", "limit_violated")
    score, own, sol, tr = best
    return Optimum(ocp, sol, tr, score, rows, own, solver.build_time_s)


def baselines(ocp: SpinupOcp, intervals: int = 2000) -> dict[str, Trajectory]:
    """The constant-ramp baselines (CVODES, fine piecewise-constant mesh): the constant ramp over the
    horizon and the maximum-acceleration ramp followed by a hold, each with the settling window."""
    ms = mesh(ocp, intervals)
    h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])
    const = min(abs(ocp.omega_final - ocp.omega_start) / ocp.horizon, ocp.alpha_max)
    out = {}
    for key, label, a in (("constant_ramp", f"constant ramp {const:.4g} rad/s^2", const),
                          ("max_acceleration_ramp", f"ramp {ocp.alpha_max:.4g} rad/s^2 and hold", ocp.alpha_max)):
        u = np.concatenate([ramp_profile(ocp, ms.n, a), np.zeros(ms.ns)])
        out[key] = resimulate(ocp, u, h, label, points=6)
    return out
