"""Typed Results of the spin-up studies (issue #34 item 1): ``RobustResult`` (``spinup_robust``; the modal rotor's
``ModalRobustResult``, ``ross_spinup_robust``) and ``TimeOptimalResult`` (``spinup_time_optimal``,
``ross_spinup_time_optimal``) are frozen records whose fields carry their declarations.  For each shipped scene that
runs them: the block goes out and comes back equal (``from_dict(to_dict(r)) == r``, through JSON as results.json),
``autobal.load_run`` loads it, and report.html rendered again from the loaded Results is the page the run wrote,
byte for byte."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import autobal
from autobal import report
from autobal.analysis.run import fields
from autobal.analysis.run.result import plain
from autobal.ocp import robust_study
from autobal.ocp.robust_study import ModalRobustResult, Profiles, RobustResult
from autobal.ocp.spinup_study import Baseline, Dwell, Rotor, SpinupResult
from autobal.ocp.time_optimal_study import ModalTimeOptimalResult, TimeOptimalResult


def _round_trip(res, cls):
    """The Result's block through JSON and back: equal, the same keys in the same order, and every number of it
    declared by a field or the extra declarations."""
    d = json.loads(json.dumps(plain(res.to_dict())))
    back = cls.from_dict(d)
    assert type(back) is cls and back == res
    assert plain(back.to_dict()) == d and json.dumps(plain(back.to_dict())) == json.dumps(d)  # key order too
    assert cls.quantities.undeclared(d) == []
    assert back.verdict() == res.verdict() and back.summary() == res.summary()
    return back


def _loads_back(folder, name, res):
    """load_run gives the Result back equal, and report.html rendered again from the loaded Results is the page
    the run wrote, byte for byte."""
    saved = json.loads((folder / "results.json").read_text())
    done = autobal.load_run(folder)
    assert name not in done.unloaded and done[name] == res
    assert plain(done[name].to_dict()) == saved[name]
    assert report.html(folder) == (folder / report.REPORT).read_text(encoding="utf-8")
    return done[name]


def test_the_robust_key_paths_are_the_declarations():
    """Every declared number of the robust block is a field path (the peaks once per unit, delta/e and m), with the
    unit its declaration gives; the headline is the three profiles' worst validation peaks first."""
    paths = fields.key_paths(RobustResult)
    assert {"profiles.robust.validation_worst_over_e", "profiles.ramp.validation_worst_m",
            "rounds[].worst_design_peak_m", "ramps[].alpha_rad_s2", "robust_collocation_worst_over_e"} <= set(paths)
    q = robust_study.QUANTITIES
    assert q.find("profiles.nominal.validation_quantiles_m.0.99").unit == "m"
    assert q.find("profiles.nominal.validation_quantiles_over_e.0.5").unit == "1"
    assert q.find("rounds.3.worst_design_peak_m").display == "µm"
    assert [k for x in q if x.headline for k in x.keys][:6] == [
        f"profiles.{p}.validation_worst_{s}" for p in ("robust", "nominal", "ramp") for s in ("over_e", "m")]
    assert ModalRobustResult.quantities is RobustResult.quantities
    assert report.result_class("ross_spinup_robust") is ModalRobustResult
    assert report.result_class("spinup_robust") is RobustResult


def test_robust_statuses_are_made_from_the_nulls_not_stored():
    """A null of the block gets its ``<key>_status`` from the Result's null reasons when it goes out; a status read
    back beside a field's key is kept in the record's statuses, one beside no field is refused."""
    prof = {"robust": {"label": "robust", "validation_worst_m": 1e-5},
            "nominal": {"label": "nominal", "validation_worst_m": 2e-5},
            "ramp": {"label": "ramp", "validation_worst_m": 3e-5, "within_drive_limits": None}}
    p = Profiles.from_dict(prof)
    assert p.ramp.within_drive_limits is None and p.ramp.validation_worst == 3e-5
    assert robust_study.verdict(p, 10, "m") == (True, "worst peak over 10 validation rotors: robust 10.00 µm, "
                                                      "nominal optimum 20.00 µm, best ramp 30.00 µm")
    with_status = prof | {"ramp": prof["ramp"] | {"within_drive_limits_status": "why"}}
    back = Profiles.from_dict(with_status)  # a status read back is kept beside its key, and goes out again
    assert back.ramp.statuses == {"within_drive_limits": "why"} and back.to_dict()["ramp"] == with_status["ramp"]
    with pytest.raises(KeyError, match="_Toy has no field 'other_status'"):  # a status is skipped beside a field only
        _Toy.from_dict({"limit": 1.0, "peak": 1.0, "other_status": "why"})


