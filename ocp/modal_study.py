"""The multi-mode spin-up study of a scene (``ross_spinup``): the optimal spin-up of a reduced ROSS rotor
(:class:`autobal.ocp.modal.ModalSpinupOcp`, solved by :func:`autobal.ocp.solve.optimize`) beside the constant ramps,
every peak re-simulated, with the reduced model's critical speeds and their API 684 margins beside ROSS's own."""

from __future__ import annotations

import numpy as np

from autobal.analysis.numerics.standards import (
    Margin,
    half_power_readings,
    margin_check,
    margin_quantities,
    margin_words,
)
from autobal.analysis.run.fields import Record, TypedResult, declarations, quantity, record, unsaved
from autobal.analysis.run.figures import Figure, record_axis
from autobal.analysis.run.quantities import Quantity
from autobal.analysis.run.result import new_figure, speed_axis, unit_axis
from autobal.models import ross_rotor as rr
from autobal.models.ross_rotor import POINTS_PER_REV, RESIM_TOL
from autobal.ocp.columns import headed
from autobal.ocp.drive_profile import drive_table
from autobal.ocp.modal import ModalSpinupOcp, ModalTrajectory, baselines
from autobal.ocp.simulation import (
    DRIVE_QUANTITIES,
    DRIVE_TOL,
    best_within_limits,
    drive_use,
    ramp_runs,
    require_resimulations,
    torque_reference,
)
from autobal.ocp.solve import optimize


def _node():
    return quantity("1", "", "node of the shaft model")


def _peak(description: str, headline: int = 0):
    return quantity("m", "r*", description, "µm", headline=headline)


@record
class ModalBaseline(Record):
    """A constant-ramp baseline of the modal rotor, re-simulated, and its drive use."""

    label: str
    peak_deflection_m: float = _peak("peak deflection of a ramp baseline")
    time_of_peak_s: float = quantity("s", "t*", "time of a ramp baseline's peak")
    omega_at_peak_rad_s: float = quantity("rad/s", "ω*", "speed at a ramp baseline's peak")
    node_of_peak: int = _node()
    max_torque_N_m: float | None = quantity("N*m", "M", "largest and smallest drive torque of a ramp baseline")
    min_torque_N_m: float | None = quantity("N*m", "M", "largest and smallest drive torque of a ramp baseline")
    max_power_W: float | None = quantity("W", "P", "largest drive power of a ramp baseline", "kW")
    within_drive_limits: bool | None
    violated: list[str]


@record
class Unbalance(Record):
    node: int = _node()
    magnitude_kg_m: float = quantity("kg*m", "m e", "unbalance", "g·mm")
    phase_rad: float = quantity("rad", "φ", "phase of the unbalance")


def _critical():
    return quantity("rad/s", "ω_c", "critical speeds below the final speed: reduced model, ROSS")


def _damping():
    return quantity("1", "ζ", "damping ratio of each critical speed's mode: reduced model, ROSS")


@record
class CriticalSpeeds(Record):
    """The reduced model's critical speeds below the final speed with their API 684 margins, and ROSS's (None: not
    compared)."""

    reduced_wd_rad_s: list[float] = _critical()
    reduced_damping_ratio: list[float] = _damping()
    margins: list[Margin]
    ross_wd_rad_s: list[float] | None = _critical()
    ross_damping_ratio: list[float] | None = _damping()
    max_rel_error_vs_ross: float | None = quantity("1", "", "largest critical-speed difference from ROSS", headline=7)


def _time():
    return quantity("s", "", "times: final solve, search for starts")


def _frequency():
    return quantity("rad/s", "ω_n", "undamped natural frequencies of the kept modes, the cutoff, the lowest left out")


def _inertia():
    return quantity("kg*m^2", "J", "polar inertia the drive accelerates (rotor and drive); the rotor's, from ROSS's "
                                   "mass matrix")


_NO_INERTIA = "the rotor and its drive have no polar inertia: the drive torque is not known"
_NO_RAMP = "no ramp keeps the drive limits (each is labelled outside them): no gain is quoted"
_NOT_COMPARED = "not compared with ROSS (validate_with_ross: false)"


