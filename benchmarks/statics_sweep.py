"""Benchmark: a sweep of 1000 discharge pressures of the pump device (App. A), solved by autobal
and by scipy.optimize.fsolve on the same residuals written in numpy, in one run.

Both solve the square static system with no stop reached (psi1 in [0.25, 1.15], where the
regulator regulates), both warm-start along the grid where they can, and every solution is
measured with the same relative residual.  Run: ``python -m benchmarks.statics_sweep``.
Writes benchmarks/results/statics_sweep.md.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import fsolve

from autobal import scenario
from autobal.adapters import design
from autobal.analysis.statics import StaticsSolver
from autobal.models.throttles import SQRT_SMOOTHING
from benchmarks._timing import best_of

POINTS, DPSI = 1000, 0.04
GRID = np.linspace(0.25, 1.15, POINTS)
NAMES = ("psi2", "psi3", "u", "psi_e", "psi_cam", "xi")


def numpy_residual(g):
    """(2.19) with the regulator, in numpy: the same equations and smooth signed root as autobal."""
    r, eps2 = g.regulator, SQRT_SMOOTHING**2

    def ssqrt(x):
        return x / (x * x + eps2) ** 0.25

    def res(x, psi1):
        psi2, psi3, u, psi_e, psi_cam, xi = x
        q_e = g.alpha_e1 * (psi_e - psi2)
        q_t = max(u, 0.0) ** 1.5 * g.alpha_TB1 * ssqrt(psi2 - psi3)
        q_v = xi * r.alpha_B1 * ssqrt(psi_cam - psi_e)
        return [g.sigma * (psi2 - psi3) + g.chi - g.b * psi1,
                q_e - (psi2 - psi1) - q_t,
                q_t - g.alpha_31 * ssqrt(psi3 - g.psi4),
                r.sigma_m * (psi_e - psi1 - DPSI),
                r.alpha_in1 * (r.psi_in - psi_cam) - q_v,
                q_v - q_e]

    return res



def main(repeats: int = 3) -> str:
    solver = StaticsSolver(design(scenario.load("pump_pe600_statics").device))
    idx = [solver.system.unknowns.index(k) for k in NAMES]
    res = numpy_residual(solver.design.groups)

    def by_fsolve():
        x, rows = solver.guess(GRID[0], DPSI)[idx], []
        with warnings.catch_warnings():  # fsolve warns when xtol = 1e-13 is below what it can still improve
            warnings.simplefilter("ignore", RuntimeWarning)
            for p in GRID:
                x = fsolve(res, x, args=(p,), xtol=1e-13)
                rows.append(x)
        full = np.zeros((POINTS, len(solver.system.unknowns)))
        full[:, idx] = rows
        return full

    solver.fast_sweep(GRID, DPSI)  # build once (Functions are built once and called many times)
    solver.batch(GRID, DPSI)
    runs = {
        "autobal fast_sweep (mapped Newton, IPOPT fallback)": lambda: solver.fast_sweep(GRID, DPSI)[0],
        "autobal batch (one IPOPT NLP over the grid)": lambda: solver.batch(GRID, DPSI)[0],
        "autobal sweep (IPOPT continuation, warm start)": lambda: np.array([p.x for p in solver.sweep(GRID, DPSI)]),
        "scipy fsolve (numpy residuals, continuation)": by_fsolve,
    }
    rows = {}
    for name, fn in runs.items():
        t, X = best_of(repeats, fn)
        rows[name] = (t, solver.relative_residual(X, GRID, DPSI).max())
    t_peer = rows["scipy fsolve (numpy residuals, continuation)"][0]
    lines = [
        "# Statics sweep: autobal vs scipy.optimize.fsolve",
        "",
        f"Pump PE 600-300 (App. A), {POINTS} discharge ratios psi1 in [0.25, 1.15], dpsi = {DPSI}; "
        f"best of {repeats}; residual = max over points and balances of |residual| / largest term.",
        "",
        "| method | time (s) | fsolve time / this time | max relative residual |",
        "|---|---|---|---|",
    ]
    for name, (t, r) in rows.items():
        lines.append(f"| {name} | {t:.4f} | {t_peer / t:.1f} | {r:.1e} |")
    text = "\n".join(lines) + "\n"
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    (out / "statics_sweep.md").write_text(text)
    return text


if __name__ == "__main__":
    print(main())
