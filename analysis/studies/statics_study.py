"""The static calculation of a scene: exact IPOPT solution beside the source's closed forms.

``run(solver, spec)`` (a frozen :class:`Spec`) returns a :class:`StaticsResult`, plain data that writes itself as
the ``statics`` block of results.json, CSV tables and the figures equivalent to the source's
Figs 2.4-2.6 (pump) and 2.9-2.10 (compressor), plus the force-gap characteristic (2.35).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autobal.analysis.numerics import closed_form
from autobal.analysis.numerics.statics import StaticPoint, StaticsSolver
from autobal.analysis.run import solver_options
from autobal.analysis.run.fields import Record, TypedResult, declarations, explained, optional, quantity, record, shared
from autobal.analysis.run.figures import Figure, record_axis
from autobal.analysis.run.quantities import Quantity, convert, display_unit_of
from autobal.analysis.run.result import fixed_layout, fmt, new_figure
from autobal.analysis.studies import workprecision
from autobal.errors import SolveError
from autobal.models.device import groups_by_name

SWEEP_KEYS = ("psi_e", "psi2", "psi3", "psi_cam", "u", "xi")
REGULATOR_KEYS = ("psi_cam", "xi")  # the sweep's regulator states: none without a regulator
REFINE_POINTS = 12  # extra points inside each sweep interval where a stop is reached or left (figures)

_P14 = "Pavlenko (2014)"


@dataclass(frozen=True)
class Spec:
    """What the static calculation of a device computes (the validated ``analyses.statics`` of a scene).

    Attributes
    ----------
    operating_ratio : float
        psi1 = p1/p_B of the reported operating point, dimensionless.
    start, stop : float
        The sweep's range of psi1, dimensionless (Pavlenko (2014), Figs 2.4-2.6).
    points : int
        Points of the sweep.
    force_gap_points : int
        Points of the force-gap characteristic phi(u), Eq. (2.35).
    """

    operating_ratio: float
    start: float
    stop: float
    points: int
    force_gap_points: int = 60

    def __post_init__(self):
        if not 0 < self.start < self.stop:
            raise ValueError(f"discharge_ratio: start {self.start:g} and stop {self.stop:g} need 0 < start < stop (1)")
        if self.points < 2 or self.force_gap_points < 2:
            raise ValueError("discharge_ratio.points and force_gap_points: at least 2")


# the declarations several fields share (one Quantity each: the key paths of equal declarations are joined);
# Pavlenko (2014), ch. 2: groups (2.18); psi = p/p_B, u = z/z_B, xi = x/x_B, q = Q/Q_B
_psi1 = shared("1", "ψ1", "discharge pressure ratio p1/p_B")


_psi1_kr = shared("1", "ψ1_kr", "critical discharge ratio", source=f"{_P14}, Eq. (2.32)")


_dpsi_kr = shared("1", "δψ_kr", "critical barrier margin (p_e − p1)/p_B", source=f"{_P14}, Eq. (2.31)")


_u0 = shared("1", "u0", "face-gap ratio z0/z_B", source=f"{_P14}, Eq. (2.27)")


_xi0 = shared("1", "ξ0", "valve-opening ratio x0/x_B", source=f"{_P14}, Eq. (2.28)")


_psi2_0 = shared("1", "ψ20", "disc-chamber ratio p2/p_B", source=f"{_P14}, Eq. (2.24)")


_psi3_0 = shared("1", "ψ30", "cavity ratio p3/p_B", source=f"{_P14}, Eq. (2.25)")


_psi_e0 = shared("1", "ψ_e0", "barrier-chamber ratio p_e/p_B")


_psi_cam0 = shared("1", "ψ_cam0", "valve-chamber ratio p_cam/p_B", source=f"{_P14}, Eq. (2.26)")


_kappa_s = shared("1", "κ_s", "axial stiffness of the balancing force (group)", source=f"{_P14}, Eq. (2.36)")


_q = shared("1", "q", "flow ratio Q/Q_B", source=f"{_P14}, Eq. (2.30)")


_residual = shared("1", "", "largest relative residual of the static equations / difference from a Newton polish")


_residuals = shared("1", "r", "complementarity residuals of the valve stop and the contact")


_area = shared("m^2", "s", "areas")


_conductance = shared("m^3/(Pa*s)", "g", "hydraulic conductances")


_ratio = shared("1", "", "the ratios of the sweep over ψ1")


_flow = shared("m^3/s", "Q", "flows over the sweep")


_force_gap = shared("1", "u, φ, τ", "balancing force against the gap at the operating pressure",
                    source=f"{_P14}, Eq. (2.35)")


@record
class Accuracy(Record):
    """The statics' estimate of its own error (its numbers declared as every analysis' ``accuracy``)."""

    max_relative_residual: float
    newton_max_difference: float
    how: str
    estimate: float


@record(kw_only=True)
class Scales(Record):
    """The SI bases of the source's dimensionless groups (Pavlenko (2014), Eq. (2.18))."""

    p_B: float = quantity("Pa", "p_B", "base pressure of the ratios ψ")
    s_B: float = _area()
    z_B: float = quantity("m", "z_B", "base gap of the ratio u", "µm")
    x_B: float | None = quantity("m", "x_B", "base opening of the ratio ξ", optional=True)  # no regulator: none
    g1: float = _conductance()
    Q_scale: float = quantity("m^3/s", "g1 p_B", "flow scale")
    s_e: float = _area()
    Q_n: float = quantity("m^3/s", "Q_n", "nominal flow of the machine", "m³/h")


_loss = shared("1", "ζ, b", "loss coefficients and the impeller group")


@record
class Derived(Record):
    """Loss coefficients, areas and the impeller's axial-force group of the device (models.device.design)."""

    zeta_u3: float = _loss()
    zeta_TB: float = _loss()
    f_TB: float = _area()
    s_T: float = _area()
    s_e: float = _area()
    b_from_impeller: float = _loss()


