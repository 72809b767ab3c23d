"""``analyses.estimation``: fitting device parameters to measured static and flow characteristics (Pavlenko
(2014), Sec. 4.4); the device section is optional (the device model's fits need it).

The data file is read and checked at load time (``autobal check`` catches a bad CSV): columns,
units, signs and the number of points against the free parameters of every fit.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, PrivateAttr, ValidationInfo, model_validator

from autobal.analyses import COST
from autobal.analysis.run.solver_options import DEFAULTS
from autobal.errors import ScenarioError
from autobal.measurements import QUANTITIES, Measurements, check_fit, read_csv
from autobal.models.device import DEVICE_GROUPS, PRESSURE_GROUPS, REGULATOR_GROUPS
from autobal.schema import NonNegative, Positive, Strict
from autobal.units import Area, Length, Pressure, VolumeFlow

if TYPE_CHECKING:
    from autobal.models.hydroheel import DiscLosses

DESCRIPTION = "parameter fits to measured characteristics"
NEEDS = None
QUANTITIES_MODULE = "autobal.analysis.studies.estimation_study"  # its QUANTITIES declare every number of its block
TITLE = "Parameter estimation"  # of its section of report.html

# Parameters each model can fit.  traditional_disc: (4.16)-(4.31).  device: the groups (2.18) of the
# full static model (models/device.py) and the loss coefficients they come from.
MODEL_PARAMETERS = {
    "traditional_disc": ("alpha", "tau_max"),
    "device": (*(k for k in (*DEVICE_GROUPS, *REGULATOR_GROUPS) if k not in PRESSURE_GROUPS),
               "face_friction", "outer_local_loss", "outer_friction"),
}


class Parameter(Strict):
    """One model parameter: its value (the initial guess when free), free or fixed, bounds."""

    value: Annotated[float, Field(
        description="value of the parameter in its unit (dimensionless groups: 1); the initial guess when free")]
    free: Annotated[bool, Field(description="fitted (true) or held at value (false)")] = True
    lower: Annotated[float | None, Field(
        description="lower bound when free (default: positive, tau_max above the largest load)")] = None
    upper: Annotated[float | None, Field(description="upper bound when free (default: none)")] = None

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

    u: Annotated[Positive, Field(description="weight of the gap residual, 1/(standard deviation of u)")] = 1.0
    q: Annotated[Positive, Field(description="weight of the flow residual, 1/(standard deviation of q)")] = 1.0


class Fit(Strict):
    """One nonlinear least-squares fit."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_]+$", description="name of the fit in results and file names")]
    model: Annotated[Literal["traditional_disc", "device"], Field(
        description="traditional_disc: (4.16)-(4.31) in alpha and tau_max; device: the full static model")] = \
        "traditional_disc"
    residual: Annotated[Literal["u", "q", "both"], Field(
        description="measured variable(s) the residual is taken in: gap u, flow q or both")] = "u"
    weights: Annotated[Weights, Field(description="residual weights")] = Weights()
    parameters: Annotated[dict[str, Parameter], Field(description="model parameter -> value, free, bounds")]
    flow_throttle: Annotated[str, Field(
        description="device model: throttle whose flow is measured (e, 1, T, 3, in, valve)")] = "T"
    hessian: Annotated[Literal["gauss-newton", "exact"], Field(
        description="Hessian IPOPT uses: Gauss-Newton J'J or the exact Lagrangian Hessian")] = "gauss-newton"
    max_iterations: Annotated[int, Field(ge=1, le=10000, description="IPOPT's iteration limit")] = \
        DEFAULTS["fit.max_iter"]

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


def _disc_defined(fit: Fit, top: float, where: str) -> None:
    """Refuse traditional_disc settings under which the gap (4.18) is undefined at a data point:
    tau_max fixed at or below the largest load tau, or bounded there from above; alpha fixed at 0 or
    bounded from above at or below 0."""
    t, a = fit.parameters["tau_max"], fit.parameters["alpha"]
    if not t.free and t.value <= top:
        raise ScenarioError(f"{where}.parameters.tau_max: fixed at {t.value:g}, not above the largest measured load "
                            f"tau = {top:.6g}, where the gap (4.18) is undefined; free it or give a larger value")
    if t.free and t.upper is not None and t.upper <= top:
        raise ScenarioError(f"{where}.parameters.tau_max: upper = {t.upper:g} is not above the largest measured load "
                            f"tau = {top:.6g}, where the gap (4.18) is undefined; raise it")
    if not a.free and a.value == 0:
        raise ScenarioError(f"{where}.parameters.alpha: fixed at 0, where the gap (4.18) is undefined; give a "
                            f"positive conductance ratio")
    if a.free and a.upper is not None and a.upper <= 0:
        raise ScenarioError(f"{where}.parameters.alpha: upper = {a.upper:g}; alpha = g_TB/g1 is a positive conductance "
                            f"ratio: give a positive upper bound")


