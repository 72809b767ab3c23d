"""Declared quantities of liquid_balancer, estimation, montecarlo and rotor_dynamics (issue #23): every number of
their blocks is declared (the walker of tests/test_quantities.py covers them and fails on an undeclared key), the
terminal summaries print the declared display units (g·cm, mm, mL, µm, MPa, L/s, rpm beside rad/s), and a printed
value is the SI value of results.json converted."""

from __future__ import annotations

import json
import math
import re
import shutil

import pytest
import yaml

from autobal import api, cli, report, scenario
from autobal.analysis.run import executor as ex
from autobal.analysis.studies import montecarlo as mc
from autobal.parts.device import design
from tests.test_quantities import FAST, SLOW, check_declared

MINE = {"liquid_balancer": "autobal.analysis.studies.liquid_balancer",
        "estimation": "autobal.analysis.studies.estimation_study",
        "montecarlo": "autobal.analysis.studies.montecarlo", "rotor_dynamics": "autobal.analysis.studies.rotor_study"}


def line(out: str, symbol: str) -> str:
    """The summary line of the headline quantity ``symbol`` (description, symbol, value and unit)."""
    return next(x for x in out.splitlines() if re.match(rf"\s+\S.*\s{re.escape(symbol)}\s+\S", x))


def value(text: str, unit: str) -> float:
    """The number printed before ``unit`` in a summary line."""
    return float(re.search(rf"(-?[\d.]+(?:e-?\d+)?) {re.escape(unit)}(?:\s|\)|,|$)", text).group(1))


def test_the_four_analyses_are_declared_and_each_has_a_shipped_scene_the_walker_runs():
    assert {k: report.DECLARED.get(k) for k in MINE} == MINE
    assert not set(MINE) & set(report.UNDECLARED)
    assert not hasattr(report, "_UNDECLARED_RULES")  # no unit rule keyed on names at all
    walked = {a for name in (*FAST, *SLOW) for a in scenario.load(name).analyses.model_dump(exclude_none=True)}
    assert set(MINE) <= walked


@pytest.mark.cli
def test_the_walker_fails_on_an_undeclared_number(shipped_run, tmp_path):
    """check_declared (tests/test_quantities.py) on a copy of the estimation run with one number added."""
    folder = tmp_path / "copy"
    shutil.copytree(shipped_run("rig_table43_fit")[1], folder)
    check_declared(folder)
    results = json.loads((folder / "results.json").read_text())
    results["estimation"]["fits"]["static_1p"]["leak_flow"] = 1e-3
    (folder / "results.json").write_text(json.dumps(results))
    with pytest.raises(AssertionError, match="estimation: numbers without a declaration"):
        check_declared(folder)


@pytest.mark.cli
def test_liquid_balancer_summary_in_engineering_units(capsys, tmp_path):
    """`autobal run washer_liquid_balancer_nested`: the unbalances in g·cm as Khomyak (2020) writes them, the
    working speed in rad/s with rpm beside, Pashkov's deflection in mm; the numbers those of results.json."""
    assert cli.main(["run", "washer_liquid_balancer_nested", "--out", str(tmp_path / "out")]) == 3 - 3
    out = capsys.readouterr().out
    lb = json.loads((tmp_path / "out" / "results.json").read_text())["liquid_balancer"]
    assert "NOT OK: NO balancing equilibrium at γ = 1.472" in out  # one verdict, first
    assert value(line(out, "D0"), "g·cm") == pytest.approx(lb["system"]["D0"] / 1e-5, rel=5e-4)  # 3000 g·cm
    assert value(line(out, "D"), "g·cm") == pytest.approx(lb["operating_point"]["D"] / 1e-5, rel=5e-4)
    speed = line(out, "ω")
    assert value(speed, "rad/s") == pytest.approx(87.9, rel=5e-4)
    assert value(speed, "rpm") == pytest.approx(lb["operating_point"]["omega"] * 60 / (2 * math.pi), rel=5e-4)
    multi = next(x for x in out.splitlines() if x.startswith("  Pashkov multi"))
    assert value(multi, "mm") == pytest.approx(lb["pashkov"]["multi"]["deflection"] * 1e3, rel=5e-4)
    assert value(multi, "rpm") == pytest.approx(lb["pashkov"]["multi"]["critical_speed"] * 30 / math.pi, rel=5e-4)
    assert "kg*m" not in out and "m**3" not in out and "lambda0 = " not in out


