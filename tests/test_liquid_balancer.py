"""Liquid auto-balancer: Khomyak (2020), computations C1-C13 as golden tests,
IPOPT optima against dense grids, Pashkov's calculators,
bad input.  [T] = Khomyak 2020 thesis; [derived] = numbers derived from the thesis's equations."""

import json
import math

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from autobal import cli, scenario
from autobal.analyses.liquid_balancer import spec
from autobal.analysis.numerics import liquid_balancer_optimum as optimum
from autobal.analysis.numerics import rotor_identification as rid
from autobal.analysis.studies import liquid_balancer as study
from autobal.errors import ScenarioError
from autobal.models import balancing_norms as norms
from autobal.models import liquid_balancer as lb
from autobal.models.rotor import RotorParams
from autobal.parts import liquid_balancer as liquid_balancer_part

WCR, N = 59.7, 7.85  # Table 3.1
GAMMAS = np.array([0.4, 0.6, 0.8, 1.0, 1.2, 1.4])
WASHER = yaml.safe_load(scenario.resolve("washer_liquid_balancer").read_text())


@pytest.fixture(scope="module")
def washer():
    return liquid_balancer_part.adapt(scenario.load("washer_liquid_balancer").liquid_balancer)


def table31(variant, gammas=GAMMAS, e_f=0.2, **kw):
    p = {"omega": np.asarray(gammas) * WCR, "omega_cr": WCR, "n": N, "R": 0.2, "h": 0.05, "V": 1.5e-4,
         "rho": 1000.0, "D0": 0.03, "e_f": e_f} | kw
    return lb.evaluate(variant, **p)


# ---- C1 --------------------------------------------------------------------------------------

def test_c1_damping_from_decrement(tmp_path, scene_edit):
    # Khomyak (2020), Table 3.1 (erratum 1): n = theta w_cr / (2 pi) = 7.8483 matches the printed "7.85";
    # the literal 2n = theta w_cr does not
    assert_allclose(lb.n_from_decrement(0.826, 59.7), 7.8483, atol=5e-5)
    assert_allclose(lb.n_from_decrement(0.826, 59.7), 7.85, atol=0.005)  # Table 3.1 to its printed digits
    assert_allclose(lb.n_from_decrement_literal(0.826, 59.7), 24.66, atol=0.005)
    # a scene that gives only the decrement gets that n through the adapter
    p = tmp_path / "decrement.yaml"
    p.write_text(yaml.safe_dump(scene_edit(WASHER, "liquid_balancer.rotor.damping_coefficient", None)))
    assert_allclose(liquid_balancer_part.adapt(scenario.load(p).liquid_balancer).n, 7.8483, atol=5e-5)


@pytest.mark.literature
def test_c1_scene_uses_table_3_1(washer):
    assert_allclose([washer.D0, washer.m_l, washer.M_sys, washer.n], [0.03, 0.15, 7.3, 7.85], rtol=1e-12)


# ---- C2 --------------------------------------------------------------------------------------

C2 = np.array([  # gamma, delta deg, sin^2 delta, phi deg, G (2.7), exact Jeffcott, zeta/e_c (2.6)  [derived]
    [0.4, 7.138, 0.01544, 6.038, 0.18245, 0.18900, 1.18125],
    [0.6, 13.850, 0.05730, 9.079, 0.52714, 0.54615, 1.51707],
    [0.8, 30.302, 0.25458, 12.145, 1.48121, 1.53489, 2.39827],
    [1.0, 90.000, 1.00000, 15.247, 3.66870, 3.80255, 3.80255],
    [1.2, 144.351, 0.33968, 18.396, 2.56506, 2.65943, 1.84683],
    [1.4, 159.017, 0.12822, 21.603, 1.83796, 1.90628, 0.97259],
])


def test_c2_jeffcott_kinematics():
    o = table31("corrected", C2[:, 0])
    # printed to 3 decimals (deg) / 5 digits: half a unit of the last digit
    assert_allclose(np.degrees(o["delta"]), C2[:, 1], atol=5e-4)
    assert_allclose(o["sin2d"], C2[:, 2], atol=5e-6)
    assert_allclose(np.degrees(o["phi"]), C2[:, 3], atol=5e-4)
    assert_allclose(o["G"], C2[:, 4], atol=5e-6)
    assert_allclose(o["G_exact"], C2[:, 5], atol=5e-6)
    assert_allclose(o["zeta_over_ec"], C2[:, 6], atol=5e-6)
    assert np.all(np.isfinite(o["G"]))  # no division by zero at omega = omega_cr


def test_c2_literal_damping_breaks_sin_phi():
    # [derived]: with 2n = 49.3 (literal erratum-1 reading) sin(phi) > 1 for gamma >= ~1.21 -> NaN with a reason
    n_lit = lb.n_from_decrement_literal(0.826, WCR)
    o = table31("corrected", [1.15, 1.25, 1.4], n=n_lit)
    assert np.isfinite(o["phi"][0]) and not np.isfinite(o["phi"][1])
    assert all("sin(phi) > 1" in r for r in o["reason"][1:])
    assert_allclose(WCR**2 / (2 * n_lit * WCR), 1.21, atol=5e-3)  # gamma where sin(phi) = 1: recomputed "~1.21"


