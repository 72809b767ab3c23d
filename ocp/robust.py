"""Robust spin-up: one speed profile for a set of rotors (the multi-stage idea of do-mpc, Lucia et al. (2013),
with one stage: a control shared by every scenario).

The uncertain rotor (:class:`Uncertainty`): the critical speed within +-``critical_speed_spread`` (the shaft
stiffness c scaled by the square of a factor, so omega_cr = sqrt(c/m) scales by it), the damping chi scaled
by a factor in ``damping_factor`` and, with a liquid block, the full-chamber liquid mass m2* scaled by a factor
in ``liquid_mass_factor``.  The design set is a grid over these ranges; the validation sample draws rotors
uniformly from the same ranges (the damping factor log-uniformly).

The robust OCP (:class:`RobustSolver`): every scenario transcribed by the same method on the same mesh in SI
time (each scenario's dimensionless time tau = Omega0 t differs), the controls u = alpha/alpha_max and the
epigraph level S shared: minimise S subject to delta_i^2 <= S at every collocation point of every scenario.
The speed, the same in SI for every scenario, is kept once: the speed states of the other scenarios are the
first one's scaled by Omega0_1/Omega0_i, so the final-speed condition, the speed cap and the jerk bound appear
once (no duplicated constraints, no degenerate multipliers).

The validation of a profile on many rotors (:func:`fast_peaks`) uses the exponential integrator of the global
search (:func:`autobal.ocp.search.simulate_steps`), checked against CVODES (:func:`cvodes_peaks`).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from autobal.analysis.numerics import ipopt
from autobal.analysis.run import solver_options
from autobal.errors import SolveError
from autobal.models.rotor import RotorParams
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.search import FAST_STEP, FixedFrameModes, simulate_steps, steps_of
from autobal.ocp.simulation import initial_guess, ramp_profile, rate_text, resimulate
from autobal.ocp.solve import coarse_intervals
from autobal.ocp.transcription import DirectCollocation, jerk_regulariser, mesh, structured_derivatives, transcribe


@dataclass(frozen=True)
class Uncertainty:
    """Ranges of the uncertain rotor, as factors on the nominal values.

    Attributes
    ----------
    critical_speed_spread : float
        omega_cr within (1 +- spread) of nominal (the stiffness scaled by the factor squared), 1.
    damping_factor : tuple
        chi within [lo, hi] times nominal, 1.
    liquid_mass_factor : tuple or None
        m2* within [lo, hi] times nominal (a rotor with a liquid block only), 1.
    """

    critical_speed_spread: float = 0.05
    damping_factor: tuple = (0.5, 2.0)
    liquid_mass_factor: tuple | None = None

    def __post_init__(self):
        if not 0 <= self.critical_speed_spread < 1:
            raise ValueError("critical_speed_spread must be in [0, 1)")
        lo, hi = self.damping_factor
        if not 0 < lo <= hi:
            raise ValueError("damping_factor must be 0 < lo <= hi")
        if self.liquid_mass_factor is not None and not 0 <= self.liquid_mass_factor[0] <= self.liquid_mass_factor[1]:
            raise ValueError("liquid_mass_factor must be 0 <= lo <= hi")

    @property
    def dims(self) -> int:
        return 3 if self.liquid_mass_factor is not None else 2

    def grid(self, points: int) -> np.ndarray:
        """The design set: ``points`` values of each factor (the range ends included), (S, 3)
        columns critical-speed, damping and liquid-mass factors; a zero-width range gives one value."""
        s = self.critical_speed_spread
        axes = [np.unique(np.linspace(1 - s, 1 + s, points)),
                np.unique(np.geomspace(*self.damping_factor, points)),
                np.unique(np.linspace(*self.liquid_mass_factor, points)) if self.liquid_mass_factor else [1.0]]
        return np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` rotors drawn from the ranges (uniform; the damping factor log-uniform), (n, 3)."""
        s = self.critical_speed_spread
        lo, hi = self.damping_factor
        liq = self.liquid_mass_factor or (1.0, 1.0)
        return np.column_stack([rng.uniform(1 - s, 1 + s, n), np.exp(rng.uniform(np.log(lo), np.log(hi), n)),
                                rng.uniform(*liq, n)])


