"""autobal explore's computation (autobal/explore.py, no Bokeh needed): the live fast path gives the batch run's
numbers for a changed setting, the saved scene reproduces the setting, bad settings are refused or reported."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import autobal
from autobal.analysis.numerics import frequency as fr
from autobal.analysis.numerics import stability as st
from autobal.analysis.numerics.linearize import Setup
from autobal.explore import DeviceExplorer, SpinupExplorer, StaticsExplorer
from autobal.parts.device import dynamic_device

SCENE = "pump_pe600_dynamics"
CHANGED = {"device.disc.face.base_gap": 0.17, "device.dynamics.cavity_volume": 2.3e-4,
           "device.dynamics.regulator.spring_stiffness": 1.3e7, "device.regulator.supply_pressure": 42.5,
           "device.disc.outer_seal.clearance": 0.32}


@pytest.fixture(scope="module")
def explorer():
    return DeviceExplorer(SCENE)


def batch(scene):
    """The batch path of analyses.frequency and analyses.stability on a scene: IPOPT statics, the model
    built at its point, python-control's AFC (headline: energy-consistent model, physical forcing)."""
    setup = Setup(dynamic_device(scene), scene.analyses.frequency.operating_ratio)
    o = scene.analyses.frequency.omega
    f = fr.study(setup, ["nonlinear"], "physical", (o.start, o.stop, o.points)).head
    return setup, f, st.verdict(setup.linear("nonlinear"))  # the headline verdict of analyses.stability


def test_sliders_are_the_scene_values_within_their_declared_bounds(explorer):
    params = {p.path: p for p in explorer.params}
    assert params["device.disc.face.base_gap"].unit == "mm" and params["device.disc.face.base_gap"].value == 0.15
    assert params["device.dynamics.cavity_volume"].unit == "m^3"
    assert params["device.operating.impeller.speed"].unit == "rpm"
    for p in explorer.params:
        assert p.start <= p.value <= p.end, p.path
        assert p.start >= 0, p.path  # every declared quantity here is nonnegative or positive
    assert params["device.regulator.valve.discharge_coefficient"].end == 1  # declared le=1
    # the conversion is the scene loader's: 0.17 mm -> SI exactly as --set reads it
    assert params["device.disc.face.base_gap"].si(0.17) == autobal.load(
        SCENE, set={"device.disc.face.base_gap": "0.17 mm"}).device.disc.face.base_gap


def test_live_numbers_equal_the_batch_run(explorer):
    """Every number the page shows for a changed setting equals the batch path's (IPOPT statics, the model
    rebuilt at its point, python-control) to the solvers' tolerance."""
    values = explorer.defaults() | CHANGED
    live = explorer.evaluate(values)
    assert live["status"] == "ok", live["message"]
    scene = autobal.load(SCENE, set=explorer.overrides(values))
    setup, f, s = batch(scene)
    z_b = setup.dev.scales["z_B"]
    assert live["gap"] == pytest.approx(setup.static.values["u"] * z_b, rel=1e-8)
    assert live["leak"] == pytest.approx(setup.static.flows["e"] * setup.dev.scales["Q_scale"], rel=1e-8)
    for k, v in live["pressures"].items():
        assert v == pytest.approx(setup.static.values[k] * setup.dev.scales["p_B"], rel=1e-8), k
    assert live["decay_rate"] == pytest.approx(s["margin"]["decay_rate"], rel=1e-8)
    assert live["min_damping_ratio"] == pytest.approx(s["margin"]["min_damping_ratio"], rel=1e-8)
    np.testing.assert_allclose(np.sort_complex(live["poles"]["real"] + 1j * live["poles"]["imag"]),
                               np.sort_complex(np.asarray(s["poles"]["real"]) + 1j * np.asarray(s["poles"]["imag"])),
                               rtol=1e-8)
    assert live["stable"] == s["stable"]
    assert len(live["peaks"]) == len(f.peaks) >= 1
    for a, b in zip(live["peaks"], f.peaks, strict=True):
        assert a["omega"] == pytest.approx(b.omega, rel=1e-7)
        assert a["amplitude"] == pytest.approx(b.amplitude, rel=1e-8)
    assert live["amplitude_at_omega0"] == pytest.approx(f.at_operating_speed.amplitude, rel=1e-8)
    assert live["static_amplitude"] == pytest.approx(f.static_amplitude, rel=1e-8)
    # the AFC curve by the modal sum against python-control's on the same grid
    np.testing.assert_allclose(live["omega"], f.omega, rtol=1e-9)  # the grid follows the poles
    np.testing.assert_allclose(live["amplitude"], f.amplitude, rtol=1e-8)
    assert explorer.check(values, live) == ""  # IPOPT agrees, the scene's checks pass


