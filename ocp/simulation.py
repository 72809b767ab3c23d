"""Simulation of speed profiles with CVODES: the initial guess of the NLP, the re-simulation of
every optimum at tight tolerance (the reported peak), and the constant-ramp baselines."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import casadi as ca
import numpy as np

from autobal.analysis import interrupt
from autobal.analysis.rotor import deflection, peak, unbalance
from autobal.models.rotor import rotor_model
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.transcription import Nlp, interval_integrator, mesh, path_fractions

# CVODES tolerance of the re-simulation (Adams): the peak of the 5 s deadline optimum moves by 7e-10 relative
# from 1e-12, in half the time (benchmarks/spinup_ocp.md, "Study time")
RESIM_TOL = 1e-10
RESIM_POINTS = 24  # re-simulation samples per interval


@cache
def chained_integrator(fractions: tuple, tol: float, intervals: int, multistep: str) -> ca.Function:
    """:func:`interval_integrator` chained over ``intervals`` intervals in one CasADi call (``mapaccum``: CVODES
    restarts at every interval, as the control jumps there): (q0 (5), [a*, h, p] (6, K)) -> (q(T), states
    (5, K len(fractions)))."""
    F = interval_integrator(fractions, tol, multistep)
    q, par = ca.MX.sym("q", 5), ca.MX.sym("par", 6)
    xf = F(x0=q, p=par)["xf"]
    return ca.Function("spinup_interval_step", [q, par], [xf[:, -1], xf]).mapaccum("spinup_chain", intervals, [0], [0])


def runs(u: np.ndarray, h: np.ndarray) -> list[tuple[int, int]]:
    """(first interval, length) of the maximal runs of consecutive intervals with equal control and length."""
    change = np.flatnonzero((np.diff(u) != 0) | (np.diff(h) != 0)) + 1
    starts = np.concatenate([[0], change])
    return list(zip(starts.tolist(), np.diff(np.append(starts, len(u))).tolist(), strict=True))


def simulate_profile(ocp: SpinupOcp, u, h, fractions, tol: float = RESIM_TOL, multistep: str = "bdf",
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
    tol : float
        CVODES relative and absolute tolerance.
    multistep : str
        "bdf" or "adams" (:func:`autobal.ocp.transcription.interval_integrator`).
    merge : bool
        Integrate each run of equal intervals (a held speed, a full-acceleration arc) in one CVODES call, with
        restarts only where the control jumps (otherwise at every interval, as the multiple shooting does).

    Returns
    -------
    ndarray, shape (K, len(fractions), 5)
        The states at the fractions of each interval.
    """
    if abs(fractions[-1] - 1) > 1e-14:
        raise ValueError("the last output fraction must be the interval end (1)")
    u, h = np.asarray(u, float), np.asarray(h, float)
    K, nf, fr, p = len(u), len(fractions), tuple(float(f) for f in fractions), list(ocp.params.p)
    if len(h) != K:
        raise ValueError(f"{K} controls for {len(h)} intervals")
    pieces = runs(u, h) if merge else [(0, K)]
    q, out, i = np.asarray(ocp.q0, float), [], 0
    while i < len(pieces):
        k, m = pieces[i]
        if merge and m > 1:  # one call over the run, outputs at the fractions of each of its intervals
            F = interval_integrator(tuple((r + f) / m for r in range(m) for f in fr), tol, multistep)
            xs = np.array(interrupt.call(F, x0=q, p=[u[k] * ocp.a_max, m * h[k], *p])["xf"])
            i += 1
        else:  # single intervals (or all, without merge): one chained call restarting at each
            j = i
            while j < len(pieces) and (not merge or pieces[j][1] == 1):
                j += 1
            m = sum(r[1] for r in pieces[i:j])
            F = chained_integrator(fr, tol, m, multistep)
            par = np.vstack([u[k:k + m] * ocp.a_max, h[k:k + m], np.tile(np.array(p)[:, None], m)])
            xs = np.array(interrupt.call(F, q, par)[1])
            i = j
        out.append(xs.T.reshape(m, nf, 5))
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
    h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])
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
        pts = np.array(w0[nlp.index["Xc"]] if nlp.index["Xc"] is not None else w0[nlp.index["X"]]).reshape(-1, 5)
        if ocp.objective == "peak_deflection":
            level = np.max(pts[:, 0] ** 2 + pts[:, 1] ** 2)
        else:
            level = np.max(unbalance(pts.T, ocp.params.psi) ** 2)
        w0[nlp.index["v"][0]] = 1.05 * level / nlp.ref
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

    def to_dict(self) -> dict:
        return {"label": self.label, "peak_deflection_over_e": self.peak_delta, "peak_unbalance": self.peak_d,
                "time_of_peak_s": self.t_peak, "integral_deflection2_s": self.integral_delta2}


