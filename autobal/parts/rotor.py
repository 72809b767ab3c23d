"""Scene part ``rotor``: the Jeffcott rotor's schema (with its optional liquid layer and drive) and its adapter
to :class:`autobal.models.rotor.RotorParams` (SI); ``rotor_dynamics`` (the source's studies, Pashkov 2010) and
the spin-up analyses are built on it.

Quantities are written with units and converted to SI at load time; the source's dimensionless
groups (psi, mu1, the stationary n, zeta, a*) are plain numbers named as in the source.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.models.rotor import LiquidLayer, RotorParams
from autobal.schema import Strict
from autobal.units import AngularSpeed, Density, Length, quantity

Mass = quantity("mass")
Stiffness = quantity("stiffness")
DampingOrZero = quantity("damping", "nonnegative")
Torque = quantity("torque")
Power = quantity("power")
Inertia = quantity("moment of inertia")
RotationalDampingOrZero = quantity("rotational damping", "nonnegative")
Fraction = Annotated[float, Field(gt=0, le=1)]


class Liquid(Strict):
    """Liquid auto-balancer layer (model M1): a chamber of wall radius R and height h of
    liquid density rho (full-chamber mass rho pi R^2 h), or the design parameter psi = m1/m directly."""

    density: Density | None = None
    radius: Length | None = None
    height: Length | None = None
    free_surface_radius: Length | None = None
    psi: Fraction | None = None

    @model_validator(mode="after")
    def _geometry_or_psi(self):
        geo = [self.density, self.radius, self.height]
        if self.psi is None and any(v is None for v in geo):
            raise ValueError("give density, radius and height of the chamber, or psi")
        if self.psi is not None and any(v is not None for v in geo):
            raise ValueError("give either the chamber (density, radius, height) or psi, not both")
        if self.free_surface_radius is not None and self.radius is not None and self.free_surface_radius >= self.radius:
            raise ValueError("free_surface_radius must be smaller than radius")
        return self


class Motor(Strict):
    """Linear motor characteristic L(omega) = stall_torque (1 - omega/no_load_speed)."""

    stall_torque: Torque
    no_load_speed: AngularSpeed


class Drive(Strict):
    polar_inertia: Inertia = Field(description="J_p of rotor and drive")
    drag: RotationalDampingOrZero = Field(0.0, description="b, N m s")
    max_torque: Torque | None = None
    max_power: Power | None = None
    motor: Motor | None = None


class Rotor(Strict):
    """Jeffcott (Laval) rotor on a flexible shaft, with optional liquid layer and drive."""

    mass: Mass = Field(description="m1, without liquid")
    stiffness: Stiffness = Field(description="c")
    damping: DampingOrZero = Field(description="chi, external viscous friction")
    eccentricity: Length = Field(description="e")
    liquid: Liquid | None = None
    drive: Drive | None = None


SCHEMA = Rotor
DESCRIPTION = "Jeffcott rotor with optional liquid layer and drive"


def adapt(r: Rotor) -> RotorParams:
    """The scene's ``rotor`` section as :class:`autobal.models.rotor.RotorParams` (SI).

    Parameters
    ----------
    r : Rotor
        The validated section; a liquid layer is given by its chamber or by psi = m1/m.

    Returns
    -------
    RotorParams
    """
    p = RotorParams(m1=r.mass, c=r.stiffness, chi=r.damping, e=r.eccentricity,
                    J_p=r.drive.polar_inertia if r.drive else 0.0, b=r.drive.drag if r.drive else 0.0)
    if r.liquid is None:
        return p
    if r.liquid.psi is not None:
        return p.with_psi(r.liquid.psi)
    return p.with_liquid(LiquidLayer(r.liquid.density, r.liquid.radius, r.liquid.height,
                                     r.liquid.free_surface_radius))