def test_saved_scene_reproduces_the_setting(explorer, tmp_path):
    values = explorer.defaults() | CHANGED
    path = explorer.save(values, tmp_path / "explored.yaml")
    text = path.read_text()
    assert "0.17 mm" in text and "42.5 MPa" in text  # in the scene's own units
    saved = dynamic_device(autobal.load(path))
    assert saved == explorer.device(values)  # the same SI parameters, number for number
    assert dataclasses.asdict(dynamic_device(autobal.load(explorer.save(explorer.defaults(), tmp_path / "d.yaml")))) \
        == dataclasses.asdict(dynamic_device(autobal.load(SCENE)))


@pytest.mark.parametrize(("path", "value", "status", "words"), [
    ("device.disc.face.inner_diameter", 300.0, "refused", "outer_diameter must be larger than inner_diameter"),
    ("device.regulator.supply_pressure", 8.0, "no_statics", "regulator valve on its stop"),
    ("device.operating.nominal_pressure", 6.5, "no_statics", "face in contact"),
])
def test_bad_settings_are_reported_and_the_next_good_one_recovers(explorer, path, value, status, words):
    ans = explorer.evaluate(explorer.defaults() | {path: value})
    assert ans["status"] == status and words in ans["message"]
    assert "decay_rate" not in ans  # no dynamics number for a setting without a regulated operating point
    good = explorer.evaluate(explorer.defaults())
    # the shipped scene's headline decay rate, as the batch stability analysis gives it (-max Re lambda = 82.64 1/s)
    assert good["status"] == "ok" and good["decay_rate"] == pytest.approx(82.6444322, rel=1e-6)


def test_a_crossed_margin_turns_the_verdict(explorer):
    """A larger cavity volume makes the energy-consistent model unstable (Pavlenko (2014), §2.6's map axis)."""
    ans = explorer.evaluate(explorer.defaults() | {"device.dynamics.cavity_volume": 5e-4})
    assert ans["status"] == "ok" and not ans["stable"] and not ans["meets_requirement"]
    assert ans["decay_rate"] < 0 and math.isfinite(ans["decay_rate"])


@pytest.mark.cli
@pytest.mark.parametrize(("argv", "words"), [
    (["explore", "hydroheel_wear", "--no-browser"], "explore needs a scene with device.dynamics"),
    (["explore", "pump_pe600_dynamics", "--no-browser", "--port", "70000"], "--port 70000"),
])
def test_explore_command_refuses_bad_input_with_exit_2(argv, words, capsys):
    from autobal import cli

    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert words in err or "pip install 'autobal[explore]'" in err  # without the extra: the one line saying so