@record
class ModalSpinupResult(TypedResult):
    """The optimal spin-up of a reduced ROSS rotor beside the constant ramps (every peak re-simulated), with the
    reduced model's critical speeds beside ROSS's own: deflections in m (the largest radius of the whirl orbit over
    the nodes of interest, 0-peak), speeds in rad/s.  The run also holds the re-simulations and the Campbell diagram
    its figures draw (None in a Result loaded from results.json)."""

    title: str
    objective: str
    method: str
    status: str
    ipopt_iterations: int = quantity("1", "", "iterations of the final solve")
    solve_time_s: float = _time()
    build_time_s: float = quantity("s", "", "build time")
    search_time_s: float = _time()
    total_solve_time_s: float = quantity("s", "", "solve time (all starts)")
    peak_deflection_m: float = _peak("peak deflection of the optimum, 0-peak (re-simulated)", 1)
    collocation_peak_m: float = _peak("peak deflection of the collocation / of a start's optimum, re-simulated")
    resimulation_rel_error: float = quantity("1", "", "relative difference, CVODES re-simulation vs collocation")
    node_of_peak: int = quantity("1", "", "node of the peak")
    time_of_peak_s: float = quantity("s", "t*", "time of the peak", headline=4)
    omega_at_peak_rad_s: float = quantity("rad/s", "ω*", "speed at the peak", headline=5)
    baseline_ramp_peak_m: float | None = _peak("peak deflection of the best ramp within the drive limits", 2)
    baseline_ramp_key: str | None
    improvement_over_best_ramp: float | None = quantity("1", "", "improvement over that ramp, 1 − r*/r*_ramp",
                                                        headline=3)
    #: one row per NLP solve of the multi-start (its keys by stage: the solver's log)
    starts: list[dict]
    baselines: dict[str, ModalBaseline]
    max_torque_N_m: float | None  # DRIVE_QUANTITIES
    min_torque_N_m: float | None
    max_power_W: float | None
    within_drive_limits: bool | None
    violated: list[str]
    drive_polar_inertia_kg_m2: float = _inertia()
    rotor_polar_inertia_kg_m2: float = _inertia()
    torque_limit_N_m: float | None
    power_limit_W: float | None
    braking_torque_limit_N_m: float | None
    max_deceleration_rad_s2: float = quantity("rad/s^2", "−α_min", "largest deceleration the drive allows")
    brakes: bool | None
    modes: int = quantity("1", "", "modes kept")
    natural_frequencies_rad_s: list[float] = _frequency()
    mode_cutoff_rad_s: float = quantity("rad/s", "ω_c", "mode cutoff")
    lowest_dropped_natural_frequency_rad_s: float | None = _frequency()
    gyroscopic: bool
    gyroscopic_shift: float = quantity("1", "", "largest relative shift of a critical speed by the gyroscopic terms")
    unbalance: list[Unbalance]
    critical_speeds: CriticalSpeeds
    accuracy: dict
    final_speed_rad_s: float = quantity("rad/s", "ω_f", "final (service) speed", headline=6)
    optimum: ModalTrajectory | None = unsaved()
    ramp_runs: dict | None = unsaved()  # baseline key -> its ModalTrajectory
    campbell: dict | None = unsaved()  # "omega" (rad/s), "wd" (rad/s, speeds x modes) of the reduced model
    name = "ross_spinup"
    null_reasons = {"ross_wd_rad_s": _NOT_COMPARED, "ross_damping_ratio": _NOT_COMPARED,
                    "max_rel_error_vs_ross": _NOT_COMPARED,
                    "lowest_dropped_natural_frequency_rad_s": "no mode was left out: all lateral modes are below the "
                                                              "cutoff",
                    **dict.fromkeys(("baseline_ramp_peak_m", "baseline_ramp_key", "improvement_over_best_ramp"),
                                    _NO_RAMP),
                    **dict.fromkeys(("max_torque_N_m", "min_torque_N_m", "max_power_W", "within_drive_limits",
                                     "brakes"), _NO_INERTIA),
                    "torque_limit_N_m": "no torque limit in the scene", "power_limit_W": "no power limit in the scene",
                    "braking_torque_limit_N_m": "no braking-torque limit in the scene"}

    @property
    def peak_deflection(self) -> float:
        """Re-simulated peak deflection of the optimum over the nodes of interest, m."""
        return self.peak_deflection_m

    @property
    def best_ramp_peak(self) -> float:
        """Re-simulated peak deflection of the better constant ramp, m."""
        return self.baseline_ramp_peak_m

    @property
    def critical_speed_rel_error(self) -> float | None:
        """Largest relative difference between the reduced model's critical speeds and ROSS's (None unchecked)."""
        return self.critical_speeds.max_rel_error_vs_ross

    @property
    def final_speed(self) -> float:
        """The final (service) speed, rad/s: where the optimum ends."""
        return self.final_speed_rad_s

    def verdict(self) -> tuple[bool | None, str]:
        """The optimum's peak deflection (0-peak) against the best ramp within the drive limits (the only reference a
        gain is quoted against), whether it brakes and keeps the drive limits; the NLP status first when it failed."""
        q = QUANTITIES.find
        words = f"peak deflection {q('peak_deflection_m').text(self.peak_deflection_m)} 0-peak at node " \
                f"{self.node_of_peak}"
        gain = self.improvement_over_best_ramp
        if gain is not None:
            words += (f", {-100 * gain:+.1f} % against the best ramp within the drive limits "
                      f"({q('baseline_ramp_peak_m').text(self.baseline_ramp_peak_m)})")
        else:
            words += ", no ramp keeps the drive limits: no gain is quoted"
        if self.brakes is not None:
            words += (f"; it brakes (smallest torque {q('min_torque_N_m').text(self.min_torque_N_m)})" if self.brakes
                      else "; it does not brake")
        ok = gain is None or gain >= -1e-4
        if self.within_drive_limits is False:
            ok, words = False, words + f"; drive limits EXCEEDED ({', '.join(self.violated or [])})"
        if self.status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
            ok, words = False, f"NLP solver {self.status}: " + words
        return ok, words

    def summary(self) -> str:
        cs, q = self.critical_speeds, QUANTITIES.find
        ok, words = self.verdict()
        ross = cs.ross_wd_rad_s
        speed = q("critical_speeds.reduced_wd_rad_s")
        lines = [f"multi-mode spin-up: {'ok' if ok else 'NOT OK'}: {words}", *self.quantities.lines(self.to_dict()),
                 f"  {self.modes} modes up to {q('mode_cutoff_rad_s').text(self.mode_cutoff_rad_s)}, gyroscopic "
                 f"terms {'kept' if self.gyroscopic else 'dropped'} (they move a critical speed by "
                 f"{100 * self.gyroscopic_shift:.3g} %)",
                 "  critical speeds below the final speed (reduced model; API 684 (2005): amplification factor at "
                 "the half-power points of the unbalance response at the nodes of interest, separation margin from "
                 "the final (service) speed):"]
        for i, w in enumerate(cs.reduced_wd_rad_s):
            lines.append(f"    {speed.text(w)}: {margin_words(cs.margins[i].to_dict())}"
                         + ("" if ross is None or i >= len(ross) else f"; ROSS {speed.text(ross[i])}"))
        if ross is not None:
            lines.append(f"  largest difference of the reduced model's critical speeds from ROSS's: "
                         f"{100 * cs.max_rel_error_vs_ross:.3f} %")
        lines.append(f"  NLP: {self.status}, {self.ipopt_iterations} IPOPT iterations, {self.solve_time_s:.2f} s "
                     f"(build {self.build_time_s:.2f} s, search for starts {self.search_time_s:.2f} s); collocation "
                     f"peak {q('collocation_peak_m').text(self.collocation_peak_m)} (difference "
                     f"{self.resimulation_rel_error:.2e})")
        for k, v in self.baselines.items():
            lim = " (outside the drive limits: " + ", ".join(v.violated) + ")" if v.within_drive_limits is False \
                else ""
            lines.append(f"  {v.label:40s} peak {q('peak_deflection_m').text(v.peak_deflection_m)} at node "
                         f"{v.node_of_peak}{lim}" + (" [reference]" if k == self.baseline_ramp_key else ""))
        return "\n".join(lines)

    def _held(self):
        require_resimulations(self.name, self.optimum)

    def tables(self) -> dict[str, dict]:
        """The tables headed 'name [unit]' in their display units (:func:`autobal.ocp.columns.headed`); each ramp's
        time beside its speed and largest deflection over the nodes."""
        self._held()
        o, cs = self.optimum, self.critical_speeds
        cols = {}
        for k, v in self.ramp_runs.items():
            cols |= {f"{k}_time": v.t, f"{k}_speed": v.omega, f"{k}_deflection": v.deflection.max(axis=0)}
        n = min(len(c) for c in cols.values())
        m = len(cs.reduced_wd_rad_s)
        ross = cs.ross_wd_rad_s
        tables = {"ross_spinup_optimum.csv": {"time": o.t, "speed": o.omega} | {
                      f"deflection_node{nd}": o.deflection[i] for i, nd in enumerate(o.nodes)},
                  "ross_spinup_controls.csv": {"t_start": o.t_u, "acceleration": o.alpha},
                  "drive_profile.csv": drive_table(o),
                  "ross_spinup_baselines.csv": {k: np.asarray(v)[:n] for k, v in cols.items()},
                  "ross_modes.csv": {"mode": np.arange(1, self.modes + 1),
                                     "natural_frequency": self.natural_frequencies_rad_s},
                  "ross_critical_speeds.csv": {"reduced_wd": cs.reduced_wd_rad_s,
                                               "reduced_damping_ratio": cs.reduced_damping_ratio,
                                               "ross_wd": (ross[:m] + [np.nan] * (m - len(ross))) if ross is not None
                                               else [np.nan] * m}}
        return {file: headed(t) for file, t in tables.items()}

    def _runs(self):
        self._held()
        uses = {k: {"within_drive_limits": b.within_drive_limits} for k, b in self.baselines.items()}
        return [(self.optimum, "C3", "-", 1.4, "optimum"), *ramp_runs(self.ramp_runs, uses)]

    def _criticals(self, ax, vertical: bool, factor: float) -> None:
        for i, w in enumerate(self.critical_speeds.reduced_wd_rad_s):
            (ax.axvline if vertical else ax.axhline)(w * factor, color="k", lw=0.6, ls=":",
                                                     label="critical speeds (reduced model)" if i == 0 else None)

    def draw(self, ax) -> None:
        """Largest deflection over the nodes of interest against speed, optimum and ramps (the declared display unit,
        µm; the speed in rpm, rad/s on top)."""
        q = QUANTITIES.find("peak_deflection_m")
        fw = speed_axis(ax, "x")
        for tr, c, ls, lw, lab in self._runs():
            ax.plot(tr.omega * fw, q.shown(tr.deflection.max(axis=0)), color=c, ls=ls, lw=lw,
                    label=f"{lab} (peak {q.text(tr.peak)})")
        self._criticals(ax, True, fw)
        ax.set_ylabel(rf"deflection $\max_{{nodes}}\sqrt{{x^2+y^2}}$, {q.display} 0-peak")
        record_axis(ax, "y", q.unit, q.display)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict[str, Figure]:
        """Speed (rpm, rad/s) and acceleration (rad/s², rpm/s) against time; deflection (µm) against time and speed;
        Campbell diagram (rad/s, rpm and Hz); every axis in its display unit."""
        title, q = self.title, QUANTITIES.find("peak_deflection_m")
        fig, axes = new_figure((8, 6), 2, 1, sharex=True)
        ft = unit_axis(axes[1], "time t", "s", which="x")
        fw, fa = speed_axis(axes[0]), unit_axis(axes[1], r"acceleration $\alpha$", "rad/s^2")
        for tr, c, ls, lw, lab in self._runs():
            axes[0].plot(tr.t * ft, tr.omega * fw, color=c, ls=ls, lw=lw, label=lab)
            axes[1].plot(np.append(tr.t_u, tr.t[-1]) * ft, np.append(tr.alpha, tr.alpha[-1]) * fa,
                         drawstyle="steps-post", color=c, ls=ls, lw=lw)
        self._criticals(axes[0], False, fw)
        for ax in axes:
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.suptitle(title, fontsize=9)

        fig2, (a1, a2) = new_figure((8, 7), 2, 1)
        ft = unit_axis(a1, "time t", "s", which="x")
        for tr, c, ls, lw, _ in self._runs():
            a1.plot(tr.t * ft, q.shown(tr.deflection.max(axis=0)), color=c, ls=ls, lw=lw)
        a1.set_ylabel(f"deflection, {q.display} 0-peak")
        record_axis(a1, "y", q.unit, q.display)
        a1.grid(alpha=0.3)
        self.draw(a2)
        fig2.suptitle(title, fontsize=9)

        fig3, ax = new_figure((7, 5))
        cb, cs = self.campbell, self.critical_speeds
        fw = speed_axis(ax, "x")
        ff = unit_axis(ax, "frequency", "rad/s", "Hz", other="rad/s")
        for k in range(cb["wd"].shape[1]):
            ax.plot(cb["omega"] * fw, cb["wd"][:, k] * ff, color="C0", lw=1.0,
                    label="damped natural frequencies (reduced)" if k == 0 else None)
        ax.plot(cb["omega"] * fw, cb["omega"] * ff, color="k", lw=0.8, label="synchronous line")
        ax.plot(np.asarray(cs.reduced_wd_rad_s) * fw, np.asarray(cs.reduced_wd_rad_s) * ff, "o", mfc="none",
                color="C3", label="critical speeds (reduced)")
        if cs.ross_wd_rad_s is not None:
            ax.plot(np.asarray(cs.ross_wd_rad_s) * fw, np.asarray(cs.ross_wd_rad_s) * ff, "x", color="k",
                    label="critical speeds (ROSS)")
        ax.set_ylim(0, 1.2 * cb["omega"][-1] * ff)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title("Campbell diagram of the reduced rotor", fontsize=9)
        what = "of the optimum beside the ramps, critical speeds of the reduced model dotted"
        return {"ross_spinup_profiles.png": Figure(fig, f"Multi-mode spin-up: speed and acceleration against time "
                                                        f"{what}"),
                "ross_spinup_deflection.png": Figure(fig2, "Multi-mode spin-up: deflection (largest over the nodes) "
                                                           f"against time and against speed {what}"),
                "ross_campbell.png": Figure(fig3, "Campbell diagram of the reduced rotor: damped natural frequencies "
                                                  "against speed, critical speeds of the reduced model (o) and of "
                                                  "ROSS (x)")}


