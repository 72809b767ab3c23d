"""The rotor identified from a run-up (analysis/studies/runup.py, issue #36): the transient Jeffcott model of the 1x
vectors against an independent simulation (scipy DOP853 and a per-revolution DFT of its own), the fit's recovery of
the critical speed, damping ratio and unbalance within their 95 % intervals at moderate and fast rates, the
classical readings' bias beside it, the coverage of the intervals over many noisy run-ups (slow), a run that never
reaches the critical speed, and the adequacy test against a rotor the Jeffcott model does not describe."""

import json
import math
import types

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal.analysis.numerics.rotor import steady_state
from autobal.analysis.studies import runup as R
from autobal.models.rotor import RotorParams
from tests.hostile import refused

WN, ZETA, ECC, ANGLE = 100.0, 0.05, 20e-6, 0.7  # rad/s, 1, m, rad
NOISE = 8e-6  # m per sample, 32 samples a revolution: 2 µm per vector component, 1 % of the peak (200 µm)
RATES = {"slow": 2e-4, "moderate": 2e-3, "fast": 1e-2}  # alpha / w_n^2


def synthetic(rate: str, start=50.0, end=150.0, **kw) -> R.SyntheticRunup:
    """A run-up from 0.5 to 1.5 w_n at alpha = RATES[rate] w_n^2 (the independent simulator)."""
    alpha = RATES[rate] * WN**2
    args = dict(critical_speed=WN, damping_ratio=ZETA, eccentricity=ECC, angle=ANGLE) | kw
    return R.SyntheticRunup(start_speed=start, end_speed=end, duration=abs(end - start) / alpha, **args)


def one_x(v: dict, y: bool = True, time: bool = True):
    """The vectors as :class:`autobal.runup_data.OneX` carries them (speed, x, y, time, notes)."""
    return types.SimpleNamespace(speed=v["speed"], x=v["x"], y=v["y"] if y else None,
                                 time=v["time"] if time else None, notes=())


@pytest.fixture(scope="module")
def moderate():
    return synthetic("moderate")


@pytest.fixture(scope="module")
def fast():
    return synthetic("fast")


# ---- the model against an independent simulation --------------------------------------------------------------

def test_steady_whirl_is_the_closed_form():
    """The steady 1x vector per unit eccentricity from ode_fixed's Jacobian ((i nu I - A) Z = F) equals Pashkov
    (2010), Eq. (3) at psi = 1 (analysis/numerics/rotor.py) and the hand formula w^2/(w_n^2 - w^2 + 2 i zeta w_n w)."""
    w = np.array([10.0, 60.0, 99.0, 100.0, 101.0, 250.0])
    H = R.steady_response(w, WN, ZETA)
    assert_allclose(H, w**2 / (WN**2 - w**2 + 2j * ZETA * WN * w), rtol=1e-12)
    s = steady_state(RotorParams.from_groups(Omega0=WN, chi_over_m1=2 * ZETA * WN), w / WN)
    assert_allclose(H, s["x"] + 1j * s["y"], rtol=1e-12)
    assert_allclose(abs(H[3]), 1 / (2 * ZETA), rtol=1e-12)  # the resonance's height e/(2 zeta)


@pytest.mark.parametrize("rate", ["moderate", "fast"])
def test_transient_vectors_match_the_independent_simulation(rate, moderate, fast):
    """The fitting model's 1x vectors (RK4 of ode_fixed on the measured profile, windows of one revolution) equal the
    independent simulation's (DOP853 at rtol 1e-10, DFT from pulse to pulse) within 3e-4 of the peak, while the
    steady response misses them by more than 5 % of the peak at these rates (the passage effect)."""
    sim = {"moderate": moderate, "fast": fast}[rate]
    v = sim.vectors()
    model = R.TransientModel(v["time"], v["speed"], 2 * v["speed"].max())
    A_re, A_im, B_re, B_im = (np.asarray(a, float).ravel() for a in model.unit(WN, ZETA))
    eps = ECC * np.exp(1j * ANGLE)
    X = eps * (A_re + 1j * A_im) + np.conj(eps) * (B_re + 1j * B_im)
    Y = -1j * (eps * (A_re + 1j * A_im) - np.conj(eps) * (B_re + 1j * B_im))
    peak = np.abs(v["x"]).max()
    assert np.abs(X - v["x"]).max() < 3e-4 * peak
    assert np.abs(Y - v["y"]).max() < 3e-4 * peak
    steady = eps * R.steady_response(v["speed"], WN, ZETA)
    assert np.abs(steady - v["x"]).max() > 0.05 * peak


