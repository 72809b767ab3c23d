"""``analyses.spinup``: the optimal spin-up of the scene's rotor through its critical speed (global search,
direct collocation, CVODES re-simulation); :func:`ocp` is the declared problem the other spin-up analyses
share."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.errors import ScenarioError
from autobal.schema import Positive, Strict
from autobal.units import AngularAcceleration, AngularSpeed, SpeedOrZero, Time, TimeOrZero, quantity

DESCRIPTION = "optimal spin-up through the critical speed"
NEEDS = "rotor"
REPORT_SECTION = "spinup_section"
AngularJerk = quantity("angular jerk")


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


SETTINGS = Spinup


def ocp(scene, settings: Spinup):
    """The declared spin-up problem (autobal.ocp.problem.SpinupOcp) of a scene's rotor and settings."""
    from autobal.ocp.problem import SpinupOcp
    from autobal.parts.rotor import adapt

    if scene.rotor is None:
        raise ScenarioError("analyses.spinup needs a rotor section")
    drive = scene.rotor.drive
    try:
        problem = SpinupOcp(
            adapt(scene.rotor), settings.start_speed, settings.final_speed, settings.horizon,
            settings.max_acceleration,
            objective=settings.objective, settling_time=settings.settling_time, omega_max=settings.max_speed,
            torque_max=drive.max_torque if drive else None, power_max=drive.max_power if drive else None,
            braking_torque_max=drive.max_braking_torque if drive else None,
            alpha_min=-drive.max_deceleration if drive and drive.max_deceleration is not None else None,
            motor_stall_torque=drive.motor.stall_torque if drive and drive.motor else None,
            motor_no_load_speed=drive.motor.no_load_speed if drive and drive.motor else None,
            deflection_limit=settings.deflection_limit, jerk_max=settings.max_jerk,
            jerk_penalty=settings.jerk_penalty, jerk_variation=settings.jerk_variation)
    except ValueError as exc:
        raise ScenarioError(f"analyses.spinup: {exc}") from None
    why = problem.ill_posed()
    if why:
        raise ScenarioError(f"analyses.spinup: {why}")
    return problem


def run(scene, settings: Spinup):
    """Optimal spin-up through the critical speed (global search, collocation, CVODES re-simulation)."""
    from autobal.analysis import progress
    from autobal.ocp import spinup_study
    from autobal.ocp.solve import ipopt_options

    with progress.steps(None, "spin-up (starts, mesh stages)", "IPOPT solve", catch=True):
        return spinup_study.run(ocp(scene, settings), spinup_study.method_of(settings), scene.title,
                                settings.multistart, ipopt_options(settings.max_iterations, settings.tolerance),
                                settings.segments)


def estimate_seconds(settings: Spinup) -> float:
    """One collocation point per interval and degree, for each of the global search's four starts."""
    return COST["start"] + COST["ocp_collocation_point"] * settings.intervals * settings.degree * (
        4 if settings.multistart else 1)


def accuracy(scene, settings: Spinup):
    """Work-precision of the scene's spin-up OCP (collocation degree and intervals)."""
    from autobal.analysis import progress
    from autobal.ocp.workprecision import spinup_study

    with progress.steps(None, "accuracy spinup (degrees x intervals)", "IPOPT solve", catch=True):
        return spinup_study(ocp(scene, settings))
