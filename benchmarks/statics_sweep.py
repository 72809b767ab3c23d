"""Benchmark: a sweep of the pump device's statics (App. A) over discharge ratios, autobal against the
hand-written limit (a vectorised numpy Newton on the same balances with the analytic Jacobian) and
scipy fsolve (analytic Jacobian, and finite differences), in one run.

Every method solves the square system with no stop reached (psi1 in [0.25, 1.15], the regulator
regulating) from the same start, the exact ideal-regulator closed form (2.22) (autobal's
``ideal_guess``; its time is inside every method's time), to the same accuracy: Newton's stop
|r| <= 1e-14 (fsolve: xtol 1e-13); the error column is the largest relative balance residual (each
residual over the largest term in its balance) over all points.  Build times (CasADi Functions,
maps, NLPs) are measured on the first call and reported beside the solve times, not in the ratios.
Run: ``python -m benchmarks statics_sweep``; writes benchmarks/results/statics_sweep.json.
"""

from __future__ import annotations

import time

import numpy as np

from autobal import scenario
from autobal.adapters import design
from autobal.analysis.statics import StaticsSolver, call_rows
from benchmarks import _numpy_statics as ns
from benchmarks._results import case, write
from benchmarks._timing import best_of

DPSI = 0.04


def profile(solver: StaticsSolver, grid, X, repeats: int) -> str:
    """Where fast_sweep's time goes: start, mapped check (buffer and DM paths), acceptance, Newton."""
    par, points = solver.parametric, len(grid)
    P = np.column_stack([grid, np.full(points, DPSI)])
    X0 = solver.ideal_guess(grid, DPSI)
    free = par.free()[0]
    fn = par.mapped("check", frozenset(), points)
    t_guess, _ = best_of(repeats, lambda: solver.ideal_guess(grid, DPSI))
    t_check, _ = best_of(repeats, lambda: par.evaluate("check", frozenset(), X0, P))
    t_dm, _ = best_of(repeats, lambda: [np.asarray(a) for a in fn(X0.T, P.T)])
    t_step, _ = best_of(repeats, lambda: par.evaluate("step", frozenset(), X0[:, free], P))
    rootfinder = par.newton()[0].map(points)
    t_newton, _ = best_of(repeats, lambda: call_rows(rootfinder, X0[:, free], P))
    return (f"Profile of fast_sweep at {points} points (best of {repeats}): closed-form start "
            f"{t_guess * 1e3:.2f} ms, mapped balance check (absolute and relative residuals, flows, pressures) "
            f"through a buffer {t_check * 1e3:.2f} ms (the same call through numpy<->DM conversion: "
            f"{t_dm * 1e3:.2f} ms); not needed here since the start is a root: one mapped Newton step "
            f"{t_step * 1e3:.2f} ms, CasADi's rootfinder mapped over the points {t_newton * 1e3:.2f} ms. "
            f"CasADi's virtual machine runs the check's "
            f"{par.function('check', frozenset()).n_instructions()} instructions point after point; the numpy Newton "
            f"runs each operation once over all points (F and J, then stops).")


