"""One verdict per device result, never contradicted beside it (issue #32, item 4).

A device without a regulator has no regulator states anywhere (summary, verdict, report, figures, CSVs,
results.json); the source's closed forms carry their assumption (an ideal regulator); the AFC of the headline
model is shown once, the source's appendix forcing only in the validation part; the barrier margins say which
is the operating one and which the critical one.
"""

import copy
import csv
import json
import re

import numpy as np
import pytest
import yaml

import autobal
from autobal import report
from autobal.analysis.numerics import frequency
from autobal.analysis.numerics.statics import StaticsSolver
from autobal.analysis.run.result import plain
from autobal.analysis.studies.statics_study import QUANTITIES
from autobal.parts.device import design
from autobal.scenario import shipped

pytestmark = pytest.mark.cli  # each test runs its scene through autobal.run

AMPLITUDE = frequency.QUANTITIES.find("peaks.0.amplitude")  # the AFC's amplitudes: m, shown in µm
REGULATOR_KEYS = {"x0", "xi0", "pcam", "psi_cam0", "regulator_saturated", "r_valve"}


def _scene_file(folder, name: str, edit) -> str:
    """A shipped scene as a YAML file of its own, edited by ``edit(dict)``."""
    src = next(p for p in shipped() if p.stem == name)
    d = yaml.safe_load(src.read_text())
    edit(d)
    path = folder / f"{d['name']}.yaml"
    path.write_text(yaml.safe_dump(d, sort_keys=False, allow_unicode=True))
    return str(path)


def _without_regulator(d: dict) -> None:
    """pump_pe600_statics with ``device.regulator`` deleted (how the issue's author got a device without one)."""
    del d["device"]["regulator"]
    d["name"], d["title"] = "pump_no_regulator_statics", "Pump PE 600-300: statics without a regulator"


@pytest.fixture(scope="module")
def no_regulator(tmp_path_factory):
    folder = tmp_path_factory.mktemp("no_regulator")
    scene = autobal.load(_scene_file(folder, "pump_pe600_statics", _without_regulator))
    assert scene.device.regulator is None
    out = folder / "out"
    return scene, autobal.run(scene, out=out)["statics"], out


@pytest.fixture(scope="module")
def with_regulator(tmp_path_factory):
    out = tmp_path_factory.mktemp("with_regulator") / "out"
    return autobal.run("pump_pe600_statics", out=out)["statics"], out


def _line(text: str, symbol: str) -> str:
    return next(x for x in text.splitlines() if re.match(rf"\s+\S.*\s{re.escape(symbol)}\s", x))


# --------------------------------------------------------------------------------------------------------------
# a device without a regulator
# --------------------------------------------------------------------------------------------------------------


def test_no_regulator_has_no_regulator_states_in_results_json_and_csv(no_regulator):
    _, res, out = no_regulator
    s = json.loads((out / "results.json").read_text())["statics"]
    assert not REGULATOR_KEYS & set(s["exact"])
    assert not {"xi0", "psi_cam0"} & set(s["closed_form"])
    assert not {"xi", "psi_cam", "regulator_saturated"} & (set(s["sweep"]) | set(s["sweep_refined"]))
    assert not {"xi", "psi_cam"} & set(s["sweep"]["closed_form"])
    assert "psi1_kr_regulator_saturated" not in s["critical_exact"] and "x_B" not in s["scales"]
    assert "xi_max" not in s["groups"]
    text = json.dumps(s)
    assert "null" not in text  # nothing left over as a null 'the device has no regulator'
    with open(out / "statics_sweep.csv", newline="") as f:
        header = next(csv.reader(f))
    assert not [h for h in header if re.match(r"(x|xi|pcam|psi_cam|regulator_saturated)\b", h)], header
    assert "Q_e [L/s]" in header and "z [µm]" in header


