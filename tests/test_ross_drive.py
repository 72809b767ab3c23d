"""The drive of the modal (ROSS) rotor's spin-up (issue 26, item 2): ``ross_rotor.drive`` gives the Jeffcott
rotor's drive limits (torque, power, motor, braking, deceleration) and the drive's own polar inertia; the torque the
drive needs is J alpha, J from ROSS's mass matrix and the drive's.  The limits are rows of the shared
transcription (:meth:`autobal.ocp.problem.Dimensionless.drive_constraints`), the search draws within the
deceleration limit, and a gain is quoted only against a ramp within the limits."""

import dataclasses

import numpy as np
import pytest

from autobal import api
from autobal.analyses.ross_spinup import drive
from autobal.errors import ScenarioError
from autobal.models import ross_rotor as rr
from autobal.ocp import modal, modal_study
from autobal.ocp.simulation import drive_use
from autobal.ocp.solve import optimize
from tests.test_ross_rotor import Ip, disk_rotor, needs_ross

J_DRIVE = 0.05  # kg m^2, the drive's own


def _ocp(**kw) -> modal.ModalSpinupOcp:
    red = rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5)
    return modal.ModalSpinupOcp(dataclasses.replace(red, polar_inertia=Ip), 50.0, 150.0, 1.5, 100.0, (0,),
                                settling_time=0.3, omega_max=150.0, intervals=30, **kw)


@pytest.fixture(scope="module")
def free_and_no_braking():
    ocp = _ocp()
    return [optimize(p, p.method, options={"max_iter": 300}) for p in (ocp, dataclasses.replace(ocp, alpha_min=0.0))]


def test_no_deceleration_keeps_the_speed_from_falling(free_and_no_braking):
    free, held = free_and_no_braking
    assert free.solution.u.min() < -0.5  # the free optimum backs off before the critical speed
    assert held.solution.u.min() >= -1e-8  # the bound of the shared transcription
    assert held.trajectory.alpha.min() >= -1e-8 * held.ocp.alpha_max
    assert np.all(np.diff(held.trajectory.omega) >= -1e-9 * held.ocp.omega_final)
    # a bound can only cost: the held optimum peaks no lower than the free one (to the re-simulation's accuracy)
    assert held.trajectory.peak >= free.trajectory.peak * (1 - 1e-4)
    for _, u in held.ocp.starts(held.ocp.intervals):  # the four-phase search draws within the limit
        assert u.min() >= -1e-12


def test_the_drive_torque_is_the_inertia_times_the_acceleration(free_and_no_braking):
    tr = free_and_no_braking[0].trajectory
    ocp = free_and_no_braking[0].ocp
    assert ocp.inertia == Ip
    i = np.searchsorted(tr.t_u, 0.7)  # inside an interval: J alpha of that interval
    k = np.flatnonzero((tr.t > tr.t_u[i - 1]) & (tr.t < tr.t_u[i]))
    assert np.all(tr.torque[k] == Ip * tr.alpha[i - 1])
    use = drive_use(ocp, tr)
    assert use["min_torque_N_m"] == pytest.approx(Ip * tr.alpha.min())
    assert use["max_power_W"] == pytest.approx(np.max(tr.torque * tr.omega))


