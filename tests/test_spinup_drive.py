"""The spin-up as a drive takes it (issue #26): the rotor from its datasheet, braking limits, baselines within the
drive limits as the reference of the gain, drive_profile.csv and the K-segment ramp table, each table integrated
independently (scipy, from the CSV alone)."""

from __future__ import annotations

import csv
import dataclasses
import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

import autobal
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.analysis.run.quantities import is_display_unit
from autobal.errors import ScenarioError
from autobal.ocp import spinup_study
from autobal.ocp.columns import COLUMNS, HEADER
from autobal.ocp.search import grid_search
from autobal.parts import rotor as rotor_part

SCENE = "scenarios/spinup_rotor_datasheet.yaml"
SMALL = {"analyses.spinup.intervals": 40, "analyses.spinup.multistart": False}
RPM = 2 * math.pi / 60


def _rows(path):
    return [{k: float(v) for k, v in r.items()} for r in _rows_text(path)]


def _rows_text(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


def read_csv_columns(path) -> dict:
    """A CSV file as header -> column, numbers as floats, words as they are."""
    def value(x):
        try:
            return float(x)
        except ValueError:
            return x

    rows = _rows_text(path)
    return {k: [value(r[k]) for r in rows] for k in rows[0]}


def jeffcott_peak(t, w, rotor) -> float:
    """Peak |u|/e of the Jeffcott rotor m u'' + chi u' + c u = m e (w^2 - i alpha) e^(i beta) (fixed frame, SI)
    driven by the piecewise-linear speed through the rows (t, w), from the steady whirl at w[0]; scipy DOP853."""
    m, c, chi, e = rotor["mass_kg"], rotor["stiffness_N_per_m"], rotor["damping_N_s_per_m"], rotor["eccentricity_m"]
    t, w = np.asarray(t), np.asarray(w)
    keep = np.concatenate([[True], np.diff(t) > 0])
    t, w = t[keep], w[keep]
    slope = np.diff(w) / np.diff(t)

    def rhs(s, y):
        k = min(max(np.searchsorted(t, s, side="right") - 1, 0), len(slope) - 1)
        om = w[k] + slope[k] * (s - t[k])
        f = m * e * (om**2 - 1j * slope[k]) * np.exp(1j * y[4])
        u, v = y[0] + 1j * y[1], y[2] + 1j * y[3]
        a = (f - chi * v - c * u) / m
        return [v.real, v.imag, a.real, a.imag, om]

    u0 = m * e * w[0] ** 2 / (c - m * w[0] ** 2 + 1j * chi * w[0])
    v0 = 1j * w[0] * u0
    ts = np.linspace(t[0], t[-1], 40001)
    sol = solve_ivp(rhs, (t[0], t[-1]), [u0.real, u0.imag, v0.real, v0.imag, 0.0], method="DOP853", rtol=1e-10,
                    atol=1e-12 * e, t_eval=ts, max_step=(t[-1] - t[0]) / 4000)
    assert sol.success
    return float(np.max(np.hypot(sol.y[0], sol.y[1])) / e)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("drive")
    scene = autobal.load(SCENE, set={**SMALL, "analyses.spinup.segments": 2})
    autobal.run(scene, out=out)
    return out, json.loads((out / "results.json").read_text())["spinup"]


@pytest.mark.cli
def test_drive_profile_csv_integrated_independently_matches_the_reported_peak(run):
    out, res = run
    rows = _rows(out / "drive_profile.csv")
    t = np.array([r["time [s]"] for r in rows])
    w = np.array([r["speed [rad/s]"] for r in rows])
    # the columns agree with each other: rpm beside rad/s, the acceleration the slope of the speed, P = M omega
    assert_allclose([r["speed [rpm]"] * RPM for r in rows], w, rtol=1e-12)
    assert_allclose([r["acceleration [rpm/s]"] * RPM for r in rows], [r["acceleration [rad/s²]"] for r in rows],
                    rtol=1e-12)
    assert_allclose(np.diff(w) / np.diff(t), [r["acceleration [rad/s²]"] for r in rows[1:]], rtol=1e-6, atol=1e-6)
    assert_allclose([r["power [kW]"] for r in rows], [r["torque [N·m]"] * r["speed [rad/s]"] * 1e-3 for r in rows],
                    rtol=1e-12)
    assert t[-1] == pytest.approx(8.0)
    assert_allclose(jeffcott_peak(t, w, res["rotor"]), res["peak_deflection_over_e"], rtol=1e-3)


@pytest.mark.cli
def test_segment_table_integrated_independently_matches_the_reported_peak(run):
    out, res = run
    rows = _rows(out / "drive_segments.csv")
    assert len(rows) in (2, 3)  # two ramp segments, then the hold to the end of the window if any
    t = [rows[0]["t_start [s]"]] + [r["t_end [s]"] for r in rows]
    w = [rows[0]["speed_start [rpm]"] * RPM] + [r["speed_end [rpm]"] * RPM for r in rows]
    for r in rows:
        assert r["rate [rpm/s]"] == pytest.approx((r["speed_end [rpm]"] - r["speed_start [rpm]"]) /
                                                (r["t_end [s]"] - r["t_start [s]"]), rel=1e-9)
        assert r["rate [rad/s²]"] <= 60.0 * (1 + 1e-3)  # the acceleration limit
    assert w[0] == pytest.approx(600 * RPM) and w[-1] == pytest.approx(4000 * RPM)
    assert t[-1] == pytest.approx(8.0)
    seg = res["segments"]
    assert_allclose(jeffcott_peak(t, w, res["rotor"]), seg["peak_deflection_over_e"], rtol=1e-3)
    # a coarser profile than the optimum: it loses against it, and keeps every drive limit
    assert seg["loss_vs_optimum_pct"] >= -0.1
    assert seg["within_drive_limits"]
    assert seg["max_power_W"] <= 45e3 * 1.001 and seg["min_torque_N_m"] >= -0.15


@pytest.mark.cli
def test_every_spinup_csv_is_headed_name_unit_in_the_display_unit(run):
    """Every column of the spin-up's CSV files is 'name [unit]' in a display unit of its declaration (no word columns),
    the numbers in the unit the header names: the largest power in kW and torque in N·m are those of results.json."""
    out, res = run
    tables = {f.name: read_csv_columns(f) for f in out.glob("*.csv")}
    assert set(tables) == {"drive_profile.csv", "drive_segments.csv", "spinup_baselines.csv", "spinup_controls.csv",
                           "spinup_optimum.csv"}
    for name, cols in tables.items():  # each header 'name [unit]', the unit a display unit of the column's declaration
        for header in cols:
            m = HEADER.fullmatch(header)
            assert m is not None and is_display_unit(m["unit"], COLUMNS.find(m["name"]).unit), (name, header)
    assert list(tables["drive_profile.csv"]) == ["time [s]", "speed [rpm]", "speed [rad/s]", "acceleration [rpm/s]",
                                                 "acceleration [rad/s²]", "torque [N·m]", "power [kW]"]
    assert list(tables["drive_segments.csv"]) == ["segment [1]", "t_start [s]", "t_end [s]", "speed_start [rpm]",
                                                  "speed_start [rad/s]", "speed_end [rpm]", "speed_end [rad/s]",
                                                  "rate [rpm/s]", "rate [rad/s²]"]
    drive = tables["drive_profile.csv"]
    assert max(drive["power [kW]"]) == pytest.approx(res["max_power_W"] / 1e3, rel=1e-9)
    assert max(drive["torque [N·m]"]) == pytest.approx(res["max_torque_N_m"], rel=1e-9)


def test_spinup_table_headers_follow_the_display_units_and_read_back_si(tmp_path):
    """headed(): speeds in the unit chosen for their kind with the twin beside, an undeclared number refused;
    read_table() gives the SI table back, exactly from the SI twin."""
    from autobal.analysis.run.quantities import display_units
    from autobal.analysis.run.result import write_csv
    from autobal.ocp.columns import headed, read_table

    table = {"time": [0.0, 0.5], "speed": [10.0, 2 * math.pi * 7 / 3], "acceleration": [1 / 3, 0.0],
             "power": [1234.5, 0.0], "label": ["a", "b"]}
    assert list(headed(table)) == ["time [s]", "speed [rpm]", "speed [rad/s]", "acceleration [rpm/s]",
                                   "acceleration [rad/s²]", "power [kW]", "label"]
    with display_units({"speed": "Hz", "power": "W"}):
        cols = headed(table)
    assert list(cols) == ["time [s]", "speed [Hz]", "speed [rpm]", "acceleration [rpm/s]", "acceleration [rad/s²]",
                          "power [W]", "label"]
    assert cols["speed [Hz]"] == pytest.approx([10.0 / (2 * math.pi), 7 / 3], rel=1e-15)
    assert cols["speed [rpm]"] == pytest.approx([10.0 / RPM, 140.0], rel=1e-15)
    assert headed(table)["power [kW]"] == [1.2345, 0.0]
    back = read_table(write_csv(tmp_path / "t.csv", headed(table)))
    assert back["power"] == pytest.approx(table["power"], rel=1e-15)  # kW converted back
    assert back | {"power": table["power"]} == table  # the rest exactly: the SI twin
    back = read_table(write_csv(tmp_path / "hz.csv", cols))
    assert back["speed"] == pytest.approx(table["speed"], rel=1e-15) and back["power"] == table["power"]
    with pytest.raises(ValueError, match="column 'wobble' is not declared"):
        headed({"wobble": [1.0]})


@pytest.mark.cli
def test_every_baseline_a_percentage_refers_to_keeps_the_drive_limits(run):
    out, res = run
    J, tmax, pmax = 2.0, 150.0, 45e3
    base = res["baselines"]
    ref = res["baseline_ramp_key"]
    assert ref is not None and base[ref]["within_drive_limits"]
    # the 60 rad/s^2 ramp needs J alpha omega_f = 50.3 kW at the top speed: outside the limits, never a reference
    assert not base["max_acceleration_ramp"]["within_drive_limits"]
    assert base["max_acceleration_ramp"]["violated"] == ["power limit"]
    assert ref == "feasible_ramp"
    rows = _rows(out / "spinup_baselines.csv")
    t = np.array([r["time [s]"] for r in rows])
    for key in (ref, "constant_ramp"):  # both are quoted as percentages
        b = base[key]
        assert b["max_torque_N_m"] <= tmax * 1.001 and b["max_power_W"] <= pmax * 1.001
        assert b["min_torque_N_m"] >= -1e-3 * tmax  # no braking in this scene
        # independently from the CSV: the inertial torque J alpha and its power J alpha omega (the rotor's reaction,
        # below 1 N m here, aside)
        w = np.array([r[f"{key}_speed [rad/s]"] for r in rows])
        alpha = np.diff(w) / np.diff(t)
        assert np.max(J * alpha) <= tmax * 1.01
        assert np.max(J * alpha * w[1:]) <= pmax * 1.01
        assert np.min(alpha) >= -1e-6
    # the numbers: the fastest ramp and hold within 45 kW is power-limited at the top speed,
    # 45 kW / (2 kg m^2 x 418.9 rad/s) = 53.7 rad/s^2, and peaks at 20.82 e (issue #26: about 53.6, 20.83 e)
    assert "53.71 rad/s² (512.9 rpm/s)" in base[ref]["label"]
    assert base[ref]["peak_deflection_over_e"] == pytest.approx(20.83, abs=0.02)
    gain = res["gain_vs_best_feasible_ramp_pct"]
    assert gain == pytest.approx(100 * (res["peak_deflection_over_e"] / base[ref]["peak_deflection_over_e"] - 1))
    assert gain < 0


@pytest.mark.cli
def test_no_braking_keeps_the_torque_nonnegative_and_the_summary_says_so(run):
    out, res = run
    assert res["braking_torque_limit_N_m"] == 0.0
    assert res["brakes"] is False
    assert res["min_torque_N_m"] >= -1e-3 * 150
    assert res["within_drive_limits"]


def test_braking_allowed_by_default_and_the_optimum_may_brake():
    scene = autobal.load(SCENE, set={**SMALL, "analyses.spinup.segments": 0, "rotor.drive.max_braking_torque": None})
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    assert ocp.torque_bounds == (-150.0, 150.0)
    res = spinup_study.run(ocp, spinup_study.method_of(scene.analyses.spinup), multistart=False)
    assert res.braking_torque_limit_N_m == 150.0
    assert res.brakes == (res.min_torque_N_m < -0.15)
    assert res.min_torque_N_m >= -150 * 1.001
    assert "brake" in res.summary()


def test_deceleration_limit_bounds_the_control():
    scene = autobal.load(SCENE, set={**SMALL, "rotor.drive.max_deceleration": "0 rad/s^2"})
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    assert ocp.u_min == 0.0
    scene = autobal.load(SCENE, set={**SMALL, "rotor.drive.max_deceleration": "15 rad/s^2"})
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    assert ocp.u_min == pytest.approx(-0.25)
    # the global search draws its middle phase within the limit too (without it, down to -alpha_max)
    found = grid_search(ocp, keep=8)
    assert found.params.size and found.params[:, 2].min() >= -0.25 - 1e-12
    assert grid_search(dataclasses.replace(ocp, alpha_min=None), keep=8).params[:, 2].min() < -0.25


def _si_scene(rotor):
    return {"name": "r", "title": "r", "source": "test", "rotor": rotor,
            "analyses": {"spinup": {"start_speed": "600 rpm", "final_speed": "4000 rpm", "horizon": "8 s",
                                    "max_acceleration": "60 rad/s^2", "intervals": 40, "multistart": False,
                                    "segments": 0}}}


def test_datasheet_rotor_gives_the_same_optimum_as_the_rotor_in_si(tmp_path):
    import yaml

    sheet = {"mass": "120 kg", "critical_speed": "2400 rpm", "damping_ratio": 0.02,
             "unbalance": {"grade": "G2.5", "service_speed": "3000 rpm"}}
    wc = 2400 * RPM
    e = 2.5e-3 / (3000 * RPM)  # ISO 21940-11: e = G / Omega_service
    si = {"mass": "120 kg", "stiffness": f"{120 * wc**2!r} N/m", "damping": f"{2 * 0.02 * 120 * wc!r} N*s/m",
          "eccentricity": f"{e!r} m"}
    out = {}
    for key, rotor in (("sheet", sheet), ("si", si)):
        (tmp_path / f"{key}.yaml").write_text(yaml.safe_dump(_si_scene(rotor)))
        scene = autobal.load(tmp_path / f"{key}.yaml")
        p = rotor_part.adapt(scene.rotor)
        out[key] = (p, spinup_study.run(spinup_ocp(scene, scene.analyses.spinup),
                                        spinup_study.method_of(scene.analyses.spinup), multistart=False))
    p = out["sheet"][0]
    assert_allclose([p.m1, p.c, p.chi, p.e], [120, 120 * wc**2, 2 * 0.02 * 120 * wc, e], rtol=1e-12)
    assert p.zeta0 == pytest.approx(0.02, rel=1e-12) and p.Omega0 == pytest.approx(wc, rel=1e-12)
    a, b = out["sheet"][1], out["si"][1]
    assert_allclose(a.peak_deflection_over_e, b.peak_deflection_over_e, rtol=1e-9)
    assert_allclose(a.peak_deflection_m, b.peak_deflection_m, rtol=1e-9)
    r = a.rotor
    assert r.critical_speed_rad_s == pytest.approx(wc)
    assert r.damping_ratio == pytest.approx(0.02)
    assert r.amplification_factor == pytest.approx(24.96, abs=0.005)  # API 684: half-power points, not 1/(2 zeta)
    assert r.separation_margin_pct == pytest.approx(100 * (4000 - 2400 / math.sqrt(1 - 8e-4)) / 4000)  # from N_s
    assert a.peak_deflection_m == pytest.approx(a.peak_deflection_over_e * e)


def test_residual_unbalance_in_g_mm():
    scene = autobal.load(SCENE)
    assert rotor_part.adapt(scene.rotor).e == pytest.approx(6000e-6 / 120)  # 6000 g*mm / 120 kg = 50 um


@pytest.mark.parametrize("rotor, match", [
    ({"stiffness": "1e6 N/m"}, "exactly one of stiffness and critical_speed"),
    ({"critical_speed": None}, "exactly one of stiffness and critical_speed"),
    ({"damping": "10 N*s/m"}, "exactly one of damping and damping_ratio"),
    ({"unbalance": {"grade": "G2.5"}}, "grade .* together with service_speed"),
    ({"unbalance": {"grade": "2.5", "service_speed": "3000 rpm"}}, "balance quality grade is G"),
    ({"unbalance": {"residual": "6 kg"}}, "unbalance"),
])
def test_datasheet_refusals_name_the_field(rotor, match):
    with pytest.raises(ScenarioError, match=match):
        autobal.load(SCENE, set={f"rotor.{k}": v for k, v in rotor.items()})


@pytest.mark.parametrize("solver", ["ipopt", "fatrop"])
def test_settling_no_braking_rows_keep_drive_tol_and_the_screening_keeps_them_as_stated(solver):
    """Without braking (rotor.drive.max_braking_torque 0), the torque rows' lower bound is 0 on the horizon and
    -DRIVE_TOL (of the torque limit) over the settling window, where the speed is held (transcription
    relax_settling_brake); brake_tol=0, as the coarse screening builds it, keeps them all at 0.  The upper bound
    (the torque limit) is never touched.  Both the collocation NLP and fatrop's stage form."""
    from autobal.ocp import solve
    from autobal.ocp.transcription import DRIVE_TOL

    scene = autobal.load(SCENE, set={**SMALL, "analyses.spinup.settling_time": "1 s"})
    ocp = spinup_ocp(scene, scene.analyses.spinup)
    method = dataclasses.replace(spinup_study.method_of(scene.analyses.spinup), intervals=20, solver=solver)
    assert ocp.torque_bounds[0] == 0.0 and ocp.tau_s > 0
    for tol in (DRIVE_TOL, 0.0):
        nlp = solve.Solver(ocp, method, None, None, brake_tol=tol).nlp
        rows = dict(nlp.blocks)[next(n for n, _ in nlp.blocks if n.startswith("torque limit"))]
        K, n = nlp.mesh.n + nlp.mesh.ns, nlp.mesh.n
        rows = np.sort(rows) if solver == "fatrop" else rows  # the stage form's rows run stage by stage
        horizon, settle = rows[:len(rows) // K * n], rows[len(rows) // K * n:]
        assert settle.size and np.all(nlp.lbg[horizon] == 0.0)
        assert np.all(nlp.lbg[settle] == -tol)
        assert np.all(nlp.ubg[rows] == 1.0)
