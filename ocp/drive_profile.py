"""What a drive takes: the optimum as one speed/acceleration/torque/power table, and a K-segment ramp table.

A drive is programmed with a few ramp segments (start speed, end speed, rate), not with hundreds of acceleration
steps.  :func:`segment_profile` poses that as a low-dimensional problem of its own: the breakpoints
(t_i, omega_i) of a piecewise-linear speed profile with K segments from omega_start to omega_final, arriving by
the deadline and held to the end of the settling window, chosen to minimise the same objective under the same
drive limits (an exact penalty on :func:`autobal.ocp.simulation.drive_excess`) by Nelder-Mead.  Its starts: the
K segments fitted to the full optimum, the same projected onto the drive limits (:func:`projected`) and ramps
at the drive's rate with a hold below the critical speed (:func:`hold_start`); the best is searched.  The
search integrates with the exponential integrator of the global search (:func:`fast_segments`, a bounded number
of steps), the kept profile is re-simulated by CVODES (:func:`simulate_segments`): its reported peak and limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autobal.analysis.numerics.rotor import deflection, peak, unbalance
from autobal.models.rotor import rotor_model
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.search import FAST_STEP, STEP, FixedFrameModes, simulate_steps
from autobal.ocp.simulation import (
    Trajectory,
    acceleration_at,
    drive_excess,
    drive_use,
    rate_cap,
    resimulate,
)

RPM = 60 / (2 * math.pi)  # rpm per rad/s
SEGMENT_INTERVALS = 200  # the reported re-simulation is sampled as that of a profile on 200 control intervals
# the search's integrator: at most 8000 steps (the 8 s datasheet scene at the step 0.5 of FAST_STEP: peak within
# 2e-6 of CVODES; a 60 s horizon at the step 2.0: within 6e-5; the largest power within 1e-6 on both)
SEARCH_STEPS = 8000
# the step of the search itself, that of the global search: the kept tables of the six shipped Jeffcott scenes
# integrate within 2.8e-4 of CVODES at it, below their losses against the optimum (>= 8.5e-4), the search taking
# 0.47-0.61 of its CPU time at FAST_STEP (docs/dev/spinup.md, "The drive's segment table")
SEGMENT_STEP = STEP
PENALTY = 10.0  # exact penalty on the relative excess over the drive limits (a fraction of the objective)
SEGMENT_EVALUATIONS = 200  # Nelder-Mead's budget of integrations from the best start
HOLD_FRACTIONS = (0.8, 0.9, 0.95)  # starts holding the speed at these fractions of the critical speed


def drive_table(tr: Trajectory) -> dict[str, np.ndarray]:
    """drive_profile.csv, SI (:func:`autobal.ocp.columns.headed` heads it): the profile as a drive takes it, at the
    re-simulation's samples (the Jeffcott rotor's or the modal rotor's trajectory): time, speed, acceleration (of the
    interval ending at each sample; the first row that of the first interval), torque and power."""
    alpha = acceleration_at(tr.t, tr.t_u, tr.alpha)
    return {"time": tr.t, "speed": tr.omega, "acceleration": alpha, "torque": tr.torque, "power": tr.torque * tr.omega}


def objective_of(ocp: SpinupOcp, tr: Trajectory) -> float:
    """The problem's objective on a re-simulation: the peak deflection or unbalance, or the integral of delta^2."""
    return {"peak_deflection": tr.peak_delta, "peak_unbalance": tr.peak_d,
            "integrated_deflection": tr.integral_delta2}[ocp.objective]