# ---- C3 --------------------------------------------------------------------------------------

def test_c3_liquid_geometry():
    o = table31("corrected", [0.4])
    assert_allclose(o["r"], 0.1975983, atol=5e-8)  # [derived]
    assert_allclose(0.2 - o["r"], 2.4017e-3, atol=5e-8)
    # D = rho pi h r^2 f = m_l x_p, machine precision
    assert_allclose(o["D"], 1000 * math.pi * 0.05 * o["r"] ** 2 * o["f"], rtol=1e-14)
    assert_allclose(o["D"], 0.15 * o["x_p"], rtol=1e-14)
    assert_allclose(o["x_p"], o["r"] ** 2 * o["f"] / (0.04 - o["r"] ** 2), rtol=1e-14)
    assert_allclose(lb.limit_mass(2e-3, 1000, 0.05, 0.2), 2 * 2e-3 * 1000 * math.pi * 0.05 * 0.2, rtol=1e-15)


@pytest.mark.parametrize("omega", [23.88, 59.7, 87.9])
def test_c3_paraboloid_volume_and_mean_radius(omega):
    # [derived]: the paraboloid holds V and the mean of rho_s^2 over the height is r^2
    R, h, V = 0.2, 0.05, 1.5e-4
    p = lb.paraboloid(R, h, V, omega, math.radians(90))
    assert_allclose(lb.paraboloid_volume(R, h, p["a"], p["z_star"]), V, rtol=1e-12)
    z = np.linspace(0, h, 200001)
    mean = np.trapezoid((z - p["z_star"]) / p["a"], z) / h
    assert_allclose(mean, R**2 - V / (math.pi * h), rtol=1e-12)
    assert p["valid"]


def test_c3_crescent_equals_thesis_while_sufficient_and_stays_inside_the_wall():
    R, h, V = 0.2, 0.05, 1.5e-4
    r = math.sqrt(R**2 - V / (math.pi * h))
    for f in (1e-4, 1e-3, 0.99 * (R - r)):
        c = lb.crescent(R, h, V, f)
        assert c["sufficient"]
        assert_allclose(c["x_p"], r**2 * f / (R**2 - r**2), rtol=1e-9)
    for f in (0.01, 0.0365, 0.1):  # insufficient: the centroid stays inside the chamber (thesis formula does not)
        c = lb.crescent(R, h, V, f)
        assert not c["sufficient"] and 0.15 < c["x_p"] < R
        assert r**2 * f / (R**2 - r**2) > R


# ---- C4 --------------------------------------------------------------------------------------

def test_c4_lambda0_at_alpha_pi():
    # [derived], [T]: lambda0(k, pi) = k/|1-k|; the threshold k > 0.5
    k = np.array([0.25, 0.5, 0.75, 0.9, 1.1, 2.0])
    assert_allclose(np.asarray(lb.lambda0(k, -1.0)).ravel(), [1 / 3, 1.0, 3.0, 9.0, 11.0, 2.0], rtol=1e-12)


def test_c4_extremum_table():
    # [derived] table: k* = -1/cos a0, lambda_max = 1/|sin a0| [T]
    a = np.radians([120.0, 150.0, 170.0, 179.0])
    e = lb.extremum(a)
    assert_allclose(e["k_star"], [2.000000, 1.154701, 1.015427, 1.000152], atol=5e-7)
    assert_allclose(e["lambda0_max"], [1.154701, 2.000000, 5.758770, 57.298688], atol=5e-7)
    fn = lb.lambda0_of_k_function()
    for ai, ki, li in zip(a, e["k_star"], e["lambda0_max"], strict=True):
        lam, d1, _ = (float(v) for v in fn(ki, ai))
        assert_allclose([lam, d1], [li, 0.0], atol=1e-9)
        ks = np.linspace(0.01, 10, 2001)
        assert np.all(np.asarray(fn.map(ks.size)(ks.reshape(1, -1), ai)[0]).ravel() <= li * (1 + 1e-12))
    assert np.isnan(lb.extremum(math.radians(60.0))["k_star"])  # cos a0 > 0: no maximum for k >= 0


@pytest.mark.literature
def test_c4_derivatives_and_printed_second_derivative():
    fn = lb.lambda0_of_k_function()
    a = math.radians(150.0)
    for k in (0.3, 1.3, 4.0):
        _, d1, d2 = (float(v) for v in fn(k, a))
        assert_allclose(d1, lb.dlambda0_dk(k, a), rtol=1e-12)  # [T]
        assert_allclose(d2, lb.d2lambda0_dk2(k, a), rtol=1e-12)  # general form, erratum 6
    # [derived]: at k = 1.3 numeric -1.69630 = general; the printed form gives -2.55 (valid at k* only)
    # (-1.6963096 here and by a finite difference: the recomputation's sixth digit is truncated, not rounded)
    assert_allclose(lb.d2lambda0_dk2(1.3, a), -1.69630, atol=1e-5)
    assert_allclose(lb.d2lambda0_dk2(1.3, a, printed=True), -2.55, atol=5e-3)
    ks = -1 / math.cos(a)
    assert_allclose(lb.d2lambda0_dk2(ks, a, printed=True), lb.d2lambda0_dk2(ks, a), rtol=1e-12)