# ---- the fit recovers the rotor --------------------------------------------------------------------------------

def _inside(value, ci):
    return ci[0] <= value <= ci[1]


def _near(value, ci, k: float = 3.0):
    """Within k standard errors: the 95 % interval (+- 1.96 se, near enough for these degrees of freedom) widened to
    +- k se; a single draw then misses with a probability of 0.3 % (the coverage of the 95 % interval itself is the
    slow test's)."""
    mid, half = (ci[0] + ci[1]) / 2, (ci[1] - ci[0]) / 2
    return abs(value - mid) <= k / 1.96 * half


@pytest.mark.parametrize("rate", ["moderate", "fast"])
def test_transient_fit_recovers_the_rotor_within_its_intervals(rate, moderate, fast):
    """Noisy vectors of the independent simulation: the transient fit holds w_n, zeta, e and theta within 3 standard
    errors; the verdict is identified, the adequacy test passes, and the intervals are narrow (w_n within 0.5 %)."""
    sim = {"moderate": moderate, "fast": fast}[rate]
    res = R.run(one_x(sim.vectors(NOISE, np.random.default_rng(7))), title=rate, mass=10.0, service_speed=140.0)
    t = res.transient
    assert res.identified, res.reason
    assert _near(WN, t.critical_speed_ci) and _near(ZETA, t.damping_ratio_ci)
    assert _near(ECC, t.eccentricity_ci) and _near(math.degrees(ANGLE), t.unbalance_angle_ci_deg)
    assert (t.critical_speed_ci[1] - t.critical_speed_ci[0]) / 2 < 5e-3 * WN
    assert res.adequacy.adequate
    assert_allclose(res.unbalance, 10.0 * res.eccentricity, rtol=1e-12)  # U = m e
    assert_allclose(res.stiffness, 10.0 * res.critical_speed**2, rtol=1e-12)
    assert_allclose(res.balance_grade, res.eccentricity * 140.0, rtol=1e-12)  # G = e Omega (ISO 21940-11)


def test_classical_readings_are_biased_at_a_fast_rate_and_the_transient_fit_is_not(fast):
    """At alpha = 0.01 w_n^2 the peak lies 10-20 % above the critical speed and the half-power damping is more than
    1.5 times the true one, both far outside the transient fit's intervals; the steady-state fit is biased the same way
    (Lewis's passage effect), while the transient fit holds the truth."""
    res = R.run(one_x(fast.vectors(NOISE, np.random.default_rng(3))), title="fast")
    c, t, s = res.classical, res.transient, res.steady
    assert 10 < c.critical_speed_bias_pct < 20
    assert c.peak_speed > t.critical_speed_ci[1] and c.damping_ratio > 1.5 * t.damping_ratio_ci[1]
    assert s.critical_speed_ci[0] > 1.05 * WN  # the steady-state fit excludes the truth
    assert _near(WN, t.critical_speed_ci) and _near(ZETA, t.damping_ratio_ci)