@dataclass
class Segments:
    """A K-segment ramp profile: breakpoints, its re-simulation, drive use and loss against the full optimum."""

    t: np.ndarray  # breakpoint times, s (K + 1), the last the arrival at omega_final
    omega: np.ndarray  # speeds at the breakpoints, rad/s
    trajectory: Trajectory
    objective: float
    fitted_objective: float  # the search's start, the segments fitted to the full optimum: its penalised objective
    evaluations: int
    drive: dict
    start: str = "fitted"  # the start the kept profile was searched from
    start_objectives: dict | None = None  # each distinct start's penalised objective

    @property
    def rates(self) -> np.ndarray:
        return np.diff(self.omega) / np.diff(self.t)

    def table(self, end: float) -> dict[str, list]:
        """drive_segments.csv, SI (:func:`autobal.ocp.columns.headed` heads it): the K segments and the hold to ``end``
        (s) as the last row (rate 0)."""
        t = np.append(self.t, end) if end > self.t[-1] * (1 + 1e-12) else self.t
        w = np.append(self.omega, self.omega[-1]) if len(t) > len(self.t) else self.omega
        r = np.diff(w) / np.diff(t)
        return {"segment": list(range(1, len(r) + 1)), "t_start": t[:-1], "t_end": t[1:], "speed_start": w[:-1],
                "speed_end": w[1:], "rate": r}


def _profile(ocp: SpinupOcp, t, w, step: float):
    """u (over alpha_max) and h (tau) of the segments (t, w) and the hold to the end of the settling window, each
    split into equal sub-intervals of about ``step`` s (the samples of the re-simulation)."""
    end = ocp.horizon + ocp.settling_time
    t, w = np.asarray(t, float), np.asarray(w, float)
    if end > t[-1] * (1 + 1e-12):
        t, w = np.append(t, end), np.append(w, w[-1])
    dt = np.diff(t)
    n = np.maximum(1, np.ceil(dt / step - 1e-9)).astype(int)
    return np.repeat(np.diff(w) / dt / ocp.alpha_max, n), np.repeat(dt / n * ocp.Om, n)


def simulate_segments(ocp: SpinupOcp, t, w, label: str = "segments", intervals: int = SEGMENT_INTERVALS,
                      tol: float | None = None) -> Trajectory:
    """CVODES re-simulation of the piecewise-linear speed profile through (t, w) (s, rad/s), held after, sampled
    as densely as a profile on ``intervals`` control intervals over the horizon (the resimulation solver options; one
    CVODES call per segment)."""
    u, h = _profile(ocp, t, w, ocp.horizon / intervals)
    return resimulate(ocp, u, h, label, tol=tol)


def fast_segments(ocp: SpinupOcp, t, w, dt: float = FAST_STEP, rotor: FixedFrameModes | None = None,
                  max_steps: int = SEARCH_STEPS) -> Trajectory:
    """The piecewise-linear speed profile through (t, w) (s, rad/s), held after, by the exponential integrator
    of the global search (:func:`autobal.ocp.search.simulate_steps`, fixed step ``dt`` in Omega0 t, the speed
    exact at the step ends): deflection, unbalance and drive torque (:func:`autobal.models.rotor.rotor_model`)
    at the step ends.  At most ``max_steps`` steps over the horizon and settling window (the step grows on
    longer ones), so its work is bounded whatever the horizon."""
    end = ocp.horizon + ocp.settling_time
    t, w = np.asarray(t, float), np.asarray(w, float)
    dt = max(dt, end * ocp.Om / max_steps)
    tau = np.arange(int(np.ceil(end * ocp.Om / dt)) + 1) * dt
    nu = np.interp(tau / ocp.Om, t, w) / ocp.Om  # held at w[-1] after t[-1]
    u = np.diff(nu) / dt / ocp.a_max
    _, Z, nus, beta = simulate_steps(ocp, u[None, :], dt, rotor, states=True)
    turn = np.exp(-1j * beta[0])
    r = (Z[0, 0] + 1j * Z[1, 0]) * turn  # the rotating frame
    v = (Z[2, 0] + 1j * Z[3, 0]) * turn - 1j * nus[0] * r
    q = np.array([r.real, r.imag, v.real, v.imag, nus[0]])
    # the breakpoints as samples too (the top speed of each segment: the largest power): the speed exact, the
    # rotor's state interpolated between the step ends
    tb = t[(t > 0) & (t * ocp.Om < tau[-1])] * ocp.Om
    qb = np.array([np.interp(tb, tau, qk) for qk in q[:4]] + [np.interp(tb / ocp.Om, t, w) / ocp.Om])
    order = np.argsort(np.concatenate([tau, tb]), kind="stable")
    tau, q = np.concatenate([tau, tb])[order], np.hstack([q, qb])[:, order]
    # the acceleration at each sample: the rate of the segment it ends (the first at t = 0, zero in the hold)
    rates = np.append(np.diff(w) / np.diff(t), 0.0)
    a = rates[np.clip(np.searchsorted(t, tau / ocp.Om, side="left") - 1, 0, len(rates) - 1)] / ocp.Om**2
    P = ocp.params
    torque = np.array(rotor_model().torque(q, a[None, :], P.p)).ravel() * P.torque_scale  # column by column
    dl, dd = deflection(q), unbalance(q, P.psi)
    pk, tpk = peak(tau, dl)
    return Trajectory("segments (exponential integrator)", tau / ocp.Om, q[4] * ocp.Om, dl, dd, torque,
                      np.arange(u.size) * dt / ocp.Om, u * ocp.alpha_max, pk, peak(tau, dd)[0], tpk / ocp.Om,
                      float(np.trapezoid(dl**2, tau) / ocp.Om))


