"""Error against run time of every solver of a scene (work-precision), with a reference solution
computed by a different method, and a summary of the cheapest setting that reaches a target error.

A :class:`Method` runs one solver at one setting and returns the main outputs; :func:`study`
runs every method over its ladder of settings against a reference and returns a
:class:`WorkPrecision` result (rows of method, setting, error, time; figure; CSV; summary).
The studies of a scene (``autobal accuracy``) are the ``accuracy`` functions of the analyses' modules
(:mod:`autobal.analyses`); the spin-up's is in :mod:`autobal.ocp.workprecision`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca
import numpy as np

from autobal.analysis.numerics import closed_form, ipopt
from autobal.analysis.run import progress
from autobal.analysis.run.fields import Record, TypedResult, declarations, keyed, optional, quantity, record
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.result import new_figure
from autobal.errors import ScenarioError

TARGET = 1e-6  # relative error for the "cheapest setting" summary


@dataclass
class Method:
    """A solver with a ladder of settings; ``run(setting)`` returns the main outputs (1-D array)."""

    name: str
    settings: list
    run: Callable[[object], np.ndarray]
    setting_name: str = "tolerance"


@record
class Trial(Record):
    """One solve of one method at one setting against the reference (a setting that fails: NaN error and time,
    and why)."""

    method: str
    setting: float = quantity("1", "", "the method's setting: a tolerance, a number of steps or intervals")
    setting_name: str | None = optional(kw_only=True)
    error: float = quantity("1", "ε", "max relative error of the main outputs against the reference")
    time_s: float = quantity("s", "t", "run time per solve")
    objective: float | None = optional(kw_only=True)  # the spin-up's objective, re-simulated, in its own unit
    iterations: int | None = quantity("1", "", "IPOPT iterations", optional=True)
    failed: str | None = optional()


@record
class Cheapest(Record):
    """A method's fastest setting reaching the target error (None: none does), and the best error it reached."""

    setting: float | None = quantity("1", "", "the cheapest setting reaching the target error")
    time_s: float | None = quantity("s", "t", "its run time per solve")
    best_error: float | None = quantity("1", "ε", "the smallest error the method reached")


def _modulus():
    return quantity("1/s", "|λ|", "smallest and largest eigenvalue modulus of the linear model")


@record
class Stiffness(Record):
    """Why the time integration is stiff, and the integrator chosen for it."""

    min_abs_eigenvalue: float = _modulus()
    max_abs_eigenvalue: float = _modulus()
    ratio: float = quantity("1", "", "stiffness ratio max |λ| / min |λ|")
    chosen: str
    why: str
    reference_difference_cvodes_vs_radau: float = quantity("1", "", "difference of the two references (CVODES, "
                                                                    "scipy Radau) relative to the state")
    problem: str


