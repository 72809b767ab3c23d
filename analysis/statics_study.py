"""The static calculation of a scene: exact IPOPT solution beside the source's closed forms.

``run(design, settings)`` returns a :class:`StaticsResult`, plain data that writes itself as
the ``statics`` block of results.json, CSV tables and the figures equivalent to the source's
Figs 2.4-2.6 (pump) and 2.9-2.10 (compressor), plus the force-gap characteristic (2.35).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autobal.analysis import closed_form, solver_options, workprecision
from autobal.analysis.quantities import Declarations, Quantity, convert, display_unit_of
from autobal.analysis.result import Result, fixed_layout, fmt, new_figure, with_statuses
from autobal.analysis.statics import StaticPoint, StaticsSolver
from autobal.errors import SolveError
from autobal.models.device import groups_by_name

SWEEP_KEYS = ("psi_e", "psi2", "psi3", "psi_cam", "u", "xi")
REGULATOR_KEYS = ("psi_cam", "xi")  # the sweep's regulator states: none without a regulator
REFINE_POINTS = 12  # extra points inside each sweep interval where a stop is reached or left (figures)

_P14 = "Pavlenko (2014)"
_SWEEPS = "sweep sweep_refined"


def _both(*keys: str) -> str:
    """The keys in the sweep and its refined points."""
    return " ".join(f"{s}.{k}" for s in _SWEEPS.split() for k in keys)


#: every number of the statics block (Pavlenko 2014, ch. 2: groups (2.18); psi = p/p_B, u = z/z_B, xi = x/x_B,
#: q = Q/Q_B); the headline quantities first, in the order the summary prints them
QUANTITIES = Declarations(
    Quantity("exact.z0", "m", "z0", "face gap at the operating point", "µm", headline=True),
    Quantity("exact.x0", "m", "x0", "valve opening at the operating point", "mm", headline=True),
    Quantity("exact.p1", "Pa", "p1", "discharge pressure", headline=True),
    Quantity("exact.p2", "Pa", "p2", "disc-chamber pressure", headline=True),
    Quantity("exact.p3", "Pa", "p3", "pressure in the cavity behind the disc", headline=True),
    Quantity("exact.pe", "Pa", "p_e", "barrier-chamber pressure", headline=True),
    Quantity("exact.pcam", "Pa", "p_cam", "valve-chamber pressure", headline=True),
    Quantity("exact.Q_e", "m^3/s", "Q_e", "barrier flow (the leak of the device)", headline=True),
    Quantity("exact.Q_T", "m^3/s", "Q_T", "face-throttle leak", headline=True),
    Quantity("exact.Q_1", "m^3/s", "Q_1", "inner-seal flow (positive towards the disc)", headline=True),
    Quantity("exact.Q_3", "m^3/s", "Q_3", "flow through the cavity throttle"),
    Quantity("critical_exact.p1_kr", "Pa", "p1_kr", "discharge pressure at which the inner-seal flow reverses",
             headline=True),
    Quantity("exact.dp", "Pa", "Δp", "operating barrier margin p_e − p1", "bar", headline=True),
    Quantity("critical_exact.dp_kr", "Pa", "Δp_kr", "critical barrier margin p_e − p1 (inner-seal flow reverses)",
             "bar", headline=True),
    Quantity("critical_exact.psi1_kr closed_form.psi1_kr", "1", "ψ1_kr", "critical discharge ratio",
             source=f"{_P14}, Eq. (2.32)"),
    Quantity("critical_exact.dpsi_kr closed_form.dpsi_kr", "1", "δψ_kr", "critical barrier margin (p_e − p1)/p_B",
             source=f"{_P14}, Eq. (2.31)"),
    Quantity("exact.psi1 force_gap.psi1", "1", "ψ1", "discharge pressure ratio p1/p_B"),
    Quantity("dpsi", "1", "δψ", "barrier margin (p_e − p1)/p_B of the scene", source=f"{_P14}, Eq. (2.18)"),
    Quantity("exact.u0 closed_form.u0 closed_form.u0_quadratic", "1", "u0", "face-gap ratio z0/z_B",
             source=f"{_P14}, Eq. (2.27)"),
    Quantity("exact.xi0 closed_form.xi0", "1", "ξ0", "valve-opening ratio x0/x_B", source=f"{_P14}, Eq. (2.28)"),
    Quantity("exact.psi2_0 closed_form.psi2_0 closed_form.psi2_0_quadratic", "1", "ψ20", "disc-chamber ratio p2/p_B",
             source=f"{_P14}, Eq. (2.24)"),
    Quantity("exact.psi3_0 closed_form.psi3_0 closed_form.psi3_0_quadratic", "1", "ψ30", "cavity ratio p3/p_B",
             source=f"{_P14}, Eq. (2.25)"),
    Quantity("exact.psi_e0 closed_form.psi_e0", "1", "ψ_e0", "barrier-chamber ratio p_e/p_B"),
    Quantity("exact.psi_cam0 closed_form.psi_cam0", "1", "ψ_cam0", "valve-chamber ratio p_cam/p_B",
             source=f"{_P14}, Eq. (2.26)"),
    Quantity("exact.kappa_s closed_form.kappa_s", "1", "κ_s", "axial stiffness of the balancing force (group)",
             source=f"{_P14}, Eq. (2.36)"),
    Quantity("exact.c_s", "N/m", "c_s", "axial stiffness of the balancing force −dF/dz at the operating point, "
             "κ_s p_B s_B / z_B", "N/µm", headline=True, source=f"{_P14}, Eq. (2.36)"),
    Quantity("closed_form.kappa_u_2_162", "1", "κ_u", "stiffness along the pressure sweep (gas device)",
             source=f"{_P14}, Eq. (2.162)"),
    Quantity("exact.q_e exact.q_T exact.q_1 closed_form.q_T closed_form.q_1", "1", "q", "flow ratio Q/Q_B",
             source=f"{_P14}, Eq. (2.30)"),
    Quantity("closed_form.Q_e", "m^3/s", "Q_e", "barrier flow, closed form"),
    Quantity("closed_form.Q_B", "m^3/s", "Q_B", "base flow of the flow ratios q", source=f"{_P14}, Eq. (2.29)"),
    Quantity("closed_form.Q_e_over_Q_n", "1", "Q_e/Q_n", "barrier flow over the nominal flow of the machine"),
    Quantity("exact.r_valve exact.r_contact", "1", "r", "complementarity residuals of the valve stop and the contact"),
    Quantity("exact.solver.iterations", "1", "", "IPOPT iterations"),
    Quantity("exact.solver.max_relative_residual exact.newton_max_difference sweep.max_relative_residual", "1", "",
             "largest relative residual of the static equations / difference from a Newton polish"),
    Quantity("groups.*", "1", "", "the source's dimensionless groups", source=f"{_P14}, Eq. (2.18)"),
    Quantity("derived.zeta_u3 derived.zeta_TB derived.b_from_impeller", "1", "ζ, b", "loss coefficients and the "
             "impeller group"),
    Quantity("scales.p_B", "Pa", "p_B", "base pressure of the ratios ψ"),
    Quantity("scales.z_B", "m", "z_B", "base gap of the ratio u", "µm"),
    Quantity("scales.x_B", "m", "x_B", "base opening of the ratio ξ"),
    Quantity("scales.s_B scales.s_e derived.f_TB derived.s_T derived.s_e", "m^2", "s", "areas"),
    Quantity("scales.g1 conductances.*", "m^3/(Pa*s)", "g", "hydraulic conductances"),
    Quantity("scales.Q_scale", "m^3/s", "g1 p_B", "flow scale"),
    Quantity("scales.Q_n", "m^3/s", "Q_n", "nominal flow of the machine", "m³/h"),
    Quantity(_both("psi1", "psi_e", "psi2", "psi3", "psi_cam", "u", "xi", "q_e", "q_T", "q_1", "kappa_s",
                   "regulator_saturated", "closed_form.*"), "1", "", "the ratios of the sweep over ψ1"),
    Quantity(_both("Q_e", "Q_1", "Q_T"), "m^3/s", "Q", "flows over the sweep"),
    Quantity("force_gap.u force_gap.phi_exact force_gap.phi_closed_form force_gap.tau", "1", "u, φ, τ",
             "balancing force against the gap at the operating pressure", source=f"{_P14}, Eq. (2.35)"),
)


@dataclass
class StaticsResult(Result):
    """The static calculation of one device: operating point, criticals, sweep, force-gap curve.

    ``data`` is the results.json block; the headline numbers are the properties below.
    """

    data: dict  # the results.json block; numbers in SI or as named dimensionless groups
    name = "statics"
    quantities = QUANTITIES

    @property
    def face_gap(self) -> float:
        """Face gap z0 at the operating point, m."""
        return self.data["exact"]["z0"]

    @property
    def barrier_flow(self) -> float:
        """Barrier (leak) flow Q_e at the operating point, m^3/s."""
        return self.data["exact"]["Q_e"]

    @property
    def chamber_pressures(self) -> dict[str, float]:
        """Pressures at the operating point, Pa: p1 (discharge), p2 (disc chamber), p3, pe (barrier)."""
        ex = self.data["exact"]
        return {k: ex[k] for k in ("p1", "p2", "p3", "pe")}

    @property
    def critical_discharge_pressure(self) -> float | None:
        """Exact discharge pressure p1_kr at which the inner-seal flow reverses, Pa (None if none)."""
        return self.data["critical_exact"].get("p1_kr")

    @property
    def critical_margin(self) -> float | None:
        """Exact critical barrier margin dpsi_kr = (p_e - p1)/p_B, dimensionless (None if none)."""
        return self.data["critical_exact"]["dpsi_kr"]

    def to_dict(self) -> dict:
        return self.data

    @property
    def has_regulator(self) -> bool:
        """Whether the device has a regulator (without one it has no regulator states: no valve, no p_cam)."""
        return "regulator_saturated" in self.data["exact"]

    def verdict(self) -> tuple[bool, str]:
        """At the operating point: regulating (or, without a regulator, the barrier margin held by its supply), no
        face contact, inner-seal flow towards the disc; the operating barrier margin against the critical one, and
        how far the discharge pressure is from the one that reverses the inner-seal flow."""
        ex, crit = self.data["exact"], self.data.get("critical_exact") or {}
        kr = crit.get("psi1_kr")
        problems = [w for w, bad in (("regulator SATURATED", ex.get("regulator_saturated")),
                                     ("face CONTACT", ex["contact"]),
                                     ("inner-seal flow REVERSED", not ex["Q_1"] > 0)) if bad]
        held = "regulating" if self.has_regulator else "no regulator (the barrier supply holds p_e − p1)"
        words = "operating point: " + (", ".join(problems) if problems else
                                       f"{held}, face gap {QUANTITIES.find('exact.z0').text(ex['z0'])}, "
                                       "inner-seal flow towards the disc")
        dp, dp_kr = ex.get("dp"), crit.get("dp_kr")
        if dp is not None and dp_kr is not None:
            bar = QUANTITIES.find("exact.dp")
            words += f"; operating barrier margin {bar.text(dp)} against the critical {bar.text(dp_kr)}"
        if kr is not None and ex["psi1"]:
            words += f"; the inner-seal flow reverses at {kr / ex['psi1']:.3g} × the operating discharge pressure"
        return not problems, words

    def closed_form_note(self) -> str:
        """The assumption of the source's closed forms and whether this device meets it at the operating point."""
        ex = self.data["exact"]
        margin = QUANTITIES.find("exact.dp").text(self.data["dpsi"] * self.data["scales"]["p_B"])
        note = f"they assume an ideal regulator (p_e − p1 held at δψ p_B = {margin})"
        if not self.has_regulator:
            return note + ", as the barrier supply of this device (no regulator) does"
        if ex["regulator_saturated"]:
            return note + "; NOT valid here: the regulator is saturated at the operating point"
        return note

    def summary(self) -> str:
        ex, cf = self.data["exact"], self.data["closed_form"]
        crit = self.data["critical_exact"]
        ok, words = self.verdict()
        lines = [f"statics at p1 = {QUANTITIES.find('exact.p1').text(ex['p1'])} (psi1 = {ex['psi1']:g}): IPOPT "
                 f"{ex['solver']['status']}, max relative residual {ex['solver']['max_relative_residual']:.1e}",
                 f"  {'ok' if ok else 'NOT OK'}: {words}",
                 *QUANTITIES.lines(self.data),
                 "  the source's dimensionless groups, exact and by its closed forms (Pavlenko 2014, "
                 "Eqs. (2.24)-(2.36));",
                 f"  {self.closed_form_note()}",
                 f"  {'':10s}{'exact':>12s}{'closed form':>14s}"]
        for k in ("u0", "xi0", "psi2_0", "psi3_0", "psi_e0", "psi_cam0", "kappa_s"):
            if k in ex:
                lines.append(f"  {k:10s}{fmt(ex.get(k)):>12s}{fmt(cf.get(k)):>14s}")
        kr = f"  {'psi1_kr':10s}{fmt(crit['psi1_kr']):>12s}{fmt(cf['psi1_kr']):>14s}"
        if crit.get("psi1_kr_regulator_saturated"):
            kr += "  (exact: with the regulator saturated, where the ideal regulator does not hold)"
        lines.append(kr)
        lines.append(f"  {'dpsi_kr':10s}{fmt(crit['dpsi_kr']):>12s}{fmt(cf['dpsi_kr']):>14s}")
        q_e = QUANTITIES.find("exact.Q_e")
        lines.append(f"  {'Q_e':10s}{q_e.text(ex['Q_e']):>12s}{q_e.text(cf['Q_e']):>14s}")
        sat = self.data["sweep"].get("regulator_saturated", [])
        if any(sat):
            first = self.data["sweep"]["psi1"][int(np.argmax(sat))]
            lines.append(f"  regulator saturated (valve on its open stop) from psi1 = {first:.4g}")
        if ex.get("regulator_saturated"):
            lines.append("  the operating point itself has the regulator saturated")
        return "\n".join(lines)

    #: sweep column -> (its base in data["scales"], the operating-point quantity whose display unit it takes)
    _DIMENSIONAL = {"psi1": ("p_B", "exact.p1", "p1"), "psi_e": ("p_B", "exact.pe", "pe"),
                    "psi2": ("p_B", "exact.p2", "p2"), "psi3": ("p_B", "exact.p3", "p3"),
                    "psi_cam": ("p_B", "exact.pcam", "pcam"), "u": ("z_B", "exact.z0", "z"),
                    "xi": ("x_B", "exact.x0", "x")}

    def tables(self) -> dict[str, dict]:
        """statics_sweep.csv: every pressure, gap and flow in its display unit (MPa, µm, mm, L/s unless
        the scene or the CLI chooses others; the header names it) beside the source's dimensionless group;
        force_gap.csv in the groups of (2.35)."""
        sw, fg, sc = self.data["sweep"], self.data["force_gap"], self.data["scales"]
        cols = {}
        for k in ("psi1", *(k for k in SWEEP_KEYS if k in sw)):
            base, key, name = self._DIMENSIONAL[k]
            q = QUANTITIES.find(key)
            cols[f"{name} [{q.display}]"] = [None if v is None else q.shown(v * sc[base]) for v in sw[k]]
            cols[f"{k} [1]"] = sw[k]
        for k in ("Q_e", "Q_1", "Q_T"):
            q = QUANTITIES.find(f"exact.{k}")
            cols[f"{k} [{q.display}]"] = [None if v is None else q.shown(v) for v in sw[k]]
        cols |= {f"{k} [1]": sw[k] for k in ("q_e", "q_T", "q_1", "kappa_s")}
        cols |= {k: sw[k] for k in ("regulator_saturated", "contact") if k in sw}
        cols |= {f"closed_form_{k} [1]": v for k, v in sw["closed_form"].items() if not k.endswith("_status")}
        return {"statics_sweep.csv": cols,
                "force_gap.csv": {"u [1]": fg["u"], "phi_exact [1]": fg["phi_exact"],
                                  "phi_closed_form [1]": fg["phi_closed_form"]}}

    # dimensional axes: (key of the base in data["scales"] or "Q_B", the quantity whose shown unit the axis takes)
    _BASES = {"p": ("p_B", "exact.p1"), "z": ("z_B", "exact.z0"), "x": ("x_B", "exact.x0"), "Q": ("Q_B", "exact.Q_T")}
    _CF = "closed form (ideal regulator), Pavlenko (2014)"
    # inches: tick labels and the two-line label on the left, the suptitle on top, tick labels and label below
    _MARGINS = {"left": 0.95, "right": 0.25, "top": 0.4, "bottom": 0.55, "hspace": 0.08}

    def _base(self, kind: str) -> tuple[float, str]:
        """The factor from a dimensionless group to the shown unit, and the unit (p_B, z_B, x_B, Q_B): the
        display unit of the operating point's pressure, gap, opening and leak (MPa, µm, mm, L/s unless chosen)."""
        key, quantity = self._BASES[kind]
        base = self.data["closed_form"]["Q_B"] if key == "Q_B" else self.data["scales"][key]
        q = QUANTITIES.find(quantity)
        return q.shown(base), q.display

    def _curve(self, key: str, closed: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """psi1 and ``key`` over the sweep with the refined points near the kinks merged in, sorted."""
        sw, rf = self.data["sweep"], self.data.get("sweep_refined") or {}
        parts = [(sw["psi1"], (sw["closed_form"] if closed else sw)[key])]
        if len(rf.get("psi1", [])):
            parts.append((rf["psi1"], (rf["closed_form"] if closed else rf)[key]))
        psi = np.concatenate([np.asarray(a, float) for a, _ in parts])
        y = np.concatenate([np.asarray(b, float) for _, b in parts])
        order = np.argsort(psi, kind="stable")
        return psi[order], y[order]

    def _operating_x(self) -> float:
        return self.data["exact"]["psi1"] * self._base("p")[0]

    def _decorate(self, ax, kind: str, ylabel: str, xlabel: bool = True) -> None:
        """Dimensional axes, p1 and y in the display units of ``kind`` (:meth:`_base`), their labels naming the
        source's groups and bases (psi1 = p1/p_B, u = z/z_B ...); the saturated range shaded and labelled, the critical
        discharge pressures marked."""
        sw = self.data["sweep"]
        P, p_unit = self._base("p")
        p1 = np.asarray(sw["psi1"], float) * P
        x, sat = self._curve("regulator_saturated") if self.has_regulator else (p1, np.zeros(p1.shape))
        sat = sat > 0.5
        kr = self.data["critical_exact"]["psi1_kr"]
        kr_cf = self.data["closed_form"]["psi1_kr"]
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
                       label=rf"$p_1^{{kr}}$, {self._CF} Eq. ({'2.160' if self.data['medium'] == 'gas' else '2.32'})")
        ax.set_xlim(p1.min(), p1.max())
        if xlabel:  # the groups in the labels: a secondary axis costs about a tenth of a draw
            ax.set_xlabel(rf"discharge pressure p₁, {p_unit}  (ψ₁ = p₁/$p_B$, $p_B$ = {P:.3g} {p_unit})")
        if kind in self._BASES:
            F, unit = self._base(kind)
            group = {"p": "ψ = p/$p_B$", "z": "u = z/$z_B$", "x": "ξ = x/$x_B$", "Q": "Q/$Q_B$"}[kind]
            base = "" if kind == "p" else f", ${self._BASES[kind][0]}$ = {F:.3g} {unit}"
            ax.set_ylabel(f"{ylabel}, {unit}\n{group}{base}")
        else:
            ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)

    def _operating_point(self, ax, y: float | None) -> None:
        if y is not None and np.isfinite(y):
            ax.plot([self._operating_x()], [y], "k*", ms=9, zorder=5, label="operating point")

    def draw(self, ax) -> None:
        """Chamber pressures against the discharge pressure (Fig 2.4 / 2.9) in the display unit (MPa unless
        chosen), the group psi named in the label."""
        ex = self.data["exact"]
        P, _ = self._base("p")
        for k, k0, lab in (("psi_e", "psi_e0", "pₑ barrier"), ("psi2", "psi2_0", "p₂ disc chamber"),
                           ("psi3", "psi3_0", "p₃"), ("psi_cam", "psi_cam0", r"$p_{cam}$ regulator")):
            if k not in self.data["sweep"]:
                continue  # no regulator: no valve chamber
            x, y = self._curve(k)
            line, = ax.plot(x * P, y * P, label=f"{lab}, exact")
            x, y = self._curve(k, closed=True)
            ax.plot(x * P, y * P, ls="--", color=line.get_color())
            if ex.get(k0) is not None:
                ax.plot([self._operating_x()], [ex[k0] * P], "k*", ms=8, zorder=5)
        ax.plot([], [], "k--", label=f"{self._CF} (dashed)")
        ax.plot([], [], "k*", ms=8, label="operating point")
        self._decorate(ax, "p", "pressure")

    def _valve_panel(self, ax) -> None:
        """The valve opening against the discharge pressure (Fig 2.5, lower panel), exact and (2.28)."""
        sw, ex = self.data["sweep"], self.data["exact"]
        P, _ = self._base("p")
        X, _ = self._base("x")
        x, xi = self._curve("xi")
        ax.plot(x * P, xi * X, color="C2", label="valve opening x, exact (dots: sweep grid)")
        ax.plot(np.asarray(sw["psi1"], float) * P, np.asarray(sw["xi"], float) * X, ".", ms=4, color="C2")
        xc, xi_cf = self._curve("xi", closed=True)
        stop = ""
        if np.isfinite(xi_cf).any() and not np.isfinite(xi_cf).all():
            last = xc[np.isfinite(xi_cf)].max()
            stop = f";\nends: no opening passes the flow beyond ψ₁ = {last:.4g}"
        ax.plot(xc * P, xi_cf * X, ls="--", color="C3", label=f"valve, {self._CF} Eq. (2.28){stop}")
        self._operating_point(ax, ex["xi0"] * X if ex.get("xi0") is not None else None)
        self._decorate(ax, "x", "valve opening x")

    def figures(self) -> dict:
        """Pressures (Fig 2.4/2.9), gap and valve (Fig 2.5), flows (Fig 2.6/2.10), phi(u) (2.35); dimensional
        axes in the display units (MPa, µm, mm, L/s, kN unless the scene or the CLI chooses others) whose labels
        name the source's groups and their bases."""
        sw, ex = self.data["sweep"], self.data["exact"]
        psi1 = np.asarray(sw["psi1"], float)
        P, _ = self._base("p")
        p1 = psi1 * P
        figs = {}

        fig, ax = new_figure((8, 4.6))
        self.draw(ax)
        _legend(fig, ax)
        figs["fig_pressures.png"] = fig

        if self.has_regulator:
            fig, (a1, a2) = new_figure((8, 6.4), 2, 1, sharex=True)
        else:  # no regulator: the face gap alone, no valve panel
            fig, a1 = new_figure((8, 4.6))
        Z, _ = self._base("z")
        x, y = self._curve("u")
        a1.plot(x * P, y * Z, label="face gap z, exact")
        a1.plot(p1, np.asarray(sw["u"], float) * Z, ".", ms=4, color="C0")
        x, y = self._curve("u", closed=True)
        a1.plot(x * P, y * Z, ls="--",
                label=f"face gap, {self._CF} Eq. ({'2.147' if self.data['medium'] == 'gas' else '2.27'})")
        self._operating_point(a1, ex["u0"] * Z)
        self._decorate(a1, "z", "face gap z", xlabel=not self.has_regulator)
        if self.has_regulator:
            self._valve_panel(a2)
        _legend(fig, *fig.axes)
        figs["fig_gap.png"] = fig

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
        self._operating_point(ax, ex["q_T"] * Q)
        ax.axhline(0, color="k", lw=0.5)
        neg = min(np.nanmin(np.asarray(sw[k], float)) for k in ("q_e", "q_T", "q_1")) * Q
        if neg < -0.3 * span:  # reversed flows: the axis kept to the normal range, the reversal marked
            ax.set_ylim(-0.3 * span, 1.15 * span)
            ax.axhspan(-0.3 * span, 0, color="C3", alpha=0.06, zorder=0)
            ax.text(0.01, 0.1, f"below 0: reversed flow (axis cut; down to {neg:.3g} {self._base('Q')[1]} = "
                    f"{neg / Q:.3g} $Q_B$)", transform=ax.transAxes, fontsize=7, color="C3")
        self._decorate(ax, "Q", "flow Q")
        _legend(fig, ax)
        figs["fig_flows.png"] = fig

        fg = self.data["force_gap"]
        fig, ax = new_figure((8, 4.6))
        Z, unit = self._base("z")
        u = np.asarray(fg["u"], float)
        force = display_unit_of("N")
        F = convert(self.data["scales"]["p_B"] * self.data["scales"]["s_B"], "N", force)
        ax.plot(u * Z, np.asarray(fg["phi_exact"], float) * F, label="φ(u), exact network")
        if any(v is not None for v in fg["phi_closed_form"]):
            ax.plot(u * Z, np.asarray(fg["phi_closed_form"], float) * F, ls="--", label=f"{self._CF} Eq. (2.35)")
        ax.axhline(fg["tau"] * F, color="k", lw=0.8, ls=":", label="load τ − χ")
        if fg["psi1"] == ex["psi1"]:
            ax.plot([ex["u0"] * Z], [fg["tau"] * F], "k*", ms=9, zorder=5, label="operating point")
        ax.set_xlabel(f"face gap z, {unit}  (u = z/$z_B$, $z_B$ = {Z:.3g} {unit})")
        ax.set_ylabel(f"balancing force F, {force}\nφ = F/($p_B s_B$), $p_B s_B$ = {F:.3g} {force}")
        ax.grid(alpha=0.3)
        _legend(fig, ax)
        figs["fig_force_gap.png"] = fig
        for f in figs.values():
            f.suptitle(self.data["title"], fontsize=9)
            fixed_layout(f, **self._MARGINS)
        return figs


