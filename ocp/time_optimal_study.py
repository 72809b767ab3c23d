"""The ``spinup_time_optimal`` analysis of a scene: the earliest arrival at the final speed with the peak
bounded (when the scene gives ``deflection_limit``) and the Pareto front of peak against arrival time, each
point re-simulated (:mod:`autobal.ocp.time_optimal`).

``run(...)`` returns a :class:`TimeOptimalResult` (results.json block, the front as a CSV table, figures: the
front, and the profiles of the front's points); the modal rotor's ``ross_spinup_time_optimal`` a
:class:`ModalTimeOptimalResult`.
"""

from __future__ import annotations

import re
from dataclasses import KW_ONLY

import numpy as np

from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record, unsaved
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import Declarations, significant
from autobal.analysis.run.result import new_figure, speed_axis, unit_axis
from autobal.ocp import time_optimal as to
from autobal.ocp.columns import headed
from autobal.ocp.drive_profile import drive_table
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.protocol import PEAK_KEY
from autobal.ocp.robust_study import PEAK_SYMBOL, deflection_of, peak_text
from autobal.ocp.simulation import require_resimulations
from autobal.ocp.solve import TIE
from autobal.ocp.spinup_study import deflection_axis
from autobal.ocp.transcription import DirectCollocation


def _peak(unit: str, key: str, description: str, headline: int = 0, **kw):
    """A peak of the block in ``unit`` ("1": delta/e, Pashkov (2010), Eq. (2); "m": the modal rotor's, shown in µm)
    at the key ``key`` + ``_over_e`` or ``_m``."""
    return quantity(unit, PEAK_SYMBOL[unit], description, "" if unit == "1" else "µm", headline=headline,
                    key=f"{key}_{PEAK_KEY[unit]}", **kw)


def _point_peak(unit: str, key: str):
    return _peak(unit, key, "peak of a front point: re-simulated, collocation")


def _deadline():
    return quantity("s", "T", "arrival deadline of a front point (held from an earlier point's profile)")


def _numbers():
    return quantity("1", "", "relative difference collocation vs CVODES; intervals and iterations of a point")


def _times():
    return quantity("s", "", "build and solve times")


@record
class Point(Record):
    """A point of the front (or the earliest arrival): the smallest re-simulated peak for an arrival deadline,
    delta/e (:class:`ModalPoint`: m)."""

    arrival_time_s: float = _deadline()
    resimulated_peak: float = _point_peak("1", "resimulated_peak")
    collocation_peak: float = _point_peak("1", "collocation_peak")
    resimulation_rel_error: float = _numbers()
    objective: str
    intervals: int = _numbers()
    held_from_s: float | None = _deadline()  # None: the point's own optimum
    iterations: int = _numbers()
    build_time_s: float = _times()
    solve_time_s: float = _times()


@record
class ModalPoint(Point):
    """A point of the modal rotor's front: peaks in m."""

    resimulated_peak: float = _point_peak("m", "resimulated_peak")
    collocation_peak: float = _point_peak("m", "collocation_peak")


def _limit(unit: str):
    return _peak(unit, "deflection_limit", "peak limit of the scene", 3)


def _ramp_peak(unit: str):
    return _peak(unit, "ramp_peak", "peak of the maximum-acceleration ramp", 6)


def _peak_deflection(unit: str):
    return _peak(unit, "peak_deflection", "peak deflection of the earliest arrival (re-simulated)", 2, optional=True)


def _model(**kw):
    return quantity("1", "", "modes of the reduced rotor; the nodes whose deflection counts", optional=True, **kw)


