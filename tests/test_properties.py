"""Property tests over physical parameter ranges of the device dynamics: the nonlinear model's
equilibrium is the static solution, its exact Jacobian equals central differences, and a run from the
equilibrium with no input stays there to the integrator's tolerance (or the failure is reported)."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from autobal import adapters, scenario
from autobal.analysis import linearize
from autobal.analysis.simulate import Simulator, equilibrium_residual

SETUP = linearize.Setup(adapters.device(scenario.load("pump_pe600_dynamics").device))
FACTOR = st.floats(0.2, 5.0)


@st.composite
def dynamic_data(draw):
    d = SETUP.data
    return d.with_(m_p=d.m_p * draw(FACTOR), c_z=d.c_z * draw(FACTOR), V2=d.V2 * draw(FACTOR),
                   V3=d.V3 * draw(FACTOR), m0=d.m0 * draw(FACTOR), k_reg=d.k_reg * draw(FACTOR),
                   V_cam=d.V_cam * draw(FACTOR), V_m=d.V_m * draw(FACTOR))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(dynamic_data(), st.sampled_from(["energy", "chain"]))
def test_linearization_equals_finite_differences(data, form):
    from autobal.models.dynamics import build

    m = build(SETUP.dev, data, SETUP.point, form)
    assert equilibrium_residual(m) < 1e-9
    J = np.array(linearize.jacobians(m)(m.x0, m.w0, m.p0)[0])
    Jfd = linearize.finite_difference(m, h=1e-6)
    scale = np.sqrt(np.outer(np.abs(J).max(axis=1), np.abs(J).max(axis=0)))
    assert np.max(np.abs(J - Jfd) / scale) < 1e-6


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(dynamic_data())
def test_equilibrium_is_a_fixed_point_of_the_integration(data):
    from autobal.models.dynamics import build

    m = build(SETUP.dev, data, SETUP.point, "energy")
    sim = Simulator(m, t_end=0.005, points=11, rtol=1e-10, atol=1e-12)
    out = sim.run([0.0] * 6)
    assert out["failure"] is None and out["stopped"] is None
    assert np.max(np.abs(out["X"] - m.x0)) < 1e-8