@record
class WorkPrecision(TypedResult):
    """Error against run time of every method of one analysis (``autobal accuracy``): a :class:`Trial` per method
    and setting, and per method the cheapest setting reaching :data:`TARGET` (results.json key ``cheapest``)."""

    analysis: str
    reference: str  # how the reference was computed
    outputs: list[str]
    target_error: float = quantity("1", "ε_target", "relative error the cheapest setting has to reach")
    rows: list[Trial]
    cheapest_settings: dict[str, Cheapest] = keyed("cheapest")
    stiffness: Stiffness | None = optional()

    @classmethod
    def of(cls, analysis: str, reference: str, outputs: list[str], rows: list[Trial],
           stiffness: Stiffness | None = None) -> WorkPrecision:
        """The result of ``rows``, with each method's cheapest setting for :data:`TARGET`."""
        return cls(analysis, reference, outputs, TARGET, rows, cheapest(rows, TARGET), stiffness)

    def cheapest(self, target: float = TARGET) -> dict[str, Cheapest]:
        """Per method: the fastest setting whose error is <= target (None if none reaches it)."""
        return cheapest(self.rows, target)

    def summary(self) -> str:
        lines = [f"work-precision of {self.analysis} (reference: {self.reference})",
                 f"  {'method':44s}{'setting for 1e-6':>18s}{'time (s)':>12s}{'best error':>12s}"]
        for m, c in self.cheapest_settings.items():
            s = "not reached" if c.setting is None else f"{c.setting:g}"
            t = "-" if c.time_s is None else f"{c.time_s:.2e}"
            best = "failed" if c.best_error is None else f"{c.best_error:.1e}"
            lines.append(f"  {m:44s}{s:>18s}{t:>12s}{best:>12s}")
        if (st := self.stiffness) is not None:
            lines.append(f"  stiffness: eigenvalue moduli {st.min_abs_eigenvalue:.3g} .. "
                         f"{st.max_abs_eigenvalue:.3g} 1/s (ratio {st.ratio:.2g}); "
                         f"integrator: {st.chosen}: {st.why}")
        return "\n".join(lines)

    @property
    def name(self) -> str:
        return self.analysis

    def tables(self) -> dict[str, dict]:
        columns = {"method": "method", "setting [1]": "setting", "error [1]": "error", "time [s]": "time_s"}
        return {f"workprecision_{self.analysis}.csv": {name: [getattr(r, k) for r in self.rows]
                                                       for name, k in columns.items()}}

    def figures(self) -> dict[str, Figure]:
        fig, ax = new_figure((6.4, 4.6))
        self.draw(ax)
        caption = f"Work-precision of {self.analysis}: error against run time of every solver and setting"
        return {f"workprecision_{self.analysis}.png": Figure(fig, caption)}

    def draw(self, ax) -> None:
        """Error against run time per method, the target error dotted."""
        for m in dict.fromkeys(r.method for r in self.rows):
            rs = [r for r in self.rows if r.method == m]
            err = np.maximum([r.error for r in rs], 1e-17)
            ax.loglog([r.time_s for r in rs], err, "o-", label=m, ms=4)
        ax.axhline(TARGET, color="k", lw=0.7, ls=":")
        ax.set_xlabel("run time per solve (s)")
        ax.set_ylabel("max relative error of " + ", ".join(self.outputs))
        ax.set_title(f"work-precision: {self.analysis}\nreference: {self.reference}", fontsize=8)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)


def cheapest(rows: list[Trial], target: float = TARGET) -> dict[str, Cheapest]:
    """Per method of ``rows``: the fastest setting whose error is <= target (None if none reaches it)."""
    out = {}
    for m in dict.fromkeys(r.method for r in rows):
        ok = [r for r in rows if r.method == m and r.error <= target]
        best = min(ok, key=lambda r: r.time_s) if ok else None
        errors = [r.error for r in rows if r.method == m and np.isfinite(r.error)]
        out[m] = Cheapest(best.setting if best else None, best.time_s if best else None,
                          min(errors) if errors else None)
    return out


#: every number of a work-precision result, from the fields (the spin-up's objective is in its own unit)
WorkPrecision.quantities = QUANTITIES = declarations(WorkPrecision)


def timed(fn, repeats: int = 5):
    """Best-of-``repeats`` wall time of ``fn()`` and its result."""
    best, out = np.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def study(analysis: str, methods: list[Method], reference: np.ndarray, reference_how: str,
          outputs: list[str], repeats: int = 5, floor: float = 1e-300, references: dict | None = None) -> WorkPrecision:
    """Run every method over its settings; error = max |y - reference| / max(|reference|, floor)
    (floor = 1 on O(1) scaled states gives an absolute error there).  ``references`` maps a method
    name to its own reference (a method is never judged against itself)."""
    rows = []
    with progress.steps(sum(len(m.settings) for m in methods), f"accuracy {analysis}", "setting") as bar:
        for m in methods:
            ref = (references or {}).get(m.name, reference)
            scale = np.maximum(np.abs(ref), floor)
            for s in m.settings:
                try:
                    t, y = timed(lambda m=m, s=s: m.run(s), repeats)
                    if not np.all(np.isfinite(y)):
                        raise FloatingPointError("diverged: non-finite result")
                    err = float(np.max(np.abs(np.asarray(y, float) - ref) / scale))
                except Exception as exc:  # a setting that fails is a result: recorded, not hidden
                    t, err = float("nan"), float("nan")
                    rows.append(Trial(m.name, s, error=err, time_s=t, failed=str(exc).strip().splitlines()[-1][:200]))
                    bar.tick(note=f"{m.name}, {s}: failed")
                    continue
                rows.append(Trial(m.name, s, error=err if np.isfinite(err) else float("nan"), time_s=t))
                bar.tick(note=f"{m.name}, {s}")
    return WorkPrecision.of(analysis, reference_how, outputs, rows)


