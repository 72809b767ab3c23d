"""Typed Results (issue #34 item 1): a Result is a frozen dataclass whose fields carry their declarations; its
results.json block, ``units`` map and headline come from the fields, ``from_dict`` rebuilds it, ``autobal.load_run``
loads a finished run back, and the report section of a typed analysis reads the loaded Result's fields.  First
analysis typed: ``stability``."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import autobal
from autobal import report, scenario
from autobal.analysis.numerics import stability
from autobal.analysis.numerics.linearize import Setup
from autobal.analysis.numerics.stability import QUANTITIES, StabilityResult
from autobal.analysis.run import fields
from autobal.analysis.run.quantities import significant
from autobal.analysis.run.result import Failures, html_block, plain
from autobal.api import Run
from autobal.cli import main
from autobal.parts.device import dynamic_device


@pytest.fixture(scope="module")
def pump():
    """Pump PE 600-300 (Pavlenko 2014, App. A): the stability study without a map, and its scene."""
    scene = autobal.load("pump_pe600_dynamics")
    setup = Setup(dynamic_device(scene), 1.0)
    return scene, stability.study(setup, ["nonlinear", "program"], None, "pump", 50.0)


def test_to_dict_and_from_dict_are_inverse(pump):
    _, res = pump
    d = res.to_dict()
    back = StabilityResult.from_dict(json.loads(json.dumps(plain(d))))  # through JSON, as results.json
    assert back == res and plain(back.to_dict()) == plain(d)
    assert list(back.to_dict()) == list(d)  # the keys in the same order: results.json byte for byte
    assert "maps" not in d and "failures" not in d  # not computed / none: not in the block
    # the fields read as the block says: the energy-consistent model's decay rate is -max Re of its poles, stable
    decay = -max(d["models"]["nonlinear"]["poles"]["real"])
    assert back.margin.decay_rate == pytest.approx(decay, rel=1e-12) and back.decay_rate == back.margin.decay_rate
    assert decay > 0 and back.stable is True
    assert back.required_decay_rate == 50.0 == d["decay_rate"]
    assert back.head.margin_to_required == pytest.approx(back.decay_rate - 50.0, rel=1e-12)
    assert back.models["program"].poles.real.max() == pytest.approx(d["models"]["program"]["poles"]["real"].max())
    # == compares the numbers: one pole moved is another result
    moved = dataclasses.replace(back, poles=dataclasses.replace(back.poles, real=back.poles.real + 1e-9))
    assert moved != back


def test_a_null_in_results_json_comes_back_as_nan_and_goes_out_as_null(pump):
    _, res = pump
    d = json.loads(json.dumps(plain(res.to_dict())))
    d["models"]["program"]["damping_ratio"][0] = None
    back = StabilityResult.from_dict(d)
    assert math.isnan(back.models["program"].damping_ratio[0])
    assert plain(back.to_dict()) == d


def test_a_result_is_frozen_but_takes_what_a_run_sets(pump):
    _, res = pump
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.title = "another"
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.margin.decay_rate = 1.0
    copy = dataclasses.replace(res)
    copy.display_choice = {"speed": "rpm"}  # autobal.run sets the scene's display units on each Result
    assert copy.display_choice == {"speed": "rpm"} and copy == res


def test_a_renamed_or_missing_key_is_an_error_naming_it(pump):
    _, res = pump
    d = json.loads(json.dumps(plain(res.to_dict())))
    renamed = json.loads(json.dumps(d))
    renamed["margin"]["decay"] = renamed["margin"].pop("decay_rate")
    with pytest.raises(KeyError, match="Margin has no field 'decay'"):
        StabilityResult.from_dict(renamed)
    del d["headline"]
    with pytest.raises(KeyError, match="no 'headline'"):
        StabilityResult.from_dict(d)


def test_every_declaration_of_the_fields_is_a_field_path_with_its_unit():
    """The declarations come from the fields: each key of a field's Quantity is the path of that field, and the
    units map finds the field's unit at each path (a renamed field renames its key; nothing is written twice)."""
    paths = fields.key_paths(StabilityResult)
    assert {"decay_rate", "poles.real", "models.*.hurwitz.minors", "headline.leading_pole.imag",
            "maps.*.max_real", "models.*.unstable_modes[].real"} <= set(paths)
    own = [q for q in QUANTITIES if set(q.keys) & set(paths)]
    assert sorted(k for q in own for k in q.keys) == sorted(paths)
    for path, f in fields._walk(StabilityResult):
        if fields.QUANTITY in f.metadata:
            concrete = path.replace("*", "nonlinear").replace("[]", ".0")
            assert QUANTITIES.find(concrete).unit == f.metadata[fields.QUANTITY][0], path
    # the headline in the order of the fields' ranks (the summary's and the report's rows)
    assert [q.symbol for q in QUANTITIES if q.headline] == ["α", "η", "η − α", "ζ_min", "Im λ"]


