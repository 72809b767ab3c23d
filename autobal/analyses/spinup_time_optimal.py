"""``analyses.spinup_time_optimal``: the earliest arrival at the final speed with the peak deflection bounded,
and the front of peak against arrival time up to the deadline."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analyses.spinup import Spinup, ocp

DESCRIPTION = "earliest arrival with the peak bounded, and the front of peak against arrival time"
NEEDS = "rotor"
QUANTITIES_MODULE = "autobal.ocp.time_optimal_study"  # its QUANTITIES declare every number of its block
TITLE = "Time-optimal spin-up"  # of its section of report.html


class SpinupTimeOptimal(Spinup):
    """Time-optimal spin-up: the earliest arrival at ``final_speed`` with the peak deflection bounded (the
    settling window still counts), and the Pareto front of peak against arrival time up to the deadline
    ``horizon``."""

    front_points: Annotated[int, Field(ge=2, le=50)] = Field(
        6, description="points of the front between the minimum-peak profile and the fastest ramp, 2 to 50")

    @model_validator(mode="after")
    def _time_optimal(self):
        if self.method != "collocation":
            raise ValueError("spinup_time_optimal is built on collocation")
        if self.nlp_solver != "ipopt":
            raise ValueError("spinup_time_optimal solves with nlp_solver ipopt")
        if "segments" in self.model_fields_set:
            raise ValueError("segments: the ramp table is written by the spinup analysis only")
        return self


SETTINGS = SpinupTimeOptimal


def run(scene, settings: SpinupTimeOptimal):
    """The earliest arrival with the peak bounded, and the front of peak against arrival time."""
    from autobal.analysis import progress
    from autobal.analysis.solver_options import ipopt_options
    from autobal.ocp import time_optimal_study
    from autobal.ocp.transcription import DirectCollocation

    with progress.steps(None, "time-optimal spin-up (front deadlines)", "IPOPT solve", catch=True):
        return time_optimal_study.run(ocp(scene, settings),
                                      DirectCollocation(settings.intervals, settings.degree, settings.scheme),
                                      settings.front_points, scene.title, settings.multistart,
                                      ipopt_options(settings.max_iterations, settings.tolerance))


def estimate_seconds(settings: SpinupTimeOptimal) -> float:
    """The minimum-peak and fastest solves and two per front point, each at the spin-up's cost."""
    return COST["start"] + COST["ocp_collocation_point"] * settings.intervals * settings.degree * (
        4 + 2 * settings.front_points)


def report_section(sec) -> None:
    """Time-optimal spin-up (the Jeffcott rotor's ``spinup_time_optimal``, peaks delta/e; the modal rotor's
    ``ross_spinup_time_optimal``, peaks in m shown in µm or the chosen length unit, as the block's ``peak_unit``
    states): the earliest arrival under the peak limit (the verdict) and the front."""
    from autobal.ocp.problem import PEAK_KEY
    from autobal.ocp.robust_study import PEAK_SYMBOL
    from autobal.ocp.spinup_study import QUANTITIES as SPINUP
    from autobal.ocp.time_optimal_study import QUANTITIES, verdict  # the verdict's one copy
    from autobal.report import cell, number, table, text

    unit = sec.get("peak_unit") or "1"
    s, sym = PEAK_KEY[unit], PEAK_SYMBOL[unit]
    sec.conclude(*verdict(sec.block))
    sec.row("final speed", "ω_f", "final_speed_rad_s")
    sec.row("peak limit", "δ/e" if unit == "1" else "r_lim", f"deflection_limit_{s}")
    sec.row("earliest arrival at the final speed", "T", "arrival_time_s")
    sec.row("latest front deadline whose minimum peak exceeds the limit", "", "arrival_time_lower_bound_s")
    sec.row("peak deflection of the earliest arrival (re-simulated)", sym, f"peak_deflection_{s}")
    sec.row("margin below the limit, 1 − peak/limit", "", "limit_margin")
    sec.row("arrival of the maximum-acceleration ramp", "", "ramp_arrival_time_s")
    sec.row("peak of the maximum-acceleration ramp", sym, f"ramp_peak_{s}")
    sec.row("eccentricity (δ* = e δ*/e, 0-peak)", "e", "eccentricity_m")
    sec.row("largest relative difference, collocation vs CVODES re-simulation", "", "resimulation_rel_error")
    sec.row("build time", "", "build_time_s")
    sec.row("solve time", "", "solve_time_s")
    if sec.get(f"deflection_limit_{s}") is not None:  # else the front's monotonicity is the verdict
        sec.verdict(sec.get("monotone"), "the front's peak does not rise with the arrival deadline"
                    if sec.get("monotone") else "the front is NOT monotone (a local optimum)")
    if sec.get("drive"):
        sec.notes.append(f"Drive: {sec.get('drive')}.")
    e, physical = sec.get("eccentricity_m"), SPINUP.find("peak_deflection_m")
    shown = None if unit == "1" else QUANTITIES.find(f"peak_deflection_{s}").display
    rows = [[cell(p.get("arrival_time_s"), "s"), cell(p.get(f"resimulated_peak_{s}"), unit, shown)]
            + ([cell(None if e is None else p.get(f"resimulated_peak_{s}") * e, "m", physical.display)]
               if unit == "1" else [])
            + [cell(p.get(f"collocation_peak_{s}"), unit, shown), cell(p.get("resimulation_rel_error"), "1"),
               cell(p.get("intervals"), "1"), cell(p.get("solve_time_s"), "s"),
               text(f"held from {number(p['held_from_s'])} s" if p.get("held_from_s") else "")]
            for p in sec.get("front", [])]
    if rows:
        sec.tables.append(table("Front: the smallest peak for each arrival deadline",
                                ["arrival by", f"{sym} (re-simulated)"] + (["δ* (0-peak)"] if unit == "1" else [])
                                + [f"{sym} (collocation)", "difference", "intervals", "solve time", "profile"], rows,
                                headline=True))