#: every number of the ross_spinup block, from the fields: deflections in m (the largest radius of the whirl orbit
#: over the nodes of interest, 0-peak), speeds in rad/s; the drive's use of the optimum and the API 684 margins
#: (declared where they are computed) and the solver log of the starts as extra declarations
ModalSpinupResult.quantities = QUANTITIES = declarations(
    ModalSpinupResult, *DRIVE_QUANTITIES, *margin_quantities("critical_speeds.margins[]."),
    Quantity("starts[].objective starts[].resimulated_peak_m", "m", "r*", "peak deflection of a start's optimum, "
             "re-simulated", "µm"),
    Quantity("starts[].iterations", "1", "", "iterations of a start's solve"),
    Quantity("starts[].solve_time_s starts[].build_time_s", "s", "", "a start's solve and build time"))


def steady_deflection(ocp: ModalSpinupOcp, omega) -> np.ndarray:
    """The steady unbalance response at constant speeds ``omega`` (rad/s): the largest deflection envelope over the
    nodes of interest (the major half-axis of each node's orbit, :meth:`ModalSpinupOcp.epigraph2`) of the steady modal
    amplitude (:meth:`autobal.models.ross_rotor.ModalRotor.steady_amplitude`), m."""
    omega = np.atleast_1d(np.asarray(omega, float))
    a, n = ocp.amplitude_scale, ocp.rotor.n
    E = np.array([ocp.rotor.steady_amplitude(w) for w in omega]) / a
    X = np.hstack([E.real, E.imag, np.zeros((omega.size, 2 * n)), omega[:, None] / ocp.omega_final])
    return np.sqrt(ocp.epigraph2(X)) * a


