"""Declared quantities of the spin-up analyses (spinup, spinup_robust, spinup_time_optimal, ross_spinup): every
numeric leaf of their results.json blocks is declared, the terminal summaries and the report speak the engineer's
units (mm and µm beside delta/e, rpm beside rad/s, rpm/s beside rad/s², kW, N·m), a printed value is the SI value
of results.json converted, and each analysis has one verdict: the spin-up's is the optimum's peak deflection, its
gain against the best ramp within the drive limits and whether it brakes."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import re

import pytest

import autobal
from autobal import report
from autobal.analysis.run.quantities import significant
from autobal.ocp import robust_study, spinup_study, time_optimal_study
from autobal.ocp.modal_study import QUANTITIES as MODAL
from autobal.ocp.solve import ipopt_options
from tests.test_quantities import check_declared

SPIN = ("spinup", "spinup_robust", "spinup_time_optimal", "ross_spinup")
SCENE = "scenarios/spinup_rotor_datasheet.yaml"
# the datasheet rotor (120 kg, 2400 rpm, zeta 0.02, 45 kW, no braking) on a coarse mesh: a few seconds
SMALL = {"analyses.spinup.intervals": 40, "analyses.spinup.multistart": False, "analyses.spinup.segments": 2}
SCENES = {"spinup_robust": "spinup_robust_jeffcott", "spinup_time_optimal": "spinup_time_optimal",
          "ross_spinup": "spinup_ross_rotor"}


@pytest.fixture(scope="module")
def datasheet(tmp_path_factory):
    out = tmp_path_factory.mktemp("spin") / "datasheet"
    run = autobal.run(autobal.load(SCENE, set=SMALL), out=out)
    return run, out, json.loads((out / "results.json").read_text())


def line(text: str, symbol: str) -> str:
    """The summary's headline line of a symbol ('  description  symbol  value unit')."""
    return next(x for x in text.splitlines() if re.match(rf"\s+\S.*\s{re.escape(symbol)}\s+\S", x))


def printed(text: str, symbol: str) -> tuple[float, str]:
    """(value, unit) printed on the headline line of a symbol."""
    m = re.search(r"\s(-?[\d.]+(?:e-?\d+)?)\s?([^\s(]*)(?: \(.*\))?$", line(text, symbol))
    return float(m.group(1)), m.group(2)


def test_the_spinup_analyses_are_declared_and_have_no_name_rule():
    for name in SPIN:
        assert name in report.DECLARED and name not in report.UNDECLARED
        assert report.declarations(name) is not None
    assert not hasattr(report, "_UNDECLARED_RULES")  # no unit rule keyed on names at all


@pytest.mark.cli
def test_every_number_of_the_spinup_block_is_declared(datasheet):
    """The generic walker of tests/test_quantities.py on a spin-up run: every numeric leaf declared, the units
    map and the report's unit column from the declarations."""
    _, out, results = datasheet
    check_declared(out)
    assert results["units"]["spinup.max_power_W"] == "W" and results["units"]["spinup.peak_deflection_m"] == "m"
    assert results["units"]["spinup.rotor.critical_speed_rad_s"] == "rad/s"
    assert results["units"]["spinup.segments.start_objectives.fitted"] == "1"


def test_a_new_key_without_a_declaration_is_found():
    """The walker can fail: a number the declarations do not name is reported, one that they name is not."""
    block = {"peak_deflection_m": 1e-3, "peak_deflection_over_e": 20.2, "rotor": {"mass_kg": 120.0},
             "baselines": {"constant_ramp": {"peak_deflection_over_e": 21.4, "label": "ramp", "max_power_W": 4e4}},
             "starts": [{"iterations": 3, "solve_time_s": 0.2}], "peak_velocity_m_s": 0.3,
             "rotor_extra": {"mass_kg": 1.0}}
    assert spinup_study.QUANTITIES.undeclared(block) == ["peak_velocity_m_s", "rotor_extra.mass_kg"]
    assert robust_study.QUANTITIES.undeclared({"profiles": {"robust": {"validation_worst_over_e": 1.0}},
                                               "new_peak": 2.0}) == ["new_peak"]
    assert time_optimal_study.QUANTITIES.undeclared({"front": [{"arrival_time_s": 4.0, "jerk": 1.0}]}) \
        == ["front[].jerk"]
    assert MODAL.undeclared({"peak_deflection_m": 2e-5, "critical_speeds": {"new": [1.0]}}) \
        == ["critical_speeds.new"]


