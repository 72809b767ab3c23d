"""The design study: solve the design NLP (analysis/numerics/design.py), certify it, and report a DesignResult.

Certification: eigenvalues of the ordinary statics + exact linearisation at every operating point,
a random search over the same variables and a local one in a box of +-0.5 % of each range about
the optimum (no feasible sample may beat the optimum by more than 0.5 %), the active constraints
with their multipliers, and the spectral abscissa over the operating range before and after.
"""

from __future__ import annotations

import dataclasses
import math
import re
import textwrap

import numpy as np
import scipy.linalg
from matplotlib.ticker import NullFormatter

from autobal.analysis.numerics.design import UNITS, DesignProblem, Evaluation, Spec, apply, variable_key
from autobal.analysis.numerics.frequency import MODEL_LABELS
from autobal.analysis.numerics.linearize import Setup, finite_difference, jacobians, operator
from autobal.analysis.numerics.stability import PARAMETERS, pencil
from autobal.analysis.run import solver_options
from autobal.analysis.run.fields import Record, TypedResult, declarations, explained, record, shared, unsaved
from autobal.analysis.run.fields import quantity as field_quantity
from autobal.analysis.run.figures import Figure, record_axis
from autobal.analysis.run.quantities import Quantity, is_number, significant
from autobal.analysis.run.result import new_figure
from autobal.errors import SolveError
from autobal.models.device import DeviceParams

CERTIFY_TOL = 0.005  # a sampled feasible design may not beat the optimum by more than this (relative)
ACTIVE_MARGIN = 1e-6  # a decay-rate constraint is active where -max Re lambda <= alpha (1 + this) + this
LOCAL_RADIUS = 0.005  # half-width of the local search box about the optimum, fraction of each variable's range


SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def si_unit(key: str) -> str:
    """The SI unit of a design variable as results.json writes units ("m^3"; "" for a group)."""
    return UNITS[key].replace("**", "^")


def quantity(key: str, value: float) -> str:
    """A design value at full precision with its SI unit, e.g. "4.7e-05 m^3" (what ``--set`` reads)."""
    return f"{value:.10g} {si_unit(key)}".strip()


def variable(path: str) -> Quantity | None:
    """The declaration of the design variable at a scene path (None: not a design variable): a dynamic parameter's
    (stability.PARAMETERS), else its SI unit (analysis/numerics/design.py UNITS) shown in the default display unit of
    its kind (mm, MPa: analysis/run/kinds.py), an area in cm²."""
    key = variable_key(path)
    if key is None:
        return None
    name = path.rsplit(".", 1)[-1]
    if path.startswith("device.dynamics.") and name in PARAMETERS:
        return dataclasses.replace(PARAMETERS[name], key=path)
    unit = si_unit(key) or "1"
    return Quantity(path, unit, key, f"design variable {path.removeprefix('device.')}", "cm²" if unit == "m^2" else "")


def _values(path: str, block: dict | None = None) -> Quantity | None:
    """The declaration of ``optimum.values_si.<scene path>`` and ``nominal.values_si.<scene path>``."""
    m = re.fullmatch(r"(optimum|nominal)\.values_si\.(.+)", path)
    q = variable(m.group(2)) if m else None
    return None if q is None else dataclasses.replace(q, key=path)


_PSI = "at each operating point ψ1"
_P14 = "Pavlenko (2014)"


_points = shared("1", "ψ1", "operating discharge ratios p1/p_B")


_objective = shared("1", "J", "objective (over the nominal design's)")


_abscissa = shared("1/s", "max Re λ", "spectral abscissa (designed-for model)")


_samples = shared("1", "", "designs sampled / feasible in the certification")


