"""Probabilistic calculation of the balancing device: the Monte Carlo study (Pavlenko 2014, chapter 3).

The groups of the static model (2.18) {alpha_in1, alpha_B1, alpha_e1, alpha_TB1, alpha_31, b, sigma,
chi, dpsi, psi_in} are random (analysis/numerics/sampling.py); each sample is one realisation of the device,
swept over the discharge ratios psi1 of the scene (the source re-draws the samples at every grid
point; the statistics per point are the same in distribution, and common samples give smooth
bands), solved exactly and by the source's closed forms (analysis/studies/montecarlo_statics.py), with
exact sensitivities and the first-order variance; optionally the AFC amplitude through a linear
model of the dynamics (analysis/studies/montecarlo_afc.py).

Outputs per grid point: mean, standard deviation (population formulas, as the source), coefficient
of variation, bands mean +- k sigma (k = ``band_sigma``, 3 reproduces the source's "20 %" and
"25 %") and quantiles.

Status: a failed statics solve of the nominal device raises SolveError; samples whose exact statics do not
solve are counted (``invalid``) and left out of the statistics, and more than :data:`MAX_INVALID_SHARE` of them
at a discharge ratio is a failure of the result (:meth:`MonteCarloResult.failures`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from autobal.analysis.numerics import closed_form
from autobal.analysis.numerics.frequency import MODEL_LABELS
from autobal.analysis.numerics.sampling import (
    Sampler,
    correlation_matrix,
    marginals,
    relative_standard_errors,
    statistics,
)
from autobal.analysis.numerics.statics import RESIDUAL_TOL, StaticsSolver
from autobal.analysis.run.fields import (
    Record,
    TypedResult,
    declarations,
    explained,
    optional,
    quantity,
    record,
    shared,
    unsaved,
)
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Quantity, significant
from autobal.analysis.run.result import failed_head, new_figure, twin_axis, unit_axis
from autobal.analysis.studies.montecarlo_afc import afc_names, afc_study
from autobal.analysis.studies.montecarlo_statics import (
    OUTPUTS,
    REGULATOR_PARAMETERS,
    SENSITIVITY_OUTPUTS,
    SOURCE_OUTPUTS,
    Task,
    evaluator,
    sensitivities,
    simulate,
)
from autobal.errors import ScenarioError
from autobal.models.device import DeviceDesign

# a study whose exact statics did not solve for more than this share of the samples at a discharge ratio is
# failed (its statistics would be those of the samples that solved); the shipped scene has 27 of 1e5 at psi1 = 1.25
MAX_INVALID_SHARE = 0.01
OUTPUT_NAMES = {"u": r"face gap $u = z/z_B$", "q_T": r"face leak $q_T = Q_T/Q_B$"}
PARAMETER_NAMES = {  # the random groups of (2.18) by what they are
    "alpha_in1": r"inlet throttle $\alpha_{in1} = g_{in}/g_1$",
    "alpha_B1": r"regulator valve $\alpha_{B1} = g_B/(g_1\sqrt{p_B})$",
    "alpha_e1": r"barrier throttle $\alpha_{e1} = g_e/g_1$",
    "alpha_TB1": r"face throttle $\alpha_{TB1}$ (at $u$ = 1)",
    "alpha_31": r"outer seal $\alpha_{31} = g_3/g_1$",
    "b": r"axial force law $b$ ($\tau = b\psi_1$)",
    "sigma": r"barrier area $\sigma = s_e/s_B$",
    "chi": r"push-off preload $\chi = F_{pr}/(p_B s_B)$",
    "dpsi": r"barrier margin $\Delta\psi = (p_e - p_1)/p_B$",
    "psi_in": r"supply pressure $\psi_{in} = p_{in}/p_B$",
}

#: exact output (a group of (2.18)) -> its physical quantity in ``dimensional`` and the scale it is the ratio to
DIMENSIONAL = {"u": ("z", "z_B"), "xi": ("x", "x_B"), "psi2": ("p2", "p_B"), "psi3": ("p3", "p_B"),
               "psi_e": ("p_e", "p_B"), "psi_cam": ("p_cam", "p_B")}
DIMENSIONAL_NAMES = tuple(name for name, _ in DIMENSIONAL.values())
#: the statistics that scale with the quantity (cv, spread and the counts do not)
SCALED = ("nominal", "mean", "std", "band_low", "band_high")

_P14 = "Pavlenko (2014), ch. 3"
_STATS = " ".join(f"{part}.*.{k}" for part in ("exact", "source") for k in ("cv", "spread", "valid", "invalid"))
_AFC_AMPLITUDES = "afc.nominal afc.mean afc.std afc.band_low afc.band_high afc.at.*.nominal " \
                  "afc.at.*.mean afc.at.*.std afc.quantiles.** afc.nominal_peaks[].amplitude"

_psi1 = shared("1", "ψ1", "discharge pressure ratio p1/p_B", source=f"{_P14}, Figs 3.3-3.4")


_count = shared("1", "", "counts, the band width k, the AFC's operating ratio and coefficients of variation")


_sampled = shared("1", "θ", "the sampled groups: distribution parameters, sample mean and std, correlations",
                  source=f"{_P14}, Eq. (2.18)")


_time = shared("s", "t", "wall time")


@record
class Scales(Record):
    """The bases of the source's groups (Pavlenko (2014), Eq. (2.18)): z = u z_B, p = ψ p_B, x = ξ x_B."""

    p_B: float = quantity("Pa", "p_B", "base pressure of the ratios ψ")
    z_B: float = quantity("m", "z_B", "base gap of the ratio u", "µm")
    x_B: float = quantity("m", "x_B", "base valve opening of the ratio ξ", "mm")


