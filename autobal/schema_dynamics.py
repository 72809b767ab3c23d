"""Scenario schema of the device dynamics (Pavlenko 2014, §2.4, §2.6, App. A/B dynamic data).

``device.dynamics`` holds the masses, stiffnesses, damping, chamber volumes and bulk modulus of
the rotor - balancing device - regulator system; ``analyses.frequency``, ``analyses.stability``
and ``analyses.transient`` name the studies built on it (analysis/frequency.py, stability.py,
simulate.py).  Quantities carry units and are converted to SI on loading.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.models.dynamics import LONG_NAMES
from autobal.schema import Positive, Strict
from autobal.units import AngularSpeed, Area, quantity, to_si

Mass = quantity("mass")
Stiffness = quantity("stiffness")
Damping = quantity("damping")
DampingOrZero = quantity("damping", "nonnegative")
Volume = quantity("volume")
Time = quantity("time")
BulkModulus = quantity("bulk modulus")


class RegulatorDynamics(Strict):
    """Stem of the pressure-drop regulator and its two chambers (Pavlenko (2014), App. A)."""

    stem_mass: Mass = Field(description="m0")
    spring_stiffness: Stiffness = Field(description="k_reg")
    stem_damping: DampingOrZero = Field(0.0, description="c_x (the source: 0)")
    valve_chamber_volume: Volume = Field(description="V_cam")
    membrane_chamber_volume: Volume = Field(description="V_m")
    seat_area: Area | None = Field(None, description="s_c; default pi d_c^2 / 4 from regulator.valve.seat_diameter")


class Dynamics(Strict):
    """Dynamic data of the device (``device.dynamics``), Pavlenko (2014), App. A / App. B."""

    rotor_mass: Mass = Field(description="m_p")
    pushoff_stiffness: Stiffness = Field(description="k_pr; preload deflection F_pr/k_pr + z0")
    rotor_damping: DampingOrZero | None = Field(
        None, description="c_z (0: undamped); default the squeeze film, Pavlenko (2014), App. A")
    bulk_modulus: BulkModulus = Field(description="E of the barrier medium (gas: the source's 1.42e5 Pa)")
    disc_chamber_volume: Volume = Field(description="V2, chamber before the face throttle")
    cavity_volume: Volume = Field(description="V3, cavity behind the disc")
    regulator: RegulatorDynamics | None = Field(None, description="needed when the device has a regulator")
    forcing_amplitude: Positive = Field(0.2, description="delta psi_1a, amplitude of the harmonic discharge pressure")
    operating_speed: AngularSpeed | None = Field(None, description="omega0; default the impeller speed")


# scenario key -> unit kind of each dynamic parameter a stability map may scan (models/dynamics.LONG_NAMES)
PARAMETERS = {
    "rotor_mass": "mass", "pushoff_stiffness": "stiffness", "rotor_damping": "damping", "bulk_modulus": "bulk modulus",
    "disc_chamber_volume": "volume", "cavity_volume": "volume", "stem_mass": "mass", "spring_stiffness": "stiffness",
    "stem_damping": "damping", "valve_chamber_volume": "volume", "membrane_chamber_volume": "volume",
    "seat_area": "area",
}
assert set(PARAMETERS) == set(LONG_NAMES)
ParameterName = Literal[tuple(PARAMETERS)]  # type: ignore[valid-type]
ModelName = Literal["nonlinear", "nonlinear_chain", "program", "thesis", "consistent"]


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
