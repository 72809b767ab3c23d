"""``analyses.spinup_robust``: one spin-up profile minimising the worst-case peak over a set of rotors around
the scene's, validated on a random sample beside the nominal optimum and the constant ramps."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analyses.spinup import Spinup, check, ocp  # noqa: F401 (check: the same as spinup's)
from autobal.errors import ScenarioError
from autobal.schema import Positive

DESCRIPTION = "one spin-up profile for a set of rotors (worst case)"
NEEDS = "rotor"
QUANTITIES_MODULE = "autobal.ocp.robust_study"  # its QUANTITIES declare every number of its block
TITLE = "Robust spin-up"  # of its section of report.html


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


SETTINGS = SpinupRobust


def run(scene, settings: SpinupRobust):
    """One spin-up profile minimising the worst-case peak over a set of rotors, validated on a random sample
    (on the executor the CLI or the scene names)."""
    from autobal.analysis.run import executor, progress
    from autobal.analysis.run.solver_options import ipopt_options
    from autobal.ocp import robust, robust_study
    from autobal.ocp.transcription import DirectCollocation

    problem = ocp(scene, settings)
    liquid = settings.liquid_mass_factor
    if liquid is not None and problem.params.m2_star == 0:
        raise ScenarioError("analyses.spinup_robust.liquid_mass_factor: the rotor has no liquid block (rotor.liquid)")
    unc = robust.Uncertainty(settings.critical_speed_spread, tuple(settings.damping_factor),
                             tuple(liquid) if liquid is not None else None)
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe, \
            progress.steps(None, "robust spin-up (nominal, scenario generation)", "IPOPT solve", catch=True):
        return robust_study.run(problem, DirectCollocation(settings.intervals, settings.degree, settings.scheme), unc,
                                settings.design_points, settings.validation_samples, settings.seed, settings.ramps,
                                exe, scene.title, settings.multistart,
                                ipopt_options(settings.max_iterations, settings.tolerance))


def estimate_seconds(settings: SpinupRobust) -> float:
    """The nominal and multi-rotor collocation NLPs, then every profile on every validation rotor."""
    return (COST["start"] + COST["ocp_collocation_point"] * settings.intervals * settings.degree * 12
            + COST["robust_validation_run"] * settings.validation_samples * (settings.ramps + 2))


def report_section(sec) -> None:
    """Robust spin-up (the Jeffcott rotor's ``spinup_robust``, peaks delta/e; the modal rotor's
    ``ross_spinup_robust``, peaks in m shown in µm or the chosen length unit, as the block's ``peak_unit`` states):
    the robust profile, the nominal optimum and the best ramp on the design set and on the validation sample; the
    verdict is the robust profile's worst validation peak against the others'.  Reads the fields of the loaded
    :class:`~autobal.ocp.robust_study.RobustResult` (``sec.result``)."""
    from autobal.ocp.robust_study import PEAK_SYMBOL
    from autobal.ocp.spinup_study import QUANTITIES as SPINUP
    from autobal.report import cell, table, text

    r = sec.result
    sec.conclude(*r.verdict())
    sec.headline_rows()  # the rows of the fields declared headline
    sec.rows_of(r, "eccentricity_m", "design_scenarios", "active_scenarios", "validation_samples", "build_time_s",
                "solve_time_s", "validation_time_s", "validation_check_rel_error")
    unit, sym, e = r.peak_unit, PEAK_SYMBOL[r.peak_unit], r.eccentricity_m
    shown = None if unit == "1" else r.quantities.find("profiles.robust.validation_worst_m").display

    def pc(v):
        return cell(v, unit, shown)

    physical = SPINUP.find("peak_deflection_m")
    rows = []
    for _, p in r.profiles.items():
        q, worst = p.validation_quantiles, p.validation_worst
        rows.append([text(p.label), pc(p.nominal_peak), pc(p.design_worst), pc(q.get("0.5")), pc(q.get("0.99")),
                     pc(worst)]
                    + ([cell(None if e is None or worst is None else worst * e, "m", physical.display)]
                       if unit == "1" else []))
    what = ("δ*/e", "; the worst as a deflection δ* (0-peak)") if unit == "1" else \
        ("r* (the largest whirl radius over the nodes, 0-peak)", "")
    sec.tables.append(table(f"Peak deflection {what[0]} of each profile: on the nominal rotor, worst over the "
                            f"design set (CVODES), and over the validation sample{what[1]}",
                            ["profile", "nominal rotor", "design worst", "validation median", "validation 99 %",
                             "validation worst"] + (["validation worst δ*"] if unit == "1" else []), rows,
                            headline=True))
    alpha = r.quantities.find("ramps[].alpha_rad_s2")
    rows = [[text(p.label), cell(p.alpha_rad_s2, alpha.unit, alpha.display, 4), pc(p.design_worst),
             pc(p.validation_worst),
             text({True: "within", False: f"OUTSIDE: {p.violated}", None: "no drive data"}[p.within_drive_limits])]
            for p in r.ramps]
    if rows:
        sec.tables.append(table(f"Constant ramps: worst peak {sym} over the design set and the validation sample",
                                ["ramp", "acceleration", "design worst", "validation worst", "drive limits"], rows))
    rows = [[text(x.start), cell(x.intervals, "1"), cell(x.scenarios, "1"), text(x.status), cell(x.iterations, "1"),
             cell(x.build_time_s, "s"), cell(x.solve_time_s, "s"),
             pc(x.worst_design_peak)] for x in r.rounds]
    if rows:
        sec.tables.append(table("Scenario generation: each NLP solve", ["start", "intervals", "scenarios", "status",
                                                                        "iterations", "build", "solve",
                                                                        f"worst design {sym}"], rows))
