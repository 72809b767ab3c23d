"""Declared result quantities and the display units an engineer reads.

Every number a result writes into its results.json block is declared once, beside the code that computes
it, as a :class:`Quantity`: the key (a dotted path in the block), the symbol, the SI unit, the display unit,
a description and, for a published value, the source.  The ``units`` map of results.json, the unit column
of the report, the terminal summaries and docs/results.md are made from these declarations; nothing reads a
unit off a key's name.

Keys are dotted paths within an analysis block; ``*`` stands for one key of a mapping whose keys are names
(a model, a fit, a parameter), ``**`` for any keys below (a block of bookkeeping numbers), ``[]`` for the
items of a list of records; one declaration may name several keys separated by spaces.  SI units are
written as results.json writes them (``m^3/s``, ``"1"`` for the source's dimensionless groups); display
units as engineers write them (``m³/h``, ``µm``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

#: display unit -> (SI unit, SI value of one display unit): the one conversion table of the toolkit (a unit is
#: also a display unit of itself, spelled as engineers write it: see :func:`spelled`)
DISPLAY_UNITS = {
    "m": ("m", 1.0), "mm": ("m", 1e-3), "µm": ("m", 1e-6),
    "m²": ("m^2", 1.0), "mm²": ("m^2", 1e-6), "cm²": ("m^2", 1e-4),
    "m³": ("m^3", 1.0), "L": ("m^3", 1e-3), "cm³": ("m^3", 1e-6), "mL": ("m^3", 1e-6),
    "Pa": ("Pa", 1.0), "kPa": ("Pa", 1e3), "MPa": ("Pa", 1e6), "bar": ("Pa", 1e5),
    "N": ("N", 1.0), "kN": ("N", 1e3),
    "N/m": ("N/m", 1.0), "kN/m": ("N/m", 1e3), "MN/m": ("N/m", 1e6),
    "N·s/m": ("N*s/m", 1.0), "kN·s/m": ("N*s/m", 1e3),
    "m³/s": ("m^3/s", 1.0), "L/s": ("m^3/s", 1e-3), "L/min": ("m^3/s", 1e-3 / 60), "m³/h": ("m^3/s", 1 / 3600),
    "rad/s": ("rad/s", 1.0), "rpm": ("rad/s", 2 * math.pi / 60), "Hz": ("rad/s", 2 * math.pi),
    "s": ("s", 1.0), "ms": ("s", 1e-3),
    "kg": ("kg", 1.0), "g": ("kg", 1e-3), "kg·m": ("kg*m", 1.0), "g·cm": ("kg*m", 1e-5),
}

#: SI unit -> the display unit used when a declaration names none (the field's habits: MPa, mm, L/s, kN)
DEFAULT_DISPLAY = {"m": "mm", "m^2": "mm²", "m^3": "L", "Pa": "MPa", "N": "kN", "m^3/s": "L/s"}

#: SI unit -> the unit shown beside it: speeds in rpm beside rad/s
BESIDE = {"rad/s": "rpm"}


def spelled(unit: str) -> str:
    """A unit as engineers write it: "m^3/s" -> "m³/s", "um" -> "µm", "N*m" -> "N·m"."""
    for a, b in (("um", "µm"), ("^2", "²"), ("^3", "³"), ("*", "·")):
        unit = unit.replace(a, b)
    return unit


def display_unit_of(si: str) -> str:
    """The default display unit of a unit of results.json (the unit itself, engineer-spelled, when it has none)."""
    return DEFAULT_DISPLAY.get(si, spelled(si))


def is_display_unit(shown: str, si: str) -> bool:
    """Whether ``shown`` is a display unit of the results.json unit ``si`` (the unit itself, spelled, is one)."""
    return shown == spelled(si) or DISPLAY_UNITS.get(shown, (None,))[0] == si


def convert(value: float, si: str, shown: str) -> float:
    """A value of results.json unit ``si`` in the display unit ``shown``; ValueError if it is not one of ``si``."""
    if not is_display_unit(shown, si):
        raise ValueError(f"'{shown}' is not a display unit of '{si}'")
    return value if shown == spelled(si) else value / DISPLAY_UNITS[shown][1]


def significant(value, digits: int = 4) -> str:
    """A number to ``digits`` significant digits, plainly written ('—' for null/NaN, 'yes'/'no')."""
    if value is None or isinstance(value, float) and not math.isfinite(value):
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if value == 0:
        return "0"
    mantissa, exp = f"{value:.{digits - 1}e}".split("e")  # rounded to the digits first: 0.099999 -> 1.000e-01
    exp = int(exp)
    if not -3 <= exp < 6:
        return f"{mantissa}e{exp}"
    return f"{float(mantissa) * 10.0 ** exp:.{max(digits - 1 - exp, 0)}f}"


@dataclass(frozen=True)
class Quantity:
    """One declared number of a results.json block.

    Attributes
    ----------
    key : str
        Dotted path(s) in the analysis block, space-separated; ``*`` one named key, ``[]`` list items.
    unit : str
        SI unit as written in results.json (``"1"``: a dimensionless group named as in the source).
    symbol : str
        The symbol, as in the source (``z0``, ``ψ1``).
    description : str
        What it is, in words.
    display : str
        The unit a person reads (a key of :data:`DISPLAY_UNITS`); default :func:`display_unit_of`.
    source : str
        Where the value (or its definition) is published: author, year, equation/table/figure.
    headline : bool
        One of the numbers a reader looks at first (the summary, the notebook table).
    beside : str
        A unit shown in brackets after the display unit; default :data:`BESIDE` (rpm beside a speed), "Hz"
        beside a vibration frequency.
    """

    key: str
    unit: str
    symbol: str = ""
    description: str = ""
    display: str = ""
    source: str = ""
    headline: bool = False
    beside: str | None = None

    def __post_init__(self):
        shown = self.display or display_unit_of(self.unit)
        if not is_display_unit(shown, self.unit):
            raise ValueError(f"{self.key}: display unit '{shown}' is not a unit of '{self.unit}'")
        object.__setattr__(self, "display", shown)

    @property
    def keys(self) -> list[str]:
        return self.key.split()

    def shown(self, value) -> float | None:
        """``value`` (SI) in the display unit."""
        return None if value is None else convert(value, self.unit, self.display)

    def text(self, value, digits: int = 4) -> str:
        """'value unit' in the display unit, speeds with rpm beside: '143.9 µm', '1977 rad/s (18 880 rpm)'."""
        shown = self.shown(value)
        unit = "" if self.display == "1" else f" {self.display}"
        out = significant(shown, digits) + unit
        beside = BESIDE.get(self.unit) if self.beside is None else self.beside
        if beside and self.display != beside and value is not None:
            out += f" ({significant(convert(value, self.unit, beside), digits)} {beside})"
        return out


def _pattern(key: str) -> re.Pattern:
    parts = [{"**": r".+", "*": r"[^.\[\]]+"}.get(p) or re.escape(p) for p in re.split(r"(\*\*|\*)", key)]
    return re.compile("".join(parts))


class Declarations:
    """The declared quantities of one analysis: key path -> :class:`Quantity`.

    ``resolve(path, block)``, optional, declares the keys whose unit is that of a parameter the key or the
    block names (the values of a scanned parameter, a design variable by its scene path): it returns the
    :class:`Quantity` of such a key, or None; ``block`` is None where only the path is known."""

    def __init__(self, *quantities: Quantity, resolve=None):
        quantities = (*quantities, *COMMON)
        self.quantities = list(quantities)
        self.resolve = resolve
        self._exact = {k: q for q in quantities for k in q.keys if "*" not in k}
        self._patterns = [(_pattern(k), q) for q in quantities for k in q.keys if "*" in k]

    def __iter__(self):
        return iter(self.quantities)

    def find(self, path: str, block: dict | None = None) -> Quantity | None:
        """The declaration of a key path, or None; an integer key picks an item of a list of records
        (``peaks.0.omega`` is ``peaks[].omega``) or, last, an element of a list of numbers (``P.0`` is ``P``);
        then ``resolve(path, block)``."""
        records = re.sub(r"\.\d+(?=\.)", "[]", path)
        for candidate in (path, re.sub(r"\.\d+$", "[]", records), re.sub(r"\.\d+$", "", records)):
            if candidate in self._exact:
                return self._exact[candidate]
            q = next((q for p, q in self._patterns if p.fullmatch(candidate)), None)
            if q is not None:
                return q
        return None if self.resolve is None else self.resolve(path, block)

    def headline(self, block: dict) -> list[tuple[Quantity, str, object]]:
        """(declaration, key, value) of the headline quantities ``block`` holds, in declaration order."""
        out = []
        for q in self.quantities:
            for k in q.keys if q.headline else ():
                v = lookup(block, k)
                if v is not MISSING and (v is None or is_number(v)):
                    out.append((q, k, v))
        return out

    def lines(self, block: dict) -> list[str]:
        """The headline quantities as summary lines: description, symbol, value in the display unit."""
        rows = [(q.description, q.symbol, q.text(v)) for q, _, v in self.headline(block)]
        width = max((len(d) for d, _, _ in rows), default=0)
        return [f"  {d:<{width}s}  {s:<7s} {t}" for d, s, t in rows]

    def columns(self, table: dict, prefix: str) -> dict:
        """CSV columns of ``table`` (the block's mapping at ``prefix``, column name -> values): a declared numeric
        column headed 'name [display unit]' in that unit ('[1]' for a group), words and yes/no as they are."""
        out = {}
        for name, values in table.items():
            q = self.find(f"{prefix}.{name}" if prefix else name)
            if q is None or not any(is_number(v) for v in flatten(values)):
                out[name] = values
            else:
                out[f"{name} [{q.display}]"] = [q.shown(v) if is_number(v) else None for v in values]
        return out

    def undeclared(self, block: dict) -> list[str]:
        """The key paths of ``block``'s numeric leaves that have no declaration."""
        return list(dict.fromkeys(p for p, _ in leaf_paths(block, "") if self.find(p, block) is None))


MISSING = object()


def lookup(block, path: str, default=MISSING):
    """``block`` at a dotted path (an integer picks a list item), or ``default``."""
    for key in path.split("."):
        if isinstance(block, dict) and key in block:
            block = block[key]
        elif isinstance(block, list) and key.isdigit() and int(key) < len(block):
            block = block[int(key)]
        else:
            return default
    return block


#: the numbers every analysis block may carry
COMMON = (Quantity("accuracy.**", "1", "", "estimated relative error of the main outputs and its parts"),)


def is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def flatten(seq):
    for v in seq:
        if isinstance(v, list | tuple):
            yield from flatten(v)
        else:
            yield v


def leaf_paths(value, path: str = ""):
    """(dotted path, value) of every numeric leaf; lists of records are walked as ``key[]``, ``*_status``
    strings and words are skipped, lists of numbers are one leaf."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from leaf_paths(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, list | tuple) and value and all(isinstance(v, dict) for v in value):
        for v in value:
            yield from leaf_paths(v, path + "[]")
    elif isinstance(value, list | tuple):
        if any(is_number(v) for v in flatten(value)):
            yield path, value
    elif is_number(value):
        yield path, value