def resimulate(ocp: SpinupOcp, u, h, label: str, points: int = RESIM_POINTS, tol: float = RESIM_TOL,
               multistep: str = "adams", merge: bool = True) -> Trajectory:
    """CVODES at tight tolerance with the piecewise-constant profile u (over alpha_max) on intervals h
    (``multistep``, ``merge``: :func:`simulate_profile`)."""
    frac = list(np.linspace(0, 1, points + 1)[1:])
    sim = simulate_profile(ocp, u, h, frac, tol, multistep, merge)
    K = len(u)
    t0 = np.concatenate([[0.0], np.cumsum(h)[:-1]])
    tau = np.concatenate([[0.0], (t0[:, None] + np.asarray(h)[:, None] * np.array(frac)[None, :]).ravel()])
    q = np.vstack([np.asarray(ocp.q0, float)[None, :], sim.reshape(K * points, 5)]).T
    a = np.concatenate([np.repeat(np.asarray(u) * ocp.a_max, points)[:1], np.repeat(np.asarray(u) * ocp.a_max,
                                                                                     points)])
    dl, dd = deflection(q), unbalance(q, ocp.params.psi)
    pk, tpk = peak(tau, dl)
    m = rotor_model()
    P = ocp.params
    # the drive torque (without drive data J_p = b = 0: the unbalance reaction alone)
    torque = np.array(m.torque.map(q.shape[1])(q, a[None, :], ca.repmat(ca.DM(P.p), 1, q.shape[1]))).ravel() \
        * P.torque_scale
    Om = ocp.Om
    integral = float(np.trapezoid(dl**2, tau) / Om)
    return Trajectory(label, tau / Om, q[4] * Om, dl, dd, torque, t0 / Om, np.asarray(u) * ocp.alpha_max,
                      pk, peak(tau, dd)[0], tpk / Om, integral)


def baselines(ocp: SpinupOcp, intervals: int = 200, points: int = 60) -> dict[str, Trajectory]:
    """The constant-ramp baselines (CVODES, ``points`` samples on each of ``intervals`` piecewise-constant
    intervals): the constant ramp over the horizon and the maximum-acceleration ramp followed by a hold, each
    with the settling window.  200 x 60 samples give the peaks of 2000 x 6 to 1e-6 in a quarter of the time
    (one CVODES call per interval)."""
    ms = mesh(ocp, intervals)
    h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])
    const = min(abs(ocp.omega_final - ocp.omega_start) / ocp.horizon, ocp.alpha_max)
    out = {}
    for key, label, a in (("constant_ramp", f"constant ramp {const:.4g} rad/s^2", const),
                          ("max_acceleration_ramp", f"ramp {ocp.alpha_max:.4g} rad/s^2 and hold", ocp.alpha_max)):
        u = np.concatenate([ramp_profile(ocp, ms.n, a), np.zeros(ms.ns)])
        out[key] = resimulate(ocp, u, h, label, points=points)
    return out
