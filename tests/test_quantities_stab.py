"""Declared quantities of `stability` and `design` (issue #23): every number of their results.json blocks is declared
(a map axis and a design variable by the parameter they name), the terminal prints the declared display units, a
printed value is the SI value of results.json converted, and the one verdict carries the decay rate and the margin to
the required one."""

from __future__ import annotations

import csv
import json
import math
import re
import shutil

import pytest
import yaml

import autobal
from autobal import report, scenario
from autobal.analyses.design import VARIABLES
from autobal.analysis.numerics import stability
from autobal.analysis.numerics.linearize import Setup
from autobal.analysis.run.quantities import leaf_paths, significant
from autobal.analysis.run.result import plain
from autobal.analysis.studies import design_study
from autobal.parts.device import dynamic_device
from autobal.units import DIMENSIONS
from tests.test_quantities import FAST, SLOW, check_declared

EXTREME = sorted(p for p in (scenario.resolve("pump_pe600_dynamics").parent / "extreme").glob("dynamics_*.yaml"))


def _uses(path, analysis: str) -> bool:
    return analysis in (yaml.safe_load(path.read_text()).get("analyses") or {})


@pytest.mark.parametrize("analysis", ["stability", "design"])
def test_the_walker_covers_every_shipped_scene_of_the_analysis(analysis):
    """tests/test_quantities.py walks every shipped scene; these analyses are declared, not on the allow-list."""
    scenes = {p.stem for p in scenario.shipped() if _uses(p, analysis)}
    assert scenes and scenes <= set(FAST) | set(SLOW)
    assert analysis in report.DECLARED and analysis not in report.UNDECLARED
    assert not hasattr(report, "_UNDECLARED_RULES")  # no unit rule keyed on names at all
    assert not hasattr(report, "_parameter_unit")


@pytest.mark.cli
def test_the_walker_fails_on_an_undeclared_or_a_misdeclared_number(shipped_run, tmp_path):
    """The walker can fail: a number nobody declared, and a map axis whose declared unit (its parameter's) is not
    the units map's."""
    folder = shipped_run("pump_pe600_dynamics")[1]
    check_declared(folder)
    for change in ("undeclared", "axis"):
        copy = shutil.copytree(folder, tmp_path / change)
        results = json.loads((copy / "results.json").read_text())
        if change == "undeclared":
            results["stability"]["margin"]["growth"] = 1.0
        else:  # the axis now names a mass; the units map still says m^3
            results["stability"]["maps"]["nonlinear"]["x"]["parameter"] = "rotor_mass"
        (copy / "results.json").write_text(json.dumps(results))
        with pytest.raises(AssertionError):
            check_declared(copy)


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if i else p
                                  for i, p in enumerate(EXTREME)], ids=[p.stem for p in EXTREME])
def test_every_number_of_an_extreme_scene_is_declared(path):
    from autobal.analyses import stability as room

    scene = autobal.load(path)
    block = plain(room.run(scene, scene.analyses.stability).to_dict())
    assert stability.QUANTITIES.undeclared(block) == []
    assert set(report.units({"stability": block})) == {f"stability.{p}" for p, _ in leaf_paths(block)}


def test_every_design_variable_is_declared_in_the_unit_of_its_scene_field():
    """The two tables agree: the scene's unit kind of each design variable (autobal/analyses/design.py) and the SI
    unit the design states for its key (analysis/numerics/design.py), through the declaration by scene path."""
    for path, (key, kind) in VARIABLES.items():
        q = design_study.variable(path)
        assert q is not None and q.symbol == key and q.display, path
        assert q.unit == (DIMENSIONS[kind][1].replace("**", "^") if kind else "1"), path
        assert design_study.QUANTITIES.find(f"optimum.values_si.{path}").unit == q.unit
    assert design_study.variable("device.fluid.density") is None