@record
class Design(Record):
    """One evaluated design (:func:`block`): its parameters by scene path, objective, leakage and, by operating
    point ψ1 (keys "0.5", "1"), its decay rate, spectral abscissa, stiffness, face gap and valve travel."""

    #: scene path -> value with its SI unit, at full precision (what ``--set`` reads)
    parameters: dict
    #: scene path -> SI value (declared by the scene path's variable: :func:`variable`)
    values_si: dict
    objective: float = _objective()
    leakage: float = field_quantity("m^3/s", "Q_e", "barrier leakage")
    feasible: bool
    infeasible_reason: str
    #: by operating point: keys are the discharge ratios ψ1
    margin: dict
    spectral_abscissa: dict
    stiffness: dict
    face_gap: dict
    valve_travel: dict


@record
class Nominal(Design):
    """The starting design (the scene's)."""

    leakage: float = field_quantity("m^3/s", "Q_e", "barrier leakage of the nominal design", headline=2)


@record
class Optimum(Design):
    """The optimum."""

    objective: float = field_quantity("1", "J/J_nom", "objective of the optimum over the nominal design's", headline=4)
    leakage: float = field_quantity("m^3/s", "Q_e", "barrier leakage of the optimum", headline=3)


@record(kw_only=True)
class Active(Record):
    """A constraint active at the optimum, with its multiplier."""

    constraint: str
    multiplier: float = field_quantity("1", "λ", "multiplier of an active constraint (the objective is O(1))")
    value: float = field_quantity("1", "", "the NLP's (scaled) value of an active constraint row or variable")
    decay_rate: float | None = field_quantity("1/s", "−max Re λ", "decay rate at an active decay-rate constraint",
                                        optional=True)


@record
class Certification(Record):
    """The optimum's certificate: eigenvalues at every operating point, a random and a local search."""

    eigenvalues_ok: bool
    samples: int = _samples()
    feasible_samples: int = _samples()
    best_sample: float = _objective()
    tolerance: float = field_quantity("1", "", "relative amount a sample may beat the optimum by")
    local_samples: int = _samples()
    local_radius: float = field_quantity("1", "", "half-width of the local search box, fraction of each range")
    feasible_local_samples: int = _samples()
    best_local_sample: float = _objective()
    beaten: bool


@record
class ModelCheck(Record):
    """The spectral abscissa of the nominal design and of the optimum under a model it was not designed for, by
    operating point (keys are the discharge ratios ψ1)."""

    model: str
    nominal: dict
    optimum: dict


@record
class AbscissaSweep(Record):
    """The spectral abscissa of both designs over the operating range."""

    psi1: np.ndarray = _points()
    nominal: np.ndarray = _abscissa()
    optimum: np.ndarray = _abscissa()