# ---- statics ---------------------------------------------------------------------------------

STATICS_OUTPUTS = ["psi2", "psi3", "u", "psi_e", "psi_cam", "xi"]


def statics_reference(g, psi1: float, dpsi: float, digits: int = 40) -> np.ndarray:
    """Exact solution with the regulator regulating, in ``digits``-digit arithmetic (mpmath): the
    disc root (2.22) (liquid) or (2.144) (gas), then the regulator balances solved in closed form."""
    import mpmath as mp

    mp.mp.dps = digits
    f = mp.mpf
    ae, a3, at, b, chi, sg, p4 = (f(x) for x in (g.alpha_e1, g.alpha_31, g.alpha_TB1, g.b, g.chi, g.sigma, g.psi4))
    psi1, dpsi = f(psi1), f(dpsi)
    c = (b * psi1 - chi) / sg
    p = (1 + ae) * psi1 + ae * dpsi
    if g.medium == "liquid":
        disc = a3**2 + 4 * (1 + ae) * ((1 + ae) * (psi1 - c - p4) + ae * dpsi)
        psi2 = (a3**2 + 2 * (1 + ae) * p - a3 * mp.sqrt(disc)) / (2 * (1 + ae) ** 2)
        psi3 = psi2 - c
        u = mp.cbrt((a3 / at) ** 2 * (psi3 - p4) / c)
    else:
        den = (1 + ae) ** 2 - a3**2
        a = ((1 + ae) * p - a3**2 * c) / den
        psi2 = a - mp.sqrt(a**2 - (p**2 - a3**2 * (c**2 - p4**2)) / den)
        psi3 = psi2 - c
        u = mp.cbrt((a3 / at) ** 2 * (psi3**2 - p4**2) / (psi2**2 - psi3**2))
    r = g.regulator
    psi_e = psi1 + dpsi
    q_e = ae * (psi_e - psi2)
    psi_cam = f(r.psi_in) - q_e / f(r.alpha_in1)
    xi = q_e / (f(r.alpha_B1) * mp.sqrt(psi_cam - psi_e))
    return np.array([float(v) for v in (psi2, psi3, u, psi_e, psi_cam, xi)])


def statics_methods(solver, psi1: float, dpsi: float) -> list[Method]:
    """IPOPT over its tolerance, CasADi's Newton over its tolerance, scipy fsolve (peer, same
    residual function) over xtol, and the source's closed form (2.24)-(2.28) (one setting).
    Every iterative method starts from that closed form, the engineer's first estimate."""
    from scipy.optimize import fsolve  # the peer only: scipy.optimize is not imported by a plain statics run

    sys_ = solver.system
    idx = [sys_.unknowns.index(k) for k in STATICS_OUTPUTS]
    n = len(sys_.unknowns)
    w, p = ca.SX.sym("w", n), ca.SX.sym("p", 2)
    r = sys_.residual(w, p[0], p[1])
    cf = closed_form.for_medium(solver.design.groups, psi1, dpsi)
    cf_out = np.array([float(cf[k]) for k in STATICS_OUTPUTS])
    x0 = np.zeros(n)
    x0[idx] = cf_out
    bounds = {"lbx": np.array(sys_.lower, float), "ubx": np.array(sys_.upper, float), "lbg": 0, "ubg": 0}

    def ipopt_at(tol):
        s = ipopt.nlpsol("wp_ipopt", w, p, sys_.complementarity(w), r, tol=tol, constr_viol_tol=tol,
                         compl_inf_tol=tol)
        return lambda: ipopt.solve(s, x0=x0, p=[psi1, dpsi], **bounds)["x"][idx]

    free = [i for i, k in enumerate(sys_.unknowns) if not k.startswith("r_")]  # no stop reached
    wf = ca.SX.sym("wf", len(free))
    full = ca.vertcat(*[wf[free.index(i)] if i in free else 0 for i in range(n)])
    square = ca.Function("square", [wf, p], [ca.substitute(r, w, full)])
    out_idx = [free.index(i) for i in idx]

    def newton_at(tol):
        rf = ca.rootfinder("wp_newton", "newton", square, {"abstol": tol, "error_on_fail": False})
        return lambda: np.asarray(rf(x0[free], [psi1, dpsi])).ravel()[out_idx]

    res_np = lambda x: np.asarray(square(x, [psi1, dpsi])).ravel()  # noqa: E731

    def fsolve_at(tol):
        return lambda: fsolve(res_np, x0[free], xtol=tol)[out_idx]

    tols = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    built = {}

    def cached(factory):
        def run(tol):
            if (factory, tol) not in built:
                built[(factory, tol)] = factory(tol)
            return built[(factory, tol)]()
        return run

    return [
        Method("IPOPT (bounds, complementarity)", tols, cached(ipopt_at)),
        Method("CasADi Newton rootfinder (exact Jacobian)", tols, cached(newton_at)),
        Method("scipy fsolve (MINPACK hybrd, FD Jacobian)", tols, cached(fsolve_at)),
        Method("closed form (2.24)-(2.28) / (2.145)-(2.147)", [0], lambda _: cf_out, "none"),
    ]