@record
class Reference(Record):
    """The headline numbers at the reference discharge ratio (the first grid point if it is not on the grid)."""

    psi1: float = _psi1()
    p1: float = quantity("Pa", "p1", "discharge pressure of the reference point", headline=1)
    z_mean: float = quantity("m", "z̄", "face gap, mean over the samples", "µm", headline=2)
    z_std: float = quantity("m", "σ_z", "face gap, standard deviation", "µm", headline=3)
    gap_spread: float = quantity("1", "δu", "face-gap spread kσ/mean (k: band_sigma)",
                                 source=f"{_P14}, conclusion 4 (about 0.20 with k = 3)", headline=4)
    Q_T_mean: float = quantity("m^3/s", "Q̄_T", "face leak, mean over the samples", headline=5)
    Q_T_std: float = quantity("m^3/s", "σ_Q", "face leak, standard deviation", headline=6)
    leak_spread: float = quantity("1", "δq_T", "face-leak spread kσ/mean (k: band_sigma)",
                                  source=f"{_P14}, conclusion 4 (about 0.25 with k = 3)", headline=7)
    saturated_fraction: float = quantity("1", "", "share of samples with the regulator valve on its stop",
                                         headline=8)


@record(kw_only=True)
class MonteCarloResult(TypedResult):
    """The Monte Carlo study: statistics of the exact statics and of the source's closed forms per discharge ratio,
    sensitivities and, optionally, the AFC amplitude.  The blocks by output name (``exact``, ``source``,
    ``dimensional``, ``sensitivity``, ``afc``) hold numbers whose unit is the output's (the extra declarations);
    ``raw`` the sampled arrays (samples x discharge ratios), not written."""

    title: str
    samples: int = quantity("1", "N", "samples")
    seed: int = _count()
    chunk_size: int = _count()
    executor: str
    band_sigma: float = _count()
    psi1: list[float] = _psi1()
    reference_psi1: float = _psi1()
    #: the names of the random groups, in the order of the sample arrays' columns
    parameters: list[str]
    #: group -> its distribution and parameters
    distributions: dict
    correlation: np.ndarray | None = _sampled()
    sample_mean: np.ndarray = _sampled()
    sample_std: np.ndarray = _sampled()
    #: output -> its statistics over the samples per discharge ratio (exact statics; the source's closed forms)
    exact: dict
    source: dict
    saturated_fraction: np.ndarray = quantity("1", "", "share of samples with the regulator valve on its stop")
    #: sensitivities, elasticities, first-order and Monte Carlo stds by output
    sensitivity: dict
    time_s: float = _time()
    time_monte_carlo_s: float = _time()
    # the physical values (None in a results.json written before them)
    scales: Scales | None = optional()
    p1: np.ndarray | None = quantity("Pa", "p1", "discharge pressures of the grid", optional=True)
    #: the physical gap, valve opening and pressures (z, x, p2, p3, p_e, p_cam) over the samples
    dimensional: dict | None = optional()
    reference: Reference | None = optional()
    afc: dict | None = optional()
    accuracy: dict
    raw: dict = unsaved(default_factory=dict)
    name = "montecarlo"

    def to_dict(self) -> dict:
        """The block, its failures last (in results.json also when there are none)."""
        return {k: v for k, v in super().to_dict().items() if k != "failures"} | {"failures": list(self.failures)}

    @property
    def discharge_ratios(self) -> list[float]:
        """The grid of discharge ratios psi1 = p1/p_B, dimensionless."""
        return self.psi1

    @property
    def gap_spread(self) -> np.ndarray:
        """Spread k sigma / mean of the face gap u (exact statics) at each discharge ratio, dimensionless
        (k = band_sigma; Pavlenko (2014), conclusion 4: about 0.20 at psi1 = 1 with k = 3)."""
        return np.asarray(self.exact["u"]["spread"])

    @property
    def leak_spread(self) -> np.ndarray:
        """Spread k sigma / mean of the face-throttle leak q_T = Q_T/Q_B (exact statics) at each discharge
        ratio, dimensionless (Pavlenko (2014), conclusion 4: about 0.25 at psi1 = 1 with k = 3)."""
        return np.asarray(self.exact["q_T"]["spread"])

    def verdict(self) -> tuple[bool, str]:
        """The one verdict: the face gap and leak at the reference discharge ratio with their spreads, and whether
        the exact statics solved for (nearly) every sample (more than MAX_INVALID_SHARE unsolved is a failure)."""
        q, r, k = QUANTITIES.find, self.reference, self.band_sigma
        invalid = sum(self.exact["u"]["invalid"])
        return not self.failures(), (
            f"at ψ1 = {r.psi1:g}: face gap {q('reference.z_mean').text(r.z_mean)} ± "
            f"{q('reference.z_std').text(r.z_std)} (spread {k:g}σ/mean {100 * r.gap_spread:.3g} %), face leak "
            f"{q('reference.Q_T_mean').text(r.Q_T_mean)} (spread {100 * r.leak_spread:.3g} %); "
            + (f"{invalid} of {self.samples * len(self.psi1)} sample solves without a converged exact solution, left "
               "out of the statistics" if invalid else "every sample has a converged exact solution"))

    def summary(self) -> str:
        ok, words = self.verdict()
        lines = [*failed_head(self.failures()),
                 f"monte carlo: {self.samples} samples x {len(self.psi1)} discharge ratios, seed {self.seed}, "
                 f"{self.executor}, {self.time_s:.2f} s; bands mean +- {self.band_sigma:g} sigma",
                 f"  {'ok' if ok else 'NOT OK'}: {words}", *QUANTITIES.lines(self.to_dict())]
        ex, dim, q = self.exact, self.dimensional, QUANTITIES.find
        units = {k: q(key).display for k, key in (("p", "p1"), ("z", "dimensional.z.mean"),
                                                  ("Q", "exact.Q_T.mean"))}
        lines.append(f"  {'psi1':>6s} {'p1 ' + units['p']:>10s} {'z ' + units['z']:>9s} {'std z':>7s} {'spread u':>8s} "
                     f"{'Q_T ' + units['Q']:>9s} {'spread q_T':>10s} saturated invalid")
        for j, p in enumerate(self.psi1):
            lines.append(f"  {p:6.3f} {significant(q('p1').shown(self.p1[j])):>10s} "
                         f"{significant(q('dimensional.z.mean').shown(dim['z']['mean'][j])):>9s} "
                         f"{significant(q('dimensional.z.std').shown(dim['z']['std'][j])):>7s} "
                         f"{significant(ex['u']['spread'][j]):>8s} "
                         f"{significant(q('exact.Q_T.mean').shown(ex['Q_T']['mean'][j])):>9s} "
                         f"{significant(ex['q_T']['spread'][j]):>10s} {self.saturated_fraction[j]:9.3f} "
                         f"{ex['u']['invalid'][j]:7d}")
        s = self.sensitivity
        for k in ("u", "q_T"):
            lines.append(f"  first-order std of {k} / Monte Carlo std: "
                         + ", ".join(f"{r:.3f}" for r in s["std_ratio"][k]))
        src, j = self.source, self._reference()
        lines.append(f"  validation against the source: at psi1 = {self.psi1[j]:g} the source's closed forms give "
                     f"{self.band_sigma:g} sigma / mean of u {src['u']['spread'][j]:.3f}, of q_T "
                     f"{src['q_T']['spread'][j]:.3f} (exact {ex['u']['spread'][j]:.3f}, {ex['q_T']['spread'][j]:.3f});"
                     " Pavlenko (2014), conclusion 4: 0.20 and 0.25")
        if self.afc is not None:
            a = self.afc
            om, amp = q("afc.at.x.omega"), q("afc.at.x.mean")
            lines.append(f"  AFC ({a['model']} model, {a['samples']} samples, {a['time_s']:.2f} s): "
                         + "; ".join(f"{k.replace('_', ' ')} {om.text(v['omega'])}: nominal "
                                     f"{amp.text(v['nominal'])}, mean {amp.text(v['mean'])}, cv {v['cv']:.3f}"
                                     for k, v in a["at"].items()))
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        """montecarlo_statics.csv: per discharge ratio the statistics of the source's groups, the leak flows (L/s)
        and, beside them, the gap (µm), valve opening (mm) and pressures (MPa); every header names its unit."""
        out = {}
        cols = {"psi1": self.psi1, "p1": self.p1, "saturated_fraction": self.saturated_fraction}
        stats = ("nominal", "mean", "std", "band_low", "band_high", "invalid")
        for part, keys in (("exact", OUTPUTS), ("source", SOURCE_OUTPUTS), ("dimensional", DIMENSIONAL_NAMES)):
            block = getattr(self, part)
            for k in keys:
                cols |= {f"{part}.{k}.{stat}": block[k][stat] for stat in stats if stat in block[k]}
        out["montecarlo_statics.csv"] = {name.replace(".", "_"): v for name, v in QUANTITIES.columns(cols, "").items()}
        sens = self.sensitivity
        # d output / d group, SI: the unit of each row's output in its own column (the groups are dimensionless)
        rows = {"psi1 [1]": [], "output": [], "unit": [], **{f"d_d_{n}": [] for n in self.parameters}}
        for j, p in enumerate(self.psi1):
            for k in SENSITIVITY_OUTPUTS:
                rows["psi1 [1]"].append(p)
                rows["output"].append(k)
                rows["unit"].append(QUANTITIES.find(f"sensitivity.jacobian.{k}").unit)
                for i, n in enumerate(self.parameters):
                    rows[f"d_d_{n}"].append(sens["jacobian"][k][j][i])
        out["montecarlo_sensitivities.csv"] = rows
        if self.afc is not None:
            a = self.afc
            out["montecarlo_afc.csv"] = QUANTITIES.columns({k: a[k] for k in ("omega", "nominal", "mean", "std",
                                                                              "band_low", "band_high")}, "afc")
        return out

    def _band(self, s: dict) -> tuple[np.ndarray, np.ndarray, str]:
        """The outer quantile band of a statistics block (respects skew), else mean +- k sigma."""
        qs = s.get("quantiles", {})
        if len(qs) >= 2:
            lo, hi = min(qs, key=float), max(qs, key=float)
            if float(lo) < 0.5 < float(hi):
                return (np.asarray(qs[lo], float), np.asarray(qs[hi], float),
                        f"{100 * float(lo):.3g}-{100 * float(hi):.5g} % quantiles")
        k = self.band_sigma
        return np.asarray(s["band_low"], float), np.asarray(s["band_high"], float), rf"mean $\pm {k:g}\sigma$"

    def _reference(self) -> int:
        return reference_index(self.psi1, self.reference_psi1)

    def figures(self) -> dict[str, Figure]:
        """Bands against the discharge ratio with the sensitivities (Figs 3.3-3.6), histograms of the
        headline outputs at the reference discharge ratio with the fitted normal, and the AFC bands."""
        psi1 = np.asarray(self.psi1, float)
        fig, axes = new_figure(figsize=(13, 4.6), ncols=3)
        for ax, k, lab in ((axes[0], "u", OUTPUT_NAMES["u"]), (axes[1], "q_T", OUTPUT_NAMES["q_T"])):
            for part, ls, fill, c in (("exact", "-", 0.15, "C0"), ("source", "--", 0.0, "C1")):
                s = getattr(self, part)[k]
                lo, hi, what = self._band(s)
                name = "exact statics" if part == "exact" else "source's closed forms"
                ax.plot(psi1, s["mean"], ls=ls, color=c, marker="o", ms=3, label=f"mean, {name}")
                if fill:
                    ax.fill_between(psi1, lo, hi, color=c, alpha=fill, lw=0)
                ax.plot(psi1, lo, color=c, ls=ls, lw=0.8, label=f"{what}, {name}")
                ax.plot(psi1, hi, color=c, ls=ls, lw=0.8)
            ax.plot(psi1, self.exact[k]["nominal"], "k:", label="deterministic (nominal groups)")
            ax.set_xlabel(r"discharge pressure ratio $\psi_1 = p_1/p_B$")
            ax.set_ylabel(lab)
            ax.grid(alpha=0.3)
            if self.scales is not None:  # the physical discharge pressure on top, in its display unit
                q = QUANTITIES.find("p1")
                twin_axis(ax, q.shown(self.scales.p_B), f"discharge pressure $p_1$, {q.display}", "x")
        if self.scales is not None:  # the face gap beside u = z/z_B (q_T is over a per-sample base flow: no axis)
            q = QUANTITIES.find("scales.z_B")
            twin_axis(axes[0], q.shown(self.scales.z_B), f"face gap z, {q.display}")
        sens = self.sensitivity
        j = self._reference()
        names = self.parameters
        y = np.arange(len(names))
        for off, k, c in ((-0.2, "u", "C0"), (0.2, "q_T", "C1")):
            axes[2].barh(y + off, sens["variance_share"][k][j], height=0.4, color=c, label=OUTPUT_NAMES[k])
        axes[2].set_yticks(y, [PARAMETER_NAMES.get(n, n) for n in names], fontsize=7)
        axes[2].invert_yaxis()
        axes[2].set_xlabel(f"share of first-order variance at $\\psi_1$ = {self.psi1[j]:g}")
        axes[2].legend(fontsize=7, loc="lower right")
        axes[2].grid(alpha=0.3, axis="x")
        seen = dict(zip(*reversed(axes[1].get_legend_handles_labels()), strict=True))
        fig.legend(list(seen.values()), list(seen), loc="outside lower center", ncols=3, fontsize=7)
        fig.suptitle(self.title, fontsize=9)
        figs = {"fig_montecarlo.png": Figure(
            fig, "Face gap, valve opening and leak over the samples against ψ1: mean and 0.135-99.865 % quantile "
            "bands; Pavlenko (2014), Figs. 3.8-3.9")}
        if self.raw.get("exact"):
            figs["fig_montecarlo_hist.png"] = Figure(
                self._histograms(j), "Distribution of the face gap and the face leak at the reference discharge "
                "ratio, with the fitted normal, ±3σ and the quantiles")
        if self.afc is not None:
            a = self.afc
            fig, ax = new_figure(figsize=(7, 4.8))
            q_omega, q_amp = QUANTITIES.find("afc.omega"), QUANTITIES.find("afc.mean")
            fw = unit_axis(ax, r"shaft speed $\omega$", q_omega.unit, q_omega.declared, "x", q_omega.beside)
            fa = unit_axis(ax, "face-gap amplitude $A_u$", q_amp.unit, q_amp.declared)
            omega = np.asarray(a["omega"], float) * fw
            ax.plot(omega, np.asarray(a["nominal"], float) * fa, "k:",
                    label=f"nominal: {MODEL_LABELS.get(a['model'], a['model'])}, {a['forcing']} forcing")
            line, = ax.plot(omega, np.asarray(a["mean"], float) * fa, color="C0", label="mean")
            lo, hi, what = self._band(a)
            ax.fill_between(omega, lo * fa, hi * fa, color="C0", alpha=0.15, lw=0.8, edgecolor="C0", label=what)
            ax.plot(omega, np.maximum(a["band_low"], 0) * fa, color="C1", lw=0.8, ls="--")
            ax.plot(omega, np.asarray(a["band_high"], float) * fa, color="C1", lw=0.8, ls="--",
                    label=rf"mean $\pm {self.band_sigma:g}\sigma$ (normal assumption)")
            ax.grid(alpha=0.3)
            fig.legend(loc="outside lower center", ncols=2, fontsize=7)
            src = ("Pavlenko (2014) Figs 3.7/3.10" if a["model"] == "program" else
                   "the source's Figs 3.7/3.10 use its program model")
            ax.set_title(f"{self.title}\nAFC Monte Carlo: {MODEL_LABELS.get(a['model'], a['model'])} model, "
                         f"{a['forcing']} forcing, {len(a['parameters'])} uncertain parameters\n({src})", fontsize=8)
            figs["fig_montecarlo_afc.png"] = Figure(
                fig, "AFC amplitude over the sampled parameters (by default the energy-consistent model under the "
                "physical forcing, its dynamic data uncertain): nominal, mean, the 0.135-99.865 % quantile band and "
                "the ±3σ lines")
        return figs

    def _histograms(self, j: int):
        """Histogram of each headline output (exact statics) at grid point j with the fitted normal,
        the mean +- k sigma and the outer quantiles marked."""
        k_sig = self.band_sigma
        fig, axes = new_figure(figsize=(10, 4.8), ncols=2)
        for ax, k in zip(axes, ("u", "q_T"), strict=True):
            y = np.asarray(self.raw["exact"][k])[:, j]
            y = y[np.isfinite(y)]
            m, sd = float(y.mean()), float(y.std())
            ax.hist(y, bins=80, density=True, color="C0", alpha=0.45, edgecolor="C0", lw=0.3,
                    label=f"exact statics, {y.size} samples")
            x = np.linspace(min(y.min(), m - k_sig * sd), max(y.max(), m + k_sig * sd), 400)
            ax.plot(x, np.exp(-0.5 * ((x - m) / sd) ** 2) / (sd * np.sqrt(2 * np.pi)), "k-", lw=1.2,
                    label=f"fitted normal (mean {m:.4g}, std {sd:.3g})")
            for v in (m - k_sig * sd, m + k_sig * sd):
                ax.axvline(v, color="k", ls="--", lw=0.8)
            lo, hi, what = self._band(self.exact[k])
            for v in (lo[j], hi[j]):
                ax.axvline(v, color="C3", ls="-", lw=1.0)
            ax.plot([], [], "k--", lw=0.8, label=rf"mean $\pm {k_sig:g}\sigma$")
            ax.plot([], [], color="C3", lw=1.0, label=what)
            ax.set_xlabel(OUTPUT_NAMES[k])
            ax.set_ylabel("probability density")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncols=2)
        fig.suptitle(f"{self.title}\ndistribution at the reference discharge ratio $\\psi_1$ = {self.psi1[j]:g}",
                     fontsize=9)
        return fig


