"""The static calculation of a scene: exact IPOPT solution beside the source's closed forms.

``run(design, settings)`` returns a :class:`StaticsResult`, plain data that writes itself as
the ``statics`` block of results.json, CSV tables and the figures equivalent to the source's
Figs 2.4-2.6 (pump) and 2.9-2.10 (compressor), plus the force-gap characteristic (2.35).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autobal.analysis import closed_form, workprecision
from autobal.analysis.result import Result, fmt, new_figure, with_statuses
from autobal.analysis.statics import StaticPoint, StaticsSolver
from autobal.errors import SolveError
from autobal.models.device import groups_by_name

SWEEP_KEYS = ("psi_e", "psi2", "psi3", "psi_cam", "u", "xi")
PATH_NODES = 257  # continuation nodes across a sweep's range, whatever the number of requested points
MAX_HALVINGS = 6  # a failed continuation step is halved at most this many times


@dataclass
class StaticsResult(Result):
    """The static calculation of one device: operating point, criticals, sweep, force-gap curve.

    ``data`` is the results.json block; the headline numbers are the properties below.
    """

    data: dict  # the results.json block; numbers in SI or as named dimensionless groups
    name = "statics"

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

    def summary(self) -> str:
        ex, cf = self.data["exact"], self.data["closed_form"]
        crit = self.data["critical_exact"]
        lines = [f"statics at psi1 = {ex['psi1']:g}: IPOPT {ex['solver']['status']}, "
                 f"max relative residual {ex['solver']['max_relative_residual']:.1e}",
                 f"  {'':10s}{'exact':>12s}{'closed form':>14s}"]
        for k in ("u0", "xi0", "psi2_0", "psi3_0", "psi_e0", "psi_cam0", "kappa_s"):
            lines.append(f"  {k:10s}{fmt(ex.get(k)):>12s}{fmt(cf.get(k)):>14s}")
        lines.append(f"  {'psi1_kr':10s}{fmt(crit['psi1_kr']):>12s}{fmt(cf['psi1_kr']):>14s}")
        lines.append(f"  {'dpsi_kr':10s}{fmt(crit['dpsi_kr']):>12s}{fmt(cf['dpsi_kr']):>14s}")
        lines.append(f"  Q_e [m3/s]{fmt(ex['Q_e']):>12s}{fmt(cf['Q_e']):>14s}")
        sat = self.data["sweep"]["regulator_saturated"]
        if any(sat):
            first = self.data["sweep"]["psi1"][int(np.argmax(sat))]
            lines.append(f"  regulator saturated (valve on its open stop) from psi1 = {first:.4g}")
        if ex["regulator_saturated"]:
            lines.append("  the operating point itself has the regulator saturated")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        sw, fg = self.data["sweep"], self.data["force_gap"]
        cols = {k: sw[k] for k in ("psi1", *SWEEP_KEYS, "q_e", "q_T", "q_1", "Q_e", "Q_1", "Q_T",
                                   "kappa_s", "regulator_saturated", "contact")}
        cols |= {f"closed_form_{k}": v for k, v in sw["closed_form"].items() if not k.endswith("_status")}
        return {"statics_sweep.csv": cols,
                "force_gap.csv": {"u": fg["u"], "phi_exact": fg["phi_exact"],
                                  "phi_closed_form": fg["phi_closed_form"]}}

    def _decorate(self, ax, ylabel: str) -> None:
        sw = self.data["sweep"]
        psi1 = np.asarray(sw["psi1"], float)
        sat = np.asarray(sw["regulator_saturated"], bool)
        kr = self.data["critical_exact"]["psi1_kr"]
        kr_cf = self.data["closed_form"]["psi1_kr"]
        if sat.any():
            ax.axvspan(psi1[sat].min(), psi1.max(), color="0.9", label="regulator saturated")
        if kr is not None:
            ax.axvline(kr, color="k", lw=0.8, ls=":", label=r"$\psi_1^{kr}$ exact")
        ax.axvline(kr_cf, color="0.5", lw=0.8, ls="-.", label=r"$\psi_1^{kr}$ (2.32)/(2.160)")
        ax.set_xlabel(r"discharge pressure ratio $\psi_1 = p_1/p_B$")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def draw(self, ax) -> None:
        """Chamber pressure ratios against the discharge ratio (Fig 2.4 / 2.9)."""
        sw, cf = self.data["sweep"], self.data["sweep"]["closed_form"]
        psi1 = np.asarray(sw["psi1"], float)
        for k, lab in (("psi_e", r"$\psi_e$"), ("psi2", r"$\psi_2$"), ("psi3", r"$\psi_3$"),
                       ("psi_cam", r"$\psi_{cam}$")):
            line, = ax.plot(psi1, np.asarray(sw[k], float), label=f"{lab} exact")
            ax.plot(psi1, np.asarray(cf[k], float), ls="--", color=line.get_color(), label=f"{lab} closed form")
        self._decorate(ax, "pressure ratio")

    def figures(self) -> dict:
        """Pressures (Fig 2.4/2.9), gap and valve (Fig 2.5), flows (Fig 2.6/2.10), phi(u) (2.35)."""
        sw, cf = self.data["sweep"], self.data["sweep"]["closed_form"]
        psi1 = np.asarray(sw["psi1"], float)
        figs = {}

        fig, ax = new_figure()
        self.draw(ax)
        figs["fig_pressures.png"] = fig

        fig, (a1, a2) = new_figure((6.4, 6), 2, 1, sharex=True)
        a1.plot(psi1, np.asarray(sw["u"], float), label="u exact")
        a1.plot(psi1, np.asarray(cf["u"], float), ls="--", label="u closed form")
        self._decorate(a1, r"face gap $u = z/z_B$")
        a2.plot(psi1, np.asarray(sw["xi"], float), label=r"$\xi$ exact")
        a2.plot(psi1, np.asarray(cf["xi"], float), ls="--", label=r"$\xi$ closed form (2.28)")
        self._decorate(a2, r"valve opening $\xi = x/x_B$")
        figs["fig_gap.png"] = fig

        fig, ax = new_figure()
        for k, lab in (("q_e", "$q_e$"), ("q_T", "$q_T$"), ("q_1", "$q_1$")):
            line, = ax.plot(psi1, np.asarray(sw[k], float), label=f"{lab} exact")
            ax.plot(psi1, np.asarray(cf[k], float), ls="--", color=line.get_color(), label=f"{lab} closed form")
        ax.axhline(0, color="k", lw=0.5)
        self._decorate(ax, r"flow / $Q_B$ (source's base flow)")
        figs["fig_flows.png"] = fig

        fg = self.data["force_gap"]
        fig, ax = new_figure()
        ax.plot(fg["u"], fg["phi_exact"], label=r"$\varphi(u)$ exact network")
        if any(v is not None for v in fg["phi_closed_form"]):
            ax.plot(fg["u"], np.asarray(fg["phi_closed_form"], float), ls="--", label=r"$\varphi(u)$ (2.35)")
        ax.axhline(fg["tau"], color="k", lw=0.8, ls=":", label=r"$\tau - \chi$ (load)")
        ax.set_xlabel(r"face gap $u = z/z_B$")
        ax.set_ylabel(r"balancing force $\varphi = F/(p_B s_B)$")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        figs["fig_force_gap.png"] = fig
        for f in figs.values():
            f.suptitle(self.data["title"], fontsize=9)
        return figs


def _state(solver: StaticsSolver, pt: StaticPoint, q_base: float) -> dict:
    """Unknowns, SI values and flows of one solved point (flows relative to q_base too)."""
    sc = solver.design.scales
    v, q = pt.values, pt.flows
    q_e = q["e"]
    return {
        "psi1": pt.psi1, "u0": v["u"], "xi0": v.get("xi"), "psi2_0": v["psi2"], "psi3_0": v["psi3"],
        "psi_e0": v["psi_e"], "psi_cam0": v.get("psi_cam"),
        "z0": v["u"] * sc["z_B"], "x0": v.get("xi", np.nan) * sc["x_B"],
        "p1": pt.psi1 * sc["p_B"], "p2": v["psi2"] * sc["p_B"], "p3": v["psi3"] * sc["p_B"],
        "pe": v["psi_e"] * sc["p_B"], "pcam": v.get("psi_cam", np.nan) * sc["p_B"],
        **{f"Q_{k}": q[k] * sc["Q_scale"] for k in ("e", "1", "T", "3")},
        "q_e": q_e / q_base, "q_T": q["T"] / q_base, "q_1": q["1"] / q_base,
        "kappa_s": solver.stiffness(pt),
        "regulator_saturated": pt.saturated, "contact": pt.contact,
        "r_valve": v.get("r_valve", 0.0), "r_contact": v["r_contact"],
        "solver": {"status": pt.status, "iterations": pt.iterations, "max_relative_residual": pt.max_residual},
    }


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
        out |= {"psi1_kr": pt.psi1, "psi1_kr_regulator_saturated": pt.saturated, "p1_kr": pt.psi1 * sc["p_B"]}
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

    A grid of at most :data:`PATH_NODES` points is solved as one continuation path, each point
    warm-started from the one before.  A denser grid is not: a path of :data:`PATH_NODES` evenly
    spaced nodes across ``span`` is solved first, and each requested point is warm-started from its
    nearest node, so a 100,000-point sweep takes the same continuation steps as a 1,000-point one
    (thousands of tiny warm-started steps drift into a point IPOPT cannot leave, e.g. the compressor
    at psi1 = 1.26162 where its regulator saturates).  A step that fails is halved (at most
    :data:`MAX_HALVINGS` times) before the sweep gives up.

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
    if span is None and len(psi1s) <= PATH_NODES:
        return _path(solver, psi1s, dpsi)
    lo, hi = span if span is not None else (psi1s[0], psi1s[-1])
    nodes = _path(solver, np.linspace(lo, hi, PATH_NODES), dpsi)
    at = np.array([p.psi1 for p in nodes])
    out = []
    for s in psi1s:
        near = nodes[int(np.argmin(np.abs(at - s)))]
        out.append(near if near.psi1 == s else _step(solver, near, float(s), dpsi))
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
        if halvings >= MAX_HALVINGS:
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
        "dpsi_kr": cf["dpsi_kr"], "psi1_kr": cf["psi1_kr"], "u0": cf["u"], "xi0": cf.get("xi"),
        "psi2_0": cf["psi2"], "psi3_0": cf["psi3"], "psi_e0": cf["psi_e"], "psi_cam0": cf.get("psi_cam"),
        "Q_e": cf["Q_e_over_g1pB"] * sc["Q_scale"], "Q_B": q_base * sc["Q_scale"],
        "q_T": cf["q_T"], "q_1": cf["q_1"], "kappa_s": cf["kappa_s"],
    }
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
    sweep = {"psi1": grid}
    for k in SWEEP_KEYS:
        sweep[k] = np.array([p.values.get(k, np.nan) for p in points])
    for k in ("q_e", "q_T", "q_1", "Q_e", "Q_1", "Q_T", "kappa_s", "regulator_saturated", "contact"):
        sweep[k] = np.array([s[k] for s in states])
    sweep["status"] = [p.status for p in points]
    sweep["max_relative_residual"] = max(p.max_residual for p in points)
    sweep["closed_form"] = {k: np.broadcast_to(np.asarray(cfs.get(k, np.nan), float), grid.shape)
                            for k in (*SWEEP_KEYS, "q_e", "q_T", "q_1")}

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
        "scales": sc, "conductances": dev.conductances, "derived": dev.extra,
        "closed_form": closed, "exact": exact, "critical_exact": critical,
        "sweep": sweep, "force_gap": force_gap,
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
        "phi_closed_form": "the closed form (2.35) is the liquid device's" if gas else None,
    }
