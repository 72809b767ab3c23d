"""The ``spinup`` analysis of a scene: the optimal spin-up profile beside the constant-ramp baselines.

``run(ocp, method)`` returns a :class:`SpinupResult` (the ``spinup`` block of results.json, CSV
tables and figures: omega(t), alpha(t), torque, deflection against time and against speed, the
optimum and both ramps on each plot).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass

import numpy as np

from autobal.analysis import solver_options, standards
from autobal.analysis.quantities import Declarations, Quantity, significant
from autobal.analysis.result import Result, new_figure, speed_axis, twin_axis, unit_axis
from autobal.analysis.rotor_study import api_margins
from autobal.ocp import drive_profile
from autobal.ocp.drive_profile import RPM
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


def _drive(prefix: str = "") -> str:
    return " ".join(f"{prefix}{k}" for k in ("max_torque_N_m", "min_torque_N_m"))


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


#: every number of the spinup block: deflections delta/e (the source's group, Pashkov (2010), Eq. (2)) beside the
#: physical deflection (0-peak, the radius of the whirl orbit); the headline quantities first, in summary order
QUANTITIES = Declarations(
    Quantity("peak_deflection_m", "m", "δ*", "peak deflection of the optimum, 0-peak (re-simulated)", "mm",
             headline=True),
    Quantity("peak_deflection_over_e", "1", "δ*/e", "peak deflection of the optimum over the eccentricity",
             headline=True),
    Quantity("baseline_ramp_peak_over_e", "1", "δ*/e", "peak of the best ramp within the drive limits",
             headline=True),
    Quantity("gain_vs_best_feasible_ramp_pct", "%", "", "gain of the optimum against that ramp", headline=True),
    Quantity("gain_vs_constant_ramp_pct", "%", "", "gain of the optimum against the constant ramp"),
    Quantity("rotor.critical_speed_rad_s", "rad/s", "ω_cr", "undamped critical speed √(c/m), m the rotor's mass with "
             "its liquid layer's if it has one (critical_label says which)"),
    Quantity("omega_cr_rad_s", "rad/s", "ω_cr", "critical speed Ω0 √ψ", source=f"{_P10}, ch. 3"),
    *standards.margin_quantities("rotor.", headline=True),
    Quantity("rotor.service_speed_rad_s", "rad/s", "N_s", "service speed (the final speed of the spin-up)"),
    *DRIVE_QUANTITIES,
    Quantity("time_of_peak_s", "s", "t*", "time of the peak"),
    Quantity("omega_at_peak_rad_s", "rad/s", "ω*", "speed at the peak"),
    Quantity("final_time_s", "s", "T", "final time (the deadline, or the arrival with min_time)"),
    Quantity("rotor.mass_kg", "kg", "m1", "rotor mass", source=f"{_P10}, ch. 3"),
    Quantity("rotor.liquid_mass_kg", "kg", "m2*", "full-chamber liquid mass ρπR²h", source=f"{_P10}, ch. 3"),
    Quantity("rotor.stiffness_N_per_m", "N/m", "c", "shaft stiffness"),
    Quantity("rotor.damping_N_s_per_m", "N*s/m", "χ", "external viscous damping"),
    Quantity("rotor.eccentricity_m eccentricity_m", "m", "e", "eccentricity (mass centre from the shaft axis)", "µm"),
    Quantity("rotor.damping_ratio", "1", "ζ", "damping ratio χ/(2√(c m)) of the rotor with its liquid mass"),
    Quantity("psi", "1", "ψ", "mass ratio m1/(m1 + m2*)", source=f"{_P10}, ch. 3"),
    Quantity("Omega0_rad_s", "rad/s", "Ω0", "natural frequency √(c/m1) of the rotor without liquid",
             source=f"{_P10}, ch. 3"),
    Quantity("zeta0", "1", "ζ0", "damping group of the source", source=f"{_P10}, ch. 3"),
    Quantity("drive_polar_inertia_kg_m2", "kg*m^2", "J_p", "polar inertia of the rotor and drive"),
    Quantity("peak_unbalance collocation_peak_unbalance", "1", "d*", "peak system unbalance",
             source=f"{_P10}, Eq. (2)"),
    Quantity("collocation_peak_over_e", "1", "δ*/e", "peak deflection of the collocation (before re-simulation)"),
    Quantity("integral_deflection2_s", "s", "∫(δ/e)² dt", "integral of the squared deflection over the window"),
    Quantity("control_pulse_variation", "1", "", "chattering: total variation of the one-interval pulses of α/α_max"),
    Quantity("resimulation_rel_error", "1", "", "relative difference, CVODES re-simulation vs transcription"),
    Quantity("ipopt_iterations", "1", "", "iterations of the final solve"),
    Quantity("solve_time_s total_solve_time_s build_time_s wall_time_s time_split.*", "s", "",
             "times: final solve, every solve, NLP builds, the analysis; the wall time by part"),
    Quantity("starts[].iterations", "1", "", "iterations of a start's solve"),
    Quantity("starts[].solve_time_s starts[].build_time_s", "s", "", "solve and build time of a start"),
    Quantity("starts[].resimulated_peak_over_e", "1", "δ*/e", "re-simulated peak of a start"),
    Quantity("baselines.*.peak_deflection_over_e", "1", "δ*/e", "peak deflection of a ramp baseline"),
    Quantity("baselines.*.peak_unbalance", "1", "d*", "peak system unbalance of a ramp baseline"),
    Quantity("baselines.*.time_of_peak_s", "s", "t*", "time of a ramp baseline's peak"),
    Quantity("baselines.*.integral_deflection2_s", "s", "∫(δ/e)² dt", "integral of a ramp baseline's δ²"),
    Quantity(_drive("baselines.*.") + " " + _drive("segments."), "N*m", "M", "largest and smallest drive torque"),
    Quantity("baselines.*.max_power_W segments.max_power_W", "W", "P", "largest drive power", "kW"),
    Quantity("segments.segments", "1", "K", "ramp segments of the drive's table"),
    Quantity("dwell.time_near_critical_s segments.dwell.time_near_critical_s", "s", "t_cr",
             f"time within {100 * DWELL_BAND:.0f} % of the critical speed (optimum, ramp table)"),
    Quantity("dwell.fastest_crossing_s segments.dwell.fastest_crossing_s", "s", "",
             f"time the maximum acceleration takes across {100 * DWELL_BAND:.0f} % either side of the critical speed"),
    Quantity("dwell.hold_speed_rad_s segments.dwell.hold_speed_rad_s", "rad/s", "ω_hold",
             f"speed held longest within {100 * DWELL_BAND:.0f} % of the critical speed (time-weighted median)"),
    Quantity("dwell.hold_steady_deflection_over_e segments.dwell.hold_steady_deflection_over_e", "1", "δ_ss/e",
             "steady whirl of the rotor at that speed"),
    Quantity("segments.peak_deflection_over_e", "1", "δ*/e", "peak deflection of the ramp table (re-simulated)"),
    Quantity("segments.peak_unbalance", "1", "d*", "peak system unbalance of the ramp table"),
    Quantity("segments.loss_vs_optimum_pct", "%", "", "loss of the ramp table against the full optimum"),
    Quantity("segments.evaluations", "1", "", "re-simulations of the ramp table's search"),
    resolve=objective_quantity,
)


@dataclass
class SpinupResult(Result):
    """The optimal spin-up profile beside the constant-ramp baselines (every peak re-simulated)."""

    data: dict  # the results.json block
    optimum: Trajectory
    baselines: dict  # key -> Trajectory
    segments: drive_profile.Segments | None = None
    name = "spinup"
    quantities = QUANTITIES

    @property
    def peak_deflection(self) -> float:
        """Re-simulated peak deflection of the optimum over the horizon and the settling window, delta/e."""
        return self.data["peak_deflection_over_e"]

    @property
    def resimulation_rel_error(self) -> float:
        """Relative difference between the transcription's optimum and its CVODES re-simulation."""
        return self.data["resimulation_rel_error"]

    def to_dict(self) -> dict:
        return self.data

    def verdict(self) -> tuple[bool | None, str]:
        return verdict(self.data)

    def summary(self) -> str:
        d = self.data
        ok, words = self.verdict()
        q = QUANTITIES.find
        status = {True: "ok", False: "NOT OK", None: "to check"}[ok]
        lines = [f"spin-up ({d['objective'].replace('_', ' ')}): {status}: {words}",
                 f"  {critical_label(d['rotor']['liquid_mass_kg'] > 0)}  ω_cr  "
                 f"{q('rotor.critical_speed_rad_s').text(d['rotor']['critical_speed_rad_s'])}",
                 *QUANTITIES.lines(d),
                 f"  API 684 (2005): {standards.margin_words(d['rotor'])}",
                 f"  NLP ({d['method']}): {d['status']}, {d['ipopt_iterations']} iterations in the final solve "
                 f"({d['solve_time_s']:.2f} s); {len(d['starts'])} starts and mesh stages "
                 f"{d['total_solve_time_s']:.2f} s (" + ", ".join(f"{r['solve_time_s']:.2f}" for r in d["starts"]
                                                               if "solve_time_s" in r)
                 + f" s), NLP build {d['build_time_s']:.2f} s, wall {d['wall_time_s']:.2f} s (with the global "
                 "search, re-simulations and baselines)",
                 "  wall time split: " + ", ".join(f"{k[:-7].replace('_', ' ')} {v:.2f} s" for k, v in
                                                   d.get("time_split", {}).items()),
                 f"  optimum: collocation peak {significant(d['collocation_peak_over_e'])} e (re-simulation "
                 f"difference {d['resimulation_rel_error']:.2e}), peak unbalance {significant(d['peak_unbalance'])}, "
                 f"peak at t = {q('time_of_peak_s').text(d['time_of_peak_s'])} and "
                 f"{q('omega_at_peak_rad_s').text(d['omega_at_peak_rad_s'])}, final time "
                 f"{q('final_time_s').text(d['final_time_s'])}, chattering (pulse variation of alpha/alpha_max) "
                 f"{d['control_pulse_variation']:.3g}"]
        j = QUANTITIES.find("objective_value", d)
        if j is not None and d.get("objective_value") is not None:
            lines.append(f"  objective {j.symbol} ({d['objective'].replace('_', ' ')}): {j.text(d['objective_value'])}")
        r = d["rotor"]
        rotor = ", ".join(f"{sym} {q(f'rotor.{k}').text(r[k])}" for sym, k in (
            ("m1", "mass_kg"), ("c", "stiffness_N_per_m"), ("χ", "damping_N_s_per_m"), ("ζ", "damping_ratio"),
            ("e", "eccentricity_m")))
        lines.append(f"  rotor: {rotor}; deflections are 0-peak (the radius of the whirl orbit)")
        e = d["eccentricity_m"]
        for k, v in d["baselines"].items():
            lim = {True: "", False: " (outside the drive limits: " + ", ".join(v["violated"]) + ")",
                   None: ""}[v["within_drive_limits"]]
            ref = " [reference]" if k == d["baseline_ramp_key"] else ""
            lines.append(f"  {v['label']:52s} peak {deflection_text(v['peak_deflection_over_e'], e)}{lim}{ref}")
        if d["gain_vs_constant_ramp_pct"] is not None:
            lines.append(f"  gain against the constant ramp: {d['gain_vs_constant_ramp_pct']:+.2f} %")
        sg = d.get("segments")
        if sg:
            lines.append(f"  {sg['segments']}-segment ramp table: peak "
                         f"{deflection_text(sg['peak_deflection_over_e'], e)}, {sg['loss_vs_optimum_pct']:+.2f} % "
                         f"against the full optimum (searched from the {sg['start']} start)"
                         + ("" if sg["within_drive_limits"] else " (outside the drive limits)"))
            if (sg.get("dwell") or {}).get("dwells"):
                lines.append("  CAUTION: " + dwell_words(f"the {sg['segments']}-segment ramp table", sg["dwell"],
                                                         d["omega_cr_rad_s"]))
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        o = self.optimum
        cols = {"t_s": next(iter(self.baselines.values())).t}
        for k, v in self.baselines.items():
            cols |= {f"{k}_omega_rad_s": v.omega, f"{k}_deflection_over_e": v.delta, f"{k}_unbalance_d": v.d}
        e = self.data.get("eccentricity_m") or np.nan
        return {"spinup_optimum.csv": {"t_s": o.t, "omega_rad_s": o.omega, "omega_rpm": o.omega * RPM,
                                       "deflection_over_e": o.delta, "deflection_mm": o.delta * e * 1e3,
                                       "unbalance_d": o.d, "torque_N_m": o.torque},
                "spinup_controls.csv": {"t_start_s": o.t_u, "alpha_rad_s2": o.alpha},
                "spinup_baselines.csv": cols, "drive_profile.csv": drive_profile.drive_table(o)} | (
            {} if self.segments is None else {"drive_segments.csv": self.segments.table(o.t[-1])})

    def _runs(self):
        seg = [] if self.segments is None else [(self.segments.trajectory, "C4", "-.", 1.0,
                                                 self.segments.trajectory.label)]
        return [(self.optimum, "C3", "-", 1.4, "optimum"), *seg, *ramp_runs(self.baselines, self.data["baselines"])]

    def draw(self, ax) -> None:
        """Deflection against time of the optimum and both ramps (delta/e; mm on the right)."""
        ft = unit_axis(ax, "time t", "s", which="x")
        for tr, c, ls, lw, lab in self._runs():
            ax.plot(tr.t * ft, tr.delta, color=c, ls=ls, lw=lw,
                    label=f"{lab} (peak {deflection_text(tr.peak_delta, self.data.get('eccentricity_m'))})")
        ax.set_ylabel(r"deflection $\delta/e$")
        deflection_axis(ax, self.data.get("eccentricity_m"))
        ax.grid(alpha=0.3)
        legend_above_curves(ax)  # every run's peak stays visible

    def figures(self) -> dict:
        """Speed (rpm, rad/s), acceleration steps (rad/s², rpm/s), drive torque (N·m) and, with drive data, power (kW)
        against time; deflection (delta/e, mm) against time and speed; every axis in its display unit."""
        title = self.data["title"]
        wc = self.data["omega_cr_rad_s"]
        drive = self.data["drive_polar_inertia_kg_m2"] != 0
        fig, axes = new_figure((8, 10 if drive else 8), 4 if drive else 3, 1, sharex=True)
        kw = QUANTITIES.find("max_power_W")
        ft = unit_axis(axes[-1], "time t", "s", which="x")
        fw = speed_axis(axes[0])
        fa = unit_axis(axes[1], r"acceleration $\alpha$", "rad/s^2")
        fm = unit_axis(axes[2], "drive torque M" if drive else "torque M", "N*m")
        fp = unit_axis(axes[3], "drive power P", "W", kw.declared) if drive else None
        for tr, c, ls, lw, lab in self._runs():
            axes[0].plot(tr.t * ft, tr.omega * fw, color=c, ls=ls, lw=lw, label=lab)
            axes[1].plot(np.append(tr.t_u, tr.t[-1]) * ft, np.append(tr.alpha, tr.alpha[-1]) * fa,
                         drawstyle="steps-post", color=c, ls=ls, lw=lw)
            axes[2].plot(tr.t * ft, tr.torque * fm, color=c, ls=ls, lw=lw)
            if drive:
                axes[3].plot(tr.t * ft, tr.torque * tr.omega * fp, color=c, ls=ls, lw=lw)
        liquid = self.data["rotor"]["liquid_mass_kg"] > 0
        axes[0].axhline(wc * fw, color="k", lw=0.8, ls=":", label=critical_label(liquid, tex=True) + " = "
                        + QUANTITIES.find("omega_cr_rad_s").text(wc))
        if drive:
            brake = self.data.get("braking_torque_limit_N_m")
            for ax, limit, f in ((axes[2], self.data.get("torque_limit_N_m"), fm),
                                 (axes[2], None if brake is None else -brake, fm),
                                 (axes[3], self.data.get("power_limit_W"), fp)):
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
        for tr, c, ls, lw, _ in self._runs():
            a2.plot(tr.omega * fw, tr.delta, color=c, ls=ls, lw=lw)
        a2.axvline(wc * fw, color="k", lw=0.8, ls=":", label=critical_label(liquid, tex=True) + " = "
                   + QUANTITIES.find("omega_cr_rad_s").text(wc))
        a2.set_ylabel(r"deflection $\delta/e$")
        deflection_axis(a2, self.data.get("eccentricity_m"))
        a2.grid(alpha=0.3)
        a2.legend(fontsize=7)
        fig2.suptitle(title, fontsize=9)
        return {"spinup_profiles.png": fig, "spinup_deflection.png": fig2}