def fit_segments(tr: Trajectory, omega_final: float, horizon: float, K: int) -> tuple[np.ndarray, np.ndarray]:
    """K segments through the optimum's speed: breakpoints on the optimum, their K - 1 inner times minimising the
    squared speed error (Nelder-Mead), the last the optimum's arrival at omega_final."""
    arrive = np.flatnonzero(np.abs(tr.omega - omega_final) <= 1e-9 * omega_final)
    span = np.abs(np.diff(tr.omega)) > 0
    last = tr.t[min(arrive[0], np.flatnonzero(span)[-1] + 1)] if arrive.size and span.any() else tr.t[-1]
    keep = tr.t <= last

    def err(x):
        tt = np.concatenate([[0.0], np.sort(np.clip(x, 0, last)), [last]])
        return float(np.mean((np.interp(tr.t[keep], tt, np.interp(tt, tr.t, tr.omega)) - tr.omega[keep]) ** 2))

    from scipy.optimize import minimize  # 0.4 s to import: only the segments' fit needs it

    x0 = np.linspace(0, last, K + 1)[1:-1]
    x = np.sort(np.clip(minimize(err, x0, method="Nelder-Mead", options={"maxfev": 200 * K}).x, 0, last)) \
        if K > 1 else x0
    t = np.concatenate([[0.0], x, [last]])
    w = np.interp(t, tr.t, tr.omega)
    t[-1] = min(last, horizon)
    w[-1] = omega_final
    return t, w


def projected(ocp: SpinupOcp, t, w) -> tuple[np.ndarray, np.ndarray] | None:
    """The segments (t, w) with each rising segment's rate capped by what the drive gives at its top speed
    (:func:`autobal.ocp.simulation.rate_cap`), the time this takes recovered from the segments below their cap
    (in proportion to their slack) so that the arrival time is kept; None when no slack is left for it."""
    t, w = np.asarray(t, float), np.asarray(w, float)
    dt, dw = np.diff(t), np.diff(w)
    cap = np.array([rate_cap(ocp, max(a, b)) for a, b in zip(w[:-1], w[1:], strict=True)])
    if np.any(cap <= 0):
        return None
    shortest = np.where(dw > 0, dw / cap, 0.0)  # the shortest duration of each segment within the caps
    need = np.maximum(dt, shortest)
    extra = need.sum() - dt.sum()
    slack = need - shortest
    if extra > 0:
        if slack.sum() <= extra:
            return None
        need = need - slack * extra / slack.sum()
    return np.concatenate([[0.0], np.cumsum(need)]), w