@pytest.mark.cli
def test_spinup_summary_prints_the_engineers_units(datasheet):
    run, _, results = datasheet
    text = run["spinup"].summary()
    assert printed(text, "δ*")[1] == "mm" and printed(text, "P_max")[1] == "kW"
    assert printed(text, "M_max")[1] == "N·m" and printed(text, "ω_cr")[1] == "rad/s"
    assert re.search(r"ω_cr\s+251\.3 rad/s \(2400 rpm\)$", line(text, "ω_cr"))  # the datasheet's 2400 rpm
    assert "e 50.00 µm" in text  # 6000 g·mm on 120 kg
    assert re.search(r"ramp 60 rad/s² \(573 rpm/s\) and hold", text)
    assert "0-peak" in text
    for raw in (" um", "N m", "m**", "rad/s^2", " W,", "max_power_W"):
        assert raw not in text, raw


@pytest.mark.cli
def test_printed_values_are_the_si_values_converted(datasheet):
    """Each printed headline number is its results.json SI value in the display unit, to the 4 digits shown."""
    run, _, results = datasheet
    d = results["spinup"]
    text = run["spinup"].summary()
    for symbol, si, factor in (("δ*", d["peak_deflection_m"], 1e3), ("P_max", d["max_power_W"], 1e-3),
                               ("M_max", d["max_torque_N_m"], 1.0), ("ω_cr", d["rotor"]["critical_speed_rad_s"], 1.0),
                               ("δ*/e", d["peak_deflection_over_e"], 1.0), ("SM", d["rotor"]["separation_margin_pct"],
                                                                            1.0)):
        value, _ = printed(text, symbol)
        assert value == pytest.approx(si * factor, rel=6e-4), symbol
    speed = re.search(r"\((\d+) rpm\)$", line(text, "ω_cr")).group(1)
    assert float(speed) == pytest.approx(d["rotor"]["critical_speed_rad_s"] * 30 / math.pi, rel=5e-4)
    # the physical deflection is e delta/e: the declared peak in mm is the eccentricity times the group
    assert d["peak_deflection_m"] == pytest.approx(d["peak_deflection_over_e"] * d["eccentricity_m"], rel=1e-12)
    # API 684 (2005): AF at the half-power points of the unbalance response (24.96, tests/test_standards.py), SM from
    # the service speed 4000 rpm to the response's peak 2400/sqrt(1 - 2 zeta^2) rpm
    assert d["rotor"]["amplification_factor"] == pytest.approx(24.96, abs=0.005)
    assert d["rotor"]["separation_margin_pct"] == pytest.approx(100 * (4000 - 2400 / math.sqrt(1 - 8e-4)) / 4000)


@pytest.mark.cli
def test_spinup_optimum_csv_has_rpm_and_mm_beside_si(datasheet):
    _, out, results = datasheet
    d = results["spinup"]
    with (out / "spinup_optimum.csv").open() as fh:
        rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    assert list(rows[0]) == ["time [s]", "speed [rpm]", "speed [rad/s]", "deflection_over_e [1]", "deflection [mm]",
                             "unbalance [1]", "torque [N·m]"]
    for r in rows:
        assert r["speed [rpm]"] == pytest.approx(r["speed [rad/s]"] * 30 / math.pi, rel=1e-12)
        assert r["deflection [mm]"] == pytest.approx(r["deflection_over_e [1]"] * d["eccentricity_m"] * 1e3,
                                                     rel=1e-12)
    assert max(r["deflection [mm]"] for r in rows) == pytest.approx(d["peak_deflection_m"] * 1e3, rel=1e-3)


@pytest.mark.cli
def test_spinup_verdict_is_the_peak_the_gain_and_braking(datasheet):
    """The report's one verdict of the spin-up: the peak in mm and delta/e, the gain against the best ramp within
    the drive limits (the fastest ramp and hold within 45 kW, never the 60 rad/s² ramp that needs 50 kW), and
    that the optimum does not brake (the scene forbids it); the NLP status is a check, not the verdict."""
    run, _, results = datasheet
    d = results["spinup"]
    (sec,) = report.sections(results)
    main = sec["overall"]
    assert main["ok"] is True
    gain = d["gain_vs_best_feasible_ramp_pct"]
    ref = d["baselines"][d["baseline_ramp_key"]]
    assert ref["within_drive_limits"] and d["baseline_ramp_key"] == "feasible_ramp"
    assert main["text"] == (f"peak deflection {d['peak_deflection_m'] * 1e3:.3f} mm 0-peak "
                            f"({d['peak_deflection_over_e']:.2f} e), {gain:+.1f} % against the best ramp within the "
                            f"drive limits ({ref['label']}); it does not brake")
    assert "Solve_Succeeded" not in main["text"]
    assert run["spinup"].verdict() == (True, main["text"])
    headline = {r[0]["text"]: (r[2]["text"], r[3]["text"]) for r in sec["tables"][0]["rows"]}
    assert headline["largest drive power of the optimum"] == (significant(d["max_power_W"] / 1e3), "kW")
    assert headline["peak deflection of the optimum over the eccentricity"][1] == "dimensionless"


