"""``analyses.transient``: time responses of the nonlinear device model from its static solution (Pavlenko
(2014), Eq. (2.111)), by CVODES, IDAS or the Rosenbrock methods RODAS4 / RODAS4P."""

from __future__ import annotations

import dataclasses
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.schema import Positive, Strict
from autobal.units import AngularSpeed, Time

DESCRIPTION = "time responses"
NEEDS = "device.dynamics"
QUANTITIES_MODULE = "autobal.analysis.numerics.simulate"  # its QUANTITIES declare every number of its block
TITLE = "Transients"  # of its section of report.html


class TransientCase(Strict):
    """One time response from the static solution (2.111)."""

    input: Literal["force_step", "pressure_step", "pressure_harmonic"]
    amplitude: Annotated[float, Field(ge=-100, le=100)] = Field(
        0.01, description="dtau (force step) or dpsi1 (pressure), dimensionless, -100 to 100 (as p1 / p_B)")
    frequency: AngularSpeed | None = Field(None, description="harmonic input; default the operating speed")
    thrust_follows_pressure: bool = Field(True, description="with a pressure input, dtau = b dpsi1")


class Transient(Strict):
    operating_ratio: Positive = 1.0
    model: Literal["nonlinear", "nonlinear_chain"] = "nonlinear"
    integrator: Literal["cvodes", "idas", "rodas4", "rodas4p"] = Field(
        "cvodes", description="cvodes (BDF, Newton with the exact Jacobian; default), idas, rodas4: the "
        "L-stable Rosenbrock method RODAS4 (Hairer & Wanner 1996, Sect. IV.7) with step-size control, its steps "
        "clipped to the output times, compiled to C (cached; CasADi's virtual machine without a C compiler), or "
        "rodas4p: the same with Steinebach's (1995) RODASP coefficients, which keep order 4 where a stiff mode "
        "is driven by a harmonic input (RODAS4 drops towards order 2 there)")
    duration: Time = 0.05
    points: Annotated[int, Field(ge=10, le=200000)] = Field(2001, description="output times, 10 to 200,000")
    cases: Annotated[list[TransientCase], Field(min_length=1, max_length=100)] = Field(
        description="time responses to compute, 1 to 100")

    @model_validator(mode="after")
    def _pressure_stays_positive(self):
        for i, c in enumerate(self.cases):
            lowest = self.operating_ratio + (c.amplitude if c.input == "pressure_step" else -abs(c.amplitude))
            if c.input != "force_step" and lowest <= 0:
                raise ValueError(f"cases.{i}.amplitude: {c.amplitude:g} takes the discharge ratio psi1 from "
                                 f"operating_ratio {self.operating_ratio:g} to {lowest:g}; a discharge pressure "
                                 "must stay above zero")
        return self


SETTINGS = Transient


def _model(scene, settings: Transient):
    """The scene's nonlinear device model at the settings' operating point."""
    from autobal.analysis.numerics.linearize import Setup
    from autobal.parts.device import dynamic_device

    setup = Setup(dynamic_device(scene), settings.operating_ratio)
    return setup.nonlinear("chain" if settings.model == "nonlinear_chain" else "energy")


def run(scene, settings: Transient):
    """Time responses of the nonlinear device model from its static solution (CVODES / IDAS / RODAS4)."""
    from autobal.analysis.numerics import simulate as sim

    model = _model(scene, settings)
    cases = [{"input": c.input, "amplitude": c.amplitude, "frequency": c.frequency,
              "couple": c.thrust_follows_pressure} for c in settings.cases]
    res = sim.study(model, cases, settings.duration, settings.points, settings.integrator, scene.title)
    return dataclasses.replace(res, accuracy=sim.accuracy(model, res, cases, settings.duration, settings.points,
                                                          settings.integrator))


def estimate_seconds(settings: Transient) -> float:
    """One integrator output time per point and case."""
    return COST["start"] + COST["transient_point"] * settings.points * len(settings.cases)


def accuracy(scene, settings: Transient):
    """Work-precision of the time integration of the scene's transient (first force step, or dtau = 0.01)."""
    from autobal.analysis.studies import workprecision

    dtau = next((c.amplitude for c in settings.cases if c.input == "force_step"), 0.01)
    return workprecision.dynamics_study(_model(scene, settings), settings.duration, dtau)


def report_section(sec) -> None:
    """Nonlinear transients by CVODES/IDAS (Pavlenko 2014, §2.5).  Reads the fields of the loaded
    :class:`~autobal.analysis.numerics.simulate.TransientResult` (``sec.result``)."""
    from autobal.report import cell, table, text

    r = sec.result
    sec.headline_rows()  # the rows of the fields declared headline
    dz = r.quantities.find("cases.0.max_dz")
    rows = []
    for c in r.cases:
        failure = c.failure and c.failure.to_dict()
        rows.append([text(c.input), cell(c.amplitude, "1"), cell(c.frequency, "rad/s"),
                     cell(c.max_dz, dz.unit, dz.display, 4), cell(c.final_dz, dz.unit, dz.display, 4),
                     cell(c.t_end, "s"), cell(c.integrator_steps, "1"), text(failure or "ok")])
        if failure:
            sec.verdict(False, f"{c.input}: integration failed: {failure}")
        for e in c.events:
            sec.warnings.append(f"{c.input}: event {e.to_dict()}")
    sec.tables.append(table(f"Transients of the {r.model} model ({r.integrator}): face-gap change dz",
                            ["input", "amplitude", "frequency", "max |dz|", "final dz", "t_end", "steps", "status"],
                            rows, headline=True))
    if rows and not any(c.failure for c in r.cases):
        sec.verdict(True, "every transient integrated to its end time")
