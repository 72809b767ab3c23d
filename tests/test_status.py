"""A status never says ok over a failure, and the API's contract (issue #25, items 2 and 8).

Each silently-wrong case of the issue asserts its exit code and outcome: a drain pressure above the discharge
pressure is refused (exit 2); a point whose balances do not hold is not a solution whatever IPOPT's status says;
a transient whose integrator fails makes the run "failed" (exit 3, the results kept and marked); a CasADi
function that raises is a failed solve; ``load(set=...)`` checks its argument and a validated scene cannot be
changed.
"""

from __future__ import annotations

import dataclasses
import json

import casadi as ca
import numpy as np
import pytest
import yaml

import autobal
from autobal import scenario
from autobal.analysis.numerics import statics as st
from autobal.analysis.run import executor, interrupt
from autobal.cli import main
from autobal.errors import ScenarioError, SolveError, SolverFailure
from autobal.models import device as dv
from autobal.parts import device as device_part

# ---- the drain pressure above the discharge pressure (issue: exit 0, "ok", relative residual 1.0) ---------


@pytest.mark.cli
def test_drain_pressure_above_the_discharge_pressure_is_refused(tmp_path, capsys):
    # 32.27 MPa + 40 MPa: refused before anything runs, one line naming the field and the unit
    rc = main(["run", "pump_pe600_statics", "--set", "device.operating.drain_pressure=72.27 MPa",
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and not (tmp_path / "o").exists()
    assert len(err.strip().splitlines()) == 1
    assert "drain_pressure: 72.27 MPa is not below the nominal discharge pressure 32.2749 MPa" in err
    with pytest.raises(ScenarioError, match="drain_pressure"):
        autobal.load("pump_pe600_statics", set={"device.operating.drain_pressure": "32.2749 MPa"})


def pe600_with_drain(drain: float) -> st.StaticsSolver:
    """The PE 600 device with a drain pressure (Pa) set on its SI parameters (the scene refuses it)."""
    p = device_part.adapt(autobal.load("pump_pe600_statics").device)
    return st.StaticsSolver(dv.design(dataclasses.replace(p, operating=dataclasses.replace(
        p.operating, drain_pressure=drain))))


def test_the_drain_case_is_a_closed_face_and_its_residual_is_measured_not_0_over_0():
    # what the model says about a drain 40 MPa above... the nominal drain at 40 MPa (above p1 = 32.27 MPa): an
    # equilibrium exists, the disc pressed onto the pad (contact), chamber 3 at the drain's pressure, no flow
    # through the face or the outer seal; the chamber-3 balance q_T - q_3 = 0 has both terms ~1e-20 and was
    # scaled by its own largest term (relative residual 1.0); now by 1e-9 of the network's flow
    solver = pe600_with_drain(40e6)
    pt = solver.solve(1.0, solver.design.dpsi)
    assert pt.contact and pt.status == "Solve_Succeeded"
    assert pt.values["psi3"] == pytest.approx(40e6 / 32.2749e6, rel=1e-9)
    assert abs(pt.flows["T"]) < 1e-15 and abs(pt.flows["3"]) < 1e-15 and pt.flows["e"] > 1e-3
    assert pt.max_residual <= st.MAX_RELATIVE_RESIDUAL


def test_ipopt_success_with_balances_not_satisfied_is_not_a_solution():
    # IPOPT's "Solve_Succeeded" at a point whose balances do not hold (the root moved by 1 % in psi2) is
    # Residual_Above_Tolerance, not a success; the root itself is one
    solver = pe600_with_drain(0.0)
    good = solver.solve(1.0, solver.design.dpsi)
    x = good.x.copy()
    x[solver.system.index("psi2")] *= 1.01

    def succeeded(at):
        return {"success": True, "status": "Solve_Succeeded", "iterations": 3, "x": at, "f": np.zeros(1),
                "lam_x": good.lam["x"], "lam_g": good.lam["g"]}

    res, pt = solver._solved(1.0, solver.design.dpsi, succeeded(x))
    assert not res["success"] and res["status"].startswith("Residual_Above_Tolerance")
    assert pt.max_residual > 1e-3 and pt.status == res["status"]
    res, pt = solver._solved(1.0, solver.design.dpsi, succeeded(good.x))
    assert res["success"] and pt.max_residual <= st.MAX_RELATIVE_RESIDUAL



def test_force_gap_point_whose_balances_do_not_hold_is_not_a_solution(monkeypatch):
    # the force-gap characteristic (2.35) checks every balance but the disc force (the gap is prescribed): IPOPT's
    # "Solve_Succeeded" at a point 1 % off the root in psi2 is Residual_Above_Tolerance; the true points pass
    solver = pe600_with_drain(0.0)
    dpsi = solver.design.dpsi
    phi = solver.force_gap(1.0, dpsi, [0.8, 1.2])
    assert np.all(np.isfinite(phi))
    real = st.ipopt.solve

    def off_root(*args, **kw):
        res = real(*args, **kw)
        x = np.array(res["x"], float).ravel()
        x[solver.system.index("psi2")] *= 1.01
        return res | {"x": x}

    good = solver.solve(1.0, dpsi)  # the operating point the continuation starts from, solved before the patch
    monkeypatch.setattr(solver, "solve", lambda *args: good)
    monkeypatch.setattr(st.ipopt, "solve", off_root)
    with pytest.raises(SolveError, match="the balances do not hold") as err:
        solver.force_gap(1.0, dpsi, [0.8, 1.2])
    assert err.value.status.startswith("Residual_Above_Tolerance")

# ---- a transient whose integrator fails (issue: exit 0, "ok", the failure a field inside the case) ---------

def failing_transient(tmp_path) -> str:
    """The compressor K180 without rotor damping and with a force step of 100 (the schema's bound): CVODES stops
    at t = 0 with CV_TOO_MUCH_WORK; a second, small case solves.  (With the face's squeeze film, which grows as
    the gap closes, the same step solves.)"""
    d = yaml.safe_load(scenario.resolve("compressor_k180_dynamics").read_text())
    d["device"]["dynamics"]["rotor_damping"] = "0 N*s/m"
    d["analyses"] = {"transient": {"duration": "2 ms", "points": 21, "cases": [
        {"input": "force_step", "amplitude": 100}, {"input": "force_step", "amplitude": 0.01}]}}
    path = tmp_path / "k180_failing.yaml"
    path.write_text(yaml.safe_dump(d))
    return str(path)


@pytest.mark.cli
def test_transient_integrator_failure_is_a_failed_run(tmp_path, capsys):
    rc = main(["run", failing_transient(tmp_path), "--out", str(tmp_path / "o")])
    out, err = capsys.readouterr()
    assert rc == 3
    assert out.splitlines()[0].startswith("FAILED: case 1 (force_step, amplitude 100): the integrator failed "
                                          "at t = 0 s")
    assert err.startswith("autobal: solve failed: transient: case 1") and "results.json" in err
    res = json.loads((tmp_path / "o" / "results.json").read_text())
    assert res["status"] == "failed"
    [line] = res["failures"]["transient"]
    assert "CV_TOO_MUCH_WORK" in line and res["transient"]["failures"] == [line]
    first, second = res["transient"]["cases"]
    assert first["failure"]["t"] == 0 and second["failure"] is None and second["max_dz"] > 0
    html = (tmp_path / "o" / "report.html").read_text()
    assert "Failed: the results below are kept" in html and "CV_TOO_MUCH_WORK" in html


@pytest.mark.cli
def test_the_api_run_says_failed_too(tmp_path):
    run = autobal.run(failing_transient(tmp_path))
    assert run.status == "failed" and list(run.failures) == ["transient"]
    assert run["transient"].summary().startswith("FAILED: ")
    assert run.to_dict()["status"] == "failed"


@pytest.mark.cli
def test_a_run_without_failures_is_ok(tmp_path):
    d = yaml.safe_load(scenario.resolve("compressor_k180_dynamics").read_text())
    d["analyses"] = {"transient": {"duration": "2 ms", "points": 11, "cases": [{"input": "force_step"}]}}
    path = tmp_path / "ok.yaml"
    path.write_text(yaml.safe_dump(d))
    assert main(["run", str(path), "-q", "--out", str(tmp_path / "o")]) == 0
    res = json.loads((tmp_path / "o" / "results.json").read_text())
    assert res["status"] == "ok" and res["failures"] == {} and res["transient"]["failures"] == []
    assert res["transient"]["equilibrium_residual"] < 1e-9


@pytest.mark.cli
def test_the_issues_pump_force_step_is_a_runaway_reported_and_cut_there():
    # the PE 600 with a force step of -50 (the issue's case): the gap runs away (unstable), a stop event, not a
    # solver failure: status ok, the event reported, the response cut at the first sample past 20 z_B (before,
    # the rest of the chunk was kept: max |dz| 0.24 m)
    run = autobal.run(autobal.load("pump_pe600_dynamics", set={"analyses": {"transient": {
        "cases": [{"input": "force_step", "amplitude": -50}]}}}))
    assert run.status == "ok"
    [case] = run["transient"].cases
    assert [e.event for e in case.events] == ["gap_runaway"] and case.failure is None
    z_b = 0.15e-3
    assert case.z[-2] <= 20 * z_b < case.z[-1] < 21 * z_b
    assert case.t_end == pytest.approx(case.events[0].t) and case.t_end < 2e-3


@pytest.mark.cli
def test_monte_carlo_with_many_samples_unsolved_is_failed():
    # a supply pressure psi_in with cv 0.9: about 13 % of the devices drawn cannot feed the barrier chamber and
    # have no static solution; the statistics of the others are kept, the result says failed
    scn = autobal.load("pump_pe600_montecarlo", set={
        "analyses.montecarlo.samples": 1000, "analyses.montecarlo.chunk_size": 1000, "analyses.montecarlo.afc": None,
        "analyses.montecarlo.discharge_ratio": [1.0],
        "analyses.montecarlo.parameters": {"psi_in": {"distribution": "normal", "cv": 0.9}}})
    res = autobal.run(scn)
    [invalid] = res["montecarlo"].exact["u"]["invalid"]
    assert 0.05 * 1000 < invalid < 0.3 * 1000
    assert res.status == "failed"
    assert res.failures["montecarlo"] == [f"psi1 = 1: the exact statics did not solve for {invalid} of 1000 samples "
                                          "(more than 1 %: the statistics would be of a selection)"]
    assert res["montecarlo"].summary().startswith("FAILED: psi1 = 1: ")
    # the same study with the scene's 5 %: nothing unsolved, ok
    ok = autobal.run(autobal.load("pump_pe600_montecarlo", set={
        "analyses.montecarlo.samples": 1000, "analyses.montecarlo.chunk_size": 1000, "analyses.montecarlo.afc": None,
        "analyses.montecarlo.discharge_ratio": [1.0]}))
    assert ok.status == "ok" and list(ok["montecarlo"].exact["u"]["invalid"]) == [0]


def test_a_casadi_function_that_raises_is_a_failed_solve():
    # CVODES allowed one step cannot reach t = 1: CasADi raises RuntimeError; through interrupt.call it is a
    # SolverFailure: a SolveError (exit 3, failed_solve.json) with CVODES' flag as status, still a RuntimeError
    x = ca.SX.sym("x")
    f = ca.integrator("stiff", "cvodes", {"x": x, "ode": -1e6 * x}, 0, 1.0, {"max_num_steps": 1})
    with pytest.raises(SolverFailure) as info:
        interrupt.call(f, x0=1.0)
    assert isinstance(info.value, SolveError) and isinstance(info.value, RuntimeError)
    assert info.value.status == "CV_TOO_MUCH_WORK" and str(info.value).startswith("stiff: ")


# ---- the API's contract ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("value", "message"), [
    ("a=b", "set: a mapping of dotted scene paths to values"),
    ([("a", "b")], "set: a mapping of dotted scene paths to values"),
    ({1: "x"}, "set: 1 is not a dotted scene path"),
    ({"": "x"}, "set: '' is not a dotted scene path"),
    ({"device..disc": "x"}, "set: 'device..disc' is not a dotted scene path"),
    ({"device.disc.face.base_gap": object()}, "set device.disc.face.base_gap: a value of type object"),
    ({"analyses.statics.operating_ratio": [1, {2: 3}]}, "set analyses.statics.operating_ratio: a value of type list"),
])
def test_load_set_checks_its_argument(value, message):
    with pytest.raises(ScenarioError, match=message.replace(".", r"\.").replace("(", r"\(")):
        autobal.load("pump_pe600_statics", set=value)


