"""The least-squares core of the parameter estimation: min 0.5 ||r(x; p)||^2 with bounds (and
equality constraints g(x; p) = 0 for models with states).

* :class:`LeastSquares` solves one problem by IPOPT with a **Gauss-Newton Hessian**: CasADi's
  ``hess_lag`` option hands IPOPT lam_f J'J (J = dr/dx), so no second derivatives of the model are
  formed (with constraints this is the constrained Gauss-Newton method).  IPOPT's stopping test
  uses exact gradients, so the optimum is that of the exact problem; ``hessian="exact"`` gives
  IPOPT the exact Lagrangian Hessian instead.
* :class:`GaussNewtonBatch` solves many unconstrained problems of the same residual Function at
  once: projected Gauss-Newton steps unrolled into one CasADi Function and mapped over the
  problems (one call for all of them).  Problems it does not converge are flagged, for the
  caller to hand to IPOPT.
* :func:`uncertainty`: standard errors, Student-t intervals and correlation from the Jacobian at
  the optimum (linearised covariance s^2 (J'J)^-1; an extension, Pavlenko (2014) gives none).
* :func:`percentile_interval`: the bootstrap's percentile interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from scipy import stats

from autobal.analysis.numerics import ipopt
from autobal.analysis.run import solver_options


def uncertainty(r, J, estimate, confidence: float = 0.95) -> dict:
    """Linearised uncertainty of a least-squares estimate.

    Parameters
    ----------
    r : array (N,)
        Weighted residual at the optimum (1).
    J : array (N, p)
        Jacobian of r in the free parameters at the optimum (units of 1/parameter).
    estimate : array (p,)
        The free parameters at the optimum.
    confidence : float
        Level of the Student-t intervals (1).

    Returns
    -------
    dict with points, dof = N - p, ssr = r'r, residual_std s = sqrt(ssr/dof), covariance
    s^2 (J'J)^-1, standard_error, t_quantile, ci_low, ci_high, correlation, jtj_condition, confidence.
    """
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


def percentile_interval(samples, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Percentile bootstrap interval (Efron & Tibshirani, 1993, Sec. 13.3) of each column of
    ``samples`` (rows: bootstrap replicates); NaN rows (failed refits) are left out.  With fewer than
    two refits left there is no interval: NaN bounds."""
    s = np.asarray(samples, float)
    s = s[np.all(np.isfinite(s), axis=1)]
    if len(s) < 2:
        nan = np.full(np.shape(samples)[1], np.nan)
        return nan, nan.copy()
    lo = 100 * (0.5 - confidence / 2)
    return np.percentile(s, lo, axis=0), np.percentile(s, 100 - lo, axis=0)


class LeastSquares:
    """min 0.5 ||r(x; p)||^2 s.t. g(x; p) = 0 and bounds, by IPOPT; x = [scaled parameters (n_theta);
    states].  ``hessian``: "gauss-newton" (lam_f J'J through CasADi's ``hess_lag``) or "exact".
    Built once, called many times (data and fixed values are the NLP parameters ``p``)."""

    def __init__(self, name: str, x, p, r, g, n_theta: int, hessian: str = "gauss-newton", max_iter: int | None = None,
                 tol: float | None = None):
        f = 0.5 * ca.sumsqr(r)
        opts = solver_options.get("fit") | solver_options.ipopt_options(max_iter, tol)  # None: the "fit" group's
        if hessian == "gauss-newton":
            J = ca.jacobian(r, x)
            sym = type(x)  # SX or MX, as the model is built
            lam_f, lam_g = sym.sym("lam_f"), sym.sym("lam_g", g.numel())
            hess = ca.Function("gauss_newton_hessian", [x, p, lam_f, lam_g], [ca.triu(lam_f * ca.mtimes(J.T, J))],
                               ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])
            self.solver = ipopt.nlpsol(name, x, p, f, g, hess_lag=hess, **opts)
        elif hessian == "exact":
            self.solver = ipopt.nlpsol(name, x, p, f, g, **opts)
        else:
            raise ValueError(f"hessian must be 'gauss-newton' or 'exact', got {hessian!r}")
        self.n_theta = n_theta
        self.ng = g.numel()
        self.parts = ca.Function(f"{name}_parts", [x, p], [r, ca.jacobian(r, x), ca.jacobian(g, x)])

    def solve(self, x0, lbx, ubx, p) -> dict:
        """IPOPT's solution, with the residual r and its reduced Jacobian in the scaled parameters
        (states eliminated by the implicit-function theorem: dz/dtheta = -g_z^-1 g_theta)."""
        res = ipopt.solve(self.solver, x0=x0, lbx=lbx, ubx=ubx, lbg=0, ubg=0, p=p)
        r, jr, jg = (np.asarray(v.full()) for v in self.parts(res["x"], p))
        k = self.n_theta
        J = jr[:, :k]
        if self.ng:
            J = J - jr[:, k:] @ np.linalg.solve(jg[:, k:], jg[:, :k])
        return res | {"r": r.ravel(), "J": J}


