"""RODAS4 (analysis/numerics/rosenbrock.py) and the transient Simulator's ``integrator="rodas4"``: against CVODES at a
tight tolerance on the pump's energy-consistent model, against the exact solution (matrix exponential) of a stiff
linear system, its order under a step ladder, failures, stop events, and the virtual machine against C."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import scipy.linalg

from autobal import scenario
from autobal.analyses import transient as transient_analysis
from autobal.analysis.numerics import rosenbrock, simulate
from autobal.analysis.numerics.linearize import Setup
from autobal.models.dynamics import build
from autobal.parts import device as device_part

KINDS = ("force_step", "pressure_step", "pressure_harmonic")


@pytest.fixture(scope="module")
def pump():
    return Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device)).nonlinear("energy")


@pytest.fixture(scope="module")
def cvodes_ref(pump):
    """CVODES at rtol 1e-10 on the scene's three transient cases, 50 ms, 51 outputs."""
    sim = simulate.Simulator(pump, 0.05, 51, "cvodes", rtol=1e-10, atol=1e-12)
    return {k: sim.run(sim.input_vector(k, 0.01, pump.data.omega0))["X"] for k in KINDS}


@pytest.mark.parametrize("rtol", [1e-5, 1e-7])
def test_rodas4_agrees_with_cvodes_within_its_tolerance(pump, cvodes_ref, rtol):
    # the scene's cases (pump_pe600_dynamics: force step, pressure step, harmonic pressure, amplitude 0.01);
    # 51 outputs (1 ms apart) leave the step sizes to the controller
    sim = simulate.Simulator(pump, 0.05, 51, "rodas4", rtol=rtol, atol=rtol * 1e-2)
    for k in KINDS:
        r = sim.run(sim.input_vector(k, 0.01, pump.data.omega0))
        assert r["failure"] is None and r["stopped"] is None and len(r["t"]) == 51
        err = np.abs(r["X"] - cvodes_ref[k]).max()  # the scaled states are O(1) (0 ... 2 here)
        assert 1e-3 * rtol < err < 0.5 * rtol, (k, err / rtol)  # measured 0.04-0.2 rtol; CVODES: 0.5-3 rtol


