"""The ``spinup_time_optimal`` analysis of a scene: the earliest arrival at the final speed with the peak
bounded (when the scene gives ``deflection_limit``) and the Pareto front of peak against arrival time, each
point re-simulated (:mod:`autobal.ocp.time_optimal`).

``run(...)`` returns a :class:`TimeOptimalResult` (results.json block, the front as a CSV table, figures: the
front, and the profiles of the front's points).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autobal.analysis.quantities import Declarations, Quantity, significant
from autobal.analysis.result import Result, new_figure, speed_axis, unit_axis, with_statuses
from autobal.ocp import time_optimal as to
from autobal.ocp.drive_profile import drive_table
from autobal.ocp.problem import PEAK_KEY, SpinupOcp
from autobal.ocp.robust_study import PEAK_SYMBOL, deflection_of
from autobal.ocp.robust_study import peak_text as _peak_text
from autobal.ocp.solve import TIE
from autobal.ocp.spinup_study import deflection_axis
from autobal.ocp.transcription import DirectCollocation


def _point(*keys: str) -> str:
    """The keys of a front point and of the earliest arrival (``limited``)."""
    return " ".join(f"{w}.{k}" for k in keys for w in ("front[]", "limited"))


def _peaks(unit: str) -> tuple[tuple[Quantity, ...], tuple[Quantity, ...]]:
    """The peaks of the block in ``unit`` ("1": delta/e; "m": the modal rotor's, shown in µm): (headline, rest)."""
    s, sym, shown = PEAK_KEY[unit], PEAK_SYMBOL[unit], "" if unit == "1" else "µm"
    lim = "δ_lim/e" if unit == "1" else "r_lim"
    return ((Quantity(f"peak_deflection_{s}", unit, sym, "peak deflection of the earliest arrival (re-simulated)",
                      shown, headline=True),
             Quantity(f"deflection_limit_{s}", unit, lim, "peak limit of the scene", shown, headline=True)),
            (Quantity(f"ramp_peak_{s}", unit, sym, "peak of the maximum-acceleration ramp", shown, headline=True),
             Quantity(_point(f"resimulated_peak_{s}", f"collocation_peak_{s}"), unit, sym,
                      "peak of a front point: re-simulated, collocation", shown)))


#: every number of a time-optimal block: ``spinup_time_optimal`` (the Jeffcott rotor, peaks delta/e (Pashkov (2010),
#: Eq. (2)), the physical deflection (0-peak) e delta/e beside them in the summary) and ``ross_spinup_time_optimal``
#: (the modal rotor, peaks in m shown in µm, the largest whirl radius over the nodes of interest, 0-peak); the
#: headline quantities first, in summary order
QUANTITIES = Declarations(
    Quantity("arrival_time_s", "s", "T", "earliest arrival at the final speed with the peak within the limit",
             headline=True),
    *_peaks("1")[0], *_peaks("m")[0],
    Quantity("limit_margin", "1", "", "margin of the earliest arrival's peak below the limit, 1 − peak/limit",
             headline=True),
    Quantity("ramp_arrival_time_s", "s", "T_ramp", "arrival of the maximum-acceleration ramp", headline=True),
    _peaks("1")[1][0], _peaks("m")[1][0],
    Quantity("final_speed_rad_s", "rad/s", "ω_f", "final speed", headline=True),
    Quantity("eccentricity_m", "m", "e", "eccentricity (a peak δ*/e is the deflection δ* = e δ*/e, 0-peak)", "µm"),
    Quantity("arrival_time_lower_bound_s", "s", "", "latest front deadline whose minimum peak exceeds the limit"),
    Quantity("horizon_s", "s", "", "latest arrival (the front's slow end)"),
    Quantity(_point("arrival_time_s", "held_from_s"), "s", "T", "arrival deadline of a front point (held from an "
             "earlier point's profile)"),
    _peaks("1")[1][1], _peaks("m")[1][1],
    Quantity(_point("resimulation_rel_error", "intervals", "iterations") + " resimulation_rel_error", "1", "",
             "relative difference collocation vs CVODES; intervals and iterations of a point"),
    Quantity(_point("build_time_s", "solve_time_s") + " build_time_s solve_time_s", "s", "", "build and solve times"),
    Quantity("critical_speeds_rad_s", "rad/s", "ω_c", "critical speeds of the reduced rotor's modes (up to its mode "
             "cutoff)"),
    Quantity("modes nodes", "1", "", "modes of the reduced rotor; the nodes whose deflection counts"),
)


@dataclass
class TimeOptimalResult(Result):
    """The front of peak deflection against arrival time (every point re-simulated) and its two ends (peaks in the
    unit the block states: delta/e for the Jeffcott rotor, m for the modal rotor)."""

    data: dict
    front: to.Front
    limited: to.FrontPoint | None  # the earliest arrival at the scene's deflection_limit (None: the ramp)
    name: str = "spinup_time_optimal"
    quantities = QUANTITIES

    @property
    def key(self) -> str:
        """The suffix of the block's peaks: ``over_e`` or ``m``."""
        return PEAK_KEY[self.data["peak_unit"]]

    @property
    def arrival_times(self) -> np.ndarray:
        """Arrival times of the front's points, s (limits increasing)."""
        return np.array([p["arrival_time_s"] for p in self.data["front"]])

    @property
    def peaks(self) -> np.ndarray:
        """Re-simulated peaks of the front's points, in the block's ``peak_unit`` (delta/e or m)."""
        return np.array([p[f"resimulated_peak_{self.key}"] for p in self.data["front"]])

    def to_dict(self) -> dict:
        return self.data

    def verdict(self) -> tuple[bool | None, str]:
        return verdict(self.data)

    def _shown(self) -> tuple[float, str, str]:
        """(factor, axis label, CSV suffix) of the peaks as a person reads them: delta/e, or µm."""
        if self.data["peak_unit"] == "1":
            return 1.0, r"peak deflection $\delta^*/e$", "over_e"
        q = QUANTITIES.find("peak_deflection_m")
        return q.shown(1.0), f"peak deflection r*, {q.display} 0-peak", q.display.replace("µ", "u")

    def summary(self) -> str:
        d, s = self.data, self.key
        ok, words = self.verdict()

        def pk(x):
            return peak_text(d, x)

        if d["peak_unit"] == "1":
            unit = (f"peaks δ*/e and the deflection δ* = e δ*/e, 0-peak (e = "
                    f"{QUANTITIES.find('eccentricity_m').text(d['eccentricity_m'])})")
        else:
            unit = f"peaks r*, the largest whirl radius over the nodes {d['nodes']}, 0-peak; {d['drive']}"
        lines = [f"time-optimal spin-up: {'ok' if ok else 'NOT OK'}: {words}", *QUANTITIES.lines(d),
                 f"  {d['method']}: front of {len(d['front'])} points, build {d['build_time_s']:.2f} s, solve "
                 f"{d['solve_time_s']:.2f} s; {unit}",
                 f"  fast end: {d['ramp_label']} arrives at {d['ramp_arrival_time_s']:.4g} s, peak "
                 f"{pk(d[f'ramp_peak_{s}'])}"]
        for p in d["front"]:
            lines.append(f"  arrival by {p['arrival_time_s']:.4f} s: peak {pk(p[f'resimulated_peak_{s}'])} "
                         f"(collocation {pk(p[f'collocation_peak_{s}'])}, "
                         f"{100 * p['resimulation_rel_error']:.2f} %)")
        if d.get(f"deflection_limit_{s}") is not None:
            by = (d["limited"] or {}).get("objective")
            how = {"min_time": "by the min_time OCP", "peak_deflection": "by regula falsi on the minimum-peak "
                   "deadline"}.get(by, "the ramp")
            lines.append(f"  earliest arrival with the peak <= {pk(d[f'deflection_limit_{s}'])}: "
                         f"{d['arrival_time_s']:.4f} s {how} (the minimum-peak OCP with the deadline "
                         f"{d.get('arrival_time_lower_bound_s', float('nan')):.4f} s exceeds the limit)")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        factor, _, col = self._shown()
        s = self.key
        f = self.data["front"]
        front = {}
        for k in f[0]:
            peak = k.endswith("_" + s)
            front[k[:-len(s)] + col if peak else k] = [factor * p[k] if peak else p.get(k) for p in f]
        out = {f"{self.name}_front.csv": front}
        if self.limited is not None:
            tr = self.limited.trajectory
            out[f"{self.name}_profile.csv"] = {"t_s": tr.t, "omega_rad_s": tr.omega,
                                               f"deflection_{col}": factor * deflection_of(tr)}
            out["drive_profile.csv"] = drive_table(tr)
        return out

    def draw(self, ax) -> None:
        """The front: re-simulated peak against arrival time, with the two ends."""
        d, s = self.data, self.key
        factor, label, _ = self._shown()
        # the front through the ramp, its points and the earliest arrival
        line = np.array(sorted([(d["ramp_arrival_time_s"], d[f"ramp_peak_{s}"]),
                                *zip(self.arrival_times, self.peaks, strict=True)]
                               + ([(d["arrival_time_s"], d[f"peak_deflection_{s}"])] if self.limited else [])))
        ft = unit_axis(ax, "arrival time at the final speed", "s", which="x")
        ax.plot(line[:, 0] * ft, factor * line[:, 1], "-", color="0.6", lw=0.8)
        ax.plot(np.asarray(self.arrival_times) * ft, factor * self.peaks, "o", color="C3",
                label="minimum peak for an arrival deadline")
        ax.plot(d["ramp_arrival_time_s"] * ft, factor * d[f"ramp_peak_{s}"], "s", color="C2", label=d["ramp_label"])
        if d.get(f"deflection_limit_{s}") is not None:
            ax.axhline(factor * d[f"deflection_limit_{s}"], color="k", ls=":", lw=0.8)
            ax.plot(d["arrival_time_s"] * ft, factor * d[f"peak_deflection_{s}"], "*", ms=12, color="k",
                    label=f"earliest arrival with the peak <= {peak_text(d, d[f'deflection_limit_{s}'])}")
        ax.set_ylabel(f"{label} (re-simulated)")
        deflection_axis(ax, self.data.get("eccentricity_m"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict:
        """The front; the speed and deflection of its points and of the earliest arrival (black, the limit dotted)."""
        title = self.data["title"]
        factor, label, _ = self._shown()
        fig, ax = new_figure((8.5, 4.8))
        self.draw(ax)
        fig.suptitle(title, fontsize=8)
        fig2, (a0, a1) = new_figure((8, 7), 2, 1, sharex=True)
        cmap = [f"C{i % 10}" for i in range(len(self.front.points))]
        runs = [(p, c, 0.9, f"arrival by {p.arrival_time_s:.3g} s") for p, c in zip(self.front.points, cmap,
                                                                                  strict=True)]
        if self.limited is not None:
            runs.append((self.limited, "k", 1.6, f"earliest arrival, {self.limited.arrival_time_s:.4g} s"))
        ft, fw = unit_axis(a1, "time t", "s", which="x"), speed_axis(a0)
        for p, c, lw, lab in runs:
            a0.plot(p.trajectory.t * ft, p.trajectory.omega * fw, color=c, lw=lw, label=lab)
            a1.plot(p.trajectory.t * ft, factor * deflection_of(p.trajectory), color=c, lw=lw,
                    label=f"peak {peak_text(self.data, p.peak)}")
        if self.limited is not None:
            a1.axhline(factor * self.data[f"deflection_limit_{self.key}"], color="k", ls=":", lw=0.8)
        a1.set_ylabel(label.replace("peak deflection", "deflection").replace("^*", "").replace("r*", "r"))
        deflection_axis(a1, self.data.get("eccentricity_m"))
        for a in (a0, a1):
            a.grid(alpha=0.3)
            a.legend(fontsize=6, ncols=2)
        fig2.suptitle(title, fontsize=8)
        return {f"{self.name}_front.png": fig, f"{self.name}_profiles.png": fig2}


def peak_text(d: dict, x) -> str:
    """A peak of the block as read (:func:`autobal.ocp.robust_study.peak_text`)."""
    return _peak_text(x, d.get("peak_unit", "1"), d.get("eccentricity_m"))


def verdict(d: dict) -> tuple[bool | None, str]:
    """The time-optimal spin-up's one verdict from its results.json block: with a peak limit, the earliest arrival
    at the final speed whose re-simulated peak keeps it, and by how much; without one, whether the front's peak
    falls with the deadline."""
    s = PEAK_KEY[d.get("peak_unit", "1")]
    speed = QUANTITIES.find("final_speed_rad_s").text(d["final_speed_rad_s"])
    if d.get(f"deflection_limit_{s}") is None:
        return d["monotone"], (f"front of {len(d['front'])} deadlines to {speed}: the smallest peak "
                               + ("falls with the arrival deadline" if d["monotone"] else "is NOT monotone in the "
                                  "deadline (a local optimum)"))
    lim, peak = d[f"deflection_limit_{s}"], d[f"peak_deflection_{s}"]

    def pk(x):
        return peak_text(d, x)

    ok = peak <= lim * (1 + 1e-6)
    return ok, (f"earliest arrival at {speed} with the peak ≤ {pk(lim)}: {significant(d['arrival_time_s'])} s, peak "
                f"{pk(peak)} ({significant(100 * abs(1 - peak / lim))} % {'below' if ok else 'ABOVE'} the limit); "
                f"the maximum-acceleration ramp arrives at {significant(d['ramp_arrival_time_s'])} s with "
                f"{pk(d[f'ramp_peak_{s}'])}")


def run(ocp, method: DirectCollocation, points: int, title: str = "", multistart: bool = True,
        options: dict | None = None, name: str = "spinup_time_optimal") -> TimeOptimalResult:
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
    name : str
        The analysis (the results.json block, the file names).

    Returns
    -------
    TimeOptimalResult
        Arrival times in s, peaks in delta/e (Jeffcott) or m (modal), as its ``peak_unit`` states.
    """
    jeffcott = isinstance(ocp, SpinupOcp)
    s = PEAK_KEY[ocp.deflection_unit]
    fr = to.front(ocp, method, points, options, multistart)
    limited = None
    if ocp.deflection_limit is not None:
        limited, lower = to.earliest_arrival(ocp, method, ocp.deflection_limit, fr, options, multistart)
    every = fr.points + ([limited] if limited else [])
    own = [p for p in every if p.held_from_s is None]  # a held point repeats an earlier one's solve
    if jeffcott:
        model = {"eccentricity_m": ocp.params.e}
    else:
        model = {"nodes": list(ocp.nodes), "modes": ocp.rotor.n,
                 "critical_speeds_rad_s": list(ocp.rotor.critical_speeds(ocp.rotor.cutoff_rad_s)["wd"]),
                 "drive": "the acceleration limit only: the time-optimal study of the modal rotor takes no drive "
                          "torque or power model"}
    data = {
        "title": title, "method": method.label, "peak_unit": ocp.deflection_unit, **model, "horizon_s": ocp.horizon,
        "ramp_label": fr.ramp.label, "final_speed_rad_s": ocp.omega_final,
        "ramp_arrival_time_s": fr.ramp_arrival_time_s, f"ramp_peak_{s}": fr.ramp.peak,
        "front": [p.to_dict() for p in fr.points],
        # the ramp, the front and the earliest arrival by arrival time: the peak non-increasing up to the
        # multi-start's tie tolerance (beyond some deadline the peak no longer falls)
        "monotone": bool(np.all(np.diff(pk := [fr.ramp.peak] + [p.peak for p in sorted(
            every, key=lambda p: p.arrival_time_s)]) <= TIE * np.array(pk[1:]))),
        "build_time_s": sum(p.optimum.build_time_s for p in own),
        "solve_time_s": sum(p.to_dict()["solve_time_s"] for p in own),
        "resimulation_rel_error": max(p.resimulation_rel_error for p in every),
        "accuracy": {"estimate": max(p.resimulation_rel_error for p in every),
                     "how": "largest relative difference between a point's collocation peak and its CVODES "
                            "re-simulation"},
        f"deflection_limit_{s}": ocp.deflection_limit,
    }
    if ocp.deflection_limit is not None:
        data |= ({"arrival_time_s": limited.arrival_time_s, f"peak_deflection_{s}": limited.peak,
                  "arrival_time_lower_bound_s": lower, "limited": limited.to_dict()} if limited else
                 {"arrival_time_s": fr.ramp_arrival_time_s, f"peak_deflection_{s}": fr.ramp.peak,
                  "limited": None})
        data["limit_margin"] = 1 - data[f"peak_deflection_{s}"] / ocp.deflection_limit
    data = with_statuses(data, {f"deflection_limit_{s}": "no deflection_limit in the scene: the front only",
                                "held_from_s": "the point's own minimum-peak optimum",
                                "limited": "the maximum-acceleration ramp keeps the limit: it arrives first"})
    return TimeOptimalResult(data, fr, limited, name)