def test_a_coast_down_is_identified_and_its_peak_lies_below_the_critical_speed():
    """A coast-down 1.5 -> 0.5 w_n at alpha = -0.002 w_n^2: identified within 3 standard errors; the classical peak
    now lies below the critical speed (the passage effect reversed)."""
    sim = synthetic("moderate", start=150.0, end=50.0)
    res = R.run(one_x(sim.vectors(NOISE, np.random.default_rng(21))), title="coast-down")
    t = res.transient
    assert res.identified and res.reason.startswith("identified from the coast-down")
    assert _near(WN, t.critical_speed_ci) and _near(ZETA, t.damping_ratio_ci) and _near(ECC, t.eccentricity_ci)
    assert res.classical.critical_speed_bias_pct < -2


def test_one_probe_and_the_run_out_fitted(moderate):
    """Probe x alone, with a run-out of 5 µm added to the signal: the run-out vector and the rotor are recovered
    within their intervals."""
    sim = synthetic("moderate", runout_x=5e-6 * np.exp(0.4j))
    res = R.run(one_x(sim.vectors(NOISE, np.random.default_rng(11)), y=False), title="x only")
    t = res.transient
    assert res.identified and t.runout_y is None
    assert _near(WN, t.critical_speed_ci) and _near(ZETA, t.damping_ratio_ci) and _near(ECC, t.eccentricity_ci)
    assert_allclose(t.runout_x, [5e-6 * math.cos(0.4), 5e-6 * math.sin(0.4)], atol=1e-6)


# ---- what the data cannot determine -----------------------------------------------------------------------------

def test_a_run_that_never_reaches_the_critical_speed_is_not_identified():
    """A run-up from 0.3 to 0.75 w_n: the verdict is 'not identifiable from these data' with the reason (the run ends
    below the critical speed, what is determined and what is not); no headline number is reported, no rotor
    section is written."""
    sim = synthetic("moderate", start=30.0, end=75.0)
    res = R.run(one_x(sim.vectors(NOISE, np.random.default_rng(5))), title="short", mass=10.0)
    assert not res.identified
    assert res.reason.startswith("not identifiable from these data")
    assert "below the critical speed" in res.reason and "damping ratio and the critical speed are not" in res.reason
    assert res.critical_speed is None and res.damping_ratio is None and res.unbalance is None
    assert res.rotor_yaml == ""
    assert res.verdict() == (False, res.reason)


def test_a_coast_down_that_stays_above_the_critical_speed_is_not_identified():
    """A coast-down from 3 to 1.3 w_n: not identifiable, the reason says the run stays above the critical speed and
    that the run-out imitates the response there."""
    sim = synthetic("fast", start=300.0, end=130.0)
    res = R.run(one_x(sim.vectors(NOISE, np.random.default_rng(6)), y=False), title="above")
    assert not res.identified and "is above the critical speed" in res.reason and "run-out" in res.reason
    assert res.critical_speed is None and res.eccentricity is None


def test_without_time_stamps_only_the_steady_fit_is_made(fast):
    """Vectors without time: no transient fit; the verdict says why (the steady-state fit is biased by the rate)."""
    res = R.run(one_x(fast.vectors(NOISE, np.random.default_rng(2)), time=False), title="no time")
    assert res.transient is None and res.steady is not None
    assert not res.identified and "no time stamps" in res.reason


@pytest.mark.parametrize("given", [False, True], ids=["noise estimated", "noise given"])
def test_the_adequacy_test_refuses_a_rotor_with_a_second_mode(moderate, given):
    """The response of a second mode (w_n2 = 1.3 w_n) added to the measured vectors: the Jeffcott rotor does not fit
    them within their noise (F > F_crit), so the verdict is not identified; the noise estimated from the vectors or
    given (a vector's noise is the samples' over sqrt(32/2): the chi-square test), and with the given noise the one
    mode alone passes."""
    noise = NOISE / 4 if given else None
    second = synthetic("moderate", critical_speed=130.0, eccentricity=8e-6).vectors()
    v = moderate.vectors(NOISE, np.random.default_rng(9))
    if given:
        assert R.run(one_x(v), title="one mode", noise=noise).adequacy.adequate
    v = v | {"x": v["x"] + second["x"], "y": v["y"] + second["y"]}
    res = R.run(one_x(v), title="two modes", noise=noise)
    assert res.adequacy.F > res.adequacy.F_crit and res.adequacy.adequate is False
    assert not res.identified


