"""Probabilistic calculation of the balancing device: Monte Carlo over uncertain dimensionless groups,
exact parametric sensitivities and a first-order variance estimate (Pavlenko 2014, chapter 3).

Method (spec reliability-experiments-estimation.md §3): the groups of the static model (2.18)
{alpha_in1, alpha_B1, alpha_e1, alpha_TB1, alpha_31, b, sigma, chi, dpsi, psi_in} are random, each
with its own distribution (normal, uniform, lognormal, or the source's sum of 12 uniforms
``gauss12``, Fig. 3.1), optionally correlated through a Gaussian copula.  Each sample is one
realisation of the device, swept over the discharge ratios psi1 of the scene (the source re-draws
the samples at every grid point; the statistics per point are the same in distribution, and common
samples give smooth bands).

Two evaluations of every sample:

* ``exact``: the static balances of models/device.py with the sample's groups as a symbolic
  parameter vector, solved by CasADi's Newton rootfinder *mapped* over all samples and grid points
  (one call, no Python loop), first with the regulator regulating, then, for the samples outside
  the bounds, with the valve on its open stop (saturation, a square system too).  A sample that
  neither solves is invalid and counted.
* ``source``: the source's closed forms as the Ch. 3 programs evaluate them, Figs. 3.3-3.4:
  u (2.27), xi (2.28), q_T (2.30) for the pump ((2.144)-(2.147) and (2.159) for the gas); NaN where
  they have no value (xi when psi_in is too low) and counted.

Outputs per grid point: mean, standard deviation (population formulas, as the source), coefficient
of variation, bands mean +- k sigma (k = ``band_sigma``, 3 reproduces the source's "20 %" and
"25 %", spec §3.4) and quantiles.  Leak flows: q_T = Q_T / Q_B over the source's base flow (2.29)
per sample (the source's normalisation), and Q_T, Q_e in m^3/s.

Sensitivities: d(output)/d(parameter) at the parameters' means by exact derivatives of the
rootfinder (CasADi's implicit-function sensitivities), checked against central differences; the
first-order variance J Sigma J^T beside the Monte Carlo variance.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import casadi as ca
import numpy as np
from scipy.special import ndtr

from autobal.analysis import closed_form
from autobal.analysis.statics import ideal_guess
from autobal.errors import ScenarioError
from autobal.models.device import DEVICE_GROUPS, REGULATOR_GROUPS, DeviceDesign, static_system
from autobal.results import save_figure, write_csv

# the static model's groups that may be uncertain (DeviceGroups, RegulatorGroups and the margin dpsi)
PARAMETERS = (*DEVICE_GROUPS, "dpsi", *REGULATOR_GROUPS)
REGULATOR_PARAMETERS = REGULATOR_GROUPS
# exact outputs per sample and grid point; the source's closed forms give the SOURCE_OUTPUTS
OUTPUTS = ("u", "xi", "psi2", "psi3", "psi_e", "psi_cam", "q_T", "q_1", "Q_T", "Q_e")
SOURCE_OUTPUTS = ("u", "xi", "q_T", "q_1")
SENSITIVITY_OUTPUTS = ("u", "xi", "q_T", "Q_T", "Q_e")
RESIDUAL_TOL = 1e-10  # a Newton root is accepted below this largest absolute balance residual


# ---- distributions -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Marginal:
    """One uncertain parameter, resolved: kind, mean and standard deviation of the parameter itself
    (uniform also low, high)."""

    name: str
    kind: str
    mean: float
    std: float
    low: float = math.nan
    high: float = math.nan

    def transform(self, z: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Samples from standard normal scores z (Gaussian copula); gauss12 draws its own uniforms."""
        if self.kind == "normal":
            return self.mean + self.std * z
        if self.kind == "lognormal":
            s2 = math.log1p((self.std / self.mean) ** 2)
            return self.mean * np.exp(math.sqrt(s2) * z - 0.5 * s2)
        if self.kind == "uniform":
            return self.low + (self.high - self.low) * ndtr(z)
        if self.kind == "gauss12":  # Fig. 3.1: x (1 + kappa (sum of 12 rnd(1) - 6))
            return self.mean + self.std * (rng.random((z.size, 12)).sum(axis=1) - 6.0)
        raise ValueError(f"unknown distribution {self.kind!r}")


def marginals(parameters: dict, nominal: dict, where: str = "analyses.montecarlo.parameters") -> tuple:
    """Resolve the scene's distributions (autobal.schema_reliability.Distribution) against the
    model's nominal values; a lognormal with a mean <= 0 is refused naming the parameter."""
    out = []
    for name, d in parameters.items():
        if d.distribution == "uniform" and d.low is not None:
            low, high = d.low, d.high
            mean, std = 0.5 * (low + high), (high - low) / math.sqrt(12.0)
        else:
            mean = d.mean if d.mean is not None else nominal[name]
            std = d.std if d.std is not None else d.cv * abs(mean)
            low, high = mean - math.sqrt(3.0) * std, mean + math.sqrt(3.0) * std
        if d.distribution == "lognormal" and not mean > 0:
            raise ScenarioError(f"{where}.{name}: a lognormal parameter needs a positive mean, got {mean:g}")
        out.append(Marginal(name, d.distribution, float(mean), float(std), float(low), float(high)))
    return tuple(out)


