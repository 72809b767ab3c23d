"""Parameter estimation with the full static model of the balancing device (models/device.py):
any conductance ratio, area ratio or loss coefficient of the flow network free, fitted to measured
face gaps and/or the flow of one throttle (an extension of Pavlenko (2014), Sec. 4.4, to the
device of Ch. 2).

The parametric balances are :class:`~autobal.analysis.numerics.statics.ParametricStatics` with the fitted
groups as its parameter vector (the one evaluator of the statics, the Monte Carlo and this fit).  The fit is one
NLP in the parameters and the static states of every data point (balances as equality
constraints, stops fixed as :class:`~autobal.analysis.numerics.statics.StaticsSolver` found them at the
initial guess), solved by :class:`~autobal.analysis.numerics.least_squares.LeastSquares` (constrained
Gauss-Newton); the fitted model is re-solved by StaticsSolver to confirm.
"""

from __future__ import annotations

import math
from dataclasses import replace

import casadi as ca
import numpy as np

from autobal.analysis.numerics.least_squares import FitResult, LeastSquares, measured_parts, scale_of, uncertainty
from autobal.analysis.numerics.statics import ParametricStatics, StaticsSolver
from autobal.errors import ScenarioError, SolveError
from autobal.models.device import DEVICE_GROUPS, REGULATOR_GROUPS
from autobal.models.throttles import annulus_loss, face_loss

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
    """The groups (2.18) of Pavlenko (2014) that the device parameters ``theta`` set (numbers or
    CasADi expressions), for the DeviceDesign ``dev`` of the scene's ``device`` section.

    Loss coefficients act through the square-root conductances, g ~ 1/sqrt(zeta) (2.16):
    face friction lambda_T through zeta_TB, the outer seal's local loss and friction through
    zeta_u3 = zeta + lambda l/(2h) (Pavlenko (2014), App. A).
    """
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


