"""The one verdict of the liquid auto-balancer (issue #32): not ok when the liquid does not suffice or adds to the
unbalance, with what fails and by how much, while the run's status (solver failures) stays ok; each efficiency
labelled with its definition and equation (Khomyak (2020), Eqs. (2.14), (3.9), (3.14)); V_opt said what it is
optimal for.  Hand calculations on the Table 3.1 system: R = 0.2 m, h = 0.05 m, V = 150 mL, rho = 1000 kg/m^3,
M_p = 6.5 kg, M_k = 0.5 kg, m_d = 0.15 kg at e_d = 0.2 m (D0 = 0.03 kg m).
"""

from __future__ import annotations

import math

import pytest

from autobal.analysis.studies.liquid_balancer import EFFICIENCIES, QUANTITIES, OperatingPoint, balance_verdict

R, H, V, RHO, D0 = 0.2, 0.05, 150e-6, 1000.0, 0.15 * 0.2
LAYER = R - math.sqrt(R**2 - V / (math.pi * H))  # R - r: 2.402 mm


@pytest.mark.cli
def test_washer_verdict_is_not_ok_and_names_the_shortage_but_the_run_did_not_fail(shipped_run):
    """f = 36.49 mm (the source's algorithm at gamma = 0.4) against R - r = 2.402 mm: short by 34.09 mm; lambda0 =
    0.1423 < 1, the system's eccentricity 1/lambda0 = 7.03 times the rotor's.  A failed design, not a failed solve."""
    run, _ = shipped_run("washer_liquid_balancer")
    lb = run["liquid_balancer"]
    op = lb.to_dict()["operating_point"]
    assert op["sufficiency_ok"] is False
    assert lb.to_dict()["system"]["R_minus_r"] == pytest.approx(LAYER, rel=1e-12)
    assert LAYER * 1e3 == pytest.approx(2.402, abs=5e-4) and op["f"] * 1e3 == pytest.approx(36.49, abs=5e-3)
    ok, words = lb.verdict()
    assert ok is False
    assert (f"the liquid does NOT suffice: the deflection f = 36.49 mm exceeds the liquid layer R − r = 2.402 mm "
            f"by {(op['f'] - LAYER) * 1e3:.2f} mm") in words
    assert "λ0 = e0/e_c = 0.1423 < 1, the system's eccentricity e_c is 7.03 times the rotor's e0" in words
    assert lb.summary().splitlines()[1] == f"  NOT OK: {words}"
    assert lb.to_dict()["verdict"] == {"ok": False, "text": words}
    assert run.status == "ok" and run.failures == {} and lb.failures() == []


@pytest.mark.cli
def test_nested_washer_verdict_names_both_failures(tmp_path):
    """washer_liquid_balancer_nested at gamma = 1.472: no equilibrium (k_D < sin delta), and f > R - r."""
    from autobal import api

    run = api.run("washer_liquid_balancer_nested", out=tmp_path / "out")
    ok, words = run["liquid_balancer"].verdict()
    op = run["liquid_balancer"].to_dict()["operating_point"]
    assert ok is False and run.status == "ok"
    assert words.startswith("NO balancing equilibrium at γ = 1.472: no equilibrium (k_D < sin delta)")
    assert f"exceeds the liquid layer R − r = 2.402 mm by {(op['f'] - LAYER) * 1e3:.1f} mm" in words


def _verdict(lambda0, k_d, f, equilibrium=True):
    """The verdict of a balancer at gamma = 0.4 with R - r = LAYER (the numbers it does not read NaN)."""
    unread = dict.fromkeys(("omega", "delta_deg", "phi_deg", "G", "r", "x_p", "D", "alpha0_deg",
                            "lambda0_self_consistent", "lambda0_self_consistent_minus", "extremum_k_star",
                            "extremum_lambda0_max", "zeta_over_ec"), math.nan)
    op = OperatingPoint(**unread, gamma=0.4, f=f, k_D=k_d, lambda0=lambda0, variant="corrected",
                        equilibrium_exists=equilibrium, sufficiency_ok=bool(LAYER >= f), reason="")
    return balance_verdict(op, LAYER)


