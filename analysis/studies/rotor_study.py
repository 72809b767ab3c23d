"""The ``rotor_dynamics`` analysis of a scene: the source's studies of the rotor with a liquid
auto-balancer (Pashkov (2010), ch. 2).

Parts (each optional in the scene): ``stationary`` (Eq. (9), Figs 5-6, table §5.1, and the
steady state (3) and stability (P) of the scene's rotor), ``steps`` (speed steps (4)-(7), Figs 3-4,
closed form beside CVODES, table §5.3), ``passage`` (uniform acceleration (8')-(9'), Figs 7-9,
table §5.4, crossover n*), ``lewis`` (table §5.5) and ``motor_runup``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autobal.analysis.numerics import rotor as R
from autobal.analysis.numerics import standards
from autobal.analysis.run import progress, solver_options
from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record, unsaved
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Quantity
from autobal.analysis.run.result import new_figure, speed_axis, unit_axis
from autobal.errors import ScenarioError
from autobal.models.rotor import RotorParams

STEP_TOL = 1e-12  # CVODES tolerance of the step transients checked against the closed form

_P10 = "Pashkov (2010), ch. 2"

def _declared(q, **kw):
    """A field declared as the Quantity ``q`` of another module (the API margins of analysis/numerics/standards.py)."""
    return quantity(q.unit, q.symbol, q.description, q.declared, source=q.source, beside=q.beside, **kw)


_AF, _SM, _SM_REQ, _N_C, _HALF_POWER = standards.margin_quantities()


def _check():
    return quantity("1", "", "cross-checks: steady state (3) against (9), eigenpair residual, closed form (5)-(7) "
                             "against CVODES")


def _damping():
    return quantity("1/s", "n", "damping n = χ/m of the steady state (3) and of the passage (8')", source=_P10)


@record
class Rotor(Record):
    """The scene's rotor: its groups, its critical speed and its API 684 (2005) margins
    (:func:`api_margins`; a null beside its ``*_status``)."""

    psi: float = quantity("1", "ψ", "liquid mass ratio m1/m", source=_P10, headline=3)
    mu1: float = quantity("1", "μ1", "liquid-to-rotor mass group of Eq. (9)", source=f"{_P10}, Eq. (9)")
    Omega0_rad_s: float = quantity("rad/s", "Ω0", "natural frequency without liquid", "rad/s", headline=2)
    omega_cr_rad_s: float = quantity("rad/s", "ω_cr", "critical speed √(c/m) (m with the liquid mass, if any)",
                                     "rad/s", source=_P10, headline=1)
    zeta0: float = quantity("1", "ζ0", "damping ratio of the rotor", headline=4)
    n_steady_1_s: float = _damping()
    n_stationary: float = quantity("1", "n", "damping group n = χ²/(c m1) of Eq. (9)", source=f"{_P10}, Eq. (9)")
    n_passage_1_s: float = _damping()
    service_speed_rad_s: float | None = quantity("rad/s", "N_s",
                                                 "service speed (the scene's rotor.unbalance.service_speed)")
    amplification_factor: float | None = _declared(_AF, headline=5)
    response_peak_speed_rad_s: float | None = _declared(_N_C, headline=6)
    half_power_speeds_rad_s: list[float] | None = _declared(_HALF_POWER)
    amplification_factor_status: str | None = optional(kw_only=True)
    half_power_speeds_rad_s_status: str | None = optional(kw_only=True)
    response_peak_speed_rad_s_status: str | None = optional(kw_only=True)
    separation_margin_pct: float | None = _declared(_SM, headline=7)
    required_separation_margin_pct: float | None = _declared(_SM_REQ, headline=8)
    separation_margin_ok: bool | None
    separation_margin_pct_status: str | None = optional(kw_only=True)
    required_separation_margin_pct_status: str | None = optional(kw_only=True)
    separation_margin_ok_status: str | None = optional(kw_only=True)
    service_speed_rad_s_status: str | None = optional(kw_only=True)


def _z():
    return quantity("1", "z", "speed group z = (ω/Ω0)² of the stationary table's points",
                    source=f"{_P10}, Eq. (9), table §5.1")


def _whirl():
    return quantity("1", "a/e", "whirl amplitude over the eccentricity", source=f"{_P10}, Fig. 5")


def _moment():
    return quantity("1", "M/(e²c)", "moment group of Fig. 6", source=f"{_P10}, Fig. 6")


def _case():
    return quantity("1", "μ1, n", "the (μ1, n) case of Eq. (9)", source=f"{_P10}, Figs 5-6")


@record
class StationaryCase(Record):
    """The special points of the stationary curves (9) of one (μ1, n) (:func:`autobal.analysis.numerics.rotor.
    stationary_points`): the torque's maximum and minimum null where they do not exist, with the reason."""

    mu1: float = _case()
    n: float = _case()
    z_kp: float = _z()
    a_kp: float = _whirl()
    z_helps: float = _z()
    a_inf: float = _whirl()
    z1: float | None = _z()
    M1: float | None = _moment()
    z2: float | None = _z()
    M2: float | None = _moment()
    d_max: float = quantity("1", "d/(m1 e)", "largest system unbalance", source=f"{_P10}, Eq. (7)")
    z_d_max: float = _z()
    z1_status: str | None = optional()
    M1_status: str | None = optional()
    z2_status: str | None = optional()
    M2_status: str | None = optional()


