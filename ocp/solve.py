"""Solving the transcribed spin-up problem: IPOPT from chosen starts (a cheap global search over
three-phase profiles, then the ramps), mesh continuation, and the CVODES re-simulation that judges
every optimum (the reported peak is the re-simulated one)."""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from autobal.analysis.numerics import ipopt
from autobal.analysis.run import forked, solver_options
from autobal.analysis.run.solver_options import ipopt_options  # noqa: F401 (the rooms' and tests' name)
from autobal.errors import SolveError
from autobal.models.rotor import RotorParams
from autobal.ocp.protocol import PEAK_KEY, SpinupProblem
from autobal.ocp.search import (
    FixedFrameModes,
    backoff_controls,
    backoff_search,
    controls_on_mesh,
    drive_rates,
    grid_search,
    horizon_steps,
    profile_peak,
)
from autobal.ocp.simulation import (
    Trajectory,
    initial_guess,
    ramp_profile,
    resimulate,
    simulate_profile,
)
from autobal.ocp.transcription import (
    DRIVE_TOL,
    DirectCollocation,
    Mesh,
    MultipleShooting,
    Nlp,
    complete_stage_guess,
    interpolate,
    mesh,
    on_uniform,
    point_times,
    structured_derivatives,
    transcribe,
    transcribe_stages,
)

if TYPE_CHECKING:  # the problem classes call this module (their starts, reference level and ranking)
    from autobal.ocp.problem import SpinupOcp

# the OCP's IPOPT options (the groups "spinup", "spinup_warm" for the fine stages of the mesh continuation,
# "spinup_coarse" and "fatrop"): analysis/run/solver_options.py, with the measurements that chose them
FATROP_STATUS = {0: "Solve_Succeeded", 1: "Maximum_Iterations_Exceeded"}  # fatrop's return flags

INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed")
TIE = 1e-4  # relative: optima closer than this are equal, the first start is kept


@dataclass
class SpinupSolution:
    """One IPOPT solve of one transcription."""

    method: str
    status: str
    success: bool
    iterations: int
    solve_time_s: float
    build_time_s: float
    objective: float  # the NLP's objective in problem units (delta/e, d, integral (s), or T (s))
    final_time_s: float
    u: np.ndarray  # control intervals (over alpha_max), settling window included (zeros)
    h: np.ndarray  # interval lengths, tau
    points: np.ndarray  # (K, npath, nx) states at the path points (collocation or shooting outputs)
    peak_collocation: float  # largest delta/e at the path points (or d for peak_unbalance; m for the modal rotor)
    w: np.ndarray = field(repr=False, default=None)
    lam_g: np.ndarray = field(repr=False, default=None)  # IPOPT's multipliers of the constraints
    lam_x: np.ndarray = field(repr=False, default=None)  # and of the variable bounds
    guess_time_s: float = 0.0  # simulating the initial guess (s)


def _objective_value(ocp: SpinupOcp, nlp: Nlp, wopt: np.ndarray, f: float) -> float:
    if ocp.objective in ("peak_deflection", "peak_unbalance"):
        return math.sqrt(max(f, 0.0) * nlp.ref) * ocp.epigraph_unit
    if ocp.objective == "min_time":
        return f * ocp.horizon
    return f * nlp.ref / ocp.Om


def _points(nlp: Nlp, wopt: np.ndarray, ocp: SpinupOcp) -> np.ndarray:
    if nlp.index["Xc"] is not None:
        pts = wopt[nlp.index["Xc"]]
        if len(nlp.fractions) > nlp.method.degree:
            pts = np.concatenate([pts, wopt[nlp.index["X"][1:]][:, None, :]], axis=1)
        return pts
    u, h = _controls(nlp, wopt, ocp)
    return simulate_profile(ocp, u, h, nlp.fractions, tol=nlp.method.tol)  # = the shooting outputs


def _controls(nlp: Nlp, wopt: np.ndarray, ocp: SpinupOcp) -> tuple[np.ndarray, np.ndarray]:
    ms = nlp.mesh
    if not ocp.free_time:
        return wopt[nlp.index["u"]], ms.lengths
    hn = wopt[nlp.index["v"][0]] * ocp.tau_h / ms.n
    return wopt[nlp.index["u"]], np.concatenate([np.full(ms.n, hn), np.full(ms.ns, ms.hs)])


def reference_level(ocp: SpinupOcp) -> float:
    """Scale of the objective (the maximum-acceleration ramp's peak squared, or its integral of delta^2; 1 for
    min_time)."""
    if ocp.objective not in ("peak_deflection", "peak_unbalance", "integrated_deflection"):
        return 1.0
    # BDF restarted at every interval, as the guesses: the NLP's scale to the last bit (the robust study's
    # optimum moves by 0.5 % when its start moves by 1e-7)
    base = resimulate(ocp, ramp_profile(ocp, 50, ocp.alpha_max), np.full(50, ocp.tau_h / 50), "ref", 8, 1e-8,
                      "bdf", merge=False)
    return {"peak_deflection": base.peak_delta**2, "peak_unbalance": base.peak_d**2,
            "integrated_deflection": base.integral_delta2 * ocp.Om}[ocp.objective]


