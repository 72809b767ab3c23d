"""Every results.json carries, per analysis, an ``accuracy`` block: ``estimate`` (relative error of the
main outputs, or a bound) and ``how``.  The runners frequency, stability, transient, liquid_balancer,
reliability and montecarlo are run on their shipped scenes (Monte Carlo on a smaller copy) through the
CLI; the estimators themselves are checked against known errors (a peak moved by a known amount, the
standard error of a normal sample's cv, the descriptor pencil of the hand model)."""

import json
import math

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from autobal import scenario
from autobal.analysis.numerics import frequency, sampling, stability, statics
from autobal.analysis.numerics.linearize import Setup
from autobal.cli import main
from autobal.parts import device as device_part


def run_scene(scene, out):
    assert main(["run", str(scene), "--out", str(out)]) == 0
    return json.loads((out / "results.json").read_text())["accuracy"]


def check(block, bound):
    """estimate: a finite float below ``bound``; how: a sentence."""
    est = block["estimate"]
    assert isinstance(est, float) and math.isfinite(est), block
    assert 0.0 <= est < bound, block
    assert isinstance(block["how"], str) and len(block["how"]) > 40


@pytest.fixture(scope="module")
def dynamics_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("dyn")
    assert main(["run", "pump_pe600_dynamics", "--out", str(out)]) == 0
    return json.loads((out / "results.json").read_text())


@pytest.fixture(scope="module")
def dynamics(dynamics_run):
    return dynamics_run["accuracy"]


@pytest.fixture(scope="module")
def pump_setup():
    return Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device), 1.0)


def true_peak(lin, omega: float) -> float:
    """The maximum of |G(i w)| near ``omega``: the root of d|G|^2/dw by bracketing (brentq), independent of
    the peak search and of its Newton-step error estimate."""
    from scipy.optimize import brentq

    n, b, j = len(lin.states), lin.forcing("appendix"), lin.u_out

    def slope(w):
        M = 1j * w * np.eye(n) - lin.A
        x = np.linalg.solve(M, b)
        dx = -1j * np.linalg.solve(M, x)
        return 2.0 * (x[j].conjugate() * dx[j]).real

    return brentq(slope, omega * (1 - 1e-4), omega * (1 + 1e-4), xtol=1e-14 * omega, rtol=1e-15)


@pytest.mark.cli
def test_frequency_block(dynamics_run, pump_setup):
    a = dynamics_run["accuracy"]["frequency"]
    # peaks located by a bounded search with xatol 1e-6 omega; measured 1.2e-7 (Newton step on d|G|^2/d omega)
    check(a, 1e-6)
    assert a["response_max_relative_rounding_error"] < 1e-11  # double LU vs 34-digit solve
    # the reported error of the peak frequencies is the actual distance from the true maxima
    actual = [abs(p["omega"] - true_peak(pump_setup.linear(m), p["omega"])) / p["omega"]
              for m, c in dynamics_run["frequency"]["models"].items() for p in c["peaks"]]
    assert len(actual) >= 2
    assert_allclose(a["peak_frequency_max_relative_error"], max(actual), rtol=1e-3)  # 1e-6 measured


@pytest.mark.cli
def test_stability_block(dynamics, pump_setup):
    import mpmath as mp

    a = dynamics["stability"]
    check(a, 1e-9)  # QR vs QZ on the descriptor pencil: 1e-11 measured
    assert a["signs_certain"]
    for m in ("program", "nonlinear", "nonlinear_chain", "consistent", "thesis"):
        v = a["models"][m]
        assert v["max_residual"] < 1e-11  # backward stable eigensolver: residual ~ n eps
        assert v["descriptor_max_relative_difference"] <= v["max_relative_bound"]  # QR and QZ within the bound
    # the bound holds against poles computed in 30-digit arithmetic from the same matrix
    for m in ("program", "nonlinear"):
        A = pump_setup.linear(m).A
        lam = np.linalg.eigvals(A)
        with mp.workdps(30):
            ref = np.array([complex(z) for z in mp.eig(mp.matrix(A.tolist()), left=False, right=False)])
        err = max(np.min(np.abs(ref - z)) / abs(z) for z in lam)
        assert err <= a["models"][m]["max_relative_bound"], (m, err)
        assert err < 1e-9


@pytest.mark.cli
def test_transient_block(dynamics):
    a = dynamics["transient"]
    check(a, 1e-5)  # rtol 1e-9 against 1e-11: 7e-7 measured
    assert a["estimate"] > 0 and len(a["cases"]) == 3


