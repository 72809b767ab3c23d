"""``analyses.frequency``: the AFC / Bode of the face gap for a harmonic discharge pressure (Pavlenko (2014),
Eqs. (2.100)-(2.110)), on the device with its dynamic data (``device.dynamics``)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.parts.device_dynamics import ModelName
from autobal.schema import Positive, Strict
from autobal.units import AngularSpeed

DESCRIPTION = "frequency response (AFC/Bode)"
NEEDS = "device.dynamics"
QUANTITIES_MODULE = "autobal.analysis.frequency"  # its QUANTITIES declare every number of its block
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
    from autobal.analysis import frequency as fr
    from autobal.analysis.linearize import Setup
    from autobal.parts.device import dynamic_device

    setup = Setup(dynamic_device(scene), settings.operating_ratio)
    o = settings.omega
    res = fr.study(setup, list(settings.models), settings.forcing, (o.start, o.stop, o.points), scene.title)
    res.data["accuracy"] = fr.accuracy(setup, res.data["curves"], settings.forcing)
    return res


def estimate_seconds(settings: Frequency) -> float:
    """One AFC point per frequency and model."""
    return COST["start"] + COST["afc_point"] * settings.omega.points * len(settings.models)


def report_section(sec) -> None:
    """AFC of the face gap (Pavlenko 2014, §2.6): the headline model (energy-consistent, physical forcing)
    gives the verdict; the source's models are the validation part."""
    from autobal.analysis.frequency import QUANTITIES
    from autobal.report import (
        MODEL_ORDER,
        SOURCE_MODELS,
        cell,
        get_path,
        model_name,
        number,
        ordered_models,
        source_model_line,
        stable_models,
        table,
        text,
    )

    amp = QUANTITIES.find("peaks.0.amplitude")  # face-gap amplitudes: m in results.json, shown in µm
    stable = stable_models(sec.results)
    models = sec.get("models", {})
    h = sec.get("headline")
    if h:
        what = f"{model_name(h['model'])}, {h['forcing']} forcing"
        verdict = "stable" if h.get("stable") else "UNSTABLE"
        sec.conclude(h.get("stable"), f"{what}: {verdict} (max Re λ = {number(h.get('max_real'))} 1/s); first "
                                      f"resonance at {number(get_path(h, 'peaks.0.omega'))} rad/s; amplitude at the "
                                      f"operating speed {amp.text(get_path(h, 'at_operating_speed.amplitude'))}")
        sec.row(f"first resonance ({what})", "ω_I", "headline.peaks.0.omega")
        sec.row(f"amplitude at the first resonance ({what})", "A_I", "headline.peaks.0.amplitude")
        sec.row("operating speed", "ω0", "headline.at_operating_speed.omega")
        sec.row(f"amplitude at the operating speed ({what})", "A(ω0)", "headline.at_operating_speed.amplitude")
        sec.row(f"static amplitude ({what})", "A(0)", "headline.static_amplitude")
    else:  # no headline block: the toolkit's own first model, never one of the source's
        lead = next((m for m in MODEL_ORDER if m in models and m not in SOURCE_MODELS), None)
        if lead is not None:
            what = model_name(lead)
            sec.row(f"first resonance ({what})", "ω_I", f"models.{lead}.peaks.0.omega")
            sec.row(f"amplitude at the first resonance ({what})", "A_I", f"models.{lead}.peaks.0.amplitude")
            sec.row("operating speed", "ω0", f"models.{lead}.at_operating_speed.omega")
            sec.row(f"amplitude at the operating speed ({what})", "A(ω0)",
                    f"models.{lead}.at_operating_speed.amplitude")
    sec.row("forcing amplitude", "δψ_1a", "forcing_amplitude")
    from autobal.analysis.frequency import FORCING_WORDS

    own, source = [], []
    for model, m in ordered_models(models):
        peaks = m.get("peaks", [])
        at = m.get("at_operating_speed", {})
        verdict = {True: "stable", False: "UNSTABLE", None: "—"}[stable.get(model)]
        # the verdict's part holds the toolkit's model under the headline's forcing, i.e. the headline curve itself
        mine = model not in SOURCE_MODELS and (not h or m.get("forcing") == h.get("forcing"))
        rows = own if mine else source
        for i, pk in enumerate(peaks or [{}]):
            first = i == 0
            rows.append([text(model_name(model) if first else ""), text(m.get("forcing") if first else ""),
                         text(verdict if first else ""), cell(pk.get("omega"), "rad/s"),
                         cell(pk.get("amplitude"), "m", amp.display),
                         cell(at.get("amplitude") if i == 0 else None, "m", amp.display),
                         cell(m.get("static_amplitude") if i == 0 else None, "m", amp.display)])
        if stable.get(model) is False and mine:
            sec.warnings.append(f"{model_name(model)}: the model is unstable at this operating point; its AFC is the "
                                "response of an unstable system (no steady state exists)")
        if model in SOURCE_MODELS:
            source_model_line(sec, model, stable.get(model), m.get("forcing"))
    columns = ["model", "forcing", "stability", "peak ω", "peak amplitude", "amplitude at ω0", "static amplitude"]
    forcing = sec.get("forcing")
    caption = (f"{FORCING_WORDS.get(forcing, forcing)}, ω0 = {number(sec.get('at_operating_speed.omega'))} "
               "rad/s: peaks, amplitude at the operating speed and the static amplitude")
    if own:
        sec.tables.append(table(f"AFC of the face gap, {caption}", columns, own, headline=True))
    if source:
        whose = "the source's models" if forcing == "physical" or not h else "the models"
        sec.validation_tables.append(table(f"AFC of the face gap of {whose}, {caption}", columns, source))
