"""``analyses.stability``: poles, damping, Hurwitz determinants and margin of the device's linear models, and
an optional stability map over two dynamic parameters (Pavlenko (2014), §2.6)."""

from __future__ import annotations

import dataclasses
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.parts.device_dynamics import PARAMETERS, ModelName, ParameterName
from autobal.schema import Positive, Strict
from autobal.units import quantity, to_si

RateOrZero = quantity("rate", "nonnegative")

DESCRIPTION = "poles, Hurwitz, stability maps"
NEEDS = "device.dynamics"
QUANTITIES_MODULE = "autobal.analysis.numerics.stability"  # its QUANTITIES declare every number of its block
TITLE = "Stability"  # of its section of report.html


class MapAxis(Strict):
    """One axis of a stability map: a dynamic parameter from ``start`` to ``stop`` (with units)."""

    parameter: ParameterName
    start: str | float
    stop: str | float
    points: Annotated[int, Field(ge=3, le=400)] = Field(41, description="values on this axis, 3 to 400")
    scale: Literal["log", "linear"] = "log"

    @model_validator(mode="before")
    @classmethod
    def _to_si(cls, data):
        if isinstance(data, dict) and isinstance(data.get("parameter"), str) and data["parameter"] in PARAMETERS:
            kind = PARAMETERS[data["parameter"]]
            data = dict(data)
            for k in ("start", "stop"):
                if k in data:
                    try:
                        data[k] = to_si(data[k], kind)
                    except ValueError as exc:
                        raise ValueError(f"{k}: {exc}") from None
        return data

    @model_validator(mode="after")
    def _range(self):
        if not float(self.stop) > float(self.start) >= 0:
            raise ValueError("need 0 <= start < stop")
        if self.scale == "log" and float(self.start) <= 0:
            raise ValueError("a log axis needs start > 0")
        return self


class StabilityMap(Strict):
    x: MapAxis
    y: MapAxis
    models: Annotated[list[ModelName], Field(min_length=1)] = ["program", "nonlinear"]


class Stability(Strict):
    """Poles, damping, Hurwitz determinants, margin; optional map over two parameters."""

    operating_ratio: Positive = 1.0
    models: Annotated[list[ModelName], Field(min_length=1)] = ["program", "nonlinear", "nonlinear_chain"]
    map: StabilityMap | None = None
    decay_rate: RateOrZero = Field(0.0, description="required decay rate alpha of the energy-consistent model "
                                   "(every pole Re lambda <= -alpha), e.g. '50 1/s'; 0: asymptotic stability")


SETTINGS = Stability


def run(scene, settings: Stability):
    """Poles, damping, Hurwitz determinants, margin and the optional stability map."""
    from autobal.analysis.numerics import stability as st
    from autobal.analysis.numerics.linearize import Setup
    from autobal.parts.device import dynamic_device

    setup = Setup(dynamic_device(scene), settings.operating_ratio)
    res = st.study(setup, list(settings.models), settings.map, scene.title, settings.decay_rate)
    return dataclasses.replace(res, accuracy=st.accuracy(setup, list(settings.models)))


def estimate_seconds(settings: Stability) -> float:
    """One map point per grid point and model (the poles themselves are cheap)."""
    m = settings.map
    return COST["start"] + (COST["map_point"] * m.x.points * m.y.points * len(m.models) if m else 0.0)


def _rate(decay) -> str:
    from autobal.report import number

    return ("" if decay is None else f"disturbances decay at {number(decay)} 1/s" if decay > 0
            else f"disturbances GROW at {number(-decay)} 1/s")


def report_section(sec) -> None:
    """Poles, Hurwitz determinants and margins (Pavlenko 2014, §2.7): the headline model (energy-consistent)
    gives the verdict; the source's models are the validation part.  Reads the fields of the loaded
    :class:`~autobal.analysis.numerics.stability.StabilityResult` (``sec.result``)."""
    from autobal.analysis.run.result import plain
    from autobal.report import (
        SOURCE_MODELS,
        cell,
        leading_poles,
        model_name,
        ordered_models,
        source_model_line,
        table,
        text,
    )

    r = sec.result
    sec.conclude(*r.verdict())
    sec.headline_rows()  # the rows of the fields declared headline
    own, source = [], []
    for model, m in ordered_models(r.models):
        lead = leading_poles(plain(m.poles.real), plain(m.poles.imag))
        row = [text(model_name(model)), text("stable" if m.stable else "UNSTABLE"),
               {"text": lead, "unit": "1/s", "num": True}, cell(m.margin.decay_rate, "1/s"),
               cell(m.margin.min_damping_ratio, "1")]
        if model in SOURCE_MODELS:
            source.append(row)
            source_model_line(sec, model, m.stable)
            continue
        own.append(row)
        if model != r.head.model:  # another model of the toolkit's own: a check, not the verdict
            sec.verdict(m.stable, f"{model_name(model)}: {'stable' if m.stable else 'UNSTABLE'}; leading poles {lead} "
                                  f"1/s; {_rate(m.margin.decay_rate)}")
    columns = ["model", "verdict", "leading poles", "decay rate", "min damping ratio ζ"]
    caption = "leading poles (largest real part), decay rate −max Re λ and the smallest damping ratio"
    if own:
        sec.tables.append(table(f"Stability: {caption}", columns, own, headline=True))
    if source:
        sec.validation_tables.append(table(f"Stability of the source's models: {caption}", columns, source))
    for m, t in (r.restoring or {}).items():
        (sec.validation_notes if m in SOURCE_MODELS else sec.notes).append(
            f"{model_name(m)}: {t.removeprefix(m + ': ')}")
