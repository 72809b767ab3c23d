"""The spin-up study on a family of problems (issue 35) against independent references.

The problems (tests/data/spinup_family.json, written by ``python -m benchmarks spinup_family --refs``) span damping
ratios 0.005-0.1, 0.5-20 natural periods per passage, tight and loose deadlines, drive limits without braking
(torque, power), drag, speed caps and a datasheet rotor.  Each reference is the best profile of a method
independent of the study's (scipy differential evolution over four profile families, judged by scipy solve_ivp,
DOP853 at rtol 1e-10, on the model's fixed-frame equations); the test re-runs the study (not the reference) and holds
it within 0.1 % of the reference or below it.  The references' own checks (deadline reached, speed cap and drive
limits kept on the solve_ivp trajectory) are asserted too, so a reference that breaks a limit cannot pass as a
target."""

import json
import math
from pathlib import Path

import pytest
import yaml

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.ocp import spinup as S
from autobal.ocp.simulation import DRIVE_TOL, torque_reference
from autobal.ocp.spinup_study import method_of

DATA = json.loads((Path(__file__).parent / "data" / "spinup_family.json").read_text())
PROBLEMS = DATA["problems"]


def load(tmp_path, name: str):
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"name": name, "title": name} | PROBLEMS[name]["scene"], sort_keys=False))
    scene = api.load(path)
    return spinup_ocp(scene, scene.analyses.spinup), scene


def test_family_spans_the_issue():
    """Damping ratios 0.005-0.1, passages of 0.5-20 natural periods across +-10 % of the critical speed at the full
    acceleration, braking and non-braking drives, speed caps and none: read from the problems themselves."""
    zetas, periods, brakes, caps = [], [], set(), set()
    for name in PROBLEMS:
        ocp, _ = load_path(name)
        P = ocp.params
        zetas.append(P.chi / (2 * math.sqrt(P.c * P.m)))
        periods.append(0.2 * P.omega_cr / ocp.alpha_max / (2 * math.pi / P.omega_cr))
        brakes.add(ocp.braking_torque_max == 0)
        caps.add(ocp.omega_max is not None)
    assert min(zetas) <= 0.0051 and max(zetas) >= 0.099
    assert min(periods) <= 0.55 and max(periods) >= 19
    assert brakes == {True, False} and caps == {True, False}
    assert 8 <= len(PROBLEMS) <= 12


def load_path(name: str):
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        return load(Path(tmp), name)


@pytest.mark.parametrize("name", list(PROBLEMS))
def test_reference_keeps_its_limits(name):
    ref = PROBLEMS[name]
    ocp, _ = load_path(name)
    check = ref["check"]
    assert check["peak_over_e"] == ref["reference_peak_over_e"]
    assert abs(check["deadline_speed_rad_s"] - ocp.omega_final) <= 1e-6 * ocp.omega_final
    if ocp.omega_max is not None:
        assert check["max_speed_rad_s"] <= ocp.omega_max * (1 + 1e-9)
    # the drive limits within the study's own tolerance of a re-simulated profile (DRIVE_TOL, relative; on torques
    # relative to the torque reference)
    if ocp.torque_max is not None:
        assert check["max_torque_N_m"] <= ocp.torque_max * (1 + DRIVE_TOL)
    if ocp.power_max is not None:
        assert check["max_power_W"] <= ocp.power_max * (1 + DRIVE_TOL)
    if ocp.braking_torque_max is not None:
        assert check["min_torque_N_m"] >= -ocp.braking_torque_max - DRIVE_TOL * torque_reference(ocp)
    # the search integrator and solve_ivp agree on the reference's peak (two integrators)
    assert check["integrator_peak_over_e"] == pytest.approx(ref["reference_peak_over_e"], rel=2e-3)


#: problems the study misses, with the measured reason (strict: a fix makes the test fail until this is removed)
MISSES: dict[str, str] = {}  # none since the settling window's no-braking rows keep DRIVE_TOL (torque_no_brake)


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=MISSES[n]))
                                  if n in MISSES else n for n in PROBLEMS])
def test_study_within_0_1_pct_of_the_reference(tmp_path, name):
    ocp, scene = load(tmp_path, name)
    opt = S.optimize(ocp, method_of(scene.analyses.spinup))
    assert opt.score <= PROBLEMS[name]["reference_peak_over_e"] * (1 + 1e-3)


@pytest.mark.slow
def test_integrated_objective_on_a_long_window_refines_from_the_screening():
    """The datasheet rotor's 8 s window with the integrated objective (issue 35, item 4): the coarse screening
    (without the regulariser) converges from at least one start, so the study refines it by mesh continuation
    instead of solving the full mesh from every start (712-766 iterations each before); the refined stages with
    the regulariser converge in under 100 iterations each, and the optimum re-simulates within 1e-3."""
    scene = api.load("spinup_rotor_datasheet", {"analyses.spinup.objective": "integrated_deflection"})
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    opt = S.optimize(ocp, method_of(scene.analyses.spinup))
    stages = [r for r in opt.starts if r["start"] == "mesh continuation"]
    assert stages and all(r["success"] and r["iterations"] < 100 for r in stages)
    assert opt.solution.status == "Solve_Succeeded" and opt.resimulation_rel_error < 1e-3


@pytest.mark.slow
def test_torque_no_brake_basin_is_kept_with_the_settling_brake_rows_to_drive_tol(tmp_path):
    """The measured cause of the torque_no_brake miss, fixed (docs/dev/spinup.md, "Where torque_no_brake's basin is
    lost"): from the two-back-off profile (holds at 78 and 88 rad/s) the mesh continuation's 100-interval stage is in
    the reference's basin.  With the no-braking rows M >= 0 over the settling window (where the speed is held) as
    stated, its 200-interval stage leaves it (11.4034 e, +0.17 %); kept to the re-simulation check's tolerance
    DRIVE_TOL (the transcription's default), it stays in it: below the reference, and the re-simulated profile keeps
    the drive's limits within DRIVE_TOL."""
    import dataclasses

    import numpy as np

    from autobal.ocp import solve
    from autobal.ocp.search import backoff_controls
    from autobal.ocp.simulation import drive_use
    from autobal.ocp.transcription import interpolate

    ocp, scene = load(tmp_path, "torque_no_brake")
    method = method_of(scene.analyses.spinup)
    ref = ocp.reference_level()
    x = np.array([0.2375, 0.1669, 0.0840, 0.4081, 0.0])  # the family's best (Nelder-Mead on the search integrator)
    coarse = solve.coarse_solver(ocp, method, ref, None)
    nc = coarse.nlp.mesh.n
    start = coarse.solve(backoff_controls(ocp, x[None], 2, np.linspace(0, ocp.horizon, nc + 1))[0],
                         hold_states=ocp.hold_states)
    peaks = {}
    for tol in (0.0, DRIVE_TOL):
        prev, sol = coarse, start
        for n in (2 * nc, method.intervals):
            stage = solve.Solver(ocp, dataclasses.replace(method, intervals=n), ref, None, warm=True, brake_tol=tol)
            w0, lg0, lx0 = interpolate(prev.nlp, sol.w, sol.lam_g, sol.lam_x, stage.nlp)
            sol = stage.solve(w0=w0, lam_g0=lg0, lam_x0=lx0)
            prev = stage
        tr = ocp.resimulate(sol.u, sol.h, "refined")
        peaks[tol] = tr.peak
        assert drive_use(ocp, tr)["within_drive_limits"]
    reference = PROBLEMS["torque_no_brake"]["reference_peak_over_e"]
    assert peaks[0.0] > reference * (1 + 1e-3) and peaks[DRIVE_TOL] < reference
