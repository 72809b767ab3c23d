"""``analyses.ross_spinup``: the minimum-peak spin-up of a ROSS rotor reduced to its modes, through two or more
critical speeds (:mod:`autobal.ocp.modal_study`), with the reduced model's critical speeds checked against ROSS's own.

Needs the optional ROSS package (``pip install -e '.[ross]'``); a scene naming it without the package
installed exits 2 with one line naming the extra.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analysis.run.solver_options import DEFAULTS
from autobal.errors import ScenarioError
from autobal.parts.ross_rotor import Node
from autobal.schema import Strict
from autobal.units import AngularAcceleration, AngularSpeed, SpeedOrZero, Time, TimeOrZero

DESCRIPTION = "optimal spin-up of a ROSS rotor reduced to its modes (the ross extra)"
NEEDS = "ross_rotor"
EXTRA = "ross"  # the optional package it needs (autobal.analyses.EXTRAS)
QUANTITIES_MODULE = "autobal.ocp.modal_study"  # its QUANTITIES declare every number of its block
TITLE = "Optimal spin-up of a ROSS rotor (multi-mode)"  # of its section of report.html


class RossSpinup(Strict):
    """Minimum-peak spin-up of the ROSS rotor reduced to its modes, posed as a drive is specified (as the
    Jeffcott ``spinup``): reach ``final_speed`` by the deadline ``horizon``, hold it over ``settling_time``
    (the peak counts over the whole window), never exceed ``max_speed``, |alpha| <= ``max_acceleration``, within
    the limits of the rotor's ``drive`` (``ross_rotor.drive``)."""

    start_speed: SpeedOrZero = Field(description="speed at t = 0 (steady state there)")
    final_speed: AngularSpeed = Field(description="reached by the deadline")
    horizon: Time = Field(description="the deadline")
    max_acceleration: AngularAcceleration = Field(description="bound on |alpha|")
    settling_time: TimeOrZero = Field(0.0, description="held at final_speed after the deadline")
    max_speed: AngularSpeed | None = Field(None, description="speed cap")
    nodes: Annotated[list[Node], Field(min_length=1, max_length=50)] = Field(
        description="nodes whose lateral deflection sqrt(x^2 + y^2) counts (the peak is the largest)")
    mode_cutoff: Annotated[float, Field(ge=1.0, le=10.0)] = Field(
        1.5, description="modes with natural frequency up to mode_cutoff x final_speed are kept, 1 to 10")
    gyroscopic_tolerance: Annotated[float, Field(ge=0, le=1)] = Field(
        1e-3, description="the gyroscopic terms are kept when they move a critical speed by more than this fraction")
    intervals: Annotated[int, Field(ge=4, le=2000)] = Field(160, description="control intervals over the horizon")
    degree: Annotated[int, Field(ge=1, le=9)] = Field(3, description="Radau collocation degree, 1 to 9")
    max_iterations: Annotated[int, Field(ge=1, le=100000)] = Field(DEFAULTS["spinup.max_iter"],
                                                                   description="IPOPT iterations per solve")
    validate_with_ross: bool = Field(True, description="compare the reduced critical speeds with ROSS's own")

    @model_validator(mode="after")
    def _consistent(self):
        if self.max_speed is not None and self.max_speed < max(self.start_speed, self.final_speed):
            raise ValueError("max_speed must not be below start_speed and final_speed")
        if self.final_speed - self.start_speed > self.max_acceleration * self.horizon:
            raise ValueError("max_acceleration x horizon is less than the speed change: the deadline cannot be met")
        return self


SETTINGS = RossSpinup


