"""The time-optimal spin-up of the modal (ROSS) rotor through the time-optimal study of the Jeffcott rotor
(autobal.ocp.time_optimal): the modal problem's min_time objective and deflection limit on the shared transcription,
and the shipped scene end to end, its earliest arrival re-simulated in two frames and compared with the fastest
constant ramp that keeps the same limit."""

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal import scenario
from autobal.analyses import ross_spinup_time_optimal as analysis
from autobal.models import ross_rotor as rr
from autobal.ocp import modal
from autobal.ocp import time_optimal as to
from autobal.ocp.simulation import ramp_profile, simulate_profile
from autobal.ocp.solve import Solver
from autobal.ocp.time_optimal_study import QUANTITIES, peak_text
from tests.test_quantities import check_declared
from tests.test_ross_rotor import disk_rotor, needs_ross


def small(**kw) -> modal.ModalSpinupOcp:
    """The 4-DOF disk rotor (critical speed 100 rad/s) spun up to 80 rad/s, below it."""
    red = rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=80.0, cutoff=1.5)
    return modal.ModalSpinupOcp(red, 0.0, 80.0, 0.6, 400.0, (0,), settling_time=0.3, omega_max=80.0, intervals=24,
                                **kw)


def test_the_modal_min_time_problem_is_the_shared_transcriptions():
    """The modal problem's min_time objective is the generic free-time transcription (the final time over the
    horizon as the one extra variable) with the deflection limit as a path constraint at every collocation point:
    solved from the maximum-acceleration ramp, its collocation peak is at the limit and its final time is the
    objective; a limit the ramp keeps is inactive and the ramp is the optimum; min_time needs a limit."""
    lim = 0.9 * to.fastest_ramp(small(), small().method).peak
    ocp = small(objective="min_time", deflection_limit=lim)
    solver = Solver(ocp, ocp.method)
    names = [n for n, _ in solver.nlp.blocks]
    assert any(n.startswith("deflection limit") for n in names) and not any("epigraph" in n for n in names)
    sol = solver.solve(ramp_profile(ocp, ocp.intervals, ocp.alpha_max))
    assert sol.objective == pytest.approx(sol.final_time_s, rel=1e-9)
    assert 0.2 < sol.final_time_s < ocp.horizon
    assert sol.peak_collocation == pytest.approx(lim, rel=1e-6)  # the limit binds
    tr = ocp.resimulate(sol.u, sol.h, "min_time")
    assert_allclose(tr.peak, lim, rtol=1e-2)
    assert tr.omega[-1] == pytest.approx(80.0, rel=1e-9)
    with pytest.raises(ValueError, match="min_time objective needs a deflection_limit"):
        small(objective="min_time")
    with pytest.raises(ValueError, match="positive"):
        small(deflection_limit=0.0)


def test_peaks_are_declared_in_the_models_unit():
    """The modal block's peaks are declared in m and shown in µm, the Jeffcott block's in delta/e; the text of a peak
    follows the unit the block states."""
    for key in ("peak_deflection_{}", "deflection_limit_{}", "ramp_peak_{}", "front.2.resimulated_peak_{}",
                "limited.collocation_peak_{}"):
        m, e = QUANTITIES.find(key.format("m")), QUANTITIES.find(key.format("over_e"))
        assert (m.unit, m.display, e.unit) == ("m", "µm", "1"), key
    assert peak_text(6.9846e-6, "m") == "6.985 µm"
    assert peak_text(12.99, "1", 1e-4) == "12.99 e (1.299 mm)"


def ramp_peak(ocp: modal.ModalSpinupOcp, alpha: float) -> float:
    """Peak whirl radius (m) of the constant ramp at ``alpha`` (rad/s^2) to the final speed, then held over the
    settling window: the fixed-frame CVODES re-simulation of the modal rotor."""
    t_ramp = (ocp.omega_final - ocp.omega_start) / alpha
    _, _, xy = rr.simulate_fixed(ocp.rotor, ocp.omega_start, np.array([alpha, 0.0]),
                                    np.array([t_ramp, ocp.settling_time]), ocp.nodes)
    return float(np.hypot(xy[:, 0], xy[:, 1]).max())