def dwell(P, tr: Trajectory, alpha_max: float) -> dict:
    """How long a profile stays near the critical speed: its time within DWELL_BAND of omega_cr (s), the time
    the maximum acceleration ``alpha_max`` takes across that band, the speed it spends the most time at there
    (the time-weighted median, rad/s) with the rotor's steady whirl at that speed (delta/e, the model's steady state
    :func:`autobal.analysis.rotor.steady_state`), and whether it dwells (more than DWELL_FACTOR times that
    crossing)."""
    from autobal.analysis.rotor import steady_state

    wc, dt = P.omega_cr, np.diff(tr.t)
    mid = 0.5 * (tr.omega[1:] + tr.omega[:-1])
    inside = np.abs(mid - wc) <= DWELL_BAND * wc
    t_in, crossing = float(dt[inside].sum()), 2 * DWELL_BAND * wc / alpha_max
    out = {"time_near_critical_s": t_in, "fastest_crossing_s": crossing, "dwells": t_in > DWELL_FACTOR * crossing,
           "hold_speed_rad_s": None, "hold_steady_deflection_over_e": None}
    if t_in > 0:
        order = np.argsort(mid[inside])
        cum = np.cumsum(dt[inside][order])
        hold = float(mid[inside][order][np.searchsorted(cum, 0.5 * cum[-1])])
        out |= {"hold_speed_rad_s": hold, "hold_steady_deflection_over_e": float(steady_state(P, hold / P.Omega0)["a"])}
    else:
        out |= {k: "the profile never comes within 10 % of the critical speed" for k in (
            "hold_speed_rad_s_status", "hold_steady_deflection_over_e_status")}
    return out