@pytest.mark.slow
@pytest.mark.cli
def test_spinup_page_numbers_equal_autobal_run_after_reoptimising(tmp_path):
    """Spin-up: the ramps re-simulated for a changed rotor and drive (its acceleration limit) are the batch run's
    baselines; the current optimum's speed profile re-simulated for them (the same accelerations for the same
    seconds: 40 -> 210 rad/s by 5 s, held 3 s, whatever the rotor's critical speed that scales the problem) differs
    from the batch run until "re-optimise", then equals it."""
    ex = SpinupExplorer("spinup_jeffcott_deadline_5s")
    assert [p.path for p in ex.params][-1] == "analyses.spinup.max_acceleration" and ex.params[-1].unit == "rad/s^2"
    values = ex.defaults() | {"rotor.damping": 6.2, "rotor.stiffness": 12000.0,
                              "analyses.spinup.max_acceleration": 45.0}
    ans = ex.evaluate(values)
    assert ans["status"] == "no_optimum" and "optimum" not in ans  # nothing shown as the optimum before one exists
    ex.optimise(ex.defaults())
    stale = ex.evaluate(values)["optimum"]
    run = autobal.run(autobal.load(ex.save(values, tmp_path / "spin.yaml")))["spinup"].to_dict()
    for key, ramp in ans["ramps"].items():
        assert ramp["peak_over_e"] == pytest.approx(run["baselines"][key]["peak_deflection_over_e"], rel=1e-9), key
        assert ramp["within_drive_limits"] == run["baselines"][key]["within_drive_limits"]
    assert ans["critical_speed"] == pytest.approx(run["omega_cr_rad_s"], rel=1e-12)
    for key in ("amplification_factor", "separation_margin_pct", "required_separation_margin_pct",
                "separation_margin_ok"):  # API 684 of the changed rotor, as the batch study's rotor block
        assert ans["api"][key] == pytest.approx(run["rotor"][key], rel=1e-12), key
    assert stale["optimised_for"] == {} and stale["peak_over_e"] != pytest.approx(run["peak_deflection_over_e"],
                                                                                   rel=1e-6)
    assert stale["t"][-1] == pytest.approx(8.0, rel=1e-12) and stale["omega"][-1] == pytest.approx(210.0, rel=1e-9)
    ex.optimise(values)
    fresh = ex.evaluate(values)["optimum"]
    assert fresh["peak_over_e"] == pytest.approx(run["peak_deflection_over_e"], rel=1e-9)
    assert fresh["peak_over_e"] < min(r["peak_over_e"] for r in ans["ramps"].values())


# ---- the statics page (a device-statics scene) ---------------------------------------------------------------------

STATICS = "pump_pe600_statics"
STATICS_CHANGED = {"device.regulator.supply_pressure": 42.0, "device.barrier.supply_throttle.diameter": 3.2}


@pytest.fixture(scope="module")
def statics_explorer():
    return StaticsExplorer(STATICS)


def assert_statics_equal(live: dict, block: dict, rel: float = 1e-8):
    """The live statics against the batch study's results.json block (IPOPT): operating point, criticals,
    characteristic, verdict."""
    from autobal.analysis.studies.statics_study import StaticsResult

    ex, crit, sw = block["exact"], block["critical_exact"], block["sweep"]
    assert live["gap"] == pytest.approx(ex["z0"], rel=rel)
    assert live["leak"] == pytest.approx(ex["Q_e"], rel=rel)
    assert live["inner_seal_flow"] == pytest.approx(ex["Q_1"], rel=rel)
    assert live["dp"] == pytest.approx(ex["dp"], rel=rel)
    for k, key in (("psi2", "p2"), ("psi3", "p3"), ("psi_e", "pe"), ("psi_cam", "pcam")):
        assert (live["pressures"][k] == pytest.approx(ex[key], rel=rel)) if key in ex else k not in live["pressures"]
    for key in ("p1_kr", "dp_kr", "psi1_kr", "dpsi_kr"):
        assert live["critical"][key] == pytest.approx(crit[key], rel=rel), key
    assert live["margin_to_p1_kr"] == pytest.approx(crit["p1_kr"] - ex["p1"], rel=rel)
    assert live["verdict"] == StaticsResult.from_dict(block).verdict()
    np.testing.assert_allclose(live["sweep"]["p1"], np.asarray(sw["psi1"]) * block["scales"]["p_B"], rtol=1e-12)
    np.testing.assert_allclose(live["sweep"]["gap"], np.asarray(sw["u"]) * block["scales"]["z_B"], rtol=rel)
    np.testing.assert_allclose(live["sweep"]["leak"], sw["Q_e"], rtol=rel)
    assert live["sweep"]["saturated"] == list(sw.get("regulator_saturated", [False] * len(sw["psi1"])))
    assert live["sweep"]["contact"] == list(sw["contact"])