@pytest.mark.cli
@pytest.mark.slow
def test_spinup_robust_jeffcott_round_trip_and_report(shipped_run):
    """The shipped robust scene (Jeffcott rotor, peaks delta/e): the typed Result round trip, the statuses of its
    nulls made again, load_run and the report byte for byte; a loaded Result has no re-simulations and says so."""
    run, folder = shipped_run("spinup_robust_jeffcott")
    res = run["spinup_robust"]
    assert type(res) is RobustResult and res.peak_unit == "1" and res.eccentricity_m > 0
    back = _round_trip(res, RobustResult)
    d = res.to_dict()
    assert d["liquid_mass_factor"] is None and d["liquid_mass_factor_status"].startswith("the rotor has no liquid")
    assert res.worst_validation["robust"] == res.profiles.robust.validation_worst_over_e == max(
        res.validation["robust"])
    loaded = _loads_back(folder, "spinup_robust", res)
    assert loaded.nominal_runs is None and back.validation is None
    with pytest.raises(ValueError, match="holds no re-simulations"):
        loaded.figures()
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.peak_unit = "m"


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.extra("ross")
def test_ross_spinup_robust_round_trip_and_report(shipped_run):
    """The shipped ROSS robust scene (modal rotor, peaks in m): a ModalRobustResult, its ramps' null drive limits
    with the modal rotor's reason, the round trip, load_run and the report byte for byte."""
    run, folder = shipped_run("ross_spinup_robust")
    res = run["ross_spinup_robust"]
    assert type(res) is ModalRobustResult and res.peak_unit == "m" and res.eccentricity_m is None
    _round_trip(res, ModalRobustResult)
    d = res.to_dict()
    assert "eccentricity_m" not in d and d["nodes"] == res.nodes
    assert d["ramps"][0]["within_drive_limits_status"].startswith("the modal rotor's problem has no drive")
    _loads_back(folder, "ross_spinup_robust", res)


@fields.record
class _Arrival(fields.Record):
    time_s: float = fields.quantity("s", "T", "arrival")


@fields.record
class _Toy(fields.TypedResult):
    limit: float | None = fields.quantity("1", "", "a limit; None: none")
    peak: float = fields.quantity("1", "", "a peak")
    arrival: _Arrival | None = fields.optional(present_with="limit")
    trace: list | None = fields.unsaved()
    null_reasons = {"limit": "no limit given", "arrival": "the ramp keeps the limit"}


def test_run_only_fields_statuses_and_a_null_present_with_another_field():
    """fields.py as the spin-up Results use it: a run-only field is neither in the block nor compared and is None
    when loaded; a null gets its status from null_reasons going out and loses it coming back; an optional field
    present_with another is null (with its status) when that one is set, and absent when it is not."""
    a = _Toy(limit=2.0, peak=1.5, arrival=None, trace=[1, 2, 3])
    d = a.to_dict()
    assert d == {"limit": 2.0, "peak": 1.5, "arrival": None, "arrival_status": "the ramp keeps the limit"}
    back = _Toy.from_dict(d)
    assert back == a and back.trace is None and back.to_dict() == d
    b = _Toy(limit=None, peak=1.5)
    assert b.to_dict() == {"limit": None, "limit_status": "no limit given", "peak": 1.5}
    assert _Toy.from_dict(b.to_dict()) == b
    c = _Toy(limit=2.0, peak=float("nan"), arrival=_Arrival(3.0))
    assert plain(c.to_dict()) == {"limit": 2.0, "peak": None, "peak_status": "no value here (NaN)",
                                  "arrival": {"time_s": 3.0}}
    assert _Toy.from_dict(plain(c.to_dict())) == c and c != b
    with pytest.raises(KeyError, match="_Toy has no field 'trace'"):
        _Toy.from_dict(d | {"trace": [1]})
    assert fields.key_paths(_Toy) == ["limit", "peak", "arrival.time_s"]


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name, analysis, cls", [
    ("spinup_time_optimal", "spinup_time_optimal", TimeOptimalResult),
    pytest.param("ross_spinup_time_optimal", "ross_spinup_time_optimal", ModalTimeOptimalResult,
                 marks=pytest.mark.extra("ross"))])
