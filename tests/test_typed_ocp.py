"""Typed Results of the spin-up studies (issue #34 item 1): ``RobustResult`` (``spinup_robust``; the modal rotor's
``ModalRobustResult``, ``ross_spinup_robust``) and ``TimeOptimalResult`` (``spinup_time_optimal``,
``ross_spinup_time_optimal``) are frozen records whose fields carry their declarations.  For each shipped scene that
runs them: the block goes out and comes back equal (``from_dict(to_dict(r)) == r``, through JSON as results.json),
``autobal.load_run`` loads it, and report.html rendered again from the loaded Results is the page the run wrote,
byte for byte."""

from __future__ import annotations

import dataclasses
import json

import pytest

import autobal
from autobal import report
from autobal.analysis import fields
from autobal.analysis.result import plain
from autobal.ocp import robust_study
from autobal.ocp.robust_study import ModalRobustResult, Profiles, RobustResult


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
    """A null of the block gets its ``<key>_status`` from the Result's null reasons when it goes out, and the status
    is dropped when it comes back (it is not a field)."""
    prof = {"robust": {"label": "robust", "validation_worst_m": 1e-5},
            "nominal": {"label": "nominal", "validation_worst_m": 2e-5},
            "ramp": {"label": "ramp", "validation_worst_m": 3e-5, "within_drive_limits": None}}
    p = Profiles.from_dict(prof)
    assert p.ramp.within_drive_limits is None and p.ramp.validation_worst == 3e-5
    assert robust_study.verdict(p, 10, "m") == (True, "worst peak over 10 validation rotors: robust 10.00 µm, "
                                                      "nominal optimum 20.00 µm, best ramp 30.00 µm")
    with pytest.raises(KeyError, match="RampProfile has no field 'within_drive_limits_status'"):
        Profiles.from_dict(prof | {"ramp": prof["ramp"] | {"within_drive_limits_status": "why"}})
    assert fields._without_statuses({"a": None, "a_status": "why", "b_status": "kept: no b"}) == {
        "a": None, "b_status": "kept: no b"}


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
    trace: list | None = fields.run_only()
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
