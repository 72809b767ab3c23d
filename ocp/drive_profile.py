"""What a drive takes: the optimum as one speed/acceleration/torque/power table, and a K-segment ramp table.

A drive is programmed with a few ramp segments (start speed, end speed, rate), not with hundreds of acceleration
steps.  :func:`segment_profile` poses that as a low-dimensional problem of its own: the breakpoints
(t_i, omega_i) of a piecewise-linear speed profile with K segments from omega_start to omega_final, arriving by
the deadline and held to the end of the settling window, chosen to minimise the same re-simulated objective
(CVODES, :func:`autobal.ocp.simulation.resimulate`) under the same drive limits (an exact penalty on
:func:`autobal.ocp.simulation.drive_excess`), by Nelder-Mead from the K segments fitted to the full optimum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from autobal.ocp.problem import SpinupOcp
from autobal.ocp.simulation import RESIM_TOL, Trajectory, drive_excess, drive_use, resimulate

RPM = 60 / (2 * math.pi)  # rpm per rad/s
SEGMENT_INTERVALS = 200  # the reported re-simulation is sampled as that of a profile on 200 control intervals
SEARCH_INTERVALS = 25  # and the search's, 8 times coarser, at CVODES tolerance 1e-6 (its peak within 1e-5)
PENALTY = 10.0  # exact penalty on the relative excess over the drive limits (a fraction of the objective)
SEGMENT_EVALUATIONS = 200  # Nelder-Mead's budget of re-simulations


def drive_table(tr: Trajectory) -> dict[str, np.ndarray]:
    """The profile as a drive takes it, at the re-simulation's samples: time s, speed rpm and rad/s, acceleration
    rpm/s and rad/s^2 (of the interval ending at each sample; the first row that of the first interval), torque
    N m and power kW."""
    # the samples are t = 0 and the same number of points inside each interval, its end included
    K = len(tr.alpha)
    alpha = tr.alpha[np.concatenate([[0], np.repeat(np.arange(K), (len(tr.t) - 1) // K)])]
    return {"time_s": tr.t, "speed_rpm": tr.omega * RPM, "speed_rad_s": tr.omega,
            "acceleration_rpm_s": alpha * RPM, "acceleration_rad_s2": alpha, "torque_N_m": tr.torque,
            "power_kW": tr.torque * tr.omega * 1e-3}


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

    @property
    def rates(self) -> np.ndarray:
        return np.diff(self.omega) / np.diff(self.t)

    def table(self, end: float) -> dict[str, list]:
        """drive_segments.csv: the K segments and the hold to ``end`` (s) as the last row (rate 0)."""
        t = np.append(self.t, end) if end > self.t[-1] * (1 + 1e-12) else self.t
        w = np.append(self.omega, self.omega[-1]) if len(t) > len(self.t) else self.omega
        r = np.diff(w) / np.diff(t)
        return {"segment": list(range(1, len(r) + 1)), "t_start_s": t[:-1], "t_end_s": t[1:],
                "speed_start_rpm": w[:-1] * RPM, "speed_end_rpm": w[1:] * RPM, "rate_rpm_s": r * RPM,
                "rate_rad_s2": r}


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
                      tol: float = RESIM_TOL) -> Trajectory:
    """CVODES re-simulation of the piecewise-linear speed profile through (t, w) (s, rad/s), held after, sampled
    as densely as a profile on ``intervals`` control intervals over the horizon (RESIM_POINTS per interval; one
    CVODES call per segment)."""
    u, h = _profile(ocp, t, w, ocp.horizon / intervals)
    return resimulate(ocp, u, h, label, tol=tol)


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

    x0 = np.linspace(0, last, K + 1)[1:-1]
    x = np.sort(np.clip(minimize(err, x0, method="Nelder-Mead", options={"maxfev": 200 * K}).x, 0, last)) \
        if K > 1 else x0
    t = np.concatenate([[0.0], x, [last]])
    w = np.interp(t, tr.t, tr.omega)
    t[-1] = min(last, horizon)
    w[-1] = omega_final
    return t, w


def segment_profile(ocp: SpinupOcp, optimum: Trajectory, K: int, evaluations: int = SEGMENT_EVALUATIONS
                    ) -> Segments:
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
        Budget of re-simulations of the search.

    Returns
    -------
    Segments
        Its drive use says whether it keeps every limit (within :data:`autobal.ocp.simulation.DRIVE_TOL`).
    """
    t0, w0 = fit_segments(optimum, ocp.omega_final, ocp.horizon, K)
    T, wf = ocp.horizon, max(ocp.omega_final, ocp.omega_start, 1e-300)

    def unpack(x):
        t = np.concatenate([[0.0], x[:K] * T])
        t[-1] = min(t[-1], T) if t[-1] <= T * (1 + 1e-9) else t[-1]  # the deadline, to rounding
        w = np.concatenate([[ocp.omega_start], x[K:] * wf, [ocp.omega_final]])
        return t, w

    def score(x):
        t, w = unpack(x)
        dt = np.diff(t)
        bad = max(0.0, -dt.min() / T) + max(0.0, t[-1] / T - 1) + max(0.0, -w.min() / wf)
        if bad > 0 or dt.min() <= 1e-9 * T:
            return 1e3 * (1 + bad)
        tr = simulate_segments(ocp, t, w, intervals=SEARCH_INTERVALS, tol=1e-6)
        excess = drive_excess(ocp, tr)
        return objective_of(ocp, tr) * (1 + PENALTY * sum(excess.values()))

    x0 = np.concatenate([t0[1:] / T, w0[1:-1] / wf])
    fitted = score(x0)
    res = minimize(score, x0, method="Nelder-Mead",
                   options={"maxfev": evaluations, "xatol": 1e-6, "fatol": 1e-7 * fitted, "adaptive": True})
    x = res.x if res.fun <= fitted else x0
    t, w = unpack(x)
    tr = simulate_segments(ocp, t, w, f"{K}-segment ramp profile")
    return Segments(t, w, tr, objective_of(ocp, tr), fitted, int(res.nfev), drive_use(ocp, tr))