@record(kw_only=True)
class ClosedForm(Record):
    """The source's closed forms at the operating point (ideal regulator; Pavlenko (2014), Eqs. (2.24)-(2.36),
    (2.147)-(2.162) for the gas device)."""

    dpsi_kr: float = _dpsi_kr()
    psi1_kr: float = _psi1_kr()
    u0: float = _u0()
    psi2_0: float = _psi2_0()
    psi3_0: float = _psi3_0()
    psi_e0: float = _psi_e0()
    Q_e: float = quantity("m^3/s", "Q_e", "barrier flow, closed form")
    Q_B: float = quantity("m^3/s", "Q_B", "base flow of the flow ratios q", source=f"{_P14}, Eq. (2.29)")
    q_T: float = _q()
    q_1: float = _q()
    kappa_s: float = _kappa_s()
    xi0: float | None = _xi0(optional=True)  # with a regulator
    psi_cam0: float | None = _psi_cam0(optional=True)
    kappa_u_2_162: float | None = quantity("1", "κ_u", "stiffness along the pressure sweep (gas device)",
                                           source=f"{_P14}, Eq. (2.162)", optional=True)
    Q_e_over_Q_n: float = quantity("1", "Q_e/Q_n", "barrier flow over the nominal flow of the machine")
    psi2_0_quadratic: float | None = _psi2_0(optional=True)  # the liquid device's quadratic forms
    psi3_0_quadratic: float | None = _psi3_0(optional=True)
    u0_quadratic: float | None = _u0(optional=True)


@record
class Solver(Record):
    status: str
    iterations: int = quantity("1", "", "IPOPT iterations")
    max_relative_residual: float = _residual()


@record(kw_only=True)
class Exact(Record):
    """The operating point solved exactly (IPOPT on the full static system, stops as complementarity)."""

    psi1: float = _psi1()
    u0: float = _u0()
    psi2_0: float = _psi2_0()
    psi3_0: float = _psi3_0()
    psi_e0: float = _psi_e0()
    z0: float = quantity("m", "z0", "face gap at the operating point", "µm", headline=1)
    p1: float = quantity("Pa", "p1", "discharge pressure", headline=3)
    p2: float = quantity("Pa", "p2", "disc-chamber pressure", headline=4)
    p3: float = quantity("Pa", "p3", "pressure in the cavity behind the disc", headline=5)
    pe: float = quantity("Pa", "p_e", "barrier-chamber pressure", headline=6)
    dp: float = quantity("Pa", "Δp", "operating barrier margin p_e − p1", "bar", headline=12)
    Q_e: float = quantity("m^3/s", "Q_e", "barrier flow (the leak of the device)", headline=8)
    Q_1: float = quantity("m^3/s", "Q_1", "inner-seal flow (positive towards the disc)", headline=10)
    Q_T: float = quantity("m^3/s", "Q_T", "face-throttle leak", headline=9)
    Q_3: float = quantity("m^3/s", "Q_3", "flow through the cavity throttle")
    q_e: float = _q()
    q_T: float = _q()
    q_1: float = _q()
    kappa_s: float = _kappa_s()
    c_s: float = quantity("N/m", "c_s", "axial stiffness of the balancing force −dF/dz at the operating point, "
                          "κ_s p_B s_B / z_B", "N/µm", headline=14, source=f"{_P14}, Eq. (2.36)")
    contact: bool
    r_contact: float = _residuals()
    solver: Solver
    # the regulator's states: none without a regulator
    xi0: float | None = _xi0(optional=True)
    psi_cam0: float | None = _psi_cam0(optional=True)
    x0: float | None = quantity("m", "x0", "valve opening at the operating point", "mm", headline=2, optional=True)
    pcam: float | None = quantity("Pa", "p_cam", "valve-chamber pressure", headline=7, optional=True)
    regulator_saturated: bool | None = optional()
    r_valve: float | None = _residuals(optional=True)
    newton_max_difference: float = _residual()


@record(kw_only=True)
class Critical(Record):
    """The criticals solved exactly (q1 = 0); a critical that has no value is None with its status."""

    psi1_kr: float | None = _psi1_kr()
    p1_kr: float | None = quantity("Pa", "p1_kr", "discharge pressure at which the inner-seal flow reverses",
                                   headline=11, optional=True)
    psi1_kr_regulator_saturated: bool | None = optional()
    dpsi_kr: float | None = _dpsi_kr()
    dp_kr: float | None = quantity("Pa", "Δp_kr", "critical barrier margin p_e − p1 (inner-seal flow reverses)",
                                   "bar", headline=13, optional=True)


@record(kw_only=True)
class Ratios(Record):
    """The source's ratios over a grid of discharge ratios ψ1 (the sweep, its refined points)."""

    psi1: np.ndarray = _ratio()
    psi_e: np.ndarray = _ratio()
    psi2: np.ndarray = _ratio()
    psi3: np.ndarray = _ratio()
    psi_cam: np.ndarray | None = _ratio(optional=True)  # with a regulator
    u: np.ndarray = _ratio()
    xi: np.ndarray | None = _ratio(optional=True)
    q_e: np.ndarray = _ratio()
    q_T: np.ndarray = _ratio()
    q_1: np.ndarray = _ratio()


@record(kw_only=True)
class Refined(Ratios):
    """The extra points inside each sweep interval where a stop is reached or left (figures)."""

    regulator_saturated: np.ndarray | None = _ratio(optional=True)  # 1.0 where saturated
    #: the closed forms at the same ratios: keys are the ratios' names
    closed_form: dict


@record(kw_only=True)
class Sweep(Ratios):
    """The continuation sweep over the discharge ratio ψ1 (Pavlenko (2014), Figs 2.4-2.6, 2.9-2.10)."""

    Q_e: np.ndarray = _flow()
    Q_1: np.ndarray = _flow()
    Q_T: np.ndarray = _flow()
    kappa_s: np.ndarray = _ratio()
    contact: list[bool]
    regulator_saturated: list[bool] | None = _ratio(optional=True)
    status: list[str]
    max_relative_residual: float = _residual()
    #: the closed forms at the same ratios: keys are the ratios' names
    closed_form: dict


@record
class ForceGap(Record):
    """The balancing force against the gap at the operating pressure (Pavlenko (2014), Eq. (2.35))."""

    psi1: float = _psi1()
    u: np.ndarray = _force_gap()
    phi_exact: np.ndarray = _force_gap()
    phi_closed_form: np.ndarray = _force_gap()
    tau: float = _force_gap()


