"""The design study: solve the design NLP (analysis/design.py), certify it, and report a DesignResult.

Certification: eigenvalues of the ordinary statics + exact linearisation at every operating point,
a random search over the same variables (no feasible sample may beat the optimum by more than
0.5 %), the active constraints with their multipliers, and the spectral abscissa over the operating
range before and after.
"""

from __future__ import annotations

import math

import numpy as np

from autobal.analysis.design import UNITS, DesignProblem, Evaluation, Spec
from autobal.analysis.result import Result, fmt, new_figure, with_statuses
from autobal.errors import SolveError
from autobal.models.device import DeviceParams

CERTIFY_TOL = 0.005  # a sampled feasible design may not beat the optimum by more than this (relative)


def quantity(key: str, value: float) -> str:
    """A design value as a string with its SI unit, e.g. "4.7e-05 m**3" (what ``--set`` reads)."""
    unit = UNITS[key]
    return f"{value:.10g} {unit}".strip()


def block(problem: DesignProblem, ev: Evaluation) -> dict:
    """results.json block of one evaluated design: parameters by scene path, objective, margins."""
    paths = {v.key: v.path for v in problem.spec.variables}
    return {
        "parameters": {paths[k]: quantity(k, v) for k, v in ev.values.items()},
        "values_si": {paths[k]: v for k, v in ev.values.items()},
        "objective": ev.objective,
        "leakage": ev.leakage,
        "feasible": ev.feasible,
        "infeasible_reason": ev.reason,
        "margin": {f"{p:g}": -a for p, a in ev.abscissa.items()},
        "spectral_abscissa": {f"{p:g}": a for p, a in ev.abscissa.items()},
        "stiffness": {f"{p:g}": k for p, k in ev.stiffness.items()},
        "face_gap": {f"{p:g}": z for p, z in ev.gap.items()},
        "valve_travel": {f"{p:g}": x for p, x in ev.valve.items()},
    }


class DesignResult(Result):
    """Result of ``analyses.design``: the optimum, the starting design, certification and history."""

    name = "design"

    def __init__(self, data: dict, sweep: dict, history: dict, title: str = ""):
        self.data, self.sweep, self.history, self.title = data, sweep, history, title

    @property
    def parameters(self) -> dict:
        """Optimum design values by scene path, as strings with SI units."""
        return self.data["optimum"]["parameters"]

    @property
    def objective(self) -> float:
        """Objective at the optimum (dimensionless: Q_e / Q_e,nominal by default)."""
        return self.data["optimum"]["objective"]

    @property
    def margin(self) -> dict:
        """Decay rate -max Re lambda at each operating point of the optimum, 1/s."""
        return self.data["optimum"]["margin"]

    def to_dict(self) -> dict:
        return with_statuses(self.data, default="no value at this operating point: the design has no static "
                             "solution or spectral abscissa there (NaN)")

    def summary(self) -> str:
        d = self.data
        o, n = d["optimum"], d["nominal"]
        lines = [f"design ({d['form']} model, alpha = {d['decay_rate']:g} 1/s): status {d['status']}",
                 f"  objective {fmt(n['objective'])} -> {fmt(o['objective'])}; leakage Q_e "
                 f"{fmt(n['leakage'])} -> {fmt(o['leakage'])} m^3/s"]
        for p, a in o["margin"].items():
            lines.append(f"  psi1 = {p}: margin {fmt(n['margin'].get(p, math.nan))} -> {fmt(a)} 1/s")
        for path, v in o["parameters"].items():
            lines.append(f"  {path}: {n['parameters'][path]} -> {v}")
        cmp = d["other_model"]
        lines.append(f"  {cmp['model']} model: max Re lambda nominal "
                     + ", ".join(fmt(v) for v in cmp["nominal"].values()) + "; optimum "
                     + ", ".join(fmt(v) for v in cmp["optimum"].values()) + " 1/s")
        lines.append("  active: " + (", ".join(a["constraint"] for a in d["active"]) or "-"))
        c = d["certification"]
        lines.append(f"  certified: eigenvalues {c['eigenvalues_ok']}; random search {c['samples']} samples, "
                     f"{c['feasible_samples']} feasible, best {fmt(c['best_sample'])} (optimum {fmt(o['objective'])})")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        return {"design_abscissa.csv": {"psi1": self.sweep["psi1"], "nominal": self.sweep["nominal"],
                                        "optimum": self.sweep["optimum"]}}

    def draw(self, ax) -> None:
        s = self.sweep
        ax.plot(s["psi1"], s["nominal"], "o-", label="nominal")
        ax.plot(s["psi1"], s["optimum"], "s-", label="optimum")
        ax.axhline(-self.data["decay_rate"], color="k", ls="--", lw=0.8, label=r"$-\alpha$")
        ax.set_xlabel(r"discharge ratio $\psi_1$")
        ax.set_ylabel(r"spectral abscissa max Re $\lambda$, 1/s")
        ax.legend()

    def figures(self) -> dict:
        fig1, ax = new_figure()
        self.draw(ax)
        ax.set_title(self.title)
        fig2, ax2 = new_figure()
        o, n = self.data["optimum"]["values_si"], self.data["nominal"]["values_si"]
        names = list(o)
        ratio = [o[k] / n[k] if n[k] else math.nan for k in names]
        ax2.barh(range(len(names)), ratio)
        ax2.set_yticks(range(len(names)), [k.rsplit(".", 1)[-1] for k in names])
        ax2.axvline(1.0, color="k", lw=0.8)
        ax2.set_xlabel("optimum / nominal")
        fig3, ax3 = new_figure()
        h = self.history
        if h.get("obj"):
            ax3.semilogy(np.abs(h["obj"]), label="|objective|")
            ax3.semilogy(np.maximum(h["inf_pr"], 1e-18), label="primal infeasibility")
            ax3.semilogy(np.maximum(h["inf_du"], 1e-18), label="dual infeasibility")
            ax3.legend()
        ax3.set_xlabel("IPOPT iteration")
        return {"design_abscissa.png": fig1, "design_parameters.png": fig2, "design_convergence.png": fig3}


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
        Random-search samples of the certification.
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
    best = min((s.objective for s in feasible), default=math.nan)
    lo, hi = min(prob.points), max(prob.points)
    psi1s = np.linspace(lo, hi, sweep_points)
    sweep = {"psi1": psi1s, "nominal": abscissa_sweep(prob, prob.nominal, psi1s),
             "optimum": abscissa_sweep(prob, out["values"], psi1s)}
    other = "chain" if spec.form == "energy" else "energy"
    compare = {"model": other} | {k: {f"{p:g}": a for p, a in prob.evaluate(v, form=other).abscissa.items()}
                                  for k, v in (("nominal", prob.nominal), ("optimum", out["values"]))}
    data = {
        "form": spec.form, "decay_rate": spec.decay_rate, "points": prob.points,
        "status": out["res"]["status"], "iterations": out["res"]["iterations"],
        "optimum": block(prob, opt), "nominal": block(prob, nominal),
        "active": out["active"],
        "certification": {
            "eigenvalues_ok": bool(opt.feasible), "samples": samples, "feasible_samples": len(feasible),
            "best_sample": best, "tolerance": CERTIFY_TOL,
            "beaten": bool(math.isfinite(best) and best < opt.objective - CERTIFY_TOL * abs(opt.objective)),
        },
        "other_model": compare,  # spectral abscissa (1/s) of the same designs in the other chamber form
        "abscissa_sweep": {"psi1": psi1s, "nominal": sweep["nominal"], "optimum": sweep["optimum"]},
    }
    return DesignResult(data, sweep, out["history"], title)
