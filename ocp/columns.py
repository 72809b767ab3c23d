"""The columns of the spin-up CSV tables, declared once, and their headers ``name [unit]``.

Every spin-up table (``drive_profile.csv``, ``drive_segments.csv``, ``spinup_*.csv``, the robust, time-optimal and
ROSS ones) is held SI under plain names (``time``, ``speed``, ``acceleration``); :func:`headed` writes each
declared numeric column as ``name [display unit]`` in that unit (the unit chosen for its kind, else the declared
one), a speed or an acceleration with its twin in the unit beside it (rpm with rad/s, rpm/s with rad/s²: a drive
is programmed in rpm, the models think in rad/s); a column of words stays as it is.  :func:`read_table` reads such
a table back, SI (from the SI twin where there is one: full precision).
"""

from __future__ import annotations

import csv
import numbers
import re
from pathlib import Path

from autobal.analysis.run.quantities import Declarations, Quantity, beside, convert, spelled

#: the columns of the spin-up tables; ``*`` one ramp's key (``constant_ramp_speed``) or one node (``deflection_node3``)
COLUMNS = Declarations(
    Quantity("time t_start t_end arrival_time held_from *_time", "s", "t", "time"),
    Quantity("build_time solve_time", "s", "", "wall time of the NLP build or solve"),
    Quantity("speed speed_start speed_end *_speed", "rad/s", "ω", "rotor speed", "rpm"),
    Quantity("reduced_wd ross_wd", "rad/s", "ω_d", "damped critical speed (reduced model, ROSS)", "rpm"),
    Quantity("natural_frequency", "rad/s", "ω_n", "natural frequency of a mode at standstill", "rpm"),
    Quantity("acceleration rate", "rad/s^2", "α", "angular acceleration (of the interval ending at the sample)",
             "rpm/s"),
    Quantity("torque", "N*m", "M", "drive torque"),
    Quantity("power", "W", "P", "drive power M ω", "kW"),
    Quantity("deflection", "m", "δ", "deflection of the Jeffcott rotor, 0-peak", "mm"),
    Quantity("deflection_node* *_deflection robust_peak nominal_peak ramp_peak design_worst validation_worst "
             "resimulated_peak collocation_peak", "m", "r", "deflection of the modal rotor, 0-peak", "µm"),
    Quantity("deflection_over_e *_deflection_over_e *_peak_over_e *_worst_over_e", "1", "δ/e",
             "deflection over the eccentricity"),
    Quantity("unbalance *_unbalance", "1", "d", "system unbalance"),
    Quantity("critical_speed_factor damping_factor liquid_mass_factor", "1", "", "factor on the nominal rotor"),
    Quantity("reduced_damping_ratio", "1", "ζ", "damping ratio of a mode of the reduced model"),
    Quantity("resimulation_rel_error", "1", "", "relative difference of the re-simulated peak"),
    Quantity("segment mode intervals iterations", "1", "", "a count or a number"),
)


def _number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def headed(table: dict) -> dict:
    """The CSV columns of a spin-up table held SI (name -> values): each declared column 'name [unit]' in its display
    unit (its nulls empty), a speed or an acceleration with its twin in the unit beside; words as they are.
    ValueError for a numeric column that is not declared in :data:`COLUMNS`."""
    out = {}
    for name, values in table.items():
        values, q = list(values), COLUMNS.find(name)
        if q is None and any(_number(v) for v in values):
            raise ValueError(f"spin-up table column '{name}' is not declared (autobal.ocp.columns.COLUMNS)")
        if q is None:
            out[name] = values
            continue
        words = [v for v in values if v is not None and not _number(v)]
        if words:
            raise ValueError(f"spin-up table column '{name}' is declared a quantity but holds {words[0]!r}")
        for unit in dict.fromkeys(u for u in (q.display, beside(q.unit, q.display)) if u):
            out[f"{name} [{unit}]"] = [convert(v, q.unit, unit) if _number(v) else None for v in values]
    return out


HEADER = re.compile(r"(?P<name>.+) \[(?P<unit>[^\]]+)\]")


def read_table(path: Path) -> dict | None:
    """A spin-up table a run wrote, SI under its plain names (:func:`headed` undone; a twin read from its SI column,
    exactly), words as they are; None where the run wrote none."""
    if not Path(path).is_file():
        return None
    with Path(path).open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    out, exact = {}, set()
    for header in rows[0] if rows else ():
        m = HEADER.fullmatch(header)
        if m is None:
            out[header] = [_value(r[header]) for r in rows]
            continue
        name, unit = m["name"], m["unit"]
        if COLUMNS.find(name) is None:
            raise ValueError(f"{Path(path).name}: column '{header}' is not a spin-up table column "
                             "(autobal.ocp.columns.COLUMNS)")
        si = COLUMNS.find(name).unit
        if name in exact or name in out and unit != spelled(si):
            continue
        one = convert(1.0, si, unit)
        out[name] = [None if r[header] == "" else float(r[header]) / one for r in rows]
        if unit == spelled(si):
            exact.add(name)
    return out


def _value(x: str):
    try:
        return float(x)
    except ValueError:
        return x
