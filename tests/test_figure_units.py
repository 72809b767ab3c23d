"""Figure axes speak the display units (analysis/run/quantities.py): shaft speeds in rpm with rad/s beside, frequencies
in rad/s with Hz beside, amplitudes in µm, times in s; a scene's or a caller's choice (``display:``, ``--units``,
:func:`display_units`) changes the label and the plotted data, which are the SI data converted.  The spin-up's
objective value is declared in the unit of the scene's objective (δ*/e and d* dimensionless, ∫(δ/e)² dt and the
arrival time in s): results.json ``units``, the terminal and the report."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import re

import numpy as np
import pytest

import autobal
from autobal import cli, report, scenario
from autobal.analysis.numerics import frequency, stability
from autobal.analysis.numerics.linearize import Setup
from autobal.analysis.run.quantities import display_units
from autobal.analysis.run.result import new_figure, unit_axis
from autobal.models.rotor import RotorParams
from autobal.ocp import spinup as S
from autobal.ocp import spinup_study
from autobal.parts import device as device_part

RPM = 60 / (2 * math.pi)  # rpm per rad/s
HZ = 1 / (2 * math.pi)  # Hz per rad/s
SMALL_SPINUP = {"analyses.spinup.intervals": 40, "analyses.spinup.multistart": False,
                "analyses.spinup.segments": 0}


def secondary(ax) -> list[str]:
    """The labels of the secondary axes of ``ax`` (the other unit beside the axis' own)."""
    return [c.get_xlabel() or c.get_ylabel() for c in ax.child_axes]


def test_unit_axis_labels_the_display_unit_converts_and_puts_the_other_unit_beside():
    _, ax = new_figure()
    assert unit_axis(ax, "speed", "rad/s", which="x") == 1.0
    assert ax.get_xlabel() == "speed, rad/s" and secondary(ax) == ["rpm"]
    _, ax = new_figure()
    with display_units({"speed": "rpm", "length": "µm"}):
        assert unit_axis(ax, "speed", "rad/s") == pytest.approx(RPM, rel=1e-15)
        assert unit_axis(ax, "gap", "m", "mm", "x") == pytest.approx(1e6, rel=1e-15)  # the choice over the declared
    assert ax.get_ylabel() == "speed, rpm" and ax.get_xlabel() == "gap, µm"
    assert secondary(ax) == ["rad/s"]  # a length has no unit beside it
    _, ax = new_figure()
    assert unit_axis(ax, "frequency", "rad/s", "Hz", other="rad/s") == pytest.approx(HZ, rel=1e-15)
    assert ax.get_ylabel() == "frequency, Hz" and secondary(ax) == ["rad/s"]
    _, ax = new_figure()  # a declared amplitude in µm, the field's volume L, the field's pressure MPa
    assert (unit_axis(ax, "A", "um"), unit_axis(ax, "V", "m^3", which="x")) == (1.0, pytest.approx(1e3))
    assert (ax.get_ylabel(), ax.get_xlabel(), secondary(ax)) == ("A, µm", "V, L", [])


# ------------------------------------------------------------------------------------------- device dynamics
@pytest.fixture(scope="module")
def pump():
    return Setup(device_part.adapt(scenario.load("pump_pe600_dynamics").device))


@pytest.fixture(scope="module")
def afc(pump):
    return frequency.study(pump, ["nonlinear", "program"], "appendix", (10.0, 8000.0, 80), "pump")


def test_the_afc_is_in_rad_s_with_hz_beside_and_in_the_chosen_units(afc):
    h = afc.head
    fig = afc.figures()["fig_afc.png"]
    a1, a2 = fig.axes[:2]
    assert a2.get_xlabel() == r"frequency $\omega$, rad/s" and a1.get_ylabel() == "gap amplitude $A_u$, µm"
    assert secondary(a1) == ["Hz"]  # on top of the amplitude plot
    line = a1.get_lines()[0]  # the headline curve, drawn first
    np.testing.assert_allclose(line.get_xdata(), h.omega, rtol=1e-15)
    np.testing.assert_allclose(line.get_ydata(), np.asarray(h.amplitude) / 1e-6, rtol=1e-15)  # m -> µm
    with display_units({"speed": "Hz", "length": "mm"}):
        fig = afc.figures()["fig_afc.png"]
    a1, a2 = fig.axes[:2]
    assert a2.get_xlabel() == r"frequency $\omega$, Hz" and a1.get_ylabel() == "gap amplitude $A_u$, mm"
    assert secondary(a1) == ["rpm"]
    line = a1.get_lines()[0]
    np.testing.assert_allclose(line.get_xdata(), np.asarray(h.omega) * HZ, rtol=1e-12)
    np.testing.assert_allclose(line.get_ydata(), np.asarray(h.amplitude) * 1e3, rtol=1e-12)
    phase = a2.get_lines()[0]
    np.testing.assert_allclose(phase.get_xdata(), np.asarray(h.omega) * HZ, rtol=1e-12)
    marker = [x for x in a1.get_lines() if x.get_marker() == "D"][0]  # A(omega0), headline
    assert marker.get_xdata()[0] == pytest.approx(h.at_operating_speed.omega * HZ, rel=1e-12)
    assert "Hz" in marker.get_label() or "mm" in marker.get_label()


def test_the_poles_imaginary_axis_in_rad_s_with_hz_beside_and_in_rpm_when_chosen(pump):
    st = stability.study(pump, ["nonlinear"], None, "pump")
    imag = np.asarray(st.models["nonlinear"].poles.imag, float)
    ax = st.figures()["fig_poles.png"].axes[0]
    assert ax.get_ylabel() == r"Im $\lambda$, rad/s" and secondary(ax) == ["Hz"]
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), imag, rtol=1e-15)
    with display_units({"speed": "rpm"}):
        ax = st.figures()["fig_poles.png"].axes[0]
    assert ax.get_ylabel() == r"Im $\lambda$, rpm" and secondary(ax) == ["Hz"]
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), imag * RPM, rtol=1e-12)


