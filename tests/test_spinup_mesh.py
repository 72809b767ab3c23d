"""The graded mesh of the spin-up transcription (ocp/transcription.py ``mesh``, ocp/solve.py ``grading``): a graded
mesh with every length equal is the uniform NLP bit for bit (collocation and the stage form, jerk rows included);
a graded collocation optimum re-simulates by CVODES as closely as the uniform one; the jerk limit bounds each pair of
intervals by its own step; the grading keeps its bounds."""

import casadi as ca
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from autobal.models.rotor import RotorParams
from autobal.ocp import solve
from autobal.ocp import spinup as S
from autobal.ocp.transcription import (
    interpolate,
    jerk_steps,
    on_uniform,
    point_times,
    structured_derivatives,
    transcribe,
    transcribe_stages,
)

SMALL = RotorParams.from_groups(1.0, 0.1, 1.0)  # Omega0 = 1: zeta0 = 0.05


def small(**kw):
    args = dict(omega_start=0.5, omega_final=1.5, horizon=50.0, alpha_max=0.03, settling_time=10.0) | kw
    return S.SpinupOcp(SMALL, **args)


def middle_grading(n: int) -> np.ndarray:
    """Twice as dense over the middle third of the horizon (where the small rotor passes its critical speed)."""
    return solve.equidistributed(lambda t: np.where(np.abs(t / 50.0 - 0.5) < 1 / 6, 2.0, 1.0), 50.0, n, 2.0)


@pytest.mark.parametrize("form", ["collocation", "stages"])
def test_equal_graded_mesh_is_the_uniform_nlp_bit_for_bit(form):
    """Objective, constraints (the jerk limit's rows among them), their bounds and, for the collocation, the
    structured Jacobian at a random point: identical with a mesh of n equal graded lengths."""
    ocp = small(jerk_max=2e-4, jerk_variation=1e-4)
    method, n = S.DirectCollocation(20, 3, "radau"), 20
    make = (lambda ms: transcribe(ocp, method, 1.0, "MX", ms)) if form == "collocation" else (
        lambda ms: transcribe_stages(ocp, method, 1.0, ms))
    uniform, graded = make(None), make(S.mesh(ocp, n, np.ones(n)))
    assert graded.mesh.grading is not None and uniform.mesh.grading is None
    w = np.random.default_rng(1).uniform(-1, 1, uniform.x.numel())
    fa = ca.Function("a", [uniform.x], [uniform.f, uniform.g])(w)
    fb = ca.Function("b", [graded.x], [graded.f, graded.g])(w)
    for x, y in zip(fa, fb, strict=True):
        assert_array_equal(np.array(x), np.array(y))
    for k in ("lbx", "ubx", "lbg", "ubg"):
        assert_array_equal(getattr(uniform, k), getattr(graded, k))
    if form == "collocation":
        ja = structured_derivatives(uniform)["jac_g"](w, [])[1]
        jb = structured_derivatives(graded)["jac_g"](w, [])[1]
        assert_array_equal(np.array(ja), np.array(jb))


def test_graded_mesh_lengths_and_grading_bounds():
    """The mesh covers the horizon, the grading is bounded by its longest interval and twice as dense where asked;
    a grading that does not sum to n, or one with a free final time, is refused."""
    ocp = small()
    g = middle_grading(60)
    ms = S.mesh(ocp, 60, g)
    assert ms.control_lengths.sum() == pytest.approx(ocp.tau_h, rel=1e-12)
    assert ms.lengths.size == 60 + ms.ns and np.all(ms.lengths[60:] == ms.hs)
    assert g.max() <= 2.0 * (1 + 1e-2)
    mid = np.cumsum(g) - g / 2  # interval midpoints over tau_h / n
    inner, outer = g[np.abs(mid / 60 - 0.5) < 0.12], g[np.abs(mid / 60 - 0.5) > 0.22]
    assert_allclose(outer.mean() / inner.mean(), 2.0, rtol=2e-2)
    assert_array_equal(jerk_steps(S.mesh(ocp, 60)), np.ones(59))
    assert_allclose(jerk_steps(ms), (g[1:] + g[:-1]) / 2, rtol=0, atol=0)
    with pytest.raises(ValueError, match="summing to 60"):
        S.mesh(ocp, 60, 2 * g)
    with pytest.raises(ValueError, match="fixed deadline"):
        S.mesh(small(objective="min_time", deflection_limit=5.0), 60, g)


