"""Declared result quantities (analysis/run/quantities.py): every numeric leaf of results.json has a declared unit,
the report's unit is the declaration's display unit, the terminal speaks engineering units, and report.py has
no unit rule for a declared analysis."""

from __future__ import annotations

import json
import math
import re

import pytest

from autobal import cli, report, scenario
from autobal.analysis.run.quantities import Declarations, Quantity, convert, is_display_unit, significant
from tests.test_report import Page

FAST = ("pump_pe600_statics", "pump_pe600_dynamics", "rig_table43_fit", "washer_liquid_balancer_nested")
SLOW = tuple(p.stem for p in scenario.shipped() if p.stem not in FAST)


def check_declared(folder) -> None:
    """Every numeric leaf of a declared analysis has a declaration whose SI unit is the units map's; the
    headline cells of the report show a display unit of that SI unit; an analysis is declared or on the
    allow-list."""
    results = json.loads((folder / "results.json").read_text())
    for name in results["outputs"]:
        assert name in report.DECLARED or name in report.UNDECLARED, f"{name}: neither declared nor allowed"
        decl = report.declarations(name)
        if decl is None:
            continue
        assert decl.undeclared(results[name]) == [], f"{name}: numbers without a declaration"
        for path, unit in results["units"].items():
            if path.startswith(name + "."):
                assert report.quantity(path, results).unit == unit, path
    page = Page((folder / "report.html").read_text(encoding="utf-8"))
    keyed = [c for c in page.headline_cells if c.get("data-key")]
    for c in keyed:
        q = report.quantity(c["data-key"], results)
        if q is None:  # an analysis of the allow-list
            assert c["data-key"].split(".")[0] in report.UNDECLARED
            continue
        shown = {"dimensionless": "1"}.get(c["data-unit"], c["data-unit"])
        assert is_display_unit(shown, q.unit), f"{c['data-key']}: report shows {shown}, declared {q.unit}"


@pytest.mark.cli
@pytest.mark.parametrize("name", FAST)
def test_every_number_of_a_fast_scene_is_declared(shipped_run, name):
    check_declared(shipped_run(name)[1])


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_every_number_of_every_other_scene_is_declared(shipped_run, name):
    check_declared(shipped_run(name)[1])


def test_an_undeclared_key_is_found():
    decl = Declarations(Quantity("exact.z0", "m"), Quantity("fits.*.estimate", "1"),
                        Quantity("peaks[].omega", "rad/s"))
    block = {"exact": {"z0": 1e-4, "p2": 3e7, "ok": True, "why": "text"}, "fits": {"a": {"estimate": 1.0}},
             "peaks": [{"omega": 1.0, "amplitude": 2.0}], "accuracy": {"estimate": 1e-9, "parts": {"x": 1.0}}}
    assert decl.undeclared(block) == ["exact.p2", "peaks[].amplitude"]
    assert decl.find("peaks.0.omega").unit == "rad/s" and decl.find("exact.z0").unit == "m"
    curve = Declarations(Quantity("literal.P", "1"), Quantity("table[]", "h"))
    assert curve.find("literal.P.2").unit == "1" and curve.find("table.0").unit == "h"  # list elements, records


def test_a_display_unit_must_be_a_unit_of_the_si_unit():
    with pytest.raises(ValueError, match="'bar' is not a unit of 'm'"):
        Quantity("z0", "m", display="bar")
    assert Quantity("p", "Pa").display == "MPa" and Quantity("Q", "m^3/s").display == "L/s"
    assert Quantity("F", "N").display == "kN" and Quantity("V", "m^3").display == "L"


