"""Benchmark: the spin-up OCP of the issue (Jeffcott rotor, psi = 1, n = 5 1/s, 40 -> 210 rad/s in 8.5 s,
|alpha| <= 40 rad/s^2, minimum peak deflection, epigraph form) by autobal's direct collocation and by the
same problem written with rockit (rockit-meco) in the same run.

Both transcribe the same dimensionless model (the same CasADi Function), 200 (and 400) intervals of
Radau collocation of degree 3, the epigraph constraint at the collocation points (rockit:
``grid='integrator_roots'``), the same IPOPT options, and start from the constant 20 rad/s^2 ramp.
rockit's ``set_initial`` fills the collocation points with the interval-start values, so autobal is
also run from that same cruder guess.  Times: transcription + solver construction ("build"), and the
IPOPT solve (best of 3 repeated solves from the same guess).  Every optimum is re-simulated with CVODES.
Run: ``python -m benchmarks.spinup_ocp``.  Writes benchmarks/results/spinup_ocp.md.
"""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

import casadi as ca
import numpy as np

from autobal.models.rotor import RotorParams, rotor_model
from autobal.ocp import spinup as S
from benchmarks._timing import best_of

OUT = Path(__file__).resolve().parent / "results" / "spinup_ocp.md"
REPEATS = 3


def problem() -> S.SpinupOcp:
    return S.SpinupOcp(RotorParams.from_groups(105.0, 5.0, 1.0), 40.0, 210.0, 8.5, 40.0)



def autobal_run(ocp, N, crude: bool):
    t = time.perf_counter()
    solver = S.Solver(ocp, S.DirectCollocation(N, 3, "radau"))
    build = time.perf_counter() - t
    u0 = S.ramp_profile(ocp, N, (ocp.omega_final - ocp.omega_start) / ocp.horizon)
    w0 = S.initial_guess(ocp, solver.nlp, u0)
    if crude:  # the guess rockit gets: collocation points = the interval-start states
        X = w0[solver.nlp.index["X"]]
        w0[solver.nlp.index["Xc"]] = X[:-1, None, :]
    solve, sol = best_of(REPEATS, lambda: solver.solve(w0=w0.copy()))
    tr = S.resimulate(ocp, sol.u, sol.h, "autobal")
    return {"build": build, "solve": solve, "iterations": sol.iterations, "status": sol.status,
            "objective": sol.objective, "resim": tr.peak_delta, "ref": solver.nlp.ref}


def rockit_run(ocp, N, ref: float):
    """The same problem in rockit's own declaration API."""
    from rockit import DirectCollocation, Ocp

    t = time.perf_counter()
    r = Ocp(t0=0, T=ocp.tau_h)
    qs = [r.state() for _ in range(5)]
    q = ca.vertcat(*qs)
    u = r.control()
    s = r.variable()
    f = rotor_model().ode(q, u * ocp.a_max, ocp.params.p)
    for i in range(5):
        r.set_der(qs[i], f[i])
    r.subject_to(-1 <= (u <= 1))
    r.subject_to(r.at_t0(q) == ocp.q0)
    r.subject_to(r.at_tf(qs[4]) == ocp.nuf)
    r.subject_to((qs[0] ** 2 + qs[1] ** 2 - s * ref) / ref <= 0, grid="integrator_roots")
    r.subject_to(s >= 0)
    r.add_objective(s)
    opts = {f"ipopt.{k}": v for k, v in S.IPOPT_OPTIONS.items()} | {"ipopt.print_level": 0, "ipopt.sb": "yes",
                                                                      "print_time": False}
    r.solver("ipopt", opts)
    r.method(DirectCollocation(N=N, M=1, degree=3, scheme="radau"))
    u0 = S.ramp_profile(ocp, N, (ocp.omega_final - ocp.omega_start) / ocp.horizon)
    h = np.full(N, ocp.tau_h / N)
    X = np.vstack([np.asarray(ocp.q0)[None, :], S.simulate_profile(ocp, u0, h, [1.0], tol=1e-8)[:, -1, :]]).T
    tg = np.concatenate([[0.0], np.cumsum(h)])
    for i in range(5):  # rockit 0.6.7's set_initial of a numeric matrix fails for collocation (NameError 'kron')
        r.set_initial(qs[i], ca.interpolant(f"g{i}", "linear", [tg], X[i])(r.t))
    r.set_initial(u, u0)
    r.set_initial(s, 1.05 * np.max(X[0] ** 2 + X[1] ** 2) / ref)
    declare = time.perf_counter() - t
    t = time.perf_counter()
    sol = r.solve()  # transcription + nlpsol construction + first solve
    first = time.perf_counter() - t
    solve, sol = best_of(REPEATS, r.solve)  # Opti reuses the built solver: the repeated solves are the solve time
    st = sol.stats
    _, us = sol.sample(u, grid="control")
    uu = np.asarray(us, float)[:N]
    tr = S.resimulate(ocp, uu, h, "rockit")
    return {"build": declare + first - solve, "solve": solve, "iterations": st["iter_count"],
            "status": st["return_status"], "objective": float(np.sqrt(sol.value(s) * ref)), "resim": tr.peak_delta}


