"""Benchmark: waypoint profiles on the real spin-up problem (issue 26, item 5), the issue's own search family.

The scenes ``spinup_jeffcott_deadline_5s`` (40 rad/s^2, 5 s) and ``spinup_jeffcott_horizon_10s`` (20 rad/s^2,
10 s): 40 -> 210 rad/s by the deadline, a 3 s hold over which the peak counts, never above 210 rad/s.  The family:
the speed given at K free instants, linear between them (any rate within |alpha| <= alpha_max, not only
bang-bang), then full acceleration to 210 rad/s and the hold.  Each of the K segments is coded by its rate
u_k (over alpha_max, -1...1) and a fraction f_k (0...1) of the longest duration that still keeps
0 <= omega <= omega_final and leaves the time to reach omega_final at full acceleration by the deadline, so
every point of the box is a feasible profile.  scipy's differential evolution minimises the peak of the
exponential integrator (:func:`autobal.ocp.search.simulate_steps`, each step with the exact mean acceleration
of the profile, step ``DT``), Nelder-Mead polishes the best at the finer step ``POLISH_DT``, and CVODES
re-simulates it with the segments as intervals (:func:`autobal.ocp.simulation.resimulate`).

Run: ``python -m benchmarks spinup_waypoints`` (tens of minutes); writes benchmarks/results/spinup_waypoints.json.
"""

from __future__ import annotations

import os
import time

import numpy as np
from scipy.optimize import differential_evolution, minimize

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.ocp import search
from autobal.ocp.simulation import resimulate
from benchmarks._results import case, write

SCENES = ("spinup_jeffcott_deadline_5s", "spinup_jeffcott_horizon_10s")
DT = 0.5  # dimensionless step of the search integrator (4.8 ms)
POLISH_DT = 0.1  # step of the polish (1 ms)
# the runs of benchmarks/spinup_ocp.md: (segments K, seed, population multiplier, generations, integrator step of
# the search, polish); the unpolished runs at a coarse step show how far such a search's own reading falls below
# the re-simulated peak of its profile
RUNS = {"spinup_jeffcott_deadline_5s": [(3, 1, 10, 300, DT, True), (4, 1, 10, 300, DT, True),
                                        (5, 1, 10, 300, DT, True), (6, 1, 10, 300, DT, True),
                                        (8, 1, 10, 300, DT, True), (5, 2, 25, 400, DT, True),
                                        (4, 1, 10, 300, 2.0, False), (4, 1, 10, 300, 1.0, False)],
        "spinup_jeffcott_horizon_10s": [(4, 1, 10, 300, DT, True), (6, 1, 10, 300, DT, True),
                                        (4, 1, 10, 300, 2.0, False)]}
# the best full-braking profiles of the searches of benchmarks/spinup_ocp.md (`python -m benchmarks spinup_search`
# and its exploratory runs; phase durations, s, alternately full acceleration and full braking), polished here
BANG_BANG = {"spinup_jeffcott_deadline_5s": [1.004968, 0.0, 0.236354, 0.006297, 0.412206, 0.335701, 0.585426,
                                             0.029814, 0.843241, 0.001221],
             "spinup_jeffcott_horizon_10s": [3.016849, 5.6e-05, 0.002098, 0.247027, 0.533299, 0.500742]}