@record
class WhirlStability(Record):
    max_real_over_Omega0: float = quantity("1", "Re λ/Ω0", "stability of the steady whirl: largest real part of "
                                                           "the eigenvalues", headline=9)
    max_eigenvalue_residual: float = _check()


@record
class Stationary(Record):
    """Table §5.1 for each (μ1, n), and the steady state (3) and stability (P) of the scene's rotor."""

    cases: list[StationaryCase]
    steady_vs_eq9_max_rel_diff: float = _check()
    stability: WhirlStability


def _psi():
    return quantity("1", "ψ", "liquid mass ratio of the case")


def _unbalance():
    return quantity("1", "d", "system unbalance (7): at the step, its peak, the new steady value",
                    source=f"{_P10}, Eq. (7), table §5.3")


def _whirl_step():
    return quantity("1", "a/e", "whirl amplitude over the eccentricity: peak, new steady value",
                    source=f"{_P10}, table §5.3")


def _step_time():
    return quantity("ms", "t", "time of the peak of d, time to settle within 5 %")


def _step_speed():
    return quantity("rad/s", "ω", "speed before and after the step", "rad/s", source=f"{_P10}, Figs 3-4")


@record
class Step(Record):
    """One speed step (:func:`step_case`): the closed form (5)-(7) beside CVODES."""

    step: str
    omega_from: float = _step_speed()
    omega_to: float = _step_speed()
    psi: float = _psi()
    d0: float = _unbalance()
    d_max: float = _unbalance()
    t_d_max_ms: float = _step_time()
    d_ss: float = _unbalance()
    a_max_over_e: float = _whirl_step()
    a_ss_over_e: float = _whirl_step()
    t_5pct_ms: float = _step_time()
    closed_form_vs_cvodes: float = _check()


@record
class Steps(Record):
    table: list[Step]
    closed_form_vs_cvodes_max_rel_diff: float = _check()


def _nu():
    return quantity("1", "ν = ω/Ω0", "speed ratio at the peak")


@record
class PassageRun(Record):
    """One run through the critical speed at a uniform acceleration (8')-(9')."""

    n: float = quantity("1/s", "n", "damping n = χ/m1 of the run", source=f"{_P10}, Figs 7-9")
    psi: float = _psi()
    delta_max_over_e: float = quantity("1", "δ*/e", "peak deflection over the eccentricity",
                                       source=f"{_P10}, Fig. 9, table §5.4")
    z_delta_max: float = _nu()
    d_max: float = quantity("1", "d*", "peak system unbalance", source=f"{_P10}, Fig. 9")
    z_d_max: float = _nu()


def _acceleration():
    return quantity("rad/s^2", "2ε", "angular acceleration of the passage", source=f"{_P10}, Eq. (8')")


