"""``analyses.statics``: the static calculation of the balancing device (Pavlenko (2014), ch. 2): operating
point, sweep over the discharge pressure, criticals, force-gap characteristic."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.schema import MAX_FORCE_GAP_POINTS, PressureRatio, Range, Strict

DESCRIPTION = "static calculation"
NEEDS = "device"
REPORT_SECTION = "statics_section"


class Statics(Strict):
    """Static calculation: operating point, sweep over discharge pressure, criticals."""

    operating_ratio: PressureRatio = Field(1.0, description="psi1 = p1 / p_B of the reported operating point, "
                                                            "0 to 100")
    discharge_ratio: Range = Field(description="sweep of psi1 = p1 / p_B, Pavlenko (2014), Figs 2.4-2.6")
    force_gap_points: Annotated[int, Field(ge=2, le=MAX_FORCE_GAP_POINTS)] = Field(
        60, description=f"points of the force-gap characteristic phi(u), Eq. (2.35), 2 to {MAX_FORCE_GAP_POINTS}")

    @model_validator(mode="after")
    def _ratios(self):
        if self.discharge_ratio.stop > 100:
            raise ValueError("discharge_ratio.stop: at most 100 (p1 / p_B)")
        return self


SETTINGS = Statics


def run(scene, settings: Statics):
    """Static calculation of the balancing device: operating point, criticals, sweep, force-gap."""
    from autobal.analysis import progress, statics_study
    from autobal.analysis.statics import StaticsSolver
    from autobal.parts.device import design

    with progress.steps(None, "statics", "IPOPT solve", catch=True):
        return statics_study.run(StaticsSolver(design(scene.device)), settings, scene.title)


def estimate_seconds(settings: Statics) -> float:
    """One warm-started IPOPT solve per sweep point (and path node) and per force-gap point."""
    from autobal.analysis.statics_study import PATH_NODES

    n = settings.discharge_ratio.points
    return COST["start"] + COST["ipopt_solve"] * (n + (PATH_NODES if n > PATH_NODES else 0)
                                                  + settings.force_gap_points)


def accuracy(scene, settings: Statics):
    """Work-precision of the statics at the scene's operating point."""
    from autobal.analysis import workprecision
    from autobal.analysis.statics import StaticsSolver
    from autobal.parts.device import design

    solver = StaticsSolver(design(scene.device))
    return workprecision.statics_study(solver, settings.operating_ratio, solver.design.dpsi)
