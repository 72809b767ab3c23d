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
from autobal.ocp.problem import SpinupOcp
from autobal.ocp.solve import TIE
from autobal.ocp.spinup_study import deflection_axis, deflection_text
from autobal.ocp.transcription import DirectCollocation


def _point(*keys: str) -> str:
    """The keys of a front point and of the earliest arrival (``limited``)."""
    return " ".join(f"{w}.{k}" for k in keys for w in ("front[]", "limited"))


#: every number of the spinup_time_optimal block: peaks delta/e (Pashkov (2010), Eq. (2)), the physical deflection
#: (0-peak) e delta/e beside them in the summary; the headline quantities first, in summary order
QUANTITIES = Declarations(
    Quantity("arrival_time_s", "s", "T", "earliest arrival at the final speed with the peak within the limit",
             headline=True),
    Quantity("peak_deflection_over_e", "1", "δ*/e", "peak deflection of the earliest arrival (re-simulated)",
             headline=True),
    Quantity("deflection_limit_over_e", "1", "δ_lim/e", "peak limit of the scene", headline=True),
    Quantity("ramp_arrival_time_s", "s", "T_ramp", "arrival of the maximum-acceleration ramp", headline=True),
    Quantity("ramp_peak_over_e", "1", "δ*/e", "peak of the maximum-acceleration ramp", headline=True),
    Quantity("final_speed_rad_s", "rad/s", "ω_f", "final speed", headline=True),
    Quantity("eccentricity_m", "m", "e", "eccentricity (a peak δ*/e is the deflection δ* = e δ*/e, 0-peak)", "µm"),
    Quantity("arrival_time_lower_bound_s", "s", "", "latest front deadline whose minimum peak exceeds the limit"),
    Quantity("horizon_s", "s", "", "latest arrival (the front's slow end)"),
    Quantity(_point("arrival_time_s", "held_from_s"), "s", "T", "arrival deadline of a front point (held from an "
             "earlier point's profile)"),
    Quantity(_point("resimulated_peak_over_e", "collocation_peak_over_e"), "1", "δ*/e",
             "peak of a front point: re-simulated, collocation"),
    Quantity(_point("resimulation_rel_error", "intervals", "iterations") + " resimulation_rel_error", "1", "",
             "relative difference collocation vs CVODES; intervals and iterations of a point"),
    Quantity(_point("build_time_s", "solve_time_s") + " build_time_s solve_time_s", "s", "", "build and solve times"),
)


