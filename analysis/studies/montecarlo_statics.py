"""Monte Carlo of the device statics (Pavlenko 2014, chapter 3): every sample of the uncertain groups
solved exactly, beside the source's closed forms, and exact sensitivities at the means.

Two evaluations of every sample:

* ``exact``: the static balances with the sample's groups as parameters, solved by the Newton
  rootfinder of :class:`autobal.analysis.numerics.statics.ParametricStatics` mapped over all samples (one
  call, no Python loop), first with the stop set of the nominal device (from its first-order
  predictor), then with the other set (regulator regulating or the valve on its open stop).  A
  sample that neither solves is invalid and counted.
* ``source``: the source's closed forms as the Ch. 3 programs evaluate them, Figs. 3.3-3.4:
  u (2.27), xi (2.28), q_T (2.30) for the pump ((2.144)-(2.147) and (2.159) for the gas); NaN where
  they have no value (xi when psi_in is too low) and counted.

Leak flows: q_T = Q_T / Q_B over the source's base flow (2.29)/(2.156) per sample
(:func:`autobal.analysis.numerics.closed_form.flow_base`), and Q_T, Q_e in m^3/s.  Sensitivities:
d(output)/d(parameter) at the parameters' means by exact derivatives of the rootfinder
(implicit-function theorem), checked against central differences; the first-order variance
J Sigma J^T beside the Monte Carlo variance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import casadi as ca
import numpy as np

from autobal.analysis.numerics import closed_form
from autobal.analysis.numerics.sampling import Chunks, Sampler
from autobal.analysis.numerics.statics import ParametricStatics, ideal_guess
from autobal.models.device import DEVICE_GROUPS, REGULATOR_GROUPS, DeviceDesign

DISC_PARAMETERS = DEVICE_GROUPS
REGULATOR_PARAMETERS = REGULATOR_GROUPS
# exact outputs per sample and grid point; the source's closed forms give the SOURCE_OUTPUTS
OUTPUTS = ("u", "xi", "psi2", "psi3", "psi_e", "psi_cam", "q_T", "q_1", "Q_T", "Q_e")
SOURCE_OUTPUTS = ("u", "xi", "q_T", "q_1")
SENSITIVITY_OUTPUTS = ("u", "xi", "q_T", "Q_T", "Q_e")


class SampledStatics:
    """The statics of one device for samples of its uncertain groups (rows of X in the order of
    ``names``; "dpsi" may be one of them): the samples mapped onto the parameter columns of one
    :class:`~autobal.analysis.numerics.statics.ParametricStatics`, its outputs and derivatives.

    Parameters
    ----------
    dev : DeviceDesign
        The nominal device.
    names : sequence of str
        The uncertain groups (fields of the device's groups, or "dpsi").
    """

    def __init__(self, dev: DeviceDesign, names):
        self.design = dev
        self.names = tuple(names)
        self.theta_names = [n for n in self.names if n != "dpsi"]
        self.statics = ParametricStatics(dev.groups, self.theta_names)
        self.system = self.statics.system
        self._first: dict = {}  # psi1 -> the nominal device's stop set there
        self._start: dict = {}  # (psi1, active) -> the nominal root, its parameters and dW/dp

    def nominal(self) -> dict:
        """The nominal value of every group that may be uncertain (and dpsi)."""
        g = self.design.groups
        vals = {"dpsi": self.design.dpsi} | {k: getattr(g, k) for k in DISC_PARAMETERS}
        if g.regulator is not None:
            vals |= {k: getattr(g.regulator, k) for k in REGULATOR_PARAMETERS}
        return vals

    def groups(self, X: np.ndarray) -> tuple[SimpleNamespace, np.ndarray]:
        """The groups with the sampled ones as arrays (rows of X in the order of ``names``), and dpsi."""
        nom = self.nominal()
        cols = {n: X[:, j] for j, n in enumerate(self.names)}
        g = self.design.groups
        reg = None
        if g.regulator is not None:
            reg = SimpleNamespace(**{k: cols.get(k, nom[k]) for k in REGULATOR_PARAMETERS},
                                  xi_max=g.regulator.xi_max)
        return (SimpleNamespace(medium=g.medium, regulator=reg, **{k: cols.get(k, nom[k]) for k in DISC_PARAMETERS}),
                cols.get("dpsi", np.full(len(X), nom["dpsi"])))

    def params(self, X: np.ndarray, psi1: float) -> np.ndarray:
        """Parameter rows [psi1, dpsi, theta] of the evaluator, one per sample."""
        nom = self.nominal()
        cols = {n: X[:, j] for j, n in enumerate(self.names)}
        rows = [np.full(len(X), psi1), cols.get("dpsi", np.full(len(X), nom["dpsi"]))]
        return np.column_stack(rows + [cols[n] for n in self.theta_names])

    def guess(self, X: np.ndarray, psi1: float) -> np.ndarray:
        """Rows of unknowns from the exact ideal-regulator closed form (2.22)/(2.144) with each
        sample's groups, clipped into the bounds."""
        g, dpsi = self.groups(X)
        W0 = ideal_guess(g, self.system.unknowns, np.full(len(X), psi1), dpsi)
        return np.clip(W0, self.statics.lower, self.statics.upper)

    def _order(self, psi1: float) -> list:
        """The stop sets in the order to try at psi1: first the one of the nominal device there."""
        ps = self.statics
        if psi1 not in self._first:
            x0 = np.array([[self.nominal()[k] for k in self.names]])
            p0 = self.params(x0, psi1)
            self._first[psi1] = ps.active_sets[0]
            for active in ps.active_sets:
                sol = ps.solve(p0, [(active, self.guess(x0, psi1))])
                if sol["valid"][0]:
                    self._first[psi1] = active
                    free = ps.free(active)[0]
                    self._start[(psi1, active)] = (sol["W"][0], p0[0],
                                                   np.asarray(ps.sensitivity(active)(sol["W"][0][free], p0[0])))
                    break
        first = self._first[psi1]
        return [first] + [a for a in ps.active_sets if a != first]

    def solve(self, X: np.ndarray, psi1: float) -> dict:
        """Exact statics of every sample at discharge ratio psi1: unknowns W (samples x unknowns),
        flows q, pressures psi, largest balance residual, validity and whether the valve saturated."""
        P = self.params(X, psi1)
        W0 = self.guess(X, psi1)
        attempts = []  # the nominal device's stop set first, its first-order predictor before the guess
        for active in self._order(psi1):
            if active and (psi1, active) in self._start:
                w_nom, p0, S = self._start[(psi1, active)]
                start = np.tile(w_nom, (len(X), 1))
                start[:, self.statics.free(active)[0]] += (P - p0) @ S.T
                attempts.append((active, start))
            attempts.append((active, W0))
        sol = self.statics.solve(P, attempts)
        on_stop = np.array(["r_valve" in a for a, _ in attempts])
        sol["saturated"] = sol["valid"] & on_stop[np.maximum(sol["active"], 0)]
        return sol

    def outputs(self, X: np.ndarray, psi1: float) -> dict:
        """OUTPUTS of the exact statics and SOURCE_OUTPUTS of the closed forms, per sample."""
        sol = self.solve(X, psi1)
        sys_ = self.system
        g, dpsi = self.groups(X)
        base = closed_form.flow_base(g, dpsi)
        qs = dict(zip(sys_.throttles, sol["q"].T, strict=True))
        w = dict(zip(sys_.unknowns, sol["W"].T, strict=True))
        nan = np.full(len(X), np.nan)
        Q = self.design.scales["Q_scale"]
        ex = {"u": w["u"], "xi": w.get("xi", nan), "psi2": w["psi2"], "psi3": w["psi3"],
              "psi_e": sol["psi"][:, 0], "psi_cam": sol["psi"][:, 3],
              "q_T": qs["T"] / base, "q_1": qs["1"] / base, "Q_T": qs["T"] * Q, "Q_e": qs["e"] * Q}
        with np.errstate(invalid="ignore", divide="ignore"):
            cf = closed_form.for_medium(g, np.full(len(X), psi1), dpsi)
        src = {k: np.asarray(cf.get(k, nan), float) * np.ones(len(X)) for k in SOURCE_OUTPUTS}
        return {"exact": ex, "source": src, "saturated": sol["saturated"], "valid": sol["valid"],
                "residual": sol["residual"]}

    def derivatives(self, x: np.ndarray, psi1: float, active: frozenset, w0: np.ndarray) -> tuple[np.ndarray, dict]:
        """Jacobian d(SENSITIVITY_OUTPUTS)/d(uncertain parameters) at parameters ``x`` by the implicit
        function theorem through the rootfinder (exact, CasADi), and the outputs there."""
        ps = self.statics
        solver, free, full = ps.newton(active)
        xs = ca.MX.sym("x", len(self.names))
        nom = self.nominal()
        col = {n: xs[j] for j, n in enumerate(self.names)}
        dpsi = col.get("dpsi", nom["dpsi"])
        theta = ca.vertcat(*[col[n] for n in self.theta_names]) if self.theta_names else ca.MX(0, 1)
        W = full(solver(w0[free], ca.vertcat(psi1, dpsi, theta)))
        q = ps.flows(W, psi1, dpsi, theta)
        sys_ = self.system
        gx = SimpleNamespace(medium=self.design.groups.medium,
                             **{k: col.get(k, nom[k]) for k in ("alpha_e1", "alpha_31", "b", "chi", "sigma")})
        base = closed_form.flow_base(gx, dpsi)
        Qs = self.design.scales["Q_scale"]
        outs = {"u": W[sys_.index("u")],
                "xi": W[sys_.index("xi")] if "xi" in sys_.unknowns else ca.MX(math.nan),
                "q_T": q[sys_.throttles.index("T")] / base, "Q_T": q[sys_.throttles.index("T")] * Qs,
                "Q_e": q[sys_.throttles.index("e")] * Qs}
        y = ca.vertcat(*[outs[k] for k in SENSITIVITY_OUTPUTS])
        yv, J = ca.Function("sens", [xs], [y, ca.jacobian(y, xs)])(x)
        return np.asarray(J), dict(zip(SENSITIVITY_OUTPUTS, np.asarray(yv).ravel(), strict=True))


# ---- the Monte Carlo task, picklable for the executor -----------------------------------------

_EVALUATORS: dict = {}


def evaluator(dev: DeviceDesign, names) -> SampledStatics:
    """One SampledStatics per process and device (CasADi Functions are built once per worker)."""
    key = (repr(dev.groups), dev.dpsi, tuple(names))
    if key not in _EVALUATORS:
        _EVALUATORS[key] = SampledStatics(dev, names)
    return _EVALUATORS[key]


@dataclass(frozen=True)
class Task(Chunks):
    """Chunk i of a study: draw its samples and evaluate them at every grid point."""

    design: DeviceDesign | None = None
    grid: tuple = ()

    def __call__(self, chunk: int) -> dict:
        X = self.draw(chunk)
        ev = evaluator(self.design, self.sampler.names)
        per = [ev.outputs(X, psi1) for psi1 in self.grid]
        out = {"X": X}
        for part, keys in (("exact", OUTPUTS), ("source", SOURCE_OUTPUTS)):
            out[part] = {k: np.column_stack([p[part][k] for p in per]) for k in keys}
        out["saturated"] = np.column_stack([p["saturated"] for p in per])
        out["valid"] = np.column_stack([p["valid"] for p in per])
        out["residual"] = np.column_stack([p["residual"] for p in per])
        return out


def simulate(task: Task, executor) -> dict:
    """Run every chunk of ``task`` on ``executor``; samples and outputs in chunk order (n x grid)."""
    parts = executor.map(task, range(task.chunks), desc="monte carlo")
    out = {"X": np.concatenate([p["X"] for p in parts])}
    for part in ("exact", "source"):
        out[part] = {k: np.concatenate([p[part][k] for p in parts]) for k in parts[0][part]}
    out["saturated"] = np.concatenate([p["saturated"] for p in parts])
    out["valid"] = np.concatenate([p["valid"] for p in parts])
    out["residual"] = np.concatenate([p["residual"] for p in parts])
    return out



def sensitivities(ev: SampledStatics, sampler: Sampler, grid, nominal_points, mc_std: dict, step: float) -> dict:
    """Exact derivatives at the parameter means, their central-difference check, the first-order
    variance J Sigma J^T and each parameter's share of it (correlations left out of the shares)."""
    x = np.array([m.mean for m in sampler.marginals])
    cov = sampler.covariance()
    s = np.sqrt(np.diag(cov))
    jac = {k: [] for k in SENSITIVITY_OUTPUTS}
    std_lin = {k: [] for k in SENSITIVITY_OUTPUTS}
    share = {k: [] for k in SENSITIVITY_OUTPUTS}
    elastic = {k: [] for k in SENSITIVITY_OUTPUTS}
    fd_err = []
    for j, psi1 in enumerate(grid):
        pt = nominal_points[j]
        J, y = ev.derivatives(x, psi1, pt["active"], pt["x"])
        # central differences on the mapped Newton (the same active set), relative step ``step``
        h = step * np.maximum(np.abs(x), 1e-3)
        Xp = np.vstack([x + np.diag(h), x - np.diag(h)])
        ok = ev.outputs(Xp, psi1)["exact"]
        fd = np.vstack([(ok[k][:len(x)] - ok[k][len(x):]) / (2 * h) for k in SENSITIVITY_OUTPUTS])
        scale = np.maximum(np.abs(J).max(axis=1, keepdims=True), 1e-300)
        err = np.abs(fd - J) / scale
        fd_err.append(float(np.nanmax(err)) if np.isfinite(err).any() else math.nan)
        for i, k in enumerate(SENSITIVITY_OUTPUTS):
            row = J[i]
            jac[k].append(row)
            var = float(row @ cov @ row)
            std_lin[k].append(math.sqrt(var) if var >= 0 else math.nan)
            contrib = (row * s) ** 2
            share[k].append(contrib / contrib.sum() if contrib.sum() > 0 else np.full(len(row), np.nan))
            with np.errstate(invalid="ignore", divide="ignore"):
                elastic[k].append(row * x / y[k])
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = {k: (np.array(std_lin[k]) / np.asarray(mc_std[k])).tolist() for k in SENSITIVITY_OUTPUTS}
    return {"outputs": list(SENSITIVITY_OUTPUTS), "at": x, "jacobian": {k: np.array(v) for k, v in jac.items()},
            "elasticity": {k: np.array(v) for k, v in elastic.items()},
            "std_first_order": std_lin, "std_monte_carlo": {k: mc_std[k] for k in SENSITIVITY_OUTPUTS},
            "std_ratio": ratio, "variance_share": {k: np.array(v) for k, v in share.items()},
            "finite_difference_max_relative_error": fd_err}


