"""The ``spinup_robust`` analysis of a scene: the robust profile beside the nominal optimum and the constant
ramps, on the design set and on a random validation sample (the exponential integrator, checked against
CVODES on a few validation rotors; each profile's worst design rotors re-simulated with CVODES).

``run(...)`` returns a :class:`RobustResult` (results.json block, CSV tables, figures: the profiles and their
deflection on the worst design rotor, the distribution of the validation peaks, the peak against the
critical-speed factor).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from autobal.analysis.quantities import Declarations, Quantity, significant
from autobal.analysis.result import Result, new_figure, with_statuses
from autobal.ocp import robust as rb
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.search import FAST_STEP, controls_on_mesh, grid_search
from autobal.ocp.simulation import Trajectory, best_within_limits, drive_use, resimulate
from autobal.ocp.solve import optimize
from autobal.ocp.spinup_study import RPM, deflection_axis, deflection_text, twin_axis
from autobal.ocp.transcription import DirectCollocation

QUANTILES = (0.5, 0.9, 0.99)
CHECKED = 4  # validation rotors re-simulated with CVODES to check the fast integrator
CVODES_WORST = 3  # design rotors re-simulated with CVODES per profile (its worst by the fast integrator)

_PROFILE = "profiles.*."
#: every number of the spinup_robust block: peaks delta/e (Pashkov (2010), Eq. (2)) with the physical deflection
#: (0-peak) e delta/e beside them in the summary; the rotors as factors on the nominal critical speed, damping and
#: liquid mass; the headline quantities first, in summary order
QUANTITIES = Declarations(
    Quantity("profiles.robust.validation_worst_over_e", "1", "δ*/e", "robust profile: worst peak over the "
             "validation rotors", headline=True),
    Quantity("profiles.nominal.validation_worst_over_e", "1", "δ*/e", "nominal optimum: worst peak over the "
             "validation rotors", headline=True),
    Quantity("profiles.ramp.validation_worst_over_e", "1", "δ*/e", "best ramp: worst peak over the validation rotors",
             headline=True),
    Quantity("profiles.robust.design_worst_over_e", "1", "δ*/e", "robust profile: worst peak over the design rotors "
             "(CVODES)", headline=True),
    Quantity("profiles.robust.nominal_peak_over_e", "1", "δ*/e", "robust profile: peak on the nominal rotor",
             headline=True),
    Quantity("omega_cr_rad_s", "rad/s", "ω_cr", "nominal critical speed", headline=True),
    Quantity("eccentricity_m", "m", "e", "eccentricity (a peak δ*/e is the deflection δ* = e δ*/e, 0-peak)", "µm"),
    Quantity(" ".join(_PROFILE + k for k in ("nominal_peak_over_e", "design_worst_over_e", "design_peaks_over_e",
                                             "validation_worst_over_e", "validation_mean_over_e",
                                             "validation_quantiles_over_e.**")),
             "1", "δ*/e", "peaks of a profile: nominal rotor, design set (worst, each), validation sample (worst, "
             "mean, quantiles)"),
    Quantity("critical_speed_spread", "1", "", "relative spread of the critical speed (± factor − 1)"),
    Quantity("damping_factor liquid_mass_factor", "1", "", "range of the factor on the damping / liquid mass"),
    Quantity("design_set active_design_rotors worst_design_rotor", "1", "",
             "design rotors as factors (critical speed, damping, liquid mass)"),
    Quantity("design_scenarios active_scenarios validation_samples seed", "1", "",
             "design rotors, those in the final NLP, validation rotors, seed of the sample"),
    Quantity("robust_collocation_worst_over_e", "1", "δ*/e", "worst collocation peak of the robust NLP"),
    Quantity("resimulation_rel_error validation_check_rel_error", "1", "",
             "relative difference: robust NLP vs CVODES; validation integrator vs CVODES"),
    Quantity("validation_step_tau", "1", "Δτ", "step of the validation integrator in Ω0 t"),
    Quantity("build_time_s solve_time_s nominal_build_time_s nominal_solve_time_s validation_time_s wall_time_s "
             "time_split.*", "s", "", "times: robust NLPs, nominal optimum, validation, the analysis; the wall time by "
             "part"),
    Quantity("rounds[].intervals rounds[].scenarios rounds[].active rounds[].iterations", "1", "",
             "an NLP solve of the scenario generation: intervals, design rotors (which), iterations"),
    Quantity("rounds[].build_time_s rounds[].solve_time_s", "s", "", "build and solve time of an NLP solve"),
    Quantity("rounds[].worst_design_peak_over_e rounds[].collocation_worst_over_e", "1", "δ*/e",
             "worst design peak after an NLP solve (re-simulated, collocation)"),
    Quantity("ramps[].alpha_rad_s2", "rad/s^2", "α", "acceleration of a constant ramp"),
    Quantity("ramps[].design_worst_over_e ramps[].validation_worst_over_e", "1", "δ*/e",
             "worst peak of a ramp over the design set / the validation sample"),
)


@dataclass
class RobustResult(Result):
    """The robust profile, the nominal optimum and the best constant ramp, each on the design set and on the
    validation sample (peaks delta/e)."""

    data: dict
    nominal_runs: dict  # key -> Trajectory on the nominal rotor
    worst_runs: dict  # key -> Trajectory on the robust profile's worst design rotor
    validation: dict  # key -> (samples,) peaks; "factors" -> (samples, 3)
    name = "spinup_robust"
    quantities = QUANTITIES

    KEYS = ("robust", "nominal", "ramp")
    COLORS = {"robust": "C3", "nominal": "C0", "ramp": "C2"}

    @property
    def worst_validation(self) -> dict:
        """Worst peak over the validation sample of each profile (robust, nominal, ramp), delta/e."""
        return {k: self.data["profiles"][k]["validation_worst_over_e"] for k in self.KEYS}

    @property
    def worst_design(self) -> dict:
        """Worst CVODES peak over the design set of each profile, delta/e."""
        return {k: self.data["profiles"][k]["design_worst_over_e"] for k in self.KEYS}

    def to_dict(self) -> dict:
        return self.data

    def verdict(self) -> tuple[bool | None, str]:
        return verdict(self.data)

    def summary(self) -> str:
        d = self.data
        ok, words = self.verdict()
        lines = [f"robust spin-up: {'ok' if ok else 'NOT OK'}: {words}", *QUANTITIES.lines(d),
                 f"  {d['design_scenarios']} design rotors ({d['active_scenarios']} in the final NLP), {d['method']}: "
                 f"build {d['build_time_s']:.2f} s, solve {d['solve_time_s']:.2f} s; validation on "
                 f"{d['validation_samples']} rotors ({d['executor']}, {d['validation_time_s']:.2f} s)",
                 "  wall time split: " + ", ".join(f"{k[:-7].replace('_', ' ')} {v:.2f} s" for k, v in
                                                   d.get("time_split", {}).items()),
                 f"  peaks δ*/e and the deflection δ* = e δ*/e, 0-peak (e = "
                 f"{QUANTITIES.find('eccentricity_m').text(d.get('eccentricity_m'))}):"]
        def pk(x):
            return deflection_text(x, d.get("eccentricity_m"))

        for k in self.KEYS:
            p = d["profiles"][k]
            lines.append(f"  {p['label']:28s} nominal rotor {pk(p['nominal_peak_over_e'])}, worst design "
                         f"{pk(p['design_worst_over_e'])}, validation worst {pk(p['validation_worst_over_e'])} "
                         f"(median {significant(p['validation_quantiles_over_e']['0.5'])} e, 99 % "
                         f"{significant(p['validation_quantiles_over_e']['0.99'])} e)")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        f = self.validation["factors"]
        cols = {"critical_speed_factor": f[:, 0], "damping_factor": f[:, 1], "liquid_mass_factor": f[:, 2]}
        cols |= {f"{k}_peak_over_e": self.validation[k] for k in self.KEYS}
        r = self.nominal_runs["robust"]
        design = {"critical_speed_factor": [], "damping_factor": [], "liquid_mass_factor": []}
        for row in self.data["design_set"]:
            for key, v in zip(design, row, strict=True):
                design[key].append(v)
        design |= {f"{k}_peak_over_e": self.data["profiles"][k]["design_peaks_over_e"] for k in self.KEYS}
        return {"spinup_robust_validation.csv": cols, "spinup_robust_design.csv": design,
                "spinup_robust_controls.csv": {"t_start_s": r.t_u, "alpha_rad_s2": r.alpha},
                "spinup_robust_ramps.csv": {k: [row[k] for row in self.data["ramps"]] for k in self.data["ramps"][0]}}

    def draw(self, ax) -> None:
        """Empirical distribution of the validation peaks of the three profiles."""
        for k in self.KEYS:
            v = np.sort(self.validation[k])
            lab = self.data["profiles"][k]["label"]
            ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", color=self.COLORS[k],
                    label=f"{lab} (worst {v[-1]:.3f} e)")
        ax.set_xlabel(r"peak deflection $\delta^*/e$")
        deflection_axis(ax, self.data.get("eccentricity_m"), "x")
        ax.set_ylabel(f"fraction of the {self.validation['factors'].shape[0]} validation rotors")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict:
        """Profiles and the deflection on the worst design rotor; validation distribution; peak against the
        critical-speed factor."""
        title = self.data["title"]
        fig, (a0, a1) = new_figure((8, 7), 2, 1, sharex=True)
        for k in self.KEYS:
            tr, tw = self.nominal_runs[k], self.worst_runs[k]
            lab = self.data["profiles"][k]["label"]
            a0.plot(tr.t, tr.omega, color=self.COLORS[k], label=lab)
            a1.plot(tw.t, tw.delta, color=self.COLORS[k],
                    label=f"{lab} (peak {deflection_text(tw.peak_delta, self.data.get('eccentricity_m'))})")
        wc = self.data["omega_cr_rad_s"]
        a0.axhline(wc, color="k", ls=":", lw=0.8,
                   label="nominal critical speed " + QUANTITIES.find("omega_cr_rad_s").text(wc))
        a0.set_ylabel(r"speed $\omega$, rad/s")
        twin_axis(a0, RPM, "rpm")
        w = self.data["worst_design_rotor"]
        a1.set_title(f"on the robust profile's worst design rotor (critical speed x{w[0]:.3g}, damping x{w[1]:.3g}"
                     + (f", liquid x{w[2]:.3g}" if self.data["liquid"] else "") + ")", fontsize=8, loc="left")
        a1.set_ylabel(r"deflection $\delta/e$")
        deflection_axis(a1, self.data.get("eccentricity_m"))
        a1.set_xlabel("time t, s")
        for ax in (a0, a1):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(title, fontsize=8)
        fig2, ax2 = new_figure((8.5, 4.8))
        self.draw(ax2)
        fig2.suptitle(title, fontsize=8)
        fig3, ax3 = new_figure((8.5, 4.8))
        f = self.validation["factors"]
        for k in self.KEYS:
            ax3.scatter(f[:, 0], self.validation[k], s=3, color=self.COLORS[k], alpha=0.5,
                        label=self.data["profiles"][k]["label"])
        ax3.set_xlabel("critical-speed factor (1 = nominal)")
        ax3.set_ylabel(r"peak deflection $\delta^*/e$")
        deflection_axis(ax3, self.data.get("eccentricity_m"))
        ax3.grid(alpha=0.3)
        ax3.legend(fontsize=7, markerscale=4)
        fig3.suptitle(title, fontsize=8)
        return {"spinup_robust_profiles.png": fig, "spinup_robust_distribution.png": fig2,
                "spinup_robust_scatter.png": fig3}


def verdict(d: dict) -> tuple[bool | None, str]:
    """The robust spin-up's one verdict from its results.json block: the robust profile's worst peak over the
    validation rotors against the nominal optimum's and the best ramp's (a ramp outside the drive limits is shown,
    never compared)."""
    w = {k: d["profiles"][k]["validation_worst_over_e"] for k in RobustResult.KEYS}
    ramp_ok = d["profiles"]["ramp"].get("within_drive_limits") is not False

    def pk(x):
        return deflection_text(x, d.get("eccentricity_m"))

    ok = w["robust"] < min(w["nominal"], w["ramp"] if ramp_ok else math.inf)
    return ok, (f"worst peak over {d.get('validation_samples', 'the')} validation rotors: robust {pk(w['robust'])}, "
                f"nominal optimum {pk(w['nominal'])}, best ramp {pk(w['ramp'])}"
                + ("" if ramp_ok else " (outside the drive limits, not compared)"))


def _on(ocp: SpinupOcp, factors, profile: rb.Profile) -> Trajectory:
    o = rb.scenario_ocps(ocp, np.atleast_2d(factors))[0]
    u, h = profile.on(o)
    return resimulate(o, u, h, profile.label, points=8)


def best_ramp_within_limits(ocp: SpinupOcp, ramps: list[rb.Profile], worst: np.ndarray
                            ) -> tuple[int, rb.Profile, dict]:
    """The ramp with the smallest worst peak among those that keep the drive limits on the nominal rotor (CVODES,
    :func:`autobal.ocp.simulation.drive_use`, the spin-up study's check), labelled as the best ramp; when none
    keeps them, the smallest of all, labelled as outside the drive limits.

    Parameters
    ----------
    ocp : SpinupOcp
        The nominal problem (SI).
    ramps : list of Profile
        The constant ramps.
    worst : ndarray, shape (len(ramps),)
        Their worst peaks, delta/e.

    Returns
    -------
    tuple
        (index, the labelled Profile, {index: drive use} of every ramp).
    """
    use = {i: drive_use(ocp, _on(ocp, [1.0, 1.0, 1.0], p)) for i, p in enumerate(ramps)}
    ib = best_within_limits(dict(enumerate(np.asarray(worst, float))), use)
    label = "best {}"
    if ib is None:
        ib, label = int(np.argmin(worst)), "best {} (outside the drive limits: no ramp keeps them)"
    return ib, rb.Profile(label.format(ramps[ib].label), ramps[ib].u), use


def robust_starts(ocp: SpinupOcp, factors: np.ndarray, nominal: rb.Profile, ramps: list[rb.Profile],
                  ramp_peaks: np.ndarray) -> list[rb.Profile]:
    """Starts of the robust NLP: the nominal optimum, the ramp with the smallest worst design peak and the
    global search's two best three-phase profiles on that ramp's worst design rotor (the robust optimum
    depends on the start: docs/dev/spinup_robust.md, "Build and solve").

    Parameters
    ----------
    ocp : SpinupOcp
        The nominal problem (SI).
    factors : ndarray, shape (S, 3)
        The design set.
    nominal : Profile
        The nominal optimum.
    ramps : list of Profile
        The constant ramps.
    ramp_peaks : ndarray, shape (S, len(ramps))
        Their peaks on the design set (:func:`autobal.ocp.robust.fast_peaks`), delta/e.

    Returns
    -------
    list of Profile
        On the ramps' control intervals.
    """
    ib = int(np.argmin(ramp_peaks.max(axis=0)))
    worst = int(np.argmax(ramp_peaks[:, ib]))
    o = rb.scenario_ocps(ocp, factors[[worst]])[0]
    n = ramps[ib].u.size
    return [nominal, ramps[ib], *[rb.Profile(f"global search on design rotor {worst}", controls_on_mesh(o, p, n))
                                  for p in grid_search(o, keep=2).params]]


def run(ocp: SpinupOcp, method: DirectCollocation, uncertainty: rb.Uncertainty, design_points: int,
        samples: int, seed: int, ramps: int, executor, title: str = "", multistart: bool = True,
        options: dict | None = None) -> RobustResult:
    """Nominal optimum, robust optimum over the design grid, constant ramps; all validated on a sample.

    Parameters
    ----------
    ocp : SpinupOcp
        The nominal problem (SI), objective peak_deflection.
    method : DirectCollocation
        The transcription of every scenario.
    uncertainty : Uncertainty
        The ranges of the rotor (factors).
    design_points : int
        Grid points per uncertain quantity.
    samples, seed : int
        Size and seed of the validation sample.
    ramps : int
        Constant ramps compared.
    executor
        Where the validation chunks run (:func:`autobal.analysis.executor.make`).
    title : str
        The scene's title.
    multistart : bool
        Multi-start of the nominal optimum.
    options : dict, optional
        IPOPT options.

    Returns
    -------
    RobustResult
        Peaks in delta/e, times in s.
    """
    n = method.intervals
    t_start = time.perf_counter()
    nominal = optimize(ocp, method, multistart, options)
    t_nominal = time.perf_counter() - t_start
    pn = rb.Profile("nominal optimum", nominal.solution.u[:n])
    family = rb.ramp_family(ocp, n, ramps)
    F = uncertainty.grid(design_points)
    t0 = time.perf_counter()
    ramp_peaks = rb.fast_peaks(ocp, F, family)
    design_ramps = ramp_peaks.max(axis=0)
    starts = robust_starts(ocp, F, pn, family, ramp_peaks)
    t_starts = time.perf_counter() - t0
    ro = rb.optimize_robust_refined(ocp, F, method, starts, nominal.score**2, options)
    profiles = [ro.profile, pn, *family]
    t0 = time.perf_counter()
    factors, peaks = rb.validate(ocp, uncertainty, profiles, samples, seed, executor)
    t_val = time.perf_counter() - t0
    ramp_worst = peaks[:, 2:].max(axis=0)
    ib, best_ramp, ramp_use = best_ramp_within_limits(ocp, family, ramp_worst)
    chosen = {"robust": (ro.profile, peaks[:, 0]), "nominal": (pn, peaks[:, 1]),
              "ramp": (best_ramp, peaks[:, 2 + ib])}
    # the design set's peaks by the fast integrator, each profile's CVODES_WORST worst rotors re-simulated by CVODES
    fast_design = rb.fast_peaks(ocp, F, [p for p, _ in chosen.values()])
    design = {}
    for j, (k, (p, _)) in enumerate(chosen.items()):
        worst = np.argsort(-fast_design[:, j])[:CVODES_WORST]
        design[k] = fast_design[:, j].copy()
        design[k][worst] = rb.cvodes_peaks(ocp, F[worst], p)
    worst_rotor = F[int(np.argmax(design["robust"]))]
    check = rb.cvodes_peaks(ocp, factors[:CHECKED], ro.profile)
    fast_err = float(np.max(np.abs(peaks[:CHECKED, 0] / check - 1)))
    nominal_runs = {k: _on(ocp, [1.0, 1.0, 1.0], p) for k, (p, _) in chosen.items()}
    worst_runs = {k: _on(ocp, worst_rotor, p) for k, (p, _) in chosen.items()}
    prof = {}
    for k, (p, v) in chosen.items():
        prof[k] = {"label": p.label, "nominal_peak_over_e": nominal_runs[k].peak_delta,
                   "design_peaks_over_e": design[k].tolist(), "design_worst_over_e": float(design[k].max()),
                   "validation_worst_over_e": float(v.max()), "validation_mean_over_e": float(v.mean()),
                   "validation_quantiles_over_e": {str(q): float(np.quantile(v, q)) for q in QUANTILES}}
    prof["ramp"]["within_drive_limits"] = ramp_use[ib]["within_drive_limits"]
    data = {
        "title": title, "method": method.label, "omega_cr_rad_s": ocp.params.omega_cr, "eccentricity_m": ocp.params.e,
        "critical_speed_spread": uncertainty.critical_speed_spread,
        "damping_factor": list(uncertainty.damping_factor), "liquid": uncertainty.liquid_mass_factor is not None,
        "liquid_mass_factor": list(uncertainty.liquid_mass_factor) if uncertainty.liquid_mass_factor else None,
        "design_set": F.tolist(), "design_scenarios": len(F), "active_scenarios": len(ro.active),
        "active_design_rotors": F[ro.active].tolist(), "worst_design_rotor": worst_rotor.tolist(),
        "robust_collocation_worst_over_e": ro.collocation_worst,
        "resimulation_rel_error": abs(ro.collocation_worst - design["robust"].max()) / design["robust"].max(),
        "build_time_s": ro.build_time_s, "solve_time_s": ro.solve_time_s, "rounds": ro.rounds,
        "nominal_build_time_s": nominal.build_time_s,
        "nominal_solve_time_s": sum(r.get("solve_time_s", 0.0) for r in nominal.starts),
        "validation_samples": int(samples), "seed": int(seed), "executor": executor.name,
        "validation_time_s": t_val, "validation_step_tau": FAST_STEP,
        "validation_check_rel_error": fast_err,
        "profiles": prof,
        "ramps": [{"label": p.label, "alpha_rad_s2": float(p.u[0] * ocp.alpha_max),
                   "design_worst_over_e": float(d), "validation_worst_over_e": float(w),
                   "within_drive_limits": ramp_use[i]["within_drive_limits"],
                   "violated": ", ".join(ramp_use[i]["violated"])}
                  for i, (p, d, w) in enumerate(zip(family, design_ramps, ramp_worst, strict=True))],
        "accuracy": {"estimate": fast_err,
                     "how": f"largest relative difference of the validation integrator (exponential, step "
                            f"{FAST_STEP} in Omega0 t) against CVODES on {CHECKED} validation rotors"},
    }
    validation = {"factors": factors} | {k: v for k, (_, v) in chosen.items()}
    # the wall time by part (s): the nominal optimum (global search, multi-start, its builds and solves), the
    # robust starts (the ramps on the design set, the global search), the robust NLPs' builds and solves, the
    # validation; rest: the scenario generation's design-set checks and the CVODES re-simulations
    split = {"nominal_optimum": t_nominal, "robust_starts": t_starts, "robust_build": ro.build_time_s,
             "robust_solve": ro.solve_time_s, "validation": t_val}
    data["wall_time_s"] = time.perf_counter() - t_start
    split["rest"] = data["wall_time_s"] - sum(split.values())
    data["time_split"] = {f"{k}_time_s": v for k, v in split.items()}
    data = with_statuses(data, {"liquid_mass_factor": "the rotor has no liquid block (or its mass is not uncertain)"})
    return RobustResult(data, nominal_runs, worst_runs, validation)
