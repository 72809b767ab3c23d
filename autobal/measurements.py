"""Measured rig data: CSV files whose header names each column's quantity and unit.

A header cell is ``quantity [unit]``: ``tau [1]``, ``axial_force [kN]``, ``u [1]``, ``gap [mm]``,
``q [1]``, ``flow [L/min]``, ``group [1]``.  Lines starting with ``#`` are comments (the file's
provenance).  Dimensional columns are converted to SI on reading and made dimensionless with the
base values of the scene (p_B, s_B, z_B, Q_B), as the source does (Pavlenko 2014, (1.17)-(1.21),
(4.29)).  Every problem is a :class:`autobal.errors.ScenarioError` with one line naming the file,
the line or column and the expected unit.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from autobal.errors import ScenarioError
from autobal.paths import SCENARIO_DIR
from autobal.units import DIMENSIONS, unit_factor

# quantity name -> (role, unit kind or None when dimensionless, meaning)
QUANTITIES = {
    "tau": ("load", None, "axial force over p_B s_B (source's tau; Table 4.3's generalised load)"),
    "axial_force": ("load", "force", "axial force T"),
    "psi1": ("load", None, "discharge pressure over p_B"),
    "discharge_pressure": ("load", "pressure", "discharge pressure p1"),
    "u": ("gap", None, "face gap over its base value z_B"),
    "gap": ("gap", "length", "face gap z"),
    "q": ("flow", None, "leak flow over its base value"),
    "flow": ("flow", "volume flow", "leak flow Q"),
    "group": ("group", None, "label of a group of repeated measurements (integer)"),
    "point": ("label", None, "point number (not used)"),
}
DIMENSIONLESS = ("1", "-", "")
_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[([^\]]*)\]\s*$")
# base value needed to make a dimensional column dimensionless: quantity -> base key
BASE_OF = {"axial_force": "force", "discharge_pressure": "pressure", "gap": "gap", "flow": "flow"}


@dataclass
class Measurements:
    """Columns of a data file: values in SI (dimensional columns) or dimensionless, by quantity."""

    path: Path
    columns: dict  # quantity -> np.ndarray
    units: dict  # quantity -> unit as written
    comments: list[str] = field(default_factory=list)

    @property
    def points(self) -> int:
        return len(next(iter(self.columns.values())))

    def has(self, role: str) -> str | None:
        """The quantity holding ``role`` (load, gap, flow, group), or None."""
        return next((k for k in self.columns if QUANTITIES[k][0] == role), None)

    def dimensionless(self, role: str, bases: dict) -> np.ndarray:
        """Column of ``role`` made dimensionless: a dimensional column over ``bases[key]`` (SI)."""
        name = self.has(role)
        if name is None:
            raise ScenarioError(f"{self.path}: no {role} column")
        values = self.columns[name]
        if name not in BASE_OF:
            return values
        key = BASE_OF[name]
        if not bases.get(key):
            raise ScenarioError(f"{self.path}: column '{name} [{self.units[name]}]' is dimensional: give the base "
                                f"value analyses.estimation.bases.{key} (or use '{_twin(name)} [1]')")
        return values / bases[key]


def _twin(name: str) -> str:
    role = QUANTITIES[name][0]
    return next(k for k, v in QUANTITIES.items() if v[0] == role and v[1] is None)


def _unit_factor(path: Path, name: str, unit: str) -> float:
    """SI factor of ``unit`` for quantity ``name``; refuses a unit of the wrong dimension."""
    kind = QUANTITIES[name][1]
    cell = f"'{name} [{unit}]'"
    if kind is None:
        if unit.strip() in DIMENSIONLESS:
            return 1.0
        role = QUANTITIES[name][0]
        dimensional = next((k for k, v in QUANTITIES.items() if v[0] == role and v[1] is not None), None)
        hint = f", or '{dimensional} [{DIMENSIONS[QUANTITIES[dimensional][1]][1]}]'" if dimensional else ""
        raise ScenarioError(f"{path}: column {cell}: {name} is dimensionless: write '{name} [1]'{hint}")
    try:
        return unit_factor(unit, kind)
    except ValueError as exc:
        raise ScenarioError(f"{path}: column {cell}: {exc} (a {kind})") from None


def resolve(path: str | Path) -> Path:
    """A data path as written in a scene: absolute, relative to the working folder, or relative
    to the shipped ``scenarios/`` folder."""
    p = Path(path)
    for candidate in (p, SCENARIO_DIR / p):
        if candidate.is_file():
            return candidate
    raise ScenarioError(f"{path}: no such data file (relative paths are tried from the working folder "
                        f"and from {SCENARIO_DIR})")


def read_csv(path: str | Path) -> Measurements:
    """Read and check a measured-data CSV; values converted to SI (or dimensionless)."""
    path = resolve(path)
    comments, rows = [], []
    with path.open(newline="") as fh:
        for lineno, line in enumerate(fh, start=1):
            if line.lstrip().startswith("#"):
                comments.append(line.strip().lstrip("#").strip())
            elif line.strip():
                rows.append((lineno, next(csv.reader([line]))))
    if not rows:
        raise ScenarioError(f"{path}: no header row (expected e.g. 'tau [1],u [1]')")
    (head_line, header), body = rows[0], rows[1:]
    names, units, factors = [], {}, []
    for j, cell in enumerate(header):
        m = _HEADER.match(cell)
        if m is None:
            raise ScenarioError(f"{path}: line {head_line}, column {j + 1}: header {cell.strip()!r} must read "
                                f"'quantity [unit]', e.g. 'u [1]' or 'gap [mm]'")
        name, unit = m.group(1), m.group(2).strip()
        if name not in QUANTITIES:
            raise ScenarioError(f"{path}: column {j + 1}: unknown quantity {name!r}; expected one of "
                                f"{', '.join(QUANTITIES)}")
        if name in units:
            raise ScenarioError(f"{path}: column {name!r} appears twice")
        factors.append(_unit_factor(path, name, unit))
        names.append(name)
        units[name] = unit
    for role in ("load", "gap", "flow", "group"):
        same = [n for n in names if QUANTITIES[n][0] == role]
        if len(same) > 1:
            raise ScenarioError(f"{path}: columns {' and '.join(repr(n) for n in same)} both give the {role}; "
                                f"keep one")
    if not any(QUANTITIES[n][0] == "load" for n in names):
        raise ScenarioError(f"{path}: no load column; add one of 'tau [1]', 'axial_force [kN]', 'psi1 [1]', "
                            f"'discharge_pressure [MPa]'")
    if not body:
        raise ScenarioError(f"{path}: no data rows")
    values = np.empty((len(body), len(names)))
    for i, (lineno, row) in enumerate(body):
        if len(row) != len(names):
            raise ScenarioError(f"{path}: line {lineno}: {len(row)} values, the header has {len(names)}")
        for j, (cell, name) in enumerate(zip(row, names, strict=True)):
            where = f"{path}: line {lineno}, column '{name} [{units[name]}]'"
            try:
                v = float(cell)
            except ValueError:
                raise ScenarioError(f"{where}: {cell.strip()!r} is not a number") from None
            if not math.isfinite(v):
                raise ScenarioError(f"{where}: {cell.strip()!r} is not a finite number")
            role = QUANTITIES[name][0]
            if role == "load" and not v > 0:
                raise ScenarioError(f"{where}: a load must be positive, got {v:g}")
            if role in ("gap", "flow") and v < 0:
                raise ScenarioError(f"{where}: a measured {role} must not be negative, got {v:g}")
            if role == "group" and v != int(v):
                raise ScenarioError(f"{where}: a group label is an integer, got {v:g}")
            values[i, j] = v * factors[j]
    return Measurements(path=path, columns={n: values[:, j] for j, n in enumerate(names)}, units=units,
                        comments=comments)


def check_fit(data: Measurements, residual: str, free: int, where: str) -> None:
    """Refuse data that cannot carry a fit: the measured column(s) of ``residual`` ("u", "q",
    "both") missing, or no more residuals than ``free`` parameters (one degree of freedom is
    needed for the residual variance and the confidence intervals)."""
    need = {"u": ["gap"], "q": ["flow"], "both": ["gap", "flow"]}[residual]
    for role in need:
        if data.has(role) is None:
            cols = {"gap": "'u [1]' or 'gap [mm]'", "flow": "'q [1]' or 'flow [L/min]'"}[role]
            raise ScenarioError(f"{where}: residual '{residual}' needs a measured {role} column ({cols}) "
                                f"in {data.path.name}")
    n = data.points * len(need)
    if n <= free:
        raise ScenarioError(f"{where}: {n} measured values for {free} free parameter(s); a fit needs at least "
                            f"{free + 1} (one degree of freedom for the uncertainty)")
