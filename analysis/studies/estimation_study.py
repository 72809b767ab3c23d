"""The estimation study of a scene: fits, the source's closed-form estimators, the adequacy test,
bootstrap intervals and the back-calculation of a loss coefficient (Pavlenko (2014), Secs. 4.3.3-4.4).

``run(spec, data)`` (a frozen :class:`Spec` and the measurements) returns an :class:`EstimationResult`: the
``estimation`` block of results.json, a summary, CSV tables and one figure per fit (the Result protocol).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, replace

import numpy as np

from autobal.analysis.numerics import disc_fit
from autobal.analysis.numerics.adequacy import decision, fisher_adequacy
from autobal.analysis.numerics.device_fit import DeviceFitter
from autobal.analysis.numerics.least_squares import FitResult
from autobal.analysis.run.fields import Record, TypedResult, declarations, keyed, optional, quantity, record, shared
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Quantity, is_number, significant
from autobal.analysis.run.result import new_figure, plain, twin_axis
from autobal.errors import ScenarioError, SolveError
from autobal.models.device import DeviceParams, design
from autobal.models.hydroheel import DiscLosses, TurbulentDisc

# The source's Table 4.4 (printed as a second "Table 4.3"), from points it does not publish.
SOURCE_TABLE_4_4 = {
    "static_1p": {"alpha": 1.68, "tau_max": 2.75},
    "static_2p": {"alpha": 1.72, "tau_max": 2.75},
    "flow_1p": {"alpha": 1.67, "tau_max": 2.73},
    "flow_2p": {"alpha": 1.70, "tau_max": 2.73},
    "note": "estimated by the source from static/flow points it shows only as figures (Figs 4.5, 4.6, 4.11); "
            "not reproducible from any tabulated data",
}
TRANSFORMED = {
    "static_1p_4_23": "minimises sum [1/tau_i - (1 + alpha^2 u_i^3)/tau_max]^2 (4.20), tau_max fixed",
    "static_2p_4_26": "minimises sum [tau_max - tau_i (1 + alpha^2 u_i^3)]^2 (normal equations (4.25))",
    "flow_1p_4_35": "minimises sum [(q_i^2 - 1 + tau_i/tau_max) alpha^2 - (1 - tau_i/tau_max)]^2, tau_max fixed",
    "flow_2p_4_36": "minimises sum {[(q_i^2 - 1) tau_max + tau_i] alpha^2 - tau_max + tau_i}^2 numerically",
}

_P14 = "Pavlenko (2014)"
_ADEQUACY = ("F", "F_crit", "p_value", "sigma1_sq", "sigma2_sq", "dof", "groups", "points", "parameters",
             "significance", "group_load", "group_mean", "group_theory", "load_spread_in_groups", "lack_of_fit.F",
             "lack_of_fit.F_crit", "lack_of_fit.p_value", "lack_of_fit.dof")


#: the fitted groups that are a physical quantity over a base: group -> (its key in ``physical``, the base, meaning);
#: the other groups are ratios of like quantities (α = g_TB/g1 a ratio of conductances, σ of areas) with no unit
PHYSICAL = {"tau_max": ("F_max", "force", "closing load of the face F_max = τ_max p_B s_B"),
            "chi": ("F_pr", "force", "push-off preload F_pr = χ p_B s_B")}
_PHYSICAL_VALUES = ("estimate", "standard_error", "ci_low", "ci_high", "bootstrap_ci_low", "bootstrap_ci_high")
#: the dimensional form of a data column: its group -> (the base, the physical symbol)
COLUMNS = {"tau": ("force", "F"), "psi1": ("pressure", "p1"), "u": ("gap", "h"), "q": ("flow", "Q")}


def _adequacy(*keys: str) -> str:
    """The keys of the fits' own adequacy tests and of the reference curve's."""
    return " ".join(f"{where}.{k}" for where in ("fits.*.adequacy", "adequacy_reference") for k in keys)


_stat = shared("1", "", "the fit's statistics (in the residual's group), solver counts, the scipy cross-check, "
               "the bootstrap's settings, the device fit's groups")


_matrix = shared("1", "r, Σ", "correlation and covariance of the free parameters")


@record
class Data(Record):
    """The measurements the fits were made to: the file, its points, its columns' units and load groups."""

    file: str
    path: str
    points: int = _stat()
    #: column -> its unit in the file
    columns: dict
    groups: int | None = _stat()
    provenance: list[str]


@record(kw_only=True)
class Fit(Record):
    """A solved fit: estimates with their standard errors and intervals, statistics, the data and the fitted curve
    with its band (all in the source's groups), and what was computed beside it.  Its blocks by parameter, data
    column or group (``parameters``, ``data``, ``curve``, ``bootstrap``, ``adequacy``, ``physical``) are declared
    by path."""

    status: str
    model: str
    residual: str
    hessian: str
    weights: dict
    load_kind: str
    #: parameter -> estimate, free, start, bounds, standard error and interval
    parameters: dict
    free: list[str]
    correlation: list = _matrix()
    covariance: list = _matrix()
    residual_std: float = _stat()
    ssr: float = _stat()
    dof: int = _stat()
    points: int = _stat()
    confidence: float = _stat()
    t_quantile: float = _stat()
    jtj_condition: float | None = _stat()
    solver: dict
    #: its key "data": the load and, per measured variable, the measured, fitted and residual values
    table: dict = keyed("data")
    curve: dict
    extra: dict
    cross_check_scipy: dict | None = optional()
    bases: dict | None = optional()
    bootstrap: dict | None = optional()
    adequacy: dict | None = optional()
    physical: dict

    @classmethod
    def from_dict(cls, block: dict):
        """A solved fit, or the :class:`FailedFit` of a fit whose block says it failed."""
        return FailedFit.from_dict(block) if block.get("status") == "failed" else super().from_dict(block)