class Solver:
    """The NLP of one (problem, method) pair, built once and solved from any guess."""

    def __init__(self, ocp: SpinupOcp, method, ref: float | None = None, options: dict | None = None,
                 warm: bool = False, mesh: Mesh | None = None, brake_tol: float = DRIVE_TOL):
        t0 = time.perf_counter()
        self.ocp, self.method = ocp, method
        # MX: the interval Function mapped over the intervals, so the construction hardly grows with N
        # (SX: 1.7 s at N = 200; benchmarks/spinup_ocp.md, "Levers")
        ref = ocp.reference_level() if ref is None else ref
        if getattr(method, "solver", "ipopt") == "fatrop":
            self.nlp = transcribe_stages(ocp, method, ref, mesh, brake_tol)
            self.solver = fatrop_solver(self.nlp, options)
            self.build_time_s = time.perf_counter() - t0
            return
        self.nlp = transcribe(ocp, method, ref, "MX", mesh, brake_tol)
        nlp = self.nlp
        extra = solver_options.get("spinup") | (solver_options.get("spinup_warm") if warm else {}) | (options or {})
        if isinstance(method, MultipleShooting):
            extra["hessian_approximation"] = method.hessian
        # collocation: the Jacobian and Hessian from the interval Function's SX derivatives, mapped
        derivatives = structured_derivatives(nlp) if nlp.intervals is not None else {}
        self.solver = ipopt.nlpsol("spinup", nlp.x, ca.SX.sym("p", 0) if isinstance(nlp.x, ca.SX) else ca.MX.sym(
            "p", 0), nlp.f, nlp.g, **derivatives, **extra)
        self.build_time_s = time.perf_counter() - t0

    def solve(self, u_guess: np.ndarray | None = None, w0: np.ndarray | None = None, raise_on_failure=True,
              hold_states: bool = False, lam_g0: np.ndarray | None = None,
              lam_x0: np.ndarray | None = None, bounds: dict | None = None) -> SpinupSolution:
        """One IPOPT solve from the control profile ``u_guess`` (over alpha_max, the n control intervals;
        the states simulated from it) or from the full NLP guess ``w0``.  ``hold_states``: the
        collocation states start at the interval-start values (rockit's guess) instead of the simulated
        ones: from a coarse mesh this reaches a better basin (measured in benchmarks/spinup_ocp.md).
        ``lam_g0``, ``lam_x0``: initial multipliers (with ``w0``; a solver built with ``warm=True`` uses them).
        ``bounds``: any of ``lbx``, ``ubx``, ``lbg``, ``ubg`` for this solve instead of the NLP's (e.g. a
        tightened limit row), used by the error message too."""
        ocp, nlp = self.ocp, self.nlp
        if bounds:
            nlp = dataclasses.replace(nlp, **bounds)
        t0 = time.perf_counter()
        if w0 is None:
            if u_guess is None:
                u_guess = ramp_profile(ocp, nlp.mesh.n, ocp.alpha_max if ocp.free_time else
                                       (ocp.omega_final - ocp.omega_start) / ocp.horizon)
            w0 = initial_guess(ocp, nlp, u_guess)
            if hold_states and nlp.index["Xc"] is not None:
                w0[nlp.index["Xc"]] = w0[nlp.index["X"]][:-1, None, :]
        t_guess = time.perf_counter() - t0
        t0 = time.perf_counter()
        duals = {k: v for k, v in (("lam_g0", lam_g0), ("lam_x0", lam_x0)) if v is not None and nlp.stages is None}
        r = ipopt.solve(self.solver, x0=complete_stage_guess(nlp, w0), lbx=nlp.lbx, ubx=nlp.ubx, lbg=nlp.lbg,
                        ubg=nlp.ubg, **duals)
        if nlp.stages is not None:
            r["status"] = FATROP_STATUS.get(r["status"], f"fatrop return flag {r['status']}")
        dt = time.perf_counter() - t0
        wopt = r["x"]
        if not r["success"] and raise_on_failure:
            raise infeasibility_error(ocp, nlp, wopt, r)
        u, h = _controls(nlp, wopt, ocp)
        pts = _points(nlp, wopt, ocp)
        pk = float(np.sqrt(np.max(ocp.epigraph2(pts)))) * ocp.epigraph_unit
        return SpinupSolution(self.method.label, r["status"], r["success"], r["iterations"], dt, self.build_time_s,
                              _objective_value(ocp, nlp, wopt, float(r["f"][0])), float(np.sum(h[:nlp.mesh.n]))
                              / ocp.Om, u, h, pts, pk, wopt, r["lam_g"], r["lam_x"], t_guess)


def fatrop_solver(nlp: Nlp, options: dict | None = None) -> ca.Function:
    """fatrop (through CasADi, structure given stage by stage) for the stage form ``nlp``; of ``options`` (IPOPT's
    names, as :func:`ipopt_options` writes them) it takes ``tol``, ``max_iter`` and ``mu_init``."""
    spinup = solver_options.get("spinup")
    opts = {"print_level": 0, "tol": spinup["tol"], "max_iter": spinup["max_iter"]} | solver_options.get("fatrop") | {
        k: v for k, v in (options or {}).items() if k in ("tol", "max_iter", "mu_init")}
    return ca.nlpsol("spinup", "fatrop", {"x": nlp.x, "p": ca.MX.sym("p", 0), "f": nlp.f, "g": nlp.g},
                     {"structure_detection": "manual", **nlp.stages, "fatrop": opts, "print_time": False,
                      # CasADi's fatrop plugin takes no user derivatives (IPOPT's hess_lag, jac_g), so the stage
                      # form is expanded to SX and differentiated whole: builds of 1.1 / 3.4 / 11 s at 200 / 400 /
                      # 800 intervals; the MX derivatives of the mapped stage instead cost 3x more per evaluation
                      # (benchmarks/spinup_ocp.md, "fatrop")
                      "record_time": True, "expand": True})


