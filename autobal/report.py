"""report.html of an output folder: one self-contained page an engineer can hand on.

``render(folder)`` reads what a run left in ``folder`` (``results.json``, or the status file of a
failed, interrupted or refused run), embeds every PNG figure as a data URI and writes
``report.html`` through the jinja2 templates in ``autobal/templates``.  Nothing in the page is
fetched from elsewhere.  Per analysis it shows the inputs as given and in SI, the headline numbers
with their units, the verdicts, the figures with captions, the accuracy estimate and the run time,
the comparison with the source's published values and the warnings.

``units(results)`` is the ``units`` map of results.json: every numeric key of an analysis block
(dotted path, ``[]`` for the items of a list of records) -> its SI unit, ``"1"`` for a
dimensionless group named as in the source.
"""

from __future__ import annotations

import base64
import csv
import functools
import hashlib
import importlib
import itertools
import json
import math
import re
import warnings
from html import escape as html_escape
from importlib import resources
from pathlib import Path

import jinja2
import yaml
from markupsafe import Markup

from autobal import report_input
from autobal.analysis.quantities import (
    Declarations,
    Quantity,
    beside,
    checked_choice,
    chosen,
    convert,
    current_choice,
    display_unit_of,
    display_units,
    flatten,
    is_display_unit,
    is_number,
    leaf_paths,
    lookup,
    significant,
    spelled,
)
from autobal.analysis.result import html_verdict, plain
from autobal.errors import ScenarioError
from autobal.report_input import MAX_FIGURE_BYTES
from autobal.scenario import MAX_FILE_BYTES as MAX_SCENE_BYTES
from autobal.text import clean as text_clean
from autobal.units import si_unit_of

REPORT = "report.html"
STATUS_FILES = ("failed_solve.json", "interrupted.json", "error.json")

# --------------------------------------------------------------------------------------------
# units of the results.json keys: the declarations of each Result class (analysis/quantities.py)
# --------------------------------------------------------------------------------------------
#: analysis -> the module whose QUANTITIES declare every number of its block (imported when a report needs it)
DECLARED = {"statics": "autobal.analysis.statics_study", "frequency": "autobal.analysis.frequency",
            "transient": "autobal.analysis.simulate", "reliability": "autobal.analysis.reliability",
            "liquid_balancer": "autobal.analysis.liquid_balancer", "estimation": "autobal.analysis.estimation_study",
            "montecarlo": "autobal.analysis.montecarlo", "rotor_dynamics": "autobal.analysis.rotor_study",
            "stability": "autobal.analysis.stability", "design": "autobal.analysis.design_study",
            "spinup": "autobal.ocp.spinup_study", "spinup_robust": "autobal.ocp.robust_study",
            "spinup_time_optimal": "autobal.ocp.time_optimal_study", "ross_spinup": "autobal.ocp.modal",
            "ross_spinup_robust": "autobal.ocp.robust_study"}

#: analyses whose numbers are not declared: none (every analysis declares its numbers beside its Result class, and
#: no unit is read off a key's name; tests/test_quantities.py fails on an analysis that is not declared)
UNDECLARED: tuple[str, ...] = ()


@functools.cache
def declarations(analysis: str) -> Declarations | None:
    """The declared quantities of an analysis, None for a key that is no analysis."""
    if analysis not in DECLARED:
        return None
    return importlib.import_module(DECLARED[analysis]).QUANTITIES


def quantity(path: str, results: dict | None = None) -> Quantity | None:
    """The declaration of a results.json key ``analysis.dotted.path``, or None (``results``: the run's, for a
    key whose unit is that of a parameter its block names, e.g. the axis of a stability map)."""
    analysis, _, rest = path.partition(".")
    decl = declarations(analysis)
    return None if decl is None else decl.find(rest, None if results is None else results.get(analysis))


def unit_of(path: str, results: dict | None = None) -> str | None:
    """SI unit of a results.json key ``analysis.dotted.path`` ("1" when dimensionless) from its declaration, or
    None (an undeclared key: tests/test_quantities.py fails on one)."""
    q = quantity(path, results)
    return None if q is None else q.unit


def units(results: dict, analyses: list[str] | None = None) -> dict[str, str]:
    """The ``units`` map of results.json: dotted key -> SI unit of every numeric key of the analysis
    blocks ("1" for dimensionless groups named as in the source)."""
    names = analyses if analyses is not None else [k for k in results if k in SECTIONS]
    out = {}
    for name in names:
        for path, _ in leaf_paths(plain(results.get(name, {})), name):
            unit = unit_of(path, results)
            if unit is not None:
                out.setdefault(path, unit)
    return out


def _get(data, path: str, default=None):
    """``data`` at a dotted path (``a.b.c``; an integer picks a list item), or ``default``."""
    return lookup(data, path, default)


# --------------------------------------------------------------------------------------------
# numbers and cells
# --------------------------------------------------------------------------------------------
def pretty_unit(unit: str) -> str:
    """A unit as printed in the report ("1" -> "dimensionless")."""
    return "dimensionless" if unit == "1" else spelled(unit)


