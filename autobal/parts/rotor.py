"""Scene part ``rotor``: the Jeffcott rotor's schema (with its optional liquid layer and drive) and its adapter
to :class:`autobal.models.rotor.RotorParams` (SI); ``rotor_dynamics`` (the source's studies, Pashkov 2010) and
the spin-up analyses are built on it.

Quantities are written with units and converted to SI at load time; the source's dimensionless
groups (psi, mu1, the stationary n, zeta, a*) are plain numbers named as in the source.

The schema is derived from :class:`~autobal.models.rotor.RotorParams` and ``rotor.liquid`` from
:class:`~autobal.models.rotor.LiquidLayer` (:mod:`autobal.parts.derived`), where each parameter is declared with
its scene key, unit, meaning and default.  Written here by hand, as scene-only inputs without a field of their
own in the model: the datasheet form (``critical_speed``, ``damping_ratio``, ``unbalance``: a grade or a residual
unbalance), the liquid layer's alternative ``psi``, and the drive's limits (``max_torque``, ``max_power``,
``motor``, ``max_braking_torque``, ``max_deceleration``), which the spin-up analyses read from the scene.
"""

from __future__ import annotations

import math
import re
from typing import Annotated

from pydantic import Field, field_validator, model_validator

from autobal.models.rotor import LiquidLayer, RotorParams
from autobal.parts.derived import Group, schema, to_params
from autobal.schema import Strict
from autobal.units import AngularSpeed, quantity

Torque = quantity("torque")
Power = quantity("power")
Fraction = Annotated[float, Field(gt=0, le=1)]
UnbalanceMass = quantity("unbalance")
_GRADE = re.compile(r"G\s*(\d+(?:\.\d*)?)")


class _Liquid(Strict):
    """Liquid auto-balancer layer (model M1): a chamber of wall radius R and height h of
    liquid density rho (full-chamber mass rho pi R^2 h), or the design parameter psi = m1/m directly."""

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


Liquid = schema(LiquidLayer, "Liquid", base=_Liquid)


class Motor(Strict):
    """Linear motor characteristic L(omega) = stall_torque (1 - omega/no_load_speed)."""

    stall_torque: Torque
    no_load_speed: AngularSpeed


class DriveLimits(Strict):
    """The drive as specified: inertia and drag, torque and power limits, motor characteristic, and braking
    (a braking-torque limit, 0 = no braking, and/or a deceleration limit, 0 = the speed never falls; without
    either the drive brakes up to max_torque and decelerates up to the spin-up's max_acceleration)."""

    max_torque: Torque | None = None
    max_power: Power | None = None
    motor: Motor | None = None
    max_braking_torque: quantity("torque", "nonnegative") | None = Field(
        None, description="the largest braking torque -M, N m (0: the drive cannot brake)")
    max_deceleration: quantity("angular acceleration", "nonnegative") | None = Field(
        None, description="the largest deceleration -alpha (0: the speed never falls), rad/s^2")


class Unbalance(Strict):
    """The rotor's unbalance as a datasheet gives it: a balance quality grade G (ISO 21940-11, G in mm/s) at the
    service speed, e = G/Omega_service, or the residual unbalance U (e.g. 120 g*mm), e = U/m."""

    grade: str | None = Field(None, description="balance quality grade, e.g. G2.5 (G = e Omega in mm/s)")
    service_speed: AngularSpeed | None = None
    residual: UnbalanceMass | None = None

    @field_validator("grade")
    @classmethod
    def _grade(cls, v):
        if v is not None and (not _GRADE.fullmatch(v.strip()) or float(_GRADE.fullmatch(v.strip())[1]) <= 0):
            raise ValueError(f"{v!r}: a balance quality grade is G and a positive number in mm/s, e.g. G2.5")
        return v

    @model_validator(mode="after")
    def _one(self):
        if (self.grade is None) != (self.service_speed is None):
            raise ValueError("give grade (e.g. G2.5) together with service_speed (e.g. 3000 rpm)")
        if (self.grade is None) == (self.residual is None):
            raise ValueError("give either grade with service_speed or residual (e.g. 120 g*mm), not both")
        return self

    @property
    def grade_m_s(self) -> float | None:
        """G in SI, m/s."""
        return None if self.grade is None else float(_GRADE.fullmatch(self.grade.strip())[1]) * 1e-3


class _Rotor(Strict):
    """Jeffcott (Laval) rotor on a flexible shaft, with optional liquid layer and drive.

    Given in SI (stiffness, damping, eccentricity) or from its datasheet (critical_speed, the undamped natural
    frequency sqrt(c/m1) of the rotor without liquid; damping_ratio zeta = chi/(2 sqrt(c m1)); unbalance as a
    balance quality grade or a residual unbalance); each pair one or the other."""

    critical_speed: AngularSpeed | None = Field(None, description="undamped critical speed sqrt(c/m1)")
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] | None = Field(
        None, description="zeta = chi/(2 sqrt(c m1)), dimensionless")
    unbalance: Unbalance | None = None
    liquid: Liquid | None = None

    @model_validator(mode="after")
    def _si_or_datasheet(self):
        for si, sheet, how in (("stiffness", "critical_speed", "N/m, or rpm"),
                               ("damping", "damping_ratio", "N*s/m, or dimensionless"),
                               ("eccentricity", "unbalance", "m, or a grade/residual block")):
            if (getattr(self, si) is None) == (getattr(self, sheet) is None):
                raise ValueError(f"give exactly one of {si} and {sheet} ({how})")
        return self


Rotor = schema(RotorParams, "Rotor", base=_Rotor, groups=(
    Group("drive", "Drive", "the drive: inertia, drag and limits", DriveLimits, optional=True),))
SCHEMA = Rotor
DESCRIPTION = "Jeffcott rotor with optional liquid layer and drive"


def adapt(r: Rotor) -> RotorParams:
    """The scene's ``rotor`` section as :class:`autobal.models.rotor.RotorParams` (SI).

    Parameters
    ----------
    r : Rotor
        The validated section; a liquid layer is given by its chamber or by psi = m1/m.  From the datasheet:
        c = m1 Omega_c^2 (Omega_c the undamped critical speed without liquid), chi = 2 zeta sqrt(c m1)
        = 2 zeta m1 Omega_c, e = G/Omega_service (balance quality grade G, ISO 21940-11) or e = U/m1 (residual
        unbalance U).

    Returns
    -------
    RotorParams
    """
    m1, filled = r.mass, {}
    c = r.stiffness
    if c is None:
        c = filled["c"] = m1 * r.critical_speed**2
    if r.damping is None:
        filled["chi"] = 2 * r.damping_ratio * math.sqrt(c * m1)
    if r.eccentricity is None:
        u = r.unbalance
        if u.grade is not None:
            from autobal.analysis.numerics.standards import permissible_eccentricity  # e = G/Omega, ISO 21940-11

            filled["e"] = permissible_eccentricity(u.grade_m_s, u.service_speed)
        else:
            filled["e"] = u.residual / m1
    p = to_params(r, **filled)
    if r.liquid is None:
        return p
    if r.liquid.psi is not None:
        return p.with_psi(r.liquid.psi)
    return p.with_liquid(to_params(r.liquid))
