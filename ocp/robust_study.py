"""The ``spinup_robust`` analysis of a scene: the robust profile beside the nominal optimum and the constant
ramps, on the design set and on a random validation sample (the exponential integrator, checked against
CVODES on a few validation rotors; each profile's worst design rotors re-simulated with CVODES).

``run(...)`` returns a :class:`RobustResult` (results.json block, CSV tables, figures: the profiles and their
deflection on the worst design rotor, the distribution of the validation peaks, the peak against the
critical-speed factor); the modal rotor's ``ross_spinup_robust`` a :class:`ModalRobustResult`.
"""

from __future__ import annotations

import math
import time
from dataclasses import KW_ONLY, field

import numpy as np

from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record, unsaved
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Quantity, significant
from autobal.analysis.run.result import new_figure, speed_axis, unit_axis
from autobal.ocp import robust as rb
from autobal.ocp.columns import headed
from autobal.ocp.drive_profile import drive_table
from autobal.ocp.modal_search import grid_search as modal_grid_search
from autobal.ocp.modal_search import phase_profiles
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.protocol import PEAK_KEY
from autobal.ocp.search import FAST_STEP, controls_on_mesh, grid_search
from autobal.ocp.simulation import Trajectory, best_within_limits, drive_use, require_resimulations, resimulate
from autobal.ocp.spinup_study import deflection_axis, deflection_text
from autobal.ocp.time_optimal import minimum_peak
from autobal.ocp.transcription import DirectCollocation

QUANTILES = (0.5, 0.9, 0.99)
CHECKED = 4  # validation rotors re-simulated with CVODES to check the fast integrator
CVODES_WORST = 3  # design rotors re-simulated with CVODES per profile (its worst by the fast integrator)

PEAK_SYMBOL = {"1": "δ*/e", "m": "r*"}


def _peak(unit: str, description: str = "peaks of a profile: nominal rotor, design set (worst, each), validation "
          "sample (worst, mean, quantiles)", headline: int = 0):
    """A peak of the block in ``unit`` ("1": delta/e, Pashkov (2010), Eq. (2); "m": the modal rotor's, shown in
    µm): the Jeffcott rotor's block has the one, the modal rotor's the other."""
    return quantity(unit, PEAK_SYMBOL[unit], description, "" if unit == "1" else "µm", headline=headline,
                    optional=True)


def _either(over_e, m):
    """The peak the block has: delta/e (Jeffcott rotor) or m (modal rotor)."""
    return m if over_e is None else over_e


class _Worst:
    """The worst peaks of a profile or a ramp in the block's ``peak_unit``, whichever its fields hold."""

    @property
    def design_worst(self) -> float:
        """Worst peak over the design set (CVODES), in the block's ``peak_unit``."""
        return _either(self.design_worst_over_e, self.design_worst_m)

    @property
    def validation_worst(self) -> float:
        """Worst peak over the validation sample, in the block's ``peak_unit``."""
        return _either(self.validation_worst_over_e, self.validation_worst_m)


@record
class Profile(_Worst, Record):
    """A profile's peaks on the nominal rotor, the design set (CVODES on its worst) and the validation sample, in the
    block's ``peak_unit`` (the ``*_over_e`` fields for the Jeffcott rotor, ``*_m`` for the modal rotor)."""

    label: str
    nominal_peak_over_e: float | None = _peak("1")
    nominal_peak_m: float | None = _peak("m")
    design_peaks_over_e: list[float] | None = _peak("1")
    design_peaks_m: list[float] | None = _peak("m")
    design_worst_over_e: float | None = _peak("1")
    design_worst_m: float | None = _peak("m")
    validation_worst_over_e: float | None = _peak("1")
    validation_worst_m: float | None = _peak("m")
    validation_mean_over_e: float | None = _peak("1")
    validation_mean_m: float | None = _peak("m")
    #: quantile ("0.5", "0.9", "0.99") -> peak
    validation_quantiles_over_e: dict[str, float] | None = optional()
    validation_quantiles_m: dict[str, float] | None = optional()

    @property
    def nominal_peak(self) -> float:
        """Peak on the nominal rotor (re-simulated), in the block's ``peak_unit``."""
        return _either(self.nominal_peak_over_e, self.nominal_peak_m)

    @property
    def design_peaks(self) -> list[float]:
        """Peak on each design rotor, in the block's ``peak_unit``."""
        return _either(self.design_peaks_over_e, self.design_peaks_m)

    @property
    def validation_quantiles(self) -> dict[str, float]:
        """Quantile ("0.5", "0.9", "0.99") -> peak over the validation sample, in the block's ``peak_unit``."""
        return _either(self.validation_quantiles_over_e, self.validation_quantiles_m)


