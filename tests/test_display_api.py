"""The display units of a scene reach the Python API as they reach the CLI (issue #32 items 5, 6): a Result keeps
its scene's choice, so summary(), headline(), _repr_html_() and to_dataframe() show it after the run; a caller's
own ``display_units`` block wins; CSV headers name their units; results.json stays SI (AFC amplitudes in m)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import yaml

import autobal
from autobal import report, scenario
from autobal.analysis.numerics import frequency, simulate, stability
from autobal.analysis.numerics.linearize import Setup
from autobal.analysis.run.quantities import DISPLAY_UNITS, display_units, flatten, is_number, significant
from autobal.parts import device as device_part

pytestmark = pytest.mark.cli  # end to end through autobal.run / the CLI

RPM = 2 * math.pi / 60  # rad/s per rpm


def scene_file(tmp_path, name: str, display: dict, analyses: dict | None = None):
    """A copy of a shipped scene with a ``display`` section (and only the given analyses)."""
    data = yaml.safe_load(next(p for p in scenario.shipped() if p.stem == name).read_text())
    data["display"] = display
    if analyses is not None:
        data["analyses"] = analyses
    path = tmp_path / f"{name}_display.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


@pytest.fixture(scope="module")
def statics_bar(tmp_path_factory):
    path = scene_file(tmp_path_factory.mktemp("display"), "pump_pe600_statics", {"pressure": "bar", "speed": "rpm"})
    return autobal.run(path)


@pytest.fixture(scope="module")
def pump():
    return Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device))


@pytest.mark.extra("notebook")  # to_dataframe() needs pandas
def test_the_scenes_display_reaches_summary_headline_html_and_dataframes_after_the_run(statics_bar):
    st = statics_bar["statics"]
    p1 = st.to_dict()["exact"]["p1"]  # Pa
    bar = significant(p1 / 1e5)
    assert bar == "322.7"  # p1 = p_B = 32.27 MPa of the pump (Pavlenko 2014, App. A)
    text = st.summary()  # outside any display_units block
    assert text.startswith(f"statics at p1 = {bar} bar") and "MPa" not in text
    rows = {r["key"]: r for r in st.headline()}
    assert (rows["exact.p1"]["value"], rows["exact.p1"]["unit"], rows["exact.p1"]["si_unit"]) == (bar, "bar", "Pa")
    assert f"<td>discharge pressure</td><td>p1</td><td>{bar}</td><td>bar</td>" in st._repr_html_()
    assert "<td>bar</td>" in statics_bar._repr_html_(figures=False)
    frame = st.to_dataframe("statics_sweep.csv")
    sweep = st.tables()["statics_sweep.csv"]
    assert "p1 [bar]" in frame.columns and "p1 [MPa]" not in sweep
    assert frame["p1 [bar]"].to_numpy() == pytest.approx(np.asarray(sweep["psi1 [1]"]) * p1 / 1e5, rel=1e-12)
    assert statics_bar.to_dict()["statics"]["exact"]["p1"] == p1  # results.json stays SI


def test_an_explicit_display_units_block_wins_over_the_scenes(statics_bar):
    st = statics_bar["statics"]
    p1 = st.to_dict()["exact"]["p1"]
    with display_units({"pressure": "kPa"}):
        text, rows = st.summary(), {r["key"]: r for r in st.headline()}
        assert "p1 [kPa]" in st.tables()["statics_sweep.csv"]
    assert text.startswith(f"statics at p1 = {significant(p1 / 1e3)} kPa") and " bar" not in text.splitlines()[0]
    assert rows["exact.p1"]["unit"] == "kPa" and rows["exact.p1"]["value"] == significant(p1 / 1e3)
    with display_units({"length": "mm"}):  # a kind the caller chose; the scene's pressure stays
        rows = {r["key"]: r for r in st.headline()}
    assert rows["exact.z0"]["unit"] == "mm" and rows["exact.p1"]["unit"] == "bar"
    assert st.summary().startswith(f"statics at p1 = {significant(p1 / 1e5)} bar")  # the block ended


def test_load_with_a_display_override_changes_the_summary():
    plain = autobal.run("pump_pe600_statics")["statics"]
    chosen = autobal.run(autobal.load("pump_pe600_statics", set={"display.pressure": "bar"}))["statics"]
    p1 = plain.to_dict()["exact"]["p1"]
    assert plain.summary().startswith(f"statics at p1 = {significant(p1 / 1e6)} MPa")
    assert chosen.summary().startswith(f"statics at p1 = {significant(p1 / 1e5)} bar")
    assert chosen.display_choice == {"pressure": "bar"} and plain.display_choice == {}


def test_a_speed_in_rpm_by_the_scene_with_its_other_units_beside(tmp_path):
    path = scene_file(tmp_path, "pump_pe600_dynamics", {"pressure": "bar", "speed": "rpm"},
                      {"stability": {"operating_ratio": 1.0, "models": ["nonlinear"]}})
    st = autobal.run(path)["stability"]
    rows = {r["key"]: r for r in st.headline()}
    im = rows["headline.leading_pole.imag"]
    assert im["unit"] == "rpm" and im["si_unit"] == "rad/s"
    assert im["value"] == significant(im["si_value"] / RPM)
    assert im["beside"] == f"{significant(im['si_value'] / (2 * math.pi))} Hz"  # the declared unit beside it
    html = st._repr_html_()
    assert f"<td>{im['value']}</td><td>rpm</td><td>{im['beside']}</td>" in html
    assert f"{im['value']} rpm ({im['beside']})" in st.summary()


def test_rpm_beside_rad_s_in_the_notebook_headline_table(pump):
    fr = frequency.study(pump, ["program", "nonlinear"], "appendix", (10.0, 8000.0, 200), "pump")
    rows = {r["key"]: r for r in fr.headline()}
    w0 = rows["headline.at_operating_speed.omega"]
    assert (w0["value"], w0["unit"], w0["beside"]) == ("659.7", "rad/s", f"{significant(659.734 / RPM)} rpm")
    assert "<td>659.7</td><td>rad/s</td><td>6300 rpm</td>" in fr._repr_html_()  # 660 rad/s = 6300 rpm of the pump


def test_afc_amplitudes_are_si_in_results_json(pump):
    fr = frequency.study(pump, ["program", "nonlinear"], "appendix", (10.0, 8000.0, 200), "pump")
    d = fr.to_dict()
    keys = [k for k, _ in _keys(d)]
    assert not [k for k in keys if re.search(r"_(um|mm|kN|bar|rpm|MPa)$", k)]
    units = report.units({"frequency": d}, ["frequency"])
    assert units["frequency.peaks[].amplitude"] == units["frequency.headline.static_amplitude"] == "m"
    # the program model under the appendix forcing: 1977.2 rad/s with 25.20 µm (Pavlenko (2014), App. A, recomputed)
    peak = d["models"]["program"]["peaks"][0]
    assert peak["omega"] == pytest.approx(1977.2, abs=1.0) and peak["amplitude"] == pytest.approx(25.20e-6, abs=0.02e-6)
    assert fr.amplitude_at_operating_speed == d["at_operating_speed"]["amplitude"]  # the property is m, as the key
    table = fr.tables()["afc_program.csv"]
    curve = fr.models["program"]
    assert np.asarray(table["amplitude [µm]"]) == pytest.approx(np.asarray(curve.amplitude) * 1e6, rel=1e-12)
    assert np.max(table["amplitude [µm]"]) == pytest.approx(peak["amplitude"] * 1e6, rel=1e-3)


def test_transient_gap_changes_are_si(pump):
    tr = simulate.study(pump.nonlinear("energy"), [{"input": "force_step", "amplitude": 0.01}], 0.002, 50,
                        title="pump")
    case = tr.to_dict()["cases"][0]
    z = np.asarray(tr.cases[0].z)
    assert case["max_dz"] == pytest.approx(np.abs(z - z[0]).max(), rel=1e-12) and 0 < case["max_dz"] < 1e-4  # m
    assert report.units({"transient": tr.to_dict()}, ["transient"])["transient.cases[].max_dz"] == "m"
    table = tr.tables()["transient_0_force_step.csv"]
    assert np.asarray(table["z [µm]"]) == pytest.approx(z * 1e6, rel=1e-12)
    assert np.asarray(table["t [ms]"]) == pytest.approx(np.asarray(tr.cases[0].t) * 1e3, rel=1e-12)


def _keys(block, path=""):
    if isinstance(block, dict):
        for k, v in block.items():
            yield f"{path}.{k}" if path else str(k), v
            yield from _keys(v, f"{path}.{k}" if path else str(k))
    elif isinstance(block, list):
        for v in block:
            yield from _keys(v, path + "[]")


HEADER = re.compile(r"^\S(.*\S)? \[(?P<unit>[^\]]+)\]$")
WORDS = {"1", "deg", "1/s"}  # units that are not display units of a kind


def headers_without_units(tables: dict) -> list[str]:
    """'file: column' of every numeric column whose header does not end in '[unit]' with a unit the toolkit knows
    (a table with a 'unit' column states the unit of each row instead)."""
    bad = []
    for name, cols in tables.items():
        if "unit" in cols:
            continue
        for col, values in cols.items():
            if not any(is_number(v) for v in flatten(np.asarray(values, dtype=object).ravel().tolist())):
                continue
            m = HEADER.match(col)
            if m is None or not (m["unit"] in DISPLAY_UNITS or m["unit"] in WORDS):
                bad.append(f"{name}: {col}")
    return bad


def test_every_csv_header_names_its_unit(pump, statics_bar):
    fr = frequency.study(pump, ["program", "nonlinear"], "appendix", (10.0, 8000.0, 200), "pump")
    tr = simulate.study(pump.nonlinear("energy"), [{"input": "force_step", "amplitude": 0.01}], 0.002, 50,
                        title="pump")
    st = stability.study(pump, ["program"], None, "pump")
    for result in (fr, tr, st, statics_bar["statics"]):
        assert headers_without_units(result.tables()) == [], result.name
    assert headers_without_units({"x.csv": {"omega_rad_s": [1.0], "note": ["words"]}}) == ["x.csv: omega_rad_s"]