@record
class Passage(Record):
    """The passage runs (table §5.4) and the crossover damping n* per ψ (keys: ψ as given)."""

    table: list[PassageRun]
    crossover_n_star: dict
    crossover_n_star_sensitivity: dict
    acceleration_rad_s2: float = _acceleration()
    sensitivity_acceleration_rad_s2: float | None = _acceleration()


def _lewis_peak():
    return quantity("1", "|u|/e", "peak amplitude over the eccentricity; the undamped asymptote 1.4672/√a*",
                    source="Lewis (1932)")


def _lewis_nu():
    return quantity("1", "ν = ω/Ω", "speed ratio at the peak")


@record
class LewisCase(Record):
    zeta: float = quantity("1", "ζ", "damping ratio", source="Lewis (1932)")
    a_star: float = quantity("1", "a* = α/Ω²", "acceleration group", source="Lewis (1932)")
    peak_over_e: float = _lewis_peak()
    nu_peak: float = _lewis_nu()
    undamped_asymptote: float = _lewis_peak()
    nu_asymptote: float = _lewis_nu()


@record
class Lewis(Record):
    table: list[LewisCase]


@record
class MotorRunup(Record):
    omega_final_rad_s: float = quantity("rad/s", "ω_end", "speed at the end of the motor run-up", "rad/s",
                                        headline=10)
    passed: bool
    peak_deflection_over_e: float = quantity("1", "δ/e", "peak deflection of the run-up over the eccentricity",
                                             headline=11)