def test_a_balancer_that_reduces_the_unbalance_with_enough_liquid_is_ok():
    """lambda0 = 1.5 > 1 and f = 1 mm <= R - r: ok; complete balancing (lambda0 unbounded, null in results.json)
    is ok too; lambda0 = 0.9 with enough liquid is not (the liquid adds to the unbalance)."""
    ok, words = _verdict(1.5, 0.6, 1e-3)
    assert ok is True and words == ("a balancing equilibrium at γ = 0.4000 reduces the unbalance (λ0 = e0/e_c = 1.500 "
                                    "> 1); the liquid suffices: the liquid layer R − r = 2.402 mm ≥ the deflection "
                                    "f = 1.000 mm")
    assert _verdict(None, 1.0, 1e-3)[0] is True
    ok, words = _verdict(0.9, 0.47, 1e-3)
    assert ok is False and "λ0 = e0/e_c = 0.9000 < 1" in words and "1.11 times the rotor's e0" in words
    ok, words = _verdict(1.5, 0.6, 3e-3)
    assert ok is False and words.startswith("the liquid does NOT suffice: the deflection f = 3.000 mm exceeds the "
                                            "liquid layer R − r = 2.402 mm by 0.5983 mm")


@pytest.mark.cli
def test_each_efficiency_says_what_it_is(shipped_run):
    """lambda0 = 0.1423 and lambda0+ = 1.152 are both e0/e_c of (2.14), by the source's algorithm and by the
    self-consistent closure; Pashkov's E_e = (m + rho pi h R^2)/m = 1.879 by hand (m = 7.15 kg, 6.283 kg of liquid
    would fill the chamber), (3.9); why one exceeds 1: a reduction factor, not a share of energy."""
    run, _ = shipped_run("washer_liquid_balancer")
    out, d = run["liquid_balancer"].summary(), run["liquid_balancer"].to_dict()
    m = 6.5 + 0.5 + 0.15
    assert d["pashkov"]["single"]["efficiency"] == pytest.approx((m + RHO * math.pi * H * R**2) / m, rel=1e-12)
    assert d["pashkov"]["single"]["efficiency"] == pytest.approx(1.8788, abs=5e-5)
    assert "efficiency e0/e_c (2.14), the source's algorithm         λ0      0.1423" in out
    assert "efficiency e0/e_c (2.14), self-consistent f (extension)  λ0⁺     1.152" in out
    for label in EFFICIENCIES:
        assert f"  {label}" in out
    assert "Eq. (2.14)" in EFFICIENCIES[0] and "not a share of energy" in EFFICIENCIES[0]
    assert "a toolkit extension" in EFFICIENCIES[1]
    assert "Eqs. (3.9), (3.14)" in EFFICIENCIES[2] and "at least 1 by construction" in EFFICIENCIES[2]
    assert "E_e = e0/e" in QUANTITIES.find("pashkov.single.efficiency").description
    headline = {key: q for q, key, _ in QUANTITIES.headline(d)}
    assert "Eqs. (2.13)-(2.14)" in headline["operating_point.lambda0"].source


@pytest.mark.cli
def test_v_opt_says_what_it_is_optimal_for_and_how_it_compares_with_the_chamber(shipped_run):
    """V_opt = pi h R^2 - D0/(rho f) (complete balancing, k_D = 1, in the documented model) by hand: 5461 mL, 36.4
    times the scene's 150 mL and 86.9 % of the 6283 mL chamber; the empty core D0/(rho f) = 822.2 mL."""
    run, folder = shipped_run("washer_liquid_balancer")
    d = run["liquid_balancer"].to_dict()
    f = d["optimal_volume"]["f"]
    chamber = math.pi * H * R**2
    v_opt = chamber - D0 / (RHO * f)
    assert d["optimal_volume"]["optimum"] == pytest.approx(v_opt, rel=1e-9)
    line = next(x for x in run["liquid_balancer"].summary().splitlines() if x.startswith("  V_opt = "))
    assert line.startswith(f"  V_opt = {v_opt * 1e6:.0f} mL is the fill at which the documented model balances "
                           "completely (k_D = D0/D = 1, λ0 unbounded)")
    assert (f"{v_opt / V:.3g} times the scene's liquid (150.0 mL) and {100 * v_opt / chamber:.3g} % of the chamber "
            f"πR²h = {chamber * 1e6:.0f} mL") in line
    assert f"D0/(ρf) = {D0 / (RHO * f) * 1e6:.1f} mL" in line
    from autobal import report

    sec = next(s for s in report.context(folder)["sections"] if s["name"] == "liquid_balancer")
    rows = {r[0]["text"]: r for r in sec["tables"][0]["rows"]}
    assert rows["optimal liquid volume (largest λ0)"][-1]["text"].startswith(line.strip())
    assert sec["overall"]["ok"] is False and sec["overall"]["text"] == run["liquid_balancer"].verdict()[1]
    assert all(e in sec["notes"] for e in EFFICIENCIES)
