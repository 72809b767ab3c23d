"""Benchmark: a sweep of the pump device's statics (App. A) over discharge ratios, autobal against the
hand-written limit (a vectorised numpy Newton on the same balances with the analytic Jacobian) and
scipy fsolve (analytic Jacobian, and finite differences), in one run.

Every method solves the square system with no stop reached (psi1 in [0.25, 1.15], the regulator
regulating) from the same start, the exact ideal-regulator closed form (2.22) (autobal's
``ideal_guess``; its time is inside every method's time), to the same accuracy: Newton's stop
|r| <= 1e-14 (fsolve: xtol 1e-13); the error column is the largest relative balance residual (each
residual over the largest term in its balance) over all points.  autobal's batch evaluations run as
CasADi maps generated as C and compiled (the default when a C compiler is found); the levers (map
modes, block size, CasADi's virtual machine) are measured beside it and checked to give the default's
rows bit for bit.  Build times (CasADi Functions, compiled maps into a fresh cache folder, NLPs) are
measured on the first call and reported beside the solve times, not in the ratios.
Run: ``python -m benchmarks statics_sweep``; writes benchmarks/results/statics_sweep.json.
"""

from __future__ import annotations

import os
import tempfile
import time

import casadi as ca
import numpy as np

from autobal import scenario
from autobal.analysis.numerics.statics import StaticsSolver, call_rows
from autobal.parts.device import design
from benchmarks import _numpy_statics as ns
from benchmarks._results import case, write
from benchmarks._timing import best_of, cpu_best_of

DPSI = 0.04


# (label, ParametricStatics settings): the levers measured on fast_sweep, the default first
LEVERS = [
    ("compiled map, serial, 1024-point blocks (default)", {}),
    ("compiled map, 2 OpenMP threads", {"parallel": "openmp"}),
    ("compiled map, 2 POSIX threads (CasADi thread map)", {"parallel": "thread"}),
    ("compiled map, 256-point blocks", {"block": 256}),
    ("compiled map, 4096-point blocks", {"block": 4096}),
    ("virtual machine map, serial (no C compiler)", {"jit": False}),
    ("virtual machine map, 2 threads", {"jit": False, "parallel": "thread"}),
]
DEFAULT = {"jit": True, "parallel": "serial", "block": 1024}


def settings(par, **kw):
    """Set the evaluator ``par`` (a ParametricStatics) to the default, changed by ``kw``."""
    for k, v in (DEFAULT | kw).items():
        setattr(par, k, v)


def profile(solver: StaticsSolver, grid, repeats: int) -> str:
    """Where fast_sweep's time goes: start, the mapped check by each evaluator, acceptance."""
    par, points = solver.parametric, len(grid)
    P = np.column_stack([grid, np.full(points, DPSI)])
    X0 = solver.ideal_guess(grid, DPSI)
    f = par.function("check", frozenset())
    vm = par.mapped("check", frozenset(), points)
    w, p = ca.SX.sym("w", X0.shape[1]), ca.SX.sym("p", 2)
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:  # CasADi's jit leaves its files in the working folder
        os.chdir(tmp)
        try:
            jitted = ca.Function("check_jit", [w, p], f.call([w, p]), {"jit": True, "compiler": "shell",
                                 "jit_options": {"flags": ["-O2"], "verbose": False}}).map(points)
        finally:
            os.chdir(here)
    settings(par)
    t_guess, _ = best_of(repeats, lambda: solver.ideal_guess(grid, DPSI))
    t_check, _ = best_of(repeats, lambda: par.evaluate("check", frozenset(), X0, P))
    t_vm, _ = best_of(repeats, lambda: call_rows(vm, X0, P))
    t_jit, _ = best_of(repeats, lambda: call_rows(jitted, X0, P))
    t_dm, _ = best_of(repeats, lambda: [np.asarray(a) for a in vm(X0.T, P.T)])
    t_solve, _ = best_of(repeats, lambda: par.solve(P, [(frozenset(), X0)], tol=np.inf))
    t_all, _ = best_of(repeats, lambda: solver.fast_sweep(grid, DPSI))
    idx = [solver.system.index(k) for k in ns.NAMES]
    x0 = X0[:, idx]
    t_np, _ = best_of(repeats, lambda: ns.newton(x0, grid, DPSI, solver.design.groups))
    return (f"Profile of fast_sweep at {points} points (best of {repeats}, wall): closed-form start "
            f"{t_guess * 1e3:.3f} ms; the balance check of every start (absolute and relative residuals, flows, "
            f"pressures, bounds; {f.n_instructions()} instructions a point) by the compiled map "
            f"{t_check * 1e3:.3f} ms, by CasADi's virtual machine {t_vm * 1e3:.3f} ms (through numpy<->DM "
            f"conversion instead of a buffer: {t_dm * 1e3:.3f} ms), by CasADi's jit of the point function under a "
            f"virtual-machine map {t_jit * 1e3:.3f} ms; acceptance and bookkeeping "
            f"{(t_solve - t_check) * 1e3:.3f} ms; fast_sweep in all {t_all * 1e3:.3f} ms.  The numpy peer: the same "
            f"start, then its Newton (F and J over all points, |F| test) {t_np * 1e3:.3f} ms.  The check's time is "
            f"mostly libm calls: one pow (u^1.5) and six sqrt (the three fourth roots (x^2 + eps^2)^(1/4) of the "
            f"square-root throttles are written as sqrt(sqrt(.)), which halved the check: 0.181 ms with four pow "
            f"calls at about 11 ns each); numpy evaluates pow with SIMD (about 1.6 ns an element), which the "
            f"generated code cannot use without fast-math, i.e. without giving up the virtual machine's results "
            f"bit for bit.  No Newton step is taken: "
            f"the start is a root.")