@record
class RotorDynamicsResult(TypedResult):
    """The source's studies of the rotor with a liquid auto-balancer (Pashkov (2010), ch. 2): speeds in rad/s
    (rpm beside), the source's groups dimensionless (ν = ω/Ω0 and z of Eq. (9), deflections over the eccentricity e,
    the system unbalance d of (7)); each part None where the scene does not ask for it.  ``curves`` holds the
    arrays of the figures (not in results.json: None in a loaded Result)."""

    title: str
    rotor: Rotor
    stationary: Stationary | None = optional()
    steps: Steps | None = optional()
    passage: Passage | None = optional()
    lewis: Lewis | None = optional()
    motor_runup: MotorRunup | None = optional()
    accuracy: dict | None = optional()
    curves: dict | None = unsaved()
    name = "rotor_dynamics"

    @property
    def psi(self) -> float:
        """psi = m1/m of the scene's rotor (dimensionless; 1 without liquid)."""
        return self.rotor.psi

    @property
    def critical_speed(self) -> float:
        """Undamped critical speed with the liquid, omega_cr = sqrt(c/m), rad/s."""
        return self.rotor.omega_cr_rad_s

    def verdict(self) -> tuple[bool, str] | None:
        """The one verdict: the steady whirl's stability (P) over the speed range, else whether the motor
        run-up passes the critical speed; None when the scene asks for neither."""
        if self.stationary is not None:
            mr = self.stationary.stability.max_real_over_Omega0
            return mr < 0, (f"steady whirl {'asymptotically stable' if mr < 0 else 'NOT stable'} over the speed "
                            f"range (max Re λ/Ω0 = {mr:.4g})")
        if self.motor_runup is not None:
            m = self.motor_runup
            speed = QUANTITIES.find("motor_runup.omega_final_rad_s").text(m.omega_final_rad_s)
            return m.passed, ("the motor run-up passes the critical speed" if m.passed else
                              f"the motor run-up is captured below the critical speed, at {speed}")
        return None

    def summary(self) -> str:
        v = self.verdict()
        lines = ["rotor with a liquid auto-balancer (Pashkov 2010, ch. 2)",
                 *([f"  {'ok' if v[0] else 'NOT OK'}: {v[1]}"] if v else []), *QUANTITIES.lines(self.to_dict()),
                 f"  API 684 (2005): {standards.margin_words(self.rotor.to_dict())}"]
        if (s := self.stationary) is not None:
            lines.append(f"  stationary (9): {len(s.cases)} (mu1, n) cases; steady state (3) = (9) to "
                         f"{s.steady_vs_eq9_max_rel_diff:.1e}; eigenvalues = lambda +- i nu to "
                         f"{s.stability.max_eigenvalue_residual:.1e}")
        if (s := self.steps) is not None:
            lines.append(f"  steps (5)-(7): {len(s.table)} cases, closed form vs CVODES max difference "
                         f"{s.closed_form_vs_cvodes_max_rel_diff:.1e}")
        if (s := self.passage) is not None:
            n_star = QUANTITIES.find("passage.crossover_n_star.x")
            cx = ", ".join(f"psi = {k}: {n_star.text(v)}" for k, v in s.crossover_n_star.items())
            accel = QUANTITIES.find("passage.acceleration_rad_s2").text(s.acceleration_rad_s2)
            lines.append(f"  passage (8')-(9') at {accel}: {len(s.table)} runs; crossover n*: {cx or '-'}")
        if self.lewis is not None:
            lines.append(f"  Lewis passage: {len(self.lewis.table)} cases")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        out = {}
        for key, rows in (("steps", "table"), ("passage", "table"), ("lewis", "table"), ("stationary", "cases")):
            if getattr(self, key) is not None:
                table = [r.to_dict() for r in getattr(getattr(self, key), rows)]
                # headers with their units (ms, rad/s, 1/s; '[1]' for groups)
                out[f"rotor_{key}.csv"] = QUANTITIES.columns({k: [r[k] for r in table] for k in table[0]},
                                                             f"{key}.{rows}[]")
        return out

    #: figure -> its caption
    CAPTIONS = {
        "fig_rotor_stationary.png": "Rotor with a liquid auto-balancer, stationary whirl against the squared speed "
                                    "ratio: amplitude a/e, moment, system unbalance and the amplitude ratio per μ1 = "
                                    "m/m1 and damping n; Pashkov (2010), Figs. 5-6, Eq. (10)",
        "fig_rotor_steps.png": "Rotor with a liquid auto-balancer: the system unbalance d after a step of the speed, "
                               "per mass ratio ψ = m1/m; Pashkov (2010), Figs. 3-4",
        "fig_rotor_passage.png": "Rotor with a liquid auto-balancer passing its critical speed: deflection δ/e and "
                                 "system unbalance d against the speed ratio, the least and the largest damping; "
                                 "Pashkov (2010), Figs. 7-8",
        "fig_rotor_peaks.png": "Rotor with a liquid auto-balancer: the largest deflection δ*/e and unbalance d* of "
                               "the passage against the damping n, per mass ratio ψ; Pashkov (2010), Fig. 9",
        "fig_rotor_lewis.png": "Peak deflection of a rotor accelerated through its critical speed at a constant rate "
                               "a* = α/Ω², per damping ratio ζ, with the undamped asymptote 1.4672/√a*",
        "fig_rotor_motor.png": "Rotor with a liquid auto-balancer driven by its motor: speed and deflection δ/e "
                               "against time, the critical speed dotted"}

    def figures(self) -> dict[str, Figure]:
        if self.curves is None:
            raise ValueError("rotor_dynamics: a loaded Result holds no curves (results.json has the tables; the "
                             "figures of the run are in its folder)")
        c, figs = self.curves, {}

        def save(fig, name):
            figs[name] = Figure(fig, self.CAPTIONS[name])

        if "stationary" in c:
            fig, ax = new_figure(figsize=(9, 7), nrows=2, ncols=2)
            for (mu1, n), cv in c["stationary"].items():
                lab = rf"$\mu_1$={mu1:g}, n={n:g}"
                ax[0, 0].plot(cv["z"], cv["a"], label=lab)
                ax[0, 1].plot(cv["z"], cv["M"], label=lab)
                ax[1, 0].plot(cv["z"], cv["d"], label=lab)
                ax[1, 1].plot(cv["z"], cv["ratio_a"], label=lab)
            for a, yl in zip(ax.ravel(), ("a/e (Fig. 5)", r"M/(e$^2$c) (Fig. 6)", r"d/(m$_1$e)",
                                          r"a/a$_1$ = d/d$_1$ (10)"), strict=True):
                a.set_xlabel(r"z = $(\omega/\Omega_0)^2$")
                a.set_ylabel(yl)
                a.set_yscale("log") if "M" in yl else None
                a.grid(alpha=0.3)
                a.legend(fontsize=7)
            save(fig, "fig_rotor_stationary.png")
        if "steps" in c:
            keys = list(c["steps"])
            fig, ax = new_figure(figsize=(9, 7), nrows=2, ncols=2, sharey=False)
            for a, key in zip(ax.ravel(), keys, strict=False):
                f = unit_axis(a, "time t", "s", "ms", "x")
                for psi, cv in c["steps"][key].items():
                    a.plot(cv["t"] * f, cv["d"], label=rf"$\psi$={psi:g}")
                a.set_title(f"step {key} rad/s (Figs 3-4)", fontsize=9)
                a.set_ylabel("system unbalance d (7)")
                a.grid(alpha=0.3)
                a.legend(fontsize=7)
            save(fig, "fig_rotor_steps.png")
        if "passage" in c:
            fig, ax = new_figure(figsize=(9, 7), nrows=2, ncols=2)
            for col, n in enumerate(sorted(c["passage"]["curves"])[:1] + sorted(c["passage"]["curves"])[-1:]):
                for psi, cv in c["passage"]["curves"][n].items():
                    ax[0, col].plot(cv["z"], cv["delta"], lw=0.8, label=rf"$\psi$={psi:g}")
                    ax[1, col].plot(cv["z"], cv["d"], lw=0.8, label=rf"$\psi$={psi:g}")
                for r, yl in ((0, r"$\delta/e$"), (1, "d (9')")):
                    ax[r, col].set_title(f"n = {n:g} 1/s (Fig. {7 if col == 0 else 8})", fontsize=9)
                    ax[r, col].set_xlabel(r"z = $\omega/\Omega_0$")
                    ax[r, col].set_ylabel(yl)
                    ax[r, col].grid(alpha=0.3)
                    ax[r, col].legend(fontsize=7)
            save(fig, "fig_rotor_passage.png")
            fig, ax = new_figure(figsize=(9, 3.8), ncols=2)
            tab = self.passage.table
            for psi in sorted({r.psi for r in tab}, reverse=True):
                rows = [r for r in tab if r.psi == psi]
                n = [r.n for r in rows]
                ax[0].plot(n, [r.delta_max_over_e for r in rows], "o-", label=rf"$\psi$={psi:g}")
                ax[1].plot(n, [r.d_max for r in rows], "o-", label=rf"$\psi$={psi:g}")
            for a, yl in zip(ax, (r"$\delta^*/e$", "d*"), strict=True):
                a.set_xscale("symlog", linthresh=1)
                a.set_xlabel(r"n = $\chi/m_1$ (1/s) (Fig. 9)")
                a.set_ylabel(yl)
                a.grid(alpha=0.3)
                a.legend(fontsize=7)
            save(fig, "fig_rotor_peaks.png")
        if self.lewis is not None:
            fig, a = new_figure(figsize=(6, 4))
            tab = self.lewis.table
            for z in sorted({r.zeta for r in tab}):
                rows = [r for r in tab if r.zeta == z]
                a.loglog([r.a_star for r in rows], [r.peak_over_e for r in rows], "o-", label=rf"$\zeta$={z:g}")
            aa = np.array(sorted({r.a_star for r in tab}))
            a.loglog(aa, 1.4672 / np.sqrt(aa), "k--", lw=0.8, label=r"1.4672/$\sqrt{a^*}$ (undamped asymptote)")
            a.set_xlabel(r"$a^* = \alpha/\Omega^2$")
            a.set_ylabel("peak |u|/e")
            a.grid(alpha=0.3, which="both")
            a.legend(fontsize=7)
            save(fig, "fig_rotor_lewis.png")
        if "motor" in c:
            fig, a = new_figure(figsize=(6, 5), nrows=2, sharex=True)
            m = c["motor"]
            ft, fw = unit_axis(a[1], "time t", "s", which="x"), speed_axis(a[0])
            a[0].plot(np.asarray(m["t"]) * ft, np.asarray(m["omega"]) * fw)
            a[0].axhline(self.rotor.omega_cr_rad_s * fw, color="k", ls=":", lw=0.8,
                         label=r"$\omega_{cr}$")
            a[0].legend(fontsize=7)
            a[1].plot(np.asarray(m["t"]) * ft, m["delta"])
            a[1].set_ylabel(r"$\delta/e$")
            for x in a:
                x.grid(alpha=0.3)
            save(fig, "fig_rotor_motor.png")
        return figs


