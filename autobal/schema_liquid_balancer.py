"""Scenario schema of the liquid auto-balancer (top-level part ``liquid_balancer:``) and of its analysis
(``analyses.liquid_balancer:``).  Quantities carry units and are converted to SI at load time.

Sources: Khomyak 2020 (Table 3.1 system, App. В/Г programs), Pashkov 2010 ch. 3 (nested chambers);
Khomyak (2020), Pashkov (2010).
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.schema import Positive, Range, Strict
from autobal.units import AngularSpeed, Density, Length, Viscosity, quantity

Mass = quantity("mass")
Volume = quantity("volume")
Stiffness = quantity("stiffness")
LengthOrZero = quantity("length", "nonnegative")
Rate = quantity("rate")


class LBRotor(Strict):
    """Rotor with its unbalance (Table 3.1)."""

    mass: Mass = Field(description="M_p, rotor mass")
    unbalance_mass: Mass = Field(description="m_d")
    unbalance_radius: Length = Field(description="e_d; D0 = m_d e_d")
    critical_speed: AngularSpeed = Field(description="omega_p (resonance speed)")
    log_decrement: Positive | None = Field(None, description="theta; n = theta omega_p / (2 pi) (erratum 1)")
    damping_coefficient: Rate | None = Field(None, description="n; overrides log_decrement")
    stiffness: Stiffness | None = Field(None, description="c [N/m], for the chapter-3 / Pashkov calculators only")

    @model_validator(mode="after")
    def _damping(self):
        if self.log_decrement is None and self.damping_coefficient is None:
            raise ValueError("give log_decrement or damping_coefficient (1/s, e.g. '7.85 1/s')")
        return self


class LBChamber(Strict):
    mass: Mass = Field(description="M_k")
    radius: Length = Field(description="R, inner radius of the (outer) chamber wall")
    height: Length = Field(description="h")
    inclination_deg: Annotated[float, Field(ge=0, le=90)] | None = Field(
        None, description="Omega_inc; 90 = vertical rotor")


class LBLiquid(Strict):
    volume: Volume = Field(description="V")
    density: Density = Field(description="rho")
    viscosity: Viscosity | None = Field(None, description="mu (viscous zone (2.15))")


class NestedChamber(Strict):
    radius: Length = Field(description="R_i, wall radius")
    volume: Volume = Field(description="V_i, liquid in this chamber")


class Nested(Strict):
    """Further concentric chambers inside the outer one, outermost first (Pashkov ch. 3, [T] (3.10)-(3.14))."""

    wall_thickness: LengthOrZero = Field(description="t_w, partition thickness")
    hub_radius: LengthOrZero = Field(0.0, description="inner wall of the innermost chamber")
    chambers: Annotated[list[NestedChamber], Field(min_length=1, max_length=100)] = Field(
        description="nested chambers, outermost first, 1 to 100")


class LiquidBalancer(Strict):
    """The system: rotor, chamber, liquid, working speed (Table 3.1 / GUI fig. 3.5)."""

    rotor: LBRotor
    chamber: LBChamber
    liquid: LBLiquid
    speed: AngularSpeed = Field(description="working angular speed omega")
    nested: Nested | None = None

    @model_validator(mode="after")
    def _geometry(self):
        R, h = self.chamber.radius, self.chamber.height
        vol = math.pi * R**2 * h
        if self.liquid.volume >= vol:
            raise ValueError(f"liquid.volume {self.liquid.volume:.6g} m^3 is not smaller than the chamber volume "
                             f"pi R^2 h = {vol:.6g} m^3: no free surface")
        if self.nested is not None:
            outer = R
            radii = [R] + [c.radius for c in self.nested.chambers]
            inner = [r + self.nested.wall_thickness for r in radii[1:]] + [self.nested.hub_radius]
            for i, (Ri, ri) in enumerate(zip(radii, inner, strict=True)):
                if ri >= Ri:
                    raise ValueError(f"nested.chambers[{i}].radius: chamber {i + 1} must fit inside chamber {i} "
                                     f"(radius + wall_thickness {ri:.6g} m >= {Ri:.6g} m)")
            for i, (c, ri) in enumerate(zip(self.nested.chambers, inner[1:], strict=True)):
                annulus = math.pi * h * (c.radius**2 - ri**2)
                if c.volume >= annulus:
                    raise ValueError(f"nested.chambers[{i}].volume {c.volume:.6g} m^3 is not smaller than the "
                                     f"chamber's annulus volume {annulus:.6g} m^3")
            annulus = math.pi * h * (outer**2 - inner[0] ** 2)
            if self.liquid.volume >= annulus:
                raise ValueError(f"liquid.volume {self.liquid.volume:.6g} m^3 is not smaller than the outer "
                                 f"chamber's annulus volume {annulus:.6g} m^3 (nested chambers inside)")
        return self


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
