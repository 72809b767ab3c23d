"""The ``spinup`` analysis of a scene: the optimal spin-up profile beside the constant-ramp baselines.

``run(ocp, method)`` returns a :class:`SpinupResult` (the ``spinup`` block of results.json, CSV
tables and figures: omega(t), alpha(t), torque, deflection against time and against speed, the
optimum and both ramps on each plot).
"""

from __future__ import annotations

import dataclasses
import functools
import re
import time
from dataclasses import KW_ONLY, field
from pathlib import Path

import numpy as np

from autobal.analysis.numerics import standards
from autobal.analysis.numerics.standards import Margin
from autobal.analysis.run import forked, solver_options
from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record, unsaved
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Quantity, significant
from autobal.analysis.run.result import new_figure, speed_axis, twin_axis, unit_axis
from autobal.analysis.studies.rotor_study import api_margins
from autobal.ocp import drive_profile
from autobal.ocp.columns import headed, read_table
from autobal.ocp.problem import SpinupOcp, pulse_variation
from autobal.ocp.simulation import (
    DRIVE_QUANTITIES,
    DRIVE_TOL,
    Trajectory,
    baselines,
    best_within_limits,
    drive_use,
    legend_above_curves,
    ramp_runs,
    require_resimulations,
    torque_reference,
)
from autobal.ocp.solve import optimize
from autobal.ocp.transcription import DirectCollocation, MultipleShooting

_P10 = "Pashkov (2010)"
SOLVED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
#: a profile dwells near the critical speed when it spends, within DWELL_BAND of omega_cr (10 %: there the steady
#: whirl of a lightly damped rotor is above 1/(1 - 0.9^2) = 4.3 e; API 684 asks 16 to 26 % of a service speed at
#: large AF), more than DWELL_FACTOR times the time the maximum acceleration takes across that band
DWELL_BAND = 0.10
DWELL_FACTOR = 2.0


#: the objective J of each ``objective`` of a scene: (SI unit, symbol, what it measures); Pashkov (2010), Eq. (2)
#: for the deflection delta/e and the system unbalance d
OBJECTIVES = {
    "peak_deflection": ("1", "δ*/e", "peak deflection over the eccentricity"),
    "peak_unbalance": ("1", "d*", "peak system unbalance"),
    "integrated_deflection": ("s", "∫(δ/e)² dt", "integral of the squared deflection over the window"),
    "min_time": ("s", "T", "arrival time at the final speed"),
}

#: the keys that hold a value of the objective: the optimum's, each start's, the ramp table's (and its starts')
_OBJECTIVE_KEYS = {"objective_value": "objective of the optimum (re-simulated)",
                   "objective_value_transcription": "objective of the optimum (transcription)",
                   "starts[].objective": "re-simulated objective of a start",
                   "segments.objective_value": "objective of the ramp table",
                   "segments.start_objectives.*": "objective of a start of the ramp table's search"}


def objective_quantity(path: str, block: dict | None) -> Quantity | None:
    """The declaration of a key that holds a value of the objective J, in the unit of the block's ``objective``
    (:data:`OBJECTIVES`: δ*/e and d* dimensionless, ∫(δ/e)² dt and the arrival time in s); None for another key or
    without the block."""
    key = re.sub(r"\.\d+\.", "[].", path)
    key = "segments.start_objectives.*" if key.startswith("segments.start_objectives.") else key
    objective = block.get("objective") if isinstance(block, dict) else None
    if key not in _OBJECTIVE_KEYS or objective not in OBJECTIVES:
        return None
    unit, symbol, words = OBJECTIVES[objective]
    return Quantity(path, unit, f"J = {symbol}", f"{_OBJECTIVE_KEYS[key]}: the {words}")


def _drive_torque():
    return quantity("N*m", "M", "largest and smallest drive torque")


def _drive_power():
    return quantity("W", "P", "largest drive power", "kW")


def _dwell_time():
    return quantity("s", "t_cr", f"time within {100 * DWELL_BAND:.0f} % of the critical speed (optimum, ramp table)")


@record
class Dwell(Record):
    """How long a profile stays near the critical speed (:func:`dwell`)."""

    time_near_critical_s: float = _dwell_time()
    fastest_crossing_s: float = quantity("s", "", f"time the maximum acceleration takes across {100 * DWELL_BAND:.0f}"
                                                  " % either side of the critical speed")
    dwells: bool
    hold_speed_rad_s: float | None = quantity("rad/s", "ω_hold", f"speed held longest within {100 * DWELL_BAND:.0f} "
                                                                 "% of the critical speed (time-weighted median)")
    hold_steady_deflection_over_e: float | None = quantity("1", "δ_ss/e", "steady whirl of the rotor at that speed")
    hold_speed_rad_s_status: str | None = optional()  # the profile never comes near the critical speed
    hold_steady_deflection_over_e_status: str | None = optional()