MonteCarloResult.quantities = QUANTITIES = declarations(
    MonteCarloResult,
    Quantity("dimensional.z.**", "m", "z", "face gap over the samples: nominal, mean, std, bands, quantiles",
             "µm"),
    Quantity("dimensional.x.**", "m", "x", "valve opening over the samples", "mm"),
    Quantity("dimensional.p2.** dimensional.p3.** dimensional.p_e.** dimensional.p_cam.**", "Pa", "p",
             "disc-chamber, cavity, barrier-chamber and valve-chamber pressures over the samples"),
    Quantity(_STATS, "1", "cv, kσ/mean, N", "coefficient of variation, spread, valid and invalid samples"),
    Quantity("exact.Q_T.** exact.Q_e.** " + " ".join(f"sensitivity.{s}.{k}" for s in ("jacobian", "std_first_order",
                                                                                    "std_monte_carlo")
                                                   for k in ("Q_T", "Q_e")), "m^3/s", "Q_T, Q_e",
             "face and barrier leak flows over the samples (the jacobian: per unit of the group)"),
    Quantity("exact.** source.**", "1", "u, ξ, ψ, q", "the source's output groups over the samples (exact statics, "
             "the source's closed forms): nominal, mean, std, bands, quantiles", source=f"{_P14}, Figs 3.3-3.6"),
    Quantity("sensitivity.**", "1", "∂y/∂θ", "sensitivities, elasticities, first-order and Monte Carlo stds of "
             "the groups, their ratio and variance shares", source=f"{_P14}, §3.2"),
    Quantity("distributions.**", "1", "θ", "the sampled groups: distribution parameters, sample mean and std, "
             "correlations", source=f"{_P14}, Eq. (2.18)"),
    Quantity("afc.samples afc.psi1 afc.cv afc.spread afc.valid afc.invalid afc.at.*.cv", "1", "",
             "counts, the band width k, the AFC's operating ratio and coefficients of variation"),
    Quantity("afc.omega afc.at.*.omega afc.nominal_peaks[].omega", "rad/s", "ω", "frequency of the AFC",
             "rad/s"),
    Quantity(_AFC_AMPLITUDES, "m", "A_u", "face-gap amplitude over the samples (nominal, mean, std, bands, "
             "quantiles)", "µm", source=f"{_P14}, Fig. 3.7"),
    Quantity("afc.time_s", "s", "t", "wall time"),
)