# ---- the Result -------------------------------------------------------------------------------------------------

def test_result_round_trip_and_units(fast, tmp_path):
    """results.json block -> RunupResult -> the same block; every number declared; the rotor section parses as YAML
    with the identified values in its units; save() writes it beside the CSV and the figures."""
    import yaml

    res = R.run(one_x(fast.vectors(NOISE, np.random.default_rng(4))), title="rt", mass=10.0, service_speed=140.0)
    block = res.to_dict()
    assert R.RunupResult.from_dict(block) == res
    for path in ("critical_speed", "transient.critical_speed_ci", "classical.peak_speed", "series.x_amplitude",
                 "unbalance", "balance_grade", "margins.amplification_factor", "adequacy.noise"):
        assert R.QUANTITIES.find(path) is not None, path
    assert R.QUANTITIES.find("unbalance").display == "g·mm"
    rotor = yaml.safe_load(res.rotor_yaml)["rotor"]
    assert rotor["mass"] == "10 kg"
    assert_allclose(float(rotor["critical_speed"].split()[0]), res.critical_speed * 30 / math.pi, rtol=1e-5)
    assert_allclose(float(rotor["unbalance"]["residual"].split()[0]), res.unbalance * 1e6, rtol=1e-4)
    names = {p.name for p in res.save(tmp_path)}
    assert {"identified_rotor.yaml", "runup_vectors.csv", "fig_runup_bode.png",
            "fig_runup_polar_residual.png"} <= names


# ---- slow: the slow rate and the coverage over many run-ups ------------------------------------------------------

@pytest.mark.slow
def test_slow_run_up_fits_and_the_classical_readings_agree():
    """At alpha = 2e-4 w_n^2 (about 800 revolutions) the transient fit holds the truth and the classical readings are
    nearly unbiased (peak speed within 2 % of w_n)."""
    sim = synthetic("slow")
    res = R.run(one_x(sim.vectors(NOISE, np.random.default_rng(1))), title="slow")
    t = res.transient
    assert res.identified
    assert _near(WN, t.critical_speed_ci) and _near(ZETA, t.damping_ratio_ci) and _near(ECC, t.eccentricity_ci)
    assert abs(res.classical.critical_speed_bias_pct) < 2


@pytest.mark.slow
def test_coverage_of_the_intervals_over_120_noisy_run_ups():
    """120 noise draws on one fast run-up (one model and its fitters built once and reused): each 95 % interval of
    w_n, zeta and e holds the truth in 88 % to 99.5 % of them (binomial: 95 % +- 3 standard deviations), and the
    mean of each estimate is within 2 standard errors of the mean of the truth."""
    sim = synthetic("fast", end=130.0)
    v0 = sim.vectors()
    model = R.TransientModel(v0["time"], v0["speed"], R.WN_MAX_FACTOR * v0["speed"].max())
    fitters, hits, est = {}, {"critical_speed": 0, "damping_ratio": 0, "e": 0}, []
    rng = np.random.default_rng(2026)
    n = 120
    for _ in range(n):
        v = sim.vectors(NOISE, rng)
        idn = R.identify(v["time"], v["speed"], v["x"], v["y"], model=model, fitters=fitters)
        f = idn.transient
        assert f.success
        hits["critical_speed"] += _inside(WN, f.interval("critical_speed"))
        hits["damping_ratio"] += _inside(ZETA, f.interval("damping_ratio"))
        e = f.eccentricity()
        hits["e"] += _inside(ECC, e[1:])
        est.append([f.value("critical_speed"), f.value("damping_ratio"), e[0]])
    for name, k in hits.items():
        assert 0.88 <= k / n <= 0.995, (name, k)
    est = np.array(est)
    se = est.std(axis=0, ddof=1) / math.sqrt(n)
    assert np.all(np.abs(est.mean(axis=0) - [WN, ZETA, ECC]) < 3 * se)


