"""Physical quantities written as users write them ("32.3 MPa", "0.35 mm", "6300 rpm"), parsed
with pint and converted to SI floats at load time."""

from __future__ import annotations

from typing import Annotated

import pint
from pydantic import AfterValidator, BeforeValidator

UREG = pint.UnitRegistry()

# name -> (pint dimensionality, SI unit used inside the toolkit, example)
DIMENSIONS = {
    "length": ("[length]", "m", "0.35 mm"),
    "area": ("[length] ** 2", "m**2", "0.016 m^2"),
    "volume": ("[length] ** 3", "m**3", "4.7e-5 m^3"),
    "pressure": ("[mass] / [length] / [time] ** 2", "Pa", "32.3 MPa"),
    "force": ("[mass] * [length] / [time] ** 2", "N", "3.3e5 N"),
    "density": ("[mass] / [length] ** 3", "kg/m**3", "1000 kg/m^3"),
    "viscosity": ("[mass] / [length] / [time]", "Pa*s", "1e-3 Pa*s"),
    "volume flow": ("[length] ** 3 / [time]", "m**3/s", "0.167 m^3/s"),
    "angular speed": ("1 / [time]", "rad/s", "6300 rpm"),
    "mass": ("[mass]", "kg", "3000 kg"),  # dynamics (autobal/schema_dynamics.py)
    "stiffness": ("[mass] / [time] ** 2", "N/m", "1e8 N/m"),
    "damping": ("[mass] / [time]", "N*s/m", "8.9e4 N*s/m"),
    "time": ("[time]", "s", "50 ms"),
    "angular acceleration": ("1 / [time] ** 2", "rad/s**2", "40 rad/s^2"),  # rotor spin-up (schema_rotor.py)
    "angular jerk": ("1 / [time] ** 3", "rad/s**3", "2000 rad/s^3"),  # spin-up jerk bound
    "torque": ("[mass] * [length] ** 2 / [time] ** 2", "N*m", "0.04 N*m"),
    "power": ("[mass] * [length] ** 2 / [time] ** 3", "W", "6 W"),
    "moment of inertia": ("[mass] * [length] ** 2", "kg*m**2", "1e-3 kg*m^2"),
    "rotational damping": ("[mass] * [length] ** 2 / [time]", "N*m*s", "1e-5 N*m*s"),
}


def to_si(value: object, kind: str) -> float:
    """Convert ``value`` (a string with a unit) to a float in the SI unit of ``kind``."""
    dim, si, example = DIMENSIONS[kind]
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise ValueError(f"expected a {kind} with a unit, e.g. '{example}'")
    if not isinstance(value, str):
        raise ValueError(f"{value!r} has no unit: write a {kind} with its unit, e.g. '{example}'")
    try:
        q = UREG.Quantity(value)
    except Exception as exc:  # pint raises several unrelated types on garbage
        raise ValueError(f"cannot read {value!r} as a {kind} (e.g. '{example}'): {exc}") from None
    if q.dimensionality != UREG.get_dimensionality(dim):
        raise ValueError(f"{value!r} is not a {kind}: expected a unit like '{example}' "
                         f"(SI: {si}), got dimension {q.dimensionality}")
    return float(q.to(si).magnitude)


def _positive(x: float) -> float:
    if not x > 0:
        raise ValueError(f"must be positive, got {x:g} (SI)")
    return x


def _nonnegative(x: float) -> float:
    if not x >= 0:
        raise ValueError(f"must not be negative, got {x:g} (SI)")
    return x


def quantity(kind: str, sign: str = "positive"):
    """An annotated float field holding a ``kind`` quantity in SI, checked for ``sign``."""
    check = {"positive": _positive, "nonnegative": _nonnegative}[sign]
    return Annotated[float, BeforeValidator(lambda v: to_si(v, kind)), AfterValidator(check)]


Length = quantity("length")
Area = quantity("area")
Pressure = quantity("pressure")
PressureOrZero = quantity("pressure", "nonnegative")
Force = quantity("force")
ForceOrZero = quantity("force", "nonnegative")
Density = quantity("density")
Viscosity = quantity("viscosity")
VolumeFlow = quantity("volume flow")
AngularSpeed = quantity("angular speed")