def dwell_words(what: str, dw: dict, omega_cr: float) -> str:
    """'the 4-segment ramp table holds the rotor 4.3 s within 10 % of its critical speed (most of it at 1709 rpm,
    95 % of ω_cr, where its steady whirl is 8.0 e), more than twice the 0.75 s the maximum acceleration takes across:
    a dwell near the critical speed'."""
    q = QUANTITIES.find
    hold = dw["hold_speed_rad_s"]
    return (f"{what} holds the rotor {dw['time_near_critical_s']:.2g} s within {100 * DWELL_BAND:.0f} % of its "
            f"critical speed (most of it at {q('omega_at_peak_rad_s').text(hold)}, {100 * hold / omega_cr:.0f} % of "
            f"ω_cr, where its steady whirl is {significant(dw['hold_steady_deflection_over_e'], 2)} e), more than "
            f"{DWELL_FACTOR:g} × the {dw['fastest_crossing_s']:.2g} s the maximum acceleration takes across: a dwell "
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


def verdict(d: dict) -> tuple[bool | None, str]:
    """The spin-up's one verdict from its results.json block: the optimum's peak deflection (physical, 0-peak,
    and delta/e), its gain against the best ramp within the drive limits (the only reference a gain is quoted
    against), whether it brakes and whether it keeps the drive limits; the NLP status first when it is not a
    success.  An optimum that dwells near the critical speed (:func:`dwell`) is neither good nor bad (None) with a
    CAUTION: its peak holds only for the critical speed of the scene."""
    peak = QUANTITIES.find("peak_deflection_m").text(d["peak_deflection_m"])
    words = f"peak deflection {peak} 0-peak ({significant(d['peak_deflection_over_e'])} e)"
    gain, key = d.get("gain_vs_best_feasible_ramp_pct"), d.get("baseline_ramp_key")
    if gain is not None:
        words += f", {gain:+.1f} % against the best ramp within the drive limits ({d['baselines'][key]['label']})"
    else:
        words += ", no ramp keeps the drive limits: no gain is quoted"
    if d.get("brakes") is not None:
        words += (f"; it brakes (smallest torque {QUANTITIES.find('min_torque_N_m').text(d['min_torque_N_m'])})"
                  if d["brakes"] else "; it does not brake")
    ok = gain is None or gain <= 0.01
    if (d.get("dwell") or {}).get("dwells"):  # good only if the critical speed is where the scene puts it: no verdict
        ok, words = (None if ok else ok), words + "; CAUTION: " + dwell_words("it", d["dwell"], d["omega_cr_rad_s"])
    if d.get("within_drive_limits") is False:
        ok, words = False, words + f"; drive limits EXCEEDED ({', '.join(d.get('violated') or [])})"
    if d["status"] not in SOLVED:
        ok, words = False, f"NLP solver {d['status']}: " + words
    return ok, words


def method_of(settings):
    if settings.method == "collocation":
        return DirectCollocation(settings.intervals, settings.degree, settings.scheme, settings.nlp_solver)
    return MultipleShooting(settings.intervals, settings.degree, settings.scheme)


def _pct(x: float, ref: float | None) -> float | None:
    return None if not ref else 100 * (x - ref) / ref


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
    opt = optimize(ocp, method, multistart, options)
    t1 = time.perf_counter()
    base = baselines(ocp)
    t_base = time.perf_counter() - t1
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
    rotor = {"mass_kg": P.m1, "stiffness_N_per_m": P.c, "damping_N_s_per_m": P.chi, "eccentricity_m": P.e,
             "liquid_mass_kg": P.m2_star, "critical_speed_rad_s": P.omega_cr,
             "damping_ratio": zeta, "service_speed_rad_s": ocp.omega_final,
             **api_margins(P, ocp.omega_final),
             "amplitude_convention": "0-peak (the radius of the whirl orbit)"}
    data = {
        "title": title, "objective": ocp.objective, "method": method.label, "status": sol.status,
        "peak_deflection_over_e": tr.peak_delta,
        "baseline_ramp_peak_over_e": ref_peak, "baseline_ramp_key": ref_key,
        "gain_vs_best_feasible_ramp_pct": _pct(tr.peak_delta, ref_peak),
        "gain_vs_constant_ramp_pct": _pct(tr.peak_delta, base["constant_ramp"].peak_delta)
        if use["constant_ramp"]["within_drive_limits"] is not False else None,
        "peak_deflection_m": tr.peak_delta * P.e, "rotor": rotor,
        "resimulation_rel_error": opt.resimulation_rel_error,
        "solve_time_s": sol.solve_time_s,
        "ipopt_iterations": sol.iterations,
        "collocation_peak_over_e": sol.peak_collocation if ocp.objective != "peak_unbalance" else None,
        "objective_value": opt.score, "objective_value_transcription": opt.collocation_value,
        "peak_unbalance": tr.peak_d, "time_of_peak_s": tr.t_peak,
        # chattering of the optimal acceleration: the one-interval pulses' total variation (alpha/alpha_max)
        "control_pulse_variation": pulse_variation(sol.u[:method.intervals]),
        "omega_at_peak_rad_s": float(np.interp(tr.t_peak, tr.t, tr.omega)),
        "integral_deflection2_s": tr.integral_delta2, "final_time_s": sol.final_time_s,
        "build_time_s": opt.build_time_s, "total_solve_time_s": sum(r.get("solve_time_s", 0.0) for r in opt.starts),
        "wall_time_s": time.perf_counter() - t0,
        "starts": opt.starts, "baselines": {k: v.to_dict() | use[k] for k, v in base.items()},
        "psi": ocp.params.psi, "eccentricity_m": ocp.params.e,
        "omega_cr_rad_s": ocp.params.omega_cr, "Omega0_rad_s": ocp.params.Omega0,
        "zeta0": ocp.params.zeta0, "drive_polar_inertia_kg_m2": ocp.params.J_p, **opt_use,
        "braking_torque_limit_N_m": -ocp.torque_bounds[0] if np.isfinite(ocp.torque_bounds[0]) else None,
        "torque_limit_N_m": ocp.torque_max, "power_limit_W": ocp.power_max,
        # the optimum brakes when its smallest torque is below zero by more than the limit check's tolerance
        "brakes": None if opt_use["min_torque_N_m"] is None or P.J_p == 0 else
        bool(opt_use["min_torque_N_m"] < -DRIVE_TOL * torque_reference(ocp)),
        "dwell": dwell(P, tr, ocp.alpha_max),
        "accuracy": {"estimate": opt.resimulation_rel_error,
                     "how": "relative difference between the transcription's optimal objective and its CVODES "
                            f"re-simulation (rtol {solver_options.defaults['resimulation.tol']:g}, "
                            f"{solver_options.defaults['resimulation.points']} samples per interval)"},
    }
    outside = "no ramp baseline keeps the drive limits (each is labelled outside them): no gain is quoted"
    for key, why in (("braking_torque_limit_N_m", "no braking-torque limit: the scene names no drive limit"),
                     ("torque_limit_N_m", "no torque limit in the scene"),
                     ("power_limit_W", "no power limit in the scene"),
                     ("brakes", "unknown: the scene gives no drive inertia, so the optimum's torque is not known"),
                     ("baseline_ramp_peak_over_e", outside), ("baseline_ramp_key", outside),
                     ("gain_vs_best_feasible_ramp_pct", outside),
                     ("gain_vs_constant_ramp_pct", "the constant ramp is outside the drive limits: no gain is quoted")):
        if data[key] is None:
            data[f"{key}_status"] = why
    if ocp.objective == "peak_unbalance":
        data["collocation_peak_unbalance"] = opt.collocation_value
    if seg is not None:
        data["segments"] = {"segments": segments, "peak_deflection_over_e": seg.trajectory.peak_delta,
                            "peak_unbalance": seg.trajectory.peak_d, "objective_value": seg.objective,
                            "loss_vs_optimum_pct": _pct(seg.objective, opt.score),
                            "evaluations": seg.evaluations, "start": seg.start,
                            "start_objectives": seg.start_objectives, **seg.drive,
                            "dwell": dwell(P, seg.trajectory, ocp.alpha_max)}
    # the wall time by part (s): what the global search, the initial guesses, the NLP builds, the IPOPT solves,
    # the CVODES re-simulations (reference ramp, ranking near-ties, the optimum) and the baselines took
    split = {"global_search": opt.times.get("global_search", 0.0), "guesses": opt.times.get("guesses", 0.0),
             "build": opt.build_time_s, "solve": data["total_solve_time_s"],
             "resimulation": opt.times.get("resimulation", 0.0), "baselines": t_base,
             "segments": t_seg}
    data["wall_time_s"] = time.perf_counter() - t0
    split["rest"] = data["wall_time_s"] - sum(split.values())
    data["time_split"] = {f"{k}_time_s": v for k, v in split.items()}
    return SpinupResult(data, tr, base, seg)
