"""Measured rig data: CSV files whose header names each column's quantity and unit.

A header cell is ``quantity [unit]``: ``tau [1]``, ``axial_force [kN]``, ``u [1]``, ``gap [mm]``,
``q [1]``, ``flow [L/min]``, ``group [1]``.  Lines starting with ``#`` are comments (the file's
provenance).  Spreadsheet exports are read as written: UTF-8 with a byte-order mark, ';' as the
separator with decimal commas, and extra columns when the scene names the columns to take by their
headers (``analyses.estimation.columns``).  Dimensional columns are converted to SI on reading and
made dimensionless with the base values of the scene (p_B, s_B, z_B, Q_B), as the source does
(Pavlenko 2014, (1.17)-(1.21), (4.29)).  Every problem is a :class:`autobal.errors.ScenarioError`
with one line naming the file, the line or column and the expected unit.
"""

from __future__ import annotations

import csv
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from autobal.errors import ScenarioError
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
_UNIT_AT_END = re.compile(r"(?:\[([^\]]*)\]|\(([^)]*)\))\s*$")  # 'name [unit]' or 'name (unit)'
MAX_DATA_BYTES = 20_000_000  # a data file is a text of at most 20 MB
MAX_POINTS = 100_000  # data rows of one file
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


def resolve(path: str | Path, folder: Path | None = None) -> Path:
    """A data path as written in a scene: absolute, or relative to ``folder`` (the scene file's
    folder; the working folder when None).  Only a readable regular file of at most
    :data:`MAX_DATA_BYTES` is taken: a folder, device, FIFO, socket or system file (/proc, /sys,
    /dev) is refused with one line."""
    p = Path(path)
    if not p.is_absolute():
        p = (folder if folder is not None else Path.cwd()) / p
    where = f"relative paths are read from {folder}" if folder is not None else \
        "relative paths are read from the working folder"
    try:
        st = p.stat()
        real = p.resolve()
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such data file ({where})") from None
    except (OSError, RuntimeError) as exc:
        raise ScenarioError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise ScenarioError(f"{path}: is a folder, not a data file")
    if not stat.S_ISREG(st.st_mode):
        raise ScenarioError(f"{path}: not a regular file (a device, FIFO or socket); name a CSV file")
    if real.parts[:2] in (("/", "proc"), ("/", "sys"), ("/", "dev")):
        raise ScenarioError(f"{path}: a system file ({real.parts[1]}), not a data file; name a CSV file")
    if st.st_size > MAX_DATA_BYTES:
        raise ScenarioError(f"{path}: {st.st_size} bytes: a data file is a CSV text of at most {MAX_DATA_BYTES} bytes")
    return p


def _text(path: Path) -> str:
    """The file's text: UTF-8 with or without a byte-order mark (spreadsheets write one)."""
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_DATA_BYTES + 1)
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_DATA_BYTES:
        raise ScenarioError(f"{path}: more than {MAX_DATA_BYTES} bytes: a data file is a CSV text of at most "
                            f"{MAX_DATA_BYTES} bytes")
    if b"\0" in raw[:8192]:
        raise ScenarioError(f"{path}: a binary file, not a CSV text")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); save it "
                            f"as 'CSV UTF-8'") from None


def _delimiter(header: str) -> str:
    """The separator of a file, from its header line: ';' (spreadsheets in locales with decimal
    commas), else a tab, else ','."""
    return ";" if ";" in header else "\t" if "\t" in header else ","


def _short(cell: str) -> str:
    cell = cell.strip()
    return repr(cell if len(cell) <= 40 else cell[:40] + "...")


def _header_unit(cell: str) -> str:
    """The unit a free-form header carries at its end, ``name [unit]`` or ``name (unit)``; '1' when none."""
    m = _UNIT_AT_END.search(cell)
    return (m.group(1) if m.group(1) is not None else m.group(2)).strip() if m else "1"