_ROBUST = "robust profile: worst peak over the validation rotors"


@record
class RobustProfile(Profile):
    """The robust profile: its worst validation and design peaks and its peak on the nominal rotor are headline."""

    nominal_peak_over_e: float | None = _peak("1", "robust profile: peak on the nominal rotor", 5)
    nominal_peak_m: float | None = _peak("m", "robust profile: peak on the nominal rotor", 5)
    design_worst_over_e: float | None = _peak("1", "robust profile: worst peak over the design rotors (CVODES)", 4)
    design_worst_m: float | None = _peak("m", "robust profile: worst peak over the design rotors (CVODES)", 4)
    validation_worst_over_e: float | None = _peak("1", _ROBUST, 1)
    validation_worst_m: float | None = _peak("m", _ROBUST, 1)


_NOMINAL = "nominal optimum: worst peak over the validation rotors"


@record
class NominalProfile(Profile):
    """The nominal optimum: its worst validation peak is headline."""

    validation_worst_over_e: float | None = _peak("1", _NOMINAL, 2)
    validation_worst_m: float | None = _peak("m", _NOMINAL, 2)


_RAMP = "best ramp: worst peak over the validation rotors"


@record
class RampProfile(Profile):
    """The best ramp: its worst validation peak is headline; whether it keeps the drive limits (None: no drive
    data)."""

    validation_worst_over_e: float | None = _peak("1", _RAMP, 3)
    validation_worst_m: float | None = _peak("m", _RAMP, 3)
    _: KW_ONLY
    within_drive_limits: bool | None


@record
class Profiles(Record):
    robust: RobustProfile
    nominal: NominalProfile
    ramp: RampProfile

    def items(self) -> list[tuple[str, Profile]]:
        """(key, profile) of the three profiles compared, in the order of the tables and figures."""
        return [("robust", self.robust), ("nominal", self.nominal), ("ramp", self.ramp)]


def _count(**kw):
    return quantity("1", "", "an NLP solve of the scenario generation: intervals, design rotors (which), iterations",
                    optional=True, **kw)


def _nlp_time():
    return quantity("s", "", "build and solve time of an NLP solve", optional=True)


def _round_peak(unit: str):
    return _peak(unit, "worst design peak after an NLP solve (re-simulated, collocation)")


@record
class Round(Record):
    """One NLP solve of the scenario generation (a failed solve has only its start, scenarios and status)."""

    start: str
    intervals: int | None = _count()
    scenarios: int | None = _count()
    active: list[int] | None = _count()
    status: str | None = optional()
    iterations: int | None = _count()
    solve_time_s: float | None = _nlp_time()
    build_time_s: float | None = _nlp_time()
    worst_design_peak_over_e: float | None = _round_peak("1")
    worst_design_peak_m: float | None = _round_peak("m")
    collocation_worst_over_e: float | None = _round_peak("1")
    collocation_worst_m: float | None = _round_peak("m")

    @property
    def worst_design_peak(self) -> float | None:
        """Worst design peak after the solve (re-simulated), in the block's ``peak_unit``; None for a failed solve."""
        return _either(self.worst_design_peak_over_e, self.worst_design_peak_m)


def _ramp_peak(unit: str):
    return _peak(unit, "worst peak of a ramp over the design set / the validation sample")