@record
class StaticsResult(TypedResult):
    """The static calculation of one device: operating point, criticals, sweep, force-gap curve; numbers in SI or
    as the source's named dimensionless groups."""

    accuracy: Accuracy
    title: str
    medium: str
    dpsi: float = quantity("1", "δψ", "barrier margin (p_e − p1)/p_B of the scene", source=f"{_P14}, Eq. (2.18)")
    #: the source's dimensionless groups: keys are their names
    groups: dict
    scales: Scales
    #: hydraulic conductances: keys are their names
    conductances: dict
    derived: Derived
    closed_form: ClosedForm
    exact: Exact
    critical_exact: Critical
    sweep: Sweep
    sweep_refined: Refined
    force_gap: ForceGap
    name = "statics"

    @property
    def face_gap(self) -> float:
        """Face gap z0 at the operating point, m."""
        return self.exact.z0

    @property
    def barrier_flow(self) -> float:
        """Barrier (leak) flow Q_e at the operating point, m^3/s."""
        return self.exact.Q_e

    @property
    def chamber_pressures(self) -> dict[str, float]:
        """Pressures at the operating point, Pa: p1 (discharge), p2 (disc chamber), p3, pe (barrier)."""
        return {k: getattr(self.exact, k) for k in ("p1", "p2", "p3", "pe")}

    @property
    def critical_discharge_pressure(self) -> float | None:
        """Exact discharge pressure p1_kr at which the inner-seal flow reverses, Pa (None if none)."""
        return self.critical_exact.p1_kr

    @property
    def critical_margin(self) -> float | None:
        """Exact critical barrier margin dpsi_kr = (p_e - p1)/p_B, dimensionless (None if none)."""
        return self.critical_exact.dpsi_kr

    @property
    def has_regulator(self) -> bool:
        """Whether the device has a regulator (without one it has no regulator states: no valve, no p_cam)."""
        return self.exact.regulator_saturated is not None

    def verdict(self) -> tuple[bool, str]:
        """At the operating point: regulating (or, without a regulator, the barrier margin held by its supply), no
        face contact, inner-seal flow towards the disc; the operating barrier margin against the critical one, and
        how far the discharge pressure is from the one that reverses the inner-seal flow (:func:`verdict`)."""
        ex, crit = self.exact, self.critical_exact
        return verdict(ex.psi1, ex.z0, ex.Q_1, ex.contact, ex.regulator_saturated, ex.dp, crit.dp_kr, crit.psi1_kr)

    def closed_form_note(self) -> str:
        """The assumption of the source's closed forms and whether this device meets it at the operating point."""
        margin = QUANTITIES.find("exact.dp").text(self.dpsi * self.scales.p_B)
        note = f"they assume an ideal regulator (p_e − p1 held at δψ p_B = {margin})"
        if not self.has_regulator:
            return note + ", as the barrier supply of this device (no regulator) does"
        if self.exact.regulator_saturated:
            return note + "; NOT valid here: the regulator is saturated at the operating point"
        return note

    #: the operating point's groups beside the source's closed forms (summary, report): (key, symbol)
    COMPARED = (("u0", "u0"), ("xi0", "ξ0"), ("psi2_0", "ψ20"), ("psi3_0", "ψ30"), ("psi_e0", "ψ_e0"),
                ("psi_cam0", "ψ_cam0"), ("kappa_s", "κ_s"))

    def compared(self) -> list[tuple[str, str, str, object, object]]:
        """(key path of the exact value, its name, symbol, closed form, exact) of each number the source's closed
        forms give (Pavlenko (2014), Eqs. (2.24)-(2.36)), the regulator's with a regulator only."""
        ex, cf, crit = self.exact, self.closed_form, self.critical_exact
        rows = [(f"exact.{k}", k, sym, getattr(cf, k), getattr(ex, k)) for k, sym in self.COMPARED
                if self.has_regulator or k not in ("xi0", "psi_cam0")]
        return rows + [("critical_exact.psi1_kr", "psi1_kr", "ψ1_kr", cf.psi1_kr, crit.psi1_kr),
                       ("critical_exact.dpsi_kr", "dpsi_kr", "δψ_kr", cf.dpsi_kr, crit.dpsi_kr),
                       ("exact.Q_e", "Q_e", "Q_e", cf.Q_e, ex.Q_e)]

    def summary(self) -> str:
        ex, cf, crit = self.exact, self.closed_form, self.critical_exact
        ok, words = self.verdict()
        lines = [f"statics at p1 = {QUANTITIES.find('exact.p1').text(ex.p1)} (psi1 = {ex.psi1:g}): IPOPT "
                 f"{ex.solver.status}, max relative residual {ex.solver.max_relative_residual:.1e}",
                 f"  {'ok' if ok else 'NOT OK'}: {words}",
                 *QUANTITIES.lines(self.to_dict()),
                 "  the source's dimensionless groups, exact and by its closed forms (Pavlenko 2014, "
                 "Eqs. (2.24)-(2.36));",
                 f"  {self.closed_form_note()}",
                 f"  {'':10s}{'exact':>12s}{'closed form':>14s}"]
        for _, k, _, closed, exact in self.compared()[:-3]:
            lines.append(f"  {k:10s}{fmt(exact):>12s}{fmt(closed):>14s}")
        kr = f"  {'psi1_kr':10s}{fmt(crit.psi1_kr):>12s}{fmt(cf.psi1_kr):>14s}"
        if crit.psi1_kr_regulator_saturated:
            kr += "  (exact: with the regulator saturated, where the ideal regulator does not hold)"
        lines.append(kr)
        lines.append(f"  {'dpsi_kr':10s}{fmt(crit.dpsi_kr):>12s}{fmt(cf.dpsi_kr):>14s}")
        q_e = QUANTITIES.find("exact.Q_e")
        lines.append(f"  {'Q_e':10s}{q_e.text(ex.Q_e):>12s}{q_e.text(cf.Q_e):>14s}")
        first = self.saturated_from()
        if first is not None:
            lines.append(f"  regulator saturated (valve on its open stop) from psi1 = {first:.4g}")
        if ex.regulator_saturated:
            lines.append("  the operating point itself has the regulator saturated")
        return "\n".join(lines)

    def saturated_from(self) -> float | None:
        """The first discharge ratio ψ1 of the sweep with the regulator saturated, or None."""
        return None if self.sweep.regulator_saturated is None else _first(self.sweep.psi1,
                                                                              self.sweep.regulator_saturated)

    def contact_from(self) -> float | None:
        """The first discharge ratio ψ1 of the sweep with the face in contact, or None."""
        return _first(self.sweep.psi1, self.sweep.contact)

    #: sweep column -> (its base in scales, the operating-point quantity whose display unit it takes, its name)
    _DIMENSIONAL = {"psi1": ("p_B", "exact.p1", "p1"), "psi_e": ("p_B", "exact.pe", "pe"),
                    "psi2": ("p_B", "exact.p2", "p2"), "psi3": ("p_B", "exact.p3", "p3"),
                    "psi_cam": ("p_B", "exact.pcam", "pcam"), "u": ("z_B", "exact.z0", "z"),
                    "xi": ("x_B", "exact.x0", "x")}

    def tables(self) -> dict[str, dict]:
        """statics_sweep.csv: every pressure, gap and flow in its display unit (MPa, µm, mm, L/s unless
        the scene or the CLI chooses others; the header names it) beside the source's dimensionless group;
        force_gap.csv in the groups of (2.35)."""
        sw, fg = self.sweep, self.force_gap
        cols = {}
        for k in ("psi1", *(k for k in SWEEP_KEYS if getattr(sw, k) is not None)):
            base, key, name = self._DIMENSIONAL[k]
            q = QUANTITIES.find(key)
            cols[f"{name} [{q.display}]"] = [None if v is None else q.shown(v * getattr(self.scales, base))
                                             for v in getattr(sw, k)]
            cols[f"{k} [1]"] = getattr(sw, k)
        for k in ("Q_e", "Q_1", "Q_T"):
            q = QUANTITIES.find(f"exact.{k}")
            cols[f"{k} [{q.display}]"] = [None if v is None else q.shown(v) for v in getattr(sw, k)]
        cols |= {f"{k} [1]": getattr(sw, k) for k in ("q_e", "q_T", "q_1", "kappa_s")}
        if sw.regulator_saturated is not None:
            cols["regulator_saturated"] = sw.regulator_saturated
        cols["contact"] = sw.contact
        cols |= {f"closed_form_{k} [1]": v for k, v in sw.closed_form.items() if not k.endswith("_status")}
        return {"statics_sweep.csv": cols,
                "force_gap.csv": {"u [1]": fg.u, "phi_exact [1]": fg.phi_exact,
                                  "phi_closed_form [1]": fg.phi_closed_form}}

    # dimensional axes: (the base in scales or "Q_B" of the closed forms, the quantity whose shown unit the axis takes)
    _BASES = {"p": ("p_B", "exact.p1"), "z": ("z_B", "exact.z0"), "x": ("x_B", "exact.x0"), "Q": ("Q_B", "exact.Q_T")}
    _CF = "closed form (ideal regulator), Pavlenko (2014)"
    # inches: tick labels and the two-line label on the left, the suptitle on top, tick labels and label below
    _MARGINS = {"left": 0.95, "right": 0.25, "top": 0.4, "bottom": 0.55, "hspace": 0.08}

    def _base(self, kind: str) -> tuple[float, str]:
        """The factor from a dimensionless group to the shown unit, and the unit (p_B, z_B, x_B, Q_B): the
        display unit of the operating point's pressure, gap, opening and leak (MPa, µm, mm, L/s unless chosen)."""
        key, quantity = self._BASES[kind]
        base = self.closed_form.Q_B if key == "Q_B" else getattr(self.scales, key)
        q = QUANTITIES.find(quantity)
        return q.shown(base), q.display

    def _curve(self, key: str, closed: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """psi1 and ``key`` over the sweep with the refined points near the kinks merged in, sorted."""
        parts = [(sw.psi1, sw.closed_form[key] if closed else getattr(sw, key))
                 for sw in (self.sweep, self.sweep_refined) if len(sw.psi1)]
        psi = np.concatenate([np.asarray(a, float) for a, _ in parts])
        y = np.concatenate([np.asarray(b, float) for _, b in parts])
        order = np.argsort(psi, kind="stable")
        return psi[order], y[order]

    def _operating_x(self) -> float:
        return self.exact.psi1 * self._base("p")[0]

    def _decorate(self, ax, kind: str, ylabel: str, xlabel: bool = True) -> None:
        """Dimensional axes, p1 and y in the display units of ``kind`` (:meth:`_base`), their labels naming the
        source's groups and bases (psi1 = p1/p_B, u = z/z_B ...); the saturated range shaded and labelled, the critical
        discharge pressures marked."""
        P, p_unit = self._base("p")
        p1 = np.asarray(self.sweep.psi1, float) * P
        x, sat = self._curve("regulator_saturated") if self.has_regulator else (p1, np.zeros(p1.shape))
        sat = sat > 0.5
        kr = self.critical_exact.psi1_kr
        kr_cf = self.closed_form.psi1_kr
        if sat.any():
            lo = x[sat].min() * P
            ax.axvspan(lo, p1.max(), color="0.92", zorder=0)
            ax.text(lo, 0.03, " regulator saturated (valve on its stop):\n the closed forms' ideal regulator "
                    "does not hold", transform=ax.get_xaxis_transform(),
                    va="bottom", ha="left", fontsize=7, color="0.3")
        inside = lambda v: v is not None and np.isfinite(v) and p1.min() <= v * P <= p1.max()  # noqa: E731
        if inside(kr):  # a line outside the axis gets no legend entry either
            ax.axvline(kr * P, color="k", lw=0.8, ls=":", label=r"$p_1^{kr}$ (inner-seal flow reverses), exact")
        if inside(kr_cf):
            ax.axvline(kr_cf * P, color="0.5", lw=0.8, ls="-.",
                       label=rf"$p_1^{{kr}}$, {self._CF} Eq. ({'2.160' if self.medium == 'gas' else '2.32'})")
        ax.set_xlim(p1.min(), p1.max())
        if xlabel:  # the groups in the labels: a secondary axis costs about a tenth of a draw
            ax.set_xlabel(rf"discharge pressure p₁, {p_unit}  (ψ₁ = p₁/$p_B$, $p_B$ = {P:.3g} {p_unit})")
            record_axis(ax, "x", "Pa", p_unit)
        if kind in self._BASES:
            F, unit = self._base(kind)
            group = {"p": "ψ = p/$p_B$", "z": "u = z/$z_B$", "x": "ξ = x/$x_B$", "Q": "Q/$Q_B$"}[kind]
            base = "" if kind == "p" else f", ${self._BASES[kind][0]}$ = {F:.3g} {unit}"
            ax.set_ylabel(f"{ylabel}, {unit}\n{group}{base}")
            record_axis(ax, "y", QUANTITIES.find(self._BASES[kind][1]).unit, unit)
        else:
            ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)

    def _operating_point(self, ax, y: float | None) -> None:
        if y is not None and np.isfinite(y):
            ax.plot([self._operating_x()], [y], "k*", ms=9, zorder=5, label="operating point")

    def draw(self, ax) -> None:
        """Chamber pressures against the discharge pressure (Fig 2.4 / 2.9) in the display unit (MPa unless
        chosen), the group psi named in the label."""
        ex = self.exact
        P, _ = self._base("p")
        for k, k0, lab in (("psi_e", "psi_e0", "pₑ barrier"), ("psi2", "psi2_0", "p₂ disc chamber"),
                           ("psi3", "psi3_0", "p₃"), ("psi_cam", "psi_cam0", r"$p_{cam}$ regulator")):
            if getattr(self.sweep, k) is None:
                continue  # no regulator: no valve chamber
            x, y = self._curve(k)
            line, = ax.plot(x * P, y * P, label=f"{lab}, exact")
            x, y = self._curve(k, closed=True)
            ax.plot(x * P, y * P, ls="--", color=line.get_color())
            if getattr(ex, k0) is not None:
                ax.plot([self._operating_x()], [getattr(ex, k0) * P], "k*", ms=8, zorder=5)
        ax.plot([], [], "k--", label=f"{self._CF} (dashed)")
        ax.plot([], [], "k*", ms=8, label="operating point")
        self._decorate(ax, "p", "pressure")

    def _valve_panel(self, ax) -> None:
        """The valve opening against the discharge pressure (Fig 2.5, lower panel), exact and (2.28)."""
        sw, ex = self.sweep, self.exact
        P, _ = self._base("p")
        X, _ = self._base("x")
        x, xi = self._curve("xi")
        ax.plot(x * P, xi * X, color="C2", label="valve opening x, exact (dots: sweep grid)")
        ax.plot(np.asarray(sw.psi1, float) * P, np.asarray(sw.xi, float) * X, ".", ms=4, color="C2")
        xc, xi_cf = self._curve("xi", closed=True)
        stop = ""
        if np.isfinite(xi_cf).any() and not np.isfinite(xi_cf).all():
            last = xc[np.isfinite(xi_cf)].max()
            stop = f";\nends: no opening passes the flow beyond ψ₁ = {last:.4g}"
        ax.plot(xc * P, xi_cf * X, ls="--", color="C3", label=f"valve, {self._CF} Eq. (2.28){stop}")
        self._operating_point(ax, ex.xi0 * X if ex.xi0 is not None else None)
        self._decorate(ax, "x", "valve opening x")

    def figures(self) -> dict[str, Figure]:
        """Pressures (Fig 2.4/2.9), gap and valve (Fig 2.5), flows (Fig 2.6/2.10), phi(u) (2.35); dimensional
        axes in the display units (MPa, µm, mm, L/s, kN unless the scene or the CLI chooses others) whose labels
        name the source's groups and their bases."""
        sw, ex = self.sweep, self.exact
        psi1 = np.asarray(sw.psi1, float)
        P, _ = self._base("p")
        p1 = psi1 * P
        figs = {}

        fig, ax = new_figure((8, 4.6))
        self.draw(ax)
        _legend(fig, ax)
        figs["fig_pressures.png"] = Figure(
            fig, "Chamber pressures (ψ = p/p_B on the right) against the discharge pressure, exact (solid) and "
            "the source's closed forms (dashed); Pavlenko (2014), Fig. 2.4 / 2.9")

        if self.has_regulator:
            fig, (a1, a2) = new_figure((8, 6.4), 2, 1, sharex=True)
        else:  # no regulator: the face gap alone, no valve panel
            fig, a1 = new_figure((8, 4.6))
        Z, _ = self._base("z")
        x, y = self._curve("u")
        a1.plot(x * P, y * Z, label="face gap z, exact")
        a1.plot(p1, np.asarray(sw.u, float) * Z, ".", ms=4, color="C0")
        x, y = self._curve("u", closed=True)
        a1.plot(x * P, y * Z, ls="--",
                label=f"face gap, {self._CF} Eq. ({'2.147' if self.medium == 'gas' else '2.27'})")
        self._operating_point(a1, ex.u0 * Z)
        self._decorate(a1, "z", "face gap z", xlabel=not self.has_regulator)
        if self.has_regulator:
            self._valve_panel(a2)
        _legend(fig, *fig.axes)
        figs["fig_gap.png"] = Figure(
            fig, "Face gap z (u = z/z_B) and, with a regulator, its valve opening x (ξ = x/x_B) against the "
            "discharge pressure; Pavlenko (2014), Fig. 2.5")

        fig, ax = new_figure((8, 4.6))
        Q, _ = self._base("Q")
        span = 0.0
        for k, lab in (("q_e", "Qₑ barrier leak"), ("q_T", "$Q_T$ face leak"), ("q_1", "Q₁ inner seal")):
            x, y = self._curve(k)
            y = y * Q
            line, = ax.plot(x * P, y, label=f"{lab}, exact")
            x, yc = self._curve(k, closed=True)
            ax.plot(x * P, yc * Q, ls="--", color=line.get_color())
            span = max(span, np.nanmax(np.abs(y[y > 0])) if (y > 0).any() else 0.0)
        ax.plot([], [], "k--", label=f"{self._CF} (dashed)")
        self._operating_point(ax, ex.q_T * Q)
        ax.axhline(0, color="k", lw=0.5)
        neg = min(np.nanmin(np.asarray(getattr(sw, k), float)) for k in ("q_e", "q_T", "q_1")) * Q
        if neg < -0.3 * span:  # reversed flows: the axis kept to the normal range, the reversal marked
            ax.set_ylim(-0.3 * span, 1.15 * span)
            ax.axhspan(-0.3 * span, 0, color="C3", alpha=0.06, zorder=0)
            ax.text(0.01, 0.1, f"below 0: reversed flow (axis cut; down to {neg:.3g} {self._base('Q')[1]} = "
                    f"{neg / Q:.3g} $Q_B$)", transform=ax.transAxes, fontsize=7, color="C3")
        self._decorate(ax, "Q", "flow Q")
        _legend(fig, ax)
        figs["fig_flows.png"] = Figure(
            fig, "Flows (Q/Q_B on the right) against the discharge pressure, reversed flows cut and "
            "annotated; Pavlenko (2014), Fig. 2.6 / 2.10")

        fg = self.force_gap
        fig, ax = new_figure((8, 4.6))
        Z, unit = self._base("z")
        u = np.asarray(fg.u, float)
        force = display_unit_of("N")
        F = convert(self.scales.p_B * self.scales.s_B, "N", force)
        ax.plot(u * Z, np.asarray(fg.phi_exact, float) * F, label="φ(u), exact network")
        if np.isfinite(np.asarray(fg.phi_closed_form, float)).any():  # the gas device has none
            ax.plot(u * Z, np.asarray(fg.phi_closed_form, float) * F, ls="--", label=f"{self._CF} Eq. (2.35)")
        ax.axhline(fg.tau * F, color="k", lw=0.8, ls=":", label="load τ − χ")
        if fg.psi1 == ex.psi1:
            ax.plot([ex.u0 * Z], [fg.tau * F], "k*", ms=9, zorder=5, label="operating point")
        ax.set_xlabel(f"face gap z, {unit}  (u = z/$z_B$, $z_B$ = {Z:.3g} {unit})")
        ax.set_ylabel(f"balancing force F, {force}\nφ = F/($p_B s_B$), $p_B s_B$ = {F:.3g} {force}")
        record_axis(ax, "x", "m", unit)
        record_axis(ax, "y", "N", force)
        ax.grid(alpha=0.3)
        _legend(fig, ax)
        figs["fig_force_gap.png"] = Figure(
            fig, "Balancing force φ(u) against the face gap at the operating ψ1 and the load τ − χ; "
            "Pavlenko (2014), Eq. (2.35)")
        for f in figs.values():
            f.suptitle(self.title, fontsize=9)
            fixed_layout(f, **self._MARGINS)
        return figs


