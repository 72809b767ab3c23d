"""``analyses.runup``: the rotor identified from a measured run-up or coast-down (issue #36): the critical speed,
damping ratio and unbalance fitted to the 1x vectors by the transient Jeffcott response driven by the measured speed
profile (:mod:`autobal.analysis.studies.runup`), beside the steady-state fit and the classical readings; the measurement
is read by :mod:`autobal.runup_data` (1x vectors, or raw probe and key-phasor signals by order tracking).  It needs no
scene part: the identified rotor is written as the ``rotor:`` section of a spin-up scene in the run folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, PrivateAttr, ValidationInfo, model_validator

from autobal.analyses import COST
from autobal.schema import Strict
from autobal.units import AngularSpeed, Force, Length, Mass, Stiffness

DESCRIPTION = "the rotor (critical speed, damping, unbalance) identified from a measured run-up"
NEEDS = None
QUANTITIES_MODULE = "autobal.analysis.studies.runup"
TITLE = "Rotor identified from a run-up"
FILE_KEY = "analyses.runup.measurement.file"


class Measurement(Strict):
    """The measured run-up: a CSV of 1x vectors or of raw signals (formats: :mod:`autobal.runup_data`)."""

    file: Annotated[str, Field(description="CSV path: absolute, or relative to the scene file's folder (a path given "
                                           "by --set / load(set=...) is relative to the working folder)")]
    kind: Annotated[Literal["vectors", "signals"], Field(
        description="vectors: one 1x vector a row (speed, amplitude, phase); signals: time, probe_x [, probe_y], "
                    "keyphasor or speed, order-tracked per revolution")] = "vectors"
    amplitude: Annotated[Literal["0-peak", "peak-to-peak"] | None, Field(
        description="amplitude convention of a vectors file (required for vectors)")] = None
    phase: Annotated[Literal["lag", "lead"] | None, Field(
        description="phase convention of a vectors file, from the key-phasor (required for vectors)")] = None
    speed_unit: Annotated[str | None, Field(description="unit of a speed column whose header has none")] = None
    slow_roll: Annotated[list[AngularSpeed] | None, Field(
        min_length=2, max_length=2, description="[low, high] speed range whose mean 1x vector (the run-out) is "
                                                "subtracted, e.g. ['200 rpm', '400 rpm']")] = None
    columns: Annotated[dict[str, str] | None, Field(
        description="quantity -> header of its column, e.g. {speed: 'Drehzahl (rpm)'}")] = None

    @model_validator(mode="after")
    def _conventions(self):
        if self.kind == "vectors" and (self.amplitude is None or self.phase is None):
            raise ValueError("a vectors file needs its conventions: amplitude ('0-peak' or 'peak-to-peak') and "
                             "phase ('lag' or 'lead')")
        if self.kind == "signals" and (self.amplitude is not None or self.phase is not None):
            raise ValueError("amplitude and phase conventions belong to a vectors file; raw signals carry none")
        if self.slow_roll is not None and not self.slow_roll[0] < self.slow_roll[1]:
            raise ValueError("slow_roll: give [low, high] with low below high (rad/s, e.g. ['200 rpm', '400 rpm'])")
        return self


class StaticTest(Strict):
    """A static deflection under a known load at the rotor's modal point: the shaft stiffness c = load/deflection."""

    load: Annotated[Force, Field(description="the static load, N")]
    deflection: Annotated[Length, Field(description="the deflection it makes, m")]


class Runup(Strict):
    """The rotor identified from a run-up: transient Jeffcott fit, steady-state fit, classical readings."""

    measurement: Measurement
    mass: Annotated[Mass | None, Field(description="modal mass m, kg: the unbalance m e and c, chi are reported "
                                                   "(give mass or stiffness, not both)")] = None
    stiffness: Annotated[Stiffness | None, Field(
        description="shaft stiffness c, N/m: the modal mass is then m = c/w_n^2")] = None
    static_test: Annotated[StaticTest | None, Field(
        description="a static deflection under a known load (c = load/deflection), instead of stiffness")] = None
    service_speed: Annotated[AngularSpeed | None, Field(
        description="service speed: the 1x vector read there, the ISO 21940-11 grade, the API 684 separation "
                    "margin")] = None
    runout: Annotated[bool, Field(description="fit a constant run-out 1x vector per probe (false: none, or "
                                              "subtracted by slow_roll)")] = True
    noise: Annotated[Length | None, Field(description="noise of a 1x vector per component, m (default: from the "
                                                      "spread of the vectors' second differences)")] = None
    max_relative_interval: Annotated[float, Field(
        gt=0, le=1, description="identified only when the 95 % intervals of w_n, zeta and e are each narrower "
                                "than +- this fraction of the value")] = 0.25
    significance: Annotated[float, Field(gt=0, lt=1, description="level of the adequacy F test")] = 0.05

    _folder: Path | None = PrivateAttr(default=None)
    _data = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _read(self, info: ValidationInfo):
        if sum(v is not None for v in (self.mass, self.stiffness, self.static_test)) > 1:
            raise ValueError("give one of the modal mass (kg), the stiffness (N/m) or a static_test (load N, "
                             "deflection m), not more")
        ctx = info.context or {}
        overridden = any(FILE_KEY == k or FILE_KEY.startswith(k + ".") for k in ctx.get("overrides", ()))
        self._folder = Path.cwd() if overridden or ctx.get("folder") is None else Path(ctx["folder"])
        self._data = self.read()
        return self

    def read(self):
        """The measurement read into 1x vectors (:class:`autobal.runup_data.OneX`)."""
        from autobal.runup_data import read_signals, read_vectors

        m = self.measurement
        slow = None if m.slow_roll is None else tuple(m.slow_roll)
        if m.kind == "signals":
            return read_signals(m.file, slow_roll=slow, columns=m.columns, folder=self._folder)
        return read_vectors(m.file, amplitude=m.amplitude, phase=m.phase, speed_unit=m.speed_unit, slow_roll=slow,
                            columns=m.columns, folder=self._folder)

    @property
    def data(self):
        if self._data is None:
            self._data = self.read()
        return self._data


