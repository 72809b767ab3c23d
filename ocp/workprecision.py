"""Work-precision of the spin-up OCP: the transcription error of each optimum against its own CVODES
re-simulation, over the collocation degree and the number of intervals (and multiple shooting)."""

from __future__ import annotations

from autobal.analysis.studies.workprecision import Trial, WorkPrecision
from autobal.ocp.simulation import resimulate
from autobal.ocp.solve import Solver, resimulated_scores
from autobal.ocp.transcription import DirectCollocation, MultipleShooting


def spinup_study(ocp, degrees=(2, 3, 4), intervals=(50, 100, 200, 400), shooting=()) -> WorkPrecision:
    """Transcription error of the spin-up optimum against its own CVODES re-simulation (rtol 1e-12):
    direct collocation (Radau) over degree and number of intervals, and multiple shooting (CVODES)
    over ``shooting`` intervals if given (by default not: one solve at 50 intervals takes about a
    minute; tests/test_spinup.py checks that both transcriptions reach the same optimum); one start
    (the constant ramp), solve time of IPOPT (the NLP is built beforehand)."""
    rows = []
    ladders = [(f"direct collocation, Radau degree {d}", lambda n, d=d: DirectCollocation(n, d, "radau"), intervals)
               for d in degrees]
    if shooting:
        ladders.append(("multiple shooting (CVODES)", lambda n: MultipleShooting(n), shooting))
    for name, method, settings in ladders:
        for n in settings:
            try:
                sol = Solver(ocp, method(n)).solve()
                score, own = resimulated_scores(ocp, sol, resimulate(ocp, sol.u, sol.h, "workprecision"))
                rows.append(Trial(name, n, setting_name="intervals", error=abs(own - score) / abs(score),
                                  time_s=sol.solve_time_s, objective=score, iterations=sol.iterations))
            except Exception as exc:  # a failed solve is a result: recorded, not hidden
                rows.append(Trial(name, n, setting_name="intervals", error=float("nan"), time_s=float("nan"),
                                  failed=str(exc).strip().splitlines()[-1][:200]))
    return WorkPrecision.of("spinup", "each optimum's CVODES re-simulation at rtol 1e-12 (the exact response to "
                            "the optimal speed profile)", [f"{ocp.objective} (re-simulated)"], rows)
