"""``analyses.spinup``: the optimal spin-up of the scene's rotor through its critical speed (global search,
direct collocation, CVODES re-simulation); :func:`ocp` is the declared problem the other spin-up analyses
share."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analysis.run.solver_options import DEFAULTS
from autobal.errors import ScenarioError
from autobal.schema import Positive, Strict
from autobal.units import AngularAcceleration, AngularSpeed, SpeedOrZero, Time, TimeOrZero, quantity

DESCRIPTION = "optimal spin-up through the critical speed"
NEEDS = "rotor"
QUANTITIES_MODULE = "autobal.ocp.spinup_study"  # its QUANTITIES declare every number of its block
TITLE = "Optimal spin-up"  # of its section of report.html
AngularJerk = quantity("angular jerk")


class Spinup(Strict):
    """Optimal spin-up through the critical speed, posed as a drive is specified: reach ``final_speed``
    by the deadline ``horizon``, hold it over ``settling_time`` (the peak counts over the whole window),
    never exceed ``max_speed``."""

    start_speed: SpeedOrZero
    final_speed: AngularSpeed
    horizon: Time = Field(description="the deadline: the final time (its upper bound with the min_time objective)")
    max_acceleration: AngularAcceleration
    max_speed: AngularSpeed | None = None
    objective: Literal["peak_deflection", "peak_unbalance", "integrated_deflection", "min_time"] = "peak_deflection"
    settling_time: TimeOrZero = 0.0
    deflection_limit: Positive | None = Field(None, description="bound on the deflection delta/e")
    max_jerk: AngularJerk | None = Field(None, description="bound on |d alpha/dt| between control intervals")
    jerk_penalty: Annotated[float, Field(ge=0, le=1e6)] = Field(
        0.0, description="weight of sum (Delta alpha/alpha_max)^2 over the control intervals in the objective "
        "(scaled by the maximum-acceleration ramp's), dimensionless")
    jerk_variation: Annotated[float, Field(ge=0, le=1e6)] = Field(
        1e-4, description="weight of the total variation sum |Delta alpha/alpha_max| over the control intervals "
        "(smoothed below 0.01) in the objective (scaled by the maximum-acceleration ramp's), dimensionless: "
        "removes one-interval pulses (chattering), keeps the switches sharp; 0 switches it off")
    method: Literal["collocation", "multiple_shooting"] = "collocation"
    scheme: Literal["radau", "legendre"] = "radau"
    degree: Annotated[int, Field(ge=1, le=9)] = Field(3, description="collocation degree, 1 to 9")
    intervals: Annotated[int, Field(ge=4, le=5000)] = Field(200, description="control intervals, 4 to 5,000")
    nlp_solver: Literal["ipopt", "fatrop"] = Field(
        "ipopt", description="the NLP solver of the collocation: ipopt (MUMPS), or fatrop (a Riccati recursion over "
        "the stages; Radau collocation only)")
    multistart: bool = True
    segments: Annotated[int, Field(ge=0, le=12)] = Field(
        4, description="ramp segments of the drive's table (drive_segments.csv), optimised for the same objective "
        "under the same limits, 1 to 12; 0: no table")
    max_iterations: Annotated[int, Field(ge=1, le=100000)] = Field(
        DEFAULTS["spinup.max_iter"],
        description="IPOPT's iteration limit per solve (each start and each mesh-continuation stage)")
    tolerance: Annotated[float, Field(gt=0, lt=1)] = Field(
        DEFAULTS["spinup.tol"],
        description="IPOPT's tolerance (dimensionless): optimality, constraint violation and complementarity")

    @model_validator(mode="after")
    def _consistent(self):
        if self.objective == "min_time" and self.deflection_limit is None:
            raise ValueError("the min_time objective needs deflection_limit (delta/e)")
        if self.max_speed is not None and self.max_speed < max(self.start_speed, self.final_speed):
            raise ValueError("max_speed must not be below start_speed and final_speed")
        if self.method == "multiple_shooting" and self.objective == "integrated_deflection":
            raise ValueError("multiple_shooting supports the peak and min_time objectives")
        if self.nlp_solver == "fatrop" and (self.method != "collocation" or self.scheme != "radau"):
            raise ValueError("nlp_solver fatrop needs method collocation with scheme radau")
        return self


SETTINGS = Spinup


def ocp(scene, settings: Spinup):
    """The declared spin-up problem (autobal.ocp.problem.SpinupOcp) of a scene's rotor and settings."""
    from autobal.ocp.problem import SpinupOcp
    from autobal.ocp.simulation import drive_unreachable
    from autobal.parts.rotor import adapt

    if scene.rotor is None:
        raise ScenarioError("analyses.spinup needs a rotor section")
    drive = scene.rotor.drive
    try:
        problem = SpinupOcp(
            adapt(scene.rotor), settings.start_speed, settings.final_speed, settings.horizon,
            settings.max_acceleration,
            objective=settings.objective, settling_time=settings.settling_time, omega_max=settings.max_speed,
            torque_max=drive.max_torque if drive else None, power_max=drive.max_power if drive else None,
            braking_torque_max=drive.max_braking_torque if drive else None,
            alpha_min=-drive.max_deceleration if drive and drive.max_deceleration is not None else None,
            motor_stall_torque=drive.motor.stall_torque if drive and drive.motor else None,
            motor_no_load_speed=drive.motor.no_load_speed if drive and drive.motor else None,
            deflection_limit=settings.deflection_limit, jerk_max=settings.max_jerk,
            jerk_penalty=settings.jerk_penalty, jerk_variation=settings.jerk_variation)
    except ValueError as exc:
        raise ScenarioError(f"analyses.spinup: {exc}") from None
    why = problem.ill_posed() or drive_unreachable(problem)
    if why:
        raise ScenarioError(f"analyses.spinup: {why}")
    return problem


