"""One place for solver options (analysis/run/solver_options.py): documented defaults, set for a session, reset,
changed within a block, refused when unknown; every solver reads them when it is built or run."""

import re
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import autobal
from autobal.analysis.run import solver_options as so

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _documented():
    so.reset_defaults()
    yield
    so.reset_defaults()


def test_the_documented_defaults_are_the_ones_in_force_and_the_front_door_reads_them():
    assert so.get() == dict(so.DEFAULTS)
    assert autobal.solver_defaults("ipopt") == {"tol": 1e-12, "constr_viol_tol": 1e-12, "compl_inf_tol": 1e-12,
                                                "acceptable_iter": 0, "bound_relax_factor": 0.0, "max_iter": 300}
    assert autobal.solver_defaults()["spinup.max_iter"] == 1000
    assert autobal.solver_defaults()["transient.rtol"] == 1e-9
    # a copy: changing it changes nothing
    autobal.solver_defaults("ipopt")["max_iter"] = 1
    autobal.solver_defaults()["ipopt.max_iter"] = 1
    assert so.defaults["ipopt.max_iter"] == 300


def test_set_reset_and_a_temporary_change():
    autobal.set_solver_defaults("spinup", max_iter=3000, tol=1e-6)
    assert so.get("spinup")["max_iter"] == 3000 and so.defaults["spinup.tol"] == 1e-6
    assert so.get("spinup")["constr_viol_tol"] == 1e-8  # the others as they were
    with autobal.using_solver_defaults("spinup", max_iter=5):
        assert so.defaults["spinup.max_iter"] == 5
    assert so.defaults["spinup.max_iter"] == 3000  # back to the session's, not the documented
    with pytest.raises(RuntimeError), autobal.using_solver_defaults("transient", rtol=1e-6):
        raise RuntimeError("inside")
    assert so.defaults["transient.rtol"] == 1e-9  # restored when the block raised
    autobal.reset_solver_defaults()
    assert so.get() == dict(so.DEFAULTS)
    assert so.DEFAULTS["spinup.max_iter"] == 1000  # the documented values are read-only
    with pytest.raises(TypeError):
        so.DEFAULTS["spinup.max_iter"] = 1


@pytest.mark.parametrize("group, options, message", [
    ("ipopt", {"max_itr": 5}, "unknown solver option 'ipopt.max_itr'; ipopt has tol, "),
    ("ipopts", {}, "unknown solver option group 'ipopts'; known: ipopt, "),
    ("ipopt", {"max_iter": 2.5}, "solver option 'ipopt.max_iter' takes a value of type int, got 2.5"),
    ("ipopt", {"max_iter": True}, "solver option 'ipopt.max_iter' takes a value of type int, got True"),
    ("ipopt", {"tol": "1e-6"}, "solver option 'ipopt.tol' takes a value of type float, got '1e-6'"),
    ("transient", {"rtol": -1e-6}, "solver option 'transient.rtol' must be >= 0, got -1e-06"),
    ("design", {"mu_strategy": 1}, "solver option 'design.mu_strategy' takes a value of type str, got 1"),
])
def test_an_unknown_option_or_a_wrong_value_is_one_line_and_sets_nothing(group, options, message):
    with pytest.raises(ValueError) as err:
        autobal.set_solver_defaults(group, **({"acceptable_iter": 7} if group == "ipopt" else {}), **options)
    assert str(err.value).startswith(message) and "\n" not in str(err.value)
    assert so.get() == dict(so.DEFAULTS)  # the valid option given with it was not set either
    with pytest.raises(ValueError, match="unknown solver option"), autobal.using_solver_defaults("spinup", maxiter=1):
        pass


def test_an_integer_is_a_float_option():
    autobal.set_solver_defaults("transient", rtol=0, atol=1)
    assert so.get("transient")["atol"] == 1


def _fit(max_iter=None):
    """A two-parameter least-squares fit that IPOPT needs several iterations for: r = (e^x0 - 2, x1^3 - 1)."""
    from autobal.analysis.numerics.least_squares import LeastSquares

    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 0)
    ls = LeastSquares("fit_test", x, p, ca.vertcat(ca.exp(x[0]) - 2, x[1] ** 3 - 1), ca.SX(0, 1), 2,
                      max_iter=max_iter)
    return ls.solver, ipopt_solve(ls.solver)


def ipopt_solve(solver):
    from autobal.analysis.numerics import ipopt

    return ipopt.solve(solver, x0=[3.0, 3.0], lbx=-10, ubx=10, lbg=0, ubg=0, p=[])


