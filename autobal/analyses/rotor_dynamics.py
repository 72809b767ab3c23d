"""``analyses.rotor_dynamics``: the source's studies of the Jeffcott rotor with a liquid auto-balancer
(Pashkov (2010)): stationary curves, speed steps, passage through the critical speed, Lewis' table, motor run-up."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field

from autobal.analyses import COST
from autobal.errors import ScenarioError
from autobal.schema import Positive, Range, Strict
from autobal.units import AngularAcceleration, AngularSpeed, SpeedOrZero, Time, quantity

DESCRIPTION = "Jeffcott rotor studies"
NEEDS = "rotor"
QUANTITIES_MODULE = "autobal.analysis.studies.rotor_study"  # its QUANTITIES declare every number of its block
TITLE = "Rotor dynamics"  # of its section of report.html
RateOrZero = quantity("rate", "nonnegative")  # n = chi/m1, 1/s
Fraction = Annotated[float, Field(gt=0, le=1)]


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


SETTINGS = RotorDynamics


def run(scene, settings: RotorDynamics):
    """The source's studies of the Jeffcott rotor with a liquid auto-balancer (Pashkov (2010))."""
    from autobal.analysis.run import progress
    from autobal.analysis.studies import rotor_study
    from autobal.ocp.problem import MAX_PERIODS
    from autobal.parts.rotor import adapt

    if scene.rotor is None:
        raise ScenarioError("analyses.rotor_dynamics needs a rotor section")
    drive, params = scene.rotor.drive, adapt(scene.rotor)
    ps = settings.passage
    for key in ("acceleration", "sensitivity_acceleration"):
        a = getattr(ps, key, None)
        periods = (ps.final_ratio * params.Omega0 - ps.start_speed) / a * params.Omega0 / (2 * math.pi) if a else 0
        if periods > MAX_PERIODS:  # CVODES over the passage would not finish
            raise ScenarioError(f"analyses.rotor_dynamics.passage.{key}: {a:g} rad/s^2 takes {periods:.3g} natural "
                                f"periods of the rotor to reach final_ratio, more than {MAX_PERIODS:.0e}: give at "
                                f"least {a * periods / MAX_PERIODS:.3g} rad/s^2")
    from autobal.analysis.numerics.rotor import lewis_end

    for a in settings.lewis.accel_ratio if settings.lewis else ():
        periods = lewis_end(a) / a / (2 * math.pi)  # from rest to lewis_end at a* = alpha/Omega^2, in 2 pi/Omega
        if periods > MAX_PERIODS:  # CVODES over the run would not finish
            raise ScenarioError(f"analyses.rotor_dynamics.lewis.accel_ratio: {a:g} takes {periods:.3g} natural "
                                f"periods of the rotor from rest past its critical speed, more than "
                                f"{MAX_PERIODS:.0e}: give at least {a * periods / MAX_PERIODS:.2g}")
    with progress.steps(None, "rotor dynamics (curves, steps, passage, Lewis cases)", "part", catch=True):
        return rotor_study.run(params, spec(settings, drive.motor if drive else None), scene.title,
                               scene.rotor.unbalance.service_speed if scene.rotor.unbalance else None)


def spec(settings: RotorDynamics, motor=None):
    """The study's :class:`~autobal.analysis.studies.rotor_study.Spec` of the validated settings and the scene's
    ``rotor.drive.motor`` (SI)."""
    from autobal.analysis.studies import rotor_study as rs

    s, st, p = settings, settings.stationary, settings.passage
    return rs.Spec(
        stationary=st and rs.StationarySpec(tuple(st.cases), (st.z.start, st.z.stop, st.z.points)),
        steps=s.steps and rs.StepsSpec(tuple(s.steps.psi), tuple(s.steps.steps), s.steps.duration),
        passage=p and rs.PassageSpec(tuple(p.psi), tuple(p.friction), p.start_speed, p.acceleration, p.final_ratio,
                                     p.crossover, p.sensitivity_acceleration),
        lewis=s.lewis and rs.LewisSpec(tuple(s.lewis.zeta), tuple(s.lewis.accel_ratio)),
        motor_runup=s.motor_runup and rs.MotorRunupSpec(s.motor_runup.duration, *(
            (motor.stall_torque, motor.no_load_speed) if motor else ())))


def estimate_seconds(settings: RotorDynamics) -> float:
    """One integrator run per step response, passage (twice with the crossover search), Lewis case and run-up."""
    rd, runs = settings, 0
    runs += len(rd.steps.psi) * len(rd.steps.steps) if rd.steps else 0
    runs += len(rd.passage.psi) * len(rd.passage.friction) * (2 if rd.passage.crossover else 1) if rd.passage else 0
    runs += len(rd.lewis.zeta) * len(rd.lewis.accel_ratio) if rd.lewis else 0
    runs += 1 if rd.motor_runup else 0
    return COST["start"] + COST["rotor_run"] * runs


def report_section(sec) -> None:
    """Rotor with a liquid auto-balancer: stationary, steps, passage (Pashkov 2010); one verdict, the result's.
    Reads the fields of the loaded :class:`~autobal.analysis.studies.rotor_study.RotorDynamicsResult`
    (``sec.result``)."""
    from autobal.report import cell, table

    r = sec.result
    sec.headline_rows()  # the rows of the fields declared headline
    verdict = r.verdict()
    if verdict:
        sec.conclude(*verdict)
    api_verdict(sec, r.rotor.to_dict())
    p = r.passage
    if p is None:
        return
    accel = r.quantities.find("passage.acceleration_rad_s2")
    columns = ("n", "psi", "delta_max_over_e", "z_delta_max", "d_max")
    shown = [r.quantities.find(f"passage.table.0.{k}") for k in columns]
    rows = [[cell(getattr(run, k), q.unit, q.display, 4) for k, q in zip(columns, shown, strict=True)]
            for run in p.table]
    if rows:
        sec.tables.append(table(f"Passage through the critical speed at {accel.text(p.acceleration_rad_s2)}: peak "
                                "deflection δ*/e and its speed ratio ν = ω/Ω0",
                                ["n", "ψ", "δ*/e", "ν at the peak", "d*"], rows, headline=True))
    if p.crossover_n_star:  # keys: ψ as given
        n_star = r.quantities.find("passage.crossover_n_star.x")
        found = [(a, n) for a, n in ((p.acceleration_rad_s2, p.crossover_n_star),
                                     (p.sensitivity_acceleration_rad_s2, p.crossover_n_star_sensitivity)) if a and n]
        rows = [[cell(float(psi), "1"), *(cell(n.get(psi), n_star.unit) for _, n in found)]
                for psi in p.crossover_n_star]
        sec.tables.append(table("Damping n* above which the liquid raises the passage peak, per liquid mass ratio ψ "
                                "(Pashkov (2010), Fig. 9)", ["ψ", *(f"n* at {accel.text(a)}" for a, _ in found)],
                                rows))


def api_verdict(sec, margins: dict) -> None:
    """The check line of the API 684 (2005) separation margin (kept or not, or why there is none)."""
    from autobal.analysis.numerics.standards import margin_words

    if "amplification_factor" in margins:
        sec.verdict(margins.get("separation_margin_ok"), "API 684 (2005): " + margin_words(margins))