@record
class TimeOptimalResult(TypedResult):
    """The front of peak deflection against arrival time (every point re-simulated) and its two ends, peaks delta/e
    (the Jeffcott rotor, Pashkov (2010), Eq. (2); the physical deflection (0-peak) e delta/e beside them in the
    summary); with a peak limit, the earliest arrival under it.  The run also holds the front's re-simulations
    (None in a Result loaded from results.json)."""

    title: str
    method: str
    peak_unit: str
    _: KW_ONLY
    eccentricity_m: float | None = quantity("m", "e", "eccentricity (a peak δ*/e is the deflection δ* = e δ*/e, "
                                                      "0-peak)", "µm", optional=True)
    nodes: list[int] | None = _model()
    modes: int | None = _model()
    critical_speeds_rad_s: list[float] | None = quantity(
        "rad/s", "ω_c", "critical speeds of the reduced rotor's modes (up to its mode cutoff)", optional=True)
    drive: str | None = optional()
    horizon_s: float = quantity("s", "", "latest arrival (the front's slow end)")
    ramp_label: str
    final_speed_rad_s: float = quantity("rad/s", "ω_f", "final speed", headline=7)
    ramp_arrival_time_s: float = quantity("s", "T_ramp", "arrival of the maximum-acceleration ramp", headline=5)
    ramp_peak: float = _ramp_peak("1")
    front: list[Point]
    monotone: bool
    build_time_s: float = quantity("s", "", "build time")
    solve_time_s: float = quantity("s", "", "solve time")
    resimulation_rel_error: float = quantity("1", "", "largest relative difference, collocation vs CVODES "
                                                      "re-simulation")
    accuracy: dict
    deflection_limit: float | None = _limit("1")  # None: no limit, the front only
    arrival_time_s: float | None = quantity("s", "T", "earliest arrival at the final speed with the peak within the "
                                                      "limit", headline=1, optional=True)
    peak_deflection: float | None = _peak_deflection("1")
    arrival_time_lower_bound_s: float | None = quantity(
        "s", "", "latest front deadline whose minimum peak exceeds the limit", optional=True)
    limited: Point | None = optional(present_with="deflection_limit")  # None: the ramp keeps the limit
    limit_margin: float | None = quantity("1", "", "margin of the earliest arrival's peak below the limit, "
                                                   "1 − peak/limit", headline=4, optional=True)
    points: list | None = unsaved()  # the front's FrontPoints (their re-simulations)
    limited_point: to.FrontPoint | None = unsaved()  # the earliest arrival's (None: the ramp)
    front_run: to.Front | None = unsaved()  # the front as solved (points, the ramp's re-simulation)
    name = "spinup_time_optimal"
    #: figure -> its caption
    CAPTIONS = {"front": "Time-optimal spin-up: the smallest re-simulated peak against the arrival deadline, the ramp "
                         "and the earliest arrival under the limit",
                "profiles": "Time-optimal spin-up: speed and deflection of the front's points"}
    null_reasons = {"deflection_limit_over_e": "no deflection_limit in the scene: the front only",
                    "held_from_s": "the point's own minimum-peak optimum",
                    "limited": "the maximum-acceleration ramp keeps the limit: it arrives first"}

    @property
    def arrival_times(self) -> np.ndarray:
        """Arrival times of the front's points, s (limits increasing)."""
        return np.array([p.arrival_time_s for p in self.front])

    @property
    def peaks(self) -> np.ndarray:
        """Re-simulated peaks of the front's points, in the block's ``peak_unit`` (delta/e or m)."""
        return np.array([p.resimulated_peak for p in self.front])

    def peak_text(self, x) -> str:
        """A peak of the block as read: delta/e with the deflection e delta/e beside it, or in µm."""
        return peak_text(x, self.peak_unit, self.eccentricity_m)

    def verdict(self) -> tuple[bool | None, str]:
        """With a peak limit, the earliest arrival at the final speed whose re-simulated peak keeps it, and by how
        much; without one, whether the front's peak falls with the deadline."""
        speed = self.quantities.find("final_speed_rad_s").text(self.final_speed_rad_s)
        if self.deflection_limit is None:
            return self.monotone, (f"front of {len(self.front)} deadlines to {speed}: the smallest peak "
                                   + ("falls with the arrival deadline" if self.monotone else "is NOT monotone in "
                                      "the deadline (a local optimum)"))
        lim, peak, pk = self.deflection_limit, self.peak_deflection, self.peak_text
        ok = peak <= lim * (1 + 1e-6)
        return ok, (f"earliest arrival at {speed} with the peak ≤ {pk(lim)}: {significant(self.arrival_time_s)} s, "
                    f"peak {pk(peak)} ({significant(100 * abs(1 - peak / lim))} % {'below' if ok else 'ABOVE'} the "
                    f"limit); the maximum-acceleration ramp arrives at {significant(self.ramp_arrival_time_s)} s with "
                    f"{pk(self.ramp_peak)}")

    def _shown(self) -> tuple[float, str, str]:
        """(factor, axis label, CSV suffix) of the peaks as a person reads them: delta/e, or µm."""
        if self.peak_unit == "1":
            return 1.0, r"peak deflection $\delta^*/e$", "over_e"
        q = QUANTITIES.find("peak_deflection_m")
        return q.shown(1.0), f"peak deflection r*, {q.display} 0-peak", q.display.replace("µ", "u")

    def summary(self) -> str:
        ok, words = self.verdict()
        pk = self.peak_text
        if self.peak_unit == "1":
            unit = (f"peaks δ*/e and the deflection δ* = e δ*/e, 0-peak (e = "
                    f"{QUANTITIES.find('eccentricity_m').text(self.eccentricity_m)})")
        else:
            unit = f"peaks r*, the largest whirl radius over the nodes {self.nodes}, 0-peak; {self.drive}"
        lines = [f"time-optimal spin-up: {'ok' if ok else 'NOT OK'}: {words}", *self.quantities.lines(self.to_dict()),
                 f"  {self.method}: front of {len(self.front)} points, build {self.build_time_s:.2f} s, solve "
                 f"{self.solve_time_s:.2f} s; {unit}",
                 f"  fast end: {self.ramp_label} arrives at {self.ramp_arrival_time_s:.4g} s, peak "
                 f"{pk(self.ramp_peak)}"]
        for p in self.front:
            lines.append(f"  arrival by {p.arrival_time_s:.4f} s: peak {pk(p.resimulated_peak)} "
                         f"(collocation {pk(p.collocation_peak)}, {100 * p.resimulation_rel_error:.2f} %)")
        if self.deflection_limit is not None:
            how = {"min_time": "by the min_time OCP", "peak_deflection": "by regula falsi on the minimum-peak "
                   "deadline"}.get(self.limited.objective if self.limited else None, "the ramp")
            lower = self.arrival_time_lower_bound_s
            lines.append(f"  earliest arrival with the peak <= {pk(self.deflection_limit)}: "
                         f"{self.arrival_time_s:.4f} s {how} (the minimum-peak OCP with the deadline "
                         f"{float('nan') if lower is None else lower:.4f} s exceeds the limit)")
        return "\n".join(lines)

    def _runs(self):
        require_resimulations(self.name, self.points)

    def tables(self) -> dict[str, dict]:
        """The tables headed 'name [unit]' in their display units (:func:`autobal.ocp.columns.headed`): peaks delta/e
        (``*_peak_over_e``) or m shown in µm (``*_peak``), as the block's ``peak_unit``."""
        self._runs()
        s = PEAK_KEY[self.peak_unit]
        f = self.to_dict()["front"]  # the rows as results.json has them (with the statuses of their nulls)
        # the keys without their SI suffix: arrival_time_s -> arrival_time, resimulated_peak_m -> resimulated_peak
        plain = {k: re.sub(r"_s(?=$|_status$)", "", k.removesuffix("_m") if s == "m" else k) for k in f[0]}
        out = {f"{self.name}_front.csv": {plain[k]: [p.get(k) for p in f] for k in f[0]}}
        if self.limited_point is not None:
            tr = self.limited_point.trajectory
            out[f"{self.name}_profile.csv"] = {"time": tr.t, "speed": tr.omega,
                                               "deflection_over_e" if s == "over_e" else "largest_deflection":
                                               deflection_of(tr)}
            out["drive_profile.csv"] = drive_table(tr)
        return {file: headed(t) for file, t in out.items()}

    def draw(self, ax) -> None:
        """The front: re-simulated peak against arrival time, with the two ends."""
        factor, label, _ = self._shown()
        # the front through the ramp, its points and the earliest arrival
        line = np.array(sorted([(self.ramp_arrival_time_s, self.ramp_peak),
                                *zip(self.arrival_times, self.peaks, strict=True)]
                               + ([(self.arrival_time_s, self.peak_deflection)] if self.limited else [])))
        ft = unit_axis(ax, "arrival time at the final speed", "s", which="x")
        ax.plot(line[:, 0] * ft, factor * line[:, 1], "-", color="0.6", lw=0.8)
        ax.plot(np.asarray(self.arrival_times) * ft, factor * self.peaks, "o", color="C3",
                label="minimum peak for an arrival deadline")
        ax.plot(self.ramp_arrival_time_s * ft, factor * self.ramp_peak, "s", color="C2", label=self.ramp_label)
        if self.deflection_limit is not None:
            ax.axhline(factor * self.deflection_limit, color="k", ls=":", lw=0.8)
            ax.plot(self.arrival_time_s * ft, factor * self.peak_deflection, "*", ms=12, color="k",
                    label=f"earliest arrival with the peak <= {self.peak_text(self.deflection_limit)}")
        ax.set_ylabel(f"{label} (re-simulated)")
        deflection_axis(ax, self.eccentricity_m)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict[str, Figure]:
        """The front; the speed and deflection of its points and of the earliest arrival (black, the limit dotted)."""
        self._runs()
        title = self.title
        factor, label, _ = self._shown()
        fig, ax = new_figure((8.5, 4.8))
        self.draw(ax)
        fig.suptitle(title, fontsize=8)
        fig2, (a0, a1) = new_figure((8, 7), 2, 1, sharex=True)
        cmap = [f"C{i % 10}" for i in range(len(self.points))]
        runs = [(p, c, 0.9, f"arrival by {p.arrival_time_s:.3g} s") for p, c in zip(self.points, cmap, strict=True)]
        if self.limited_point is not None:
            runs.append((self.limited_point, "k", 1.6, f"earliest arrival, {self.limited_point.arrival_time_s:.4g} s"))
        ft, fw = unit_axis(a1, "time t", "s", which="x"), speed_axis(a0)
        for p, c, lw, lab in runs:
            a0.plot(p.trajectory.t * ft, p.trajectory.omega * fw, color=c, lw=lw, label=lab)
            a1.plot(p.trajectory.t * ft, factor * deflection_of(p.trajectory), color=c, lw=lw,
                    label=f"peak {self.peak_text(p.peak)}")
        if self.limited_point is not None:
            a1.axhline(factor * self.deflection_limit, color="k", ls=":", lw=0.8)
        a1.set_ylabel(label.replace("peak deflection", "deflection").replace("^*", "").replace("r*", "r"))
        deflection_axis(a1, self.eccentricity_m)
        for a in (a0, a1):
            a.grid(alpha=0.3)
            a.legend(fontsize=6, ncols=2)
        fig2.suptitle(title, fontsize=8)
        return {f"{self.name}_front.png": Figure(fig, self.CAPTIONS["front"]),
                f"{self.name}_profiles.png": Figure(fig2, self.CAPTIONS["profiles"])}