@record
class Ramp(_Worst, Record):
    """A constant ramp: its worst peaks and whether it keeps the drive limits (None: no drive data)."""

    label: str
    alpha_rad_s2: float = quantity("rad/s^2", "α", "acceleration of a constant ramp")
    design_worst_over_e: float | None = _ramp_peak("1")
    design_worst_m: float | None = _ramp_peak("m")
    validation_worst_over_e: float | None = _ramp_peak("1")
    validation_worst_m: float | None = _ramp_peak("m")
    _: KW_ONLY
    within_drive_limits: bool | None
    violated: str



def _factor_range():
    return quantity("1", "", "range of the factor on the damping / liquid mass")


def _rotors():
    return quantity("1", "", "design rotors as factors (critical speed, damping, liquid mass)")


def _time():
    return quantity("s", "", "times: the nominal optimum's NLP build and solve, the analysis")


def _model(**kw):
    return quantity("1", "", "modes of the reduced rotor; the nodes whose deflection counts", optional=True, **kw)


@record
class RobustResult(TypedResult):
    """The robust profile, the nominal optimum and the best constant ramp, each on the design set and on the
    validation sample (peaks in the unit the block states, ``peak_unit``: delta/e for the Jeffcott rotor (Pashkov
    (2010), Eq. (2), the deflection e delta/e, 0-peak, beside them in the summary), m for the modal rotor (shown in
    µm)); the rotors as factors on the nominal critical speed, damping and liquid mass.  The run also holds the
    re-simulations its figures draw and the validation sample's peaks (None in a Result loaded from
    results.json)."""

    title: str
    method: str
    peak_unit: str
    omega_cr_rad_s: float | None = quantity("rad/s", "ω_cr", "nominal critical speed (the lowest below the final "
                                                              "speed)", headline=6)
    _: KW_ONLY
    eccentricity_m: float | None = quantity("m", "e", "eccentricity (a peak δ*/e is the deflection δ* = e δ*/e, "
                                                      "0-peak)", "µm", optional=True)
    validation_step_tau: float | None = quantity("1", "Δτ", "step of the validation integrator in Ω0 t",
                                                 optional=True)
    nodes: list[int] | None = _model()
    modes: int | None = _model()
    critical_speed_spread: float = quantity("1", "", "relative spread of the critical speed (± factor − 1)")
    damping_factor: list[float] = _factor_range()
    liquid: bool
    liquid_mass_factor: list[float] | None = _factor_range()
    design_set: list[list[float]] = _rotors()
    design_scenarios: int = quantity("1", "", "design rotors (grid)")
    active_scenarios: int = quantity("1", "", "design rotors in the final NLP (binding)")
    active_design_rotors: list[list[float]] = _rotors()
    worst_design_rotor: list[float] = _rotors()
    robust_collocation_worst_over_e: float | None = _peak("1", "worst collocation peak of the robust NLP")
    robust_collocation_worst_m: float | None = _peak("m", "worst collocation peak of the robust NLP")
    resimulation_rel_error: float = quantity("1", "", "relative difference, robust NLP vs CVODES")
    build_time_s: float = quantity("s", "", "build time (robust NLPs)")
    solve_time_s: float = quantity("s", "", "solve time (robust NLPs)")
    rounds: list[Round]
    nominal_build_time_s: float = _time()
    nominal_solve_time_s: float = _time()
    validation_samples: int = quantity("1", "", "validation rotors")
    seed: int = quantity("1", "", "seed of the validation sample")
    executor: str
    validation_time_s: float = quantity("s", "", "validation time")
    validation_check_rel_error: float = quantity("1", "", "validation integrator against CVODES (largest relative "
                                                          "difference)")
    profiles: Profiles
    ramps: list[Ramp]
    accuracy: dict
    wall_time_s: float = _time()
    #: part -> its wall time, s
    time_split: dict[str, float] = field(default_factory=dict)
    nominal_runs: dict | None = unsaved()  # key -> re-simulation on the nominal rotor
    worst_runs: dict | None = unsaved()  # key -> re-simulation on the robust profile's worst design rotor
    validation: dict | None = unsaved()  # key -> (samples,) peaks; "factors" -> (samples, 3)
    name = "spinup_robust"
    #: figure -> its caption
    CAPTIONS = {"profiles": "Robust spin-up: speed of the robust profile, the nominal optimum and the best ramp, and "
                            "their deflection on the worst design rotor",
                "distribution": "Robust spin-up: distribution of the peak deflection over the validation rotors, each "
                                "profile",
                "scatter": "Robust spin-up: peak deflection of each validation rotor against its critical-speed factor"}
    null_reasons = {"liquid_mass_factor": "the rotor has no liquid block (or its mass is not uncertain)",
                    "omega_cr_rad_s": "no critical speed below the final speed",
                    "within_drive_limits": "no drive torque data (the scene's drive)"}

    KEYS = ("robust", "nominal", "ramp")
    COLORS = {"robust": "C3", "nominal": "C0", "ramp": "C2"}

    @property
    def worst_validation(self) -> dict:
        """Worst peak over the validation sample of each profile (robust, nominal, ramp), in :attr:`peak_unit`."""
        return {k: p.validation_worst for k, p in self.profiles.items()}

    @property
    def worst_design(self) -> dict:
        """Worst CVODES peak over the design set of each profile, in :attr:`peak_unit`."""
        return {k: p.design_worst for k, p in self.profiles.items()}

    @property
    def robust_collocation_worst(self) -> float:
        """Worst collocation peak of the robust NLP, in :attr:`peak_unit`."""
        return _either(self.robust_collocation_worst_over_e, self.robust_collocation_worst_m)

    def peak_text(self, x) -> str:
        """A peak of the block as read: delta/e with the deflection e delta/e beside it, or in µm."""
        return peak_text(x, self.peak_unit, self.eccentricity_m)

    def verdict(self) -> tuple[bool | None, str]:
        return verdict(self.profiles, self.validation_samples, self.peak_unit, self.eccentricity_m)

    def _shown(self) -> tuple[float, str, str]:
        """(factor, axis label, CSV suffix) of the peaks as a person reads them: delta/e, or µm."""
        if self.peak_unit == "1":
            return 1.0, r"peak deflection $\delta^*/e$", "over_e"
        q = QUANTITIES.find("profiles.robust.validation_worst_m")
        return q.shown(1.0), f"peak deflection r*, {q.display} 0-peak", q.display.replace("µ", "u")

    def summary(self) -> str:
        ok, words = self.verdict()
        if self.peak_unit == "1":
            unit_line = ("  peaks δ*/e and the deflection δ* = e δ*/e, 0-peak (e = "
                         f"{QUANTITIES.find('eccentricity_m').text(self.eccentricity_m)}):")

            def quantile(x):
                return f"{significant(x)} e"
        else:
            unit_line = f"  peaks r*, the largest whirl radius over the nodes {self.nodes}, 0-peak:"
            quantile = self.peak_text
        lines = [f"robust spin-up: {'ok' if ok else 'NOT OK'}: {words}", *self.quantities.lines(self.to_dict()),
                 f"  {self.design_scenarios} design rotors ({self.active_scenarios} in the final NLP), {self.method}: "
                 f"build {self.build_time_s:.2f} s, solve {self.solve_time_s:.2f} s; validation on "
                 f"{self.validation_samples} rotors ({self.executor}, {self.validation_time_s:.2f} s)",
                 "  wall time split: " + ", ".join(f"{k[:-7].replace('_', ' ')} {v:.2f} s" for k, v in
                                                   self.time_split.items()),
                 unit_line]
        for _, p in self.profiles.items():
            q = p.validation_quantiles
            lines.append(f"  {p.label:28s} nominal rotor {self.peak_text(p.nominal_peak)}, worst design "
                         f"{self.peak_text(p.design_worst)}, validation worst {self.peak_text(p.validation_worst)} "
                         f"(median {quantile(q['0.5'])}, 99 % {quantile(q['0.99'])})")
        return "\n".join(lines)

    def _runs(self):
        require_resimulations(self.name, self.nominal_runs)

    def tables(self) -> dict[str, dict]:
        """The tables headed 'name [unit]' in their display units (:func:`autobal.ocp.columns.headed`): peaks delta/e
        (``*_peak_over_e``) or m shown in µm (``*_peak``), as the block's ``peak_unit``."""
        self._runs()
        name = "_over_e" if self.peak_unit == "1" else ""
        f = self.validation["factors"]
        cols = {"critical_speed_factor": f[:, 0], "damping_factor": f[:, 1], "liquid_mass_factor": f[:, 2]}
        cols |= {f"{k}_peak{name}": self.validation[k] for k in self.KEYS}
        r = self.nominal_runs["robust"]
        design = {"critical_speed_factor": [], "damping_factor": [], "liquid_mass_factor": []}
        for row in self.design_set:
            for key, v in zip(design, row, strict=True):
                design[key].append(v)
        design |= {f"{k}_peak{name}": np.asarray(p.design_peaks) for k, p in self.profiles.items()}
        ramps = {"label": [p.label for p in self.ramps], "acceleration": [p.alpha_rad_s2 for p in self.ramps],
                 f"design_worst{name}": [p.design_worst for p in self.ramps],
                 f"validation_worst{name}": [p.validation_worst for p in self.ramps],
                 "within_drive_limits": [p.within_drive_limits for p in self.ramps],
                 "violated": [p.violated for p in self.ramps]}
        tables = {f"{self.name}_validation.csv": cols, f"{self.name}_design.csv": design,
                  f"{self.name}_controls.csv": {"t_start": r.t_u, "acceleration": r.alpha},
                  f"{self.name}_ramps.csv": ramps, "drive_profile.csv": drive_table(r)}
        return {file: headed(t) for file, t in tables.items()}

    def draw(self, ax) -> None:
        """Empirical distribution of the validation peaks of the three profiles."""
        self._runs()
        factor, label, _ = self._shown()
        for k, p in self.profiles.items():
            v = np.sort(self.validation[k])
            ax.step(factor * v, np.arange(1, v.size + 1) / v.size, where="post", color=self.COLORS[k],
                    label=f"{p.label} (worst {self.peak_text(v[-1])})")
        ax.set_xlabel(label)
        deflection_axis(ax, self.eccentricity_m, "x")
        ax.set_ylabel(f"fraction of the {self.validation['factors'].shape[0]} validation rotors")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict[str, Figure]:
        """Profiles and the deflection on the worst design rotor; validation distribution; peak against the
        critical-speed factor."""
        self._runs()
        factor, label, _ = self._shown()
        title = self.title
        fig, (a0, a1) = new_figure((8, 7), 2, 1, sharex=True)
        ft, fw = unit_axis(a1, "time t", "s", which="x"), speed_axis(a0)
        for k, p in self.profiles.items():
            tr, tw = self.nominal_runs[k], self.worst_runs[k]
            a0.plot(tr.t * ft, tr.omega * fw, color=self.COLORS[k], label=p.label)
            a1.plot(tw.t * ft, factor * deflection_of(tw), color=self.COLORS[k],
                    label=f"{p.label} (peak {self.peak_text(tw.peak)})")
        wc = self.omega_cr_rad_s
        if wc is not None:
            a0.axhline(wc * fw, color="k", ls=":", lw=0.8,
                       label="nominal critical speed " + QUANTITIES.find("omega_cr_rad_s").text(wc))
        w = self.worst_design_rotor
        a1.set_title(f"on the robust profile's worst design rotor (critical speed x{w[0]:.3g}, damping x{w[1]:.3g}"
                     + (f", liquid x{w[2]:.3g}" if self.liquid else "") + ")", fontsize=8, loc="left")
        a1.set_ylabel(label.replace("peak deflection", "deflection").replace("^*", "").replace("r*", "r"))
        deflection_axis(a1, self.eccentricity_m)
        for ax in (a0, a1):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(title, fontsize=8)
        fig2, ax2 = new_figure((8.5, 4.8))
        self.draw(ax2)
        fig2.suptitle(title, fontsize=8)
        fig3, ax3 = new_figure((8.5, 4.8))
        f = self.validation["factors"]
        for k, p in self.profiles.items():
            ax3.scatter(f[:, 0], factor * self.validation[k], s=3, color=self.COLORS[k], alpha=0.5, label=p.label)
        ax3.set_xlabel("critical-speed factor (1 = nominal)")
        ax3.set_ylabel(label)
        deflection_axis(ax3, self.eccentricity_m)
        ax3.grid(alpha=0.3)
        ax3.legend(fontsize=7, markerscale=4)
        fig3.suptitle(title, fontsize=8)
        figs = {"profiles": fig, "distribution": fig2, "scatter": fig3}
        return {f"{self.name}_{k}.png": Figure(f, self.CAPTIONS[k]) for k, f in figs.items()}


