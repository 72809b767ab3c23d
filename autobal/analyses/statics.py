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

    with progress.steps(None, "statics", "IPOPT solve", catch=True):
        return statics_study.run(StaticsSolver(design(scene.device)), settings, scene.title)


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
    """Operating point, criticals, saturation and contact (Pavlenko 2014, ch. 2.2-2.3)."""
    from autobal.report import cell, number, table, text

    sec.row("discharge pressure ratio at the operating point", "ψ1 = p1/p_B", "exact.psi1")
    sec.row("discharge pressure", "p1", "exact.p1")
    sec.row("base pressure", "p_B", "scales.p_B")
    sec.row("face gap", "z0", "exact.z0")
    sec.row("face gap ratio", "u0 = z0/z_B", "exact.u0")
    sec.row("valve opening", "x0", "exact.x0")
    sec.row("valve opening ratio", "ξ0 = x0/x_B", "exact.xi0")
    for k, sym, what in (("p2", "p2", "disc chamber"), ("p3", "p3", "cavity behind the disc"),
                         ("pe", "p_e", "barrier chamber"), ("pcam", "p_cam", "valve chamber")):
        sec.row(f"{what} pressure", sym, f"exact.{k}")
    sec.row("barrier flow", "Q_e", "exact.Q_e")
    sec.row("face-throttle leak", "Q_T", "exact.Q_T")
    sec.row("inner-seal flow", "Q_1", "exact.Q_1")
    sec.row("base flow of the source's flow ratios q", "Q_B", "closed_form.Q_B")
    sec.row("axial stiffness of the balancing force", "c_s", "exact.c_s")
    sec.row("axial stiffness of the balancing force (group)", "κ_s", "exact.kappa_s")
    sec.row("critical discharge pressure (inner-seal flow reverses)", "p1_kr", "critical_exact.p1_kr")
    sec.row("critical discharge ratio", "ψ1_kr", "critical_exact.psi1_kr")
    sec.row("operating barrier margin p_e − p1", "Δp", "exact.dp")
    sec.row("critical barrier margin p_e − p1 (inner-seal flow reverses)", "Δp_kr", "critical_exact.dp_kr")
    sec.row("critical barrier margin ratio", "δψ_kr", "critical_exact.dpsi_kr")
    ex, sw = sec.get("exact", {}), sec.get("sweep", {})
    sat, contact, psi1 = sw.get("regulator_saturated", []), sw.get("contact", []), sw.get("psi1", [])
    from autobal.analysis.statics_study import StaticsResult  # the verdict's one copy

    if {"contact", "Q_1", "z0", "psi1"} <= set(ex):
        sec.conclude(*StaticsResult(sec.block).verdict())  # the operating point: regulator, contact, inner seal
    if any(sat):
        first = psi1[sat.index(True)]
        sec.verdict(False, f"regulator saturated (valve on its stop) from ψ1 = {number(first)} in the sweep")
        sec.warnings.append(f"regulator saturation from ψ1 = {number(first)}: the closed forms assume an ideal "
                            "regulator and are not valid there")
    if any(contact):
        sec.verdict(False, f"face contact in the sweep from ψ1 = {number(psi1[contact.index(True)])}")
    cf = sec.get("closed_form", {})
    rows = []
    for key, sym, path in (("u0", "u0", "exact.u0"), ("xi0", "ξ0", "exact.xi0"), ("psi2_0", "ψ20", "exact.psi2_0"),
                           ("psi3_0", "ψ30", "exact.psi3_0"), ("psi_e0", "ψ_e0", "exact.psi_e0"),
                           ("psi_cam0", "ψ_cam0", "exact.psi_cam0"), ("kappa_s", "κ_s", "exact.kappa_s"),
                           ("psi1_kr", "ψ1_kr", "critical_exact.psi1_kr"),
                           ("dpsi_kr", "δψ_kr", "critical_exact.dpsi_kr"), ("Q_e", "Q_e", "exact.Q_e")):
        if key in cf:
            u = sec.unit(path) or "?"
            rows.append([text(sym), cell(cf[key], u), cell(sec.get(path), u)])
    if rows:
        note = StaticsResult(sec.block).closed_form_note() if {"dpsi", "scales"} <= set(sec.block) else \
            "they assume an ideal regulator"
        sec.tables.append(table(f"The source's closed forms (Eqs. (2.24)-(2.36)) beside the exact IPOPT solution of "
                                f"the full static system: {note}", ["quantity", "closed form", "exact"], rows))
