"""The one verdict of a fit (issue #32): adequate only when Fisher's test (4.14) and the lack-of-fit test both pass
at the scene's significance, otherwise the failing test named with its F against F_crit and its p against the
significance; the fitted force groups in N / kN (a hand calculation); the CSV headers with their units.

The data are Pavlenko (2014), Table 4.3 (the fit guide's scenarios/examples/rig_face_gap.csv, in kN and mm):
twelve gaps in four groups of three repeats at tau = 0.5, 1, 1.5, 2 (p_B = 2 MPa, s_B = 0.01 m^2, h_TB = 0.15 mm).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

import autobal
from autobal.analysis.numerics.adequacy import decision, fisher_adequacy
from autobal.analysis.studies.estimation_study import EstimationResult, _physical
from autobal.models.hydroheel import TurbulentDisc

ROOT = Path(__file__).resolve().parents[1]
GUIDE_SCENE = ROOT / "scenarios" / "examples" / "rig_fit.yaml"
FORCE_BASE = 2e6 * 0.01  # p_B s_B = 20 kN


@pytest.fixture(scope="module")
def guide_fit(tmp_path_factory):
    """The fit guide's scene without its bootstrap (the verdict does not read it): (Run, output folder)."""
    folder = tmp_path_factory.mktemp("fit") / "rig_fit"
    scene = autobal.load(GUIDE_SCENE, set={"analyses.estimation.bootstrap": "null"})
    return autobal.run(scene, out=folder), folder


def _table43():
    """Table 4.3 as tau, u and group (read from the guide's data file: kN over p_B s_B, mm over h_TB)."""
    rows = [r.split(";") for r in (ROOT / "scenarios" / "examples" / "rig_face_gap.csv").read_text(
        encoding="utf-8-sig").splitlines()[1:] if r.strip()]
    group = np.array([float(r[0]) for r in rows])
    tau = np.array([float(r[2].replace(",", ".")) * 1e3 / FORCE_BASE for r in rows])
    u = np.array([float(r[3].replace(",", ".")) / 0.15 for r in rows])
    return tau, u, group


@pytest.mark.cli
def test_the_guides_one_parameter_fit_fails_the_lack_of_fit_test_by_hand(guide_fit):
    """alpha_only (tau_max held at 2.75): Fisher's test passes (F = 1.437 <= 2.660) but the lack-of-fit test fails,
    F = 3.135 > F_crit(0.90; 3, 8) = 2.924, p = 0.0872 < 0.1; the verdict says so, and the lack-of-fit F is the
    hand calculation sum n_i (u_fit - u_mean)^2/(n - l) over sum (u - u_mean)^2/(m - n) on the fitted alpha."""
    run, _ = guide_fit
    est = run["estimation"]
    ok, words = est.verdict()
    assert ok is False
    ad = est.to_dict()["fits"]["alpha_only"]["adequacy"]
    assert ad["adequate"] is False and ad["fisher_adequate"] is True and ad["lack_of_fit"]["adequate"] is False
    tau, u, group = _table43()
    alpha = est.estimates["alpha_only"]["alpha"]
    labels, idx = np.unique(group, return_inverse=True)
    sizes = np.bincount(idx)
    means = np.bincount(idx, u) / sizes
    fitted = TurbulentDisc(alpha, 2.75).gap(np.bincount(idx, tau) / sizes)
    n, m, l_ = len(labels), len(u), 1
    f_lof = (np.sum(sizes * (fitted - means) ** 2) / (n - l_)) / (np.sum((u - means[idx]) ** 2) / (m - n))
    assert_allclose(ad["lack_of_fit"]["F"], f_lof, rtol=1e-9)
    assert_allclose(ad["lack_of_fit"]["F_crit"], stats.f.ppf(0.9, 3, 8), rtol=1e-12)
    assert_allclose([ad["lack_of_fit"]["F"], ad["lack_of_fit"]["F_crit"], ad["lack_of_fit"]["p_value"]],
                    [3.135, 2.924, 0.08721], rtol=5e-4)
    assert ("alpha_only (alpha): NOT adequate: the lack-of-fit test fails, F = 3.135 > F_crit = 2.924 "
            "(p = 0.08721 < significance 0.1); Fisher's test (4.14) passes, F = 1.437 ≤ F_crit = 2.660") in words
    assert est.summary().splitlines()[1].startswith("  NOT OK: alpha_only (alpha): NOT adequate: the lack-of-fit")