def _legend(fig, *axes) -> None:
    """One compact legend below the axes of ``fig``, each label once."""
    seen = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(lab, h)
    fig.legend(list(seen.values()), list(seen), loc="outside lower center", ncols=2, fontsize=7)


def _state(solver: StaticsSolver, pt: StaticPoint, q_base: float) -> dict:
    """Unknowns, SI values and flows of one solved point (flows relative to q_base too)."""
    sc = solver.design.scales
    v, q = pt.values, pt.flows
    q_e = q["e"]
    out = {
        "psi1": pt.psi1, "u0": v["u"], "psi2_0": v["psi2"], "psi3_0": v["psi3"], "psi_e0": v["psi_e"],
        "z0": v["u"] * sc["z_B"],
        "p1": pt.psi1 * sc["p_B"], "p2": v["psi2"] * sc["p_B"], "p3": v["psi3"] * sc["p_B"],
        "pe": v["psi_e"] * sc["p_B"], "dp": (v["psi_e"] - pt.psi1) * sc["p_B"],
        **{f"Q_{k}": q[k] * sc["Q_scale"] for k in ("e", "1", "T", "3")},
        "q_e": q_e / q_base, "q_T": q["T"] / q_base, "q_1": q["1"] / q_base,
        "kappa_s": (kappa := solver.stiffness(pt)),
        "c_s": kappa * sc["p_B"] * sc["s_B"] / sc["z_B"],  # F = phi p_B s_B, z = u z_B
        "contact": pt.contact, "r_contact": v["r_contact"],
        "solver": {"status": pt.status, "iterations": pt.iterations, "max_relative_residual": pt.max_residual},
    }
    if solver.design.groups.regulator is not None:  # a device without a regulator has no regulator states
        out |= {"xi0": v["xi"], "psi_cam0": v["psi_cam"], "x0": v["xi"] * sc["x_B"],
                "pcam": v["psi_cam"] * sc["p_B"], "regulator_saturated": pt.saturated,
                "r_valve": v.get("r_valve", 0.0)}
    return out


