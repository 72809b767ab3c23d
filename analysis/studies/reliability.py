"""Reliability of the traditional balance disc: probability of failure-free operation P(t) and
mean time to failure, Pavlenko (2014) chapter 1.2, Eqs. (1.36)-(1.52).

The disc works while its gap stays in [u_min, u_max] (region B of Fig. 1.24).  The gap depends
on the load tau (a stationary truncated normal variable, (1.45)-(1.47)) and on the inner seal's
clearance chi(t) = chi0 + b t, which grows with erosive wear at a truncated normal rate b
((1.38)-(1.43)).  For load tau the disc is failure-free while chi1(tau) <= chi(t) <= chi2(tau)
with chi_j from (1.34), so (1.48):

    P(t) = int_0^{sigma psi1} [F_chi(chi2(tau), t) - F_chi(chi1(tau), t)] p_tau(tau) dtau

(upper limit sigma psi1 as reconstructed here; see the validation ledger), and the mean time to failure is
T = int_0^inf P(t) dt (1.49).  Both are implemented literally: trapezoid quadrature in tau on
``tau_nodes`` nodes and the exact CDF of chi(t).  An independent cross-check of (1.49): for fixed
(tau, b) the time spent in region B up to a horizon is the length of the interval where
chi1 <= chi0 + b t <= chi2, so int_0^H P dt = E_{tau,b}[that length], computed by quadrature in b
instead of in t (``sojourn``).

Spec reliability-experiments-estimation.md §1.6: the literal model does not give the source's
P(2000 h) = 0.75 and T = 2.7 thousand h; it gives 0.671 and 4.12 thousand h (see
docs/validation.md).  The option ``renormalise`` divides p_tau by its mass on [0, sigma psi1],
the other reading of the printed formula.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr

from autobal.analysis.run import progress
from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Quantity
from autobal.analysis.run.result import new_figure, unit_axis
from autobal.models.hydroheel import (
    WearModel,
    WornDisc,
    conductance_ratio,
    flow_ratio,
    initial_clearance,
    max_gap,
    seal_shape_factor,
)

HOUR = 3600.0  # s
KILOHOUR = 1000 * HOUR

# Chapter 1.2 printed values (L871-L951), kept beside the computed ones in results.json.
SOURCE = {
    "u_max": 1.5, "chi0": 1.76, "b_mean_per_s": 1.39e-7, "b_std_per_s": 2.78e-8, "tau_std": 0.19, "k": 3.3,
    "a_b": 1.0, "a_tau": 1.0, "wear_le_zB_2000h": 0.5, "P_2000h": 0.75, "P_4000h_about": 0.25,
    "mttf": 2700.0 * HOUR,
}
# Table 1.2 (L944-L951): mean time to failure and time of reliable operation at P = 0.8 (printed in thousand h), for
# the bush materials; the meaning of the two rows is lost in the OCR and the wear rates of SCh20 and
# 20Kh13 are not given, so the table is reference data only (Pavlenko 2014, ch. 1.2).
TABLE_1_2 = {
    "materials": ["SCh20 (grey cast iron)", "20Kh13", "30Kh3MA"],
    "mttf": [[x * KILOHOUR for x in row] for row in ([1.6, 3.9, 5.8], [3.5, 8.7, 14.0])],
    "time_at_P_0.8": [[x * KILOHOUR for x in row] for row in ([1.0, 2.6, 3.5], [2.5, 7.4, 13.2])],
}


@dataclass
class Reliability:
    """P(t) and mean time to failure of a worn disc, Eqs. (1.48)-(1.49).

    disc: the disc of (1.33)-(1.36); wear: the wear law; tau_mean, tau_std: load (1.45);
    u_min, u_max: the gap limits of region B; tau_nodes: trapezoid nodes on [0, sigma psi1];
    renormalise: divide p_tau by its mass on [0, sigma psi1] instead of by its mass on [0, inf) (1.46).
    """

    disc: WornDisc
    wear: WearModel
    tau_mean: float
    tau_std: float
    u_min: float
    u_max: float
    tau_nodes: int = 20001
    renormalise: bool = False
    _nodes: tuple = field(init=False, repr=False)

    def __post_init__(self):
        top = self.disc.sigma * self.disc.psi1
        tau = np.linspace(0.0, top, self.tau_nodes)
        w = np.full(tau.shape, tau[1] - tau[0])
        w[[0, -1]] *= 0.5  # trapezoid weights
        dens = np.exp(-0.5 * ((tau - self.tau_mean) / self.tau_std) ** 2) / (np.sqrt(2 * np.pi) * self.tau_std)
        dens *= self.a_tau  # truncated at tau >= 0, (1.45)-(1.46)
        if self.renormalise:
            dens /= np.sum(w * dens)
        chi1, chi2 = self.disc.clearance(self.u_min, tau), self.disc.clearance(self.u_max, tau)
        chi1[-1] = chi2[-1] = np.inf  # tau = sigma psi1: no finite clearance balances it
        self._nodes = (tau, w * dens, chi1, chi2)

    @property
    def a_tau(self) -> float:
        """Normaliser of the load density truncated at 0, Eq. (1.46)."""
        return float(1.0 / ndtr(self.tau_mean / self.tau_std))

    @property
    def load_mass(self) -> float:
        """Probability mass of the load density on [0, sigma psi1] (1 when renormalised)."""
        return float(np.sum(self._nodes[1]))

    def probability(self, t, chunk: int = 64) -> np.ndarray:
        """P(t) of Eq. (1.48) at times t (s), vectorised in chunks of ``chunk`` times."""
        t = np.atleast_1d(np.asarray(t, float))
        _, wd, chi1, chi2 = self._nodes
        out = np.empty(t.shape)
        for i in range(0, t.size, chunk):
            tt = t[i:i + chunk, None]
            f = self.wear.clearance_cdf(chi2, tt) - self.wear.clearance_cdf(chi1, tt)
            out[i:i + chunk] = f @ wd
        return out

    def mttf(self, horizon: float, points: int = 4001) -> tuple[float, np.ndarray, np.ndarray]:
        """Mean time to failure (1.49) as int_0^horizon P(t) dt by the trapezoid rule; also (t, P)."""
        t = np.linspace(0.0, horizon, points)
        p = self.probability(t)
        return float(np.trapezoid(p, t)), t, p

    def sojourn(self, horizon: float = np.inf, b_nodes: int = 4001) -> float:
        """int_0^horizon P(t) dt by the time-in-region-B identity, quadrature in b and tau (s).

        For b > 0 the clearance chi0 + b t is in [chi1, chi2] for t in [(chi1 - chi0)/b,
        (chi2 - chi0)/b]; the length of that interval within [0, horizon] is averaged over the
        truncated normal b (nodes within 8 standard deviations) and the load density.  With
        horizon = inf the node b = 0 is left out (its density is a_b phi(b_mean/b_std)/b_std; the
        integral diverges there only logarithmically, by that density per e-fold of time)."""
        wr = self.wear
        lo = max(0.0, wr.b_mean - 8.0 * wr.b_std)
        b = np.linspace(lo, wr.b_mean + 8.0 * wr.b_std, b_nodes)
        pb = wr.a_b * np.exp(-0.5 * ((b - wr.b_mean) / wr.b_std) ** 2) / (np.sqrt(2 * np.pi) * wr.b_std)
        wb = np.full(b.shape, b[1] - b[0])
        wb[[0, -1]] *= 0.5
        keep = b > 0
        b, wb = b[keep], wb[keep] * pb[keep]
        _, wd, chi1, chi2 = self._nodes
        total = 0.0
        for i in range(0, wd.size, 512):  # blocks of load nodes: memory 512 x b_nodes
            c1, c2 = chi1[i:i + 512, None], chi2[i:i + 512, None]
            with np.errstate(invalid="ignore"):
                t_in = np.maximum(c1 - wr.chi0, 0.0) / b  # entry into region B
                t_out = np.minimum((c2 - wr.chi0) / b, horizon)  # exit (u > u_max) or horizon
                length = np.nan_to_num(np.clip(t_out - t_in, 0.0, None), posinf=0.0)
            total += wd[i:i + 512] @ (length @ wb)
        return float(total)

    def time_at(self, probability: float, horizon: float) -> float:
        """Time of reliable operation at level ``probability`` (Table 1.2): the first t with
        P(t) = probability; NaN if P(0) is already below it (s)."""
        f = lambda t: float(self.probability(t)[0]) - probability  # noqa: E731
        if f(0.0) < 0:
            return float("nan")
        if f(horizon) > 0:
            return float("inf")
        return brentq(f, 0.0, horizon, xtol=1.0)


_P14 = "Pavlenko (2014)"
_BOTH = ("literal", "renormalised")


def _models(*keys: str) -> str:
    """The keys of the literal (1.48) and the renormalised load density."""
    return " ".join(f"{m}.{k}" for m in _BOTH for k in keys)


def _time(**kw):
    return quantity("s", "t", "operating times", "h", **kw)


def _probability(**kw):
    return quantity("1", "P(t)", "probability of failure-free operation (at the times of times) / of wear ≤ z_B",
                    source=f"{_P14}, Eq. (1.48), Figs. 1.27-1.28", **kw)


def _other_time(**kw):
    return quantity("s", "T", "mean time to failure by the sojourn cross-check / to an infinite horizon; time at a "
                    "reliability", "h", **kw)


def _group(**kw):
    return quantity("1", "k, α, χ0, u, τ ...", "the source's groups of the wear model",
                    source=f"{_P14}, Eqs. (1.30)-(1.52)", **kw)


def _curve(**kw):
    return quantity("1", "P(t)", "reliability curves", **kw)


def _region(**kw):
    return quantity("1", "χ, τ", "region B of Fig. 1.24", source=f"{_P14}, Fig. 1.24", **kw)


def _published(**kw):
    return quantity("1", "", "the source's published groups and probabilities", source=f"{_P14}, ch. 1.2", **kw)


@record
class Variant(Record):
    """P(t), MTTF and the time of reliable operation of one reading of (1.48), times in s."""

    P0: float = _probability()
    P: np.ndarray = _probability()
    mttf: float
    mttf_sojourn: float = _other_time()
    mttf_infinite: float = _other_time()
    time_at: float = _other_time()  # NaN (null) where P(t) never is the level
    time_at_status: str | None = optional()


@record
class Literal(Variant):
    """(1.48)-(1.49) as printed."""

    mttf: float = quantity("s", "T", "mean time to failure, (1.48)-(1.49) as printed", "h",
                           source=f"{_P14}, Eq. (1.49)", headline=2)


@record
class Renormalised(Variant):
    """The load density renormalised on [0, σψ1]."""

    mttf: float = quantity("s", "T", "mean time to failure, load density renormalised on [0, σψ1]", "h",
                           source=f"{_P14}, Eq. (1.49)", headline=1)


@record
class Curve(Record):
    t: np.ndarray = _time()
    P_literal: np.ndarray = _curve()
    P_renormalised: np.ndarray = _curve()
    P_wear_le_base_gap: np.ndarray = _curve()


@record
class Region(Record):
    """Region B of Fig. 1.24: the load between the curves of the smallest and the largest gap."""

    chi: np.ndarray = _region()
    tau_u_min: np.ndarray = _region()
    tau_u_max: np.ndarray = _region()


@record
class Published(Record):
    """The source's published values (:data:`SOURCE`)."""

    u_max: float = _published()
    chi0: float = _published()
    b_mean_per_s: float = quantity("1/s", "b", "the source's wear rate, mean and std")
    b_std_per_s: float = quantity("1/s", "b", "the source's wear rate, mean and std")
    tau_std: float = _published()
    k: float = _published()
    a_b: float = _published()
    a_tau: float = _published()
    wear_le_zB_2000h: float = _published()
    P_2000h: float = _published()
    P_4000h_about: float = _published()
    mttf: float = quantity("s", "T", "the source's mean time to failure", "h", source=f"{_P14}, Eq. (1.49)")


