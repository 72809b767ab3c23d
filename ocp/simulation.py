"""Simulation of speed profiles with CVODES: the initial guess of the NLP, the re-simulation of
every optimum at tight tolerance (the reported peak), and the constant-ramp baselines."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from autobal.analysis.numerics.rotor import deflection, peak, unbalance
from autobal.analysis.run import interrupt, solver_options
from autobal.analysis.run.quantities import Quantity
from autobal.models.rotor import rotor_model
from autobal.ocp.transcription import DRIVE_TOL, Nlp, interval_integrator, mesh, path_fractions

if TYPE_CHECKING:
    from autobal.ocp.problem import SpinupOcp

# the re-simulation's CVODES tolerance and samples: the solver options "resimulation" (analysis/run/solver_options.py)


def rate_text(alpha: float) -> str:
    """An angular acceleration as an engineer reads it: rad/s² with rpm/s beside (n' = 30 alpha / pi)."""
    return f"{alpha:.4g} rad/s² ({alpha * 30 / np.pi:.4g} rpm/s)"


@cache
def chained_integrator(rhs: ca.Function, fractions: tuple, tol: float, intervals: int, multistep: str,
                       max_steps: int = 20000) -> ca.Function:
    """:func:`interval_integrator` of the model's equation ``rhs`` chained over ``intervals`` intervals in one
    CasADi call (``mapaccum``: CVODES restarts at every interval, as the control jumps there): (q0 (nx),
    [a*, h, p] (2 + np, K)) -> (q(T), states (nx, K len(fractions)))."""
    F = interval_integrator(rhs, fractions, tol, multistep, max_steps)
    q, par = ca.MX.sym("q", rhs.size1_in(0)), ca.MX.sym("par", 2 + rhs.size1_in(2))
    xf = F(x0=q, p=par)["xf"]
    return ca.Function("spinup_interval_step", [q, par], [xf[:, -1], xf]).mapaccum("spinup_chain", intervals, [0], [0])


def require_resimulations(name: str, held) -> None:
    """ValueError when a spin-up Result loaded from results.json (``held`` None: no re-simulations) is asked for its
    tables or figures, which only its run held (they are the files of its run)."""
    if held is None:
        raise ValueError(f"{name}: a Result loaded from results.json holds no re-simulations; its tables and "
                         "figures are the files of its run")


def runs(u: np.ndarray, h: np.ndarray) -> list[tuple[int, int]]:
    """(first interval, length) of the maximal runs of consecutive intervals with equal control and length."""
    change = np.flatnonzero((np.diff(u) != 0) | (np.diff(h) != 0)) + 1
    starts = np.concatenate([[0], change])
    return list(zip(starts.tolist(), np.diff(np.append(starts, len(u))).tolist(), strict=True))


def simulate_profile(ocp: SpinupOcp, u, h, fractions, tol: float | None = None, multistep: str = "bdf",
                     merge: bool = False) -> np.ndarray:
    """CVODES run of piecewise-constant u (over alpha_max) on intervals of lengths h (tau).

    Parameters
    ----------
    ocp : SpinupOcp
        The problem (rotor, start state).
    u, h : array_like, shape (K,)
        Acceleration over alpha_max and length (tau) of each interval.
    fractions : sequence of float
        Output instants as fractions of each interval, the last one 1.
    tol : float, optional
        CVODES relative and absolute tolerance; default the solver option ``resimulation.tol``.
    multistep : str
        "bdf" or "adams" (:func:`autobal.ocp.transcription.interval_integrator`).
    merge : bool
        Integrate each run of equal intervals (a held speed, a full-acceleration arc) in one CVODES call, with
        restarts only where the control jumps (otherwise at every interval, as the multiple shooting does).

    Returns
    -------
    ndarray, shape (K, len(fractions), nx)
        The states at the fractions of each interval.
    """
    tol = solver_options.defaults["resimulation.tol"] if tol is None else tol
    if abs(fractions[-1] - 1) > 1e-14:
        raise ValueError("the last output fraction must be the interval end (1)")
    u, h = np.asarray(u, float), np.asarray(h, float)
    K, nf, fr, p = len(u), len(fractions), tuple(float(f) for f in fractions), list(ocp.p)
    rhs, steps = ocp.rhs(), ocp.max_steps
    if len(h) != K:
        raise ValueError(f"{K} controls for {len(h)} intervals")
    pieces = runs(u, h) if merge else [(0, K)]
    q, out, i = np.asarray(ocp.q0, float), [], 0
    while i < len(pieces):
        k, m = pieces[i]
        if merge and m > 1:  # one call over the run, outputs at the fractions of each of its intervals
            F = interval_integrator(rhs, tuple((r + f) / m for r in range(m) for f in fr), tol, multistep, steps)
            xs = np.array(interrupt.call(F, x0=q, p=[u[k] * ocp.a_max, m * h[k], *p])["xf"])
            i += 1
        else:  # single intervals (or all, without merge): one chained call restarting at each
            j = i
            while j < len(pieces) and (not merge or pieces[j][1] == 1):
                j += 1
            m = sum(r[1] for r in pieces[i:j])
            F = chained_integrator(rhs, fr, tol, m, multistep, steps)
            par = np.vstack([u[k:k + m] * ocp.a_max, h[k:k + m], np.tile(np.array(p)[:, None], m)])
            xs = np.array(interrupt.call(F, q, par)[1])
            i = j
        out.append(xs.T.reshape(m, nf, ocp.nx))
        q = xs[:, -1]
    return np.concatenate(out)


def ramp_profile(ocp: SpinupOcp, n: int, alpha: float, hold_at: float | None = None,
                 accel2: float | None = None) -> np.ndarray:
    """Piecewise-constant u on the n control intervals of a ramp: constant acceleration ``alpha``
    until omega_final (then hold), or, with ``hold_at``, ramp to hold_at, hold, and ramp at
    ``accel2`` so as to reach omega_final at the horizon (a piecewise profile for multi-start)."""
    h = ocp.tau_h / n
    nu = np.empty(n + 1)
    nu[0] = ocp.nu0
    a, a_cap = alpha / ocp.Om**2, ocp.a_max
    if hold_at is None:
        for k in range(n):
            nu[k + 1] = min(ocp.nuf, nu[k] + a * h) if ocp.nuf >= ocp.nu0 else max(ocp.nuf, nu[k] - a * h)
    else:
        a2 = (accel2 or ocp.alpha_max) / ocp.Om**2
        t2 = ocp.tau_h - (ocp.nuf - hold_at / ocp.Om) / a2  # start of the second ramp
        for k in range(n):
            t1 = (k + 1) * h
            nu[k + 1] = min(hold_at / ocp.Om, ocp.nu0 + a * t1)
            if t1 > t2:
                nu[k + 1] = min(ocp.nuf, max(nu[k + 1], hold_at / ocp.Om + a2 * (t1 - t2)))
    return np.clip(np.diff(nu) / h / a_cap, -1, 1)


def initial_guess(ocp: SpinupOcp, nlp: Nlp, u: np.ndarray) -> np.ndarray:
    """Fill all NLP variables by simulating the control profile u (n control intervals).  CVODES BDF restarted
    at every interval: from the Adams guess (1e-8 apart) the robust study's NLP lands in another local optimum."""
    ms = nlp.mesh
    uu = np.concatenate([u, np.zeros(ms.ns)])
    h = ms.lengths
    w0 = np.zeros(nlp.x.numel())
    if nlp.index["Xc"] is not None:
        sim = simulate_profile(ocp, uu, h, path_fractions(nlp.method.degree, nlp.method.scheme), tol=1e-8)
        d = nlp.method.degree
        w0[nlp.index["Xc"]] = sim[:, :d, :]
        w0[nlp.index["X"][1:]] = sim[:, -1, :]
    else:
        sim = simulate_profile(ocp, uu, h, [1.0], tol=1e-8)
        w0[nlp.index["X"][1:]] = sim[:, -1, :]
    w0[nlp.index["X"][0]] = ocp.q0
    w0[nlp.index["u"]] = uu
    if ocp.free_time:
        w0[nlp.index["v"][0]] = 1.0
    elif nlp.index["v"]:
        pts = np.array(w0[nlp.index["Xc"]] if nlp.index["Xc"] is not None else w0[nlp.index["X"]])
        w0[nlp.index["v"][0]] = 1.05 * np.max(ocp.epigraph2(pts)) / nlp.ref
    return w0


@dataclass
class Trajectory:
    """A speed profile and the rotor's response, in SI (deflection over e)."""

    label: str
    t: np.ndarray  # s
    omega: np.ndarray  # rad/s
    delta: np.ndarray  # delta/e
    d: np.ndarray  # system unbalance d (9')
    torque: np.ndarray  # N m (nan without drive data)
    t_u: np.ndarray  # interval starts, s
    alpha: np.ndarray  # rad/s^2 on each interval
    peak_delta: float
    peak_d: float
    t_peak: float
    integral_delta2: float  # integral of (delta/e)^2 dt, s

    @property
    def peak(self) -> float:
        """The peak deflection in the problem's deflection unit (``deflection_unit`` "1": delta/e), as the modal
        rotor's trajectory states its own (m): what a deflection limit bounds."""
        return self.peak_delta

    def to_dict(self) -> dict:
        return {"label": self.label, "peak_deflection_over_e": self.peak_delta, "peak_unbalance": self.peak_d,
                "time_of_peak_s": self.t_peak, "integral_deflection2_s": self.integral_delta2}


def acceleration_at(t: np.ndarray, t_u: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The acceleration at the sample times ``t`` of a piecewise-constant profile (``alpha`` on the intervals
    starting at ``t_u``): that of the interval each sample ends (a sample on a switch takes the interval before
    it, the first sample the first interval's)."""
    k = np.searchsorted(t_u, np.asarray(t) * (1 - 1e-12), side="left") - 1  # the interval's end, to rounding
    return np.asarray(alpha)[np.clip(k, 0, len(alpha) - 1)]


def resimulate(ocp: SpinupOcp, u, h, label: str, points: int | None = None, tol: float | None = None,
               multistep: str = "adams", merge: bool = True) -> Trajectory:
    """CVODES at tight tolerance with the piecewise-constant profile u (over alpha_max) on intervals h
    (``multistep``, ``merge``: :func:`simulate_profile`); ``points`` samples per interval, default the solver option
    ``resimulation.points``, at ``tol`` (``resimulation.tol``)."""
    points = solver_options.defaults["resimulation.points"] if points is None else points
    frac = list(np.linspace(0, 1, points + 1)[1:])
    sim = simulate_profile(ocp, u, h, frac, tol, multistep, merge)
    return trajectory(ocp, u, h, label, sim)


@cache
def _mapped(f: ca.Function, n: int) -> ca.Function:
    return f.map(n)


def trajectory(ocp: SpinupOcp, u, h, label: str, sim: np.ndarray, torque=None) -> Trajectory:
    """The :class:`Trajectory` of the states ``sim`` (K, points, nx) at the ends of ``points`` equal parts of each
    of the K intervals h (tau) of the profile u (over alpha_max), from the start state ``ocp.q0``; ``torque`` (q (nx,
    N), a* (1, N), p) -> M~ (N,), default the model's ``torque`` Function mapped over the samples."""
    K, points = sim.shape[:2]
    frac = np.linspace(0, 1, points + 1)[1:]
    t0 = np.concatenate([[0.0], np.cumsum(h)[:-1]])
    tau = np.concatenate([[0.0], (t0[:, None] + np.asarray(h)[:, None] * frac[None, :]).ravel()])
    q = np.vstack([np.asarray(ocp.q0, float)[None, :], sim.reshape(K * points, ocp.nx)]).T
    a = np.concatenate([np.repeat(np.asarray(u) * ocp.a_max, points)[:1], np.repeat(np.asarray(u) * ocp.a_max,
                                                                                     points)])
    dl, dd = deflection(q), unbalance(q, ocp.params.psi)
    pk, tpk = peak(tau, dl)
    P = ocp.params
    if torque is None:
        torque = lambda q, a, p: np.array(_mapped(rotor_model().torque, q.shape[1])(q, a, p)).ravel()  # noqa: E731
    # the drive torque (without drive data J_p = b = 0: the unbalance reaction alone)
    torque = torque(q, a[None, :], P.p) * P.torque_scale
    Om = ocp.Om
    integral = float(np.trapezoid(dl**2, tau) / Om)
    return Trajectory(label, tau / Om, q[4] * Om, dl, dd, torque, t0 / Om, np.asarray(u) * ocp.alpha_max,
                      pk, peak(tau, dd)[0], tpk / Om, integral)


def torque_reference(ocp: SpinupOcp) -> float:
    """The drive's torque scale, N m: max_torque, else the inertial torque of the full acceleration."""
    return ocp.torque_max or ocp.inertia * ocp.alpha_max


def drive_excess(ocp: SpinupOcp, tr: Trajectory) -> dict[str, float]:
    """How far a re-simulated profile goes beyond each drive limit of the problem, relative (0: kept): torque and
    braking over the torque reference (:func:`torque_reference`), power over max_power, the motor characteristic
    over its stall torque, acceleration over alpha_max, speed over omega_max."""
    M, w = tr.torque, tr.omega
    lo, hi = ocp.torque_bounds
    ref = torque_reference(ocp)
    out = {"torque limit": (np.max(M) - hi) / ref, "braking limit": (lo - np.min(M)) / ref,
           "acceleration limits": max(np.max(tr.alpha) - ocp.alpha_max, ocp.u_min * ocp.alpha_max - np.min(tr.alpha))
           / ocp.alpha_max}
    if ocp.power_max is not None:
        out["power limit"] = np.max(M * w) / ocp.power_max - 1
    if ocp.omega_max is not None:
        out["speed limit"] = np.max(w) / ocp.omega_max - 1
    if ocp.motor_stall_torque is not None:
        out["motor characteristic"] = np.max(M - ocp.motor_stall_torque * (1 - w / ocp.motor_no_load_speed)) \
            / ocp.motor_stall_torque
    return {k: max(float(v), 0.0) for k, v in out.items()}


def drive_use(ocp: SpinupOcp, tr: Trajectory) -> dict:
    """The largest and smallest drive torque and the largest power of a re-simulated profile, and whether it keeps
    every drive limit of the problem (torque, braking, power, motor characteristic, acceleration, speed) within
    :data:`DRIVE_TOL` (:func:`drive_excess`); ``violated`` names the limits it breaks."""
    M, w = tr.torque, tr.omega
    if np.all(np.isnan(M)):
        return {"max_torque_N_m": None, "min_torque_N_m": None, "max_power_W": None, "within_drive_limits": None,
                "violated": []}
    bad = [k for k, v in drive_excess(ocp, tr).items() if v > DRIVE_TOL]
    return {"max_torque_N_m": float(np.max(M)), "min_torque_N_m": float(np.min(M)),
            "max_power_W": float(np.max(M * w)), "within_drive_limits": not bad, "violated": bad}


#: the drive's numbers of a spin-up block (:func:`drive_use` of the optimum, and the limits), declared once for the
#: Jeffcott and the modal rotor's blocks
DRIVE_QUANTITIES = (
    Quantity("max_torque_N_m", "N*m", "M_max", "largest drive torque of the optimum", headline=True),
    Quantity("max_power_W", "W", "P_max", "largest drive power of the optimum", "kW", headline=True),
    Quantity("min_torque_N_m", "N*m", "M_min", "smallest drive torque of the optimum (below 0: it brakes)",
             headline=True),
    Quantity("torque_limit_N_m braking_torque_limit_N_m", "N*m", "M_lim", "torque and braking-torque limits of the "
             "drive"),
    Quantity("power_limit_W", "W", "P_lim", "power limit of the drive", "kW"),
)


def ramp_runs(baselines: dict, uses: dict) -> list[tuple]:
    """The ramp baselines as the figures draw them: (trajectory, colour, line style, line width, label) each, dotted
    and labelled "outside the drive limits" where its drive use (``uses``: the results.json baselines, or
    :func:`drive_use` of each) says it breaks them."""
    out = []
    for (k, tr), c in zip(baselines.items(), ("C0", "C2", "C1"), strict=False):
        outside = uses[k]["within_drive_limits"] is False
        label = tr.label + (" (outside the drive limits)" if outside else "")
        out.append((tr, c, ":" if outside else "--", 1.0, label))
    return out


def legend_above_curves(ax, fontsize: float = 6.5) -> None:
    """The legend of the runs in a band of its own above the curves (upper right): the y-axis raised by the legend's
    height (its rows at ``fontsize``, estimated from the axes' height), so that it covers no run's peak."""
    handles, labels = ax.get_legend_handles_labels()
    lo, hi = ax.get_ylim()
    height = ax.get_position().height * ax.figure.get_figheight() * 72  # points
    band = min(0.6, (len(labels) * 1.45 * fontsize + 10) / height)
    ax.set_ylim(lo, lo + (hi - lo) / (1 - band))
    ax.legend(handles, labels, fontsize=fontsize, loc="upper right")


def best_within_limits(peaks: dict, uses: dict):
    """The key of the smallest peak among the profiles that keep the drive limits (``uses``: :func:`drive_use` of
    each; a profile without drive data counts as keeping them), None when none does: the only reference a
    gain may be quoted against."""
    feasible = [k for k in peaks if uses[k]["within_drive_limits"] is not False]
    return min(feasible, key=peaks.get) if feasible else None


def _ramp(ocp: SpinupOcp, alpha: float, h, n: int, ns: int, points: int, label: str, resim=resimulate
          ) -> Trajectory:
    u = np.concatenate([ramp_profile(ocp, n, alpha), np.zeros(ns)])
    return resim(ocp, u, h, label, points=points)


def rate_cap(ocp: SpinupOcp, omega: float) -> float:
    """The largest acceleration the drive gives at speed ``omega`` (rad/s) by its inertia alone, rad/s^2:
    J alpha + b omega within the torque, power and motor limits, and alpha within alpha_max (the rotor's
    reaction torque left out: a start, checked by re-simulation)."""
    J, b = ocp.inertia, ocp.drag
    caps = [ocp.alpha_max]
    if J > 0:
        if ocp.torque_max is not None:
            caps.append((ocp.torque_max - b * omega) / J)
        if ocp.power_max is not None:
            caps.append((ocp.power_max / max(omega, 1e-300) - b * omega) / J)
        if ocp.motor_stall_torque is not None:
            caps.append((ocp.motor_stall_torque * (1 - omega / ocp.motor_no_load_speed) - b * omega) / J)
    return min(caps)


def drive_unreachable(ocp: SpinupOcp, points: int = 401) -> str | None:
    """Why the drive cannot take the rotor from omega_start up to omega_final by the deadline, or None: its earliest
    arrival, at :func:`rate_cap` at every speed (the acceleration limit alpha_max, and the torque, power and motor
    limits on the inertia it accelerates), later than the horizon, or a speed it cannot accelerate past.  A check
    before solving (the Jeffcott and the modal rotor)."""
    w0, wf = ocp.omega_start, ocp.omega_final
    if wf <= w0:
        return None
    limited = ocp.inertia > 0 and (ocp.torque_max is not None or ocp.power_max is not None
                                   or ocp.motor_stall_torque is not None)
    w = np.linspace(w0, wf, points)
    a = np.array([rate_cap(ocp, x) for x in w])
    what = (f"the drive's torque, power and motor limits on its inertia {ocp.inertia:.4g} kg m^2 and "
            if limited else "")
    if (a <= 0).any():
        return (f"{what.removesuffix(' and ')} accelerate it no further than {w[np.argmax(a <= 0)]:.4g} rad/s: "
                f"it never reaches the final speed {wf:.4g} rad/s")
    # dt = d omega / alpha by the midpoint rule: 1/alpha is convex in omega (the largest of 1/alpha_max and of the
    # torque, power and motor caps' reciprocals, each convex), so this is a lower bound and a deadline the drive
    # can keep is never refused (trapezoids overestimated by 0.1 % near a motor's no-load speed)
    mid = 0.5 * (w[1:] + w[:-1])
    t = float(np.sum(np.diff(w) / np.array([rate_cap(ocp, x) for x in mid])))
    if t > ocp.horizon * (1 + 1e-6):
        return (f"{what or 'the acceleration limit '}|alpha| <= {ocp.alpha_max:g} rad/s^2 "
                f"take{'' if what else 's'} it from {w0:.4g} to {wf:.4g} rad/s in "
                f"{t:.4g} s at the earliest, after the horizon {ocp.horizon:g} s")
    return None


def fastest_feasible_rate(ocp: SpinupOcp, intervals: int = 200, points: int = 60, tries: int = 12,
                          resim=resimulate) -> tuple[float, Trajectory] | None:
    """The fastest constant acceleration (ramp to omega_final, then hold) that keeps every drive limit at every
    speed it passes and arrives by the deadline, with its re-simulation; None when even the slowest ramp that
    arrives by the deadline breaks a limit.

    Started from the drive's inertia alone (J alpha + b omega within the torque, power and motor limits at the
    top speed), then lowered by the re-simulated excess torque (the rotor's reaction) until the re-simulation
    keeps the limits."""
    ms = mesh(ocp, intervals)
    h = ms.lengths
    J = ocp.inertia
    slowest = min(abs(ocp.omega_final - ocp.omega_start) / ocp.horizon, ocp.alpha_max)
    wt = max(ocp.omega_start, ocp.omega_final)
    a = max(rate_cap(ocp, wt) if ocp.omega_final > ocp.omega_start else ocp.alpha_max, slowest)
    for _ in range(tries):
        tr = _ramp(ocp, a, h, ms.n, ms.ns, points, f"ramp {rate_text(a)} and hold (fastest within the drive limits)",
                   resim)
        use = drive_use(ocp, tr)
        if use["within_drive_limits"]:
            return a, tr
        if a <= slowest or J <= 0 or "braking limit" in use["violated"] or "speed limit" in use["violated"]:
            return None
        M, w = tr.torque, tr.omega
        excess = [np.max(M - ocp.torque_max)] if ocp.torque_max is not None else []
        if ocp.power_max is not None:
            excess.append(np.max(M - ocp.power_max / np.maximum(w, 1e-300)))
        if ocp.motor_stall_torque is not None:
            excess.append(np.max(M - ocp.motor_stall_torque * (1 - w / ocp.motor_no_load_speed)))
        step = max(max(excess, default=0.0) / J, DRIVE_TOL * a)
        a = max(a - 1.5 * step, slowest)
    return None


def baselines(ocp: SpinupOcp, intervals: int = 200, points: int = 60, resim=resimulate) -> dict[str, Trajectory]:
    """The constant-ramp baselines (CVODES, ``points`` samples on each of ``intervals`` piecewise-constant
    intervals): the constant ramp over the horizon and the maximum-acceleration ramp followed by a hold, each
    with the settling window, and, when the maximum-acceleration ramp breaks a drive limit, the fastest ramp and
    hold that keeps them all (:func:`fastest_feasible_rate`).  200 x 60 samples give the peaks of 2000 x 6 to 1e-6
    in a quarter of the time (one CVODES call per interval).  ``resim``: the re-simulation, :func:`resimulate`'s
    signature (the spin-up explorer's live path passes :func:`autobal.ocp.linear_response.resimulate`)."""
    ms = mesh(ocp, intervals)
    h = ms.lengths
    const = min(abs(ocp.omega_final - ocp.omega_start) / ocp.horizon, ocp.alpha_max)
    out = {}
    for key, label, a in (("constant_ramp", f"constant ramp {rate_text(const)}", const),
                          ("max_acceleration_ramp", f"ramp {rate_text(ocp.alpha_max)} and hold", ocp.alpha_max)):
        out[key] = _ramp(ocp, a, h, ms.n, ms.ns, points, label, resim)
    if not drive_use(ocp, out["max_acceleration_ramp"])["within_drive_limits"] and \
            drive_use(ocp, out["constant_ramp"])["within_drive_limits"]:
        best = fastest_feasible_rate(ocp, intervals, points, resim=resim)
        if best is not None:
            out["feasible_ramp"] = best[1]
    return out
