"""The ``spinup`` analysis of a scene: the optimal spin-up profile beside the constant-ramp baselines.

``run(ocp, method)`` returns a :class:`SpinupResult` (the ``spinup`` block of results.json, CSV
tables and figures: omega(t), alpha(t), torque, deflection against time and against speed, the
optimum and both ramps on each plot).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from autobal.analysis.result import Result, new_figure
from autobal.ocp import drive_profile
from autobal.ocp.problem import SpinupOcp, pulse_variation
from autobal.ocp.simulation import (
    DRIVE_TOL,
    RESIM_POINTS,
    RESIM_TOL,
    Trajectory,
    baselines,
    best_within_limits,
    drive_use,
    torque_reference,
)
from autobal.ocp.solve import optimize
from autobal.ocp.transcription import DirectCollocation, MultipleShooting


@dataclass
class SpinupResult(Result):
    """The optimal spin-up profile beside the constant-ramp baselines (every peak re-simulated)."""

    data: dict  # the results.json block
    optimum: Trajectory
    baselines: dict  # key -> Trajectory
    segments: drive_profile.Segments | None = None
    name = "spinup"

    @property
    def peak_deflection(self) -> float:
        """Re-simulated peak deflection of the optimum over the horizon and the settling window, delta/e."""
        return self.data["peak_deflection_over_e"]

    @property
    def resimulation_rel_error(self) -> float:
        """Relative difference between the transcription's optimum and its CVODES re-simulation."""
        return self.data["resimulation_rel_error"]

    def to_dict(self) -> dict:
        return self.data

    def summary(self) -> str:
        d = self.data
        b = d["baselines"]
        lines = [f"spin-up OCP ({d['objective']}), {d['method']}: {d['status']}, {d['ipopt_iterations']} "
                 f"iterations in the final solve ({d['solve_time_s']:.2f} s)",
                 f"  times: {len(d['starts'])} starts and mesh stages {d['total_solve_time_s']:.2f} s ("
                 + ", ".join(f"{r['solve_time_s']:.2f}" for r in d["starts"] if "solve_time_s" in r)
                 + f" s), NLP build {d['build_time_s']:.2f} s, wall {d['wall_time_s']:.2f} s (with the global "
                 "search, re-simulations and baselines)",
                 "  wall time split: " + ", ".join(f"{k[:-7].replace('_', ' ')} {v:.2f} s" for k, v in
                                                   d.get("time_split", {}).items()),
                 f"  optimum: peak deflection {d['peak_deflection_over_e']:.4f} e (collocation "
                 f"{d['collocation_peak_over_e']:.4f} e, re-simulation difference {d['resimulation_rel_error']:.2e}),"
                 f" peak unbalance {d['peak_unbalance']:.4f}, final time {d['final_time_s']:.4g} s, chattering "
                 f"(pulse variation of alpha/alpha_max) {d['control_pulse_variation']:.3g}"]
        r = d["rotor"]
        lines.append(f"  rotor: m1 {r['mass_kg']:.4g} kg, c {r['stiffness_N_per_m']:.4g} N/m, chi "
                     f"{r['damping_N_s_per_m']:.4g} N s/m, e {r['eccentricity_m'] * 1e6:.4g} um; critical speed "
                     f"{r['critical_speed_rad_s'] * 30 / np.pi:.5g} rpm ({d['omega_cr_rad_s']:.4g} rad/s), damping "
                     f"ratio {r['damping_ratio']:.4g}; peak deflection {d['peak_deflection_m'] * 1e6:.4g} um (0-peak)")
        if r["amplification_factor"] is not None:
            lines.append(f"  API 684: amplification factor {r['amplification_factor']:.4g}, separation margin of the "
                         f"final speed {r['separation_margin_pct']:.3g} % from the critical speed")
        if d["min_torque_N_m"] is not None:
            brakes = {True: "brakes", False: "does not brake", None: "(no drive data)"}[d["brakes"]]
            lines.append(f"  braking: the optimum {brakes} (smallest torque {d['min_torque_N_m']:.4g} N m)")
        for k, v in b.items():
            lim = {True: "", False: " (outside the drive limits: " + ", ".join(v["violated"]) + ")",
                   None: ""}[v["within_drive_limits"]]
            ref = " [reference]" if k == d["baseline_ramp_key"] else ""
            lines.append(f"  {v['label']:40s} peak deflection {v['peak_deflection_over_e']:.4f} e, "
                         f"peak unbalance {v['peak_unbalance']:.4f}{lim}{ref}")
        if d["gain_vs_best_feasible_ramp_pct"] is not None:
            lines.append(f"  gain: {d['gain_vs_best_feasible_ramp_pct']:+.2f} % against the best ramp within the "
                         "drive limits" + ("" if d["gain_vs_constant_ramp_pct"] is None else
                                           f", {d['gain_vs_constant_ramp_pct']:+.2f} % against the constant ramp"))
        else:
            lines.append("  gain: no ramp baseline keeps the drive limits, so none is quoted")
        sg = d.get("segments")
        if sg:
            lines.append(f"  {sg['segments']}-segment ramp table: peak {sg['peak_deflection_over_e']:.4f} e, "
                         f"{sg['loss_vs_optimum_pct']:+.2f} % against the full optimum (searched from the "
                         f"{sg['start']} start)"
                         + ("" if sg["within_drive_limits"] else " (outside the drive limits)"))
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        o = self.optimum
        cols = {"t_s": next(iter(self.baselines.values())).t}
        for k, v in self.baselines.items():
            cols |= {f"{k}_omega_rad_s": v.omega, f"{k}_deflection_over_e": v.delta, f"{k}_unbalance_d": v.d}
        return {"spinup_optimum.csv": {"t_s": o.t, "omega_rad_s": o.omega, "deflection_over_e": o.delta,
                                       "unbalance_d": o.d, "torque_N_m": o.torque},
                "spinup_controls.csv": {"t_start_s": o.t_u, "alpha_rad_s2": o.alpha},
                "spinup_baselines.csv": cols, "drive_profile.csv": drive_profile.drive_table(o)} | (
            {} if self.segments is None else {"drive_segments.csv": self.segments.table(o.t[-1])})

    def _runs(self):
        base = [(v, c, "--" if self.data["baselines"][k]["within_drive_limits"] is not False else ":", 1.0)
                for (k, v), c in zip(self.baselines.items(), ("C0", "C2", "C1"), strict=False)]
        seg = [] if self.segments is None else [(self.segments.trajectory, "C4", "-.", 1.0)]
        return [(self.optimum, "C3", "-", 1.4), *seg, *base]

    def _label(self, tr) -> str:
        if tr is self.optimum:
            return "optimum"
        out = {v.label: k for k, v in self.baselines.items()}.get(tr.label)
        return tr.label + (" (outside the drive limits)" if out and
                           self.data["baselines"][out]["within_drive_limits"] is False else "")

    def _mm_axis(self, ax) -> None:
        """The deflection in mm on the right (delta = (delta/e) e), when the eccentricity is known."""
        e = self.data.get("eccentricity_m")
        if e:
            ax.secondary_yaxis("right", functions=(lambda d: d * e * 1e3, lambda mm: mm / (e * 1e3))).set_ylabel(
                f"deflection, mm 0-peak  (e = {e * 1e3:.3g} mm)")

    def draw(self, ax) -> None:
        """Deflection against time of the optimum and both ramps (delta/e, mm on the right)."""
        for tr, c, ls, lw in self._runs():
            lab = self._label(tr)
            ax.plot(tr.t, tr.delta, color=c, ls=ls, lw=lw, label=f"{lab} (peak {tr.peak_delta:.3f} e)")
        ax.set_xlabel("time t, s")
        ax.set_ylabel(r"deflection $\delta/e$")
        self._mm_axis(ax)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict:
        """Speed, acceleration (steps) and torque against time; deflection against time and speed."""
        title = self.data["title"]
        wc = self.data["omega_cr_rad_s"]
        fig, axes = new_figure((8, 8), 3, 1, sharex=True)
        for tr, c, ls, lw in self._runs():
            lab = self._label(tr)
            axes[0].plot(tr.t, tr.omega, color=c, ls=ls, lw=lw, label=lab)
            axes[1].plot(np.append(tr.t_u, tr.t[-1]), np.append(tr.alpha, tr.alpha[-1]), drawstyle="steps-post",
                         color=c, ls=ls, lw=lw)
            axes[2].plot(tr.t, tr.torque, color=c, ls=ls, lw=lw)
        axes[0].axhline(wc, color="k", lw=0.8, ls=":",
                        label=rf"critical speed $\omega_{{cr}} = \Omega_0\sqrt{{\psi}}$ = {wc:.4g} rad/s")
        axes[0].set_ylabel(r"speed $\omega$, rad/s")
        axes[1].set_ylabel(r"acceleration $\alpha$, rad/s$^2$")
        if self.data["drive_polar_inertia_kg_m2"] == 0:
            axes[2].set_ylabel("torque M, N m")
            axes[2].set_title("no drive data: the torque is the unbalance reaction only", fontsize=8, loc="left")
        else:
            axes[2].set_ylabel("drive torque M, N m")
        axes[2].set_xlabel("time t, s")
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.legend(loc="outside lower center", ncols=2, fontsize=7)
        fig.suptitle(title, fontsize=9)

        fig2, (a1, a2) = new_figure((8, 7), 2, 1)
        self.draw(a1)
        for tr, c, ls, lw in self._runs():
            a2.plot(tr.omega, tr.delta, color=c, ls=ls, lw=lw)
        a2.axvline(wc, color="k", lw=0.8, ls=":", label=rf"critical speed $\omega_{{cr}}$ = {wc:.4g} rad/s")
        a2.set_xlabel(r"speed $\omega$, rad/s")
        a2.set_ylabel(r"deflection $\delta/e$")
        self._mm_axis(a2)
        a2.grid(alpha=0.3)
        a2.legend(fontsize=7)
        fig2.suptitle(title, fontsize=9)
        return {"spinup_profiles.png": fig, "spinup_deflection.png": fig2}