StaticsResult.quantities = QUANTITIES = declarations(
    StaticsResult,
    Quantity("groups.*", "1", "", "the source's dimensionless groups", source=f"{_P14}, Eq. (2.18)"),
    Quantity("conductances.*", "m^3/(Pa*s)", "g", "hydraulic conductances"),
    Quantity("sweep.closed_form.* sweep_refined.closed_form.*", "1", "", "the ratios of the sweep over ψ1"),
)


def verdict(psi1: float, z0: float, Q_1: float, contact: bool, saturated: bool | None, dp: float | None = None,
            dp_kr: float | None = None, psi1_kr: float | None = None) -> tuple[bool, str]:
    """The verdict on an operating point (of :class:`StaticsResult`, and of the live explorer): regulating (or,
    without a regulator, ``saturated`` None, the barrier margin held by its supply), no face contact, inner-seal
    flow ``Q_1`` (m^3/s) towards the disc; the operating barrier margin ``dp`` against the critical ``dp_kr`` (Pa),
    and how far the discharge ratio ``psi1`` is from the one that reverses the inner-seal flow, ``psi1_kr``."""
    problems = [w for w, bad in (("regulator SATURATED", saturated), ("face CONTACT", contact),
                                 ("inner-seal flow REVERSED", not Q_1 > 0)) if bad]
    held = "regulating" if saturated is not None else "no regulator (the barrier supply holds p_e − p1)"
    words = "operating point: " + (", ".join(problems) if problems else
                                   f"{held}, face gap {QUANTITIES.find('exact.z0').text(z0)}, "
                                   "inner-seal flow towards the disc")
    if dp is not None and dp_kr is not None:
        bar = QUANTITIES.find("exact.dp")
        words += f"; operating barrier margin {bar.text(dp)} against the critical {bar.text(dp_kr)}"
    if psi1_kr is not None and psi1:
        words += f"; the inner-seal flow reverses at {psi1_kr / psi1:.3g} × the operating discharge pressure"
    return not problems, words


