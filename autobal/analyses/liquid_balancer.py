"""``analyses.liquid_balancer``: design calculations of the liquid auto-balancer (Khomyak (2020), App. В/Г;
Pashkov (2010), ch. 3): efficiency against the speed ratio, its extremum, the optimal height, volume and liquid."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from autobal.analyses import COST
from autobal.schema import Positive, Range, Strict
from autobal.units import Density, Length, Mass, Viscosity, Volume

DESCRIPTION = "liquid auto-balancer studies"
NEEDS = "liquid_balancer"
QUANTITIES_MODULE = "autobal.analysis.studies.liquid_balancer"  # its QUANTITIES declare every number of its block
TITLE = "Liquid auto-balancer"  # of its section of report.html


class Candidate(Strict):
    name: str
    density: Density
    viscosity: Viscosity


class HeightSearch(Strict):
    """Optimal chamber height for the given radius (App. В OPTIMUM_KAMERA) as an IPOPT problem."""

    max_height: Length = Field(description="h_k, the largest height the design allows")
    min_height: Length | None = Field(None, description="h_p; default: just above V/(pi R^2)")
    grid_points: Annotated[int, Field(ge=3, le=2_000_001)] = Field(
        20001, description="dense grid cross-check, 3 to 2,000,001")


class VolumeSearch(Strict):
    """Optimal liquid volume for the given unbalance (App. Г OPTIMUM_LIQUID) as an IPOPT problem."""

    min_volume: Volume | None = Field(None, description="V0; default 1e-6 of the chamber volume")
    grid_points: Annotated[int, Field(ge=3, le=2_000_001)] = Field(
        20001, description="dense grid cross-check, 3 to 2,000,001")


class LiquidBalancerAnalysis(Strict):
    """Efficiency vs speed ratio, extremum, optimal height / volume / liquid, Pashkov calculators."""

    variant: Literal["printed", "program", "corrected"] = Field("corrected", description="equilibrium angle (2.13)")
    deflection: Literal["program", "system"] = Field("program", description="f = G D0/m_d (App. В code) or G D0/M_sys")
    speed_ratio: Range = Field(description="gamma = omega/omega_cr sweep for the efficiency curve")
    table_ratios: Annotated[list[Positive], Field(min_length=1, max_length=1000)] = [0.4, 0.6, 0.8, 1.0, 1.2, 1.4]
    arc_angle_deg: Annotated[float, Field(gt=0, le=360)] | None = Field(
        None, description="xi of (2.15); default: program Г")
    conversion_coefficient: Positive = Field(
        1.0, description="kappa of (3.5), (3.6), (3.9), (3.13); 1 = sufficient liquid")
    height: HeightSearch | None = None
    volume: VolumeSearch | None = None
    liquids: list[Candidate] = Field([], max_length=100, description="liquid choice by viscosity (App. Г), at most 100")
    unbalance_masses: list[Mass] = Field(
        [], max_length=100, description="optimal volume per unbalance (Table 3.3: 50/100/150/200 g at e_d)")
    thesis_comparison: bool = Field(
        False, description="compare with Tables 3.2 / 3.3 (only meaningful for the Table 3.1 system)")


SETTINGS = LiquidBalancerAnalysis


def run(scene, settings: LiquidBalancerAnalysis):
    """Design calculations of the liquid auto-balancer (Khomyak (2020); Pashkov (2010), ch. 3)."""
    from autobal.analysis.studies import liquid_balancer as lb
    from autobal.parts import liquid_balancer as part

    return lb.run(part.adapt(scene.liquid_balancer), spec(settings), scene.title)


def spec(settings: LiquidBalancerAnalysis):
    """The study's :class:`~autobal.analysis.studies.liquid_balancer.Spec` of the validated settings (SI)."""
    from autobal.analysis.studies import liquid_balancer as lb

    s, r = settings, settings.speed_ratio
    return lb.Spec(s.variant, s.deflection, (r.start, r.stop, r.points), tuple(s.table_ratios), s.arc_angle_deg,
                   s.conversion_coefficient, s.height and lb.HeightSearch(**dict(s.height)),
                   s.volume and lb.VolumeSearch(**dict(s.volume)), tuple(lb.Liquid(**dict(c)) for c in s.liquids),
                   tuple(s.unbalance_masses), s.thesis_comparison)


