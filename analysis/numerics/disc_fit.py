"""Parameter estimation of the traditional disc of Pavlenko (2014), Sec. 4.4: alpha = g_TB/g1 and
tau_max = sigma psi1 from measured static (u) and/or flow (q) characteristics, Eqs. (4.16)-(4.37).

* :class:`DiscFitter`: nonlinear least squares in u, q or both, with bounds and any subset of
  parameters free, by IPOPT with a Gauss-Newton Hessian
  (:class:`~autobal.analysis.numerics.least_squares.LeastSquares`); ``fit_many`` fits many data sets in one mapped
  Gauss-Newton call generated from the same residual Function (IPOPT re-solves what it does not converge); ``bootstrap``
  uses it for residual-bootstrap confidence intervals.
* :func:`scipy_disc_fit`: the same problem by scipy.optimize.least_squares (the independent peer).
* The source's closed-form estimators, which minimise *transformed* residuals (linear in alpha^2
  or in (tau_max, alpha^2)), kept as cross-checks: (4.23), (4.26)-(4.27), (4.35), (4.36).

The model equations are :class:`autobal.models.hydroheel.TurbulentDisc`.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
from scipy import optimize

from autobal.analysis.numerics.least_squares import (
    FitResult,
    GaussNewtonBatch,
    LeastSquares,
    measured_parts,
    percentile_interval,
    scale_of,
    uncertainty,
)
from autobal.errors import SolveError
from autobal.models.hydroheel import TurbulentDisc

DISC = ("alpha", "tau_max")
START = {"alpha": 1.75, "tau_max": 2.75}  # the design values of Pavlenko (2014), Sec. 4.3.3


# ---- the source's closed-form estimators (transformed residuals) --------------------------------

def static_1p(tau, u, tau_max: float) -> float:
    """alpha of Pavlenko (2014), Eq. (4.23), tau_max fixed: minimises
    sum [1/tau_i - (1 + alpha^2 u_i^3)/tau_max]^2 (4.20).

    Parameters
    ----------
    tau, u : array
        Loads and measured gaps (1).
    tau_max : float
        The fixed tau_max (1).

    Returns
    -------
    alpha (1).
    """
    tau, u = np.asarray(tau, float), np.asarray(u, float)
    return math.sqrt(np.sum((tau_max / tau - 1.0) * u**3) / np.sum(u**6))


def static_2p(tau, u) -> tuple[float, float]:
    """(tau_max, alpha) of Pavlenko (2014), Eqs. (4.26)-(4.27): the normal equations (4.25) of the
    linear residual tau_max - tau_i (1 + alpha^2 u_i^3).

    Parameters
    ----------
    tau, u : array
        Loads and measured gaps (1).

    Returns
    -------
    tau_max (1), alpha (1; NaN when the fitted alpha^2 is not positive); both NaN when every load is the same.
    """
    tau, u = np.asarray(tau, float), np.asarray(u, float)
    n = len(tau)
    s0, s1, s2, s3 = tau.sum(), (u**3 * tau).sum(), (u**6 * tau**2).sum(), (u**3 * tau**2).sum()
    det = n * s2 - s1**2
    if det == 0:  # one load only: (4.25) is singular
        return math.nan, math.nan
    alpha2 = (s0 * s1 - n * s3) / det
    return (s0 * s2 - s1 * s3) / det, math.sqrt(alpha2) if alpha2 > 0 else math.nan


def flow_1p(tau, q, tau_max: float) -> float:
    """alpha of Pavlenko (2014), Eq. (4.35), tau_max fixed: minimises
    sum [(q_i^2 - 1 + tau_i/tau_max) alpha^2 - (1 - tau_i/tau_max)]^2 ((4.33) with the sign of (4.34)).

    Parameters
    ----------
    tau, q : array
        Loads and measured flows Q/Q_B (1).
    tau_max : float
        The fixed tau_max (1).

    Returns
    -------
    alpha (1; NaN when the fitted alpha^2 is not positive).
    """
    tau, q = np.asarray(tau, float), np.asarray(q, float)
    c = q**2 - 1.0 + tau / tau_max
    alpha2 = np.sum(c * (1.0 - tau / tau_max)) / np.sum(c**2)
    return math.sqrt(alpha2) if alpha2 > 0 else math.nan


def flow_sums(tau, q) -> dict:
    """The sums a1..a5 of Pavlenko (2014), Eq. (4.37) (a3 = sum tau_i (q_i^2 - 1), consistent with
    the first equation of (4.36); the printed a3 squares the bracket) and n."""
    tau, q = np.asarray(tau, float), np.asarray(q, float)
    d = q**2 - 1.0
    return {"a1": np.sum(d**2), "a2": np.sum(d), "a3": np.sum(tau * d), "a4": np.sum(tau), "a5": np.sum(tau**2),
            "n": len(tau)}


def stationarity_4_36(x: float, y: float, s: dict) -> tuple[float, float]:
    """The two stationarity conditions of the transformed residual of Pavlenko (2014), Eq. (4.36),
    derived again (the printed second equation has a4 for a5 and a1 for a2), at x = tau_max, y = alpha^2."""
    a1, a2, a3, a4, a5, n = (s[k] for k in ("a1", "a2", "a3", "a4", "a5", "n"))
    return (x * (a1 * y**2 - 2 * a2 * y + n) + a3 * y**2 + (a3 - a4) * y - a4,
            (a1 * x**2 + 2 * a3 * x + a5) * y - a2 * x**2 + (a3 - a4) * x + a5)


def flow_2p(tau, q, start: tuple[float, float] | None = None) -> tuple[float, float]:
    """(tau_max, alpha) minimising the transformed residual of Pavlenko (2014), Eq. (4.36),
    r_i = [(q_i^2 - 1) x + tau_i] y - x + tau_i with x = tau_max, y = alpha^2, numerically (the
    source: "solved numerically").  Bounds x > max tau, y > 0 exclude the spurious zero-residual
    point x = 0, y = -1 of this residual.

    Parameters
    ----------
    tau, q : array
        Loads and measured flows Q/Q_B (1).
    start : (tau_max, alpha), optional
        Initial guess; default 1.3 max tau and the (4.35) estimate there.

    Returns
    -------
    tau_max (1), alpha (1).
    """
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


# ---- nonlinear least squares of (4.18) and (4.31) ---------------------------------------------------

def _bounds(tau, free, bounds: dict | None) -> dict:
    """Bounds of the free parameters: given ones, else alpha > 0; tau_max above max tau always
    (the gap (4.18) is undefined at and below the largest load)."""
    floor = np.max(tau) * (1 + 1e-9)
    upper = ((bounds or {}).get("alpha") or (None, None))[1]
    tiny = 1e-8 if upper is None or upper <= 0 else min(1e-8, 1e-3 * upper)  # alpha > 0, below a tiny upper bound
    default = {"alpha": (tiny, math.inf), "tau_max": (floor, math.inf)}
    out = {k: tuple(d if b is None else b for b, d in zip((bounds or {}).get(k, (None, None)), default[k],
                                                         strict=True)) for k in free}
    if "tau_max" in out:
        out["tau_max"] = (max(out["tau_max"][0], floor), out["tau_max"][1])
    return out


def feasible_start(tau, values: dict, bnd: dict) -> tuple[dict, dict]:
    """The initial guess moved to where the model is defined and inside the bounds ``bnd`` (free
    parameters): tau_max not above the largest load -> 1.05 times it (or the middle of its bounds);
    any other free value outside its bounds -> the middle of its bounds, or just inside the one bound.

    Returns
    -------
    (values, moved): the start, and name -> {"from", "to", "why"} for each value moved.
    """
    out, moved = dict(values), {}
    top = float(np.max(tau))
    for k, (lo, hi) in bnd.items():
        if not lo < hi:
            raise ValueError(f"{k}: no value between its bounds [{lo:g}, {hi:g}] where the model is defined")
        v = out[k]
        if k == "tau_max" and v <= top:
            new = 1.05 * top if 1.05 * top < hi else 0.5 * (lo + hi)
            why = (f"the initial tau_max {v:g} is not above the largest load {top:g}, where the gap (4.18) is "
                   f"undefined; started at {new:.6g} (1.05 x the largest load, within the bounds)")
        elif not lo < v < hi:
            new = 0.5 * (lo + hi) if math.isfinite(lo + hi) else \
                lo + 0.01 * max(abs(lo), 1.0) if v <= lo else hi - 0.01 * max(abs(hi), 1.0)
            why = f"the initial {k} {v:g} is not inside its bounds [{lo:g}, {hi:g}]; started at {new:.6g}"
        else:
            continue
        out[k] = float(new)
        moved[k] = {"from": v, "to": float(new), "why": why}
    return out, moved


class DiscFitter:
    """Least squares of (4.18) and/or (4.31) for n data points.

    The residual r = w (model - measured) is one CasADi Function of x (the free parameters, scaled
    by their initial values) and p = [tau (n), u (n), q (n), w (2), fixed values (2), scales (2)];
    the IPOPT NLP (one fit) and the mapped Gauss-Newton (many fits) are both generated from it and
    built once.  ``batch``: options of the :class:`~autobal.analysis.numerics.least_squares.GaussNewtonBatch`
    (block, tol, max_blocks, parallelization).
    """

    def __init__(self, n: int, residual: str = "u", free: tuple[str, ...] = DISC, hessian: str = "gauss-newton",
                 max_iter: int | None = None, tol: float | None = None, batch: dict | None = None):
        self.n, self.residual, self.free, self.hessian = n, residual, tuple(free), hessian
        # the residual of one point, mapped over the n points: the graph's size does not grow with n
        xs, point = ca.SX.sym("x", len(self.free)), ca.SX.sym("point", 3)  # tau, u, q of a point
        w, fixed, scale = ca.SX.sym("w", 2), ca.SX.sym("fixed", 2), ca.SX.sym("scale", 2)
        disc = TurbulentDisc(*[scale[j] * xs[self.free.index(k)] if k in self.free else fixed[j]
                               for j, k in enumerate(DISC)])
        parts = []
        if residual in ("u", "both"):
            parts.append(w[0] * (disc.gap(point[0]) - point[1]))
        if residual in ("q", "both"):
            parts.append(w[1] * (disc.flow(point[0]) - point[2]))
        one = ca.Function("disc_point_residual", [xs, point, w, fixed, scale], [ca.vertcat(*parts)])
        x, p = ca.MX.sym("x", len(self.free)), ca.MX.sym("p", 3 * n + 6)
        data = ca.reshape(p[:3 * n], n, 3).T  # one column per point
        common = [p[3 * n + 2 * j:3 * n + 2 * j + 2] for j in range(3)]
        r = ca.vec(one.map(n)(x, data, *common).T)  # every point's u residual, then every point's q residual
        self.residual_function = ca.Function("disc_residual", [x, p], [r], ["x", "p"], ["r"])
        self.ls = LeastSquares(f"fit_disc_{residual}", x, p, r, ca.MX(0, 1), len(self.free), hessian, max_iter, tol)
        self.batch_options = dict(batch or {})
        self._batch: GaussNewtonBatch | None = None

    def _setup(self, tau, values, bounds, weights):
        weights = {"u": 1.0, "q": 1.0} | (weights or {})
        bnd = _bounds(tau, self.free, bounds)
        values, self.moved = feasible_start(tau, START | (values or {}), bnd)
        scale = np.array([scale_of(values[k]) for k in DISC])
        sc = np.array([scale[DISC.index(k)] for k in self.free])
        return values, weights, bnd, scale, sc

    def _data(self, tau, u, q, weights, values, scale) -> np.ndarray:
        zeros = np.zeros(self.n)
        u = zeros if u is None else np.asarray(u, float)
        q = zeros if q is None else np.asarray(q, float)
        return np.concatenate([tau, u, q, [weights["u"], weights["q"]], [values[k] for k in DISC], scale])

    def fit(self, tau, u=None, q=None, values: dict | None = None, bounds: dict | None = None,
            weights: dict | None = None, name: str = "fit", confidence: float = 0.95) -> FitResult:
        """One fit by IPOPT, with its linearised uncertainty.

        Parameters
        ----------
        tau : array (n,)
            Loads (1).
        u, q : array (n,), optional
            Measured gaps u = z/z_B and flows q = Q/Q_B (1), as the residual setting needs.
        values : dict, optional
            alpha, tau_max: initial guess when free, value when fixed (1); default 1.75, 2.75.
        bounds : dict, optional
            name -> (lower, upper) of free parameters (None: alpha > 0, tau_max > max tau).
        weights : dict, optional
            "u", "q" -> weight of that residual (1/its unit).
        name : str
            Label of the fit in messages.
        confidence : float
            Level of the Student-t intervals (1).

        Returns
        -------
        FitResult
        """
        tau = np.asarray(tau, float)
        values, weights, bnd, scale, sc = self._setup(tau, values, bounds, weights)
        p = self._data(tau, u, q, weights, values, scale)
        x0 = [values[k] / s for k, s in zip(self.free, sc, strict=True)]
        res = self.ls.solve(x0, [bnd[k][0] / s for k, s in zip(self.free, sc, strict=True)],
                            [bnd[k][1] / s for k, s in zip(self.free, sc, strict=True)], p)
        est = dict(values)
        for i, k in enumerate(self.free):
            est[k] = float(res["x"][i] * sc[i])
        if not res["success"]:
            raise SolveError(f"fit {name!r} (traditional_disc, residual in {self.residual}) did not converge",
                             res["status"], {"iterations": res["iterations"], **est})
        parts = measured_parts(self.residual)
        disc = TurbulentDisc(est["alpha"], est["tau_max"])
        fitted = {"u": disc.gap(tau), "q": disc.flow(tau)}
        meas = {"u": u, "q": q}
        return FitResult(
            name=name, model="traditional_disc", residual=self.residual, hessian=self.hessian, free=list(self.free),
            estimate=est, initial=dict(values), bounds=bnd, load=tau,
            measured={k: np.asarray(meas[k], float) for k in parts}, fitted={k: fitted[k] for k in parts},
            weights={k: weights[k] for k in parts},
            stats=uncertainty(res["r"], res["J"] / sc, [est[k] for k in self.free], confidence),
            solver={"status": res["status"], "iterations": res["iterations"], "success": res["success"],
                    "objective": float(res["f"][0])},
            extra={"start_moved": self.moved} if self.moved else {})

    def fit_many(self, tau, u=None, q=None, values: dict | None = None, bounds: dict | None = None,
                 weights: dict | None = None) -> dict:
        """Fit N data sets at once: one mapped Gauss-Newton call (generated from the residual
        Function), IPOPT for the data sets it does not converge.

        Parameters
        ----------
        tau : array (n,)
            Loads, common to every data set (1).
        u, q : array (N, n), optional
            Measured gaps and flows of each data set (1).
        values, bounds, weights : dict, optional
            As in :meth:`fit`, common to every data set.

        Returns
        -------
        dict: estimate (N, number of free parameters; NaN where IPOPT failed too), gauss_newton
        (N,) bool, fallback (number re-solved by IPOPT), failed (number IPOPT failed), blocks.
        """
        tau = np.asarray(tau, float)
        values, weights, bnd, scale, sc = self._setup(tau, values, bounds, weights)
        n_sets = np.shape(u if u is not None else q)[0]
        zeros = np.zeros((self.n, n_sets))
        common = np.concatenate([[weights["u"], weights["q"]], [values[k] for k in DISC], scale])
        p = np.vstack([np.broadcast_to(tau[:, None], (self.n, n_sets)),
                       zeros if u is None else np.asarray(u, float).T, zeros if q is None else np.asarray(q, float).T,
                       np.broadcast_to(common[:, None], (len(common), n_sets))])
        lb = np.array([bnd[k][0] for k in self.free]) / sc
        ub = np.array([bnd[k][1] for k in self.free]) / sc
        x0 = np.array([values[k] for k in self.free]) / sc
        if self._batch is None:
            self._batch = GaussNewtonBatch(self.residual_function, **self.batch_options)
        gn = self._batch.solve(x0, p, lb, ub)
        x = gn["x"].copy()
        failed = 0
        for j in np.flatnonzero(~gn["converged"]):
            res = self.ls.solve(x0, lb, ub, p[:, j])
            x[:, j] = res["x"] if res["success"] else np.nan
            failed += not res["success"]
        return {"estimate": (x * sc[:, None]).T, "gauss_newton": gn["converged"],
                "fallback": int(np.sum(~gn["converged"])), "failed": failed, "blocks": gn["blocks"]}

    def bootstrap(self, fit: FitResult, samples: int = 1000, seed: int = 0, confidence: float = 0.95) -> dict:
        """Residual-bootstrap confidence intervals of a fit's free parameters.

        Data sets y* = fitted + e*, e* drawn with replacement from the fit's residuals rescaled by
        sqrt(N/(N - p)) (Davison & Hinkley, 1997, Sec. 6.2.3; for the "both" residual one point index
        draws the u and the q residual together), each refitted by :meth:`fit_many`; percentile
        intervals (Efron & Tibshirani, 1993, Sec. 13.3).

        Parameters
        ----------
        fit : FitResult
            A fit of this fitter.
        samples : int
            Number of bootstrap data sets.
        seed : int
            Seed of the resampling.
        confidence : float
            Level of the intervals (1).

        Returns
        -------
        dict: samples, seed, method, confidence, ci_low, ci_high, std, mean (per free parameter, in
        the order of ``fit.free``), fallback (refits IPOPT finished), failed (refits left out).
        """
        rng = np.random.default_rng(seed)
        parts = list(fit.measured)
        n_res = sum(len(fit.measured[k]) for k in parts)
        inflate = math.sqrt(n_res / (n_res - len(fit.free)))
        idx = rng.integers(0, self.n, size=(samples, self.n))
        data = {k: fit.fitted[k][None, :] + inflate * (fit.measured[k] - fit.fitted[k])[idx] for k in parts}
        bounds = {k: fit.bounds[k] for k in fit.free}
        res = self.fit_many(fit.load, data.get("u"), data.get("q"), values=fit.estimate, bounds=bounds,
                            weights=fit.weights)
        est = res["estimate"]
        lo, hi = percentile_interval(est, confidence)
        ok = est[np.all(np.isfinite(est), axis=1)]
        std, mean = (ok.std(axis=0, ddof=1), ok.mean(axis=0)) if len(ok) >= 2 else (lo, hi)  # NaN: no interval
        return {"samples": samples, "seed": seed, "method": "residual", "confidence": confidence,
                "ci_low": lo, "ci_high": hi, "std": std, "mean": mean,
                "fallback": res["fallback"], "failed": res["failed"]}


def reference_fit(tau, u, free: tuple[str, ...] = DISC, values: dict | None = None, digits: int = 40) -> np.ndarray:
    """The least-squares fit in u of (4.18) in ``digits``-digit arithmetic (mpmath): Gauss-Newton with
    the analytic Jacobian du/dalpha = -2u/(3 alpha), du/dtau_max = u/(3 (tau_max - tau)), from
    ``values`` until the step is below 10^-(digits - 10); an independent reference for the fits
    (its fixed point is the stationary point of the sum of squares, whatever the algorithm).

    Parameters
    ----------
    tau, u : array (n,)
        Loads and measured gaps (1).
    free : tuple of str
        The free parameters; the others keep their ``values``.
    values : dict, optional
        Start of the free parameters and value of the fixed ones (default 1.75, 2.75).
    digits : int
        Working precision, decimal digits.

    Returns
    -------
    The free parameters at the optimum, rounded to double (1).
    """
    import mpmath as mp

    values = START | (values or {})
    with mp.workdps(digits):
        th = {k: mp.mpf(float(values[k])) for k in DISC}
        taus, us = [mp.mpf(float(x)) for x in tau], [mp.mpf(float(x)) for x in u]
        for _ in range(1000):
            m = [mp.cbrt((th["tau_max"] / x - 1) / th["alpha"] ** 2) for x in taus]
            r = [mi - ui for mi, ui in zip(m, us, strict=True)]
            cols = {"alpha": [-2 * mi / (3 * th["alpha"]) for mi in m],
                    "tau_max": [mi / (3 * (th["tau_max"] - x)) for mi, x in zip(m, taus, strict=True)]}
            J = [cols[k] for k in free]
            A = mp.matrix([[mp.fsum(a * b for a, b in zip(ji, jk, strict=True)) for jk in J] for ji in J])
            g = mp.matrix([mp.fsum(a * b for a, b in zip(ji, r, strict=True)) for ji in J])
            d = mp.lu_solve(A, -g)
            for i, k in enumerate(free):
                th[k] += d[i]
            if max(abs(d[i]) for i in range(len(free))) < mp.mpf(10) ** (10 - digits):
                break
        return np.array([float(th[k]) for k in free])


def scipy_disc_fit(tau, u=None, q=None, residual: str = "u", values: dict | None = None,
                   free: tuple[str, ...] = DISC, bounds: dict | None = None, weights: dict | None = None,
                   tol: float = 1e-15, method: str = "trf") -> dict:
    """The same least-squares problem as :class:`DiscFitter` solved by scipy.optimize.least_squares
    with an analytic Jacobian in numpy: the independent peer of the IPOPT fit.

    ``method``: "trf" (trust-region reflective, with the bounds) or "lm" (Levenberg-Marquardt,
    MINPACK; no bounds, for optima inside them).  ``tol`` is xtol = ftol = gtol.

    Returns
    -------
    dict: estimate (free parameters), success, status, nfev, cost.
    """
    tau = np.asarray(tau, float)
    values = START | (values or {})
    weights = {"u": 1.0, "q": 1.0} | (weights or {})
    bnd = _bounds(tau, free, bounds)
    parts = measured_parts(residual)
    meas = {"u": u, "q": q}

    def theta(v):
        th = dict(values)
        th.update(zip(free, v, strict=True))
        return th["alpha"], th["tau_max"]

    def res(v):
        disc = TurbulentDisc(*theta(v))
        model = {"u": disc.gap, "q": disc.flow}
        return np.concatenate([weights[k] * (model[k](tau) - meas[k]) for k in parts])

    def jac(v):
        a, t = theta(v)
        disc = TurbulentDisc(a, t)
        rows = []
        for k in parts:
            if k == "u":
                y = disc.gap(tau)
                d = {"alpha": -2.0 * y / (3.0 * a), "tau_max": y / (3.0 * (t - tau))}
            else:
                y = disc.flow(tau)
                d = {"alpha": -(1.0 - tau / t) / (a**3 * y), "tau_max": (1.0 + a**-2) * tau / (2.0 * y * t**2)}
            rows.append(weights[k] * np.column_stack([d[n] for n in free]))
        return np.vstack(rows)

    x0 = np.array([min(max(values[k], bnd[k][0] * (1 + 1e-6)), bnd[k][1]) for k in free])
    kw = {"xtol": tol, "ftol": tol, "gtol": tol}
    if method == "lm":
        sol = optimize.least_squares(res, x0, jac=jac, method="lm", **kw)
    else:
        sol = optimize.least_squares(res, x0, jac=jac, bounds=([bnd[k][0] for k in free], [bnd[k][1] for k in free]),
                                     method=method, max_nfev=2000, **kw)
    return {"estimate": dict(zip(free, map(float, sol.x), strict=True)), "success": bool(sol.status > 0),
            "status": sol.message, "nfev": int(sol.nfev), "cost": float(sol.cost)}


_DISC_CURVE: list = []


def disc_curve(tau, estimate: dict, free: list[str], cov, t: float) -> dict:
    """(4.18), (4.31) on ``tau`` with a delta-method band: value +- t sqrt(g' cov g), g = d value/d free.

    Returns
    -------
    dict: load, "u" and "q" -> (value, band low, band high) (1).
    """
    if not _DISC_CURVE:
        ts, th = ca.SX.sym("tau"), ca.SX.sym("theta", 2)
        disc = TurbulentDisc(th[0], th[1])
        y = ca.vertcat(disc.gap(ts), disc.flow(ts))
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
