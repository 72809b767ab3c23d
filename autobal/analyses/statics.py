"""``analyses.statics``: the static calculation of the balancing device (Pavlenko (2014), ch. 2): operating
point, sweep over the discharge pressure, criticals, force-gap characteristic."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.schema import MAX_FORCE_GAP_POINTS, PressureRatio, Range, Strict

DESCRIPTION = "static calculation"
NEEDS = "device"
QUANTITIES_MODULE = "autobal.analysis.studies.statics_study"  # its QUANTITIES declare every number of its block
TITLE = "Statics"  # of its section of report.html


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


def spec(settings: Statics):
    """The statics study's spec (autobal.analysis.studies.statics_study.Spec) of the validated settings."""
    from autobal.analysis.studies import statics_study

    r = settings.discharge_ratio
    return statics_study.Spec(settings.operating_ratio, r.start, r.stop, r.points, settings.force_gap_points)


def run(scene, settings: Statics):
    """Static calculation of the balancing device: operating point, criticals, sweep, force-gap."""
    from autobal.analysis.numerics.statics import StaticsSolver
    from autobal.analysis.run import progress
    from autobal.analysis.studies import statics_study
    from autobal.parts.device import design

    with progress.steps(None, "statics", "IPOPT solve", catch=True):
        return statics_study.run(StaticsSolver(design(scene.device)), spec(settings), scene.title)


def estimate_seconds(settings: Statics) -> float:
    """One warm-started IPOPT solve per sweep point (and path node) and per force-gap point."""
    from autobal.analysis.run.solver_options import defaults

    nodes = defaults["continuation.path_nodes"]

    n = settings.discharge_ratio.points
    return COST["start"] + COST["ipopt_solve"] * (n + (nodes if n > nodes else 0)
                                                  + settings.force_gap_points)


def accuracy(scene, settings: Statics):
    """Work-precision of the statics at the scene's operating point."""
    from autobal.analysis.numerics.statics import StaticsSolver
    from autobal.analysis.studies import workprecision
    from autobal.parts.device import design

    solver = StaticsSolver(design(scene.device))
    return workprecision.statics_study(solver, settings.operating_ratio, solver.design.dpsi)


def report_section(sec) -> None:
    """Operating point, criticals, saturation and contact (Pavlenko 2014, ch. 2.2-2.3); reads the fields of the
    loaded :class:`~autobal.analysis.studies.statics_study.StaticsResult` (``sec.result``)."""
    from autobal.report import cell, number, table, text

    r = sec.result
    ex, cf, crit, sc = r.exact, r.closed_form, r.critical_exact, r.scales
    sec.rows_of(ex, "psi1", "p1")
    sec.rows_of(sc, "p_B")
    sec.rows_of(ex, "z0", "u0", "x0", "xi0", "p2", "p3", "pe", "pcam", "Q_e", "Q_T", "Q_1")
    sec.rows_of(cf, "Q_B")
    sec.rows_of(ex, "c_s", "kappa_s")
    sec.rows_of(crit, "p1_kr", "psi1_kr")
    sec.rows_of(ex, "dp")
    sec.rows_of(crit, "dp_kr", "dpsi_kr")
    sec.conclude(*r.verdict())  # the operating point: regulator, contact, inner seal
    first = r.saturated_from()
    if first is not None:
        sec.verdict(False, f"regulator saturated (valve on its stop) from ψ1 = {number(first)} in the sweep")
        sec.warnings.append(f"regulator saturation from ψ1 = {number(first)}: the closed forms assume an ideal "
                            "regulator and are not valid there")
    if r.contact_from() is not None:
        sec.verdict(False, f"face contact in the sweep from ψ1 = {number(r.contact_from())}")
    rows = []
    for key, _, symbol, closed, exact in r.compared():
        unit = sec.unit(key) or "?"
        rows.append([text(symbol), cell(closed, unit), cell(exact, unit)])
    sec.tables.append(table(f"The source's closed forms (Eqs. (2.24)-(2.36)) beside the exact IPOPT solution of "
                            f"the full static system: {r.closed_form_note()}", ["quantity", "closed form", "exact"],
                            rows))