@pytest.mark.literature
def test_c4_corrected_branch_and_printed_defect():
    # corrected (2.13-corr) through (2.14) equals the closed form k/||cos d| - sqrt(k^2 - sin^2 d)|
    rng = np.random.default_rng(1)
    d = rng.uniform(0.05, 3.1, 50)
    k = np.sin(d) + rng.uniform(0.01, 3, 50)
    y = (np.sin(d) ** 2 + np.sqrt(np.cos(d) ** 2 * (k**2 - np.sin(d) ** 2))) / k
    assert_allclose(k / np.sqrt(1 - 2 * k * y + k**2), lb.lambda0_corrected(k, d), rtol=1e-9)
    assert_allclose(lb.lambda0_corrected(np.array([0.25, 0.75, 2.0]), math.pi), [1 / 3, 3.0, 2.0], rtol=1e-12)
    assert np.isnan(lb.lambda0_corrected(0.3, math.radians(30)))  # k < sin delta: no real solution
    # printed (2.13) at delta = pi gives alpha0 = pi - arccos(k): the documented defect
    s = float(np.sin(math.pi) ** 2)
    for kk in (0.3, 0.8):
        y_pr = float(lb.acos_argument(s, kk, "printed"))
        y_co = float(lb.acos_argument(s, kk, "corrected"))
        assert_allclose(math.pi - math.acos(y_pr), math.pi - math.acos(kk), atol=1e-7)
        assert_allclose(y_co, 1.0, atol=1e-12)  # corrected: cos alpha0 = -1 as the thesis claims [T]


def test_c4_sign_convention_of_2_12():
    # [derived]: delta = 7.138 deg, k = 6.5238: (2.10b) root 186.05 deg, (2.12)/(2.13-corr) 173.95 deg
    d, k = math.radians(7.138), 6.5238
    y = float(lb.acos_argument(math.sin(d) ** 2, k, "corrected"))
    assert_allclose(math.degrees(math.pi - math.acos(y)), 173.95, atol=5e-3)
    assert_allclose(math.degrees(d + math.pi - math.asin(math.sin(d) / k)), 186.05, atol=5e-3)


# ---- C5 --------------------------------------------------------------------------------------

S81 = {  # [derived]: App. В pipeline as documented, f from e0 = D0/m_d = 0.2 m
    "f": [0.036489, 0.10543, 0.29624, 0.73374, 0.51301, 0.36759],
    "x_p": [1.4920, 4.3107, 12.113, 30.001, 20.976, 15.030],
    "D": [0.22380, 0.64661, 1.8169, 4.5002, 3.1464, 2.2545],
    "k_D": [0.13405, 0.046396, 0.016512, 0.0066664, 0.0095347, 0.013307],
}


def test_c5_documented_algorithm_reproduces_the_derived_values():
    o = table31("program")
    for key, ref in S81.items():
        assert_allclose(o[key], ref, rtol=5e-5, err_msg=key)  # 5 significant digits
    assert_allclose(np.degrees(o["alpha0"][0]), 92.874, atol=5e-4)
    nan = [1, 2, 4, 5]
    expect = {"program": [0.1337, 0.0067], "printed": [0.1340, 0.0067], "corrected": [0.1423, math.nan]}
    for v, (l04, l10) in expect.items():
        lam = table31(v)["lambda0"]
        assert_allclose(lam[0], l04, atol=5e-5, err_msg=v)
        if math.isnan(l10):
            assert math.isnan(lam[3])
        else:
            assert_allclose(lam[3], l10, atol=5e-5)
        assert np.all(np.isnan(lam[nan])), v
        assert all(r.startswith("no equilibrium") for r in table31(v)["reason"][nan])


def test_c5_system_eccentricity_check_of_8_1():
    # [derived]: f from D0/M_sys (4.11 mm) does not reproduce Table 3.2 either
    ef = 0.03 / 7.3
    pr, co = table31("printed", e_f=ef)["lambda0"], table31("corrected", e_f=ef)["lambda0"]
    assert_allclose(pr, [np.nan, np.nan, 1.3232, 0.4802, np.nan, 0.8355], atol=5e-5, equal_nan=True)
    assert_allclose(co, [1.1796, 1.7719, 3.3767, np.nan, np.nan, 1.6432], atol=5e-5, equal_nan=True)


@pytest.mark.literature
def test_c5_table_3_2_statistic_and_self_consistent_closure(washer):
    T, X = np.array(study.TABLE_3_2["theory"]), np.array(study.TABLE_3_2["experiment"])
    dev = 100 * (T - X) / T
    assert_allclose(dev, [12.31, 5.92, 15.96, -5.43, 3.08, 4.65], atol=5e-3)  # [derived]
    assert_allclose(np.abs(dev).max(), 15.96, atol=5e-3)  # the thesis's "no more than 16 %" [T]
    assert_allclose(np.abs(100 * (T - X) / X).max(), 18.99, atol=5e-3)  # relative to experiment (ledger)
    sc = lb.self_consistent(GAMMAS * WCR, WCR, N, 0.2, 0.05, 1.5e-4, 1000, 7.3)  # [derived]
    assert_allclose(sc["Q"], [6.52382, 2.25792, 0.80356, 0.32443, 0.46402, 0.64759], atol=5e-6)
    assert_allclose(sc["lambda0_plus"], [1.1523, 1.4339, 2.1674, 3.2405, 3.0244, 2.5036], atol=5e-5)
    # the "-" root needs Q <= |cos delta|; at gamma = 1 |cos delta| = 0, so it does not exist (the recomputation's
    # table prints the formula's value 3.2405 there, equal to the "+" root)
    assert_allclose(sc["lambda0_minus"], [np.nan, np.nan, 0.6323, np.nan, 1.4635, 0.7078], atol=5e-5,
                    equal_nan=True)
    # sub-critical agreement with experiment (derived): +1.1 %, +0.3 %, -1.8 %
    assert_allclose(100 * (sc["lambda0_plus"][[0, 1, 3]] / X[[0, 1, 3]] - 1), [1.1, 0.3, -1.8], atol=0.05)