@record
class ModalTimeOptimalResult(TimeOptimalResult):
    """The time-optimal study of the modal (ROSS) rotor (``ross_spinup_time_optimal``): peaks in m (the largest
    whirl radius over the nodes of interest, 0-peak, shown in µm), the reduced rotor's modes, nodes and critical
    speeds; the drive is the acceleration limit only."""

    ramp_peak: float = _ramp_peak("m")
    front: list[ModalPoint]
    deflection_limit: float | None = _limit("m")
    peak_deflection: float | None = _peak_deflection("m")
    limited: ModalPoint | None = optional(present_with="deflection_limit")
    name = "ross_spinup_time_optimal"
    CAPTIONS = {"front": "Time-optimal spin-up of the ROSS rotor: the smallest re-simulated peak against the "
                         "arrival deadline, the ramp and the earliest arrival under the limit",
                "profiles": "Time-optimal spin-up of the ROSS rotor: speed and deflection of the front's points "
                            "and of the earliest arrival"}
    null_reasons = {"deflection_limit_m" if k == "deflection_limit_over_e" else k: v
                    for k, v in TimeOptimalResult.null_reasons.items()}


TimeOptimalResult.quantities = declarations(TimeOptimalResult)
ModalTimeOptimalResult.quantities = declarations(ModalTimeOptimalResult)
#: every number of a time-optimal block: ``spinup_time_optimal`` (the Jeffcott rotor, peaks delta/e) and
#: ``ross_spinup_time_optimal`` (the modal rotor, peaks in m shown in µm), from the fields of the two Results
QUANTITIES = Declarations(*TimeOptimalResult.quantities, *ModalTimeOptimalResult.quantities)


