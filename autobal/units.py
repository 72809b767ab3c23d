"""Physical quantities written as users write them ("32.3 MPa", "0.35 mm", "6300 rpm"), converted to
SI floats at load time.

A quantity is read as a plain decimal number followed by a unit; only the unit is given to pint, and
only after a strict grammar has accepted it (unit names joined by ``*``, ``/``, a space, and integer
powers ``^n`` or ``**n``), so no text is ever evaluated as an arithmetic expression.  Values that are
not finite, or that leave the physical range of their kind (:data:`DIMENSIONS`, from the one unit vocabulary of
:mod:`autobal.analysis.run.kinds` that the display reads too), are refused.
The plain SI-prefixed units (``mm``, ``MPa``, ``kg/m^3``, ...) are read from a small table; pint's
registry is built on first use of any other unit, or to explain an error.  A quantity is at most
:data:`MAX_CHARS` characters, so that reading it takes linear time.

Rotational quantities follow ISO 80000-3: a speed written as a rotational frequency n (``Hz``, ``rps``,
``rpm``, ``r/min``, or ``1/min`` as datasheets write rpm, DIN 1301-2) is the angular speed omega = 2 pi n;
``Hz/s`` and ``rpm/s`` are angular accelerations likewise; ``rad/s`` and ``deg/s`` are read as written.
A bare ``1/s`` on an angular field is refused: physicists write omega in 1/s meaning rad/s, engineers
write n in 1/s meaning r/s.  Prefixed hertz (``kHz``) is a rotational frequency as well.  These
fields are read by :func:`_angular`, never by pint, which reads Hz as 1/s.
"""

from __future__ import annotations

import math
import re
from functools import cache
from typing import Annotated

from pydantic import AfterValidator, BeforeValidator, Field

from autobal.analysis.run.kinds import TABLE

# name -> (pint dimensionality, SI unit used inside the toolkit, example, (smallest positive, largest) in SI): the
# kinds of the one unit vocabulary (autobal/analysis/run/kinds.py), which the display reads too
DIMENSIONS = {k.name: (k.dimension, k.written, k.example, k.magnitude) for k in TABLE}

MAX_CHARS = 100  # a quantity as written, spaces at its ends stripped: "6300 rpm" is 8
_NUMBER = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d{1,3})?"
_NAME = r"(?:[A-Za-zµμΩ°%][A-Za-z_µμΩ°%]*)"
_FACTOR = rf"(?:{_NAME}(?: *(?:\^|\*\*) *-?\d)?)"
# unit := ["1" "/"] factor { ("*" | "/" | " ") factor }: names with single-digit integer powers, nothing else;
# only plain spaces, and no two ways to read a run of them (linear time)
_UNIT = re.compile(rf"(?:1 */ *)?{_FACTOR}(?:(?: *(?:\*(?!\*)|/) *| +){_FACTOR})*")
# applied to the stripped text: the number, then the unit (everything after it, newlines included)
_QUANTITY = re.compile(rf"({_NUMBER})\s*(.*)", re.DOTALL)


# The plain SI-prefixed units read without pint (pint's import and registry take about 0.3 s of CPU, a
# tenth of a statics run): name -> (SI factor, exponents of (mass, length, time)), with the names that
# take an SI prefix. The same factors as pint's registry (tests/test_units_table.py checks every entry).
_TABLE = {"m": (1.0, (0, 1, 0)), "g": (1e-3, (1, 0, 0)), "s": (1.0, (0, 0, 1)), "Pa": (1.0, (1, -1, -2)),
          "bar": (1e5, (1, -1, -2)), "N": (1.0, (1, 1, -2)), "J": (1.0, (1, 2, -2)), "W": (1.0, (1, 2, -3)),
          "L": (1e-3, (0, 3, 0)), "l": (1e-3, (0, 3, 0)), "min": (60.0, (0, 0, 1)), "h": (3600.0, (0, 0, 1))}
_PREFIXED = ("m", "g", "s", "Pa", "bar", "N", "J", "W", "L", "l")
_PREFIXES = {"T": 1e12, "G": 1e9, "M": 1e6, "k": 1e3, "h": 1e2, "da": 1e1, "d": 1e-1, "c": 1e-2, "m": 1e-3,
             "u": 1e-6, "µ": 1e-6, "μ": 1e-6, "n": 1e-9, "p": 1e-12}


