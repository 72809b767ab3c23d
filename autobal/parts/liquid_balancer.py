"""Scene part ``liquid_balancer``: the liquid auto-balancer's schema and its adapter to
:class:`autobal.models.liquid_balancer.System` (SI).  Quantities carry units and are converted to SI at load time.

Sources: Khomyak 2020 (Table 3.1 system, App. В/Г programs), Pashkov 2010 ch. 3 (nested chambers);
Khomyak (2020), Pashkov (2010).
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, model_validator

from autobal.models.liquid_balancer import System, n_from_decrement
from autobal.schema import Positive, Strict
from autobal.units import AngularSpeed, Density, Length, LengthOrZero, Mass, Stiffness, Viscosity, Volume, quantity

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


SCHEMA = LiquidBalancer
DESCRIPTION = "liquid auto-balancer"


def adapt(part: LiquidBalancer) -> System:
    """The scene's ``liquid_balancer`` section as :class:`autobal.models.liquid_balancer.System` (SI).

    The damping constant n is the section's ``damping_coefficient`` or, from the log decrement,
    n = theta omega_cr / (2 pi) (:func:`autobal.models.liquid_balancer.n_from_decrement`).
    """
    ro, ch, li = part.rotor, part.chamber, part.liquid
    n = ro.damping_coefficient if ro.damping_coefficient is not None else n_from_decrement(
        ro.log_decrement, ro.critical_speed)
    nest = part.nested
    return System(rotor_mass=ro.mass, chamber_mass=ch.mass, unbalance_mass=ro.unbalance_mass,
                  unbalance_radius=ro.unbalance_radius, omega_cr=ro.critical_speed, n=n, R=ch.radius,
                  h=ch.height, V=li.volume, rho=li.density, speed=part.speed, mu=li.viscosity,
                  stiffness=ro.stiffness,
                  inclination=None if ch.inclination_deg is None else math.radians(ch.inclination_deg),
                  nested_radii=tuple(c.radius for c in nest.chambers) if nest else (),
                  nested_volumes=tuple(c.volume for c in nest.chambers) if nest else (),
                  wall_thickness=nest.wall_thickness if nest else 0.0,
                  hub_radius=nest.hub_radius if nest else 0.0)