def fastest_ramp_within(ocp: modal.ModalSpinupOcp, limit: float, rtol: float = 1e-3) -> float:
    """The fastest constant acceleration (rad/s^2, at most alpha_max) whose ramp and hold keep the peak at most
    ``limit``: the first that keeps it on a geometric scan down from alpha_max (the peak is not monotone in the
    rate everywhere: the residual vibration beats), then bisection between it and the next faster one."""
    rates = np.geomspace(ocp.alpha_max, ocp.alpha_max / 40, 25)
    peaks = [ramp_peak(ocp, a) for a in rates]
    k = next(i for i, p in enumerate(peaks) if p <= limit)
    assert k > 0, "the maximum-acceleration ramp already keeps the limit"
    lo, hi = rates[k], rates[k - 1]  # keeps, breaks
    while hi / lo - 1 > rtol:
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if ramp_peak(ocp, mid) <= limit else (lo, mid)
    return float(lo)


@pytest.mark.cli
@pytest.mark.slow
@needs_ross
@pytest.mark.parametrize("scene", ["ross_spinup_time_optimal"])  # with the scene's other tests on one xdist worker
def test_shipped_scene_end_to_end(shipped_run, scene):
    """ross_spinup_time_optimal through autobal.run: every number declared (peaks in m), the verdict ok; the earliest
    arrival's profile re-simulated by CVODES in the fixed frame (rtol 1e-11) keeps the 7 µm limit and the limit binds
    (within 0.3 %: the collocation's difference from the re-simulation on the 25 ms step), and the envelope equation
    of the collocation, integrated by CVODES, gives the same peak (two frames, within 0.5 %); the earliest arrival is
    before the fastest constant ramp that keeps the same limit (about 2 s against 0.28 s) and after the
    maximum-acceleration ramp, which breaks it."""
    run, folder = shipped_run(scene)
    res = run[scene]
    check_declared(folder)
    assert res.peak_unit == "m" and json.loads((folder / "results.json").read_text())[scene]
    assert res.verdict()[0] is True and res.limited.objective == "min_time"
    lim = 7e-6
    assert res.deflection_limit == pytest.approx(lim, rel=1e-12)

    s = scenario.load(scene).analyses.ross_spinup_time_optimal
    ocp = analysis.ross_spinup.problem(scenario.load(scene), s)
    sol = res.limited_point.optimum.solution
    t, w, xy = rr.simulate_fixed(ocp.rotor, ocp.omega_start, sol.u * ocp.alpha_max, sol.h / ocp.Om, ocp.nodes,
                                    tol=1e-11)
    peak = float(np.hypot(xy[:, 0], xy[:, 1]).max())
    assert lim * (1 - 3e-3) <= peak <= lim * (1 + 1e-5)
    assert_allclose(peak, res.peak_deflection, rtol=1e-5)
    assert w[-1] == pytest.approx(s.final_speed, rel=1e-9)
    assert res.arrival_time_s == pytest.approx(float(np.sum(sol.h[:res.limited.intervals])) / ocp.Om, rel=1e-12)
    # the collocation's own equation (the complex envelope), integrated by CVODES on the same profile
    env = simulate_profile(ocp, sol.u, sol.h, list(np.linspace(0, 1, 33)[1:]), tol=1e-10)
    assert_allclose(np.sqrt(ocp.epigraph2(env).max()) * ocp.amplitude_scale, peak, rtol=5e-3)

    a_ramp = fastest_ramp_within(ocp, lim)
    t_ramp = (s.final_speed - s.start_speed) / a_ramp
    assert res.arrival_time_s < 0.5 * t_ramp
    assert res.ramp_arrival_time_s < res.arrival_time_s and res.ramp_peak > lim
    text = res.summary()
    assert "µm" in text and " e (" not in text and "acceleration limit only" in text
    page = (folder / "report.html").read_text()
    assert "Time-optimal spin-up of a ROSS rotor" in page and "acceleration limit only" in page
    assert {f.name for f in folder.iterdir()} >= {f"{scene}_front.png", f"{scene}_profiles.png", f"{scene}_front.csv",
                                                   f"{scene}_profile.csv", "drive_profile.csv"}