# ---- C6 / C7: the optimisation problems (IPOPT against dense grids) ---------------------------

@pytest.mark.literature
@pytest.mark.parametrize("gamma, variant, deflection, h_ref", [
    # [derived] regression values, grid dh = 1e-5 m
    (0.4, "program", "program", 0.00764), (0.4, "printed", "program", 0.00774),
    (0.8, "program", "program", 0.00187), (1.2, "program", "program", 0.00157),
    (0.8, "printed", "system", 0.04041), (1.2, "printed", "system", 0.02384),
])
def test_c6_optimal_height_regression_8_4(washer, gamma, variant, deflection, h_ref):
    o = optimum.optimise(washer, "height", variant, deflection, 0.0, 0.1, 2001, omega=gamma * WCR)
    assert o["solver"]["status"] == "Solve_Succeeded"
    assert abs(o["optimum"] - h_ref) <= 1e-5  # the recomputation's grid step
    assert o["agree"] and o["grid_difference"] <= o["grid_step"]
    if variant == "printed":  # singular at k_D = 1: the analytic h* = (D0/(rho f) + V)/(pi R^2)
        assert_allclose(o["k_D"], 1.0, atol=1e-6)
        assert_allclose(o["optimum"], o["k_D_equals_1_at"], rtol=1e-6)
    else:  # program variant: a finite maximum slightly below h*
        assert o["optimum"] < o["k_D_equals_1_at"] and np.isfinite(o["lambda0_max"])


@pytest.mark.parametrize("kind", ["height", "volume"])
@pytest.mark.parametrize("variant", ["program", "corrected"])
def test_ipopt_optimum_agrees_with_dense_grid(washer, kind, variant):
    lo, hi = (0.0, 0.1) if kind == "height" else (1e-6, math.inf)
    o = optimum.optimise(washer, kind, variant, "program", lo, hi, 200001)
    # independent check: the grid's best lambda0 is within one grid step of IPOPT's optimum
    assert o["agree"], (o["optimum"], o["grid_optimum"], o["grid_step"])
    assert o["grid_difference"] <= o["grid_step"]
    # and IPOPT's optimum is at least as good as every grid point (up to the singular branch)
    assert o["lambda0_max"] >= o["grid_lambda0"] * (1 - 1e-9)


def test_optimum_volume_is_k_equal_one_and_falls_with_d0(washer):
    # [derived]: V* = pi h R^2 - D0/(rho f), decreasing with D0 (why Table 3.3 is not reproducible)
    vs = []
    for md in (0.05, 0.10, 0.15, 0.20):
        s = study.System(**{**washer.__dict__, "unbalance_mass": md})
        o = optimum.optimise(s, "volume", "corrected", "program", 1e-6, math.inf, 2001)
        assert_allclose(o["k_D"], 1.0, atol=1e-6)
        assert_allclose(o["optimum"], math.pi * 0.05 * 0.04 - s.D0 / (1000 * o["f"]), rtol=1e-7)
        vs.append(o["optimum"])
    assert np.all(np.diff(vs) < 0)


def test_no_equilibrium_in_bounds_is_reported_not_raised(washer):
    # gamma = 0.6: the documented model has no equilibrium at h = 0.05, and none for h in [0.03, 0.1]
    o = optimum.optimise(washer, "height", "corrected", "program", 0.03, 0.1, 101, omega=0.6 * WCR)
    assert math.isnan(o["optimum"]) and "no equilibrium" in o["reason"]


@pytest.fixture(scope="module")
def washer_run(tmp_path_factory):
    """The shipped washer scene run once through the CLI: (results.json block, output folder)."""
    out = tmp_path_factory.mktemp("washer")
    assert cli.main(["run", "washer_liquid_balancer", "--out", str(out)]) == 0
    return json.loads((out / "results.json").read_text())["liquid_balancer"], out


@pytest.mark.literature
@pytest.mark.cli
def test_c7_table_3_3_derived_numbers(washer_run):
    # Khomyak (2020), Table 3.3 as the run reports it: the published capacity D implies k_D = D0/D
    # [derived], and the published V_opt differs from the experiment by -3.0 .. +4.1 %
    rows = washer_run[0]["table_3_3"]["rows"]
    assert_allclose([r["D0_gcm"] for r in rows], [1000, 2000, 3000, 4000], rtol=1e-12)
    assert_allclose([r["published_k_D"] for r in rows], [1.0413, 1.0278, 1.0439, 1.0220], atol=5e-5)
    assert_allclose([r["published_vs_experiment_pct"] for r in rows], [-3.0, 4.1, 2.9, -1.8], atol=0.05)


