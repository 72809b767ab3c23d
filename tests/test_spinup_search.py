"""The best profiles found on the real spin-up problem (issue 26, item 5) against the study.

The reference profiles are the best of two independent searches (benchmarks/spinup_ocp.md, "The best optimum of
the real problem"): full-braking back-offs with switching instants free in continuous time (differential evolution
on the modal integrator, `python -m benchmarks spinup_search`), then polished as waypoint profiles (the speed at
free instants, linear between, any rate within |alpha| <= alpha_max; Nelder-Mead on the integrator at a 1 ms
step, `python -m benchmarks spinup_waypoints`).  They are written as segments (duration to 1 us, rate over
alpha_max to 1e-6), re-simulated by CVODES and checked feasible, and the shipped scenes' studies are held to them.
Issue 26 asks for 12.295 e (40 rad/s^2) and 15.235 e (20 rad/s^2): no profile found reaches the first (the best is
0.065 % above it); the second is reached by the search's profile, not by the study with its default regulariser."""

import numpy as np
import pytest

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.ocp import spinup as S

# segments (duration s, acceleration over alpha_max) from the start; then full acceleration to 210 rad/s and the
# hold.  Peaks (delta/e): the CVODES re-simulation of each profile.
BEST = {
    # waypoint polish of the 5-back-off search profile (12.30351 e): the switches moved by up to 1 ms and an
    # arc at 0.988 alpha_max after the 29 ms brake past the critical speed
    "spinup_jeffcott_deadline_5s": ([(1.004966, 1.0), (0.236351, 1.0), (0.006305, -0.999457), (0.412204, 1.0),
                                     (0.335848, -1.0), (0.586231, 1.0), (0.028766, -1.0), (0.242195, 0.988464),
                                     (0.001041, -0.972797)], 12.30305),
    # the 2-back-off search profile; its waypoint polish moves the peak by -1e-6 relative (15.23318 e)
    "spinup_jeffcott_horizon_10s": ([(3.016849, 1.0), (5.6e-05, -1.0), (0.002098, 1.0), (0.247027, -1.0),
                                     (0.533299, 1.0), (0.500742, -1.0)], 15.23318),
}
# issue 26, item 5, and whether the best profile reaches it (20 rad/s^2: by 0.012 %; 40 rad/s^2: 0.065 % above,
# no searched family reaches it)
TARGET = {"spinup_jeffcott_deadline_5s": (12.295, False), "spinup_jeffcott_horizon_10s": (15.235, True)}
# how far the shipped study stays above the best profile (relative): 0.051 % and 0.030 % measured, the control
# step (40 rad/s^2) and the default regulariser (20 rad/s^2) holding it there; the next basins the study's solve
# path reaches are 0.055 % and more above (benchmarks/spinup_ocp.md)
GAP = {"spinup_jeffcott_deadline_5s": 5.3e-4, "spinup_jeffcott_horizon_10s": 4e-4}


def scene_ocp(name: str) -> S.SpinupOcp:
    scene = api.load(name)
    return spinup_ocp(scene, scene.analyses.spinup)


def profile(ocp: S.SpinupOcp, segments) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u over alpha_max, interval lengths in tau, speeds at the interval ends in rad/s) of the segments, the last
    acceleration to omega_final and the hold appended, each segment cut into pieces of at most 10 ms."""
    d, u = np.asarray(segments, float).T
    w_end = ocp.omega_start + np.sum(u * d) * ocp.alpha_max
    t_go = (ocp.omega_final - w_end) / ocp.alpha_max
    d = np.append(d, [t_go, ocp.horizon + ocp.settling_time - d.sum() - t_go])
    u = np.append(u, [1.0, 0.0])
    pieces = np.maximum(np.ceil(d / 0.01), 1).astype(int) * (d > 0)
    uu, hh = np.repeat(u, pieces), np.repeat(d / np.maximum(pieces, 1), pieces)
    return uu, hh * ocp.Om, ocp.omega_start + np.cumsum(uu * hh) * ocp.alpha_max


@pytest.mark.parametrize("name", list(BEST))
def test_best_profile_is_feasible_and_resimulates(name):
    ocp = scene_ocp(name)
    segments, peak = BEST[name]
    u, h, w = profile(ocp, segments)
    assert np.all(np.abs(u) <= 1)  # acceleration bounds
    assert w.min() >= 0 and w.max() <= ocp.omega_max * (1 + 1e-12)  # speed cap
    t = np.cumsum(h) / ocp.Om
    assert np.all(np.abs(w[t >= ocp.horizon - 1e-9] - ocp.omega_final) < 1e-9 * ocp.omega_final)  # deadline, held
    assert abs(t[-1] - ocp.horizon - ocp.settling_time) < 1e-9
    resimulated = S.resimulate(ocp, u, h, "best profile").peak_delta
    assert resimulated == pytest.approx(peak, rel=2e-6)
    target, reached = TARGET[name]
    assert (resimulated <= target) == reached


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BEST))
def test_study_within_its_measured_gap_of_the_best_profile(name):
    ocp = scene_ocp(name)
    scene = api.load(name)
    opt = S.optimize(ocp, S.DirectCollocation(scene.analyses.spinup.intervals, 3, "radau"))
    assert opt.score <= BEST[name][1] * (1 + GAP[name])