@record
class _RotorData(Record):
    mass_kg: float = quantity("kg", "m1", "rotor mass", source=f"{_P10}, ch. 3")
    stiffness_N_per_m: float = quantity("N/m", "c", "shaft stiffness (c = m1 Ω_c²)")
    damping_N_s_per_m: float = quantity("N*s/m", "χ", "external viscous damping (χ = 2 ζ m1 Ω_c)")
    eccentricity_m: float = quantity("m", "e", "eccentricity (mass centre from the shaft axis)", "µm")
    liquid_mass_kg: float = quantity("kg", "m2*", "full-chamber liquid mass ρπR²h", source=f"{_P10}, ch. 3")
    critical_speed_rad_s: float = quantity("rad/s", "ω_cr", "undamped critical speed √(c/m), m the rotor's mass with "
                                                            "its liquid layer's if it has one (critical_label says "
                                                            "which)")
    damping_ratio: float = quantity("1", "ζ", "damping ratio χ/(2√(c m)) of the rotor with its liquid mass")
    service_speed_rad_s: float = quantity("rad/s", "N_s", "service speed (the final speed of the spin-up)")


@record
class Rotor(Margin, _RotorData):
    """The rotor as the scene gives it, then its critical speed against the service speed (API 684 (2005), API 617
    (2014): the fields of :class:`autobal.analysis.numerics.standards.Margin`,
    :func:`~autobal.analysis.numerics.standards.margin_check`'s block), then the amplitude convention."""

    _: KW_ONLY
    amplitude_convention: str

    def margins(self) -> dict:
        """The API 684 check as :func:`autobal.analysis.numerics.standards.margin_check` gives it (its words, its
        rows)."""
        return {k: v for k, v in self.to_dict().items() if k not in _ROTOR_OWN}


_ROTOR_OWN = ("mass_kg", "stiffness_N_per_m", "damping_N_s_per_m", "eccentricity_m", "liquid_mass_kg",
              "critical_speed_rad_s", "damping_ratio", "service_speed_rad_s", "amplitude_convention")


@record
class Baseline(Record):
    """A constant-ramp baseline, re-simulated, and its drive use."""

    label: str
    peak_deflection_over_e: float = quantity("1", "δ*/e", "peak deflection of a ramp baseline")
    peak_unbalance: float = quantity("1", "d*", "peak system unbalance of a ramp baseline")
    time_of_peak_s: float = quantity("s", "t*", "time of a ramp baseline's peak")
    integral_deflection2_s: float = quantity("s", "∫(δ/e)² dt", "integral of a ramp baseline's δ²")
    max_torque_N_m: float | None = _drive_torque()
    min_torque_N_m: float | None = _drive_torque()
    max_power_W: float | None = _drive_power()
    within_drive_limits: bool | None
    violated: list[str]


@record
class RampTable(Record):
    """The drive's K-segment ramp table (:func:`autobal.ocp.drive_profile.segment_profile`), re-simulated."""

    segments: int = quantity("1", "K", "ramp segments of the drive's table")
    peak_deflection_over_e: float = quantity("1", "δ*/e", "peak deflection of the ramp table (re-simulated)")
    peak_unbalance: float = quantity("1", "d*", "peak system unbalance of the ramp table")
    objective_value: float  # in the objective's unit (objective_quantity)
    loss_vs_optimum_pct: float = quantity("%", "", "loss of the ramp table against the full optimum")
    evaluations: int = quantity("1", "", "re-simulations of the ramp table's search")
    start: str
    start_objectives: dict[str, float]  # start -> its penalised objective (objective_quantity)
    max_torque_N_m: float | None = _drive_torque()
    min_torque_N_m: float | None = _drive_torque()
    max_power_W: float | None = _drive_power()
    within_drive_limits: bool | None
    violated: list[str]
    dwell: Dwell


def _unbalance(**kw):
    return quantity("1", "d*", "peak system unbalance", source=f"{_P10}, Eq. (2)", **kw)


