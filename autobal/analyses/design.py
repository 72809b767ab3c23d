"""``analyses.design``: stability-constrained design of the balancing device.

Each design variable is a scene path with bounds in units, e.g.
``device.dynamics.disc_chamber_volume: {lower: 1e-6 m^3, upper: 2e-3 m^3}``; the analysis is
analysis/numerics/design.py and analysis/studies/design_study.py.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.schema import NonNegative, Positive, Strict
from autobal.units import Length, to_si

DESCRIPTION = "stability-constrained design of the device"
NEEDS = "device.dynamics"
QUANTITIES_MODULE = "autobal.analysis.studies.design_study"  # its QUANTITIES declare every number of its block
TITLE = "Stability-constrained design"  # of its section of report.html

# scene path -> (design key of analysis/numerics/design.py, unit kind; None: dimensionless)
VARIABLES = {
    "device.dynamics.disc_chamber_volume": ("V2", "volume"),
    "device.dynamics.cavity_volume": ("V3", "volume"),
    "device.dynamics.rotor_damping": ("c_z", "damping"),
    "device.dynamics.regulator.stem_damping": ("c_x", "damping"),
    "device.dynamics.regulator.spring_stiffness": ("k_reg", "stiffness"),
    "device.dynamics.regulator.valve_chamber_volume": ("V_cam", "volume"),
    "device.dynamics.regulator.membrane_chamber_volume": ("V_m", "volume"),
    "device.barrier.margin_ratio": ("dpsi", None),
    "device.regulator.supply_pressure": ("p_in", "pressure"),
    "device.regulator.membrane_area": ("s_m", "area"),
    "device.barrier.supply_throttle.diameter": ("d_e", "length"),
    "device.barrier.supply_throttle.length": ("l_e", "length"),
    "device.regulator.inlet_throttle.diameter": ("d_in", "length"),
    "device.regulator.inlet_throttle.length": ("l_in", "length"),
    "device.disc.outer_seal.clearance": ("h_3", "length"),
    "device.disc.outer_seal.length": ("l_3", "length"),
    "device.disc.outer_seal.diameter": ("d_3", "length"),
    "device.disc.outer_seal.local_loss": ("zeta_3", None),
    "device.disc.outer_seal.friction": ("lambda_3", None),
    "device.disc.face.friction": ("lambda_T", None),
    "device.regulator.valve.discharge_coefficient": ("phi_B", None),
    "device.disc.inner_seal.clearance": ("h_1", "length"),  # g1: the flow scale, symbolic in the NLP
    "device.disc.inner_seal.length": ("l_1", "length"),
    "device.disc.inner_seal.diameter": ("d_1", "length"),  # also s_e
    "device.disc.face.base_gap": ("z_B", "length"),  # the scale of u = z/z_B, symbolic in the NLP
    "device.disc.face.inner_diameter": ("d_T2", "length"),  # s_e: sigma and the displacement flows
    "device.disc.face.outer_diameter": ("d_T3", "length"),
    "device.regulator.valve.base_opening": ("x_B", "length"),  # the scale of xi = x/x_B
    "device.regulator.valve.seat_diameter": ("d_c", "length"),  # and s_c = pi d_c^2/4 (refused if the scene gives s_c)
}


class Bounds(Strict):
    """Bounds of one design variable, with units (a number for the dimensionless margin)."""

    lower: str | float
    upper: str | float


class GapBounds(Strict):
    lower: Length
    upper: Length


class Design(Strict):
    """``analyses.design``: variables (scene path -> bounds), operating points, margins, objective."""

    variables: dict[str, Bounds]
    operating_ratios: Annotated[list[Positive], Field(min_length=1)]  # psi1 = p1/p_B
    nominal_ratio: Positive = 1.0  # psi1 of the objective
    decay_rate: NonNegative  # alpha, 1/s: every eigenvalue Re lambda <= -alpha
    face_gap: GapBounds
    valve_band: Annotated[float, Field(ge=0, lt=0.5)] = 0.05  # free fraction of the valve travel at each end
    min_stiffness: float | None = None  # kappa_s lower bound (dimensionless)
    objective: Literal["leakage", "stiffness", "mix"] = "leakage"
    weights: tuple[NonNegative, NonNegative] = (1.0, 1.0)  # mix: leakage, stiffness
    model: Literal["energy", "chain", "program"] = "energy"  # program: refused with the reason (validator)
    samples: Annotated[int, Field(ge=0, le=100000)] = 200  # random-search certification
    seed: int = 0
    sweep_points: Annotated[int, Field(ge=2, le=1000)] = 11

    @model_validator(mode="after")
    def _paths(self):
        if self.model == "program":
            raise ValueError("model 'program' cannot be designed for: the source's program model is the hand "
                             "model (2.43)/(2.101) with constants computed as numbers at the closed-form point "
                             "(2.24)-(2.28), not expressions of the NLP's statics; use 'energy' or 'chain' (its "
                             "spectral abscissa is reported for comparison as program_model)")
        for path in self.variables:
            if path not in VARIABLES:
                raise ValueError(f"design variable {path!r} is not one of {sorted(VARIABLES)}")
        self.bounds_si()  # units and lower < upper, when the scene is read (autobal check sees them)
        return self

    def bounds_si(self) -> dict:
        """Scene path -> (key, lower, upper) in SI."""
        out = {}
        for path, b in self.variables.items():
            key, kind = VARIABLES[path]
            conv = (lambda v: float(v)) if kind is None else (lambda v, k=kind: to_si(v, k))
            try:
                lo, hi = conv(b.lower), conv(b.upper)
            except ValueError as exc:
                raise ValueError(f"variables.{path}: {exc}") from None
            if not hi > lo:
                raise ValueError(f"variables.{path}: upper must exceed lower")
            out[path] = (key, lo, hi)
        return out


SETTINGS = Design


def spec(settings: Design):
    """The design study's spec (autobal.analysis.numerics.design.Spec, SI) of the validated settings."""
    from autobal.analysis.numerics import design as ds

    variables = tuple(ds.Variable(path, key, lo, hi) for path, (key, lo, hi) in settings.bounds_si().items())
    gap = (settings.face_gap.lower, settings.face_gap.upper)
    weights = {"leakage": (1.0, 0.0), "stiffness": (0.0, 1.0), "mix": tuple(settings.weights)}[settings.objective]
    return ds.Spec(variables=variables, points=tuple(settings.operating_ratios), nominal_ratio=settings.nominal_ratio,
                   decay_rate=settings.decay_rate, gap=gap, valve_band=settings.valve_band,
                   min_stiffness=-float("inf") if settings.min_stiffness is None else settings.min_stiffness,
                   weights=weights, form=settings.model)


