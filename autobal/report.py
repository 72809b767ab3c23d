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
import contextlib
import functools
import hashlib
import importlib
import inspect
import json
import math
import os
import re
import tempfile
import warnings
from collections.abc import Mapping
from html import escape as html_escape
from importlib import resources
from pathlib import Path

import jinja2
import yaml
from markupsafe import Markup

from autobal import analyses as rooms
from autobal import report_input
from autobal.analysis.run.fields import STATUS, Record, field_key, place
from autobal.analysis.run.quantities import (
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
from autobal.analysis.run.result import Result, html_verdict, plain
from autobal.errors import ScenarioError
from autobal.output import umask
from autobal.report_input import MAX_FIGURE_BYTES
from autobal.scenario import MAX_FILE_BYTES as MAX_SCENE_BYTES
from autobal.text import clean as text_clean
from autobal.units import si_unit_of

REPORT = "report.html"
STATUS_FILES = ("failed_solve.json", "interrupted.json", "error.json")


class _FromRooms(Mapping):
    """analysis -> ``name`` defined in its room (``autobal/analyses/<key>.py``), read when asked: a look-up
    imports that room only (a statics report imports no dynamics); iterating imports every room."""

    def __init__(self, name: str):
        self.name = name

    def __contains__(self, key) -> bool:
        return key in rooms.MODULES and hasattr(rooms.module(key), self.name)

    def __getitem__(self, key: str):
        if key not in self:
            raise KeyError(key)
        return getattr(rooms.module(key), self.name)

    def __iter__(self):
        return (key for key in rooms.MODULES if key in self)

    def __len__(self) -> int:
        return sum(1 for _ in self)


# --------------------------------------------------------------------------------------------
# units of the results.json keys: the declarations of each Result class (analysis/run/quantities.py)
# --------------------------------------------------------------------------------------------
#: analysis -> the module whose QUANTITIES declare every number of its block, named by its room
#: (``QUANTITIES_MODULE``; the declarations are imported when a report needs them)
DECLARED: Mapping = _FromRooms("QUANTITIES_MODULE")

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


@functools.cache
def result_class(analysis: str) -> type | None:
    """The Result class of an analysis: the one its declaring module (the room's ``QUANTITIES_MODULE``) defines
    for it, or None for a key that is no analysis."""
    if analysis not in DECLARED:
        return None
    module = importlib.import_module(DECLARED[analysis])
    own = [c for c in vars(module).values()
           if isinstance(c, type) and issubclass(c, Result) and c.__module__ == module.__name__ and c.name]
    return next((c for c in own if c.name == analysis), own[0] if len(own) == 1 else None)


def load_result(analysis: str, block: dict, folder: Path | None = None) -> Result:
    """The Result of an analysis rebuilt from its results.json block: a typed Result (analysis/run/fields.py) by its
    ``from_dict``; a Result that holds only ``data`` with the block as its data, if its ``to_dict()`` gives the
    block back.  ValueError naming the analysis where neither works (a Result that holds more than its block:
    samples, curves, solver runs)."""
    cls = result_class(analysis)
    if cls is None:
        raise ValueError(f"{analysis}: no analysis of this name")
    if issubclass(cls, Record):
        return cls.from_folder(block, folder)  # with what the run's files in ``folder`` hold (its CSV tables)
    try:
        result = cls(data=block, **({"name": analysis} if "name" in inspect.signature(cls).parameters else {}))
        same = plain(result.to_dict()) == plain(block)
    except (TypeError, KeyError) as exc:
        same, result = False, exc
    if not same:
        raise ValueError(f"{analysis}: {cls.__name__} holds more than its results.json block"
                         + (f" ({type(result).__name__}: {result})" if isinstance(result, Exception) else ""))
    return result


def get_path(data, path: str, default=None):
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
    ``shown`` (default: the unit chosen for its kind, else the field's unit of analysis/run/quantities.py, µm for
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
    """The report section of one analysis, filled by ``report_section(sec)`` of its room (SECTIONS)."""

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

    @functools.cached_property
    def result(self) -> Result:
        """The analysis' Result loaded from its block (:func:`load_result`): what a typed section reads."""
        return load_result(self.name, self.block, self.folder)

    def get(self, path: str, default=None):
        return get_path(self.block, path, default)

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
        if value is None and not has_path(self.block, path):
            return
        typed, declared = result_class(self.name), quantity(f"{self.name}.{path}", self.results)
        if typed is not None and issubclass(typed, Record) and not unit and declared is None:
            raise KeyError(f"{self.name}.{path}: no field of {type(self.result).__name__} declares it")
        v = self.get(path) if value is None else value
        c = cell(v, unit) if unit else self.cell(path, v)
        c["key"] = f"{self.name}.{path}"
        note = f"{note} {self.get(path + '_status') or ''}"
        si = unit or getattr(declared, "unit", None) or self.unit(path)
        if si is not None and is_number(v) and beside(si, c["unit"]):  # speeds, accelerations in the other units
            others = ("rad/s", "rpm", "Hz") if is_display_unit("rpm", si) else ("rad/s²", "rpm/s")
            note = " = ".join(f"{number(convert(v, si, u))} {u}" for u in others if u != c["unit"]) + f" {note}"
        self.rows.append([text(label), text(symbol), c, text(c["unit"]), text(note.strip())])

    def rows_of(self, rec: Record, *names: str, label=None, note: str = "") -> None:
        """Headline rows of the fields ``names`` of ``rec`` (``sec.result`` or a record it holds; its key path is
        its place in the Result), each labelled by its declaration's description and symbol; a list or mapping of
        numbers gives a row per item (key ``<key>.<i>``, ``<key>.<name>``), labelled ``label(i or name)`` where
        the declaration's words cannot tell the items apart; ``label`` a string: the label of one field's row where
        the scene decides its words (the critical speed with or without a liquid layer).  A name that is no field
        of ``rec`` is a KeyError at once: a renamed field leaves no stale row."""
        if label is not None and len(names) != 1:
            raise ValueError("a label names the row(s) of one field")
        at = place(self.result, rec)
        keys = [at + field_key(rec, name) for name in names]  # every name checked before a row is written
        for name, key in zip(names, keys, strict=True):
            v = plain(getattr(rec, name))
            items = (enumerate(v) if isinstance(v, list) else
                     [(k, x) for k, x in v.items() if not k.endswith(STATUS)] if isinstance(v, dict) else [(None, v)])
            for item, x in items:
                path = key if item is None else f"{key}.{item}"
                q = self.result.quantities.find(path, self.block)
                if q is None:
                    raise KeyError(f"{self.name}.{path}: no declaration")
                if isinstance(label, str):
                    words = label
                elif label is not None and item is not None:
                    words = label(item)
                else:
                    words = q.description
                self.row(words, q.symbol, path, value=x, note=note)

    def headline_rows(self, notes: Mapping | None = None) -> None:
        """The rows of the Result's fields declared ``headline=N``, in that order; ``notes``: key -> its note."""
        r = self.result
        for q, key, v in r.quantities.headline(r.to_dict()):
            self.row(q.description, q.symbol, key, value=v, note=(notes or {}).get(key, ""))

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


def has_path(data, path: str) -> bool:
    sentinel = object()
    return get_path(data, path, sentinel) is not sentinel


def leading_poles(real: list, imag: list, count: int = 2) -> str:
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
#: the data file of the sources' published values (scene -> analysis -> rows)
PUBLISHED_FILE = "published.yaml"


@functools.cache
def published() -> dict[str, dict[str, list[tuple]]]:
    """scene -> analysis -> rows (quantity, symbol, key in the block or None, published value in SI, its SI unit,
    where the source prints it), read from :data:`PUBLISHED_FILE`."""
    data = yaml.safe_load(resources.files("autobal").joinpath(PUBLISHED_FILE).read_text(encoding="utf-8"))
    return {scene: {analysis: [(r["quantity"], r["symbol"], r.get("key"), r["published"], r["unit"], r["source"])
                               for r in rows] for analysis, rows in analyses.items()}
            for scene, analyses in data.items()}


def _comparison(sec: Section, scenario: str) -> None:
    rows = published().get(scenario, {}).get(sec.name)
    if not rows:
        return
    out = []
    for label, symbol, key, value, unit, where in rows:
        if key and key.startswith("afc.") and sec.get("afc.model") not in SOURCE_MODELS:
            continue  # the published AFC spread is the program model's (the montecarlo room's report_section says so)
        got = sec.get(key) if key else None
        rel = (got - value) / abs(value) if isinstance(got, int | float) and value else None
        q = quantity(f"{sec.name}.{key}", sec.results) if key else None  # its declared display unit (µm, not mm)
        shown = q.display if q is not None and q.unit == unit else None
        out.append([text(label), text(symbol), cell(value, unit, shown), cell(got, unit, shown),
                    cell(None if rel is None else 100 * rel, "%"), text(where)])
    sec.comparison = table("Comparison with the source's published values (docs/validation.md explains each "
                           "difference)",
                           ["quantity", "symbol", "published", "toolkit (the source's model)", "difference", "source"],
                           out)


# --------------------------------------------------------------------------------------------
# what several sections share: the section of an analysis (headline rows, verdicts, tables, warnings) is
# report_section(sec) in its room, autobal/analyses/<key>.py, found through SECTIONS
# --------------------------------------------------------------------------------------------


def stable_models(results: dict) -> dict:
    return {m: v.get("stable") for m, v in get_path(results, "stability.models", {}).items()}


MODEL_ORDER = ("nonlinear", "nonlinear_chain", "consistent", "program", "thesis")


def ordered_models(models: dict) -> list:
    """Models with the energy-consistent one first and the source's hand models last (validation)."""
    rank = {m: i for i, m in enumerate(MODEL_ORDER)}
    return sorted(models.items(), key=lambda kv: rank.get(kv[0], len(rank)))


def model_name(model: str) -> str:
    """What a model is (analysis/numerics/frequency.py MODEL_LABELS, the one copy)."""
    from autobal.analysis.numerics.frequency import (
        MODEL_LABELS,  # python-control and scipy: only a dynamics report needs it
    )

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


def source_model_line(sec: Section, model: str, stable: bool | None, forcing: str | None = None) -> None:
    """The validation line of one of the source's models: how closely it reproduces the scene's published
    values (the comparison table, program model), whether it is stable, and why not."""
    rows = published().get(sec.results.get("scenario", ""), {}).get(sec.name) or []
    diffs = [abs(sec.get(key) - pub) / abs(pub) for _, _, key, pub, _, _ in rows
             if key and key.startswith(f"models.{model}.") and isinstance(sec.get(key), int | float) and pub]
    where = rows[0][5] if rows else "the source"
    repro = (f"reproduces the published values ({where}) within {100 * max(diffs):.1f} % ({len(diffs)} values); "
             if diffs else "")
    m = sec.get(f"models.{model}") or {}
    poles = m.get("poles") or get_path(sec.results, f"stability.models.{model}.poles") or {}
    lead = leading_poles(poles.get("real", []), poles.get("imag", [])) if poles else ""
    state = {True: "stable", None: "stability not computed",
             False: f"UNSTABLE (leading poles {lead} 1/s): {WHY_UNSTABLE.get(model, '')}"}[stable]
    if stable is False and sec.name == "frequency":
        state += "; its AFC is not a steady response"
    text_ = f"{model_name(model)}{f', {forcing} forcing' if forcing else ''}: {repro}{state}"
    if text_ not in [v["text"] for v in sec.validation]:
        sec.validation.append({"ok": None, "text": text_})  # what the source's model shows, not a verdict


#: analysis -> its section function ``report_section(sec)``, in its room
SECTIONS: Mapping = _FromRooms("report_section")

#: analysis -> the title of its section, in its room
TITLES: Mapping = _FromRooms("TITLE")

def data_uri(path: Path) -> str:
    kind = {".png": "image/png", ".svg": "image/svg+xml", ".jpg": "image/jpeg"}[path.suffix.lower()]
    return f"data:{kind};base64," + base64.b64encode(report_input.read_regular(path, MAX_FIGURE_BYTES)).decode("ascii")


FIGURE_SUFFIXES = (".png", ".svg", ".jpg")


def _figures(folder: Path, results: dict) -> dict[str, list[dict]]:
    """analysis -> its figures {name, caption, uri}, from results.json ``outputs`` (the analysis whose files they
    are, else none) and ``captions`` (written by ``Result.write`` from its figures; a file without one says so)."""
    outputs = results.get("outputs") if isinstance(results.get("outputs"), dict) else {}
    captions = results.get("captions") if isinstance(results.get("captions"), dict) else {}
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
        words = captions.get(name)
        words = words if isinstance(words, str) else "no caption in results.json"
        out.setdefault(owner.get(name, ""), []).append({"name": name, "caption": words, "uri": data_uri(path)})
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
    scene = get_path(meta, "scene_si.display") if isinstance(meta, dict) else None
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
        Kind -> display unit (``{"pressure": "bar"}``, see :data:`autobal.analysis.run.quantities.KINDS`), over
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
    # a temporary file in the folder, then os.replace: a reader never sees half a page, and a report.html that is
    # a symbolic link is replaced itself (the file it points to, maybe outside the folder, is left as it was)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{REPORT}.", suffix=".tmp", dir=Path(folder))
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(page)
        os.chmod(tmp, 0o666 & ~umask())  # as a file open() makes (mkstemp's is 0o600)
        os.replace(tmp, out)
    except OSError as exc:  # a read-only folder, a full disk, a folder named report.html
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        raise ScenarioError(f"{text_clean(out)}: cannot be written ({exc.strerror})") from None
    return out