@pytest.mark.cli
def test_a_fit_that_passes_both_tests_is_adequate(guide_fit):
    """both (alpha and tau_max free): Fisher F = 0.1411 <= 2.860 and lack of fit F = 0.3079 <= 3.113, p = 0.7433."""
    ad = guide_fit[0]["estimation"].to_dict()["fits"]["both"]["adequacy"]
    assert ad["adequate"] is True and ad["fisher_adequate"] is True and ad["lack_of_fit"]["adequate"] is True
    assert ad["decision"] == ("adequate: Fisher's test (4.14) passes, F = 0.1411 ≤ F_crit = 2.860 (p = 0.8699 ≥ "
                              "significance 0.1); the lack-of-fit test passes, F = 0.3079 ≤ F_crit = 3.113 "
                              "(p = 0.7433 ≥ significance 0.1)")


def test_the_decision_takes_every_test_and_names_each_that_fails():
    """Property of the decision: adequate iff every test passes; each failing test is named; a test that passes
    cannot outvote one that fails (here the source's Fisher test fails and the lack-of-fit test passes)."""
    base = {"F": 1.0, "F_crit": 2.0, "p_value": 0.4, "significance": 0.05}
    lof_ok = {"F": 1.5, "F_crit": 3.0, "p_value": 0.3, "adequate": True}
    lof_bad = {"F": 4.0, "F_crit": 3.0, "p_value": 0.02, "adequate": False}
    assert decision(base | {"lack_of_fit": lof_ok})[0] is True
    ok, words = decision(base | {"F": 2.5, "p_value": 0.03, "lack_of_fit": lof_ok})
    assert ok is False and words.startswith("NOT adequate: Fisher's test (4.14) fails, F = 2.500 > F_crit = 2.000 "
                                            "(p = 0.03000 < significance 0.05)")
    ok, words = decision(base | {"F": 2.5, "p_value": 0.03, "lack_of_fit": lof_bad})
    assert ok is False and "Fisher's test (4.14) fails" in words and "the lack-of-fit test fails, F = 4.000" in words
    ok, words = decision(base)  # no repeats: only Fisher's test
    assert ok is True and "no lack-of-fit test" in words
    assert decision({"F": None, "note": "needs more groups (2) than parameters (2)"})[0] is None


def test_fisher_adequacy_sets_adequate_from_both_tests_on_table43():
    """The source's design curve (alpha 1.75, tau_max 2.75, l = 2) on Table 4.3: Fisher's test passes (F = 2.62 <=
    2.86), the lack-of-fit test fails (F = 5.71 > 3.11): not adequate."""
    tau, u, group = _table43()
    ad = fisher_adequacy(tau, u, group, TurbulentDisc(1.75, 2.75).gap, 2, 0.1)
    assert ad["fisher_adequate"] and not ad["lack_of_fit"]["adequate"] and ad["adequate"] is False
    assert_allclose([ad["F"], ad["lack_of_fit"]["F"]], [2.615, 5.706], rtol=5e-4)
    assert "the lack-of-fit test fails, F = 5.706 > F_crit = 3.113" in ad["decision"]


@pytest.mark.cli
def test_fitted_tau_max_in_newtons_is_the_group_times_p_b_s_b(guide_fit):
    """F_max = tau_max p_B s_B with p_B s_B = 2 MPa x 0.01 m^2 = 20 kN: both's 4.623 -> 92.46 kN, its standard
    error and interval scaled alike; alpha_only's held 2.75 -> 55 kN; results.json in N, the summary in kN."""
    est = guide_fit[0]["estimation"]
    fits = est.to_dict()["fits"]
    p, ph = fits["both"]["parameters"]["tau_max"], fits["both"]["physical"]["F_max"]
    for k in ("estimate", "standard_error", "ci_low", "ci_high"):
        assert_allclose(ph[k], p[k] * FORCE_BASE, rtol=1e-12)
    assert_allclose(ph["estimate"], 92.46e3, rtol=5e-4)
    assert ph["scale"] == pytest.approx(FORCE_BASE) and ph["free"] is True
    fixed = fits["alpha_only"]["physical"]["F_max"]
    assert fixed["estimate"] == pytest.approx(2.75 * FORCE_BASE) and fixed["free"] is False
    assert "standard_error" not in fixed
    assert "alpha" not in fits["both"]["physical"]  # g_TB/g1: a ratio of conductances, no unit
    out = est.summary()
    assert "= closing load of the face F_max = τ_max p_B s_B = 92.46 kN +- 27 kN, CI [31.48, 153.4] kN" in out
    assert "= closing load of the face F_max = τ_max p_B s_B = 55.00 kN" in out
    assert est.quantities.find("fits.both.physical.F_max.estimate").unit == "N"