class Bases(Strict):
    """Base values that make dimensional data columns dimensionless (1.17)-(1.21), (4.29).
    The device model takes p_B, s_B, z_B and g1 p_B from the scene's device when these are omitted."""

    pressure: Annotated[Pressure | None, Field(description="base pressure p_B, Pa")] = None
    area: Annotated[Area | None, Field(description="base area s_B, m^2; force base = p_B s_B")] = None
    gap: Annotated[Length | None, Field(description="base gap z_B = h_TB, m")] = None
    flow: Annotated[VolumeFlow | None, Field(description="base flow Q_B, m^3/s")] = None

    def values(self) -> dict:
        """Base values in SI by the key the data columns use: pressure (Pa), gap (m), flow (m^3/s),
        force p_B s_B (N); None where not given."""
        force = self.pressure * self.area if self.pressure and self.area else None
        return {"pressure": self.pressure, "gap": self.gap, "flow": self.flow, "force": force}


class Adequacy(Strict):
    """Fisher adequacy test (4.14)-(4.15) on the groups of the data."""

    significance: Annotated[float, Field(gt=0, lt=1, description="level of the F test")] = 0.1
    reference: Annotated[dict[str, Positive] | None, Field(
        description="traditional_disc parameters (alpha, tau_max) of a theory curve to test, e.g. the source's")] = None
    reference_parameters: Annotated[int, Field(ge=0, description="l of (4.15) for the reference curve (source: 2)")] = 2


class LossCoefficient(Strict):
    """Solve (4.38) for one loss coefficient from a fitted alpha, the others fixed."""

    fit: Annotated[str, Field(description="name of the traditional_disc fit whose alpha is used")]
    unknown: Annotated[Literal["zeta1", "lambda1", "zeta2", "lambda2"], Field(
        description="the loss coefficient solved for")]
    face_mean_diameter: Annotated[Length, Field(description="d_m = r2 + r3, m")]
    seal_diameter: Annotated[Length, Field(description="d_u (d1) of the annular seal, m")]
    base_gap: Annotated[Length, Field(description="h_TB, m")]
    seal_clearance: Annotated[Length, Field(description="h1, m")]
    seal_length: Annotated[Length, Field(description="l1, m")]
    face_length: Annotated[Length, Field(description="l2 = r3 - r2, m")]
    zeta1: Annotated[NonNegative, Field(description="annular seal: local loss coefficient")] = 1.5
    lambda1: Annotated[NonNegative, Field(description="annular seal: friction coefficient")] = 0.06
    zeta2: Annotated[NonNegative, Field(description="face throttle: local (inlet) loss coefficient")] = 1.5
    lambda2: Annotated[NonNegative, Field(description="face throttle: friction coefficient")] = 0.06
    friction_factor: Annotated[Positive, Field(
        description="f in zeta + f lambda l/h: 0.5 as (2.11) and Sec. 4.3.3; 1.0 as (4.38) is printed")] = 0.5

    def losses(self) -> DiscLosses:
        """The geometry and loss coefficients as the model's parameter object (SI)."""
        from autobal.models.hydroheel import DiscLosses  # scipy.special: not at scene load

        return DiscLosses(**self.model_dump(exclude={"fit", "unknown"}))


BOOTSTRAP_POINTS = 2_000_000  # bootstrap samples x data rows: about 50 MB of data sets, 3 s of refits


class Bootstrap(Strict):
    """Residual-bootstrap confidence intervals of the traditional_disc fits (refits batched in one
    mapped Gauss-Newton call); percentile intervals at the estimation's ``confidence``."""

    samples: Annotated[int, Field(ge=20, le=1_000_000, description=(
        "number of bootstrap data sets; samples x data rows at most 2,000,000 (the refits are held in memory "
        "together)"))] = 2000
    seed: Annotated[int, Field(ge=0, description="seed of the resampling")] = 0


DATA_KEY = "analyses.estimation.data"