def method_of(settings):
    if settings.method == "collocation":
        return DirectCollocation(settings.intervals, settings.degree, settings.scheme, settings.nlp_solver)
    return MultipleShooting(settings.intervals, settings.degree, settings.scheme)


def _pct(x: float, ref: float | None) -> float | None:
    return None if not ref else 100 * (x - ref) / ref


def run(ocp: SpinupOcp, method, title: str = "", multistart: bool = True, options: dict | None = None,
        segments: int = 0) -> SpinupResult:
    """Optimise (global search and multi-start), re-simulate, and compute the constant-ramp baselines.

    Parameters
    ----------
    ocp : SpinupOcp
        The declared problem (SI).
    method : DirectCollocation or MultipleShooting
        The transcription.
    title : str
        The scene's title (figures).
    multistart : bool
        Solve from several starts and keep the best re-simulated optimum.
    options : dict, optional
        IPOPT options (e.g. :func:`autobal.ocp.solve.ipopt_options`).
    segments : int
        Ramp segments of the drive's table (:func:`autobal.ocp.drive_profile.segment_profile`; 0: none, and none
        for the min_time objective).

    Returns
    -------
    SpinupResult
        The optimum's re-simulation beside the ramps; peaks in delta/e, times in s.
    """
    t0 = time.perf_counter()
    opt = optimize(ocp, method, multistart, options)
    t1 = time.perf_counter()
    base = baselines(ocp)
    t_base = time.perf_counter() - t1
    sol, tr = opt.solution, opt.trajectory
    use = {k: drive_use(ocp, v) for k, v in base.items()}
    # percentages refer only to the baselines the drive can run
    ref_key = best_within_limits({k: v.peak_delta for k, v in base.items()}, use)
    ref_peak = base[ref_key].peak_delta if ref_key else None
    t2 = time.perf_counter()
    seg = drive_profile.segment_profile(ocp, tr, segments) if segments and ocp.objective != "min_time" else None
    t_seg = time.perf_counter() - t2
    P = ocp.params
    zeta = P.chi / (2 * (P.c * P.m) ** 0.5)  # of the rotor with its liquid mass: u'' + 2 zeta w u' + w^2 u
    opt_use = drive_use(ocp, tr)
    rotor = {"mass_kg": P.m1, "stiffness_N_per_m": P.c, "damping_N_s_per_m": P.chi, "eccentricity_m": P.e,
             "liquid_mass_kg": P.m2_star, "critical_speed_rad_s": P.omega_cr, "damping_ratio": zeta,
             # API 684 (2005): AF = N_c/(N_2 - N_1) at the half-power points, 1/(2 zeta) for the linear rotor;
             # separation margin SM = |N_service - N_c|/N_c of the final (service) speed
             "amplification_factor": 1 / (2 * zeta) if zeta > 0 else None,
             "separation_margin_pct": 100 * abs(ocp.omega_final - P.omega_cr) / P.omega_cr,
             "amplitude_convention": "0-peak (the radius of the whirl orbit)"}
    data = {
        "title": title, "objective": ocp.objective, "method": method.label, "status": sol.status,
        "peak_deflection_over_e": tr.peak_delta,
        "baseline_ramp_peak_over_e": ref_peak, "baseline_ramp_key": ref_key,
        "gain_vs_best_feasible_ramp_pct": _pct(tr.peak_delta, ref_peak),
        "gain_vs_constant_ramp_pct": _pct(tr.peak_delta, base["constant_ramp"].peak_delta)
        if use["constant_ramp"]["within_drive_limits"] is not False else None,
        "peak_deflection_m": tr.peak_delta * P.e, "rotor": rotor,
        "resimulation_rel_error": opt.resimulation_rel_error,
        "solve_time_s": sol.solve_time_s,
        "ipopt_iterations": sol.iterations,
        "collocation_peak_over_e": sol.peak_collocation if ocp.objective != "peak_unbalance" else None,
        "objective_value": opt.score, "objective_value_transcription": opt.collocation_value,
        "peak_unbalance": tr.peak_d, "time_of_peak_s": tr.t_peak,
        # chattering of the optimal acceleration: the one-interval pulses' total variation (alpha/alpha_max)
        "control_pulse_variation": pulse_variation(sol.u[:method.intervals]),
        "omega_at_peak_rad_s": float(np.interp(tr.t_peak, tr.t, tr.omega)),
        "integral_deflection2_s": tr.integral_delta2, "final_time_s": sol.final_time_s,
        "build_time_s": opt.build_time_s, "total_solve_time_s": sum(r.get("solve_time_s", 0.0) for r in opt.starts),
        "wall_time_s": time.perf_counter() - t0,
        "starts": opt.starts, "baselines": {k: v.to_dict() | use[k] for k, v in base.items()},
        "psi": ocp.params.psi, "eccentricity_m": ocp.params.e,
        "omega_cr_rad_s": ocp.params.omega_cr, "Omega0_rad_s": ocp.params.Omega0,
        "zeta0": ocp.params.zeta0, "drive_polar_inertia_kg_m2": ocp.params.J_p, **opt_use,
        "braking_torque_limit_N_m": -ocp.torque_bounds[0] if np.isfinite(ocp.torque_bounds[0]) else None,
        # the optimum brakes when its smallest torque is below zero by more than the limit check's tolerance
        "brakes": None if opt_use["min_torque_N_m"] is None or P.J_p == 0 else
        bool(opt_use["min_torque_N_m"] < -DRIVE_TOL * torque_reference(ocp)),
        "accuracy": {"estimate": opt.resimulation_rel_error,
                     "how": "relative difference between the transcription's optimal objective and its CVODES "
                            f"re-simulation (rtol {RESIM_TOL:g}, {RESIM_POINTS} samples per interval)"},
    }
    outside = "no ramp baseline keeps the drive limits (each is labelled outside them): no gain is quoted"
    for key, why in (("braking_torque_limit_N_m", "no braking-torque limit: the scene names no drive limit"),
                     ("brakes", "unknown: the scene gives no drive inertia, so the optimum's torque is not known"),
                     ("baseline_ramp_peak_over_e", outside), ("baseline_ramp_key", outside),
                     ("gain_vs_best_feasible_ramp_pct", outside),
                     ("gain_vs_constant_ramp_pct", "the constant ramp is outside the drive limits: no gain is quoted")):
        if data[key] is None:
            data[f"{key}_status"] = why
    if ocp.objective == "peak_unbalance":
        data["collocation_peak_unbalance"] = opt.collocation_value
    if seg is not None:
        data["segments"] = {"segments": segments, "peak_deflection_over_e": seg.trajectory.peak_delta,
                            "peak_unbalance": seg.trajectory.peak_d, "objective_value": seg.objective,
                            "loss_vs_optimum_pct": _pct(seg.objective, opt.score),
                            "evaluations": seg.evaluations, "start": seg.start,
                            "start_objectives": seg.start_objectives, **seg.drive}
    # the wall time by part (s): what the global search, the initial guesses, the NLP builds, the IPOPT solves,
    # the CVODES re-simulations (reference ramp, ranking near-ties, the optimum) and the baselines took
    split = {"global_search": opt.times.get("global_search", 0.0), "guesses": opt.times.get("guesses", 0.0),
             "build": opt.build_time_s, "solve": data["total_solve_time_s"],
             "resimulation": opt.times.get("resimulation", 0.0), "baselines": t_base,
             "segments": t_seg}
    data["wall_time_s"] = time.perf_counter() - t0
    split["rest"] = data["wall_time_s"] - sum(split.values())
    data["time_split"] = {f"{k}_time_s": v for k, v in split.items()}
    return SpinupResult(data, tr, base, seg)