def check(scene, settings: Spinup) -> None:
    """``autobal check``: the problem posed, the drive's reach checked (:func:`ocp`), nothing solved."""
    ocp(scene, settings)


def run(scene, settings: Spinup):
    """Optimal spin-up through the critical speed (global search, collocation, CVODES re-simulation)."""
    from autobal.analysis.run import progress
    from autobal.analysis.run.solver_options import ipopt_options
    from autobal.ocp import spinup_study

    with progress.steps(None, "spin-up (starts, mesh stages)", "IPOPT solve", catch=True):
        return spinup_study.run(ocp(scene, settings), spinup_study.method_of(settings), scene.title,
                                settings.multistart, ipopt_options(settings.max_iterations, settings.tolerance),
                                settings.segments)


def estimate_seconds(settings: Spinup) -> float:
    """One collocation point per interval and degree, for each of the global search's four starts."""
    return COST["start"] + COST["ocp_collocation_point"] * settings.intervals * settings.degree * (
        4 if settings.multistart else 1)


def accuracy(scene, settings: Spinup):
    """Work-precision of the scene's spin-up OCP (collocation degree and intervals)."""
    from autobal.analysis.run import progress
    from autobal.ocp.workprecision import spinup_study

    with progress.steps(None, "accuracy spinup (degrees x intervals)", "IPOPT solve", catch=True):
        return spinup_study(ocp(scene, settings))


