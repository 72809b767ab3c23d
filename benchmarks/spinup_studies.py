"""Benchmark: solve times of the spin-up studies beyond one nominal rotor (issue 15): the shipped scenes
``spinup_robust_jeffcott`` (robust spin-up), ``spinup_time_optimal`` (earliest arrival and the front) and
``spinup_ross_rotor`` (multi-mode ROSS rotor, needs ``pip install -e '.[ross]'``), each run once through
:func:`autobal.api.run`; and the study time of the nominal spin-up (issue 14: the whole study under 2 s) on the
three shipped scenes ``spinup_jeffcott_deadline_5s``, ``spinup_jeffcott_horizon_10s`` and
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
from benchmarks._results import case, write

NO_PEER = "no peer: no other tool solves these problems (robust, time-optimal, multi-mode spin-up)"


def robust(d: dict) -> dict:
    """Timings (s) of a spinup_robust Result: the nominal optimum and the scenario generation's NLPs."""
    return {"build": d["build_time_s"] + d["nominal_build_time_s"],
            "solve": d["solve_time_s"] + d["nominal_solve_time_s"], "validation": d["validation_time_s"],
            "detail": f"nominal optimum: build {d['nominal_build_time_s']:.1f} s, solve "
                      f"{d['nominal_solve_time_s']:.1f} s; robust NLPs ({len(d['rounds'])} NLP solves): build "
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
    from autobal import adapters
    from autobal.models import ross_rotor as rr

    t0 = time.perf_counter()
    rotor = rr.ross_rotor(adapters.ross_rotor(scene.ross_rotor)[0])
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
    return cases + study_time()


SCENES = ("spinup_jeffcott_deadline_5s", "spinup_jeffcott_horizon_10s", "spinup_liquid_balancer")
# one fresh process per scene: its import, then the spinup analysis as `autobal run` does it (no files)
CHILD = """
import json, os, sys, time
w, c = time.perf_counter(), time.process_time()
from autobal import api
from autobal.runners import RUNNERS
import autobal.ocp.spinup_study
imp = (time.perf_counter() - w, time.process_time() - c)
scene = api.load(sys.argv[1])
w, c, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
d = RUNNERS["spinup"](scene, scene.analyses.spinup).to_dict()
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
                                                                       "resimulation", "baselines", "rest"))
                    + f" | {r['load_before']:.1f} → {r['load_after']:.1f} |")
    table = ("| scene | peak (e) | import (s) | study wall (s) | study CPU (s) | global search | guesses | builds | "
             "IPOPT solves | re-simulations | baselines | rest | load (1 min) |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n" + "\n".join(rows))
    write("spinup_study_time", "Spin-up study time (issue 14: the whole study under 2 s)", cases, [
        "autobal (s) is the IPOPT solve time of every solve of the study, autobal build (s) the NLP builds; the "
        "error is the collocation-vs-re-simulation difference of the optimum. No peer: the peer fields are null.",
        "Each scene in a fresh Python process: import of autobal and the spin-up modules, then the scene's spinup "
        "analysis (the runner `autobal run` calls; no files written). The split (s, wall) is the Result's own "
        "time_split; study CPU is the process's CPU time over the analysis.",
        "The machine is shared (2 cores, up to 8 jobs): wall times stretch with the load average shown; CPU "
        "times much less."], [table])
    return cases


if __name__ == "__main__":
    study_time() if sys.argv[1:] == ["study-time"] else main()