def run(ocp, method: DirectCollocation, points: int, title: str = "", multistart: bool = True,
        options: dict | None = None) -> TimeOptimalResult:
    """The front of peak against arrival time and, when ``ocp.deflection_limit`` is set, the earliest arrival
    at that limit.

    Parameters
    ----------
    ocp : SpinupOcp or ModalSpinupOcp
        The problem (SI; objective peak_deflection): the Jeffcott rotor's (:class:`autobal.ocp.problem.SpinupOcp`,
        a limit in delta/e) or the modal rotor's (:class:`autobal.ocp.modal.ModalSpinupOcp`, a limit in m); its
        horizon is the latest arrival (the front's slow end), s.
    method : DirectCollocation
        The transcription (its control step is kept at every deadline).
    points : int
        Points of the front between its ends.
    title : str
        The scene's title.
    multistart : bool
        Multi-start of the minimum-peak problem at each deadline.
    options : dict, optional
        IPOPT options.

    Returns
    -------
    TimeOptimalResult
        Arrival times in s, peaks in delta/e (Jeffcott) or m (:class:`ModalTimeOptimalResult` of the modal rotor),
        as its ``peak_unit`` states.
    """
    jeffcott = isinstance(ocp, SpinupOcp)
    fr = to.front(ocp, method, points, options, multistart)
    limited = None
    if ocp.deflection_limit is not None:
        limited, lower = to.earliest_arrival(ocp, method, ocp.deflection_limit, fr, options, multistart)
    every = fr.points + ([limited] if limited else [])
    own = [p for p in every if p.held_from_s is None]  # a held point repeats an earlier one's solve
    cls, point = (TimeOptimalResult, Point) if jeffcott else (ModalTimeOptimalResult, ModalPoint)
    if jeffcott:
        model = {"eccentricity_m": ocp.params.e}
    else:
        model = {"nodes": list(ocp.nodes), "modes": ocp.rotor.n,
                 "critical_speeds_rad_s": list(ocp.rotor.critical_speeds(ocp.rotor.cutoff_rad_s)["wd"]),
                 "drive": "the acceleration limit only: the time-optimal study of the modal rotor takes no drive "
                          "torque or power model"}
    limit = ocp.deflection_limit
    if limit is None:
        end = {}
    elif limited:
        end = {"arrival_time_s": limited.arrival_time_s, "peak_deflection": limited.peak,
               "arrival_time_lower_bound_s": lower, "limited": _point(point, limited)}
    else:  # the maximum-acceleration ramp keeps the limit: it arrives first
        end = {"arrival_time_s": fr.ramp_arrival_time_s, "peak_deflection": fr.ramp.peak}
    return cls(
        title, method.label, ocp.deflection_unit, **model, horizon_s=ocp.horizon, ramp_label=fr.ramp.label,
        final_speed_rad_s=ocp.omega_final, ramp_arrival_time_s=fr.ramp_arrival_time_s, ramp_peak=fr.ramp.peak,
        front=[_point(point, p) for p in fr.points],
        # the ramp, the front and the earliest arrival by arrival time: the peak non-increasing up to the
        # multi-start's tie tolerance (beyond some deadline the peak no longer falls)
        monotone=bool(np.all(np.diff(pk := [fr.ramp.peak] + [p.peak for p in sorted(
            every, key=lambda p: p.arrival_time_s)]) <= TIE * np.array(pk[1:]))),
        build_time_s=sum(p.optimum.build_time_s for p in own), solve_time_s=sum(p.solve_time_s for p in own),
        resimulation_rel_error=max(p.resimulation_rel_error for p in every),
        accuracy={"estimate": max(p.resimulation_rel_error for p in every),
                  "how": "largest relative difference between a point's collocation peak and its CVODES "
                         "re-simulation"},
        deflection_limit=limit, **end,
        limit_margin=None if limit is None else 1 - end["peak_deflection"] / limit,
        points=fr.points, limited_point=limited, front_run=fr)


def _point(cls, p: to.FrontPoint) -> Point:
    """The record of a front point (:class:`Point`, or :class:`ModalPoint` for the modal rotor)."""
    return cls(p.arrival_time_s, p.peak, p.collocation_peak, p.resimulation_rel_error, p.optimum.ocp.objective,
               p.intervals, p.held_from_s, p.iterations, p.optimum.build_time_s, p.solve_time_s)