def infeasibility_error(ocp: SpinupOcp, nlp: Nlp, wopt: np.ndarray, r: dict) -> SolveError:
    """A SolveError naming the real cause (infeasible, iteration limit, restoration failure); for an
    infeasible problem the binding constraint (the drive limit active on most of the horizon at the last
    iterate: acceleration bound, torque, power, motor, speed limit) and the final-speed condition it
    prevents; the constraint blocks the last iterate violates; the last iterate goes with it (the CLI
    saves it)."""
    g = np.asarray(r["g"]).ravel()
    viol = np.maximum(np.maximum(nlp.lbg - g, g - nlp.ubg), 0.0)
    u, h = _controls(nlp, wopt, ocp)
    n = nlp.mesh.n
    X = wopt[nlp.index["X"]]
    nu = X[:, ocp.speed_index]
    active = {f"acceleration limit |alpha| <= {ocp.alpha_max:g} rad/s^2": float(np.mean(np.abs(u[:n]) > 1 - 1e-6))}
    if ocp.omega_max is not None:
        active[f"speed limit omega <= {ocp.omega_max:g} rad/s"] = float(np.mean(nu[1:] * ocp.Om >
                                                                              ocp.omega_max * (1 - 1e-6)))
    for name, rows in nlp.blocks:
        if "limit" in name or "characteristic" in name:
            gap = np.minimum(g[rows] - nlp.lbg[rows], nlp.ubg[rows] - g[rows])
            active[name] = float(np.mean(gap < 1e-6))
    binding = max(active, key=active.get)
    status, its = r["status"], r.get("iterations", -1)
    cause = {"Infeasible_Problem_Detected": "infeasible (IPOPT detected locally infeasible constraints)",
             "Restoration_Failed": "IPOPT's restoration phase failed (no feasible point found from this start)",
             "Maximum_Iterations_Exceeded": f"iteration limit reached ({its} iterations; raise max_iterations)",
             "Maximum_CpuTime_Exceeded": "time limit reached"}.get(status, f"not solved ({status})")
    parts = [f"spin-up OCP {cause} ({nlp.method.label})"]
    # the binding constraint is named only when it binds: a drive limit active on most of the horizon
    # of a problem the solver found infeasible
    if status in INFEASIBLE and active[binding] > 0.5:
        parts.append(f"binding constraint: {binding}, active on {100 * active[binding]:.0f} % of the horizon, "
                     f"prevents the final speed omega(T) = {ocp.omega_final:g} rad/s")
        if binding.startswith("acceleration"):
            parts.append(f"alpha_max x horizon = {ocp.alpha_max * ocp.horizon:.4g} rad/s of speed change, "
                         f"{abs(ocp.omega_final - ocp.omega_start):.4g} rad/s needed")
        else:
            parts.append(f"the last iterate ends at omega = {nu[n] * ocp.Om:.4g} rad/s")
    bad = [(name, float(viol[rows].max(initial=0.0))) for name, rows in nlp.blocks]
    bad = [f"'{k}' by {v:.3g}" for k, v in bad if v > 1e-6]
    if bad:
        parts.append("the last iterate violates " + ", ".join(bad))
    last = {"t_s": list(np.concatenate([[0.0], np.cumsum(h)]) / ocp.Om), "omega_rad_s": list(nu * ocp.Om),
            **ocp.deflection_of(X), "alpha_rad_s2": list(u * ocp.alpha_max),
            "constraint_violation": {name: float(viol[rows].max(initial=0.0)) for name, rows in nlp.blocks},
            "active_fraction": active}
    return SolveError("; ".join(parts), r["status"], last)


def starts(ocp: SpinupOcp, n: int, multistart: bool = True) -> list[tuple[str, np.ndarray]]:
    """Initial control profiles on the n control intervals.

    For a peak objective with a fixed deadline, the two best profiles of the grid over three-phase profiles
    (:func:`autobal.ocp.search.grid_search`: its partial-rate middle phase wins on the liquid balancer) come first,
    then the best profile of each back-off family the problem's numbers choose (:func:`backoff_families`,
    :func:`autobal.ocp.search.backoff_search`); without ``multistart`` only the best of these.  Then the constant
    ramp, and with ``multistart`` the maximum-acceleration ramp with hold, a faster constant ramp, and a piecewise
    ramp that holds below the critical speed.  For the peak deflection the three constant ramps are left out after
    the back-off search, and after the grid alone when its best profile is AHEAD (relative) below each of their
    peaks (the exponential integrator): on the issue-35 family (benchmarks/spinup_family.py) their optima were
    never the best (docs/dev/spinup.md); the ramp that holds below the critical speed, a structure outside the
    searched families, stays.  For the integrated objective the late ramp (:func:`late_ramp`: a hold at the start
    speed, then the drive's full rate) replaces the three constant ramps where there is slack for it."""
    const = abs(ocp.omega_final - ocp.omega_start) / ocp.horizon
    out, lead, families = [], None, []
    if ocp.objective in ("peak_deflection", "peak_unbalance") and horizon_steps(ocp) <= SEARCH_STEPS:
        families = backoff_families(ocp)
        # the grid and the back-off searches are independent: shared with a forked process (analysis/run/forked.py)
        searches = [functools.partial(grid_search, ocp, keep=2 if multistart else 1)] + [
            functools.partial(backoff_search, ocp, k, above) for k, above in families]
        found, *backoffs = forked.shared(lambda i: searches[i](), len(searches))
        out += [(f"global search: {p[0] * ocp.alpha_max:.3g} rad/s^2 to {p[1]:.4g} rad/s, {p[2] * ocp.alpha_max:.3g} "
                 f"rad/s^2 for {p[3]:.3g} s, then {ocp.alpha_max:.3g} rad/s^2 (peak {pk:.4g} e)",
                 controls_on_mesh(ocp, p, n)) for p, pk in zip(found.params, found.peaks, strict=True)]
        peaks = list(found.peaks)
        edges = np.linspace(0.0, ocp.horizon, n + 1)
        for (k, above), (x, pk, _) in zip(families, backoffs, strict=True):
            out.append((f"back-off search: {k} back-off{'s' if k > 1 else ''}, the first excursion "
                        f"{'above' if above else 'below'} the critical speed (peak {pk:.4g} e)",
                        backoff_controls(ocp, x[None], k, edges)[0]))
            peaks.append(pk)
        if not multistart and out:  # the search's best profile alone
            out = [out[int(np.argmin(peaks))]]
        if ocp.objective == "peak_deflection" and peaks and multistart:
            lead = min(peaks)
    ramps = [("constant ramp", ramp_profile(ocp, n, min(const, ocp.alpha_max) if not ocp.free_time
                                            else ocp.alpha_max))]
    if multistart:
        ramps.append(("maximum-acceleration ramp and hold", ramp_profile(ocp, n, ocp.alpha_max)))
        if not ocp.free_time:
            ramps.append(("ramp at the mean of both", ramp_profile(ocp, n, 0.5 * (const + ocp.alpha_max))))
    late = late_ramp(ocp, n) if ocp.objective == "integrated_deflection" else None
    if late is not None:  # the integrated objective: the late ramp instead of the three ramps
        out.append(late)
    elif not (lead is not None and families) and (
            lead is None or AHEAD <= 0 or min(profile_peak(ocp, u) for _, u in ramps) * (1 - AHEAD) < lead):
        out += ramps
    if multistart and not ocp.free_time:
        w_hold = 0.8 * ocp.params.omega_cr
        # the second ramp at the acceleration the drive still has at the final speed: at alpha_max past a
        # drive limit the start ends short of omega_final (the liquid balancer's took 200 IPOPT iterations
        # without converging); with the drive-limited ramp the liquid balancer has no time left to hold
        # (8.3 s needed of the 8.5 s horizon) and the start is left out (benchmarks/spinup_ocp.md)
        a2 = drive_acceleration(ocp, ocp.omega_final)
        t_need = (w_hold - ocp.omega_start) / ocp.alpha_max + (ocp.omega_final - w_hold) / a2
        if ocp.omega_start < w_hold < ocp.omega_final and t_need < 0.9 * ocp.horizon:
            out.append(("ramp, hold at 0.8 omega_cr, ramp", ramp_profile(ocp, n, ocp.alpha_max, hold_at=w_hold,
                                                                         accel2=a2)))
    return out


