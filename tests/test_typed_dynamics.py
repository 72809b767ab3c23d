"""Typed Results of the dynamics side (issue #34 item 1): frequency, transient, rotor dynamics and liquid balancer.

For every shipped scene that runs one of them: the Result is a typed Result, ``from_dict(to_dict(r)) == r`` through
JSON, its block is the one results.json holds, ``autobal.load_run`` loads it back (it is not in ``unloaded``), its
summary is the run's, and report.html rendered again from the loaded Results is the page the run wrote, byte for
byte.  Beside them the small pieces of analysis/run/fields.py and analysis/run/quantities.py these Results need."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import autobal
from autobal import report
from autobal.analysis.run import fields
from autobal.analysis.run.quantities import Declarations, Quantity
from autobal.analysis.run.result import plain

DYNAMICS = ("frequency", "transient", "rotor_dynamics", "liquid_balancer")  # the analyses typed here
SCENES = [pytest.param("compressor_k180_dynamics", id="compressor_k180_dynamics"),
          *(pytest.param(n, id=n, marks=pytest.mark.slow) for n in ("pump_pe600_dynamics", "pump_pe600_simplified",
                                                                     "pashkov_runup", "washer_liquid_balancer",
                                                                     "washer_liquid_balancer_nested"))]


@pytest.mark.cli
@pytest.mark.parametrize("scene", SCENES)
def test_the_dynamics_results_round_trip_load_back_and_render_the_same_report(shipped_run, scene):
    run, folder = shipped_run(scene)
    saved = json.loads((folder / "results.json").read_text())
    done = autobal.load_run(folder)
    mine = [name for name in DYNAMICS if name in saved]
    assert mine, scene
    for name in mine:
        res = run[name]
        assert isinstance(res, fields.TypedResult), name
        back = type(res).from_dict(json.loads(json.dumps(plain(res.to_dict()))))
        assert back == res and plain(back.to_dict()) == saved[name], name
        assert list(back.to_dict()) == list(saved[name]), name  # the keys in results.json's order
        assert name not in done.unloaded and done[name] == res, name
        assert done[name].summary() == res.summary(), name
    assert report.html(folder) == (folder / report.REPORT).read_text(encoding="utf-8")
    sections = {s["name"]: s for s in report.context(folder)["sections"]}
    assert [sections[name]["error"] for name in mine] == [None] * len(mine)  # each section renders from its Result


@pytest.mark.cli
def test_the_loaded_frequency_result_reads_its_fields_and_has_no_curves(shipped_run):
    """Compressor K180: the headline (energy-consistent, physical forcing) read from the loaded Result's fields is
    results.json's; the curves are not in results.json (afc_<model>.csv holds them), so a loaded Result says so
    instead of drawing nothing."""
    run, folder = shipped_run("compressor_k180_dynamics")
    saved = json.loads((folder / "results.json").read_text())["frequency"]
    loaded = autobal.load_run(folder)["frequency"]
    h = loaded.head
    assert (h.model, h.forcing) == ("nonlinear", "physical") == (saved["headline"]["model"], "physical")
    assert h.peaks[0].omega == saved["headline"]["peaks"][0]["omega"] and 100 < h.peaks[0].omega < 8000  # rad/s
    assert loaded.models["program"].static_amplitude == saved["models"]["program"]["static_amplitude"]
    assert run["frequency"].head.omega is not None and h.omega is None
    with pytest.raises(ValueError, match="a loaded Result holds no curves"):
        loaded.tables()
    # the CSV of the run is the curve the Result held: its peak is the refined peak to the grid's resolution
    table = run["frequency"].tables()["afc_nonlinear.csv"]
    assert max(table["amplitude [µm]"]) == pytest.approx(run["frequency"].models["nonlinear"].peaks[0].amplitude
                                                         * 1e6, rel=1e-3)


@fields.record
class _Curve(fields.Record):
    peak: float = fields.quantity("m", "A", "a peak", "µm", headline=1)
    grid: np.ndarray | None = fields.unsaved()


@fields.record
class _Toy(fields.TypedResult):
    title: str
    curves: list[_Curve]
    after: float = fields.quantity("s", "t", "a time")
    failures_after = "title"
    name = "toy"


_Toy.quantities = fields.declarations(_Toy)


def test_an_unsaved_field_is_held_not_written_and_none_when_loaded():
    toy = _Toy(title="x", curves=[_Curve(2e-6, grid=np.arange(3.0))], after=1.0)
    d = toy.to_dict()
    assert d == {"title": "x", "failures": [], "curves": [{"peak": 2e-6}], "after": 1.0}
    back = _Toy.from_dict(d)
    assert back == toy and back.curves[0].grid is None and toy.curves[0].grid[2] == 2.0
    assert fields.key_paths(_Toy) == ["curves[].peak", "after"]  # the unsaved grid has no key
    with pytest.raises(KeyError, match="_Curve has no field 'grid'"):
        _Toy.from_dict(d | {"curves": [{"peak": 2e-6, "grid": [0.0]}]})


def test_failures_after_keeps_their_place_and_are_written_when_none():
    failed = _Toy(title="x", curves=[], after=1.0, failures=["case 1: the integrator failed"])
    d = failed.to_dict()
    assert list(d) == ["title", "failures", "curves", "after"] and d["failures"] == ["case 1: the integrator failed"]
    assert _Toy.from_dict(d) == failed and failed.failures() == ["case 1: the integrator failed"]
    assert dataclasses.replace(failed, failures=[]).to_dict()["failures"] == []


def test_a_headline_through_a_list_of_records_gives_each_item():
    q = Quantity("head.peaks[].omega", "rad/s", "ω", "resonance", headline=True)
    block = {"head": {"peaks": [{"omega": 10.0}, {"omega": 30.0}]}}
    assert [(k, v) for _, k, v in Declarations(q).headline(block)] == [("head.peaks.0.omega", 10.0),
                                                                        ("head.peaks.1.omega", 30.0)]
    assert Declarations(q).headline({"head": {"peaks": []}}) == []
    toy = _Toy(title="x", curves=[_Curve(2e-6), _Curve(5e-6)], after=1.0)
    assert [r["value"] for r in toy.headline()] == ["2.000", "5.000"]  # µm, as declared


@pytest.mark.cli
def test_a_failed_transient_case_loads_back_with_its_nulls_and_failure(tmp_path):
    """Compressor K180 without rotor damping, a force step of 100: CVODES stops at t = 0 (CV_TOO_MUCH_WORK); the
    case's max |Δz| and final Δz are null with their status, its failure a record, the Result's failures a field
    kept in results.json's place; all of it comes back from results.json and renders the same report."""
    import yaml

    from autobal import scenario

    d = yaml.safe_load(scenario.resolve("compressor_k180_dynamics").read_text())
    d["device"]["dynamics"]["rotor_damping"] = "0 N*s/m"
    d["analyses"] = {"transient": {"duration": "2 ms", "points": 21, "cases": [
        {"input": "force_step", "amplitude": 100}, {"input": "force_step", "amplitude": 0.01}]}}
    (tmp_path / "k180_failing.yaml").write_text(yaml.safe_dump(d))
    run = autobal.run(autobal.load(tmp_path / "k180_failing.yaml"), out=tmp_path / "o")
    res, saved = run["transient"], json.loads((tmp_path / "o" / "results.json").read_text())["transient"]
    failed, solved = res.cases
    assert failed.failure.t == 0 and "CV_TOO_MUCH_WORK" in failed.failure.message and solved.failure is None
    assert failed.max_dz is None and failed.max_dz_status.startswith("the integrator failed at t = 0 s")
    assert saved["cases"][0]["max_dz"] is None and saved["cases"][0]["failure"] == failed.failure.to_dict()
    assert list(saved)[list(saved).index("equilibrium_residual") + 1] == "failures" == list(res.to_dict())[5]
    done = autobal.load_run(tmp_path / "o")
    assert done["transient"] == res and done["transient"].failures() == res.failures() == saved["failures"]
    assert done["transient"].max_gap_change == [None, solved.max_dz] and 0 < solved.max_dz < 1e-4  # m
    with pytest.raises(ValueError, match="a loaded Result holds no time series"):
        done["transient"].tables()
    assert report.html(tmp_path / "o") == (tmp_path / "o" / report.REPORT).read_text(encoding="utf-8")