@dataclass(frozen=True)
class Distribution:
    """One uncertain parameter: normal, lognormal, gauss12 (the source's sum of 12 uniforms, Fig. 3.1) by ``mean``
    (None: the model's nominal value) and ``std`` or ``cv``; uniform by ``low`` and ``high`` or as the others
    (:func:`autobal.analysis.numerics.sampling.marginals`).  In the parameter's unit (a group: 1)."""

    distribution: str
    mean: float | None = None
    std: float | None = None
    cv: float | None = None
    low: float | None = None
    high: float | None = None


@dataclass(frozen=True)
class Correlation:
    """The correlation coefficient ``rho`` of two uncertain parameters (Gaussian copula)."""

    between: tuple
    rho: float


@dataclass(frozen=True)
class Grid:
    """A logarithmic frequency grid: ``points`` from ``start`` to ``stop``, rad/s."""

    start: float
    stop: float
    points: int


@dataclass(frozen=True)
class AfcSpec:
    """The AFC Monte Carlo (Fig. 3.7): the linear ``model`` and its uncertain ``parameters`` (name ->
    :class:`Distribution`), ``samples`` in tasks of ``chunk_size``, at psi1 = ``operating_ratio`` under the
    ``forcing`` (appendix or physical), over the frequency grid ``omega``."""

    model: str
    samples: int
    chunk_size: int
    operating_ratio: float
    forcing: str
    omega: Grid
    parameters: dict