def test_time_optimal_round_trip_and_report(shipped_run, name, analysis, cls):
    """The shipped time-optimal scenes (Jeffcott rotor delta/e, modal rotor m): the typed Result round trip, the
    earliest arrival as a Point record (its FrontPoint held by the run only), load_run and the report byte for
    byte."""
    run, folder = shipped_run(name)
    res = run[analysis]
    assert type(res) is cls and res.deflection_limit is not None and res.limited is not None
    assert res.limited.resimulated_peak == res.peak_deflection == res.limited_point.peak
    assert res.limit_margin == pytest.approx(1 - res.peak_deflection / res.deflection_limit, rel=1e-12)
    assert list(res.arrival_times) == [p.arrival_time_s for p in res.front]
    back = _round_trip(res, cls)
    assert back.limited_point is None and back == res and back.limited.arrival_time_s == res.limited.arrival_time_s
    d = res.to_dict()
    assert d["front"][0]["held_from_s_status"] == "the point's own minimum-peak optimum"
    _loads_back(folder, analysis, res)


def spinup_result(**changes) -> SpinupResult:
    """A SpinupResult of made-up numbers (a 1 kg Jeffcott rotor, delta/e 12.31 against the ramp's 14.15, no drive
    data) with ``changes``: for the tests of its verdict and words, which read its fields."""
    rotor = Rotor(1.0, 1.1025e4, 5.0, 1e-4, 0.0, 105.0, 0.0238, 210.0, 20.0, 105.1, [102.5, 107.5],
                  separation_margin_pct=50.0, required_separation_margin_pct=16.0, separation_margin_ok=True,
                  amplitude_convention="0-peak (the radius of the whirl orbit)")
    ramp = Baseline("ramp 40 rad/s² and hold", 14.15, 13.5, 2.2, 120.0, None, None, None, None, [])
    res = SpinupResult(
        "made up", "peak_deflection", "collocation", "Solve_Succeeded", 12.31, 14.15, "hold", -13.0, None, 1.231e-3,
        rotor, 1e-3, 1.0, 20, 12.30, 12.31, 12.30, 13.1, 2.61, 8e-4, 116.7, 150.0, 5.0, 0.5, 5.0, 12.0, [],
        {"hold": ramp}, 1.0, 1e-4, 105.0, 105.0, 0.0238, 0.0, None, None, None, None, [], None, None, None, None,
        dwell=Dwell(0.5, 0.53, False, 101.8, 12.0), accuracy={})
    return dataclasses.replace(res, **changes)


def test_a_made_up_spinup_result_goes_out_and_comes_back():
    """The helper's Result is a complete record: its block comes back equal, every number declared."""
    res = spinup_result(brakes=True, min_torque_N_m=-120.0)
    d = json.loads(json.dumps(plain(res.to_dict())))
    assert SpinupResult.from_dict(d) == res and SpinupResult.quantities.undeclared(d) == []
    assert res.verdict()[0] is True and "it brakes (smallest torque -120.0 N·m)" in res.verdict()[1]