def _wear_rate(**kw):
    return quantity("1/s", "b", "wear rate of the inner-seal clearance ratio χ, mean and std",
                    source=f"{_P14}, Eqs. (1.38)-(1.43)", **kw)


@record
class ReliabilityResult(TypedResult):
    """Reliability of the traditional balance disc (Pavlenko 2014, ch. 1.2): P(t), MTTF, wear CDF."""

    title: str
    k: float = _group()
    alpha_T1: float = _group()
    chi0: float = _group()
    u_max: float = quantity("1", "u_max", "largest gap", source=f"{_P14}, Fig. 1.24")
    u_min: float = _group()
    q_at_u_max: float = _group()
    b_mean: float = quantity("1/s", "b̄", "mean wear rate of the inner-seal clearance ratio χ",
                             source=f"{_P14}, Eqs. (1.38)-(1.43)")
    b_std: float = _wear_rate()
    a_b: float = _group()
    tau_mean: float = quantity("1", "τ̄", "mean load", source=f"{_P14}, Eq. (1.45)")
    tau_std: float = _group()
    sigma: float = _group()
    psi1: float = _group()
    z_B: float = quantity("m", "z_B", "base gap", "µm")
    a_tau: float = _group()
    load_mass_on_0_sigma_psi1: float = _group()
    times: np.ndarray = _time()
    horizon: float = _time()
    reliable_probability: float = _probability()
    wear_le_base_gap: np.ndarray = _probability()
    literal: Literal
    curve: Curve
    renormalised: Renormalised
    region: Region
    source: Published
    #: Table 1.2 (:data:`TABLE_1_2`): its keys are the source's row names
    table_1_2: dict
    accuracy: dict | None = optional()
    name = "reliability"

    @property
    def mttf(self) -> float:
        """Mean time to failure by (1.49) with the load density renormalised on [0, sigma psi1], s."""
        return self.renormalised.mttf

    @property
    def mttf_literal(self) -> float:
        """Mean time to failure by (1.48)-(1.49) as printed, s."""
        return self.literal.mttf

    def summary(self) -> str:
        s = self.source
        lines = [
            "reliability of the traditional balance disc (ch. 1.2)",
            f"  u_max {self.u_max:.4f} (source {s.u_max}), chi0 {self.chi0:.4f} ({s.chi0}), k {self.k:.4f} "
            f"({s.k}), b_mean {self.b_mean:.4g} 1/s ({s.b_mean_per_s})",
            "  P(wear <= z_B): " + ", ".join(f"{h:g} h: {p:.4f}" for h, p in
                                             zip(self.times / HOUR, self.wear_le_base_gap, strict=True)),
        ]
        for name, r in (("literal (1.48)", self.literal), ("renormalised p_tau", self.renormalised)):
            lines.append(f"  {name}: P(0) {r.P0:.4f}; " + ", ".join(
                f"P({h:g} h) {p:.4f}" for h, p in zip(self.times / HOUR, r.P, strict=True))
                + f"; MTTF {_hours(r.mttf)} to {_hours(self.horizon)} ({_hours(r.mttf_sojourn)} by sojourn),"
                f" {_hours(r.mttf_infinite)} to infinity; t(P = {self.reliable_probability}) {_hours(r.time_at)}")
        lines.append(f"  source: P(2000 h) {s.P_2000h}, MTTF {_hours(s.mttf)}: "
                     "not reproduced (see the validation ledger)")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        c = self.curve
        q = QUANTITIES.find("curve.t")
        curves = QUANTITIES.columns({"P_literal": c.P_literal, "P_renormalised": c.P_renormalised,
                                     "P_wear_le_base_gap": c.P_wear_le_base_gap}, "curve")
        return {"reliability_curve.csv": {f"t [{q.display}]": q.shown(np.asarray(c.t, float))} | curves}

    def draw(self, ax) -> None:
        """Probability of failure-free operation against time, both readings of (1.48), Fig. 1.28."""
        c = self.curve
        f = unit_axis(ax, "time t", "s", "h", which="x")  # hours unless a time unit is chosen
        t = np.asarray(c.t, float) * f
        ax.plot(t, c.P_literal, label="P(t), (1.48) literal")
        ax.plot(t, c.P_renormalised, ls="--", label=r"P(t), $p_\tau$ renormalised on [0, $\sigma\psi_1$]")
        ax.plot(t, c.P_wear_le_base_gap, ls=":", label=r"P(wear $\leq z_B$) (Fig. 1.27)")
        ax.plot(np.array([2000, 4000]) * HOUR * f, [0.75, 0.25], "kx", label="source (Fig. 1.28)")
        ax.axvline(self.literal.mttf * f, color="0.4", lw=0.8, label="MTTF (1.49), literal")
        ax.set_xlim(0, min(t[-1], 12000 * HOUR * f))
        ax.set_ylabel("probability")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict[str, Figure]:
        fig, (a1, a2) = new_figure((10, 4.2), 1, 2)
        self.draw(a1)
        reg = self.region
        a2.plot(reg.chi, reg.tau_u_min, label=r"$\tau_1(\chi)$, $u = u_{min}$")
        a2.plot(reg.chi, reg.tau_u_max, label=r"$\tau_2(\chi)$, $u = u_{max}$")
        a2.fill_between(reg.chi, reg.tau_u_max, reg.tau_u_min, color="0.9", label="B: failure-free")
        a2.axvline(self.chi0, color="k", lw=0.8, ls=":", label=r"$\chi_0$")
        a2.axhline(self.tau_mean, color="0.5", lw=0.8, ls="--", label=r"$\bar\tau$")
        a2.set_xlabel(r"seal clearance $\chi = h_1/z_B$")
        a2.set_ylabel(r"axial force $\tau$")
        a2.grid(alpha=0.3)
        a2.legend(fontsize=7)
        fig.suptitle(self.title, fontsize=9)
        return {"fig_reliability.png": Figure(fig, "Reliability P(t) (literal and renormalised load density) and the "
                                                   "wear probability; Pavlenko (2014), Figs. 1.27-1.28")}