@pytest.mark.cli
def test_fitted_disc_stiffness_in_newtons_per_micrometre_by_hand(guide_fit):
    """c = -dF/dh = kappa p_B s_B/h_TB with kappa = -d tau/du of (4.16) = 3 alpha^2 u^2 tau^2/tau_max: both at
    tau = 1 (F = 20 kN): u = cbrt(3.623/alpha^2), c = 368.5 N/um; checked against a central difference of (4.16)."""
    est = guide_fit[0]["estimation"]
    st = est.to_dict()["fits"]["both"]["physical"]["stiffness"]
    alpha, tau_max = (est.estimates["both"][k] for k in ("alpha", "tau_max"))
    assert st["tau"] == pytest.approx([0.5, 1.0, 1.5, 2.0]) and st["load"] == pytest.approx([1e4, 2e4, 3e4, 4e4])
    u = ((tau_max / 1.0 - 1) / alpha**2) ** (1 / 3)
    kappa = 3 * alpha**2 * u**2 / tau_max  # tau = 1
    disc, du = TurbulentDisc(alpha, tau_max), 1e-6
    assert kappa == pytest.approx(-(disc.load(u + du) - disc.load(u - du)) / (2 * du), rel=1e-8)
    assert st["kappa"][1] == pytest.approx(kappa, rel=1e-12)
    assert st["value"][1] == pytest.approx(kappa * FORCE_BASE / 0.15e-3, rel=1e-12)
    assert st["value"][1] / 1e6 == pytest.approx(368.5, abs=0.05)
    assert est.quantities.find("fits.both.physical.stiffness.value").display == "N/µm"
    assert "N/µm at F in kN: 159.4 at 10.00, 368.5 at 20.00" in est.summary()


def test_preload_group_in_newtons_and_a_missing_force_base_says_so():
    """A device fit's chi -> F_pr = chi p_B s_B; without the force base no number, a status naming the base."""
    block = {"parameters": {"chi": {"estimate": 0.05, "free": True, "standard_error": 0.01, "ci_low": 0.03,
                                    "ci_high": 0.07}, "sigma": {"estimate": 2.0, "free": True}}}
    ph = _physical(block, {"force": 4e4})
    assert list(ph) == ["F_pr"] and ph["F_pr"]["estimate"] == pytest.approx(2e3)
    assert ph["F_pr"]["ci_high"] == pytest.approx(0.07 * 4e4)
    missing = _physical(block, {"force": None})["F_pr"]
    assert "estimate" not in missing and "force base" in missing["status"]


@pytest.mark.cli
def test_the_fits_csv_headers_carry_units(guide_fit):
    """The points and curve tables head each group '[1]' and its physical value with its unit (F in kN, h in mm,
    the group times its base); the parameters table has a unit column (kN for F_max)."""
    folder = guide_fit[1]

    def read(name):
        with (folder / name).open() as fh:
            rows = list(csv.reader(fh))
        return rows[0], rows[1:]

    head, rows = read("estimation_alpha_only_points.csv")
    assert head == ["tau [1]", "F [kN]", "u_measured [1]", "u_fitted [1]", "u_residual [1]", "h_measured [mm]",
                    "h_fitted [mm]", "h_residual [mm]"]
    first = [float(x) for x in rows[0]]
    assert first[:2] == pytest.approx([0.5, 10.0]) and first[5] == pytest.approx(0.1575)  # Table 4.3's first point
    assert first[1] == pytest.approx(first[0] * FORCE_BASE / 1e3) and first[5] == pytest.approx(first[2] * 0.15)
    head, _ = read("estimation_both_curve.csv")
    assert head[:2] == ["tau [1]", "F [kN]"] and "h_band_low [mm]" in head and "q_value [1]" in head
    assert not any(h.startswith("Q") for h in head)  # no flow base in the scene: the group only
    head, rows = read("estimation_parameters.csv")
    assert head == ["fit", "parameter", "free", "estimate", "standard_error", "ci_low", "ci_high", "unit"]
    f_max = next(r for r in rows if r[:2] == ["both", "F_max"])
    assert f_max[-1] == "kN" and float(f_max[3]) == pytest.approx(92.46, rel=5e-4)


@pytest.mark.cli
def test_the_report_concludes_with_the_same_verdict(guide_fit):
    """report.html's verdict is the one verdict (the same words), and its parameter table shows F_max in kN."""
    from autobal import report

    run, folder = guide_fit
    sec = next(s for s in report.context(folder)["sections"] if s["name"] == "estimation")
    assert sec["overall"]["ok"] is False and sec["overall"]["text"] == run["estimation"].verdict()[1]
    fitted = sec["tables"][0]
    row = next(r for r in fitted["rows"] if r[1]["text"].startswith("F_max"))
    assert row[0]["text"] == "both" and row[-1]["text"] == "kN" and row[2]["text"] == "92.46"
    assert EstimationResult.from_dict(run["estimation"].to_dict()).verdict() == run[
        "estimation"].verdict()
