"""Property tests over physical parameter ranges of the device dynamics: the nonlinear model's
equilibrium is the static solution, its exact Jacobian equals central differences, and a run from the
equilibrium with no input stays there to the integrator's tolerance (or the failure is reported)."""

import functools

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from autobal import scenario
from autobal.analysis.numerics import linearize
from autobal.analysis.numerics.simulate import Simulator, equilibrium_residual
from autobal.models.dynamics import build
from autobal.parts import device as device_part

FACTOR = st.floats(0.2, 5.0)
SCALED = ("m_p", "c_z", "V2", "V3", "m0", "k_reg", "V_cam", "V_m")


@functools.cache
def setup() -> linearize.Setup:
    """The pump's device at psi1 = 1 (solved once, on first use: nothing solves at import)."""
    return linearize.Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device))


def scaled_data(factors):
    d = setup().data
    return d.with_(**{k: getattr(d, k) * f for k, f in zip(SCALED, factors, strict=True)})


FACTORS = st.tuples(*[FACTOR] * len(SCALED))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(FACTORS, st.sampled_from(["energy", "chain"]))
def test_linearization_equals_finite_differences(factors, form):
    m = build(setup().dev, scaled_data(factors), setup().point, form)
    assert equilibrium_residual(m) < 1e-9
    J = np.array(linearize.jacobians(m)(m.x0, m.w0, m.p0)[0])
    Jfd = linearize.finite_difference(m, h=1e-6)
    scale = np.sqrt(np.outer(np.abs(J).max(axis=1), np.abs(J).max(axis=0)))
    assert np.max(np.abs(J - Jfd) / scale) < 1e-6


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(FACTORS)
def test_equilibrium_is_a_fixed_point_of_the_integration(factors):
    m = build(setup().dev, scaled_data(factors), setup().point, "energy")
    sim = Simulator(m, t_end=0.005, points=11, rtol=1e-10, atol=1e-12)
    out = sim.run([0.0] * 6)
    assert out["failure"] is None and out["stopped"] is None
    assert np.max(np.abs(out["X"] - m.x0)) < 1e-8