# ---- the shipped measurement: made by the independent simulator --------------------------------------------------

RPM = 2 * math.pi / 60
#: the shipped scene's rotor and run (scenarios/runup_identification.yaml, scenarios/data/runup_vectors.csv)
SHIPPED = dict(critical_speed=2400 * RPM, damping_ratio=0.03, eccentricity=12e-6, angle=math.radians(60.0),
               start_speed=900 * RPM, end_speed=3600 * RPM, duration=(2700 * RPM) / 60.0,
               runout_x=4e-6 * np.exp(0.5j), runout_y=3e-6 * np.exp(-1.0j))
SHIPPED_NOISE, SHIPPED_SEED = 3e-6, 36


def shipped_measurement() -> str:
    """The CSV text of scenarios/data/runup_vectors.csv: the independent simulator's run-up of :data:`SHIPPED`,
    white noise of 3 µm on each of 32 samples a revolution (seed 36), exported as an analyser does: peak-to-peak
    amplitudes in µm, phase lags in degrees (0 to 360) from the key-phasor, both probes."""
    sim = R.SyntheticRunup(**SHIPPED)
    v = sim.vectors(SHIPPED_NOISE, np.random.default_rng(SHIPPED_SEED))
    s = SHIPPED
    lines = [
        "# Synthetic run-up of a 120 kg Jeffcott rotor, made by autobal.analysis.studies.runup.SyntheticRunup (scipy",
        "# DOP853, order tracking by its own DFT from key-phasor pulse to pulse), not by the fitting model's code:",
        "# tests/test_runup.py::shipped_measurement writes this file and",
        "# test_the_shipped_measurement_is_the_simulators checks it. Truth: critical speed 2400 rpm, damping ratio",
        "# 0.03, eccentricity 12 um at 60 deg from the key-phasor mark in the direction of rotation (1440 g*mm at",
        "# 120 kg); run-out 4 um at 28.6 deg (x) and 3 um at -57.3 deg (y); 900 -> 3600 rpm in",
        f"# {s['duration']:.4g} s (alpha = 60 rad/s^2); noise 3 um rms per sample, 32 samples a revolution,",
        f"# seed {SHIPPED_SEED}.",
        "# Conventions: amplitude peak-to-peak, phase lag from the key-phasor pulse; probe y 90 deg from x in the",
        "# direction of rotation.",
        "time [s],speed [rpm],amplitude_x [um],phase_x [deg],amplitude_y [um],phase_y [deg]",
    ]
    for t, w, x, y in zip(v["time"], v["speed"], v["x"], v["y"], strict=True):
        lag = [math.degrees(-np.angle(z)) % 360 for z in (x, y)]
        lines.append(f"{t:.5f},{w / RPM:.3f},{2e6 * abs(x):.3f},{lag[0]:.2f},{2e6 * abs(y):.3f},{lag[1]:.2f}")
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_the_shipped_measurement_is_the_simulators():
    """scenarios/data/runup_vectors.csv is what :func:`shipped_measurement` writes (its provenance)."""
    from importlib.resources import files

    shipped = files("autobal.scenarios").joinpath("data/runup_vectors.csv").read_text(encoding="utf-8")
    assert shipped == shipped_measurement()


# ---- the shipped scene end to end, and bad settings ---------------------------------------------------------------