def _select(path: Path, head_line: int, header: list[str], columns: dict | None,
            where: str = "analyses.estimation.columns", example: str = "tau [1],u [1]") -> list[tuple[int, str, str]]:
    """(column index, quantity, unit as written) of the columns to read.  Without ``columns`` every
    header cell must read 'quantity [unit]'; with it, the named headers are taken and others skipped.
    ``where`` is the scene key of ``columns`` and ``example`` a header line, both for the messages."""
    if not any(_HEADER.match(c) or _UNIT_AT_END.search(c) for c in header):
        # not the expected table (a system file, a text): its content is not quoted
        raise ScenarioError(f"{path}: not a data table: line {head_line} is no header of 'quantity [unit]' cells "
                            f"(e.g. '{example}'); name a CSV file of measurements")
    if columns is None:
        out = []
        for j, cell in enumerate(header):
            m = _HEADER.match(cell)
            if m is None:
                raise ScenarioError(f"{path}: line {head_line}, column {j + 1}: header {_short(cell)} must read "
                                    f"'quantity [unit]', e.g. 'u [1]' or 'gap [mm]' (or name the columns to read "
                                    f"in {where})")
            out.append((j, m.group(1), m.group(2).strip()))
        return out
    norm = [" ".join(c.split()).casefold() for c in header]
    out = []
    for name, head in columns.items():
        key = " ".join(head.split()).casefold()
        if norm.count(key) != 1:
            what = "no column" if key not in norm else "two columns"
            raise ScenarioError(f"{path}: {what} headed {head!r} ({where}.{name}); the headers "
                                f"are {', '.join(_short(c) for c in header)}")
        out.append((norm.index(key), name, _header_unit(head)))
    return out


def read_csv(path: str | Path, columns: dict | None = None, folder: Path | None = None) -> Measurements:
    """Read and check a measured-data CSV; values converted to SI (or dimensionless).

    Parameters
    ----------
    path : str or Path
        The file: absolute, or relative to ``folder``.
    columns : dict, optional
        Quantity -> header of its column (other columns are skipped); the unit is the header's
        trailing ``[unit]`` or ``(unit)``.  Default: every header cell reads ``quantity [unit]``.
    folder : Path, optional
        Folder of relative paths (the scene file's folder); default the working folder.

    The text is UTF-8 (a byte-order mark is dropped); the separator is ',' or, when the header
    holds one, ';' or a tab (then a decimal comma is read as a decimal point).
    """
    table = read_table(path, columns, folder)
    path = table.path
    names, units, factors = [], {}, []
    for j, name, unit in table.selected:
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
    table.check_rows(MAX_POINTS)
    values = np.empty((len(table.body), len(names)))
    for k, (j, name, _) in enumerate(table.selected):
        values[:, k] = table.numbers(j, f"{name} [{units[name]}]", QUANTITIES[name][0]) * factors[k]
    return Measurements(path=path, columns={n: values[:, j] for j, n in enumerate(names)}, units=units,
                        comments=table.comments)


@dataclass
class Table:
    """A measured CSV as read (:func:`read_table`): its comments, its header, the columns to take (column
    index, quantity, unit as written) and its data rows (line number, cells)."""

    path: Path
    comments: list[str]
    header: list[str]
    selected: list[tuple[int, str, str]]
    body: list[tuple[int, list[str]]]
    sep: str | None

    @property
    def lines(self) -> list[int]:
        """The file's line number of each data row."""
        return [lineno for lineno, _ in self.body]

    def check_rows(self, max_rows: int) -> None:
        """Refuse a file without data rows, with more than ``max_rows`` or with a row of the wrong length."""
        if not self.body:
            raise ScenarioError(f"{self.path}: no data rows")
        if len(self.body) > max_rows:
            raise ScenarioError(f"{self.path}: {len(self.body)} data rows; a data file of this kind holds at most "
                                f"{max_rows}")
        for lineno, row in self.body:
            if len(row) != len(self.header):
                raise ScenarioError(f"{self.path}: line {lineno}: {len(row)} values, the header has "
                                    f"{len(self.header)}")

    def numbers(self, j: int, column: str, role: str) -> np.ndarray:
        """Column ``j`` as numbers (a decimal comma read as a point where the separator is not ','), checked
        for its ``role`` by :func:`_numbers`; ``column`` names it in the messages."""
        cells = [row[j].replace(",", ".") if self.sep != "," else row[j] for _, row in self.body]
        return _numbers(self.path, cells, self.lines, column, role)