@record
class DesignResult(TypedResult):
    """Result of ``analyses.design``: the optimum, the starting design, certification and IPOPT's history."""

    form: str
    decay_rate: float = field_quantity("1/s", "α", "required decay rate (every pole Re λ ≤ −α)", headline=1)
    points: list[float] = _points()
    status: str
    iterations: int = field_quantity("1", "", "IPOPT iterations")
    barrier: str
    optimum: Optimum
    nominal: Nominal
    active: list[Active]
    certification: Certification
    #: spectral abscissa (1/s) of the same designs in the other chamber form
    other_model: ModelCheck
    #: the same for the source's program model (hand constants, closed-form point)
    program_model: ModelCheck
    abscissa_sweep: AbscissaSweep
    accuracy: dict
    #: IPOPT's iterates (obj, inf_pr, inf_du) for the convergence figure, and the scene's title: not in results.json
    history: dict = unsaved(default_factory=dict)
    title: str = unsaved("")
    name = "design"

    @property
    def parameters(self) -> dict:
        """Optimum design values by scene path, as strings with SI units."""
        return self.optimum.parameters

    @property
    def objective(self) -> float:
        """Objective at the optimum (dimensionless: Q_e / Q_e,nominal by default)."""
        return self.optimum.objective

    @property
    def margin(self) -> dict:
        """Decay rate -max Re lambda at each operating point of the optimum, 1/s."""
        return self.optimum.margin

    def verdict(self, which: str = "optimum") -> tuple[bool, str]:
        """The verdict on the ``which`` design under the model it was designed for: stable or not, its smallest
        decay rate over the operating points and the margin to the required α (ok: α met at every point, IPOPT
        converged)."""
        alpha, eta = self.decay_rate, QUANTITIES.find("decay_rate")
        margins = {p: v for p, v in getattr(self, which).margin.items() if not p.endswith("_status")}
        values = [v for v in margins.values() if is_number(v) and math.isfinite(v)]
        missing = [p for p, v in margins.items() if not (is_number(v) and math.isfinite(v))]
        model = MODEL_LABELS[{"chain": "nonlinear_chain"}.get(self.form, "nonlinear")]
        if not values:
            return False, f"{which} design, {model}: no operating point has a static solution off the stops"
        worst = min(values)
        met = worst >= alpha * (1 - 1e-6) and not missing
        where = ("at every operating point" if not missing else f"at {len(values)} of {len(margins)} operating "
                 f"points (none at ψ1 = {', '.join(missing)}: no static solution off the stops there)")
        state = (f"stable, decay rate ≥ {eta.text(worst)}" if worst > 0 else
                 f"UNSTABLE, disturbances grow at up to {eta.text(-worst)}")
        margin = (f"{eta.text(worst - alpha)} above the required {eta.text(alpha)}" if met else
                  f"the required {eta.text(alpha)} is NOT met")
        words = f"{which} design, {model}: {state} {where}, {margin}"
        if which == "optimum" and self.status not in SUCCESS:
            return False, f"{words}; IPOPT did NOT converge ({self.status})"
        return met, words

    def source_models(self) -> list[tuple[str, str]]:
        """(model, sentence) per model the design is checked under but not designed for (the other chamber form,
        the source's program model): its spectral abscissa of the optimum and of the starting design, and whether
        the optimum is unstable, and more so than the starting design, under it."""
        out = []
        for block in (self.other_model, self.program_model):
            model = {"chain": "nonlinear_chain", "energy": "nonlinear"}.get(block.model, block.model)
            opt, nom = ([v for k, v in values.items() if not k.endswith("_status") and is_number(v)
                         and math.isfinite(v)] for values in (block.optimum, block.nominal))
            if not model or not opt:
                continue
            words = (f"{MODEL_LABELS.get(model, model)}: spectral abscissa max Re λ of the optimum {_signed(min(opt))} "
                     f"to {_signed(max(opt))} 1/s over the operating points"
                     + (f" (nominal design {_signed(min(nom))} to {_signed(max(nom))} 1/s)" if nom else ""))
            if min(opt) > 0:
                words += ": UNSTABLE under this model" + ("" if not nom else ", MORE unstable than the nominal "
                                                           "design" if max(opt) > max(nom) else ", less unstable "
                                                           "than the nominal design")
            out.append((model, words))
        return out

    def summary(self) -> str:
        o, n, c = self.optimum, self.nominal, self.certification
        lines = [f"design: {self.verdict()[1]}", f"  IPOPT {self.status}, {self.iterations} iterations",
                 *QUANTITIES.lines(self.to_dict()),
                 f"  nominal design: {self.verdict('nominal')[1].removeprefix('nominal design, ')}",
                 "  decay rate −max Re λ (nominal design → optimum), 1/s: " + "; ".join(
                     f"ψ1 = {p}: {significant(n.margin.get(p))} → {significant(a)}"
                     for p, a in o.margin.items() if not p.endswith("_status")),
                 "  design variables (nominal design → optimum; results.json optimum.parameters in full):"]
        width = max((len(p) for p in o.values_si), default=0)
        for path, v in o.values_si.items():
            q = variable(path)
            lines.append(f"    {path:<{width}s}  {q.symbol:<7s} {q.text(n.values_si[path])} → {q.text(v)}")
        lines.append("  active constraints: " + (", ".join(a.constraint for a in self.active) or "none"))
        lines.append(f"  certified: eigenvalues {'confirm' if c.eigenvalues_ok else 'do NOT confirm'} the optimum; "
                     f"random search {c.feasible_samples} of {c.samples} samples feasible, best "
                     f"{significant(c.best_sample)}; local search {c.feasible_local_samples} of "
                     f"{c.local_samples} feasible, best {significant(c.best_local_sample)} (optimum "
                     f"{significant(o.objective)})" + ("; a sample BEATS the optimum" if c.beaten else ""))
        lines.append("  validation against the source (its models do not judge the design):")
        lines += [f"    {words}" for _, words in self.source_models()]
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        s = self.abscissa_sweep
        return {"design_abscissa.csv": QUANTITIES.columns({"psi1": s.psi1, "nominal": s.nominal,
                                                           "optimum": s.optimum}, "abscissa_sweep")}

    def draw(self, ax) -> None:
        s = self.abscissa_sweep
        ax.plot(s.psi1, s.nominal, "o-", label="nominal")
        ax.plot(s.psi1, s.optimum, "s-", label="optimum")
        ax.axhline(-self.decay_rate, color="k", ls="--", lw=0.8, label=r"$-\alpha$")
        ax.set_xlabel(r"discharge ratio $\psi_1$")
        ax.set_ylabel(r"spectral abscissa max Re $\lambda$, 1/s")
        record_axis(ax, "y", "1/s", "1/s")
        ax.legend()

    def figures(self) -> dict[str, Figure]:
        fig1, ax = new_figure()
        self.draw(ax)
        fig2, ax2 = new_figure((8.0, 4.4))
        o, n = self.optimum.values_si, self.nominal.values_si
        names = list(o)
        ratio = np.array([o[k] / n[k] if n[k] else math.nan for k in names])
        ax2.barh(range(len(names)), ratio - 1.0, left=1.0, color=np.where(ratio >= 1, "C0", "C1"))
        ax2.set_xscale("log")
        finite = ratio[np.isfinite(ratio) & (ratio > 0)]
        lo, hi = min(finite.min(initial=1.0), 1.0) / 1.6, max(finite.max(initial=1.0), 1.0) * 1.6
        ax2.set_xlim(lo, hi)
        ticks = [t for e in range(-4, 5) for t in (10.0 ** e, 2 * 10.0 ** e, 5 * 10.0 ** e) if lo <= t <= hi]
        ax2.set_xticks(ticks, [f"{t:g}" for t in ticks])  # major ticks only: the minor labels overlapped
        ax2.xaxis.set_minor_formatter(NullFormatter())
        ax2.set_yticks(range(len(names)), [".".join(k.split(".")[-2:]) for k in names], fontsize=8)
        ax2.axvline(1.0, color="k", lw=0.8)
        values = ax2.twinx()  # the values themselves, in display units, as the right-hand tick labels
        values.set_ylim(ax2.get_ylim())
        values.set_yticks(range(len(names)), [f"{variable(k).text(n[k])} → {variable(k).text(o[k])}" for k in names],
                          fontsize=7)
        values.set_ylabel("nominal → optimum", fontsize=8)
        for i in np.flatnonzero(~np.isfinite(ratio) | (ratio <= 0)):  # from or to zero: no ratio to draw
            ax2.text(1.0, i, "  from 0" if not n[names[i]] else "  to 0", va="center", fontsize=7, color="0.3")
        ax2.set_xlabel("optimum / nominal (log scale)")
        fig3, ax3 = new_figure()
        h = self.history
        if h.get("obj"):
            ax3.semilogy(np.abs(h["obj"]), label="|objective|")
            ax3.semilogy(np.maximum(h["inf_pr"], 1e-18), label="primal infeasibility")
            ax3.semilogy(np.maximum(h["inf_du"], 1e-18), label="dual infeasibility")
            ax3.legend()
        ax3.set_xlabel("IPOPT iteration")
        model = {"energy": "energy-consistent", "chain": "chain (printed)"}[self.form]
        what = {fig1: f"spectral abscissa over the operating range ({model} model)",
                fig2: "design variables, optimum against the nominal design",
                fig3: f"IPOPT convergence ({self.status}, {self.iterations} iterations, {self.barrier} barrier)"}
        for fig, sub in what.items():
            fig.suptitle(textwrap.fill(self.title, 80) + "\n" + sub if self.title else sub, fontsize=9)
        return {"design_abscissa.png": Figure(fig1, "Spectral abscissa max Re λ against the discharge ratio, nominal "
                                                    "and optimum designs, with the required −α"),
                "design_parameters.png": Figure(fig2, "Design parameters: optimum relative to nominal"),
                "design_convergence.png": Figure(fig3, "IPOPT convergence of the design NLP")}


