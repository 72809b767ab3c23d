"""``analyses.montecarlo``: Monte Carlo of the balancing device's statics (and optionally its AFC) over the
uncertain dimensionless groups (Pavlenko (2014), ch. 3), on the executor the CLI or the scene names.

Uncertain parameters are named by the model's dimensionless groups (2.18); a name the model does
not have, a negative standard deviation or an impossible correlation is refused at load time
with one line naming it.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from autobal.analyses import COST
from autobal.analyses.frequency import OmegaGrid
from autobal.errors import ScenarioError
from autobal.models.device import DEVICE_GROUPS, REGULATOR_GROUPS
from autobal.schema import Positive, Strict

Probability = Annotated[float, Field(gt=0, lt=1)]
MAX_SAMPLES = 2_000_000  # statics Monte Carlo: ~0.2 kB a sample in memory (0.4 GB at the bound)
MAX_AFC_SAMPLES = 1_000_000  # AFC Monte Carlo: a frequency response per sample

DESCRIPTION = "Monte Carlo of the statics (and AFC)"
NEEDS = "device"
QUANTITIES_MODULE = "autobal.analysis.studies.montecarlo"  # its QUANTITIES declare every number of its block
TITLE = "Monte Carlo"  # of its section of report.html


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

    @model_validator(mode="after")
    def _names(self):
        from autobal.analysis.studies.montecarlo_afc import afc_names  # the names of its model (imports the model)

        try:
            afc_names(self.model, self.parameters)
        except ScenarioError as exc:  # checked when the scene is read, so that check sees it too
            raise ValueError(str(exc).removeprefix("analyses.montecarlo.afc.")) from None
        return self


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


SETTINGS = MonteCarlo


def run(scene, settings: MonteCarlo):
    """Monte Carlo of the device statics (and optionally the AFC) over uncertain groups (Pavlenko (2014),
    ch. 3), on the executor the CLI or the scene names."""
    from autobal.analysis.run import executor
    from autobal.analysis.studies import montecarlo as mc
    from autobal.parts.device import adapt, design

    if scene.device is None:
        raise ScenarioError("analyses.montecarlo needs a device section")
    device = adapt(scene.device)
    with executor.make(scene_executor=getattr(scene, "executor", None)) as exe:
        return mc.run(design(scene.device), spec(settings), exe, scene.title, device=device)


def spec(settings: MonteCarlo):
    """The study's :class:`~autobal.analysis.studies.montecarlo.Spec` of the validated settings (SI)."""
    from autobal.analysis.studies import montecarlo as mc

    def distributions(parameters: dict) -> dict:
        return {name: mc.Distribution(**dict(d)) for name, d in parameters.items()}

    s, a = settings, settings.afc
    afc = a and mc.AfcSpec(a.model, a.samples, a.chunk_size, a.operating_ratio, a.forcing, mc.Grid(**dict(a.omega)),
                           distributions(a.parameters))
    return mc.Spec(s.samples, s.seed, s.chunk_size, tuple(s.discharge_ratio), distributions(s.parameters),
                   tuple(mc.Correlation(tuple(c.between), c.rho) for c in s.correlations), s.band_sigma,
                   tuple(s.quantiles), s.sensitivity_step, afc)


def estimate_seconds(settings: MonteCarlo) -> float:
    """The mapped statics per sample and discharge ratio, and the linear AFC per sample and frequency."""
    t = COST["start"] + COST["mc_statics_sample"] * settings.samples * len(settings.discharge_ratio)
    if settings.afc is not None:
        t += COST["start"] + COST["mc_afc_point"] * settings.afc.samples * settings.afc.omega.points
    return t


def _reference_rows(sec, r) -> None:
    """The headline rows: the face gap and leak at the reference discharge ratio, with their spreads."""
    from autobal.report import number

    ref = r.reference
    sec.rows_of(ref, "p1", note=f"ψ1 = p1/p_B = {number(ref.psi1)}")
    sec.rows_of(ref, "z_mean", "z_std")
    sec.rows_of(ref, "gap_spread", note=f"k = {number(r.band_sigma)}")
    sec.rows_of(ref, "Q_T_mean", "Q_T_std", "leak_spread", "saturated_fraction")


