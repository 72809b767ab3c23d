"""Scenario schema of the reliability studies: the traditional disc's wear and time to failure
(``analyses.reliability``, Pavlenko 2014 ch. 1.2), the Monte Carlo spreads of the balancing device
(``analyses.montecarlo``, ch. 3) and where studies run (top-level ``executor``).

Uncertain parameters are named by the model's dimensionless groups (2.18); a name the model does
not have, a negative standard deviation or an impossible correlation is refused at load time
with one line naming it.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from autobal.models.device import DEVICE_GROUPS, REGULATOR_GROUPS
from autobal.schema import NonNegative, Positive, Strict
from autobal.schema_dynamics import OmegaGrid
from autobal.units import Length, quantity

Time = quantity("time")
Probability = Annotated[float, Field(gt=0, lt=1)]
MAX_SAMPLES = 2_000_000  # statics Monte Carlo: ~0.2 kB a sample in memory (0.4 GB at the bound)
MAX_AFC_SAMPLES = 1_000_000  # AFC Monte Carlo: a frequency response per sample

# ---- chapter 1.2: traditional disc, wear and time to failure -------------------------------------


class HydroHeelDisc(Strict):
    """Traditional balance disc, (1.30)-(1.32): inner annular seal r1, l1; face r2 < r3; base gap z_B.

    The new seal is given by its clearance ``seal_clearance`` (h1, chi0 = h1/z_B) or by the face/seal
    conductance ratio ``conductance_ratio`` (alpha_T1, chi0 = cbrt(k/alpha_T1)), not both."""

    seal_radius: Length = Field(description="r1")
    seal_length: Length = Field(description="l1")
    face_inner_radius: Length = Field(description="r2")
    face_outer_radius: Length = Field(description="r3")
    base_gap: Length = Field(description="h_TB = z_B")
    effective_area_ratio: Positive = Field(description="sigma = s_e/s_B")
    conductance_ratio: Positive | None = Field(None, description="alpha_T1")
    seal_clearance: Length | None = Field(None, description="h1")

    @model_validator(mode="after")
    def _one_clearance(self):
        if self.face_outer_radius <= self.face_inner_radius:
            raise ValueError("face_outer_radius must be larger than face_inner_radius")
        if (self.conductance_ratio is None) == (self.seal_clearance is None):
            raise ValueError("give exactly one of conductance_ratio (alpha_T1) or seal_clearance (h1, m)")
        return self


class Wear(Strict):
    """Mean wear of the seal clearance read from the erosion curve (Fig. 1.25): ``depth`` per ``per``."""

    depth: Length = Field(description="e.g. 0.05 mm")
    per: Time = Field(description="e.g. 1000 h")
    cv: NonNegative = Field(0.2, description="kappa = sigma_b / b_mean (1.50)")

    @field_validator("cv")
    @classmethod
    def _cv_positive(cls, v):
        if v <= 0:
            raise ValueError("the wear rate's coefficient of variation must be positive (kappa, e.g. 0.2)")
        return v


class Load(Strict):
    mean: Positive = Field(description="tau_bar = T/(p_B s_B)")
    cv: Positive = Field(0.2, description="kappa = sigma_tau / tau_bar (1.50)")
    discharge_ratio: Positive = Field(1.0, description="psi1")


class Limits(Strict):
    min_gap: Positive = Field(description="u_min")
    max_flow: Positive = Field(description="q_max -> u_max (1.52)")


class Reliability(Strict):
    """P(t) (1.48) and mean time to failure (1.49) of the traditional disc."""

    disc: HydroHeelDisc
    wear: Wear
    load: Load
    limits: Limits
    times: list[Time] = Field(default_factory=lambda: [7.2e6, 1.44e7], min_length=1, max_length=1000,
                             description="times at which P(t) is reported (at most 1000)")
    horizon: Time = Field(1.44e8, description="40 000 h, upper limit of (1.49) by the trapezoid rule")
    time_points: Annotated[int, Field(ge=11, le=100001)] = Field(
        4001, description="points of the P(t) curve, 11 to 100,001")
    tau_nodes: Annotated[int, Field(ge=101, le=200001)] = Field(
        20001, description="nodes of the load integral, 101 to 200,001")
    reliable_probability: Probability = Field(0.8, description="Table 1.2: time of reliable operation at this P")

    @model_validator(mode="after")
    def _limits(self):
        from autobal.models.hydroheel import conductance_ratio, max_gap, seal_shape_factor

        d = self.disc
        k = seal_shape_factor(d.seal_radius, d.seal_length, d.face_inner_radius, d.face_outer_radius)
        alpha = d.conductance_ratio or float(conductance_ratio(k, d.seal_clearance / d.base_gap))
        u_max = max_gap(self.limits.max_flow, alpha)
        if not u_max > self.limits.min_gap:
            raise ValueError(f"limits: min_gap {self.limits.min_gap:g} must be below the gap at max_flow "
                             f"(u_max = {u_max:.4g} by (1.52))")
        if any(t <= 0 for t in self.times) or max(self.times) > self.horizon:
            raise ValueError("times must be positive and not beyond the horizon (s, e.g. '2000 h')")
        return self


# ---- chapter 3: Monte Carlo ------------------------------------------------------------------------


class Distribution(Strict):
    """One uncertain parameter.

    normal, lognormal, gauss12 (the source's sum of 12 uniforms, Fig. 3.1): ``mean`` (default: the
    model's nominal value) and ``std`` (absolute) or ``cv`` (std/mean); lognormal's mean and std
    are those of the parameter itself.  uniform: ``low`` and ``high``, or ``mean`` with ``std``/``cv``
    (half-width sqrt(3) std)."""

    distribution: Literal["normal", "uniform", "lognormal", "gauss12"] = "normal"
    mean: float | None = None
    std: float | None = None
    cv: float | None = None
    low: float | None = None
    high: float | None = None

    @model_validator(mode="after")
    def _spread(self):
        for key in ("std", "cv"):
            v = getattr(self, key)
            if v is not None and not v >= 0:
                raise ValueError(f"{key} must not be negative, got {v:g}")
        bounds = self.low is not None or self.high is not None
        spread = self.std is not None or self.cv is not None
        if self.std is not None and self.cv is not None:
            raise ValueError("give std or cv, not both")
        if self.distribution == "uniform" and bounds:
            if self.low is None or self.high is None or spread or self.mean is not None:
                raise ValueError("uniform: give low and high, or mean with std or cv")
            if not self.high > self.low:
                raise ValueError(f"uniform: high ({self.high:g}) must be larger than low ({self.low:g})")
        elif bounds:
            raise ValueError(f"low/high are for the uniform distribution, not {self.distribution}")
        elif not spread:
            raise ValueError(f"{self.distribution}: give std or cv")
        return self


class Correlation(Strict):
    """A correlation coefficient between two uncertain parameters (Gaussian copula)."""

    between: Annotated[list[str], Field(min_length=2, max_length=2)]
    rho: Annotated[float, Field(ge=-1, le=1)]


# the static model's groups that may be uncertain: its DeviceGroups and RegulatorGroups and the margin dpsi
PARAMETERS = (*DEVICE_GROUPS, "dpsi", *REGULATOR_GROUPS)


class AfcMonteCarlo(Strict):
    """Monte Carlo of the face-gap amplitude A_u(omega) through a linear model of the dynamics (Fig. 3.7).

    ``model``: by default the exact linearization of the energy-consistent nonlinear model ("nonlinear";
    or "nonlinear_chain"), whose uncertain parameters are the dynamic data m_p, k_pr, c_z, E, V2, V3,
    m0, k_reg, c_x, V_cam, V_m, s_c (SI); or, for the validation against the source, a hand model of
    (2.43)/(2.101) ("program" as App. A/B and Fig. 3.7, "thesis", "consistent"), whose uncertain
    parameters are its constants K1..K13, T1..T9, tau3, tau5, tau6, tau7, zeta1, zeta2 (the program
    model is unstable at the pumps' operating points: its AFC is not a steady response)."""

    model: Literal["program", "thesis", "consistent", "nonlinear", "nonlinear_chain"] = Field(
        "nonlinear", description="linear model of the AFC: nonlinear (energy-consistent, default), nonlinear_chain, "
                                 "or the source's hand models program, thesis, consistent (validation)")
    samples: Annotated[int, Field(ge=10, le=MAX_AFC_SAMPLES)] = Field(
        20_000, description=f"Monte Carlo samples of the AFC, 10 to {MAX_AFC_SAMPLES:,}")
    chunk_size: Annotated[int, Field(ge=10, le=100_000)] = Field(5_000, description="samples per task, 10 to 100,000")
    operating_ratio: Positive = Field(1.0, description="psi1 of the operating point")
    forcing: Literal["appendix", "physical"] = Field(
        "physical", description="dtau = b dpsi1 (physical, default) or dpsi1 (App. A/B, Fig. 3.7)")
    omega: OmegaGrid = Field(default_factory=lambda: OmegaGrid(start="100 rad/s", stop="6000 rad/s", points=120),
                             description="frequency grid; default 100 to 6000 rad/s, 120 points")
    parameters: dict[str, Distribution] = Field(min_length=1)



class MonteCarlo(Strict):
    """Monte Carlo over the device's uncertain dimensionless groups (ch. 3)."""

    samples: Annotated[int, Field(ge=10, le=MAX_SAMPLES)] = Field(
        100_000, description=f"Monte Carlo samples, 10 to {MAX_SAMPLES:,}")
    seed: Annotated[int, Field(ge=0)] = 2014
    chunk_size: Annotated[int, Field(ge=10, le=1_000_000)] = Field(25_000, description="samples per executor task")
    discharge_ratio: list[Annotated[float, Field(gt=0, le=100)]] = Field(
        default_factory=lambda: [0.5, 0.75, 1.0, 1.25, 1.5], min_length=1, max_length=20,
        description="discharge ratios psi1 = p1/p_B (0 to 100) at which the statics are sampled, at most 20")
    parameters: dict[str, Distribution] = Field(min_length=1)
    correlations: list[Correlation] = Field(default_factory=list, max_length=100)
    band_sigma: Positive = Field(
        3.0, description="bands m +- k sigma; k = 3 reproduces the source's \"20 %\", \"25 %\"")
    quantiles: list[Probability] = Field(
        default_factory=lambda: [0.00135, 0.5, 0.99865], max_length=100,
        description="quantiles reported (at most 100); the default: +-3 sigma of a normal")
    sensitivity_step: Positive = Field(
        1e-6, description="relative step of the finite-difference check of the exact derivatives")
    afc: AfcMonteCarlo | None = Field(
        None, description="the AFC amplitude through a linear model of the dynamics (needs device.dynamics)")

    @model_validator(mode="after")
    def _names(self):
        for name in self.parameters:
            if name not in PARAMETERS:
                raise ValueError(f"parameters.{name}: not a parameter of the model; expected one of "
                                 f"{', '.join(PARAMETERS)}")
        for c in self.correlations:
            for name in c.between:
                if name not in self.parameters:
                    raise ValueError(f"correlations: {name} is not one of the uncertain parameters")
            if c.between[0] == c.between[1]:
                raise ValueError(f"correlations: {c.between[0]} with itself")
            gauss12 = [n for n in c.between if self.parameters[n].distribution == "gauss12"]
            if gauss12:
                raise ValueError(f"correlations: {gauss12[0]} has the gauss12 distribution, which has no "
                                 f"copula; use normal")
        if self.correlations:
            names = list(self.parameters)
            c = np.eye(len(names))
            for r in self.correlations:
                i, j = names.index(r.between[0]), names.index(r.between[1])
                c[i, j] = c[j, i] = r.rho
            if np.linalg.eigvalsh(c).min() <= 1e-12:
                raise ValueError("correlations: the correlation matrix is not positive definite")
        return self


class Executor(Strict):
    """How studies run: the progress bar.  Where they run (a dask.distributed scheduler) is never a scene's
    choice: ``--scheduler``, ``autobal.run(..., scheduler=...)`` or the environment variable AUTOBAL_SCHEDULER."""

    progress: bool = Field(True, description="a progress bar on runs of more than one task (on a terminal)")

    @model_validator(mode="before")
    @classmethod
    def _no_scheduler(cls, data):
        if isinstance(data, dict) and "scheduler" in data:
            raise ValueError("scheduler: a scene cannot name a scheduler (a scene is data and contacts no host); "
                             "give it on the command line (--scheduler), in the API (autobal.run(..., "
                             "scheduler=...)) or in the environment (AUTOBAL_SCHEDULER)")
        return data