DesignResult.quantities = QUANTITIES = declarations(
    DesignResult,
    Quantity("optimum.margin.** nominal.margin.**", "1/s", "−max Re λ", f"decay rate {_PSI}"),
    Quantity("optimum.spectral_abscissa.** nominal.spectral_abscissa.**", "1/s", "max Re λ",
             "spectral abscissa (designed-for model)"),
    Quantity("other_model.nominal.** other_model.optimum.**", "1/s", "max Re λ",
             "spectral abscissa under the other chamber form (validation)"),
    Quantity("program_model.nominal.** program_model.optimum.**", "1/s", "max Re λ",
             "spectral abscissa under the source's program model (validation)", source=f"{_P14}, App. A/B"),
    Quantity("optimum.stiffness.** nominal.stiffness.**", "1", "κ_s", f"static stiffness of the balancing force {_PSI}",
             source=f"{_P14}, Eq. (2.33)"),
    Quantity("optimum.face_gap.** nominal.face_gap.**", "m", "z0", f"face gap {_PSI}", "µm"),
    Quantity("optimum.valve_travel.** nominal.valve_travel.**", "1", "x0/x_max",
             f"valve opening over its travel {_PSI}"),
    resolve=_values,
)


def _signed(v: float) -> str:
    return ("+" if v > 0 else "") + significant(v)


