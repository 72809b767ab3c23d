"""``analyses.spinup``: the optimal spin-up of the scene's rotor through its critical speed (global search,
direct collocation, CVODES re-simulation); :func:`ocp` is the declared problem the other spin-up analyses
share."""

from __future__ import annotations

import csv
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analysis.solver_options import DEFAULTS
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


def run(scene, settings: Spinup):
    """Optimal spin-up through the critical speed (global search, collocation, CVODES re-simulation)."""
    from autobal.analysis import progress
    from autobal.analysis.solver_options import ipopt_options
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
    from autobal.analysis import progress
    from autobal.ocp.workprecision import spinup_study

    with progress.steps(None, "accuracy spinup (degrees x intervals)", "IPOPT solve", catch=True):
        return spinup_study(ocp(scene, settings))


def _spinup_binding(sec) -> list[str]:
    """The limits the optimum runs on: acceleration (from the controls table), torque, power, deflection."""
    from autobal.report import get_path, number, quantity

    scene = get_path(sec.results, "meta.scene_si") or {}
    ocp, drive = get_path(scene, "analyses.spinup") or {}, get_path(scene, "rotor.drive") or {}
    out = []
    amax, controls = ocp.get("max_acceleration"), sec.folder / "spinup_controls.csv" if sec.folder else None
    if amax and controls is not None and controls.exists():
        with controls.open() as fh:
            alpha = [float(r["alpha_rad_s2"]) for r in csv.DictReader(fh)]
        on = sum(abs(a) >= 0.999 * amax for a in alpha)
        if on:
            from autobal.ocp.simulation import rate_text  # rad/s² with rpm/s beside, the one copy

            out.append(f"acceleration limit |α| ≤ {rate_text(amax)} on {on} of {len(alpha)} control intervals "
                       f"({number(100 * on / len(alpha))} %)")
    for key, limit, what in (("max_torque_N_m", drive.get("max_torque"), "drive torque limit"),
                             ("max_power_W", drive.get("max_power"), "drive power limit")):
        got, q = sec.get(key), quantity(f"spinup.{key}")
        if limit and got is not None and got >= 0.999 * limit:
            out.append(f"{what} {q.text(limit)} reached (largest {q.text(got)})")
    lim = ocp.get("deflection_limit")
    if lim and sec.get("peak_deflection_over_e") is not None and sec.get("peak_deflection_over_e") >= 0.999 * lim:
        out.append(f"deflection limit δ/e ≤ {number(lim)} reached")
    if not out:
        out.append("none of the acceleration, torque, power and deflection limits is active at the optimum")
    return out


