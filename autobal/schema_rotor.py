"""Scenario schema of the rotor (optional top-level part ``rotor:``) and of its analyses
``rotor_dynamics`` (the source's studies, Pashkov 2010) and ``spinup`` (the optimal spin-up OCP).

Quantities are written with units and converted to SI at load time; the source's dimensionless
groups (psi, mu1, the stationary n, zeta, a*) are plain numbers named as in the source.
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from autobal.schema import Positive, Range, Strict
from autobal.units import AngularSpeed, Density, Length, quantity

Mass = quantity("mass")
Stiffness = quantity("stiffness")
DampingOrZero = quantity("damping", "nonnegative")
Time = quantity("time")
TimeOrZero = quantity("time", "nonnegative")
AngularAcceleration = quantity("angular acceleration")
AngularJerk = quantity("angular jerk")
Torque = quantity("torque")
Power = quantity("power")
Inertia = quantity("moment of inertia")
RotationalDampingOrZero = quantity("rotational damping", "nonnegative")
SpeedOrZero = quantity("angular speed", "nonnegative")
RateOrZero = quantity("rate", "nonnegative")  # n = chi/m1, 1/s
Fraction = Annotated[float, Field(gt=0, le=1)]
UnbalanceMass = quantity("unbalance")
_GRADE = re.compile(r"G\s*(\d+(?:\.\d*)?)")


class Liquid(Strict):
    """Liquid auto-balancer layer (model M1): a chamber of wall radius R and height h of
    liquid density rho (full-chamber mass rho pi R^2 h), or the design parameter psi = m1/m directly."""

    density: Density | None = None
    radius: Length | None = None
    height: Length | None = None
    free_surface_radius: Length | None = None
    psi: Fraction | None = None

    @model_validator(mode="after")
    def _geometry_or_psi(self):
        geo = [self.density, self.radius, self.height]
        if self.psi is None and any(v is None for v in geo):
            raise ValueError("give density, radius and height of the chamber, or psi")
        if self.psi is not None and any(v is not None for v in geo):
            raise ValueError("give either the chamber (density, radius, height) or psi, not both")
        if self.free_surface_radius is not None and self.radius is not None and self.free_surface_radius >= self.radius:
            raise ValueError("free_surface_radius must be smaller than radius")
        return self


class Motor(Strict):
    """Linear motor characteristic L(omega) = stall_torque (1 - omega/no_load_speed)."""

    stall_torque: Torque
    no_load_speed: AngularSpeed


class Drive(Strict):
    """The drive as specified: inertia and drag, torque and power limits, motor characteristic, and braking
    (a braking-torque limit, 0 = no braking, and/or a deceleration limit, 0 = the speed never falls; without
    either the drive brakes up to max_torque and decelerates up to the spin-up's max_acceleration)."""

    polar_inertia: Inertia = Field(description="J_p of rotor and drive")
    drag: RotationalDampingOrZero = Field(0.0, description="b, N m s")
    max_torque: Torque | None = None
    max_power: Power | None = None
    motor: Motor | None = None
    max_braking_torque: quantity("torque", "nonnegative") | None = Field(
        None, description="the largest braking torque -M, N m (0: the drive cannot brake)")
    max_deceleration: quantity("angular acceleration", "nonnegative") | None = Field(
        None, description="the largest deceleration -alpha (0: the speed never falls), rad/s^2")


class Unbalance(Strict):
    """The rotor's unbalance as a datasheet gives it: a balance quality grade G (ISO 21940-11, G in mm/s) at the
    service speed, e = G/Omega_service, or the residual unbalance U (e.g. 120 g*mm), e = U/m."""

    grade: str | None = Field(None, description="balance quality grade, e.g. G2.5 (G = e Omega in mm/s)")
    service_speed: AngularSpeed | None = None
    residual: UnbalanceMass | None = None

    @field_validator("grade")
    @classmethod
    def _grade(cls, v):
        if v is not None and (not _GRADE.fullmatch(v.strip()) or float(_GRADE.fullmatch(v.strip())[1]) <= 0):
            raise ValueError(f"{v!r}: a balance quality grade is G and a positive number in mm/s, e.g. G2.5")
        return v

    @model_validator(mode="after")
    def _one(self):
        if (self.grade is None) != (self.service_speed is None):
            raise ValueError("give grade (e.g. G2.5) together with service_speed (e.g. 3000 rpm)")
        if (self.grade is None) == (self.residual is None):
            raise ValueError("give either grade with service_speed or residual (e.g. 120 g*mm), not both")
        return self

    @property
    def grade_m_s(self) -> float | None:
        """G in SI, m/s."""
        return None if self.grade is None else float(_GRADE.fullmatch(self.grade.strip())[1]) * 1e-3


class Rotor(Strict):
    """Jeffcott (Laval) rotor on a flexible shaft, with optional liquid layer and drive.

    Given in SI (stiffness, damping, eccentricity) or from its datasheet (critical_speed, the undamped natural
    frequency sqrt(c/m1) of the rotor without liquid; damping_ratio zeta = chi/(2 sqrt(c m1)); unbalance as a
    balance quality grade or a residual unbalance); each pair one or the other."""

    mass: Mass = Field(description="m1, without liquid (the modal mass)")
    stiffness: Stiffness | None = Field(None, description="c")
    damping: DampingOrZero | None = Field(None, description="chi, external viscous friction")
    eccentricity: Length | None = Field(None, description="e")
    critical_speed: AngularSpeed | None = Field(None, description="undamped critical speed sqrt(c/m1)")
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] | None = Field(
        None, description="zeta = chi/(2 sqrt(c m1)), dimensionless")
    unbalance: Unbalance | None = None
    liquid: Liquid | None = None
    drive: Drive | None = None

    @model_validator(mode="after")
    def _si_or_datasheet(self):
        for si, sheet, how in (("stiffness", "critical_speed", "N/m, or rpm"),
                               ("damping", "damping_ratio", "N*s/m, or dimensionless"),
                               ("eccentricity", "unbalance", "m, or a grade/residual block")):
            if (getattr(self, si) is None) == (getattr(self, sheet) is None):
                raise ValueError(f"give exactly one of {si} and {sheet} ({how})")
        return self