def statics_study(solver, psi1: float, dpsi: float) -> WorkPrecision:
    pt = solver.solve(psi1, dpsi)
    if pt.active:
        raise ScenarioError(f"work-precision of the statics needs a regulated operating point; at psi1 = {psi1:g} "
                         f"the stops {sorted(pt.active)} are reached")
    ref = statics_reference(solver.design.groups, psi1, dpsi)
    return study("statics", statics_methods(solver, psi1, dpsi), ref,
                 "exact ideal-regulator root (2.22)/(2.144) in 40-digit arithmetic (mpmath)", STATICS_OUTPUTS)


# ---- time integration of the device dynamics ------------------------------------------------------

INTEGRATOR_TOLS = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
SCIPY_TOLS = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]


def dynamics_study(model, duration: float, dtau: float, quick: bool = False) -> WorkPrecision:
    """Final state of an axial-force step ``dtau`` over ``duration`` s from the equilibrium, by
    CVODES (BDF, exact Jacobian), IDAS, CasADi's fixed-step RK4 and Radau collocation, and scipy's
    solve_ivp (Radau, BDF, LSODA, same right-hand side and exact Jacobian) over their settings.
    Reference: CVODES at rtol 1e-13, and for the CVODES rows scipy Radau at rtol 1e-12.
    ``quick`` keeps two settings per method (for tests)."""
    from scipy.integrate import solve_ivp

    from autobal.analysis.numerics.linearize import exact

    n = len(model.states)
    x, w = ca.SX.sym("x", n), model.w0 + np.array([0.0, dtau])
    rhs = model.ode(x, w, model.p0)
    f = ca.Function("f", [x], [rhs])
    jac = ca.Function("J", [x], [ca.jacobian(rhs, x)])
    dae = {"x": x, "ode": rhs}

    def casadi_at(plugin, **fixed):
        def make(setting):
            opts = fixed | {"show_eval_warnings": False} | (
                {"number_of_finite_elements": int(setting)} if plugin in ("rk", "collocation")
                            else {"reltol": setting, "abstol": setting * 1e-2, "max_num_steps": 10**6})
            F = ca.integrator(f"wp_{plugin}", plugin, dae, 0.0, duration, opts)
            return lambda: np.asarray(F(x0=model.x0)["xf"]).ravel()
        return make

    def scipy_at(method):
        def make(rtol):
            def run():
                sol = solve_ivp(lambda t, y: np.asarray(f(y)).ravel(), (0.0, duration), model.x0, method=method,
                                rtol=rtol, atol=rtol * 1e-2, jac=lambda t, y: np.asarray(jac(y)))
                if not sol.success:
                    raise RuntimeError(sol.message)
                return sol.y[:, -1]
            return run
        return make

    def cached(make):
        built = {}

        def run(setting):
            if setting not in built:
                built[setting] = make(setting)
            return built[setting]()
        return run

    tols, stols = (INTEGRATOR_TOLS[2::5], SCIPY_TOLS[2::5]) if quick else (INTEGRATOR_TOLS, SCIPY_TOLS)
    steps = [400, 4000] if quick else [400, 4000, 40000]
    coll = [20, 80] if quick else [20, 80, 320]
    methods = [
        Method("CVODES (BDF, exact Jacobian)", tols, cached(casadi_at("cvodes"))),
        Method("IDAS (BDF, exact Jacobian)", tols, cached(casadi_at("idas"))),
        Method("CasADi RK4, fixed step", steps, cached(casadi_at("rk")), "steps"),
        Method("CasADi Radau collocation (degree 3)", coll, cached(casadi_at("collocation",
               collocation_scheme="radau", interpolation_order=3)), "intervals"),
        *[Method(f"scipy solve_ivp {k}", stols, cached(scipy_at(k))) for k in ("Radau", "BDF", "LSODA")],
    ]
    ref = casadi_at("cvodes")(1e-13)()
    ref_radau = scipy_at("Radau")(1e-12)()
    lam = exact(model).poles()
    mod = np.abs(lam[np.abs(lam) > 0])
    h_rk4 = 2.785 / mod.max()  # RK4 stability limit on the negative real axis
    stiffness = Stiffness(
        min_abs_eigenvalue=float(mod.min()), max_abs_eigenvalue=float(mod.max()), ratio=float(mod.max() / mod.min()),
        chosen="CVODES (BDF, exact Jacobian)",
        why=(f"the fastest mode ({mod.max():.2g} 1/s) limits an explicit method to steps below "
             f"{h_rk4:.2g} s, i.e. {duration / h_rk4:.2g} steps over {duration * 1e3:g} ms; a variable-order "
             "implicit BDF with the exact Jacobian steps over it at the accuracy asked"),
        reference_difference_cvodes_vs_radau=float(np.max(np.abs(ref - ref_radau) / np.maximum(np.abs(ref), 1))),
        problem=f"axial-force step dtau = {dtau:g} over {duration * 1e3:g} ms from the static solution, "
                f"{model.form} chamber balances, {n} states")
    wp = study("dynamics", methods, ref, "CVODES at rtol 1e-13 (for the CVODES rows: scipy Radau at rtol 1e-12)",
               ["final state (O(1) scaled)"], repeats=1 if quick else 3, floor=1.0,
               references={"CVODES (BDF, exact Jacobian)": ref_radau})
    return dataclasses.replace(wp, stiffness=stiffness)