# ------------------------------------------------------------------------------------------------- spin-up
@pytest.fixture(scope="module")
def spin(tmp_path_factory):
    """The datasheet rotor (120 kg, 2400 rpm, 45 kW) on a coarse mesh without the ramp table, saved: seconds."""
    out = tmp_path_factory.mktemp("figunits") / "datasheet"
    return autobal.run(autobal.load("scenarios/spinup_rotor_datasheet.yaml", set=SMALL_SPINUP), out=out), out


@pytest.mark.cli
def test_spinup_speed_time_and_power_axes_follow_the_display_units(spin):
    """Shaft speeds in rpm with rad/s beside, accelerations in rad/s² with rpm/s beside, the power in kW; a choice
    of rad/s, rpm/s, ms and W changes labels and data."""
    res = spin[0]["spinup"]
    opt = res.optimum
    figs = res.figures()
    axes = figs["spinup_profiles.png"].axes
    assert axes[0].get_ylabel() == r"speed $\omega$, rpm" and secondary(axes[0]) == ["rad/s"]
    assert axes[1].get_ylabel() == r"acceleration $\alpha$, rad/s²" and secondary(axes[1]) == ["rpm/s"]
    assert axes[3].get_ylabel() == "drive power P, kW" and axes[3].get_xlabel() == "time t, s"
    line = axes[0].get_lines()[0]
    np.testing.assert_allclose(line.get_xdata(), opt.t, rtol=1e-15)
    np.testing.assert_allclose(line.get_ydata(), opt.omega * RPM, rtol=1e-12)
    np.testing.assert_allclose(axes[3].get_lines()[0].get_ydata(), opt.torque * opt.omega / 1e3, rtol=1e-12)
    critical = [x for x in axes[0].get_lines() if list(x.get_xdata()) == [0, 1]][0]  # axhline: axes coordinates
    assert critical.get_ydata()[0] == pytest.approx(res.omega_cr_rad_s * RPM, rel=1e-12)
    a2 = figs["spinup_deflection.png"].axes[1]
    assert a2.get_xlabel() == r"speed $\omega$, rpm" and "rad/s" in secondary(a2)
    np.testing.assert_allclose(a2.get_lines()[0].get_xdata(), opt.omega * RPM, rtol=1e-12)
    np.testing.assert_allclose(a2.get_lines()[0].get_ydata(), opt.delta, rtol=1e-15)  # δ/e stays δ/e
    with display_units({"speed": "rad/s", "time": "ms", "acceleration": "rpm/s", "power": "W"}):
        figs = res.figures()
    axes = figs["spinup_profiles.png"].axes
    assert axes[0].get_ylabel() == r"speed $\omega$, rad/s" and secondary(axes[0]) == ["rpm"]
    assert axes[1].get_ylabel() == r"acceleration $\alpha$, rpm/s" and secondary(axes[1]) == ["rad/s²"]
    assert axes[3].get_ylabel() == "drive power P, W" and axes[3].get_xlabel() == "time t, ms"
    line = axes[0].get_lines()[0]
    np.testing.assert_allclose(line.get_xdata(), opt.t * 1e3, rtol=1e-12)
    np.testing.assert_allclose(line.get_ydata(), opt.omega, rtol=1e-15)
    steps = axes[1].get_lines()[0]
    np.testing.assert_allclose(steps.get_ydata()[:-1], opt.alpha * RPM, rtol=1e-12)
    np.testing.assert_allclose(axes[3].get_lines()[0].get_ydata(), opt.torque * opt.omega, rtol=1e-12)
    a2 = figs["spinup_deflection.png"].axes[1]
    assert a2.get_xlabel() == r"speed $\omega$, rad/s"
    np.testing.assert_allclose(a2.get_lines()[0].get_xdata(), opt.omega, rtol=1e-15)