@dataclass(frozen=True)
class Spec:
    """What the Monte Carlo study computes (the validated ``analyses.montecarlo`` of a scene).

    Attributes
    ----------
    samples, seed, chunk_size : int
        Samples, the seed of their streams, samples per executor task.
    discharge_ratio : tuple of float
        psi1 = p1/p_B at which the statics are sampled.
    parameters : dict
        The uncertain groups of (2.18): name -> :class:`Distribution`.
    correlations : tuple of Correlation
    band_sigma : float
        k of the bands mean +- k sigma.
    quantiles : tuple of float
        The probabilities of the quantiles reported.
    sensitivity_step : float
        Relative step of the finite-difference check of the exact derivatives.
    afc : AfcSpec or None
        The AFC Monte Carlo (None: not run).
    """

    samples: int
    seed: int
    chunk_size: int
    discharge_ratio: tuple
    parameters: dict
    correlations: tuple
    band_sigma: float
    quantiles: tuple
    sensitivity_step: float
    afc: AfcSpec | None = None


def run(dev: DeviceDesign, spec: Spec, executor, title: str = "", solver=None, device=None) -> MonteCarloResult:
    """The Monte Carlo study of a device: spreads vs discharge ratio, sensitivities, first-order variance,
    and with ``spec.afc`` the AFC amplitude (``device``: the scene's device with its dynamics)."""
    t0 = time.perf_counter()
    names = list(spec.parameters)
    if dev.groups.regulator is None:
        bad = [n for n in names if n in REGULATOR_PARAMETERS]
        if bad:
            raise ScenarioError(f"analyses.montecarlo.parameters.{bad[0]}: not a parameter of this device "
                                f"(it has no regulator section)")
    if spec.afc is not None:
        afc_names(spec.afc.model, spec.afc.parameters)
    ev = evaluator(dev, names)
    margs = marginals(spec.parameters, ev.nominal())
    corr = correlation_matrix(names, spec.correlations) if spec.correlations else None
    sampler = Sampler(margs, corr, spec.seed)
    grid = tuple(float(p) for p in spec.discharge_ratio)
    task = Task(sampler, spec.samples, min(spec.chunk_size, spec.samples), design=dev, grid=grid)
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

    exact = {k: statistics(raw["exact"][k], spec.band_sigma, spec.quantiles) | {"nominal": nom[k]}
             for k in OUTPUTS}
    source = {k: statistics(raw["source"][k], spec.band_sigma, spec.quantiles)
              | {"nominal": np.asarray(cf_nom.get(k, np.nan), float) * np.ones(len(grid))} for k in SOURCE_OUTPUTS}
    sens = sensitivities(ev, sampler, grid, nominal_points, {k: exact[k]["std"] for k in SENSITIVITY_OUTPUTS},
                         spec.sensitivity_step)
    samples_X = raw["X"]
    sc = {k: float(dev.scales[k]) for k in ("p_B", "z_B", "x_B")}
    dim = dimensional(exact, sc)
    afc = None
    if spec.afc is not None:
        t1 = time.perf_counter()
        afc = afc_study(device, spec.afc, spec.seed, executor, spec.band_sigma, spec.quantiles)
        raw["afc"] = afc.pop("amplitude_samples")
        afc["time_s"] = time.perf_counter() - t1
    grid_list, saturated = list(grid), raw["saturated"].mean(axis=0)
    j = reference_index(grid_list, 1.0)
    res = MonteCarloResult(
        title=title, samples=spec.samples, seed=spec.seed, chunk_size=task.chunk_size,
        executor=executor.name, band_sigma=spec.band_sigma, psi1=grid_list, reference_psi1=1.0,
        parameters=names,
        distributions={m.name: {"distribution": m.kind, "mean": m.mean, "std": m.std,
                                **({"low": m.low, "high": m.high} if m.kind == "uniform" else {})} for m in margs},
        correlation=corr, sample_mean=samples_X.mean(axis=0), sample_std=samples_X.std(axis=0),
        exact=exact, source=source, saturated_fraction=saturated, sensitivity=sens,
        time_s=time.perf_counter() - t0, time_monte_carlo_s=t_mc,
        scales=Scales(**sc), p1=np.asarray(grid, float) * sc["p_B"], dimensional=dim,
        reference=Reference(
            psi1=grid_list[j], p1=float(grid_list[j] * sc["p_B"]), z_mean=float(dim["z"]["mean"][j]),
            z_std=float(dim["z"]["std"][j]), gap_spread=float(exact["u"]["spread"][j]),
            Q_T_mean=float(exact["Q_T"]["mean"][j]), Q_T_std=float(exact["Q_T"]["std"][j]),
            leak_spread=float(exact["q_T"]["spread"][j]), saturated_fraction=float(saturated[j])),
        afc=afc, accuracy=accuracy(afc, sens, raw), raw=raw,
        failures=[f"psi1 = {p:g}: the exact statics did not solve for {k} of {spec.samples} samples "
                  f"(more than {100 * MAX_INVALID_SHARE:g} %: the statistics would be of a selection)"
                  for p, k in zip(grid, exact["u"]["invalid"], strict=True)
                  if k > MAX_INVALID_SHARE * spec.samples])
    return explained(res, {"correlation": "no correlations given: the parameters are independent"},
                     "null where the valve opening xi has no spread (the valve on its stop at every sample) or the "
                     "source's closed form has no valve opening (the valve saturates)")