def test_peak_error_measures_a_known_offset():
    # a peak moved by 1e-5 (relative) from the refined one: the Newton step reports that distance, to the
    # refined peak's own error (<= 2e-7), and the amplitude lost ~ quadratically
    setup = Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device), 1.0)
    lin = setup.linear("program")
    c = frequency.characteristic(lin, (10.0, 8000.0, 800), "appendix", 0.2, 659.734)
    for p in c["peaks"]:
        near, loss_near = frequency.peak_error(lin, p["omega"], "appendix")
        moved, loss = frequency.peak_error(lin, p["omega"] * (1 + 1e-5), "appendix")
        assert_allclose(moved, 1e-5, atol=2 * near + 1e-9)
        assert loss > 100 * loss_near
        got = abs(lin.response([p["omega"]])[0])
        assert_allclose(got, abs(frequency.exact_response(lin, p["omega"], "appendix")), rtol=1e-11)


def test_pencil_of_the_operator_has_the_hand_descriptor_poles():
    import scipy.linalg

    setup = Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device), 1.0)
    c = setup.constants("program")
    E, A = stability.pencil(*c.operator()[:3])
    Eh, Ah = c.descriptor()[:2]
    mine = np.sort_complex(scipy.linalg.eig(A, E, right=False))
    hand = np.sort_complex(scipy.linalg.eig(Ah, Eh, right=False))
    assert_allclose(mine, hand, rtol=1e-10)


@pytest.mark.cli
def test_liquid_balancer_block(tmp_path):
    a = run_scene("washer_liquid_balancer", tmp_path)["liquid_balancer"]
    # IPOPT optimum vs the analytic k_D = 1 point (1e-13 measured); CVODES vs (2.5) (7e-10 measured)
    check(a, 1e-8)
    assert a["bounded"] == [] and set(a["parts"]) == {"optimal_height", "optimal_volume", "jeffcott_delta",
                                                       "jeffcott_ratio"}


@pytest.mark.slow  # > 5 s; the capability is also checked by the default run
@pytest.mark.cli
def test_reliability_block(tmp_path):
    a = run_scene("hydroheel_wear", tmp_path)["reliability"]
    # dominated by the load quadrature of the MTTF to infinity: 1.3e-3 measured at 20001 nodes
    check(a, 5e-3)
    lit = a["parts"]["literal"]
    assert lit["mttf_sojourn"] < 1e-6 and lit["mttf_time"] < 1e-6 and lit["P_tau"] < 1e-6
    assert lit["mttf_tau"] < lit["mttf_infinite_tau"]


@pytest.mark.cli
def test_montecarlo_block_small_copy(tmp_path):
    d = yaml.safe_load(scenario.resolve("pump_pe600_montecarlo").read_text())
    d["analyses"]["montecarlo"] |= {"samples": 2000, "chunk_size": 1000, "discharge_ratio": [0.75, 1.0]}
    d["analyses"]["montecarlo"]["afc"] |= {"samples": 1000, "chunk_size": 1000,
                                           "omega": {"start": "500 rad/s", "stop": "5000 rad/s", "points": 20}}
    scene = tmp_path / "mc_small.yaml"
    scene.write_text(yaml.safe_dump(d))
    a = run_scene(scene, tmp_path / "out")["montecarlo"]
    check(a, 0.2)
    # the spread's standard error of ~normal outputs is about 1/sqrt(2 N) (N = 2000: 0.0158)
    se = np.array(a["spread_relative_standard_error"]["exact_u"])
    assert np.all((0.8 / math.sqrt(4000) < se) & (se < 1.5 / math.sqrt(4000)))
    assert a["estimate"] >= 1 / math.sqrt(2 * 1000)  # the AFC part has 1000 samples
    assert a["max_root_residual"] <= a["root_residual_tolerance"] == statics.RESIDUAL_TOL


def test_standard_error_of_cv_matches_the_normal_theory():
    # normal samples: var(s)/s^2 = 1/(2N), var(m)/m^2 = cv^2/N, independent -> rel SE(cv) = sqrt(1/(2N) + cv^2/N)
    rng = np.random.default_rng(7)
    n, cv = 200_000, 0.05
    Y = 1.0 + cv * rng.standard_normal((n, 2))
    Y[:5, 1] = np.nan  # invalid samples are left out
    se_mean, se_cv = sampling.relative_standard_errors(Y)
    assert_allclose(se_cv, math.sqrt(1 / (2 * n) + cv**2 / n), rtol=0.02)
    assert_allclose(se_mean, cv / math.sqrt(n), rtol=0.02)