def _hours(t: float) -> str:
    """A time in s shown in hours for the summary, 'nan h' where there is none (NaN, or null read back)."""
    return f"{math.nan if t is None else t / HOUR:.0f} h"


#: every number of the reliability block (Pavlenko 2014, ch. 1.2), from the fields; times in s, shown in hours
ReliabilityResult.quantities = QUANTITIES = declarations(
    ReliabilityResult,
    Quantity("table_1_2.mttf table_1_2.time_at_P_0.8", "s", "T", "Table 1.2: times (printed in thousands of hours)",
             "kh", source=f"{_P14}, Table 1.2"))


@dataclass(frozen=True)
class Disc:
    """The traditional balance disc, (1.30)-(1.32): inner annular seal r1, l1, face r2 < r3, base gap z_B (m); the
    new seal by its clearance h1 (m) or by the face/seal conductance ratio alpha_T1, the other None."""

    seal_radius: float
    seal_length: float
    face_inner_radius: float
    face_outer_radius: float
    base_gap: float
    effective_area_ratio: float  # sigma = s_e/s_B
    conductance_ratio: float | None = None  # alpha_T1
    seal_clearance: float | None = None  # h1, m


@dataclass(frozen=True)
class Wear:
    """Mean wear of the seal clearance (Fig. 1.25): ``depth`` (m) per ``per`` (s); its coefficient of variation."""

    depth: float
    per: float
    cv: float  # kappa = sigma_b / b_mean (1.50)