class Estimation(Strict):
    data: Annotated[str, Field(
        description="CSV path: absolute, or relative to the scene file's folder (a shipped scene's: the package's "
                    "scenarios/); a path given by --set / load(set=...) is relative to the working folder. "
                    "A readable regular file of at most 20 MB, UTF-8 (a byte-order mark is dropped), separated by "
                    "',' or by ';' or tabs (then with decimal commas)")]
    columns: Annotated[dict[str, str] | None, Field(
        description="quantity -> header of its column in the data file, e.g. {axial_force: 'F [kN]', gap: "
                    "'h (mm)'}: only these columns are read, others are skipped; a column's unit is its header's "
                    "trailing [unit] or (unit), 1 when none. Default: every header reads 'quantity [unit]'")] = None
    bases: Annotated[Bases, Field(description="base values of dimensional data columns")] = Bases()
    fits: Annotated[list[Fit], Field(min_length=1, max_length=100, description="the fits, 1 to 100")]
    closed_forms: Annotated[bool, Field(
        description="the source's estimators (4.23), (4.26)-(4.27), (4.35), (4.36)")] = True
    tau_max: Annotated[Positive | None, Field(
        description="fixed tau_max of (4.23)/(4.35); default: the first disc fit's value")] = None
    adequacy: Annotated[Adequacy | None, Field(description="Fisher adequacy test (4.14)-(4.15)")] = None
    loss_coefficient: Annotated[LossCoefficient | None, Field(
        description="solve (4.38) for one loss coefficient")] = None
    confidence: Annotated[float, Field(gt=0, lt=1, description="level of every confidence interval and band")] = 0.95
    band_points: Annotated[int, Field(ge=2, le=10000, description="points of the fitted curve and its band")] = 101
    cross_check: Annotated[bool, Field(
        description="re-fit with scipy.optimize.least_squares (traditional_disc fits)")] = True
    bootstrap: Annotated[Bootstrap | None, Field(
        description="residual-bootstrap intervals of the traditional_disc fits")] = None

    _folder: Path | None = PrivateAttr(default=None)  # folder of a relative data path, fixed at validation
    _points: int = PrivateAttr(default=0)

    @property
    def points(self) -> int:
        """Number of data rows of the data file (read at validation)."""
        return self._points

    def measurements(self) -> Measurements:
        """The data file, read and checked (values in SI or dimensionless)."""
        return read_csv(self.data, self.columns, self._folder)

    @model_validator(mode="after")
    def _data_fits(self, info: ValidationInfo):
        names = [f.name for f in self.fits]
        if len(set(names)) != len(names):
            raise ValueError("fits: two fits have the same name")
        for k in self.columns or {}:
            if k not in QUANTITIES:
                raise ValueError(f"columns.{k}: not a quantity of a data file (one of {', '.join(QUANTITIES)})")
        ctx = info.context or {}
        overridden = any(DATA_KEY == k or DATA_KEY.startswith(k + ".") for k in ctx.get("overrides", ()))
        self._folder = Path.cwd() if overridden or ctx.get("folder") is None else Path(ctx["folder"])
        try:
            data = self.measurements()
            self._points = data.points
            bs = self.bootstrap
            if bs is not None and bs.samples * data.points > BOOTSTRAP_POINTS:
                most = BOOTSTRAP_POINTS // data.points
                raise ScenarioError(f"bootstrap.samples: {bs.samples} data sets of {data.points} rows exceed "
                                    f"{BOOTSTRAP_POINTS:,} rows in all; "
                                    + (f"use at most {most} samples" if most >= 20 else
                                       "leave the bootstrap out (with this many rows the linearised intervals "
                                       "hold)"))
            for i, fit in enumerate(self.fits):
                check_fit(data, fit.residual, len(fit.free()), f"fits.{i}")
                if fit.model == "traditional_disc" and data.has("load") in ("psi1", "discharge_pressure"):
                    raise ScenarioError(f"fits.{i}: the traditional_disc model takes a load column "
                                        f"(tau or axial_force), not {data.has('load')}")
                if fit.model == "traditional_disc":  # the device model has its own bases
                    bases = self.bases.values()
                    for role in ("load", *{"u": ["gap"], "q": ["flow"], "both": ["gap", "flow"]}[fit.residual]):
                        data.dimensionless(role, bases)
                    _disc_defined(fit, float(data.dimensionless("load", bases).max()), f"fits.{i}")
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


SETTINGS = Estimation


def run(scene, settings: Estimation):
    """Parameter estimation from measured static and flow characteristics (Pavlenko (2014), Sec. 4.4)."""
    from autobal.analysis.run import progress
    from autobal.analysis.studies import estimation_study
    from autobal.parts.device import adapt

    device = adapt(scene.device) if scene.device is not None else None
    with progress.steps(None, "estimation", "IPOPT solve", catch=True):
        return estimation_study.run(spec(settings), settings.measurements(), device, scene.title)


