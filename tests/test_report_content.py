"""What the reports carry (issue #23 item 5): the estimation report's bootstrap intervals, parameter correlation and
adequacy; nulls as one grouped note, not warnings; design parameters to 4 significant digits in engineering units;
headline values far from the published ones say why in their row."""

from __future__ import annotations

import pytest

from autobal import report
from autobal.analysis.studies.design_study import quantity, variable


@pytest.mark.cli
def test_estimation_report_shows_bootstrap_correlation_and_adequacy(shipped_run):
    """Pavlenko (2014), Table 4.3: the two-parameter fit's alpha and tau_max are correlated at 0.986."""
    folder = shipped_run("rig_table43_fit")[1]
    ctx = report.context(folder)
    sec = next(s for s in ctx["sections"] if s["name"] == "estimation")
    captions = [t["caption"] for t in sec["tables"]]
    assert any("bootstrap percentile interval" in c for c in captions)
    assert any(c.startswith("Adequacy: Fisher test") for c in captions)
    fitted = sec["tables"][0]
    assert fitted["columns"][-3:] == ["bootstrap low", "bootstrap high", "unit"]
    assert all(row[-2]["text"] != "—" for row in fitted["rows"]), "a free parameter without its bootstrap interval"
    correlation = next(t for t in sec["tables"] if t["caption"].startswith("Correlation of the free parameters"))
    assert [[c["text"] for c in r[:3]] for r in correlation["rows"]] == [["static_2p", "alpha, tau_max", "0.98636"]]
    assert sec["overall"]["text"].startswith("static_1p (alpha): NOT adequate: the lack-of-fit test fails, F = 3.135 > "
                                             "F_crit = 2.924 (p = 0.08721 < significance 0.1)")
    assert not sec["warnings"], "the trivial nulls are a note, not warnings"
    assert [n for n in sec["notes"] if n.startswith("10 values are null") and "a fixed parameter (5 values)" in n]


def test_null_note_groups_by_reason():
    block = {"a": None, "a_status": "fixed", "b": {"c": None, "c_status": "fixed", "d": None, "d_status": "fixed"},
             "e": [{"f": None, "f_status": "no bound"}]}
    assert report._null_note(block, "x") == ("4 values are null (no number), each with its reason in results.json: "
                                             "fixed (3 values); no bound: e[0].f")
    assert report._null_note({"a": 1.0}, "x") is None


def test_design_parameters_to_four_digits_in_engineering_units():
    def shown(path: str, value: float) -> str:
        return variable(f"device.{path}").text(value)

    assert shown("dynamics.disc_chamber_volume", 0.00020915546094574952) == "209.2 cm³"
    assert shown("barrier.margin_ratio", 0.09999999863063493) == "0.1000"
    assert shown("regulator.supply_pressure", 43662724.52325561) == "43.66 MPa"
    assert shown("disc.outer_seal.clearance", 0.00012108193232249605) == "0.1211 mm"
    assert shown("dynamics.regulator.spring_stiffness", 44636137.84295489) == "44.64 MN/m"
    assert shown("regulator.membrane_area", 0.0153604935) == "153.6 cm²"
    assert quantity("V2", 0.00020915546094574952) == "0.0002091554609 m^3"  # full precision for --set, no m**3


@pytest.mark.cli
@pytest.mark.slow
def test_washer_optimum_row_says_why_lambda0_is_unbounded(shipped_run):
    """Khomyak (2020), Table 3.3 publishes optima of 0.05-0.18 L; the toolkit's optimum is the complete-balancing
    point (k_D = 1), where lambda0 is unbounded: the row says so."""
    ctx = report.context(shipped_run("washer_liquid_balancer")[1])
    rows = {r[0]["text"]: r for r in ctx["sections"][0]["tables"][0]["rows"]}
    for label in ("optimal chamber height (largest λ0)", "optimal liquid volume (largest λ0)"):
        note = rows[label][-1]["text"]
        assert "balances completely (k_D = D0/D = 1, λ0 unbounded)" in note and "how close IPOPT came" in note, note
    assert "Table 3.3 measured 50-180 mL" in rows["optimal liquid volume (largest λ0)"][-1]["text"]