def test_c7_crescent_extension_rises_with_d0(washer):
    f = 0.2 * float(lb.evaluate("corrected", **washer.inputs("program"))["G"])
    v = [optimum.crescent_volume(0.2, 0.05, f, d0, 1000)["V"] for d0 in (0.01, 0.02, 0.03, 0.04)]
    assert np.all(np.diff(v) > 0)
    assert_allclose(np.array(v) * 1e6, [52.789, 109.395, 169.490, 233.169], atol=5e-3)  # toolkit regression


# ---- C8 --------------------------------------------------------------------------------------

def test_c8_sin_beta_star():
    # [derived]: water, R = 0.2, m = 0.15, omega = 23.88
    s = lb.sin_beta_star(1e-3, 0.2, np.array([90.0, 180.0, 261.0]), 0.15, 23.88)
    assert_allclose(s, [0.002204, 0.004409, 0.006392], atol=5e-7)
    assert_allclose(math.degrees(math.asin(s[1])), 0.2526, atol=5e-5)
    # the nu form (program Г reconstructed) is the same number
    assert_allclose(lb.sin_beta_star_nu(1e-6, 0.2, np.radians([90.0, 180.0, 261.0]), 1.5e-4, 23.88), s, rtol=1e-12)
    # monotonic: up with mu, down with omega [T]
    assert lb.sin_beta_star(2e-3, 0.2, 90, 0.15, 23.88) > s[0] > lb.sin_beta_star(1e-3, 0.2, 90, 0.15, 50)


def test_c8_program_sinus_example():
    # [derived]: Table 3.1, gamma = 0.4, f = 0.036489, water
    a = lb.program_arc(0.2, 0.05, 1.5e-4, 0.036489)
    assert_allclose(float(a["z"]), -0.15665, atol=5e-6)
    assert_allclose(float(a["xi"]), 4.5551, atol=5e-5)
    assert_allclose(math.degrees(float(a["xi"])), 260.99, atol=5e-3)
    assert_allclose(lb.sin_beta_star_nu(1e-6, 0.2, a["xi"], 1.5e-4, 23.88), 0.0063921, atol=5e-8)
    assert_allclose(lb.sinus_literal(1e-6, 0.2, 1.5e-4, 0.05, 23.88, 0.036489), 3.196e-8, atol=5e-12)


def test_c8_viscous_zone():
    q, sb = 40.8879, 0.0063921
    d = float(lb.zone_half_width(q, sb))
    assert_allclose(abs(lb.tan_beta(d, q)), sb / math.sqrt(1 - sb**2), rtol=1e-12)  # (2.15) boundary
    assert abs(lb.tan_beta(0.9 * d, q)) < math.tan(math.asin(sb))
    assert float(lb.zone_half_width(q, 2 * sb)) > d  # zone widens with viscosity
    assert np.isnan(lb.zone_half_width(q, 0.05))  # t q > 1: every angle is an equilibrium


def test_c8_liquid_choice_is_argmin_sin_beta(washer):
    settings = scenario.load("washer_liquid_balancer").analyses.liquid_balancer
    settings = settings.model_copy(update={"height": None, "unbalance_masses": [], "thesis_comparison": False,
                                           "volume": settings.volume.model_copy(update={"grid_points": 201})})
    d = study.run(washer, spec(settings)).to_dict()["liquid_choice"]
    sb = [c["sin_beta_star"] for c in d["candidates"]]
    assert d["chosen"] == d["candidates"][int(np.argmin(sb))]["name"] == "water"
    assert sb == sorted(sb)  # water < ethylene glycol < glycerol (nu increases)


# ---- C9 / C10 / Pashkov --------------------------------------------

def test_c9_simplified_model():
    m, rho, h, R = 7.15, 1000.0, 0.05, 0.2
    full = lb.full_liquid_mass(rho, h, [R])
    assert_allclose(lb.efficiency(m, full), 1.87877, atol=5e-6)  # [derived]
    c, e0 = 26018.0, 0.03 / m
    wk = lb.critical_speed(c, m, full)
    s = float(lb.deflection(e0, m, 1e3 * wk, c, full))
    r = math.sqrt(R**2 - 1.5e-4 / (math.pi * h))
    m_p, s_p = rho * 1.5e-4, s * R**2 / (R**2 - r**2)
    # (3.7) -> (3.8) as omega -> infinity
    assert_allclose(lb.eccentricity_37(e0, m, s, m_p, s_p), lb.eccentricity_38(e0, m, full), rtol=1e-5)
    # omega_k falls with h, R, rho (3.3)
    assert lb.critical_speed(c, m, lb.full_liquid_mass(rho, 2 * h, [R])) < wk
    assert lb.critical_speed(c, m, lb.full_liquid_mass(rho, h, [1.1 * R])) < wk
    assert lb.critical_speed(c, m, lb.full_liquid_mass(1.2 * rho, h, [R])) < wk