def late_ramp(ocp: SpinupOcp, n: int) -> tuple[str, np.ndarray] | None:
    """The integrated objective's start on n control intervals: hold at the start speed, then the drive's full rate
    (:func:`drive_acceleration` at each speed) so as to reach omega_final at the deadline; None without slack for a
    hold (or for a free final time or a spin-down).  (delta/e)^2 grows with the speed below the critical and stays
    above 1 above it, so the integral's optimum spends the slack at the lowest speed and crosses late at the
    drive's rate (on ``spinup_rotor_datasheet`` a 2 s hold at 600 rpm).  From the three constant ramps the coarse
    solves of that scene stop at their 200-iteration cap (docs/dev/spinup.md, "The integrated objective on long
    windows")."""
    if ocp.free_time or ocp.omega_final <= ocp.omega_start:
        return None
    steps = 20 * n  # the full-rate climb integrated back from omega_final at the deadline (explicit Euler)
    dt, w = ocp.horizon / steps, [ocp.omega_final]
    while w[-1] > ocp.omega_start and len(w) <= steps:
        w.append(w[-1] - drive_acceleration(ocp, w[-1]) * dt)
    if len(w) > steps:
        return None
    t = ocp.horizon - dt * np.arange(len(w))[::-1]
    omega = np.interp(np.linspace(0.0, ocp.horizon, n + 1), t, np.maximum(w[::-1], ocp.omega_start),
                      left=ocp.omega_start)
    u = np.clip(np.diff(omega) / (ocp.horizon / n) / ocp.alpha_max, -1, 1)
    return f"hold at the start speed for {t[0]:.3g} s, then the drive's full rate", u


def backoff_families(ocp: SpinupOcp) -> list[tuple[int, bool]]:
    """The back-off families the global search covers (:func:`autobal.ocp.search.backoff_search`), as (back-offs,
    whether the first excursion ends above the critical speed), chosen by the problem's own numbers: none without
    slack (the deadline leaves no time beyond the ramp's at the drive's full rate, :func:`drive_rates`); one
    back-off, and two when the slack is at least two natural periods 2 pi/omega_cr (each back-off and the climb
    back take about one); the first excursion below the critical speed when the start is below it, above it when
    the top speed is above it (the lightly damped rotors of the shipped scenes win with a back-off just above or
    below the critical speed, the heavily damped rotor of issue 35 from below)."""
    a, wc = drive_rates(ocp)[0], ocp.params.omega_cr
    slack = ocp.horizon - (ocp.omega_final - ocp.omega_start) / a if a > 0 else -1.0
    top = ocp.omega_final if ocp.omega_max is None else min(ocp.omega_final, ocp.omega_max)
    if ocp.free_time or slack <= 0 or ocp.omega_final <= ocp.omega_start:
        return []
    sides = [s for s, ok in ((False, ocp.omega_start < wc), (True, wc < top)) if ok]
    counts = (1, 2) if slack >= 2 * (2 * np.pi / wc) else (1,)
    return [(k, s) for k in counts for s in sides]


def drive_acceleration(ocp: SpinupOcp, omega: float) -> float:
    """The largest acceleration the drive sustains at the speed ``omega``: alpha_max, and the torque,
    power and motor-characteristic limits over the drive's inertia J_p + m1 e^2 (1 - psi) (the torque
    equation of :mod:`autobal.models.rotor` without its drag and unbalance terms).

    Parameters
    ----------
    ocp : SpinupOcp
        The declared problem (its drive limits).
    omega : float
        Speed, rad/s.

    Returns
    -------
    float
        Acceleration, rad/s^2.
    """
    inertia = ocp.inertia
    torque = [t for t in (ocp.torque_max, ocp.power_max / omega if ocp.power_max else None,
                          ocp.motor_stall_torque * (1 - omega / ocp.motor_no_load_speed)
                          if ocp.motor_stall_torque else None) if t is not None]
    return min([ocp.alpha_max] + ([t / inertia for t in torque] if inertia > 0 else []))


