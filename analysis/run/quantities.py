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
from collections.abc import Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

from autobal.analysis.run import kinds

#: display unit -> (SI unit, SI value of one display unit): the display units of the one unit vocabulary
#: (:data:`autobal.analysis.run.kinds.TABLE`; a unit is also a display unit of itself, spelled as engineers write it:
#: see :func:`spelled`)
DISPLAY_UNITS = {u: (k.si, f) for k in kinds.TABLE for u, f in k.display.items()}

#: SI unit -> the display unit used when a declaration names none (the field's habits: MPa, mm, L/s, kN)
DEFAULT_DISPLAY = {k.si: k.default for k in kinds.TABLE if k.default}

#: kind of quantity a scene (``display:``) or the CLI (``--units``) can choose the display unit of, by its short
#: name -> (its SI unit, what it covers); every quantity whose unit converts to that SI unit is shown in the choice
KINDS = {k.choice: (k.si, k.covers) for k in kinds.TABLE if k.covers}

#: the display units chosen for this run: SI unit -> display unit (see :func:`display_units`)
_CHOSEN: ContextVar[dict[str, str] | None] = ContextVar("autobal_display_units", default=None)


def spelled(unit: str) -> str:
    """A unit as engineers write it: "m^3/s" -> "m³/s", "um" -> "µm", "N*m" -> "N·m"."""
    for a, b in (("um", "µm"), ("^2", "²"), ("^3", "³"), ("*", "·")):
        unit = unit.replace(a, b)
    return unit


def _base(unit: str) -> tuple[str, float]:
    """The SI unit of a unit of results.json or a display unit, and the SI value of one of it ("um" -> m, 1e-6)."""
    return DISPLAY_UNITS.get(spelled(unit), (unit, 1.0))


def _choosable(kind: str) -> kinds.Kind:
    """The :class:`~autobal.analysis.run.kinds.Kind` of a kind of :data:`KINDS` named by its short name or its name
    ("flow", "volume flow"); ValueError naming the kinds to choose units for."""
    k = kinds.BY_NAME.get(kind)
    if k is None or not k.covers:
        raise ValueError(f"'{kind}' is not a kind of quantity; choose units for {', '.join(KINDS)}")
    return k


def units_of_kind(kind: str) -> list[str]:
    """The display units of a kind of :data:`KINDS` (its short name or its name), as engineers write them."""
    return list(_choosable(kind).display)


def unit_of_kind(kind: str, unit: str) -> str:
    """``unit`` as written by a person ("m3/h", "um", "m^3/h", "l/s", "kN/mm", "r/min") spelled as
    :data:`DISPLAY_UNITS` spells it; ValueError naming the kind and the units to write when it is not a display
    unit of ``kind`` (its short name or its name, e.g. "flow" or "volume flow")."""
    k = _choosable(kind)
    text = str(unit).strip()
    text = k.unit_aliases.get(text, text).replace("μ", "µ").replace("**", "^")
    text = re.sub(r"(?<![A-Za-z])u(?=m)", "µ", text)
    text = re.sub(r"\^?([23])", lambda m: "²³"[int(m.group(1)) - 2], text).replace("*", "·")
    text = re.sub(r"(?<![A-Za-z])(m?)l(?=$|/)", r"\1L", text)
    if text not in k.display:
        raise ValueError(f"'{unit}' is not a unit of {kind} ({k.si}): write one of {', '.join(k.display)}")
    return text


def checked_choice(choice: Mapping[str, str] | None) -> dict[str, str]:
    """kind (its short name) -> display unit, each unit spelled as :data:`DISPLAY_UNITS` spells it; ValueError for
    a kind or a unit that is not one (see :func:`unit_of_kind`)."""
    return {_choosable(kind).choice: unit_of_kind(kind, unit) for kind, unit in (choice or {}).items()
            if unit is not None}


def current_choice() -> dict[str, str]:
    """kind -> display unit chosen by the enclosing :func:`display_units` blocks."""
    by_si = _CHOSEN.get() or {}
    return {kind: by_si[si] for kind, (si, _) in KINDS.items() if si in by_si}


@contextmanager
def display_units(choice: Mapping[str, str] | None, under: bool = False):
    """Within the block, quantities of the kinds in ``choice`` (kind -> display unit, e.g. ``{"pressure": "bar",
    "flow": "m³/h"}``) are shown in those units: summaries, report tables, CSV headers and figure axes; the
    others in their declared display units.  results.json stays SI.  ``under``: the choice only fills the
    kinds an enclosing block did not choose (a scene's ``display`` section under the caller's choice)."""
    given = checked_choice(choice)
    given = given | current_choice() if under else current_choice() | given
    token = _CHOSEN.set({KINDS[kind][0]: unit for kind, unit in given.items()})  # checked_choice: short names
    try:
        yield
    finally:
        _CHOSEN.reset(token)


def chosen(kind: str) -> str | None:
    """The display unit chosen for a kind of :data:`KINDS` in this block of :func:`display_units`, or None."""
    return (_CHOSEN.get() or {}).get(_choosable(kind).si)