@record
class ModalRobustResult(RobustResult):
    """The robust study of the modal (ROSS) rotor (``ross_spinup_robust``): peaks in m, the nodes and modes of the
    reduced rotor; its problem has no drive torque or power model."""

    name = "ross_spinup_robust"
    CAPTIONS = {k: f"Robust spin-up of the ROSS rotor (multi-mode): {k}" for k in RobustResult.CAPTIONS}
    null_reasons = RobustResult.null_reasons | {
        "within_drive_limits": "the modal rotor's problem has no drive torque or power model (its ramps keep the "
                               "acceleration bound and the speed cap)"}


def _quantiles(unit: str) -> Quantity:
    return Quantity(f"profiles.*.validation_quantiles_{PEAK_KEY[unit]}.**", unit, PEAK_SYMBOL[unit],
                    "quantiles of a profile's peaks over the validation sample", "" if unit == "1" else "µm")


#: every number of a robust spin-up block (``spinup_robust``: the Jeffcott rotor, peaks delta/e; ``ross_spinup_robust``:
#: the modal rotor, peaks in m shown in µm), from the fields; the headline quantities first, in summary order
RobustResult.quantities = ModalRobustResult.quantities = QUANTITIES = declarations(
    RobustResult, _quantiles("1"), _quantiles("m"),
    Quantity("time_split.*", "s", "", "the wall time by part"))