@record
class SpinupResult(TypedResult):
    """The optimal spin-up profile beside the constant-ramp baselines (every peak re-simulated): deflections delta/e
    (the source's group, Pashkov (2010), Eq. (2)) beside the physical deflection (0-peak, the radius of the whirl
    orbit).  The run also holds the optimum's re-simulation, the ramps' and the ramp table's (None in a Result loaded
    from results.json); ``controls`` and ``ramp_table`` (its controls table and the drive's segment table) are read
    back from the run's files by :meth:`from_folder`."""

    title: str
    objective: str
    method: str
    status: str
    peak_deflection_over_e: float = quantity("1", "δ*/e", "peak deflection of the optimum over the eccentricity",
                                             headline=2)
    baseline_ramp_peak_over_e: float | None = quantity("1", "δ*/e", "peak of the best ramp within the drive limits",
                                                       headline=3)
    baseline_ramp_key: str | None
    gain_vs_best_feasible_ramp_pct: float | None = quantity("%", "", "gain of the optimum against that ramp",
                                                            headline=4)
    gain_vs_constant_ramp_pct: float | None = quantity("%", "", "gain of the optimum against the constant ramp")
    peak_deflection_m: float = quantity("m", "δ*", "peak deflection of the optimum, 0-peak (re-simulated)", "mm",
                                        headline=1)
    rotor: Rotor
    resimulation_rel_error: float = quantity("1", "", "relative difference, CVODES re-simulation vs transcription")
    solve_time_s: float = quantity("s", "", "time of the final solve")
    ipopt_iterations: int = quantity("1", "", "iterations of the final solve")
    collocation_peak_over_e: float | None = quantity("1", "δ*/e", "peak deflection of the collocation (before "
                                                                  "re-simulation)")
    objective_value: float | None  # in the objective's unit (objective_quantity)
    objective_value_transcription: float | None
    peak_unbalance: float = _unbalance()
    time_of_peak_s: float = quantity("s", "t*", "time of the peak")
    control_pulse_variation: float = quantity("1", "", "chattering of the optimal acceleration (pulse variation of "
                                                       "α/α_max; 0: none)")
    omega_at_peak_rad_s: float = quantity("rad/s", "ω*", "speed at the peak")
    integral_deflection2_s: float = quantity("s", "∫(δ/e)² dt", "integral of the squared deflection over the window")
    final_time_s: float = quantity("s", "T", "final time (the deadline, or the arrival with min_time)")
    build_time_s: float = quantity("s", "", "NLP build time")
    total_solve_time_s: float = quantity("s", "", "NLP solve time (IPOPT or fatrop), all starts and mesh stages")
    wall_time_s: float = quantity("s", "", "wall time of the analysis (search, solves, re-simulations)")
    #: one row per NLP solve of the multi-start (its keys by stage: the solver's log)
    starts: list[dict]
    baselines: dict[str, Baseline]
    psi: float = quantity("1", "ψ", "mass ratio m1/(m1 + m2*)", source=f"{_P10}, ch. 3")
    eccentricity_m: float = quantity("m", "e", "eccentricity (mass centre from the shaft axis)", "µm")
    omega_cr_rad_s: float = quantity("rad/s", "ω_cr", "critical speed Ω0 √ψ", source=f"{_P10}, ch. 3")
    Omega0_rad_s: float = quantity("rad/s", "Ω0", "natural frequency √(c/m1) of the rotor without liquid",
                                   source=f"{_P10}, ch. 3")
    zeta0: float = quantity("1", "ζ0", "damping group of the source", source=f"{_P10}, ch. 3")
    drive_polar_inertia_kg_m2: float = quantity("kg*m^2", "J_p", "polar inertia of the rotor and drive")
    max_torque_N_m: float | None  # DRIVE_QUANTITIES
    min_torque_N_m: float | None
    max_power_W: float | None
    within_drive_limits: bool | None
    violated: list[str]
    braking_torque_limit_N_m: float | None
    torque_limit_N_m: float | None
    power_limit_W: float | None
    brakes: bool | None
    dwell: Dwell
    accuracy: dict
    braking_torque_limit_N_m_status: str | None = optional()
    torque_limit_N_m_status: str | None = optional()
    power_limit_W_status: str | None = optional()
    brakes_status: str | None = optional()
    baseline_ramp_peak_over_e_status: str | None = optional()
    baseline_ramp_key_status: str | None = optional()
    gain_vs_best_feasible_ramp_pct_status: str | None = optional()
    gain_vs_constant_ramp_pct_status: str | None = optional()
    collocation_peak_unbalance: float | None = _unbalance(optional=True)  # the peak_unbalance objective's
    segments: RampTable | None = optional()
    baselines_time_s: float | None = quantity("s", "", "wall time of the ramp baselines' own re-simulations, run "
                                              "alongside the optimisation (in a forked process where one can be "
                                              "had; time_split has what was waited for them)", optional=True)
    #: part -> its wall time, s
    time_split: dict[str, float] = field(default_factory=dict)
    optimum: Trajectory | None = unsaved()
    ramp_runs: dict | None = unsaved()  # baseline key -> its Trajectory
    ramp_table_run: drive_profile.Segments | None = unsaved()
    controls: dict | None = unsaved()  # spinup_controls.csv, SI: t_start, acceleration
    ramp_table: dict | None = unsaved()  # drive_segments.csv, SI (drive_profile.Segments.table), None without one
    name = "spinup"

    @property
    def peak_deflection(self) -> float:
        """Re-simulated peak deflection of the optimum over the horizon and the settling window, delta/e."""
        return self.peak_deflection_over_e

    @classmethod
    def from_folder(cls, block: dict, folder=None):
        """The Result of its results.json block with the controls and the drive's ramp table its run wrote in
        ``folder`` (spinup_controls.csv, drive_segments.csv; None: the block alone)."""
        res = cls.from_dict(block)
        if folder is None:
            return res
        tables = {name: read_table(Path(folder) / name) for name in ("spinup_controls.csv", "drive_segments.csv")}
        return dataclasses.replace(res, controls=tables["spinup_controls.csv"],
                                   ramp_table=tables["drive_segments.csv"])

    def verdict(self) -> tuple[bool | None, str]:
        """The spin-up's one verdict: the optimum's peak deflection (physical, 0-peak, and delta/e), its gain against
        the best ramp within the drive limits (the only reference a gain is quoted against), whether it brakes and
        whether it keeps the drive limits; the NLP status first when it is not a success.  An optimum that dwells
        near the critical speed (:func:`dwell`) is neither good nor bad (None) with a CAUTION: its peak holds only for
        the critical speed of the scene."""
        q = self.quantities.find
        words = (f"peak deflection {q('peak_deflection_m').text(self.peak_deflection_m)} 0-peak "
                 f"({significant(self.peak_deflection_over_e)} e)")
        gain, key = self.gain_vs_best_feasible_ramp_pct, self.baseline_ramp_key
        if gain is not None:
            words += f", {gain:+.1f} % against the best ramp within the drive limits ({self.baselines[key].label})"
        else:
            words += ", no ramp keeps the drive limits: no gain is quoted"
        if self.brakes is not None:
            words += (f"; it brakes (smallest torque {q('min_torque_N_m').text(self.min_torque_N_m)})"
                      if self.brakes else "; it does not brake")
        ok = gain is None or gain <= 0.01
        if self.dwell.dwells:  # good only if the critical speed is where the scene puts it: no verdict
            ok, words = (None if ok else ok), words + "; CAUTION: " + dwell_words("it", self.dwell,
                                                                                  self.omega_cr_rad_s)
        if self.within_drive_limits is False:
            ok, words = False, words + f"; drive limits EXCEEDED ({', '.join(self.violated or [])})"
        if self.status not in SOLVED:
            ok, words = False, f"NLP solver {self.status}: " + words
        return ok, words

    def summary(self) -> str:
        ok, words = self.verdict()
        q = self.quantities.find
        r = self.rotor
        status = {True: "ok", False: "NOT OK", None: "to check"}[ok]
        lines = [f"spin-up ({self.objective.replace('_', ' ')}): {status}: {words}",
                 f"  {critical_label(r.liquid_mass_kg > 0)}  ω_cr  "
                 f"{q('rotor.critical_speed_rad_s').text(r.critical_speed_rad_s)}",
                 *self.quantities.lines(self.to_dict()),
                 f"  API 684 (2005): {standards.margin_words(r.margins())}",
                 f"  NLP ({self.method}): {self.status}, {self.ipopt_iterations} iterations in the final solve "
                 f"({self.solve_time_s:.2f} s); {len(self.starts)} starts and mesh stages "
                 f"{self.total_solve_time_s:.2f} s (" + ", ".join(f"{s['solve_time_s']:.2f}" for s in self.starts
                                                                 if "solve_time_s" in s)
                 + f" s), NLP build {self.build_time_s:.2f} s, wall {self.wall_time_s:.2f} s (with the global "
                 "search, re-simulations and baselines)",
                 "  wall time split: " + ", ".join(f"{k[:-7].replace('_', ' ')} {v:.2f} s" for k, v in
                                                   self.time_split.items())
                 + ("" if self.baselines_time_s is None else
                    f"; the ramp baselines took {self.baselines_time_s:.2f} s alongside"),
                 f"  optimum: collocation peak {significant(self.collocation_peak_over_e)} e (re-simulation "
                 f"difference {self.resimulation_rel_error:.2e}), peak unbalance {significant(self.peak_unbalance)}, "
                 f"peak at t = {q('time_of_peak_s').text(self.time_of_peak_s)} and "
                 f"{q('omega_at_peak_rad_s').text(self.omega_at_peak_rad_s)}, final time "
                 f"{q('final_time_s').text(self.final_time_s)}, chattering (pulse variation of alpha/alpha_max) "
                 f"{self.control_pulse_variation:.3g}"]
        j = objective_quantity("objective_value", {"objective": self.objective})
        if j is not None and self.objective_value is not None:
            lines.append(f"  objective {j.symbol} ({self.objective.replace('_', ' ')}): {j.text(self.objective_value)}")
        rotor = ", ".join(f"{sym} {q(f'rotor.{k}').text(getattr(r, k))}" for sym, k in (
            ("m1", "mass_kg"), ("c", "stiffness_N_per_m"), ("χ", "damping_N_s_per_m"), ("ζ", "damping_ratio"),
            ("e", "eccentricity_m")))
        lines.append(f"  rotor: {rotor}; deflections are 0-peak (the radius of the whirl orbit)")
        e = self.eccentricity_m
        for k, v in self.baselines.items():
            lim = {True: "", False: " (outside the drive limits: " + ", ".join(v.violated) + ")",
                   None: ""}[v.within_drive_limits]
            ref = " [reference]" if k == self.baseline_ramp_key else ""
            lines.append(f"  {v.label:52s} peak {deflection_text(v.peak_deflection_over_e, e)}{lim}{ref}")
        if self.gain_vs_constant_ramp_pct is not None:
            lines.append(f"  gain against the constant ramp: {self.gain_vs_constant_ramp_pct:+.2f} %")
        sg = self.segments
        if sg:
            lines.append(f"  {sg.segments}-segment ramp table: peak "
                         f"{deflection_text(sg.peak_deflection_over_e, e)}, {sg.loss_vs_optimum_pct:+.2f} % "
                         f"against the full optimum (searched from the {sg.start} start)"
                         + ("" if sg.within_drive_limits else " (outside the drive limits)"))
            if sg.dwell.dwells:
                lines.append("  CAUTION: " + dwell_words(f"the {sg.segments}-segment ramp table", sg.dwell,
                                                         self.omega_cr_rad_s))
        return "\n".join(lines)

    def _held(self):
        require_resimulations(self.name, self.optimum)

    def tables(self) -> dict[str, dict]:
        """The tables headed 'name [unit]' in their display units (:func:`autobal.ocp.columns.headed`)."""
        self._held()
        o = self.optimum
        cols = {"time": next(iter(self.ramp_runs.values())).t}
        for k, v in self.ramp_runs.items():
            cols |= {f"{k}_speed": v.omega, f"{k}_deflection_over_e": v.delta, f"{k}_unbalance": v.d}
        e = self.eccentricity_m or np.nan
        tables = {"spinup_optimum.csv": {"time": o.t, "speed": o.omega, "deflection_over_e": o.delta,
                                         "deflection": o.delta * e, "unbalance": o.d, "torque": o.torque},
                  "spinup_controls.csv": self.controls, "spinup_baselines.csv": cols,
                  "drive_profile.csv": drive_profile.drive_table(o), "drive_segments.csv": self.ramp_table}
        return {name: headed(t) for name, t in tables.items() if t is not None}

    def _runs(self):
        self._held()
        seg = [] if self.ramp_table_run is None else [(self.ramp_table_run.trajectory, "C4", "-.", 1.0,
                                                       self.ramp_table_run.trajectory.label)]
        uses = {k: {"within_drive_limits": b.within_drive_limits} for k, b in self.baselines.items()}
        return [(self.optimum, "C3", "-", 1.4, "optimum"), *seg, *ramp_runs(self.ramp_runs, uses)]

    def draw(self, ax) -> None:
        """Deflection against time of the optimum and both ramps (delta/e; mm on the right)."""
        ft = unit_axis(ax, "time t", "s", which="x")
        for tr, c, ls, lw, lab in self._runs():
            ax.plot(tr.t * ft, tr.delta, color=c, ls=ls, lw=lw,
                    label=f"{lab} (peak {deflection_text(tr.peak_delta, self.eccentricity_m)})")
        ax.set_ylabel(r"deflection $\delta/e$")
        deflection_axis(ax, self.eccentricity_m)
        ax.grid(alpha=0.3)
        legend_above_curves(ax)  # every run's peak stays visible

    def figures(self) -> dict[str, Figure]:
        """Speed (rpm, rad/s), acceleration steps (rad/s², rpm/s), drive torque (N·m) and, with drive data, power (kW)
        against time; deflection (delta/e, mm) against time and speed; every axis in its display unit."""
        title = self.title
        wc = self.omega_cr_rad_s
        drive = self.drive_polar_inertia_kg_m2 != 0
        runs = self._runs()
        fig, axes = new_figure((8, 10 if drive else 8), 4 if drive else 3, 1, sharex=True)
        kw = QUANTITIES.find("max_power_W")
        ft = unit_axis(axes[-1], "time t", "s", which="x")
        fw = speed_axis(axes[0])
        fa = unit_axis(axes[1], r"acceleration $\alpha$", "rad/s^2")
        fm = unit_axis(axes[2], "drive torque M" if drive else "torque M", "N*m")
        fp = unit_axis(axes[3], "drive power P", "W", kw.declared) if drive else None
        for tr, c, ls, lw, lab in runs:
            axes[0].plot(tr.t * ft, tr.omega * fw, color=c, ls=ls, lw=lw, label=lab)
            axes[1].plot(np.append(tr.t_u, tr.t[-1]) * ft, np.append(tr.alpha, tr.alpha[-1]) * fa,
                         drawstyle="steps-post", color=c, ls=ls, lw=lw)
            axes[2].plot(tr.t * ft, tr.torque * fm, color=c, ls=ls, lw=lw)
            if drive:
                axes[3].plot(tr.t * ft, tr.torque * tr.omega * fp, color=c, ls=ls, lw=lw)
        liquid = self.rotor.liquid_mass_kg > 0
        axes[0].axhline(wc * fw, color="k", lw=0.8, ls=":", label=critical_label(liquid, tex=True) + " = "
                        + QUANTITIES.find("omega_cr_rad_s").text(wc))
        if drive:
            brake = self.braking_torque_limit_N_m
            for ax, limit, f in ((axes[2], self.torque_limit_N_m, fm),
                                 (axes[2], None if brake is None else -brake, fm),
                                 (axes[3], self.power_limit_W, fp)):
                if limit is not None:
                    ax.axhline(limit * f, color="k", lw=0.8, ls=":")  # the drive's limits
        else:
            axes[2].set_title("no drive data: the torque is the unbalance reaction only", fontsize=8, loc="left")
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.legend(loc="outside lower center", ncols=2, fontsize=7)
        fig.suptitle(title, fontsize=9)

        fig2, (a1, a2) = new_figure((8, 7), 2, 1)
        self.draw(a1)
        fw = speed_axis(a2, "x")
        for tr, c, ls, lw, _ in runs:
            a2.plot(tr.omega * fw, tr.delta, color=c, ls=ls, lw=lw)
        a2.axvline(wc * fw, color="k", lw=0.8, ls=":", label=critical_label(liquid, tex=True) + " = "
                   + QUANTITIES.find("omega_cr_rad_s").text(wc))
        a2.set_ylabel(r"deflection $\delta/e$")
        deflection_axis(a2, self.eccentricity_m)
        a2.grid(alpha=0.3)
        a2.legend(fontsize=7)
        fig2.suptitle(title, fontsize=9)
        return {"spinup_profiles.png": Figure(fig, "Optimal spin-up: speed, acceleration, drive torque (and power) "
                                                   "of the optimum beside the ramps against time, the critical speed "
                                                   "and the drive's limits dotted"),
                "spinup_deflection.png": Figure(fig2, "Optimal spin-up: deflection of the optimum beside the ramps "
                                                      "against time and against speed")}