def hold_start(ocp: SpinupOcp, K: int, w_hold: float) -> tuple[np.ndarray, np.ndarray] | None:
    """K segments that ramp at the drive's rate (:func:`autobal.ocp.simulation.rate_cap` at each segment's top
    speed) from omega_start to ``w_hold`` (rad/s), hold there, and ramp in K - 2 equal speed steps to
    omega_final, arriving at the deadline; None for K < 3 or when the ramps alone take longer."""
    w0, wf = ocp.omega_start, ocp.omega_final
    if K < 3 or not w0 < w_hold < wf:
        return None
    w = np.concatenate([[w0, w_hold, w_hold], np.linspace(w_hold, wf, K - 1)[1:]])
    dw = np.diff(w)
    rise = np.array([d / rate_cap(ocp, b) if d > 0 else 0.0 for d, b in zip(dw, w[1:], strict=True)])
    if np.any(rise < 0) or rise.sum() >= ocp.horizon:
        return None
    rise[1] = ocp.horizon - rise.sum()
    return np.concatenate([[0.0], np.cumsum(rise)]), w


def segment_profile(ocp: SpinupOcp, optimum: Trajectory, K: int, evaluations: int = SEGMENT_EVALUATIONS,
                    step: float = SEGMENT_STEP, start: str | None = None) -> Segments:
    """The best K-segment ramp profile for the problem (see the module docstring).

    Parameters
    ----------
    ocp : SpinupOcp
        The problem (a peak or integrated objective, not min_time).
    optimum : Trajectory
        The full optimum's re-simulation (the start).
    K : int
        Number of ramp segments.
    evaluations : int
        Budget of integrations of the search.
    step : float
        The search integrator's step (dimensionless time Omega0 t, :func:`fast_segments`).
    start : str, optional
        Search from this start (a key of ``Segments.start_objectives``) instead of the best one.

    Returns
    -------
    Segments
        Its drive use says whether it keeps every limit (within :data:`autobal.ocp.simulation.DRIVE_TOL`).
    """
    T, wf = ocp.horizon, max(ocp.omega_final, ocp.omega_start, 1e-300)

    def unpack(x):
        t = np.concatenate([[0.0], x[:K] * T])
        t[-1] = min(t[-1], T) if t[-1] <= T * (1 + 1e-9) else t[-1]  # the deadline, to rounding
        w = np.concatenate([[ocp.omega_start], x[K:] * wf, [ocp.omega_final]])
        return t, w

    rotor = FixedFrameModes.of(ocp)

    def score(x):
        t, w = unpack(x)
        dt = np.diff(t)
        bad = max(0.0, -dt.min() / T) + max(0.0, t[-1] / T - 1) + max(0.0, -w.min() / wf)
        if bad > 0 or dt.min() <= 1e-9 * T:
            return 1e3 * (1 + bad)
        tr = fast_segments(ocp, t, w, step, rotor)
        excess = drive_excess(ocp, tr)
        return objective_of(ocp, tr) * (1 + PENALTY * sum(excess.values()))

    fit = fit_segments(optimum, ocp.omega_final, ocp.horizon, K)
    starts = {"fitted": fit, "projected": projected(ocp, *fit)}
    wc = ocp.params.omega_cr
    for f in HOLD_FRACTIONS:
        starts[f"hold at {f:g} omega_cr"] = hold_start(ocp, K, f * wc)
    xs = {}
    for k, v in starts.items():  # the distinct starts (the projection of segments within the limits is theirs)
        x = None if v is None else np.concatenate([v[0][1:] / T, v[1][1:-1] / wf])
        if x is not None and not any(np.array_equal(x, y) for y in xs.values()):
            xs[k] = x
    scores = {k: score(x) for k, x in xs.items()}
    best = start or min(scores, key=scores.get)
    from scipy.optimize import minimize  # 0.4 s to import: only the segments' polish needs it

    res = minimize(score, xs[best], method="Nelder-Mead",
                   options={"maxfev": evaluations, "xatol": 1e-6, "fatol": 1e-7 * scores[best], "adaptive": True})
    x = res.x if res.fun < scores[best] else xs[best]
    t, w = unpack(x)
    tr = simulate_segments(ocp, t, w, f"{K}-segment ramp profile")
    return Segments(t, w, tr, objective_of(ocp, tr), scores["fitted"], len(scores) + int(res.nfev),
                    drive_use(ocp, tr), best, scores)