def test_no_regulator_verdict_and_summary_never_say_regulating(no_regulator):
    _, res, _ = no_regulator
    ok, words = res.verdict()
    assert ok and "regulating" not in words and "no regulator" in words
    text = res.summary()
    assert "regulating" not in text and "valve" not in text and "saturated" not in text
    assert not re.search(r"^\s+(xi0|psi_cam0)\s", text, re.M)
    assert not re.search(r"\s(x0|p_cam)\s", text)


def test_no_regulator_closed_forms_state_their_assumption_and_it_holds_here(no_regulator):
    """The closed forms assume an ideal regulator (p_e - p1 held at dpsi p_B); a device without a regulator has
    exactly that barrier supply, so its exact operating point is the exact ideal-regulator root (2.22) of the
    source (closed_form.pump_quadratic), an independent solution, to round-off."""
    _, res, _ = no_regulator
    ex, cf = res.exact, res.closed_form
    text = res.summary()
    assert "ideal regulator" in text and "as the barrier supply of this device (no regulator) does" in text
    assert ex.psi2_0 == pytest.approx(cf.psi2_0_quadratic, rel=1e-10)
    assert ex.psi3_0 == pytest.approx(cf.psi3_0_quadratic, rel=1e-10)
    assert ex.u0 == pytest.approx(cf.u0_quadratic, rel=1e-10)
    # the barrier margin is the scene's, held: p_e - p1 = dpsi p_B (Pavlenko 2014, Eq. (2.18))
    assert ex.dp == pytest.approx(res.dpsi * res.scales.p_B, rel=1e-12)
    assert ex.dp == pytest.approx(ex.pe - ex.p1, rel=1e-12)
    assert ex.psi_e0 == pytest.approx(cf.psi_e0, rel=1e-14)


def test_no_regulator_result_round_trips_without_the_regulator_keys(no_regulator):
    """The typed StaticsResult of a device without a regulator: its block has none of the regulator's keys (the
    optional fields are left out), comes back equal through results.json, and loads back with the same report."""
    _, res, out = no_regulator
    saved = json.loads((out / "results.json").read_text())["statics"]
    assert not REGULATOR_KEYS & set(saved["exact"]) and "x_B" not in saved["scales"]
    assert "psi_cam" not in saved["sweep"] and "xi" not in saved["sweep_refined"]
    back = type(res).from_dict(saved)
    assert back == res and json.dumps(plain(back.to_dict())) == json.dumps(saved)
    assert not back.has_regulator and back.exact.x0 is None and back.sweep.regulator_saturated is None
    done = autobal.load_run(out)
    assert done["statics"] == res and report.html(out) == (out / report.REPORT).read_text(encoding="utf-8")


def test_no_regulator_numbers_beside_the_verdict_agree(no_regulator):
    """The verdict's ratio p1_kr/p1 is the critical row's; the exact critical discharge ratio is where the
    inner-seal flow changes sign (re-solved on either side of it); the critical margin is below the operating one."""
    scene, res, _ = no_regulator
    ex, crit = res.exact, res.critical_exact
    _, words = res.verdict()
    assert f"reverses at {crit.p1_kr / ex.p1:.3g} × the operating discharge pressure" in words
    q = QUANTITIES.find("exact.dp")
    assert f"operating barrier margin {q.text(ex.dp)} against the critical {q.text(crit.dp_kr)}" in words
    assert 0 < crit.dp_kr < ex.dp
    solver = StaticsSolver(design(scene.device))
    kr = crit.psi1_kr
    below, above = solver.solve(0.99 * kr, res.dpsi), solver.solve(1.01 * kr, res.dpsi)
    assert below.flows["1"] > 0 > above.flows["1"]


