"""The face's squeeze film in the headline (energy-consistent) model is evaluated at the instantaneous gap,
c(z) = 1.5 mu s_T^2/(pi z^3) = c_z (z_B/z)^3 with c_z its value at the base gap (Pavlenko (2014), App. A), so the
base gap z_B is only the normalising base of the face law: for a fixed physical device it moves neither the
operating point nor the headline poles.  The validation models keep the source's constant c_z at z_B."""

import casadi as ca
import numpy as np
import pytest
from numpy.testing import assert_allclose

import autobal
from autobal.analysis.numerics import linearize, simulate, stability
from autobal.analysis.numerics.linearize import Setup
from autobal.models import dynamics as dy
from autobal.models.device import face_area
from autobal.parts.device import dynamic_device

GAPS_MM = (0.10, 0.15, 0.18)
C_Z_015 = 8.936e4  # N s/m, the scene's c_z = 1.5 mu s_T^2/(pi z_B^3) at z_B = 0.15 mm (Pavlenko (2014), App. A)


def _setup(gap_mm: float) -> Setup:
    """pump_pe600_dynamics with the base gap moved and the physical device held fixed: the face's diameters and
    friction factor (so the face law g_TB (z/z_B)^(3/2) is the same function of the physical gap z, g_TB being
    proportional to z_B^(3/2)), and the squeeze-film constant c_z z_B^3 = 1.5 mu s_T^2/pi (the scene gives c_z
    at its base gap, so it is scaled by (0.15 mm / z_B)^3)."""
    c_z = C_Z_015 * (0.15 / gap_mm) ** 3
    scene = autobal.load("pump_pe600_dynamics", set={"device.disc.face.base_gap": f"{gap_mm} mm",
                                                     "device.dynamics.rotor_damping": f"{c_z!r} N*s/m"})
    return Setup(dynamic_device(scene), 1.0)


@pytest.fixture(scope="module")
def setups() -> dict:
    return {g: _setup(g) for g in GAPS_MM}


def _sorted(poles: np.ndarray) -> np.ndarray:
    return poles[np.lexsort((poles.imag, poles.real))]


def test_the_held_fixed_device_is_the_same_physical_device(setups):
    # face conductance per z^(3/2) (m^3/(Pa^0.5 s) / m^1.5) and c_z z_B^3 (N s m^2) are the same at every base
    per_gap = [s.dev.conductances["g_TB"] / s.dev.scales["z_B"] ** 1.5 for s in setups.values()]
    film = [s.data.c_z * s.dev.scales["z_B"] ** 3 for s in setups.values()]
    assert_allclose(per_gap, per_gap[1], rtol=1e-12)
    assert_allclose(film, film[1], rtol=1e-12)
    # the default squeeze film of the adapter is the scene's c_z at 0.15 mm (App. A prints 8.936e4 N s/m)
    s = setups[0.15]
    assert_allclose(dy.squeeze_damping(1.0e-3, face_area(s.device.disc.face), 0.15e-3), C_Z_015, rtol=5e-4)


def test_base_gap_moves_neither_the_operating_point_nor_the_headline_poles(setups):
    z0 = {g: s.static.values["u"] * s.dev.scales["z_B"] for g, s in setups.items()}  # m
    q_e = {g: s.static.flows["e"] * s.dev.scales["Q_scale"] for g, s in setups.items()}  # m^3/s
    poles = {g: _sorted(s.linear("nonlinear").poles()) for g, s in setups.items()}  # 1/s
    for g in GAPS_MM:
        assert z0[g] == pytest.approx(z0[0.15], rel=1e-9)
        assert q_e[g] == pytest.approx(q_e[0.15], rel=1e-9)
        assert_allclose(poles[g], poles[0.15], rtol=1e-7)
    assert z0[0.15] == pytest.approx(143.86e-6, rel=1e-4)  # 143.9 um: u0 = 0.9591 of 0.15 mm
    # the headline decay rate of the shipped scene: the film at z0 (c_z / u0^3), -82.64 1/s
    assert -poles[0.15].real.max() == pytest.approx(82.644, abs=1e-3)


def test_validation_models_keep_the_source_constant_film(setups):
    """The source's models take c_z as a constant (at z_B): with the same held-fixed device their poles move with
    the base (program: the hand model at App. A's point; chain: the printed form)."""
    rate = {g: s.linear("program").poles().real.max() for g, s in setups.items()}  # 1/s
    assert abs(rate[0.10] - rate[0.15]) > 10.0 and abs(rate[0.18] - rate[0.15]) > 10.0
    chain = {g: _sorted(s.linear("nonlinear_chain").poles()) for g, s in setups.items()}
    for g in (0.10, 0.18):
        assert np.max(np.abs(chain[g] / chain[0.15] - 1)) > 1e-3
    s = setups[0.15]
    assert s.nonlinear("chain").damping_gap == "base" and s.nonlinear("energy").damping_gap == "instantaneous"
    # the headline linearisation's rotor damping is the film at the operating gap, c_z / u0^3 (zeta1 read off its
    # rows), the chain's the constant c_z (App. A: zeta1 = c_z / (2 k_pr T1))
    table = linearize.coefficient_table(s)["columns"]
    u0 = s.static.values["u"]
    assert table["nonlinear"]["zeta1"] == pytest.approx(table["nonlinear_chain"]["zeta1"] / u0**3, rel=1e-9)
    assert table["nonlinear_chain"]["zeta1"] == pytest.approx(table["consistent"]["zeta1"], rel=1e-12)