#: every number of the rotor_dynamics block, from the fields; the crossover damping n* per ψ (keys: ψ as given)
RotorDynamicsResult.quantities = QUANTITIES = declarations(
    RotorDynamicsResult,
    Quantity("passage.crossover_n_star.** passage.crossover_n_star_sensitivity.**", "1/s", "n*",
             "damping above which the liquid raises the passage peak (per ψ; the second at the sensitivity "
             "acceleration)", source=f"{_P10}, Fig. 9"))


def api_margins(P: RotorParams, min_speed: float | None, max_speed: float | None = None) -> dict:
    """The rotor's critical speed against its operating speed range
    (:func:`autobal.analysis.numerics.standards.margin_check`, API 684 (2005), API 617 (2014)): the amplification factor
    read off the half-power points of the model's own steady unbalance response |delta/e|
    (:func:`autobal.analysis.numerics.rotor.steady_state`, with the liquid mass), the separation margin from N_min..N_mc
    (rad/s; None: no operating speed, the AF alone) and the margin required."""
    reading = standards.half_power_readings(lambda w: R.steady_state(P, w / P.Omega0)["a"], [P.omega_cr],
                                            high=20 * P.omega_cr, points=8001, undamped=[P.chi == 0])[0]
    return standards.margin_check(reading, min_speed, max_speed)