def report_section(sec) -> None:
    """Optimal spin-up through the critical speed (direct collocation, CVODES re-simulation): the verdict is the
    optimum's peak deflection, its gain against the best ramp within the drive limits and whether it brakes."""
    from autobal.analyses.rotor_dynamics import api_rows, api_verdict  # the API 684 rows' one copy
    from autobal.ocp.spinup_study import DWELL_BAND, OBJECTIVES, critical_label, dwell_words, verdict
    from autobal.report import cell, get_path, number, table, text

    sec.conclude(*verdict(sec.block))
    sec.verdict(None, f"objective: {str(sec.get('objective', '')).replace('_', ' ')}; {sec.get('method')}; "
                      f"wall time {number(sec.get('wall_time_s'))} s (NLP build {number(sec.get('build_time_s'))} s, "
                      f"NLP solves {number(sec.get('total_solve_time_s'))} s over {len(sec.get('starts', []))} solves, "
                      "the rest global search, re-simulations and baselines)")
    sec.row("peak deflection of the optimum, 0-peak (the whirl orbit's radius; re-simulated)", "δ*",
            "peak_deflection_m")
    sec.row("peak deflection of the optimum over the eccentricity", "δ*/e", "peak_deflection_over_e")
    sec.row("peak deflection of the best ramp within the drive limits", "δ*/e", "baseline_ramp_peak_over_e")
    sec.row("gain against the best ramp within the drive limits", "", "gain_vs_best_feasible_ramp_pct")
    sec.row("gain against the constant ramp", "", "gain_vs_constant_ramp_pct")
    sec.row("eccentricity of the rotor", "e", "eccentricity_m")
    liquid = (sec.get("rotor.liquid_mass_kg") or 0) > 0
    for label, sym, key in (("rotor mass", "m1", "mass_kg"),
                            ("shaft stiffness (c = m1 Ω_c²)", "c", "stiffness_N_per_m"),
                            ("damping (χ = 2 ζ m1 Ω_c)", "χ", "damping_N_s_per_m"),
                            ("damping ratio", "ζ", "damping_ratio"),
                            (critical_label(liquid), "ω_cr", "critical_speed_rad_s"),
                            ("service speed (the final speed)", "N_s", "service_speed_rad_s")):
        sec.row(label, sym, f"rotor.{key}")
    api_rows(sec, "rotor.")
    api_verdict(sec, sec.get("rotor") or {})
    objective = OBJECTIVES.get(sec.get("objective"))
    if objective is not None:
        sec.row(f"objective of the optimum (re-simulated): the {objective[2]}", f"J = {objective[1]}",
                "objective_value")
    band = f"{100 * DWELL_BAND:.0f} %"
    sec.row(f"time of the optimum within {band} of the critical speed", "t_cr", "dwell.time_near_critical_s")
    sec.row(f"time of the ramp table within {band} of the critical speed", "t_cr",
            "segments.dwell.time_near_critical_s")
    sec.row(f"time of the maximum acceleration across {band} either side of the critical speed", "",
            "dwell.fastest_crossing_s")
    sec.row("time of the peak", "t*", "time_of_peak_s")
    sec.row("speed at the peak", "ω*", "omega_at_peak_rad_s")
    sec.row("final time", "T", "final_time_s")
    sec.row("largest drive torque", "M_max", "max_torque_N_m")
    sec.row("smallest drive torque (below 0: the drive brakes)", "M_min", "min_torque_N_m")
    sec.row("largest drive power", "P_max", "max_power_W")
    sec.row("relative difference, CVODES re-simulation vs transcription", "", "resimulation_rel_error")
    sec.row("chattering of the optimal acceleration (pulse variation of α/α_max; 0: none)", "",
            "control_pulse_variation")
    sec.row("NLP build time", "", "build_time_s")
    sec.row("NLP solve time (IPOPT or fatrop), all starts and mesh stages", "", "total_solve_time_s")
    sec.row("wall time of the analysis (search, solves, re-simulations)", "", "wall_time_s")
    st = sec.get("status")
    sec.verdict(st in ("Solve_Succeeded", "Solved_To_Acceptable_Level"), f"NLP solver: {st} ({sec.get('method')})")
    base = sec.get("baselines") or {}
    e = sec.get("eccentricity_m")
    rows = []
    for k, b in base.items():
        pk = b.get("peak_deflection_over_e")
        limits = {True: "within", False: "OUTSIDE: " + ", ".join(b.get("violated", [])), None: "no drive data"}
        rows.append([text(b.get("label")), sec.cell(f"baselines.{k}.peak_deflection_over_e"),
                     sec.cell("peak_deflection_m", None if pk is None or e is None else pk * e),
                     sec.cell(f"baselines.{k}.max_torque_N_m"), sec.cell(f"baselines.{k}.max_power_W"),
                     text(limits[b.get("within_drive_limits")]),
                     text("reference of the gain" if k == sec.get("baseline_ramp_key") else "")])
        if b.get("within_drive_limits") is False:
            sec.verdict(None, f"{b.get('label')}: outside the drive limits ({', '.join(b.get('violated', []))}), "
                              f"peak {number(pk)} e, drawn but no reference")
    if rows:
        sec.tables.append(table("Ramp baselines (re-simulated): a gain is quoted only against a ramp within the drive "
                                "limits", ["baseline", "peak δ*/e", "peak δ*, 0-peak", "largest torque",
                                           "largest power", "drive limits", ""], rows))
    if sec.get("brakes") is not None:
        sec.verdict(None, f"the optimum {'brakes' if sec.get('brakes') else 'does not brake'} (smallest drive "
                          f"torque {number(sec.get('min_torque_N_m'))} N·m; braking limit "
                          f"{number(sec.get('braking_torque_limit_N_m'))} N·m)")
    seg = sec.get("segments")
    if seg:
        dw = seg.get("dwell") or {}
        sec.verdict(seg.get("within_drive_limits") and not dw.get("dwells"),
                    f"{seg['segments']}-segment ramp table (drive_segments.csv): peak "
                    f"{number(seg.get('peak_deflection_over_e'))} e, {number(seg.get('loss_vs_optimum_pct'))} % "
                    "against the full optimum, " + ("within" if seg.get("within_drive_limits") else "OUTSIDE")
                    + " the drive limits" + ("; CAUTION: " + dwell_words("it", dw, sec.get("omega_cr_rad_s"))
                                             if dw.get("dwells") else ""))
    drive = get_path(sec.results, "meta.scene_si.rotor.drive") or {}
    if not (drive.get("max_torque") or drive.get("max_power")):
        sec.verdict(None, "no drive torque or power limit in the scene")
    elif "within_drive_limits" in sec.block:
        sec.verdict(sec.get("within_drive_limits"), "drive torque and power limits " +
                    ("kept" if sec.get("within_drive_limits") else "EXCEEDED") + " in the re-simulation")
    for b in _spinup_binding(sec):
        sec.verdict(None, f"binding constraint: {b}")
    segs = sec.folder / "drive_segments.csv" if sec.folder else None
    if segs is not None and segs.exists():
        with segs.open() as fh:
            rows = [[text(r["segment"]), cell(float(r["t_start_s"]), "s"), cell(float(r["t_end_s"]), "s"),
                     text(number(float(r["speed_start_rpm"]))), text(number(float(r["speed_end_rpm"]))),
                     text(number(float(r["rate_rpm_s"]))), cell(float(r["rate_rad_s2"]), "rad/s^2")]
                    for r in csv.DictReader(fh)]
        caution = "; CAUTION: it dwells near the critical speed (the checks above)" if (
            (seg or {}).get("dwell") or {}).get("dwells") else ""
        sec.tables.append(table("Ramp table for the drive (drive_segments.csv; the last row the hold): speeds in "
                                "rpm, rates in rpm/s" + caution, ["segment", "start", "end", "start speed, rpm",
                                                        "end speed, rpm", "rate, rpm/s", "rate"], rows))
    keeps = {True: "yes", False: "NO", None: "—"}
    rows = [[text(s.get("start")), text(s.get("stage", "final mesh")), text(s.get("status")),
             text(s.get("iterations", "—")), cell(s.get("solve_time_s"), "s"), sec.cell(f"starts.{i}.objective"),
             text(keeps[s.get("keeps_limit")])] for i, s in enumerate(sec.get("starts", []))]
    if rows:
        sec.tables.append(table("NLP solves of the multi-start: every start on the coarse mesh, the best one "
                                "refined on the final mesh and judged by its CVODES re-simulation",
                                ["start", "stage", "status", "iterations", "solve time", "re-simulated objective",
                                 "keeps limit"], rows))