def run(scene, settings: RossSpinup):
    """Optimal spin-up of a ROSS rotor reduced to its modes, through its critical speeds, with the reduced
    model's critical speeds checked against ROSS's own (needs the ross extra)."""
    from autobal.analysis.run import progress, solver_options
    from autobal.ocp import modal_study

    ocp, ross_cs = posed(scene, settings, settings.final_speed if settings.validate_with_ross else None)
    try:
        with progress.steps(None, "multi-mode spin-up (starts)", "IPOPT solve", catch=True):
            return modal_study.run(ocp, scene.title, ross_cs, solver_options.ipopt_options(settings.max_iterations))
    except ValueError as exc:
        raise ScenarioError(f"analyses.ross_spinup: {exc}") from None


def posed(scene, settings: RossSpinup, upper: float | None = None, key: str = "ross_spinup", **extra):
    """The spin-up problem of the scene's ROSS rotor reduced to its modes (SI; needs the ross extra), with the
    limits of ``ross_rotor.drive`` and the ``extra`` members of :class:`autobal.ocp.modal.ModalSpinupOcp` (e.g. a
    deflection limit), and ROSS's own critical speeds below ``upper`` (rad/s; None: not computed).  A problem that
    cannot be posed (a drive that cannot reach the final speed by the deadline too) raises ScenarioError naming
    ``analyses.<key>``."""
    from autobal.models import ross_rotor as rr
    from autobal.ocp.modal import ModalSpinupOcp
    from autobal.parts.ross_rotor import adapt

    spec, unbalances = adapt(scene.ross_rotor)
    lateral, ross_cs = ross_side(spec, upper)
    reduced = rr.reduce(lateral, unbalances, settings.final_speed, settings.mode_cutoff,
                        settings.gyroscopic_tolerance)
    try:
        return ModalSpinupOcp(reduced, settings.start_speed, settings.final_speed, settings.horizon,
                              settings.max_acceleration, tuple(settings.nodes), settings.settling_time,
                              settings.max_speed, settings.intervals, settings.degree, **drive(scene), **extra), ross_cs
    except ValueError as exc:
        raise ScenarioError(f"analyses.{key}: {exc}") from None


def _ross_side(spec, upper: float | None):
    from autobal.models import ross_rotor as rr

    rotor = rr.ross_rotor(spec)
    return rr.lateral_matrices(rotor), None if upper is None else rr.ross_critical_speeds(rotor, upper)


def ross_side(spec, upper: float | None = None):
    """What ROSS computes of the rotor ``spec``: its lateral matrices and, with ``upper`` (rad/s), its own critical
    speeds below it; in a child process (:func:`autobal.analysis.run.interrupt.isolated`), since ROSS's numba compiles
    drop a Ctrl-C and its Python runs on for tens of seconds without a check.  The child is a fresh interpreter with
    the string hash seed 0: ROSS assembles M, G and K_sdt over ``set(self.elements)`` (ross/rotor_assembly.py), whose
    order, and so the matrices' last bits, followed the process's hash seed (the reduced rotor's natural frequencies
    moved by 1e-12 and the spin-up optimum by 1e-8 from run to run)."""
    from autobal.analysis.run import interrupt

    return interrupt.isolated(_ross_side, spec, upper, hash_seed=0)  # ROSS sums over a set of its elements


def drive(scene) -> dict:
    """The scene's ``ross_rotor.drive`` as keyword arguments of :class:`autobal.ocp.modal.ModalSpinupOcp` (SI; none
    without a drive section: |alpha| <= max_acceleration only)."""
    d = scene.ross_rotor.drive
    if d is None:
        return {}
    return {"drive_inertia": d.polar_inertia, "torque_max": d.max_torque, "power_max": d.max_power,
            "braking_torque_max": d.max_braking_torque,
            "alpha_min": None if d.max_deceleration is None else -d.max_deceleration,
            "motor_stall_torque": d.motor.stall_torque if d.motor else None,
            "motor_no_load_speed": d.motor.no_load_speed if d.motor else None}


