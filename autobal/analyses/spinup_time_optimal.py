"""``analyses.spinup_time_optimal``: the earliest arrival at the final speed with the peak deflection bounded,
and the front of peak against arrival time up to the deadline."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analyses.spinup import Spinup, ocp

DESCRIPTION = "earliest arrival with the peak bounded, and the front of peak against arrival time"
NEEDS = "rotor"
REPORT_SECTION = "spinup_time_optimal_section"


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
    from autobal.ocp import time_optimal_study
    from autobal.ocp.solve import ipopt_options
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
