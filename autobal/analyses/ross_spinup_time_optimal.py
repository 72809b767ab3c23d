"""``analyses.ross_spinup_time_optimal``: the earliest arrival of a ROSS rotor reduced to its modes at the final
speed with its peak deflection bounded, and the front of peak against arrival time: the time-optimal study of
:mod:`autobal.ocp.time_optimal_study` on the modal problem of :mod:`autobal.ocp.modal` (its ``min_time`` objective
and its deflection limit as a path constraint of the shared transcription).

The drive is the acceleration limit only (the modal problem has no drive torque or power model).  Needs the
optional ROSS package (``pip install -e '.[ross]'``).
"""

from __future__ import annotations

from pydantic import Field, create_model, model_validator

from autobal.analyses import COST, ross_spinup
from autobal.analyses.ross_spinup import RossSpinup
from autobal.analyses.spinup_time_optimal import SpinupTimeOptimal, report_section  # noqa: F401  one section for both
from autobal.units import Length

DESCRIPTION = "earliest arrival of a ROSS rotor with its peak deflection bounded, and the front (the ross extra)"
NEEDS = "ross_rotor"
EXTRA = "ross"  # the optional package it needs (autobal.analyses.EXTRAS)
QUANTITIES_MODULE = "autobal.ocp.time_optimal_study"  # the time-optimal study's declarations: peaks in m here
TITLE = "Time-optimal spin-up of a ROSS rotor (multi-mode)"


class RossSpinupTimeOptimal(create_model("_RossSpinupWithFront", __base__=RossSpinup, front_points=(
        SpinupTimeOptimal.model_fields["front_points"].annotation, SpinupTimeOptimal.model_fields["front_points"]))):
    """Time-optimal spin-up of the ROSS rotor reduced to its modes, posed as ``ross_spinup``: the earliest arrival at
    ``final_speed`` whose re-simulated peak deflection (the largest whirl radius over ``nodes``, 0-peak; the settling
    window still counts) is at most ``deflection_limit``, and the front of the smallest peak against the arrival
    deadline up to ``horizon``.  The drive is |alpha| <= ``max_acceleration`` only (a ``ross_rotor.drive`` is
    refused)."""

    deflection_limit: Length | None = Field(
        None, description="largest deflection allowed (the whirl radius over the nodes, 0-peak), e.g. a fraction of "
                          "the bearing clearance; without it the front only")

    @model_validator(mode="after")
    def _time_optimal(self):
        if "validate_with_ross" in self.model_fields_set:
            raise ValueError("validate_with_ross: the time-optimal study does not compare critical speeds with "
                             "ROSS's (the ross_spinup analysis does)")
        return self


SETTINGS = RossSpinupTimeOptimal


def check(scene, settings: RossSpinupTimeOptimal) -> None:
    """``autobal check``: the modal problem posed, nothing solved."""
    ross_spinup.problem(scene, settings, "ross_spinup_time_optimal", deflection_limit=settings.deflection_limit)


def run(scene, settings: RossSpinupTimeOptimal):
    """The earliest arrival of the reduced ROSS rotor with the peak bounded, and the front of peak against arrival
    time (needs the ross extra)."""
    from autobal.analysis.run import progress, solver_options
    from autobal.ocp import time_optimal_study

    ocp = ross_spinup.problem(scene, settings, "ross_spinup_time_optimal", deflection_limit=settings.deflection_limit)
    with progress.steps(None, "time-optimal spin-up of the modal rotor (front deadlines)", "IPOPT solve", catch=True):
        return time_optimal_study.run(ocp, ocp.method, settings.front_points, scene.title,
                                      options=solver_options.ipopt_options(settings.max_iterations))


def estimate_seconds(settings: RossSpinupTimeOptimal) -> float:
    """ROSS's import and the rotor's matrices (about 10 s), then a minimum-peak study of the modal envelope (about
    four starts) per front point and the min_time solves."""
    return COST["ross_rotor"] + COST["start"] + COST["modal_ocp_point"] * settings.intervals * settings.degree * (
        4 + 4 * settings.front_points)