def test_an_ipopt_solver_is_built_with_the_options_in_force():
    _, done = _fit()
    assert done["success"] and done["iterations"] > 3
    np.testing.assert_allclose(done["x"], [np.log(2.0), 1.0], rtol=1e-9)  # hand calculation
    with autobal.using_solver_defaults("fit", max_iter=2):
        solver, capped = _fit()
    assert (capped["status"], capped["iterations"]) == ("Maximum_Iterations_Exceeded", 2)
    # built under the change, the solver keeps it after the block; a solver built now has the default again
    assert ipopt_solve(solver)["iterations"] == 2 and _fit()[1]["iterations"] == done["iterations"]
    # the caller's own limit (a scene's fit.max_iterations) wins over the session's
    with autobal.using_solver_defaults("fit", max_iter=2):
        assert _fit(max_iter=50)[1]["success"]
    # the base group reaches every IPOPT solve: the fit's tolerance is ipopt.tol's
    with autobal.using_solver_defaults("ipopt", tol=1e-2, constr_viol_tol=1e-2, compl_inf_tol=1e-2):
        loose = _fit()[1]
    assert loose["success"] and loose["iterations"] < done["iterations"]


def test_the_statics_read_the_ipopt_and_continuation_groups():
    from autobal.analysis.numerics.statics import StaticsSolver
    from autobal.analysis.studies.statics_study import continuation
    from autobal.errors import SolveError
    from autobal.parts.device import design
    from autobal.scenario import load

    solver = StaticsSolver(design(load("pump_pe600_statics").device))
    grid = np.linspace(0.6, 1.4, 9)
    along = continuation(solver, grid, 0.2)
    # 9 points > 4 path nodes: solved from a path of 4 nodes instead of along the grid, the same statics
    with autobal.using_solver_defaults("continuation", path_nodes=4):
        from_nodes = continuation(solver, grid, 0.2)
    np.testing.assert_allclose([p.values["u"] for p in from_nodes], [p.values["u"] for p in along], rtol=1e-8)
    with autobal.using_solver_defaults("ipopt", max_iter=1), pytest.raises(SolveError, match="Maximum_Iterations"):
        StaticsSolver(design(load("pump_pe600_statics").device)).solve(1.0, 0.2)


def test_the_spinup_coarse_stage_and_the_transient_read_theirs():
    from autobal.ocp.solve import coarse_options

    assert coarse_options(None) == {"max_iter": 200}
    assert coarse_options({"max_iter": 50, "tol": 1e-6}) == {"max_iter": 50, "tol": 1e-6}
    with autobal.using_solver_defaults("spinup_coarse", max_iter=7):
        assert coarse_options(None) == {"max_iter": 7}
    with autobal.using_solver_defaults("spinup", max_iter=100), autobal.using_solver_defaults("spinup_coarse",
                                                                                              max_iter=500):
        assert coarse_options(None) == {"max_iter": 100}


def test_the_transient_integrator_reads_its_group():
    from autobal.analysis.numerics.linearize import Setup
    from autobal.analysis.numerics.simulate import Simulator
    from autobal.parts import device

    model = Setup(device.adapt(autobal.load("pump_pe600_dynamics").device)).nonlinear("energy")
    sim = Simulator(model, 0.01, 11)
    assert (sim.rtol, sim.atol) == (1e-9, 1e-11)
    with autobal.using_solver_defaults("transient", rtol=1e-6, atol=1e-8):
        loose = Simulator(model, 0.01, 11)
    assert (loose.rtol, loose.atol) == (1e-6, 1e-8)
    assert Simulator(model, 0.01, 11, rtol=1e-7).rtol == 1e-7  # the caller's own wins
    # cross-check: the loose run agrees with the tight one within its tolerance, and differs from it
    tight_x, loose_x = (s.run(s.input_vector("force_step", 0.01))["X"] for s in (sim, loose))
    scale = np.abs(tight_x).max()
    assert 0 < np.abs(loose_x - tight_x).max() < 1e-3 * scale
    # the step budget of RODAS4 is the group's max_num_steps: 3 steps do not reach the first output
    with autobal.using_solver_defaults("transient", max_num_steps=3):
        short = Simulator(model, 0.05, 51, "rodas4")
    assert "step budget" in short.run(short.input_vector("force_step", 0.01))["failure"]["message"]


def test_the_rotor_studies_read_their_group():
    """Lewis' run-up (analysis/numerics/rotor.py): a looser tolerance of the group moves the peak, within it, and a step
    budget of 3 does not reach the first output (CVODES fails)."""
    from autobal.analysis.numerics import rotor

    ref = rotor.lewis(0.05, 0.01)["peak"]
    with autobal.using_solver_defaults("rotor", tol=1e-5):
        loose = rotor.lewis(0.05, 0.01)["peak"]
    assert 0 < abs(loose - ref) < 1e-3 * ref
    assert rotor.lewis(0.05, 0.01, tol=1e-5)["peak"] == loose  # the caller's own wins
    with autobal.using_solver_defaults("rotor", max_num_steps=3), pytest.raises(RuntimeError):
        rotor.lewis(0.05, 0.01)