def report_section(sec) -> None:
    """Spreads of face gap, pressures and leak over the sampled groups (Pavlenko 2014, ch. 3): the physical values
    beside the source's groups; its closed forms in the validation part.  Reads the fields of the loaded
    :class:`~autobal.analysis.studies.montecarlo.MonteCarloResult` (``sec.result``)."""
    from autobal.analysis.run.quantities import significant
    from autobal.report import SOURCE_MODELS, model_name, number, stable_models, table, text

    r = sec.result
    ref = r.reference
    sec.rows_of(r, "samples")
    if ref is not None:  # a results.json written before the physical values has none
        _reference_rows(sec, r)
    ex, src, dim = r.exact, r.source, r.dimensional
    rows, validation = [], []
    for i, p in enumerate(r.psi1):  # each cell in the display unit of its key's declaration
        if dim is not None:
            rows.append([sec.cell(f"psi1.{i}", p), sec.cell(f"p1.{i}", r.p1[i]),
                         *(sec.cell(f"dimensional.{k}.{stat}.{i}", dim[k][stat][i]) for k, stat in (
                             ("z", "mean"), ("z", "std"))),
                         sec.cell(f"exact.u.spread.{i}", ex["u"]["spread"][i]),
                         sec.cell(f"dimensional.p2.mean.{i}", dim["p2"]["mean"][i]),
                         *(sec.cell(f"exact.{k}.{stat}.{i}", ex[k][stat][i]) for k, stat in (
                             ("Q_T", "mean"), ("Q_T", "std"), ("q_T", "spread"))),
                         sec.cell(f"saturated_fraction.{i}", r.saturated_fraction[i]),
                         sec.cell(f"exact.u.invalid.{i}", ex["u"]["invalid"][i])])
        validation.append([sec.cell(f"psi1.{i}", p), *(sec.cell(f"{part}.{k}.{stat}.{i}", block[k][stat][i])
                                                       for k in ("u", "q_T") for part, block in (("exact", ex),
                                                                                                 ("source", src))
                                                       for stat in ("mean", "spread"))])
    saturated = [f"ψ1 = {number(p)}: {significant(100 * f, 3)} %" for p, f in
                 zip(r.psi1, r.saturated_fraction, strict=True) if f]
    if saturated:  # one line: the source's closed forms assume an ideal regulator
        sec.warnings.append("samples with the regulator valve on its stop (the closed forms assume an ideal "
                            "regulator): " + ", ".join(saturated))
    if dim is not None:
        sec.tables.append(table("Exact statics over the samples: the physical values (mean, standard deviation) "
                                "beside the source's groups' spread kσ/mean",
                                ["ψ1", "p1", "mean z", "std z", "spread u", "mean p2", "mean Q_T", "std Q_T",
                                 "spread q_T", "saturated fraction", "invalid samples"], rows, headline=True))
    sec.validation_tables.append(table("The source's closed forms (ideal regulator, Figs 3.3-3.4) beside the exact "
                                       "statics over the same samples: mean and spread of u = z/z_B and q_T = Q_T/Q_B",
                                       ["ψ1", "u exact", "spread", "u closed form", "spread", "q_T exact", "spread",
                                        "q_T closed form", "spread"], validation))
    if ref is not None:
        sec.conclude(*r.verdict())
    else:  # a results.json written before the physical values
        invalid = sum(ex["u"]["invalid"])
        sec.conclude(not r.failures(), f"{invalid} sample solves without a converged exact solution"
                     if invalid else "every sample has a converged exact solution")
    at = (r.afc or {}).get("at") or {}
    if at:
        model, forcing = r.afc["model"], r.afc["forcing"]
        st = stable_models(sec.results).get(model)
        sec.tables.append(table(f"AFC amplitude spread of the {model_name(model)} model under the {forcing} forcing "
                                f"({r.afc['samples']} samples of {len(r.afc['parameters'])} uncertain parameters)",
                                ["where", "ω", "nominal", "mean", "std", "cv"],
                                [[text(k.replace("_", " ")), *(sec.cell(f"afc.at.{k}.{x}", v[x]) for x in (
                                    "omega", "nominal", "mean", "std", "cv"))] for k, v in at.items()], headline=True))
        if model in SOURCE_MODELS:
            sec.warnings.append(f"the AFC spread is computed on the {model_name(model)}, which the stability analysis "
                                "reports unstable at the pumps' operating points (see the dynamics scenes): a "
                                "validation of the source's Fig. 3.7, not a prediction" if st is None else
                                f"the AFC model '{model_name(model)}' is {'stable' if st else 'UNSTABLE'}")
        else:
            sec.validation.append({"ok": None, "text": "the source's AFC spread (Fig. 3.7, 'up to 40 %') was "
                                                       "computed on its program model, which is unstable; this run "
                                                       f"uses the {model_name(model)} model (set "
                                                       "analyses.montecarlo.afc.model: program, forcing: appendix "
                                                       "and its 28 constants to reproduce the source)"})