@pytest.mark.cli
def test_the_shipped_scene_identifies_the_simulated_rotor(shipped_run):
    """autobal run runup_identification: the transient fit's intervals hold the simulator's truth (2400 rpm, zeta
    0.03, 1440 g*mm at 60 deg), the classical peak lies above them, and the run folder holds the rotor section."""
    run, folder = shipped_run("runup_identification")
    data = json.loads((folder / "results.json").read_text(encoding="utf-8"))
    block = data["runup"]
    t, s = block["transient"], SHIPPED
    assert block["identified"] is True
    assert _near(s["critical_speed"], t["critical_speed_ci"]) and _near(s["damping_ratio"], t["damping_ratio_ci"])
    assert _near(s["eccentricity"], t["eccentricity_ci"]) and _near(60.0, t["unbalance_angle_ci_deg"])
    assert block["classical"]["peak_speed"] > t["critical_speed_ci"][1]
    assert_allclose(block["unbalance"], 120 * block["eccentricity"], rtol=1e-12)
    assert (folder / "identified_rotor.yaml").is_file() and (folder / "fig_runup_bode.png").is_file()
    assert data["units"]["runup.unbalance"] == "kg*m"


@pytest.mark.cli
def test_a_static_test_gives_the_modal_mass(tmp_path):
    """static_test (a load and its deflection) instead of the mass: c = load/deflection and m = c/w_n^2, the
    unbalance m e with its interval (delta method over w_n and eps)."""
    import autobal

    c = 120 * (2400 * RPM) ** 2  # the simulated rotor's stiffness, N/m
    scene = autobal.load("runup_identification", set={"analyses.runup.mass": None, "analyses.runup.static_test": {
        "load": f"{c * 1e-4:.6g} N", "deflection": "0.1 mm"}})
    res = autobal.run(scene)["runup"]
    assert_allclose(res.stiffness, c, rtol=1e-5)
    assert_allclose(res.mass, res.stiffness / res.critical_speed**2, rtol=1e-12)
    assert_allclose(res.mass, 120.0, rtol=1e-3)
    assert res.unbalance_ci[0] < res.unbalance < res.unbalance_ci[1]
    assert_allclose(res.unbalance, res.mass * res.eccentricity, rtol=1e-12)


@pytest.mark.cli
@pytest.mark.parametrize("override, words", [
    ("analyses.runup.stiffness=1e6 N/m", "give one of the modal mass (kg), the stiffness (N/m) or a static_test"),
    ("analyses.runup.static_test={load: '1 kN', deflection: '0.1 mm'}", "give one of the modal mass"),
    ("analyses.runup.measurement.amplitude=null", "a vectors file needs its conventions"),
    ("analyses.runup.measurement.kind=signals", "amplitude and phase conventions belong to a vectors file"),
    ("analyses.runup.measurement.slow_roll=['400 rpm', '200 rpm']", "slow_roll: give [low, high]"),
    ("analyses.runup.max_relative_interval=0", "max_relative_interval"),
    ("analyses.runup.measurement.file=data/no_such_file.csv", "no_such_file.csv"),
])
def test_bad_settings_are_refused_in_one_line(capsys, override, words):
    assert words in refused(capsys, "runup_identification", override)


def test_raw_probe_and_key_phasor_signals_through_order_tracking(tmp_path):
    """The independent simulator's raw signals (2 kHz, probes x and y with noise, a 5 V key-phasor) written as a CSV,
    order-tracked by autobal.runup_data.read_signals and fitted: the rotor is recovered within 3 standard errors,
    as from the simulator's own vectors."""
    from autobal.runup_data import read_signals

    sim = synthetic("moderate")
    s = sim.signals(2000.0, NOISE, np.random.default_rng(17))
    path = tmp_path / "signals.csv"
    rows = ["time [s],probe_x [um],probe_y [um],keyphasor [V]"]
    rows += [f"{t:.6f},{1e6 * x:.4f},{1e6 * y:.4f},{k:g}" for t, x, y, k in
             zip(s["time"], s["x"], s["y"], s["keyphasor"], strict=True)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    res = R.run(read_signals(path), title="raw signals", mass=10.0)
    t = res.transient
    assert res.identified, res.reason
    assert _near(WN, t.critical_speed_ci) and _near(ZETA, t.damping_ratio_ci)
    assert _near(ECC, t.eccentricity_ci) and _near(math.degrees(ANGLE), t.unbalance_angle_ci_deg)
