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
REPORT_SECTION = "frequency_section"


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
    forcing: Literal["appendix", "physical"] = Field("appendix", description="dtau = dpsi1 (App. A/B) or b dpsi1")
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
