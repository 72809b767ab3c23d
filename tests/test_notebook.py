"""Notebook display (issue #23 item 6): a Run and every Result render in Jupyter (``_repr_html_``: the verdict, the
headline table in display units, the figures), and their tables come as pandas DataFrames."""

from __future__ import annotations

import sys

import pytest

from autobal.analysis.run.result import Result


@pytest.fixture(scope="module")
def statics_run(shipped_run):
    return shipped_run("pump_pe600_statics")[0]


@pytest.mark.cli
def test_a_result_renders_its_verdict_headline_in_display_units_and_figures(statics_run):
    res = statics_run["statics"]
    html = res._repr_html_()
    assert "✔ operating point: regulating, face gap 143.9 µm" in html
    assert "<td>face gap at the operating point</td><td>z0</td><td>143.9</td><td>µm</td>" in html
    assert "<td>barrier flow (the leak of the device)</td><td>Q_e</td><td>11.29</td><td>L/s</td>" in html
    assert html.count("<img") == len(res.figures()) == 4 and "data:image/png;base64," in html
    rows = {r["key"]: r for r in res.headline()}
    assert rows["exact.p2"]["unit"] == "MPa" and rows["exact.p2"]["si_unit"] == "Pa"
    assert float(rows["exact.p2"]["value"]) == pytest.approx(rows["exact.p2"]["si_value"] / 1e6, rel=1e-3)


@pytest.mark.cli
def test_a_run_renders_one_verdict_per_analysis(statics_run):
    html = statics_run._repr_html_(figures=False)
    assert html.count("✔") + html.count("✘") == len(statics_run) == 1
    assert "Headline numbers" in html and "MPa" in html and "µm" in html and "<img" not in html


@pytest.mark.cli
@pytest.mark.extra("notebook")
def test_tables_as_dataframes(statics_run):
    import pandas as pd

    res = statics_run["statics"]
    frame = res.to_dataframe("statics_sweep.csv")
    assert isinstance(frame, pd.DataFrame) and list(frame.columns) == list(res.tables()["statics_sweep.csv"])
    assert len(frame) == len(res.to_dict()["sweep"]["psi1"])
    assert frame["p1 [MPa]"].iloc[0] == pytest.approx(8.0687, rel=1e-4)  # psi1 = 0.25 of p_B = 32.27 MPa
    assert set(statics_run.to_dataframe()) == set(statics_run.tables()) == {"statics_sweep.csv", "force_gap.csv"}
    with pytest.raises(KeyError, match="has no table 'nope.csv'; it has: statics_sweep.csv, force_gap.csv"):
        res.to_dataframe("nope.csv")


@pytest.mark.cli
def test_without_pandas_the_error_says_what_to_install(statics_run, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match="pip install pandas"):
        statics_run["statics"].to_dataframe()


def test_a_result_without_declarations_shows_its_summary():
    class Bare(Result):
        name = "bare"

        def summary(self) -> str:
            return "x = 1 <b>"

    html = Bare()._repr_html_()
    assert "<pre>x = 1 &lt;b&gt;</pre>" in html and "✔" not in html