# ---- the spec ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class StationarySpec:
    """Stationary curves (9) of Figs 5-6 for pairs (mu1, n), n = chi^2/(c m1), over z = (omega/Omega0)^2 from
    ``z = (start, stop, points)``."""

    cases: tuple
    z: tuple


@dataclass(frozen=True)
class StepsSpec:
    """Speed steps (4)-(7), Figs 3-4, for each psi: ``steps`` (from, to) in rad/s, each run for ``duration`` s."""

    psi: tuple
    steps: tuple
    duration: float


@dataclass(frozen=True)
class PassageSpec:
    """Uniform acceleration through the critical speed (8')-(9'), Figs 7-9: rad/s, rad/s^2, n = chi/m1 in 1/s."""

    psi: tuple
    friction: tuple
    start_speed: float
    acceleration: float
    final_ratio: float  # run to omega/Omega0
    crossover: bool  # find n* where max d(psi) = max d(1)
    sensitivity_acceleration: float | None = None


@dataclass(frozen=True)
class LewisSpec:
    """The Jeffcott rotor from rest at constant acceleration: the table over zeta and a* = alpha/Omega^2."""

    zeta: tuple
    accel_ratio: tuple


@dataclass(frozen=True)
class MotorRunupSpec:
    """A run-up of ``duration`` s on the linear motor characteristic L = stall_torque (1 - omega/no_load_speed)
    (N m, rad/s; None: the scene has no motor)."""

    duration: float
    stall_torque: float | None = None
    no_load_speed: float | None = None


@dataclass(frozen=True)
class Spec:
    """The parts of the rotor study a scene asks for (the validated ``analyses.rotor_dynamics``; None: not run)."""

    stationary: StationarySpec | None = None
    steps: StepsSpec | None = None
    passage: PassageSpec | None = None
    lewis: LewisSpec | None = None
    motor_runup: MotorRunupSpec | None = None


# ---- parts -----------------------------------------------------------------------------------------