def perturbed(params: RotorParams, factors) -> RotorParams:
    """The rotor with the factors (critical speed, damping, liquid mass) applied: c (cr)^2, chi d, m2* l.

    Parameters
    ----------
    params : RotorParams
        The nominal rotor (SI).
    factors : sequence of 3 floats
        Critical-speed, damping and liquid-mass factors (1: nominal).

    Returns
    -------
    RotorParams
        The perturbed rotor (SI).
    """
    return params.scaled(*factors)


def scenario_ocps(ocp: SpinupOcp, factors: np.ndarray) -> list[SpinupOcp]:
    """The spin-up problem of each perturbed rotor (same drive, speeds, deadline and limits): the problem's own
    ``perturbed`` (the Jeffcott rotor's :meth:`autobal.ocp.problem.SpinupOcp.perturbed`, the modal rotor's
    :meth:`autobal.ocp.modal.ModalSpinupOcp.perturbed`)."""
    return [ocp.perturbed(f) for f in factors]


@dataclass(frozen=True)
class Profile:
    """A speed profile in SI: u = alpha/alpha_max on ``n`` equal control intervals of the horizon (then held)."""

    label: str
    u: np.ndarray  # (n,) control intervals of the horizon

    def on(self, ocp: SpinupOcp) -> tuple[np.ndarray, np.ndarray]:
        """(u, h) of the profile on ``ocp``'s mesh (dimensionless interval lengths, settling window appended)."""
        ms = mesh(ocp, self.u.size)
        return np.concatenate([self.u, np.zeros(ms.ns)]), ms.lengths


def cvodes_peaks(ocp: SpinupOcp, factors: np.ndarray, profile: Profile, points: int = 8) -> np.ndarray:
    """Peak of the profile on each perturbed rotor, CVODES at tight tolerance (the reference): delta/e for the
    Jeffcott rotor (:func:`autobal.ocp.simulation.resimulate`), m for the modal rotor (its own
    ``resimulated_peak``)."""
    out = []
    for o in scenario_ocps(ocp, factors):
        u, h = profile.on(o)
        out.append(resimulate(o, u, h, profile.label, points=points).peak_delta if isinstance(o, SpinupOcp)
                   else o.resimulated_peak(u, h, profile.label, points=points))
    return np.array(out)


def fast_peaks(ocp: SpinupOcp, factors: np.ndarray, profiles: list[Profile]) -> np.ndarray:
    """Peak of every profile on every perturbed rotor by a fast integrator (the exponential integrator of the
    Jeffcott rotor's global search, :func:`autobal.ocp.search.simulate_steps`; another model's own
    ``fast_peaks``, e.g. the modal rotor's Runge-Kutta screening, :func:`autobal.ocp.modal_search.screen`), all profiles
    of one rotor at once.

    Parameters
    ----------
    ocp : SpinupOcp
        The nominal problem (SI).
    factors : ndarray, shape (R, 3)
        The rotors (:func:`perturbed`).
    profiles : list of Profile
        The speed profiles (same number of control intervals).

    Returns
    -------
    ndarray, shape (R, P)
        Peaks (delta/e, or m for the modal rotor).
    """
    out = np.empty((len(factors), len(profiles)))
    U = np.array([p.u for p in profiles])
    for i, o in enumerate(scenario_ocps(ocp, factors)):
        if isinstance(o, SpinupOcp):
            steps = np.array([steps_of(o, u, FAST_STEP) for u in U])
            out[i] = simulate_steps(o, steps, FAST_STEP, FixedFrameModes.of(o))
        else:
            out[i] = o.fast_peaks(U)
    return out


@dataclass(frozen=True)
class ValidationTask:
    """One chunk of the validation sample (plain data, picklable for a Dask worker): its rotors are drawn
    from ``SeedSequence(seed, spawn_key=(chunk,))``, so the sample is the same on any executor."""

    ocp: SpinupOcp
    uncertainty: Uncertainty
    profiles: tuple
    seed: int
    chunk: int
    size: int

    def __call__(self) -> tuple[np.ndarray, np.ndarray]:
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(self.chunk,)))
        factors = self.uncertainty.sample(self.size, rng)
        return factors, fast_peaks(self.ocp, factors, list(self.profiles))