# ---- analyses ----------------------------------------------------------------------------------------

class Stationary(Strict):
    """Stationary curves (9) of Figs 5-6 over z = (omega/Omega0)^2 for pairs (mu1, n), n = chi^2/(c m1)."""

    cases: Annotated[list[tuple[Annotated[float, Field(ge=1, le=1e6)], Positive]], Field(max_length=100)] = [
        (2, 0.1), (2, 0.7), (4, 0.1), (4, 0.7)]
    z: Range = Range(start=0.01, stop=3.0, points=600)


class Steps(Strict):
    """Speed steps (4)-(7), Figs 3-4: closed form beside CVODES, for each psi."""

    psi: Annotated[list[Fraction], Field(max_length=100)] = [1.0, 0.75, 0.5, 0.25]
    steps: list[tuple[SpeedOrZero, SpeedOrZero]] = Field(max_length=100, description="(from, to) angular speeds")
    duration: Time = 0.6


class Passage(Strict):
    """Uniform acceleration through the critical speed (8')-(9'), Figs 7-9."""

    psi: Annotated[list[Fraction], Field(max_length=100)] = [1.0, 0.75, 0.5, 0.25]
    friction: list[RateOrZero] = Field(max_length=100, description="n = chi/m1 of section 3.7, 1/s")
    start_speed: AngularSpeed
    acceleration: AngularAcceleration = Field(description="beta'' = 2 eps")
    final_ratio: Positive = Field(2.0, description="run to omega/Omega0")
    crossover: bool = Field(True, description="find n* where max d(psi) = max d(1)")
    sensitivity_acceleration: AngularAcceleration | None = Field(None, description="the 10 s^-2 variant")


class Lewis(Strict):
    """Jeffcott rotor from rest at constant acceleration: table over zeta and a* = alpha/Omega^2."""

    zeta: Annotated[list[Annotated[float, Field(ge=0, lt=1)]], Field(max_length=100)] = [0.0, 0.01, 0.02, 0.05, 0.1]
    accel_ratio: Annotated[list[Positive], Field(max_length=100)] = [1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2]


class MotorRunup(Strict):
    """Run-up with the scene's motor characteristic: passes, or is captured (Sommerfeld)."""

    duration: Time


class RotorDynamics(Strict):
    stationary: Stationary | None = None
    steps: Steps | None = None
    passage: Passage | None = None
    lewis: Lewis | None = None
    motor_runup: MotorRunup | None = None


