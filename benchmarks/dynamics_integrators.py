"""Benchmark: the stiff nonlinear device model integrated by CasADi's CVODES (BDF, Newton with the
exact symbolic Jacobian) against scipy.integrate.solve_ivp (Radau, BDF, LSODA), at matched final
error, in one run.

Problem: the pump PE 600-300 device (App. A data, energy-consistent chamber balances), a step of the
axial force dtau = 0.01 from the static solution, 50 ms; eigenvalues from -8e8 to -81 +- 986i 1/s
(stiffness ratio 1e7).  scipy gets the same right-hand side and the same exact Jacobian as CasADi
Functions (what a user of the toolkit would hand it), evaluated one call at a time from Python.
Each method runs over a ladder of relative tolerances (absolute = relative x 1e-2, states are O(1));
its error is the largest deviation of the final state from a reference (CVODES at rtol 1e-13, checked
against Radau at rtol 1e-12).  For each target error the time of the fastest run that meets it is
reported, and the ratio to CVODES.  Run: ``python -m benchmarks dynamics_integrators``.
Writes benchmarks/results/dynamics_integrators.json.
"""

from __future__ import annotations

import re
import time

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from autobal import adapters, scenario
from autobal.analysis.linearize import Setup
from benchmarks._results import case, write
from benchmarks._timing import best_of

T_END = 0.05
DTAU = 0.01
RTOLS = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]
TARGETS = [1e-4, 1e-6, 1e-8]
REPEAT = 3
MIN_TOTAL = 0.1  # s: a run shorter than this is repeated until it has taken that long (at most MAX_REPEAT)
MAX_REPEAT = 200


def timed(run):
    """Best wall time of ``run()`` and its last result: at least REPEAT calls, more for a short run (as
    ``timeit`` does), the same rule for every method, so that a sub-millisecond call is not judged on
    three samples of a loaded machine while a 60 ms call is."""
    t, out = best_of(1, run)
    n = int(min(MAX_REPEAT, max(REPEAT - 1, MIN_TOTAL / max(t, 1e-9))))
    best, out = best_of(n, run)
    return min(t, best), out


def problem():
    setup = Setup(adapters.device(scenario.load("pump_pe600_dynamics").device))
    m = setup.nonlinear("energy")
    w = m.w0 + np.array([0.0, DTAU])
    x = ca.SX.sym("x", len(m.states))
    f = ca.Function("f", [x], [m.ode(x, w, m.p0)])
    jac = ca.Function("J", [x], [ca.jacobian(m.ode(x, w, m.p0), x)])
    return m, w, f, jac


def cvodes_runner(m, w, rtol):
    x = ca.SX.sym("x", len(m.states))
    dae = {"x": x, "ode": m.ode(x, w, m.p0)}
    F = ca.integrator("F", "cvodes", dae, 0.0, T_END, {"reltol": rtol, "abstol": rtol * 1e-2,
                                                      "max_num_steps": 10**6})

    def run():
        return np.array(F(x0=m.x0)["xf"]).ravel(), int(F.stats()["nsteps"])

    return run


def scipy_runner(m, f, jac, method, rtol):
    def rhs(t, x):
        return np.array(f(x)).ravel()

    def J(t, x):
        return np.array(jac(x))

    def run():
        sol = solve_ivp(rhs, (0.0, T_END), m.x0, method=method, rtol=rtol, atol=rtol * 1e-2, jac=J)
        if not sol.success:
            raise RuntimeError(sol.message)
        return sol.y[:, -1], int(sol.nfev)

    return run



