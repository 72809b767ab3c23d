"""Parameter estimation of the balancing device from measured static and flow characteristics
(Pavlenko 2014, Sec. 4.4, Eqs. (4.14)-(4.38); spec reliability-experiments-estimation.md §4.5, §5).

Two models:

* ``traditional_disc`` — the disc of Sec. 4.4 without outer throttle, both throttles turbulent,
  parameters alpha = g_TB/g1 and tau_max = sigma psi1: static characteristic (4.18)
  u = cbrt[(tau_max/tau - 1)/alpha^2] and flow characteristic (4.31)
  q = sqrt[(1 + alpha^2)/alpha^2 (1 - tau/tau_max)], q = Q/Q_B with Q_B of (4.28).
* ``device`` — the full static model of models/device.py (any conductance ratio, area ratio or
  loss coefficient of the flow network free).  The parameters enter the balances affinely, so
  the parametric balances are assembled exactly from ``static_system`` instances (no second copy
  of the equations; checked on construction) and the fit is one NLP in the parameters and the
  static states of every data point (balances as equality constraints, stops as
  :class:`~autobal.analysis.statics.StaticsSolver` found them at the initial guess; the fitted
  model is re-solved by StaticsSolver to confirm).

Nonlinear least squares min 0.5 ||r||^2, r = weight (model - measured), in u, q or both, with
bounds and any subset of parameters free, is solved by IPOPT with a **Gauss-Newton Hessian**:
CasADi's ``hess_lag`` option hands IPOPT lam_f J'J (J = dr/dx, x = scaled parameters and states),
so no second derivatives of the model or of the balances are formed (for the device model this
is the constrained Gauss-Newton method).  The optimum is that of the exact problem: IPOPT's
stopping test uses exact gradients; the Hessian only shapes the steps.  ``hessian: exact`` gives
IPOPT the exact Lagrangian Hessian instead.

Uncertainty (an extension; the source gives none, spec §5.6): with J the Jacobian of r in the free
parameters at the optimum (for the device model the reduced Jacobian through the implicit-function
theorem), s^2 = ||r||^2/(N - p), covariance s^2 (J'J)^-1, standard errors, Student-t confidence
intervals, correlation, and a delta-method confidence band of the fitted curve.

The source's closed-form estimators minimise *transformed* residuals (linear in alpha^2 or in
(tau_max, alpha^2)), not the residual in u or q, and are kept as cross-checks: (4.23), (4.26)-(4.27),
(4.35) and the two-parameter flow problem (4.36) solved numerically.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np
from scipy import optimize, stats

from autobal.analysis import ipopt
from autobal.errors import ScenarioError, SolveError
from autobal.models.device import DEVICE_GROUPS, REGULATOR_GROUPS

DISC = ("alpha", "tau_max")


# ---- the traditional disc, (4.16)-(4.31) ------------------------------------------------------

def gap_from_load(tau, alpha, tau_max):
    """Static characteristic (4.18): u = cbrt[(tau_max/tau - 1)/alpha^2] (numpy or CasADi)."""
    return ((tau_max / tau - 1.0) / alpha**2) ** (1.0 / 3.0)


def load_from_gap(u, alpha, tau_max):
    """(4.16)-(4.17): tau = tau_max / (1 + alpha^2 u^3)."""
    return tau_max / (1.0 + alpha**2 * u**3)


def flow_from_load(tau, alpha, tau_max):
    """Flow characteristic (4.31): q = sqrt[(1 + alpha^2)/alpha^2 (1 - tau/tau_max)], q = Q/Q_B."""
    return ((1.0 + alpha**2) / alpha**2 * (1.0 - tau / tau_max)) ** 0.5


def flow_from_gap(u, alpha):
    """(4.30): q = sqrt[(1 + alpha^2) u^3 / (1 + alpha^2 u^3)]."""
    return ((1.0 + alpha**2) * u**3 / (1.0 + alpha**2 * u**3)) ** 0.5


def base_flow(g1: float, g_tb: float, p1: float) -> float:
    """Q_B of (4.28): the flow at u = 1, sqrt(g1^2 g_TB^2 p1/(g1^2 + g_TB^2)) (OCR's g_c is g1)."""
    return math.sqrt(g1**2 * g_tb**2 * p1 / (g1**2 + g_tb**2))


# ---- the source's closed-form estimators (transformed residuals) --------------------------------

def static_1p(tau, u, tau_max: float) -> float:
    """alpha of (4.23), tau_max fixed: minimises sum [1/tau_i - (1 + alpha^2 u_i^3)/tau_max]^2 (4.20)."""
    tau, u = np.asarray(tau, float), np.asarray(u, float)
    return math.sqrt(np.sum((tau_max / tau - 1.0) * u**3) / np.sum(u**6))


def static_2p(tau, u) -> tuple[float, float]:
    """(tau_max, alpha) of (4.26)-(4.27): the normal equations (4.25) of the linear residual
    tau_max - tau_i (1 + alpha^2 u_i^3) (spec §5.3)."""
    tau, u = np.asarray(tau, float), np.asarray(u, float)
    n = len(tau)
    s0, s1, s2, s3 = tau.sum(), (u**3 * tau).sum(), (u**6 * tau**2).sum(), (u**3 * tau**2).sum()
    det = n * s2 - s1**2
    alpha2 = (s0 * s1 - n * s3) / det
    return (s0 * s2 - s1 * s3) / det, math.sqrt(alpha2) if alpha2 > 0 else math.nan


def flow_1p(tau, q, tau_max: float) -> float:
    """alpha of (4.35), tau_max fixed: minimises sum [(q_i^2 - 1 + tau_i/tau_max) alpha^2
    - (1 - tau_i/tau_max)]^2 ((4.33) with the sign of (4.34), spec §5.4)."""
    tau, q = np.asarray(tau, float), np.asarray(q, float)
    c = q**2 - 1.0 + tau / tau_max
    alpha2 = np.sum(c * (1.0 - tau / tau_max)) / np.sum(c**2)
    return math.sqrt(alpha2) if alpha2 > 0 else math.nan


def flow_sums(tau, q) -> dict:
    """The sums a1..a5 of (4.37) (a3 as corrected in spec §5.5) and n."""
    tau, q = np.asarray(tau, float), np.asarray(q, float)
    d = q**2 - 1.0
    return {"a1": np.sum(d**2), "a2": np.sum(d), "a3": np.sum(tau * d), "a4": np.sum(tau), "a5": np.sum(tau**2),
            "n": len(tau)}


def stationarity_4_36(x: float, y: float, s: dict) -> tuple[float, float]:
    """The two stationarity conditions of (4.36), as corrected in spec §5.5, at x = tau_max, y = alpha^2."""
    a1, a2, a3, a4, a5, n = (s[k] for k in ("a1", "a2", "a3", "a4", "a5", "n"))
    return (x * (a1 * y**2 - 2 * a2 * y + n) + a3 * y**2 + (a3 - a4) * y - a4,
            (a1 * x**2 + 2 * a3 * x + a5) * y - a2 * x**2 + (a3 - a4) * x + a5)


def flow_2p(tau, q, start: tuple[float, float] | None = None) -> tuple[float, float]:
    """(tau_max, alpha) minimising the transformed residual of (4.36),
    r_i = [(q_i^2 - 1) x + tau_i] y - x + tau_i with x = tau_max, y = alpha^2, numerically (the
    source: "solved numerically").  Bounds x > max tau, y > 0 exclude the spurious zero-residual
    point x = 0, y = -1 of this residual."""
    tau, q = np.asarray(tau, float), np.asarray(q, float)
    if start is None:
        x0 = 1.3 * tau.max()
        start = (x0, flow_1p(tau, q, x0))
    x0, a0 = start
    y0 = a0**2 if np.isfinite(a0) and a0 > 0 else 1.0

    def res(v):
        return ((q**2 - 1.0) * v[0] + tau) * v[1] - v[0] + tau

    def jac(v):
        return np.column_stack([(q**2 - 1.0) * v[1] - 1.0, (q**2 - 1.0) * v[0] + tau])

    lo = [tau.max() * (1 + 1e-9), 1e-12]
    sol = optimize.least_squares(res, [max(x0, lo[0] * 1.01), y0], jac=jac, bounds=(lo, [np.inf, np.inf]),
                                 xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return float(sol.x[0]), math.sqrt(sol.x[1])


# ---- (4.38): conductance ratio from loss coefficients --------------------------------------------

LOSS_NAMES = ("zeta1", "lambda1", "zeta2", "lambda2")


def alpha_from_losses(lc, **override) -> float:
    """(4.38) as corrected (spec §5.7): alpha = (d_m/d_u)(h_TB/h1) sqrt[(zeta1 + f lambda1 l1/h1) /
    (zeta2 + f lambda2 l2/h_TB)]; f = ``friction_factor`` (0.5: zeta + lambda l/(2h) as (2.11) and
    §4.5; 1.0: (4.38) as printed).  ``lc``: a LossCoefficient block (SI)."""
    v = {k: getattr(lc, k) for k in LOSS_NAMES} | override
    f = lc.friction_factor
    num = v["zeta1"] + f * v["lambda1"] * lc.seal_length / lc.seal_clearance
    den = v["zeta2"] + f * v["lambda2"] * lc.face_length / lc.base_gap
    return (lc.face_mean_diameter / lc.seal_diameter) * (lc.base_gap / lc.seal_clearance) * math.sqrt(num / den)


def loss_from_alpha(lc, alpha: float) -> float:
    """Solve (4.38) for the loss coefficient ``lc.unknown``, the others fixed; closed form."""
    f = lc.friction_factor
    k = (alpha / ((lc.face_mean_diameter / lc.seal_diameter) * (lc.base_gap / lc.seal_clearance))) ** 2
    seal = lc.seal_length / lc.seal_clearance
    face = lc.face_length / lc.base_gap
    num = lc.zeta1 + f * lc.lambda1 * seal
    den = lc.zeta2 + f * lc.lambda2 * face
    return {"zeta1": k * den - f * lc.lambda1 * seal,
            "lambda1": (k * den - lc.zeta1) / (f * seal),
            "zeta2": num / k - f * lc.lambda2 * face,
            "lambda2": (num / k - lc.zeta2) / (f * face)}[lc.unknown]


# ---- Fisher adequacy test (4.14)-(4.15) -----------------------------------------------------------

def fisher_adequacy(load, measured, group, theory, parameters: int, significance: float = 0.1) -> dict:
    """The source's adequacy test (4.14)-(4.15) and the standard lack-of-fit F test.

    ``theory(loads)`` gives the model value at each group's load.  Source:
    sigma1^2 = sum_groups (u_theory - u_mean)^2/(n - l), sigma2^2 = sum_points (u - u_mean)^2/(m - 1),
    F = sigma1^2/sigma2^2 against F_crit = F_{1-significance}(n - l, m - 1).  **Decision rule: the
    model is adequate when F <= F_crit**; the source calls F > F_crit adequate (inverted, spec
    §4.5), reported as ``source_rule_adequate``.  The standard test weights each group by its
    size and uses the pure-error variance on m - n degrees of freedom.
    """
    load, measured, group = (np.asarray(a, float) for a in (load, measured, group))
    labels = np.unique(group)
    n, m, l_ = len(labels), len(measured), parameters
    idx = np.searchsorted(labels, group)
    sizes = np.bincount(idx)
    means = np.bincount(idx, measured) / sizes
    loads = np.bincount(idx, load) / sizes
    spread = max(np.ptp(load[idx == k]) for k in range(n))
    th = np.asarray(theory(loads), float)
    out = {"groups": n, "points": m, "parameters": l_, "significance": significance,
           "group_load": loads, "group_mean": means, "group_theory": th, "load_spread_in_groups": spread}
    if n - l_ < 1 or m < 2:
        return out | {"F": None, "note": f"needs more groups ({n}) than parameters ({l_})"}
    s1 = np.sum((th - means) ** 2) / (n - l_)
    ss_pe = np.sum((measured - means[idx]) ** 2)
    s2 = ss_pe / (m - 1)
    f_emp = s1 / s2
    f_crit = stats.f.ppf(1 - significance, n - l_, m - 1)
    out |= {"sigma1_sq": s1, "sigma2_sq": s2, "F": f_emp, "F_crit": f_crit, "dof": [n - l_, m - 1],
            "p_value": stats.f.sf(f_emp, n - l_, m - 1), "adequate": bool(f_emp <= f_crit),
            "source_rule_adequate": bool(f_emp > f_crit),
            "rule": "adequate when F <= F_crit (the source's text calls F > F_crit adequate: inverted)"}
    if m - n >= 1:
        ss_lof = np.sum(sizes * (means - th) ** 2)
        f_lof = (ss_lof / (n - l_)) / (ss_pe / (m - n))
        crit = stats.f.ppf(1 - significance, n - l_, m - n)
        out["lack_of_fit"] = {"F": f_lof, "F_crit": crit, "dof": [n - l_, m - n],
                              "p_value": stats.f.sf(f_lof, n - l_, m - n), "adequate": bool(f_lof <= crit)}
    return out


# ---- least squares with IPOPT ------------------------------------------------------------------------

def uncertainty(r, J, estimate, confidence: float = 0.95) -> dict:
    """Standard errors, Student-t confidence intervals and correlation from the Jacobian J of the
    weighted residual r in the free parameters at the optimum: cov = s^2 (J'J)^-1, s^2 = r'r/(N - p)."""
    r, J, est = np.asarray(r, float), np.atleast_2d(np.asarray(J, float)), np.asarray(estimate, float)
    n, p = J.shape
    dof = n - p
    ssr = float(r @ r)
    s2 = ssr / dof if dof > 0 else math.nan
    jtj = J.T @ J
    cond = float(np.linalg.cond(jtj))
    cov = s2 * np.linalg.inv(jtj) if cond < 1e14 else np.full((p, p), math.nan)
    se = np.sqrt(np.diag(cov))
    t = stats.t.ppf(0.5 + confidence / 2, dof) if dof > 0 else math.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    return {"points": n, "dof": dof, "ssr": ssr, "residual_std": math.sqrt(s2) if dof > 0 else math.nan,
            "covariance": cov, "standard_error": se, "t_quantile": t, "ci_low": est - t * se, "ci_high": est + t * se,
            "correlation": corr, "jtj_condition": cond, "confidence": confidence}


class LeastSquares:
    """min 0.5 ||r(x; p)||^2 s.t. g(x; p) = 0 and bounds, by IPOPT; x = [scaled parameters (n_theta);
    states].  ``hessian``: "gauss-newton" (lam_f J'J through CasADi's ``hess_lag``) or "exact".
    Built once, called many times (data and fixed values are the NLP parameters ``p``)."""

    def __init__(self, name: str, x, p, r, g, n_theta: int, hessian: str = "gauss-newton", max_iter: int = 300,
                 tol: float | None = None):
        f = 0.5 * ca.sumsqr(r)
        opts = {"max_iter": max_iter} | ({"tol": tol, "constr_viol_tol": tol, "compl_inf_tol": tol} if tol else {})
        if hessian == "gauss-newton":
            J = ca.jacobian(r, x)
            lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", g.numel())
            hess = ca.Function("gauss_newton_hessian", [x, p, lam_f, lam_g], [ca.triu(lam_f * ca.mtimes(J.T, J))],
                               ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])
            self.solver = ipopt.nlpsol(name, x, p, f, g, hess_lag=hess, **opts)
        elif hessian == "exact":
            self.solver = ipopt.nlpsol(name, x, p, f, g, **opts)
        else:
            raise ValueError(f"hessian must be 'gauss-newton' or 'exact', got {hessian!r}")
        self.n_theta = n_theta
        self.ng = g.numel()
        self._parts = ca.Function(f"{name}_parts", [x, p], [r, ca.jacobian(r, x), ca.jacobian(g, x)])

    def solve(self, x0, lbx, ubx, p) -> dict:
        """IPOPT's solution, with the residual r and its reduced Jacobian in the scaled parameters
        (states eliminated by the implicit-function theorem: dz/dtheta = -g_z^-1 g_theta)."""
        res = ipopt.solve(self.solver, x0=x0, lbx=lbx, ubx=ubx, lbg=0, ubg=0, p=p)
        r, jr, jg = (np.asarray(v.full()) for v in self._parts(res["x"], p))
        k = self.n_theta
        J = jr[:, :k]
        if self.ng:
            J = J - jr[:, k:] @ np.linalg.solve(jg[:, k:], jg[:, :k])
        return res | {"r": r.ravel(), "J": J}


def _scale(value: float) -> float:
    return abs(value) if value != 0 else 1.0


@dataclass
class FitResult:
    """One fit: estimates, uncertainty, data and fitted values, solver report (plain data)."""

    name: str
    model: str
    residual: str
    hessian: str
    free: list[str]
    estimate: dict  # every parameter of the fit (free and fixed)
    initial: dict
    bounds: dict  # name -> (lower, upper), free parameters
    load: np.ndarray  # dimensionless load of each data point (tau, or psi1 for device data given so)
    measured: dict  # "u" / "q" -> measured values
    fitted: dict  # "u" / "q" -> model values at the data
    weights: dict
    stats: dict  # uncertainty()
    solver: dict  # status, iterations, success, hessian
    extra: dict = field(default_factory=dict)
    curve: dict = field(default_factory=dict)  # load grid, "u"/"q" -> (value, band low, band high)

    def se(self, name: str) -> float:
        return float(self.stats["standard_error"][self.free.index(name)]) if name in self.free else 0.0

    def interval(self, name: str) -> tuple[float, float]:
        if name not in self.free:
            return self.estimate[name], self.estimate[name]
        i = self.free.index(name)
        return float(self.stats["ci_low"][i]), float(self.stats["ci_high"][i])


def _measured_parts(residual: str) -> list[str]:
    return {"u": ["u"], "q": ["q"], "both": ["u", "q"]}[residual]


class DiscFitter:
    """Least squares of (4.18) and/or (4.31) for n data points, IPOPT with a Gauss-Newton Hessian.

    The NLP is built once for (n, residual, free set, hessian) and reused: loads, measured values,
    weights, fixed parameter values and scales are NLP parameters.
    """

    def __init__(self, n: int, residual: str = "u", free: tuple[str, ...] = DISC, hessian: str = "gauss-newton",
                 max_iter: int = 300, tol: float | None = None):
        self.n, self.residual, self.free, self.hessian = n, residual, tuple(free), hessian
        x = ca.SX.sym("x", len(self.free))
        tau, um, qm = ca.SX.sym("tau", n), ca.SX.sym("u", n), ca.SX.sym("q", n)
        w, fixed, scale = ca.SX.sym("w", 2), ca.SX.sym("fixed", 2), ca.SX.sym("scale", 2)
        theta = [scale[j] * x[self.free.index(k)] if k in self.free else fixed[j] for j, k in enumerate(DISC)]
        parts = []
        if residual in ("u", "both"):
            parts.append(w[0] * (gap_from_load(tau, *theta) - um))
        if residual in ("q", "both"):
            parts.append(w[1] * (flow_from_load(tau, *theta) - qm))
        self.ls = LeastSquares(f"fit_disc_{residual}", x, ca.vertcat(tau, um, qm, w, fixed, scale),
                               ca.vertcat(*parts), ca.SX(0, 1), len(self.free), hessian, max_iter, tol)

    def fit(self, tau, u=None, q=None, values: dict | None = None, bounds: dict | None = None,
            weights: dict | None = None, name: str = "fit") -> FitResult:
        """Fit; ``values``: alpha, tau_max (initial guess when free, value when fixed); ``bounds``:
        name -> (lower, upper) of free parameters (None for the default: alpha > 0, tau_max > max tau)."""
        tau = np.asarray(tau, float)
        values = {"alpha": 1.75, "tau_max": 2.75} | (values or {})
        weights = {"u": 1.0, "q": 1.0} | (weights or {})
        default = {"alpha": (1e-8, math.inf), "tau_max": (tau.max() * (1 + 1e-9), math.inf)}
        bnd = {k: tuple(d if b is None else b for b, d in zip((bounds or {}).get(k, (None, None)), default[k],
                                                              strict=True)) for k in self.free}
        scale = np.array([_scale(values[k]) for k in DISC])
        sc = {k: scale[DISC.index(k)] for k in self.free}
        zeros = np.zeros(self.n)
        meas = {"u": zeros if u is None else np.asarray(u, float), "q": zeros if q is None else np.asarray(q, float)}
        p = np.concatenate([tau, meas["u"], meas["q"], [weights["u"], weights["q"]],
                            [values[k] for k in DISC], scale])
        x0 = [values[k] / sc[k] for k in self.free]
        res = self.ls.solve(x0, [bnd[k][0] / sc[k] for k in self.free], [bnd[k][1] / sc[k] for k in self.free], p)
        est = dict(values)
        for i, k in enumerate(self.free):
            est[k] = float(res["x"][i] * sc[k])
        if not res["success"]:
            raise SolveError(f"fit {name!r} (traditional_disc, residual in {self.residual}) did not converge",
                             res["status"], {"iterations": res["iterations"], **est})
        J = res["J"] / np.array([sc[k] for k in self.free])
        parts = _measured_parts(self.residual)
        fitted = {"u": gap_from_load(tau, est["alpha"], est["tau_max"]),
                  "q": flow_from_load(tau, est["alpha"], est["tau_max"])}
        return FitResult(
            name=name, model="traditional_disc", residual=self.residual, hessian=self.hessian, free=list(self.free),
            estimate=est, initial=dict(values), bounds=bnd, load=tau,
            measured={k: meas[k] for k in parts}, fitted={k: fitted[k] for k in parts},
            weights={k: weights[k] for k in parts}, stats=uncertainty(res["r"], J, [est[k] for k in self.free]),
            solver={"status": res["status"], "iterations": res["iterations"], "success": res["success"],
                    "objective": float(res["f"][0])})


def scipy_disc_fit(tau, u=None, q=None, residual: str = "u", values: dict | None = None,
                   free: tuple[str, ...] = DISC, bounds: dict | None = None, weights: dict | None = None,
                   tol: float = 1e-15) -> dict:
    """The same least-squares problem as :class:`DiscFitter` solved by scipy.optimize.least_squares
    (trust-region reflective, analytic Jacobian in numpy): the independent peer of the IPOPT fit."""
    tau = np.asarray(tau, float)
    values = {"alpha": 1.75, "tau_max": 2.75} | (values or {})
    weights = {"u": 1.0, "q": 1.0} | (weights or {})
    default = {"alpha": (1e-8, np.inf), "tau_max": (tau.max() * (1 + 1e-9), np.inf)}
    bnd = {k: tuple(d if b is None else b for b, d in zip((bounds or {}).get(k, (None, None)), default[k],
                                                          strict=True)) for k in free}
    parts = _measured_parts(residual)
    meas = {"u": u, "q": q}

    def theta(v):
        th = dict(values)
        th.update(zip(free, v, strict=True))
        return th["alpha"], th["tau_max"]

    def res(v):
        a, t = theta(v)
        model = {"u": lambda: gap_from_load(tau, a, t), "q": lambda: flow_from_load(tau, a, t)}
        return np.concatenate([weights[k] * (model[k]() - meas[k]) for k in parts])

    def jac(v):
        a, t = theta(v)
        rows = []
        for k in parts:
            if k == "u":
                y = gap_from_load(tau, a, t)
                d = {"alpha": -2.0 * y / (3.0 * a), "tau_max": y / (3.0 * (t - tau))}
            else:
                y = flow_from_load(tau, a, t)
                d = {"alpha": -(1.0 - tau / t) / (a**3 * y), "tau_max": (1.0 + a**-2) * tau / (2.0 * y * t**2)}
            rows.append(weights[k] * np.column_stack([d[n] for n in free]))
        return np.vstack(rows)

    x0 = np.array([min(max(values[k], bnd[k][0] * (1 + 1e-6)), bnd[k][1]) for k in free])
    sol = optimize.least_squares(res, x0, jac=jac, bounds=([bnd[k][0] for k in free], [bnd[k][1] for k in free]),
                                 method="trf", xtol=tol, ftol=tol, gtol=tol, max_nfev=2000)
    return {"estimate": dict(zip(free, map(float, sol.x), strict=True)), "success": bool(sol.status > 0),
            "status": sol.message, "nfev": int(sol.nfev), "cost": float(sol.cost)}


_DISC_CURVE: list = []


def disc_curve(tau, estimate: dict, free: list[str], cov, t: float) -> dict:
    """(4.18), (4.31) on ``tau`` with a delta-method band: value +- t sqrt(g' cov g), g = d value/d free."""
    if not _DISC_CURVE:
        ts, th = ca.SX.sym("tau"), ca.SX.sym("theta", 2)
        y = ca.vertcat(gap_from_load(ts, th[0], th[1]), flow_from_load(ts, th[0], th[1]))
        _DISC_CURVE.append(ca.Function("disc_curve", [ts, th], [y, ca.vec(ca.jacobian(y, th))]))
    tau = np.asarray(tau, float)
    th = np.array([estimate[k] for k in DISC])
    y, g = (np.asarray(a.full()) for a in _DISC_CURVE[0].map(len(tau))(tau, np.tile(th[:, None], len(tau))))
    g = g.T.reshape(len(tau), 2, 2, order="F")[:, :, [DISC.index(k) for k in free]]  # point, output, parameter
    out = {"load": tau}
    for j, k in enumerate(("u", "q")):
        half = t * np.sqrt(np.einsum("ni,ij,nj->n", g[:, j, :], cov, g[:, j, :]))
        out[k] = (y[j], y[j] - half, y[j] + half)
    return out


# ---- the full static model of the device ----------------------------------------------------------

GROUP_FIELDS, REGULATOR_FIELDS = DEVICE_GROUPS, REGULATOR_GROUPS
LOSS_TARGET = {"face_friction": "alpha_TB1", "outer_local_loss": "alpha_31", "outer_friction": "alpha_31"}


def with_groups(groups, values: dict):
    """``groups`` (DeviceGroups) with the fields in ``values`` replaced (regulator fields too)."""
    reg = {k: v for k, v in values.items() if k in REGULATOR_FIELDS}
    if reg:
        if groups.regulator is None:
            raise ScenarioError(f"{', '.join(reg)}: the device has no regulator")
        groups = replace(groups, regulator=replace(groups.regulator, **reg))
    return replace(groups, **{k: v for k, v in values.items() if k in GROUP_FIELDS})


def group_values(dev, device, theta: dict) -> dict:
    """The groups (2.18) that the device parameters ``theta`` set (numbers or CasADi expressions).

    Loss coefficients act through the square-root conductances, g ~ 1/sqrt(zeta) (2.16):
    face friction lambda_T through zeta_TB (App. A L3191), the outer seal's local loss and friction
    through zeta_u3 = zeta + lambda l/(2h) (App. A L3165).
    """
    from autobal.models.throttles import annulus_loss, face_loss

    out = {}
    for name, th in theta.items():
        if name == "face_friction":
            f = device.disc.face
            z0 = face_loss(f.friction, f.inner_diameter, f.outer_diameter, f.base_gap)
            out["alpha_TB1"] = dev.groups.alpha_TB1 * (z0 / face_loss(th, f.inner_diameter, f.outer_diameter,
                                                                      f.base_gap)) ** 0.5
        elif name in ("outer_local_loss", "outer_friction"):
            o = device.disc.outer_seal
            z0 = annulus_loss(o.local_loss, o.friction, o.length, o.clearance)
            z = (annulus_loss(th, o.friction, o.length, o.clearance) if name == "outer_local_loss"
                 else annulus_loss(o.local_loss, th, o.length, o.clearance))
            out["alpha_31"] = dev.groups.alpha_31 * (z0 / z) ** 0.5
        else:
            out[name] = th
    return out


class ParametricStatics:
    """The static balances and flows of models/device.py with the groups ``fields`` as an input
    gamma: ``residual(w, psi1, dpsi, gamma)``, ``flows(w, psi1, dpsi, gamma)`` (throttle flows)."""

    def __init__(self, groups, fields: list[str]):
        from autobal.models.device import static_system

        self.fields = list(fields)
        self.system = static_system(groups)
        par = static_system(groups, self.fields)
        self.residual = par.residual
        w, psi1, dpsi, gam = (par.flows.sx_in(i) for i in range(4))
        self.flows = ca.Function("parametric_flows", [w, psi1, dpsi, gam], [par.flows(w, psi1, dpsi, gam)[0]])


def free_unknowns(system, active) -> tuple[list[int], dict]:
    """Indices of the unknowns left free when each stop is fixed as StaticsSolver found it (inactive:
    reaction 0; active: coordinate on its stop), and the fixed values by index."""
    fixed = {system.index(k): v for k, v in system.fixed_by_stops(active).items()}
    return [i for i in range(len(system.unknowns)) if i not in fixed], fixed


class DeviceFitter:
    """Least squares of the device's full static model: parameters and the static states of every
    data point are the NLP's unknowns, the balances its equality constraints (stops fixed as found
    at the initial guess), the residual in u and/or the flow of one throttle.

    ``device`` is the scene's validated device section, ``dev`` its DeviceDesign; ``params``:
    name -> (value, free, lower, upper).  Loads are tau (psi1 = tau/b) or psi1.
    """

    def __init__(self, device, dev, params: dict, residual: str = "u", flow_throttle: str = "T",
                 hessian: str = "gauss-newton", max_iter: int = 300):
        self.device, self.dev, self.params = device, dev, params
        self.residual, self.hessian, self.max_iter = residual, hessian, max_iter
        self.free = [k for k, v in params.items() if v[1]]
        self.scale = np.array([_scale(params[k][0]) for k in self.free])
        self.fields = sorted(group_values(dev, device, {k: 1.0 for k in params}))
        self.ps = ParametricStatics(dev.groups, self.fields)
        sys_ = self.ps.system
        if flow_throttle not in sys_.throttles:
            raise ScenarioError(f"flow_throttle: {flow_throttle!r} is not a throttle of this device "
                                f"({', '.join(sys_.throttles)})")
        self.k_flow = sys_.throttles.index(flow_throttle)

    def gamma(self, theta: dict):
        """Vector of the fitted groups for parameter values ``theta`` (all listed parameters)."""
        g = group_values(self.dev, self.device, theta)
        return ca.vertcat(*[g[k] for k in self.fields])

    def design(self, theta: dict):
        """The DeviceDesign with the groups set by ``theta``."""
        g = np.asarray(ca.evalf(self.gamma(theta))).ravel() if self.fields else []
        return replace(self.dev, groups=with_groups(self.dev.groups, dict(zip(self.fields, map(float, g),
                                                                              strict=True))))

    def _psi1(self, load, load_kind: str, b):
        return load / b if load_kind == "tau" else load

    def fit(self, load, load_kind: str, u=None, q=None, weights: dict | None = None, name: str = "fit") -> FitResult:
        from autobal.analysis.statics import StaticsSolver

        load = np.asarray(load, float)
        weights = {"u": 1.0, "q": 1.0} | (weights or {})
        parts = _measured_parts(self.residual)
        meas = {"u": None if u is None else np.asarray(u, float), "q": None if q is None else np.asarray(q, float)}
        sys_ = self.ps.system
        values0 = {k: v[0] for k, v in self.params.items()}
        start = StaticsSolver(self.design(values0))
        b0 = values0.get("b", self.dev.groups.b)
        points, prev = [], None
        for lv in load:
            prev = start.solve(float(self._psi1(lv, load_kind, b0)), self.dev.dpsi, prev)
            points.append(prev)

        xt = ca.SX.sym("theta", len(self.free))
        theta = {k: (self.scale[self.free.index(k)] * xt[self.free.index(k)] if v[1] else v[0])
                 for k, v in self.params.items()}
        gam = self.gamma(theta)
        b = theta.get("b", self.dev.groups.b)
        zs, z0, lbz, ubz, g, r = [], [], [], [], [], {k: [] for k in parts}
        lo, hi = np.array(sys_.lower, float), np.array(sys_.upper, float)
        iu = sys_.index("u")
        for i, pt in enumerate(points):
            free_i, fixed = free_unknowns(sys_, pt.active)
            z = ca.SX.sym(f"z{i}", len(free_i))
            wfull = ca.vertcat(*[z[free_i.index(j)] if j in free_i else fixed[j] for j in range(len(sys_.unknowns))])
            psi1 = self._psi1(load[i], load_kind, b)
            g.append(self.ps.residual(wfull, psi1, self.dev.dpsi, gam))
            if "u" in parts:
                r["u"].append(weights["u"] * (wfull[iu] - meas["u"][i]))
            if "q" in parts:
                r["q"].append(weights["q"] * (self.ps.flows(wfull, psi1, self.dev.dpsi, gam)[self.k_flow]
                                              - meas["q"][i]))
            zs.append(z)
            z0.append(pt.x[free_i])
            lbz.append(lo[free_i])
            ubz.append(hi[free_i])
        r = ca.vertcat(*[e for k in parts for e in r[k]])
        x = ca.vertcat(xt, *zs)
        ls = LeastSquares(f"fit_device_{self.residual}", x, ca.SX.sym("p", 0), r, ca.vertcat(*g), len(self.free),
                          self.hessian, self.max_iter)
        lbt = [(-math.inf if self.params[k][2] is None else self.params[k][2]) / s for k, s in
               zip(self.free, self.scale, strict=True)]
        ubt = [(math.inf if self.params[k][3] is None else self.params[k][3]) / s for k, s in
               zip(self.free, self.scale, strict=True)]
        # group ratios and loss coefficients are positive unless bounded otherwise (chi may be 0)
        lbt = [lb if np.isfinite(lb) or k == "chi" else 0.0 for lb, k in zip(lbt, self.free, strict=True)]
        x0 = np.concatenate([[values0[k] / s for k, s in zip(self.free, self.scale, strict=True)], *z0])
        res = ls.solve(x0, np.concatenate([lbt, *lbz]), np.concatenate([ubt, *ubz]), [])
        est = dict(values0)
        for i, k in enumerate(self.free):
            est[k] = float(res["x"][i] * self.scale[i])
        if not res["success"]:
            raise SolveError(f"fit {name!r} (device, residual in {self.residual}) did not converge", res["status"],
                             {"iterations": res["iterations"], **est})
        J = res["J"] / self.scale
        fitted_r = res["r"]
        fitted = {}
        for j, k in enumerate(parts):
            fitted[k] = fitted_r[j * len(load):(j + 1) * len(load)] / weights[k] + meas[k]

        # confirm with StaticsSolver on the fitted design: same states, same stops
        check = StaticsSolver(self.design(est))
        b_hat = est.get("b", self.dev.groups.b)
        diffs, changed, prev = [], 0, None
        for i, lv in enumerate(load):
            prev = check.solve(float(self._psi1(lv, load_kind, b_hat)), self.dev.dpsi, prev)
            changed += prev.active != points[i].active
            y = {"u": prev.values["u"], "q": prev.flows[sys_.throttles[self.k_flow]]}
            diffs += [abs(y[k] - fitted[k][i]) for k in parts]
        groups_hat = {k: getattr(check.design.groups, k) if k in GROUP_FIELDS else
                      getattr(check.design.groups.regulator, k) for k in self.fields}
        result = FitResult(
            name=name, model="device", residual=self.residual, hessian=self.hessian, free=list(self.free),
            estimate=est, initial=values0,
            bounds={k: (self.params[k][2], self.params[k][3]) for k in self.free}, load=load,
            measured={k: meas[k] for k in parts}, fitted=fitted, weights={k: weights[k] for k in parts},
            stats=uncertainty(fitted_r, J, [est[k] for k in self.free]),
            solver={"status": res["status"], "iterations": res["iterations"], "success": res["success"],
                    "objective": float(res["f"][0])},
            extra={"load_kind": load_kind, "flow_throttle": sys_.throttles[self.k_flow], "fitted_groups": groups_hat,
                   "statics_resolve_max_difference": float(max(diffs)), "stops_changed_points": int(changed),
                   "stops": [sorted(p.active) for p in points]})
        self._solver_hat, self._load_kind = check, load_kind
        return result

    def curve(self, fit: FitResult, loads) -> dict:
        """Fitted u and flow on ``loads`` (StaticsSolver continuation on the fitted design) with a
        delta-method band; sensitivities by the implicit-function theorem on the parametric balances."""
        solver, sys_ = self._solver_hat, self.ps.system
        est = fit.estimate
        w, ld, xt = ca.SX.sym("w", len(sys_.unknowns)), ca.SX.sym("load"), ca.SX.sym("theta", len(self.free))
        theta = {k: (xt[self.free.index(k)] if k in self.free else est[k]) for k in self.params}
        gam = self.gamma(theta)
        psi1 = self._psi1(ld, self._load_kind, theta.get("b", self.dev.groups.b))
        rr = self.ps.residual(w, psi1, self.dev.dpsi, gam)
        y = ca.vertcat(w[sys_.index("u")], self.ps.flows(w, psi1, self.dev.dpsi, gam)[self.k_flow])
        fn = ca.Function("sens", [w, ld, xt], [y, ca.jacobian(rr, w), ca.jacobian(rr, xt), ca.jacobian(y, w),
                                               ca.jacobian(y, xt)])
        th = np.array([est[k] for k in self.free])
        b_hat = est.get("b", self.dev.groups.b)
        cov, t = fit.stats["covariance"], fit.stats["t_quantile"]
        vals, halves, prev = [], [], None
        for lv in np.asarray(loads, float):
            prev = solver.solve(float(self._psi1(lv, self._load_kind, b_hat)), self.dev.dpsi, prev)
            yv, rw, rt, yw, yt = (np.asarray(a.full()) for a in fn(prev.x, lv, th))
            free_i, _ = free_unknowns(sys_, prev.active)
            dw = -np.linalg.solve(rw[:, free_i], rt)
            gr = yt + yw[:, free_i] @ dw
            vals.append(yv.ravel())
            halves.append(t * np.sqrt(np.einsum("ji,ik,jk->j", gr, cov, gr)))
        vals, halves = np.array(vals), np.array(halves)
        return {"load": np.asarray(loads, float),
                **{k: (vals[:, j], vals[:, j] - halves[:, j], vals[:, j] + halves[:, j]) for j, k in
                   enumerate(("u", "q"))}}