def sweep_keys(g) -> tuple[str, ...]:
    """The unknowns the sweep reports for the device of groups ``g``: a device without a regulator has no
    regulator states."""
    return SWEEP_KEYS if g.regulator is not None else tuple(k for k in SWEEP_KEYS if k not in REGULATOR_KEYS)


def cf_xi(g, psi1s, dpsi):
    """The exact ideal-regulator valve opening along psi1s (NaN where no opening passes the flow)."""
    return closed_form.regulator(g, psi1s, dpsi, psi2=closed_form.exact_ideal(g, psi1s, dpsi)["psi2"])[1]


def _criticals(solver: StaticsSolver, psi1: float, dpsi: float, psi1_guess: float, dpsi_guess: float,
               psi1_max: float) -> dict:
    """Exact psi1_kr and dpsi_kr (q1 = 0); where none exists (a stop reached, flow never reverses)
    the value is null with the solver status that says so."""
    sc = solver.design.scales
    out = {}
    # the closed forms start the search; where they have no value (NaN, < 0) start at the operating point
    psi1_guess = min(psi1_guess, psi1_max) if psi1_guess > 0 else psi1
    dpsi_guess = dpsi_guess if dpsi_guess > 0 else dpsi
    try:
        pt = solver.critical("psi1", dpsi, psi1_guess)
        out |= {"psi1_kr": pt.psi1, "p1_kr": pt.psi1 * sc["p_B"]}
        if solver.design.groups.regulator is not None:
            out["psi1_kr_regulator_saturated"] = pt.saturated
    except SolveError as exc:
        out |= {"psi1_kr": None, "psi1_kr_status": f"no discharge ratio with q1 = 0 found: {exc.status}"}
    try:
        pt = solver.critical("dpsi", psi1, dpsi_guess)
        out |= {"dpsi_kr": pt.dpsi, "dp_kr": pt.dpsi * sc["p_B"]}
    except SolveError as exc:
        out |= {"dpsi_kr": None, "dpsi_kr_status": f"no margin with q1 = 0 at psi1 = {psi1:g}: {exc.status}"}
    return out


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


