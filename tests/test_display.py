"""Display units chosen by the scene (``display:``) and the CLI (``--units``): the terminal, the report tables, the
statics CSV headers and figure axes show them, results.json stays SI; figures written as SVG beside the PNG; the
report's print stylesheet."""

from __future__ import annotations

import csv
import json
import re
import shutil
import subprocess

import pytest
import yaml

from autobal import cli, report, scenario
from autobal.analysis.run.quantities import (
    DISPLAY_UNITS,
    KINDS,
    Quantity,
    convert,
    display_units,
    significant,
    unit_of_kind,
    units_of_kind,
)

PUMP = yaml.safe_load(scenario.resolve("pump_pe600_statics").read_text())


def results(folder) -> dict:
    return json.loads((folder / "results.json").read_text())


def summary_line(out: str, symbol: str) -> str:
    """The summary line of a headline quantity (description, symbol, value unit)."""
    return next(x for x in out.splitlines() if re.match(rf"\s+\S.*\s{re.escape(symbol)}\s", x))


def headline_cell(page: str, key: str) -> tuple[str, str]:
    """(text, data-unit) of the report's headline cell of a results.json key."""
    m = re.search(rf'<td class="num" data-unit="([^"]*)" data-key="{re.escape(key)}">([^<]*)<', page)
    assert m, key
    return m.group(2), m.group(1)


def numbers(data: dict) -> str:
    """The numbers of a results.json: every analysis block and the units map, as JSON text."""
    return json.dumps({k: v for k, v in data.items() if k not in ("meta", "timing", "files", "outputs")},
                      sort_keys=True)


# ------------------------------------------------------------------------------------------ the conversion table
@pytest.mark.parametrize("kind, written, spelled", [
    ("flow", "m3/h", "m³/h"), ("flow", "m^3/h", "m³/h"), ("flow", "l/min", "L/min"), ("flow", "L/s", "L/s"),
    ("length", "um", "µm"), ("length", "μm", "µm"), ("length", " mm ", "mm"), ("area", "mm2", "mm²"),
    ("volume", "ml", "mL"), ("pressure", "mbar", "mbar"), ("speed", "rpm", "rpm"), ("speed", "Hz", "Hz"),
    ("acceleration", "rpm/s", "rpm/s"), ("acceleration", "rad/s^2", "rad/s²"), ("power", "kW", "kW"),
    ("unbalance", "g*mm", "g·mm"), ("time", "h", "h"),
])
def test_a_unit_is_read_as_engineers_write_it(kind, written, spelled):
    assert unit_of_kind(kind, written) == spelled