@record
class FailedFit(Record):
    """A fit that failed: IPOPT's status, its last iterate and a hint."""

    status: str
    model: str
    residual: str
    reason: str
    solver: dict
    #: parameter -> its value at the last iterate
    last_iterate: dict
    hint: str


@record(kw_only=True)
class EstimationResult(TypedResult):
    """Parameter fits of one scene, with the source's closed forms, adequacy tests, bootstrap intervals and (4.38)
    (Pavlenko (2014), Secs. 4.3.3-4.4); headline numbers are the properties."""

    title: str
    data: Data
    #: group -> the SI base of the data's groups (null: not given in the scene)
    bases: dict
    status: str
    #: fit name -> its results (a :class:`FailedFit` where it failed)
    fits: dict[str, Fit]
    closed_forms: dict | None
    adequacy_reference: dict | None
    loss_coefficient: dict | None
    accuracy: dict
    run_time_s: float = quantity("s", "t", "wall time")
    name = "estimation"

    def to_dict(self) -> dict:
        """The block, its failures after its status (in results.json also when there are none)."""
        out = {k: v for k, v in super().to_dict().items() if k != "failures"}
        keys = list(out)
        at = keys.index("status") + 1
        return {k: out[k] for k in keys[:at]} | {"failures": list(self.failures)} | {k: out[k] for k in keys[at:]}

    @property
    def solved(self) -> dict[str, Fit]:
        """Fit name -> results block, of the fits that converged (a failed fit's block has status "failed")."""
        return {n: f for n, f in self.fits.items() if isinstance(f, Fit)}

    @property
    def estimates(self) -> dict[str, dict[str, float]]:
        """Fit name -> parameter -> estimate (dimensionless groups, or loss coefficients), of the solved fits."""
        return {n: {k: p["estimate"] for k, p in f.parameters.items()} for n, f in self.solved.items()}

    @property
    def intervals(self) -> dict[str, dict[str, tuple[float, float]]]:
        """Fit name -> free parameter -> linearised (Student-t) confidence interval, in the parameter's unit."""
        return {n: {k: (p["ci_low"], p["ci_high"]) for k, p in f.parameters.items() if p["free"]}
                for n, f in self.solved.items()}

    @property
    def bootstrap_intervals(self) -> dict[str, dict[str, tuple[float, float]]]:
        """Fit name -> free parameter -> bootstrap percentile interval (fits that have one)."""
        return {n: {k: (p["ci_low"], p["ci_high"]) for k, p in f.bootstrap["parameters"].items()}
                for n, f in self.solved.items() if "parameters" in (f.bootstrap or {})}

    def verdict(self) -> tuple[bool, str]:
        """The one verdict over the fits: each solved and adequate, that is passing both Fisher's test (4.14) and
        the lack-of-fit test at the scene's significance (:func:`autobal.analysis.numerics.adequacy.decision`); a fit
        that fails one says which, with its F against F_crit and its p against the significance."""
        oks, words = [], []
        for name, f in self.fits.items():
            free = [k for k, p in f.parameters.items() if p.get("free")] if isinstance(f, Fit) else []
            solved = bool(f.solver.get("success"))
            adequacy = f.adequacy if isinstance(f, Fit) else None
            ok, said = decision(adequacy) if adequacy else (None, "adequacy not tested")
            w = f"{name} ({', '.join(free)}): " + ("" if solved else f"solver FAILED ({f.solver.get('status')}); ")
            oks.append(solved and ok is not False)
            words.append(w + said)
        return all(oks), "; ".join(words)

    def summary(self) -> str:
        ok, words = self.verdict()
        lines = [f"estimation on {self.data.file} ({self.data.points} points)",
                 f"  {'ok' if ok else 'NOT OK'}: {words}"]
        lines += [f"  FAILED {x}" for x in self.failures]
        for name, f in self.solved.items():
            lines.append(f"  fit {name} ({f.model}, residual in {f.residual}, {f.hessian} Hessian): "
                         f"IPOPT {f.solver['status']} in {f.solver['iterations']} iterations, "
                         f"residual std {significant(f.residual_std)}")
            for m in f.extra.get("start_moved", {}).values():
                lines.append(f"    start moved: {m['why']}")
            bs = f.bootstrap or {}
            boot = bs.get("parameters", {}) if bs.get("status") == "ok" else {}
            for k, p in f.parameters.items():
                if not p["free"]:
                    lines.append(f"    {k:10s} {significant(p['estimate'])} (fixed)")
                else:
                    line = (f"    {k:10s} {significant(p['estimate'])} +- {significant(p['standard_error'], 2)}  "
                            f"{100 * f.confidence:.0f} % CI [{significant(p['ci_low'])}, "
                            f"{significant(p['ci_high'])}]")
                    if k in boot:
                        line += (f", bootstrap ({bs['samples']} refits) [{significant(boot[k]['ci_low'])}, "
                                 f"{significant(boot[k]['ci_high'])}]")
                    lines.append(line)
                lines += _physical_lines(f, k)
            if bs.get("status", "ok").startswith("failed"):
                lines.append(f"    bootstrap {bs['status']}")
            free = f.free or []
            corr = f.correlation or []
            for i, j in itertools.combinations(range(min(len(free), len(corr))), 2):
                r = corr[i][j]  # null when the covariance is undefined (a singular Hessian)
                lines.append(f"    correlation of {free[i]} and {free[j]}: {significant(r)}"
                             + (" (the data hardly separate them)" if r is not None and abs(r) >= 0.9 else ""))
            lines += _stiffness_lines(f)
            cc = f.cross_check_scipy
            if cc:
                lines.append(f"    scipy least_squares: max |difference| {cc['max_abs_difference']:.1e}")
        lc = self.loss_coefficient
        if lc and "status" in lc:
            lines.append(f"  (4.38) {lc['status']}")
        elif lc:
            lines.append(f"  (4.38): {lc['unknown']} = {significant(lc['value'])} [{significant(lc['ci_low'])}, "
                         f"{significant(lc['ci_high'])}] from alpha = {significant(lc['alpha'])} of fit {lc['fit']} "
                         f"(nominal alpha {significant(lc['alpha_nominal'])})")
        lines.append("  validation against the source (Pavlenko 2014, Secs. 4.3.3-4.4):")
        cf = self.closed_forms or {}
        for k, v in cf.items():
            if isinstance(v, dict) and "alpha" in v:
                lines.append(f"    closed form {k:16s} alpha = {significant(v['alpha'])}, tau_max = "
                             f"{significant(v['tau_max'])}")
        if "status" in cf:
            lines.append(f"    closed forms {cf['status']}")
        ref = self.adequacy_reference
        if ref and ref.get("F") is not None:
            lines.append(f"    the source's curve (alpha {significant(ref['reference']['alpha'])}, tau_max "
                         f"{significant(ref['reference']['tau_max'])}): sigma1^2 = {ref['sigma1_sq']:.3g}, sigma2^2 = "
                         f"{ref['sigma2_sq']:.3g}; {decision(ref)[1]} (the source's inverted rule F > F_crit: "
                         f"{'adequate' if ref['source_rule_adequate'] else 'not adequate'})")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        """estimation_parameters.csv (each row's unit in its column 'unit': the groups and, beside them, the fitted
        force groups in kN); per fit its points (measured, fitted, residual) and its curve with band, each group
        headed '[1]' and, where the data's base is known, beside it its physical value headed with its unit."""
        out = {}
        cols = ("estimate", "standard_error", "ci_low", "ci_high")
        rows = {k: [] for k in ("fit", "parameter", "free", *cols, "unit")}
        for name, f in self.solved.items():
            for k, p in f.parameters.items():
                for col, v in ({"fit": name, "parameter": k, "free": p["free"], "unit": "1"}
                               | {c: p.get(c) for c in cols}).items():
                    rows[col].append(v)
            for key, ph in (f.physical or {}).items():
                if "estimate" in ph:
                    q = QUANTITIES.find(f"fits.{name}.physical.{key}.estimate")
                    for col, v in ({"fit": name, "parameter": key, "free": ph["free"], "unit": q.display}
                                   | {c: q.shown(ph[c]) if c in ph else None for c in cols}).items():
                        rows[col].append(v)
            kind = f.load_kind
            pts = self._columns(f, {kind: f.table["load"]})
            cur = self._columns(f, {kind: f.curve["load"]})
            for k in f.table:
                if k != "load":
                    pts |= self._columns(f, {c: f.table[k][c] for c in ("measured", "fitted", "residual")}, k)
            for k in ("u", "q"):
                cur |= self._columns(f, {c: f.curve[k][c] for c in ("value", "band_low", "band_high")}, k)
            out[f"estimation_{name}_points.csv"] = pts
            out[f"estimation_{name}_curve.csv"] = cur
        return {"estimation_parameters.csv": rows, **out}

    def _columns(self, f: Fit, values: dict, group: str | None = None) -> dict:
        """CSV columns of one group of the data (``group``, or the load's kind as the key of ``values``): each
        column of ``values`` headed 'group_column [1]', then, where the base of the group is known, the same
        columns in their physical unit ('F [kN]', 'h_measured [mm]': the group times its base)."""
        out, physical = {}, {}
        base, symbol = COLUMNS[group or next(iter(values))]
        scale = self._base(f, base)
        q = QUANTITIES.find(f"bases.{base}")
        for col, v in values.items():
            suffix = f"_{col}" if group else ""
            out[f"{group or col}{suffix} [1]"] = v
            if is_number(scale) and scale > 0:
                physical[f"{symbol}{suffix} [{q.display}]"] = [q.shown(x * scale) if is_number(x) else None
                                                               for x in v]
        return out | physical

    def draw(self, ax) -> None:
        """The first fit's first measured variable: data, fitted curve and its confidence band."""
        name, f = next(iter(self.solved.items()))
        self._draw_fit(ax, name, f, next(k for k in ("u", "q") if k in f.table))

    def _base(self, f: Fit, base: str) -> float | None:
        """The SI base of a group of the fit's data: the device fit's own, else the scene's."""
        return (f.bases if f.bases else self.bases).get(base)

    def _draw_fit(self, ax, name: str, f: Fit, k: str) -> None:
        label = {"u": r"face gap $u = z/z_B$",
                 "q": r"flow $q = Q/Q_B$ (4.29)" if f.model == "traditional_disc" else
                 rf"flow $q_{{{f.extra.get('flow_throttle', 'T')}}} = Q/(g_1 p_B)$"}
        grid = np.asarray(f.curve["load"], float)
        c = f.curve[k]
        ax.fill_between(grid, c["band_low"], c["band_high"], color="C0", alpha=0.2,
                        label=f"{100 * f.confidence:.0f}% confidence band")
        ax.plot(grid, c["value"], color="C0", label=f"fit {name}: {_params_text(f)}")
        ax.plot(np.asarray(f.table["load"], float), f.table[k]["measured"], "ko", ms=4, label="measured")
        cf = self.closed_forms or {}
        if f.model == "traditional_disc":
            keys = ("static_1p_4_23", "static_2p_4_26") if k == "u" else ("flow_1p_4_35", "flow_2p_4_36")
            for key, ls in zip(keys, ("--", ":"), strict=True):
                v = cf.get(key)
                if v and v.get("alpha") is not None and v.get("tau_max") is not None:
                    disc = TurbulentDisc(v["alpha"], v["tau_max"])
                    with np.errstate(invalid="ignore"):
                        ax.plot(grid, (disc.gap if k == "u" else disc.flow)(grid), ls=ls, color="0.4",
                                label=f"({key.split('_', 2)[2].replace('_', '.')}): alpha {v['alpha']:.4g}, "
                                      f"tau_max {v['tau_max']:.4g}")
        ax.set_ylabel(label[k])
        self._physical_axis(ax, f, {"u": "gap", "q": "flow"}[k], "face gap z" if k == "u" else "flow Q")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def _physical_axis(self, ax, f: Fit, base: str, label: str, which: str = "y") -> None:
        """The physical values beside a group of the data (u = z/z_B ...) on a secondary axis, in their display
        unit, where the data's base (SI) is known."""
        value = self._base(f, base)
        if is_number(value) and value > 0:
            q = QUANTITIES.find(f"bases.{base}")
            twin_axis(ax, q.shown(value), f"{label}, {q.display}", which)

    def figures(self) -> dict[str, Figure]:
        """One figure per fit: data, fitted curve, confidence band (and the closed forms' curves for
        the traditional disc), and the residuals below."""
        figs = {}
        for name, f in self.solved.items():
            parts = [k for k in ("u", "q") if k in f.table]
            fig, axes = new_figure((6.4 * len(parts), 6.4), 2, len(parts), squeeze=False,
                                   gridspec_kw={"height_ratios": [3, 1]}, sharex="col")
            x = np.asarray(f.table["load"], float)
            tau = f.load_kind == "tau"
            xl = r"load $\tau$" if tau else r"discharge pressure $\psi_1$"
            for j, k in enumerate(parts):
                self._draw_fit(axes[0, j], name, f, k)
                self._physical_axis(axes[0, j], f, "force" if tau else "pressure",
                                    "axial force F" if tau else "discharge pressure $p_1$", "x")
                axr = axes[1, j]
                axr.axhline(0, color="k", lw=0.6)
                axr.plot(x, f.table[k]["residual"], "ko", ms=4)
                axr.set_ylabel("fit - measured")
                axr.set_xlabel(xl)
                axr.grid(alpha=0.3)
            fig.suptitle(f"{self.title}: fit {name} ({f.model}, residual in {f.residual})", fontsize=9)
            figs[f"fig_estimation_{name}.png"] = Figure(
                fig, f"Fit {name.replace('_', ' ')}: data, fitted curve and its 95 % band; Pavlenko (2014), "
                "Table 4.3")
        return figs