def main(repeats: int = 5) -> list[dict]:
    t0 = time.perf_counter()
    solver = StaticsSolver(design(scenario.load("pump_pe600_statics").device))
    t_solver = time.perf_counter() - t0  # the IPOPT NLPs and the parametric evaluator
    g = solver.design.groups
    idx = [solver.system.index(k) for k in ns.NAMES]
    par = solver.parametric

    def error(X, grid):
        return float(solver.relative_residual(X, grid, DPSI).max())

    def full(rows, m):
        X = np.zeros((m, len(solver.system.unknowns)))
        X[:, idx] = rows
        return X

    cases, notes = [], []
    peer = "numpy vectorised Newton (analytic Jacobian)"
    with tempfile.TemporaryDirectory() as cache:
        os.environ["AUTOBAL_CACHE"] = cache  # the first call compiles (cold), as on a new machine
        for points in (1000, 10_000):
            grid = np.linspace(0.25, 1.15, points)

            def numpy_newton(grid=grid):
                x, _ = ns.newton(solver.ideal_guess(grid, DPSI)[:, idx], grid, DPSI, g)
                return x

            tag = f"{points} points"
            reps = 6 * repeats  # calls of a millisecond or less: more of them against the noise of a shared machine
            t_n, xn = best_of(reps, numpy_newton)
            c_n = cpu_best_of(reps, numpy_newton)
            first = None
            for label, kw in LEVERS:
                settings(par, **kw)
                t0 = time.perf_counter()
                solver.fast_sweep(grid, DPSI)
                build = time.perf_counter() - t0
                t_a, (X, used_ipopt) = best_of(reps, lambda grid=grid: solver.fast_sweep(grid, DPSI))
                c_a = cpu_best_of(reps, lambda grid=grid: solver.fast_sweep(grid, DPSI))
                extra = {"cpu_ratio": c_n / c_a}
                if first is None:
                    first = (t_a, build, X)
                    extra |= {"ipopt_points": int(used_ipopt.sum())}
                cases.append(case(f"{tag}: fast_sweep, {label}", t_a, build, peer, t_n, error(X, grid),
                                  error(full(xn, points), grid) if first[2] is X else None,
                                  identical_to_default=bool(np.array_equal(X, first[2], equal_nan=True)), **extra))
            settings(par)
            t_a, build, X = first
            if points == 1000:
                t_fj, xfj = best_of(3, lambda grid=grid: ns.fsolve_rows(
                    solver.ideal_guess(grid, DPSI)[:, idx], grid, DPSI, g))
                t_fd, xfd = best_of(3, lambda grid=grid: ns.fsolve_rows(
                    solver.ideal_guess(grid, DPSI)[:, idx], grid, DPSI, g, jacobian=False))
                cases.append(case(f"{tag}: fast_sweep", t_a, build, "scipy fsolve, analytic Jacobian, continuation",
                                  t_fj, error(X, grid), error(full(xfj, points), grid)))
                cases.append(case(f"{tag}: fast_sweep", t_a, build, "scipy fsolve, finite differences, continuation",
                                  t_fd, error(X, grid), error(full(xfd, points), grid)))
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
                notes.append(profile(solver, grid, 6 * repeats))
                # a new process on a machine that compiled before: the maps are loaded from the disk cache
                t0 = time.perf_counter()
                StaticsSolver(solver.design).fast_sweep(grid, DPSI)
                warm = time.perf_counter() - t0
                notes.append(f"Build of the compiled check map (gcc -O2, cold cache): "
                             f"{cases[0]['autobal_build_s']:.2f} s, once per machine and device; a new evaluator "
                             f"loading it from the disk cache (incl. its own Functions): {warm:.3f} s.")
        del os.environ["AUTOBAL_CACHE"]
    notes += [
        "The start (closed form (2.22) with the exact regulator) is a root to rounding where no stop is reached, so "
        "each method's work is one verified evaluation per point: the sweep measures per-point cost and overhead.",
        "Levers not in the table: the whole Newton loop as one Function (no Newton step is taken here; in the Monte "
        "Carlo 160 of 1e5 samples need one, see there); evaluating on the dimensionless groups (the evaluator "
        "already works on them); the numpy<->DM conversion and CasADi's jit of the point function (the profile).",
        "cpu_ratio: the same ratio from CPU times (process_time), less disturbed by other processes on a shared "
        "machine; identical_to_default: the lever's rows of unknowns equal the default's bit for bit.",
    ]
    first = cases[0]
    fs = next(c for c in cases if c["peer"].startswith("scipy fsolve, analytic"))
    notes.insert(0, f"Goals (issue 17), 1000 points: at least as fast as the numpy Newton: "
                    f"{'met' if first['ratio'] >= 1 else 'missed'} ({first['ratio']:.2f}x wall, "
                    f"{first['cpu_ratio']:.2f}x CPU; the profile below says where the time goes); >= 20x fsolve "
                    f"with the analytic Jacobian: {'met' if fs['ratio'] >= 20 else 'missed'} ({fs['ratio']:.0f}x).")
    write("statics_sweep", "Statics sweep: fast_sweep vs a vectorised numpy Newton and scipy fsolve", cases,
          notes=["Pump PE 600-300 (App. A), psi1 in [0.25, 1.15], dpsi = 0.04; same closed-form start for all; "
                 "error = max relative balance residual; times best of several calls."] + notes)
    return cases


if __name__ == "__main__":
    for c in main():
        print(c)
