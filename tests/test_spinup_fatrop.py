"""fatrop on the stage form of the spin-up collocation (ocp/transcription.py ``transcribe_stages``,
ocp/solve.py ``fatrop_solver``): the same discrete problem as IPOPT's layout, the same optimum from the same
guess, honest statuses, and the scene key."""

import dataclasses

import casadi as ca
import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.errors import ScenarioError, SolveError
from autobal.ocp import solve as osolve
from autobal.ocp import spinup_study
from autobal.ocp.transcription import DirectCollocation, complete_stage_guess, transcribe, transcribe_stages
from tests.test_spinup_derivatives import VARIANTS, graded


def stage_point(ipopt_nlp, stage_nlp, w):
    """The stage form's variables at the IPOPT layout's point ``w`` (the copies filled)."""
    ws = np.zeros(stage_nlp.x.numel())
    for key in ("X", "Xc", "u", "v"):
        ws[stage_nlp.index[key]] = w[ipopt_nlp.index[key]]
    return complete_stage_guess(stage_nlp, ws)


@pytest.mark.parametrize("mesh", ["uniform", "graded"])
@pytest.mark.parametrize("name", VARIANTS)
def test_the_stage_form_is_the_same_discrete_problem(name, mesh):
    """At a random point: the same objective, the same values of every constraint block (the gap rows the stage
    form adds are zero there), and the same bounds; on the uniform mesh and on a graded one (the jerk limit's rows
    with each interval pair's own step)."""
    ocp = VARIANTS[name]
    if mesh == "graded" and ocp.free_time:
        pytest.skip("the free-time transcription is uniform")
    ms = graded(ocp) if mesh == "graded" else None
    a = transcribe(ocp, DirectCollocation(12), 200.0, "MX", ms)
    b = transcribe_stages(ocp, DirectCollocation(12, solver="fatrop"), 200.0, ms)
    w = np.random.default_rng(3).normal(size=a.x.numel())
    w[a.index["v"]] = np.abs(w[a.index["v"]])
    ws = stage_point(a, b, w)
    fa, ga = (np.array(v).ravel() for v in ca.Function("a", [a.x], [a.f, a.g])(w))
    fb, gb = (np.array(v).ravel() for v in ca.Function("b", [b.x], [b.f, b.g])(ws))
    assert_allclose(fb, fa, rtol=1e-14)
    blocks = dict(b.blocks)
    for name_a, rows in a.blocks:
        if name_a == "dynamics":  # the stage form's dynamics rows: its collocation residuals and its gap rows
            mine = gb[blocks["dynamics"]]
            assert_allclose(np.sort(mine[np.abs(mine) > 0]), np.sort(ga[rows][np.abs(ga[rows]) > 0]), rtol=1e-13)
            assert np.count_nonzero(mine) == np.count_nonzero(ga[rows])
        elif name_a.startswith("final speed"):  # one row of the stage form's speed block
            speed = blocks[next(k for k in blocks if k.startswith("speed"))]
            assert np.isclose(gb[speed], ga[rows][0] + ocp.nuf, rtol=1e-14, atol=0).sum() == 1
        else:  # the stage form's rows with a bound (a free row where the limit does not apply)
            mine = blocks[name_a][np.isfinite(b.lbg[blocks[name_a]]) | np.isfinite(b.ubg[blocks[name_a]])]
            assert_allclose(np.sort(gb[mine]), np.sort(ga[rows]), rtol=1e-13)
    for key in ("u", "v"):
        assert_allclose(b.lbx[b.index[key]], a.lbx[a.index[key]])
        assert_allclose(b.ubx[b.index[key]], a.ubx[a.index[key]])
    assert_allclose(b.lbx[b.index["X"][0]], a.lbx[a.index["X"][0]])
    assert_allclose(b.ubx[b.index["X"][0]], a.ubx[a.index["X"][0]])
    # the speed bounds, on variables in IPOPT's layout, are rows of the stage form (fatrop ignores fixed bounds)
    speed = next(r for k, r in b.blocks if k.startswith("speed"))
    n = a.mesh.n
    assert_allclose(b.ubg[speed][1:n], a.ubx[a.index["X"][1:n, 4]])
    assert_allclose(b.lbg[speed][1:n], a.lbx[a.index["X"][1:n, 4]])


def test_fatrop_reaches_ipopt_s_optimum_from_the_same_guess():
    """The deadline scene (no jerk term), 100 intervals: fatrop and IPOPT converge from the benchmark's guess (the
    global search's profile, the collocation states held at the interval start) to the same optimum."""
    scene = api.load("spinup_jeffcott_deadline_5s")
    ocp = dataclasses.replace(spinup_ocp(scene, scene.analyses.spinup), jerk_variation=0.0)
    ipopt = osolve.Solver(ocp, DirectCollocation(100), 200.0)
    fatrop = osolve.Solver(ocp, DirectCollocation(100, solver="fatrop"), 200.0)
    u = osolve.starts(ocp, 100)[0][1]  # the global search's three-phase profile
    a = ipopt.solve(u, hold_states=True)
    b = fatrop.solve(u, hold_states=True)
    assert a.success and b.success and b.status == "Solve_Succeeded"
    assert_allclose(b.objective, a.objective, rtol=1e-6)
    assert_allclose(b.u, a.u, atol=1e-3)
    assert 12.0 < b.objective < 12.6


def test_fatrop_failure_names_the_iteration_limit():
    scene = api.load("spinup_jeffcott_deadline_5s")
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    solver = osolve.Solver(ocp, DirectCollocation(50, solver="fatrop"), 200.0, {"max_iter": 3})
    with pytest.raises(SolveError, match="iteration limit reached") as err:
        solver.solve(osolve.starts(ocp, 50, multistart=False)[0][1])
    assert err.value.status == "Maximum_Iterations_Exceeded"


def test_nlp_solver_is_a_scene_key():
    scene = api.load("spinup_jeffcott_deadline_5s", {"analyses.spinup.nlp_solver": "fatrop"})
    assert spinup_study.method_of(scene.analyses.spinup).solver == "fatrop"
    for overrides in ({"analyses.spinup.nlp_solver": "fatrop", "analyses.spinup.scheme": "legendre"},
                      {"analyses.spinup.nlp_solver": "knitro"}):
        with pytest.raises(ScenarioError, match="nlp_solver"):
            api.load("spinup_jeffcott_deadline_5s", overrides)
    with pytest.raises(ScenarioError, match="nlp_solver"):
        api.load("spinup_robust_jeffcott", {"analyses.spinup_robust.nlp_solver": "fatrop"})


@pytest.mark.slow
def test_the_study_with_fatrop_finds_ipopt_s_optimum():
    """The shipped deadline scene's whole study (starts, coarse screening, mesh continuation, re-simulation) with
    either solver: the same re-simulated optimum."""
    scene = api.load("spinup_jeffcott_deadline_5s")
    s = scene.analyses.spinup
    ocp = spinup_ocp(scene, s)
    peaks = {}
    for solver in ("ipopt", "fatrop"):
        r = spinup_study.run(ocp, spinup_study.method_of(s.model_copy(update={"nlp_solver": solver})))
        assert r.status == "Solve_Succeeded"
        peaks[solver] = r.peak_deflection_over_e
    assert_allclose(peaks["fatrop"], peaks["ipopt"], rtol=1e-4)