def test_load_set_takes_what_yaml_gives_and_numpy_numbers():
    scn = autobal.load("pump_pe600_dynamics", set={"analyses.transient.points": np.int64(11),
                                                   "analyses.transient.cases": [{"input": "force_step",
                                                                                 "amplitude": 0.02}]})
    assert scn.analyses.transient.points == 11 and scn.analyses.transient.cases[0].amplitude == 0.02


def test_a_validated_scene_cannot_be_changed():
    scn = autobal.load("pump_pe600_dynamics")
    models = scn.analyses.stability.models
    assert models == ["nonlinear", "nonlinear_chain", "consistent", "program", "thesis"]
    for change in (lambda: models.append(-1), lambda: models.extend([-1]), lambda: models.insert(0, -1),
                   lambda: models.__setitem__(0, -1), lambda: models.pop(), lambda: models.clear(),
                   lambda: models.sort(), lambda: models.__delitem__(0)):
        with pytest.raises(TypeError, match="a validated scene cannot be changed"):
            change()
    with pytest.raises(TypeError):
        scn.analyses.transient.cases += []
    with pytest.raises(TypeError, match="a validated scene cannot be changed"):
        scn.analyses.transient.cases.append(scn.analyses.transient.cases[0])
    with pytest.raises(Exception, match="frozen"):
        scn.analyses.transient.points = 3
    assert models == ["nonlinear", "nonlinear_chain", "consistent", "program", "thesis"]
    fit = autobal.load("rig_table43_fit").analyses.estimation.fits[0]
    with pytest.raises(TypeError, match="a validated scene cannot be changed"):
        fit.parameters["alpha"] = None
    # plain data still: JSON dumps lists, copies keep the scene
    assert isinstance(scn.model_dump(mode="json")["analyses"]["stability"]["models"], list)
    assert scn.model_copy(deep=True).analyses.stability.models == models


def test_the_scheduler_comes_from_the_run_or_the_environment(monkeypatch):
    monkeypatch.delenv(executor.ENV, raising=False)
    assert executor.default_scheduler() is None
    monkeypatch.setenv(executor.ENV, "tcp://10.0.0.1:8786")
    assert executor.default_scheduler() == "tcp://10.0.0.1:8786"
    with executor.using("tcp://127.0.0.1:1"):
        assert executor.default_scheduler() == "tcp://127.0.0.1:1"
        with executor.using(None):  # a nested run without one keeps the run's
            assert executor.default_scheduler() == "tcp://127.0.0.1:1"
    assert executor.default_scheduler() == "tcp://10.0.0.1:8786"
    monkeypatch.delenv(executor.ENV)
    with executor.make(progress=False) as exe:
        assert exe.name == "in-process"