def run(scene, settings: Design):
    """Stability-constrained design of the balancing device (analysis/numerics/design.py)."""
    from autobal.analysis.run import progress
    from autobal.analysis.studies import design_study
    from autobal.parts.device import dynamic_device

    with progress.steps(None, "design", "IPOPT solve", catch=True):
        return design_study.run(dynamic_device(scene), spec(settings), settings.samples, settings.seed,
                                settings.sweep_points, scene.title)


def estimate_seconds(settings: Design) -> float:
    """The random and local certification samples, the nominal and optimal designs at every operating point,
    and the two spectral-abscissa sweeps (the NLP's own iterations are of the same order, left in the constant)."""
    evaluations = (settings.samples + settings.samples // 2 + 2) * len(settings.operating_ratios)
    return COST["start"] + COST["design_point"] * (evaluations + 2 * settings.sweep_points)


def report_section(sec) -> None:
    """Stability-constrained design: the optimum's verdict with its margin to the required decay rate, its
    certificate, the parameters in display units; the designs under the source's models in the validation part.
    Reads the fields of the loaded :class:`~autobal.analysis.studies.design_study.DesignResult` (``sec.result``)."""
    from autobal.analysis.run.quantities import is_number, significant
    from autobal.analysis.studies import design_study as ds  # the declarations and the variables: one copy each
    from autobal.report import WHY_UNSTABLE, table, text

    r = sec.result
    sec.conclude(*r.verdict())
    sec.verdict(r.status in ds.SUCCESS, f"IPOPT: {r.status} ({r.iterations} iterations)")
    sec.headline_rows()  # the rows of the fields declared headline
    for which, design in (("nominal", r.nominal), ("optimum", r.optimum)):  # keys are the discharge ratios ("0.5")
        sec.rows_of(design, "margin", label=lambda p, which=which: f"decay rate at ψ1 = {p}, {which} design")
    sec.verdict(*r.verdict("nominal"))
    for model, text_ in r.source_models():
        sec.validation.append({"ok": None, "text": text_ + (f"; the headline verdict stands: {WHY_UNSTABLE[model]}"
                                                            if "UNSTABLE" in text_ and model in WHY_UNSTABLE else "")})
    cert = r.certification
    sec.verdict(cert.eigenvalues_ok, "eigenvalues confirm every constraint at the optimum"
                if cert.eigenvalues_ok else "eigenvalues do NOT confirm the smooth stability conditions")
    sec.verdict(not cert.beaten, f"random search: {cert.feasible_samples} of {cert.samples} samples feasible, best "
                f"{significant(cert.best_sample)} "
                + ("(none better by more than 0.5 %)" if not cert.beaten else "BEATS the optimum"))
    for a in r.active:
        sec.verdict(None, f"active constraint: {a.constraint} (multiplier {significant(a.multiplier)})")
    nominal, rows = r.nominal.values_si, []
    for path, value in r.optimum.values_si.items():
        q, n = ds.variable(path), nominal.get(path)
        ratio = value / n if is_number(n) and n and is_number(value) else None
        rows.append([text(path), text(q.symbol), text(q.text(n)), text(q.text(value)),
                     text("—" if ratio is None else f"× {significant(ratio, 3)}")])
    if rows:
        sec.tables.append(table("Design parameters to 4 significant digits (results.json optimum.parameters holds "
                                "them in full: `autobal run SCENE --set PATH=VALUE` reproduces the optimum)",
                                ["scene path", "symbol", "nominal", "optimum", "optimum / nominal"], rows))