def peak_text(x, unit: str = "1", e: float | None = None) -> str:
    """A peak as read: delta/e (``unit`` "1") with the deflection e delta/e beside it when the eccentricity ``e``
    (m) is known (Jeffcott rotor), or in µm (``unit`` "m", modal rotor)."""
    if unit == "1":
        return deflection_text(x, e)
    return QUANTITIES.find("profiles.robust.validation_worst_m").text(x)


def deflection_of(tr) -> np.ndarray:
    """The deflection of a re-simulation against its time: delta/e, or the largest node's in m."""
    return tr.delta if isinstance(tr, Trajectory) else tr.deflection.max(axis=0)


def verdict(profiles: Profiles, samples: int | None, unit: str = "1", e: float | None = None
            ) -> tuple[bool | None, str]:
    """The robust spin-up's one verdict: the robust profile's worst peak over the validation rotors against the
    nominal optimum's and the best ramp's (a ramp outside the drive limits is shown, never compared)."""
    w = {k: p.validation_worst for k, p in profiles.items()}
    ramp_ok = profiles.ramp.within_drive_limits is not False

    def pk(x):
        return peak_text(x, unit, e)

    ok = w["robust"] < min(w["nominal"], w["ramp"] if ramp_ok else math.inf)
    return ok, (f"worst peak over {samples if samples is not None else 'the'} validation rotors: robust "
                f"{pk(w['robust'])}, nominal optimum {pk(w['nominal'])}, best ramp {pk(w['ramp'])}"
                + ("" if ramp_ok else " (outside the drive limits, not compared)"))