def display_unit_of(unit: str, declared: str = "") -> str:
    """The unit a value of results.json unit ``unit`` is shown in: the unit chosen for its kind
    (:func:`display_units`), else ``declared``, else the field's default (:data:`DEFAULT_DISPLAY`), else the
    unit itself, engineer-spelled."""
    return (_CHOSEN.get() or {}).get(_base(unit)[0]) or declared or DEFAULT_DISPLAY.get(unit, spelled(unit))


def is_display_unit(shown: str, si: str) -> bool:
    """Whether ``shown`` is a display unit of the results.json unit ``si`` (the unit itself, spelled, is one)."""
    return shown == spelled(si) or shown in DISPLAY_UNITS and DISPLAY_UNITS[shown][0] == _base(si)[0]


def convert(value: float, si: str, shown: str) -> float:
    """A value of results.json unit ``si`` in the display unit ``shown``; ValueError if it is not one of ``si``."""
    if not is_display_unit(shown, si):
        raise ValueError(f"'{shown}' is not a display unit of '{si}'")
    return value if shown == spelled(si) else value * _base(si)[1] / DISPLAY_UNITS[shown][1]


def beside(si: str, shown: str) -> str | None:
    """The unit shown beside a value of ``si`` displayed in ``shown``: rpm beside rad/s and Hz, rad/s beside rpm;
    rpm/s beside rad/s², rad/s² beside rpm/s."""
    base = _base(si)[0]
    if base == "rad/s":
        return "rad/s" if shown == "rpm" else "rpm"
    if base == "rad/s^2":
        return "rad/s²" if shown == "rpm/s" else "rpm/s"
    return None


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


@dataclass(frozen=True, init=False)
class Quantity:
    """One declared number of a results.json block.

    ``Quantity(key, unit, symbol="", description="", display="", source="", headline=False, beside=None)``.

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
    declared : str
        The unit a person reads unless a scene or the CLI chooses another for its kind: the ``display`` given
        (a key of :data:`DISPLAY_UNITS`), else the field's unit of :data:`DEFAULT_DISPLAY`.
    source : str
        Where the value (or its definition) is published: author, year, equation/table/figure.
    headline : bool
        One of the numbers a reader looks at first (the summary, the notebook table).
    beside : str
        A unit shown in brackets after the display unit; default :func:`beside` (rpm beside a speed, rad/s
        beside one shown in rpm), "Hz" beside a vibration frequency.
    """

    key: str
    unit: str
    symbol: str = ""
    description: str = ""
    declared: str = ""
    source: str = ""
    headline: bool = False
    beside: str | None = None

    def __init__(self, key: str, unit: str, symbol: str = "", description: str = "", display: str = "",
                 source: str = "", headline: bool = False, beside: str | None = None, *, declared: str = ""):
        declared = display or declared or DEFAULT_DISPLAY.get(unit, spelled(unit))  # declared: dataclasses.replace
        if not is_display_unit(declared, unit):
            raise ValueError(f"{key}: display unit '{declared}' is not a unit of '{unit}'")
        for name, value in (("key", key), ("unit", unit), ("symbol", symbol), ("description", description),
                            ("declared", declared), ("source", source), ("headline", headline), ("beside", beside)):
            object.__setattr__(self, name, value)

    @property
    def keys(self) -> list[str]:
        return self.key.split()

    @property
    def display(self) -> str:
        """The unit the value is shown in now: the one chosen for its kind (:func:`display_units`), else
        :attr:`declared`.  Label a number with it and convert with :meth:`shown` (or write :meth:`text`)."""
        return display_unit_of(self.unit, self.declared)

    def shown(self, value) -> float | None:
        """``value`` (SI) in :attr:`display`."""
        return None if value is None else convert(value, self.unit, self.display)

    def text(self, value, digits: int = 4) -> str:
        """'value unit' in :attr:`display`, speeds with rpm (or rad/s) beside, or the declared :attr:`beside`:
        '143.9 µm', '1977 rad/s (18880 rpm)'."""
        unit = self.display
        out = significant(None if value is None else convert(value, self.unit, unit), digits)
        out += "" if unit == "1" else f" {unit}"
        also = self.also(value, digits)
        return f"{out} ({also})" if also else out

    def also(self, value, digits: int = 4) -> str:
        """'value unit' in the unit shown beside :attr:`display` (rpm beside rad/s, or the declared
        :attr:`beside`), or "" where there is none: '18880 rpm'."""
        unit = self.display
        other = beside(self.unit, unit) if self.beside is None else self.beside
        if not other or other == unit or value is None:
            return ""
        return f"{significant(convert(value, self.unit, other), digits)} {other}"


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
        """(declaration, key, value) of the headline quantities ``block`` holds, in declaration order (a key
        through a list of records, ``peaks[].omega``, gives each item's: ``peaks.0.omega``, ``peaks.1.omega``)."""
        out = []
        for q in self.quantities:
            for k in q.keys if q.headline else ():
                for key, v in _items(block, k):
                    if v is not MISSING and (v is None or is_number(v)):
                        out.append((q, key, v))
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


def _items(block, key: str):
    """(concrete key, value) of a declared key in ``block``, a list of records (``[]``) walked item by item."""
    if "[]" not in key:
        yield key, lookup(block, key)
        return
    head, rest = key.split("[]", 1)
    for i, item in enumerate(lookup(block, head, None) or []):
        for k, v in _items(item, rest.removeprefix(".")):
            yield f"{head}.{i}.{k}", v


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