def stationary_part(P: RotorParams, cases, z) -> tuple[Stationary, dict]:
    """Table §5.1 for each (mu1, n); (3) vs (9) and stability (P) of the scene's rotor over speed."""
    rows, curves = [], {}
    for mu1, n in cases:
        rows.append(StationaryCase(**R.stationary_points(mu1, n)))
        curves[(mu1, n)] = R.stationary(mu1, n, z)
    nu = np.sqrt(np.asarray(z))
    ss = R.steady_state(P, nu)
    eq9 = R.stationary(P.mu1, P.n_stationary(), nu**2)
    rel = float(np.max(np.abs(ss["a"] - eq9["a"]) / eq9["a"]))
    stab = [R.stability(P, float(v)) for v in np.linspace(0.05, float(nu.max()), 25)]
    return Stationary(rows, rel, WhirlStability(max(s["max_real"] for s in stab),
                                                max(s["residual"] for s in stab))), curves


def step_case(P: RotorParams, w0: float, w1: float, duration: float, points: int = 6000) -> dict:
    """One step w0 -> w1 (rad/s): the closed form (5)-(7) on a dense grid, and CVODES for comparison."""
    Om = P.Omega0
    tau = np.linspace(0, duration * Om, points + 1)
    w = R.step_closed_form(P, w0 / Om, w1 / Om, tau)
    q0 = R.steady_q(P, w0 / Om)[:4] + [w1 / Om]
    sim = R.simulate(P, q0, np.zeros(points // 100), np.full(points // 100, tau[-1] / (points // 100)), points=100,
                     tol=STEP_TOL)
    w_int = sim["q"][0] + 1j * sim["q"][1]
    diff = float(np.max(np.abs(w_int - w)) / np.max(np.abs(w)))
    psi = P.psi
    d = np.abs(w / psi + 1)
    a = np.abs(w)
    ss = R.steady_state(P, w1 / Om)
    d_ss, a_ss = float(ss["d"]), float(ss["a"])
    dmax, tmax = R.peak(tau, d)
    out = np.nonzero(np.abs(d - d_ss) > 0.05 * d_ss)[0]
    return {"step": f"{w0:g}->{w1:g}", "omega_from": w0, "omega_to": w1, "psi": psi, "d0": float(d[0]),
            "d_max": dmax, "t_d_max_ms": tmax / Om * 1e3,
            "d_ss": d_ss, "a_max_over_e": R.peak(tau, a)[0], "a_ss_over_e": a_ss,
            "t_5pct_ms": float(tau[out[-1]] / Om * 1e3) if len(out) else 0.0, "closed_form_vs_cvodes": diff,
            "_t": tau / Om, "_d": d}


def passage_part(P: RotorParams, s: PassageSpec) -> tuple[Passage, dict]:
    Om = P.Omega0
    rows, curves, cross = [], {}, {}
    for n in s.friction:
        curves[n] = {}
        for psi in s.psi:
            Pn = P.with_chi(n * P.m1).with_psi(psi)
            r = R.passage(Pn, s.start_speed / Om, s.acceleration / Om**2, s.final_ratio)
            rows.append(PassageRun(n, psi, r["delta_max"], r["nu_delta_max"], r["d_max"], r["nu_d_max"]))
            keep = slice(None, None, max(1, len(r["nu"]) // 3000))
            curves[n][psi] = {"z": r["nu"][keep], "delta": r["delta"][keep], "d": r["d"][keep]}
    sens = {}
    if s.crossover:
        for psi in (p for p in s.psi if p < 1):
            cross[str(psi)] = R.crossover(Om, psi, s.start_speed, s.acceleration, s.final_ratio)
            if s.sensitivity_acceleration:
                sens[str(psi)] = R.crossover(Om, psi, s.start_speed, s.sensitivity_acceleration, s.final_ratio)
    return Passage(rows, cross, sens, s.acceleration, s.sensitivity_acceleration), {"curves": curves}


def run(P: RotorParams, spec: Spec, title: str = "", service_speed: float | None = None) -> RotorDynamicsResult:
    """The parts the spec names; the rotor's API 684 margins (:func:`api_margins`) from ``service_speed`` (rad/s,
    the scene's rotor.unbalance.service_speed; None: the amplification factor alone)."""
    rotor = Rotor(psi=P.psi, mu1=P.mu1, Omega0_rad_s=P.Omega0, omega_cr_rad_s=P.omega_cr, zeta0=P.zeta0,
                  n_steady_1_s=P.n_steady(), n_stationary=P.n_stationary(), n_passage_1_s=P.n_passage(),
                  service_speed_rad_s=service_speed, **api_margins(P, service_speed),
                  service_speed_rad_s_status=None if service_speed is not None else
                  "the scene gives no service speed (rotor.unbalance)")
    curves, stationary, steps, passage, lewis, runup = {}, None, None, None, None, None
    if spec.stationary is not None:
        s = spec.stationary
        z = np.linspace(*s.z)
        stationary, curves["stationary"] = stationary_part(P, s.cases, z)
        progress.tick(note="stationary curves")
    if spec.steps is not None:
        s, rows, curves["steps"] = spec.steps, [], {}
        for w0, w1 in s.steps:
            key = f"{w0:g}->{w1:g}"
            curves["steps"][key] = {}
            for psi in s.psi:
                r = step_case(P.with_psi(psi), w0, w1, s.duration)
                curves["steps"][key][psi] = {"t": r.pop("_t"), "d": r.pop("_d")}
                rows.append(Step(**r))
                progress.tick(note=f"step {key}, psi {psi:g}")
        steps = Steps(rows, max(r.closed_form_vs_cvodes for r in rows))
    if spec.passage is not None:
        passage, curves["passage"] = passage_part(P, spec.passage)
        progress.tick(note="passage")
    if spec.lewis is not None:
        rows = []
        for z in spec.lewis.zeta:
            for a in spec.lewis.accel_ratio:
                r = R.lewis(z, a)
                rows.append(LewisCase(z, a, r["peak"], r["nu_peak"], r["asymptote"], r["nu_asymptote"]))
                progress.tick(note=f"Lewis zeta {z:g}, a* {a:g}")
        lewis = Lewis(rows)
    if spec.motor_runup is not None:
        motor = spec.motor_runup
        if motor.stall_torque is None:
            raise ScenarioError("analyses.rotor_dynamics.motor_runup needs rotor.drive.motor")
        if P.J_p + P.m1 * P.e**2 * (1 - P.psi) <= 0:
            raise ScenarioError("analyses.rotor_dynamics.motor_runup needs rotor.drive.polar_inertia > 0")
        ts = P.torque_scale
        r = R.motor_runup(P, motor.stall_torque / ts, motor.no_load_speed / P.Omega0,
                          motor.duration * P.Omega0)
        runup = MotorRunup(r["nu_final"] * P.Omega0, r["passed"], float(r["delta"].max()))
        curves["motor"] = {"t": r["tau"] / P.Omega0, "omega": r["nu"] * P.Omega0, "delta": r["delta"]}
    return RotorDynamicsResult(title, rotor, stationary, steps, passage, lewis, runup,
                               accuracy=accuracy(stationary, steps), curves=curves)


def accuracy(stationary: Stationary | None, steps: Steps | None) -> dict:
    """The run's own cross-checks as its error estimate: steady state (3) against the stationary
    curve (9), eigenpair residuals of the stability check, and the step transients' closed form
    (4)-(7) against CVODES; the passage and Lewis integrations run at the solver options' ``rotor.tol`` with no
    second method."""
    tol = solver_options.get("rotor")["tol"]
    checks = {
        "steady_state_vs_eq9": stationary and stationary.steady_vs_eq9_max_rel_diff,
        "stability_eigen_residual": stationary and stationary.stability.max_eigenvalue_residual,
        "steps_closed_form_vs_cvodes": steps and steps.closed_form_vs_cvodes_max_rel_diff,
    }
    checks = {k: v for k, v in checks.items() if v is not None}
    how = (f"largest of the run's cross-checks ({', '.join(checks) or 'none in this scene'}); the passage, Lewis "
           f"and run-up integrations use CVODES at rtol = atol = {tol:g} and are bounded by that tolerance only")
    return {"estimate": max(checks.values(), default=tol), "how": how, **checks, "integration_tol": tol}
