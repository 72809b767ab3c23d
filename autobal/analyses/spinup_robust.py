"""``analyses.spinup_robust``: one spin-up profile minimising the worst-case peak over a set of rotors around
the scene's, validated on a random sample beside the nominal optimum and the constant ramps."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analyses.spinup import Spinup, ocp
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
    from autobal.analysis import executor, progress
    from autobal.analysis.solver_options import ipopt_options
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
    verdict is the robust profile's worst validation peak against the others'."""
    from autobal.ocp.robust_study import PEAK_SYMBOL, QUANTITIES, peak_key, verdict  # the verdict's one copy
    from autobal.ocp.spinup_study import QUANTITIES as SPINUP
    from autobal.report import cell, table, text

    prof = sec.get("profiles") or {}
    if prof:
        sec.conclude(*verdict(sec.block))
    unit = sec.get("peak_unit") or "1"
    s, sym = peak_key(sec.block), PEAK_SYMBOL[unit]
    shown = None if unit == "1" else QUANTITIES.find(f"profiles.robust.validation_worst_{s}").display

    def pc(v):
        return cell(v, unit, shown)

    for key, label in (("robust", "robust profile"), ("nominal", "nominal optimum"), ("ramp", "best ramp")):
        sec.row(f"{label}: worst peak over the validation rotors", sym, f"profiles.{key}.validation_worst_{s}")
    sec.row("robust profile: worst peak over the design rotors (CVODES)", sym, f"profiles.robust.design_worst_{s}")
    sec.row("nominal critical speed", "ω_cr", "omega_cr_rad_s")
    sec.row("eccentricity (δ* = e δ*/e, 0-peak)", "e", "eccentricity_m")
    sec.row("design rotors (grid)", "", "design_scenarios")
    sec.row("design rotors in the final NLP (binding)", "", "active_scenarios")
    sec.row("validation rotors", "", "validation_samples")
    sec.row("build time (robust NLPs)", "", "build_time_s")
    sec.row("solve time (robust NLPs)", "", "solve_time_s")
    sec.row("validation time", "", "validation_time_s")
    sec.row("validation integrator against CVODES (largest relative difference)", "", "validation_check_rel_error")
    e = sec.get("eccentricity_m")
    physical = SPINUP.find("peak_deflection_m")
    rows = []
    for key in ("robust", "nominal", "ramp"):
        p = prof.get(key) or {}
        q = p.get(f"validation_quantiles_{s}") or {}
        worst = p.get(f"validation_worst_{s}")
        rows.append([text(p.get("label")), pc(p.get(f"nominal_peak_{s}")), pc(p.get(f"design_worst_{s}")),
                     pc(q.get("0.5")), pc(q.get("0.99")), pc(worst)]
                    + ([cell(None if e is None or worst is None else worst * e, "m", physical.display)]
                       if unit == "1" else []))
    if prof:
        what = ("δ*/e", "; the worst as a deflection δ* (0-peak)") if unit == "1" else \
            ("r* (the largest whirl radius over the nodes, 0-peak)", "")
        sec.tables.append(table(f"Peak deflection {what[0]} of each profile: on the nominal rotor, worst over the "
                                f"design set (CVODES), and over the validation sample{what[1]}",
                                ["profile", "nominal rotor", "design worst", "validation median", "validation 99 %",
                                 "validation worst"] + (["validation worst δ*"] if unit == "1" else []), rows,
                                headline=True))
    rows = [[text(r.get("label")), sec.cell(f"ramps.{i}.alpha_rad_s2"), pc(r.get(f"design_worst_{s}")),
             pc(r.get(f"validation_worst_{s}")),
             text({True: "within", False: f"OUTSIDE: {r.get('violated')}", None: "no drive data"}
                  [r.get("within_drive_limits")])] for i, r in enumerate(sec.get("ramps") or [])]
    if rows:
        sec.tables.append(table(f"Constant ramps: worst peak {sym} over the design set and the validation sample",
                                ["ramp", "acceleration", "design worst", "validation worst", "drive limits"], rows))
    rows = [[text(r.get("start")), cell(r.get("intervals"), "1"), cell(r.get("scenarios"), "1"), text(r.get("status")),
             cell(r.get("iterations"), "1"), cell(r.get("build_time_s"), "s"), cell(r.get("solve_time_s"), "s"),
             pc(r.get(f"worst_design_peak_{s}"))] for r in sec.get("rounds", [])]
    if rows:
        sec.tables.append(table("Scenario generation: each NLP solve", ["start", "intervals", "scenarios", "status",
                                                                        "iterations", "build", "solve",
                                                                        f"worst design {sym}"], rows))