def _name(name: str) -> tuple[float, tuple[int, int, int]] | None:
    """SI factor and dimension of one unit name from :data:`_TABLE`, or None (unknown or ambiguous)."""
    if name in _TABLE:
        return _TABLE[name]
    if name == "hbar":  # pint's reduced Planck constant, not a hectobar
        return None
    found = [(f * _TABLE[name[len(p):]][0], _TABLE[name[len(p):]][1]) for p, f in _PREFIXES.items()
             if name.startswith(p) and name[len(p):] in _PREFIXED]
    return found[0] if len(found) == 1 else None


def _a(kind: str) -> str:
    """``kind`` with its indefinite article: "a length", "an angular speed"."""
    return f"{'an' if kind[0] in 'aeiou' else 'a'} {kind}"


def clip(text: str, width: int = 40) -> str:
    """``text`` for a one-line message: control characters escaped (a newline as \\n), cut to its first
    30 characters and its length if longer than ``width``."""
    one = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text[:width + 1])
    return one if len(text) <= width else f"{one[:30]}... ({len(text)} characters)"


def _shown(text: str) -> str:
    return f"'{clip(text)}'"


@cache
def _powers(text: str) -> tuple[tuple[str, int], ...] | None:
    """The names of a unit accepted by :data:`_UNIT` with their integer powers, read left to right as
    pint reads them ("1/min/s" -> (("min", -1), ("s", -1))); None if a space joins two names (pint reads it)."""
    s = re.sub(r" *(\^|\*\*|\*|/) *", lambda m: "^" if m.group(1) == "**" else m.group(1), text.strip())
    if " " in s:
        return None
    sign, out = 1, []
    if s.startswith("1/"):
        s, sign = s[2:], -1
    for op, item in re.findall(r"([*/]?)([^*/]+)", s):
        name, _, power = item.partition("^")
        out.append((name, (int(power) if power else 1) * (-1 if op == "/" else 1) * (sign if not op else 1)))
    return tuple(out)


@cache
def _table_unit(text: str) -> tuple[float, tuple[int, int, int]] | None:
    """SI factor and dimension of a unit made of :data:`_TABLE` names joined by ``*``, ``/`` and integer
    powers (read left to right, as pint reads them), or None: then pint reads it."""
    powers = _powers(text)
    if powers is None:
        return None
    factor, dims = 1.0, (0, 0, 0)
    for name, n in powers:
        unit = _name(name)
        if unit is None:
            return None
        factor *= unit[0] ** n
        dims = tuple(d + n * e for d, e in zip(dims, unit[1], strict=True))
    return factor, dims


def _fast(unit: str, kind: str) -> float | None:
    """The factor from ``unit`` to the SI unit of ``kind`` read from :data:`_TABLE`; None where the table
    does not know ``unit`` or its dimension is not that of ``kind`` (pint then reads it and explains), and
    for the angular kinds (read by :func:`_angular`)."""
    text = unit.strip()
    if kind in ANGULAR or len(text) > 64 or not _UNIT.fullmatch(text):
        return None
    mine, si = _table_unit(text), _table_unit(DIMENSIONS[kind][1])
    return mine[0] / si[0] if mine is not None and mine[1] == si[1] else None


# ---- rotational quantities (ISO 80000-3): omega = 2 pi n ------------------------------------------------
TURN = 2 * math.pi  # rad in one revolution
# angular kind -> the power k of its SI unit rad/s^k
ANGULAR = {"angular speed": 1, "angular acceleration": 2, "angular jerk": 3}
# angles in rad, and rotational frequencies n in rad/s (one revolution per unit time is 2 pi rad), with the
# long names pint writes (the unit of a pint Quantity given to autobal.load(set=...)) and its time units
_ANGLES = {"rad": 1.0, "deg": math.pi / 180, "°": math.pi / 180, "r": TURN, "rev": TURN, "turn": TURN,
           "radian": 1.0, "degree": math.pi / 180, "revolution": TURN}
_ROTATIONAL_FREQUENCIES = {"Hz": TURN, "rps": TURN, "rpm": TURN / 60, "hertz": TURN,
                           "revolutions_per_second": TURN, "revolutions_per_minute": TURN / 60}