class GaussNewtonBatch:
    """Many least-squares problems min 0.5 ||r(x; p_j)||^2, lb_j <= x <= ub_j, j = 1..N, in one call.

    Generated from the residual Function ``residual(x, p) -> r`` (the one the IPOPT fit uses): a
    projected Gauss-Newton step x+ = clip(x - (J'J)^-1 J'r, lb, ub) unrolled ``block`` times into
    one Function, mapped over the N problems (columns; ``parallelization="thread"`` maps on two
    threads).  Blocks are repeated until every problem
    has converged (last step below ``tol`` in the scaled variables) or ``max_blocks`` is reached (defaults: the
    solver options ``gauss_newton``).
    A problem is *converged* when its last step is below ``tol``, its values are finite and no
    bound is active (a clipped Gauss-Newton point need not satisfy the bound-constrained
    optimality conditions); the others are for the caller to re-solve (e.g. by IPOPT).
    """

    def __init__(self, residual: ca.Function, block: int | None = None, tol: float | None = None,
                 max_blocks: int | None = None, parallelization: str = "serial"):
        o = solver_options.get("gauss_newton")  # None: the option's
        block, tol, max_blocks = (o[k] if v is None else v for k, v in (("block", block), ("tol", tol),
                                                                         ("max_blocks", max_blocks)))
        nx, n_p = residual.size1_in(0), residual.size1_in(1)
        x, p = ca.SX.sym("x", nx), ca.SX.sym("p", n_p)
        lb, ub = ca.SX.sym("lb", nx), ca.SX.sym("ub", nx)
        r = residual(x, p)
        J = ca.jacobian(r, x)
        step = ca.Function("gauss_newton_step", [x, p, lb, ub],
                           [ca.fmin(ca.fmax(x - ca.solve(J.T @ J, J.T @ r), lb), ub)])
        xk, prev = x, x
        for _ in range(block):
            prev, xk = xk, step(xk, p, lb, ub)
        self.unrolled = ca.Function("gauss_newton_block", [x, p, lb, ub], [xk, ca.norm_inf(xk - prev)])
        self.tol, self.max_blocks, self.parallelization = tol, max_blocks, parallelization
        self._maps: dict[int, ca.Function] = {}

    def solve(self, x0, p, lb, ub) -> dict:
        """Solve the N problems whose data are the columns of ``p`` (n_p x N).

        Parameters
        ----------
        x0, lb, ub : array (nx, N) or (nx,)
            Start and bounds (scaled variables), per problem or common.
        p : array (n_p, N)
            Data of each problem.

        Returns
        -------
        dict: x (nx, N), step (N,) the last step, converged (N,) bool, blocks (number of unrolled
        blocks run).
        """
        p = np.asarray(p, float)
        n = p.shape[1]
        nx = self.unrolled.size1_in(0)
        x0, lb, ub = (np.broadcast_to(np.asarray(a, float).reshape(nx, -1), (nx, n)) for a in (x0, lb, ub))
        if n not in self._maps:
            self._maps[n] = self.unrolled.map(n, self.parallelization, 2) if self.parallelization == "thread" \
                else self.unrolled.map(n)
        fn = self._maps[n]
        x, blocks = np.array(x0), 0
        while blocks < self.max_blocks:
            xd, sd = fn(x, p, lb, ub)
            x, step, blocks = np.asarray(xd), np.asarray(sd).ravel(), blocks + 1
            if np.all((step <= self.tol) | ~np.isfinite(step)):  # converged or diverged: no use iterating
                break
        with np.errstate(invalid="ignore"):
            interior = np.all((x > lb) & (x < ub), axis=0)
        converged = (step <= self.tol) & np.all(np.isfinite(x), axis=0) & interior
        return {"x": x, "step": step, "converged": converged, "blocks": blocks}


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
        """Standard error of parameter ``name`` (0 for a fixed one), in its unit."""
        return float(self.stats["standard_error"][self.free.index(name)]) if name in self.free else 0.0

    def interval(self, name: str) -> tuple[float, float]:
        """Student-t confidence interval of parameter ``name`` (the value twice for a fixed one)."""
        if name not in self.free:
            return self.estimate[name], self.estimate[name]
        i = self.free.index(name)
        return float(self.stats["ci_low"][i]), float(self.stats["ci_high"][i])


def measured_parts(residual: str) -> list[str]:
    """The measured variables a residual setting ("u", "q", "both") is taken in."""
    return {"u": ["u"], "q": ["q"], "both": ["u", "q"]}[residual]


def scale_of(value: float) -> float:
    """The scale of a parameter in the NLP: |value|, or 1 for 0."""
    return abs(value) if value != 0 else 1.0
