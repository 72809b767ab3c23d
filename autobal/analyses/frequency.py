"""``analyses.frequency``: the AFC / Bode of the face gap for a harmonic discharge pressure (Pavlenko (2014),
Eqs. (2.100)-(2.110)), on the device with its dynamic data (``device.dynamics``)."""

from __future__ import annotations

import dataclasses
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.parts.device_dynamics import ModelName
from autobal.schema import Positive, Strict
from autobal.units import AngularSpeed

DESCRIPTION = "frequency response (AFC/Bode)"
NEEDS = "device.dynamics"
QUANTITIES_MODULE = "autobal.analysis.numerics.frequency"  # its QUANTITIES declare every number of its block
TITLE = "Frequency response (AFC)"  # of its section of report.html


class OmegaGrid(Strict):
    start: AngularSpeed
    stop: AngularSpeed
    points: Annotated[int, Field(ge=10, le=20000)] = Field(600, description="frequencies, 10 to 20,000")

    @model_validator(mode="after")
    def _increasing(self):
        if self.stop <= self.start:
            raise ValueError("stop must be larger than start")
        return self


class Frequency(Strict):
    """AFC / Bode of the face gap for a harmonic discharge pressure (2.100)-(2.110)."""

    operating_ratio: Positive = Field(1.0, description="psi1 of the operating point")
    # first model: the top-level keys (peaks, at_operating_speed); all are reported under `models`
    models: Annotated[list[ModelName], Field(min_length=1)] = ["program", "nonlinear", "nonlinear_chain"]
    forcing: Literal["appendix", "physical"] = Field(
        "physical", description="the forcing of the models listed: physical, dtau = b dpsi1 (the machine's; the "
                                "headline's, always), or appendix, dtau = dpsi1 (the source's App. A/B, to compare "
                                "with its published AFC: validation)")
    omega: OmegaGrid = Field(default_factory=lambda: OmegaGrid(start="10 rad/s", stop="8000 rad/s"),
                             description="frequency grid; default 10 to 8000 rad/s, 600 points")


SETTINGS = Frequency


def run(scene, settings: Frequency):
    """AFC/PFC of the face gap of every named model (Pavlenko (2014), Eqs. (2.100)-(2.110))."""
    from autobal.analysis.numerics import frequency as fr
    from autobal.analysis.numerics.linearize import Setup
    from autobal.parts.device import dynamic_device

    setup = Setup(dynamic_device(scene), settings.operating_ratio)
    o = settings.omega
    res = fr.study(setup, list(settings.models), settings.forcing, (o.start, o.stop, o.points), scene.title)
    return dataclasses.replace(res, accuracy=fr.accuracy(setup, res.models, settings.forcing))


def estimate_seconds(settings: Frequency) -> float:
    """One AFC point per frequency and model."""
    return COST["start"] + COST["afc_point"] * settings.omega.points * len(settings.models)


def report_section(sec) -> None:
    """AFC of the face gap (Pavlenko 2014, §2.6): the headline model (energy-consistent, physical forcing)
    gives the verdict; the source's models are the validation part.  Reads the fields of the loaded
    :class:`~autobal.analysis.numerics.frequency.FrequencyResult` (``sec.result``)."""
    from autobal.analysis.numerics.frequency import FORCING_WORDS, QUANTITIES
    from autobal.report import (
        SOURCE_MODELS,
        cell,
        model_name,
        number,
        ordered_models,
        source_model_line,
        stable_models,
        table,
        text,
    )

    amp = QUANTITIES.find("peaks.0.amplitude")  # face-gap amplitudes: m in results.json, shown in µm
    r = sec.result
    h = r.head
    stable = stable_models(sec.results)
    what = f"{model_name(h.model)}, {h.forcing} forcing"
    first = h.peaks[0].omega if h.peaks else None
    sec.conclude(h.stable, f"{what}: {'stable' if h.stable else 'UNSTABLE'} (max Re λ = {number(h.max_real)} 1/s); "
                           f"first resonance at {number(first)} rad/s; amplitude at the operating speed "
                           f"{amp.text(h.at_operating_speed.amplitude)}")
    sec.headline_rows()  # the rows of the fields declared headline
    own, source = [], []
    for model, m in ordered_models(r.models):
        verdict = {True: "stable", False: "UNSTABLE", None: "—"}[stable.get(model)]
        # the verdict's part holds the toolkit's model under the headline's forcing, i.e. the headline curve itself
        mine = model not in SOURCE_MODELS and m.forcing == h.forcing
        rows = own if mine else source
        for i, pk in enumerate(m.peaks or [None]):
            first = i == 0
            rows.append([text(model_name(model) if first else ""), text(m.forcing if first else ""),
                         text(verdict if first else ""), cell(pk and pk.omega, "rad/s"),
                         cell(pk and pk.amplitude, "m", amp.display),
                         cell(m.at_operating_speed.amplitude if first else None, "m", amp.display),
                         cell(m.static_amplitude if first else None, "m", amp.display)])
        if stable.get(model) is False and mine:
            sec.warnings.append(f"{model_name(model)}: the model is unstable at this operating point; its AFC is the "
                                "response of an unstable system (no steady state exists)")
        if model in SOURCE_MODELS:
            source_model_line(sec, model, stable.get(model), m.forcing)
    columns = ["model", "forcing", "stability", "peak ω", "peak amplitude", "amplitude at ω0", "static amplitude"]
    caption = (f"{FORCING_WORDS.get(r.forcing, r.forcing)}, ω0 = {number(r.at_operating_speed.omega)} "
               "rad/s: peaks, amplitude at the operating speed and the static amplitude")
    if own:
        sec.tables.append(table(f"AFC of the face gap, {caption}", columns, own, headline=True))
    if source:
        whose = "the source's models" if r.forcing == "physical" else "the models"
        sec.validation_tables.append(table(f"AFC of the face gap of {whose}, {caption}", columns, source))