def _spinup_binding(sec, r) -> list[str]:
    """The limits the optimum ``r`` (the loaded Result) runs on: acceleration (its controls), torque, power,
    deflection."""
    from autobal.report import get_path, number

    scene = get_path(sec.results, "meta.scene_si") or {}
    ocp, drive = get_path(scene, "analyses.spinup") or {}, get_path(scene, "rotor.drive") or {}
    out = []
    amax = ocp.get("max_acceleration")
    if amax and r.controls is not None:
        alpha = r.controls["acceleration"]
        on = sum(abs(a) >= 0.999 * amax for a in alpha)
        if on:
            from autobal.ocp.simulation import rate_text  # rad/s² with rpm/s beside, the one copy

            out.append(f"acceleration limit |α| ≤ {rate_text(amax)} on {on} of {len(alpha)} control intervals "
                       f"({number(100 * on / len(alpha))} %)")
    for got, limit, what, q in ((r.max_torque_N_m, drive.get("max_torque"), "drive torque limit", "max_torque_N_m"),
                                (r.max_power_W, drive.get("max_power"), "drive power limit", "max_power_W")):
        if limit and got is not None and got >= 0.999 * limit:
            q = r.quantities.find(q)
            out.append(f"{what} {q.text(limit)} reached (largest {q.text(got)})")
    lim = ocp.get("deflection_limit")
    if lim and r.peak_deflection_over_e is not None and r.peak_deflection_over_e >= 0.999 * lim:
        out.append(f"deflection limit δ/e ≤ {number(lim)} reached")
    if not out:
        out.append("none of the acceleration, torque, power and deflection limits is active at the optimum")
    return out


