"""Scenario schema of ``analyses.estimation``: fitting device parameters to measured static and
flow characteristics (Pavlenko (2014), Sec. 4.4).

The data file is read and checked at load time (``autobal check`` catches a bad CSV): columns,
units, signs and the number of points against the free parameters of every fit.
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.errors import ScenarioError
from autobal.measurements import Measurements, check_fit, read_csv
from autobal.models.device import DEVICE_GROUPS, PRESSURE_GROUPS, REGULATOR_GROUPS
from autobal.models.hydroheel import DiscLosses
from autobal.schema import NonNegative, Positive, Strict
from autobal.units import Area, Length, Pressure, VolumeFlow

# Parameters each model can fit.  traditional_disc: (4.16)-(4.31).  device: the groups (2.18) of the
# full static model (models/device.py) and the loss coefficients they come from.
MODEL_PARAMETERS = {
    "traditional_disc": ("alpha", "tau_max"),
    "device": (*(k for k in (*DEVICE_GROUPS, *REGULATOR_GROUPS) if k not in PRESSURE_GROUPS),
               "face_friction", "outer_local_loss", "outer_friction"),
}


class Parameter(Strict):
    """One model parameter: its value (the initial guess when free), free or fixed, bounds."""

    value: float
    free: bool = True
    lower: float | None = None
    upper: float | None = None

    @model_validator(mode="after")
    def _inside(self):
        if self.lower is not None and self.upper is not None and self.upper <= self.lower:
            raise ValueError("upper must be larger than lower")
        if self.lower is not None and self.value < self.lower:
            raise ValueError(f"value {self.value:g} is below lower = {self.lower:g}")
        if self.upper is not None and self.value > self.upper:
            raise ValueError(f"value {self.value:g} is above upper = {self.upper:g}")
        return self


class Weights(Strict):
    """Residual weights, r = weight (model - measured); use 1/standard deviation of each measurement."""

    u: Positive = 1.0
    q: Positive = 1.0


class Fit(Strict):
    """One nonlinear least-squares fit."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_]+$")]
    model: Literal["traditional_disc", "device"] = "traditional_disc"
    residual: Literal["u", "q", "both"] = "u"  # measured variable(s) the residual is taken in
    weights: Weights = Weights()
    parameters: dict[str, Parameter]
    flow_throttle: str = "T"  # device model: throttle whose flow is measured (e, 1, T, 3, in, valve)
    hessian: Literal["gauss-newton", "exact"] = "gauss-newton"
    max_iterations: Annotated[int, Field(ge=1, le=10000)] = 300

    @model_validator(mode="after")
    def _known(self):
        known = MODEL_PARAMETERS[self.model]
        for k in self.parameters:
            if k not in known:
                raise ValueError(f"parameters.{k}: not a parameter of model {self.model} (one of {', '.join(known)})")
        if not any(p.free for p in self.parameters.values()):
            raise ValueError("parameters: no free parameter to fit")
        if self.model == "traditional_disc" and set(self.parameters) != set(known):
            raise ValueError("parameters: the traditional_disc model needs both alpha and tau_max (free or fixed)")
        both = [("alpha_31", "outer_local_loss", "outer_friction"), ("alpha_TB1", "face_friction")]
        for same in both:
            free = [k for k in same if k in self.parameters]
            if len(free) > 1:
                raise ValueError(f"parameters: {' and '.join(free)} set the same conductance; give one of them")
        return self

    def free(self) -> list[str]:
        return [k for k, p in self.parameters.items() if p.free]


class Bases(Strict):
    """Base values that make dimensional data columns dimensionless (1.17)-(1.21), (4.29).
    The device model takes p_B, s_B, z_B and g1 p_B from the scene's device when these are omitted."""

    pressure: Pressure | None = None  # p_B
    area: Area | None = None  # s_B; force base = p_B s_B
    gap: Length | None = None  # z_B = h_TB
    flow: VolumeFlow | None = None  # Q_B

    def values(self) -> dict:
        """Base values in SI by the key the data columns use: pressure (Pa), gap (m), flow (m^3/s),
        force p_B s_B (N); None where not given."""
        force = self.pressure * self.area if self.pressure and self.area else None
        return {"pressure": self.pressure, "gap": self.gap, "flow": self.flow, "force": force}