SEARCH_STEPS = 20000  # longer passages (quasi-static, thousands of whirl periods) skip the global search
# Mesh continuation, the one used by every spin-up study (Jeffcott, liquid balancer, the modal rotor, the robust
# NLP): the starts are solved on N / 2^k control intervals, the fewest still at least COARSE, and the best coarse
# optimum is refined by doubling (:func:`refine`).  On the shipped modal scene (160 intervals) the coarse mesh is
# 80, which leads to the optimum the 160-interval mesh reaches from all its starts (19.57 um; 40 coarse intervals
# lead to a worse one, 20.45 um).
COARSE = 50
AHEAD = 0.05  # the constant ramps are not solved when the search's best is this far below them
RANK_TIE = 2e-3  # relative: coarse optima this close to the best by the fast integrator are ranked by CVODES


def coarse_intervals(n: int) -> int:
    """The control intervals of the coarse stage of the mesh continuation: N / 2^k, the fewest that are still at
    least COARSE (N itself when it is already that coarse)."""
    while n % 2 == 0 and n // 2 >= COARSE:
        n //= 2
    return n


def coarse_options(options: dict | None) -> dict:
    """IPOPT options of a coarse-stage solve: the iteration limit capped at the solver option spinup_coarse.max_iter."""
    cap = min(int((options or {}).get("max_iter", solver_options.defaults["spinup.max_iter"])),
              solver_options.defaults["spinup_coarse.max_iter"])
    return (options or {}) | {"max_iter": cap}


def coarse_solver(ocp: SpinupOcp, method, ref: float, options: dict | None) -> Solver | None:
    """The coarse stage of the mesh continuation (:func:`coarse_intervals`), or None when N is already that
    coarse.  Every start is solved there and only the best is refined (with a single start the fine mesh is
    solved directly)."""
    if not isinstance(method, DirectCollocation) or ocp.free_time:
        return None
    n = coarse_intervals(method.intervals)
    if n == method.intervals:
        return None
    # the screening is solved without the total-variation regulariser (the refined stages keep it): with it the
    # heavily damped rotor's coarse solves stop at the iteration cap from 7 of 10 starts, without it all converge
    # in 20-133 iterations (docs/dev/spinup.md, "Screening without the regulariser")
    screen = dataclasses.replace(ocp, jerk_variation=0.0) if getattr(ocp, "jerk_variation", 0.0) else ocp
    # and with the no-braking limit of the settling window as stated (the answer's NLP keeps it to DRIVE_TOL,
    # transcription.relax_settling_brake): screened with it relaxed, the datasheet rotor of the family refines from
    # another start to 20.2049 e instead of 20.1954 e (docs/dev/spinup.md, "Where torque_no_brake's basin is lost")
    return Solver(screen, dataclasses.replace(method, intervals=n), ref, coarse_options(options), brake_tol=0.0)


def on_coarse(u: np.ndarray, nc: int) -> np.ndarray:
    """A control profile over the horizon's intervals (any number) on ``nc`` coarse intervals: averaged over each
    when they divide evenly, else interpolated."""
    return u.reshape(nc, -1).mean(axis=1) if u.size % nc == 0 else np.interp(
        np.linspace(0, 1, nc), np.linspace(0, 1, u.size), u)


def screen(ocp: SpinupProblem, solver: Solver, profiles: list[np.ndarray], twin) -> list[SpinupSolution]:
    """Each control profile (over the horizon's intervals, any number) averaged onto the coarse mesh of ``solver`` and
    solved there (never raising on a failed solve), in order.  The profiles are shared with a forked process
    (analysis/run/forked.py: IPOPT's MUMPS takes a lock that a process's threads share), which solves on a copy of the
    NLP it builds with ``twin()`` (each solver has its IPOPT log file).  A solve depends on its start alone, so the
    solutions are those of one solver taking the profiles one after another, bit for bit."""
    guesses = [on_coarse(u, solver.nlp.mesh.n) for u in profiles]
    own = []  # the helper's solver

    def solve(s: Solver, i: int) -> SpinupSolution:
        return s.solve(guesses[i], raise_on_failure=False, hold_states=ocp.hold_states)

    def helper(i: int) -> SpinupSolution:
        if not own:
            own.append(twin())
        return solve(own[0], i)

    return forked.shared(functools.partial(solve, solver), len(guesses), helper)


def rank_coarse(ocp: SpinupOcp, found: list, n: int) -> tuple[int, dict[int, float]]:
    """The best of the coarse optima ``found`` ((label, solution) pairs, in start order, ``n`` control
    intervals): its index, and the objective re-simulated by CVODES of those it was judged by (by index).

    For the peak deflection the fixed-step exponential integrator (:func:`autobal.ocp.search.profile_peak`,
    step FAST_STEP: the peak within 1e-4 of CVODES) ranks them; those within RANK_TIE of its best, and the
    optima of every other objective, are re-simulated by CVODES (rtol 1e-10) and the smallest wins (ties:
    the earlier start).  Only the winner is refined and re-simulated at the resimulation.tol solver option."""
    close = list(range(len(found)))
    if ocp.objective == "peak_deflection" and horizon_steps(ocp) <= SEARCH_STEPS:
        rotor = FixedFrameModes.of(ocp)
        fast = [profile_peak(ocp, sol.u[:n], rotor=rotor) for _, sol in found]
        close = [i for i, f in enumerate(fast) if f <= min(fast) * (1 + RANK_TIE)]
    if len(close) == 1:
        return close[0], {}
    scores = {i: resimulated_scores(ocp, found[i][1], resimulate(ocp, found[i][1].u, found[i][1].h, "coarse", 8,
                                                                 1e-10))[0] for i in close}
    return min(scores, key=scores.get), scores