EstimationResult.quantities = QUANTITIES = declarations(
    EstimationResult,
    Quantity("fits.*.parameters.*.estimate fits.*.parameters.*.initial fits.*.parameters.*.lower "
             "fits.*.parameters.*.upper fits.*.cross_check_scipy.estimate.*", "1", "α, τ_max",
             "fitted parameter (a group of the model or a loss coefficient): estimate, start, bounds",
             source=f"{_P14}, Eqs. (4.16)-(4.18), Table 4.4"),
    Quantity("fits.*.parameters.*.standard_error fits.*.parameters.*.ci_low fits.*.parameters.*.ci_high", "1",
             "s, CI", "standard error and linearised (Student-t) confidence interval"),
    Quantity("fits.*.bootstrap.parameters.*.ci_low fits.*.bootstrap.parameters.*.ci_high "
             "fits.*.bootstrap.parameters.*.std fits.*.bootstrap.parameters.*.mean", "1", "CI*",
             "residual-bootstrap percentile interval, std and mean of the refits"),
    Quantity(_adequacy("F", "F_crit", "p_value", "lack_of_fit.F", "lack_of_fit.F_crit", "lack_of_fit.p_value"), "1",
             "F, F_crit, p", "Fisher adequacy test: the fit's variance against the scatter within the load groups "
             "(passed when F ≤ F_crit), and the lack-of-fit test; adequate when both pass",
             source=f"{_P14}, Eqs. (4.14)-(4.15)"),
    Quantity(_adequacy("sigma1_sq", "sigma2_sq", "dof", "groups", "points", "parameters", "significance",
                       "group_load", "group_mean", "group_theory", "load_spread_in_groups", "lack_of_fit.dof")
             + " adequacy_reference.reference.*", "1", "σ², ν, τ, u",
             "the adequacy test's variances, degrees of freedom, level, group loads and means; the reference "
             "curve's α, τ_max", source=f"{_P14}, §4.3.3"),
    Quantity("fits.*.data.** fits.*.curve.**", "1", "τ, u, q",
             "load and measured, fitted, residual gap u = h/h_TB or flow q; the fitted curve and its band",
             source=f"{_P14}, Table 4.3"),
    Quantity("fits.*.weights.* fits.*.solver.iterations fits.*.solver.objective fits.*.cross_check_scipy.cost "
             "fits.*.cross_check_scipy.nfev fits.*.cross_check_scipy.max_abs_difference fits.*.bootstrap.samples "
             "fits.*.bootstrap.seed fits.*.bootstrap.confidence fits.*.bootstrap.failed "
             "fits.*.bootstrap.ipopt_fallback fits.*.last_iterate.* fits.*.extra.**", "1", "",
             "the fit's statistics (in the residual's group), solver counts, the scipy cross-check, the bootstrap's "
             "settings, the device fit's groups"),
    Quantity("closed_forms.**", "1", "α, τ_max", "the source's closed-form estimators and their sums",
             source=f"{_P14}, Eqs. (4.20)-(4.37), Table 4.4"),
    Quantity("loss_coefficient.value loss_coefficient.ci_low loss_coefficient.ci_high loss_coefficient.nominal",
             "1", "λ, ζ", "loss coefficient the fitted α implies, its interval and nominal value",
             source=f"{_P14}, Eq. (4.38)"),
    Quantity("loss_coefficient.alpha loss_coefficient.alpha_ci loss_coefficient.alpha_nominal "
             "loss_coefficient.check_alpha_from_solved loss_coefficient.friction_factor", "1", "α",
             "the fitted α and its interval, α of the nominal losses, α recomputed from the solved loss",
             source=f"{_P14}, Eq. (4.38)"),
    Quantity(" ".join(f"fits.*.physical.{k}.{v}" for k in ("F_max", "F_pr") for v in _PHYSICAL_VALUES)
             + " fits.*.physical.*.scale", "N", "F_max, F_pr",
             "a fitted force group in newtons: the closing load of the face F_max = τ_max p_B s_B (4.18), the "
             "push-off preload F_pr = χ p_B s_B; its estimate, standard error and intervals, and the scale p_B s_B",
             "kN", source=f"{_P14}, Eqs. (4.16)-(4.18)"),
    Quantity("fits.*.physical.stiffness.value", "N/m", "c", "axial stiffness of the fitted disc c = −dF/dh = "
             "κ p_B s_B/h_TB at the data's loads", "N/µm", source=f"{_P14}, Eqs. (4.16)-(4.18)"),
    Quantity("fits.*.physical.stiffness.load", "N", "F", "the data's loads, where the stiffness is given", "kN"),
    Quantity("fits.*.physical.stiffness.tau fits.*.physical.stiffness.kappa", "1", "τ, κ",
             "the data's loads τ and the fitted disc's stiffness κ = −dτ/du (the groups of c and F)"),
    Quantity("bases.pressure fits.*.bases.pressure", "Pa", "p_B", "pressure base of the data", "MPa"),
    Quantity("bases.gap fits.*.bases.gap", "m", "h_TB", "gap base of the data", "mm"),
    Quantity("bases.flow fits.*.bases.flow", "m^3/s", "Q_B", "flow base of the data"),
    Quantity("bases.force fits.*.bases.force", "N", "F_B", "force base of the data"),
    Quantity("fits.*.bootstrap.time_s", "s", "t", "wall time"),
)