def dimensional(exact: dict, scales: dict) -> dict:
    """The gap, valve opening and pressures of the exact statics in SI beside their groups (z = u z_B,
    p = psi p_B ...; Pavlenko (2014), Eq. (2.18)): the statistics that scale with them."""
    out = {}
    for k, (name, base) in DIMENSIONAL.items():
        s = exact[k]
        out[name] = {stat: np.asarray(s[stat], float) * scales[base] for stat in SCALED} | {
            "quantiles": {q: np.asarray(v, float) * scales[base] for q, v in s["quantiles"].items()}}
    return out


def reference_index(psi1: list[float], reference_psi1: float) -> int:
    """Index of the reference discharge ratio on the grid (the first grid point if it is not on the grid)."""
    return psi1.index(reference_psi1) if reference_psi1 in psi1 else 0


def accuracy(afc: dict | None, sensitivity: dict, raw: dict) -> dict:
    """Error estimate of the main outputs, the spreads (k cv) and means of the face gap u and the leak q_T
    (exact statics and the source's forms) at every discharge ratio and, with the AFC study, of the
    amplitude at the operating speed and the nominal peaks: their Monte Carlo standard errors
    (:func:`relative_standard_errors`); beside it the largest balance residual of the accepted roots."""
    se_mean, se_spread = {}, {}
    for part in ("exact", "source"):
        for k in ("u", "q_T"):
            a, b = relative_standard_errors(raw[part][k])
            se_mean[f"{part}_{k}"], se_spread[f"{part}_{k}"] = a.tolist(), b.tolist()
    if afc is not None:
        a, b = relative_standard_errors(raw["afc"][:, len(afc["omega"]):])
        se_mean["afc_at"], se_spread["afc_at"] = a.tolist(), b.tolist()
    worst = max(np.nanmax(v) for v in se_spread.values())
    worst_mean = max(np.nanmax(v) for v in se_mean.values())
    res = raw.get("residual")
    return {"estimate": float(max(worst, worst_mean)),
            "spread_relative_standard_error": se_spread, "mean_relative_standard_error": se_mean,
            "max_root_residual": float(np.nanmax(res)) if res is not None and np.isfinite(res).any() else None,
            "root_residual_tolerance": RESIDUAL_TOL,
            "sensitivity_finite_difference_max_relative_error": max(
                sensitivity["finite_difference_max_relative_error"]),
            "how": "largest one-standard-error Monte Carlo error, relative, of the reported spreads (k sigma / "
                   "mean, delta method on the samples) and means of u and q_T (exact and source forms) at every "
                   "psi1 and of the AFC amplitude at omega0 and the peaks; every accepted Newton root has an "
                   "absolute balance residual <= root_residual_tolerance (largest: max_root_residual), far "
                   "below the sampling error"}