def test_a_failed_solve_or_a_worse_optimum_is_not_ok():
    from tests.test_typed_ocp import spinup_result

    res = spinup_result(peak_deflection_m=1.2e-3, peak_deflection_over_e=12.0, gain_vs_best_feasible_ramp_pct=-5.0,
                        brakes=True, min_torque_N_m=-120.0, within_drive_limits=True)
    ok, words = res.verdict()
    assert ok and words.endswith("it brakes (smallest torque -120.0 N·m)") and "1.200 mm" in words
    ok, words = dataclasses.replace(res, status="Maximum_Iterations_Exceeded").verdict()
    assert ok is False and words.startswith("NLP solver Maximum_Iterations_Exceeded: peak deflection 1.200 mm")
    assert dataclasses.replace(res, gain_vs_best_feasible_ramp_pct=3.0).verdict()[0] is False
    ok, words = dataclasses.replace(res, gain_vs_best_feasible_ramp_pct=None, baseline_ramp_key=None).verdict()
    assert "no ramp keeps the drive limits: no gain is quoted" in words
    ok, words = dataclasses.replace(res, within_drive_limits=False, violated=["power limit"]).verdict()
    assert ok is False and "drive limits EXCEEDED (power limit)" in words


def test_robust_verdict_never_compares_with_a_ramp_outside_the_drive_limits():
    prof = {"robust": {"label": "robust", "validation_worst_over_e": 17.4},
            "nominal": {"label": "nominal", "validation_worst_over_e": 23.1},
            "ramp": {"label": "ramp", "validation_worst_over_e": 15.0, "within_drive_limits": False}}
    ok, words = robust_study.verdict(robust_study.Profiles.from_dict(prof), 1000, "1", 1e-4)
    assert ok and words.startswith("worst peak over 1000 validation rotors: robust 17.40 e (1.740 mm)")
    assert words.endswith("(outside the drive limits, not compared)")
    prof["ramp"]["within_drive_limits"] = True
    assert robust_study.verdict(robust_study.Profiles.from_dict(prof), 1000, "1", 1e-4)[0] is False


def test_time_optimal_verdict_is_the_earliest_arrival_under_the_limit():
    res = time_optimal_study.TimeOptimalResult(
        "t", "collocation", "1", eccentricity_m=1e-4, horizon_s=6.0, ramp_label="ramp", final_speed_rad_s=210.0,
        ramp_arrival_time_s=4.25, ramp_peak=14.15, front=[], monotone=True, build_time_s=0.0, solve_time_s=0.0,
        resimulation_rel_error=0.0, accuracy={}, deflection_limit=13.0, arrival_time_s=4.3, peak_deflection=12.99)
    ok, words = res.verdict()
    assert ok and words.startswith("earliest arrival at 210.0 rad/s (2005 rpm) with the peak ≤ 13.00 e (1.300 mm): "
                                   "4.300 s, peak 12.99 e (1.299 mm) (0.07692 % below the limit)")
    assert dataclasses.replace(res, peak_deflection=13.5).verdict()[0] is False
    ok, words = dataclasses.replace(res, deflection_limit=None, monotone=False).verdict()
    assert ok is False and "NOT monotone" in words


def test_ross_api684_values_of_each_critical_speed():
    """API 684 (2005) per critical speed below the final speed (autobal.analysis.numerics.standards.margin_check,
    computed in the run): in to_dict beside the critical speeds with their statuses, the final speed the optimum ends
    at; declared with the standard as the source."""
    from autobal.analysis.numerics.standards import HalfPower, margin_check
    from autobal.ocp.modal_study import CriticalSpeeds, Margin

    margins = [margin_check(HalfPower(91.78, 91.8, 1.0, 90.5, 93.1, 91.8 / 2.6), 350.0),
               margin_check(HalfPower(270.99, status="no peak of its own"), 350.0)]
    cs = CriticalSpeeds([91.78, 270.99], [0.01309, 0.0], [Margin(**m) for m in margins], None, None, None)
    d = cs.to_dict()["margins"]
    assert d[0]["amplification_factor"] == pytest.approx(91.8 / 2.6) and d[1]["amplification_factor"] is None
    assert d[1]["amplification_factor_status"] == "no peak of its own"
    assert [m["separation_margin_pct"] for m in d] == pytest.approx([100 * (350 - 91.8) / 350,
                                                                     100 * (350 - 270.99) / 350])
    assert d == margins and list(d[1]) == list(margins[1])  # margin_check's block, its statuses where it puts them
    assert MODAL.find("critical_speeds.margins.0.amplification_factor").source.startswith("API 684 (2005)")