@dataclass
class TimeOptimalResult(Result):
    """The front of peak deflection against arrival time (every point re-simulated) and its two ends."""

    data: dict
    front: to.Front
    limited: to.FrontPoint | None  # the earliest arrival at the scene's deflection_limit (None: the ramp)
    name = "spinup_time_optimal"
    quantities = QUANTITIES

    @property
    def arrival_times(self) -> np.ndarray:
        """Arrival times of the front's points, s (limits increasing)."""
        return np.array([p["arrival_time_s"] for p in self.data["front"]])

    @property
    def peaks(self) -> np.ndarray:
        """Re-simulated peaks of the front's points, delta/e."""
        return np.array([p["resimulated_peak_over_e"] for p in self.data["front"]])

    def to_dict(self) -> dict:
        return self.data

    def verdict(self) -> tuple[bool | None, str]:
        return verdict(self.data)

    def summary(self) -> str:
        d = self.data
        ok, words = self.verdict()

        def pk(x):
            return deflection_text(x, d["eccentricity_m"])

        lines = [f"time-optimal spin-up: {'ok' if ok else 'NOT OK'}: {words}", *QUANTITIES.lines(d),
                 f"  {d['method']}: front of {len(d['front'])} points, build {d['build_time_s']:.2f} s, solve "
                 f"{d['solve_time_s']:.2f} s; peaks δ*/e and the deflection δ* = e δ*/e, 0-peak (e = "
                 f"{QUANTITIES.find('eccentricity_m').text(d['eccentricity_m'])})",
                 f"  fast end: {d['ramp_label']} arrives at {d['ramp_arrival_time_s']:.4g} s, peak "
                 f"{pk(d['ramp_peak_over_e'])}"]
        for p in d["front"]:
            lines.append(f"  arrival by {p['arrival_time_s']:.4f} s: peak {pk(p['resimulated_peak_over_e'])} "
                         f"(collocation {significant(p['collocation_peak_over_e'])} e, "
                         f"{100 * p['resimulation_rel_error']:.2f} %)")
        if d.get("deflection_limit_over_e") is not None:
            by = (d["limited"] or {}).get("objective")
            how = {"min_time": "by the min_time OCP", "peak_deflection": "by regula falsi on the minimum-peak "
                   "deadline"}.get(by, "the ramp")
            lines.append(f"  earliest arrival with the peak <= {significant(d['deflection_limit_over_e'])} e: "
                         f"{d['arrival_time_s']:.4f} s {how} (the minimum-peak OCP with the deadline "
                         f"{d.get('arrival_time_lower_bound_s', float('nan')):.4f} s exceeds the limit)")
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        f = self.data["front"]
        out = {"spinup_time_optimal_front.csv": {k: [p[k] for p in f] for k in f[0]}}
        if self.limited is not None:
            tr = self.limited.trajectory
            out["spinup_time_optimal_profile.csv"] = {"t_s": tr.t, "omega_rad_s": tr.omega,
                                                      "deflection_over_e": tr.delta}
        return out

    def draw(self, ax) -> None:
        """The front: re-simulated peak against arrival time, with the two ends."""
        d = self.data
        # the front through the ramp, its points and the earliest arrival
        line = np.array(sorted([(d["ramp_arrival_time_s"], d["ramp_peak_over_e"]),
                                *zip(self.arrival_times, self.peaks, strict=True)]
                               + ([(d["arrival_time_s"], d["peak_deflection_over_e"])] if self.limited else [])))
        ft = unit_axis(ax, "arrival time at the final speed", "s", which="x")
        ax.plot(line[:, 0] * ft, line[:, 1], "-", color="0.6", lw=0.8)
        ax.plot(np.asarray(self.arrival_times) * ft, self.peaks, "o", color="C3",
                label="minimum peak for an arrival deadline")
        ax.plot(d["ramp_arrival_time_s"] * ft, d["ramp_peak_over_e"], "s", color="C2", label=d["ramp_label"])
        if d.get("deflection_limit_over_e") is not None:
            ax.axhline(d["deflection_limit_over_e"], color="k", ls=":", lw=0.8)
            ax.plot(d["arrival_time_s"] * ft, d["peak_deflection_over_e"], "*", ms=12, color="k",
                    label=f"earliest arrival with the peak <= {d['deflection_limit_over_e']:.4g} e")
        ax.set_ylabel(r"peak deflection $\delta^*/e$ (re-simulated)")
        deflection_axis(ax, self.data.get("eccentricity_m"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict:
        """The front; the speed and deflection of its points."""
        title = self.data["title"]
        fig, ax = new_figure((8.5, 4.8))
        self.draw(ax)
        fig.suptitle(title, fontsize=8)
        fig2, (a0, a1) = new_figure((8, 7), 2, 1, sharex=True)
        cmap = [f"C{i % 10}" for i in range(len(self.front.points))]
        ft, fw = unit_axis(a1, "time t", "s", which="x"), speed_axis(a0)
        for p, c in zip(self.front.points, cmap, strict=True):
            a0.plot(p.trajectory.t * ft, p.trajectory.omega * fw, color=c, lw=0.9,
                    label=f"arrival by {p.arrival_time_s:.3g} s")
            a1.plot(p.trajectory.t * ft, p.trajectory.delta, color=c, lw=0.9,
                    label=f"peak {deflection_text(p.peak, self.data['eccentricity_m'])}")
        a1.set_ylabel(r"deflection $\delta/e$")
        deflection_axis(a1, self.data.get("eccentricity_m"))
        for a in (a0, a1):
            a.grid(alpha=0.3)
            a.legend(fontsize=6, ncols=2)
        fig2.suptitle(title, fontsize=8)
        return {"spinup_time_optimal_front.png": fig, "spinup_time_optimal_profiles.png": fig2}


def verdict(d: dict) -> tuple[bool | None, str]:
    """The time-optimal spin-up's one verdict from its results.json block: with a peak limit, the earliest arrival
    at the final speed whose re-simulated peak keeps it; without one, whether the front's peak falls with the
    deadline."""
    speed = QUANTITIES.find("final_speed_rad_s").text(d["final_speed_rad_s"])
    if d.get("deflection_limit_over_e") is None:
        return d["monotone"], (f"front of {len(d['front'])} deadlines to {speed}: the smallest peak "
                               + ("falls with the arrival deadline" if d["monotone"] else "is NOT monotone in the "
                                  "deadline (a local optimum)"))
    lim = d["deflection_limit_over_e"]

    def pk(x):
        return deflection_text(x, d["eccentricity_m"])

    ok = d["peak_deflection_over_e"] <= lim * (1 + 1e-6)
    return ok, (f"earliest arrival at {speed} with the peak ≤ {significant(lim)} e: {significant(d['arrival_time_s'])}"
                f" s, peak {pk(d['peak_deflection_over_e'])}; the maximum-acceleration ramp arrives at "
                f"{significant(d['ramp_arrival_time_s'])} s with {pk(d['ramp_peak_over_e'])}")


def run(ocp: SpinupOcp, method: DirectCollocation, points: int, title: str = "", multistart: bool = True,
        options: dict | None = None) -> TimeOptimalResult:
    """The front of peak against arrival time and, when ``ocp.deflection_limit`` is set, the earliest arrival
    at that limit.

    Parameters
    ----------
    ocp : SpinupOcp
        The problem (SI); its horizon is the latest arrival (the front's slow end), s.
    method : DirectCollocation
        The transcription.
    points : int
        Points of the front between its ends.
    title : str
        The scene's title.
    multistart : bool
        Multi-start of the minimum-peak problem at the slow end.
    options : dict, optional
        IPOPT options.

    Returns
    -------
    TimeOptimalResult
        Arrival times in s, peaks in delta/e.
    """
    fr = to.front(ocp, method, points, options, multistart)
    limited = None
    if ocp.deflection_limit is not None:
        limited, lower = to.earliest_arrival(ocp, method, ocp.deflection_limit, fr, options, multistart)
    every = fr.points + ([limited] if limited else [])
    own = [p for p in every if p.held_from_s is None]  # a held point repeats an earlier one's solve
    data = {
        "title": title, "method": method.label, "horizon_s": ocp.horizon, "ramp_label": fr.ramp.label,
        "final_speed_rad_s": ocp.omega_final, "eccentricity_m": ocp.params.e,
        "ramp_arrival_time_s": fr.ramp_arrival_time_s, "ramp_peak_over_e": fr.ramp.peak_delta,
        "front": [p.to_dict() for p in fr.points],
        # the ramp, the front and the earliest arrival by arrival time: the peak non-increasing up to the
        # multi-start's tie tolerance (beyond some deadline the peak no longer falls)
        "monotone": bool(np.all(np.diff(pk := [fr.ramp.peak_delta] + [p.peak for p in sorted(
            every, key=lambda p: p.arrival_time_s)]) <= TIE * np.array(pk[1:]))),
        "build_time_s": sum(p.optimum.build_time_s for p in own),
        "solve_time_s": sum(p.to_dict()["solve_time_s"] for p in own),
        "resimulation_rel_error": max(p.resimulation_rel_error for p in every),
        "accuracy": {"estimate": max(p.resimulation_rel_error for p in every),
                     "how": "largest relative difference between a point's collocation peak and its CVODES "
                            "re-simulation"},
        "deflection_limit_over_e": ocp.deflection_limit,
    }
    if ocp.deflection_limit is not None:
        data |= ({"arrival_time_s": limited.arrival_time_s, "peak_deflection_over_e": limited.peak,
                  "arrival_time_lower_bound_s": lower, "limited": limited.to_dict()} if limited else
                 {"arrival_time_s": fr.ramp_arrival_time_s, "peak_deflection_over_e": fr.ramp.peak_delta,
                  "limited": None})
    data = with_statuses(data, {"deflection_limit_over_e": "no deflection_limit in the scene: the front only",
                                "held_from_s": "the point's own minimum-peak optimum",
                                "limited": "the maximum-acceleration ramp keeps the limit: it arrives first"})
    return TimeOptimalResult(data, fr, limited)