FALLBACK = 0.01  # relative: a refined optimum this far above its coarse profile's peak sends the next one too


def fell_back(ocp, coarse_u: np.ndarray, fine_u: np.ndarray) -> bool:
    """Whether the mesh continuation ended more than FALLBACK above the coarse profile it started from, both
    judged by the exponential integrator (the Jeffcott rotor's peak deflection only; another problem: False).  The
    coarse collocation keeps the drive limits at its points only, so its profile may promise a peak the fine mesh
    cannot keep: on a torque-limited rotor without braking (benchmarks/spinup_family.py, ``torque_no_brake``) the
    coarse winner re-simulated at 11.41 e and refined to 11.98 e in 381 + 914 iterations (measured cause: the
    no-braking limit at the settling window's points, where the speed is held; docs/dev/spinup.md, "Where
    torque_no_brake's basin is lost")."""
    if not fast_judged(ocp):
        return False
    return profile_peak(ocp, fine_u) > profile_peak(ocp, coarse_u) * (1 + FALLBACK)


def fast_judged(ocp) -> bool:
    """Whether the exponential integrator judges the problem's profiles in the search policy (:func:`fell_back`,
    :func:`another_basin`, :func:`moved`): the Jeffcott rotor's peak deflection over at most SEARCH_STEPS steps."""
    return ocp.objective == "peak_deflection" and isinstance(getattr(ocp, "params", None), RotorParams) \
        and horizon_steps(ocp) <= SEARCH_STEPS


REFINED = 3  # coarse optima refined at most
SAME = 1e-5  # relative: coarse optima this close by the exponential integrator are one basin


def another_basin(ocp, refined: list, coarse_u: np.ndarray, spread: float) -> bool | None:
    """Whether the coarse profile ``coarse_u`` is worth refining beside the coarse profiles ``refined`` (the Jeffcott
    rotor's peak deflection only; another problem: False): True when its peak by the exponential integrator is
    within ``spread`` (relative) of the best of theirs, None when it is within SAME of one of them (the same basin),
    else False.  The study passes as ``spread`` how far the refinements so far moved from their coarse profiles when
    that is more than FALLBACK: the coarse ranking is trusted to that much.  On the liquid balancer the refinement
    moves 2.8 % and the third coarse optimum (0.33 % above the best) refines to 4.98965 e, the best two to 4.99276
    and 5.00248 e; on the Jeffcott deadline scene it moves 1e-6, on damped_issue35 0.7 % (docs/dev/spinup.md)."""
    if not refined or not fast_judged(ocp):
        return False
    rotor = FixedFrameModes.of(ocp)
    pk, done = profile_peak(ocp, coarse_u, rotor=rotor), [profile_peak(ocp, u, rotor=rotor) for u in refined]
    if any(abs(pk - d) <= SAME * d for d in done):
        return None
    return pk <= min(done) * (1 + spread)


def moved(ocp, coarse_u: np.ndarray, fine_u: np.ndarray) -> float:
    """How far (relative) a mesh continuation moved from its coarse profile, both by the exponential integrator (the
    Jeffcott rotor's peak deflection only; another problem: 0)."""
    if not fast_judged(ocp):
        return 0.0
    return abs(profile_peak(ocp, fine_u) / profile_peak(ocp, coarse_u) - 1)


@dataclass
class Optimum:
    """The best of the multi-start solves, judged by its CVODES re-simulation."""

    ocp: SpinupOcp
    solution: SpinupSolution
    trajectory: Trajectory  # the re-simulation of the optimal profile
    score: float  # the re-simulated objective (delta/e, d, integral (s) or T (s))
    starts: list  # one dict per start
    collocation_value: float  # the transcription's own value of the same measure
    build_time_s: float
    times: dict = field(default_factory=dict)  # wall time (s) by part: global_search, guesses, resimulation

    @property
    def resimulation_rel_error(self) -> float:
        return abs(self.collocation_value - self.score) / abs(self.score)


def resimulated_scores(ocp: SpinupOcp, sol: SpinupSolution, tr: Trajectory) -> tuple[float, float]:
    """(re-simulated measure, the transcription's value of the same measure)."""
    if ocp.objective == "peak_unbalance":
        return tr.peak_d, sol.peak_collocation
    if ocp.objective == "integrated_deflection":
        return tr.integral_delta2, sol.objective
    if ocp.objective == "min_time":
        return sol.final_time_s, sol.final_time_s
    return tr.peak, sol.peak_collocation


# The graded mesh of the mesh continuation (:func:`grading`): the intervals within GRADE_NEAR of the horizon of a
# switch of the coarse optimum's control or of a point where its deflection is near its peak GRADE_RATIO times
# denser than the rest, none longer than GRADE_LONGEST times the uniform one (docs/dev/spinup.md, "The graded mesh")
GRADE_RATIO, GRADE_NEAR, GRADE_LONGEST = 2.0, 0.05, 2.0
SWITCH = 0.1  # a change of the coarse control (over alpha_max) this large between two intervals is a switch
NEAR_PEAK = 0.99  # a coarse point whose deflection is this close to the coarse peak (relative) is near it


def equidistributed(density, tau_h: float, n: int, longest: float) -> np.ndarray:
    """n interval lengths over tau_h / n (summing to n), each inversely proportional to ``density`` (a function of tau
    on [0, tau_h], positive): the nodes equidistribute its integral, the density first raised to 1/``longest`` of its
    mean wherever it is lower, so that no interval is longer than about ``longest`` times tau_h / n."""
    t = np.linspace(0.0, tau_h, 64 * n + 1)
    rho = np.asarray(density(t), float)
    for _ in range(50):
        floor = np.trapezoid(rho, t) / tau_h / longest
        if rho.min() >= floor * (1 - 1e-9):
            break
        rho = np.maximum(rho, floor)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (rho[1:] + rho[:-1]) * np.diff(t))])
    g = np.diff(np.interp(np.linspace(0.0, cum[-1], n + 1), cum, t)) / (tau_h / n)
    return g * (n / g.sum())