class Adequacy(Strict):
    """Fisher adequacy test (4.14)-(4.15) on the groups of the data."""

    significance: Annotated[float, Field(gt=0, lt=1)] = 0.1
    reference: dict[str, Positive] | None = None  # traditional_disc parameters of the source's theory curve
    reference_parameters: Annotated[int, Field(ge=0)] = 2  # l of (4.15) for the reference curve (source: 2)


class LossCoefficient(Strict):
    """Solve (4.38) for one loss coefficient from a fitted alpha, the others fixed."""

    fit: str  # name of the fit whose alpha is used
    unknown: Literal["zeta1", "lambda1", "zeta2", "lambda2"]
    face_mean_diameter: Length  # d_m = r2 + r3
    seal_diameter: Length  # d_u (d1) of the annular seal
    base_gap: Length  # h_TB
    seal_clearance: Length  # h1
    seal_length: Length  # l1
    face_length: Length  # l2 = r3 - r2
    zeta1: NonNegative = 1.5  # annular seal: local loss
    lambda1: NonNegative = 0.06  # annular seal: friction
    zeta2: NonNegative = 1.5  # face throttle: local (inlet) loss
    lambda2: NonNegative = 0.06  # face throttle: friction
    friction_factor: Positive = 0.5  # zeta + f lambda l/h: 0.5 as (2.11) and Sec. 4.3.3; 1.0 as (4.38) is printed

    def losses(self) -> DiscLosses:
        """The geometry and loss coefficients as the model's parameter object (SI)."""
        return DiscLosses(**self.model_dump(exclude={"fit", "unknown"}))


class Bootstrap(Strict):
    """Residual-bootstrap confidence intervals of the traditional_disc fits (refits batched in one
    mapped Gauss-Newton call); percentile intervals at the estimation's ``confidence``."""

    samples: Annotated[int, Field(ge=20, le=1_000_000)] = 2000
    seed: Annotated[int, Field(ge=0)] = 0


class Estimation(Strict):
    data: str  # CSV path: absolute, from the working folder, or from the shipped scenarios/ folder
    bases: Bases = Bases()
    fits: Annotated[list[Fit], Field(min_length=1)]
    closed_forms: bool = True  # the source's estimators (4.23), (4.26)-(4.27), (4.35), (4.36)
    tau_max: Positive | None = None  # fixed tau_max of (4.23)/(4.35); default: the first disc fit's value
    adequacy: Adequacy | None = None
    loss_coefficient: LossCoefficient | None = None
    confidence: Annotated[float, Field(gt=0, lt=1)] = 0.95
    band_points: Annotated[int, Field(ge=2, le=10000)] = 101
    cross_check: bool = True  # re-fit with scipy.optimize.least_squares (traditional_disc fits)
    bootstrap: Bootstrap | None = None  # bootstrap intervals of the traditional_disc fits

    def measurements(self) -> Measurements:
        """The data file, read and checked (values in SI or dimensionless)."""
        return read_csv(self.data)

    @model_validator(mode="after")
    def _data_fits(self):
        names = [f.name for f in self.fits]
        if len(set(names)) != len(names):
            raise ValueError("fits: two fits have the same name")
        try:
            data = read_csv(self.data)
            for i, fit in enumerate(self.fits):
                check_fit(data, fit.residual, len(fit.free()), f"fits.{i}")
                if fit.model == "traditional_disc" and data.has("load") in ("psi1", "discharge_pressure"):
                    raise ScenarioError(f"fits.{i}: the traditional_disc model takes a load column "
                                        f"(tau or axial_force), not {data.has('load')}")
                if fit.model == "traditional_disc":  # the device model has its own bases
                    bases = self.bases.values()
                    for role in ("load", *{"u": ["gap"], "q": ["flow"], "both": ["gap", "flow"]}[fit.residual]):
                        data.dimensionless(role, bases)
        except ScenarioError as exc:
            raise ValueError(re.sub(r"\s+", " ", str(exc))) from None
        lc = self.loss_coefficient
        if lc is not None:
            fit = next((f for f in self.fits if f.name == lc.fit), None)
            if fit is None or fit.model != "traditional_disc":
                raise ValueError(f"loss_coefficient.fit: {lc.fit!r} is not a traditional_disc fit of this scene")
        if self.adequacy is not None and data.has("group") is None:
            raise ValueError(f"adequacy: needs a 'group [1]' column in {data.path.name}")
        return self