def _physical_lines(f: Fit, group: str) -> list[str]:
    """The summary's line of a fitted group in its physical unit (``PHYSICAL``), beside the group's own line."""
    if group not in PHYSICAL:
        return []
    key = PHYSICAL[group][0]
    ph = (f.physical or {}).get(key) or {}
    if "estimate" not in ph:
        return [f"    {'':10s} {key}: {ph['status']}"] if "status" in ph else []
    q = QUANTITIES.find(f"fits.x.physical.{key}.estimate")
    line = f"    {'':10s} = {ph['meaning']} = {q.text(ph['estimate'])}"
    if "standard_error" in ph:
        line += (f" +- {significant(q.shown(ph['standard_error']), 2)} {q.display}, "
                 f"CI [{significant(q.shown(ph['ci_low']))}, {significant(q.shown(ph['ci_high']))}] {q.display}")
    if "bootstrap_ci_low" in ph:
        line += (f", bootstrap [{significant(q.shown(ph['bootstrap_ci_low']))}, "
                 f"{significant(q.shown(ph['bootstrap_ci_high']))}] {q.display}")
    return [line]


def _stiffness_lines(f: Fit) -> list[str]:
    """The summary's line of the fitted disc's axial stiffness at the data's loads, in N/µm at F in kN."""
    st = (f.physical or {}).get("stiffness")
    if not st or "value" not in st:
        return []
    c, F = QUANTITIES.find("fits.x.physical.stiffness.value"), QUANTITIES.find("fits.x.physical.stiffness.load")
    pairs = ", ".join(f"{significant(c.shown(v))} at {significant(F.shown(x))}" for x, v in zip(
        st["load"], st["value"], strict=True))
    return [f"    axial stiffness c = -dF/dh of the fitted disc, {c.display} at F in {F.display}: {pairs}"]