#: every number of the spinup block, from the fields; the API 684 margins of the rotor, the drive's use of the optimum
#: (declared where they are computed) and the solver log of the starts as extra declarations; an objective's value in
#: the unit of the block's objective (:func:`objective_quantity`)
SpinupResult.quantities = QUANTITIES = declarations(
    SpinupResult,
    *standards.margin_quantities("rotor.", headline=True),
    *DRIVE_QUANTITIES,
    Quantity("starts[].iterations", "1", "", "iterations of a start's solve"),
    Quantity("starts[].solve_time_s starts[].build_time_s", "s", "", "solve and build time of a start"),
    Quantity("starts[].resimulated_peak_over_e", "1", "δ*/e", "re-simulated peak of a start"),
    Quantity("time_split.*", "s", "", "the wall time by part"),
    resolve=objective_quantity)


def dwell(P, tr: Trajectory, alpha_max: float) -> Dwell:
    """How long a profile stays near the critical speed: its time within DWELL_BAND of omega_cr (s), the time
    the maximum acceleration ``alpha_max`` takes across that band, the speed it spends the most time at there
    (the time-weighted median, rad/s) with the rotor's steady whirl at that speed (delta/e, the model's steady state
    :func:`autobal.analysis.numerics.rotor.steady_state`), and whether it dwells (more than DWELL_FACTOR times that
    crossing)."""
    from autobal.analysis.numerics.rotor import steady_state

    wc, dt = P.omega_cr, np.diff(tr.t)
    mid = 0.5 * (tr.omega[1:] + tr.omega[:-1])
    inside = np.abs(mid - wc) <= DWELL_BAND * wc
    t_in, crossing = float(dt[inside].sum()), 2 * DWELL_BAND * wc / alpha_max
    if t_in == 0:
        never = "the profile never comes within 10 % of the critical speed"
        return Dwell(t_in, crossing, False, None, None, never, never)
    order = np.argsort(mid[inside])
    cum = np.cumsum(dt[inside][order])
    hold = float(mid[inside][order][np.searchsorted(cum, 0.5 * cum[-1])])
    return Dwell(t_in, crossing, t_in > DWELL_FACTOR * crossing, hold,
                 float(steady_state(P, hold / P.Omega0)["a"]))