def test_no_regulator_gap_figure_has_no_valve_panel_and_no_legend_for_undrawn_lines(no_regulator):
    _, res, _ = no_regulator
    figs = res.figures()
    fig = figs["fig_gap.png"]
    assert len(fig.axes) == 1
    (ax,) = fig.axes
    labels = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
    assert labels and not [lab for lab in labels if "valve" in lab or "nan" in lab]
    # the exact p1_kr (544.6 MPa, 16.9 x p1) is beyond the sweep: neither drawn nor in the legend
    assert not [lab for lab in labels if "exact" in lab and "kr" in lab]
    lo, hi = ax.get_xlim()
    for line in ax.lines:
        x = np.asarray(line.get_xdata(), float)
        if line.get_label() in labels and x.size:
            assert np.any((x >= lo) & (x <= hi)), line.get_label()
    assert "nan" not in (fig._suptitle.get_text() if fig._suptitle else "")
    pressures = [t.get_text() for legend in figs["fig_pressures.png"].legends for t in legend.get_texts()]
    assert not [lab for lab in pressures if "cam" in lab] and any("ideal regulator" in lab for lab in pressures)


def test_no_regulator_report_has_no_valve_rows_and_labels_the_closed_forms(no_regulator):
    _, _, out = no_regulator
    results = json.loads((out / "results.json").read_text())
    (sec,) = report.sections(results)
    assert "regulating" not in sec["overall"]["text"] and "no regulator" in sec["overall"]["text"]
    symbols = [row[1]["text"] for t in sec["tables"] if t["headline"] for row in t["rows"]]
    assert "z0" in symbols and not {"x0", "ξ0 = x0/x_B", "p_cam"} & set(symbols)
    closed = next(t for t in sec["tables"] if t["caption"].startswith("The source's closed forms"))
    assert "ideal regulator" in closed["caption"]
    assert not {"ξ0", "ψ_cam0"} & {row[0]["text"] for row in closed["rows"]}
    html = (out / "report.html").read_text()
    assert "regulating" not in html and "valve chamber" not in html and "regulator saturated" not in html


# --------------------------------------------------------------------------------------------------------------
# the barrier margins: operating and critical
# --------------------------------------------------------------------------------------------------------------


def test_margin_labels_say_operating_and_critical(with_regulator):
    """The shipped pump: p_e - p1 = 12.91 bar at the operating point (dpsi p_B = 0.04 x 32.27 MPa, held by the
    regulator), the critical margin 3.162 bar: each line says which it is."""
    res, out = with_regulator
    assert res.exact.dp == pytest.approx(0.04 * 32.27490e6, rel=1e-9)  # Pavlenko (2014), App. A: dpsi = 0.04
    text = res.summary()
    assert re.search(r"operating barrier margin p_e − p1\s+Δp\s+12\.91 bar$", _line(text, "Δp"))
    assert re.search(r"critical barrier margin p_e − p1 .*Δp_kr\s+3\.162 bar$", _line(text, "Δp_kr"))
    for line in text.splitlines():  # every line quoting a margin in bar names which one it is
        for value in re.findall(r"(\d+\.\d+) bar", line):
            kind = "operating" if value == "12.91" else "critical"
            assert kind in line or "δψ p_B" in line, line
    (sec,) = report.sections(json.loads((out / "results.json").read_text()))
    rows = {row[1]["text"]: row for t in sec["tables"] if t["headline"] for row in t["rows"]}
    assert rows["Δp"][0]["text"].startswith("operating barrier margin")
    assert rows["Δp_kr"][0]["text"].startswith("critical barrier margin")
    assert rows["Δp"][2]["text"] == "12.91" and rows["Δp_kr"][2]["text"] == "3.162"


def test_regulated_closed_forms_say_where_the_ideal_regulator_fails(with_regulator):
    """With the regulator the exact critical point has the valve on its stop (psi1_kr 1.2235, Pavlenko (2014)
    App. A's supply saturates near psi1 = 1.19): the closed form's 1.73 of (2.32) assumes an ideal regulator, and
    the summary says so beside it."""
    res, _ = with_regulator
    assert res.critical_exact.psi1_kr_regulator_saturated is True
    text = res.summary()
    assert "they assume an ideal regulator (p_e − p1 held at δψ p_B = 12.91 bar)" in text
    row = next(x for x in text.splitlines() if x.split()[:1] == ["psi1_kr"])
    assert "where the ideal regulator does not hold" in row
    assert "regulating" in res.verdict()[1]
    assert None not in (res.closed_form.xi0, res.closed_form.psi_cam0) and len(res.figures()["fig_gap.png"].axes) == 2