def correlation_matrix(names, correlations) -> np.ndarray:
    c = np.eye(len(names))
    for r in correlations:
        i, j = names.index(r.between[0]), names.index(r.between[1])
        c[i, j] = c[j, i] = r.rho
    return c


@dataclass(frozen=True)
class Sampler:
    """Seeded, reproducible samples: chunk i draws from SeedSequence(seed, spawn_key=(stream, i)), so
    a chunk's samples depend only on (seed, stream, chunk index, chunk size), not on who computes it."""

    marginals: tuple
    correlation: np.ndarray | None
    seed: int
    stream: int = 0  # independent streams of one seed: 0 the statics, 1 the AFC

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.marginals]

    def draw(self, chunk: int, n: int) -> np.ndarray:
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(self.seed, spawn_key=(self.stream, chunk))))
        z = rng.standard_normal((n, len(self.marginals)))
        if self.correlation is not None:
            z = z @ np.linalg.cholesky(self.correlation).T
        return np.column_stack([m.transform(z[:, j], rng) for j, m in enumerate(self.marginals)])

    def covariance(self) -> np.ndarray:
        """Covariance of the parameters (the copula's correlation taken as theirs)."""
        s = np.array([m.std for m in self.marginals])
        c = self.correlation if self.correlation is not None else np.eye(len(s))
        return c * np.outer(s, s)


# ---- the statics mapped over samples -------------------------------------------------------------

def flow_base(g, dpsi):
    """The source's base flow Q_B/(g1 p_B) of the dimensionless flows q: Q_e of (2.29) for the liquid,
    (2.156) for the gas; plain arithmetic, so it takes numpy arrays and CasADi symbols alike."""
    ae, a3 = g.alpha_e1, g.alpha_31
    if g.medium == "liquid":
        return ae * dpsi / (1 + ae)
    return ae * a3 / (ae + a3) * (1 + dpsi - (g.b - g.chi) / g.sigma)