def test_display_units_of_the_spinup_quantities():
    q = spinup_study.QUANTITIES.find
    assert q("peak_deflection_m").text(1.0104e-3) == "1.010 mm"
    assert q("max_power_W").text(44412.0) == "44.41 kW"
    assert q("min_torque_N_m").text(-120.0) == "-120.0 N·m"
    assert q("rotor.critical_speed_rad_s").text(2400 * math.pi / 30) == "251.3 rad/s (2400 rpm)"
    assert q("eccentricity_m").text(5e-5) == "50.00 µm"
    assert robust_study.QUANTITIES.find("ramps.0.alpha_rad_s2").text(40.0) == "40.00 rad/s² (382.0 rpm/s)"
    assert MODAL.find("unbalance.0.magnitude_kg_m").text(1e-4) == "100.0 g·mm"
    assert MODAL.find("peak_deflection_m").text(1.9574e-5) == "19.57 µm"


@pytest.mark.cli
def test_spinup_figures_speak_rpm_kw_and_mm(datasheet):
    run, _, _ = datasheet
    figs = run["spinup"].figures()
    axes = [a for f in figs.values() for ax in f.axes for a in (ax, *ax.child_axes)]  # with the secondary axes
    labels = [a.get_ylabel() for a in axes] + [a.get_xlabel() for a in axes]
    for unit in ("rad/s", "rpm", "rad/s²", "rpm/s", "drive torque M, N·m", "drive power P, kW",
                 "deflection δ, mm 0-peak  (e = 50.00 µm)", r"speed $\omega$, rpm"):
        assert any(unit in x for x in labels), (unit, labels)


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name, scene", SCENES.items(), ids=list(SCENES))
def test_robust_time_optimal_and_ross_summaries_and_verdicts(shipped_run, name, scene):
    """On the shipped scene: every number declared, the summary's first line is the report's one verdict, printed
    in mm (µm for the ROSS rotor) beside delta/e and rpm beside rad/s, the printed values the SI values converted."""
    run, folder = shipped_run(scene)
    check_declared(folder)
    results = json.loads((folder / "results.json").read_text())
    res, d = run[name], results[name]
    text = res.summary()
    (sec,) = [s for s in report.sections(results) if s["name"] == name]
    assert sec["overall"]["text"] == res.verdict()[1] and text.splitlines()[0].endswith(res.verdict()[1])
    assert "rpm)" in text
    if name == "ross_spinup":
        value, unit = printed(text, "r*")
        assert unit == "µm" and value == pytest.approx(d["peak_deflection_m"] * 1e6, rel=6e-4)
        assert "AF" in text and "separation margin" in text
        assert d["critical_speeds"]["margins"][0]["amplification_factor"] == pytest.approx(35.15, rel=1e-3)
        return
    e = d["eccentricity_m"]
    pk = d["profiles"]["robust"]["validation_worst_over_e"] if name == "spinup_robust" else d["peak_deflection_over_e"]
    assert f"{pk:.2f} e ({pk * e * 1e3:.3f} mm)" in sec["overall"]["text"]


def test_spinup_report_rows_carry_rpm_per_second_beside_rad_per_second_squared():
    results = {"spinup_robust": {"ramps": [{"label": "ramp", "alpha_rad_s2": 40.0}]}}
    sec = report.Section("spinup_robust", results["spinup_robust"], results)
    sec.row("acceleration", "α", "ramps.0.alpha_rad_s2")
    (row,) = sec.rows
    assert row[3]["text"] == "rad/s²" and row[4]["text"].startswith("381.97 rpm/s")


@pytest.mark.slow
@pytest.mark.parametrize("extra", [{"analyses.spinup.objective": "peak_unbalance"},
                                   {"analyses.spinup.objective": "integrated_deflection"},
                                   {"analyses.spinup.objective": "min_time", "analyses.spinup.deflection_limit": 25}])
def test_every_objective_declares_every_number(extra):
    """The option variants add keys (collocation_peak_unbalance) or change what a key holds: still all declared.
    (The integrated objective starts from the late ramp: 23 IPOPT iterations at 40 intervals, 775 from the
    constant ramp it once started from.)"""
    from autobal.analyses.spinup import ocp as spinup_ocp
    from autobal.analysis.run.result import plain

    scene = autobal.load(SCENE, set=SMALL | {"analyses.spinup.segments": 0} | extra)
    s = scene.analyses.spinup
    res = spinup_study.run(spinup_ocp(scene, s), spinup_study.method_of(s), multistart=False,
                           options=ipopt_options(s.max_iterations, s.tolerance))
    assert spinup_study.QUANTITIES.undeclared(plain(res.to_dict())) == []
    assert res.summary().startswith(f"spin-up ({extra['analyses.spinup.objective'].replace('_', ' ')}): ok: peak "
                                    "deflection ")
