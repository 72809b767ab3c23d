"""The report's headline rows come from the Result's fields (``Section.rows_of``, ``Section.headline_rows``): no
room names a key path as a string, and a renamed field fails at once instead of leaving a stale row."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest

import autobal
from autobal import report
from autobal.analysis.run.fields import Record, TypedResult, declarations, field_key, place, quantity, record
from autobal.analysis.run.quantities import Quantity
from autobal.analysis.run.result import plain

ROOT = Path(autobal.__file__).parent


def _names_a_path(node: ast.AST) -> bool:
    """A path argument written as words: a string, an f-string, or a concatenation holding one."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, str)
    if isinstance(node, ast.JoinedStr):
        return True
    return isinstance(node, ast.BinOp) and (_names_a_path(node.left) or _names_a_path(node.right))


def _row_calls(source: str):
    """The ``.row(...)`` calls of a module's source."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "row":
            yield node


def _path_strings(source: str) -> list[int]:
    """The lines of the ``.row(label, symbol, path, ...)`` calls whose path is written as a string."""
    return [c.lineno for c in _row_calls(source)
            if any(_names_a_path(a) for a in [*c.args[2:3], *(k.value for k in c.keywords if k.arg == "path")])]


def test_the_check_sees_a_path_string():
    """The AST check below can fail: a string, an f-string, a prefix joined to a key are seen, a variable not."""
    source = ('sec.row("gap", "z", "reference.z_mean", value=1)\n'
              'sec.row("P", "P(t)", f"literal.P.{i}")\n'
              'sec.row(label, sym, prefix + "amplification_factor")\n'
              'sec.row(label, sym, path="a.b")\n'
              'sec.row(q.description, q.symbol, key, value=v)\n')
    assert _path_strings(source) == [1, 2, 3, 4]


def test_no_row_in_autobal_names_a_key_path_as_a_string():
    found = [f"{p.relative_to(ROOT)}:{line}" for p in sorted(ROOT.rglob("*.py")) for line in
             _path_strings(p.read_text(encoding="utf-8"))]
    assert found == []


def test_the_rooms_write_their_rows_from_the_fields_only():
    """A room's headline rows come from rows_of / headline_rows, never from a row it spells out."""
    found = [f"{p.name}:{c.lineno}" for p in sorted((ROOT / "analyses").glob("*.py"))
             for c in _row_calls(p.read_text(encoding="utf-8"))]
    assert found == []


@record
class Gap(Record):
    z: float = quantity("m", "z", "face gap", "µm")
    Q: float = quantity("m^3/s", "Q", "leak", key="Q_T")


@record
class Toy(TypedResult):
    name = "toy"
    gap: Gap
    gaps: list[Gap]
    P: np.ndarray = quantity("1", "P(t)", "probability of failure-free operation")
    margin: dict  # operating point -> decay rate: keys that are names, declared with the Result


Toy.quantities = declarations(Toy, Quantity("margin.**", "1/s", "η", "decay rate"))


@pytest.fixture
def toy():
    r = Toy(gap=Gap(z=1e-4, Q=2e-6), gaps=[Gap(z=3e-4, Q=4e-6), Gap(z=5e-4, Q=6e-6)], P=np.array([0.9, 0.5]),
            margin={"0.5": 12.0, "1": None}, statuses={})
    sec = report.Section("toy", plain(r.to_dict()), {})
    sec.result = r  # what load_result would give for a registered analysis
    return r, sec


def test_a_record_knows_its_place_and_its_keys(toy):
    r, _ = toy
    assert [place(r, r), place(r, r.gap), place(r, r.gaps[1])] == ["", "gap.", "gaps.1."]
    assert field_key(r.gap, "Q") == "Q_T"
    with pytest.raises(ValueError, match="Toy does not hold this Gap"):
        place(r, Gap(z=1e-4, Q=2e-6))  # equal, but not the Result's own record


def test_a_renamed_field_is_a_key_error_at_once(toy):
    r, sec = toy
    with pytest.raises(KeyError, match="Gap has no field 'z_mean'"):
        sec.rows_of(r.gap, "z", "z_mean")
    assert sec.rows == []  # every name is checked before a row is written
    with pytest.raises(ValueError, match="a label names the row"):
        sec.rows_of(r.gap, "z", "Q", label="face gap")


def test_the_rows_are_the_fields_with_their_declarations(toy):
    r, sec = toy
    sec.rows_of(r.gap, "z", "Q")
    sec.rows_of(r.gaps[1], "z")
    sec.rows_of(r, "P", label=lambda i: f"P at time {i}")
    sec.rows_of(r, "margin", label=lambda p: f"decay rate at ψ1 = {p}")
    got = [(row[0]["text"], row[1]["text"], row[2]["key"]) for row in sec.rows]
    assert got == [("face gap", "z", "toy.gap.z"), ("leak", "Q", "toy.gap.Q_T"), ("face gap", "z", "toy.gaps.1.z"),
                   ("P at time 0", "P(t)", "toy.P.0"), ("P at time 1", "P(t)", "toy.P.1"),
                   ("decay rate at ψ1 = 0.5", "η", "toy.margin.0.5"), ("decay rate at ψ1 = 1", "η", "toy.margin.1")]
    values = [None if row[2].get("null") else float(row[2]["text"]) for row in sec.rows]
    assert values == pytest.approx([1e-4, 2e-6, 5e-4, 0.9, 0.5, 12.0, None], rel=1e-3)  # a null stays a null


def test_a_number_without_a_declaration_is_an_error_not_a_row(toy, monkeypatch):
    r, sec = toy
    monkeypatch.setattr(Toy, "quantities", declarations(Toy))  # without the declaration of the margins
    with pytest.raises(KeyError, match="toy.margin.0.5: no declaration"):
        sec.rows_of(r, "margin")


def _field(result, path: str):
    """The value at a key path, read by attribute from the Result (the field, not its results.json block)."""
    v = result
    for part in path.split("."):
        v = v[int(part)] if isinstance(v, list | np.ndarray) else v[part] if isinstance(v, dict) else getattr(v, part)
    return v


def test_the_statics_rows_are_its_fields_in_their_display_units(shipped_run):
    """The statics section of a run: every headline row is a field of the Result with its declaration's words,
    its value the field's in the declaration's display unit (MPa, µm, L/min ...), to the table's 4 digits."""
    _, folder = shipped_run("compressor_k180_statics")
    results = json.loads((folder / "results.json").read_text(encoding="utf-8"))
    sec = report.Section("statics", results["statics"], results, folder)
    report.SECTIONS["statics"](sec)
    r = sec.result
    keys = [row[2]["key"].removeprefix("statics.") for row in sec.rows]
    assert keys[:3] == ["exact.psi1", "exact.p1", "scales.p_B"] and "critical_exact.dpsi_kr" in keys
    for label, symbol, c, *_ in sec.rows:
        q = r.quantities.find(c["key"].removeprefix("statics."))
        assert (label["text"], symbol["text"]) == (q.description, q.symbol)
        assert float(c["text"]) == pytest.approx(q.shown(_field(r, c["key"].removeprefix("statics."))), rel=1e-3)