def spec(settings: Estimation):
    """The study's :class:`~autobal.analysis.studies.estimation_study.Spec` of the validated settings (SI)."""
    from autobal.analysis.studies import estimation_study as es

    s, ad, lc, bs = settings, settings.adequacy, settings.loss_coefficient, settings.bootstrap
    fits = tuple(es.FitSpec(f.name, f.model, f.residual, dict(f.weights),
                            {k: es.Parameter(**dict(p)) for k, p in f.parameters.items()}, f.flow_throttle, f.hessian,
                            f.max_iterations) for f in s.fits)
    return es.Spec(fits, s.bases.values(), s.closed_forms, s.tau_max,
                   ad and es.AdequacySpec(ad.significance, ad.reference, ad.reference_parameters),
                   lc and es.LossSpec(lc.fit, lc.unknown, lc.losses()), s.confidence, s.band_points, s.cross_check,
                   bs and es.BootstrapSpec(bs.samples, bs.seed))


def estimate_seconds(settings: Estimation) -> float:
    """One least-squares fit with its cross-checks per fit, each over the data rows, and the bootstrap refits of
    the traditional_disc fits."""
    e = settings
    disc = sum(f.model == "traditional_disc" for f in e.fits)
    return COST["start"] + (COST["fit"] + COST["fit_point"] * e.points) * len(e.fits) \
        + (COST["bootstrap_point"] * e.points * e.bootstrap.samples * disc if e.bootstrap else 0.0)


def accuracy(scene, settings: Estimation):
    """Work-precision of the scene's first traditional-disc fit in u (its data, its free parameters)."""
    from autobal.analysis.studies import workprecision

    fit = next((f for f in settings.fits if f.model == "traditional_disc" and f.residual == "u"), None)
    if fit is None:
        raise ScenarioError("work-precision of the estimation needs a traditional_disc fit with residual u")
    data = settings.measurements()
    bases = settings.bases.values()
    return workprecision.estimation_study(data.dimensionless("load", bases), data.dimensionless("gap", bases),
                                          fit.free(), {k: p.value for k, p in fit.parameters.items()})


#: what a fitted group without a physical unit is a ratio of (the unit column of the report's table)
RATIOS = {"alpha": "1 (α = g_TB/g1, a ratio of conductances)", "tau_max": "1 (τ_max = F_max/(p_B s_B))"}


def _adequacy_row(label: str, ad: dict) -> list[dict]:
    """One row of the adequacy table: the Fisher test (4.14) and the lack-of-fit test of a fit or a curve."""
    from autobal.report import cell, text

    lof = ad.get("lack_of_fit") or {}
    return [text(label), *(cell(ad.get(k), "1") for k in ("F", "F_crit", "p_value")), text(ad.get("fisher_adequate")),
            *(cell(lof.get(k), "1") for k in ("F", "F_crit", "p_value")), text(lof.get("adequate")),
            text(ad.get("adequate"))]