def _params_text(f: Fit) -> str:
    return ", ".join(f"{k} {p['estimate']:.4g}" for k, p in f.parameters.items() if p["free"])


@dataclass(frozen=True)
class Parameter:
    """One model parameter of a fit: its value (the initial guess when free) in its unit (a group: 1), free or
    fixed, its bounds (None: none given)."""

    value: float
    free: bool
    lower: float | None
    upper: float | None


@dataclass(frozen=True)
class FitSpec:
    """One nonlinear least-squares fit: ``model`` (traditional_disc, device) in ``residual`` (u, q, both) with the
    residual ``weights`` {"u": .., "q": ..}, its ``parameters`` (name -> :class:`Parameter`), the device model's
    measured ``flow_throttle``, IPOPT's ``hessian`` and ``max_iterations``."""

    name: str
    model: str
    residual: str
    weights: dict
    parameters: dict
    flow_throttle: str
    hessian: str
    max_iterations: int

    def free(self) -> list[str]:
        return [k for k, p in self.parameters.items() if p.free]


@dataclass(frozen=True)
class AdequacySpec:
    """The Fisher adequacy test (4.14)-(4.15) at ``significance``; ``reference`` (alpha, tau_max) a theory curve to
    test with ``reference_parameters`` = l of (4.15), or None."""

    significance: float
    reference: dict | None
    reference_parameters: int


@dataclass(frozen=True)
class LossSpec:
    """Solve (4.38) for the loss coefficient ``unknown`` of ``losses`` (SI) from the alpha of the fit ``fit``."""

    fit: str
    unknown: str
    losses: DiscLosses


@dataclass(frozen=True)
class BootstrapSpec:
    """Residual-bootstrap intervals of the traditional_disc fits: ``samples`` data sets from ``seed``."""

    samples: int
    seed: int