def dwell_words(what: str, dw: Dwell, omega_cr: float) -> str:
    """'the 4-segment ramp table holds the rotor 4.3 s within 10 % of its critical speed (most of it at 1709 rpm,
    95 % of ω_cr, where its steady whirl is 8.0 e), more than twice the 0.75 s the maximum acceleration takes across:
    a dwell near the critical speed'."""
    q = QUANTITIES.find
    hold = dw.hold_speed_rad_s
    return (f"{what} holds the rotor {dw.time_near_critical_s:.2g} s within {100 * DWELL_BAND:.0f} % of its "
            f"critical speed (most of it at {q('omega_at_peak_rad_s').text(hold)}, {100 * hold / omega_cr:.0f} % of "
            f"ω_cr, where its steady whirl is {significant(dw.hold_steady_deflection_over_e, 2)} e), more than "
            f"{DWELL_FACTOR:g} × the {dw.fastest_crossing_s:.2g} s the maximum acceleration takes across: a dwell "
            "near the critical speed (a critical speed a few per cent off the datasheet's puts it at resonance)")


def critical_label(liquid: bool, tex: bool = False) -> str:
    """What the rotor's critical speed is, as the scene has it (``liquid``: a liquid layer, rotor.liquid_mass_kg > 0):
    with a liquid layer the undamped critical speed of the rotor and its liquid mass, Omega0 sqrt(psi); without one
    (a dry rotor) sqrt(c/m1)."""
    if liquid:
        return (r"critical speed $\omega_{cr} = \Omega_0\sqrt{\psi}$ (with the liquid mass)" if tex else
                "critical speed with the liquid mass, Ω0 √ψ")
    return (r"critical speed $\omega_{cr} = \sqrt{c/m_1}$ (dry rotor, no liquid)" if tex else
            "critical speed of the dry rotor (no liquid layer), √(c/m1)")