def run_task(task: ValidationTask):
    return task()


def validate(ocp: SpinupOcp, uncertainty: Uncertainty, profiles: list[Profile], samples: int, seed: int,
             executor, chunk: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """Peaks of every profile over ``samples`` rotors drawn from the ranges, on ``executor`` in chunks.

    Returns
    -------
    factors : ndarray, shape (samples, 3)
    peaks : ndarray, shape (samples, len(profiles))
        delta/e.
    """
    tasks = [ValidationTask(ocp, uncertainty, tuple(profiles), seed, k, min(chunk, samples - k * chunk))
             for k in range((samples + chunk - 1) // chunk)]
    res = executor.map(run_task, tasks, desc="validation")
    return np.concatenate([r[0] for r in res]), np.concatenate([r[1] for r in res])


def ramp_family(ocp: SpinupOcp, n: int, count: int = 8) -> list[Profile]:
    """Constant ramps from the slowest that reaches omega_final by the deadline to alpha_max (then held)."""
    lo = min(abs(ocp.omega_final - ocp.omega_start) / ocp.horizon, ocp.alpha_max)
    return [Profile(f"ramp {rate_text(a)}", ramp_profile(ocp, n, a)) for a in np.linspace(lo, ocp.alpha_max, count)]


def scenario_nlp(ocp: SpinupOcp, method: DirectCollocation, ref: float) -> tuple:
    """The parts of :class:`RobustSolver` made per scenario: its collocation NLP (MX), the Function of its
    constraints and its structured derivatives (:func:`autobal.ocp.transcription.structured_derivatives`).
    They do not depend on the other scenarios, so a scenario generation makes them once per scenario and
    every NLP of its rounds and starts reuses them (benchmarks/spinup_ocp.md, "Robust study builds").

    Parameters
    ----------
    ocp : SpinupOcp
        The scenario's problem (SI), objective ``peak_deflection``.
    method : DirectCollocation
        The transcription.
    ref : float
        Scale of the epigraph level, (delta/e)^2.

    Returns
    -------
    tuple
        (Nlp, g Function (w) -> g, dict of the ``jac_g`` and ``hess_lag`` Functions).
    """
    if not isinstance(method, DirectCollocation):
        raise ValueError("the robust spin-up OCP is built on direct collocation")
    if ocp.objective != "peak_deflection":
        raise ValueError("the robust spin-up OCP minimises the worst-case peak deflection (peak_deflection)")
    nlp = transcribe(ocp, method, ref, "MX")
    return nlp, ca.Function("g", [nlp.x], [nlp.g]), structured_derivatives(nlp)


class RobustSolver:
    """The multi-scenario NLP: one transcription per scenario, controls and epigraph level shared,
    the speed states kept once (see the module docstring).

    Each scenario's variables are a constant selection of the robust ones, w_i = P_i x (one entry per row:
    a shared control, the level S, the scenario's own states, or the first scenario's speed state scaled by
    Omega0_1/Omega0_i).  The derivatives are the scenarios' structured ones
    (:func:`autobal.ocp.transcription.structured_derivatives`: the interval Function's SX derivatives mapped
    over the intervals) carried through P_i: dg_i/dx = (dg_i/dw_i) P_i and the Hessian sum_i P_i' H_i P_i, so
    the construction hardly grows with the intervals or the scenarios.  ``parts``: the scenarios'
    :func:`scenario_nlp` when already made (default: made here)."""

    def __init__(self, ocps: list[SpinupOcp], method: DirectCollocation, ref: float, options: dict | None = None,
                 parts: list | None = None):
        t0 = time.perf_counter()
        parts = parts or [scenario_nlp(o, method, ref) for o in ocps]
        self.ocps, self.method = ocps, method
        self.nlps = [nlp for nlp, _, _ in parts]
        first = self.nlps[0]
        K = first.index["u"].size
        n = first.mesh.n
        sp = ocps[0].speed_index
        nu_idx = np.concatenate([first.index["X"][:, sp], first.index["Xc"][..., sp].ravel()])
        lbx, ubx = [first.lbx[first.index["u"]], [0.0]], [first.ubx[first.index["u"]], [np.inf]]
        cols, scales, keeps, offset = [], [], [], K + 1
        for i, (o, nlp) in enumerate(zip(ocps, self.nlps, strict=True)):
            N = nlp.x.numel()
            own = np.ones(N, bool)
            own[nlp.index["u"]] = False
            own[nlp.index["v"]] = False
            col, sc = np.empty(N, int), np.ones(N)
            col[nlp.index["u"]] = np.arange(K)
            col[nlp.index["v"][0]] = K
            if i > 0:  # the speed: the first scenario's, scaled to this one's dimensionless time
                own[nu_idx] = False
                col[nu_idx], sc[nu_idx] = cols[0][nu_idx], ocps[0].Om / o.Om
            col[own] = offset + np.arange(own.sum())
            offset += int(own.sum())
            lbx.append(nlp.lbx[own])
            ubx.append(nlp.ubx[own])
            keep = np.ones(nlp.g.numel(), bool)
            if i > 0:  # rows that repeat the first scenario's: speed dynamics, final speed, jerk bound
                for name, rows in nlp.blocks:
                    if name == "dynamics":
                        keep[rows[np.arange(rows.size) % o.nx == sp]] = False
                    elif name.startswith(("final speed", "jerk limit")):
                        keep[rows] = False
            cols.append(col)
            scales.append(sc)
            keeps.append(np.flatnonzero(keep))
        x, p = ca.MX.sym("x", offset), ca.MX.sym("p", 0)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", sum(r.size for r in keeps))
        self.P = [ca.DM.triplet(np.arange(c.size).tolist(), c.tolist(), s.tolist(), c.size, offset)
                  for c, s in zip(cols, scales, strict=True)]
        g, gj, jac, hess, lbg, ubg, at = [], [], [], 0, [], [], 0
        for (nlp, gf, der), P, rows in zip(parts, self.P, keeps, strict=True):
            w = ca.mtimes(P, x)
            g.append(gf(w)[rows.tolist()])
            gi, Ji = der["jac_g"](w, p)
            gj.append(gi[rows.tolist()])
            jac.append(ca.mtimes(Ji[rows.tolist(), :], P))
            Q = ca.DM.triplet(rows.tolist(), list(range(rows.size)), [1.0] * rows.size, nlp.g.numel(), rows.size)
            Hu = der["hess_lag"](w, p, 0.0, ca.mtimes(Q, lam_g[at:at + rows.size]))  # upper triangle in w
            hess = hess + ca.mtimes([P.T, Hu + ca.tril(Hu.T, False), P])
            lbg.append(nlp.lbg[rows])
            ubg.append(nlp.ubg[rows])
            at += rows.size
        f = x[K] + (jerk_regulariser(ocps[0], x[1:n] - x[:n - 1]) if n > 1 else 0)
        hess = ca.triu(hess) + ca.triu(ca.hessian(lam_f * f, x)[0])
        derivatives = {"jac_g": ca.Function("robust_jac_g", [x, p], [ca.vertcat(*gj), ca.vertcat(*jac)]),
                       "hess_lag": ca.Function("robust_hess_l", [x, p, lam_f, lam_g], [hess])}
        self.x, self.f, self.derivatives, self.K, self.n = x, f, derivatives, K, n
        self.lbx, self.ubx = np.concatenate(lbx), np.concatenate(ubx)
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        self.solver = ipopt.nlpsol("robust_spinup", x, p, f, ca.vertcat(*g), **derivatives,
                                   **(solver_options.get("spinup") | (options or {})))
        self.ref = ref
        self.build_time_s = time.perf_counter() - t0

    @property
    def variables(self) -> int:
        return self.x.numel()

    def guess(self, u: np.ndarray) -> np.ndarray:
        """All variables from the control profile u (n control intervals): each scenario simulated."""
        x0 = [np.concatenate([u, np.zeros(self.K - u.size)]), [0.0]]
        for i, (o, nlp) in enumerate(zip(self.ocps, self.nlps, strict=True)):
            w0 = initial_guess(o, nlp, u)
            x0[1][0] = max(x0[1][0], w0[nlp.index["v"][0]])
            own = np.ones(w0.size, bool)
            own[nlp.index["u"]] = False
            own[nlp.index["v"]] = False
            if i > 0:
                sp = o.speed_index
                own[np.concatenate([nlp.index["X"][:, sp], nlp.index["Xc"][..., sp].ravel()])] = False
            x0.append(w0[own])
        return np.concatenate(x0)

    def solve(self, u: np.ndarray) -> dict:
        """One IPOPT solve from the control profile u; returns the profile, the worst-case collocation peak
        (delta/e), status, iterations and the solve time (s).  Raises SolveError when IPOPT fails."""
        x0 = self.guess(u)
        t0 = time.perf_counter()
        r = ipopt.solve(self.solver, x0=x0, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        dt = time.perf_counter() - t0
        if not r["success"]:
            raise SolveError(f"robust spin-up OCP not solved: {r['status']} after {r['iterations']} iterations "
                             f"({len(self.ocps)} scenarios, {self.method.label})", r["status"],
                             {"alpha_rad_s2": list(r["x"][:self.n] * self.ocps[0].alpha_max)})
        ws = [np.asarray(P @ ca.DM(r["x"])).ravel() for P in self.P]
        peaks = [float(np.sqrt(np.max(o.epigraph2(w[nlp.index["Xc"]])))) * o.epigraph_unit
                 for o, w, nlp in zip(self.ocps, ws, self.nlps, strict=True)]
        return {"u": np.asarray(r["x"][:self.n]), "collocation_peaks": np.array(peaks), "status": r["status"],
                "iterations": r["iterations"], "solve_time_s": dt}


@dataclass
class RobustOptimum:
    """The robust profile and how it was found (scenario generation over the design set)."""

    profile: Profile
    design_peaks: np.ndarray  # (S,) delta/e of the robust profile on the design set, fast integrator
    active: list  # indices of the design scenarios in the final NLP
    rounds: list  # one dict per NLP solve
    build_time_s: float
    solve_time_s: float
    collocation_worst: float  # the NLP's worst-case peak, delta/e
    others: list = dataclasses.field(default_factory=list)  # the other starts' optima, best first

    @property
    def worst(self) -> float:
        """Worst design peak (fast integrator), delta/e."""
        return float(self.design_peaks.max())


def optimize_robust(ocp: SpinupOcp, factors: np.ndarray, method: DirectCollocation, starts: list[Profile],
                    ref: float, options: dict | None = None, tol: float = 1e-3, max_rounds: int = 8,
                    active: list | None = None) -> RobustOptimum:
    """Minimise the worst-case peak over the design set ``factors`` by scenario generation: the NLP holds the
    scenarios that bind (first the worst one of the start); after each solve every design scenario is
    simulated (:func:`fast_peaks`) and those above the NLP's worst case by more than ``tol`` (relative) join
    it, until none does.  The optimum of the final NLP is then the optimum over the whole design set.  Each
    design scenario is transcribed once (:func:`scenario_nlp`), every NLP that holds it reuses its parts, and
    an active set met again (another start's round) reuses its NLP.

    Parameters
    ----------
    ocp : SpinupOcp
        The nominal problem (SI), objective ``peak_deflection``.
    factors : ndarray, shape (S, 3)
        The design set (:meth:`Uncertainty.grid`).
    method : DirectCollocation
        The transcription (the same mesh for every scenario).
    starts : list of Profile
        Initial profiles; the best robust optimum (worst case over the design set) is kept, the other
        starts' optima in its ``others`` (best first).
    ref : float
        Scale of the epigraph level, (delta/e)^2.
    options : dict, optional
        IPOPT options.
    tol : float
        Relative excess over the NLP's worst case that adds a scenario.
    max_rounds : int
        Solves per start at most.
    active : list of int, optional
        The scenarios to start with (default: the worst one of each start).

    Returns
    -------
    RobustOptimum
        Peaks in delta/e, times in s.
    """
    ocps = scenario_ocps(ocp, factors)
    found, rounds, build, solve_t, error = [], [], 0.0, 0.0, None
    made, solvers = {}, {}  # design index -> its scenario_nlp; active list -> its NLP: each made once
    for start in starts:
        u = start.u
        peaks = fast_peaks(ocp, factors, [start])[:, 0]
        act = list(active) if active else [int(np.argmax(peaks))]
        for _ in range(max_rounds):
            t0 = time.perf_counter()
            if tuple(act) not in solvers:
                made |= {i: scenario_nlp(ocps[i], method, ref) for i in act if i not in made}
                solvers[tuple(act)] = RobustSolver([ocps[i] for i in act], method, ref, options,
                                                   [made[i] for i in act])
            solver = solvers[tuple(act)]
            t_build = time.perf_counter() - t0
            build += t_build
            try:
                r = solver.solve(u)
            except SolveError as exc:
                error = exc
                rounds.append({"start": start.label, "scenarios": len(act), "status": exc.status})
                break
            solve_t += r["solve_time_s"]
            u = r["u"]
            peaks = fast_peaks(ocp, factors, [Profile("robust", u)])[:, 0]
            worst_active = peaks[act].max()
            add = [i for i in np.argsort(-peaks) if i not in act and peaks[i] > worst_active * (1 + tol)][:2]
            rounds.append({"start": start.label, "intervals": method.intervals, "scenarios": len(act),
                           "active": list(act), "status": r["status"],
                           "iterations": r["iterations"], "solve_time_s": r["solve_time_s"],
                           "build_time_s": t_build, "worst_design_peak_over_e": float(peaks.max()),
                           "collocation_worst_over_e": float(r["collocation_peaks"].max())})
            if not add:
                found.append(RobustOptimum(Profile("robust optimum", u), peaks, list(act), [], 0.0, 0.0,
                                           float(r["collocation_peaks"].max())))
                break
            act += [int(i) for i in add]
    if not found:
        raise error or SolveError("robust spin-up OCP: scenario generation did not settle within "
                                  f"{max_rounds} solves", "scenario_generation", {"rounds": rounds})
    found.sort(key=lambda o: o.worst)  # stable: on a tie the earlier start
    best = found[0]
    best.build_time_s, best.solve_time_s, best.rounds, best.others = build, solve_t, rounds, found[1:]
    return best


# coarse optima refined on the fine mesh.  The coarse ranking need not predict the fine one (it did not for
# some starts, docs/dev/spinup_robust.md, "Build and solve"); on the shipped scene a second refinement
# never won and cost 14 s more of IPOPT, so one
REFINED = 1


def optimize_robust_refined(ocp: SpinupOcp, factors: np.ndarray, method: DirectCollocation, starts: list[Profile],
                            ref: float, options: dict | None = None) -> RobustOptimum:
    """:func:`optimize_robust` by mesh continuation: every start and the scenario generation on N / 2^k
    intervals (:func:`autobal.ocp.solve.coarse_intervals`), then the REFINED best coarse optima (their worst design
    peaks more than 1e-4 apart: distinct optima) each refined on N intervals with the union of their active
    scenarios (more join if a fine profile needs them); the best fine optimum is kept.  Arguments as there."""
    n, nc = method.intervals, coarse_intervals(method.intervals)
    if nc == n:
        return optimize_robust(ocp, factors, method, starts, ref, options)
    r = n // nc
    coarse = optimize_robust(ocp, factors, dataclasses.replace(method, intervals=nc),
                             [Profile(p.label, p.u.reshape(nc, r).mean(axis=1)) for p in starts], ref, options)
    picks = []
    for o in [coarse, *coarse.others]:
        if len(picks) < REFINED and all(abs(o.worst - q.worst) > 1e-4 * q.worst for q in picks):
            picks.append(o)
    active = sorted(set().union(*(o.active for o in picks)))
    fine = optimize_robust(ocp, factors, method, [Profile(f"coarse robust optimum {k + 1} ({o.worst:.4f} e)",
                                                          np.repeat(o.profile.u, r)) for k, o in enumerate(picks)],
                           ref, options, active=active)
    fine.rounds = coarse.rounds + fine.rounds
    fine.build_time_s += coarse.build_time_s
    fine.solve_time_s += coarse.solve_time_s
    return fine