# --------------------------------------------------------------------------------------------------------------
# the AFC: one headline curve, the source's forcing apart
# --------------------------------------------------------------------------------------------------------------


def _dynamics(folder, forcing: str | None):
    """The shipped pump dynamics, its frequency analysis alone, on a coarser grid; forcing None: the scene names
    none (the default)."""

    def edit(d):
        f = copy.deepcopy(d["analyses"]["frequency"])
        f.pop("forcing")
        if forcing is not None:
            f["forcing"] = forcing
        f["omega"]["points"] = 200
        d["analyses"] = {"frequency": f}
        d["name"] = f"pump_dynamics_{forcing or 'default'}"

    scene = autobal.load(_scene_file(folder, "pump_pe600_dynamics", edit))
    out = folder / scene.name
    return autobal.run(scene, out=out)["frequency"], json.loads((out / "results.json").read_text())


@pytest.fixture(scope="module")
def afc_default(tmp_path_factory):
    return _dynamics(tmp_path_factory.mktemp("afc"), None)


@pytest.fixture(scope="module")
def afc_appendix(tmp_path_factory):
    return _dynamics(tmp_path_factory.mktemp("afc"), "appendix")


def test_default_forcing_is_the_physical_one_and_the_headline_is_its_curve(afc_default):
    res, results = afc_default
    f = results["frequency"]
    assert f["forcing"] == "physical" and f["headline"]["forcing"] == "physical"
    # the headline and the scene's-forcing curve of the energy-consistent model are one curve
    assert f["headline"]["peaks"] == f["models"]["nonlinear"]["peaks"]
    assert f["headline"]["peaks"][0]["amplitude"] == pytest.approx(15.44e-6, abs=1e-8)  # shipped pump, physical
    text = res.summary()
    amp = AMPLITUDE.text(f["headline"]["peaks"][0]["amplitude"])
    assert text.count(amp) == 1, text
    assert text.count("energy-consistent") == 1
    head, _, validation = text.partition("validation against the source")
    assert "program model" not in head and "program model" in validation


def test_the_source_forcing_is_validation_only(afc_appendix):
    """A scene naming the appendix forcing (the source's, App. A): the energy-consistent model under it
    (31.6 µm) is in the validation part, labelled with that forcing; the verdict's part has the headline alone."""
    res, results = afc_appendix
    f = results["frequency"]
    h, nl = f["headline"], f["models"]["nonlinear"]
    assert (h["forcing"], nl["forcing"]) == ("physical", "appendix")
    assert h["peaks"][0]["amplitude"] == pytest.approx(15.44e-6, abs=1e-8)
    assert nl["peaks"][0]["amplitude"] == pytest.approx(31.56e-6, abs=1e-8)
    text = res.summary()
    appendix = AMPLITUDE.text(nl["peaks"][0]["amplitude"])
    head, _, validation = text.partition("validation against the source")
    assert appendix not in head and appendix in validation
    assert "the source's appendix forcing" in validation.splitlines()[0]
    assert "the scene's forcing" not in text
    (sec,) = report.sections(results)
    amplitude = report.number(AMPLITUDE.shown(nl["peaks"][0]["amplitude"]))
    cells = [c["text"] for t in sec["tables"] for row in t["rows"] for c in row]
    assert amplitude not in cells and "appendix" not in cells
    validation_cells = [c["text"] for t in sec["validation_tables"] for row in t["rows"] for c in row]
    assert amplitude in validation_cells
    assert all("source's appendix forcing" in t["caption"] for t in sec["validation_tables"])
    labels = {key: label for key, _c, _s, label in res._styles()}
    assert labels["nonlinear"].startswith("energy-consistent (nonlinear), appendix forcing")