def test_power_limit_binds_and_the_gain_is_quoted_against_a_feasible_ramp():
    """1 kW with J = Ip + 0.05 kg m^2: the 100 rad/s^2 ramp needs 0.13 x 100 x 150 = 1950 W at the top speed; the
    fastest ramp within the limit is 1000/(0.13 x 150) = 51.3 rad/s^2, slower than the constant ramp (66.7 rad/s^2),
    which breaks it too: no ramp keeps the limit, and no gain is quoted (the optimum, on the limit above 77 rad/s,
    arrives in 1.35 s of the 1.5).  With 1.5 kW the fastest is 76.9 rad/s^2.  With 600 W the deadline cannot be
    met (J (w_f^2 - w_0^2) / 2P = 2.17 s at the limit): the problem is refused before any solve."""
    with pytest.raises(ValueError, match=r"from 50 to 150 rad/s in 2\.167 s at the earliest, after the horizon 1\.5 s"):
        _ocp(drive_inertia=J_DRIVE, power_max=600.0)
    for power, feasible in ((1000.0, None), (1500.0, 1500.0 / ((Ip + J_DRIVE) * 150.0))):
        ocp = _ocp(drive_inertia=J_DRIVE, power_max=power)
        base = modal.baselines(ocp)
        use = {k: drive_use(ocp, v) for k, v in base.items()}
        assert use["max_acceleration_ramp"]["violated"] == ["power limit"]
        res = modal_study.run(ocp, "t", None, {"max_iter": 300})
        d = res.to_dict()
        assert d["within_drive_limits"] and d["max_power_W"] <= power * (1 + 1e-3)
        assert d["max_power_W"] >= 0.9 * power  # the limit binds
        if feasible is None:
            assert "feasible_ramp" not in base and d["baseline_ramp_key"] is None
            assert d["improvement_over_best_ramp"] is None and d["improvement_over_best_ramp_status"]
            assert "no gain is quoted" in res.verdict()[1]
        else:
            assert base["feasible_ramp"].alpha.max() == pytest.approx(feasible)
            assert use["feasible_ramp"]["within_drive_limits"]
            key = d["baseline_ramp_key"]
            assert d["baselines"][key]["within_drive_limits"]
            assert d["improvement_over_best_ramp"] == pytest.approx(1 - d["peak_deflection_m"] / base[key].peak)
            # the figures draw every ramp, the one outside the limits dotted and labelled so
            lines = {ln.get_label(): ln.get_linestyle() for ln in res.figures()["ross_spinup_profiles.png"].axes[0]
                     .get_lines()}
            assert lines[base["max_acceleration_ramp"].label + " (outside the drive limits)"] == ":"
            assert lines[base["feasible_ramp"].label] == "--"
            # drive_profile.csv: the speed is the integral of the acceleration column, the torque J alpha
            c = {k: np.asarray(v) for k, v in res.tables()["drive_profile.csv"].items()}
            t, w, a = c["time [s]"], c["speed [rad/s]"], c["acceleration [rad/s²]"]
            np.testing.assert_allclose(w[1:], w[0] + np.cumsum(a[1:] * np.diff(t)), rtol=1e-9, atol=1e-6)
            np.testing.assert_allclose(c["torque [N·m]"], (Ip + J_DRIVE) * a, rtol=1e-12)
            np.testing.assert_allclose(c["power [kW]"], c["torque [N·m]"] * w / 1e3, rtol=1e-12)
            np.testing.assert_allclose(c["speed [rpm]"], w * 30 / np.pi, rtol=1e-12)


def test_scene_drive_section_reaches_the_problem():
    scene = api.load("spinup_ross_rotor", set={"ross_rotor.drive.max_deceleration": "0 rad/s^2",
                                               "ross_rotor.drive.max_power": "2 kW",
                                               "ross_rotor.drive.polar_inertia": "0.1 kg*m^2"})
    kw = drive(scene)
    assert kw["alpha_min"] == 0.0 and kw["power_max"] == 2000.0 and kw["drive_inertia"] == 0.1
    assert kw["torque_max"] is None and kw["braking_torque_max"] is None
    assert drive(api.load("spinup_ross_rotor")) == {}
    with pytest.raises(ScenarioError, match=r"ross_rotor.drive.max_deceleration: must not be negative"):
        api.load("spinup_ross_rotor", set={"ross_rotor.drive.max_deceleration": "-1 rad/s^2"})
    with pytest.raises(ValueError, match="minimum acceleration must not be positive"):
        _ocp(alpha_min=1.0)
    red = rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5)
    with pytest.raises(ValueError, match="polar inertia"):  # the test rotor without inertia, a power limit
        modal.ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), intervals=30, power_max=1000.0)


@pytest.mark.slow
@needs_ross
def test_rotor_polar_inertia_is_the_disks_and_the_shaft():
    import ross as rs

    rotor = rs.rotor_example()
    shaft = sum(s.m * (s.odl**2 + s.idl**2) / 8 for s in rotor.shaft_elements)  # m (r_o^2 + r_i^2)/2
    disks = sum(d.Ip for d in rotor.disk_elements)
    assert rr.lateral_matrices(rotor).polar_inertia == pytest.approx(disks + shaft, rel=1e-9)


@pytest.mark.parametrize("name, key", [("ross_spinup_robust", "ross_spinup_robust"),
                                       ("ross_spinup_time_optimal", "ross_spinup_time_optimal")])
def test_robust_and_time_optimal_refuse_a_drive_section(name, key):
    from autobal.analyses import ross_spinup

    scene = api.load(name, set={"ross_rotor.drive.max_power": "2 kW"})
    with pytest.raises(ScenarioError, match=rf"^analyses.{key}: ross_rotor.drive: .* acceleration limit only"):
        ross_spinup.problem(scene, getattr(scene.analyses, key), key)