@dataclass(frozen=True)
class Load:
    """The load tau = T/(p_B s_B): its mean and coefficient of variation (1.50); the discharge ratio psi1."""

    mean: float
    cv: float
    discharge_ratio: float


@dataclass(frozen=True)
class Limits:
    """Region B of Fig. 1.24: the smallest gap u_min and the largest flow q_max (-> u_max by (1.52))."""

    min_gap: float
    max_flow: float


@dataclass(frozen=True)
class Spec:
    """What the reliability study computes (the validated ``analyses.reliability`` of a scene; times in s).

    Attributes
    ----------
    disc, wear, load, limits : Disc, Wear, Load, Limits
    times : tuple of float
        Times at which P(t) is reported, s.
    horizon : float
        Upper limit of (1.49), s.
    time_points, tau_nodes : int
        Points of the P(t) curve; nodes of the load integral.
    reliable_probability : float
        The level P of Table 1.2's time of reliable operation.
    """

    disc: Disc
    wear: Wear
    load: Load
    limits: Limits
    times: tuple
    horizon: float
    time_points: int
    tau_nodes: int
    reliable_probability: float


def build(spec: Spec) -> tuple[Reliability, Reliability, dict]:
    """The literal and renormalised models of a spec, and the
    derived inputs (k, chi0, alpha_T1, u_max, b_mean, ...)."""
    d = spec.disc
    k = seal_shape_factor(d.seal_radius, d.seal_length, d.face_inner_radius, d.face_outer_radius)
    if d.conductance_ratio is not None:
        alpha, chi0 = d.conductance_ratio, initial_clearance(k, d.conductance_ratio)
    else:
        chi0 = d.seal_clearance / d.base_gap
        alpha = float(conductance_ratio(k, chi0))
    u_max = max_gap(spec.limits.max_flow, alpha)
    b_mean = spec.wear.depth / spec.wear.per / d.base_gap  # (dchi/dt)_0, 1/s
    b_std = spec.wear.cv * b_mean  # (1.50), sigma = kappa * mean (erratum 3)
    ld = spec.load
    disc = WornDisc(sigma=d.effective_area_ratio, k=k, psi1=ld.discharge_ratio)
    wear = WearModel(chi0=chi0, b_mean=b_mean, b_std=b_std)
    common = dict(disc=disc, wear=wear, tau_mean=ld.mean, tau_std=ld.cv * ld.mean, u_min=spec.limits.min_gap,
                  u_max=u_max, tau_nodes=spec.tau_nodes)
    derived = {"k": k, "alpha_T1": alpha, "chi0": chi0, "u_max": u_max, "u_min": spec.limits.min_gap,
               "q_at_u_max": float(flow_ratio(u_max, alpha)), "b_mean": b_mean, "b_std": b_std,
               "a_b": wear.a_b, "tau_mean": ld.mean, "tau_std": ld.cv * ld.mean, "sigma": d.effective_area_ratio,
               "psi1": ld.discharge_ratio, "z_B": d.base_gap}
    return Reliability(**common), Reliability(**common, renormalise=True), derived


