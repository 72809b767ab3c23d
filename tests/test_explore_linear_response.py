"""The spin-up explorer's live re-simulation (autobal/ocp/linear_response.py: the Jeffcott rotor's exact response
to a given speed profile, Duhamel's integral in the fixed frame's modes) against CVODES (ocp/simulation.py, the batch
run's re-simulation) over a range of rotors and drives, its quadrature's error bound, the numpy evaluation of the
model's CasADi Functions, and the page's cross-check on release."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from autobal.models.rotor import RotorParams, rotor_model
from autobal.ocp import linear_response as lr
from autobal.ocp import simulation as sim
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.transcription import mesh

# rotors and drives: Omega0 (rad/s), damping ratio zeta0, liquid psi, start and final speed (rad/s), horizon and
# settling (s), alpha_max (rad/s^2), drive inertia J_p (kg m^2) and drag b (N m s)
CASES = {
    "shipped (spinup_jeffcott_deadline_5s)": (105.0, 5.0 / (2 * 105.0), 1.0, 40.0, 210.0, 5.0, 3.0, 40.0, 0.0, 0.0),
    "light damping, from rest": (80.0, 0.002, 1.0, 0.0, 200.0, 4.0, 2.0, 60.0, 0.0, 0.0),
    "heavy damping, with a drive": (150.0, 0.3, 1.0, 20.0, 300.0, 6.0, 1.0, 80.0, 0.02, 0.001),
    "liquid balancer (psi 0.8), run-down": (100.0, 0.05, 0.8, 250.0, 30.0, 5.0, 2.0, 70.0, 0.0, 0.0),
    "stiff rotor, fast ramp": (400.0, 0.01, 1.0, 100.0, 700.0, 3.0, 1.0, 400.0, 0.0, 0.0),
}


def problem(case) -> SpinupOcp:
    Om, zeta, psi, w0, wf, T, ts, amax, J, b = case
    m1 = 1.3
    P = RotorParams(m1=m1, c=m1 * Om**2, chi=2 * zeta * m1 * Om, e=2e-5, m2_star=m1 * (1 / psi - 1), J_p=J, b=b)
    return SpinupOcp(P, w0, wf, T, amax, settling_time=ts)


def profiles(ocp: SpinupOcp, rng) -> dict:
    """The batch run's ramps (200 intervals) and a random profile: accelerations of both signs on intervals of
    unequal lengths (u over alpha_max, h in tau)."""
    ms = mesh(ocp, 200)
    h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])
    out = {"max_acceleration_ramp": (np.concatenate([sim.ramp_profile(ocp, ms.n, ocp.alpha_max), np.zeros(ms.ns)]),
                                     h)}
    K = 90
    hr = rng.uniform(0.5, 1.5, K)
    out["random"] = (rng.uniform(-0.3, 1.0, K), hr * (ocp.horizon + ocp.settling_time) * ocp.Om / hr.sum())
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_the_linear_response_equals_cvodes_over_rotors_and_drives(name):
    """Peak delta/e and its time, the whole deflection curve and the drive torque of the linear response equal CVODES
    at a tight tolerance (1e-13) to 1e-9 (delta/e) and the batch run's CVODES (1e-10, Adams) to 1e-8 relative in the
    peak (the page's cross-check tolerance, SPINUP_CHECK_RTOL) and 1e-6 s in its time (SPINUP_CHECK_T), on the same
    samples."""
    ocp = problem(CASES[name])
    for key, (u, h) in profiles(ocp, np.random.default_rng(7)).items():
        fast = lr.resimulate(ocp, u, h, key, points=24)
        batch = sim.resimulate(ocp, u, h, key, points=24)
        tight = sim.resimulate(ocp, u, h, key, points=24, tol=1e-13)
        assert np.array_equal(fast.t, batch.t)
        assert np.max(np.abs(fast.delta - tight.delta)) < 1e-9, key
        assert fast.peak_delta == pytest.approx(tight.peak_delta, rel=1e-10, abs=1e-10), key
        assert fast.peak_delta == pytest.approx(batch.peak_delta, rel=1e-8), key
        assert fast.t_peak == pytest.approx(batch.t_peak, abs=1e-6), key
        ref = np.max(np.abs(tight.torque))
        assert np.max(np.abs(fast.torque - tight.torque)) < 1e-8 * ref, key
        assert np.max(np.abs(fast.omega - batch.omega)) < 1e-9 * np.max(batch.omega), key


def test_cvodes_converges_to_the_linear_response():
    """The lightly damped rotor (zeta0 = 0.002, 1000 whirl periods): CVODES's deflection curve comes nearer the linear
    response at every tighter tolerance, 10x at least per two decades (the batch run's 1e-10 is off by 6e-7 here, the
    linear response's own bound is 1e-11): the live path is the more exact one."""
    ocp = problem(CASES["light damping, from rest"])
    u, h = profiles(ocp, np.random.default_rng(7))["max_acceleration_ramp"]
    fast = lr.resimulate(ocp, u, h, "ramp", points=24)
    off = [np.max(np.abs(sim.resimulate(ocp, u, h, "ramp", points=24, tol=tol).delta - fast.delta))
           for tol in (1e-10, 1e-12, 1e-14)]
    assert off[0] > 10 * off[1] > 100 * off[2] and off[2] < 2e-10, off


def test_the_quadrature_error_stays_within_its_bound():
    """The response with a loose tolerance (fewer Gauss nodes) differs from one with a tight tolerance by less than
    the sum of their stated bounds, and the loose one's bound is kept (<= its tol) while it differs visibly."""
    ocp = problem(CASES["stiff rotor, fast ramp"])
    u, h = profiles(ocp, np.random.default_rng(3))["random"]
    loose, b_loose = lr.response(ocp, u, h, 24, tol=1e-5)
    tight, b_tight = lr.response(ocp, u, h, 24, tol=1e-13)
    assert b_loose <= 1e-5 and b_tight <= 1e-13
    err = np.max(np.abs((loose[..., 0] + 1j * loose[..., 1]) - (tight[..., 0] + 1j * tight[..., 1])))
    assert 0 < err <= b_loose + b_tight


def test_the_numpy_evaluation_equals_casadi():
    """The model's Functions evaluated instruction by instruction by numpy (:func:`lr.vectorised`) equal CasADi's
    virtual machine at random points (the same operations: to rounding)."""
    m = rotor_model()
    rng = np.random.default_rng(1)
    N = 50
    q, a, p = rng.normal(size=(5, N)), rng.normal(size=N), [0.8, 0.03, 0.5, 0.01]
    outputs = ca.Function("outputs", m.outputs.sx_in(), [ca.vertcat(*m.outputs(*m.outputs.sx_in()))])
    for f in (m.torque, m.ode, outputs):
        want = np.array(f.map(N)(q, a[None, :], p))
        assert np.allclose(lr.vectorised(f)(q, a[None, :], p), want, rtol=1e-14, atol=1e-14), f.name()


def test_a_critically_damped_rotor_falls_back_to_cvodes():
    """A's double eigenvalue (zeta0 = 1, psi = 1) has no modes: the response refuses it, the explorer then uses
    CVODES."""
    case = list(CASES["shipped (spinup_jeffcott_deadline_5s)"])
    case[1] = 1.0
    with pytest.raises(ValueError, match="critically damped"):
        lr.modes(problem(case))


@pytest.mark.slow
def test_the_spin_up_page_cross_check_agrees_and_shows_cvodes_where_it_differs():
    """The page's cross-check on release: CVODES's re-simulation (what ``autobal run`` does) agrees with the live
    answer for a changed rotor, drive and the optimum's profile; a live answer off by 1e-6 is reported with CVODES's
    peak."""
    from autobal.explore import SpinupExplorer

    ex = SpinupExplorer("spinup_jeffcott_deadline_5s")
    ex.optimise(ex.defaults())
    values = ex.defaults() | {"rotor.damping": 3.0, "rotor.stiffness": 14000.0,
                              "analyses.spinup.max_acceleration": 55.0}
    live = ex.evaluate(values)
    assert live["resimulation"] == "linear response" and "optimum" in live
    assert ex.check(values, live) == ""
    cv = ex.evaluate(values, fast=False)
    assert cv["resimulation"] == "CVODES"
    for k, r in cv["ramps"].items():
        assert live["ramps"][k]["peak_over_e"] == pytest.approx(r["peak_over_e"], rel=1e-8)
    live["optimum"] = live["optimum"] | {"peak_over_e": live["optimum"]["peak_over_e"] * (1 + 1e-6)}
    said = ex.check(values, live)
    assert said.startswith("CVODES's re-simulation differs: current optimum's profile") and \
        f"{cv['optimum']['peak_over_e']:.10g}" in said