def _on(ocp, factors, profile: rb.Profile):
    """The profile re-simulated by CVODES on the rotor with ``factors`` (:class:`Trajectory`, or the modal rotor's
    ``ModalTrajectory``)."""
    o = rb.scenario_ocps(ocp, np.atleast_2d(factors))[0]
    u, h = profile.on(o)
    return resimulate(o, u, h, profile.label, points=8) if isinstance(o, SpinupOcp) else \
        o.resimulate(u, h, profile.label)


def nominal_optimum(ocp, method: DirectCollocation, multistart: bool, options: dict | None
                    ) -> tuple[rb.Profile, float, float, float]:
    """The nominal rotor's optimum by its model's study (:func:`autobal.ocp.time_optimal.minimum_peak`: the Jeffcott
    rotor's or the modal rotor's global search for starts, and the shared solver); the modal rotor's on its problem's
    own mesh.

    Returns
    -------
    tuple
        (its profile on the method's intervals, its peak in the epigraph's measure squared (the scale of the
        robust NLP's level), build time s, solve time s).
    """
    n = method.intervals
    if not isinstance(ocp, SpinupOcp) and (n != ocp.intervals or method.degree != ocp.degree):
        raise ValueError(f"the modal rotor's robust NLP is transcribed on its problem's mesh "
                         f"({ocp.intervals} intervals, degree {ocp.degree}), not {method.label}")
    r = minimum_peak(ocp, method, multistart, options)
    return (rb.Profile("nominal optimum", r.solution.u[:n]), (r.score / ocp.epigraph_unit) ** 2, r.build_time_s,
            sum(row.get("solve_time_s", 0.0) for row in r.starts))


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
    if isinstance(ocp, SpinupOcp):
        use = {i: drive_use(ocp, _on(ocp, [1.0, 1.0, 1.0], p)) for i, p in enumerate(ramps)}
    else:  # the modal problem has no drive torque or power: no drive data (a ramp keeps |alpha| and the cap)
        use = {i: {"within_drive_limits": None, "violated": []} for i in range(len(ramps))}
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
    if isinstance(o, SpinupOcp):
        found = [controls_on_mesh(o, p, n) for p in grid_search(o, keep=2).params]
    else:
        found = [phase_profiles(o, *p)[0] for p in modal_grid_search(o, keep=2).params]
    return [nominal, ramps[ib], *[rb.Profile(f"global search on design rotor {worst}", u) for u in found]]


