"""The best profiles found on the real spin-up problem against the study, and the heavily damped rotor of issue 35.

The reference profiles are the best of two independent searches (benchmarks/spinup_ocp.md, "The best optimum of
the real problem"): full-braking back-offs with switching instants free in continuous time (differential evolution
on the modal integrator, `python -m benchmarks spinup_search`), then polished as waypoint profiles (the speed at
free instants, linear between, any rate within |alpha| <= alpha_max; Nelder-Mead on the integrator at a 1 ms
step, `python -m benchmarks spinup_waypoints`).  They are written as segments (duration to 1 us, rate over
alpha_max to 1e-6), re-simulated by CVODES and checked feasible, and the shipped scenes' studies are held to them.
The reproducible targets (issue 35; issue 26's 12.295 e and 15.235 e were wrong: an independent re-run of the
reference that produced them gives 12.3029 e and 15.2335 e, the developers' profiles 12.3031 e and 15.2332 e) are
12.3029 e at 40 rad/s^2 and 15.2332 e at 20 rad/s^2; the study is held within 0.05 % of each (12.309 e, 15.241 e)
with its default regulariser."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.ocp import spinup as S
from autobal.ocp.problem import pulse_variation

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
# the reproducible targets of issue 35 and the study's bound, 0.05 % above each (delta/e)
TARGET = {"spinup_jeffcott_deadline_5s": 12.3029, "spinup_jeffcott_horizon_10s": 15.2332}
STUDY_AT_MOST = {"spinup_jeffcott_deadline_5s": 12.309, "spinup_jeffcott_horizon_10s": 15.241}
# control intervals the study needs for it: the shipped scenes' own (200 at 40 rad/s^2, 400 at 20 rad/s^2), on the mesh
# graded from the coarse optimum (ocp/solve.py ``grading``): 12.3072 e and 15.2369 e (the uniform mesh 12.3094 e and
# 15.2376 e; uniform 400 intervals at 40 rad/s^2 12.3063 e; docs/dev/spinup.md, "The graded mesh")
INTERVALS = {"spinup_jeffcott_deadline_5s": 200, "spinup_jeffcott_horizon_10s": 400}


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
    assert resimulated <= TARGET[name] * (1 + 1e-4)  # the best profile is the target, to its 4 digits


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BEST))
def test_study_within_0_05_pct_of_the_target(name):
    ocp = scene_ocp(name)
    assert api.load(name).analyses.spinup.intervals == INTERVALS[name]  # the shipped scene's own mesh
    opt = S.optimize(ocp, S.DirectCollocation(INTERVALS[name], 3, "radau"))
    assert ocp.jerk_variation == 1e-4  # the default regulariser
    assert opt.solution.h[:INTERVALS[name]].max() > 1.5 * opt.solution.h[:INTERVALS[name]].min()  # graded
    assert opt.score <= STUDY_AT_MOST[name]
    assert pulse_variation(opt.solution.u[:INTERVALS[name]]) < 0.05  # drivable: no one-interval pulses
    assert opt.score >= BEST[name][1] * (1 - 1e-3)  # a peak far below the best profile would be a wrong judge


def damped_ocp() -> S.SpinupOcp:
    """Issue 35's heavily damped rotor: zeta = 0.1 (2 kg, 20 kN/m, 40 N s/m, e = 0.05 mm), 50 -> 200 rad/s, at
    most 160 rad/s^2, a 3 s deadline, a 1 s hold, never above 200 rad/s."""
    from autobal.models.rotor import RotorParams

    return S.SpinupOcp(RotorParams(m1=2.0, c=20e3, chi=40.0, e=5e-5), 50.0, 200.0, 3.0, 160.0, settling_time=1.0,
                       omega_max=200.0)


def test_damped_issue_profile_resimulates_below_the_old_optimum():
    """The profile issue 35 describes (up to just above the critical speed, back off, up, back, a partial-rate
    ramp to 200 rad/s; its corners polished by Nelder-Mead on CVODES, full rates) re-simulates at 4.5347 e, below
    the 4.5875 e the study stopped at before the back-off search."""
    ocp = damped_ocp()
    corners = [108.597093, 74.203991, 114.553675, 105.901565]  # rad/s, reached at +-alpha_max
    w, t, u, d = ocp.omega_start, 0.0, [], []
    for c in corners:
        d.append(abs(c - w) / ocp.alpha_max)
        u.append(np.sign(c - w))
        t, w = t + d[-1], c
    u.append((ocp.omega_final - w) / (ocp.horizon - t) / ocp.alpha_max)  # the last leg ends at the deadline
    d.append(ocp.horizon - t)
    seg = list(zip(d, u, strict=True))
    uu, hh, ww = profile(ocp, seg)
    assert ww.max() <= ocp.omega_max * (1 + 1e-12) and 0 < u[-1] < 1
    assert S.resimulate(ocp, uu, hh, "issue 35").peak_delta == pytest.approx(4.5347, abs=1e-4)


@pytest.mark.slow
def test_damped_rotor_study_finds_the_basin():
    """Issue 35: at most 4.54 e (the study stopped at 4.5875 e; the issue's profile peaks at 4.5347 e)."""
    ocp = damped_ocp()
    opt = S.optimize(ocp, S.DirectCollocation(200, 3, "radau"))
    assert 4.5347 * (1 - 2e-3) <= opt.score <= 4.54


@pytest.mark.parametrize("brakes", [True, False])
def test_every_point_of_the_backoff_family_is_feasible(brakes):
    """Random points of the back-off family's unit box (one and two back-offs) keep 0 <= omega <= the cap, the drive's
    rates (:func:`search.drive_rates`; without braking the back-off is a hold) and reach omega_final by the deadline,
    exactly at every step end of their controls."""
    import dataclasses

    from autobal.ocp import search

    ocp = damped_ocp()
    if not brakes:  # a torque limit (80 rad/s^2 over J_p = 0.01 kg m^2) and no braking
        P = dataclasses.replace(ocp.params, J_p=0.01)
        ocp = dataclasses.replace(ocp, params=P, torque_max=0.8, braking_torque_max=0.0)
    up, down = search.drive_rates(ocp)
    assert (up, down) == ((160.0, -160.0) if brakes else (pytest.approx(80.0, rel=1e-6), 0.0))
    rng = np.random.default_rng(3)
    for k in (1, 2):
        x = rng.uniform(0, 1, (200, 2 * k + 1))
        t, w = search.backoff_breakpoints(ocp, x, k)
        rate = np.diff(w, axis=1) / np.maximum(np.diff(t, axis=1), 1e-300)
        assert np.all(np.diff(t, axis=1) >= 0) and np.all(t[:, -1] <= ocp.horizon * (1 + 1e-12))
        assert np.all(rate <= up * (1 + 1e-9)) and np.all(rate >= down * (1 + 1e-9) - 1e-9)
        assert w.min() >= 0 and w.max() <= ocp.omega_max * (1 + 1e-12) and np.all(w[:, -1] == ocp.omega_final)
        edges = np.linspace(0, ocp.horizon, 301)
        u = search.backoff_controls(ocp, x, k, edges)
        assert np.abs(u).max() <= 1 + 1e-9
        assert_allclose(ocp.omega_start + np.sum(u * np.diff(edges), axis=1) * ocp.alpha_max, ocp.omega_final,
                         rtol=1e-12)


def test_backoff_families_follow_the_problems_numbers():
    """One and two back-offs when the slack is at least two natural periods, one below that, none without slack;
    the first excursion below the critical speed only when the start is below it."""
    import dataclasses

    from autobal.ocp.solve import backoff_families

    ocp = damped_ocp()  # slack 3 - 150/160 = 2.06 s, natural period 2 pi/100 = 0.063 s
    assert backoff_families(ocp) == [(1, False), (1, True), (2, False), (2, True)]
    tight = dataclasses.replace(ocp, horizon=150 / 160 + 0.1)  # 0.1 s of slack: under two periods
    assert backoff_families(tight) == [(1, False), (1, True)]
    assert backoff_families(dataclasses.replace(ocp, horizon=150 / 160)) == []
    above = dataclasses.replace(ocp, omega_start=120.0)
    assert backoff_families(above) == [(1, True), (2, True)]


def test_the_search_policy_judges_by_the_exponential_integrator():
    """fast_judged / moved / fell_back / another_basin (ocp/solve.py) against the peaks of two ramps computed here:
    the Jeffcott rotor's peak objective is judged, another objective or a problem without the Jeffcott rotor's
    parameters is not; a refinement that rose more than FALLBACK fell back; a coarse profile within SAME of a
    refined one is its basin (None), within the spread worth refining (True), beyond it not (False)."""
    import dataclasses
    from types import SimpleNamespace

    from autobal.ocp import solve
    from autobal.ocp.search import profile_peak
    from autobal.ocp.simulation import ramp_profile
    from autobal.ocp.spinup import SpinupOcp
    from tests.test_spinup import JEFFCOTT

    ocp = SpinupOcp(JEFFCOTT, 40.0, 210.0, 8.5, 40.0)
    n = 60
    slow, fast = ramp_profile(ocp, n, 20.0), ramp_profile(ocp, n, 40.0)
    ps, pf = profile_peak(ocp, slow), profile_peak(ocp, fast)
    assert pf < ps  # passing faster: the lower peak
    assert solve.fast_judged(ocp)
    assert not solve.fast_judged(dataclasses.replace(ocp, objective="integrated_deflection"))
    assert not solve.fast_judged(SimpleNamespace(objective="peak_deflection", params=None))
    assert solve.moved(ocp, fast, slow) == pytest.approx(ps / pf - 1, rel=1e-12)
    assert solve.moved(dataclasses.replace(ocp, objective="integrated_deflection"), fast, slow) == 0.0
    rise = ps / pf - 1
    assert rise > solve.FALLBACK and solve.fell_back(ocp, fast, slow) and not solve.fell_back(ocp, slow, fast)
    assert solve.another_basin(ocp, [], slow, 1.0) is False  # nothing refined yet: the first is the best's
    assert solve.another_basin(ocp, [fast], fast.copy(), 0.0) is None
    assert solve.another_basin(ocp, [fast], slow, 1.01 * rise) is True
    assert solve.another_basin(ocp, [fast], slow, 0.99 * rise) is False