@pytest.mark.cli
def test_statics_live_numbers_equal_autobal_run_of_the_saved_scene(statics_explorer, tmp_path):
    """A changed setting: the page's operating point, p1_kr, dp_kr, characteristic and verdict equal ``autobal.run``
    of the scene it saves (IPOPT's operating point, critical and continuation sweep) to the solvers' tolerance."""
    ex = statics_explorer
    values = ex.defaults() | STATICS_CHANGED
    live = ex.evaluate(values)
    assert live["status"] == "ok", live["message"]
    block = autobal.run(autobal.load(ex.save(values, tmp_path / "statics.yaml")), out=tmp_path / "run")[
        "statics"].to_dict()
    assert_statics_equal(live, block)
    # the change moved the numbers: the shipped scene's gap 143.9 µm and p1_kr 39.49 MPa (its own run)
    assert live["critical"]["p1_kr"] > 40e6 and abs(live["gap"] - 143.8646e-6) > 1e-7
    assert any(live["sweep"]["saturated"]) and "regulator saturated" in live["sweep_checks"][0]


@pytest.mark.cli
def test_statics_page_of_a_device_without_regulator(tmp_path):
    """No regulator: no valve rows, the verdict's words for it, p1_kr beyond the sweep's range found all the same;
    equal to autobal.run of the scene."""
    import yaml

    raw = yaml.safe_load((Path(autobal.__file__).parents[1] / "scenarios" / f"{STATICS}.yaml").read_text())
    del raw["device"]["regulator"]
    raw["name"] = "pump_without_regulator"
    path = tmp_path / "noreg.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    ex = StaticsExplorer(path)
    assert not any("regulator" in p.path for p in ex.params)
    values = ex.defaults() | {"device.barrier.supply_throttle.diameter": 3.2}
    live = ex.evaluate(values)
    assert live["status"] == "ok" and not live["has_regulator"] and "psi_cam" not in live["pressures"]
    assert "no regulator" in live["verdict"][1] and live["critical"]["psi1_kr"] > raw["analyses"]["statics"][
        "discharge_ratio"]["stop"]
    block = autobal.run(autobal.load(ex.save(values, tmp_path / "saved.yaml")), out=tmp_path / "run")[
        "statics"].to_dict()
    assert_statics_equal(live, block)


@pytest.mark.cli
def test_statics_characteristic_keeps_its_face_contact_points(statics_explorer):
    """A nominal pressure at which the face is in contact over the whole characteristic (autobal run: contact at
    every one of the 36 discharge ratios, gap < 5e-12 m): every point is drawn, at gap 0 and marked as contact (none
    dropped as "no Newton root": the points Newton misses from the closed form are continued from their solved
    neighbours), leaks equal to the batch sweep's; the sweep's check says so."""
    ex = statics_explorer
    values = ex.defaults() | {"device.operating.nominal_pressure": 6.5}
    live = ex.evaluate(values)["sweep"]
    block = autobal.run(autobal.load(STATICS, set=ex.overrides(values)))["statics"].to_dict()
    sw = block["sweep"]
    assert all(sw["contact"]) and max(sw["u"]) * block["scales"]["z_B"] < 5e-12
    assert all(live["solved"]) and live["contact"] == list(sw["contact"])
    np.testing.assert_array_equal(live["gap"], 0.0)
    np.testing.assert_allclose(live["leak"], sw["Q_e"], rtol=1e-8)
    np.testing.assert_allclose(live["inner_seal_flow"], sw["Q_1"], rtol=1e-8)
    checks = ex.evaluate(values)["sweep_checks"]
    assert checks[0].startswith("face contact in the sweep from p1 = 1.625 MPa") and len(checks) == 1