def deflection_axis(ax, e: float | None, which: str = "y") -> None:
    """The physical deflection delta = (delta/e) e (0-peak, the declared display unit) beside a delta/e axis, when
    the eccentricity ``e`` (m) is known."""
    if e:
        q, ecc = QUANTITIES.find("peak_deflection_m"), QUANTITIES.find("eccentricity_m").text(e)
        twin_axis(ax, q.shown(e), f"deflection δ, {q.display} 0-peak  (e = {ecc})", which)


def deflection_text(over_e: float | None, e: float | None) -> str:
    """A peak delta/e with the physical deflection e delta/e beside it, 0-peak, in the display unit of the spin-up's
    peak deflection: '12.31 e (1.231 mm)'."""
    out = f"{significant(over_e)} e"
    return out if e is None or over_e is None else out + f" ({QUANTITIES.find('peak_deflection_m').text(over_e * e)})"


def method_of(settings):
    if settings.method == "collocation":
        return DirectCollocation(settings.intervals, settings.degree, settings.scheme, settings.nlp_solver)
    return MultipleShooting(settings.intervals, settings.degree, settings.scheme)


def _pct(x: float, ref: float | None) -> float | None:
    return None if not ref else 100 * (x - ref) / ref


def timed(fn, *args):
    """``fn(*args)`` and its wall time (s)."""
    t0 = time.perf_counter()
    return fn(*args), time.perf_counter() - t0