def test_rodas4_converges_at_order_four(pump):
    # fixed steps, a ladder of step counts doubling: the final error falls by 2^4 = 16 a rung
    w = pump.w0 + np.array([0.0, 0.01])
    x, t, p = ca.SX.sym("x", len(pump.states)), ca.SX.sym("t"), ca.SX.sym("p", 0)
    f = ca.Function("f", [t, x, p], [pump.ode(x, w, pump.p0)])
    ref = ca.integrator("ref", "cvodes", {"x": x, "ode": pump.ode(x, w, pump.p0)}, 0.0, 0.05,
                        {"reltol": 1e-13, "abstol": 1e-15})(x0=pump.x0)["xf"]
    errs = [float(np.abs(np.asarray(rosenbrock.rodas4_fixed(f, n, 0.05)(pump.x0, [])[0] - ref)).max())
            for n in (100, 200, 400)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert errs[-1] < 1e-7
    assert np.all((orders > 3.7) & (orders < 4.3)), orders


def _forced_linear():
    """A stiff linear system x' = A x + b cos(omega t) (eigenvalues -1, -1e3 +- 1e2 i, -1e6; non-normal) and
    its exact solution: the matrix exponential of the system with (cos, sin) appended as states."""
    rng = np.random.default_rng(1)
    T = np.eye(4) + 0.5 * rng.standard_normal((4, 4))
    A = T @ np.array([[-1.0, 0, 0, 0], [0, -1e3, 1e2, 0], [0, -1e2, -1e3, 0], [0, 0, 0, -1e6]]) @ np.linalg.inv(T)
    b, omega = np.array([1.0, -2.0, 0.5, 3.0]), 50.0
    big = np.zeros((6, 6))
    big[:4, :4], big[:4, 4] = A, b
    big[4, 5], big[5, 4] = -omega, omega  # (cos, sin)' = omega (-sin, cos)
    x, t, p = ca.SX.sym("x", 4), ca.SX.sym("t"), ca.SX.sym("p", 0)
    f = ca.Function("f", [t, x, p], [ca.mtimes(ca.DM(A), x) + ca.DM(b) * ca.cos(omega * t)])
    x0 = np.array([1.0, 0.0, -1.0, 2.0])
    return f, x0, lambda te: (scipy.linalg.expm(big * te) @ np.r_[x0, 1.0, 0.0])[:4]


def _adaptive(f, x0, t_end, rtol, linear_solver="lu", h0=1e-9):
    """One output interval [0, t_end] of the adaptive loop (2000 attempts); returns the last column."""
    F = rosenbrock.rodas4_grid(f, 2000, linear_solver)
    W = np.array(F(np.r_[0.0, h0, 0, 0, 0, 0, 0, 0, x0], t_end, 1, [rtol, rtol * 1e-2, 1e5], []))
    assert W[2, -1] == 1  # reached the output
    return W[:, -1]


@pytest.mark.parametrize("linear_solver", ["lu", "qr"])
def test_stiff_linear_system_against_its_exact_solution(linear_solver):
    f, x0, exact = _forced_linear()
    for rtol in (1e-4, 1e-8):
        w = _adaptive(f, x0, 0.5, rtol, linear_solver)
        assert w[0] == pytest.approx(0.5, rel=1e-14) and w[7] == 0
        x = exact(0.5)
        assert np.abs(w[8:] - x).max() < 10 * rtol * np.abs(x).max(), (rtol, np.abs(w[8:] - x).max())
    # the non-autonomous forcing enters through the appended time state: one fixed step of a pure
    # forcing x' = cos(omega t) is order 4 accurate
    steps = [rosenbrock.rodas4_fixed(f, n, 0.5)(x0, []) for n in (400, 800)]
    e = [np.abs(np.array(s[0]).ravel() - exact(0.5)).max() for s in steps]
    assert 12 < e[0] / e[1] < 20


def test_growth_check_rejects_a_factorisation_that_needed_pivoting():
    # A[0, 0] = 4000 1/s: at h = 1e-3 s the first pivot of I/(h gamma) - A is zero (LU without pivoting divides
    # by zero; the matrix is regular); the first attempt, clipped to the output at 1e-3 s, is rejected, the
    # smaller steps land on the exact solution
    A = np.array([[4e3, 1e4], [-1e4, -1e4]])  # eigenvalues -3000 +- 7141i 1/s
    x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 0)
    f = ca.Function("f", [t, x, p], [ca.mtimes(ca.DM(A), x)])
    step = rosenbrock.rodas4_step(f)
    assert float(step(0, [1, 0], [], 1e-3 * (1 + 1e-9))[2]) > rosenbrock.GROWTH_MAX
    assert float(step(0, [1, 0], [], 1e-4)[2]) < 10
    w = _adaptive(f, np.array([1.0, 0.0]), 1e-3, 1e-8, h0=1.0)
    exact = scipy.linalg.expm(A * 1e-3) @ [1.0, 0.0]
    assert w[7] == 0 and w[5] >= 1 and np.abs(w[8:] - exact).max() < 1e-7 * np.abs(exact).max()
    qr = _adaptive(f, np.array([1.0, 0.0]), 1e-3, 1e-8, "qr", h0=1.0)
    assert np.abs(qr[8:] - exact).max() < 1e-7 * np.abs(exact).max()


def test_non_finite_right_hand_side_is_a_step_size_underflow():
    # x' = -x + sqrt(0.5 - t): not a number past t = 0.5; every step across is rejected until the step size
    # underflows, reported with the time reached (0.5 to the last accepted step) and a finite state
    x, t, p = ca.SX.sym("x"), ca.SX.sym("t"), ca.SX.sym("p", 0)
    f = ca.Function("f", [t, x, p], [-x + ca.sqrt(0.5 - t)])
    W = np.array(rosenbrock.rodas4_grid(f, 2000)(np.r_[0.0, 1e-3, 0, 0, 0, 0, 0, 0, 1.0], 1.0, 1,
                                                 [1e-6, 1e-8, 1e5], []))
    w = W[:, -1]
    assert rosenbrock.STATUS[int(w[7])] == "step size underflow"
    assert 0.49 < w[0] <= 0.5 and np.isfinite(w[8]) and w[1] < 1e-13


def test_failure_reports_the_time_reached(pump):
    sim = simulate.Simulator(pump, 0.05, 51, "rodas4", max_num_steps=3)
    r = sim.run(sim.input_vector("force_step", 0.01))
    f = r["failure"]
    assert f is not None and "step budget" in f["message"] and "RODAS4" in f["message"]
    assert 0 <= f["t"] < 0.05 and len(r["t"]) == len(r["X"]) and r["t"][-1] <= f["t"]
    assert np.isfinite(r["X"]).all()
    with pytest.raises(ValueError, match="unknown RODAS4 options"):
        simulate.Simulator(pump, 0.05, 51, "rodas4", max_steps=3)