_LONG_TIMES = {"second": 1.0, "millisecond": 1e-3, "minute": 60.0, "hour": 3600.0}
_ROTATIONAL_NAMES = {*_ANGLES, *_ROTATIONAL_FREQUENCIES, "cycle"}  # refused on a rate in 1/s
_WRITE = {1: "rad/s, deg/s, or a rotational frequency n in Hz, rps, rpm, r/min or 1/min (omega = 2 pi n)",
          2: "rad/s^2, deg/s^2, or Hz/s, rpm/s (2 pi times the rate of change of n)",
          3: "rad/s^3, deg/s^3, or Hz/s^2, rpm/s^2 (2 pi times the second derivative of n)"}


def _rotation(name: str) -> tuple[float, int] | None:
    """rad per unit and the power of 1/s of an angle or rotational frequency (kHz, mrad with an SI
    prefix), or None."""
    if name in _ANGLES:
        return _ANGLES[name], 0
    if name in _ROTATIONAL_FREQUENCIES:
        return _ROTATIONAL_FREQUENCIES[name], -1
    for p, f in _PREFIXES.items():
        if name.startswith(p) and name[len(p):] in ("Hz", "rad"):
            return (f * TURN, -1) if name.endswith("Hz") else (f, 0)
    return None


@cache
def _angular(unit: str, kind: str) -> float:
    """The factor from ``unit`` to rad/s^k of the angular ``kind`` (:data:`ANGULAR`); ValueError naming
    the units to write.  An angle (rad, deg, r) over a time, or a rotational frequency n (Hz, rps, rpm,
    min^-1) over a time; a unit of 1/time alone (1/s) is refused as ambiguous."""
    k = ANGULAR[kind]
    text = unit.strip()
    powers = _powers(text) if len(text) <= 64 and _UNIT.fullmatch(text) else None
    if powers is None:
        raise ValueError(f"{_shown(text)} is not a unit of {_a(kind)}: write {_WRITE[k]}")
    factor, angle, time, per_minute = 1.0, 0, 0, False
    for name, n in powers:
        rotation, plain = _rotation(name), (_LONG_TIMES[name], (0, 0, 1)) if name in _LONG_TIMES else _name(name)
        if rotation is not None:
            factor, angle, time = factor * rotation[0] ** n, angle + n, time + rotation[1] * n
        elif plain is not None and plain[1] == (0, 0, 1):
            factor, time = factor * plain[0] ** n, time + n
            per_minute = per_minute or (name in ("min", "minute") and n == -1)
        else:
            raise ValueError(f"{name!r} is not a unit of {_a(kind)}: write {_WRITE[k]}")
    if angle == 0 and per_minute:  # min^-1 is rpm as datasheets write it (DIN 1301-2): revolutions per minute
        factor, angle = factor * TURN, 1
    if (angle, time) == (0, -k):
        si, hz = ("rad/s", "Hz") if k == 1 else (f"rad/s^{k}", "Hz/s" if k == 2 else f"Hz/s^{k - 1}")
        raise ValueError(f"{text!r} is ambiguous for {_a(kind)}: write {si} (radians) or {hz} (revolutions, "
                         f"omega = 2 pi n)")
    if (angle, time) != (1, -k):
        raise ValueError(f"{text!r} is not a unit of {_a(kind)}: write {_WRITE[k]}")
    return factor


def angular_text(value, kind: str) -> str:
    """An angular ``value`` in SI (a number, or a list of them) as a person reads it: in rad/s and rpm
    (rad/s^2 and rpm/s, rad/s^3 and rpm/s^2), e.g. ``"659.73 rad/s (6300 rpm)"``."""
    k = ANGULAR[kind]
    si, rpm = ("rad/s", "rpm") if k == 1 else (f"rad/s^{k}", "rpm/s" if k == 2 else f"rpm/s^{k - 1}")

    def shown(v, scale):
        return f"[{', '.join(shown(x, scale) for x in v)}]" if isinstance(v, list | tuple) else f"{v * scale:.5g}"

    return f"{shown(value, 1.0)} {si} ({shown(value, 60 / TURN)} {rpm})"