def run(spec: Spec, title: str = "") -> ReliabilityResult:
    """The chapter 1.2 study of a scene: P(t), MTTF both ways, wear CDF, region B, source values."""
    lit, ren, derived = build(spec)
    horizon = spec.horizon
    times = np.asarray(spec.times, float)
    data = {"title": title, **derived, "a_tau": lit.a_tau, "load_mass_on_0_sigma_psi1": lit.load_mass,
            "times": times, "horizon": horizon, "reliable_probability": spec.reliable_probability,
            "wear_le_base_gap": lit.wear.wear_probability(1.0, times)}
    with progress.steps(9, "reliability (P(t), MTTF, t(P), accuracy)", "stage") as bar:
        for name, model in (("literal", lit), ("renormalised", ren)):
            mttf, t, p = model.mttf(horizon, spec.time_points)
            bar.tick(note=f"{name}: P(t)")
            data[name] = {
                "P0": float(model.probability(0.0)[0]), "P": model.probability(times),
                "mttf": mttf, "mttf_sojourn": model.sojourn(horizon)}
            bar.tick(note=f"{name}: MTTF (sojourn)")
            data[name]["mttf_infinite"] = model.sojourn()
            bar.tick(note=f"{name}: MTTF to infinity")
            data[name]["time_at"] = model.time_at(spec.reliable_probability, horizon)
            bar.tick(note=f"{name}: t(P)")
            if not np.isfinite(data[name]["time_at"]):
                data[name]["time_at_status"] = (f"P(t) is not {spec.reliable_probability} at any time up to the "
                                                  f"horizon (P(0) = {data[name]['P0']:.4g})")
            data["curve"] = data.get("curve", {"t": t}) | {f"P_{name}": p}
        data["curve"]["P_wear_le_base_gap"] = lit.wear.wear_probability(1.0, data["curve"]["t"])
        chi = np.linspace(0.5, 4.0 * derived["chi0"], 200)
        data["region"] = {"chi": chi, "tau_u_min": lit.disc.load(chi, lit.u_min),
                          "tau_u_max": lit.disc.load(chi, lit.u_max)}
        data["source"] = SOURCE
        data["table_1_2"] = TABLE_1_2
        data["accuracy"] = accuracy({"literal": lit, "renormalised": ren}, spec, data)
        bar.tick(note="accuracy")
    return ReliabilityResult.from_dict(data)