def problem(scene, settings: RossSpinup, key: str = "ross_spinup", **extra):
    """The problem of :func:`posed` for the robust and time-optimal studies of the modal rotor (its callers), which
    take the acceleration limit only: a scene with ``ross_rotor.drive`` is refused."""
    if scene.ross_rotor.drive is not None:
        raise ScenarioError(f"analyses.{key}: ross_rotor.drive: this study of the ROSS rotor takes the acceleration "
                            "limit only; remove the drive section (ross_spinup takes its limits)")
    return posed(scene, settings, None, key, **extra)[0]


def check(scene, settings: RossSpinup) -> None:
    """``autobal check``: the modal problem posed as :func:`run` poses it (ROSS's rotor built and reduced, a few
    seconds), the drive's reach checked, nothing solved."""
    posed(scene, settings)


def estimate_seconds(settings: RossSpinup) -> float:
    """ROSS's import, numba compilation and matrices, its critical speeds, then the four-phase search, its starts on
    the coarse mesh and the refinement on the modal envelope: about 5.5 solves' worth on the full mesh (the shipped
    scene, 4 modes, 160 intervals of degree 3: 53 s of its 90 s)."""
    return COST["ross_rotor"] + COST["ross_critical_speeds"] * settings.validate_with_ross + COST["start"] \
        + COST["modal_ocp_point"] * settings.intervals * settings.degree * 5.5


def report_section(sec) -> None:
    """Optimal spin-up of a ROSS rotor reduced to its modes: the optimum's peak against the best ramp (the verdict),
    the reduction checked against ROSS, the API 684 (2005) margins of each critical speed.  Reads the fields of the
    loaded :class:`~autobal.ocp.modal_study.ModalSpinupResult` (``sec.result``)."""
    from autobal.analyses.spinup import declared_cell
    from autobal.analysis.numerics.standards import margin_words
    from autobal.analysis.run.quantities import convert
    from autobal.report import cell, number, table, text

    r = sec.result
    sec.conclude(*r.verdict())
    sec.headline_rows()  # the rows of the fields declared headline
    sec.rows_of(r, "node_of_peak", "modes", "mode_cutoff_rad_s", "gyroscopic_shift", "resimulation_rel_error",
                "build_time_s", "total_solve_time_s")
    st = r.status
    sec.verdict(st in ("Solve_Succeeded", "Solved_To_Acceptable_Level"), f"IPOPT: {st} ({r.method})")
    cs = r.critical_speeds
    err = cs.max_rel_error_vs_ross
    if err is not None:
        sec.verdict(err <= 0.01, f"critical speeds of the reduced model within {number(100 * err)} % of ROSS's")
    ross = cs.ross_wd_rad_s or []
    q = r.quantities.find
    rows = []
    for i, (w, m) in enumerate(zip(cs.reduced_wd_rad_s, cs.margins, strict=False)):
        kept = {True: "yes", False: "NO", None: "—"}[m.separation_margin_ok]
        rows.append([text(str(i + 1)), cell(w, "rad/s"), cell(convert(w, "rad/s", "rpm"), "rpm"),
                     cell(ross[i] if i < len(ross) else None, "rad/s"),
                     declared_cell(q("critical_speeds.reduced_damping_ratio"), cs.reduced_damping_ratio[i]),
                     *(declared_cell(q(f"critical_speeds.margins[].{k}"), getattr(m, k))
                       for k in ("amplification_factor", "separation_margin_pct", "required_separation_margin_pct")),
                     text(kept)])
        sec.verdict(m.separation_margin_ok, f"critical speed {i + 1} ({number(w)} rad/s), API 684 (2005): "
                    + margin_words(m.to_dict()))
    if rows:
        sec.tables.append(table("Critical speeds below the final speed: the API 684 (2005) amplification factor at the "
                                "half-power points of the unbalance response at the nodes of interest, the separation "
                                "margin from the final (service) speed and the margin API 684 requires for that AF",
                                ["#", "reduced model", "reduced model, rpm", "ROSS", "damping ratio", "AF", "SM",
                                 "SM required", "kept"], rows))

