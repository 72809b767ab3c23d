"""Scene part ``liquid_balancer``: the liquid auto-balancer's schema and its adapter to
:class:`autobal.models.liquid_balancer.System` (SI).  Quantities carry units and are converted to SI at load time.

The schema is derived from :class:`~autobal.models.liquid_balancer.System` (:mod:`autobal.parts.derived`), where
each parameter is declared with its place in the scene (``rotor``, ``chamber``, ``liquid``, ``nested``), unit,
meaning and default.  Written here by hand, as scene-only inputs without a field of their own in ``System``:
``rotor.log_decrement`` (the alternative to ``damping_coefficient``), ``chamber.inclination_deg`` (degrees;
the model's ``inclination`` is in rad) and the list ``nested.chambers`` (the model's ``nested_radii`` and
``nested_volumes``), and the checks across sections.

Sources: Khomyak 2020 (Table 3.1 system, App. В/Г programs), Pashkov 2010 ch. 3 (nested chambers);
Khomyak (2020), Pashkov (2010).
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, model_validator

from autobal.models.liquid_balancer import System, n_from_decrement
from autobal.parts.derived import Group, schema, to_params
from autobal.schema import Positive, Strict
from autobal.units import Length, Volume


class _LBRotor(Strict):
    """Rotor with its unbalance (Table 3.1)."""

    log_decrement: Positive | None = Field(None, description="theta; n = theta omega_p / (2 pi) (erratum 1)")

    @model_validator(mode="after")
    def _damping(self):
        if self.log_decrement is None and self.damping_coefficient is None:
            raise ValueError("give log_decrement or damping_coefficient (1/s, e.g. '7.85 1/s')")
        return self


class _LBChamber(Strict):
    inclination_deg: Annotated[float, Field(ge=0, le=90)] | None = Field(
        None, description="Omega_inc; 90 = vertical rotor")


class NestedChamber(Strict):
    radius: Length = Field(description="R_i, wall radius")
    volume: Volume = Field(description="V_i, liquid in this chamber")


class _Nested(Strict):
    """Further concentric chambers inside the outer one, outermost first (Pashkov ch. 3, [T] (3.10)-(3.14))."""

    chambers: Annotated[list[NestedChamber], Field(min_length=1, max_length=100)] = Field(
        description="nested chambers, outermost first, 1 to 100")


class _LiquidBalancer(Strict):
    """The system: rotor, chamber, liquid, working speed (Table 3.1 / GUI fig. 3.5)."""

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


LiquidBalancer = schema(System, "LiquidBalancer", base=_LiquidBalancer, groups=(
    Group("rotor", "LBRotor", "the rotor with its unbalance", _LBRotor),
    Group("chamber", "LBChamber", "the balancer's (outer) chamber", _LBChamber),
    Group("liquid", "LBLiquid", "the liquid in the chamber"),
    Group("nested", "Nested", "further chambers inside the outer one", _Nested, optional=True)))
SCHEMA = LiquidBalancer
DESCRIPTION = "liquid auto-balancer"


def adapt(part) -> System:
    """The scene's ``liquid_balancer`` section as :class:`autobal.models.liquid_balancer.System` (SI).

    The damping constant n is the section's ``damping_coefficient`` or, from the log decrement,
    n = theta omega_cr / (2 pi) (:func:`autobal.models.liquid_balancer.n_from_decrement`).
    """
    ro, ch, nest = part.rotor, part.chamber, part.nested
    filled = {}
    if ro.damping_coefficient is None:
        filled["n"] = n_from_decrement(ro.log_decrement, ro.critical_speed)
    if ch.inclination_deg is not None:
        filled["inclination"] = math.radians(ch.inclination_deg)
    if nest is not None:
        filled["nested_radii"] = tuple(c.radius for c in nest.chambers)
        filled["nested_volumes"] = tuple(c.volume for c in nest.chambers)
    return to_params(part, **filled)