def accuracy(models: dict, spec: Spec, data: dict) -> dict:
    """Error estimate of P(times), the MTTF to the horizon and to infinity and t(P = level), per model:

    * load quadrature: everything again with every other tau node (the same trapezoid rule at twice the
      step), the difference taken whole (no Richardson factor: the integrand's convergence in tau is
      slower than second order on the shipped scene);
    * time quadrature of (1.49): the trapezoid on every other time sample;
    * method: MTTF by the time integral against the sojourn identity (quadrature in b);
    * t(P = level): the load-quadrature change of P there over |dP/dt|, plus brentq's 1 s tolerance.
    """
    times, horizon = np.asarray(spec.times, float), spec.horizon
    parts = {}
    for name, m in models.items():
        d = data[name]
        coarse = Reliability(m.disc, m.wear, m.tau_mean, m.tau_std, m.u_min, m.u_max,
                             tau_nodes=(m.tau_nodes + 1) // 2, renormalise=m.renormalise)
        P = np.asarray(d["P"], float)
        t_s, curve = np.asarray(data["curve"]["t"]), np.asarray(data["curve"][f"P_{name}"])
        mttf = d["mttf"]
        p = {"P_tau": float(np.max(np.abs(coarse.probability(times) - P) / np.maximum(P, 1e-300))),
             "mttf_tau": abs(coarse.sojourn(horizon) - d["mttf_sojourn"]) / mttf,
             "mttf_time": abs(np.trapezoid(curve[::2], t_s[::2]) - mttf) / mttf,
             "mttf_sojourn": abs(d["mttf_sojourn"] - mttf) / mttf,
             "mttf_infinite_tau": abs(coarse.sojourn() - d["mttf_infinite"]) / d["mttf_infinite"]}
        t = d["time_at"]
        if np.isfinite(t) and t > 0:
            dp = abs(float(m.probability(t + HOUR)[0] - m.probability(t - HOUR)[0])) / (2 * HOUR)
            shift = abs(float(coarse.probability(t)[0] - m.probability(t)[0]))
            p["time_at_tau"] = (shift / dp + 1.0) / t if dp > 0 else math.inf
        parts[name] = p
    return {"estimate": float(max(v for p in parts.values() for v in p.values())), "parts": parts,
            "how": "largest relative change of P(times), MTTF (horizon and infinite) and t(P = level) when the load "
                   "quadrature uses every other node (difference taken whole), when the time quadrature of (1.49) "
                   "uses every other sample, and between MTTF by the time integral and by the sojourn identity"}
