"""Benchmark: solve times of the spin-up studies beyond one nominal rotor (issue 15): the shipped scenes
``spinup_robust_jeffcott`` (robust spin-up), ``spinup_time_optimal`` (earliest arrival and the front) and
``spinup_ross_rotor`` (multi-mode ROSS rotor, needs ``pip install -e '.[ross]'``), each run once through
:func:`autobal.api.run`; and the study time of the nominal spin-up with its ramp table (issue 26, item 5:
under 3 s) on the three shipped scenes ``spinup_jeffcott_deadline_5s``, ``spinup_jeffcott_horizon_10s`` and
``spinup_liquid_balancer``, each in a fresh process (:func:`study_time`, written as spinup_study_time.json).

Per study: the build time (transcriptions and IPOPT's derivative functions), the IPOPT solve time (every
solve of the study), the validation time where the Result records one, and the wall time of the analysis;
all read from each Result's ``to_dict`` and the run's timing.  These studies have no peer: the peer fields
are null.  Run: ``python -m benchmarks spinup_studies``; writes benchmarks/results/spinup_studies.json.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

from autobal import api
from autobal.errors import ScenarioError
from benchmarks._results import HERE, RESULTS, case, write

NO_PEER = "no peer: no other tool solves these problems (robust, time-optimal, multi-mode spin-up)"


def robust(d: dict) -> dict:
    """Timings (s) of a spinup_robust Result: the nominal optimum and the scenario generation's NLPs."""
    return {"build": d["build_time_s"] + d["nominal_build_time_s"],
            "solve": d["solve_time_s"] + d["nominal_solve_time_s"], "validation": d["validation_time_s"],
            "detail": f"nominal optimum: build {d['nominal_build_time_s']:.1f} s, solve "
                      f"{d['nominal_solve_time_s']:.1f} s; robust NLPs ({len(d['rounds'])} NLP solves from "
                      f"{len({r['start'] for r in d['rounds']})} starts and refinements): build "
                      f"{d['build_time_s']:.1f} s, solve {d['solve_time_s']:.1f} s; validation on "
                      f"{d['validation_samples']} rotors ({d['executor']})"}


def time_optimal(d: dict) -> dict:
    """Timings (s) of a spinup_time_optimal Result: every front point's and the earliest arrival's own solves."""
    return {"build": d["build_time_s"], "solve": d["solve_time_s"], "validation": None,
            "detail": f"{len(d['front'])} front points and the earliest arrival with the peak <= "
                      f"{d['deflection_limit_over_e']} e (each: global search, multi-start, mesh continuation)"}


def ross_spinup(d: dict) -> dict:
    """Timings (s) of a ross_spinup Result: one NLP, solved from each start."""
    return {"build": d["build_time_s"], "solve": d["total_solve_time_s"], "validation": None,
            "detail": f"{d['modes']} modes, {len(d['starts'])} starts (best: {d['ipopt_iterations']} IPOPT "
                      f"iterations, {d['solve_time_s']:.1f} s)"}


STUDIES = {"spinup_robust_jeffcott": ("spinup_robust", robust),
           "spinup_time_optimal": ("spinup_time_optimal", time_optimal),
           "spinup_ross_rotor": ("ross_spinup", ross_spinup)}


def ross_critical_speeds_time(scene) -> float:
    """Wall time (s) of ROSS's own critical speeds of the scene's rotor (the runner's validation step), alone."""
    from autobal.models import ross_rotor as rr
    from autobal.parts import ross_rotor as ross_rotor_part

    t0 = time.perf_counter()
    rotor = rr.ross_rotor(ross_rotor_part.adapt(scene.ross_rotor)[0])
    rr.ross_critical_speeds(rotor, scene.analyses.ross_spinup.final_speed)
    return time.perf_counter() - t0