def grading(ocp: SpinupOcp, coarse: Nlp, sol: SpinupSolution, n: int) -> np.ndarray | None:
    """The grading of n control intervals (:func:`autobal.ocp.transcription.mesh`) from the coarse optimum ``sol``:
    GRADE_RATIO times denser within GRADE_NEAR of the horizon of each switch of its control (a change of more than
    SWITCH between two coarse intervals) and of each of its points on the horizon whose deflection is within
    NEAR_PEAK of its peak, at most GRADE_LONGEST times the uniform interval elsewhere.  None (uniform) for a free
    final time, a coarse optimum without switches, or a problem other than the Jeffcott rotor's (the modal rotor
    keeps its uniform mesh)."""
    if ocp.free_time or not isinstance(getattr(ocp, "params", None), RotorParams):
        return None
    nc = coarse.mesh.n
    t0, _, tc = point_times(coarse)
    switches = t0[1:nc][np.abs(np.diff(sol.u[:nc])) > SWITCH]
    if not switches.size:
        return None
    d2 = ocp.epigraph2(sol.points[:, :tc.shape[1]])  # (K, d): the deflection squared at the collocation points
    at = np.concatenate([switches, tc[:nc][d2[:nc] >= NEAR_PEAK**2 * d2.max()]])

    def density(t):
        return np.where(np.min(np.abs(t[:, None] - at[None, :]), axis=1) <= GRADE_NEAR * ocp.tau_h, GRADE_RATIO, 1.0)

    return equidistributed(density, ocp.tau_h, n, GRADE_LONGEST)


def refine(ocp: SpinupOcp, method, coarse: Solver, sol: SpinupSolution, options: dict | None, rows: list,
           built: dict | None = None, graded: bool = False) -> tuple[Solver, SpinupSolution]:
    """Mesh continuation from the coarse optimum ``sol`` to ``method``'s mesh by doubling the intervals;
    each stage starts from the previous optimum and its multipliers (:func:`interpolate`) with a small
    barrier parameter.  Returns the finest stage's solver and solution (a failed last stage raises).  ``built``: the
    stages' solvers by intervals, kept across the refinements of one study (a stage built before has no build
    time in its row)."""
    prev, n, first = coarse, coarse.nlp.mesh.n, sol
    built = {} if built is None else built
    while n < method.intervals:
        n *= 2
        g = grading(ocp, coarse.nlp, first, n) if graded else None
        key = n if g is None else (n, g.tobytes())
        new = key not in built
        if new:
            built[key] = Solver(ocp, dataclasses.replace(method, intervals=n), prev.nlp.ref, options, warm=True,
                                mesh=None if g is None else mesh(ocp, n, g))
        stage = built[key]
        w0, lg0, lx0 = interpolate(prev.nlp, sol.w, sol.lam_g, sol.lam_x, stage.nlp)
        last = n >= method.intervals
        sol = stage.solve(w0=w0, lam_g0=lg0, lam_x0=lx0, raise_on_failure=last)
        rows.append({"start": "mesh continuation", "stage": f"{n} intervals", "status": sol.status,
                     "success": sol.success, "iterations": sol.iterations, "solve_time_s": sol.solve_time_s,
                     "build_time_s": stage.build_time_s if new else 0.0})
        prev = stage
    return prev, sol