def test_a_field_that_would_hide_a_result_method_is_refused():
    @fields.record
    class Bad(fields.TypedResult):
        headline: float = fields.quantity("1/s", "η")  # Result.headline() would be lost

    with pytest.raises(TypeError, match="headline"):
        fields.declarations(Bad)


def test_failures_are_a_field_and_fail_the_run(pump):
    scene, res = pump
    assert res.failures == () and res.failures() == []
    failed = dataclasses.replace(res, failures=["map point 3: eigenvalues did not converge"])
    assert isinstance(failed.failures, Failures) and failed.failures() == ["map point 3: eigenvalues did not converge"]
    block = plain(failed.to_dict())
    assert block["failures"] == ["map point 3: eigenvalues did not converge"]
    assert StabilityResult.from_dict(block) == failed
    run = Run(scene, {"stability": failed}, {"stability": 0.0})
    assert run.status == "failed" and run.failures == {"stability": ["map point 3: eigenvalues did not converge"]}
    (sec,) = report.sections({"scenario": "x", "stability": block})
    assert sec["overall"] == {"ok": False, "text": "FAILED: map point 3: eigenvalues did not converge"}
    assert "FAILED: map point 3" in html_block(failed, figures=False)


def test_a_result_holding_data_keeps_its_failures():
    from autobal.analysis.run.result import Result

    class Held(Result):
        def __init__(self, data):
            self.data = data

    r = Held({"failures": ["integrator: step size too small"]})
    assert r.failures() == ["integrator: step size too small"] and r.failures == ("integrator: step size too small",)


@pytest.mark.cli
def test_load_run_gives_the_results_back_and_the_same_report(shipped_run):
    """Pump PE 600-300 dynamics (with the stability map): load_run rebuilds the stability Result equal to the
    run's; its block is results.json's; report.html rendered again from the loaded Results is the page the
    run wrote, byte for byte."""
    run, folder = shipped_run("pump_pe600_dynamics")
    saved = json.loads((folder / "results.json").read_text())
    done = autobal.load_run(folder)
    assert done["stability"] == run["stability"] and done.status == saved["status"] == "ok"
    assert plain(done["stability"].to_dict()) == saved["stability"]
    assert done["stability"].maps["nonlinear"].stable_fraction == saved["stability"]["maps"]["nonlinear"][
        "stable_fraction"]
    assert done["stability"].summary() == run["stability"].summary()
    # every analysis is loaded and gives its block back, or is named with the reason
    for name in (k for k in saved if k in report.SECTIONS):
        if name in done:
            assert plain(done[name].to_dict()) == saved[name], name
        else:
            assert done.unloaded[name].startswith(f"{name}: "), name
    assert report.html(folder) == (folder / report.REPORT).read_text(encoding="utf-8")
    (sec,) = [s for s in report.context(folder)["sections"] if s["name"] == "stability"]
    decay = -max(saved["stability"]["models"]["nonlinear"]["poles"]["real"])
    assert sec["overall"]["text"] == ("energy-consistent (nonlinear): stable, disturbances decay at "
                                      f"{significant(decay)} 1/s")
    assert [row[1]["text"] for row in sec["tables"][0]["rows"]] == ["α", "η", "η − α", "ζ_min", "Im λ"]


def test_load_run_of_a_folder_without_results_is_one_line(tmp_path):
    with pytest.raises(autobal.ScenarioError, match="holds no results.json"):
        autobal.load_run(tmp_path)


