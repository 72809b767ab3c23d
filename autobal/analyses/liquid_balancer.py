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
REPORT_SECTION = "liquid_balancer_section"


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
    from autobal.analysis import liquid_balancer as lb
    from autobal.parts import liquid_balancer as part

    return lb.run(part.adapt(scene.liquid_balancer), settings, scene.title)


def estimate_seconds(settings: LiquidBalancerAnalysis) -> float:
    """The dense cross-check grids of the height and volume searches, per unbalance and liquid."""
    grid = sum(s.grid_points for s in (settings.height, settings.volume) if s is not None)
    return COST["start"] + COST["grid_point"] * grid * (1 + len(settings.unbalance_masses) + len(settings.liquids))