def test_exact_jacobian_of_the_film_matches_finite_differences(setups):
    """Off equilibrium (the gap moving), d(dv/dt)/du carries the film's 3 c_z v/(m_p u^4) and d(dv/dt)/dv its
    -c_z/(m_p u^3); exact CasADi Jacobian against central differences, and against the constant-film model by
    that hand value."""
    s = setups[0.15]
    m_i, m_b = (dy.build(s.dev, s.data, s.point, "energy", damping_gap=k) for k in ("instantaneous", "base"))
    x = m_i.x0.copy()
    iu, iv = m_i.index("u"), m_i.index("v")
    x[iu], x[iv] = 0.8, 0.3  # u = z/z_B, v = t_ref du/dt
    xs = ca.SX.sym("x", len(x))
    J = {k: np.array(ca.Function("J", [xs], [ca.jacobian(m.ode(xs, m.w0, m.p0), xs)])(x))
         for k, m in (("i", m_i), ("b", m_b))}
    h = 1e-6
    for j in (iu, iv):
        d = np.zeros(len(x))
        d[j] = h
        fd = (np.array(m_i.ode(x + d, m_i.w0, m_i.p0)).ravel() - np.array(m_i.ode(x - d, m_i.w0, m_i.p0)).ravel())
        assert_allclose(J["i"][iv, j], fd[iv] / (2 * h), rtol=1e-6)
    c_z, m_p = s.data.c_z, s.data.m_p
    # dv/dt = t_ref d2u/dt2 = -(c_z/u^3) (v/t_ref) t_ref/m_p + ...: film terms in the v row
    assert_allclose(J["i"][iv, iv], -c_z / (m_p * 0.8**3), rtol=1e-12)
    assert_allclose(J["b"][iv, iv], -c_z / m_p, rtol=1e-12)
    assert_allclose(J["i"][iv, iu] - J["b"][iv, iu], 3 * c_z * 0.3 / (m_p * 0.8**4), rtol=1e-9)
    # at the equilibrium the exact linearisation agrees with finite differences of the ODE (scaled states)
    A = np.array(linearize.jacobians(m_i)(m_i.x0, m_i.w0, m_i.p0)[0])
    assert_allclose(A[iv], linearize.finite_difference(m_i)[iv], rtol=1e-5, atol=1e-6 * np.abs(A[iv]).max())


def test_the_film_at_the_gap_keeps_the_unstable_compressor_open():
    """c(z) grows as z^-3, so the film does not let the face close in finite time: the unstable energy-consistent
    compressor under a force step (1 %) keeps an open gap for 50 ms, where the constant film closes it."""
    s = Setup(dynamic_device(autobal.load("compressor_k180_dynamics")), 1.0)
    assert s.linear("nonlinear").poles().real.max() > 100.0  # unstable, +146 1/s
    ends = {}
    for gap in ("instantaneous", "base"):
        m = dy.build(s.dev, s.data, s.point, "energy", damping_gap=gap)
        case = simulate.study(m, [{"input": "force_step", "amplitude": 0.01}], 0.05, 1001).cases[0]
        ends[gap] = ({e.event for e in case.events}, case.X[:, 0].min())
    assert "gap_closed" not in ends["instantaneous"][0] and ends["instantaneous"][1] > 0.05
    assert "gap_closed" in ends["base"][0]


def test_unknown_damping_gap_is_refused(setups):
    s = setups[0.15]
    with pytest.raises(ValueError, match="damping gap 'operating'"):
        dy.build(s.dev, s.data, s.point, "energy", damping_gap="operating")


def test_compressor_is_stabilised_by_a_small_cavity_or_a_strong_film_alone():
    """docs/validation.md: the unstable energy-consistent compressor (Pavlenko (2014), App. B data) becomes stable
    along a single-parameter scan for V3 <= 5.0e-6 m^3 or c_z >= 3.4e5 N s/m (c_z at z_B; the film at z0 is
    c_z/u0^3), and by no V2 or stem damping alone."""
    s = Setup(dynamic_device(autobal.load("compressor_k180_dynamics")), 1.0)
    scans = {k: v["stable_intervals"] for k, v in stability.single_parameter_scans(s, "nonlinear").items()}
    assert scans["disc_chamber_volume"] == [] and scans["stem_damping"] == []
    [(lo, hi)] = scans["cavity_volume"]
    assert hi == pytest.approx(4.99e-6, rel=2e-3)
    [(lo, hi)] = scans["rotor_damping"]
    assert lo == pytest.approx(3.39e5, rel=2e-3)
    # the boundary is one value of the film at the operating gap: c_z/u0^3 there equals the constant film's boundary
    constant_film = dy.build(s.dev, s.data.with_(c_z=lo / s.static.values["u"] ** 3), s.point, "energy",
                          damping_gap="base")
    assert linearize.exact(constant_film).poles().real.max() == pytest.approx(0.0, abs=1.0)