@pytest.mark.cli
def test_stability_summary_prints_display_units_converted_from_results_json(shipped_run):
    run, folder = shipped_run("pump_pe600_dynamics")
    text = run["stability"].summary()
    d = json.loads((folder / "results.json").read_text())["stability"]
    lines = text.splitlines()
    assert lines[0] == "stability: energy-consistent (nonlinear): stable, disturbances decay at 82.64 1/s"
    assert sum("stable" in x.lower() and x.startswith("stability:") for x in lines) == 1
    # the least-stable mode's frequency in rad/s with Hz beside: Im lambda of results.json, and / 2 pi
    imag = d["headline"]["leading_pole"]["imag"]
    m = re.search(r"Im λ\s+(\S+) rad/s \((\S+) Hz\)", text)
    assert m and m.groups() == (significant(imag), significant(imag / (2 * math.pi)))
    assert float(m.group(2)) == pytest.approx(156.9, abs=0.05)  # -82.64 +- 985.7i 1/s
    # the map's stable interval of the cavity volume, in cm³ (SI m^3 x 1e6)
    lo, hi = d["maps"]["nonlinear"]["restoring"]["along_axes"]["cavity_volume"]["stable_intervals"][0]
    assert f"cavity volume V3 alone (the other nominal): stable for {significant(lo * 1e6)} to " \
           f"{significant(hi * 1e6)} cm³" in text
    assert "stem damping c_x alone (the other nominal): stable for 0 to 20000 N·s/m" in text
    assert re.search(r"margin to the required decay rate\s+η − α\s+82\.64 1/s", text)
    # the source's models only below the validation heading
    head, _, validation = text.partition("validation against the source")
    assert "program model" not in head and "chain form" not in head and "program model" in validation
    assert "m^3" not in text and "m**3" not in text and "(SI)" not in text
    # the map's CSV: the parameter in its display unit, the header naming it
    with (folder / "stability_map_nonlinear.csv").open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    xs = d["maps"]["nonlinear"]["x"]["values"]
    assert [float(r["cavity_volume [cm³]"]) for r in rows[:len(xs)]] == pytest.approx([x * 1e6 for x in xs])


@pytest.fixture(scope="module")
def pump_setup():
    return Setup(dynamic_device(autobal.load("pump_pe600_dynamics")), 1.0)


@pytest.mark.parametrize("alpha, ok", [(0.0, True), (50.0, True), (100.0, False)])
def test_the_verdict_carries_the_margin_to_the_required_decay_rate(pump_setup, alpha, ok):
    """Pump PE 600-300 (Pavlenko 2014, App. A data): the energy-consistent model decays at 82.64 1/s; a scene that
    requires 100 1/s gets a failed verdict although the machine is stable, with the margin negative."""
    res = stability.study(pump_setup, ["nonlinear", "program"], None, "pump", alpha)
    d = plain(res.to_dict())
    decay = -max(res.poles.real)  # cross-check: the verdict's decay rate is the poles'
    assert res.stable is True and d["stable"] is True and res.decay_rate == pytest.approx(decay, rel=1e-12)
    assert decay == pytest.approx(82.64, abs=0.01)
    assert d["headline"]["margin_to_required"] == pytest.approx(decay - alpha, rel=1e-12)
    assert d["headline"]["meets_requirement"] is ok and res.verdict()[0] is ok
    words = res.verdict()[1]
    if alpha == 50.0:
        assert words.endswith("decay at 82.64 1/s, 32.64 1/s above the required 50.00 1/s")
    if alpha == 100.0:
        assert words.endswith("the required 100.0 1/s is NOT met")
    (sec,) = report.sections({"scenario": "x", "stability": d})
    assert sec["overall"] == {"ok": ok, "text": words}


@pytest.mark.cli
@pytest.mark.slow
def test_design_summary_and_report_in_display_units(shipped_run):
    """Pump PE 600-300 design: leakage in L/s, volumes in cm³, the spring in MN/m, pressure in MPa, lengths in mm,
    to 4 significant digits; the report's validation part says the optimum is more unstable under the source's chain
    and program models."""
    run, folder = shipped_run("pump_pe600_design")
    text = run["design"].summary()
    d = json.loads((folder / "results.json").read_text())["design"]
    o, n = d["optimum"], d["nominal"]
    assert text.startswith("design: optimum design, energy-consistent (nonlinear): stable, decay rate ≥ ")
    m = re.search(r"barrier leakage of the optimum\s+Q_e\s+(\S+) L/s", text)
    assert m and m.group(1) == significant(o["leakage"] * 1e3)
    path = "device.dynamics.disc_chamber_volume"
    assert re.search(rf"{re.escape(path)}\s+V2\s+{significant(n['values_si'][path] * 1e6)} cm³ → "
                     rf"{significant(o['values_si'][path] * 1e6)} cm³", text)
    for unit in ("MN/m", "MPa", " mm", "cm²", "N·s/m"):
        assert unit in text, unit
    assert "m**3" not in text and "m^3" not in text and not re.search(r"\d{8,}", text)
    # the nominal design lacks the point where its valve sits on the stop: no claim "at every operating point"
    assert "nominal design: energy-consistent (nonlinear): stable, decay rate ≥ 82.64 1/s at 3 of 4" in text
    ctx = report.context(folder)
    sec = next(s for s in ctx["sections"] if s["name"] == "design")
    validation = " ".join(v["text"] for v in sec["validation"])
    for key in ("other_model", "program_model"):
        top = max(v for v in d[key]["optimum"].values() if isinstance(v, float))
        assert f"to +{significant(top)} 1/s" in validation
    assert validation.count("MORE unstable than the nominal design") == 2
