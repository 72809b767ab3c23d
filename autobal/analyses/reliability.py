"""``analyses.reliability``: the traditional balance disc's wear and time to failure, P(t) and MTTF (Pavlenko
(2014), ch. 1.2); it needs no scene part (the disc is given in its settings)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, field_validator, model_validator

from autobal.analyses import COST
from autobal.schema import NonNegative, Positive, Strict
from autobal.units import Length, Time

DESCRIPTION = "traditional disc wear and time to failure"
NEEDS = None
QUANTITIES_MODULE = "autobal.analysis.studies.reliability"  # its QUANTITIES declare every number of its block
TITLE = "Reliability"  # of its section of report.html
Probability = Annotated[float, Field(gt=0, lt=1)]


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


SETTINGS = Reliability


def run(scene, settings: Reliability):
    """Reliability of the traditional balance disc: P(t), MTTF, wear (Pavlenko 2014, ch. 1.2)."""
    from autobal.analysis.studies import reliability as rel

    return rel.run(spec(settings), scene.title)


def spec(settings: Reliability):
    """The study's :class:`~autobal.analysis.studies.reliability.Spec` of the validated settings (SI)."""
    from autobal.analysis.studies import reliability as rel

    s = settings
    return rel.Spec(rel.Disc(**dict(s.disc)), rel.Wear(**dict(s.wear)), rel.Load(**dict(s.load)),
                    rel.Limits(**dict(s.limits)), tuple(s.times), s.horizon, s.time_points, s.tau_nodes,
                    s.reliable_probability)


def estimate_seconds(settings: Reliability) -> float:
    """The reliability integrals over (time, load) nodes."""
    return COST["start"] + COST["reliability_node"] * settings.time_points * settings.tau_nodes


def report_section(sec) -> None:
    """Wear, reliability P(t) and mean time to failure of the traditional disc (Pavlenko 2014, ch. 1.2); reads the
    fields of the loaded :class:`~autobal.analysis.studies.reliability.ReliabilityResult` (``sec.result``)."""
    from autobal.analysis.run.result import plain
    from autobal.analysis.studies.reliability import HOUR
    from autobal.report import number

    r = sec.result
    sec.rows_of(r, "u_max", "b_mean", "tau_mean")
    sec.rows_of(r.literal, "P", label=lambda i: f"reliability at {number(r.times[i] / HOUR)} h (literal (1.48))")
    sec.rows_of(r.literal, "mttf")
    sec.rows_of(r.renormalised, "mttf")
    level = r.reliable_probability
    for variant, v in (("literal", r.literal), ("renormalised", r.renormalised)):
        t = plain(v.time_at)
        if t is None and level is not None:
            sec.verdict(False, f"{variant}: P(t) never reaches {number(level)} (P(0) = {number(v.P0)}): no time of "
                               "reliable operation")
        elif t is not None:
            sec.verdict(None, f"{variant}: P(t) ≥ {number(level)} up to t = {number(t / HOUR)} h")