def knots(ocp, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Instants (s) and speeds (rad/s) of the waypoints of each row of x = (u_1..u_K, f_1..f_K): the start, the
    K segment ends, the arrival at omega_final at full acceleration and the end of the hold."""
    x = np.atleast_2d(x)
    K = x.shape[1] // 2
    a, wf, T = ocp.alpha_max, ocp.omega_final, ocp.horizon
    t = np.zeros((len(x), K + 3))
    w = np.full((len(x), K + 3), ocp.omega_start)
    for k in range(K):
        u, f = np.clip(x[:, k], -1, 1), np.clip(x[:, K + k], 0, 1)
        tk, wk = t[:, k], w[:, k]
        slack = np.maximum(T - tk - (wf - wk) / a, 0)  # time left beyond the full-acceleration arrival
        with np.errstate(divide="ignore", invalid="ignore"):
            by_time = np.where(u < 1, slack / (1 - u), np.inf)
            by_speed = np.where(u > 0, (wf - wk) / (u * a), np.where(u < 0, wk / (-u * a), np.inf))
        d = f * np.minimum(by_time, by_speed)
        d = np.where(np.isfinite(d), d, 0.0)
        t[:, k + 1], w[:, k + 1] = tk + d, wk + u * a * d
    t[:, K + 1] = t[:, K] + (wf - w[:, K]) / a
    w[:, K + 1:] = wf
    t[:, K + 2] = T + ocp.settling_time + 1.0
    return t, w


def integrator_peaks(ocp, t: np.ndarray, w: np.ndarray, rotor, dt: float) -> np.ndarray:
    """Peak delta/e of piecewise-linear speed profiles (knots t (s), w (rad/s), one row each) by the exponential
    integrator at step dt, each step with the exact mean acceleration of its profile."""
    edges = np.arange(search.horizon_steps(ocp, dt) + 1) * dt / ocp.Om
    W = np.array([np.interp(edges, ti, wi) for ti, wi in zip(t, w, strict=True)])
    return search.simulate_steps(ocp, np.diff(W, axis=1) / (ocp.alpha_max * np.diff(edges)), dt, rotor)


def cvodes_peak(ocp, t: np.ndarray, w: np.ndarray, points: int = 400) -> float:
    """CVODES re-simulation of one piecewise-linear profile, its knots as interval ends: peak delta/e."""
    t = np.minimum(np.asarray(t, float), ocp.horizon + ocp.settling_time)
    h = np.diff(t) * ocp.Om
    u = np.diff(w) / np.where(h > 0, np.diff(t) * ocp.alpha_max, 1.0)
    keep = h > 1e-12
    return resimulate(ocp, u[keep], h[keep], "waypoints", points=points).peak_delta


def describe(t: np.ndarray, w: np.ndarray, alpha_max: float) -> str:
    """The segments as 'rate over duration from speed'."""
    parts = []
    for k in range(len(t) - 2):
        d = t[k + 1] - t[k]
        if d > 1e-4:
            parts.append(f"{(w[k + 1] - w[k]) / d / alpha_max:+.2f} for {1e3 * d:.0f} ms from {w[k]:.1f}")
    return "; ".join(parts)


def encode(ocp, durations, rates) -> np.ndarray:
    """The segment code x = (u_1..u_K, f_1..f_K) of K segments of the given durations (s) and rates (over
    alpha_max): the inverse of :func:`knots`."""
    a, wf, T = ocp.alpha_max, ocp.omega_final, ocp.horizon
    f, tk, wk = [], 0.0, ocp.omega_start
    for d, u in zip(durations, rates, strict=True):
        slack = max(T - tk - (wf - wk) / a, 0.0)
        longest = min(slack / (1 - u) if u < 1 else np.inf, (wf - wk) / (u * a) if u > 0 else
                      (wk / (-u * a) if u < 0 else np.inf))
        f.append(min(d / longest, 1.0) if d > 0 else 0.0)
        tk, wk = tk + d, wk + u * a * d
    return np.concatenate([rates, f])


def polish(ocp, x0: np.ndarray, rotor, maxfev: int = 8000):
    """Nelder-Mead on the segment code from x0 at POLISH_DT: (x, integrator peak, evaluations)."""
    r = minimize(lambda x: float(integrator_peaks(ocp, *knots(ocp, x), rotor, POLISH_DT)[0]), x0,
                 method="Nelder-Mead", options={"xatol": 1e-8, "fatol": 1e-9, "maxfev": maxfev, "adaptive": True})
    return r.x, float(r.fun), int(r.nfev)


def search_waypoints(ocp, K: int, seed: int, rotor, maxiter: int = 800, popsize: int = 15, dt: float = DT,
                     polished: bool = True):
    """Differential evolution on K segments (integrator step dt), then Nelder-Mead at POLISH_DT: (x, DE peak,
    polished peak, profiles integrated); without ``polished`` the DE's profile and its peak at POLISH_DT."""
    bounds = [(-1.0, 1.0)] * K + [(0.0, 1.0)] * K
    r = differential_evolution(lambda x: integrator_peaks(ocp, *knots(ocp, x.T), rotor, dt), bounds, seed=seed,
                               vectorized=True, updating="deferred", popsize=popsize, maxiter=maxiter, tol=1e-10,
                               polish=False, mutation=(0.5, 1.0), recombination=0.9)
    if not polished:
        return r.x, float(r.fun), float(integrator_peaks(ocp, *knots(ocp, r.x), rotor, POLISH_DT)[0]), int(
            r.nit * popsize * 2 * K)
    x, fine, nfev = polish(ocp, r.x, rotor, 4000)
    return x, float(r.fun), fine, int(r.nit * popsize * 2 * K + nfev)  # r.nfev counts the vectorised calls


def main() -> list[dict]:
    cases, rows = [], []
    for name in SCENES:
        scene = api.load(name)
        ocp = spinup_ocp(scene, scene.analyses.spinup)
        rotor = search.FixedFrameModes.of(ocp)
        d = np.asarray(BANG_BANG[name])
        x0 = encode(ocp, d, np.where(np.arange(d.size) % 2 == 0, 1.0, -1.0))
        for spec in [*RUNS[name], None]:  # None: the polish of the full-braking profile
            t0, c0, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
            if spec is None:
                label = f"{d.size} waypoints from the best full-braking profile, Nelder-Mead"
                de = float(integrator_peaks(ocp, *knots(ocp, x0), rotor, DT)[0])
                x, fine, n = polish(ocp, x0, rotor)
            else:
                K, seed, popsize, gens, dt, polished = spec
                label = (f"{K} waypoints, DE seed {seed}, population {popsize} x {2 * K}, {gens} generations, step "
                         f"{dt}" + ("" if polished else ", not polished"))
                x, de, fine, n = search_waypoints(ocp, K, seed, rotor, gens, popsize, dt, polished)
            t, w = knots(ocp, x)
            pk = cvodes_peak(ocp, t[0], w[0])
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            text = describe(t[0], w[0], ocp.alpha_max)
            cases.append(case(f"{name}: {label}", cpu, None, None, None, peak_deflection_over_e=pk,
                              search_peak_over_e=de, polished_peak_over_e=fine, evaluations=n, wall_s=wall,
                              profile=text, load_average_before=load))
            rows.append(f"| `{name}` | {label} | {pk:.5f} | {de:.5f} / {fine:.5f} | {n} | {text} | "
                        f"{wall:.0f} / {cpu:.0f} |")
            print(rows[-1], flush=True)
    table = ("| scene | search | peak, CVODES (e) | integrator: start or DE / polished (e) | profiles integrated | "
             "segments (rate over alpha_max for ms from rad/s) | wall / CPU (s) |\n|---|---|---|---|---|---|---|\n"
             + "\n".join(rows))
    write("spinup_waypoints", "Spin-up: waypoint profiles on the real problem (issue 26, item 5)", cases,
          [f"autobal (s) is the CPU time of one search; differential evolution at step {DT} (4.8 ms), "
           f"Nelder-Mead at {POLISH_DT} (1 ms), CVODES (Adams, rtol 1e-10, 400 points per segment).",
           "The machine is shared (2 cores, several jobs): wall times stretch with the load average."], [table])
    return cases


if __name__ == "__main__":
    main()