def block(problem: DesignProblem, ev: Evaluation, kind: type[Design]) -> Design:
    """One evaluated design as its record ``kind`` (:class:`Nominal`, :class:`Optimum`): parameters by scene path,
    objective, margins."""
    paths = {v.key: v.path for v in problem.spec.variables}
    return kind(
        parameters={paths[k]: quantity(k, v) for k, v in ev.values.items()},
        values_si={paths[k]: v for k, v in ev.values.items()},
        objective=ev.objective, leakage=ev.leakage, feasible=ev.feasible, infeasible_reason=ev.reason,
        margin={f"{p:g}": -a for p, a in ev.abscissa.items()},
        spectral_abscissa={f"{p:g}": a for p, a in ev.abscissa.items()},
        stiffness={f"{p:g}": k for p, k in ev.stiffness.items()},
        face_gap={f"{p:g}": z for p, z in ev.gap.items()},
        valve_travel={f"{p:g}": x for p, x in ev.valve.items()})


def accuracy(problem: DesignProblem, out: dict, opt: Evaluation, best: float, samples: int) -> dict:
    """Error estimate of the design result.

    * ``abscissa``: at each operating point of the optimum, the spectral abscissa (1/s) from the
      eigenvalues (QR) of the exact Jacobian, from the generalized eigenvalues (QZ) of the pencil of the
      model's implicit rows (independent of the explicit form) and from a central finite-difference
      Jacobian (independent of CasADi's derivatives), and their relative differences;
    * ``constraints``: the largest violation of the NLP's scaled constraint rows and variable bounds at
      IPOPT's solution, and the tolerances it was solved to;
    * ``objective``: the NLP's objective against the ordinary path's (statics solver), relative;
    * ``search``: the random search's resolution, samples^(-1/d) of each variable's range (d variables).

    Parameters
    ----------
    problem : DesignProblem
    out : dict
        :meth:`DesignProblem.solve`'s result.
    opt : Evaluation
        The optimum by the ordinary path.
    best : float
        Objective of the best feasible sample (NaN: none).
    samples : int

    Returns
    -------
    dict
        With ``estimate`` (largest relative difference of the spectral abscissa between QR and QZ)
        and ``how``.
    """
    dev = apply(problem.device, out["values"])
    per = {}
    for p in problem.points:
        try:
            model = Setup(dev, p).nonlinear(problem.spec.form)
        except SolveError:
            continue
        qr = np.linalg.eigvals(np.array(jacobians(model)(model.x0, model.w0, model.p0)[0])).real.max()
        E, Ad = pencil(*operator(model)[:3])
        mu = scipy.linalg.eig(Ad, E, right=False)
        qz = mu[np.isfinite(mu)].real.max()
        fd = np.linalg.eigvals(finite_difference(model)).real.max()
        per[f"{p:g}"] = {"qr": float(qr), "qz": float(qz), "finite_difference": float(fd),
                         "relative_difference_qz": float(abs(qr - qz) / abs(qr)),
                         "relative_difference_finite_difference": float(abs(qr - fd) / abs(qr))}
    res = out["res"]
    lbx, ubx = problem.bounds()
    g, x = res["g"], res["x"]
    viol_g = float(np.max(np.maximum(problem.lbg - g, 0) + np.maximum(g - problem.ubg, 0), initial=0.0))
    viol_x = float(np.max(np.maximum(lbx - x, 0) + np.maximum(x - ubx, 0), initial=0.0))
    f_nlp = float(problem.objective_fn(x))
    d = len(problem.keys)
    est = max((v["relative_difference_qz"] for v in per.values()), default=math.nan)
    return {
        "abscissa": per,
        "constraints": {"max_scaled_violation": viol_g, "max_bound_violation": viol_x,
                        "ipopt_tol": solver_options.defaults["design.tol"],
                        "ipopt_constr_viol_tol": solver_options.defaults["design.constr_viol_tol"]},
        "objective": {"nlp": f_nlp, "statics_path": opt.objective,
                      "relative_difference": float(abs(f_nlp - opt.objective) / abs(opt.objective))},
        "search": {"samples": samples, "variables": d,
                   "resolution": float(samples ** (-1.0 / d)) if samples and d else math.nan,
                   "best_sample_gap": float((best - opt.objective) / abs(opt.objective))
                   if math.isfinite(best) else math.nan},
        "estimate": float(est),
        "how": ("largest relative difference of the spectral abscissa at an operating point of the optimum "
                "between the eigenvalues (QR) of the exact Jacobian and the generalized eigenvalues (QZ) of the "
                "pencil of the model's implicit rows; the finite-difference Jacobian's abscissa, the constraint "
                "violation at IPOPT's solution, the NLP's objective against the statics solver's and the random "
                "search's resolution are reported beside it"),
    }