@dataclass(frozen=True)
class Spec:
    """What the estimation study computes (the validated ``analyses.estimation`` of a scene, SI).

    Attributes
    ----------
    fits : tuple of FitSpec
    bases : dict
        Base values by the key the data columns use: pressure (Pa), gap (m), flow (m^3/s), force p_B s_B (N); None
        where not given.
    closed_forms : bool
        The source's estimators (4.23), (4.26)-(4.27), (4.35), (4.36).
    tau_max : float or None
        Their fixed tau_max; None: the first disc fit's value.
    adequacy : AdequacySpec or None
    loss_coefficient : LossSpec or None
    confidence : float
        Level of every confidence interval and band.
    band_points : int
        Points of the fitted curve and its band.
    cross_check : bool
        Re-fit with scipy.optimize.least_squares (traditional_disc fits).
    bootstrap : BootstrapSpec or None
    """

    fits: tuple
    bases: dict
    closed_forms: bool
    tau_max: float | None
    adequacy: AdequacySpec | None
    loss_coefficient: LossSpec | None
    confidence: float
    band_points: int
    cross_check: bool
    bootstrap: BootstrapSpec | None


def _device_bases(bases: dict, dev) -> dict:
    sc = dev.scales
    own = {"pressure": sc["p_B"], "gap": sc["z_B"], "flow": sc["Q_scale"], "force": sc["p_B"] * sc["s_B"]}
    return {k: bases[k] if bases.get(k) else own[k] for k in own}


def _fit_block(f: FitResult, curve: dict) -> dict:
    st = f.stats
    params = {}
    for k, v in f.estimate.items():
        free = k in f.free
        i = f.free.index(k) if free else None
        params[k] = {"estimate": v, "free": free, "initial": f.initial[k],
                     "lower": f.bounds[k][0] if free else None, "upper": f.bounds[k][1] if free else None,
                     "standard_error": st["standard_error"][i] if free else None,
                     "ci_low": st["ci_low"][i] if free else None, "ci_high": st["ci_high"][i] if free else None}
        for key in ("lower", "upper", "standard_error", "ci_low", "ci_high"):
            if params[k][key] is None or not np.isfinite(params[k][key]):
                params[k][f"{key}_status"] = "a fixed parameter" if not free else "no bound given"
    data = {"load": f.load}
    for k in f.measured:
        data[k] = {"measured": f.measured[k], "fitted": f.fitted[k], "residual": f.fitted[k] - f.measured[k]}
    return {
        "status": "ok", "model": f.model, "residual": f.residual, "hessian": f.hessian, "weights": f.weights,
        "load_kind": f.extra.get("load_kind", "tau"),
        "parameters": params, "free": f.free, "correlation": st["correlation"], "covariance": st["covariance"],
        "residual_std": st["residual_std"], "ssr": st["ssr"], "dof": st["dof"], "points": st["points"],
        "confidence": st["confidence"], "t_quantile": st["t_quantile"], "jtj_condition": st["jtj_condition"],
        "solver": f.solver, "data": data,
        "curve": {"load": curve["load"], **{k: dict(zip(("value", "band_low", "band_high"), curve[k], strict=True))
                                            for k in ("u", "q")}},
        "extra": {k: v for k, v in f.extra.items() if k != "load_kind"},
    }


def _bootstrap_block(fitter, res: FitResult, opts, confidence: float) -> dict:
    """Residual-bootstrap intervals of a disc fit, per free parameter, and how the refits went."""
    t0 = time.perf_counter()
    b = fitter.bootstrap(res, opts.samples, opts.seed, confidence)
    params = {k: {"ci_low": float(b["ci_low"][i]), "ci_high": float(b["ci_high"][i]), "std": float(b["std"][i]),
                  "mean": float(b["mean"][i])} for i, k in enumerate(res.free)}
    left = b["samples"] - b["failed"]
    status = "ok" if left >= 2 else f"failed: {b['failed']} of {b['samples']} refits failed, no interval"
    return {"method": "residual bootstrap, percentile intervals", "status": status, "samples": b["samples"],
            "seed": b["seed"], "confidence": confidence, "parameters": params, "ipopt_fallback": b["fallback"],
            "failed": b["failed"], "time_s": time.perf_counter() - t0}


def _closed_forms(tau, u, q, group, tau_max: float) -> dict:
    df = disc_fit
    out = {}
    if u is not None:
        out["static_1p_4_23"] = {"alpha": df.static_1p(tau, u, tau_max), "tau_max": tau_max, "tau_max_fixed": True}
        t2, a2 = df.static_2p(tau, u)
        out["static_2p_4_26"] = {"alpha": a2, "tau_max": t2, "tau_max_fixed": False}
        if group is not None:
            labels, idx = np.unique(group, return_inverse=True)
            mt, mu = np.bincount(idx, tau) / np.bincount(idx), np.bincount(idx, u) / np.bincount(idx)
            t2m, a2m = df.static_2p(mt, mu)
            out["on_group_means"] = {"static_1p_4_23": {"alpha": df.static_1p(mt, mu, tau_max), "tau_max": tau_max},
                                     "static_2p_4_26": {"alpha": a2m, "tau_max": t2m}}
    if q is not None:
        out["flow_1p_4_35"] = {"alpha": df.flow_1p(tau, q, tau_max), "tau_max": tau_max, "tau_max_fixed": True}
        t4, a4 = df.flow_2p(tau, q)
        s = df.flow_sums(tau, q)
        out["flow_2p_4_36"] = {"alpha": a4, "tau_max": t4, "tau_max_fixed": False, "sums_4_37": s,
                               "stationarity_4_36": df.stationarity_4_36(t4, a4**2, s)}
    out["objectives"] = {k: v for k, v in TRANSFORMED.items() if k in out}
    out["note"] = ("the source's estimators minimise transformed residuals (linear in alpha^2 or in "
                   "(tau_max, alpha^2)), not the residual in u or q; they differ from the least-squares fits "
                   "on noisy data and agree on noiseless data")
    out["source_printed"] = SOURCE_TABLE_4_4
    return out