def _first(psi1, flags) -> float | None:
    """The first ψ1 of the sweep whose flag is set, or None."""
    flags = list(flags)
    return float(psi1[flags.index(True)]) if True in flags else None


def _legend(fig, *axes) -> None:
    """One compact legend below the axes of ``fig``, each label once."""
    seen = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(lab, h)
    fig.legend(list(seen.values()), list(seen), loc="outside lower center", ncols=2, fontsize=7)


def _state(solver: StaticsSolver, pt: StaticPoint, q_base: float, newton_max_difference: float = math.nan) -> Exact:
    """Unknowns, SI values and flows of one solved point (flows relative to q_base too); ``newton_max_difference``
    that of its Newton polish (computed at the operating point only)."""
    sc = solver.design.scales
    v, q = pt.values, pt.flows
    kappa = solver.stiffness(pt)
    regulator = {}
    if solver.design.groups.regulator is not None:  # a device without a regulator has no regulator states
        regulator = {"xi0": v["xi"], "psi_cam0": v["psi_cam"], "x0": v["xi"] * sc["x_B"],
                     "pcam": v["psi_cam"] * sc["p_B"], "regulator_saturated": pt.saturated,
                     "r_valve": v.get("r_valve", 0.0)}
    return Exact(
        psi1=pt.psi1, u0=v["u"], psi2_0=v["psi2"], psi3_0=v["psi3"], psi_e0=v["psi_e"], z0=v["u"] * sc["z_B"],
        p1=pt.psi1 * sc["p_B"], p2=v["psi2"] * sc["p_B"], p3=v["psi3"] * sc["p_B"], pe=v["psi_e"] * sc["p_B"],
        dp=(v["psi_e"] - pt.psi1) * sc["p_B"],
        Q_e=q["e"] * sc["Q_scale"], Q_1=q["1"] * sc["Q_scale"], Q_T=q["T"] * sc["Q_scale"], Q_3=q["3"] * sc["Q_scale"],
        q_e=q["e"] / q_base, q_T=q["T"] / q_base, q_1=q["1"] / q_base,
        kappa_s=kappa, c_s=kappa * sc["p_B"] * sc["s_B"] / sc["z_B"],  # F = phi p_B s_B, z = u z_B
        contact=pt.contact, r_contact=v["r_contact"],
        solver=Solver(status=pt.status, iterations=pt.iterations, max_relative_residual=pt.max_residual),
        **regulator, newton_max_difference=newton_max_difference)