def main() -> list[dict]:
    cases, rows, notes = [], [], []
    for name, (analysis, timings) in STUDIES.items():
        load0 = os.getloadavg()[0]
        try:
            scene = api.load(name)
            run = api.run(scene)
        except (ImportError, ScenarioError) as exc:  # the ross extra not installed
            notes.append(f"{name}: not run ({exc})")
            continue
        t = timings(run[analysis].to_dict())
        wall = run.timing[analysis]
        rest = wall - t["build"] - t["solve"] - (t["validation"] or 0.0)
        extra = {}
        if analysis == "ross_spinup":
            extra["ross_critical_speeds_s"] = ross_critical_speeds_time(scene)
            t["detail"] += f"; ROSS's critical speeds alone {extra['ross_critical_speeds_s']:.1f} s"
        load = os.getloadavg()[0]
        cases.append(case(f"{name} ({analysis})", t["solve"], t["build"], None, None, validation_s=t["validation"],
                          wall_s=wall, rest_s=rest, note=NO_PEER, load_average_before=round(load0, 2),
                          load_average_after=round(load, 2), **extra))
        rows.append(f"| `{name}` | {t['build']:.1f} | {t['solve']:.1f} | "
                    + (f"{t['validation']:.1f}" if t["validation"] is not None else "-")
                    + f" | {rest:.1f} | {wall:.1f} | {load0:.1f} → {load:.1f} | {t['detail']} |")
    notes = [
        NO_PEER + "; the peer fields are null. autobal (s) is the IPOPT solve time of every solve of the study, "
        "autobal build (s) the transcriptions and IPOPT's derivative functions.",
        "Per study (table below): validation is the re-simulation of the validation sample where the Result "
        "records it (robust: 10 profiles x the validation rotors, exponential integrator); rest = wall - build - "
        "solve - validation: the global searches, the CVODES re-simulations of every optimum and ramp, the "
        "reduction and ROSS's critical speeds (ross). One run each, through autobal.api.run: no files written, "
        "no figures made.",
        "The machine is shared (2 cores, up to 8 jobs): wall times stretch with the load average shown per study.",
    ] + notes
    table = ("| scene | build (s) | IPOPT solve (s) | validation (s) | rest (s) | wall (s) | load (1 min, before → "
             "after) | what |\n|---|---|---|---|---|---|---|---|\n" + "\n".join(rows))
    write("spinup_studies", "Spin-up studies: robust, time-optimal, multi-mode ROSS rotor (solve times)", cases,
          notes, [table])
    return cases + study_time() + study_scaling()


SCENES = ("spinup_jeffcott_deadline_5s", "spinup_jeffcott_horizon_10s", "spinup_liquid_balancer")
# one fresh process per scene: its import, then the spinup analysis as `autobal run` does it (no files)
CHILD = """
import json, os, sys, time
w, c = time.perf_counter(), time.process_time()
from autobal import api
from autobal import analyses
import autobal.ocp.spinup_study
imp = (time.perf_counter() - w, time.process_time() - c)
scene = api.load(sys.argv[1])
w, c, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
d = analyses.module("spinup").run(scene, scene.analyses.spinup).to_dict()
print(json.dumps({"import_wall_s": imp[0], "import_cpu_s": imp[1], "wall_s": time.perf_counter() - w,
                  "cpu_s": time.process_time() - c, "load_before": load, "load_after": os.getloadavg()[0],
                  "peak": d["peak_deflection_over_e"], "resimulation_rel_error": d["resimulation_rel_error"],
                  "split": d["time_split"], "iterations": [r.get("iterations") for r in d["starts"]]}))
"""