def number(v) -> str:
    """A number with 5 significant digits ('—' for null)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    a = abs(v)
    return f"{v:.5g}" if a == 0 or 1e-3 <= a < 1e6 else f"{v:.4e}"


def cell(v, unit: str | None = None, shown: str | None = None, digits: int | None = None) -> dict:
    """A table cell: a number (or null) with its unit, converted from the SI ``unit`` to the display unit
    ``shown`` (default: the unit chosen for its kind, else the field's unit of analysis/quantities.py, µm for
    lengths below 10 µm), to ``digits`` significant digits (default :func:`number`'s 5); words and yes/no
    without a unit."""
    if isinstance(v, bool | str):
        return text(v)
    unit = unit or "?"
    if shown is None:
        shown = display_unit_of(unit)
        if shown == "mm" and unit == "m" and v is not None and abs(v) < 1e-5 and not chosen("length"):
            shown = "µm"
    if not is_display_unit(shown, unit):  # a unit of an undeclared analysis that has no display unit
        shown = unit
    if v is None:
        return {"text": "—", "unit": pretty_unit(shown), "num": True, "null": True}
    x = convert(v, unit, shown) if is_display_unit(shown, unit) else v
    return {"text": number(x) if digits is None else significant(x, digits), "unit": pretty_unit(shown), "num": True}


def text(v) -> dict:
    """A table cell holding words (no unit)."""
    if isinstance(v, bool):
        v = "yes" if v else "no"
    return {"text": "—" if v is None else str(v), "unit": "", "num": False}


def table(caption: str, columns: list[str], rows: list[list[dict]], headline: bool = False,
          unit_column: bool = False) -> dict:
    """A table of cells; ``headline`` marks the headline numbers, ``unit_column`` a table whose units
    stand in a column of their own (the numbers' cells then show no unit)."""
    return {"caption": caption, "columns": columns, "rows": rows, "headline": headline, "unit_column": unit_column}


def _unit_path(name: str, path: str) -> str:
    return re.sub(r"\.\d+(?=\.|$)", "[]", f"{name}.{path}")


class Section:
    """The report section of one analysis, filled by its function in SECTIONS."""

    def __init__(self, name: str, block: dict, results: dict, folder: Path | None = None):
        self.name, self.block, self.results, self.folder = name, block, results, folder
        self.rows: list[list[dict]] = []  # the headline table: quantity, symbol, value, unit
        self.tables: list[dict] = []
        self.verdicts: list[dict] = []
        self.warnings: list[str] = []
        self.notes: list[str] = []
        self.comparison: dict | None = None
        self.validation: list[dict] = []  # what the source's own models show (the validation part)
        self.validation_tables: list[dict] = []
        self.validation_notes: list[str] = []
        self.main: dict | None = None  # the one verdict of the analysis (the summary shows it)

    def get(self, path: str, default=None):
        return _get(self.block, path, default)

    def unit(self, path: str) -> str | None:
        return unit_of(_unit_path(self.name, path), self.results)

    def cell(self, path: str, value=None) -> dict:
        """The cell of the block's value at ``path`` (or ``value``) in the display unit of its declaration, to the 4
        significant digits of the terminal."""
        q = quantity(f"{self.name}.{path}", self.results)
        v = self.get(path) if value is None else value
        return cell(v, q.unit, q.display, 4) if q is not None else cell(v, self.unit(path) or "?")

    def row(self, label: str, symbol: str, path: str, unit: str | None = None, value=None, note: str = "") -> None:
        """One headline row; the value is the block's at ``path`` unless given, its unit and display unit
        its declaration's.  A key the block lacks (the analysis did not compute it) gives no row."""
        if value is None and not _has(self.block, path):
            return
        v = self.get(path) if value is None else value
        c = cell(v, unit) if unit else self.cell(path, v)
        c["key"] = f"{self.name}.{path}"
        note = f"{note} {self.get(path + '_status') or ''}"
        si = unit or getattr(quantity(f"{self.name}.{path}"), "unit", None) or self.unit(path)
        if si is not None and is_number(v) and beside(si, c["unit"]):  # speeds, accelerations in the other units
            others = ("rad/s", "rpm", "Hz") if is_display_unit("rpm", si) else ("rad/s²", "rpm/s")
            note = " = ".join(f"{number(convert(v, si, u))} {u}" for u in others if u != c["unit"]) + f" {note}"
        self.rows.append([text(label), text(symbol), c, text(c["unit"]), text(note.strip())])

    def verdict(self, ok: bool | None, message: str) -> None:
        """A check of the section: ok True (good), False (bad), None (information)."""
        self.verdicts.append({"ok": ok, "text": message})

    def conclude(self, ok: bool | None, message: str) -> None:
        """The one verdict of the analysis (the headline model's): first in the section and in the summary."""
        self.main = {"ok": ok, "text": message}
        self.verdicts.insert(0, self.main)

    def overall(self) -> dict:
        """The summary's verdict: the one concluded, else the first failed check, else the first check, else
        the first piece of information (an analysis without a pass/fail criterion says what it found)."""
        checks = [v for v in self.verdicts if v["ok"] is not None]
        return (self.main or next((v for v in checks if v["ok"] is False), None) or (checks[0] if checks else None)
                or (self.verdicts[0] if self.verdicts else
                    {"ok": None, "text": "computed; this analysis has no pass/fail criterion (the section below)"}))

    def headline(self) -> dict | None:
        if not self.rows:
            return None
        return table("Headline numbers", ["quantity", "symbol", "value", "unit", "note"], self.rows, headline=True,
                     unit_column=True)


def _has(data, path: str) -> bool:
    sentinel = object()
    return _get(data, path, sentinel) is not sentinel


def _leading(real: list, imag: list, count: int = 2) -> str:
    """The poles with the largest real part, as 're ± im i' (1/s)."""
    pairs = sorted(zip(real, imag, strict=True), key=lambda p: -(p[0] if p[0] is not None else -math.inf))
    seen, out = set(), []
    for re_, im in pairs:
        key = (round(re_, 6), round(abs(im), 6))
        if key in seen:
            continue
        seen.add(key)
        out.append(f"{number(re_)} ± {number(abs(im))}i" if abs(im) > 0 else number(re_))
        if len(out) == count:
            break
    return ", ".join(out)


def _nulls(block, path: str, out: dict[str, list[str]]) -> dict[str, list[str]]:
    """reason -> the paths of the nulls that carry it as their ``key_status``."""
    if isinstance(block, dict):
        for k, v in block.items():
            if k.endswith("_status") and isinstance(v, str) and block.get(k[:-7], 0) is None:
                out.setdefault(v, []).append(f"{path}.{k[:-7]}")
            elif isinstance(v, dict | list):
                _nulls(v, f"{path}.{k}", out)
    elif isinstance(block, list):
        for i, v in enumerate(block):
            if isinstance(v, dict):
                _nulls(v, f"{path}[{i}]", out)
    return out


def _null_note(block, path: str) -> str | None:
    """One line on the block's nulls, grouped by reason (each has its ``key_status`` in results.json): not
    a warning, a reader has nothing to act on."""
    groups = _nulls(block, path, {})
    if not groups:
        return None
    parts = [f"{reason}: {', '.join(p.removeprefix(path + '.') for p in paths)}" if len(paths) <= 2 else
             f"{reason} ({len(paths)} values)" for reason, paths in groups.items()]
    return f"{sum(map(len, groups.values()))} values are null (no number), each with its reason in results.json: " \
        + "; ".join(parts)


# --------------------------------------------------------------------------------------------
# the source's published values per shipped scene (docs/validation.md has the full ledger)
# --------------------------------------------------------------------------------------------
_STATICS = (("critical margin", "δψ_kr", "dpsi_kr", "1"), ("critical discharge ratio", "ψ1_kr", "psi1_kr", "1"),
            ("barrier flow", "Q_e", "Q_e", "m^3/s"), ("face gap", "u0", "u0", "1"), ("valve opening", "ξ0", "xi0", "1"),
            ("valve chamber pressure", "ψ_cam0", "psi_cam0", "1"), ("disc chamber pressure", "ψ20", "psi2_0", "1"),
            ("cavity pressure", "ψ30", "psi3_0", "1"))
_AFC = (("first AFC peak", "ω_I", "peaks.0.omega", "rad/s"),
        ("first peak amplitude", "A_I", "peaks.0.amplitude_um", "um"),
        ("second AFC peak", "ω_II", "peaks.1.omega", "rad/s"),
        ("second peak amplitude", "A_II", "peaks.1.amplitude_um", "um"),
        ("amplitude at the operating speed", "A(ω0)", "at_operating_speed.amplitude_um", "um"))


def _statics_published(values: tuple, where: tuple) -> list:
    """Rows of the appendix's closed-form statics (Pavlenko 2014): published values and where printed."""
    return [(label, sym, f"closed_form.{key}", v, unit, f"Pavlenko (2014), {w}")
            for (label, sym, key, unit), v, w in zip(_STATICS, values, where, strict=True)]


def _afc_published(values: tuple, where: str) -> list:
    """Rows of the published AFC of the source's program model (Pavlenko 2014)."""
    return [(label, sym, f"models.program.{key}", v, unit, f"Pavlenko (2014), {where}")
            for (label, sym, key, unit), v in zip(_AFC, values, strict=True)]


#: scene -> analysis -> rows (quantity, symbol, key in the block or None, published value, unit, where)
PUBLISHED = {
    "pump_pe600_statics": {"statics": _statics_published(
        (0.030, 1.73, 7.448e-3, 0.964, 1.294, 1.238, 1.027, 0.513),
        ("Eq. (2.31), App. A", "Eq. (2.32), App. A", "App. A", "Eq. (2.27), App. A", "Eq. (2.28), App. A",
         "Eq. (2.26), App. A", "Eq. (2.24), App. A", "Eq. (2.25), App. A"))},
    "compressor_k180_statics": {"statics": _statics_published(
        (0.017, 1.471, 0.029, 0.967, 0.356, 1.367, 1.007, 0.223),
        ("Eq. (2.160), App. B", "Eq. (2.160), App. B", "App. B", "Eq. (2.147), App. B", "App. B", "App. B",
         "Eq. (2.145), App. B", "Eq. (2.146), App. B"))},
    "pump_pe600_dynamics": {"frequency": _afc_published((1980.0, 25.0, 2920.0, 10.0, 7.0), "§2.6, AFC figure")},
    "compressor_k180_dynamics": {"frequency": _afc_published((2340.0, 33.0, 4810.0, 18.0, 20.0), "§2.7, AFC figure")},
    "hydroheel_wear": {"reliability": [
        ("largest gap", "u_max", "u_max", 1.5, "1", "Pavlenko (2014), Eq. (1.52)"),
        ("load group", "χ0", "chi0", 1.76, "1", "Pavlenko (2014), Eq. (1.30)"),
        ("exponent", "k", "k", 3.3, "1", "Pavlenko (2014), Eq. (1.32)"),
        ("P(wear ≤ z_B) at 2000 h", "", "wear_le_base_gap.0", 0.5, "1", "Pavlenko (2014), Fig. 1.27"),
        ("reliability at 2000 h", "P(t)", "literal.P.0", 0.75, "1", "Pavlenko (2014), Eq. (1.48), Fig. 1.28"),
        ("reliability at 4000 h", "P(t)", "literal.P.2", 0.25, "1", "Pavlenko (2014), Fig. 1.28 ('3 times lower')"),
        ("mean time to failure", "T", "literal.mttf_h", 2700.0, "h", "Pavlenko (2014), Eq. (1.49)"),
    ]},
    "rig_table43_fit": {"estimation": [
        ("conductance ratio from the nominal losses", "α", "loss_coefficient.alpha_nominal", 1.75, "1",
         "Pavlenko (2014), §4.5, Eq. (4.38)"),
        ("one-parameter static estimate", "α", "fits.static_1p.parameters.alpha.estimate", 1.68, "1",
         "Pavlenko (2014), Eq. (4.23)"),
        ("two-parameter static estimate", "α", "fits.static_2p.parameters.alpha.estimate", 1.72, "1",
         "Pavlenko (2014), Eqs. (4.26)-(4.27)"),
        ("two-parameter static estimate", "τ_max", "fits.static_2p.parameters.tau_max.estimate", 2.75, "1",
         "Pavlenko (2014), Eqs. (4.26)-(4.27)"),
    ]},
    "pump_pe600_montecarlo": {"montecarlo": [
        ("face-gap spread (3σ/mean) at ψ1 = 1", "δu", "exact.u.spread.2", 0.20, "1",
         "Pavlenko (2014), ch. 3, conclusion 4"),
        ("face-leak spread (3σ/mean) at ψ1 = 1", "δq_T", "source.q_T.spread.2", 0.25, "1",
         "Pavlenko (2014), ch. 3, conclusion 4"),
        ("AFC amplitude spread", "cv", "afc.at.peak_2.cv", 0.40, "1",
         "Pavlenko (2014), ch. 3, conclusion 4 ('up to 40 %')"),
    ]},
}


def _comparison(sec: Section, scenario: str) -> None:
    rows = PUBLISHED.get(scenario, {}).get(sec.name)
    if not rows:
        return
    out = []
    for label, symbol, key, published, unit, where in rows:
        if key and key.startswith("afc.") and sec.get("afc.model") not in SOURCE_MODELS:
            continue  # the published AFC spread is the program model's (montecarlo_section says so)
        got = sec.get(key) if key else None
        rel = (got - published) / abs(published) if isinstance(got, int | float) and published else None
        out.append([text(label), text(symbol), cell(published, unit), cell(got, unit),
                    cell(None if rel is None else 100 * rel, "%"), text(where)])
    sec.comparison = table("Comparison with the source's published values (docs/validation.md explains each "
                           "difference)",
                           ["quantity", "symbol", "published", "toolkit (the source's model)", "difference", "source"],
                           out)


# --------------------------------------------------------------------------------------------
# one function per analysis: headline rows, verdicts, tables, warnings
# --------------------------------------------------------------------------------------------
def statics_section(sec: Section) -> None:
    """Operating point, criticals, saturation and contact (Pavlenko 2014, ch. 2.2-2.3)."""
    sec.row("discharge pressure ratio at the operating point", "ψ1 = p1/p_B", "exact.psi1")
    sec.row("discharge pressure", "p1", "exact.p1")
    sec.row("base pressure", "p_B", "scales.p_B")
    sec.row("face gap", "z0", "exact.z0")
    sec.row("face gap ratio", "u0 = z0/z_B", "exact.u0")
    sec.row("valve opening", "x0", "exact.x0")
    sec.row("valve opening ratio", "ξ0 = x0/x_B", "exact.xi0")
    for k, sym, what in (("p2", "p2", "disc chamber"), ("p3", "p3", "cavity behind the disc"),
                         ("pe", "p_e", "barrier chamber"), ("pcam", "p_cam", "valve chamber")):
        sec.row(f"{what} pressure", sym, f"exact.{k}")
    sec.row("barrier flow", "Q_e", "exact.Q_e")
    sec.row("face-throttle leak", "Q_T", "exact.Q_T")
    sec.row("inner-seal flow", "Q_1", "exact.Q_1")
    sec.row("base flow of the source's flow ratios q", "Q_B", "closed_form.Q_B")
    sec.row("axial stiffness of the balancing force", "κ_s", "exact.kappa_s")
    sec.row("critical discharge pressure (inner-seal flow reverses)", "p1_kr", "critical_exact.p1_kr")
    sec.row("critical discharge ratio", "ψ1_kr", "critical_exact.psi1_kr")
    sec.row("critical barrier margin", "δψ_kr", "critical_exact.dpsi_kr")
    sec.row("critical barrier pressure margin", "Δp_kr", "critical_exact.dp_kr")
    ex, sw = sec.get("exact", {}), sec.get("sweep", {})
    sat, contact, psi1 = sw.get("regulator_saturated", []), sw.get("contact", []), sw.get("psi1", [])
    from autobal.analysis.statics_study import StaticsResult  # the verdict's one copy

    if {"regulator_saturated", "contact", "Q_1", "z0", "psi1"} <= set(ex):
        sec.conclude(*StaticsResult(sec.block).verdict())  # the operating point: regulator, contact, inner seal
    if any(sat):
        first = psi1[sat.index(True)]
        sec.verdict(False, f"regulator saturated (valve on its stop) from ψ1 = {number(first)} in the sweep")
        sec.warnings.append(f"regulator saturation from ψ1 = {number(first)}: the closed forms assume an ideal "
                            "regulator and are not valid there")
    if any(contact):
        sec.verdict(False, f"face contact in the sweep from ψ1 = {number(psi1[contact.index(True)])}")
    cf = sec.get("closed_form", {})
    rows = []
    for key, sym, path in (("u0", "u0", "exact.u0"), ("xi0", "ξ0", "exact.xi0"), ("psi2_0", "ψ20", "exact.psi2_0"),
                           ("psi3_0", "ψ30", "exact.psi3_0"), ("psi_e0", "ψ_e0", "exact.psi_e0"),
                           ("psi_cam0", "ψ_cam0", "exact.psi_cam0"), ("kappa_s", "κ_s", "exact.kappa_s"),
                           ("psi1_kr", "ψ1_kr", "critical_exact.psi1_kr"),
                           ("dpsi_kr", "δψ_kr", "critical_exact.dpsi_kr"), ("Q_e", "Q_e", "exact.Q_e")):
        if key in cf:
            u = sec.unit(path) or "?"
            rows.append([text(sym), cell(cf[key], u), cell(sec.get(path), u)])
    if rows:
        sec.tables.append(table("The source's closed forms (ideal regulator, Eqs. (2.24)-(2.36)) beside the exact "
                                "IPOPT solution of the full static system", ["quantity", "closed form", "exact"],
                                rows))


def _stable_models(results: dict) -> dict:
    return {m: v.get("stable") for m, v in _get(results, "stability.models", {}).items()}


MODEL_ORDER = ("nonlinear", "nonlinear_chain", "consistent", "program", "thesis")


def _ordered(models: dict) -> list:
    """Models with the energy-consistent one first and the source's hand models last (validation)."""
    rank = {m: i for i, m in enumerate(MODEL_ORDER)}
    return sorted(models.items(), key=lambda kv: rank.get(kv[0], len(rank)))


def _name(model: str) -> str:
    """What a model is (analysis/frequency.py MODEL_LABELS, the one copy)."""
    from autobal.analysis.frequency import MODEL_LABELS  # python-control and scipy: only a dynamics report needs it

    return MODEL_LABELS.get(model, model)


#: the source's own models (its printed chain form, its hand model, the appendix program, the thesis as printed):
#: reported in the validation part of a section, never as a verdict of the machine
SOURCE_MODELS = ("nonlinear_chain", "consistent", "program", "thesis")

#: why a source's model is unstable where the energy-consistent model is not (docs/theory/dynamics.md)
WHY_UNSTABLE = {
    "nonlinear_chain": "its chamber balances are the printed chain form, whose displacement flows do not match the "
                       "volume changes to the forces (not energy-consistent)",
    "consistent": "it is the linearisation of the printed chain form (equal to it to 1e-9)",
    "program": "the published AFC peaks are the magnitudes of its unstable modes (Pavlenko 2014, App. A/B)",
    "thesis": "the hand model (2.43)-(2.45) with the constants as printed",
}


def _rate(decay) -> str:
    return ("" if decay is None else f"disturbances decay at {number(decay)} 1/s" if decay > 0
            else f"disturbances GROW at {number(-decay)} 1/s")


def frequency_section(sec: Section) -> None:
    """AFC of the face gap (Pavlenko 2014, §2.6): the headline model (energy-consistent, physical forcing)
    gives the verdict; the source's models are the validation part."""
    stable = _stable_models(sec.results)
    models = sec.get("models", {})
    h = sec.get("headline")
    if h:
        what = f"{_name(h['model'])}, {h['forcing']} forcing"
        verdict = "stable" if h.get("stable") else "UNSTABLE"
        sec.conclude(h.get("stable"), f"{what}: {verdict} (max Re λ = {number(h.get('max_real'))} 1/s); first "
                                      f"resonance at {number(_get(h, 'peaks.0.omega'))} rad/s; amplitude at the "
                                      f"operating speed {number(_get(h, 'at_operating_speed.amplitude_um'))} µm")
        sec.row(f"first resonance ({what})", "ω_I", "headline.peaks.0.omega")
        sec.row(f"amplitude at the first resonance ({what})", "A_I", "headline.peaks.0.amplitude_um")
        sec.row("operating speed", "ω0", "headline.at_operating_speed.omega")
        sec.row(f"amplitude at the operating speed ({what})", "A(ω0)", "headline.at_operating_speed.amplitude_um")
        sec.row(f"static amplitude ({what})", "A(0)", "headline.static_amplitude_um")
    else:  # no headline block: the toolkit's own first model, never one of the source's
        lead = next((m for m in MODEL_ORDER if m in models and m not in SOURCE_MODELS), None)
        if lead is not None:
            what = _name(lead)
            sec.row(f"first resonance ({what})", "ω_I", f"models.{lead}.peaks.0.omega")
            sec.row(f"amplitude at the first resonance ({what})", "A_I", f"models.{lead}.peaks.0.amplitude_um")
            sec.row("operating speed", "ω0", f"models.{lead}.at_operating_speed.omega")
            sec.row(f"amplitude at the operating speed ({what})", "A(ω0)",
                    f"models.{lead}.at_operating_speed.amplitude_um")
    sec.row("forcing amplitude", "δψ_1a", "forcing_amplitude")
    own, source = [], []
    for model, m in _ordered(models):
        peaks = m.get("peaks", [])
        at = m.get("at_operating_speed", {})
        verdict = {True: "stable", False: "UNSTABLE", None: "—"}[stable.get(model)]
        rows = own if model not in SOURCE_MODELS else source
        for i, pk in enumerate(peaks or [{}]):
            first = i == 0
            rows.append([text(_name(model) if first else ""), text(m.get("forcing") if first else ""),
                         text(verdict if first else ""), cell(pk.get("omega"), "rad/s"),
                         cell(pk.get("amplitude_um"), "um"),
                         cell(at.get("amplitude_um") if i == 0 else None, "um"),
                         cell(m.get("static_amplitude_um") if i == 0 else None, "um")])
        if stable.get(model) is False and model not in SOURCE_MODELS:
            sec.warnings.append(f"{_name(model)}: the model is unstable at this operating point; its AFC is the "
                                "response of an unstable system (no steady state exists)")
        if model in SOURCE_MODELS:
            _source_model(sec, model, stable.get(model), m.get("forcing"))
    columns = ["model", "forcing", "stability", "peak ω", "peak amplitude", "amplitude at ω0", "static amplitude"]
    caption = (f"under the scene's '{sec.get('forcing')}' forcing, ω0 = {number(sec.get('at_operating_speed.omega'))} "
               "rad/s: peaks, amplitude at the operating speed and the static amplitude")
    if own:
        sec.tables.append(table(f"AFC of the face gap, {caption}", columns, own, headline=True))
    if source:
        sec.validation_tables.append(table(f"AFC of the face gap of the source's models, {caption}", columns, source))


def _source_model(sec: Section, model: str, stable: bool | None, forcing: str | None = None) -> None:
    """The validation line of one of the source's models: how closely it reproduces the scene's published
    values (the comparison table, program model), whether it is stable, and why not."""
    rows = PUBLISHED.get(sec.results.get("scenario", ""), {}).get(sec.name) or []
    diffs = [abs(sec.get(key) - pub) / abs(pub) for _, _, key, pub, _, _ in rows
             if key and key.startswith(f"models.{model}.") and isinstance(sec.get(key), int | float) and pub]
    where = rows[0][5] if rows else "the source"
    repro = (f"reproduces the published values ({where}) within {100 * max(diffs):.1f} % ({len(diffs)} values); "
             if diffs else "")
    m = sec.get(f"models.{model}") or {}
    poles = m.get("poles") or _get(sec.results, f"stability.models.{model}.poles") or {}
    lead = _leading(poles.get("real", []), poles.get("imag", [])) if poles else ""
    state = {True: "stable", None: "stability not computed",
             False: f"UNSTABLE (leading poles {lead} 1/s): {WHY_UNSTABLE.get(model, '')}"}[stable]
    if stable is False and sec.name == "frequency":
        state += "; its AFC is not a steady response"
    text_ = f"{_name(model)}{f', {forcing} forcing' if forcing else ''}: {repro}{state}"
    if text_ not in [v["text"] for v in sec.validation]:
        sec.validation.append({"ok": None, "text": text_})  # what the source's model shows, not a verdict


def stability_section(sec: Section) -> None:
    """Poles, Hurwitz determinants and margins (Pavlenko 2014, §2.7): the headline model (energy-consistent)
    gives the verdict; the source's models are the validation part."""
    h = sec.get("headline")
    if h:
        from autobal.analysis.stability import QUANTITIES, StabilityResult  # the verdict's one copy

        sec.conclude(*StabilityResult(sec.block).verdict())
        for q, key, _ in QUANTITIES.headline(sec.block):
            sec.row(q.description, q.symbol, key)
    own, source = [], []
    for model, m in _ordered(sec.get("models", {})):
        poles = m.get("poles", {})
        lead = _leading(poles.get("real", []), poles.get("imag", []))
        st = m.get("stable")
        row = [text(_name(model)), text({True: "stable", False: "UNSTABLE"}.get(st, "—")),
               {"text": lead, "unit": "1/s", "num": True}, cell(_get(m, "margin.decay_rate"), "1/s"),
               cell(_get(m, "margin.min_damping_ratio"), "1")]
        if model in SOURCE_MODELS:
            source.append(row)
            _source_model(sec, model, st)
            continue
        own.append(row)
        if model != (h or {}).get("model"):  # another model of the toolkit's own: a check, not the verdict
            sec.verdict(st, f"{_name(model)}: {'stable' if st else 'UNSTABLE'}; leading poles {lead} 1/s; "
                            f"{_rate(_get(m, 'margin.decay_rate'))}")
    columns = ["model", "verdict", "leading poles", "decay rate", "min damping ratio ζ"]
    caption = "leading poles (largest real part), decay rate −max Re λ and the smallest damping ratio"
    if own:
        sec.tables.append(table(f"Stability: {caption}", columns, own, headline=True))
    if source:
        sec.validation_tables.append(table(f"Stability of the source's models: {caption}", columns, source))
    for m, t in (sec.get("restoring") or {}).items():
        (sec.validation_notes if m in SOURCE_MODELS else sec.notes).append(f"{_name(m)}: {t.removeprefix(m + ': ')}")


def transient_section(sec: Section) -> None:
    """Nonlinear transients by CVODES/IDAS (Pavlenko 2014, §2.5)."""
    sec.row("equilibrium residual of the nonlinear model", "", "equilibrium_residual")
    rows = []
    for c in sec.get("cases", []):
        rows.append([text(c.get("input")), cell(c.get("amplitude"), "1"), cell(c.get("frequency"), "rad/s"),
                     cell(c.get("max_dz_um"), "um"), cell(c.get("final_dz_um"), "um"), cell(c.get("t_end"), "s"),
                     cell(c.get("integrator_steps"), "1"), text(c.get("failure") or "ok")])
        if c.get("failure"):
            sec.verdict(False, f"{c.get('input')}: integration failed: {c['failure']}")
        for e in c.get("events") or []:
            sec.warnings.append(f"{c.get('input')}: event {e}")
    sec.tables.append(table(f"Transients of the {sec.get('model')} model ({sec.get('integrator')}): face-gap change "
                            "dz", ["input", "amplitude", "frequency", "max |dz|", "final dz", "t_end", "steps",
                                   "status"], rows, headline=True))
    if rows and not any(c.get("failure") for c in sec.get("cases", [])):
        sec.verdict(True, "every transient integrated to its end time")


def liquid_balancer_section(sec: Section) -> None:
    """Efficiency of the liquid auto-balancer at the operating point (Khomyak 2020, ch. 3): one verdict (a balancing
    equilibrium and enough liquid at the working speed); Tables 3.2/3.3 in the validation part."""
    op = "operating_point"
    sec.row("speed ratio", "γ = ω/ω_cr", f"{op}.gamma")
    sec.row("working speed", "ω", f"{op}.omega")
    sec.row("phase lag of the deflection", "δ", f"{op}.delta_deg")
    sec.row("initial unbalance", "D0", "system.D0")
    sec.row("liquid unbalance capacity", "D", f"{op}.D")
    sec.row("capacity ratio", "k_D = D0/D", f"{op}.k_D")
    published = next((r for r in sec.get("table_3_2.rows", []) if is_number(r.get("gamma"))
                      and abs(r["gamma"] - (sec.get(f"{op}.gamma") or math.nan)) < 1e-9), None)
    why = ""
    if published and published.get("status") == "differs":  # the headline differs from the published value
        why = (f"Khomyak (2020), Table 3.2 publishes {number(published['published_theory'])} (theory) and "
               f"{number(published['published_experiment'])} (experiment) at γ = {number(published['gamma'])}: the "
               f"documented App. В algorithm makes the liquid's unbalance D ≫ D0 (k_D = {number(sec.get(f'{op}.k_D'))}"
               "); the table came from the thesis's C# program, which it does not show (docs/validation.md)")
    sec.row("efficiency (the source's algorithm)", "λ0", f"{op}.lambda0", note=why)
    sec.row("efficiency (self-consistent closure, toolkit extension)", "λ0⁺", f"{op}.lambda0_self_consistent")
    for key, label, symbol in (("optimal_height", "optimal chamber height", "h_opt"),
                               ("optimal_volume", "optimal liquid volume", "V_opt")):
        why = ""
        if sec.get(f"{key}.singular"):  # orders of magnitude from the published optimum: the row says why
            why = (f"complete balancing (k_D = 1) is reached here, where λ0 is unbounded: "
                   f"λ0 = {number(sec.get(f'{key}.lambda0_max'))} says how close IPOPT came to k_D = 1, not how "
                   "efficient the machine is; Khomyak (2020), Table 3.3 publishes optimal volumes of 48.5-176.7 mL: "
                   "in the documented model D = ρf(πhR² − V) falls with V, the table's rises with D0 "
                   "(docs/validation.md)")
        sec.row(label, symbol, f"{key}.optimum", note=why)
    if "equilibrium_exists" in sec.get(op, {}):
        from autobal.analysis.liquid_balancer import LiquidBalancerResult  # the verdict's one copy

        sec.conclude(*LiquidBalancerResult(sec.block).verdict())
    rows = sec.get("table_3_2.rows", [])
    if rows:
        sec.comparison = table("Comparison with Khomyak (2020), Table 3.2: efficiency λ0",
                               ["γ", "published theory", "published experiment", "toolkit (documented)",
                                "toolkit (self-consistent)", "status"],
                               [[cell(r.get("gamma"), "1"), cell(r.get("published_theory"), "1"),
                                 cell(r.get("published_experiment"), "1"), cell(r.get("toolkit_documented"), "1"),
                                 cell(r.get("toolkit_self_consistent"), "1"), text(r.get("status"))] for r in rows])
        differs = next((r for r in rows if r.get("status") == "differs"), None)
        if differs:
            sec.validation.append({"ok": None, "text": f"Table 3.2 is not reproduced by the documented algorithm: "
                                                       f"{differs.get('reason')}"})
    rows = sec.get("table_3_3.rows", [])
    if rows:
        sec.validation_tables.append(table("Khomyak (2020), Table 3.3: optimal liquid volume",
                                           ["D0", "published V_opt", "experiment V_opt", "toolkit (documented)",
                                            "toolkit (crescent)", "status"],
                                           [[sec.cell(f"table_3_3.rows.{i}.D0_gcm"),
                                             sec.cell(f"table_3_3.rows.{i}.published_V_opt_mL"),
                                             sec.cell(f"table_3_3.rows.{i}.experiment_V_opt_mL"),
                                             sec.cell(f"table_3_3.rows.{i}.V_opt_mL"),
                                             sec.cell(f"table_3_3.rows.{i}.V_opt_crescent_mL"), text(r.get("status"))]
                                            for i, r in enumerate(rows)]))


def _adequacy_row(label: str, ad: dict) -> list[dict]:
    """One row of the adequacy table: the Fisher test (4.14) and the lack-of-fit test of a fit or a curve."""
    lof = ad.get("lack_of_fit") or {}
    return [text(label), *(cell(ad.get(k), "1") for k in ("F", "F_crit", "p_value")), text(ad.get("adequate")),
            *(cell(lof.get(k), "1") for k in ("F", "F_crit", "p_value")), text(lof.get("adequate"))]


def estimation_section(sec: Section) -> None:
    """Least-squares fits with standard errors, bootstrap intervals, parameter correlation and adequacy
    (Pavlenko 2014, §4.3-4.4), the loss coefficient of (4.38): one verdict over the fits (solved and adequate)."""
    rows, correlations, adequacy, moved = [], [], [], []
    for fit, f in sec.get("fits", {}).items():
        boot = _get(f, "bootstrap.parameters") or {}
        free = [p for p, v in f.get("parameters", {}).items() if v.get("free")]
        for pname in free:
            at = f"fits.{fit}.parameters.{pname}"
            rows.append([text(fit), text(pname), *(sec.cell(f"{at}.{k}") for k in ("estimate", "standard_error",
                                                                                    "ci_low", "ci_high")),
                         *(sec.cell(f"fits.{fit}.bootstrap.parameters.{pname}.{k}") if k in (boot.get(pname) or {})
                           else text(None) for k in ("ci_low", "ci_high")), text("dimensionless")])
        corr = f.get("correlation") or []
        for a, b in itertools.combinations(range(len(free)), 2):
            r = corr[a][b] if a < len(corr) and b < len(corr[a]) else None
            if is_number(r):
                correlations.append([text(fit), text(f"{free[a]}, {free[b]}"), cell(r, "1"),
                                     text("the data hardly separate them: the intervals are wide along the ridge"
                                          if abs(r) >= 0.9 else "")])
        moved += [f"{fit}: {m.get('why')}" for m in (_get(f, "extra.start_moved") or {}).values()]
        ad = f.get("adequacy") or {}
        if "adequate" in ad:
            adequacy.append(_adequacy_row(f"fit {fit}", ad))
    if sec.get("fits"):
        from autobal.analysis.estimation_study import EstimationResult  # the verdict's one copy

        sec.conclude(*EstimationResult(sec.block).verdict())
    level = number(100 * (next(iter(sec.get("fits", {}).values()), {}).get("confidence") or 0.95))
    sec.tables.append(table(f"Fitted parameters: estimate, standard error, the linearised {level} % confidence "
                            "interval and the residual-bootstrap percentile interval",
                            ["fit", "parameter", "estimate", "standard error", "CI low", "CI high", "bootstrap low",
                             "bootstrap high", "unit"], rows, headline=True, unit_column=True))
    if correlations:
        sec.tables.append(table("Correlation of the free parameters (from the covariance at the optimum)",
                                ["fit", "parameters", "correlation", "meaning"], correlations))
    ref = sec.get("adequacy_reference") or {}
    if "adequate" in ref:
        r = ref.get("reference") or {}
        adequacy.append(_adequacy_row(f"the source's curve (α {number(r.get('alpha'))}, τ_max "
                                      f"{number(r.get('tau_max'))})", ref))
    if adequacy:
        sec.tables.append(table("Adequacy: Fisher test of the variance about the curve against the scatter within "
                                "the load groups (Pavlenko 2014, Eqs. (4.14)-(4.15); adequate when F ≤ F_crit), and "
                                "the lack-of-fit test; F and p dimensionless",
                                ["fit", "F", "F_crit", "p", "adequate", "lack-of-fit F", "F_crit", "p",
                                 "adequate"], adequacy))
    if "source_rule_adequate" in ref and ref["source_rule_adequate"] != ref.get("adequate"):
        sec.validation.append({"ok": None, "text": "the source's text calls F > F_crit adequate (inverted); by its "
                                                   "rule the reference curve would be "
                                                   + ("adequate" if ref["source_rule_adequate"] else "not adequate")})
    lc = sec.get("loss_coefficient") or {}
    if "value" in lc:
        sec.tables.append(table(f"Loss coefficient {lc.get('unknown')} that the fitted α of {lc.get('fit')} implies "
                                "(Pavlenko 2014, Eq. (4.38)); dimensionless",
                                ["unknown", "value", "CI low", "CI high", "nominal", "α fitted", "α nominal"],
                                [[text(lc.get("unknown")), *(sec.cell(f"loss_coefficient.{k}") for k in (
                                    "value", "ci_low", "ci_high", "nominal", "alpha", "alpha_nominal"))]]))
        if lc.get("physical") is False:
            sec.warnings.append(f"(4.38): the fitted α implies a negative {lc.get('unknown')}: the loss model does "
                                "not explain the fit")
    elif "status" in lc:
        sec.warnings.append(f"(4.38): {lc['status']}")
    if moved:  # trivial for a reader: one line
        sec.notes.append("starts moved where the model is defined: " + "; ".join(moved))


def montecarlo_section(sec: Section) -> None:
    """Spreads of face gap, pressures and leak over the sampled groups (Pavlenko 2014, ch. 3): the physical values
    beside the source's groups; its closed forms in the validation part."""
    sec.row("samples", "N", "samples")
    ref = "reference"
    sec.row("discharge pressure of the reference point", "p1", f"{ref}.p1",
            note=f"ψ1 = p1/p_B = {number(sec.get(f'{ref}.psi1'))}")
    sec.row("face gap, mean", "z̄", f"{ref}.z_mean")
    sec.row("face gap, standard deviation", "σ_z", f"{ref}.z_std")
    sec.row("face-gap spread kσ/mean", "δu", f"{ref}.gap_spread", note=f"k = {number(sec.get('band_sigma'))}")
    sec.row("face leak, mean", "Q̄_T", f"{ref}.Q_T_mean")
    sec.row("face leak, standard deviation", "σ_Q", f"{ref}.Q_T_std")
    sec.row("face-leak spread kσ/mean", "δq_T", f"{ref}.leak_spread")
    sec.row("samples with the regulator valve on its stop", "", f"{ref}.saturated_fraction")
    psi1 = sec.get("psi1", [])
    rows, src = [], []
    for i in range(len(psi1)):
        rows.append([sec.cell(f"psi1.{i}"), sec.cell(f"p1.{i}"), sec.cell(f"dimensional.z.mean.{i}"),
                     sec.cell(f"dimensional.z.std.{i}"), sec.cell(f"exact.u.spread.{i}"),
                     sec.cell(f"dimensional.p2.mean.{i}"), sec.cell(f"exact.Q_T.mean.{i}"),
                     sec.cell(f"exact.Q_T.std.{i}"), sec.cell(f"exact.q_T.spread.{i}"),
                     sec.cell(f"saturated_fraction.{i}"), sec.cell(f"exact.u.invalid.{i}")])
        src.append([sec.cell(f"psi1.{i}"), *(sec.cell(f"{part}.{k}.{stat}.{i}") for k in ("u", "q_T")
                                             for part in ("exact", "source") for stat in ("mean", "spread"))])
    saturated = [f"ψ1 = {number(p)}: {significant(100 * f, 3)} %" for p, f in
                 zip(psi1, sec.get("saturated_fraction") or [], strict=False) if f]
    if saturated:  # one line: the source's closed forms assume an ideal regulator
        sec.warnings.append("samples with the regulator valve on its stop (the closed forms assume an ideal "
                            "regulator): " + ", ".join(saturated))
    if _has(sec.block, "dimensional"):
        sec.tables.append(table("Exact statics over the samples: the physical values (mean, standard deviation) "
                                "beside the source's groups' spread kσ/mean",
                                ["ψ1", "p1", "mean z", "std z", "spread u", "mean p2", "mean Q_T", "std Q_T",
                                 "spread q_T", "saturated fraction", "invalid samples"], rows, headline=True))
    sec.validation_tables.append(table("The source's closed forms (ideal regulator, Figs 3.3-3.4) beside the exact "
                                       "statics over the same samples: mean and spread of u = z/z_B and q_T = Q_T/Q_B",
                                       ["ψ1", "u exact", "spread", "u closed form", "spread", "q_T exact", "spread",
                                        "q_T closed form", "spread"], src))
    if _has(sec.block, "reference"):
        from autobal.analysis.montecarlo import MonteCarloResult  # the verdict's one copy

        sec.conclude(*MonteCarloResult(sec.block).verdict())
    else:  # a results.json written before the physical values
        invalid = sum(_get(sec.block, "exact.u.invalid") or [])
        sec.conclude(not sec.block.get("failures"), f"{invalid} sample solves without a converged exact solution"
                     if invalid else "every sample has a converged exact solution")
    at = sec.get("afc.at") or {}
    if at:
        model, forcing = sec.get("afc.model"), sec.get("afc.forcing")
        st = _stable_models(sec.results).get(model)
        sec.tables.append(table(f"AFC amplitude spread of the {_name(model)} model under the {forcing} forcing "
                                f"({sec.get('afc.samples')} samples of {len(sec.get('afc.parameters') or [])} "
                                "uncertain parameters)", ["where", "ω", "nominal", "mean", "std", "cv"],
                                [[text(k.replace("_", " ")), *(sec.cell(f"afc.at.{k}.{x}") for x in (
                                    "omega", "nominal_um", "mean_um", "std_um", "cv"))] for k in at], headline=True))
        if model in SOURCE_MODELS:
            sec.warnings.append(f"the AFC spread is computed on the {_name(model)}, which the stability analysis "
                                "reports unstable at the pumps' operating points (see the dynamics scenes): a "
                                "validation of the source's Fig. 3.7, not a prediction" if st is None else
                                f"the AFC model '{_name(model)}' is {'stable' if st else 'UNSTABLE'}")
        else:
            sec.validation.append({"ok": None, "text": "the source's AFC spread (Fig. 3.7, 'up to 40 %') was "
                                                       "computed on its program model, which is unstable; this run "
                                                       f"uses the {_name(model)} model (set "
                                                       "analyses.montecarlo.afc.model: program, forcing: appendix "
                                                       "and its 28 constants to reproduce the source)"})


def reliability_section(sec: Section) -> None:
    """Wear, reliability P(t) and mean time to failure of the traditional disc (Pavlenko 2014, ch. 1.2)."""
    sec.row("largest gap", "u_max", "u_max")
    sec.row("mean wear rate", "b̄", "b_mean")
    sec.row("mean load", "τ̄", "tau_mean")
    times = sec.get("times_h", [])
    for i, t in enumerate(times):
        sec.row(f"reliability at {number(t)} h (literal (1.48))", "P(t)", f"literal.P.{i}")
    sec.row("mean time to failure (literal)", "T", "literal.mttf_h")
    sec.row("mean time to failure (renormalised load density)", "T", "renormalised.mttf_h")
    level = sec.get("reliable_probability")
    for variant in ("literal", "renormalised"):
        t = sec.get(f"{variant}.time_at_h")
        p0 = sec.get(f"{variant}.P0")
        if t is None and level is not None:
            sec.verdict(False, f"{variant}: P(t) never reaches {number(level)} (P(0) = {number(p0)}): no time of "
                               "reliable operation")
        elif t is not None:
            sec.verdict(None, f"{variant}: P(t) ≥ {number(level)} up to t = {number(t)} h")


def rotor_dynamics_section(sec: Section) -> None:
    """Rotor with a liquid auto-balancer: stationary, steps, passage (Pashkov 2010); one verdict, the result's."""
    sec.row("critical speed with the liquid", "ω_cr", "rotor.omega_cr_rad_s")
    sec.row("natural frequency without liquid", "Ω0", "rotor.Omega0_rad_s")
    sec.row("liquid mass ratio", "ψ", "rotor.psi")
    sec.row("damping ratio", "ζ0", "rotor.zeta0")
    sec.row("largest real part of the eigenvalues over Ω0", "max Re λ/Ω0", "stationary.stability.max_real_over_Omega0")
    for psi, n in (sec.get("passage.crossover_n_star") or {}).items():  # keys like "0.75": the value given
        sec.row(f"damping above which the liquid raises the passage peak (ψ = {psi})", "n*",
                f"passage.crossover_n_star.{psi}", value=n)
    sec.row("speed at the end of the motor run-up", "ω_end", "motor_runup.omega_final_rad_s")
    sec.row("peak deflection of the motor run-up", "δ/e", "motor_runup.peak_deflection_over_e")
    from autobal.analysis.rotor_study import RotorDynamicsResult  # the verdict's one copy

    verdict = RotorDynamicsResult(sec.block).verdict()
    if verdict:
        sec.conclude(*verdict)
    rows = [[sec.cell(f"passage.table.{i}.{k}") for k in ("n", "psi", "delta_max_over_e", "z_delta_max", "d_max")]
            for i, _ in enumerate(sec.get("passage.table", []))]
    if rows:
        key = "passage.acceleration_rad_s2"
        accel = declarations("rotor_dynamics").find(key).text(sec.get(key))
        sec.tables.append(table(f"Passage through the critical speed at {accel}: peak "
                                "deflection δ*/e and its speed ratio ν = ω/Ω0",
                                ["n", "ψ", "δ*/e", "ν at the peak", "d*"], rows, headline=True))


def spinup_section(sec: Section) -> None:
    """Optimal spin-up through the critical speed (direct collocation, CVODES re-simulation): the verdict is the
    optimum's peak deflection, its gain against the best ramp within the drive limits and whether it brakes."""
    from autobal.ocp.spinup_study import verdict  # the verdict's one copy

    sec.conclude(*verdict(sec.block))
    sec.verdict(None, f"objective: {str(sec.get('objective', '')).replace('_', ' ')}; {sec.get('method')}; "
                      f"wall time {number(sec.get('wall_time_s'))} s (NLP build {number(sec.get('build_time_s'))} s, "
                      f"NLP solves {number(sec.get('total_solve_time_s'))} s over {len(sec.get('starts', []))} solves, "
                      "the rest global search, re-simulations and baselines)")
    sec.row("peak deflection of the optimum, 0-peak (the whirl orbit's radius; re-simulated)", "δ*",
            "peak_deflection_m")
    sec.row("peak deflection of the optimum over the eccentricity", "δ*/e", "peak_deflection_over_e")
    sec.row("peak deflection of the best ramp within the drive limits", "δ*/e", "baseline_ramp_peak_over_e")
    sec.row("gain against the best ramp within the drive limits", "", "gain_vs_best_feasible_ramp_pct")
    sec.row("gain against the constant ramp", "", "gain_vs_constant_ramp_pct")
    sec.row("eccentricity of the rotor", "e", "eccentricity_m")
    for label, sym, key in (("rotor mass", "m1", "mass_kg"),
                            ("shaft stiffness (c = m1 Ω_c²)", "c", "stiffness_N_per_m"),
                            ("damping (χ = 2 ζ m1 Ω_c)", "χ", "damping_N_s_per_m"),
                            ("damping ratio", "ζ", "damping_ratio"),
                            ("critical speed (with the liquid mass: Ω0 √ψ)", "ω_cr", "critical_speed_rad_s"),
                            ("amplification factor, API 684 (2005): N_c/(N_2 − N_1) = 1/(2ζ)", "AF",
                             "amplification_factor"),
                            ("separation margin of the final speed from the critical speed, API 684 (2005)", "SM",
                             "separation_margin_pct")):
        sec.row(label, sym, f"rotor.{key}")
    sec.row("time of the peak", "t*", "time_of_peak_s")
    sec.row("speed at the peak", "ω*", "omega_at_peak_rad_s")
    sec.row("final time", "T", "final_time_s")
    sec.row("largest drive torque", "M_max", "max_torque_N_m")
    sec.row("smallest drive torque (below 0: the drive brakes)", "M_min", "min_torque_N_m")
    sec.row("largest drive power", "P_max", "max_power_W")
    sec.row("relative difference, CVODES re-simulation vs transcription", "", "resimulation_rel_error")
    sec.row("chattering of the optimal acceleration (pulse variation of α/α_max; 0: none)", "",
            "control_pulse_variation")
    sec.row("NLP build time", "", "build_time_s")
    sec.row("NLP solve time (IPOPT or fatrop), all starts and mesh stages", "", "total_solve_time_s")
    sec.row("wall time of the analysis (search, solves, re-simulations)", "", "wall_time_s")
    st = sec.get("status")
    sec.verdict(st in ("Solve_Succeeded", "Solved_To_Acceptable_Level"), f"NLP solver: {st} ({sec.get('method')})")
    base = sec.get("baselines") or {}
    e = sec.get("eccentricity_m")
    rows = []
    for k, b in base.items():
        pk = b.get("peak_deflection_over_e")
        limits = {True: "within", False: "OUTSIDE: " + ", ".join(b.get("violated", [])), None: "no drive data"}
        rows.append([text(b.get("label")), sec.cell(f"baselines.{k}.peak_deflection_over_e"),
                     sec.cell("peak_deflection_m", None if pk is None or e is None else pk * e),
                     sec.cell(f"baselines.{k}.max_torque_N_m"), sec.cell(f"baselines.{k}.max_power_W"),
                     text(limits[b.get("within_drive_limits")]),
                     text("reference of the gain" if k == sec.get("baseline_ramp_key") else "")])
        if b.get("within_drive_limits") is False:
            sec.verdict(None, f"{b.get('label')}: outside the drive limits ({', '.join(b.get('violated', []))}), "
                              f"peak {number(pk)} e, drawn but no reference")
    if rows:
        sec.tables.append(table("Ramp baselines (re-simulated): a gain is quoted only against a ramp within the drive "
                                "limits", ["baseline", "peak δ*/e", "peak δ*, 0-peak", "largest torque",
                                           "largest power", "drive limits", ""], rows))
    if sec.get("brakes") is not None:
        sec.verdict(None, f"the optimum {'brakes' if sec.get('brakes') else 'does not brake'} (smallest drive "
                          f"torque {number(sec.get('min_torque_N_m'))} N·m; braking limit "
                          f"{number(sec.get('braking_torque_limit_N_m'))} N·m)")
    seg = sec.get("segments")
    if seg:
        sec.verdict(seg.get("within_drive_limits"),
                    f"{seg['segments']}-segment ramp table (drive_segments.csv): peak "
                    f"{number(seg.get('peak_deflection_over_e'))} e, {number(seg.get('loss_vs_optimum_pct'))} % "
                    "against the full optimum, " + ("within" if seg.get("within_drive_limits") else "OUTSIDE")
                    + " the drive limits")
    drive = _get(sec.results, "meta.scene_si.rotor.drive") or {}
    if not (drive.get("max_torque") or drive.get("max_power")):
        sec.verdict(None, "no drive torque or power limit in the scene")
    elif "within_drive_limits" in sec.block:
        sec.verdict(sec.get("within_drive_limits"), "drive torque and power limits " +
                    ("kept" if sec.get("within_drive_limits") else "EXCEEDED") + " in the re-simulation")
    for b in _spinup_binding(sec):
        sec.verdict(None, f"binding constraint: {b}")
    segs = sec.folder / "drive_segments.csv" if sec.folder else None
    if segs is not None and segs.exists():
        with segs.open() as fh:
            rows = [[text(r["segment"]), cell(float(r["t_start_s"]), "s"), cell(float(r["t_end_s"]), "s"),
                     text(number(float(r["speed_start_rpm"]))), text(number(float(r["speed_end_rpm"]))),
                     text(number(float(r["rate_rpm_s"]))), cell(float(r["rate_rad_s2"]), "rad/s^2")]
                    for r in csv.DictReader(fh)]
        sec.tables.append(table("Ramp table for the drive (drive_segments.csv; the last row the hold): speeds in "
                                "rpm, rates in rpm/s", ["segment", "start", "end", "start speed, rpm",
                                                        "end speed, rpm", "rate, rpm/s", "rate"], rows))
    keeps = {True: "yes", False: "NO", None: "—"}
    rows = [[text(s.get("start")), text(s.get("stage", "final mesh")), text(s.get("status")),
             text(s.get("iterations", "—")), cell(s.get("solve_time_s"), "s"), cell(s.get("objective"), "1"),
             text(keeps[s.get("keeps_limit")])] for s in sec.get("starts", [])]
    if rows:
        sec.tables.append(table("NLP solves of the multi-start: every start on the coarse mesh, the best one "
                                "refined on the final mesh and judged by its CVODES re-simulation",
                                ["start", "stage", "status", "iterations", "solve time", "re-simulated objective",
                                 "keeps limit"], rows))


def _spinup_binding(sec: Section) -> list[str]:
    """The limits the optimum runs on: acceleration (from the controls table), torque, power, deflection."""
    scene = _get(sec.results, "meta.scene_si") or {}
    ocp, drive = _get(scene, "analyses.spinup") or {}, _get(scene, "rotor.drive") or {}
    out = []
    amax, controls = ocp.get("max_acceleration"), sec.folder / "spinup_controls.csv" if sec.folder else None
    if amax and controls is not None and controls.exists():
        with controls.open() as fh:
            alpha = [float(r["alpha_rad_s2"]) for r in csv.DictReader(fh)]
        on = sum(abs(a) >= 0.999 * amax for a in alpha)
        if on:
            from autobal.ocp.simulation import rate_text  # rad/s² with rpm/s beside, the one copy

            out.append(f"acceleration limit |α| ≤ {rate_text(amax)} on {on} of {len(alpha)} control intervals "
                       f"({number(100 * on / len(alpha))} %)")
    for key, limit, what in (("max_torque_N_m", drive.get("max_torque"), "drive torque limit"),
                             ("max_power_W", drive.get("max_power"), "drive power limit")):
        got, q = sec.get(key), quantity(f"spinup.{key}")
        if limit and got is not None and got >= 0.999 * limit:
            out.append(f"{what} {q.text(limit)} reached (largest {q.text(got)})")
    lim = ocp.get("deflection_limit")
    if lim and sec.get("peak_deflection_over_e") is not None and sec.get("peak_deflection_over_e") >= 0.999 * lim:
        out.append(f"deflection limit δ/e ≤ {number(lim)} reached")
    if not out:
        out.append("none of the acceleration, torque, power and deflection limits is active at the optimum")
    return out


def spinup_robust_section(sec: Section) -> None:
    """Robust spin-up (the Jeffcott rotor's ``spinup_robust``, peaks delta/e; the modal rotor's
    ``ross_spinup_robust``, peaks in m shown in µm or the chosen length unit, as the block's ``peak_unit`` states):
    the robust profile, the nominal optimum and the best ramp on the design set and on the validation sample; the
    verdict is the robust profile's worst validation peak against the others'."""
    from autobal.ocp.robust_study import PEAK_SYMBOL, QUANTITIES, peak_key, verdict  # the verdict's one copy
    from autobal.ocp.spinup_study import QUANTITIES as SPINUP

    prof = sec.get("profiles") or {}
    if prof:
        sec.conclude(*verdict(sec.block))
    unit = sec.get("peak_unit") or "1"
    s, sym = peak_key(sec.block), PEAK_SYMBOL[unit]
    shown = None if unit == "1" else QUANTITIES.find(f"profiles.robust.validation_worst_{s}").display

    def pc(v):
        return cell(v, unit, shown)

    for key, label in (("robust", "robust profile"), ("nominal", "nominal optimum"), ("ramp", "best ramp")):
        sec.row(f"{label}: worst peak over the validation rotors", sym, f"profiles.{key}.validation_worst_{s}")
    sec.row("robust profile: worst peak over the design rotors (CVODES)", sym, f"profiles.robust.design_worst_{s}")
    sec.row("nominal critical speed", "ω_cr", "omega_cr_rad_s")
    sec.row("eccentricity (δ* = e δ*/e, 0-peak)", "e", "eccentricity_m")
    sec.row("design rotors (grid)", "", "design_scenarios")
    sec.row("design rotors in the final NLP (binding)", "", "active_scenarios")
    sec.row("validation rotors", "", "validation_samples")
    sec.row("build time (robust NLPs)", "", "build_time_s")
    sec.row("solve time (robust NLPs)", "", "solve_time_s")
    sec.row("validation time", "", "validation_time_s")
    sec.row("validation integrator against CVODES (largest relative difference)", "", "validation_check_rel_error")
    e = sec.get("eccentricity_m")
    physical = SPINUP.find("peak_deflection_m")
    rows = []
    for key in ("robust", "nominal", "ramp"):
        p = prof.get(key) or {}
        q = p.get(f"validation_quantiles_{s}") or {}
        worst = p.get(f"validation_worst_{s}")
        rows.append([text(p.get("label")), pc(p.get(f"nominal_peak_{s}")), pc(p.get(f"design_worst_{s}")),
                     pc(q.get("0.5")), pc(q.get("0.99")), pc(worst)]
                    + ([cell(None if e is None or worst is None else worst * e, "m", physical.display)]
                       if unit == "1" else []))
    if prof:
        what = ("δ*/e", "; the worst as a deflection δ* (0-peak)") if unit == "1" else \
            ("r* (the largest whirl radius over the nodes, 0-peak)", "")
        sec.tables.append(table(f"Peak deflection {what[0]} of each profile: on the nominal rotor, worst over the "
                                f"design set (CVODES), and over the validation sample{what[1]}",
                                ["profile", "nominal rotor", "design worst", "validation median", "validation 99 %",
                                 "validation worst"] + (["validation worst δ*"] if unit == "1" else []), rows,
                                headline=True))
    rows = [[text(r.get("label")), sec.cell(f"ramps.{i}.alpha_rad_s2"), pc(r.get(f"design_worst_{s}")),
             pc(r.get(f"validation_worst_{s}")),
             text({True: "within", False: f"OUTSIDE: {r.get('violated')}", None: "no drive data"}
                  [r.get("within_drive_limits")])] for i, r in enumerate(sec.get("ramps") or [])]
    if rows:
        sec.tables.append(table(f"Constant ramps: worst peak {sym} over the design set and the validation sample",
                                ["ramp", "acceleration", "design worst", "validation worst", "drive limits"], rows))
    rows = [[text(r.get("start")), cell(r.get("intervals"), "1"), cell(r.get("scenarios"), "1"), text(r.get("status")),
             cell(r.get("iterations"), "1"), cell(r.get("build_time_s"), "s"), cell(r.get("solve_time_s"), "s"),
             pc(r.get(f"worst_design_peak_{s}"))] for r in sec.get("rounds", [])]
    if rows:
        sec.tables.append(table("Scenario generation: each NLP solve", ["start", "intervals", "scenarios", "status",
                                                                        "iterations", "build", "solve",
                                                                        f"worst design {sym}"], rows))


def spinup_time_optimal_section(sec: Section) -> None:
    """Time-optimal spin-up: the earliest arrival under the peak limit (the verdict) and the front."""
    from autobal.ocp.time_optimal_study import verdict  # the verdict's one copy

    sec.conclude(*verdict(sec.block))
    sec.row("final speed", "ω_f", "final_speed_rad_s")
    sec.row("peak limit", "δ/e", "deflection_limit_over_e")
    sec.row("earliest arrival at the final speed", "T", "arrival_time_s")
    sec.row("latest front deadline whose minimum peak exceeds the limit", "", "arrival_time_lower_bound_s")
    sec.row("peak deflection of the earliest arrival (re-simulated)", "δ*/e", "peak_deflection_over_e")
    sec.row("arrival of the maximum-acceleration ramp", "", "ramp_arrival_time_s")
    sec.row("peak of the maximum-acceleration ramp", "δ*/e", "ramp_peak_over_e")
    sec.row("eccentricity (δ* = e δ*/e, 0-peak)", "e", "eccentricity_m")
    sec.row("largest relative difference, collocation vs CVODES re-simulation", "", "resimulation_rel_error")
    sec.row("build time", "", "build_time_s")
    sec.row("solve time", "", "solve_time_s")
    if sec.get("deflection_limit_over_e") is not None:  # else the front's monotonicity is the verdict
        sec.verdict(sec.get("monotone"), "the front's peak does not rise with the arrival deadline"
                    if sec.get("monotone") else "the front is NOT monotone (a local optimum)")
    from autobal.ocp.spinup_study import QUANTITIES as SPINUP

    e, physical = sec.get("eccentricity_m"), SPINUP.find("peak_deflection_m")
    rows = [[cell(p.get("arrival_time_s"), "s"), cell(p.get("resimulated_peak_over_e"), "1"),
             cell(None if e is None else p.get("resimulated_peak_over_e") * e, "m", physical.display),
             cell(p.get("collocation_peak_over_e"), "1"), cell(p.get("resimulation_rel_error"), "1"),
             cell(p.get("intervals"), "1"), cell(p.get("solve_time_s"), "s"),
             text(f"held from {number(p['held_from_s'])} s" if p.get("held_from_s") else "")]
            for p in sec.get("front", [])]
    if rows:
        sec.tables.append(table("Front: the smallest peak for each arrival deadline",
                                ["arrival by", "δ*/e (re-simulated)", "δ* (0-peak)", "δ*/e (collocation)",
                                 "difference", "intervals", "solve time", "profile"], rows, headline=True))


def design_section(sec: Section) -> None:
    """Stability-constrained design: the optimum's verdict with its margin to the required decay rate, its
    certificate, the parameters in display units; the designs under the source's models in the validation part."""
    from autobal.analysis import design_study as ds  # the verdicts, declarations and validation: one copy each

    ok, words = ds.verdict(sec.block)
    sec.conclude(ok, words)
    sec.verdict(sec.get("status") in ds.SUCCESS, f"IPOPT: {sec.get('status')} ({sec.get('iterations')} iterations)")
    for q, key, _ in ds.QUANTITIES.headline(sec.block):
        sec.row(q.description, q.symbol, key)
    for which in ("nominal", "optimum"):  # keys are the discharge ratios ("0.5"), so read them whole
        for p, margin in (sec.get(f"{which}.margin") or {}).items():
            if not p.endswith("_status"):
                sec.row(f"decay rate at ψ1 = {p}, {which} design", "−max Re λ", f"{which}.margin.{p}", value=margin)
    sec.verdict(*ds.verdict(sec.block, "nominal"))
    for model, text_ in ds.source_models(sec.block):
        sec.validation.append({"ok": None, "text": text_ + (f"; the headline verdict stands: {WHY_UNSTABLE[model]}"
                                                            if "UNSTABLE" in text_ and model in WHY_UNSTABLE else "")})
    cert = sec.get("certification") or {}
    if cert:
        sec.verdict(bool(cert.get("eigenvalues_ok")), "eigenvalues confirm every constraint at the optimum"
                    if cert.get("eigenvalues_ok") else "eigenvalues do NOT confirm the smooth stability conditions")
        sec.verdict(not cert.get("beaten"), f"random search: {cert.get('feasible_samples')} of {cert.get('samples')} "
                    f"samples feasible, best {significant(cert.get('best_sample'))} "
                    + ("(none better by more than 0.5 %)" if not cert.get("beaten") else "BEATS the optimum"))
    for a in sec.get("active", []):
        sec.verdict(None, f"active constraint: {a.get('constraint')} (multiplier {significant(a.get('multiplier'))})")
    nominal, optimum = sec.get("nominal.values_si") or {}, sec.get("optimum.values_si") or {}
    rows = []
    for path, value in optimum.items():
        q, n = ds.variable(path), nominal.get(path)
        ratio = value / n if is_number(n) and n and is_number(value) else None
        rows.append([text(path), text(q.symbol), text(q.text(n)), text(q.text(value)),
                     text("—" if ratio is None else f"× {significant(ratio, 3)}")])
    if rows:
        sec.tables.append(table("Design parameters to 4 significant digits (results.json optimum.parameters holds "
                                "them in full: `autobal run SCENE --set PATH=VALUE` reproduces the optimum)",
                                ["scene path", "symbol", "nominal", "optimum", "optimum / nominal"], rows))


def ross_spinup_section(sec: Section) -> None:
    """Optimal spin-up of a ROSS rotor reduced to its modes: the optimum's peak against the best ramp (the verdict),
    the reduction checked against ROSS, API 684 (2005) values of each critical speed."""
    from autobal.ocp.modal import ModalSpinupResult  # the verdict's one copy

    st = sec.get("status")
    sec.conclude(*ModalSpinupResult.verdict_of(sec.block))
    sec.row("peak deflection of the optimum, 0-peak (re-simulated)", "r*", "peak_deflection_m")
    sec.row("peak deflection of the best ramp", "r*", "baseline_ramp_peak_m")
    sec.row("improvement over the best ramp", "", "improvement_over_best_ramp")
    sec.row("node of the peak", "", "node_of_peak")
    sec.row("time of the peak", "t*", "time_of_peak_s")
    sec.row("speed at the peak", "ω*", "omega_at_peak_rad_s")
    sec.row("final (service) speed", "ω_f", "final_speed_rad_s")
    sec.row("modes kept", "", "modes")
    sec.row("mode cutoff", "ω_c", "mode_cutoff_rad_s")
    sec.row("shift of a critical speed by the gyroscopic terms", "", "gyroscopic_shift")
    sec.row("largest critical-speed difference vs ROSS", "", "critical_speeds.max_rel_error_vs_ross")
    sec.row("relative difference, CVODES re-simulation vs collocation", "", "resimulation_rel_error")
    sec.row("build time", "", "build_time_s")
    sec.row("solve time (all starts)", "", "total_solve_time_s")
    sec.verdict(st in ("Solve_Succeeded", "Solved_To_Acceptable_Level"), f"IPOPT: {st} ({sec.get('method')})")
    err = sec.get("critical_speeds.max_rel_error_vs_ross")
    if err is not None:
        sec.verdict(err <= 0.01, f"critical speeds of the reduced model within {number(100 * err)} % of ROSS's")
    cs = sec.get("critical_speeds") or {}
    ross = cs.get("ross_wd_rad_s") or []
    rows = []
    for i, w in enumerate(cs.get("reduced_wd_rad_s") or []):
        at = f"critical_speeds.{{}}.{i}"
        rows.append([text(str(i + 1)), cell(w, "rad/s"), cell(convert(w, "rad/s", "rpm"), "rpm"),
                     cell(ross[i] if i < len(ross) else None, "rad/s"),
                     sec.cell(at.format("reduced_damping_ratio")),
                     sec.cell(at.format("amplification_factor")) if _has(sec.block, at.format("amplification_factor"))
                     else text(None),
                     sec.cell(at.format("separation_margin_pct")) if _has(sec.block, at.format("separation_margin_pct"))
                     else text(None)])
    if rows:
        sec.tables.append(table("Critical speeds below the final speed, with the API 684 (2005) amplification factor "
                                "1/(2ζ) and the separation margin of the final speed",
                                ["#", "reduced model", "reduced model, rpm", "ROSS", "damping ratio", "AF", "SM"],
                                rows))


SECTIONS = {"statics": statics_section, "frequency": frequency_section, "stability": stability_section,
            "transient": transient_section, "liquid_balancer": liquid_balancer_section,
            "estimation": estimation_section, "reliability": reliability_section, "montecarlo": montecarlo_section,
            "rotor_dynamics": rotor_dynamics_section, "spinup": spinup_section,
            "spinup_robust": spinup_robust_section, "spinup_time_optimal": spinup_time_optimal_section,
            "design": design_section,
            "ross_spinup": ross_spinup_section, "ross_spinup_robust": spinup_robust_section}

TITLES = {"statics": "Statics", "frequency": "Frequency response (AFC)", "stability": "Stability",
          "transient": "Transients", "liquid_balancer": "Liquid auto-balancer", "estimation": "Parameter estimation",
          "reliability": "Reliability", "montecarlo": "Monte Carlo", "rotor_dynamics": "Rotor dynamics",
          "spinup": "Optimal spin-up", "spinup_robust": "Robust spin-up", "spinup_time_optimal": "Time-optimal spin-up",
          "design": "Stability-constrained design",
          "ross_spinup": "Optimal spin-up of a ROSS rotor (multi-mode)",
          "ross_spinup_robust": "Robust spin-up of a ROSS rotor (multi-mode)"}

#: figure file name (regex) -> (analysis, caption)
CAPTIONS = [
    (r"fig_pressures", "statics", "Chamber pressures (MPa; ψ = p/p_B on the right) against the discharge pressure, "
                                  "exact (solid) and the source's closed forms (dashed); Pavlenko (2014), Fig. 2.4 / "
                                  "2.9"),
    (r"fig_gap", "statics", "Face gap z (u = z/z_B) and valve opening x (ξ = x/x_B) against the discharge pressure; "
                            "Pavlenko (2014), Fig. 2.5"),
    (r"fig_flows", "statics", "Flows (L/min; Q/Q_B on the right) against the discharge pressure, reversed flows cut "
                              "and annotated; Pavlenko (2014), Fig. 2.6 / 2.10"),
    (r"fig_force_gap", "statics", "Balancing force φ(u) against the face gap at the operating ψ1 and the load τ − χ; "
                                  "Pavlenko (2014), Eq. (2.35)"),
    (r"fig_afc", "frequency", "Amplitude and phase of the face-gap response (AFC): the headline energy-consistent "
                              "model under the physical forcing (thick), the other models under the scene's forcing, "
                              "unstable ones dashed and labelled; Pavlenko (2014), §2.6"),
    (r"fig_poles", "stability", "Poles per model (right half-plane = unstable)"),
    (r"fig_stability_map_(\w+)", "stability", "Stability map of the {0} model: largest real part of the poles over "
                                              "two parameters, the nominal design marked"),
    (r"fig_transients", "transient", "Nonlinear transients of the face gap and the chamber pressures"),
    (r"fig_liquid_efficiency", "liquid_balancer", "Efficiency λ0 against the speed ratio γ, the source's variants and "
                                                  "the self-consistent closure, with Khomyak (2020) Table 3.2"),
    (r"fig_liquid_optimum", "liquid_balancer", "Efficiency against liquid height and volume: the IPOPT optimum and a "
                                               "dense grid"),
    (r"fig_estimation_(\w+)", "estimation", "Fit {0}: data, fitted curve and its 95 % band; "
                                             "Pavlenko (2014), Table 4.3"),
    (r"fig_montecarlo_afc", "montecarlo", "AFC amplitude over the sampled parameters (by default the "
                                          "energy-consistent model under the physical forcing, its dynamic data "
                                          "uncertain): nominal, mean, the 0.135-99.865 % quantile band and the ±3σ "
                                          "lines"),
    (r"fig_montecarlo_hist", "montecarlo", "Distribution of the face gap and the face leak at the reference "
                                           "discharge ratio, with the fitted normal, ±3σ and the quantiles"),
    (r"fig_montecarlo", "montecarlo", "Face gap, valve opening and leak over the samples against ψ1: mean and "
                                      "0.135-99.865 % quantile bands; Pavlenko (2014), Figs. 3.8-3.9"),
    (r"fig_reliability", "reliability", "Reliability P(t) (literal and renormalised load density) and the wear "
                                        "probability; Pavlenko (2014), Figs. 1.27-1.28"),
    (r"fig_rotor_(\w+)", "rotor_dynamics", "Rotor with a liquid auto-balancer: {0} (Pashkov 2010)"),
    (r"spinup_robust_profiles", "spinup_robust", "Robust spin-up: speed of the robust profile, the nominal optimum "
                                                 "and the best ramp, and their deflection on the worst design rotor"),
    (r"spinup_robust_distribution", "spinup_robust", "Robust spin-up: distribution of the peak deflection over the "
                                                     "validation rotors, each profile"),
    (r"spinup_robust_scatter", "spinup_robust", "Robust spin-up: peak deflection of each validation rotor against "
                                                "its critical-speed factor"),
    (r"spinup_time_optimal_front", "spinup_time_optimal", "Time-optimal spin-up: the smallest re-simulated peak "
                                                          "against the arrival deadline, the ramp and the earliest "
                                                          "arrival under the limit"),
    (r"spinup_time_optimal_profiles", "spinup_time_optimal", "Time-optimal spin-up: speed and deflection of the "
                                                             "front's points"),
    (r"ross_spinup_robust_(profiles|distribution|scatter)", "ross_spinup_robust", "Robust spin-up of the ROSS rotor "
                                                                                   "(multi-mode): {0}, peaks in µm"),
    (r"ross_spinup_(\w+)", "ross_spinup", "Multi-mode spin-up: {0} of the optimum beside the ramps, critical "
                                          "speeds of the reduced model dotted"),
    (r"ross_campbell", "ross_spinup", "Campbell diagram of the reduced rotor: damped natural frequencies against "
                                      "speed, critical speeds of the reduced model (o) and of ROSS (x)"),
    (r"spinup_(\w+)", "spinup", "Optimal spin-up: {0} of the optimum beside the ramps"),
    (r"design_abscissa", "design", "Spectral abscissa max Re λ against the discharge ratio, nominal and optimum "
                                   "designs, with the required −α"),
    (r"design_parameters", "design", "Design parameters: optimum relative to nominal"),
    (r"design_convergence", "design", "IPOPT convergence of the design NLP"),
]


def caption(name: str) -> tuple[str | None, str]:
    """(analysis, caption) of a figure file."""
    stem = Path(name).stem
    for pattern, analysis, words in CAPTIONS:
        m = re.fullmatch(pattern, stem)
        if m:
            return analysis, words.format(*(g.replace("_", " ") for g in m.groups()))
    return None, stem.replace("_", " ")


def data_uri(path: Path) -> str:
    kind = {".png": "image/png", ".svg": "image/svg+xml", ".jpg": "image/jpeg"}[path.suffix.lower()]
    return f"data:{kind};base64," + base64.b64encode(report_input.read_regular(path, MAX_FIGURE_BYTES)).decode("ascii")


FIGURE_SUFFIXES = (".png", ".svg", ".jpg")


def _figures(folder: Path, results: dict) -> dict[str, list[dict]]:
    """analysis -> its figures {name, caption, uri}, from results.json ``outputs`` or the file names."""
    outputs = results.get("outputs") if isinstance(results.get("outputs"), dict) else {}
    owner = {f: name for name, files in outputs.items() if isinstance(files, list) for f in files
             if isinstance(f, str)}
    named = results.get("files")
    names = [n for n in (named if isinstance(named, list) and named else sorted(p.name for p in folder.iterdir()))
             if isinstance(n, str)]
    pngs = {n[:-4] for n in names if n.lower().endswith(".png")}
    out: dict[str, list[dict]] = {}
    refused = []
    for name in names:
        if Path(name).suffix.lower() not in FIGURE_SUFFIXES or name.lower().endswith(".svg") and name[:-4] in pngs:
            continue  # a figure's SVG beside its PNG is for documents: the page embeds the PNG
        path, out_of_folder = report_input.figure(folder, name)
        refused += [name] if out_of_folder else []
        if path is None:
            continue
        analysis, words = caption(name)
        out.setdefault(owner.get(name, analysis) or "", []).append({"name": name, "caption": words,
                                                                   "uri": data_uri(path)})
    if refused:
        shown = ", ".join(text_clean(n, 60) for n in refused[:3]) + (", …" if len(refused) > 3 else "")
        warnings.warn(f"{folder / 'results.json'} names {len(refused)} file(s) outside the folder ({shown}): "
                      f"not embedded", stacklevel=2)
    return out


# --------------------------------------------------------------------------------------------
# inputs: as given (the scene file and --set) and in SI
# --------------------------------------------------------------------------------------------
def _flat(data, path: str = "") -> dict:
    if isinstance(data, dict):
        out = {}
        for k, v in data.items():
            out |= _flat(v, f"{path}.{k}" if path else str(k))
        return out
    return {path: data}


def _si_unit_of(given) -> str:
    """The SI unit of a value written with a unit ('0.35 mm' -> 'm'), '' if it has none."""
    return si_unit_of(given).replace("**", "^")


def _scene_file(name) -> bytes | None:
    """The bytes of the scene file results.json names, None when it is not a readable regular file."""
    if not isinstance(name, str) or not name:
        return None
    try:
        return report_input.read_regular(Path(name), MAX_SCENE_BYTES)
    except ScenarioError:
        return None


def inputs(meta: dict) -> tuple[list[list[dict]], str]:
    """Rows (path, as given, SI value, SI unit) of the scene, and where the 'as given' column came from."""
    given, where = {}, "the scene file is not available: SI values only"
    raw = _scene_file(meta.get("file"))
    if raw is not None and hashlib.sha256(raw).hexdigest() == meta.get("sha256"):
        path = Path(meta["file"])
        given = _flat(yaml.safe_load(raw.decode("utf-8")) or {})
        where = f"as given in {path.name} (sha256 {meta['sha256'][:12]}…)"
    overrides = meta.get("overrides") or {}
    given |= {k: f"{v} (--set)" for k, v in overrides.items()}
    rows = []
    for key, si in _flat(meta.get("scene_si") or {}).items():
        g = given.get(key)
        if key in ("name", "title", "source") or si is None and g is None:
            continue  # shown at the top / a part the scene does not have
        unit = _si_unit_of(g.removesuffix(" (--set)") if isinstance(g, str) else g)
        shown = json.dumps(si) if isinstance(si, list | dict) else si
        rows.append([text(key), text("(default)" if g is None else json.dumps(g) if isinstance(g, list | dict) else g),
                     {"text": number(shown) if is_number(shown) else str(shown), "unit": pretty_unit(unit) if unit
                      else "", "num": is_number(shown)}, text(pretty_unit(unit) if unit else "")])
    return rows, where


# --------------------------------------------------------------------------------------------
# rendering
# --------------------------------------------------------------------------------------------
def css_string(value, width: int = 90) -> Markup:
    """``value`` as a quoted CSS string for the page's running header, cut to ``width`` characters: everything
    but letters, digits and plain punctuation written as a CSS escape, so no text can leave the string or
    the ``<style>`` element."""
    value = text_clean(value, width)
    return Markup('"' + "".join(c if c.isascii() and (c.isalnum() or c in " .,:;_-()+") else f"\\{ord(c):x} "
                               for c in value) + '"')  # the space ends the escape (and is not shown)


def _environment() -> jinja2.Environment:
    files = resources.files("autobal") / "templates"
    loader = jinja2.DictLoader({p.name: p.read_text(encoding="utf-8") for p in files.iterdir()
                                if p.name.endswith((".j2", ".css"))})
    env = jinja2.Environment(loader=loader, autoescape=True, trim_blocks=True, lstrip_blocks=True)
    env.filters["css_string"] = css_string
    return env


def _section(name: str, block: dict, results: dict, figures: list[dict], folder: Path) -> dict:
    sec = Section(name, block, results, folder)
    error = None
    try:
        SECTIONS[name](sec)
        _comparison(sec, results.get("scenario", ""))
    except Exception as exc:  # noqa: BLE001 (a report must not fail a run; it says what it could not show)
        error = f"this section could not be rendered: {type(exc).__name__}: {exc}"
    note = _null_note(block, name)
    if note:
        sec.notes.append(note)
    acc = (results.get("accuracy") or {}).get(name) or block.get("accuracy") or {}
    tables = [t for t in (sec.headline(), *sec.tables) if t is not None]
    failures = [f for f in block.get("failures") or [] if isinstance(f, str)]
    overall = ({"ok": False, "text": "FAILED: " + "; ".join(failures)} if failures  # never ok over a failure
               else {"ok": False, "text": error} if error else sec.overall())
    return {"name": name, "title": TITLES.get(name, name), "tables": tables, "verdicts": sec.verdicts,
            "overall": overall, "comparison": sec.comparison, "validation": sec.validation,
            "validation_tables": sec.validation_tables, "validation_notes": sec.validation_notes,
            "warnings": sec.warnings, "notes": sec.notes,
            "figures": figures,
            "accuracy": {"estimate": acc.get("estimate"), "how": acc.get("how", "")},
            "run_time": (results.get("timing") or {}).get(name), "error": error}


def _iterate_rows(it) -> list[list[str]]:
    """The solver's last iterate as (key, what) rows: scalars as they are, lists by size and ends."""
    rows = []
    for key, v in _flat(it if isinstance(it, dict) else {"x": it}).items():
        if isinstance(v, list):
            flat = list(flatten(v))
            ends = f"{number(flat[0])} … {number(flat[-1])}" if flat and all(is_number(x) for x in flat) else ""
            rows.append([key, f"{len(flat)} values {ends}".strip()])
        else:
            rows.append([key, number(v) if is_number(v) else str(v)])
    return rows


def display_choice(meta, units: dict | None = None) -> dict[str, str]:
    """kind -> display unit of a report: the ``display`` section of the run's scene (results.json
    ``meta.scene_si.display``), updated with ``units`` (``autobal report --units``); ScenarioError naming the
    key for a unit that is not one of its kind."""
    scene = _get(meta, "scene_si.display") if isinstance(meta, dict) else None
    try:
        given = checked_choice(scene) if isinstance(scene, dict) else {}
    except ValueError as exc:
        raise ScenarioError(f"results.json meta.scene_si.display: {text_clean(exc)}") from None
    try:
        return given | checked_choice(units)
    except ValueError as exc:
        raise ScenarioError(f"units: {text_clean(exc)}") from None


def context(folder: Path, units: dict | None = None) -> dict:
    """Everything the template shows, from the files of ``folder``, numbers in the display units of the run's
    scene (its ``display`` section) updated with ``units`` (kind -> display unit)."""
    folder = report_input.folder_of(folder)
    status_file = next((folder / n for n in STATUS_FILES if report_input.present(folder, n)), None)
    results_file = folder / "results.json"
    if report_input.present(folder, results_file.name):
        results = report_input.read_json(results_file)
        failure = None
    elif status_file is not None:
        results = {}
        failure = report_input.read_json(status_file) | {"file": status_file.name}
    else:
        raise ScenarioError(f"{text_clean(folder)}: holds neither results.json nor {', '.join(STATUS_FILES)}")
    if failure is not None:
        it = failure.get("last_iterate")
        failure["last_iterate_rows"] = _iterate_rows(it)
    figures = _figures(folder, results)
    names = [k for k in results if k in SECTIONS]
    meta = results.get("meta") or (failure or {}).get("meta") or {}
    meta = meta if isinstance(meta, dict) else {}
    display = display_choice(meta, units) | current_choice()  # a caller's display_units block over both
    with display_units(display):
        sections = [_section(n, results[n], results, figures.pop(n, []), folder) for n in names]
    rows, where = inputs(meta)
    others = [f for figs in figures.values() for f in figs]
    summary = [{"section": sec["title"], "name": sec["name"], **sec["overall"]} for sec in sections if sec["overall"]]
    return {"results": results, "failure": failure, "sections": sections, "summary": summary, "other_figures": others,
            "inputs": rows, "inputs_where": where, "meta": meta, "overrides": meta.get("overrides") or {},
            "display": display,
            "title": text_clean(results.get("title") or (failure or {}).get("title") or "autobal run", 500),
            "scenario": text_clean(results.get("scenario") or (failure or {}).get("scenario") or "—"),
            "log": report_input.present(folder, "autobal.log")}


def sections(results: dict) -> list[dict]:
    """The report's section of every analysis of a results.json mapping, without figures: its one verdict
    (``overall``), tables in display units, validation part, warnings."""
    return [_section(n, results[n], results, [], None) for n in results if n in SECTIONS]


def notebook(results: dict, figures: dict[str, list[str]] | None = None) -> str:
    """A run as a notebook cell's HTML: per analysis its one verdict, its headline table in display units and
    ``figures[analysis]`` (HTML ``<img>`` elements)."""
    results = plain(results)
    with display_units(display_choice(results.get("meta")), under=True):
        return _notebook(results, figures)


def _notebook(results: dict, figures: dict[str, list[str]] | None) -> str:
    out = [f"<div><h2>{html_escape(results.get('title') or '')}</h2>"
           f"<p>scene <b>{html_escape(results.get('scenario', ''))}</b></p>"]
    for sec in sections(results):
        out.append(f"<h3>{html_escape(sec['title'])}</h3>")
        if sec["overall"]:
            out.append(html_verdict((sec["overall"]["ok"], sec["overall"]["text"])))
        for t in sec["tables"][:1]:
            head = "".join(f"<th>{html_escape(c)}</th>" for c in t["columns"])
            body = "".join("<tr>" + "".join(f"<td>{html_escape(c['text'])}"
                                            + (f" {html_escape(c['unit'])}" if c.get("num") and not t["unit_column"]
                                               and c["unit"] != "dimensionless" else "") + "</td>" for c in row)
                           + "</tr>" for row in t["rows"])
            out.append(f"<table><caption>{html_escape(t['caption'])}</caption><tr>{head}</tr>{body}</table>")
        out.extend((figures or {}).get(sec["name"], []))
    return "".join(out) + "</div>"


def html(folder: str | Path, units: dict | None = None) -> str:
    """The report of an output folder as an HTML string (``units``: as :func:`render`)."""
    return _environment().get_template("report.html.j2").render(**context(Path(folder), units))


def render(folder: str | Path, units: dict | None = None) -> Path:
    """Write ``report.html`` into an output folder (from its results.json or status file); returns its path.

    Parameters
    ----------
    folder : str or Path
        An output folder of ``autobal run`` (or :meth:`autobal.api.Run.save`).
    units : dict, optional
        Kind -> display unit (``{"pressure": "bar"}``, see :data:`autobal.analysis.quantities.KINDS`), over
        the ``display`` section of the run's scene.  The tables change; the figures keep the units of the run.

    Returns
    -------
    Path
        ``folder/report.html``, self-contained: figures embedded as data URIs, no external resources.

    Raises
    ------
    ScenarioError
        The folder holds neither results.json nor a status file of a failed run.
    """
    page = html(folder, units)
    out = Path(folder) / REPORT
    try:
        out.write_text(page, encoding="utf-8")
    except OSError as exc:  # a read-only folder, a full disk
        raise ScenarioError(f"{text_clean(out)}: cannot be written ({exc.strerror})") from None
    return out