def estimate_seconds(settings: LiquidBalancerAnalysis) -> float:
    """The dense cross-check grids of the height and volume searches, per unbalance and liquid."""
    grid = sum(s.grid_points for s in (settings.height, settings.volume) if s is not None)
    return COST["start"] + COST["grid_point"] * grid * (1 + len(settings.unbalance_masses) + len(settings.liquids))


def report_section(sec) -> None:
    """Efficiency of the liquid auto-balancer at the operating point (Khomyak 2020, ch. 3): one verdict (a balancing
    equilibrium and enough liquid at the working speed); Tables 3.2/3.3 in the validation part.  Reads the fields of
    the loaded :class:`~autobal.analysis.studies.liquid_balancer.LiquidBalancerResult` (``sec.result``)."""
    from autobal.analysis.run.quantities import is_number
    from autobal.analysis.studies.liquid_balancer import EFFICIENCIES, optimum_words  # what each number is: one copy
    from autobal.report import cell, number, table, text

    r = sec.result
    op = r.operating_point
    published = next((row for row in (r.table_3_2 or {}).get("rows", []) if is_number(row.get("gamma"))
                      and abs(row["gamma"] - op.gamma) < 1e-9), None)
    notes = {}  # key -> why the headline number is what it is
    if published and published.get("status") == "differs":  # the headline differs from the published value
        notes["operating_point.lambda0"] = (
            f"Khomyak (2020), Table 3.2 publishes {number(published['published_theory'])} (theory) and "
            f"{number(published['published_experiment'])} (experiment) at γ = {number(published['gamma'])}: the "
            f"documented App. В algorithm makes the liquid's unbalance D ≫ D0 (k_D = {number(op.k_D)}); the table "
            "came from the thesis's C# program, which it does not show (docs/validation.md)")
    for key in ("optimal_height", "optimal_volume"):
        o = r.search(key)
        why = optimum_words(r, key) if o is not None else ""
        if o is not None and o.get("singular"):  # orders of magnitude from the published optimum: the row says why
            why += (f"; λ0 = {number(o.get('lambda0_max'))} there says how close IPOPT came to k_D = 1, not how "
                    "efficient the machine is (docs/validation.md)")
        notes[f"{key}.optimum"] = why
    sec.headline_rows(notes)  # the rows of the fields declared headline
    sec.notes.extend(EFFICIENCIES)
    sec.conclude(*r.verdict())
    rows = (r.table_3_2 or {}).get("rows", [])
    if rows:
        sec.comparison = table("Comparison with Khomyak (2020), Table 3.2: efficiency λ0",
                               ["γ", "published theory", "published experiment", "toolkit (documented)",
                                "toolkit (self-consistent)", "status"],
                               [[cell(row.get("gamma"), "1"), cell(row.get("published_theory"), "1"),
                                 cell(row.get("published_experiment"), "1"), cell(row.get("toolkit_documented"), "1"),
                                 cell(row.get("toolkit_self_consistent"), "1"), text(row.get("status"))]
                                for row in rows])
        differs = next((row for row in rows if row.get("status") == "differs"), None)
        if differs:
            sec.validation.append({"ok": None, "text": f"Table 3.2 is not reproduced by the documented algorithm: "
                                                       f"{differs.get('reason')}"})
    rows = (r.table_3_3 or {}).get("rows", [])
    if rows:
        columns = ("D0_gcm", "published_V_opt_mL", "experiment_V_opt_mL", "V_opt_mL", "V_opt_crescent_mL")
        shown = [r.quantities.find(f"table_3_3.rows.0.{k}") for k in columns]
        sec.validation_tables.append(table("Khomyak (2020), Table 3.3: optimal liquid volume",
                                           ["D0", "published V_opt", "experiment V_opt", "toolkit (documented)",
                                            "toolkit (crescent)", "status"],
                                           [[*(cell(row.get(k), q.unit, q.display, 4)
                                               for k, q in zip(columns, shown, strict=True)), text(row.get("status"))]
                                            for row in rows]))
