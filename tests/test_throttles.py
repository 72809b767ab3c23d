"""Throttle laws and conductances: Pavlenko (2014) (2.16), Table 2.2, App. A/B."""

import casadi as ca
import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal.models import throttles as th


@pytest.mark.literature
@pytest.mark.parametrize(
    "name, key, published",
    [  # [derived] (App. A and App. B), tolerance 0.5 %
        ("pump_pe600_statics", "g1", 8.566e-9), ("pump_pe600_statics", "g3", 1.412e-6),
        ("pump_pe600_statics", "g_TB", 1.49e-6), ("pump_pe600_statics", "g_in", 1.928e-7),
        ("pump_pe600_statics", "g_B", 2.276e-6), ("pump_pe600_statics", "g_e", 1.767e-8),
        ("compressor_k180_statics", "g1", 2.703e-7), ("compressor_k180_statics", "g3", 3.623e-7),
        ("compressor_k180_statics", "g_TB", 8.639e-8), ("compressor_k180_statics", "g_in", 2.738e-6),
        ("compressor_k180_statics", "g_B", 6.57e-5), ("compressor_k180_statics", "g_e", 4.545e-6),
    ],
)
def test_conductances_match_appendices(name, key, published):
    from autobal import scenario
    from autobal.parts.device import design

    assert_allclose(design(scenario.load(name).device).conductances[key], published, rtol=5e-3)


@pytest.mark.literature
def test_groups_match_appendix_a():
    # [derived] recomputed column (App. A)
    from autobal import scenario
    from autobal.parts.device import design

    d = design(scenario.load("pump_pe600_statics").device)
    g = d.groups
    assert_allclose([g.sigma, g.regulator.sigma_m, g.alpha_TB1, g.alpha_31, g.alpha_e1,
                     g.regulator.alpha_in1, g.regulator.alpha_B1, g.regulator.psi_in],
                    [1.58045, 1.53628, 0.0306212, 0.0290057, 2.06293, 22.5047, 0.0467692, 1.23935], rtol=2e-5)
    assert_allclose([d.extra["zeta_u3"], d.extra["zeta_TB"], d.extra["b_from_impeller"]],
                    [23.786, 8.0, 0.8327], rtol=2e-4)


def test_signed_sqrt_is_finite_and_odd_through_zero():
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [th.signed_sqrt(x), ca.jacobian(th.signed_sqrt(x), x)])
    for v in (-1.0, -1e-12, 0.0, 1e-12, 1.0):
        val, der = (float(a) for a in f(v))
        assert np.isfinite(val) and np.isfinite(der)
    assert_allclose(float(f(0.25)[0]), 0.5, rtol=1e-15)
    assert_allclose(float(f(-0.25)[0]), -0.5, rtol=1e-15)


@pytest.mark.parametrize("law", th.LAWS)
def test_flow_laws_reverse_with_pressure(law):
    a, b = 0.7, 0.4
    forward = float(th.flow(law, 2.0, a, b))
    assert forward > 0
    assert_allclose(float(th.flow(law, 2.0, b, a)), -forward, rtol=1e-12)
    assert float(th.flow(law, 2.0, a, a)) == 0.0


def test_unknown_law_is_an_error():
    with pytest.raises(ValueError, match="unknown throttle law"):
        th.flow("magic", 1.0, 1.0, 0.0)


# ---- one flow network for the statics and the dynamics; the parameter objects ----------------------

def test_closed_valve_passes_no_flow():
    # Pavlenko (2014), Eq. (2.15): Q_c = g_B xi sqrt(p_cam - p_e) holds for an open valve; on its seat
    # (xi <= 0) it passes nothing, in either direction (xi sqrt(dp) with xi < 0 would reverse the flow)
    from autobal import scenario
    from autobal.models.device import groups_by_name, network
    from autobal.parts.device import design

    g = design(scenario.load("pump_pe600_statics").device).groups
    v = {"psi2": 0.8, "psi3": 0.4, "u": 1.0, "psi_e": 1.05, "psi_cam": 1.1}
    q = {xi: float(network(g, groups_by_name(g), 1.0, 0.05, v | {"xi": xi})["valve"]) for xi in (-0.2, 0.0, 0.5)}
    assert q[-0.2] == q[0.0] == 0.0
    assert_allclose(q[0.5], 0.5 * g.regulator.alpha_B1 * np.sqrt(1.1 - 1.05), rtol=1e-9)


def test_dynamics_flows_at_equilibrium_are_the_statics_flows():
    from autobal import scenario
    from autobal.analysis.numerics.linearize import Setup
    from autobal.parts import device as device_part

    setup = Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device), 1.0)
    for form in ("energy", "chain"):
        m = setup.nonlinear(form)
        assert_allclose(np.array(m.flows(m.x0, m.w0)).ravel(), list(setup.static.flows.values()), rtol=1e-12)


def test_parameters_from_pint_quantities_equal_si_floats():
    import pint

    from autobal.models.device import Face
    from autobal.models.rotor import RotorParams

    u = pint.UnitRegistry()
    face = Face.from_quantities(inner_diameter=u("220 mm"), outer_diameter=0.3, base_gap=u("0.1 mm"))
    assert face == Face(inner_diameter=0.22, outer_diameter=0.3, base_gap=1e-4)
    rotor = RotorParams.from_quantities(m1=u("2 kg"), c=u("1 kN/m"), chi=u("2 g/s"), e=u("0.1 mm"))
    assert_allclose([rotor.m1, rotor.c, rotor.chi, rotor.e], [2.0, 1e3, 2e-3, 1e-4], rtol=1e-12)
    with pytest.raises(pint.DimensionalityError):
        Face.from_quantities(inner_diameter=u("1 kg"), outer_diameter=0.3, base_gap=1e-4)
