"""Hostile cases of the liquid_balancer, estimation, montecarlo and rotor_dynamics rooms: a report written again from
an older results.json, a failed fit inside a solved estimation, a reference discharge ratio off the grid."""

from __future__ import annotations

import copy
import json

import pytest
import yaml

from autobal import cli, report, scenario
from autobal.analysis.studies.estimation_study import EstimationResult


@pytest.fixture(scope="module")
def small_montecarlo(tmp_path_factory):
    """The shipped Monte Carlo scene with 600 samples at ψ1 = 0.75 and 1.25 (1.0, the reference, off the grid)."""
    folder = tmp_path_factory.mktemp("mc")
    d = yaml.safe_load(scenario.resolve("pump_pe600_montecarlo").read_text())
    d["analyses"]["montecarlo"] |= {"samples": 600, "chunk_size": 300, "discharge_ratio": [0.75, 1.25]}
    del d["analyses"]["montecarlo"]["afc"]
    (folder / "mc.yaml").write_text(yaml.safe_dump(d))
    assert cli.main(["run", str(folder / "mc.yaml"), "--out", str(folder / "out")]) == 0
    return folder / "out"


@pytest.mark.cli
def test_reference_off_the_grid_is_the_first_grid_point_and_said_so(small_montecarlo):
    block = json.loads((small_montecarlo / "results.json").read_text())["montecarlo"]
    assert block["reference"]["psi1"] == 0.75 and block["reference_psi1"] == 1.0
    sec = next(s for s in report.context(small_montecarlo)["sections"] if s["name"] == "montecarlo")
    assert sec["overall"]["text"].startswith("at ψ1 = 0.75: face gap ") and sec["error"] is None


@pytest.mark.cli
def test_report_again_from_a_results_file_without_the_physical_values(small_montecarlo, tmp_path):
    """`autobal report` on a folder written before montecarlo had `reference` and `dimensional`: the section renders
    (the source's groups, no physical table), one verdict, no error."""
    import shutil

    folder = tmp_path / "old"
    shutil.copytree(small_montecarlo, folder)
    results = json.loads((folder / "results.json").read_text())
    for key in ("reference", "dimensional", "scales", "p1"):
        del results["montecarlo"][key]
    (folder / "results.json").write_text(json.dumps(results))
    assert cli.main(["report", str(folder)]) == 0
    sec = next(s for s in report.context(folder)["sections"] if s["name"] == "montecarlo")
    assert sec["error"] is None and sec["overall"]["ok"] is True  # below 1 % unsolved: not a failure, said so
    assert sec["overall"]["text"].endswith("converged exact solution")
    assert not [t for t in sec["tables"] if t["caption"].startswith("Exact statics over the samples")]


@pytest.mark.cli
def test_a_failed_fit_makes_the_one_verdict_not_ok(shipped_run):
    """A fit that did not converge (its block: status failed, the solver's status) beside a solved one."""
    data = copy.deepcopy(shipped_run("rig_table43_fit")[0]["estimation"].to_dict())
    data["fits"]["static_2p"] = {"status": "failed", "model": "traditional_disc", "residual": "u",
                                 "reason": "fit 'static_2p' did not converge",
                                 "solver": {"status": "Maximum_Iterations_Exceeded", "success": False},
                                 "last_iterate": {"alpha": 2.0}, "hint": "raise max_iterations"}
    data["failures"] = ["fit 'static_2p' did not converge (status Maximum_Iterations_Exceeded); raise max_iterations"]
    ok, words = EstimationResult.from_dict(data).verdict()
    assert not ok and "static_2p (): solver FAILED (Maximum_Iterations_Exceeded)" in words
    out = EstimationResult.from_dict(data).summary()
    assert out.splitlines()[1].startswith("  NOT OK: static_1p (alpha): NOT adequate")
    assert "FAILED fit 'static_2p'" in out


@pytest.mark.cli
def test_an_undefined_correlation_prints_as_a_dash(shipped_run):
    """A singular Hessian leaves the correlation null in results.json (a case the hypothesis test of the
    estimation inputs found): the summary prints '—' and the report leaves the row out, no TypeError."""
    data = copy.deepcopy(shipped_run("rig_table43_fit")[0]["estimation"].to_dict())
    data["fits"]["static_2p"]["correlation"] = [[1.0, None], [None, 1.0]]
    out = EstimationResult.from_dict(data).summary()
    assert "correlation of alpha and tau_max: —" in out and "hardly separate" not in out