def run(ocp: SpinupOcp, method, title: str = "", multistart: bool = True, options: dict | None = None,
        segments: int = 0) -> SpinupResult:
    """Optimise (global search and multi-start), re-simulate, and compute the constant-ramp baselines.

    Parameters
    ----------
    ocp : SpinupOcp
        The declared problem (SI).
    method : DirectCollocation or MultipleShooting
        The transcription.
    title : str
        The scene's title (figures).
    multistart : bool
        Solve from several starts and keep the best re-simulated optimum.
    options : dict, optional
        IPOPT options (e.g. :func:`autobal.ocp.solve.ipopt_options`).
    segments : int
        Ramp segments of the drive's table (:func:`autobal.ocp.drive_profile.segment_profile`; 0: none, and none
        for the min_time objective).

    Returns
    -------
    SpinupResult
        The optimum's re-simulation beside the ramps; peaks in delta/e, times in s.
    """
    t0 = time.perf_counter()
    with forked.Later(functools.partial(timed, baselines, ocp)) as later:  # the ramps meanwhile, in a forked process
        opt = optimize(ocp, method, multistart, options)
        t1 = time.perf_counter()
        base, t_own = later.result()
        t_base = time.perf_counter() - t1  # what is left of them after the optimisation
    sol, tr = opt.solution, opt.trajectory
    use = {k: drive_use(ocp, v) for k, v in base.items()}
    # percentages refer only to the baselines the drive can run
    ref_key = best_within_limits({k: v.peak_delta for k, v in base.items()}, use)
    ref_peak = base[ref_key].peak_delta if ref_key else None
    t2 = time.perf_counter()
    seg = drive_profile.segment_profile(ocp, tr, segments) if segments and ocp.objective != "min_time" else None
    t_seg = time.perf_counter() - t2
    P = ocp.params
    zeta = P.chi / (2 * (P.c * P.m) ** 0.5)  # of the rotor with its liquid mass: u'' + 2 zeta w u' + w^2 u
    opt_use = drive_use(ocp, tr)
    # API 684 (2005) / API 617 (2014): AF off the half-power points of the rotor's own steady unbalance response, the
    # separation margin from the service speed (the final speed: the scene gives no operating range)
    rotor = Rotor(P.m1, P.c, P.chi, P.e, P.m2_star, P.omega_cr, zeta, ocp.omega_final,
                  **api_margins(P, ocp.omega_final), amplitude_convention="0-peak (the radius of the whirl orbit)")
    gain = _pct(tr.peak_delta, ref_peak)
    gain_constant = _pct(tr.peak_delta, base["constant_ramp"].peak_delta) \
        if use["constant_ramp"]["within_drive_limits"] is not False else None
    braking = -ocp.torque_bounds[0] if np.isfinite(ocp.torque_bounds[0]) else None
    # the optimum brakes when its smallest torque is below zero by more than the limit check's tolerance
    brakes = None if opt_use["min_torque_N_m"] is None or P.J_p == 0 else \
        bool(opt_use["min_torque_N_m"] < -DRIVE_TOL * torque_reference(ocp))
    outside = "no ramp baseline keeps the drive limits (each is labelled outside them): no gain is quoted"
    statuses = {f"{key}_status": why for key, value, why in (
        ("braking_torque_limit_N_m", braking, "no braking-torque limit: the scene names no drive limit"),
        ("torque_limit_N_m", ocp.torque_max, "no torque limit in the scene"),
        ("power_limit_W", ocp.power_max, "no power limit in the scene"),
        ("brakes", brakes, "unknown: the scene gives no drive inertia, so the optimum's torque is not known"),
        ("baseline_ramp_peak_over_e", ref_peak, outside), ("baseline_ramp_key", ref_key, outside),
        ("gain_vs_best_feasible_ramp_pct", gain, outside),
        ("gain_vs_constant_ramp_pct", gain_constant, "the constant ramp is outside the drive limits: no gain is "
                                                     "quoted")) if value is None}
    table = None if seg is None else RampTable(
        segments, seg.trajectory.peak_delta, seg.trajectory.peak_d, seg.objective, _pct(seg.objective, opt.score),
        seg.evaluations, seg.start, seg.start_objectives, **seg.drive, dwell=dwell(P, seg.trajectory, ocp.alpha_max))
    # the wall time by part (s): what the global search, the initial guesses, the NLP builds, the IPOPT solves,
    # the CVODES re-simulations (reference ramp, ranking near-ties, the optimum) took, and the wait for the baselines
    # (computed alongside: their own time is baselines_time_s); the coarse screening's guesses and solves, several at
    # once (solve.screen), by its own wall time
    screened = sum(r.get("solve_time_s", 0.0) for r in opt.starts if "coarse (" in str(r.get("stage", "")))
    total_solve = sum(r.get("solve_time_s", 0.0) for r in opt.starts)
    split = {"global_search": opt.times.get("global_search", 0.0), "screening": opt.times.get("screening", 0.0),
             "guesses": opt.times.get("guesses", 0.0), "build": opt.build_time_s, "solve": total_solve - screened,
             "resimulation": opt.times.get("resimulation", 0.0), "baselines_wait": t_base,
             "segments": t_seg}
    wall = time.perf_counter() - t0
    split["rest"] = wall - sum(split.values())
    return SpinupResult(
        title, ocp.objective, method.label, sol.status, tr.peak_delta, ref_peak, ref_key, gain, gain_constant,
        tr.peak_delta * P.e, rotor, opt.resimulation_rel_error, sol.solve_time_s, sol.iterations,
        sol.peak_collocation if ocp.objective != "peak_unbalance" else None, opt.score, opt.collocation_value,
        tr.peak_d, tr.t_peak,
        # chattering of the optimal acceleration: the one-interval pulses' total variation (alpha/alpha_max)
        pulse_variation(sol.u[:method.intervals]), float(np.interp(tr.t_peak, tr.t, tr.omega)),
        tr.integral_delta2, sol.final_time_s, opt.build_time_s, total_solve, wall, opt.starts,
        {k: Baseline(v.label, v.peak_delta, v.peak_d, v.t_peak, v.integral_delta2, **use[k]) for k, v in base.items()},
        ocp.params.psi, ocp.params.e, ocp.params.omega_cr, ocp.params.Omega0, ocp.params.zeta0, ocp.params.J_p,
        **opt_use, braking_torque_limit_N_m=braking, torque_limit_N_m=ocp.torque_max, power_limit_W=ocp.power_max,
        brakes=brakes, dwell=dwell(P, tr, ocp.alpha_max),
        accuracy={"estimate": opt.resimulation_rel_error,
                  "how": "relative difference between the transcription's optimal objective and its CVODES "
                         f"re-simulation (rtol {solver_options.defaults['resimulation.tol']:g}, "
                         f"{solver_options.defaults['resimulation.points']} samples per interval)"},
        **statuses,
        collocation_peak_unbalance=opt.collocation_value if ocp.objective == "peak_unbalance" else None,
        segments=table, baselines_time_s=t_own, time_split={f"{k}_time_s": v for k, v in split.items()},
        optimum=tr, ramp_runs=base, ramp_table_run=seg, controls={"t_start": tr.t_u, "acceleration": tr.alpha},
        ramp_table=None if seg is None else seg.table(tr.t[-1]))