def report_section(sec) -> None:
    """Least-squares fits with standard errors, bootstrap intervals, parameter correlation and adequacy
    (Pavlenko 2014, §4.3-4.4), the loss coefficient of (4.38): one verdict over the fits (solved and adequate).
    Reads the fields of the loaded :class:`~autobal.analysis.studies.estimation_study.EstimationResult`
    (``sec.result``)."""
    from autobal.analysis.run.quantities import is_number
    from autobal.report import cell, number, table, text

    r = sec.result
    rows, correlations, adequacy, moved = [], [], [], []
    for fit, f in r.solved.items():  # each cell in the display unit of its key's declaration
        boot = (f.bootstrap or {}).get("parameters") or {}
        free = [p for p, v in f.parameters.items() if v.get("free")]
        for pname in free:
            at, p = f"fits.{fit}.parameters.{pname}", f.parameters[pname]
            rows.append([text(fit), text(pname), *(sec.cell(f"{at}.{k}", p.get(k)) for k in (
                "estimate", "standard_error", "ci_low", "ci_high")),
                *(sec.cell(f"fits.{fit}.bootstrap.parameters.{pname}.{k}", boot[pname][k])
                  if k in (boot.get(pname) or {}) else text(None) for k in ("ci_low", "ci_high")),
                text(RATIOS.get(pname, "dimensionless"))])
        for key, ph in (f.physical or {}).items():  # a fitted force group in its unit, beside the group
            if "estimate" in ph and ph["free"]:
                at = f"fits.{fit}.physical.{key}"
                cells = [sec.cell(f"{at}.{k}", ph[k]) if k in ph else text(None) for k in (
                    "estimate", "standard_error", "ci_low", "ci_high", "bootstrap_ci_low", "bootstrap_ci_high")]
                rows.append([text(fit), text(f"{key} = {ph['group']} p_B s_B"), *cells, text(cells[0]["unit"])])
        corr = f.correlation or []
        for a, b in itertools.combinations(range(len(free)), 2):
            c = corr[a][b] if a < len(corr) and b < len(corr[a]) else None
            if is_number(c):
                correlations.append([text(fit), text(f"{free[a]}, {free[b]}"), cell(c, "1"),
                                     text("the data hardly separate them: the intervals are wide along the ridge"
                                          if abs(c) >= 0.9 else "")])
        moved += [f"{fit}: {m.get('why')}" for m in (f.extra.get("start_moved") or {}).values()]
        ad = f.adequacy or {}
        if "adequate" in ad:
            adequacy.append(_adequacy_row(f"fit {fit}", ad))
    if r.fits:
        sec.conclude(*r.verdict())
    first = next(iter(r.fits.values()), None)
    level = number(100 * (first.confidence if first is not None and first.status != "failed" else 0.95))
    sec.tables.append(table(f"Fitted parameters: estimate, standard error, the linearised {level} % confidence "
                            "interval and the residual-bootstrap percentile interval",
                            ["fit", "parameter", "estimate", "standard error", "CI low", "CI high", "bootstrap low",
                             "bootstrap high", "unit"], rows, headline=True, unit_column=True))
    stiffness = [[text(fit), *(sec.cell(f"fits.{fit}.physical.stiffness.{k}.{i}", st[k][i]) for k in (
                      "load", "tau", "value", "kappa"))]
                 for fit, f in r.solved.items() for st in [(f.physical or {}).get("stiffness") or {}]
                 for i in range(len(st.get("value") or []))]
    if stiffness:
        sec.tables.append(table("Axial stiffness of the fitted disc c = −dF/dh = κ p_B s_B/h_TB at the data's loads "
                                "(κ = −dτ/du of Pavlenko 2014, Eq. (4.16))",
                                ["fit", "load F", "τ", "stiffness c", "κ"], stiffness))
    if correlations:
        sec.tables.append(table("Correlation of the free parameters (from the covariance at the optimum)",
                                ["fit", "parameters", "correlation", "meaning"], correlations))
    ref = r.adequacy_reference or {}
    if "adequate" in ref:
        curve = ref.get("reference") or {}
        adequacy.append(_adequacy_row(f"the source's curve (α {number(curve.get('alpha'))}, τ_max "
                                      f"{number(curve.get('tau_max'))})", ref))
    if adequacy:
        sec.tables.append(table("Adequacy: Fisher test of the variance about the curve against the scatter within "
                                "the load groups (Pavlenko 2014, Eqs. (4.14)-(4.15); passed when F ≤ F_crit), and "
                                "the lack-of-fit test; adequate only when both pass at the significance; F and p "
                                "dimensionless",
                                ["fit", "Fisher F", "F_crit", "p", "passes", "lack-of-fit F", "F_crit", "p", "passes",
                                 "adequate"], adequacy))
    if "source_rule_adequate" in ref and ref["source_rule_adequate"] != ref.get("fisher_adequate"):
        sec.validation.append({"ok": None, "text": "the source's text calls F > F_crit adequate (inverted); by its "
                                                   "rule the reference curve would be "
                                                   + ("adequate" if ref["source_rule_adequate"] else "not adequate")})
    lc = r.loss_coefficient or {}
    if "value" in lc:
        sec.tables.append(table(f"Loss coefficient {lc.get('unknown')} that the fitted α of {lc.get('fit')} implies "
                                "(Pavlenko 2014, Eq. (4.38)); dimensionless",
                                ["unknown", "value", "CI low", "CI high", "nominal", "α fitted", "α nominal"],
                                [[text(lc.get("unknown")), *(sec.cell(f"loss_coefficient.{k}", lc.get(k)) for k in (
                                    "value", "ci_low", "ci_high", "nominal", "alpha", "alpha_nominal"))]]))
        if lc.get("physical") is False:
            sec.warnings.append(f"(4.38): the fitted α implies a negative {lc.get('unknown')}: the loss model does "
                                "not explain the fit")
    elif "status" in lc:
        sec.warnings.append(f"(4.38): {lc['status']}")
    if moved:  # trivial for a reader: one line
        sec.notes.append("starts moved where the model is defined: " + "; ".join(moved))
