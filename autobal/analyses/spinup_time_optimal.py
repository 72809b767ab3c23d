"""``analyses.spinup_time_optimal``: the earliest arrival at the final speed with the peak deflection bounded,
and the front of peak against arrival time up to the deadline."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analyses.spinup import Spinup, check, ocp  # noqa: F401 (check: the same as spinup's)

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
    from autobal.analysis.run import progress
    from autobal.analysis.run.solver_options import ipopt_options
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
    states): the earliest arrival under the peak limit (the verdict) and the front.  Reads the fields of the loaded
    :class:`~autobal.ocp.time_optimal_study.TimeOptimalResult` (``sec.result``)."""
    from autobal.ocp.robust_study import PEAK_SYMBOL
    from autobal.ocp.spinup_study import QUANTITIES as SPINUP
    from autobal.report import cell, number, table, text

    r = sec.result
    unit, sym = r.peak_unit, PEAK_SYMBOL[r.peak_unit]
    sec.conclude(*r.verdict())
    sec.headline_rows()  # the rows of the fields declared headline
    sec.rows_of(r, "arrival_time_lower_bound_s", "eccentricity_m", "resimulation_rel_error", "build_time_s",
                "solve_time_s")
    if r.deflection_limit is not None:  # else the front's monotonicity is the verdict
        sec.verdict(r.monotone, "the front's peak does not rise with the arrival deadline"
                    if r.monotone else "the front is NOT monotone (a local optimum)")
    if r.drive:
        sec.notes.append(f"Drive: {r.drive}.")
    e, physical = r.eccentricity_m, SPINUP.find("peak_deflection_m")
    shown = None if unit == "1" else r.quantities.find("peak_deflection_m").display
    rows = [[cell(p.arrival_time_s, "s"), cell(p.resimulated_peak, unit, shown)]
            + ([cell(None if e is None else p.resimulated_peak * e, "m", physical.display)] if unit == "1" else [])
            + [cell(p.collocation_peak, unit, shown), cell(p.resimulation_rel_error, "1"), cell(p.intervals, "1"),
               cell(p.solve_time_s, "s"), text(f"held from {number(p.held_from_s)} s" if p.held_from_s else "")]
            for p in r.front]
    if rows:
        sec.tables.append(table("Front: the smallest peak for each arrival deadline",
                                ["arrival by", f"{sym} (re-simulated)"] + (["δ* (0-peak)"] if unit == "1" else [])
                                + [f"{sym} (collocation)", "difference", "intervals", "solve time", "profile"], rows,
                                headline=True))
