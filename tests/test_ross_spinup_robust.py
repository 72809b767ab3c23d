"""The robust spin-up of the modal (ROSS) rotor through the robust study of the Jeffcott rotor
(autobal.ocp.robust_study.run): the peaks stated in the model's unit and declared (m, shown in µm; delta/e for the
Jeffcott rotor), the modal problem's peaks of a coarse mesh's profile equal to the same profile's on the full mesh
(the mesh continuation of the robust NLP), and the shipped scene end to end."""

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal import scenario
from autobal.analyses import ross_spinup_robust as analysis
from autobal.analysis.run.quantities import display_units
from autobal.models import ross_rotor as rr
from autobal.ocp import modal, modal_search
from autobal.ocp import robust as rb
from autobal.ocp.robust_study import QUANTITIES, peak_text
from tests.test_quantities import check_declared
from tests.test_ross_rotor import disk_rotor, needs_ross


def test_peaks_are_declared_in_the_models_unit():
    """A peak key of the modal rotor's block is declared in m and shown in µm, the Jeffcott rotor's in delta/e; the
    text of a peak follows the unit the block states, never the key's name."""
    for path in ("profiles.robust.validation_worst_{}", "profiles.nominal.design_peaks_{}.3",
                 "profiles.ramp.validation_quantiles_{}.0.99", "ramps.2.validation_worst_{}",
                 "rounds.0.worst_design_peak_{}", "robust_collocation_worst_{}"):
        m, e = QUANTITIES.find(path.format("m")), QUANTITIES.find(path.format("over_e"))
        assert (m.unit, m.display, e.unit) == ("m", "µm", "1"), path
    assert peak_text(2.2222e-5, "m") == "22.22 µm"
    assert peak_text(18.6548, "1", 1e-4) == "18.65 e (1.865 mm)"
    assert peak_text(18.6548, "1") == "18.65 e"
    with display_units({"length": "mm"}):  # a length unit the scene or the CLI chooses
        assert peak_text(2.2222e-5, "m") == "0.02222 mm"


def test_a_coarse_profile_has_the_peaks_of_the_same_profile_on_the_full_mesh():
    """The robust NLP's coarse stage hands the modal problem profiles on N/2 intervals: the screening and the
    CVODES re-simulation of such a profile give the peaks of the same speed profile written on N intervals (the
    screening within its 0.5 %, CVODES within the sampling of the peak)."""
    red = rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5)
    ocp = modal.ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), settling_time=0.3, omega_max=150.0, intervals=30)
    coarse = modal_search.phase_profiles(ocp.on_intervals(15), 80.0, -1.0, 0.2, 120.0)[0]
    fine = np.repeat(coarse, 2)
    fast = np.array([rb.fast_peaks(ocp, np.ones((1, 3)), [rb.Profile(k, v)])[0, 0] for k, v in (("c", coarse),
                                                                                                ("f", fine))])
    assert_allclose(fast[0], fast[1], rtol=5e-3)
    slow = [rb.cvodes_peaks(ocp, np.ones((1, 3)), rb.Profile(k, u))[0] for k, u in (("c", coarse), ("f", fine))]
    assert_allclose(slow[0], slow[1], rtol=1e-3)
    assert_allclose(fast, slow, rtol=1e-2)


@pytest.mark.cli
@pytest.mark.slow
@needs_ross
def test_shipped_scene_end_to_end(shipped_run):
    """ross_spinup_robust through autobal.run: every number of its block declared (peaks in m), the verdict ok;
    over the validation sample the robust profile's worst peak, re-simulated by CVODES, is below the nominal
    optimum's (CVODES on the robust profile's five worst screened rotors, the others bounded by the screening
    with a 3 % margin, its measured error 1.8 %; against CVODES on the nominal's worst screened rotor)."""
    run, folder = shipped_run("ross_spinup_robust")
    res = run["ross_spinup_robust"]
    check_declared(folder)
    assert res.peak_unit == "m" and json.loads((folder / "results.json").read_text())["ross_spinup_robust"]
    assert res.verdict()[0] is True
    assert res.modes >= 2 and res.omega_cr_rad_s < 200.0
    scene = scenario.load("ross_spinup_robust")
    s = scene.analyses.ross_spinup_robust
    ocp = analysis.problem(scene, s)
    F = res.validation["factors"]
    u = {k: res.nominal_runs[k].alpha[:s.intervals] / s.max_acceleration for k in ("robust", "nominal")}
    top = np.argsort(-res.validation["robust"])[:5]
    robust_cvodes = rb.cvodes_peaks(ocp, F[top], rb.Profile("robust", u["robust"]))
    assert_allclose(robust_cvodes, res.validation["robust"][top], rtol=3e-2)
    robust_bound = max(robust_cvodes.max(), 1.03 * np.sort(res.validation["robust"])[-6])
    nominal_worst = rb.cvodes_peaks(ocp, F[[int(np.argmax(res.validation["nominal"]))]],
                                    rb.Profile("nominal", u["nominal"]))[0]
    assert robust_bound < nominal_worst
    # the nominal optimum is the better profile on the nominal rotor (re-simulated)
    p = res.profiles
    assert p.nominal.nominal_peak_m <= p.robust.nominal_peak_m * (1 + 1e-3)
    text = res.summary()
    assert "µm" in text and " e (" not in text
    assert "Robust spin-up of a ROSS rotor" in (folder / "report.html").read_text()
    assert {f.name for f in folder.iterdir()} >= {"ross_spinup_robust_profiles.png", "ross_spinup_robust_ramps.csv",
                                                   "ross_spinup_robust_validation.csv", "drive_profile.csv"}