def test_graded_collocation_resimulates_as_the_uniform():
    """The same problem on 40 uniform and 40 graded intervals: each optimum's collocation peak against its CVODES
    re-simulation (rtol 1e-10) agree to 1e-3 relative, the graded no worse than twice the uniform's error, and both
    peaks within 1 % of each other (the same basin)."""
    ocp = small()
    errs, peaks = [], []
    for ms in (None, S.mesh(ocp, 40, middle_grading(40))):
        sol = S.Solver(ocp, S.DirectCollocation(40, 3, "radau"), mesh=ms).solve()
        assert sol.success
        if ms is not None:
            assert_array_equal(sol.h, ms.lengths)
        peak = S.resimulate(ocp, sol.u, sol.h, "r", 16, 1e-10).peak_delta
        errs.append(abs(sol.peak_collocation / peak - 1))
        peaks.append(peak)
    assert max(errs) < 1e-3 and errs[1] <= 2 * errs[0] + 1e-6
    assert peaks[1] == pytest.approx(peaks[0], rel=1e-2)


def test_graded_jerk_limit_uses_each_pairs_own_step():
    """|d alpha/dt| <= jerk_max with each pair of intervals' step (between their midpoints): kept, and binding."""
    ocp = small(jerk_max=2e-4)
    n = 40
    ms = S.mesh(ocp, n, middle_grading(n))
    sol = S.Solver(ocp, S.DirectCollocation(n, 3, "radau"), mesh=ms).solve()
    step = (sol.h[1:n] + sol.h[:n - 1]) / 2
    jerk = np.abs(np.diff(sol.u[:n] * ocp.alpha_max)) / step
    assert sol.success and jerk.max() <= 2e-4 * (1 + 1e-6)
    assert jerk.max() >= 2e-4 * (1 - 1e-4)  # the limit binds (free, the optimum's jerk exceeds it)


def test_interpolation_from_the_uniform_coarse_mesh_onto_a_graded_one():
    """The coarse optimum's controls held on the graded mesh keep the speed at every fine node to the coarse
    polynomial's accuracy, and the averaging back onto equal intervals (the search policy's judge) keeps the speed
    at their edges exactly."""
    ocp = small()
    coarse = S.Solver(ocp, S.DirectCollocation(20, 3, "radau"))
    sol = coarse.solve()
    fine = S.Solver(ocp, S.DirectCollocation(40, 3, "radau"), mesh=S.mesh(ocp, 40, middle_grading(40)))
    w0, lg0, lx0 = interpolate(coarse.nlp, sol.w, sol.lam_g, sol.lam_x, fine.nlp)
    t = np.concatenate([[0.0], np.cumsum(fine.nlp.mesh.lengths)])
    tc = np.concatenate([[0.0], np.cumsum(coarse.nlp.mesh.lengths)])
    speed = ocp.speed_index
    assert_allclose(w0[fine.nlp.index["X"]][:, speed], np.interp(t, tc, sol.w[coarse.nlp.index["X"]][:, speed]),
                    rtol=1e-9)
    assert lg0.shape == fine.nlp.lbg.shape and lx0.shape == fine.nlp.lbx.shape
    h = fine.nlp.mesh.control_lengths
    u = w0[fine.nlp.index["u"]][:40]
    uu = on_uniform(u, h, 160)
    assert_allclose(np.cumsum(uu) * (h.sum() / 160), np.interp(np.linspace(0, h.sum(), 161)[1:],
                                                               np.cumsum(np.r_[0.0, h]), np.r_[0.0, np.cumsum(u * h)]),
                    rtol=1e-12, atol=1e-12)
    assert_array_equal(on_uniform(sol.u[:20], coarse.nlp.mesh.control_lengths, 20), sol.u[:20])


def test_grading_is_twice_as_dense_near_the_coarse_switches_and_peak():
    """The grading of the mesh continuation from a coarse optimum: n lengths summing to n, none longer than
    GRADE_LONGEST, the intervals near a coarse switch (or the coarse peak) GRADE_RATIO times shorter than those far
    from both; uniform for a free final time."""
    ocp = small()
    coarse = S.Solver(ocp, S.DirectCollocation(20, 3, "radau"))
    sol = coarse.solve()
    g = solve.grading(ocp, coarse.nlp, sol, 80)
    assert g.shape == (80,) and g.sum() == pytest.approx(80, rel=1e-12)
    assert g.max() <= solve.GRADE_LONGEST * (1 + 1e-2)
    t0, _, tc = point_times(coarse.nlp)
    switches = t0[1:20][np.abs(np.diff(sol.u[:20])) > solve.SWITCH]
    d2 = ocp.epigraph2(sol.points[:, :3])
    marks = np.concatenate([switches, tc[:20][d2[:20] >= solve.NEAR_PEAK**2 * d2.max()]])
    assert switches.size
    mid = (np.cumsum(g) - g / 2) * ocp.tau_h / 80
    dist = np.min(np.abs(mid[:, None] - marks[None, :]), axis=1) / ocp.tau_h
    near, far = g[dist < solve.GRADE_NEAR - 0.02], g[dist > solve.GRADE_NEAR + 0.02]
    assert near.size and far.size
    assert_allclose(np.median(far) / np.median(near), solve.GRADE_RATIO, rtol=2e-2)
    free = small(objective="min_time", deflection_limit=5.0)
    assert solve.grading(free, coarse.nlp, sol, 80) is None