@pytest.mark.parametrize("service_speed", [None, 150.0])
def test_the_rotor_block_keeps_the_margin_keys_in_the_order_margin_check_writes_them(service_speed):
    """Pashkov's rotor (Ω0 = 100 rad/s, n = χ/m1 = 2 1/s, ψ = 0.5) with one (μ1, n) = (1, 1) case whose torque has
    no extremum (μ1 < 3n/(6 − 2√5)): the rotor block is its groups, then the API margins in the order
    standards.margin_check writes them (with or without a service speed), the nulls with their statuses; the
    stationary case's z1..M2 null with theirs; everything comes back from results.json."""
    from autobal.analyses.rotor_dynamics import RotorDynamics, Stationary, spec
    from autobal.analysis.studies.rotor_study import RotorDynamicsResult, api_margins, run
    from autobal.models.rotor import RotorParams
    from autobal.schema import Range

    P = RotorParams.from_groups(Omega0=100.0, chi_over_m1=2.0, psi=0.5)
    settings = RotorDynamics(stationary=Stationary(cases=[(1.0, 1.0)], z=Range(start=0.01, stop=3.0, points=40)))
    res = run(P, spec(settings), service_speed=service_speed)
    d = json.loads(json.dumps(plain(res.to_dict())))
    groups = ["psi", "mu1", "Omega0_rad_s", "omega_cr_rad_s", "zeta0", "n_steady_1_s", "n_stationary",
              "n_passage_1_s", "service_speed_rad_s"]
    margins = list(api_margins(P, service_speed))
    assert list(d["rotor"]) == groups + margins + ([] if service_speed else ["service_speed_rad_s_status"])
    assert (d["rotor"]["separation_margin_pct"] is None) is (service_speed is None)
    case = d["stationary"]["cases"][0]
    assert case["z1"] is None and case["M2"] is None and "needs mu1 > 3 n" in case["z1_status"]
    assert res.stationary.cases[0].z_kp == pytest.approx(2 / (2 * 1.0 - 1.0)) and res.critical_speed == P.omega_cr
    back = RotorDynamicsResult.from_dict(d)
    assert back == res and plain(back.to_dict()) == d and back.curves is None and res.curves["stationary"]
    assert back.summary() == res.summary() and back.verdict() == res.verdict()
    with pytest.raises(ValueError, match="a loaded Result holds no curves"):
        back.figures()
