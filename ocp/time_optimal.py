"""Time-optimal spin-up: the earliest arrival at the final speed with the peak deflection bounded (the settling
window still counted), and the Pareto front of peak against arrival time.

Any spin-up problem of the generic pipeline runs through it: the Jeffcott rotor's
(:class:`autobal.ocp.problem.SpinupOcp`, peaks delta/e) and the modal (ROSS) rotor's
(:class:`autobal.ocp.modal.ModalSpinupOcp`, peaks in m), each with its ``min_time`` objective and its deflection
limit as a path constraint of the shared transcription; each peak and limit in its problem's ``deflection_unit``.
Only the minimum-peak optimum of a deadline (its model's global search for starts), the fastest ramp and the
CVODES re-simulation are the model's own (:func:`minimum_peak`, :func:`fastest_ramp`, the methods of
:class:`autobal.ocp.protocol.SpinupProblem`).

The front is computed as its dual: for a deadline T, the smallest peak P*(T) by the minimum-peak OCP of
:mod:`autobal.ocp.solve` (global search, multi-start, collocation, CVODES re-simulation), the control step
kept as the scene's.  P* does not increase with T (a profile that arrives by T also arrives by any later
deadline and holds), so the earliest arrival with the peak at most L is the smallest T with P*(T) <= L:
found first by the ``min_time`` OCP (free final time, the deflection at most L at every collocation point) started from
the profile of the front's first point that keeps L, and by regula falsi on T between the two points of
the front that bracket L where that fails.  The fast end of the front is the maximum-acceleration ramp
(the earliest arrival the acceleration limit allows); the slow end is the scene's horizon.  Every point is
re-simulated with CVODES.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from autobal.errors import SolveError
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.protocol import PEAK_KEY
from autobal.ocp.search import averaged
from autobal.ocp.simulation import Trajectory, baselines
from autobal.ocp.solve import TIE, Optimum, Solver, optimize, resimulated_scores
from autobal.ocp.transcription import DirectCollocation

if TYPE_CHECKING:
    from autobal.ocp.modal import ModalSpinupOcp


def minimum_peak(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation, multistart: bool = True,
                 options: dict | None = None) -> Optimum:
    """The minimum-peak optimum of ``ocp`` on ``method``'s mesh by the shared loop (:func:`autobal.ocp.solve.optimize`:
    its model's global search for starts, the shared solver and mesh continuation); the modal problem on the
    method's intervals (its starts and baselines are on its own mesh).  On a uniform mesh: the front's later
    deadlines and the robust study start from its controls as equal intervals."""
    return optimize(ocp if isinstance(ocp, SpinupOcp) else ocp.on_intervals(method.intervals), method, multistart,
                    options, graded=False)


def fastest_ramp(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation):
    """The maximum-acceleration ramp and hold, re-simulated (the Jeffcott rotor's on 4x the method's intervals, the
    modal rotor's on its own)."""
    if isinstance(ocp, SpinupOcp):
        return baselines(ocp, intervals=4 * method.intervals)["max_acceleration_ramp"]
    from autobal.ocp.modal import baselines as modal_baselines

    return modal_baselines(ocp.on_intervals(method.intervals))["max_acceleration_ramp"]


def peak_words(ocp: SpinupOcp | ModalSpinupOcp, x: float) -> str:
    """A peak or limit in the problem's deflection unit, for messages: delta/e as "13 e", m as um."""
    return f"{x:.6g} e" if ocp.deflection_unit == "1" else f"{x * 1e6:.6g} um"


@dataclass
class FrontPoint:
    """One point of the front: the smallest peak for an arrival deadline."""

    arrival_time_s: float  # s, the deadline
    optimum: Optimum  # the minimum-peak OCP for that deadline (re-simulated)
    intervals: int  # control intervals up to the deadline
    held_from_s: float | None = None  # the profile is an earlier deadline's, held from then (s)

    @property
    def peak(self) -> float:
        """Re-simulated peak deflection, in the problem's deflection unit (delta/e or m)."""
        return self.optimum.trajectory.peak

    @property
    def collocation_peak(self) -> float:
        """Largest deflection at the collocation points (delta/e or m)."""
        return self.optimum.solution.peak_collocation

    @property
    def trajectory(self) -> Trajectory:
        return self.optimum.trajectory

    @property
    def resimulation_rel_error(self) -> float:
        """|collocation peak - re-simulated peak| / re-simulated peak."""
        return abs(self.collocation_peak - self.peak) / self.peak

    @property
    def iterations(self) -> int:
        """Solver iterations: of every start of the min_time OCP (free final time), else of the final solve."""
        o = self.optimum
        return sum(r.get("iterations", 0) for r in o.starts) if o.ocp.free_time else o.solution.iterations

    @property
    def solve_time_s(self) -> float:
        """Solve time of every start, s."""
        return sum(r.get("solve_time_s", 0.0) for r in self.optimum.starts)


def deadline_point(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation, deadline: float,
                   options: dict | None = None, multistart: bool = True) -> FrontPoint:
    """The smallest re-simulated peak when omega_final must be reached by ``deadline`` (s), on the control step
    of ``method`` over ``ocp.horizon``.

    Parameters
    ----------
    ocp : SpinupOcp or ModalSpinupOcp
        The problem (SI).
    method : DirectCollocation
        The transcription over the scene's horizon (its control step is kept).
    deadline : float
        Arrival deadline, s.
    options : dict, optional
        IPOPT options.
    multistart : bool
        Multi-start of the minimum-peak OCP.

    Returns
    -------
    FrontPoint
        Peak in the problem's deflection unit (delta/e or m).
    """
    o = dataclasses.replace(ocp, horizon=float(deadline), objective="peak_deflection", deflection_limit=None)
    m = dataclasses.replace(method, intervals=max(MIN_INTERVALS, round(method.intervals * deadline / ocp.horizon)))
    return FrontPoint(float(deadline), minimum_peak(o, m, multistart, options), m.intervals)


MIN_INTERVALS = 20


@dataclass
class Front:
    """The Pareto front of peak deflection against arrival time, with its fast end."""

    points: list  # FrontPoint, arrival times increasing (peaks decreasing)
    ramp: Trajectory  # the maximum-acceleration ramp: the earliest arrival at all
    ramp_arrival_time_s: float


def front(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation, count: int = 6, options: dict | None = None,
          multistart: bool = True) -> Front:
    """The front: ``count`` deadlines evenly between the maximum-acceleration ramp's arrival (excluded) and
    the horizon (included), each solved by :func:`deadline_point`.

    Parameters
    ----------
    ocp : SpinupOcp or ModalSpinupOcp
        The problem (SI): its horizon is the slow end of the front, s.
    method : DirectCollocation
        The transcription over the horizon.
    count : int
        Points of the front.
    options : dict, optional
        IPOPT options.
    multistart : bool
        Multi-start of each minimum-peak OCP.

    Returns
    -------
    Front
        Arrival times in s, peaks in the problem's deflection unit (delta/e or m).
    """
    t_ramp = abs(ocp.omega_final - ocp.omega_start) / ocp.alpha_max
    if t_ramp >= ocp.horizon:
        raise SolveError(f"time-optimal front: the maximum-acceleration ramp arrives at {t_ramp:.4g} s, not before "
                         f"the horizon {ocp.horizon:g} s", "no_front", {})
    peak_ocp = dataclasses.replace(ocp, objective="peak_deflection", deflection_limit=None)
    ramp = fastest_ramp(peak_ocp, method)
    # deadlines on the control grid of the horizon, so that every earlier profile, held, is one of the later
    # deadline's profiles (the meshes nest)
    dt = ocp.horizon / method.intervals
    deadlines = np.unique(np.ceil((t_ramp + (ocp.horizon - t_ramp) * np.arange(1, count + 1) / count) / dt - 1e-9)
                          * dt)
    points = []
    for T in deadlines:
        p = deadline_point(ocp, method, T, options, multistart)
        if points and p.peak > points[-1].peak * (1 + TIE):
            q = extended(ocp, method, points[-1], T, options)
            p = q if q is not None and q.peak < p.peak else p
        if points and p.peak > points[-1].peak * (1 + TIE):
            # the discretisation error of the later mesh: the earlier profile, held, is the better one
            p = dataclasses.replace(points[-1], arrival_time_s=float(T),
                                    held_from_s=points[-1].held_from_s or points[-1].arrival_time_s)
        points.append(p)
    return Front(points, ramp, t_ramp)


def extended(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation, earlier: FrontPoint, deadline: float,
             options: dict | None = None) -> FrontPoint | None:
    """The minimum-peak OCP for ``deadline`` solved from the ``earlier`` point's profile (arrive by the earlier
    deadline, then hold; the deadlines on one control grid): a later deadline admits every earlier profile,
    so this start keeps the front from rising where the multi-start finds a worse local optimum.  None when
    IPOPT fails from it."""
    o = dataclasses.replace(ocp, horizon=float(deadline), objective="peak_deflection", deflection_limit=None)
    m = dataclasses.replace(method, intervals=max(MIN_INTERVALS, round(method.intervals * deadline / ocp.horizon)))
    n0 = earlier.intervals
    u = averaged(earlier.optimum.solution.u[:n0], earlier.arrival_time_s, np.linspace(0.0, deadline, m.intervals + 1))
    solver = Solver(o, m, options=options)
    try:
        sol = solver.solve(np.clip(u, -1.0, 1.0))
    except SolveError:
        return None
    tr = o.resimulate(sol.u, sol.h, "optimum")
    score, own = resimulated_scores(o, sol, tr)
    row = {"start": f"the {earlier.arrival_time_s:.4g} s point's profile, then held", "status": sol.status,
           "success": True, "iterations": sol.iterations, "solve_time_s": sol.solve_time_s, "objective": score}
    return FrontPoint(float(deadline), Optimum(o, sol, tr, score, [row], own, solver.build_time_s), m.intervals)


# the re-simulated peak of the min_time optimum is aimed this far (relative) below the limit: the arrival
# moves by about 0.03 ms per 1e-5 on the shipped scene (the front's slope there is about 4.5 e/s)
AIM = 1e-5


def min_time_point(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation, limit: float, start: FrontPoint,
                   options: dict | None = None, corrections: int = 4) -> FrontPoint | None:
    """The earliest arrival with the re-simulated peak at most ``limit`` by the ``min_time`` OCP (free final
    time, the deflection at most a collocation limit at every collocation point), started from the profile of the
    front point ``start`` that keeps the limit; its arrival is the upper bound of the final time.

    The control step is the scene's, as at every point of the front: solved first on ``start``'s intervals,
    then, when the arrival T asks for another count (round(N T / horizon)), once more on that mesh from the
    first optimum.  The collocation peak of the optimum equals the collocation limit; its CVODES
    re-simulation differs by the discretisation error (+0.001 % to +0.006 % on the shipped scene).  While
    the re-simulated peak exceeds ``limit``, the collocation limit is lowered by secant steps on the
    re-simulated peak (aimed AIM below ``limit``), each solve started from the previous optimum and its
    multipliers (1-4 IPOPT iterations).

    Parameters
    ----------
    ocp : SpinupOcp or ModalSpinupOcp
        The spin-up problem, SI (its objective and limit are replaced).
    method : DirectCollocation
        Collocation over the scene's horizon: its control step is the one kept at the arrival.
    limit : float
        Largest peak deflection, in the problem's deflection unit (delta/e or m).
    start : FrontPoint
        A front point whose re-simulated peak is at most ``limit``.
    options : dict, optional
        IPOPT options.
    corrections : int
        Most re-solves with a lowered collocation limit.

    Returns
    -------
    FrontPoint or None
        Arrival time in s, peak in the problem's deflection unit (re-simulated, at most ``limit``); None when
        IPOPT fails or the re-simulated peak stays above ``limit``.
    """
    arrival = start.held_from_s or start.arrival_time_s
    t, n, u = arrival, start.intervals, start.optimum.solution.u[:start.intervals]
    rows, build, level = [], 0.0, float(limit)

    def record(label: str):
        tr = o.resimulate(sol.u, sol.h, "optimum")
        rows.append({"start": label, "stage": f"min_time, {n} intervals, collocation limit {peak_words(o, level)}",
                     "status": sol.status, "success": True, "iterations": sol.iterations,
                     "solve_time_s": sol.solve_time_s, "objective": sol.final_time_s,
                     f"resimulated_peak_{PEAK_KEY[o.deflection_unit]}": tr.peak})
        return tr

    for stage, label in enumerate((f"the {arrival:.4g} s point's profile", "the first optimum, on the scene's "
                                                                            "control step")):
        o = dataclasses.replace(ocp, horizon=float(t), objective="min_time", deflection_limit=float(limit))
        m = dataclasses.replace(method, intervals=n)
        cold, warm = Solver(o, m, options=options), Solver(o, m, options=options, warm=True)
        build += cold.build_time_s + warm.build_time_s
        rows_limit = next(r for name, r in cold.nlp.blocks if name.startswith("deflection limit"))
        ubx, ubg = cold.nlp.ubx.copy(), cold.nlp.ubg.copy()
        ubx[cold.nlp.index["v"][0]] = arrival / t  # the final time up to the start's arrival
        try:
            sol = cold.solve(np.clip(u, -1.0, 1.0), bounds={"ubx": ubx})
        except SolveError:
            return None
        tr = record(label)
        scene_n = max(MIN_INTERVALS, round(method.intervals * sol.final_time_s / ocp.horizon))
        if scene_n == n or stage:
            break
        t, u = sol.final_time_s, averaged(sol.u[:n], sol.final_time_s,
                                          np.linspace(0.0, sol.final_time_s, scene_n + 1))
        n = scene_n
    tried = []
    while tr.peak > limit:
        if len(tried) == corrections:
            return None
        tried.append((level, tr.peak))
        slope = (tried[-1][1] - tried[-2][1]) / (tried[-1][0] - tried[-2][0]) if len(tried) > 1 else 1.0
        level -= (tr.peak - limit * (1 - AIM)) / (slope if slope > 0 else 1.0)
        ubg[rows_limit] = (level / limit) ** 2
        try:
            sol = warm.solve(w0=sol.w, lam_g0=sol.lam_g, lam_x0=sol.lam_x, bounds={"ubx": ubx, "ubg": ubg})
        except SolveError:
            return None
        tr = record("the previous optimum")
    return FrontPoint(sol.final_time_s, Optimum(o, sol, tr, sol.final_time_s, rows, sol.final_time_s, build),
                      n)


def earliest_arrival(ocp: SpinupOcp | ModalSpinupOcp, method: DirectCollocation, limit: float, fr: Front,
                     options: dict | None = None, multistart: bool = True, rtol: float = 1e-3,
                     ttol: float = 0.01, max_solves: int = 8, min_time: bool = True) -> tuple[FrontPoint | None, float]:
    """The earliest arrival with the re-simulated peak at most ``limit`` (delta/e or m): the ``min_time`` OCP from
    the profile of the front's first point that keeps the limit (:func:`min_time_point`), and, where that
    fails or lands more than ``rtol`` below the limit, regula falsi on the deadline (each step kept in the
    middle half of the bracket, so the bracket shrinks by at least a quarter) between the two points of the
    front ``fr`` that bracket the limit, until the peak is within ``rtol`` below the limit or the bracket is
    shorter than ``ttol`` (s; where the minimum peak jumps between two basins, the earliest arrival is at the
    jump and the limit does not bind).  ``min_time=False``: regula falsi only.

    Returns
    -------
    point : FrontPoint or None
        The deadline (s) and its minimum-peak optimum; None when the maximum-acceleration ramp already keeps
        the limit (it arrives first).
    lower : float
        The latest deadline whose minimum-peak optimum (a best-of-starts local optimum) exceeds the limit, s.

    Raises
    ------
    SolveError
        When even the horizon does not keep the limit.
    """
    if fr.ramp.peak <= limit:
        return None, fr.ramp_arrival_time_s
    pts = [(fr.ramp_arrival_time_s, fr.ramp.peak, None)] + [(p.arrival_time_s, p.peak, p) for p in fr.points]
    if min(p[1] for p in pts) > limit:
        lowest = min(p[1] for p in pts)
        raise SolveError(f"time-optimal spin-up infeasible: binding constraint: deflection limit "
                         f"{peak_words(ocp, limit)}; the smallest peak reachable by the horizon {ocp.horizon:g} s is "
                         f"{peak_words(ocp, lowest)}", "Infeasible_Problem_Detected",
                         {f"smallest_peak_{PEAK_KEY[ocp.deflection_unit]}": lowest})
    k = next(i for i, p in enumerate(pts) if p[1] <= limit)
    (ta, pa, _), (tb, pb, best) = pts[k - 1], pts[k]
    q = min_time_point(ocp, method, limit, best, options) if min_time else None
    if q is not None and q.arrival_time_s < tb:
        tb, pb, best = q.arrival_time_s, q.peak, q
        # the bracket's lower end below the new arrival (a front point past it is then not Pareto-optimal)
        ta, pa = max(((t, p) for t, p, _ in pts if p > limit and t < tb), default=pts[0][:2])
    for _ in range(max_solves):
        if pb >= limit * (1 - rtol) or tb - ta < ttol:
            break
        w = tb - ta
        t = min(max(tb - w * (limit - pb) / (pa - pb), ta + 0.25 * w), tb - 0.25 * w)
        p = deadline_point(ocp, method, t, options, multistart)
        if p.peak <= limit:
            tb, pb, best = t, p.peak, p
        else:
            ta, pa = t, p.peak
    return best, ta