class DeviceFitter:
    """Least squares of the device's full static model: parameters and the static states of every
    data point are the NLP's unknowns, the balances its equality constraints (stops fixed as found
    at the initial guess), the residual in u and/or the flow of one throttle.

    ``device`` is the device's DeviceParams (SI), ``dev`` its DeviceDesign; ``params``:
    name -> (value, free, lower, upper).  Loads are tau (psi1 = tau/b) or psi1.
    """

    def __init__(self, device, dev, params: dict, residual: str = "u", flow_throttle: str = "T",
                 hessian: str = "gauss-newton", max_iter: int | None = None):
        self.device, self.dev, self.params = device, dev, params
        self.residual, self.hessian, self.max_iter = residual, hessian, max_iter
        self.free = [k for k, v in params.items() if v[1]]
        self.scale = np.array([scale_of(params[k][0]) for k in self.free])
        self.fields = sorted(group_values(dev, device, {k: 1.0 for k in params}))
        self.parametric = ParametricStatics(dev.groups, self.fields)  # the balances with the fitted groups as input
        self.system = sys_ = self.parametric.system  # unknowns, bounds, throttles and stops
        if flow_throttle not in sys_.throttles:
            raise ScenarioError(f"flow_throttle: {flow_throttle!r} is not a throttle of this device "
                                f"({', '.join(sys_.throttles)})")
        self.k_flow = sys_.throttles.index(flow_throttle)

    def gamma(self, theta: dict):
        """Vector of the fitted groups (1) for parameter values ``theta`` (all listed parameters;
        numbers or CasADi expressions)."""
        g = group_values(self.dev, self.device, theta)
        return ca.vertcat(*[g[k] for k in self.fields])

    def design(self, theta: dict):
        """The DeviceDesign with the groups set by the parameter values ``theta`` (numbers)."""
        g = np.asarray(ca.evalf(self.gamma(theta))).ravel() if self.fields else []
        return replace(self.dev, groups=with_groups(self.dev.groups, dict(zip(self.fields, map(float, g),
                                                                              strict=True))))

    def _psi1(self, load, load_kind: str, b):
        return load / b if load_kind == "tau" else load

    def fit(self, load, load_kind: str, u=None, q=None, weights: dict | None = None, name: str = "fit",
            confidence: float = 0.95) -> FitResult:
        """Fit the listed parameters to measured gaps and/or flows.

        Parameters
        ----------
        load : array (n,)
            Loads: tau, or psi1 = p1/p_B, as ``load_kind`` ("tau" or "psi1") says (1).
        u, q : array (n,), optional
            Measured face gaps u = z/z_B and flows of the fitted throttle over g1 p_B (1).
        weights : dict, optional
            "u", "q" -> weight of that residual (1/its unit).
        name : str
            Label of the fit in messages.
        confidence : float
            Level of the Student-t intervals (1).

        Returns
        -------
        FitResult, with ``extra`` holding the fitted groups, the stops of each point and the
        largest difference of a StaticsSolver re-solve of the fitted model.
        """
        load = np.asarray(load, float)
        weights = {"u": 1.0, "q": 1.0} | (weights or {})
        parts = measured_parts(self.residual)
        meas = {"u": None if u is None else np.asarray(u, float), "q": None if q is None else np.asarray(q, float)}
        sys_ = self.system
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
            free_i, fixed = self.parametric.free(pt.active)
            z = ca.SX.sym(f"z{i}", len(free_i))
            wfull = ca.vertcat(*[z[free_i.index(j)] if j in free_i else fixed[j] for j in range(len(sys_.unknowns))])
            psi1 = self._psi1(load[i], load_kind, b)
            g.append(self.parametric.residual(wfull, psi1, self.dev.dpsi, gam))
            if "u" in parts:
                r["u"].append(weights["u"] * (wfull[iu] - meas["u"][i]))
            if "q" in parts:
                r["q"].append(weights["q"] * (self.parametric.flows(wfull, psi1, self.dev.dpsi, gam)[self.k_flow]
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
            stats=uncertainty(fitted_r, J, [est[k] for k in self.free], confidence),
            solver={"status": res["status"], "iterations": res["iterations"], "success": res["success"],
                    "objective": float(res["f"][0])},
            extra={"load_kind": load_kind, "flow_throttle": sys_.throttles[self.k_flow], "fitted_groups": groups_hat,
                   "statics_resolve_max_difference": float(max(diffs)), "stops_changed_points": int(changed),
                   "stops": [sorted(p.active) for p in points]})
        self._solver_hat, self._load_kind = check, load_kind
        return result

    def curve(self, fit: FitResult, loads) -> dict:
        """Fitted u and flow on ``loads`` (StaticsSolver continuation on the fitted design) with a
        delta-method band; sensitivities by the implicit-function theorem on the parametric balances.

        Returns
        -------
        dict: load, "u" and "q" -> (value, band low, band high) (1).
        """
        solver, sys_ = self._solver_hat, self.system
        est = fit.estimate
        w, ld, xt = ca.SX.sym("w", len(sys_.unknowns)), ca.SX.sym("load"), ca.SX.sym("theta", len(self.free))
        theta = {k: (xt[self.free.index(k)] if k in self.free else est[k]) for k in self.params}
        gam = self.gamma(theta)
        psi1 = self._psi1(ld, self._load_kind, theta.get("b", self.dev.groups.b))
        rr = self.parametric.residual(w, psi1, self.dev.dpsi, gam)
        y = ca.vertcat(w[sys_.index("u")], self.parametric.flows(w, psi1, self.dev.dpsi, gam)[self.k_flow])
        fn = ca.Function("sens", [w, ld, xt], [y, ca.jacobian(rr, w), ca.jacobian(rr, xt), ca.jacobian(y, w),
                                               ca.jacobian(y, xt)])
        th = np.array([est[k] for k in self.free])
        b_hat = est.get("b", self.dev.groups.b)
        cov, t = fit.stats["covariance"], fit.stats["t_quantile"]
        vals, halves, prev = [], [], None
        for lv in np.asarray(loads, float):
            prev = solver.solve(float(self._psi1(lv, self._load_kind, b_hat)), self.dev.dpsi, prev)
            yv, rw, rt, yw, yt = (np.asarray(a.full()) for a in fn(prev.x, lv, th))
            free_i, _ = self.parametric.free(prev.active)
            dw = -np.linalg.solve(rw[:, free_i], rt)
            gr = yt + yw[:, free_i] @ dw
            vals.append(yv.ravel())
            halves.append(t * np.sqrt(np.einsum("ji,ik,jk->j", gr, cov, gr)))
        vals, halves = np.array(vals), np.array(halves)
        return {"load": np.asarray(loads, float),
                **{k: (vals[:, j], vals[:, j] - halves[:, j], vals[:, j] + halves[:, j]) for j, k in
                   enumerate(("u", "q"))}}
