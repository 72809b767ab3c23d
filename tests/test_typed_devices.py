"""Typed Results of the device-side analyses (issue #34 item 1): statics, design, estimation, Monte Carlo.  For
every shipped scene that runs them, the Result's block is results.json's, ``from_dict(to_dict(r)) == r`` through JSON
with the keys in the same order at every level, ``autobal.load_run`` loads it back equal, and report.html rendered
again from the loaded Results is the page the run wrote, byte for byte; a null's status comes from the fields as
``with_statuses`` wrote it from the dict before."""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

import autobal
from autobal import report
from autobal.analysis.run import fields
from autobal.analysis.run.result import plain, with_statuses
from autobal.analysis.studies import statics_study
from autobal.analysis.studies.statics_study import QUANTITIES, StaticsResult

#: shipped scene -> the typed analyses of this file it runs; (slow): more than about 20 s
SCENES = {"pump_pe600_statics": ("statics",), "compressor_k180_statics": ("statics",),
          "pump_pe600_design": ("design",), "compressor_k180_design": ("design",),
          "pump_pe600_montecarlo": ("montecarlo",), "rig_table43_fit": ("estimation",)}
SLOW = {"pump_pe600_design", "compressor_k180_design", "pump_pe600_montecarlo"}


def _json(d) -> str:
    return json.dumps(plain(d), allow_nan=False)


@pytest.mark.cli
@pytest.mark.parametrize("scene", [pytest.param(s, marks=pytest.mark.slow) if s in SLOW else s for s in SCENES])
def test_a_shipped_run_round_trips_and_loads_back_with_the_same_report(shipped_run, scene):
    run, folder = shipped_run(scene)
    saved = json.loads((folder / "results.json").read_text())
    done = autobal.load_run(folder)
    for name in SCENES[scene]:
        res = run[name]
        assert _json(res.to_dict()) == json.dumps(saved[name], allow_nan=False), name  # every key, in order
        back = type(res).from_dict(json.loads(json.dumps(saved[name])))
        assert back == res and _json(back.to_dict()) == _json(res.to_dict()), name
        assert name not in done.unloaded and done[name] == res, name
        assert done[name].summary() == res.summary() and done[name].verdict() == res.verdict(), name
    assert report.html(folder) == (folder / report.REPORT).read_text(encoding="utf-8")


@pytest.mark.cli
def test_the_statics_statuses_are_with_statuses_of_the_block(shipped_run):
    """Compressor K 180-131-1 (gas: no closed-form stiffness, no closed-form force-gap curve; the ideal regulator's
    valve opening has no value at the high discharge ratios): the statuses the fields give (fields.explained) are
    those with_statuses gives the same block without them, key for key and in place; they load back and a status
    of a key the record lacks is refused."""
    res = shipped_run("compressor_k180_statics")[0]["statics"]
    bare = json.loads(_json(res.to_dict()), object_hook=lambda d: {k: v for k, v in d.items()
                                                                   if not k.endswith("_status")})
    g = res.groups
    reasons = {"kappa_s": "no fixed-pressure closed form of the stiffness for the gas device (see kappa_u_2_162)",
               "phi_closed_form": "the closed form (2.35) is the liquid device's",
               "xi": "no valve opening of the ideal regulator (2.28) passes the barrier flow: the valve saturates"}
    default = "the closed form has no physical value here"
    assert _json(with_statuses(bare, reasons, default)) == _json(res.to_dict())
    assert _json(fields.explained(StaticsResult.from_dict(bare), reasons, default).to_dict()) == _json(res.to_dict())
    assert res.closed_form.kappa_s is None or math.isnan(res.closed_form.kappa_s)
    assert res.closed_form.statuses == {"kappa_s": reasons["kappa_s"]}
    assert res.force_gap.statuses == {"phi_closed_form": reasons["phi_closed_form"]}
    assert res.sweep.closed_form["xi_status"] == reasons["xi"] and "xi_max" in g
    d = json.loads(_json(res.to_dict()))
    d["closed_form"]["u0_status"] = "no value"
    assert StaticsResult.from_dict(d).closed_form.statuses["u0"] == "no value"  # a status of a field: kept
    d["closed_form"]["psi9_status"] = "no value"
    with pytest.raises(KeyError, match="ClosedForm has no field 'psi9_status'"):
        StaticsResult.from_dict(d)


