"""The one unit vocabulary: every kind of quantity, its SI unit, its physical range and the units it is shown in.

The scene loader (:mod:`autobal.units`: a value written with its unit, converted to SI) and the display
(:mod:`autobal.analysis.run.quantities`: an SI number shown in an engineer's unit, chosen by a scene's ``display:``
section or ``--units``) both read :data:`TABLE`.  A kind is named as the models declare it (``si(...,
kind="volume flow")``); the short name a display choice uses (``flow``) is its alias, and either names it.
SI units are written as results.json writes them (``m^3/s``; the loader reads them as ``m**3/s``), display units
as engineers write them (``m³/h``, ``µm``, ``kN/mm``), with the SI value of one of them; a unit's other spellings
(``r/min`` for ``rpm``) are its aliases.  ``tests/test_units_vocabulary.py`` checks every display unit's factor
against the loader reading the same unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

RPM = 2 * math.pi / 60  # rad/s in one revolution per minute (omega = 2 pi n)


@dataclass(frozen=True)
class Kind:
    """One kind of quantity.

    Attributes
    ----------
    name : str
        As the models declare it ("volume flow").
    si : str
        Its SI unit as results.json writes it ("m^3/s").
    dimension : str
        pint's dimensionality of the SI unit.
    example : str
        A value as a scene writes it, for messages ("0.167 m^3/s").
    magnitude : (float, float)
        The physical range of its magnitude in SI (a scene's value outside it is refused).
    display : dict
        Display unit -> SI value of one, in the order a message lists them.
    default : str
        The display unit of a declared number that names none ("" : the SI unit, engineer-spelled).
    alias : str
        The short name of a display choice (``display: {flow: m3/h}``), "" when it is the name.
    covers : str
        What a display choice of this kind covers; "" : the kind has no display choice.
    unit_aliases : dict
        Other spellings of a display unit -> the display unit ("r/min" -> "rpm").
    """

    name: str
    si: str
    dimension: str
    example: str
    magnitude: tuple[float, float]
    display: dict = field(default_factory=dict)
    default: str = ""
    alias: str = ""
    covers: str = ""
    unit_aliases: dict = field(default_factory=dict)

    @property
    def choice(self) -> str:
        """The name a display choice uses: the alias, else the name."""
        return self.alias or self.name

    @property
    def written(self) -> str:
        """The SI unit as a scene (and pint) writes it: "m**3/s"."""
        return self.si.replace("^", "**")


_MLT2 = "[mass] / [length] / [time] ** 2"
# The ranges are the physical ones of a rotor machine and its balancing devices, kept wide: they refuse values no
# device has (a 1 km gap, a 1 TPa pressure) before they overflow the equations.
TABLE = (
    Kind("length", "m", "[length]", "0.35 mm", (1e-9, 1e3), {"m": 1.0, "mm": 1e-3, "µm": 1e-6}, "mm",
         covers="gaps, openings, clearances, deflections, AFC amplitudes"),
    Kind("area", "m^2", "[length] ** 2", "0.016 m^2", (1e-18, 1e6), {"m²": 1.0, "mm²": 1e-6, "cm²": 1e-4}, "mm²",
         covers="areas"),
    Kind("volume", "m^3", "[length] ** 3", "4.7e-5 m^3", (1e-27, 1e9),
         {"m³": 1.0, "L": 1e-3, "cm³": 1e-6, "mL": 1e-6}, "L", covers="volumes"),
    Kind("pressure", "Pa", _MLT2, "32.3 MPa", (1e-3, 1e11),
         {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5, "mbar": 1e2}, "MPa",
         covers="pressures and pressure margins"),
    Kind("force", "N", "[mass] * [length] / [time] ** 2", "3.3e5 N", (1e-9, 1e10), {"N": 1.0, "kN": 1e3}, "kN",
         covers="forces"),
    Kind("stiffness", "N/m", "[mass] / [time] ** 2", "1e8 N/m", (1e-9, 1e14),
         {"N/m": 1.0, "kN/m": 1e3, "MN/m": 1e6, "N/µm": 1e6, "kN/mm": 1e6}, covers="stiffnesses (springs)"),
    Kind("damping", "N*s/m", "[mass] / [time]", "8.9e4 N*s/m", (1e-12, 1e12), {"N·s/m": 1.0, "kN·s/m": 1e3},
         covers="damping coefficients"),
    Kind("volume flow", "m^3/s", "[length] ** 3 / [time]", "0.167 m^3/s", (1e-15, 1e4),
         {"m³/s": 1.0, "L/s": 1e-3, "L/min": 1e-3 / 60, "m³/h": 1 / 3600}, "L/s", alias="flow",
         covers="volume flows (leaks, barrier and seal flows)"),
    Kind("angular speed", "rad/s", "1 / [time]", "6300 rpm", (1e-9, 1e7),
         {"rad/s": 1.0, "rpm": RPM, "Hz": 2 * math.pi}, alias="speed", covers="angular speeds and frequencies",
         unit_aliases={"r/min": "rpm", "1/min": "rpm", "rps": "Hz"}),
    Kind("angular acceleration", "rad/s^2", "1 / [time] ** 2", "40 rad/s^2", (1e-9, 1e10),
         {"rad/s²": 1.0, "rpm/s": RPM}, alias="acceleration", covers="angular accelerations"),
    Kind("time", "s", "[time]", "50 ms", (1e-12, 1e10), {"s": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0,
                                                        "kh": 3.6e6}, covers="times"),
    Kind("velocity", "m/s", "[length] / [time]", "2.5 mm/s", (1e-12, 1e4), {"m/s": 1.0, "mm/s": 1e-3}, "mm/s",
         covers="velocities (ISO 21940-11 balance grades G = e Ω)"),
    Kind("mass", "kg", "[mass]", "3000 kg", (1e-12, 1e8), {"kg": 1.0, "g": 1e-3}, covers="masses"),
    Kind("unbalance", "kg*m", "[mass] * [length]", "120 g*mm", (1e-15, 1e6),
         {"kg·m": 1.0, "g·cm": 1e-5, "g·mm": 1e-6}, covers="unbalances m·e"),  # residual unbalance U = m e
    Kind("power", "W", "[mass] * [length] ** 2 / [time] ** 3", "6 W", (1e-12, 1e10), {"W": 1.0, "kW": 1e3},
         covers="powers"),
    # kinds a scene writes that are shown as declared (no display choice)
    # bulk modulus of the barrier medium: up to 1e16 Pa, so that a scene can approach the incompressible limit
    Kind("bulk modulus", "Pa", _MLT2, "1.42e5 Pa", (1e-3, 1e16)),
    Kind("density", "kg/m^3", "[mass] / [length] ** 3", "1000 kg/m^3", (1e-6, 1e5)),
    Kind("viscosity", "Pa*s", "[mass] / [length] / [time]", "1e-3 Pa*s", (1e-8, 1e8)),
    Kind("rate", "1/s", "1 / [time]", "7.85 1/s", (1e-9, 1e7)),  # a decay rate n, chi/m1: not an angle per time
    Kind("angular jerk", "rad/s^3", "1 / [time] ** 3", "2000 rad/s^3", (1e-9, 1e12)),  # spin-up jerk bound
    Kind("torque", "N*m", "[mass] * [length] ** 2 / [time] ** 2", "0.04 N*m", (1e-12, 1e9)),
    Kind("moment of inertia", "kg*m^2", "[mass] * [length] ** 2", "1e-3 kg*m^2", (1e-15, 1e9)),
    Kind("rotational damping", "N*m*s", "[mass] * [length] ** 2 / [time]", "1e-5 N*m*s", (1e-15, 1e9)),
)

#: kind name and alias -> :class:`Kind`
BY_NAME = {n: k for k in TABLE for n in (k.name, k.alias) if n}


def kind(name: str) -> Kind:
    """The kind of a name or alias ("volume flow", "flow"); ValueError naming the kinds a display choice has."""
    if name not in BY_NAME:
        raise ValueError(f"'{name}' is not a kind of quantity; choose units for "
                         f"{', '.join(k.choice for k in TABLE if k.covers)}")
    return BY_NAME[name]


def markdown_table() -> str:
    """The vocabulary as a Markdown table (docs/contributing.md holds it; a test checks it is this)."""
    rows = ["| kind | display choice | SI unit | display units (**default**) | magnitude in SI |",
            "|---|---|---|---|---|"]
    for k in TABLE:
        default = k.default or next((u for u in k.display if k.display[u] == 1.0), "")
        sibling = next((o.choice for o in TABLE if o.covers and o.si == k.si and o is not k), "")
        shown = ", ".join(f"**{u}**" if u == default else u for u in k.display) or (
            f"as `{sibling}`" if sibling else "the SI unit")
        also = f" ({', '.join(f'{a} = {u}' for a, u in k.unit_aliases.items())})" if k.unit_aliases else ""
        choice = f"`{k.choice}`" if k.covers else "—"
        rows.append(f"| {k.name} | {choice} | `{k.si}` | {shown}{also} | {k.magnitude[0]:g} to {k.magnitude[1]:g} |")
    return "\n".join(rows)