@pytest.mark.cli
@pytest.mark.slow
def test_spinup_round_trip_loads_its_controls_and_renders_the_same_report(shipped_run):
    """The shipped 5 s deadline scene (Jeffcott rotor, a 4-segment ramp table): the typed Result round trip; load_run
    gives it back with the controls and the ramp table its run wrote (what the report's binding-constraint line and
    ramp table read, no longer from the CSV files in the section), and the report byte for byte."""
    run, folder = shipped_run("spinup_jeffcott_deadline_5s")
    res = run["spinup"]
    assert type(res) is SpinupResult and res.segments is not None and res.ramp_table is not None
    back = _round_trip(res, SpinupResult)
    assert back.controls is None and back.rotor == res.rotor and back.dwell.dwells is res.dwell.dwells
    loaded = _loads_back(folder, "spinup", res)
    # SI, at full precision through the CSV (headed 'name [unit]', read back from the SI twin of rpm and rpm/s)
    assert loaded.controls["acceleration"] == list(res.optimum.alpha)
    assert {k: list(v) for k, v in loaded.ramp_table.items()} == {k: list(v) for k, v in res.ramp_table.items()}
    amax = 40.0  # the scene's max_acceleration, rad/s^2
    on = int(np.sum(np.abs(res.optimum.alpha) >= 0.999 * amax))
    assert f"on {on} of {len(res.optimum.alpha)} control intervals" in (folder / report.REPORT).read_text()


def robust_result(robust: float, nominal: float, ramp: float, ramp_ok: bool | None) -> RobustResult:
    """A RobustResult of made-up numbers (delta/e) whose three profiles have these worst validation peaks."""
    from autobal.ocp.robust_study import NominalProfile, RampProfile, RobustProfile

    def peaks(cls, label, worst, **kw):
        return cls(label, nominal_peak_over_e=worst, design_peaks_over_e=[worst], design_worst_over_e=worst,
                   validation_worst_over_e=worst, validation_mean_over_e=worst,
                   validation_quantiles_over_e={"0.5": worst, "0.9": worst, "0.99": worst}, **kw)

    profiles = Profiles(peaks(RobustProfile, "robust", robust), peaks(NominalProfile, "nominal", nominal),
                        peaks(RampProfile, "ramp", ramp, within_drive_limits=ramp_ok))
    return RobustResult("made up", "collocation", "1", 105.0, eccentricity_m=1e-4, validation_step_tau=0.05,
                        critical_speed_spread=0.05, damping_factor=[0.5, 2.0], liquid=False, liquid_mass_factor=None,
                        design_set=[[1.0, 1.0, 1.0]], design_scenarios=1, active_scenarios=1,
                        active_design_rotors=[[1.0, 1.0, 1.0]], worst_design_rotor=[1.0, 1.0, 1.0],
                        robust_collocation_worst_over_e=robust, resimulation_rel_error=0.0, build_time_s=0.0,
                        solve_time_s=0.0, rounds=[], nominal_build_time_s=0.0, nominal_solve_time_s=0.0,
                        validation_samples=10, seed=1, executor="in-process", validation_time_s=0.0,
                        validation_check_rel_error=0.0, profiles=profiles, ramps=[], accuracy={}, wall_time_s=0.0)


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.extra("ross")
def test_ross_spinup_round_trip_and_report(shipped_run):
    """The shipped ROSS spin-up (modal rotor): a ModalSpinupResult whose API 684 margins keep margin_check's
    statuses where it puts them, its own nulls' statuses made; the round trip, load_run and the report byte for
    byte."""
    from autobal.ocp.modal_study import ModalSpinupResult

    run, folder = shipped_run("spinup_ross_rotor")
    res = run["ross_spinup"]
    assert type(res) is ModalSpinupResult and res.final_speed_rad_s == res.optimum.omega[-1]
    assert len(res.critical_speeds.margins) == len(res.critical_speeds.reduced_wd_rad_s)
    _round_trip(res, ModalSpinupResult)
    d = res.to_dict()
    assert d["torque_limit_N_m"] is None and d["torque_limit_N_m_status"] == "no torque limit in the scene"
    _loads_back(folder, "ross_spinup", res)