@pytest.mark.cli
@pytest.mark.parametrize("objective, unit", [("peak_deflection", "1"), ("peak_unbalance", "1"),
                                             ("integrated_deflection", "s"), ("min_time", "s")])
def test_the_objective_value_is_declared_in_the_unit_of_the_scene_objective(spin, objective, unit, tmp_path):
    """The unit follows the block's ``objective``; the block of a real run relabelled with each objective (its
    numbers are not re-read: only the declarations are under test here), through results.json ``units``, the
    terminal and the report."""
    run, folder = spin
    res = run["spinup"]
    block = copy.deepcopy(res.to_dict()) | {"objective": objective}
    q = spinup_study.QUANTITIES
    assert q.find("objective_value", block).unit == unit
    assert q.find("starts.0.objective", block).unit == unit
    assert q.find("objective_value_transcription", block).unit == unit
    assert q.find("segments.objective_value", block).unit == unit
    assert q.find("segments.start_objectives.fitted", block).unit == unit
    assert q.find("objective_value", None) is None  # without its block the key has no unit
    assert q.undeclared(block) == []
    units = report.units({"spinup": block})
    assert units["spinup.objective_value"] == unit and units["spinup.starts[].objective"] == unit
    # the terminal: 'objective J = ... (integrated deflection): 0.1234 s'
    text = dataclasses.replace(res, objective=objective).summary()
    shown = re.search(rf"objective J = .* \({objective.replace('_', ' ')}\): (\S+)( s)?$", text, re.M)
    assert shown is not None, text
    assert (shown.group(2) == " s") == (unit == "s")
    assert float(shown.group(1)) == pytest.approx(block["objective_value"], rel=1e-3)
    # the report: the row of the objective with its unit (a copy of the run's folder, the objective relabelled)
    data = json.loads((folder / "results.json").read_text())
    data["spinup"]["objective"] = objective
    (tmp_path / "results.json").write_text(json.dumps(data))
    assert cli.main(["report", str(tmp_path)]) == 0
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    row = re.search(r"objective of the optimum \(re-simulated\).*?</tr>", page, re.S)
    assert row is not None
    cells = re.findall(r"<td[^>]*>(.*?)</td>", row.group(0), re.S)
    assert ("s" in cells) == (unit == "s"), cells


def test_a_real_integrated_deflection_optimum_reports_its_objective_in_seconds():
    """A run with the integrated objective: objective_value is ∫(δ/e)² dt of the re-simulated optimum, in s."""
    ocp = S.SpinupOcp(RotorParams.from_groups(1.0, 0.1, 1.0), omega_start=0.5, omega_final=1.5, horizon=50.0,
                      alpha_max=0.03, objective="integrated_deflection", settling_time=10.0)
    res = spinup_study.run(ocp, S.DirectCollocation(40, 3, "radau"), multistart=False)
    assert res.objective_value == pytest.approx(res.integral_deflection2_s, rel=1e-9)
    assert report.units({"spinup": res.to_dict()})["spinup.objective_value"] == "s"


# --------------------------------------------------------------------------------------- every shipped scene
SHIPPED = [p.stem for p in scenario.shipped()]
#: a choice of a unit for each kind an axis can carry, and the units it replaces (the declared and the defaults)
CHOICE = {"speed": "Hz", "length": "mm", "pressure": "bar", "time": "min", "flow": "m³/h", "power": "W"}
REPLACED = re.compile(r", (rad/s|rpm|µm|\$\\mu\$m|MPa|L/s|s|ms|h|kW)(?=$|[\s(\n])")


@pytest.mark.cli
@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_every_figure_of_a_shipped_scene_follows_a_choice_of_units(shipped_run, name):
    """Under a choice for every kind, no axis of the scene's figures is left in the declared unit or the field's
    default (a secondary axis shows the other unit on purpose)."""
    run = shipped_run(name)[0]
    left, chosen = [], 0
    with display_units(CHOICE):
        for analysis in run:
            for file, fig in run[analysis].figures().items():
                for ax in fig.axes:
                    for label in (ax.get_xlabel(), ax.get_ylabel()):
                        left += [f"{analysis}/{file}: {label!r}"] if REPLACED.search(label) else []
                    for label in (t for a in (ax, *ax.child_axes) for t in (a.get_xlabel(), a.get_ylabel())):
                        chosen += bool(re.search(r", (Hz|mm|bar|min|m³/h|W)(?=$|[\s(\n])", label))
    assert left == []
    # every scene but the designs' (psi1 against 1/s) and the fit's (groups; no bases given) shows a chosen unit
    assert chosen > 0 or name.endswith("_design") or name.startswith("rig_")