@pytest.mark.cli
def test_the_statics_fields_are_its_numbers(shipped_run):
    """Pump PE 600-300 (Pavlenko 2014, App. A): the fields read as the block says, are frozen, and compare by the
    numbers; every number of the block is declared by a field or the extra declarations (groups, conductances, the
    closed forms along the sweep), each key path of a field once."""
    res = shipped_run("pump_pe600_statics")[0]["statics"]
    d = res.to_dict()
    assert res.face_gap == res.exact.z0 == d["exact"]["z0"] and res.exact.z0 == pytest.approx(143.8646e-6, rel=1e-5)
    assert res.exact.dp == pytest.approx(res.dpsi * res.scales.p_B, rel=1e-9)  # held by the regulator
    assert res.critical_exact.p1_kr == pytest.approx(res.critical_exact.psi1_kr * res.scales.p_B, rel=1e-14)
    assert res.has_regulator and res.exact.x0 == pytest.approx(res.exact.xi0 * res.scales.x_B, rel=1e-14)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.exact.z0 = 1.0
    moved = dataclasses.replace(res, exact=dataclasses.replace(res.exact, z0=res.exact.z0 * (1 + 1e-12)))
    assert moved != res and dataclasses.replace(res) == res
    assert QUANTITIES.undeclared(plain(d)) == []
    paths = fields.key_paths(StaticsResult)
    assert sorted(k for q in QUANTITIES for k in q.keys if k in paths) == sorted(paths)
    assert [q.symbol for q in QUANTITIES if q.headline] == ["z0", "x0", "p1", "p2", "p3", "p_e", "p_cam", "Q_e",
                                                            "Q_T", "Q_1", "p1_kr", "Δp", "Δp_kr", "c_s"]
    # the verdict is the one function the live explorer calls too
    ex, crit = res.exact, res.critical_exact
    assert res.verdict() == statics_study.verdict(ex.psi1, ex.z0, ex.Q_1, ex.contact, ex.regulator_saturated, ex.dp,
                                                  crit.dp_kr, crit.psi1_kr)


@pytest.mark.cli
def test_a_small_monte_carlo_round_trips_with_its_failures_last(tmp_path):
    """Pump PE 600-300, 1000 samples at ψ1 = 1 (Pavlenko 2014, ch. 3): the block ends with its failures (none),
    the null correlation has its status, the sampled arrays are held but not written, and the failures a run adds
    stay last and fail the result."""
    from autobal.analysis.studies.montecarlo import MonteCarloResult

    scene = autobal.load("pump_pe600_montecarlo", set={
        "analyses.montecarlo.samples": 1000, "analyses.montecarlo.chunk_size": 1000, "analyses.montecarlo.afc": None,
        "analyses.montecarlo.discharge_ratio": [1.0]})
    res = autobal.run(scene, out=tmp_path / "out")["montecarlo"]
    saved = json.loads((tmp_path / "out" / "results.json").read_text())["montecarlo"]
    assert list(saved)[-1] == "failures" and saved["failures"] == [] and "afc" not in saved
    assert saved["correlation"] is None and res.statuses["correlation"] == saved["correlation_status"]
    assert res.reference.z_mean == saved["reference"]["z_mean"] == pytest.approx(143.9e-6, rel=0.01)
    back = MonteCarloResult.from_dict(json.loads(json.dumps(saved)))
    assert back == res and _json(back.to_dict()) == json.dumps(saved, allow_nan=False)
    assert res.raw["exact"]["u"].shape == (1000, 1) and back.raw == {}  # the samples: in memory only
    done = autobal.load_run(tmp_path / "out")
    assert done["montecarlo"] == res and report.html(tmp_path / "out") == (
        tmp_path / "out" / report.REPORT).read_text(encoding="utf-8")
    failed = dataclasses.replace(res, failures=["psi1 = 1: 20 of 1000 samples unsolved"])
    assert list(failed.to_dict())[-1] == "failures" and failed.failures() == ["psi1 = 1: 20 of 1000 samples unsolved"]
    assert MonteCarloResult.from_dict(json.loads(_json(failed.to_dict()))) == failed and not failed.verdict()[0]


@pytest.mark.cli
def test_a_failed_fit_loads_back_as_a_failed_fit(shipped_run):
    """Table 4.3 fits (Pavlenko 2014, §4.4): the solved fits are Fit records, the failures stay after the status;
    a fit whose block says it failed comes back as a FailedFit, with its solver's status in the verdict."""
    from autobal.analysis.studies.estimation_study import EstimationResult, FailedFit, Fit

    res = shipped_run("rig_table43_fit")[0]["estimation"]
    assert all(isinstance(f, Fit) for f in res.fits.values()) and res.solved == res.fits
    d = json.loads(_json(res.to_dict()))
    assert list(d)[list(d).index("status") + 1] == "failures" and d["failures"] == []
    assert res.fits["static_1p"].parameters["alpha"]["estimate"] == pytest.approx(1.6643, abs=5e-5)  # Table 4.4
    d["fits"]["static_2p"] = {"status": "failed", "model": "traditional_disc", "residual": "u", "reason": "no",
                              "solver": {"status": "Maximum_Iterations_Exceeded", "success": False},
                              "last_iterate": {"alpha": 2.0}, "hint": "raise max_iterations"}
    d["failures"] = ["fit 'static_2p' did not converge"]
    back = EstimationResult.from_dict(d)
    assert isinstance(back.fits["static_2p"], FailedFit) and list(back.solved) == ["static_1p"]
    assert _json(back.to_dict()) == json.dumps(d) and back.failures() == d["failures"]
    assert "static_2p (): solver FAILED (Maximum_Iterations_Exceeded)" in back.verdict()[1]