def main() -> str:
    ocp = problem()
    rows, ratios = [], []
    for N in (200, 400):
        a = autobal_run(ocp, N, crude=False)
        ac = autobal_run(ocp, N, crude=True)
        try:
            rk = rockit_run(ocp, N, a["ref"])
            rk_err = None
        except Exception as exc:  # report exactly why rockit could not run
            rk, rk_err = None, f"{type(exc).__name__}: {exc}"
        rows.append((N, "autobal DirectCollocation (simulated guess at the collocation points)", a))
        rows.append((N, "autobal DirectCollocation (rockit's guess: interval-start values)", ac))
        if rk:
            rows.append((N, "rockit DirectCollocation (same problem, same IPOPT options)", rk))
            ratios.append((N, rk["solve"] / ac["solve"], rk["build"] / ac["build"],
                           (rk["solve"] / rk["iterations"]) / (ac["solve"] / ac["iterations"]),
                           abs(rk["objective"] / ac["objective"] - 1)))
        else:
            rows.append((N, f"rockit: not run ({rk_err})", None))
    lines = ["# Spin-up OCP: autobal vs rockit", "",
             "Jeffcott rotor (psi = 1, Omega0 = 105 rad/s, chi/m1 = 5 1/s), 40 -> 210 rad/s in 8.5 s, "
             "|alpha| <= 40 rad/s^2, minimum peak deflection (epigraph), Radau collocation of degree 3, "
             f"start from the constant 20 rad/s^2 ramp; IPOPT tol {S.IPOPT_OPTIONS['tol']:g}, MUMPS; solve time "
             f"= best of {REPEATS} solves from the same guess; peaks re-simulated with CVODES (rtol 1e-12).",
             f"Machine: {platform.machine()}, Python {platform.python_version()}, {os.cpu_count()} cores; "
             f"casadi {ca.__version__}.", "",
             "| intervals | method | build (s) | solve (s) | IPOPT iterations | status | optimum peak (e) "
             "| re-simulated peak (e) |",
             "|---|---|---|---|---|---|---|---|"]
    for N, label, r in rows:
        if r is None:
            lines.append(f"| {N} | {label} | - | - | - | - | - | - |")
        else:
            lines.append(f"| {N} | {label} | {r['build']:.3f} | {r['solve']:.3f} | {r['iterations']} | "
                         f"{r['status']} | {r['objective']:.5f} | {r['resim']:.5f} |")
    if ratios:
        lines += ["", "| intervals | rockit solve / autobal solve (same guess) | rockit build / autobal build "
                  "| time per iteration ratio | relative difference of the optima |", "|---|---|---|---|---|"]
        lines += [f"| {N} | {s:.2f} | {b:.2f} | {it:.2f} | {d:.1e} |" for N, s, b, it, d in ratios]
    text = "\n".join(lines) + "\n"
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(text)
    return text


if __name__ == "__main__":
    print(main())