@pytest.mark.cli
@pytest.mark.slow
def test_washer_optimum_in_mm_and_ml_and_the_unbounded_efficiency_says_why(shipped_run):
    """Khomyak (2020), App. В/Г: h_opt printed in mm, V_opt in mL; lambda0 of the singular optimum (k_D = 1) is
    not printed as an efficiency; the lambda0 row of the report says why it differs from Table 3.2 (1.30 at 0.4)."""
    run, folder = shipped_run("washer_liquid_balancer")
    out, lb = run["liquid_balancer"].summary(), run["liquid_balancer"].to_dict()
    assert value(line(out, "h_opt"), "mm") == pytest.approx(lb["optimal_height"]["optimum"] * 1e3, rel=5e-4)
    assert value(line(out, "V_opt"), "mL") == pytest.approx(lb["optimal_volume"]["optimum"] * 1e6, rel=5e-4)
    assert "optimal height: λ0 = 9.200e12 there is how close IPOPT came to k_D = 1, not an efficiency" in out
    sec = next(s for s in report.context(folder)["sections"] if s["name"] == "liquid_balancer")
    rows = {r[0]["text"]: r for r in sec["tables"][0]["rows"]}
    note = rows["efficiency e0/e_c (2.14), the source's algorithm"][-1]["text"]
    assert "Table 3.2 publishes 1.3 (theory)" in note and "D ≫ D0" in note, note


@pytest.mark.cli
def test_estimation_summary_one_verdict_bootstrap_and_correlation(shipped_run):
    """Pavlenko (2014), Table 4.3: the two-parameter fit's alpha and tau_max correlate at 0.986; the bootstrap
    intervals and the adequacy verdict are printed; the source's closed forms only in the validation part."""
    out = shipped_run("rig_table43_fit")[0]["estimation"].summary()
    lines = out.splitlines()
    assert lines[1].startswith("  NOT OK: static_1p (alpha): NOT adequate: the lack-of-fit test fails, F = 3.135 > "
                               "F_crit = 2.924 (p = 0.08721 < significance 0.1)")
    assert "correlation of alpha and tau_max: 0.9864 (the data hardly separate them)" in out
    assert re.search(r"alpha +2\.425 \+- 0\.48 +95 % CI \[1\.366, 3\.485\], bootstrap \(2000 refits\) "
                     r"\[1\.835, 5\.194\]", out)
    validation = lines.index("  validation against the source (Pavlenko 2014, Secs. 4.3.3-4.4):")
    assert [i for i, x in enumerate(lines) if "closed form" in x and i < validation] == []


@pytest.fixture(scope="module")
def montecarlo():
    """The shipped Monte Carlo scene with 4000 samples at two discharge ratios, no AFC."""
    scene = scenario.load("pump_pe600_montecarlo")
    from autobal.analyses.montecarlo import spec

    settings = scene.analyses.montecarlo.model_copy(update={"samples": 4000, "chunk_size": 2000, "afc": None,
                                                            "discharge_ratio": [0.75, 1.0]})
    return mc.run(design(scene.device), spec(settings), ex.InProcess(progress=False))


