"""Work-precision of the statics: the 40-digit reference, the error ladders, the CLI command."""

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal import cli
from autobal.analysis.run.result import plain
from autobal.analysis.studies import workprecision as wp


def test_reference_agrees_with_double_precision_newton(pump, compressor):
    for solver in (pump, compressor):
        dpsi = solver.design.dpsi
        ref = wp.statics_reference(solver.design.groups, 1.0, dpsi)
        x = solver.newton(1.0, dpsi)
        got = np.array([x[solver.system.index(k)] for k in wp.STATICS_OUTPUTS])
        assert_allclose(got, ref, rtol=1e-12)


def test_ipopt_error_follows_its_tolerance(pump):
    study = wp.statics_study(pump, 1.0, 0.04)
    rows = {r.setting: r.error for r in study.rows if r.method.startswith("IPOPT")}
    assert rows[1e-2] > 1e-4 and rows[1e-12] < 1e-11
    assert rows[1e-12] < rows[1e-8] < rows[1e-4]
    cheap = study.cheapest()
    best = cheap["IPOPT (bounds, complementarity)"]
    assert rows[best.setting] <= 1e-6  # which setting is fastest depends on the machine: cheapest() is tested below
    cf = [v for k, v in cheap.items() if k.startswith("closed form")][0]
    assert cf.setting is None and cf.best_error == pytest.approx(0.341, abs=2e-3)  # xi0: 1.294 vs 1.964


@pytest.mark.cli
def test_accuracy_command_writes_figure_csv_and_summary(tmp_path, capsys):
    assert cli.main(["accuracy", "pump_pe600_statics", "--out", str(tmp_path)]) == 0
    rep = json.loads((tmp_path / "accuracy.json").read_text())
    assert rep["studies"]["statics"]["target_error"] == 1e-6
    for f in ("workprecision_statics.csv", "workprecision_statics.png"):
        assert (tmp_path / f).stat().st_size > 0
    assert "setting for 1e-6" in capsys.readouterr().out


@pytest.mark.cli
def test_run_reports_timing_and_accuracy(tmp_path):
    assert cli.main(["run", "compressor_k180_statics", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["timing"]["statics"] > 0
    acc = res["accuracy"]["statics"]
    assert acc["estimate"] < 1e-10 and "40-digit" in acc["how"]


def test_dynamics_work_precision_orders_the_integrators():
    from autobal import scenario
    from autobal.analysis.numerics.linearize import Setup
    from autobal.parts import device as device_part

    model = Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device)).nonlinear("energy")
    study = wp.dynamics_study(model, 0.005, 0.01, quick=True)
    err = {(r.method, r.setting): r.error for r in study.rows}
    # CVODES converges with its tolerance, against a Radau reference
    assert err[("CVODES (BDF, exact Jacobian)", 1e-10)] < 1e-8 < err[("CVODES (BDF, exact Jacobian)", 1e-5)]
    # an explicit method cannot take the step a 8e8 1/s mode allows: it diverges (recorded, not hidden)
    assert all("diverged" in r.failed for r in study.rows if r.method.startswith("CasADi RK4"))
    st = study.stiffness
    assert st.ratio > 1e6 and st.max_abs_eigenvalue == pytest.approx(8.04e8, rel=0.01)
    assert st.reference_difference_cvodes_vs_radau < 1e-10
    # the block of accuracy.json comes back as the Result
    assert wp.WorkPrecision.from_dict(json.loads(json.dumps(plain(study.to_dict())))) == study


@pytest.mark.cli
def test_estimation_work_precision_on_table_43(tmp_path):
    assert cli.main(["accuracy", "rig_table43_fit", "--out", str(tmp_path)]) == 0
    rows = json.loads((tmp_path / "accuracy.json").read_text())["studies"]["estimation"]["rows"]
    best = {m: min(r["error"] for r in rows if r["method"] == m) for m in {r["method"] for r in rows}}
    assert all(e < 1e-10 for e in best.values())  # IPOPT (both Hessians) and scipy agree at tight tolerances
    loose = [r["error"] for r in rows if r["method"] == "IPOPT, Gauss-Newton Hessian" and r["setting"] == 1e-2][0]
    assert loose > 1e-10  # a loose tolerance leaves a visible error: the ladder measures something


def test_cheapest_picks_the_fastest_setting_meeting_the_target():
    # hand-made rows: the fastest meeting 1e-6 is the 1e-9 setting (not the fastest overall, 1e-4, nor the
    # loosest meeting it, 1e-7, nor the most accurate); a method that never reaches the target has no setting
    # but reports its best error
    rows = [wp.Trial("A", s, error=e, time_s=t)
            for s, e, t in ((1e-4, 1e-3, 0.1), (1e-7, 5e-7, 0.3), (1e-9, 1e-9, 0.2), (1e-12, 1e-12, 0.9))]
    rows += [wp.Trial("B", 1, error=1e-2, time_s=0.01), wp.Trial("B", 2, error=math.nan, time_s=0.02)]
    cheap = wp.WorkPrecision.of("x", "ref", ["y"], rows).cheapest(1e-6)
    assert cheap["A"].to_dict() == {"setting": 1e-9, "time_s": 0.2, "best_error": 1e-12}
    assert cheap["B"].to_dict() == {"setting": None, "time_s": None, "best_error": 1e-2}