@pytest.mark.parametrize(("path", "value", "status", "words"), [
    ("device.disc.face.inner_diameter", 300.0, "refused", "outer_diameter must be larger than inner_diameter"),
    ("device.regulator.supply_pressure", 8.0, "ok", "regulator SATURATED, inner-seal flow REVERSED"),
    ("device.operating.nominal_pressure", 6.5, "ok", "face CONTACT"),
])
def test_statics_bad_settings_are_reported(statics_explorer, path, value, status, words):
    """A setting the declarations refuse says why; an operating point on a stop is a failed verdict, in the
    study's words; the next good setting recovers the shipped scene's numbers."""
    ans = statics_explorer.evaluate(statics_explorer.defaults() | {path: value})
    assert ans["status"] == status
    assert words in (ans["message"] if status != "ok" else ans["verdict"][1])
    if status == "ok":
        assert ans["verdict"][0] is False
    good = statics_explorer.evaluate(statics_explorer.defaults())
    # the shipped scene's p1_kr by IPOPT (autobal run pump_pe600_statics: critical_exact.p1_kr = 39.4878 MPa)
    assert good["verdict"][0] and good["critical"]["p1_kr"] == pytest.approx(39487806.18, rel=1e-9)


# ---- the spin-up page: API 684 margins ------------------------------------------------------------------------------

@pytest.mark.parametrize("damping", [None, 2.0])
def test_spinup_af_and_sm_are_the_half_power_reading_of_the_changed_rotor(damping):
    """AF and SM of the page equal the hand calculation for the Jeffcott rotor (no liquid): the unbalance response
    r^2 / sqrt((1 - r^2)^2 + (2 zeta r)^2) peaks at r_p = 1/sqrt(1 - 2 zeta^2), its half-power points are the roots
    x = r^2 of (A^2 - 2) x^2 + A^2 (4 zeta^2 - 2) x + A^2 = 0 (A the peak), AF = r_p / (r_2 - r_1); SM from the
    service (final) speed 210 rad/s; API 684 requires min(16, 17 (1 - 1/(AF - 1.5))) % below the speed range."""
    ex = SpinupExplorer("spinup_jeffcott_deadline_5s")
    values = ex.defaults() | ({} if damping is None else {"rotor.damping": damping})
    api = ex.evaluate(values)["api"]
    m, c = 1.0, 11025.0
    chi = 5.0 if damping is None else damping
    zeta, wn = chi / (2 * math.sqrt(c * m)), math.sqrt(c / m)
    rp = 1 / math.sqrt(1 - 2 * zeta**2)
    peak = rp**2 / math.sqrt((1 - rp**2) ** 2 + (2 * zeta * rp) ** 2)
    x1, x2 = sorted(np.roots([peak**2 - 2, peak**2 * (4 * zeta**2 - 2), peak**2]).real)
    af = rp / (math.sqrt(x2) - math.sqrt(x1))
    assert api["amplification_factor"] == pytest.approx(af, rel=1e-6)
    # the peak speed to the bounded search's precision on a flat top (half_power_readings refines it so)
    assert api["response_peak_speed_rad_s"] == pytest.approx(rp * wn, rel=1e-7)
    assert api["separation_margin_pct"] == pytest.approx(100 * (210 - rp * wn) / 210, rel=1e-7)
    assert api["required_separation_margin_pct"] == pytest.approx(min(16.0, 17 * (1 - 1 / (af - 1.5))), rel=1e-6)
    assert api["separation_margin_ok"] is True
