"""One unit vocabulary (analysis/run/kinds.py): the scene loader (autobal/units.py) and the display
(analysis/run/quantities.py) read the same table of kinds; kN/mm in and out."""

import json
from pathlib import Path

import pytest

import autobal
from autobal import cli, units
from autobal.analysis.run import kinds
from autobal.analysis.run.quantities import (
    DEFAULT_DISPLAY,
    DISPLAY_UNITS,
    KINDS,
    Quantity,
    current_choice,
    display_units,
    unit_of_kind,
    units_of_kind,
)
from autobal.errors import ScenarioError

ROOT = Path(__file__).resolve().parents[1]


def written(display_unit: str) -> str:
    """A display unit as a scene writes it: "N·s/m" -> "N*s/m", "m³/h" -> "m^3/h"."""
    return display_unit.replace("·", "*").replace("²", "^2").replace("³", "^3")


@pytest.mark.parametrize("kind, unit, factor", [(k.name, u, f) for k in kinds.TABLE for u, f in k.display.items()])
def test_every_display_unit_is_read_by_the_loader_with_its_factor(kind, unit, factor):
    # the display's factor (SI value of one display unit) against the loader reading the same unit, and pint
    assert units.unit_factor(written(unit), kind) == pytest.approx(factor, rel=1e-14)
    assert units.to_si(f"2.5 {written(unit)}", kind) == pytest.approx(2.5 * factor, rel=1e-14)
    if kind not in units.ANGULAR:  # pint reads Hz and rpm as 1/s (the loader reads them as 2 pi n)
        ureg = units.registry()
        si = ureg.Quantity(1.0, ureg.parse_units(written(unit))).to(kinds.BY_NAME[kind].written).magnitude
        assert si == pytest.approx(factor, rel=1e-14)


def test_the_loader_and_the_display_are_made_from_the_one_table():
    assert units.DIMENSIONS == {k.name: (k.dimension, k.written, k.example, k.magnitude) for k in kinds.TABLE}
    assert list(KINDS) == ["length", "area", "volume", "pressure", "force", "stiffness", "damping", "flow", "speed",
                           "acceleration", "time", "velocity", "mass", "unbalance",
                           "power"]  # the documented display kinds
    for name, (si, _) in KINDS.items():
        k = kinds.BY_NAME[name]
        assert k.si == si and units.DIMENSIONS[k.name][1] == si.replace("^", "**")
        assert units_of_kind(name) == units_of_kind(k.name) == list(k.display)
    assert {si for si, _ in DISPLAY_UNITS.values()} == {si for si, _ in KINDS.values()}
    assert all(DISPLAY_UNITS[shown][0] == si for si, shown in DEFAULT_DISPLAY.items())
    # one display unit names one factor: no unit in two kinds
    assert len(DISPLAY_UNITS) == sum(len(k.display) for k in kinds.TABLE)


def test_kn_per_mm_in():
    assert units.to_si("35 kN/mm", "stiffness") == pytest.approx(3.5e7, rel=1e-15)
    scene = autobal.load("spinup_jeffcott_deadline_5s", set={"rotor.stiffness": "0.011025 kN/mm"})
    assert scene.rotor.stiffness == pytest.approx(11025.0, rel=1e-15)  # the shipped 11025 N/m
    with pytest.raises(ScenarioError) as err:
        autobal.load("spinup_jeffcott_deadline_5s", set={"rotor.stiffness": "35 kN/mm^2"})
    assert "rotor.stiffness" in str(err.value) and "N/m" in str(err.value) and "\n" not in str(err.value)


def test_kn_per_mm_out():
    c_s = Quantity("exact.c_s", "N/m", "c_s", "axial stiffness", "N/µm")
    assert c_s.text(7.796e8) == "779.6 N/µm"
    for written_as in ("kN/mm", " kN/mm "):
        assert unit_of_kind("stiffness", written_as) == "kN/mm"
    with display_units({"stiffness": "kN/mm"}):
        assert c_s.display == "kN/mm" and c_s.text(7.796e8) == "779.6 kN/mm"
        assert c_s.shown(2e6) == pytest.approx(2.0, rel=1e-15)
    with pytest.raises(ValueError, match=r"^'kN/cm' is not a unit of stiffness \(N/m\): write one of N/m, kN/m, "
                                         r"MN/m, N/µm, kN/mm$"):
        unit_of_kind("stiffness", "kN/cm")


def test_a_kind_by_its_name_or_its_short_name_and_a_unit_by_its_aliases():
    assert unit_of_kind("volume flow", "m3/h") == unit_of_kind("flow", "m^3/h") == "m³/h"
    with display_units({"volume flow": "l/min", "angular speed": "r/min"}):
        assert current_choice() == {"flow": "L/min", "speed": "rpm"}
        assert Quantity("q", "m^3/s").text(1e-3) == "60.00 L/min"
    for alias, unit in kinds.BY_NAME["angular speed"].unit_aliases.items():  # the loader reads them alike
        assert units.unit_factor(alias, "angular speed") == pytest.approx(kinds.BY_NAME["speed"].display[unit])
    with pytest.raises(ValueError, match=r"^'bulk modulus' is not a kind of quantity; choose units for length, "):
        unit_of_kind("bulk modulus", "bar")  # a kind a scene writes, shown as a pressure: no choice of its own


@pytest.mark.cli
def test_the_cli_and_the_scene_choose_kn_per_mm(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["run", "compressor_k180_statics", "--units", "stiffness=kN/mm", "--out", str(out)]) == 0
    assert "c_s     779.6 kN/mm" in capsys.readouterr().out  # 7.796e8 N/m (Pavlenko (2014), Eq. (2.36) exactly)
    results = json.loads((out / "results.json").read_text())
    assert results["statics"]["exact"]["c_s"] == pytest.approx(7.796e8, rel=1e-4)  # results.json stays SI
    assert "kN/mm" in (out / "report.html").read_text(encoding="utf-8")
    # the scene's display section, and a unit it does not have refused with one line naming the field and the unit
    scene = autobal.load("compressor_k180_statics", set={"display.stiffness": "kN/mm"})
    assert scene.display.stiffness == "kN/mm"
    assert cli.main(["run", "compressor_k180_statics", "--units", "stiffness=kN/cm", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--units stiffness=kN/cm" in err and "kN/mm" in err


def test_the_contributing_page_holds_the_vocabulary():
    assert kinds.markdown_table() in (ROOT / "docs" / "contributing.md").read_text()
