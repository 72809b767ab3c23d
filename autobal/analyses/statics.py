"""``analyses.statics``: the static calculation of the balancing device (Pavlenko (2014), ch. 2): operating
point, sweep over the discharge pressure, criticals, force-gap characteristic."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.schema import MAX_FORCE_GAP_POINTS, PressureRatio, Range, Strict

DESCRIPTION = "static calculation"
NEEDS = "device"
QUANTITIES_MODULE = "autobal.analysis.statics_study"  # its QUANTITIES declare every number of its block
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


def run(scene, settings: Statics):
    """Static calculation of the balancing device: operating point, criticals, sweep, force-gap."""
    from autobal.analysis import progress, statics_study
    from autobal.analysis.statics import StaticsSolver
    from autobal.parts.device import design

    r = settings.discharge_ratio
    spec = statics_study.Spec(settings.operating_ratio, r.start, r.stop, r.points, settings.force_gap_points)
    with progress.steps(None, "statics", "IPOPT solve", catch=True):
        return statics_study.run(StaticsSolver(design(scene.device)), spec, scene.title)


def estimate_seconds(settings: Statics) -> float:
    """One warm-started IPOPT solve per sweep point (and path node) and per force-gap point."""
    from autobal.analysis.solver_options import defaults

    nodes = defaults["continuation.path_nodes"]

    n = settings.discharge_ratio.points
    return COST["start"] + COST["ipopt_solve"] * (n + (nodes if n > nodes else 0)
                                                  + settings.force_gap_points)


def accuracy(scene, settings: Statics):
    """Work-precision of the statics at the scene's operating point."""
    from autobal.analysis import workprecision
    from autobal.analysis.statics import StaticsSolver
    from autobal.parts.device import design

    solver = StaticsSolver(design(scene.device))
    return workprecision.statics_study(solver, settings.operating_ratio, solver.design.dpsi)


def report_section(sec) -> None:
    """Operating point, criticals, saturation and contact (Pavlenko 2014, ch. 2.2-2.3); reads the fields of the
    loaded :class:`~autobal.analysis.statics_study.StaticsResult` (``sec.result``)."""
    from autobal.report import cell, number, table, text

    r = sec.result
    ex, cf, crit, sc = r.exact, r.closed_form, r.critical_exact, r.scales
    for label, symbol, key, v in (
            ("discharge pressure ratio at the operating point", "ψ1 = p1/p_B", "exact.psi1", ex.psi1),
            ("discharge pressure", "p1", "exact.p1", ex.p1),
            ("base pressure", "p_B", "scales.p_B", sc.p_B),
            ("face gap", "z0", "exact.z0", ex.z0),
            ("face gap ratio", "u0 = z0/z_B", "exact.u0", ex.u0),
            ("valve opening", "x0", "exact.x0", ex.x0),
            ("valve opening ratio", "ξ0 = x0/x_B", "exact.xi0", ex.xi0),
            ("disc chamber pressure", "p2", "exact.p2", ex.p2),
            ("cavity behind the disc pressure", "p3", "exact.p3", ex.p3),
            ("barrier chamber pressure", "p_e", "exact.pe", ex.pe),
            ("valve chamber pressure", "p_cam", "exact.pcam", ex.pcam),
            ("barrier flow", "Q_e", "exact.Q_e", ex.Q_e),
            ("face-throttle leak", "Q_T", "exact.Q_T", ex.Q_T),
            ("inner-seal flow", "Q_1", "exact.Q_1", ex.Q_1),
            ("base flow of the source's flow ratios q", "Q_B", "closed_form.Q_B", cf.Q_B),
            ("axial stiffness of the balancing force", "c_s", "exact.c_s", ex.c_s),
            ("axial stiffness of the balancing force (group)", "κ_s", "exact.kappa_s", ex.kappa_s),
            ("critical discharge pressure (inner-seal flow reverses)", "p1_kr", "critical_exact.p1_kr", crit.p1_kr),
            ("critical discharge ratio", "ψ1_kr", "critical_exact.psi1_kr", crit.psi1_kr),
            ("operating barrier margin p_e − p1", "Δp", "exact.dp", ex.dp),
            ("critical barrier margin p_e − p1 (inner-seal flow reverses)", "Δp_kr", "critical_exact.dp_kr",
             crit.dp_kr),
            ("critical barrier margin ratio", "δψ_kr", "critical_exact.dpsi_kr", crit.dpsi_kr)):
        sec.row(label, symbol, key, value=v)  # the field's value; its key names its declaration
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