def optimize(ocp: SpinupProblem, method, multistart: bool = True, options: dict | None = None,
             graded: bool = True) -> Optimum:
    """Solve from every start of the problem (:meth:`~autobal.ocp.protocol.SpinupProblem.starts`: the Jeffcott rotor's
    :class:`SpinupOcp` or the modal rotor's :class:`autobal.ocp.modal.ModalSpinupOcp`); keep the best optimum by
    its re-simulated objective (for min_time: the shortest time whose re-simulated peak keeps the deflection limit
    within 1 %).

    With several starts and a collocation mesh of at least 2 x COARSE intervals, every start is solved on
    the coarse mesh and the best coarse optimum (the problem's ``rank_coarse``) is refined by mesh continuation
    (:func:`refine`), on a mesh graded from the coarse optimum (:func:`grading`) with ``graded`` (uniform without it:
    for callers that read the optimum's controls as equal intervals, and for the modal rotor and a free final time
    always).  min_time is solved by continuation: first the smallest peak over the full horizon
    (if even that exceeds the deflection limit, the limit is the binding constraint and no time is
    feasible), then the minimum time started from that profile.  One row per solve in ``Optimum.starts``: the
    start, its mesh stage, status, iterations, times, and its re-simulated ``objective`` where one was computed."""
    clock = time.perf_counter()
    ref = ocp.reference_level()
    times = {"resimulation": time.perf_counter() - clock}
    n_ctrl = method.intervals
    rows, best, first_error, build = [], None, None, 0.0
    guesses = []  # every solve's initial-guess simulation (s)
    if ocp.free_time:
        peak_ocp = dataclasses.replace(ocp, objective="peak_deflection", deflection_limit=None)
        pk = optimize(peak_ocp, method, multistart, options, graded=False)  # its profile starts the uniform mesh
        # the minimum-peak stage's solves, builds and times are this study's too (its own start list instead of
        # the ramps starts() would give)
        rows += [r | {"start": f"minimum-peak stage: {r['start']}",
                      "stage": f"minimum peak, {r.get('stage', 'final mesh')}"} for r in pk.starts]
        build += pk.build_time_s
        times["resimulation"] += pk.times["resimulation"]
        times["global_search"] = pk.times["global_search"]
        times["screening"] = pk.times.get("screening", 0.0)
        guesses.append(pk.times["guesses"])
        if pk.score > ocp.deflection_limit:
            raise SolveError(f"spin-up OCP infeasible: binding constraint: deflection limit delta/e <= "
                             f"{ocp.deflection_limit:g}; the smallest peak reachable within the horizon "
                             f"{ocp.horizon:g} s is {pk.score:.4g} e", "Infeasible_Problem_Detected",
                             {"smallest_peak_over_e": pk.score, "t_s": list(pk.trajectory.t),
                              "omega_rad_s": list(pk.trajectory.omega)})
        start_list = [("minimum-peak profile over the horizon", pk.solution.u[:n_ctrl])]
    else:
        clock = time.perf_counter()
        start_list = ocp.starts(n_ctrl, multistart)
        times["global_search"] = time.perf_counter() - clock
    coarse = coarse_solver(ocp, method, ref, options) if len(start_list) > 1 else None
    solved = []  # (label, solution) of the finest mesh
    if coarse is not None:  # mesh continuation: every start on the coarse mesh, the best one refined
        build += coarse.build_time_s
        nc, found = coarse.nlp.mesh.n, []
        clock = time.perf_counter()
        screened = screen(ocp, coarse, [u for _, u in start_list], lambda: coarse_solver(ocp, method, ref, options))
        times["screening"] = time.perf_counter() - clock  # wall: its guesses and solves, two processes at once
        for (label, _), sc in zip(start_list, screened, strict=True):
            rows.append({"start": label, "stage": f"coarse ({nc} intervals)", "status": sc.status,
                         "success": sc.success, "iterations": sc.iterations, "solve_time_s": sc.solve_time_s})
            if sc.success:
                found.append((label, sc, rows[-1]))
        if not found:  # every start failed on the coarse mesh: say so, with their statuses (not a limit's words)
            statuses = list(dict.fromkeys(r["status"] for r in rows if r.get("stage") == f"coarse ({nc} intervals)"))
            raise SolveError(f"spin-up OCP: none of the {len(start_list)} starts converged on the coarse mesh ({nc} "
                             f"intervals; raise max_iterations or check the problem's limits)", ", ".join(statuses))
        start_list = []
        refined, fell, built, spread = [], False, {}, 0.0  # coarse profiles refined; the last fell back; stages
        while found and len(refined) < REFINED:  # the best coarse optimum, then the close basins and fall-backs
            if refined and not fell and not spread:  # one refinement that kept to its coarse profile: done
                break
            clock = time.perf_counter()
            i, scores = ocp.rank_coarse([f[:2] for f in found], nc)
            for j, score in scores.items():
                found[j][2]["objective"] = score
            times["resimulation"] += time.perf_counter() - clock
            label, sc, _ = found.pop(i)
            basin = another_basin(ocp, refined, sc.u[:nc], spread)
            if refined and not fell and basin is False:
                break
            if basin is None:  # the basin of a profile already refined
                continue
            refined.append(sc.u[:nc])
            try:
                _, sol = refine(ocp, method, coarse, sc, options, rows, built, graded)
                solved.append((f"{label}, refined from {nc} intervals", sol))
            except SolveError as exc:
                if exc.status in INFEASIBLE:
                    raise
                first_error, fell = exc, True
                continue
            # the search policy judges profiles on equal intervals: a graded optimum averaged onto 4 N of them
            h = sol.h[:n_ctrl]
            fine = on_uniform(sol.u[:n_ctrl], h, n_ctrl if np.all(h == h[0]) else 4 * n_ctrl)
            fell = fell_back(ocp, sc.u[:nc], fine)
            # a refinement that moved more than FALLBACK (either way) from its coarse profile: the coarse ranking is
            # trusted to that much (the liquid balancer 2.8 %; damped_issue35 0.7 %, the deadline scene 1e-6: one)
            step = moved(ocp, sc.u[:nc], fine)
            spread = max(spread, step) if step > FALLBACK else spread
        build += sum(r.get("build_time_s", 0.0) for r in rows)
    if start_list:
        solver = Solver(ocp, method, ref, options)
        build += solver.build_time_s
    for label, u in start_list:
        try:
            solved.append((label, solver.solve(u)))
            guesses.append(solved[-1][1].guess_time_s)
        except SolveError as exc:
            if exc.status in INFEASIBLE:  # no other start can fix the limits
                raise
            first_error = first_error or exc
            rows.append({"start": label, "status": exc.status, "success": False})
    clock = time.perf_counter()
    for label, sol in solved:
        tr = ocp.resimulate(sol.u, sol.h, "optimum")
        score, own = resimulated_scores(ocp, sol, tr)
        ok = ocp.deflection_limit is None or tr.peak <= 1.01 * ocp.deflection_limit
        # a refined optimum's solve is already in the row of its mesh-continuation stage
        timed = {} if any(r.get("stage") == f"{method.intervals} intervals" for r in rows) else {
            "solve_time_s": sol.solve_time_s}
        rows.append({"start": label, "status": sol.status, "success": True, "iterations": sol.iterations,
                     **timed, "objective": score, f"resimulated_peak_{PEAK_KEY[ocp.deflection_unit]}": tr.peak,
                     "keeps_limit": ok})
        if ok and (best is None or score < best[0] * (1 - TIE)):  # ties go to the earlier start
            best = (score, own, sol, tr)
    times["resimulation"] += time.perf_counter() - clock
    times["guesses"] = float(sum(guesses))
    if best is None:
        raise first_error or SolveError("no start keeps the deflection limit after re-simulation", "limit_violated")
    score, own, sol, tr = best
    return Optimum(ocp, sol, tr, score, rows, own, build, times)