def decay_rate_active(problem: DesignProblem, out: dict, opt: Evaluation) -> list[dict]:
    """The decay-rate constraints active at the optimum by its eigenvalues (max Re lambda within
    ACTIVE_MARGIN of -alpha) that the multiplier test of :meth:`DesignProblem.active` did not list: the
    stability rows are scaled by their magnitude at the start, which can be far from the optimum's, so
    their multipliers are no measure of activity.  Each with the row nearest zero and its multiplier."""
    alpha, res, listed = problem.spec.decay_rate, out["res"], {a["constraint"] for a in out["active"]}
    found = []
    for p, a in opt.abscissa.items():
        if not (math.isfinite(a) and -a <= alpha * (1 + ACTIVE_MARGIN) + ACTIVE_MARGIN):
            continue
        rows = [i for i, n in enumerate(problem.names) if n.startswith(f"psi1={p:g}: stability")]
        i = min(rows, key=lambda i: abs(res["g"][i]))
        if problem.names[i] not in listed:
            found.append({"constraint": f"psi1={p:g}: decay rate (eigenvalues; row {problem.names[i].split()[-1]})",
                          "multiplier": float(res["lam_g"][i]), "value": float(res["g"][i]),
                          "decay_rate": float(-a)})
    return found


def program_abscissa(problem: DesignProblem, values: dict) -> dict:
    """Spectral abscissa (1/s) of the source's program model (the hand model (2.43)/(2.101) at the
    closed-form point, :meth:`autobal.analysis.numerics.linearize.Setup.linear`) of one design at each operating
    point; NaN where the statics rest on a stop.  For comparison only: its constants are numbers computed
    at a closed-form point, not expressions of the NLP's static state (see docs/design.md)."""
    dev, out = apply(problem.device, values), {}
    for p in problem.points:
        try:
            out[f"{p:g}"] = float(Setup(dev, p).linear("program").poles().real.max())
        except (SolveError, ValueError):
            out[f"{p:g}"] = math.nan
    return out