def run(ocp, method: DirectCollocation, uncertainty: rb.Uncertainty, design_points: int,
        samples: int, seed: int, ramps: int, executor, title: str = "", multistart: bool = True,
        options: dict | None = None) -> RobustResult:
    """Nominal optimum, robust optimum over the design grid, constant ramps; all validated on a sample.

    Parameters
    ----------
    ocp : SpinupOcp or ModalSpinupOcp
        The nominal problem (SI), objective peak_deflection: the Jeffcott rotor's
        (:class:`autobal.ocp.problem.SpinupOcp`) or the modal rotor's (:class:`autobal.ocp.modal.ModalSpinupOcp`,
        on its own mesh).
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
        Where the validation chunks run (:func:`autobal.analysis.run.executor.make`).
    title : str
        The scene's title.
    multistart : bool
        Multi-start of the nominal optimum (the Jeffcott rotor's).
    options : dict, optional
        IPOPT options.

    Returns
    -------
    RobustResult
        Peaks in delta/e (Jeffcott) or m (:class:`ModalRobustResult` of the modal rotor), as its ``peak_unit``
        states; times in s.
    """
    jeffcott = isinstance(ocp, SpinupOcp)
    unit = "1" if jeffcott else "m"
    s = PEAK_KEY[unit]
    n = method.intervals
    t_start = time.perf_counter()
    pn, ref, nominal_build, nominal_solve = nominal_optimum(ocp, method, multistart, options)
    t_nominal = time.perf_counter() - t_start
    family = rb.ramp_family(ocp, n, ramps)
    F = uncertainty.grid(design_points)
    t0 = time.perf_counter()
    ramp_peaks = rb.fast_peaks(ocp, F, family)
    design_ramps = ramp_peaks.max(axis=0)
    starts = robust_starts(ocp, F, pn, family, ramp_peaks)
    t_starts = time.perf_counter() - t0
    ro = rb.optimize_robust_refined(ocp, F, method, starts, ref, options)
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
    kinds = {"robust": RobustProfile, "nominal": NominalProfile, "ramp": RampProfile}
    prof = {}
    for k, (p, v) in chosen.items():
        extra = {"within_drive_limits": ramp_use[ib]["within_drive_limits"]} if k == "ramp" else {}
        prof[k] = kinds[k](p.label, **{
            f"nominal_peak_{s}": nominal_runs[k].peak, f"design_peaks_{s}": design[k].tolist(),
            f"design_worst_{s}": float(design[k].max()), f"validation_worst_{s}": float(v.max()),
            f"validation_mean_{s}": float(v.mean()),
            f"validation_quantiles_{s}": {str(q): float(np.quantile(v, q)) for q in QUANTILES}}, **extra)
    # the scenario generation names a round's peaks in delta/e (:func:`autobal.ocp.robust.optimize_robust`); the
    # modal rotor's are in m
    rounds = [Round(**{(k[:-len("over_e")] + s if k.endswith("_over_e") else k): v for k, v in r.items()})
              for r in ro.rounds]
    if jeffcott:
        model = {"omega_cr_rad_s": ocp.params.omega_cr, "eccentricity_m": ocp.params.e,
                 "validation_step_tau": FAST_STEP}
        how = f"the validation integrator (exponential, step {FAST_STEP} in Omega0 t)"
    else:
        cs = ocp.rotor.critical_speeds(ocp.omega_final)["wd"]
        model = {"omega_cr_rad_s": float(cs[0]) if len(cs) else None, "nodes": list(ocp.nodes),
                 "modes": ocp.rotor.n}
        # the results.json text names the screening as the modal problem's module exports it (defined in modal_search)
        how = "the validation integrator (Runge-Kutta screening of the envelope, autobal.ocp.modal.screen)"
    ramp_rows = [Ramp(p.label, float(p.u[0] * ocp.alpha_max), **{f"design_worst_{s}": float(d),
                                                                   f"validation_worst_{s}": float(w)},
                      within_drive_limits=ramp_use[i]["within_drive_limits"],
                      violated=", ".join(ramp_use[i]["violated"]))
                 for i, (p, d, w) in enumerate(zip(family, design_ramps, ramp_worst, strict=True))]
    # the wall time by part (s): the nominal optimum (global search, multi-start, its builds and solves), the
    # robust starts (the ramps on the design set, the global search), the robust NLPs' builds and solves, the
    # validation; rest: the scenario generation's design-set checks and the CVODES re-simulations
    split = {"nominal_optimum": t_nominal, "robust_starts": t_starts, "robust_build": ro.build_time_s,
             "robust_solve": ro.solve_time_s, "validation": t_val}
    wall = time.perf_counter() - t_start
    split["rest"] = wall - sum(split.values())
    return (RobustResult if jeffcott else ModalRobustResult)(
        title, method.label, unit, **model,
        critical_speed_spread=uncertainty.critical_speed_spread, damping_factor=list(uncertainty.damping_factor),
        liquid=uncertainty.liquid_mass_factor is not None,
        liquid_mass_factor=list(uncertainty.liquid_mass_factor) if uncertainty.liquid_mass_factor else None,
        design_set=F.tolist(), design_scenarios=len(F), active_scenarios=len(ro.active),
        active_design_rotors=F[ro.active].tolist(), worst_design_rotor=worst_rotor.tolist(),
        **{f"robust_collocation_worst_{s}": ro.collocation_worst},
        resimulation_rel_error=abs(ro.collocation_worst - design["robust"].max()) / design["robust"].max(),
        build_time_s=ro.build_time_s, solve_time_s=ro.solve_time_s, rounds=rounds,
        nominal_build_time_s=nominal_build, nominal_solve_time_s=nominal_solve,
        validation_samples=int(samples), seed=int(seed), executor=executor.name, validation_time_s=t_val,
        validation_check_rel_error=fast_err, profiles=Profiles(**prof), ramps=ramp_rows,
        accuracy={"estimate": fast_err,
                  "how": f"largest relative difference of {how} against CVODES on {CHECKED} validation rotors"},
        wall_time_s=wall, time_split={f"{k}_time_s": v for k, v in split.items()},
        nominal_runs=nominal_runs, worst_runs=worst_runs,
        validation={"factors": factors} | {k: v for k, (_, v) in chosen.items()})