def _refuse_rotational(unit: str, kind: str) -> None:
    """Refuse an angle or a rotational frequency on a field of 1/time that is not an angular kind (a rate):
    pint would read Hz and rpm there as 1/s and 2 pi/60 1/s."""
    if DIMENSIONS[kind][0].startswith("1 / [time]"):
        for name in re.findall(_NAME, unit):
            if name in _ROTATIONAL_NAMES or _rotation(name) is not None:
                raise ValueError(f"{name!r} is a rotational unit, not one of {_a(kind)}: write "
                                 f"{DIMENSIONS[kind][1]}, e.g. '{DIMENSIONS[kind][2]}'")


@cache
def registry():
    """The pint unit registry, built on first use (about 0.5 s)."""
    import pint

    return pint.UnitRegistry()


def parse_unit(text: str):
    """The pint unit of ``text`` after a strict check of its grammar; ValueError if it is not a unit.

    Parameters
    ----------
    text : str
        A unit such as ``"m^3/s"``, ``"N*s/m"``, ``"1/s"`` or ``"kg*m**2"``.

    Returns
    -------
    pint.Unit
    """
    text = text.strip()
    if len(text) > 64 or not _UNIT.fullmatch(text):
        raise ValueError(f"{_shown(text)} is not a unit (names joined by *, / and integer powers ^n)")
    try:
        return registry().parse_units(text)
    except Exception:  # pint raises several unrelated types on unknown names
        raise ValueError(f"{text!r} is not a known unit") from None


def unit_factor(unit: str, kind: str) -> float:
    """The factor that converts ``unit`` to the SI unit of ``kind``; ValueError on a wrong dimension.

    Parameters
    ----------
    unit : str
        A unit, e.g. ``"mm"``.
    kind : str
        A key of :data:`DIMENSIONS`.

    Returns
    -------
    float
        SI value of one ``unit``, e.g. 0.001 for ``"mm"`` as a length, 2 pi for ``"Hz"`` as an angular speed.
    """
    dim, si, example, _ = DIMENSIONS[kind]
    if kind in ANGULAR:
        return _angular(unit, kind)
    _refuse_rotational(unit, kind)
    fast = _fast(unit, kind)
    if fast is not None:
        return fast
    u = parse_unit(unit)
    ureg = registry()
    if u.dimensionality != ureg.get_dimensionality(dim):
        raise ValueError(f"{unit!r} is not {_a(kind)} unit (e.g. '{example.split()[-1]}', SI {si}), "
                         f"its dimension is {u.dimensionality}")
    return float(ureg.Quantity(1.0, u).to(si).magnitude)


def to_si(value: object, kind: str) -> float:
    """Convert ``value`` (a string: a number and a unit) to a float in the SI unit of ``kind``.

    Parameters
    ----------
    value : str
        E.g. ``"32.3 MPa"``; a plain number without a unit is refused, and so is a text longer than
        :data:`MAX_CHARS` characters (spaces at its ends stripped).
    kind : str
        A key of :data:`DIMENSIONS`.

    Returns
    -------
    float
        The value in the SI unit of ``kind``; finite.
    """
    dim, si, example, _ = DIMENSIONS[kind]
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise ValueError(f"expected {_a(kind)} with a unit, e.g. '{example}'")
    if not isinstance(value, str):
        raise ValueError(f"{value!r} has no unit: write {_a(kind)} with its unit, e.g. '{example}'")
    text = value.strip()
    if len(text) > MAX_CHARS:
        raise ValueError(f"{_shown(text)}: {_a(kind)} is a number and a unit of at most {MAX_CHARS} characters, "
                         f"e.g. '{example}'")
    m = _QUANTITY.fullmatch(text)
    if m is None:
        word = text.split(" ")[0].lower().lstrip("+-.")
        if word in ("inf", "infinity", "nan"):
            raise ValueError(f"{_shown(text)}: {_a(kind)} must be a finite number (e.g. '{example}')")
        raise ValueError(f"cannot read {_shown(text)} as a number and a unit ({_a(kind)}, e.g. '{example}')")
    number, unit = float(m.group(1)), m.group(2)
    if not unit:
        raise ValueError(f"{_shown(text)} has no unit: write {_a(kind)} with its unit, e.g. '{example}'")
    try:
        factor = _angular(unit, kind) if kind in ANGULAR else _refuse_rotational(unit, kind)
    except ValueError as exc:
        raise ValueError(f"{_shown(text)}: {exc}") from None
    if factor is not None:
        return _finite(text, kind, number, number * factor)
    fast = _fast(unit, kind)
    if fast is not None:
        return _finite(text, kind, number, number * fast)
    try:
        u = parse_unit(unit)
    except ValueError as exc:
        raise ValueError(f"{_shown(text)}: {exc}") from None
    if u.dimensionality != registry().get_dimensionality(dim):
        raise ValueError(f"{_shown(text)} is not {_a(kind)}: expected a unit like '{example}' (SI: {si}), "
                         f"got dimension {u.dimensionality}")
    return _finite(text, kind, number, number * unit_factor(unit, kind))