def _one_fit(fit: FitSpec, spec: Spec, data, bases: dict, device) -> tuple[Fit, FitResult]:
    """One fit of the scene: its results (with the cross-check, bootstrap and adequacy test) and its FitResult;
    SolveError when it does not converge or the data do not identify it."""
    group = data.columns.get("group")
    fb = bases
    if fit.model == "device":
        if device is None:
            raise ScenarioError(f"analyses.estimation.fits.{fit.name}: the device model needs a device section")
        dev = design(device)
        fb = _device_bases(bases, dev)
    load = data.dimensionless("load", fb)
    u = data.dimensionless("gap", fb) if fit.residual in ("u", "both") else None
    q = data.dimensionless("flow", fb) if fit.residual in ("q", "both") else None
    values = {k: p.value for k, p in fit.parameters.items()}
    weights = dict(fit.weights)
    grid = np.linspace(load.min(), load.max(), spec.band_points)
    if fit.model == "traditional_disc":
        free = tuple(fit.free())
        bounds = {k: (fit.parameters[k].lower, fit.parameters[k].upper) for k in free}
        fitter = disc_fit.DiscFitter(len(load), fit.residual, free, fit.hessian, fit.max_iterations)
        res = fitter.fit(load, u, q, values=values, bounds=bounds, weights=weights, name=fit.name,
                         confidence=spec.confidence)
        _identified(res)
        curve = disc_fit.disc_curve(grid, res.estimate, res.free, res.stats["covariance"], res.stats["t_quantile"])
        block = _fit_block(res, curve)
        if spec.cross_check:
            sp = disc_fit.scipy_disc_fit(load, u, q, fit.residual, res.initial, free, bounds, weights)
            block["cross_check_scipy"] = sp | {"max_abs_difference": max(
                abs(sp["estimate"][k] - res.estimate[k]) for k in free)}
        if spec.bootstrap is not None:
            block["bootstrap"] = _bootstrap_block(fitter, res, spec.bootstrap, spec.confidence)
    else:
        params = {k: (p.value, p.free, p.lower, p.upper) for k, p in fit.parameters.items()}
        kind = "tau" if data.has("load") in ("tau", "axial_force") else "psi1"
        fitter = DeviceFitter(device, dev, params, fit.residual, fit.flow_throttle, fit.hessian, fit.max_iterations)
        res = fitter.fit(load, kind, u, q, weights=weights, name=fit.name, confidence=spec.confidence)
        _identified(res)
        curve = fitter.curve(res, grid)
        block = _fit_block(res, curve)
        block["bases"] = fb
        if spec.bootstrap is not None:
            block["bootstrap"] = {"status": "not available",
                                  "note": "bootstrap intervals are computed for traditional_disc fits only"}
    if spec.adequacy is not None and group is not None:
        var = "u" if "u" in res.measured else "q"
        fitted, meas = res.fitted[var], res.measured[var]

        def theory(loads, fitted=fitted, load=load):
            return np.array([fitted[np.isclose(load, x, rtol=1e-12)].mean() for x in loads])

        block["adequacy"] = fisher_adequacy(load, meas, group, theory, len(res.free),
                                            spec.adequacy.significance) | {"variable": var}
    block["physical"] = _physical(block, fb)
    if fit.model == "traditional_disc" and data.has("load") in ("tau", "axial_force"):
        block["physical"]["stiffness"] = _stiffness(res.estimate, np.unique(load), fb)
    return Fit.from_dict(plain(block)), res


def _stiffness(estimate: dict, loads, bases: dict) -> dict:
    """The fitted disc's axial stiffness at the data's distinct loads: kappa = -d tau/du of (4.16) (1) and, where
    the force and gap bases are given, c = kappa p_B s_B/h_TB (N/m) at the loads F = tau p_B s_B (N)."""
    kappa = TurbulentDisc(estimate["alpha"], estimate["tau_max"]).stiffness(loads)
    out = {"meaning": "axial stiffness of the fitted disc c = -dF/dh = κ p_B s_B/h_TB, κ = -dτ/du of (4.16)",
           "tau": loads, "kappa": kappa}
    force, gap = bases.get("force"), bases.get("gap")
    if force and gap:
        return out | {"load": loads * force, "value": kappa * force / gap}
    return out | {"status": "in N/m only with the force and gap bases (analyses.estimation.bases)"}


def _physical(block: dict, bases: dict) -> dict:
    """The fitted groups of ``PHYSICAL`` in SI (N): the group's estimate, standard error and intervals times its
    base (p_B s_B), where the scene gives the base; a fixed group's value alone."""
    out = {}
    boot = (block.get("bootstrap") or {}).get("parameters") or {}
    for group, p in block["parameters"].items():
        if group not in PHYSICAL:
            continue
        key, base, meaning = PHYSICAL[group]
        scale = bases.get(base)
        if not scale:
            out[key] = {"group": group, "meaning": meaning,
                        "status": f"not computed: the {base} base (analyses.estimation.bases) is not given"}
            continue
        values = {v: p.get(v) for v in _PHYSICAL_VALUES[:4]} | {
            f"bootstrap_{v}": (boot.get(group) or {}).get(v) for v in ("ci_low", "ci_high")}
        out[key] = {"group": group, "meaning": meaning, "free": p["free"], "scale": scale,
                    **{v: x * scale for v, x in values.items() if x is not None}}
    return out


def _identified(res: FitResult) -> None:
    """SolveError when the Jacobian at the optimum does not identify the free parameters (J'J
    singular to working precision: no covariance, any value along a direction fits as well)."""
    if not np.all(np.isfinite(res.stats["covariance"])):
        raise SolveError(f"fit {res.name!r}: the data do not identify its free parameters {', '.join(res.free)} "
                         f"(J'J condition {res.stats['jtj_condition']:.1e} at the optimum)", "Not_Identifiable",
                         {k: res.estimate[k] for k in res.free})


