"""The spin-up collocation NLP's derivatives: the Jacobian and Hessian assembled from the mapped interval
Function's SX derivatives (ocp/transcription.py, ``structured_derivatives``) against CasADi's own AD of the
whole NLP, and the mapped transcription against the scalar (SX) one, on every objective, both collocation
schemes, the jerk terms, the free final time and the drive limits that use the control."""

import dataclasses

import casadi as ca
import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal.models.rotor import RotorParams
from autobal.ocp import spinup as S
from autobal.ocp.transcription import structured_derivatives

JEFFCOTT = RotorParams.from_groups(105.0, 5.0, 1.0)
DRIVE = RotorParams(m1=1.0, c=105.0**2, chi=5.0, e=1e-3, J_p=1e-3).with_psi(0.5)
BASE = S.SpinupOcp(JEFFCOTT, 40.0, 210.0, 5.0, 40.0, settling_time=3.0, omega_max=210.0)
VARIANTS = {
    "peak": BASE,
    "integrated": dataclasses.replace(BASE, objective="integrated_deflection"),
    "min_time": dataclasses.replace(BASE, objective="min_time", deflection_limit=20.0),
    "jerk": dataclasses.replace(BASE, jerk_penalty=1e-3, jerk_variation=1e-4, jerk_max=400.0),
    "torque_power": S.SpinupOcp(DRIVE, 40.0, 210.0, 8.5, 40.0, torque_max=0.05, power_max=6.0),
    "deceleration_limit": dataclasses.replace(BASE, alpha_min=-10.0),  # u >= -0.25 (the stage form kept -1 once)
}


def graded(ocp, n: int = 12):
    """A graded mesh of n intervals (lengths 0.6-1.8 of the uniform one), or None (uniform) for a free final time."""
    return None if ocp.free_time else S.mesh(ocp, n, np.linspace(0.6, 1.8, n) / np.linspace(0.6, 1.8, n).mean())


@pytest.mark.parametrize("mesh", ["uniform", "graded"])
@pytest.mark.parametrize("scheme,degree", [("radau", 3), ("legendre", 2)])
@pytest.mark.parametrize("name", VARIANTS)
def test_structured_derivatives_equal_casadi_ad(name, scheme, degree, mesh):
    ocp = VARIANTS[name]
    if mesh == "graded" and ocp.free_time:
        pytest.skip("the free-time transcription is uniform")
    nlp = S.transcribe(ocp, S.DirectCollocation(12, degree, scheme), 200.0, "MX", graded(ocp) if mesh == "graded"
                       else None)
    d = structured_derivatives(nlp)
    x, g = nlp.x, nlp.g
    p, lam_f, lam_g = ca.MX.sym("p", 0), ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g.numel())
    jac = ca.Function("ad_jac", [x, p], [g, ca.jacobian(g, x)])
    hess = ca.Function("ad_hess", [x, p, lam_f, lam_g], [ca.triu(ca.hessian(lam_f * nlp.f + ca.dot(lam_g, g), x)[0])])
    rng = np.random.default_rng(1)
    xv, lv = rng.normal(size=x.numel()), rng.normal(size=g.numel())
    (g1, j1), (g2, j2) = jac(xv, []), d["jac_g"](xv, [])
    assert j1.sparsity() == j2.sparsity()
    assert_allclose(np.array(g2), np.array(g1), rtol=0, atol=0)
    assert_allclose(j2.nonzeros(), j1.nonzeros(), rtol=1e-13, atol=1e-12)
    h1, h2 = hess(xv, [], 0.7, lv), d["hess_lag"](xv, [], 0.7, lv)
    assert h1.sparsity() == h2.sparsity()
    assert_allclose(h2.nonzeros(), h1.nonzeros(), rtol=1e-12, atol=1e-12 * float(ca.norm_inf(h1)))


@pytest.mark.parametrize("name", ["peak", "min_time"])
def test_mapped_transcription_equals_the_scalar_one(name):
    """The same NLP in SX and MX: equal constraint values and objective at a random point."""
    ocp = VARIANTS[name]
    sx = S.transcribe(ocp, S.DirectCollocation(10), 200.0, "SX")
    mx = S.transcribe(ocp, S.DirectCollocation(10), 200.0, "MX")
    xv = np.random.default_rng(2).normal(size=sx.x.numel())
    f1, g1 = ca.Function("a", [sx.x], [sx.f, sx.g])(xv)
    f2, g2 = ca.Function("b", [mx.x], [mx.f, mx.g])(xv)
    assert_allclose(float(f2), float(f1), rtol=1e-15)
    assert_allclose(np.array(g2).ravel(), np.array(g1).ravel(), rtol=1e-14, atol=1e-14)
    assert [(n, list(r)) for n, r in sx.blocks] == [(n, list(r)) for n, r in mx.blocks]