def read_table(path: str | Path, columns: dict | None = None, folder: Path | None = None, *,
               where: str = "analyses.estimation.columns", example: str = "tau [1],u [1]") -> Table:
    """The header and data rows of a measured CSV (the text rules of :func:`read_csv`); the columns to take
    chosen by :func:`_select` (``where`` the scene key of ``columns``, ``example`` a header, for the messages)."""
    path = resolve(path, folder)
    comments, rows, sep = _rows(path)
    if not rows:
        raise ScenarioError(f"{path}: no header row (expected e.g. '{example}')")
    (head_line, header), body = rows[0], rows[1:]
    return Table(path, comments, header, _select(path, head_line, header, columns, where, example), body, sep)


def _rows(path: Path) -> tuple[list[str], list[tuple[int, list[str]]], str | None]:
    """The comment lines, the (line number, cells) of the other non-empty lines and the separator of a file."""
    comments, rows, sep = [], [], None
    for lineno, line in enumerate(_text(path).splitlines(), start=1):
        if line.lstrip().startswith("#"):
            comments.append(line.strip().lstrip("#").strip())
        elif line.strip():
            sep = sep or _delimiter(line)
            if line.strip(sep + " \t"):  # a spreadsheet's empty row ';;;' is no row
                # a line without quotes splits as csv reads it, several times faster (raw signals are long)
                rows.append((lineno, line.split(sep) if '"' not in line else next(csv.reader([line], delimiter=sep))))
    return comments, rows, sep


def _numbers(path: Path, cells: list[str], lines: list[int], column: str, role: str) -> np.ndarray:
    """The numbers of one column, checked for its role; one line naming the first bad cell."""
    try:
        v = np.asarray(cells, dtype=float)
    except ValueError:
        i = next(i for i, c in enumerate(cells) if not _is_number(c))
        raise ScenarioError(f"{path}: line {lines[i]}, column '{column}': {_short(cells[i])} is not a number") from None
    checks = [(~np.isfinite(v), lambda i: f"{_short(cells[i])} is not a finite number")]
    if role == "load":
        checks.append((~(v > 0), lambda i: f"a load must be positive, got {v[i]:g}"))
    if role in ("gap", "flow"):
        checks.append((v < 0, lambda i: f"a measured {role} must not be negative, got {v[i]:g}"))
    if role == "group":
        checks.append((v != np.round(v), lambda i: f"a group label is an integer, got {v[i]:g}"))
    for bad, message in checks:
        if bad.any():
            i = int(np.argmax(bad))
            raise ScenarioError(f"{path}: line {lines[i]}, column '{column}': {message(i)}")
    return v


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def check_fit(data: Measurements, residual: str, free: int, where: str) -> None:
    """Refuse data that cannot carry a fit: the measured column(s) of ``residual`` ("u", "q",
    "both") missing, no more residuals than ``free`` parameters (one degree of freedom is
    needed for the residual variance and the confidence intervals), or fewer different loads
    than the free parameters need (identical rows identify one value per measured variable)."""
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
    loads = len(np.unique(data.columns[data.has("load")]))
    if loads * len(need) < free:
        which = "every row has the same load" if loads == 1 else f"the rows have only {loads} different loads"
        raise ScenarioError(f"{where}: the data do not identify {free} free parameters: {which}; measure at "
                            f"{-(-free // len(need))} or more different loads, or fix a parameter")