def abscissa_sweep(problem: DesignProblem, values: dict, psi1s) -> list[float]:
    """Spectral abscissa (1/s) over ``psi1s`` for one design; NaN where a stop is reached."""
    ev = problem.evaluate(values, psi1s)
    return [ev.abscissa.get(float(p), math.nan) for p in psi1s]


def run(device: DeviceParams, spec: Spec, samples: int = 200, seed: int = 0, sweep_points: int = 11,
        title: str = "") -> DesignResult:
    """Solve, certify and report the design (see the module docstring).

    Parameters
    ----------
    device : DeviceParams
        Starting design with dynamic data.
    spec : Spec
        The design problem.
    samples : int
        Random-search samples of the certification (and half as many in the local search).
    seed : int
        Seed of the random search.
    sweep_points : int
        Points of the spectral-abscissa sweep over the operating range.
    title : str

    Returns
    -------
    DesignResult
    """
    prob = DesignProblem(device, spec)
    nominal = prob.evaluate(prob.nominal)
    sampled = prob.sample(samples, seed)
    feasible = [s for s in sampled if s.feasible]
    try:
        out = prob.solve()
    except SolveError:
        if not feasible:
            raise
        out = prob.solve(min(feasible, key=lambda s: s.objective))  # restart from the best feasible sample
    opt = prob.evaluate(out["values"])
    # a local search about the optimum: the global samples rarely come near it
    local = [s for s in prob.sample(samples // 2, seed + 1, around=out["values"], radius=LOCAL_RADIUS) if s.feasible]
    best = min((s.objective for s in feasible), default=math.nan)
    best_local = min((s.objective for s in local), default=math.nan)
    lo, hi = min(prob.points), max(prob.points)
    psi1s = np.linspace(lo, hi, sweep_points)
    sweep = AbscissaSweep(psi1s, *(np.asarray(abscissa_sweep(prob, v, psi1s), float)
                                   for v in (prob.nominal, out["values"])))
    other = "chain" if spec.form == "energy" else "energy"
    compare = ModelCheck(other, *({f"{p:g}": a for p, a in prob.evaluate(v, form=other).abscissa.items()}
                                  for v in (prob.nominal, out["values"])))
    program = ModelCheck("program", *(program_abscissa(prob, v) for v in (prob.nominal, out["values"])))
    res = DesignResult(
        form=spec.form, decay_rate=spec.decay_rate, points=prob.points,
        status=out["res"]["status"], iterations=out["res"]["iterations"], barrier=out["res"]["barrier"],
        optimum=block(prob, opt, Optimum), nominal=block(prob, nominal, Nominal),
        active=[Active(**a) for a in out["active"] + decay_rate_active(prob, out, opt)],
        certification=Certification(
            eigenvalues_ok=bool(opt.feasible), samples=samples, feasible_samples=len(feasible),
            best_sample=best, tolerance=CERTIFY_TOL, local_samples=samples // 2, local_radius=LOCAL_RADIUS,
            feasible_local_samples=len(local), best_local_sample=best_local,
            beaten=bool(any(math.isfinite(b) and b < opt.objective - CERTIFY_TOL * abs(opt.objective)
                            for b in (best, best_local)))),
        other_model=compare, program_model=program,
        abscissa_sweep=sweep,
        accuracy=accuracy(prob, out, opt, best, samples), history=out["history"], title=title)
    return explained(res, default="no value at this operating point: the design has no static solution or spectral "
                                  "abscissa there (NaN)")
