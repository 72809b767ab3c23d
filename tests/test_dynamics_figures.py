"""The device-dynamics figures say what they show: headline model first, unwrapped phase, coinciding and
unstable curves marked, one colour scale for the stability maps, maps in physical units."""

import numpy as np
import pytest

from autobal import scenario
from autobal.analysis.numerics import frequency, stability
from autobal.analysis.numerics.linearize import Setup
from autobal.parts import device as device_part


@pytest.fixture(scope="module")
def pump():
    return Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device))


@pytest.fixture(scope="module")
def afc(pump):
    return frequency.study(pump, ["program", "nonlinear", "nonlinear_chain", "consistent"], "appendix",
                           (10.0, 8000.0, 300), "pump")


def test_headline_is_the_energy_model_under_physical_forcing_beside_unchanged_top_level_keys(pump, afc):
    d = afc.to_dict()
    assert d["model"] == "program" and d["peaks"] == afc.models["program"].to_dict()["peaks"]
    h = d["headline"]
    assert (h["model"], h["forcing"], h["stable"]) == ("nonlinear", "physical", True)
    assert "omega" not in h  # no curves in results.json
    # A(omega0) by the direct solve against the python-control curve interpolated at omega0
    c = afc.head
    assert h["at_operating_speed"]["amplitude"] == pytest.approx(
        np.interp(h["at_operating_speed"]["omega"], c.omega, c.amplitude), rel=2e-3)
    # the stability block leads with the same model and agrees on its verdict
    st = stability.study(pump, ["program", "nonlinear"], None, "pump").to_dict()
    assert st["headline"]["model"] == "nonlinear" and st["headline"]["stable"] is True
    # the top-level keys are the headline model's (the one verdict), the program model's are under models
    assert st["stable"] is True and st["models"]["program"]["stable"] is False


def test_phase_is_unwrapped_and_starts_at_minus_180_for_a_negative_static_gain(afc):
    for c in [*afc.models.values(), afc.head]:
        assert np.max(np.abs(np.diff(c.phase_deg))) < 60.0
        assert c.phase_deg[0] == pytest.approx(-180.0, abs=15.0)


def test_legend_names_models_marks_unstable_and_the_coinciding_curve(afc):
    labels = {key: label for key, _c, _s, label in afc._styles()}
    assert labels["headline"].startswith("energy-consistent (nonlinear), physical forcing")
    assert labels["program"].startswith("source's program model (App. A/B)") and "unstable" in labels["program"]
    assert "same curve as chain form (2.40)/(2.111)" in labels["consistent"]
    assert "same curve" not in labels["nonlinear"] and "unstable" not in labels["nonlinear"]


def test_maps_share_one_symmetric_colour_scale_and_physical_axes(pump):
    class Axis:
        def __init__(self, parameter, start, stop, scale):
            self.parameter, self.start, self.stop, self.points, self.scale = parameter, start, stop, 5, scale

    class Map:
        x = Axis("cavity_volume", 1e-7, 1e-3, "log")
        y = Axis("stem_damping", 0.0, 2e4, "linear")
        models = ["program", "nonlinear"]

    figs = stability.study(pump, ["program", "nonlinear"], Map(), "pump").figures()
    norms = [figs[f"fig_stability_map_{m}.png"].axes[0].collections[0].norm for m in Map.models]
    assert norms[0].vmin == norms[1].vmin == -norms[1].vmax < 0
    ax = figs["fig_stability_map_program.png"].axes[0]
    assert ax.get_xlabel() == "cavity volume $V_{3}$, cm³" and ax.get_ylabel() == "stem damping $c_{x}$, N·s/m"
    star = next(line for line in ax.lines if line.get_label() == "scene (nominal)")
    assert star.get_xdata()[0] == pytest.approx(100.0) and star.get_clip_on() is False  # V3 = 1e-4 m^3 = 100 cm³