# ---- what fields.py gained for these Results: statuses beside nulls, unsaved fields, keyword-only records ----------

@fields.record
class _Point(fields.Record):
    x: float = fields.quantity("m", "x", "a length")
    table: dict = fields.keyed("data")


@fields.record(kw_only=True)
class _Toy(fields.TypedResult):
    title: str
    gap: float | None = fields.quantity("m", "z", "a gap", optional=True)  # optional before a required field
    ratio: float = fields.quantity("1", "u", "a ratio")
    point: _Point
    points: list[_Point]
    curve: dict
    history: dict = fields.unsaved(default_factory=dict)
    name = "toy"


def _toy(**kw) -> _Toy:
    return _Toy(**({"title": "t", "gap": 1e-4, "ratio": math.nan, "point": _Point(math.nan, {"a": 1}),
                    "points": [_Point(2.0, {}), _Point(None, {})], "curve": {"y": [1.0, math.nan]},
                    "history": {"obj": [3.0, 2.0]}} | kw))


def test_explained_gives_the_statuses_with_statuses_gives_the_dict():
    """A status beside every null, in records, lists of records and plain blocks alike: the typed with_statuses, by
    key (``reasons``) or the default; a status already given is kept; an optional field left out gets none."""
    toy = fields.explained(_toy(), {"ratio": "no ratio here"}, "no value")
    assert _json(toy.to_dict()) == _json(with_statuses(_toy().to_dict(), {"ratio": "no ratio here"}, "no value"))
    assert toy.statuses == {"ratio": "no ratio here"} and toy.point.statuses == {"x": "no value"}
    assert toy.points[1].statuses == {"x": "no value"} and toy.curve["y_status"] == "no value"
    d = json.loads(_json(toy.to_dict()))
    assert list(d)[:4] == ["title", "gap", "ratio", "ratio_status"] and d["point"] == {
        "x": None, "x_status": "no value", "data": {"a": 1}}
    back = _Toy.from_dict(d)
    assert back == toy and back.statuses == toy.statuses and _json(back.to_dict()) == _json(d)
    kept = fields.explained(dataclasses.replace(_toy(), statuses={"ratio": "given"}), {"ratio": "other"})
    assert kept.statuses == {"ratio": "given"}
    assert "gap_status" not in fields.explained(_toy(gap=None)).to_dict() and "gap" not in _toy(gap=None).to_dict()
    assert fields.explained(_toy(ratio=0.5, point=_Point(1.0, {}), points=[], curve={})).to_dict() == \
        _toy(ratio=0.5, point=_Point(1.0, {}), points=[], curve={}).to_dict()  # nothing null: no status


def test_an_unsaved_field_is_held_but_not_written_nor_compared():
    toy = _toy()
    assert "history" not in toy.to_dict() and toy.history == {"obj": [3.0, 2.0]}
    back = _Toy.from_dict(json.loads(_json(toy.to_dict())))
    assert back.history == {} and back == toy
    assert "history" not in fields.key_paths(_Toy) and "history" not in str(fields.declarations(_Toy).quantities)
    with pytest.raises(KeyError, match="_Toy has no field 'history'"):
        _Toy.from_dict(json.loads(_json(toy.to_dict())) | {"history": {}})


def test_a_keyword_only_record_takes_keywords_and_keeps_its_field_order():
    with pytest.raises(TypeError):
        _Toy("t", 1e-4, 0.5)  # the fields are keywords
    assert list(_toy().to_dict()) == ["title", "gap", "ratio", "point", "points", "curve"]
    assert [list(q.keys) for q in fields.declarations(_Toy) if q.symbol in ("z", "u", "x")] == [
        ["gap"], ["ratio"], ["point.x", "points[].x"]]


@pytest.mark.cli
def test_the_statics_study_takes_a_frozen_spec():
    """issue #34 item 3: the room validates its settings into statics_study.Spec; the study run on a Spec built in
    code gives the room's Result (compressor K 180-131-1, a coarse sweep), and a Spec is frozen and checked."""
    from autobal.analysis.numerics.statics import StaticsSolver
    from autobal.parts.device import design

    scene = autobal.load("compressor_k180_statics", set={"analyses.statics.discharge_ratio.points": 6,
                                                         "analyses.statics.force_gap_points": 5})
    r = scene.analyses.statics.discharge_ratio
    spec = statics_study.Spec(scene.analyses.statics.operating_ratio, r.start, r.stop, 6, 5)
    direct = statics_study.run(StaticsSolver(design(scene.device)), spec, scene.title)
    assert direct == autobal.run(scene)["statics"] and len(direct.sweep.psi1) == 6 and len(direct.force_gap.u) == 5
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.points = 7
    with pytest.raises(ValueError, match="discharge_ratio: start 2 and stop 1"):
        statics_study.Spec(1.0, 2.0, 1.0, 6)