def test_c10_multichamber_efficiency():
    m, rho, h = 7.15, 1000.0, 0.05
    radii = [[0.2], [0.2, 0.18], [0.2, 0.18, 0.16]]
    E = [lb.efficiency(m, lb.full_liquid_mass(rho, h, r)) for r in radii]
    assert_allclose(E, [1.87877, 2.59057, 3.15298], atol=5e-6)  # [derived], (3.14)
    wk = [lb.critical_speed(26018.0, m, lb.full_liquid_mass(rho, h, r)) for r in radii]
    assert np.all(np.diff(E) > 0) and np.all(np.diff(wk) < 0)  # claims [T]
    assert_allclose(wk, [44.0, 37.5, 34.0], atol=0.05)  # as the validation ledger prints them (rad/s)
    assert_allclose(lb.efficiency(m, lb.nested_liquid_mass(rho, h, radii[2], 0.002)), 1.849, atol=5e-4)  # ledger
    # nested first-moment alternative is smaller than the printed sum
    for r in radii[1:]:
        assert lb.nested_liquid_mass(rho, h, r, 0.002) < lb.full_liquid_mass(rho, h, r)
    assert_allclose(lb.nested_liquid_mass(rho, h, [0.2], 0.002), lb.full_liquid_mass(rho, h, [0.2]), rtol=1e-15)


def test_pashkov_sufficiency_margins():
    # Khomyak (2020), Eqs. (3.4)/(3.11): margins R_i - r_i - s and r_i - (R_{i+1} + t_w) - s
    R, V, h, s_defl = [0.2, 0.18], [1.5e-4, 1.3e-4], 0.05, 1.5e-3
    s = lb.sufficiency(R, V, h, s_defl, 0.002)
    r = np.array(s["r"])
    assert_allclose(math.pi * h * (np.square(R) - r**2), V, rtol=1e-12)  # the free surface holds the liquid
    assert_allclose(r, [0.197598, 0.177686], atol=5e-7)
    assert_allclose(s["wall_margin"], [0.000902, 0.000814], atol=5e-7)
    assert_allclose(s["partition_margin"], [0.014098, 0.176186], atol=5e-7)  # innermost: down to the hub r = 0
    assert s["all_ok"]
    tight = lb.sufficiency(R, V, h, 2.35e-3, 0.002)  # R - r: 2.402 mm outer, 2.314 mm inner chamber
    assert tight["ok"] == [True, False] and not tight["all_ok"]
    assert not lb.sufficiency([0.2], [1e-5], 0.05, 1.5e-3)["all_ok"]  # too little liquid


def test_pashkov_efficiency_is_the_inverse_of_psi():
    # Pashkov (2010): experimental efficiencies 1.75 / 2.47 mean psi = m1/m = 1/E = 0.571 / 0.405; the
    # chapter-3 efficiency (3.9) and the rotor model's psi are computed independently
    for E, psi in ((1.75, 0.571), (2.47, 0.405)):
        m2 = (E - 1.0) * 2.0  # full-chamber mass of a 2 kg rotor with efficiency E
        assert_allclose(lb.efficiency(2.0, m2), E, rtol=1e-12)
        assert_allclose(RotorParams(m1=2.0, c=1e4, chi=0.0, e=1e-4, m2_star=m2).psi, psi, atol=5e-4)


def test_pashkov_fill_level_independence(washer):
    # Pashkov (2010), Fig. 12: while sufficiency holds, deflection, omega_k and E do not depend on the fill
    a = study.pashkov(washer)["single"]
    b = study.pashkov(study.System(**{**washer.__dict__, "V": 3e-4}))["single"]
    assert a["sufficiency"]["all_ok"] and b["sufficiency"]["all_ok"]
    for key in ("deflection", "critical_speed", "efficiency"):
        assert_allclose(a[key], b[key], rtol=1e-15)
    assert b["sufficiency"]["wall_margin"][0] > a["sufficiency"]["wall_margin"][0]  # the fill itself changed


def test_pashkov_block_of_the_nested_scene():
    sysn = liquid_balancer_part.adapt(scenario.load("washer_liquid_balancer_nested").liquid_balancer)
    pk = study.pashkov(sysn)
    assert_allclose(pk["single"]["efficiency"], 1 + 1000 * math.pi * 0.05 * 0.04 / 7.15, rtol=1e-12)
    assert_allclose(pk["multi"]["efficiency"], 3.15298, atol=5e-6)
    assert pk["multi"]["critical_speed"] < pk["single"]["critical_speed"]
    assert pk["multi"]["deflection"] < 0  # supercritical: deflection opposite the unbalance
    assert pk["multi"]["sufficiency"]["all_ok"]
    assert pk["multi"]["efficiency_nested"] < pk["multi"]["efficiency"]


# ---- C11 -------------------------------------------------------------------------------------

@pytest.mark.literature
def test_c11_balancing_norms():
    n = np.array([500.0, 1000.0, 3000.0])
    assert_allclose(norms.permissible_specific_unbalance(n, "general"), [800, 200, 22.22], atol=5e-3)
    assert_allclose(norms.permissible_specific_unbalance(n, "household"), [12, 6, 2], rtol=1e-12)
    assert norms.unbalance_coefficient(50.0, 200.0) == 0.25
    # two-plane equivalents: with the reconstructed couple sign the planes sum to the static unbalance
    da, db = norms.two_plane_unbalances(1.0, 0.3, 0.7, 0.2)
    assert_allclose(da + db, 1.0, rtol=1e-15)
    da, db = norms.two_plane_unbalances(1.0, 0.3, 0.7, 0.2, couple_sign=+1)  # the printed pair does not
    assert_allclose(da + db, 1.4, rtol=1e-15)