def test_montecarlo_gap_pressures_and_leak_in_engineering_units(montecarlo):
    """Pavlenko (2014), ch. 3: the face gap in µm, p1 in MPa and the face leak in L/s beside the source's spreads;
    z = u z_B and p = psi p_B scale every statistic; printed values are those of results.json converted."""
    d = montecarlo.to_dict()
    out = montecarlo.summary()
    ref, sc = d["reference"], d["scales"]
    assert ref["psi1"] == 1.0 and ref["p1"] == pytest.approx(32.2749e6, rel=1e-12)  # p_B of App. A
    assert value(line(out, "z̄"), "µm") == pytest.approx(ref["z_mean"] * 1e6, rel=5e-4)
    assert value(line(out, "σ_z"), "µm") == pytest.approx(ref["z_std"] * 1e6, rel=5e-4)
    assert value(line(out, "Q̄_T"), "L/s") == pytest.approx(ref["Q_T_mean"] * 1e3, rel=5e-4)
    assert value(line(out, "p1"), "MPa") == pytest.approx(32.27, rel=5e-4)
    assert 140e-6 < ref["z_mean"] < 148e-6 and 0.18 < ref["gap_spread"] < 0.22  # u0 0.96 z_B; conclusion 4: 0.20
    for k, (name, base) in mc.DIMENSIONAL.items():
        for stat in mc.SCALED:
            assert d["dimensional"][name][stat] == pytest.approx(
                [v * sc[base] for v in d["exact"][k][stat]], rel=1e-12, nan_ok=True), (name, stat)
    header = next(x for x in out.splitlines() if x.strip().startswith("psi1"))
    assert "p1 MPa" in header and "z µm" in header and "Q_T L/s" in header
    assert out.splitlines()[1].startswith("  ok: at ψ1 = 1: face gap ") and "µm ±" in out.splitlines()[1]
    assert montecarlo.quantities.undeclared(d) == []
    csv = montecarlo.tables()["montecarlo_statics.csv"]  # headers name the display unit, values converted
    assert csv["p1 [MPa]"] == pytest.approx([p * sc["p_B"] / 1e6 for p in d["psi1"]], rel=1e-12)
    assert csv["dimensional_z_mean [µm]"] == pytest.approx([u * sc["z_B"] * 1e6 for u in d["exact"]["u"]["mean"]],
                                                            rel=1e-12)
    assert csv["exact_Q_T_std [L/s]"] == pytest.approx([q * 1e3 for q in d["exact"]["Q_T"]["std"]], rel=1e-12)
    assert "exact_u_spread [1]" not in csv and "exact_u_mean [1]" in csv


@pytest.mark.cli
def test_rotor_dynamics_speeds_in_rpm_beside_rad_s(tmp_path):
    """Pashkov (2010), ch. 2: Omega0 = sqrt(c/m1) = 105 rad/s = 1002.7 rpm for the shipped run-up rotor; the step
    speeds are numbers in rad/s; speed ratios stay dimensionless."""
    d = yaml.safe_load(scenario.resolve("pashkov_runup").read_text())
    rd = d["analyses"]["rotor_dynamics"]
    rd["steps"] = {"psi": [0.5], "steps": [["0 rad/s", "150 rad/s"]], "duration": "0.2 s"}
    rd["passage"] |= {"psi": [1, 0.5], "friction": ["10 1/s"], "crossover": False}
    del rd["lewis"]
    path = tmp_path / "rotor.yaml"
    path.write_text(yaml.safe_dump(d))
    run = api.run(str(path), out=tmp_path / "out")
    out, block = run["rotor_dynamics"].summary(), run["rotor_dynamics"].to_dict()
    assert out.splitlines()[1].startswith("  ok: steady whirl asymptotically stable")
    omega0 = line(out, "Ω0")
    assert value(omega0, "rad/s") == pytest.approx(105.0, rel=5e-4)
    assert value(omega0, "rpm") == pytest.approx(block["rotor"]["Omega0_rad_s"] * 30 / math.pi, rel=5e-4)
    assert value(omega0, "rpm") == pytest.approx(1002.7, rel=5e-4)
    step = block["steps"]["table"][0]
    assert (step["omega_from"], step["omega_to"]) == (0.0, 150.0)
    steps = run["rotor_dynamics"].tables()["rotor_steps.csv"]
    assert steps["omega_to [rad/s]"] == [150.0] and steps["t_5pct_ms [ms]"] == [step["t_5pct_ms"]]
    assert steps["step"] == ["0->150"] and "psi [1]" in steps
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["units"]["rotor_dynamics.steps.table[].omega_to"] == "rad/s"
    assert results["units"]["rotor_dynamics.passage.table[].z_delta_max"] == "1"
    assert report.unit_of("rotor_dynamics.passage.crossover_n_star.0.5") == "1/s"  # keys like "0.5"
    check_declared(tmp_path / "out")