def run(solver: StaticsSolver, settings, title: str = "") -> StaticsResult:
    """Operating point, criticals, continuation sweep and force-gap curve of one device."""
    dev = solver.design
    g, sc = dev.groups, dev.scales
    dpsi = dev.dpsi
    psi1 = settings.operating_ratio
    cf = closed_form.for_medium(g, psi1, dpsi)
    q_base = float(cf["Q_B_over_g1pB"])

    op = solver.solve(psi1, dpsi)
    exact = _state(solver, op, q_base)
    newton = solver.newton(psi1, dpsi, op.x, op.active)
    exact["newton_max_difference"] = float(np.abs(newton - op.x).max())

    closed = {
        "dpsi_kr": cf["dpsi_kr"], "psi1_kr": cf["psi1_kr"], "u0": cf["u"],
        "psi2_0": cf["psi2"], "psi3_0": cf["psi3"], "psi_e0": cf["psi_e"],
        "Q_e": cf["Q_e_over_g1pB"] * sc["Q_scale"], "Q_B": q_base * sc["Q_scale"],
        "q_T": cf["q_T"], "q_1": cf["q_1"], "kappa_s": cf["kappa_s"],
    }
    if g.regulator is not None:
        closed |= {"xi0": cf["xi"], "psi_cam0": cf["psi_cam"]}
    if "kappa_u_2_162" in cf:
        closed["kappa_u_2_162"] = cf["kappa_u_2_162"]
    closed["Q_e_over_Q_n"] = closed["Q_e"] / sc["Q_n"]
    if g.medium == "liquid":
        quad = closed_form.pump_quadratic(g, psi1, dpsi)
        closed |= {"psi2_0_quadratic": quad["psi2"], "psi3_0_quadratic": quad["psi3"],
                   "u0_quadratic": quad["u"]}

    critical = _criticals(solver, psi1, dpsi, float(cf["psi1_kr"]), float(cf["dpsi_kr"]),
                          settings.discharge_ratio.stop)

    r = settings.discharge_ratio
    grid = np.linspace(r.start, r.stop, r.points)
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
    cfs = closed_form.for_medium(g, grid, dpsi)
    keys = sweep_keys(g)
    sweep = {"psi1": grid}
    for k in keys:
        sweep[k] = np.array([p.values[k] for p in points])
    for k in ("q_e", "q_T", "q_1", "Q_e", "Q_1", "Q_T", "kappa_s", "contact") + (
            ("regulator_saturated",) if g.regulator is not None else ()):
        sweep[k] = np.array([s[k] for s in states])
    sweep["status"] = [p.status for p in points]
    sweep["max_relative_residual"] = max(p.max_residual for p in points)
    sweep["closed_form"] = {k: np.broadcast_to(np.asarray(cfs.get(k, np.nan), float), grid.shape)
                            for k in (*keys, "q_e", "q_T", "q_1")}
    extra = refine(solver, points, dpsi)
    fine = np.array([p.psi1 for p in extra])
    cff = closed_form.for_medium(g, fine, dpsi) if extra else {}
    refined = {"psi1": fine, **{k: np.array([p.values[k] for p in extra], dtype=float) for k in keys}}
    refined |= {f"q_{k}": np.array([p.flows[k] / q_base for p in extra], dtype=float) for k in ("e", "T", "1")}
    if g.regulator is not None:
        refined["regulator_saturated"] = np.array([p.saturated for p in extra], dtype=float)
    refined["closed_form"] = {k: np.broadcast_to(np.asarray(cff.get(k, np.nan), float), fine.shape)
                              for k in (*keys, "q_e", "q_T", "q_1")}

    us = np.linspace(0.3, 2.0, settings.force_gap_points)
    force_gap = {"psi1": psi1, "u": us, "phi_exact": solver.force_gap(psi1, dpsi, us),
                 "phi_closed_form": (closed_form.force_gap(g, psi1, dpsi, us) if g.medium == "liquid"
                                     else np.full(us.shape, np.nan)),
                 "tau": g.b * psi1 - g.chi}

    accuracy = {"max_relative_residual": max(exact["solver"]["max_relative_residual"],
                                             sweep["max_relative_residual"]),
                "newton_max_difference": exact["newton_max_difference"],
                "how": "balance residuals relative to their largest term (operating point and sweep); "
                       "IPOPT vs CasADi Newton on the same equations at the operating point"}
    if not op.active and g.regulator is not None:
        ref = workprecision.statics_reference(g, psi1, dpsi)
        got = np.array([op.values[k] for k in workprecision.STATICS_OUTPUTS])
        accuracy["estimate"] = float(np.max(np.abs(got - ref) / np.abs(ref)))
        accuracy["how"] += "; estimate = max relative error of the operating point against the 40-digit exact root"
    else:
        accuracy["estimate"] = accuracy["max_relative_residual"]
        accuracy["how"] += "; estimate = the residual (a stop is reached or there is no regulator)"
    data = {
        "accuracy": accuracy,
        "title": title, "medium": g.medium, "dpsi": dpsi,
        "groups": groups_by_name(g) | ({"xi_max": g.regulator.xi_max} if g.regulator else {}),
        "scales": sc if g.regulator is not None else {k: v for k, v in sc.items() if k != "x_B"},
        "conductances": dev.conductances, "derived": dev.extra,
        "closed_form": closed, "exact": exact, "critical_exact": critical,
        "sweep": sweep, "sweep_refined": refined, "force_gap": force_gap,
    }
    return StaticsResult(with_statuses(data, _null_reasons(g), "the closed form has no physical value here"))


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
