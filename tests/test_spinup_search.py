"""The best profiles of an independent search on the real spin-up problem (issue 26, item 5) against the study.

The reference profiles are the best of an independent search over full-braking back-offs with switching instants
free in continuous time (differential evolution on the modal integrator, `python -m benchmarks spinup_search`;
benchmarks/spinup_ocp.md, "The best optimum of the real problem"), written as phase durations to 1 us; here they
are re-simulated by CVODES and checked feasible, and the shipped scenes' studies are held to them."""

import numpy as np
import pytest

from autobal import api, runners
from autobal.ocp import spinup as S

# phase durations (s), alternately full acceleration and full braking from the first; then full acceleration to
# 210 rad/s and the hold.  Peaks (delta/e): the CVODES re-simulation of each profile.
BEST = {
    "spinup_jeffcott_deadline_5s": ([1.004968, 0.0, 0.236354, 0.006297, 0.412206, 0.335701, 0.585426, 0.029814,
                                     0.843241, 0.001221], 12.30351),
    "spinup_jeffcott_horizon_10s": ([3.016849, 5.6e-05, 0.002098, 0.247027, 0.533299, 0.500742], 15.23318),
}
# how far the shipped study stays above the search's profile (relative): 0.047 % and 0.030 % measured, the
# control step (40 rad/s^2) and the default regulariser (20 rad/s^2) holding it there; the next basins the
# study's solve path reaches are 0.051 % and more above (benchmarks/spinup_ocp.md)
GAP = {"spinup_jeffcott_deadline_5s": 5e-4, "spinup_jeffcott_horizon_10s": 4e-4}


def scene_ocp(name: str) -> S.SpinupOcp:
    scene = api.load(name)
    return runners.spinup_ocp(scene, scene.analyses.spinup)


def profile(ocp: S.SpinupOcp, durations) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u over alpha_max, interval lengths in tau, speeds at the interval ends in rad/s) of the phases, the last
    acceleration to omega_final and the hold appended, each phase cut into pieces of at most 10 ms."""
    d = np.asarray(durations, float)
    u = np.where(np.arange(d.size) % 2 == 0, 1.0, -1.0)
    w_end = ocp.omega_start + np.sum(u * d) * ocp.alpha_max
    t_go = (ocp.omega_final - w_end) / ocp.alpha_max
    d = np.append(d, [t_go, ocp.horizon + ocp.settling_time - d.sum() - t_go])
    u = np.append(u, [1.0, 0.0])
    pieces = np.maximum(np.ceil(d / 0.01), 1).astype(int) * (d > 0)
    uu, hh = np.repeat(u, pieces), np.repeat(d / np.maximum(pieces, 1), pieces)
    return uu, hh * ocp.Om, ocp.omega_start + np.cumsum(uu * hh) * ocp.alpha_max


@pytest.mark.parametrize("name", list(BEST))
def test_search_profile_is_feasible_and_resimulates(name):
    ocp = scene_ocp(name)
    durations, peak = BEST[name]
    u, h, w = profile(ocp, durations)
    assert np.all(np.abs(u) <= 1)  # acceleration bounds
    assert w.max() <= ocp.omega_max * (1 + 1e-12)  # speed cap
    t = np.cumsum(h) / ocp.Om
    assert np.all(np.abs(w[t >= ocp.horizon - 1e-9] - ocp.omega_final) < 1e-9 * ocp.omega_final)  # deadline, held
    assert abs(t[-1] - ocp.horizon - ocp.settling_time) < 1e-9
    assert S.resimulate(ocp, u, h, "search profile").peak_delta == pytest.approx(peak, rel=2e-6)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BEST))
def test_study_within_its_measured_gap_of_the_search_profile(name):
    ocp = scene_ocp(name)
    scene = api.load(name)
    opt = S.optimize(ocp, S.DirectCollocation(scene.analyses.spinup.intervals, 3, "radau"))
    assert opt.score <= BEST[name][1] * (1 + GAP[name])