class StaticsMC:
    """The device's static model with the uncertain groups as inputs, built once, mapped over samples."""

    def __init__(self, dev: DeviceDesign, names):
        self.design = dev
        self.names = tuple(names)
        self.theta_names = [n for n in self.names if n != "dpsi"]
        self.system = static_system(dev.groups, self.theta_names)
        self._solvers: dict = {}
        self._maps: dict = {}
        self._first: dict = {}
        self._start: dict = {}  # (psi1, active) -> the nominal device's root, start of the stopped sets
        sys_ = self.system
        self.lower = np.array(sys_.lower, float)
        self.upper = np.array(sys_.upper, float)
        # active sets tried in turn: regulating, then the valve on its open stop
        self.active_sets = [frozenset()] + ([frozenset({"r_valve"})] if "r_valve" in sys_.stops else [])

    # parameters
    def nominal(self) -> dict:
        g = self.design.groups
        vals = {"dpsi": self.design.dpsi}
        vals |= {k: getattr(g, k) for k in ("sigma", "chi", "b", "psi4", "alpha_TB1", "alpha_31", "alpha_e1")}
        if g.regulator is not None:
            vals |= {k: getattr(g.regulator, k) for k in REGULATOR_PARAMETERS}
        return vals

    def groups(self, X: np.ndarray) -> tuple[SimpleNamespace, np.ndarray]:
        """The groups with the sampled ones as arrays (rows of X in the order of ``names``), and dpsi."""
        nom = self.nominal()
        cols = {n: X[:, j] for j, n in enumerate(self.names)}
        g = self.design.groups
        vals = {k: cols.get(k, nom[k]) for k in ("sigma", "chi", "b", "psi4", "alpha_TB1", "alpha_31", "alpha_e1")}
        reg = None
        if g.regulator is not None:
            reg = SimpleNamespace(**{k: cols.get(k, nom[k]) for k in REGULATOR_PARAMETERS},
                                  xi_max=g.regulator.xi_max)
        return SimpleNamespace(medium=g.medium, regulator=reg, **vals), cols.get("dpsi", np.full(len(X), nom["dpsi"]))

    def _params(self, X: np.ndarray, psi1: float) -> np.ndarray:
        """Parameter columns [psi1, dpsi, theta] of the mapped functions, one per sample."""
        nom = self.nominal()
        cols = {n: X[:, j] for j, n in enumerate(self.names)}
        rows = [np.full(len(X), psi1), cols.get("dpsi", np.full(len(X), nom["dpsi"]))]
        rows += [cols[n] for n in self.theta_names]
        return np.vstack(rows)

    # solvers
    def _solver(self, active: frozenset):
        """Newton rootfinder of the square system with the stops in ``active`` reached (coordinate on
        its stop, reaction free) and the others not (reaction 0): (solver, free indices, full map)."""
        if active not in self._solvers:
            sys_ = self.system
            n, k = len(sys_.unknowns), 2 + len(self.theta_names)
            fixed = sys_.fixed_by_stops(active)
            free = [i for i, name in enumerate(sys_.unknowns) if name not in fixed]
            wf, p = ca.SX.sym("wf", len(free)), ca.SX.sym("p", k)
            full = ca.vertcat(*[wf[free.index(i)] if i in free else fixed[name]
                                for i, name in enumerate(sys_.unknowns)])
            res = sys_.residual(full, p[0], p[1], p[2:])
            rf = ca.Function("square", [wf, p], [res])
            solver = ca.rootfinder(f"newton_{'_'.join(sorted(active)) or 'free'}", "newton", rf,
                                   {"abstol": 1e-14, "max_iter": 50, "error_on_fail": False})
            self._solvers[active] = (solver, free, ca.Function("full", [wf], [full]), n)
        return self._solvers[active]

    def _sensitivity(self, active: frozenset) -> ca.Function:
        """d(free unknowns)/d(parameter column) of the rootfinder, (start, p) -> matrix (exact, IFT)."""
        solver, free, _, _ = self._solver(active)
        wf, p = ca.MX.sym("wf", len(free)), ca.MX.sym("p", 2 + len(self.theta_names))
        return ca.Function("dW_dp", [wf, p], [ca.jacobian(solver(wf, p), p)])

    def _mapped(self, active: frozenset, m: int) -> ca.Function:
        key = (active, m)
        if key not in self._maps:
            solver, free, full, n = self._solver(active)
            wf, p = ca.MX.sym("W", len(free), m), ca.MX.sym("P", 2 + len(self.theta_names), m)
            W = full.map(m)(solver.map(m)(wf, p))
            flows = self.system.flows.map(m)
            r = self.system.residual.map(m)(W, p[0, :], p[1, :], p[2:, :])
            q, psi = flows(W, p[0, :], p[1, :], p[2:, :])
            self._maps[key] = ca.Function("mapped_statics", [wf, p], [W, ca.fabs(r), q, psi])
            if len(self._maps) > 16:  # keep the cache small: sizes of the fallback passes vary
                self._maps.pop(next(iter(self._maps)))
        return self._maps[key]

    def guess(self, X: np.ndarray, psi1: float) -> np.ndarray:
        """Rows of unknowns from the exact ideal-regulator closed form (2.22)/(2.144) with each sample's
        groups (analysis/statics.py ideal_guess)."""
        g, dpsi = self.groups(X)
        return ideal_guess(g, self.system.unknowns, np.full(len(X), psi1), dpsi)

    def _order(self, psi1: float) -> list:
        """The active sets in the order to try at psi1: first the one of the nominal device there."""
        if psi1 not in self._first:
            x0 = np.array([[self.nominal()[k] for k in self.names]])
            W0 = np.clip(self.guess(x0, psi1), self.lower, self.upper)
            self._first[psi1] = self.active_sets[0]
            for active in self.active_sets:
                _, free, _, _ = self._solver(active)
                W, r, _, _ = (np.asarray(a).T for a in self._mapped(active, 1)(W0[:, free].T, self._params(x0, psi1)))
                if np.all(np.isfinite(W) & (W >= self.lower) & (W <= self.upper)) and r.max() <= RESIDUAL_TOL:
                    self._first[psi1] = active
                    p0 = self._params(x0, psi1)[:, 0]
                    self._start[(psi1, active)] = (W[0], p0, np.asarray(self._sensitivity(active)(W[0][free], p0)))
                    break
        first = self._first[psi1]
        return [first] + [a for a in self.active_sets if a != first]

    def solve(self, X: np.ndarray, psi1: float) -> dict:
        """Exact statics of every sample at discharge ratio psi1: unknowns W (n x unknowns), flows q,
        pressures, validity and the stop each sample ended on."""
        n = len(X)
        P = self._params(X, psi1)
        W0 = np.clip(self.guess(X, psi1), self.lower, self.upper)
        sys_ = self.system
        W = np.full((n, len(sys_.unknowns)), np.nan)
        q = np.full((n, len(sys_.throttles)), np.nan)
        psi = np.full((n, 4), np.nan)
        todo = np.arange(n)
        saturated = np.zeros(n, bool)
        resid = np.full(n, np.nan)  # largest absolute balance residual of each accepted root
        attempts = []  # (active set, start): the nominal device's stop first, its predictor before the guess
        for active in self._order(psi1):
            if active and (psi1, active) in self._start:
                attempts.append((active, "predictor"))
            attempts.append((active, "guess"))
        for active, how in attempts:
            if todo.size == 0:
                break
            _, free, _, _ = self._solver(active)
            f = self._mapped(active, todo.size)
            if how == "predictor":  # first order from the nominal root, exact dW/dp
                w_nom, p0, S = self._start[(psi1, active)]
                start = w_nom[free][:, None] + S @ (P[:, todo] - p0[:, None])
            else:
                start = W0[todo][:, free].T
            Wk, r, qk, pk = (np.asarray(a).T for a in f(start, P[:, todo]))
            ok = np.all(np.isfinite(Wk) & (Wk >= self.lower) & (Wk <= self.upper), axis=1)
            ok &= np.max(r, axis=1) <= RESIDUAL_TOL
            idx = todo[ok]
            W[idx], q[idx], psi[idx] = Wk[ok], qk[ok], pk[ok]
            resid[idx] = np.max(r, axis=1)[ok]
            saturated[idx] = "r_valve" in active
            todo = todo[~ok]
        return {"W": W, "q": q, "psi": psi, "valid": np.isfinite(W[:, 0]), "saturated": saturated,
                "residual": resid}

    def outputs(self, X: np.ndarray, psi1: float) -> dict:
        """OUTPUTS of the exact statics and SOURCE_OUTPUTS of the closed forms, per sample."""
        sol = self.solve(X, psi1)
        sys_ = self.system
        g, dpsi = self.groups(X)
        base = flow_base(g, dpsi)
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

    # exact derivatives
    def derivatives(self, x: np.ndarray, psi1: float, active: frozenset, w0: np.ndarray) -> tuple[np.ndarray, dict]:
        """Jacobian d(SENSITIVITY_OUTPUTS)/d(uncertain parameters) at parameters ``x`` by the implicit
        function theorem through the rootfinder (exact, CasADi), and the outputs there."""
        solver, free, full, _ = self._solver(active)
        xs = ca.MX.sym("x", len(self.names))
        nom = self.nominal()
        col = {n: xs[j] for j, n in enumerate(self.names)}
        dpsi = col.get("dpsi", nom["dpsi"])
        theta = ca.vertcat(*[col[n] for n in self.theta_names]) if self.theta_names else ca.MX(0, 1)
        P = ca.vertcat(psi1, dpsi, theta)
        W = full(solver(w0[free], P))
        q, psi = self.system.flows(W, psi1, dpsi, theta)
        sys_ = self.system
        gx = SimpleNamespace(medium=self.design.groups.medium, **{k: col.get(k, nom[k]) for k in
                                                                  ("alpha_e1", "alpha_31", "b", "chi", "sigma")})
        base = flow_base(gx, dpsi)
        Qs = self.design.scales["Q_scale"]
        outs = {"u": W[sys_.unknowns.index("u")],
                "xi": W[sys_.unknowns.index("xi")] if "xi" in sys_.unknowns else ca.MX(math.nan),
                "q_T": q[sys_.throttles.index("T")] / base, "Q_T": q[sys_.throttles.index("T")] * Qs,
                "Q_e": q[sys_.throttles.index("e")] * Qs}
        y = ca.vertcat(*[outs[k] for k in SENSITIVITY_OUTPUTS])
        f = ca.Function("sens", [xs], [y, ca.jacobian(y, xs)])
        yv, J = f(x)
        return np.asarray(J), dict(zip(SENSITIVITY_OUTPUTS, np.asarray(yv).ravel(), strict=True))