def sweep_keys(g) -> tuple[str, ...]:
    """The unknowns the sweep reports for the device of groups ``g``: a device without a regulator has no
    regulator states."""
    return SWEEP_KEYS if g.regulator is not None else tuple(k for k in SWEEP_KEYS if k not in REGULATOR_KEYS)


def cf_xi(g, psi1s, dpsi):
    """The exact ideal-regulator valve opening along psi1s (NaN where no opening passes the flow)."""
    return closed_form.regulator(g, psi1s, dpsi, psi2=closed_form.exact_ideal(g, psi1s, dpsi)["psi2"])[1]


def _criticals(solver: StaticsSolver, psi1: float, dpsi: float, psi1_guess: float, dpsi_guess: float,
               psi1_max: float) -> Critical:
    """Exact psi1_kr and dpsi_kr (q1 = 0); where none exists (a stop reached, flow never reverses)
    the value is null with the solver status that says so."""
    sc = solver.design.scales
    out, statuses = {}, {}
    # the closed forms start the search; where they have no value (NaN, < 0) start at the operating point
    psi1_guess = min(psi1_guess, psi1_max) if psi1_guess > 0 else psi1
    dpsi_guess = dpsi_guess if dpsi_guess > 0 else dpsi
    try:
        pt = solver.critical("psi1", dpsi, psi1_guess)
        out |= {"psi1_kr": pt.psi1, "p1_kr": pt.psi1 * sc["p_B"]}
        if solver.design.groups.regulator is not None:
            out["psi1_kr_regulator_saturated"] = pt.saturated
    except SolveError as exc:
        out["psi1_kr"], statuses["psi1_kr"] = None, f"no discharge ratio with q1 = 0 found: {exc.status}"
    try:
        pt = solver.critical("dpsi", psi1, dpsi_guess)
        out |= {"dpsi_kr": pt.dpsi, "dp_kr": pt.dpsi * sc["p_B"]}
    except SolveError as exc:
        out["dpsi_kr"], statuses["dpsi_kr"] = None, f"no margin with q1 = 0 at psi1 = {psi1:g}: {exc.status}"
    return Critical(**out, statuses=statuses)


