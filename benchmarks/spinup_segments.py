"""Benchmark: the K-segment ramp table's search (issue 26, items 4 and 5), its levers side by side.

On every shipped Jeffcott spin-up scene with a table, the full optimum is computed once (the study without a
table), then :func:`autobal.ocp.drive_profile.segment_profile` (K = 4) is run with:

- the shipped settings (the best start, the search integrator at ``SEGMENT_STEP``, 200 integrations);
- each other distinct start searched alone with the same budget (the previous search also searched the
  second-best start, with half the budget);
- the integrator at ``FAST_STEP`` (0.5, the previous setting), and 300 integrations.

Per run: the table's re-simulated objective (CVODES) and its loss against the full optimum, the CPU time of the
search (the peer is the shipped setting: ratio = lever's CPU / shipped CPU), and for the shipped table the
relative difference between the search integrator and CVODES on the kept profile.  Run:
``python -m benchmarks spinup_segments``; writes benchmarks/results/spinup_segments.json.
"""

from __future__ import annotations

import time

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.ocp import drive_profile as dp
from autobal.ocp import spinup_study
from autobal.ocp.search import FAST_STEP
from autobal.ocp.solve import ipopt_options
from benchmarks._results import case, write

SCENES = ("spinup_jeffcott_deadline_5s", "spinup_jeffcott_horizon_10s", "spinup_jeffcott_ramp_baselines",
          "spinup_rotor_datasheet", "spinup_liquid_balancer", "scenarios/examples/fan_rotor_spinup.yaml")
K = 4


def _timed(*args, **kw):
    """The K-segment table of ``segment_profile(*args, **kw)`` and the CPU time (s) of the call."""
    c = time.process_time()
    out = dp.segment_profile(*args, **kw)
    return out, time.process_time() - c


def main() -> list[dict]:
    cases, rows = [], []
    for name in SCENES:
        scene = api.load(name)
        s = scene.analyses.spinup
        ocp = spinup_ocp(scene, s)
        res = spinup_study.run(ocp, spinup_study.method_of(s), options=ipopt_options(s.max_iterations, s.tolerance))
        tr, full = res.optimum, res.objective_value
        shipped, cpu0 = _timed(ocp, tr, K)
        fast = dp.fast_segments(ocp, shipped.t, shipped.omega, dp.SEGMENT_STEP)
        integrator = dp.objective_of(ocp, fast) / shipped.objective - 1
        levers = {"shipped": (shipped, cpu0)}
        for start in shipped.start_objectives:
            if start != shipped.start:
                levers[f"start: {start}"] = _timed(ocp, tr, K, start=start)
        levers[f"step {FAST_STEP:g}"] = _timed(ocp, tr, K, step=FAST_STEP)
        levers["300 integrations"] = _timed(ocp, tr, K, 300)
        label = name.rsplit("/", 1)[-1].removesuffix(".yaml")
        for lever, (seg, cpu) in levers.items():
            loss = 100 * (seg.objective / full - 1)
            cases.append(case(f"{label}: {lever}", cpu, None, "shipped search", cpu0, None, None,
                              objective=seg.objective, full_optimum=full, loss_pct=loss, start=seg.start,
                              evaluations=seg.evaluations, within_drive_limits=seg.drive["within_drive_limits"],
                              **({"integrator_vs_cvodes": integrator} if lever == "shipped" else {})))
            rows.append(f"| `{label}` | {lever} | {seg.start} | {seg.objective:.6f} | {loss:+.3f} | {cpu:.2f} | "
                        f"{cpu / cpu0:.2f} | {seg.evaluations} |")
        rows.append(f"| `{label}` | (search integrator vs CVODES on the shipped table) | | | {100 * integrator:+.4f} "
                    "| | | |")
    table = ("| scene | lever | start searched | table objective (CVODES) | loss vs full optimum (%) | CPU (s) | "
             "CPU / shipped | integrations |\n|---|---|---|---|---|---|---|---|\n" + "\n".join(rows))
    write("spinup_segments", "Spin-up ramp table: the search's levers side by side (issue 26, item 4)", cases, [
        f"K = {K} segments. The shipped search: Nelder-Mead from the best of the distinct starts (penalised objective "
        f"at the start), 200 integrations, the search integrator at step {dp.SEGMENT_STEP:g} (Omega0 t). A lever "
        "changes one of these. The objective is the CVODES re-simulation of the kept table; the loss is against "
        "the full optimum of the same scene (the study with its shipped settings).",
        "The peer column is the shipped search on the same scene in the same run; ratio = shipped CPU / lever CPU. "
        "CPU time of this process (the machine is shared: 2 cores).",
    ], [table])
    return cases


if __name__ == "__main__":
    main()