def _finite(value: str, kind: str, number: float, si_value: float) -> float:
    if not math.isfinite(number) or not math.isfinite(si_value):
        raise ValueError(f"{_shown(value)}: {_a(kind)} must be a finite number (it overflows in "
                         f"{DIMENSIONS[kind][1]})")
    return si_value


def _bounded(kind: str, sign: str):
    lo, hi = DIMENSIONS[kind][3]
    si = DIMENSIONS[kind][1]

    def check(x: float) -> float:
        if sign == "positive" and not x > 0:
            raise ValueError(f"must be positive, got {x:g} {si}")
        if sign == "nonnegative" and not x >= 0:
            raise ValueError(f"must not be negative, got {x:g} {si}")
        if x != 0 and not lo <= abs(x) <= hi:
            raise ValueError(f"{x:g} {si} is outside the physical range of {_a(kind)} ({lo:g} to {hi:g} {si})")
        return x

    return check


def quantity(kind: str, sign: str = "positive"):
    """An annotated float field holding a ``kind`` quantity in SI, checked for ``sign`` and the
    physical range of :data:`DIMENSIONS`; its unit and range are added to the field's description
    (:class:`autobal.schema.Strict`).

    Parameters
    ----------
    kind : str
        A key of :data:`DIMENSIONS`.
    sign : {"positive", "nonnegative"}
        Zero allowed or not.
    """
    dim, si, example, (lo, hi) = DIMENSIONS[kind]
    zero = ">= 0" if sign == "nonnegative" else "> 0"
    text = f"{_a(kind)} with its unit, e.g. '{example}' (SI: {si}); {zero}, magnitude {lo:g} to {hi:g} {si}"
    if kind in ANGULAR:
        text += "; a rotational frequency n (Hz, rpm, 1/min) is omega = 2 pi n, 1/s is refused as ambiguous"
    return Annotated[float, BeforeValidator(lambda v: to_si(v, kind)), AfterValidator(_bounded(kind, sign)),
                     Field(json_schema_extra={"unit": si, "kind": kind, "unit_text": text})]


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
Mass = quantity("mass")
Stiffness = quantity("stiffness")
Volume = quantity("volume")
Time = quantity("time")
TimeOrZero = quantity("time", "nonnegative")
AngularAcceleration = quantity("angular acceleration")
SpeedOrZero = quantity("angular speed", "nonnegative")
DampingOrZero = quantity("damping", "nonnegative")
Inertia = quantity("moment of inertia")
LengthOrZero = quantity("length", "nonnegative")


def si_unit_of(text: object) -> str:
    """The SI unit of a value written with a unit ('0.35 mm' -> 'm'), read by the same strict grammar;
    '' if it is not a number with a unit of one of the :data:`DIMENSIONS`.

    Parameters
    ----------
    text : object
        A scene value as written.

    Returns
    -------
    str
    """
    text = text.strip() if isinstance(text, str) else ""
    m = _QUANTITY.fullmatch(text) if len(text) <= MAX_CHARS else None
    if m is None or not m.group(2):
        return ""
    for kind, (_, si, _, _) in DIMENSIONS.items():
        if kind in ANGULAR:
            try:
                _angular(m.group(2), kind)
                return si
            except ValueError:
                continue
        if _fast(m.group(2), kind) is not None:
            return si
    try:
        u = parse_unit(m.group(2))
    except ValueError:
        return ""
    ureg = registry()
    for kind, (dim, si, _, _) in DIMENSIONS.items():
        if kind not in ANGULAR and u.dimensionality == ureg.get_dimensionality(dim):
            return si
    return ""