def test_the_loaded_section_reads_the_fields_not_the_block(pump):
    """The stability section is built from sec.result: a block whose models table differs from its fields
    cannot exist, and the table's decay rate is the field's."""
    _, res = pump
    (sec,) = report.sections({"scenario": "x", "stability": plain(res.to_dict())})
    rows = {r[0]["text"]: r for t in (*sec["tables"], *sec["validation_tables"]) for r in t["rows"]}
    nonlinear = rows["energy-consistent (nonlinear)"]
    assert nonlinear[3]["text"] == report.number(res.models["nonlinear"].margin.decay_rate)
    assert np.isclose(float(nonlinear[3]["text"]), -res.models["nonlinear"].poles.real.max(), rtol=1e-4)


EXTREME = sorted((scenario.resolve("pump_pe600_dynamics").parent / "extreme").glob("dynamics_*.yaml"))


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if i else p
                                  for i, p in enumerate(EXTREME)], ids=[p.stem for p in EXTREME])
def test_the_round_trip_holds_on_the_extreme_scenes(path):
    """Incompressible liquid, no damping, small chambers, the valve on its limits: whatever the poles, the block
    comes back as it went out, and every number of it is declared by a field or the extra declarations."""
    from autobal.analyses import stability as room

    scene = autobal.load(path)
    res = room.run(scene, scene.analyses.stability)
    d = json.loads(json.dumps(plain(res.to_dict())))
    back = StabilityResult.from_dict(d)
    assert back == res and plain(back.to_dict()) == d and back.accuracy == d["accuracy"]
    assert QUANTITIES.undeclared(d) == []
    assert back.verdict() == res.verdict() and back.summary() == res.summary()


@pytest.mark.cli
def test_reliability_is_typed_loads_back_and_renders_the_same_report(tmp_path):
    """Hydro-heel wear (Pavlenko 2014, ch. 1.2) on a coarse grid (201 times, 4001 load nodes): the Result's fields
    are its block, a null (no time of reliable operation: P(0) = 0.776 < 0.8) comes back as NaN and goes out as
    null with its status, load_run rebuilds it equal, and report.html rendered again from it is the same page."""
    from autobal.analysis.studies.reliability import QUANTITIES as REL
    from autobal.analysis.studies.reliability import ReliabilityResult

    scene = autobal.load("hydroheel_wear", set={"analyses.reliability.time_points": 201,
                                                "analyses.reliability.tau_nodes": 4001})
    run = autobal.run(scene, out=tmp_path / "out")
    res = run["reliability"]
    assert isinstance(res, ReliabilityResult) and res.literal.P[0] == pytest.approx(0.671, abs=1e-3)
    assert math.isnan(res.literal.time_at) and "(P(0) = 0.7758)" in res.literal.time_at_status
    assert res.renormalised.time_at_status is None and 2000 * 3600 < res.renormalised.time_at < 2600 * 3600
    assert res.mttf == res.renormalised.mttf and res.mttf_literal == res.literal.mttf
    saved = json.loads((tmp_path / "out" / "results.json").read_text())
    done = autobal.load_run(tmp_path / "out")
    assert done["reliability"] == res and plain(done["reliability"].to_dict()) == saved["reliability"]
    assert saved["reliability"]["literal"]["time_at"] is None
    assert list(res.to_dict()) == list(saved["reliability"])  # the keys in the order results.json has them
    assert done["reliability"].summary() == res.summary()
    page = (tmp_path / "out" / report.REPORT).read_bytes()
    assert report.html(tmp_path / "out") == page.decode("utf-8")
    (tmp_path / "out" / report.REPORT).unlink()
    assert main(["report", str(tmp_path / "out")]) == 0  # autobal report OUT: the same page from the loaded Results
    assert (tmp_path / "out" / report.REPORT).read_bytes() == page
    assert [q.key for q in REL if q.headline] == ["renormalised.mttf", "literal.mttf"]
    assert set(fields.key_paths(ReliabilityResult)) == {k for q in REL for k in q.keys} - {
        "table_1_2.mttf", "table_1_2.time_at_P_0.8", "accuracy.**"}


def test_a_row_of_a_typed_section_must_name_a_declared_field(pump):
    """A report row whose key no field declares is an error of the section, not a row without a unit."""
    _, res = pump
    sec = report.Section("stability", plain(res.to_dict()), {})
    sec.row("decay rate", "η", "margin.decay_rate", value=80.0)
    with pytest.raises(KeyError, match="stability.margin.decay: no field of StabilityResult declares it"):
        sec.row("decay rate", "η", "margin.decay", value=80.0)