def test_gap_closure_stops_a_rodas4_run():
    # the energy-consistent compressor model is unstable: with the source's constant squeeze film (at the base gap)
    # a force step grows until the face gap closes (the film at the instantaneous gap keeps it open)
    s = Setup(device_part.adapt(scenario.load("compressor_k180_dynamics").device))
    comp = build(s.dev, s.data, s.point, "energy", damping_gap="base")
    res = simulate.study(comp, [{"input": "force_step", "amplitude": 0.01}], 0.05, 1001, "rodas4")
    ref = simulate.study(comp, [{"input": "force_step", "amplitude": 0.01}], 0.05, 1001, "cvodes")
    case, cv = res.cases[0], ref.cases[0]
    ev = {e.event: e for e in case.events}
    assert "gap_closed" in ev and 0 < ev["gap_closed"].t < 0.05
    assert case.t[-1] <= ev["gap_closed"].t and case.X[:, 0].min() > 0
    t_cv = next(e.t for e in cv.events if e.event == "gap_closed")
    assert ev["gap_closed"].t == pytest.approx(t_cv, rel=1e-4)
    assert res.integrator == "rodas4" and case.failure is None


def test_virtual_machine_and_compiled_give_the_same_numbers(pump, monkeypatch):
    compiled = simulate.Simulator(pump, 0.01, 101, "rodas4", rtol=1e-8, atol=1e-10)
    monkeypatch.setenv("AUTOBAL_COMPILE", "0")
    vm = simulate.Simulator(pump, 0.01, 101, "rodas4", rtol=1e-8, atol=1e-10)
    assert not vm.compiled
    s = vm.input_vector("pressure_harmonic", 0.01, pump.data.omega0)
    a, b = vm.run(s), compiled.run(s)
    assert a["steps"] == b["steps"] and a["steps"] >= 100
    assert np.abs(a["X"] - b["X"]).max() <= 1e-12


@pytest.mark.parametrize("integrator", ["rodas4", "rodas4p"])
def test_scene_key_and_accuracy_block(integrator):
    # the scene's transient (3 cases, 2001 outputs) with integrator: rodas4 / rodas4p, through the runner
    scene = scenario.load("pump_pe600_dynamics")
    settings = scene.analyses.transient.model_copy(update={"integrator": integrator})
    res = transient_analysis.run(scene, settings)
    acc = res.accuracy
    assert res.integrator == integrator and integrator in acc["how"]
    assert all(c.failure is None and len(c.t) == 2001 for c in res.cases)
    assert 0 < acc["estimate"] < 1e-5  # rtol 1e-9 against 1e-11 (CVODES' block: 7e-7 measured)


def test_prothero_robinson_order_reduction():
    # y' = lam (y - sin t) + cos t, y = sin t, lam = -1e6 (Hairer & Wanner 1996, Sect. IV.15): RODAS4 drops to
    # order 1 in the stiff limit, RODASP keeps order 3 at errors 1000x smaller
    x, t, p = ca.SX.sym("x"), ca.SX.sym("t"), ca.SX.sym("p", 0)
    f = ca.Function("f", [t, x, p], [-1e6 * (x - ca.sin(t)) + ca.cos(t)])
    orders = {}
    for method in ("rodas4", "rodas4p"):
        e = [abs(float(rosenbrock.rodas4_fixed(f, n, 1.0, method=method)(0.0, [])[0]) - np.sin(1.0))
             for n in (10, 20, 40)]
        orders[method] = np.log2(e[0] / e[1]), np.log2(e[1] / e[2]), e[-1]
    assert all(0.8 < q < 1.4 for q in orders["rodas4"][:2])
    assert all(2.7 < q < 3.5 for q in orders["rodas4p"][:2])
    assert orders["rodas4p"][2] < 1e-3 * orders["rodas4"][2]


def test_rodasp_keeps_order_four_on_the_harmonic_input(pump):
    # the pump driven by dpsi1 = 0.01 sin(omega0 t): RODAS4's fixed-step order drops to 2-3, RODASP's stays 4
    s = [0.0, 0.0, 0.01, pump.data.omega0, pump.design.groups.b, 0.0]
    x, t, p = ca.SX.sym("x", len(pump.states)), ca.SX.sym("t"), ca.SX.sym("p", 0)
    dpsi1 = s[2] * ca.sin(s[3] * t)
    w = ca.vertcat(pump.w0[0] + dpsi1, pump.w0[1] + s[4] * dpsi1)
    f = ca.Function("f", [t, x, p], [pump.ode(x, w, pump.p0)])
    ref = ca.integrator("ref", "cvodes", {"x": x, "t": t, "ode": pump.ode(x, w, pump.p0)}, 0.0, 0.05,
                        {"reltol": 1e-13, "abstol": 1e-15})(x0=pump.x0)["xf"]
    order = {}
    for method in ("rodas4", "rodas4p"):
        e = [float(np.abs(np.asarray(rosenbrock.rodas4_fixed(f, n, 0.05, method=method)(pump.x0, [])[0] - ref)).max())
             for n in (282, 564)]
        order[method] = np.log2(e[0] / e[1])
    assert order["rodas4"] < 3.0 and 3.6 < order["rodas4p"] < 4.4, order