def report_section(sec) -> None:
    """Optimal spin-up through the critical speed (direct collocation, CVODES re-simulation): the verdict is the
    optimum's peak deflection, its gain against the best ramp within the drive limits and whether it brakes.  Reads
    the fields of the loaded :class:`~autobal.ocp.spinup_study.SpinupResult` (``sec.result``, with the controls and
    the ramp table its run wrote)."""
    from autobal.analyses.rotor_dynamics import api_verdict  # the API 684 check line's one copy
    from autobal.ocp.spinup_study import DWELL_BAND, OBJECTIVES, critical_label, dwell_words
    from autobal.report import cell, get_path, number, table, text

    r = sec.result
    sec.conclude(*r.verdict())
    sec.verdict(None, f"objective: {r.objective.replace('_', ' ')}; {r.method}; "
                      f"wall time {number(r.wall_time_s)} s (NLP build {number(r.build_time_s)} s, "
                      f"NLP solves {number(r.total_solve_time_s)} s over {len(r.starts)} solves, "
                      "the rest global search, re-simulations and baselines)")
    sec.headline_rows()  # the rows of the fields declared headline
    ro, band = r.rotor, f"{100 * DWELL_BAND:.0f} %"
    sec.rows_of(r, "gain_vs_constant_ramp_pct", "eccentricity_m")
    sec.rows_of(ro, "mass_kg", "stiffness_N_per_m", "damping_N_s_per_m", "damping_ratio")
    sec.rows_of(ro, "critical_speed_rad_s", label=critical_label(ro.liquid_mass_kg > 0))
    sec.rows_of(ro, "service_speed_rad_s", "response_peak_speed_rad_s")
    sec.rows_of(r.dwell, "time_near_critical_s", label=f"time of the optimum within {band} of the critical speed")
    if r.segments:
        sec.rows_of(r.segments.dwell, "time_near_critical_s",
                    label=f"time of the ramp table within {band} of the critical speed")
    sec.rows_of(r.dwell, "fastest_crossing_s")
    sec.rows_of(r, "time_of_peak_s", "omega_at_peak_rad_s", "final_time_s", "resimulation_rel_error",
                "control_pulse_variation", "build_time_s", "total_solve_time_s", "wall_time_s")
    if OBJECTIVES.get(r.objective) is not None:  # in the objective's unit (objective_quantity)
        sec.rows_of(r, "objective_value")
    api_verdict(sec, ro.margins())
    sec.verdict(r.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level"), f"NLP solver: {r.status} ({r.method})")
    e, q = r.eccentricity_m, r.quantities.find
    rows = []
    for k, b in r.baselines.items():
        pk = b.peak_deflection_over_e
        limits = {True: "within", False: "OUTSIDE: " + ", ".join(b.violated), None: "no drive data"}
        rows.append([text(b.label), declared_cell(q("baselines.*.peak_deflection_over_e"), pk),
                     declared_cell(q("peak_deflection_m"), None if pk is None or e is None else pk * e),
                     declared_cell(q("baselines.*.max_torque_N_m"), b.max_torque_N_m),
                     declared_cell(q("baselines.*.max_power_W"), b.max_power_W),
                     text(limits[b.within_drive_limits]),
                     text("reference of the gain" if k == r.baseline_ramp_key else "")])
        if b.within_drive_limits is False:
            sec.verdict(None, f"{b.label}: outside the drive limits ({', '.join(b.violated)}), "
                              f"peak {number(pk)} e, drawn but no reference")
    if rows:
        sec.tables.append(table("Ramp baselines (re-simulated): a gain is quoted only against a ramp within the drive "
                                "limits", ["baseline", "peak δ*/e", "peak δ*, 0-peak", "largest torque",
                                           "largest power", "drive limits", ""], rows))
    if r.brakes is not None:
        sec.verdict(None, f"the optimum {'brakes' if r.brakes else 'does not brake'} (smallest drive "
                          f"torque {number(r.min_torque_N_m)} N·m; braking limit "
                          f"{number(r.braking_torque_limit_N_m)} N·m)")
    seg = r.segments
    if seg:
        dw = seg.dwell
        sec.verdict(seg.within_drive_limits and not dw.dwells,
                    f"{seg.segments}-segment ramp table (drive_segments.csv): peak "
                    f"{number(seg.peak_deflection_over_e)} e, {number(seg.loss_vs_optimum_pct)} % "
                    "against the full optimum, " + ("within" if seg.within_drive_limits else "OUTSIDE")
                    + " the drive limits" + ("; CAUTION: " + dwell_words("it", dw, r.omega_cr_rad_s)
                                             if dw.dwells else ""))
    drive = get_path(sec.results, "meta.scene_si.rotor.drive") or {}
    if not (drive.get("max_torque") or drive.get("max_power")):
        sec.verdict(None, "no drive torque or power limit in the scene")
    else:
        sec.verdict(r.within_drive_limits, "drive torque and power limits " +
                    ("kept" if r.within_drive_limits else "EXCEEDED") + " in the re-simulation")
    for b in _spinup_binding(sec, r):
        sec.verdict(None, f"binding constraint: {b}")
    t = r.ramp_table
    if t is not None:
        from autobal.analysis.run.quantities import convert

        rows = [[text(f"{s:g}"), cell(t0, "s"), cell(t1, "s"), text(number(convert(w0, "rad/s", "rpm"))),
                 text(number(convert(w1, "rad/s", "rpm"))), text(number(convert(rad, "rad/s^2", "rpm/s"))),
                 cell(rad, "rad/s^2")]
                for s, t0, t1, w0, w1, rad in zip(t["segment"], t["t_start"], t["t_end"], t["speed_start"],
                                                  t["speed_end"], t["rate"], strict=True)]
        caution = "; CAUTION: it dwells near the critical speed (the checks above)" if seg and seg.dwell.dwells else ""
        sec.tables.append(table("Ramp table for the drive (drive_segments.csv; the last row the hold): speeds in "
                                "rpm, rates in rpm/s" + caution, ["segment", "start", "end", "start speed, rpm",
                                                        "end speed, rpm", "rate, rpm/s", "rate"], rows))
    keeps = {True: "yes", False: "NO", None: "—"}
    j = q("starts.0.objective", r.to_dict())
    rows = [[text(s.get("start")), text(s.get("stage", "final mesh")), text(s.get("status")),
             text(s.get("iterations", "—")), cell(s.get("solve_time_s"), "s"), declared_cell(j, s.get("objective")),
             text(keeps[s.get("keeps_limit")])] for s in r.starts]
    if rows:
        sec.tables.append(table("NLP solves of the multi-start: every start on the coarse mesh, the best one "
                                "refined on the final mesh and judged by its CVODES re-simulation",
                                ["start", "stage", "status", "iterations", "solve time", "re-simulated objective",
                                 "keeps limit"], rows))


def declared_cell(q, v) -> dict:
    """The cell of a value declared by ``q`` in its display unit, to the 4 significant digits of the terminal (the
    spin-up sections' tables of typed fields)."""
    from autobal.report import cell

    return cell(v, q.unit, q.display, 4) if q is not None else cell(v, "?")