def continuation(solver: StaticsSolver, psi1s, dpsi: float,
                 span: tuple[float, float] | None = None) -> list[StaticPoint]:
    """Statics over the discharge ratios ``psi1s`` by a continuation that does not depend on their spacing.

    A grid of at most ``continuation.path_nodes`` points (a solver option) is solved as one continuation path,
    each point warm-started from the one before.  A denser grid is not: a path of that many evenly
    spaced nodes across ``span`` is solved first, and each requested point is warm-started from its
    nearest node, so a 100,000-point sweep takes the same continuation steps as a 1,000-point one
    (thousands of tiny warm-started steps drift into a point IPOPT cannot leave, e.g. the compressor
    at psi1 = 1.26162 where its regulator saturates).  A step that fails is halved (at most
    ``continuation.max_halvings`` times) before the sweep gives up.

    Parameters
    ----------
    solver : StaticsSolver
        The device's solver.
    psi1s : array_like
        Increasing discharge pressure ratios psi1 = p1/p_B, dimensionless.
    dpsi : float
        Margin ratio dpsi = (p_e - p1)/p_B, dimensionless.
    span : (float, float), optional
        The range the continuation path spans; default the ends of ``psi1s``.  A part of a dense grid
        solved with the whole grid's span gives exactly the whole grid's values at those points.

    Returns
    -------
    list of StaticPoint
        One per requested point.

    Raises
    ------
    SolveError
        A point that no halving of its continuation step reaches.
    """
    psi1s = np.asarray(psi1s, float)
    n_nodes = solver_options.defaults["continuation.path_nodes"]
    if span is None and len(psi1s) <= n_nodes:
        return _path(solver, psi1s, dpsi)
    lo, hi = span if span is not None else (psi1s[0], psi1s[-1])
    nodes = _path(solver, np.linspace(lo, hi, n_nodes), dpsi)
    at = np.array([p.psi1 for p in nodes])
    out = []
    for s in psi1s:
        near = nodes[int(np.argmin(np.abs(at - s)))]
        out.append(near if near.psi1 == s else _step(solver, near, float(s), dpsi))
    return out


def refine(solver: StaticsSolver, points: list[StaticPoint], dpsi: float) -> list[StaticPoint]:
    """Extra points inside each sweep interval whose ends have different stops reached (the regulator
    saturates, the face closes): the kinks of the solution, drawn as chords on the sweep grid alone.

    Parameters
    ----------
    solver : StaticsSolver
        The device's solver.
    points : list of StaticPoint
        The sweep, increasing psi1.
    dpsi : float
        Margin ratio dpsi = (p_e - p1)/p_B, dimensionless.

    Returns
    -------
    list of StaticPoint
        :data:`REFINE_POINTS` points inside each such interval, by continuation from its left end
        (empty where no stop changes; a point no continuation reaches is left out).
    """
    out = []
    for a, b in zip(points[:-1], points[1:], strict=True):
        if a.active == b.active:
            continue
        prev = a
        for s in np.linspace(a.psi1, b.psi1, REFINE_POINTS + 2)[1:-1]:
            try:
                prev = _step(solver, prev, float(s), dpsi)
            except SolveError:
                continue
            out.append(prev)
    return out


def _path(solver: StaticsSolver, psi1s: np.ndarray, dpsi: float) -> list[StaticPoint]:
    """A continuation path: the first point cold, each next one from the one before."""
    points = [solver.solve(float(psi1s[0]), dpsi)]
    for s in psi1s[1:]:
        points.append(_step(solver, points[-1], float(s), dpsi))
    return points


def _step(solver: StaticsSolver, start: StaticPoint, psi1: float, dpsi: float, halvings: int = 0) -> StaticPoint:
    """One continuation step from ``start`` to ``psi1``, halved while it fails."""
    try:
        return solver.solve(psi1, dpsi, start)
    except SolveError:
        if halvings >= solver_options.defaults["continuation.max_halvings"]:
            raise
    mid = _step(solver, start, 0.5 * (start.psi1 + psi1), dpsi, halvings + 1)
    return _step(solver, mid, psi1, dpsi, halvings + 1)