def study_time() -> list[dict]:
    """The whole nominal spin-up study of each scene (global search, starts, builds, solves, re-simulations,
    baselines) in a fresh process: wall and CPU time, the import, and the Result's own wall-time split."""
    cases, rows = [], []
    for name in SCENES:
        out = subprocess.run([sys.executable, "-c", CHILD, name], capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        sp = r["split"]
        cases.append(case(f"{name} (spinup study)", sp["solve_time_s"], sp["build_time_s"], None, None,
                          r["resimulation_rel_error"], wall_s=r["wall_s"], cpu_s=r["cpu_s"],
                          import_wall_s=r["import_wall_s"], import_cpu_s=r["import_cpu_s"],
                          peak_deflection_over_e=r["peak"], split_s=sp, load_average_before=round(r["load_before"], 2),
                          load_average_after=round(r["load_after"], 2), note=NO_PEER))
        rows.append(f"| `{name}` | {r['peak']:.6f} | {r['import_wall_s']:.2f} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | "
                    + " | ".join(f"{sp[k + '_time_s']:.2f}" for k in ("global_search", "guesses", "build", "solve",
                                                                       "resimulation", "baselines", "segments",
                                                                       "rest"))
                    + f" | {r['load_before']:.1f} → {r['load_after']:.1f} |")
    table = ("| scene | peak (e) | import (s) | study wall (s) | study CPU (s) | global search | guesses | builds | "
             "IPOPT solves | re-simulations | baselines | ramp table | rest | load (1 min) |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n" + "\n".join(rows))
    write("spinup_study_time", "Spin-up study time (issue 26, item 5: the whole study, its 4-segment ramp table "
          "included, under 3 s)", cases, [
        "autobal (s) is the IPOPT solve time of every solve of the study, autobal build (s) the NLP builds; the "
        "error is the collocation-vs-re-simulation difference of the optimum. No peer: the peer fields are null.",
        "Each scene in a fresh Python process: import of autobal and the spin-up modules, then the scene's spinup "
        "analysis (the runner `autobal run` calls; no files written). The split (s, wall) is the Result's own "
        "time_split; study CPU is the process's CPU time over the analysis.",
        "The machine is shared (2 cores, up to 8 jobs): wall times stretch with the load average shown; CPU "
        "times much less."], [table])
    return cases



# ---- study scaling with N (issue 14, item 4: solve time at most linear in the intervals) -----------------
SCALING_SCENE = "spinup_jeffcott_deadline_5s"
SCALING_N = (200, 400, 800, 1600)
# one fresh process per N: the scene with `intervals` overridden, the spinup analysis as `autobal run` does it;
# every IPOPT solve of the study timed (wall and CPU of the process) by wrapping Solver.solve; argv[3]: a JSON
# dict naming a lever measured side by side ({} = the study as shipped): "warm", overrides of the spinup_warm
# solver options; "stage_tol", the IPOPT tolerance of the intermediate mesh stages (the finest keeps the scene's)
SCALING_CHILD = """
import json, os, sys, time
from autobal import api
from autobal.analysis.run import solver_options
from autobal.ocp import solve as S
from autobal import analyses
lever, n_final = json.loads(sys.argv[3]), int(sys.argv[2])
solver_options.set_defaults("spinup_warm", **lever.get("warm", {}))
stages, solve, init = [], S.Solver.solve, S.Solver.__init__
def looser(self, ocp, method, ref=None, options=None, warm=False):
    tol = lever.get("stage_tol")  # the intermediate warm stages (not the final mesh) to a looser tolerance
    if tol and warm and method.intervals < n_final:
        options = (options or {}) | {"tol": tol, "constr_viol_tol": tol, "compl_inf_tol": tol}
    init(self, ocp, method, ref, options, warm)
S.Solver.__init__ = looser
def timed(self, *a, **k):
    w, c = time.perf_counter(), time.process_time()
    sol = solve(self, *a, **k)
    stages.append({"intervals": self.nlp.mesh.n, "iterations": sol.iterations, "solve_s": sol.solve_time_s,
                   "solve_cpu_s": time.process_time() - c - sol.guess_time_s, "build_s": self.build_time_s,
                   "success": bool(sol.success)})
    return sol
S.Solver.solve = timed
scene = api.load(sys.argv[1], set={"analyses.spinup.intervals": int(sys.argv[2])})
w, c, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
d = analyses.module("spinup").run(scene, scene.analyses.spinup).to_dict()
print(json.dumps({"wall_s": time.perf_counter() - w, "cpu_s": time.process_time() - c, "load_before": load,
                  "load_after": os.getloadavg()[0], "peak": d["peak_deflection_over_e"],
                  "collocation_peak": d["collocation_peak_over_e"], "split": d["time_split"], "stages": stages}))
"""


def slope(n, t) -> float:
    """Least-squares exponent p of t ~ n^p (log-log fit)."""
    import numpy as np

    return float(np.polyfit(np.log(n), np.log(t), 1)[0])


def scaling_run(n: int, lever: dict | None = None) -> dict:
    """The study at ``n`` intervals in a fresh process (``lever``: see SCALING_CHILD); the child's record."""
    out = subprocess.run([sys.executable, "-c", SCALING_CHILD, SCALING_SCENE, str(n), json.dumps(lever or {})],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def study_scaling(ns=SCALING_N, lever: dict | None = None, name: str = "spinup_study_scaling") -> list[dict]:
    """The toolkit's own spin-up study (screening on the coarse mesh, mesh doubling with primal-dual warm
    starts) at each N in ``ns`` intervals, each in a fresh process (``lever``: see SCALING_CHILD): per mesh
    stage its iterations, solve (wall, CPU) and build time; the study's total solve and wall time; exponents
    fitted over ``ns``.  Writes results/NAME.json."""
    cases, rows, recs = [], [], []
    for n in ns:
        r = scaling_run(n, lever)
        recs.append(r)
        st = r["stages"]
        fine = st[-1]
        total = sum(s["solve_s"] for s in st)
        cases.append(case(f"N = {n} (study)", total, sum({s["intervals"]: s["build_s"] for s in st}.values()), None,
                          None, abs(r["collocation_peak"] - r["peak"]) / r["peak"], wall_s=r["wall_s"],
                          cpu_s=r["cpu_s"], intervals=n, peak_deflection_over_e=r["peak"],
                          collocation_peak_over_e=r["collocation_peak"], total_solve_cpu_s=sum(s["solve_cpu_s"]
                                                                                               for s in st),
                          finest_solve_s=fine["solve_s"], finest_solve_cpu_s=fine["solve_cpu_s"],
                          finest_iterations=fine["iterations"], stages=st, split_s=r["split"],
                          load_average_before=round(r["load_before"], 2),
                          load_average_after=round(r["load_after"], 2), lever=lever or {}, note=NO_PEER))
        rows.append(f"| {n} | " + ", ".join(f"{s['intervals']}: {s['iterations']} / {s['solve_s']:.2f} / "
                                            f"{s['solve_cpu_s']:.2f}" for s in st)
                    + f" | {total:.2f} | {r['split']['build_time_s']:.2f} | {r['wall_s']:.2f} | {r['peak']:.7f} | "
                      f"{r['load_before']:.1f} → {r['load_after']:.1f} |")
    fits = []
    if len(ns) > 1:
        c = cases
        fit = {"total solve (wall)": [x["autobal_s"] for x in c],
               "total solve (CPU)": [x["total_solve_cpu_s"] for x in c],
               "finest stage solve (wall)": [x["finest_solve_s"] for x in c],
               "finest stage solve (CPU)": [x["finest_solve_cpu_s"] for x in c],
               "finest stage iterations": [x["finest_iterations"] for x in c],
               "finest stage CPU per iteration": [x["finest_solve_cpu_s"] / x["finest_iterations"] for x in c],
               "study wall": [x["wall_s"] for x in c], "builds": [x["autobal_build_s"] for x in c]}
        fits = [f"| {k} | {slope(ns, v):.2f} |" for k, v in fit.items()]
        for x in cases:
            x["exponents"] = {k: slope(ns, v) for k, v in fit.items()}
    table = ("| N | stages: intervals: iterations / solve wall (s) / solve CPU (s) | total solve (s) | builds (s) | "
             "study wall (s) | peak, re-simulated (e) | load (1 min) |\n|---|---|---|---|---|---|---|\n"
             + "\n".join(rows))
    tables = [table] + (["| fitted exponent p (t ~ N^p, over N = " + ", ".join(map(str, ns)) + ") | p |\n|---|---|\n"
                         + "\n".join(fits)] if fits else [])
    write(name, f"Spin-up study scaling with N ({SCALING_SCENE}"
          + (f", lever {lever}" if lever else "") + ")", cases, [
        "The toolkit's own study (autobal run's spinup analysis): every start screened on the coarse mesh "
        "(N / 2^k >= 50 intervals), the best refined by doubling the intervals, each stage warm-started with the "
        "coarser optimum's primal and dual values. autobal (s): wall time of every IPOPT solve of the study; "
        "autobal build (s): the NLP builds; error: collocation vs re-simulated peak. No peer.",
        "Each N in a fresh Python process; solve CPU is the process's CPU time over each IPOPT solve (the "
        "steadier measure on the shared 2-core machine; wall times stretch with the load shown)."], tables)
    if not lever and len(ns) > 1:
        scaling_figure()
    return cases


SCALING_FIGURE = HERE.parent / "docs" / "figures" / "benchmark_spinup_study_scaling.png"


def scaling_figure(path=SCALING_FIGURE) -> None:
    """Log-log solve time against N: the study (results/spinup_study_scaling.json: every solve, the finest
    stage, the whole study's wall time) beside the single solve from one guess, autobal and rockit
    (results/spinup_ocp.json)."""
    from matplotlib.figure import Figure

    study = json.loads((RESULTS / "spinup_study_scaling.json").read_text())["cases"]
    single = json.loads((RESULTS / "spinup_ocp.json").read_text())["cases"]
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.subplots()
    n = [c["intervals"] for c in study]
    exps = study[0].get("exponents", {})
    for key, y, label, mk in (
            ("study wall", "wall_s", "study, whole (wall: search, builds, solves, re-sim.)", "o-"),
            ("total solve (wall)", "autobal_s", "study, every IPOPT solve", "o-"),
            ("total solve (CPU)", "total_solve_cpu_s", "study, every IPOPT solve, CPU s", "o:"),
            ("finest stage solve (wall)", "finest_solve_s", "study, finest stage only", "o--")):
        ax.loglog(n, [c[y] for c in study], mk, label=f"{label}: N^{exps.get(key, float('nan')):.2f}")
    ns = [int(c["case"].split()[2]) for c in single]
    for side, label, mk in (("autobal", "single solve from one guess, autobal", "s:"),
                            ("rockit", "single solve, rockit (expand=True)", "^:")):
        pts = [(m, c[side]["solve_s"]) for m, c in zip(ns, single, strict=True) if c.get(side)]
        if len(pts) > 1:
            m, t = zip(*pts, strict=True)
            ax.loglog(m, t, mk, label=f"{label}: N^{slope(m, t):.2f}")
    t0 = study[0]["autobal_s"]
    ax.loglog(n, [t0 * x / n[0] for x in n], "k:", lw=0.8, label="$\\propto N$ (from the study's solve at N = "
              f"{n[0]})")
    ax.set_xticks(n, [str(x) for x in n])
    ax.minorticks_off()
    ax.grid(alpha=0.3, which="both")
    ax.set_xlabel("control intervals N to the deadline")
    ax.set_ylabel("time (s)")
    ax.legend(fontsize=7)
    load = [c["load_average_before"] for c in study]
    ax.set_title(f"Spin-up, spinup_jeffcott_deadline_5s: the study's mesh continuation against one solve\n"
                 f"(wall times unless named, exponents fitted over 200-1600; load {min(load):.1f}-"
                 f"{max(load):.1f} on 2 cores)",
                 fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    if sys.argv[1:2] == ["study-scaling"]:
        study_scaling(tuple(int(a) for a in sys.argv[2:]) or SCALING_N)
    else:
        study_time() if sys.argv[1:] == ["study-time"] else main()