# ---- C12 -------------------------------------------------------------------------------------

def test_c12a_dynamic_stiffness_round_trip():
    M, K, D, lam, mr = 10.0, 4e5, 150.0, 0.3, 1e-3
    Kt = lambda W: 20.0 * W  # noqa: E731  tangential stiffness K_tau(Omega)
    W = np.linspace(50, 400, 36)
    A, al = rid.synchronous_response(M, K, D, lam, Kt, mr, W, delta=0.4)
    direct, quad = rid.dynamic_stiffness(A, al, mr, W, delta=0.4)
    assert_allclose(direct, K - M * W**2, rtol=1e-10, atol=1e-6)
    assert_allclose(quad, D * (1 - lam) * W - Kt(W), rtol=1e-10, atol=1e-6)
    assert_allclose(rid.fit_stiffness_mass(W, direct), (K, M), rtol=1e-10)
    # 90 deg phase shift at sqrt(K/M) with K_tau = 0
    _, a90 = rid.synchronous_response(M, K, D, lam, 0.0, mr, math.sqrt(K / M), delta=0.0)
    assert_allclose(a90, -math.pi / 2, atol=1e-12)
    # quadrature resonance where D(1 - lambda) omega = K_tau
    Kt0 = 2000.0
    w_q = Kt0 / (D * (1 - lam))
    assert_allclose(rid.dynamic_stiffness(*rid.synchronous_response(M, K, D, lam, Kt0, mr, w_q), mr, w_q)[1], 0.0,
                    atol=1e-6)


def test_c12b_identification_bound_holds_and_grows_near_resonance():
    x = np.linspace(0.2, 0.8, 4)
    a = rid.beam_flexibility(1.0, 2e5, x)
    A = a * np.array([5.0, 8.0, 8.0, 5.0])
    w1 = 1 / math.sqrt(np.linalg.eigvals(A).real.max())  # first eigen-frequency
    e = np.array([1e-4, -2e-4, 5e-5, 1.5e-4])
    for w in (0.3 * w1, 0.8 * w1):
        b = rid.identification_bound(A, w)
        r = rid.monte_carlo_ratio(A, w, e, 1e-3, 300)
        assert r.max() <= b["bound"]
    assert rid.identification_bound(A, 0.99 * w1)["bound"] > 10 * rid.identification_bound(A, 0.5 * w1)["bound"]
    assert_allclose(a, a.T, rtol=1e-15)


@pytest.mark.parametrize("gamma", [0.4, 0.8, 1.0, 1.4])
def test_c12c_time_domain_jeffcott_confirms_phase_and_amplitude(gamma):
    # CVODES steady state against delta (2.5) and the exact Jeffcott ratio
    F = study.jeffcott_integrator(6.0, 60)
    w = gamma * WCR
    xf = np.asarray(F(x0=[0, 0, 0, 0], p=[w, WCR, N])["xf"])
    x, y = xf[0, -1], xf[1, -1]
    j = {k: float(v) for k, v in lb.jeffcott(w, WCR, N).items()}
    assert_allclose(math.hypot(x, y), j["G_exact"], rtol=1e-7)
    assert_allclose((w * 6.0 - math.atan2(y, x)) % (2 * math.pi), j["delta"], atol=1e-7)
    assert abs(j["G"] / j["G_exact"] - 1) < 0.04  # (2.7) approximates the exact ratio within 4 %


# ---- C13: the study, results.json, plot, CLI ---------------------------------------------------

@pytest.mark.cli
def test_c13_run_washer_scene(washer_run):
    res, out = washer_run
    t = res["table"]
    for col in ("gamma", "omega", "delta_deg", "phi_deg", "f", "r", "x_p", "D", "k_D", "alpha0_deg", "lambda0",
                "variant", "equilibrium_exists", "sufficiency_ok", "reason"):
        assert len(t[col]) == 6, col
    assert t["lambda0"][1] is None and t["reason"][1] == "no equilibrium (k_D < sin delta)"
    assert_allclose(t["lambda0"][0], 0.1423, atol=5e-5)
    assert_allclose(t["delta_deg"], C2[:, 1], atol=5e-4)
    rows = res["table_3_2"]["rows"]
    # Khomyak (2020), Table 3.2 experiment, and the toolkit's documented App. В closure beside it
    assert_allclose([r["published_experiment"] for r in rows], [1.14, 1.43, 1.79, 3.30, 2.20, 1.64], rtol=1e-12)
    assert_allclose(rows[0]["toolkit_documented"], 0.1423, atol=5e-5)
    assert all(r["status"] == "differs" for r in rows)
    assert_allclose(res["table_3_2"]["max_theory_experiment_pct"], 15.96, atol=5e-3)
    assert res["optimal_height"]["agree"] and res["optimal_volume"]["agree"]
    assert_allclose([r["published_V_opt_mL"] for r in res["table_3_3"]["rows"]], [48.5, 93.7, 123.5, 176.7],
                    rtol=1e-12)  # Khomyak (2020), Table 3.3
    for name in ("fig_liquid_efficiency.png", "fig_liquid_optimum.png", "liquid_balancer_table.csv",
                 "liquid_balancer_table_3_2.csv"):
        assert (out / name).stat().st_size > 0