# ---- the Monte Carlo task, picklable for the executor -----------------------------------------

_EVALUATORS: dict = {}


def _evaluator(dev: DeviceDesign, names) -> StaticsMC:
    """One StaticsMC per process and device (CasADi Functions are built once per worker)."""
    key = (repr(dev.groups), dev.dpsi, tuple(names))
    if key not in _EVALUATORS:
        _EVALUATORS[key] = StaticsMC(dev, names)
    return _EVALUATORS[key]


@dataclass(frozen=True)
class Task:
    """Chunk i of a study: draw its samples and evaluate them at every grid point."""

    design: DeviceDesign
    sampler: Sampler
    grid: tuple
    samples: int
    chunk_size: int

    @property
    def chunks(self) -> int:
        return -(-self.samples // self.chunk_size)

    def __call__(self, chunk: int) -> dict:
        n = min(self.chunk_size, self.samples - chunk * self.chunk_size)
        X = self.sampler.draw(chunk, n)
        ev = _evaluator(self.design, self.sampler.names)
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


# ---- the AFC amplitude through a linear model of the dynamics (Fig. 3.7) -------------------------

HAND_MODES = ("program", "thesis", "consistent")


def afc_parameters(model: str) -> tuple:
    """Names a model of the AFC Monte Carlo can take as uncertain: the 28 constants of the hand
    model (2.44)/(2.169), or the dynamic data of the nonlinear model (models/dynamics.py)."""
    if model in HAND_MODES:
        from autobal.analysis.hand_linear import K_NAMES, OTHER, T_NAMES

        return K_NAMES + T_NAMES + OTHER
    from autobal.models.dynamics import PARAM_NAMES

    return PARAM_NAMES


class AfcModel:
    """Face-gap amplitude A_u(omega) in um for parameter samples (analysis/linearize.py's models).

    Hand models (Fig. 3.7 with mode "program"): each sample's constants give N(p) of (2.101)
    (hand_linear.Constants.operator, assembled per sample) and W = N(i omega)^-1 B, solved for all
    samples at once per omega.  Nonlinear models: the exact Jacobians A, B of the nonlinear model
    at its equilibrium (linearize.jacobians), mapped over the samples of the dynamic data with
    CasADi ``map``, then (i omega I - A)^-1 b per omega for all samples at once.
    A_u = |W_u| dpsi1a z_B 1e6 (App. A L3412)."""

    def __init__(self, setup, model: str, names, convention: str = "appendix"):
        self.setup, self.model, self.names, self.convention = setup, model, tuple(names), convention
        self.scale = setup.data.forcing_amplitude * setup.dev.scales["z_B"] * 1e6
        if model in HAND_MODES:
            self.base = setup.constants(model)
            self._nominal = dict(self.base.c)
        else:
            from autobal.models.dynamics import PARAM_NAMES

            self.nl = setup.nonlinear("chain" if model == "nonlinear_chain" else "energy")
            self._nominal = dict(zip(PARAM_NAMES, map(float, self.nl.p0), strict=True))
        self._maps: dict = {}

    def nominal(self) -> dict:
        return dict(self._nominal)

    def amplitude(self, X: np.ndarray, omega) -> np.ndarray:
        """A_u (um), samples x omega, for rows of X in the order of ``names``."""
        omega = np.asarray(omega, float)
        if self.model in HAND_MODES:
            M0, M1, M2, bvec = self._hand(X)
        else:
            M0, M1, M2, bvec = self._nonlinear(X)
        out = np.empty((len(X), len(omega)))
        for j, w in enumerate(omega):
            s = 1j * w
            W = np.linalg.solve(M0 + s * M1 + (s * s) * M2, bvec[..., None])[..., 0]
            out[:, j] = np.abs(W[:, self._u]) * self.scale
        return out

    def _hand(self, X):
        from autobal.analysis.hand_linear import Constants

        b = self.base
        mats = []
        for row in X:  # the operator's layout is hand_linear's; only its assembly runs per sample
            c = Constants(c=self._nominal | dict(zip(self.names, map(float, row), strict=True)), sigma=b.sigma,
                          sigma_m=b.sigma_m, b=b.b, z_B=b.z_B, regulator=b.regulator, mode=b.mode)
            N0, N1, N2, Gin = c.operator()
            mats.append((N0, N1, N2, Gin @ np.array([1.0 if self.convention == "appendix" else b.b, 1.0])))
        self._u = 0
        return tuple(np.array([m[k] for m in mats]) for k in range(4))

    def _nonlinear(self, X):
        from autobal.analysis.linearize import jacobians
        from autobal.models.dynamics import PARAM_NAMES

        nl, n = self.nl, len(X)
        P = np.tile(nl.p0, (n, 1))
        for j, name in enumerate(self.names):
            P[:, PARAM_NAMES.index(name)] = X[:, j]
        if n not in self._maps:
            self._maps = {n: jacobians(nl).map(n)}
        A, B = self._maps[n](nl.x0, nl.w0, P.T)
        nx = len(nl.states)
        A = np.asarray(A).reshape(nx, n, nx).transpose(1, 0, 2)
        B = np.asarray(B).reshape(nx, n, 2).transpose(1, 0, 2)  # inputs (psi1, tau)
        tau = 1.0 if self.convention == "appendix" else nl.design.groups.b
        self._u = nl.index("u")
        eye = np.broadcast_to(np.eye(nx), A.shape)
        return -A, eye, np.zeros_like(A), B[..., 0] + tau * B[..., 1]


_AFC_MODELS: dict = {}


def _afc_model(device, psi1: float, model: str, names, convention: str) -> AfcModel:
    """One AfcModel per process, device, operating point and model (built once per worker)."""
    from autobal.analysis.linearize import Setup

    key = (repr(device), psi1, model, tuple(names), convention)
    if key not in _AFC_MODELS:
        _AFC_MODELS[key] = AfcModel(Setup(device, psi1), model, names, convention)
    return _AFC_MODELS[key]


@dataclass(frozen=True)
class AfcTask:
    """Chunk i of the AFC Monte Carlo: draw its samples (stream 1) and evaluate A_u on the omega grid."""

    device: object  # the scene's validated ``device`` (plain data)
    psi1: float
    model: str
    convention: str
    sampler: Sampler
    omega: tuple
    samples: int
    chunk_size: int

    @property
    def chunks(self) -> int:
        return -(-self.samples // self.chunk_size)

    def __call__(self, chunk: int) -> np.ndarray:
        n = min(self.chunk_size, self.samples - chunk * self.chunk_size)
        X = self.sampler.draw(chunk, n)
        return _afc_model(self.device, self.psi1, self.model, self.sampler.names, self.convention).amplitude(
            X, self.omega)


def afc_study(device, settings, seed: int, executor, band_sigma: float, quantiles) -> dict:
    """AFC Monte Carlo (Fig. 3.7): statistics of A_u on the grid, at the nominal model's peaks and at
    the operating speed, beside the nominal AFC of analysis/frequency.py."""
    from autobal.analysis import frequency

    a = settings
    if device is None or getattr(device, "dynamics", None) is None:
        raise ScenarioError("analyses.montecarlo.afc needs device.dynamics (masses, springs, volumes)")
    names = list(a.parameters)
    am = _afc_model(device, a.operating_ratio, a.model, names, a.forcing)
    lin = am.setup.linear(a.model)
    d = am.setup.data
    nominal = frequency.characteristic(lin, (a.omega.start, a.omega.stop, a.omega.points), a.forcing,
                                       d.forcing_amplitude, d.omega0)
    marks = {"operating_speed": d.omega0} | {f"peak_{i + 1}": p["omega"] for i, p in enumerate(nominal["peaks"])}
    marks = {k: float(v) for k, v in marks.items() if np.isfinite(v) and v > 0}
    grid = np.geomspace(a.omega.start, a.omega.stop, a.omega.points)
    omega = np.concatenate([grid, list(marks.values())])
    sampler = Sampler(marginals(a.parameters, am.nominal(), "analyses.montecarlo.afc.parameters"), None, seed,
                      stream=1)
    task = AfcTask(device, a.operating_ratio, a.model, a.forcing, sampler, tuple(omega), a.samples,
                   min(a.chunk_size, a.samples))
    amp = np.concatenate(executor.map(task, range(task.chunks), desc="monte carlo afc"))
    det = am.amplitude(np.array([[am.nominal()[n] for n in names]]), omega)[0]
    st = statistics(amp, band_sigma, quantiles)
    n = len(grid)
    at = {k: {"omega": w, "nominal_um": det[n + i], "mean_um": st["mean"][n + i], "std_um": st["std"][n + i],
              "cv": st["cv"][n + i]} for i, (k, w) in enumerate(marks.items())}
    return {"model": a.model, "forcing": a.forcing, "samples": a.samples, "psi1": a.operating_ratio,
            "parameters": names, "omega": grid, "nominal_um": det[:n],
            **{k: (v[:n] if isinstance(v, np.ndarray) else v) for k, v in st.items() if k != "quantiles"},
            "quantiles": {q: v[:n] for q, v in st["quantiles"].items()},
            "nominal_peaks": nominal["peaks"], "at": at, "amplitude_samples": amp}


# ---- statistics -----------------------------------------------------------------------------------

def statistics(Y: np.ndarray, band_sigma: float, quantiles) -> dict:
    """Per column of Y (samples x grid): population mean and std over the finite samples (as the
    source's S/N, sqrt(S2/N - (S/N)^2)), cv, bands mean +- k std, quantiles, valid counts."""
    ok = np.isfinite(Y)
    n = ok.sum(axis=0)
    Z = np.where(ok, Y, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = Z.sum(axis=0) / n
        std = np.sqrt(np.where(ok, (Y - mean) ** 2, 0.0).sum(axis=0) / n)
        cv = std / np.abs(mean)
    qs = np.full((len(quantiles), Y.shape[1]), np.nan)
    for j in range(Y.shape[1]):
        if n[j]:
            qs[:, j] = np.quantile(Y[ok[:, j], j], quantiles)
    return {"mean": mean, "std": std, "cv": cv, "band_low": mean - band_sigma * std,
            "band_high": mean + band_sigma * std, "spread": band_sigma * cv,
            "quantiles": {f"{q:g}": qs[i] for i, q in enumerate(quantiles)},
            "valid": n, "invalid": Y.shape[0] - n}


# ---- the study -----------------------------------------------------------------------------------

@dataclass
class MonteCarloResult:
    data: dict
    samples: dict = field(default_factory=dict, repr=False)  # raw arrays, not written to results.json

    def to_dict(self) -> dict:
        return self.data

    def summary(self) -> str:
        d = self.data
        lines = [f"monte carlo: {d['samples']} samples x {len(d['psi1'])} discharge ratios, seed {d['seed']}, "
                 f"{d['executor']}, {d['time_s']:.2f} s; bands mean +- {d['band_sigma']:g} sigma"]
        ex, src = d["exact"], d["source"]
        lines.append(f"  {'psi1':>6s} {'m_u':>8s} {'cv_u':>7s} {'m_qT':>8s} {'cv_qT':>7s} | source: "
                     f"{'m_u':>8s} {'cv_u':>7s} {'m_qT':>8s} {'cv_qT':>7s} | saturated invalid")
        for j, p in enumerate(d["psi1"]):
            lines.append(f"  {p:6.3f} {ex['u']['mean'][j]:8.4f} {ex['u']['cv'][j]:7.4f} {ex['q_T']['mean'][j]:8.4f} "
                         f"{ex['q_T']['cv'][j]:7.4f} |         {src['u']['mean'][j]:8.4f} {src['u']['cv'][j]:7.4f} "
                         f"{src['q_T']['mean'][j]:8.4f} {src['q_T']['cv'][j]:7.4f} | "
                         f"{d['saturated_fraction'][j]:9.3f} {ex['u']['invalid'][j]:7d}")
        s = d["sensitivity"]
        for k in ("u", "q_T"):
            lines.append(f"  first-order std of {k} / Monte Carlo std: "
                         + ", ".join(f"{r:.3f}" for r in s["std_ratio"][k]))
        j = d["psi1"].index(d["reference_psi1"]) if d["reference_psi1"] in d["psi1"] else 0
        lines.append(f"  at psi1 = {d['psi1'][j]:g}: {d['band_sigma']:g} sigma / mean of u {ex['u']['spread'][j]:.3f}, "
                     f"of q_T {ex['q_T']['spread'][j]:.3f} (exact); {src['u']['spread'][j]:.3f}, "
                     f"{src['q_T']['spread'][j]:.3f} (source's forms); source: 0.20 and 0.25")
        if "afc" in d:
            a = d["afc"]
            lines.append(f"  AFC ({a['model']} model, {a['samples']} samples, {a['time_s']:.2f} s): "
                         + "; ".join(f"{k} {v['omega']:.0f} rad/s: nominal {v['nominal_um']:.2f} um, mean "
                                     f"{v['mean_um']:.2f} um, cv {v['cv']:.3f}" for k, v in a["at"].items()))
        return "\n".join(lines)

    def write_tables(self, out: Path) -> list[Path]:
        d = self.data
        files = []
        if "afc" in d:
            a = d["afc"]
            write_csv(out / "montecarlo_afc.csv", {"omega_rad_s": a["omega"], "nominal_um": a["nominal_um"],
                                                   "mean_um": a["mean"], "std_um": a["std"],
                                                   "band_low_um": a["band_low"], "band_high_um": a["band_high"]})
            files.append(out / "montecarlo_afc.csv")
        cols = {"psi1": d["psi1"], "saturated_fraction": d["saturated_fraction"]}
        for part, keys in (("exact", OUTPUTS), ("source", SOURCE_OUTPUTS)):
            for k in keys:
                s = d[part][k]
                for stat in ("nominal", "mean", "std", "band_low", "band_high", "invalid"):
                    if stat in s:
                        cols[f"{part}_{k}_{stat}"] = s[stat]
        write_csv(out / "montecarlo_statics.csv", cols)
        sens = d["sensitivity"]
        rows = {"psi1": [], "output": [], **{f"d_d_{n}": [] for n in d["parameters"]}}
        for j, p in enumerate(d["psi1"]):
            for k in SENSITIVITY_OUTPUTS:
                rows["psi1"].append(p)
                rows["output"].append(k)
                for i, n in enumerate(d["parameters"]):
                    rows[f"d_d_{n}"].append(sens["jacobian"][k][j][i])
        write_csv(out / "montecarlo_sensitivities.csv", rows)
        return [out / "montecarlo_statics.csv", out / "montecarlo_sensitivities.csv"] + files

    def plot(self, out: Path) -> list[Path]:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        d = self.data
        psi1 = np.asarray(d["psi1"], float)
        fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
        for ax, k, lab in ((axes[0], "u", r"face gap $u = z/z_B$"), (axes[1], "q_T", r"leak $q_T = Q_T/Q_B$")):
            for part, ls in (("exact", "-"), ("source", "--")):
                s = d[part][k]
                line, = ax.plot(psi1, s["mean"], ls=ls, marker="o", ms=3, label=f"mean, {part}")
                ax.fill_between(psi1, s["band_low"], s["band_high"], color=line.get_color(), alpha=0.15,
                                label=rf"mean $\pm {d['band_sigma']:g}\sigma$, {part}")
            ax.plot(psi1, d["exact"][k]["nominal"], "k:", label="deterministic (nominal groups)")
            ax.set_xlabel(r"discharge pressure ratio $\psi_1$")
            ax.set_ylabel(lab)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        sens = d["sensitivity"]
        j = d["psi1"].index(d["reference_psi1"]) if d["reference_psi1"] in d["psi1"] else 0
        names = d["parameters"]
        x = np.arange(len(names))
        for off, k in ((-0.2, "u"), (0.2, "q_T")):
            axes[2].bar(x + off, sens["variance_share"][k][j], width=0.4, label=k)
        axes[2].set_xticks(x, names, rotation=60, fontsize=7)
        axes[2].set_ylabel(f"share of first-order variance at $\\psi_1$ = {d['psi1'][j]:g}")
        axes[2].legend(fontsize=7)
        axes[2].grid(alpha=0.3, axis="y")
        fig.suptitle(d["title"], fontsize=9)
        paths = [save_figure(fig, out / "fig_montecarlo.png")]
        if "afc" in d:
            a = d["afc"]
            fig, ax = plt.subplots(figsize=(7, 4.4))
            ax.plot(a["omega"], a["nominal_um"], "k:", label=f"nominal ({a['model']} model)")
            line, = ax.plot(a["omega"], a["mean"], label="mean")
            ax.fill_between(a["omega"], np.maximum(a["band_low"], 0), a["band_high"], color=line.get_color(),
                            alpha=0.2, label=rf"mean $\pm {d['band_sigma']:g}\sigma$")
            for k in ("0.00135", "0.99865"):
                if k in a["quantiles"]:
                    ax.plot(a["omega"], a["quantiles"][k], color=line.get_color(), lw=0.6, ls="--")
            ax.set_xlabel(r"$\omega$, rad/s")
            ax.set_ylabel(r"face-gap amplitude $A_u$, $\mu$m")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
            ax.set_title(f"{d['title']}\nAFC Monte Carlo (Fig. 3.7/3.10); dashed: 0.135 % and 99.865 % quantiles",
                         fontsize=9)
            paths.append(save_figure(fig, out / "fig_montecarlo_afc.png"))
        return paths


def sensitivities(ev: StaticsMC, sampler: Sampler, grid, nominal_points, mc_std: dict, step: float) -> dict:
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


def run(dev: DeviceDesign, settings, executor, title: str = "", solver=None, device=None) -> MonteCarloResult:
    """The Monte Carlo study of a device: spreads vs discharge ratio, sensitivities, first-order variance,
    and with ``settings.afc`` the AFC amplitude (``device``: the scene's device with its dynamics)."""
    from autobal.analysis.statics import StaticsSolver

    t0 = time.perf_counter()
    names = list(settings.parameters)
    if dev.groups.regulator is None:
        bad = [n for n in names if n in REGULATOR_PARAMETERS]
        if bad:
            raise ScenarioError(f"analyses.montecarlo.parameters.{bad[0]}: not a parameter of this device "
                                f"(it has no regulator section)")
    ev = _evaluator(dev, names)
    margs = marginals(settings.parameters, ev.nominal())
    corr = correlation_matrix(names, settings.correlations) if settings.correlations else None
    sampler = Sampler(margs, corr, settings.seed)
    grid = tuple(float(p) for p in settings.discharge_ratio)
    task = Task(dev, sampler, grid, settings.samples, min(settings.chunk_size, settings.samples))
    raw = simulate(task, executor)
    t_mc = time.perf_counter() - t0

    solver = solver or StaticsSolver(dev)
    nominal_points = []
    nom = {k: [] for k in OUTPUTS}
    for psi1 in grid:
        pt = solver.solve(psi1, dev.dpsi)
        nominal_points.append({"active": pt.active - {"r_contact"}, "x": pt.x})
        X0 = np.array([[ev.nominal()[n] for n in names]])
        o = ev.outputs(X0, psi1)["exact"]
        for k in OUTPUTS:
            nom[k].append(float(o[k][0]))
    cf_nom = closed_form.for_medium(dev.groups, np.array(grid), dev.dpsi)

    exact = {k: statistics(raw["exact"][k], settings.band_sigma, settings.quantiles) | {"nominal": nom[k]}
             for k in OUTPUTS}
    source = {k: statistics(raw["source"][k], settings.band_sigma, settings.quantiles)
              | {"nominal": np.asarray(cf_nom.get(k, np.nan), float) * np.ones(len(grid))} for k in SOURCE_OUTPUTS}
    sens = sensitivities(ev, sampler, grid, nominal_points, {k: exact[k]["std"] for k in SENSITIVITY_OUTPUTS},
                         settings.sensitivity_step)
    samples_X = raw["X"]
    data = {
        "title": title, "samples": settings.samples, "seed": settings.seed, "chunk_size": task.chunk_size,
        "executor": executor.name, "band_sigma": settings.band_sigma, "psi1": list(grid),
        "reference_psi1": 1.0,
        "parameters": names,
        "distributions": {m.name: {"distribution": m.kind, "mean": m.mean, "std": m.std,
                                   **({"low": m.low, "high": m.high} if m.kind == "uniform" else {})}
                          for m in margs},
        "correlation": corr if corr is not None else None,
        "sample_mean": samples_X.mean(axis=0), "sample_std": samples_X.std(axis=0),
        "exact": exact, "source": source,
        "saturated_fraction": raw["saturated"].mean(axis=0),
        "sensitivity": sens,
        "time_s": time.perf_counter() - t0, "time_monte_carlo_s": t_mc,
    }
    if settings.afc is not None:
        t1 = time.perf_counter()
        afc = afc_study(device, settings.afc, settings.seed, executor, settings.band_sigma, settings.quantiles)
        raw["afc"] = afc.pop("amplitude_samples")
        data["afc"] = afc | {"time_s": time.perf_counter() - t1}
        data["time_s"] = time.perf_counter() - t0
    data["accuracy"] = accuracy(data, raw)
    return MonteCarloResult(data, samples=raw)


def relative_standard_errors(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Monte Carlo standard errors, relative, of the mean and of cv = std/mean per column of Y (samples x
    grid, NaN = invalid sample), from the samples themselves: SE(mean) = std/sqrt(n); SE(cv) by the delta
    method, the standard deviation of the influence function (d^2 - s^2)/(2 s m) - s d/m^2, d = y - m,
    over sqrt(n).  A spread k cv has the relative error of cv."""
    ok = np.isfinite(Y)
    n = ok.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(ok, Y, 0.0).sum(axis=0) / n
        d = np.where(ok, Y - m, 0.0)
        s = np.sqrt((d**2).sum(axis=0) / n)
        infl = np.where(ok, (d**2 - s**2) / (2 * s * m) - s * d / m**2, 0.0)
        se_cv = np.sqrt((infl**2).sum(axis=0) / n) / np.sqrt(n)
        return s / np.abs(m) / np.sqrt(n), se_cv / (s / np.abs(m))


def accuracy(data: dict, raw: dict) -> dict:
    """Error estimate of the main outputs, the spreads (k cv) and means of the face gap u and the leak q_T
    (exact statics and the source's forms) at every discharge ratio and, with the AFC study, of the
    amplitude at the operating speed and the nominal peaks: their Monte Carlo standard errors
    (:func:`relative_standard_errors`); beside it the largest balance residual of the accepted roots."""
    se_mean, se_spread = {}, {}
    for part in ("exact", "source"):
        for k in ("u", "q_T"):
            a, b = relative_standard_errors(raw[part][k])
            se_mean[f"{part}_{k}"], se_spread[f"{part}_{k}"] = a.tolist(), b.tolist()
    if "afc" in data:
        a, b = relative_standard_errors(raw["afc"][:, len(data["afc"]["omega"]):])
        se_mean["afc_at"], se_spread["afc_at"] = a.tolist(), b.tolist()
    worst = max(np.nanmax(v) for v in se_spread.values())
    worst_mean = max(np.nanmax(v) for v in se_mean.values())
    res = raw.get("residual")
    return {"estimate": float(max(worst, worst_mean)),
            "spread_relative_standard_error": se_spread, "mean_relative_standard_error": se_mean,
            "max_root_residual": float(np.nanmax(res)) if res is not None and np.isfinite(res).any() else None,
            "root_residual_tolerance": RESIDUAL_TOL,
            "sensitivity_finite_difference_max_relative_error": max(
                data["sensitivity"]["finite_difference_max_relative_error"]),
            "how": "largest one-standard-error Monte Carlo error, relative, of the reported spreads (k sigma / "
                   "mean, delta method on the samples) and means of u and q_T (exact and source forms) at every "
                   "psi1 and of the AFC amplitude at omega0 and the peaks; every accepted Newton root has an "
                   "absolute balance residual <= root_residual_tolerance (largest: max_root_residual), far "
                   "below the sampling error"}


def run_scene(scn, settings, out: Path):
    """Runner of ``analyses.montecarlo`` (autobal.pipeline.RUNNERS)."""
    from autobal.adapters import device as device_params  # the runner moves to the front door (autobal/runners.py)
    from autobal.analysis import executor as ex
    from autobal.models.device import design

    if scn.device is None:
        raise ScenarioError("analyses.montecarlo needs a device section")
    with ex.make(scene_executor=getattr(scn, "executor", None)) as exe:
        res = run(design(dp := device_params(scn.device)), settings, exe, scn.title, device=dp)
    files = res.write_tables(out) + res.plot(out)
    return res.to_dict(), files, res.summary()