SETTINGS = Runup


def run(scene, settings: Runup):
    """Identify the rotor from the scene's measured run-up (:func:`autobal.analysis.studies.runup.run`)."""
    from autobal.analysis.studies import runup

    s = settings
    stiffness = s.stiffness if s.static_test is None else s.static_test.load / s.static_test.deflection
    return runup.run(s.data, title=scene.title, mass=s.mass, stiffness=stiffness, service_speed=s.service_speed,
                     runout=s.runout, noise=s.noise, max_relative_interval=s.max_relative_interval,
                     significance=s.significance)


def estimate_seconds(settings: Runup) -> float:
    """The transient model's integration over the run, per measured revolution (the vectors, or the signal rows over
    the samples a revolution)."""
    data = settings.data
    return COST["start"] + COST["runup_vector"] * len(data.speed)


def report_section(sec) -> None:
    """The identified rotor, the verdict, the fits side by side and the classical readings with their bias; reads
    the fields of the loaded :class:`~autobal.analysis.studies.runup.RunupResult` (``sec.result``)."""
    from autobal.report import number, table, text

    r = sec.result
    sec.conclude(r.identified, r.reason)
    sec.headline_rows()  # ω_n, ζ, e, θ, U, G: the fields declared headline
    sec.rows_of(r, "mass", "stiffness", "damping")
    if r.margins is not None:
        sec.verdict(r.margins.separation_margin_ok, "API 684 (2005) of the identified rotor: " + r.margins.words)
    ad = r.adequacy
    if ad is not None and ad.F is not None:
        sec.verdict(ad.adequate, f"adequacy: F = s²/σ² = {number(ad.F)} against F_crit = {number(ad.F_crit)} at "
                                 f"significance {number(ad.significance)} (σ the noise of the vectors)")
    rows = []
    for label, key, ci in (("ω_n", "critical_speed", "critical_speed_ci"), ("ζ", "damping_ratio", "damping_ratio_ci"),
                           ("e", "eccentricity", "eccentricity_ci"),
                           ("θ", "unbalance_angle_deg", "unbalance_angle_ci_deg")):
        for prefix, name in (("transient", "transient (as run)"), ("steady", "steady-state")):
            f = getattr(r, prefix)
            if f is None:
                continue
            lo, hi = getattr(f, ci)
            value = getattr(f, key)
            half = f"± {abs(hi - lo) / 2 / abs(value) * 100:.2g} %" if value else "—"
            rows.append([text(label), text(name), sec.cell(f"{prefix}.{key}"), sec.cell(f"{prefix}.{ci}", float(lo)),
                         sec.cell(f"{prefix}.{ci}", float(hi)), text(half)])
    sec.tables.append(table("The fits", ["parameter", "fit", "value", "95 % low", "95 % high", "half-width"], rows))
    c = r.classical
    if c is not None:
        crow = []
        if c.peak_speed is not None:
            crow.append([text("peak speed read as the critical"), sec.cell("classical.peak_speed"),
                         text("" if c.critical_speed_bias_pct is None else f"{c.critical_speed_bias_pct:+.3g} %")])
        if c.damping_ratio is not None:
            crow.append([text("half-power damping ratio"), sec.cell("classical.damping_ratio"),
                         text("" if c.damping_ratio_bias_pct is None else f"{c.damping_ratio_bias_pct:+.3g} %")])
        if c.service_amplitude is not None:
            crow.append([text("1x amplitude at the service speed"), sec.cell("classical.service_amplitude"),
                         text(f"lag {number(c.service_lag_deg)}°")])
        if crow:
            sec.tables.append(table("Classical readings (a slow, steady run assumed) and their difference from the "
                                    "transient fit", ["reading", "value", "bias"], crow))
        if c.status:
            sec.notes.append(f"classical readings: {c.status}")
    sec.notes.append(r.undetermined[0].upper() + r.undetermined[1:])
    for n in r.notes:
        sec.notes.append(f"reading: {n}")
    if r.rotor_yaml:
        sec.notes.append("the identified rotor, as the rotor: section of a spin-up scene, is in identified_rotor.yaml")