# ---- estimation -------------------------------------------------------------------------------------

def estimation_study(load, u, free=("alpha", "tau_max"), values=None) -> WorkPrecision:
    """Least squares in u of Pavlenko (2014), Eq. (4.18) on the data (load, u): IPOPT with the
    Gauss-Newton and with the exact Hessian over its tol, the mapped Gauss-Newton over its step
    tolerance, scipy.optimize.least_squares (trf and lm) over xtol = ftol = gtol.  Reference: the
    40-digit mpmath fit (:func:`~autobal.analysis.numerics.disc_fit.reference_fit`), independent of all of them."""
    from autobal.analysis.numerics import (
        disc_fit,  # scipy.optimize and scipy.stats: only the estimation study needs them
    )

    free, values = tuple(free), values or dict(disc_fit.START)

    def ipopt_at(hessian):
        built = {}

        def run(tol):
            if tol not in built:
                built[tol] = disc_fit.DiscFitter(len(load), "u", free, hessian, tol=tol)
            r = built[tol].fit(load, u, values=values)
            return np.array([r.estimate[k] for k in free])
        return run

    batches = {}

    def batch_at(tol):
        if tol not in batches:
            batches[tol] = disc_fit.DiscFitter(len(load), "u", free, batch={"tol": tol, "block": 1, "max_blocks": 100})
        r = batches[tol].fit_many(load, np.asarray(u)[None, :], values=values)
        if r["fallback"]:
            raise FloatingPointError("Gauss-Newton did not converge (IPOPT fallback)")
        return r["estimate"][0]

    def scipy_at(method):
        def run(tol):
            r = disc_fit.scipy_disc_fit(load, u, residual="u", values=values, free=free, tol=tol, method=method)
            return np.array([r["estimate"][k] for k in free])
        return run

    tols = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    methods = [Method("IPOPT, Gauss-Newton Hessian", tols, ipopt_at("gauss-newton")),
               Method("IPOPT, exact Hessian", tols, ipopt_at("exact")),
               Method("mapped Gauss-Newton (step tolerance)", tols + [1e-14], batch_at),
               Method("scipy least_squares (trf, analytic Jacobian)", tols + [1e-15], scipy_at("trf")),
               Method("scipy least_squares (lm, analytic Jacobian)", tols + [1e-15], scipy_at("lm"))]
    ref = disc_fit.reference_fit(load, u, free, values)
    return study("estimation", methods, ref, "least squares solved in 40-digit arithmetic (mpmath Gauss-Newton)",
                 list(free))