HINTS = {
    "Maximum_Iterations_Exceeded": "raise max_iterations, or start nearer the data (the closed forms' estimates "
                                   "are a start)",
    "Invalid_Number_Detected": "the model is undefined at an iterate: bound the parameters where it is defined "
                               "(tau_max above the largest load, ratios positive)",
    "Not_Identifiable": "measure at more different loads, or fix one of the parameters",
}


def _failed(fit: FitSpec, exc: SolveError) -> FailedFit:
    """A fit that failed: its status, IPOPT's status, the last iterate and a hint."""
    return FailedFit(status="failed", model=fit.model, residual=fit.residual, reason=exc.message,
                     solver=plain({"status": exc.status, "success": False,
                                   "iterations": exc.last_iterate.get("iterations")}),
                     last_iterate=plain({k: v for k, v in exc.last_iterate.items() if k != "iterations"}),
                     hint=HINTS.get(exc.status, "check the initial values and bounds of its parameters"))


def run(spec: Spec, data, device: DeviceParams | None = None, title: str = "") -> EstimationResult:
    """Every fit of the scene's ``analyses.estimation`` block, the closed forms, the adequacy tests,
    bootstrap intervals and (4.38).

    Parameters
    ----------
    spec : Spec
        The fits and what to compute beside them.
    data : autobal.measurements.Measurements
        The measurements, read by the caller: the study reads no file.
    device : DeviceParams, optional
        The device in SI, for fits of the device model.
    title : str
        Title of the scene, for the figures.

    Returns
    -------
    EstimationResult
    """
    t0 = time.perf_counter()
    bases = spec.bases
    role_load = data.has("load")
    group = data.columns.get("group")
    fits, solvers, failures = {}, {}, []
    for fit in spec.fits:
        try:
            fits[fit.name], solvers[fit.name] = _one_fit(fit, spec, data, bases, device)
            boot = fits[fit.name].bootstrap or {}
            if boot.get("status", "").startswith("failed"):
                failures.append(f"fit {fit.name!r}: bootstrap {boot['status']}")
        except SolveError as exc:
            fits[fit.name] = _failed(fit, exc)
            failures.append(f"{exc.message} (status {exc.status}); {fits[fit.name].hint}")
    if not solvers:
        first = fits[spec.fits[0].name]
        head = "" if len(failures) == 1 else f"all {len(failures)} fits failed: "
        raise SolveError(head + "; ".join(failures), first.solver["status"], first.last_iterate)

    first_disc = next((f for f in spec.fits if f.model == "traditional_disc"), None)
    closed = None
    if spec.closed_forms and role_load in ("tau", "axial_force"):
        tau_max = spec.tau_max or (first_disc.parameters["tau_max"].value if first_disc else None)
        top = float(data.dimensionless("load", bases).max())
        if tau_max is not None and tau_max <= top:
            closed = {"status": f"not computed: their fixed tau_max {tau_max:g} is not above the largest load "
                                f"{top:.6g}, where (4.18) is undefined; give analyses.estimation.tau_max"}
        elif tau_max is not None:
            tau = data.dimensionless("load", bases)
            u = data.dimensionless("gap", bases) if data.has("gap") else None
            q = data.dimensionless("flow", bases) if data.has("flow") else None
            closed = _closed_forms(tau, u, q, group, tau_max)

    reference = None
    ad = spec.adequacy
    if ad is not None and ad.reference is not None and group is not None and data.has("gap"):
        ref = {"alpha": 1.75, "tau_max": 2.75} | ad.reference
        tau, u = data.dimensionless("load", bases), data.dimensionless("gap", bases)
        reference = fisher_adequacy(tau, u, group, TurbulentDisc(ref["alpha"], ref["tau_max"]).gap,
                                        ad.reference_parameters, ad.significance) | {"reference": ref}

    loss = None
    lc = spec.loss_coefficient
    if lc is not None and lc.fit not in solvers:
        loss = {"fit": lc.fit, "status": f"not computed: fit {lc.fit} failed"}
    elif lc is not None:
        f = solvers[lc.fit]
        alpha = f.estimate["alpha"]
        lo, hi = f.interval("alpha")
        losses = lc.losses
        ends = sorted(losses.solve(lc.unknown, a) for a in (lo, hi))
        value = losses.solve(lc.unknown, alpha)
        loss = {"fit": lc.fit, "alpha": alpha, "alpha_ci": [lo, hi], "unknown": lc.unknown, "value": value,
                "ci_low": ends[0], "ci_high": ends[1], "physical": bool(value >= 0),
                "nominal": getattr(losses, lc.unknown), "alpha_nominal": losses.conductance_ratio(),
                "friction_factor": losses.friction_factor,
                "check_alpha_from_solved": replace(losses, **{lc.unknown: value}).conductance_ratio()}

    diffs = [b.cross_check_scipy["max_abs_difference"] for b in fits.values()
             if isinstance(b, Fit) and b.cross_check_scipy is not None]
    n_failed = len(fits) - len(solvers)
    status = f"{n_failed} of {len(fits)} fits failed" if n_failed else "a bootstrap failed" if failures else "ok"
    return EstimationResult(
        title=title,
        data=Data(file=data.path.name, path=str(data.path), points=data.points, columns=plain(data.units),
                  groups=int(len(np.unique(group))) if group is not None else None, provenance=plain(data.comments)),
        bases=plain(bases | {f"{k}_status": "not given in the scene (not needed by its fits)"
                             for k, v in bases.items() if v is None}),
        status=status, failures=failures, fits=fits, closed_forms=plain(closed), adequacy_reference=plain(reference),
        loss_coefficient=plain(loss),
        accuracy={"estimate": plain(max(diffs)) if diffs else None,
                  "how": "largest difference of a fitted parameter between IPOPT and scipy least_squares on "
                         "the same residual" if diffs else "no cross-check for these fits"},
        run_time_s=time.perf_counter() - t0)