def test_conversions_and_digits():
    assert convert(32.2749e6, "Pa", "MPa") == pytest.approx(32.2749)
    assert convert(32.2749e6, "Pa", "bar") == pytest.approx(322.749)
    assert convert(0.01129, "m^3/s", "m³/h") == pytest.approx(40.644)
    assert convert(2 * math.pi * 100, "rad/s", "Hz") == pytest.approx(100)
    assert convert(2 * math.pi, "rad/s", "rpm") == pytest.approx(60)
    assert convert(1.4386e-4, "m", "µm") == pytest.approx(143.86)
    assert significant(0.0002091554609) == "2.092e-4" and significant(0.09999999863) == "0.1000"
    assert significant(18880.3) == "18880" and significant(143.86) == "143.9"
    speed = Quantity("omega", "rad/s", display="rad/s")
    assert speed.text(1977.0) == "1977 rad/s (18880 rpm)"


def test_report_has_no_unit_rule_keyed_on_names():
    """Every analysis of the report is declared; report.py reads no unit off a key's name (issue #23)."""
    assert set(report.SECTIONS) == set(report.DECLARED) and report.UNDECLARED == ()
    assert not hasattr(report, "_UNDECLARED_RULES") and not hasattr(report, "_RULES")
    assert report.unit_of("spinup.peak_velocity_m_s") is None  # a name with a unit in it is no declaration


def test_units_map_of_a_declared_analysis():
    results = {"statics": {"exact": {"z0": 1e-4, "p2": 3e7, "Q_e": 0.01, "u0": 0.96, "kappa_s": 1.26},
                           "closed_form": {"Q_e_over_Q_n": 0.04}, "unknown_key": 1.0}}
    assert report.units(results) == {"statics.exact.z0": "m", "statics.exact.p2": "Pa",
                                     "statics.exact.Q_e": "m^3/s", "statics.exact.u0": "1",
                                     "statics.exact.kappa_s": "1", "statics.closed_form.Q_e_over_Q_n": "1"}


@pytest.mark.cli
def test_statics_prints_engineering_units_first(capsys, tmp_path):
    """`autobal run pump_pe600_statics`: the face gap in µm, the chamber pressures in MPa and the leak flows in
    L/s come before the source's dimensionless groups."""
    assert cli.main(["run", "pump_pe600_statics", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()

    def line(symbol: str) -> str:
        return next(x for x in lines if re.match(rf"\s+\S.*\s{re.escape(symbol)}\s", x))

    assert re.search(r"\sz0\s+143\.9 µm$", line("z0")), line("z0")  # Pavlenko (2014), App. A: u0 0.96 z_B
    for p in ("p2", "p3", "p_e", "p_cam"):
        assert re.search(r"\d MPa$", line(p)), line(p)
    for q in ("Q_e", "Q_T", "Q_1"):
        assert re.search(r"\d L/s$", line(q)), line(q)
    assert line("z0") in lines[: lines.index(next(x for x in lines if "dimensionless groups" in x))]
    assert "m**3" not in out and "m3/s" not in out


@pytest.mark.cli
def test_statics_csv_headers_name_engineering_units(shipped_run):
    """statics_sweep.csv: p1 in MPa beside psi1 = p1/p_B, z in µm beside u = z/z_B, flows in L/s."""
    import csv

    run, folder = shipped_run("pump_pe600_statics")
    with (folder / "statics_sweep.csv").open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert {"p1 [MPa]", "psi1 [1]", "z [µm]", "u [1]", "x [mm]", "Q_e [L/s]", "Q_T [L/s]"} <= set(rows[0])
    st = run["statics"].to_dict()
    for row in rows:
        assert float(row["p1 [MPa]"]) == pytest.approx(float(row["psi1 [1]"]) * st["scales"]["p_B"] / 1e6, rel=1e-12)
        assert float(row["z [µm]"]) == pytest.approx(float(row["u [1]"]) * st["scales"]["z_B"] * 1e6, rel=1e-12)
    at = next(r for r in rows if float(r["psi1 [1]"]) == st["exact"]["psi1"])
    assert float(at["Q_e [L/s]"]) == pytest.approx(st["exact"]["Q_e"] * 1e3, rel=1e-9)