class Spinup(Strict):
    """Optimal spin-up through the critical speed, posed as a drive is specified: reach ``final_speed``
    by the deadline ``horizon``, hold it over ``settling_time`` (the peak counts over the whole window),
    never exceed ``max_speed``."""

    start_speed: SpeedOrZero
    final_speed: AngularSpeed
    horizon: Time = Field(description="the deadline: the final time (its upper bound with the min_time objective)")
    max_acceleration: AngularAcceleration
    max_speed: AngularSpeed | None = None
    objective: Literal["peak_deflection", "peak_unbalance", "integrated_deflection", "min_time"] = "peak_deflection"
    settling_time: TimeOrZero = 0.0
    deflection_limit: Positive | None = Field(None, description="bound on the deflection delta/e")
    max_jerk: AngularJerk | None = Field(None, description="bound on |d alpha/dt| between control intervals")
    jerk_penalty: Annotated[float, Field(ge=0, le=1e6)] = Field(
        0.0, description="weight of sum (Delta alpha/alpha_max)^2 over the control intervals in the objective "
        "(scaled by the maximum-acceleration ramp's), dimensionless")
    jerk_variation: Annotated[float, Field(ge=0, le=1e6)] = Field(
        1e-4, description="weight of the total variation sum |Delta alpha/alpha_max| over the control intervals "
        "(smoothed below 0.01) in the objective (scaled by the maximum-acceleration ramp's), dimensionless: "
        "removes one-interval pulses (chattering), keeps the switches sharp; 0 switches it off")
    method: Literal["collocation", "multiple_shooting"] = "collocation"
    scheme: Literal["radau", "legendre"] = "radau"
    degree: Annotated[int, Field(ge=1, le=9)] = Field(3, description="collocation degree, 1 to 9")
    intervals: Annotated[int, Field(ge=4, le=5000)] = Field(200, description="control intervals, 4 to 5,000")
    nlp_solver: Literal["ipopt", "fatrop"] = Field(
        "ipopt", description="the NLP solver of the collocation: ipopt (MUMPS), or fatrop (a Riccati recursion over "
        "the stages; Radau collocation only)")
    multistart: bool = True
    segments: Annotated[int, Field(ge=0, le=12)] = Field(
        4, description="ramp segments of the drive's table (drive_segments.csv), optimised for the same objective "
        "under the same limits, 1 to 12; 0: no table")
    max_iterations: Annotated[int, Field(ge=1, le=100000)] = Field(
        1000, description="IPOPT's iteration limit per solve (each start and each mesh-continuation stage)")
    tolerance: Annotated[float, Field(gt=0, lt=1)] = Field(
        1e-8, description="IPOPT's tolerance (dimensionless): optimality, constraint violation and complementarity")

    @model_validator(mode="after")
    def _consistent(self):
        if self.objective == "min_time" and self.deflection_limit is None:
            raise ValueError("the min_time objective needs deflection_limit (delta/e)")
        if self.max_speed is not None and self.max_speed < max(self.start_speed, self.final_speed):
            raise ValueError("max_speed must not be below start_speed and final_speed")
        if self.method == "multiple_shooting" and self.objective == "integrated_deflection":
            raise ValueError("multiple_shooting supports the peak and min_time objectives")
        if self.nlp_solver == "fatrop" and (self.method != "collocation" or self.scheme != "radau"):
            raise ValueError("nlp_solver fatrop needs method collocation with scheme radau")
        return self


class SpinupRobust(Spinup):
    """Robust spin-up: one profile minimising the worst-case re-simulated peak over a set of rotors around the
    scene's (critical speed, damping and, with a liquid block, liquid mass), checked on a random validation
    sample beside the nominal optimum and the constant ramps."""

    critical_speed_spread: Annotated[float, Field(ge=0, le=0.5)] = Field(
        0.05, description="the critical speed within (1 +- spread) of the scene's (stiffness scaled), dimensionless")
    damping_factor: Annotated[list[Positive], Field(min_length=2, max_length=2)] = Field(
        [0.5, 2.0], description="range [lo, hi] of the factor on the damping chi, dimensionless")
    liquid_mass_factor: Annotated[list[Annotated[float, Field(ge=0, le=100)]], Field(
        min_length=2, max_length=2)] | None = Field(
        None, description="range [lo, hi] of the factor on the liquid mass (scenes with a liquid block), dimensionless")
    design_points: Annotated[int, Field(ge=1, le=9)] = Field(
        3, description="grid points per uncertain quantity in the design set, 1 to 9")
    validation_samples: Annotated[int, Field(ge=1, le=1_000_000)] = Field(
        1000, description="rotors drawn from the same ranges to validate the profiles, 1 to 1,000,000")
    seed: Annotated[int, Field(ge=0)] = Field(1, description="seed of the validation sample")
    ramps: Annotated[int, Field(ge=2, le=50)] = Field(
        8, description="constant ramps compared, from the slowest meeting the deadline to max_acceleration")

    @model_validator(mode="after")
    def _robust(self):
        if self.objective != "peak_deflection" or self.method != "collocation":
            raise ValueError("spinup_robust minimises the worst-case peak_deflection by collocation")
        if self.nlp_solver != "ipopt":
            raise ValueError("spinup_robust solves its multi-rotor NLP with nlp_solver ipopt")
        if "segments" in self.model_fields_set:
            raise ValueError("segments: the ramp table is written by the spinup analysis only")
        for name in ("damping_factor", "liquid_mass_factor"):
            v = getattr(self, name)
            if v is not None and v[0] > v[1]:
                raise ValueError(f"{name}: [lo, hi] with lo <= hi (dimensionless)")
        return self


class SpinupTimeOptimal(Spinup):
    """Time-optimal spin-up: the earliest arrival at ``final_speed`` with the peak deflection bounded (the
    settling window still counts), and the Pareto front of peak against arrival time up to the deadline
    ``horizon``."""

    front_points: Annotated[int, Field(ge=2, le=50)] = Field(
        6, description="points of the front between the minimum-peak profile and the fastest ramp, 2 to 50")

    @model_validator(mode="after")
    def _time_optimal(self):
        if self.method != "collocation":
            raise ValueError("spinup_time_optimal is built on collocation")
        if self.nlp_solver != "ipopt":
            raise ValueError("spinup_time_optimal solves with nlp_solver ipopt")
        if "segments" in self.model_fields_set:
            raise ValueError("segments: the ramp table is written by the spinup analysis only")
        return self