def test_the_scene_defaults_are_the_documented_ones():
    from autobal.analyses.estimation import Fit
    from autobal.analyses.spinup import Spinup

    fields = Spinup.model_fields
    assert (fields["max_iterations"].default, fields["tolerance"].default) == (1000, 1e-8)
    assert Fit.model_fields["max_iterations"].default == so.DEFAULTS["fit.max_iter"] == 300


def test_no_copy_of_a_documented_default_outside_the_module():
    # "option": <its documented value> written anywhere else in the library is a second place for it
    copies = []
    for path in [*ROOT.glob("analysis/**/*.py"), *ROOT.glob("ocp/*.py"), *ROOT.glob("autobal/**/*.py")]:
        if path.name == "solver_options.py":
            continue
        text = path.read_text()
        for key, value in so.DEFAULTS.items():
            name = key.split(".", 1)[1]
            if re.search(rf'"{name}"\s*:\s*{re.escape(repr(value))}(?![\d.e])', text):
                copies.append(f"{path.relative_to(ROOT)}: {name}: {value!r}")
    assert copies == []


def test_the_api_page_holds_the_table_of_defaults():
    assert so.markdown_table() in (ROOT / "docs" / "api.md").read_text()
    rows = so.markdown_table().splitlines()
    assert len([r for r in rows if r.startswith("| `")]) == len(so.DEFAULTS)


def test_the_spinup_resimulation_reads_its_group():
    from autobal.analyses.spinup import ocp as spinup_ocp
    from autobal.ocp.simulation import ramp_profile, resimulate

    scene = autobal.load("spinup_jeffcott_deadline_5s")
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    u, h = ramp_profile(ocp, 20, ocp.alpha_max), np.full(20, ocp.tau_h / 20)
    shipped = resimulate(ocp, u, h, "ramp")
    assert len(shipped.t) == 20 * 24 + 1  # resimulation.points samples per interval and the start
    explicit = resimulate(ocp, u, h, "ramp", points=24, tol=1e-10)
    assert shipped.peak_delta == explicit.peak_delta  # the documented defaults, bit for bit
    with autobal.using_solver_defaults("resimulation", points=4, tol=1e-6):
        coarse = resimulate(ocp, u, h, "ramp")
    assert len(coarse.t) == 20 * 4 + 1
    # cross-check: the loose, sparse re-simulation finds the same peak within its tolerance and sampling
    assert coarse.peak_delta != shipped.peak_delta
    np.testing.assert_allclose(coarse.peak_delta, shipped.peak_delta, rtol=2e-2)


def test_the_batched_gauss_newton_reads_its_group():
    from autobal.analysis.numerics.least_squares import GaussNewtonBatch

    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    residual = ca.Function("r", [x, p], [ca.vertcat(ca.exp(x[0]) - p[0], x[1] ** 3 - p[1])])
    data = np.array([[2.0, 3.0, 5.0], [1.0, 8.0, 27.0]])  # roots (log 2, 1), (log 3, 2), (log 5, 3)
    start, box = [np.full(2, 9.0)], [np.full(2, -10.0), np.full(2, 10.0)]
    done = GaussNewtonBatch(residual).solve(*start, data, *box)
    assert done["converged"].all() and 1 < done["blocks"] <= so.DEFAULTS["gauss_newton.max_blocks"]
    np.testing.assert_allclose(done["x"], [np.log(data[0]), np.cbrt(data[1])], rtol=1e-12)  # hand calculation
    with autobal.using_solver_defaults("gauss_newton", block=1, max_blocks=2):
        short = GaussNewtonBatch(residual).solve(*start, data, *box)
    assert short["blocks"] == 2 and not short["converged"].any()
    assert GaussNewtonBatch(residual, max_blocks=1).solve(*start, data, *box)["blocks"] == 1


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="CasADi's Linux wheels")
def test_casadis_openblas_under_mumps_runs_on_one_thread_unless_the_environment_says():
    import os
    import subprocess

    # a solver built in a new process, then the thread count of the OpenBLAS that MUMPS loaded (RTLD_NOLOAD)
    code = ("import ctypes, os, casadi; from autobal.analysis.numerics import ipopt; x = casadi.MX.sym('x'); "
            "ipopt.nlpsol('t', x, casadi.MX.sym('p', 0), x**2, casadi.MX(0, 1)); "
            "print(ctypes.CDLL(ipopt.OPENBLAS, mode=os.RTLD_NOLOAD | os.RTLD_LAZY).openblas_get_num_threads())")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    for extra, threads in (({}, "1"), ({"OPENBLAS_NUM_THREADS": "2"}, "2")):
        out = subprocess.run([sys.executable, "-c", code], env=env | extra, capture_output=True, text=True)
        assert out.stdout.split() == [threads], out.stderr