JIT = {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O2"], "verbose": False}}

# CVODES options tried side by side at rtol 1e-6 (the toolkit's defaults first)
LEVERS = {
    "defaults (BDF, max order 5, Newton, direct csparse LU)": {},
    "max_order 4": {"max_order": 4},
    "max_order 3": {"max_order": 3},
    "linear_solver qr": {"linear_solver": "qr"},
    "linear_solver symbolicqr": {"linear_solver": "symbolicqr"},
    "linear_solver lapacklu (dense)": {"linear_solver": "lapacklu"},
    "newton_scheme gmres": {"newton_scheme": "gmres"},
    "newton_scheme gmres, max_krylov 8": {"newton_scheme": "gmres", "max_krylov": 8},
    "nonlinear_solver_iteration functional (fixed point)": {"nonlinear_solver_iteration": "functional",
                                                            "max_num_steps": 20_000},
    "nonlin_conv_coeff 0.3 (default 0.1)": {"nonlin_conv_coeff": 0.3},
    "interpolation_type polynomial": {"interpolation_type": "polynomial"},
    "max_step_size 1e-3 s": {"max_step_size": 1e-3},
    "JIT of the RHS and Jacobian (gcc -O2)": JIT,
    "JIT + nonlin_conv_coeff 0.3": JIT | {"nonlin_conv_coeff": 0.3},
}


def profile(m, w, ref) -> tuple[str, list[str], dict]:
    """Where CVODES' time goes at rtol 1e-6 and the levers tried.

    The cost split comes from CVODES' own per-function counters of one call of a fresh integrator (the
    wall time CasADi records around each RHS and Jacobian callback, timer and interrupt check included);
    each lever is built and timed alone (best of 15) with its final error against the reference."""
    x = ca.SX.sym("x", len(m.states))
    dae = {"x": x, "ode": m.ode(x, w, m.p0)}
    base = {"reltol": 1e-6, "abstol": 1e-8, "max_num_steps": 10**6}
    F = ca.integrator("F", "cvodes", dae, 0.0, T_END, base)
    F(x0=m.x0)
    st = F.stats()
    t_total, _ = best_of(15, lambda: F(x0=m.x0))
    F0 = ca.integrator("F0", "cvodes", dae, 0.0, 1e-15, base)  # a call that takes no step: the fixed cost
    t_fixed, _ = best_of(15, lambda: F0(x0=m.x0))
    nf, nj = int(st["nfevals"]), int(st.get("n_call_jacF", st["nlinsetups"]))
    t_f, t_j = float(st["t_wall_daeF"]), float(st["t_wall_jacF"])
    rows = ["| CVODES variant at rtol 1e-6 | time (ms) | build (s) | steps | RHS calls | final error |",
            "|---|---|---|---|---|---|"]
    times = {}
    for name, o in LEVERS.items():
        t0 = time.perf_counter()
        try:
            G = ca.integrator("G", "cvodes", dae, 0.0, T_END, base | o)
            xf = np.array(G(x0=m.x0)["xf"]).ravel()
        except RuntimeError as exc:
            flag = re.search(r"CV_[A-Z_]+", str(exc))
            rows.append(f"| {name} | failed ({flag.group(0) if flag else str(exc).splitlines()[-1][-60:]}) "
                        "| - | - | - | - |")
            continue
        build = time.perf_counter() - t0
        sec, _ = best_of(15, lambda G=G: G(x0=m.x0))
        s = G.stats()
        times[name] = (sec, build, float(np.abs(xf - ref).max()))
        rows.append(f"| {name} | {sec * 1e3:.3f} | {build:.2f} | {s['nsteps']} | {s['nfevals']} | "
                    f"{np.abs(xf - ref).max():.2e} |")
    text = (f"Profile of CVODES at rtol 1e-6 ({t_total * 1e3:.3f} ms, best of 15; a call that takes no step costs "
            f"{t_fixed * 1e6:.0f} us): {st['nsteps']} steps, {st['nniters']} Newton iterations, {nf} RHS callbacks "
            f"taking {t_f * 1e3:.3f} ms ({t_f / nf * 1e6:.2f} us each), {nj} Jacobian callbacks {t_j * 1e3:.3f} ms, "
            f"the rest ({(t_total - t_f - t_j) * 1e3:.3f} ms, {(t_total - t_f - t_j) / st['nsteps'] * 1e6:.2f} us a "
            "step) is CVODES' step logic, the LU solves of the 8x8 iteration matrix and CasADi's SUNDIALS glue. "
            "The RHS itself is 130 SX instructions. Sampled with perf (Linux, load about 10 on 2 cores): about a "
            "third of CVODES' time is the CPU-time clock CasADi reads around every callback (FStats::tic/toc: "
            "std::clock(), a clock_gettime syscall that waits on the scheduler's lock, heavier as the load rises), "
            "about a tenth the RHS arithmetic (SXFunction::eval and pow), the rest CVODES' vector "
            "operations, the QR/LU solves and the Python call; no CasADi option turns the timers off. The step "
            "count is set by the 157 Hz oscillation (about 40 steps a period at order "
            "5), so no option cuts it; the levers below change the cost of a step by at most about 10 %.")
    return text, rows, times


def main() -> list[dict]:
    m, w, f, jac = problem()
    ref, _ = cvodes_runner(m, w, 1e-13)()
    check = solve_ivp(lambda t, x: np.array(f(x)).ravel(), (0, T_END), m.x0, method="Radau", rtol=1e-12,
                      atol=1e-14, jac=lambda t, x: np.array(jac(x))).y[:, -1]
    ref_diff = float(np.abs(check - ref).max())
    rows = []
    methods = {"CVODES (autobal)": lambda r: cvodes_runner(m, w, r)} | {
        f"scipy {k}": (lambda r, k=k: scipy_runner(m, f, jac, k, r)) for k in ("Radau", "BDF", "LSODA")}
    for name, make in methods.items():
        for rtol in RTOLS:
            try:
                sec, (xf, work) = timed(make(rtol))
                err = float(np.abs(xf - ref).max())
            except RuntimeError as exc:
                sec, err, work = np.nan, np.nan, str(exc)[:40]
            rows.append((name, rtol, err, sec, work))
            print(f"{name:18s} rtol {rtol:.0e}: error {err:.2e}, {sec:.4f} s, work {work}")
    best = {}
    for name in methods:
        for target in TARGETS:
            ok = [r for r in rows if r[0] == name and np.isfinite(r[2]) and r[2] <= target]
            best[name, target] = min(ok, key=lambda r: r[3], default=None)
    cv = "CVODES (autobal)"
    t0 = time.perf_counter()
    cvodes_runner(m, w, 1e-6)
    build = time.perf_counter() - t0
    cases = []
    for target in TARGETS:
        a = best[cv, target]
        for name in methods:
            b = best[name, target]
            if name == cv or a is None or b is None:
                continue
            cases.append(case(f"final error <= {target:.0e}", a[3], build, f"{name} (rtol {b[1]:.0e})", b[3],
                              a[2], b[2], autobal_rtol=a[1]))
    text, lever_rows, levers = profile(m, w, ref)
    runs = ["| method | rtol | final error | time (s) | steps (CVODES) / RHS calls (scipy) |", "|---|---|---|---|---|"]
    runs += [f"| {n} | {r:.0e} | {e:.2e} | {s_:.4f} | {wk} |" for n, r, e, s_, wk in rows]
    notes = [
        f"Pump PE 600-300 device (App. A), energy-consistent model, 8 states, axial-force step dtau = {DTAU} from "
        f"the static solution, {T_END * 1e3:.0f} ms; stiffness ratio about 1e7 (eigenvalues -8.0e8 ... -81 +- 986i "
        "1/s). Error: max |x(t_end) - x_ref| over the O(1) scaled states; reference CVODES rtol 1e-13 (Radau rtol "
        f"1e-12 agrees to {ref_diff:.1e}). Each method over a ladder of rtol (atol = rtol x 1e-2); per target error, "
        f"the fastest run that meets it; best of at least {REPEAT} calls, repeated up to {MIN_TOTAL:g} s "
        f"(at most {MAX_REPEAT}) for a short run, the same rule for every method; build time = constructing the CVODES "
        "integrator. scipy gets the same RHS and exact Jacobian as CasADi Functions called from Python.",
        text,
    ]
    lsoda = next((c for c in cases if c["case"] == "final error <= 1e-06" and "LSODA" in c["peer"]), None)
    if lsoda is not None:
        notes.insert(0, f"Goal (issue 17): >= 100x LSODA at final error 1e-6: "
                        f"{'met' if lsoda['ratio'] >= 100 else 'missed'} ({lsoda['ratio']:.0f}x); where CVODES' time "
                        "goes: the profile below. Most of LSODA's time is its Python-level RHS and Jacobian calls.")
        fast = levers.get("JIT + nonlin_conv_coeff 0.3")
        if fast is not None and fast[2] <= 1e-6:
            notes.insert(1, f"The best lever found, JIT of the RHS and Jacobian with nonlin_conv_coeff 0.3 "
                            f"({fast[0] * 1e3:.3f} ms against {levers[next(iter(LEVERS))][0] * 1e3:.3f} ms, "
                            f"build {fast[1]:.2f} s with gcc), would give {lsoda['peer_s'] / fast[0]:.0f}x LSODA; "
                            "the toolkit keeps the defaults (no compiler needed at run time, no build time).")
    write("dynamics_integrators", "Stiff transient: CVODES vs scipy solve_ivp at matched final error", cases,
          notes, tables=["Levers tried (same problem, same reference):\n\n" + "\n".join(lever_rows),
                  "All runs:\n\n" + "\n".join(runs)])
    return cases


if __name__ == "__main__":
    for c in main():
        print(c)