def api_readings(ocp: ModalSpinupOcp, cs: dict) -> list:
    """Each critical speed of the reduced model (``cs``, :meth:`~autobal.models.ross_rotor.ModalRotor.critical_speeds`)
    read off the steady unbalance response at the nodes of interest (:func:`steady_deflection`) up to the mode cutoff
    (:func:`autobal.analysis.numerics.standards.half_power_readings`, API 684 (2005): AF at the half-power points)."""
    return half_power_readings(lambda w: steady_deflection(ocp, w), cs["wd"], high=ocp.rotor.cutoff_rad_s,
                               undamped=[z <= 0 for z in cs["damping_ratio"]])


def run(ocp: ModalSpinupOcp, title: str = "", ross_critical: dict | None = None,
        options: dict | None = None) -> ModalSpinupResult:
    """Optimise the spin-up of the reduced rotor (multi-start), re-simulate, compare with the ramps.

    Parameters
    ----------
    ocp : ModalSpinupOcp
        The problem: the reduced rotor (:func:`autobal.models.ross_rotor.reduce`), its drive and mesh (SI: rad/s,
        rad/s^2, s).
    title : str
        For the figures.
    ross_critical : dict, optional
        ROSS's own critical speeds (:func:`autobal.models.ross_rotor.ross_critical_speeds`).
    options : dict, optional
        IPOPT options.

    Returns
    -------
    ModalSpinupResult
        Peaks in m, times in s, speeds in rad/s.
    """
    rotor = ocp.rotor
    opt = optimize(ocp, ocp.method, options=options)
    base = baselines(ocp)
    sol, tr = opt.solution, opt.trajectory
    cs = rotor.critical_speeds(ocp.omega_final)
    ross = None if ross_critical is None else list(ross_critical["wd"])
    use = {k: drive_use(ocp, v) for k, v in base.items()}
    ref_key = best_within_limits({k: v.peak for k, v in base.items()}, use)  # a gain only against these
    ref = base[ref_key].peak if ref_key else None
    opt_use = drive_use(ocp, tr)
    margins = [Margin(**margin_check(r, ocp.omega_final)) for r in api_readings(ocp, cs)]
    return ModalSpinupResult(
        title, "peak deflection over the nodes " + ", ".join(map(str, ocp.nodes)),
        f"Radau collocation (degree {ocp.degree}, {ocp.intervals} intervals + {ocp.settling_intervals} settling) of "
        "the complex envelope, structured derivatives; starts from a screened grid of four-phase profiles",
        sol.status, sol.iterations, sol.solve_time_s, opt.build_time_s, opt.times["global_search"],
        sum(r.get("solve_time_s", 0.0) for r in opt.starts), tr.peak, sol.peak_collocation,
        opt.resimulation_rel_error, tr.node_of_peak, tr.t_peak, float(np.interp(tr.t_peak, tr.t, tr.omega)), ref,
        ref_key, None if ref is None else 1 - tr.peak / ref, opt.starts,
        {k: ModalBaseline(v.label, v.peak, v.t_peak, float(np.interp(v.t_peak, v.t, v.omega)), int(v.node_of_peak),
                          **use[k]) for k, v in base.items()},
        **opt_use, drive_polar_inertia_kg_m2=ocp.inertia, rotor_polar_inertia_kg_m2=rotor.polar_inertia,
        torque_limit_N_m=ocp.torque_max, power_limit_W=ocp.power_max,
        braking_torque_limit_N_m=-ocp.torque_bounds[0] if np.isfinite(ocp.torque_bounds[0]) else None,
        max_deceleration_rad_s2=-ocp.u_min * ocp.alpha_max,
        brakes=None if opt_use["min_torque_N_m"] is None else
        bool(opt_use["min_torque_N_m"] < -DRIVE_TOL * torque_reference(ocp)),
        modes=rotor.n, natural_frequencies_rad_s=list(rotor.omega_n), mode_cutoff_rad_s=rotor.cutoff_rad_s,
        lowest_dropped_natural_frequency_rad_s=rotor.dropped_omega_n, gyroscopic=rotor.gyroscopic,
        gyroscopic_shift=rotor.gyroscopic_shift,
        unbalance=[Unbalance(u.node, u.magnitude, u.phase) for u in rotor.unbalances],
        critical_speeds=CriticalSpeeds(
            list(cs["wd"]), list(cs["damping_ratio"]), margins, ross,
            None if ross_critical is None else list(ross_critical["damping_ratio"]),
            rr.compare_critical_speeds(cs["wd"], ross_critical and ross_critical["wd"])),
        accuracy={"estimate": opt.resimulation_rel_error,
                  "how": "relative difference between the collocation's peak envelope and the CVODES re-simulation "
                         f"of the physical response (rtol {RESIM_TOL:g}, {POINTS_PER_REV} samples per revolution)"},
        final_speed_rad_s=float(tr.omega[-1]), optimum=tr, ramp_runs=base,
        campbell=rotor.campbell(1.2 * ocp.omega_final))
