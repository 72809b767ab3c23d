"""autobal explore's computation (autobal/explore.py, no Bokeh needed): the live fast path gives the batch run's
numbers for a changed setting, the saved scene reproduces the setting, bad settings are refused or reported."""

import dataclasses
import math

import numpy as np
import pytest

import autobal
from autobal.analysis import frequency as fr
from autobal.analysis import stability as st
from autobal.analysis.linearize import Setup
from autobal.explore import DeviceExplorer
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
    f = fr.study(setup, ["nonlinear"], "physical", (o.start, o.stop, o.points)).data["headline"]
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
    assert len(live["peaks"]) == len(f["peaks"]) >= 1
    for a, b in zip(live["peaks"], f["peaks"], strict=True):
        assert a["omega"] == pytest.approx(b["omega"], rel=1e-7)
        assert a["amplitude"] == pytest.approx(b["amplitude"], rel=1e-8)
    assert live["amplitude_at_omega0"] == pytest.approx(f["at_operating_speed"]["amplitude"], rel=1e-8)
    assert live["static_amplitude"] == pytest.approx(f["static_amplitude"], rel=1e-8)
    # the AFC curve by the modal sum against python-control's on the same grid
    np.testing.assert_allclose(live["omega"], f["omega"], rtol=1e-9)  # the grid follows the poles
    np.testing.assert_allclose(live["amplitude"], f["amplitude"], rtol=1e-8)
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
    (["explore", "pump_pe600_statics", "--no-browser"], "device.dynamics"),
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
    """Spin-up: the ramps re-simulated for a changed rotor are the batch run's baselines; the current optimum's
    profile re-simulated for it differs from the batch run until "re-optimise", then equals it."""
    from autobal.explore import SpinupExplorer

    ex = SpinupExplorer("spinup_jeffcott_deadline_5s")
    values = ex.defaults() | {"rotor.damping": 6.2, "rotor.stiffness": 12000.0}
    ans = ex.evaluate(values)
    assert ans["status"] == "no_optimum" and "optimum" not in ans  # nothing shown as the optimum before one exists
    ex.optimise(ex.defaults())
    stale = ex.evaluate(values)["optimum"]
    run = autobal.run(autobal.load(ex.save(values, tmp_path / "spin.yaml")))["spinup"].data
    for key, ramp in ans["ramps"].items():
        assert ramp["peak_over_e"] == pytest.approx(run["baselines"][key]["peak_deflection_over_e"], rel=1e-9), key
        assert ramp["within_drive_limits"] == run["baselines"][key]["within_drive_limits"]
    assert ans["critical_speed"] == pytest.approx(run["omega_cr_rad_s"], rel=1e-12)
    assert stale["optimised_for"] == {} and stale["peak_over_e"] != pytest.approx(run["peak_deflection_over_e"],
                                                                                   rel=1e-6)
    ex.optimise(values)
    fresh = ex.evaluate(values)["optimum"]
    assert fresh["peak_over_e"] == pytest.approx(run["peak_deflection_over_e"], rel=1e-9)
    assert fresh["peak_over_e"] < min(r["peak_over_e"] for r in ans["ramps"].values())