def main(repeats: int = 5) -> list[dict]:
    t0 = time.perf_counter()
    solver = StaticsSolver(design(scenario.load("pump_pe600_statics").device))
    t_solver = time.perf_counter() - t0  # the IPOPT NLPs and the parametric evaluator
    g = solver.design.groups
    idx = [solver.system.index(k) for k in ns.NAMES]

    def error(X, grid):
        return float(solver.relative_residual(X, grid, DPSI).max())

    def full(rows, m):
        X = np.zeros((m, len(solver.system.unknowns)))
        X[:, idx] = rows
        return X

    cases, notes = [], []
    for points in (1000, 10_000):
        grid = np.linspace(0.25, 1.15, points)

        def numpy_newton(grid=grid):
            x, _ = ns.newton(solver.ideal_guess(grid, DPSI)[:, idx], grid, DPSI, g)
            return x

        t0 = time.perf_counter()
        solver.fast_sweep(grid, DPSI)
        build = time.perf_counter() - t0
        t_a, (X, used_ipopt) = best_of(repeats, lambda grid=grid: solver.fast_sweep(grid, DPSI))
        t_n, xn = best_of(repeats, numpy_newton)
        tag = f"{points} points"
        cases.append(case(f"{tag}: fast_sweep (mapped Newton, buffers)", t_a, build,
                          "numpy vectorised Newton (analytic Jacobian)", t_n, error(X, grid),
                          error(full(xn, points), grid), ipopt_points=int(used_ipopt.sum())))
        par = solver.parametric
        par.parallel = "thread"
        solver.fast_sweep(grid, DPSI)
        t_th, _ = best_of(repeats, lambda grid=grid: solver.fast_sweep(grid, DPSI))
        par.parallel = "serial"
        cases.append(case(f"{tag}: fast_sweep, threaded map (2 threads)", t_th, None,
                          "numpy vectorised Newton (analytic Jacobian)", t_n, error(X, grid), None))
        par.jit = True
        t0 = time.perf_counter()
        solver.fast_sweep(grid, DPSI)
        jit_build = time.perf_counter() - t0
        t_jit, (Xj, _) = best_of(repeats, lambda grid=grid: solver.fast_sweep(grid, DPSI))
        par.jit = False
        cases.append(case(f"{tag}: fast_sweep, balance check compiled to C (jit)", t_jit, jit_build,
                          "numpy vectorised Newton (analytic Jacobian)", t_n, error(Xj, grid), None))
        if points == 1000:
            x0 = solver.ideal_guess(grid, DPSI)[:, idx]
            t_fj, xfj = best_of(3, lambda grid=grid, x0=x0: ns.fsolve_rows(
                solver.ideal_guess(grid, DPSI)[:, idx], grid, DPSI, g))
            t_fd, xfd = best_of(3, lambda grid=grid, x0=x0: ns.fsolve_rows(
                solver.ideal_guess(grid, DPSI)[:, idx], grid, DPSI, g, jacobian=False))
            cases.append(case(f"{tag}: fast_sweep", t_a, build, "scipy fsolve, analytic Jacobian, continuation",
                              t_fj, error(X, grid), error(full(xfj, points), grid)))
            cases.append(case(f"{tag}: fast_sweep", t_a, build,
                              "scipy fsolve, finite differences, continuation", t_fd, error(X, grid),
                              error(full(xfd, points), grid)))
            t0 = time.perf_counter()
            solver.batch(grid, DPSI)
            b_build = time.perf_counter() - t0
            t_b, (Xb, _) = best_of(3, lambda grid=grid: solver.batch(grid, DPSI))
            t_s, pts = best_of(1, lambda grid=grid: solver.sweep(grid, DPSI))
            cases.append(case(f"{tag}: batch (one IPOPT NLP over the grid)", t_b, b_build,
                              "scipy fsolve, analytic Jacobian, continuation", t_fj, error(Xb, grid), None))
            cases.append(case(f"{tag}: sweep (IPOPT continuation, warm start)", t_s, t_solver,
                              "scipy fsolve, analytic Jacobian, continuation", t_fj,
                              error(np.array([p.x for p in pts]), grid), None))
            notes.append(profile(solver, grid, X, repeats))
    notes += [
        "The start (closed form (2.22) with the exact regulator) is a root to rounding where no stop is reached, so "
        "each method's work is one verified evaluation per point: the sweep measures per-point overhead.",
        "fast_sweep before this change (numpy<->DM conversion, rootfinder called on every point, a separate "
        "relative-residual pass with a map built per call): 5.9 ms at 1000 points on this machine (3.6 ms in the "
        "previous RESULTS.md); with buffers and the start checked first: 2.1 ms; with the relative residual in the "
        "same check: see the first row.",
    ]
    first = cases[0]
    fs = next(c for c in cases if c["peer"].startswith("scipy fsolve, analytic"))
    notes.insert(0, f"Goals (issue 17), 1000 points: at least as fast as the numpy Newton: "
                    f"{'met' if first['ratio'] >= 1 else 'missed'} ({first['ratio']:.2f}x; the profile below says "
                    f"where the time goes); >= 20x fsolve with the analytic Jacobian: "
                    f"{'met' if fs['ratio'] >= 20 else 'missed'} ({fs['ratio']:.0f}x).")
    write("statics_sweep", "Statics sweep: fast_sweep vs a vectorised numpy Newton and scipy fsolve", cases,
          notes=["Pump PE 600-300 (App. A), psi1 in [0.25, 1.15], dpsi = 0.04; same closed-form start for all; "
                 "error = max relative balance residual; times best of several calls."] + notes)
    return cases


if __name__ == "__main__":
    for c in main():
        print(c)
