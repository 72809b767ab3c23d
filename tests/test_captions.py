"""Figures carry their captions and the quantity on their axes (analysis/run/figures.py); the sources' published values
are a data file (autobal/published.yaml) whose keys are key paths of the Results' declarations."""

from __future__ import annotations

import json

import pytest
from markupsafe import escape

from autobal import analyses, report, scenario
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import display_units
from autobal.analysis.run.result import new_figure

SHIPPED = [p.stem for p in scenario.shipped()]
FAST = ("pump_pe600_statics", "compressor_k180_dynamics", "rig_table43_fit")
NEEDS_ROSS = pytest.mark.extra("ross")  # a scene with a ross_rotor section
#: a display unit for each kind the fast scenes' axes show, none of them the default
CHOICE = {"length": "mm", "pressure": "bar", "force": "N", "flow": "L/min", "time": "h"}


def captioned(run) -> dict[str, Figure]:
    """Every figure of a run, file name -> Figure, checked to be captioned."""
    out = {}
    for name in run:
        for file, fig in run[name].figures().items():
            assert isinstance(fig, Figure), f"{name}/{file}: figures() returns {type(fig).__name__}, not a Figure"
            words = fig.caption
            assert len(words) > 20 and words[0].isupper() and file.removesuffix(".png") not in words, (file, words)
            out[file] = fig
    return out


def labelled_in_their_units(figures: dict[str, Figure]) -> int:
    """Assert that each axis whose quantity a figure records is labelled in the unit it shows; the count."""
    n = 0
    for file, fig in figures.items():
        for axis in fig.quantities:
            assert axis.shown == "1" or f", {axis.shown}" in axis.label, (file, axis)
            n += 1
    return n


def test_a_figure_without_a_caption_is_an_error():
    fig, _ = new_figure()
    for words in ("", "  ", None):
        with pytest.raises(ValueError, match="caption"):
            Figure(fig, words)
    assert Figure(fig, "A drawing.").axes == fig.axes  # the matplotlib figure's attributes read through it


@pytest.mark.parametrize("name", FAST)
def test_the_figures_of_a_fast_scene_have_captions_written_and_shown(shipped_run, name):
    run, folder = shipped_run(name)
    figures = captioned(run)
    results = json.loads((folder / "results.json").read_text())
    assert results["captions"] == {file: f.caption for file, f in figures.items()}
    assert {p.name for p in folder.glob("*.png")} == set(figures)
    page = (folder / "report.html").read_text()
    for f in figures.values():
        assert f"{escape(f.caption)}</figcaption>" in page


def test_the_statics_axes_carry_their_quantities_in_the_chosen_units(shipped_run):
    """Pavlenko (2014), Figs. 2.4-2.6: every dimensional axis of the statics figures says which quantity (SI unit)
    it shows and in which unit; a choice of units reaches them."""
    run = shipped_run("pump_pe600_statics")[0]
    with display_units(CHOICE):
        figures = captioned(run)
        assert labelled_in_their_units(figures) == 9
    gap = {(a.which, a.si, a.shown) for a in figures["fig_gap.png"].quantities}
    assert gap == {("x", "Pa", "bar"), ("y", "m", "mm")}
    force = figures["fig_force_gap.png"].quantities
    assert [(a.si, a.shown) for a in force] == [("m", "mm"), ("N", "N")]
    assert force[0].label.startswith("face gap z, mm")
    default = captioned(run)["fig_gap.png"].quantities  # the declared units: the gap in µm, the opening in mm
    assert [a.shown for a in default] == ["µm", "MPa", "mm"] and default[0].label.startswith("face gap z, µm")


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(p.stem, marks=[NEEDS_ROSS] * ("ross_rotor:" in p.read_text()))
                                  for p in scenario.shipped() if p.stem not in FAST])
def test_every_figure_of_a_shipped_scene_has_its_caption(shipped_run, name):
    run, folder = shipped_run(name)
    figures = captioned(run)
    labelled_in_their_units(figures)
    results = json.loads((folder / "results.json").read_text())
    assert results["captions"] == {file: f.caption for file, f in figures.items()}
    assert {p.name for p in folder.glob("*.png")} == set(figures)


def test_the_published_values_are_keyed_by_declared_paths():
    """Each row of autobal/published.yaml names a shipped scene, an analysis it runs and a key path that the
    analysis' Result declares with the row's SI unit: a renamed field fails here, not as a missing row."""
    rows = report.published()
    assert sum(len(r) for a in rows.values() for r in a.values()) == 40
    assert report.quantity("statics.closed_form.no_such_key") is None  # an unknown path is not found
    for scene, by_analysis in rows.items():
        assert scene in SHIPPED
        for analysis, table in by_analysis.items():
            assert analysis in analyses.MODULES and analysis in scenario.load(scene).analyses.model_fields_set
            for label, _, key, value, unit, where in table:
                q = report.quantity(f"{analysis}.{key}")
                assert q is not None and q.unit == unit, (scene, analysis, key)
                assert isinstance(value, float) and value > 0 and where.startswith("Pavlenko (2014), "), label


def test_the_report_compares_with_the_published_values_of_the_file(shipped_run):
    """The statics comparison (Pavlenko 2014, App. A): one row per row of the file, the published value shown."""
    folder = shipped_run("pump_pe600_statics")[1]
    page = (folder / "report.html").read_text()
    part = page[page.index("Comparison with the source&#39;s published values"):]
    part = part[:part.index("</table>")]
    rows = report.published()["pump_pe600_statics"]["statics"]
    assert part.count("<tr>") == len(rows) + 1
    for label, _, _, _, _, where in rows:
        assert escape(label) in part and escape(where) in part