@pytest.mark.cli
def test_run_nested_scene(tmp_path):
    assert cli.main(["run", "washer_liquid_balancer_nested", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "results.json").read_text())["liquid_balancer"]
    assert_allclose(res["pashkov"]["multi"]["efficiency"], 3.15298, atol=5e-6)
    assert res["operating_point"]["paraboloid"]["valid"]
    assert "table_3_2" not in res


# ---- bad input -------------------------------------------------------------------------------

@pytest.mark.cli
@pytest.mark.parametrize("path, value, message", [
    ("liquid_balancer.liquid.volume", "7 L", "is not smaller than the chamber volume"),
    ("liquid_balancer.speed", "0 rad/s", "liquid_balancer.speed: must be positive"),
    ("liquid_balancer.liquid.volume", "150 kg", "is not a volume"),
    ("liquid_balancer.rotor.log_decrement", None, None),  # damping_coefficient still given: valid
    ("liquid_balancer.chamber.colour", "red", "liquid_balancer.chamber.colour: unknown key"),
    ("analyses.liquid_balancer.variant", "fixed", "analyses.liquid_balancer.variant: Input should be"),
    ("liquid_balancer", None, "analyses.liquid_balancer needs a liquid_balancer section"),
])
def test_bad_input_one_line(tmp_path, capsys, scene_edit, path, value, message):
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(scene_edit(WASHER, path, value)))
    if message is None:
        scenario.load(p)
        return
    with pytest.raises(ScenarioError, match=message):
        scenario.load(p)
    assert cli.main(["check", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err


def test_missing_damping_and_nested_overflow(tmp_path, scene_edit):
    d = scene_edit(WASHER, "liquid_balancer.rotor.damping_coefficient", None)
    del d["liquid_balancer"]["rotor"]["log_decrement"]
    p = tmp_path / "a.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ScenarioError, match="give log_decrement or damping_coefficient"):
        scenario.load(p)
    n = yaml.safe_load(scenario.resolve("washer_liquid_balancer_nested").read_text())
    n["liquid_balancer"]["nested"]["chambers"][1]["volume"] = "5 L"
    p.write_text(yaml.safe_dump(n))
    with pytest.raises(ScenarioError, match=r"nested.chambers\[1\].volume"):
        scenario.load(p)


def test_model_never_raises_on_bad_points():
    # zero speed, liquid larger than the chamber, no equilibrium: NaN with a reason, no exception
    o = table31("corrected", [0.0, 0.4, 0.6], V=np.array([1.5e-4, 7e-3, 1.5e-4]))
    assert np.all(np.isnan(o["lambda0"]))
    assert o["reason"][0].startswith("zero speed")
    assert o["reason"][1].startswith("no free surface")
    assert o["reason"][2] == "no equilibrium (k_D < sin delta)"
    assert np.isnan(lb.crescent(0.2, 0.05, 7e-3, 0.01)["x_p"])


def test_resonance_efficiency_1_7_of_fig_3_6_differs(washer):
    # [T]: efficiency 1.7 at omega_cr for D0 = 2000 g cm, V = 100 mL; the documented pipeline gives
    # 0.0044 (printed/program) or no equilibrium (corrected); the extension 3.31 (validation ledger row)
    s = study.System(**{**washer.__dict__, "unbalance_mass": 0.1, "V": 1e-4})
    p = s.inputs("program", omega=WCR)
    assert_allclose(lb.evaluate("program", **p)["lambda0"], 0.0044279, atol=5e-8)
    assert np.isnan(lb.evaluate("corrected", **p)["lambda0"])
    assert_allclose(lb.self_consistent(WCR, WCR, N, 0.2, 0.05, 1e-4, 1000, s.M_sys)["lambda0_plus"], 3.3055,
                    atol=5e-5)


def test_result_object_without_pyplot(washer, tmp_path):
    import matplotlib
    from matplotlib.figure import Figure

    settings = scenario.load("washer_liquid_balancer").analyses.liquid_balancer
    settings = settings.model_copy(update={"height": None, "unbalance_masses": [], "liquids": [],
                                           "volume": settings.volume.model_copy(update={"grid_points": 201})})
    res = study.run(washer, spec(settings))
    before = matplotlib.get_backend()
    figs = res.plot()
    assert len(figs) == 2 and all(isinstance(f, Figure) for f in figs) and matplotlib.get_backend() == before
    fig = Figure()
    assert res.plot(ax=fig.add_subplot()) is fig and len(fig.axes[0].lines) >= 5
    names = {f.name for f in res.save(tmp_path)}
    assert {"liquid_balancer_table.csv", "fig_liquid_efficiency.png", "fig_liquid_optimum.png"} <= names
    assert res.optimal_height is None
    assert_allclose(res.optimal_volume, res.to_dict()["optimal_volume"]["k_D_equals_1_at"], rtol=1e-10)  # m^3
    assert_allclose(res.efficiency, 0.1423, atol=5e-5)  # gamma = 0.4, as C13's first row