@pytest.mark.parametrize("kind, unit, message", [
    ("pressure", "kN", "'kN' is not a unit of pressure (Pa): write one of Pa, kPa, MPa, bar, mbar"),
    ("flow", "bar", "'bar' is not a unit of flow"),
    ("length", "in", "'in' is not a unit of length"),  # no imperial units
    ("colour", "red", "'colour' is not a kind of quantity; choose units for length, area"),
])
def test_a_unit_of_another_kind_is_refused_naming_the_units_to_write(kind, unit, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        unit_of_kind(kind, unit)


def test_every_kind_has_its_si_unit_and_the_units_engineers_use():
    for kind, (si, _) in KINDS.items():
        units = units_of_kind(kind)
        assert convert(1.0, si, units[0]) == 1.0 and len(units) >= 2, kind  # the SI unit first, and others
    for unit in ("kW", "W", "rpm/s", "m³/h", "bar", "mbar", "L/s", "µm", "kN"):
        assert unit in DISPLAY_UNITS
    assert convert(1.0, "W", "kW") == 1e-3 and convert(1e5, "Pa", "mbar") == pytest.approx(1000)
    assert convert(2 * 3.141592653589793, "rad/s^2", "rpm/s") == pytest.approx(60)
    assert convert(25.0, "um", "mm") == pytest.approx(0.025)  # results.json keeps AFC amplitudes in µm


def test_the_choice_reaches_every_declared_quantity_of_its_kind():
    """The mechanism is the declarations', not an analysis': under a choice every declared quantity whose unit
    is of that kind shows the chosen unit (and the same number converted), the others their declared unit."""
    choice = {"length": "mm", "pressure": "bar", "flow": "m³/h", "speed": "Hz", "force": "N", "time": "ms"}
    seen = set()
    for name in report.DECLARED:
        for q in report.declarations(name):
            kind = next((k for k, (si, _) in KINDS.items() if DISPLAY_UNITS.get(q.declared, (None,))[0] == si), None)
            with display_units(choice):
                shown = q.display
                value = q.shown(1.0)
            if kind in choice:
                seen.add(kind)
                assert shown == choice[kind], f"{name}: {q.key}"
                assert value == pytest.approx(convert(1.0, q.unit, choice[kind])), q.key
            else:
                assert shown == q.declared == q.display, q.key
    assert {"length", "pressure", "flow", "speed"} <= seen
    assert report.declarations("statics").find("exact.p2").display == "MPa"  # the choice ends with its block


def test_a_callers_choice_stands_over_the_scenes_and_blocks_nest():
    p = Quantity("p", "Pa")
    with display_units({"pressure": "bar", "length": "mm"}):
        with display_units({"pressure": "kPa", "flow": "m³/h"}, under=True):  # a scene's section, under the caller's
            assert p.display == "bar" and Quantity("Q", "m^3/s").display == "m³/h"
        with display_units({"pressure": "kPa"}):  # an inner block over the outer
            assert p.display == "kPa" and Quantity("z", "m", display="µm").display == "mm"
        assert p.display == "bar"
    assert p.display == "MPa"


def test_a_run_summary_in_a_callers_display_units(shipped_run):
    run = shipped_run("pump_pe600_statics")[0]
    p2 = run["statics"].exact.p2
    assert summary_line(run.summary(), "p2").endswith(f" {significant(p2 / 1e6)} MPa")
    with display_units({"pressure": "bar"}):
        assert summary_line(run.summary(), "p2").endswith(f" {significant(p2 / 1e5)} bar")
        assert "bar</td>" in run._repr_html_(figures=False)


def test_speeds_show_the_other_unit_beside():
    speed = Quantity("omega", "rad/s", display="rad/s")
    assert speed.text(659.734) == "659.7 rad/s (6300 rpm)"
    with display_units({"speed": "rpm"}):
        assert speed.text(659.734) == "6300 rpm (659.7 rad/s)"
    with display_units({"speed": "Hz"}):
        assert speed.text(659.734) == "105.0 Hz (6300 rpm)"


# ------------------------------------------------------------------------------------------ end to end
@pytest.mark.cli
def test_a_scene_display_section_and_the_units_option_change_what_a_person_reads(shipped_run, tmp_path, capsys):
    """`display:` in the scene and `--units` on the command line: the summary, the report's headline table and the
    statics CSV show bar, µm and m³/h, each number the SI value of results.json converted; results.json is the
    same as a run without them, byte for byte in its numbers and units."""
    _, default = shipped_run("pump_pe600_statics")
    scene = tmp_path / "pump.yaml"
    scene.write_text(yaml.safe_dump(PUMP | {"display": {"pressure": "bar", "flow": "L/min"}}, allow_unicode=True))
    out = tmp_path / "out"
    assert cli.main(["run", str(scene), "--out", str(out), "--units", "flow=m3/h,length=um", "--units",
                     "speed=rpm"]) == 0
    text = capsys.readouterr().out
    got, ref = results(out), results(default)
    assert numbers(got) == numbers(ref)  # results.json stays SI
    assert got["meta"]["scene_si"]["display"] == {"length": "µm", "pressure": "bar", "flow": "m³/h", "speed": "rpm"}
    ex = got["statics"]["exact"]
    for symbol, key, unit in (("p2", "p2", "bar"), ("p_e", "pe", "bar"), ("Q_e", "Q_e", "m³/h"),
                              ("Q_T", "Q_T", "m³/h"), ("z0", "z0", "µm"), ("x0", "x0", "µm")):
        si = {"bar": "Pa", "m³/h": "m^3/s", "µm": "m"}[unit]
        assert summary_line(text, symbol).endswith(f" {significant(convert(ex[key], si, unit))} {unit}"), symbol
        cell, shown = headline_cell((out / "report.html").read_text(encoding="utf-8"), f"statics.exact.{key}")
        assert shown == unit and float(cell) == pytest.approx(convert(ex[key], si, unit), rel=1e-3), key
    assert re.search(r"statics at p1 = [\d.]+ bar", text)
    with open(out / "statics_sweep.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {"p2 [bar]", "pe [bar]", "z [µm]", "x [µm]", "Q_e [m³/h]", "Q_T [m³/h]"} <= set(rows[0])
    sweep, p_B = got["statics"]["sweep"], got["statics"]["scales"]["p_B"]
    assert float(rows[0]["p2 [bar]"]) == pytest.approx(sweep["psi2"][0] * p_B / 1e5, rel=1e-12)
    assert float(rows[-1]["Q_e [m³/h]"]) == pytest.approx(sweep["Q_e"][-1] * 3600, rel=1e-12)
    assert "display units" in (out / "report.html").read_text(encoding="utf-8")


@pytest.mark.cli
def test_report_units_rewrites_the_tables_and_nothing_else(shipped_run, tmp_path, capsys):
    _, default = shipped_run("pump_pe600_statics")
    folder = tmp_path / "again"
    shutil.copytree(default, folder)
    before = (folder / "results.json").read_bytes()
    assert cli.main(["report", str(folder), "--units", "pressure=kPa"]) == 0
    page = (folder / "report.html").read_text(encoding="utf-8")
    p2 = results(folder)["statics"]["exact"]["p2"]
    cell, unit = headline_cell(page, "statics.exact.p2")
    assert unit == "kPa" and float(cell) == pytest.approx(p2 / 1e3, rel=1e-3)
    assert (folder / "results.json").read_bytes() == before
    assert cli.main(["report", str(folder)]) == 0  # without the option: the declared units again
    assert headline_cell((folder / "report.html").read_text(encoding="utf-8"), "statics.exact.p2")[1] == "MPa"


def test_statics_figure_axes_follow_the_choice(shipped_run):
    result = shipped_run("pump_pe600_statics")[0]["statics"]
    default = result.figures()
    assert default["fig_flows.png"].axes[0].get_ylabel().startswith("flow Q, L/s")  # as the tables: not L/min
    assert "discharge pressure p₁, MPa" in default["fig_pressures.png"].axes[0].get_xlabel()
    with display_units({"pressure": "bar", "flow": "m³/h", "length": "mm", "force": "N"}):
        figs = result.figures()
    assert "discharge pressure p₁, bar" in figs["fig_pressures.png"].axes[0].get_xlabel()
    assert figs["fig_flows.png"].axes[0].get_ylabel().startswith("flow Q, m³/h")
    assert figs["fig_gap.png"].axes[0].get_ylabel().startswith("face gap z, mm")
    assert figs["fig_force_gap.png"].axes[0].get_ylabel().startswith("balancing force F, N")
    p1 = result.exact.p1
    star = [line for line in figs["fig_pressures.png"].axes[0].lines if line.get_marker() == "*"][0]
    assert star.get_xdata()[0] == pytest.approx(p1 / 1e5, rel=1e-9)  # the operating point at p1 in bar


@pytest.mark.cli
@pytest.mark.parametrize("args, message", [
    (["--units", "pressure=kN"], "--units pressure=kN: 'kN' is not a unit of pressure (Pa): write one of Pa, kPa"),
    (["--units", "flow=bar"], "--units flow=bar: 'bar' is not a unit of flow"),
    (["--units", "colour=red"], "--units colour=red: 'colour' is not a kind of quantity"),
    (["--units", "pressure"], "--units pressure: write KIND=UNIT"),
    (["--set", "display.pressure=kN"], "display.pressure: 'kN' is not a unit of pressure"),
    (["--set", "display.colour=red"], "display.colour: unknown key"),
])
def test_a_bad_display_unit_is_exit_2_with_one_line(capsys, args, message):
    assert cli.main(["run", "pump_pe600_statics", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


@pytest.mark.cli
def test_a_bad_display_unit_in_a_scene_file_is_exit_2_naming_the_field(tmp_path, capsys):
    scene = tmp_path / "pump.yaml"
    scene.write_text(yaml.safe_dump(PUMP | {"display": {"flow": "kg"}}))
    assert cli.main(["check", str(scene)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "display.flow: 'kg' is not a unit of flow (m^3/s): write one of m³/s, L/s, L/min, m³/h" in err


# ------------------------------------------------------------------------------------------ SVG and paper
@pytest.mark.cli
@pytest.mark.parametrize("name", ["pump_pe600_statics", "pump_pe600_dynamics"])
def test_every_png_has_its_svg_beside_it_and_the_report_embeds_the_png(shipped_run, name):
    _, folder = shipped_run(name)
    pngs = sorted(p.stem for p in folder.glob("*.png"))
    assert pngs and pngs == sorted(p.stem for p in folder.glob("*.svg"))
    files = results(folder)["files"]
    assert all(f"{stem}.svg" in files and f"{stem}.png" in files for stem in pngs)
    for stem in pngs:
        svg = (folder / f"{stem}.svg").read_text()
        assert svg.lstrip().startswith("<?xml") and "<svg" in svg and "<text" in svg  # text kept as text
    page = (folder / "report.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == len(pngs) and "data:image/svg" not in page


def test_the_report_has_a_print_stylesheet_and_the_docs_say_how_to_print_it(shipped_run):
    page = (shipped_run("pump_pe600_statics")[1] / "report.html").read_text(encoding="utf-8")
    css = page[page.index("<style>"):page.index("</style>")]
    assert "@media print" in css and "@page" in css and "counter(pages)" in css
    assert re.search(r"section > h2 \{ break-before: page; \}", css)
    assert re.search(r"tr, li, figure[^{]*\{ break-inside: avoid; \}", css)
    assert "<thead>" in page  # table headers repeat on each page
    results_md = (scenario.SCENARIO_DIR.parent / "docs" / "results.md")
    if results_md.is_file():  # a source checkout (the installed package has no docs)
        text = results_md.read_text(encoding="utf-8")
        assert "--print-to-pdf" in text and "figures/report_print_page.png" in text


def test_the_running_header_cannot_leave_its_css_string():
    for title in ('a"b', "x</style><script>alert(1)</script>", "back\\slash", "ψ1 = p1/p_B · pump"):
        quoted = report.css_string(title)
        inner = quoted[1:-1]
        assert quoted[0] == quoted[-1] == '"'
        assert re.fullmatch(r'(?:[A-Za-z0-9 .,:;_\-()+]|\\[0-9a-f]{1,6} )*', inner), quoted


def _tool(name: str) -> str | None:
    return shutil.which(name)


@pytest.mark.slow
@pytest.mark.cli
@pytest.mark.skipif(not (_tool("chromium") and _tool("pdftotext")), reason="needs chromium and poppler-utils")
def test_the_printed_report_starts_each_analysis_on_a_page_of_its_own(shipped_run, tmp_path):
    """Print the pump dynamics report with headless Chromium: each analysis' title opens a page, every page has
    the running header and its number."""
    _, folder = shipped_run("pump_pe600_dynamics")
    pdf = tmp_path / "report.pdf"
    subprocess.run([_tool("chromium"), "--headless", "--no-sandbox", "--disable-gpu", "--no-pdf-header-footer",
                    f"--print-to-pdf={pdf}", (folder / "report.html").as_uri()], check=True, capture_output=True,
                   timeout=180)
    text = subprocess.run([_tool("pdftotext"), "-layout", str(pdf), "-"], check=True, capture_output=True,
                          text=True).stdout
    pages = text.split("\f")[:-1] if text.endswith("\f") else text.split("\f")
    assert len(pages) >= 4
    titles = [report.TITLES[n] for n in results(folder) if n in report.SECTIONS]
    for title in titles:
        opening = [p for p in pages if title in "\n".join([x for x in p.splitlines() if x.strip()][:3])]
        assert opening, f"{title}: no page opens with it"
    for i, p in enumerate(pages, 1):
        assert "autobal report" in p and f"page {i} of {len(pages)}" in p, i


def test_every_result_saves_its_figures_through_the_one_place():
    """No Result class writes its files another way than Result.save (PNG with SVG beside, save_figures)."""
    import importlib
    import pkgutil

    import autobal.analysis
    import autobal.ocp
    from autobal.analysis.run.result import Result

    for package in (autobal.analysis, autobal.ocp):
        for module in pkgutil.walk_packages(package.__path__, f"{package.__name__}."):
            importlib.import_module(module.name)

    def subclasses(cls):
        for sub in cls.__subclasses__():
            yield sub
            yield from subclasses(sub)

    found = list(subclasses(Result))
    assert len(found) >= 12, [c.__name__ for c in found]
    assert [c.__name__ for c in found if c.save is not Result.save] == []