def run(solver: StaticsSolver, spec: Spec, title: str = "") -> StaticsResult:
    """Operating point, criticals, continuation sweep and force-gap curve of one device."""
    dev = solver.design
    g, sc = dev.groups, dev.scales
    dpsi = dev.dpsi
    psi1 = spec.operating_ratio
    cf = closed_form.for_medium(g, psi1, dpsi)
    q_base = float(cf["Q_B_over_g1pB"])

    op = solver.solve(psi1, dpsi)
    newton = solver.newton(psi1, dpsi, op.x, op.active)
    exact = _state(solver, op, q_base, float(np.abs(newton - op.x).max()))

    regulator = {"xi0": cf["xi"], "psi_cam0": cf["psi_cam"]} if g.regulator is not None else {}
    quad = {}
    if g.medium == "liquid":
        q2 = closed_form.pump_quadratic(g, psi1, dpsi)
        quad = {"psi2_0_quadratic": q2["psi2"], "psi3_0_quadratic": q2["psi3"], "u0_quadratic": q2["u"]}
    closed = ClosedForm(**{k: float(v) for k, v in dict(  # numbers, not numpy's 0-d arrays
        dpsi_kr=cf["dpsi_kr"], psi1_kr=cf["psi1_kr"], u0=cf["u"], psi2_0=cf["psi2"], psi3_0=cf["psi3"],
        psi_e0=cf["psi_e"], Q_e=cf["Q_e_over_g1pB"] * sc["Q_scale"], Q_B=q_base * sc["Q_scale"], q_T=cf["q_T"],
        q_1=cf["q_1"], kappa_s=cf["kappa_s"], **regulator, kappa_u_2_162=cf.get("kappa_u_2_162"),
        Q_e_over_Q_n=cf["Q_e_over_g1pB"] * sc["Q_scale"] / sc["Q_n"], **quad).items() if v is not None})

    critical = _criticals(solver, psi1, dpsi, float(cf["psi1_kr"]), float(cf["dpsi_kr"]), spec.stop)

    grid = np.linspace(spec.start, spec.stop, spec.points)
    try:
        points = continuation(solver, grid, dpsi)
    except SolveError as exc:
        reg = g.regulator
        xi = cf_xi(g, grid, dpsi) if reg is not None else np.zeros(1)
        if reg is not None and not np.isfinite(reg.xi_max) and not np.all(np.isfinite(xi)):
            first = grid[np.argmax(~np.isfinite(xi))]
            raise SolveError(f"{exc.message}; from psi1 ~ {first:.3g} the regulator valve cannot pass the barrier "
                             "flow at any opening and the valve has no travel limit (set regulator.valve.max_opening)",
                             exc.status, exc.last_iterate) from None
        raise
    states = [_state(solver, p, q_base) for p in points]
    keys = sweep_keys(g)

    def closed_forms(psi1s) -> dict:  # the closed forms along the ratios psi1s (none at no point)
        c = closed_form.for_medium(g, psi1s, dpsi) if len(psi1s) else {}
        return {k: np.broadcast_to(np.asarray(c.get(k, np.nan), float), psi1s.shape) for k in (*keys, "q_e", "q_T",
                                                                                            "q_1")}

    def column(k) -> np.ndarray:
        return np.array([getattr(s, k) for s in states])

    sweep = Sweep(psi1=grid, **{k: np.array([p.values[k] for p in points]) for k in keys},
                  **{k: column(k) for k in ("q_e", "q_T", "q_1", "Q_e", "Q_1", "Q_T", "kappa_s")},
                  contact=[bool(s.contact) for s in states],
                  regulator_saturated=([bool(s.regulator_saturated) for s in states] if g.regulator is not None
                                       else None),
                  status=[p.status for p in points], max_relative_residual=max(p.max_residual for p in points),
                  closed_form=closed_forms(grid))
    extra = refine(solver, points, dpsi)
    fine = np.array([p.psi1 for p in extra])
    refined = Refined(
        psi1=fine, **{k: np.array([p.values[k] for p in extra], dtype=float) for k in keys},
        **{f"q_{k}": np.array([p.flows[k] / q_base for p in extra], dtype=float) for k in ("e", "T", "1")},
        regulator_saturated=(np.array([p.saturated for p in extra], dtype=float) if g.regulator is not None
                             else None),
        closed_form=closed_forms(fine))

    us = np.linspace(0.3, 2.0, spec.force_gap_points)
    force_gap = ForceGap(psi1=psi1, u=us, phi_exact=solver.force_gap(psi1, dpsi, us),
                         phi_closed_form=(closed_form.force_gap(g, psi1, dpsi, us) if g.medium == "liquid"
                                          else np.full(us.shape, np.nan)),
                         tau=g.b * psi1 - g.chi)

    residual = max(exact.solver.max_relative_residual, sweep.max_relative_residual)
    how = ("balance residuals relative to their largest term (operating point and sweep); IPOPT vs CasADi Newton "
           "on the same equations at the operating point")
    if not op.active and g.regulator is not None:
        ref = workprecision.statics_reference(g, psi1, dpsi)
        got = np.array([op.values[k] for k in workprecision.STATICS_OUTPUTS])
        estimate = float(np.max(np.abs(got - ref) / np.abs(ref)))
        how += "; estimate = max relative error of the operating point against the 40-digit exact root"
    else:
        estimate = residual
        how += "; estimate = the residual (a stop is reached or there is no regulator)"
    res = StaticsResult(
        accuracy=Accuracy(max_relative_residual=residual, newton_max_difference=exact.newton_max_difference,
                          how=how, estimate=estimate),
        title=title, medium=g.medium, dpsi=dpsi,
        groups=groups_by_name(g) | ({"xi_max": g.regulator.xi_max} if g.regulator else {}),
        scales=Scales(**(sc if g.regulator is not None else {k: v for k, v in sc.items() if k != "x_B"})),
        conductances=dev.conductances, derived=Derived(**dev.extra),
        closed_form=closed, exact=exact, critical_exact=critical,
        sweep=sweep, sweep_refined=refined, force_gap=force_gap)
    return explained(res, _null_reasons(g), "the closed form has no physical value here")


def _null_reasons(g) -> dict:
    """Why a value of the statics block is NaN (null in results.json), by key."""
    no_reg = "the device has no regulator" if g.regulator is None else None
    gas = g.medium == "gas"
    return {
        "xi": no_reg or "no valve opening of the ideal regulator (2.28) passes the barrier flow: the valve saturates",
        "xi0": no_reg or "no valve opening of the ideal regulator (2.28) passes the barrier flow: the valve saturates",
        "psi_cam": no_reg, "psi_cam0": no_reg, "x0": no_reg, "pcam": no_reg,
        "kappa_s": ("no fixed-pressure closed form of the stiffness for the gas device (see kappa_u_2_162)" if gas
                    else "the face is in contact (u = 0): the gap does not move with the force"),
        "c_s": "the face is in contact (u = 0): the gap does not move with the force",
        "phi_closed_form": "the closed form (2.35) is the liquid device's" if gas else None,
    }
