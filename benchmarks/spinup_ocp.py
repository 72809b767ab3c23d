"""Benchmark: the spin-up OCP as a drive is specified, by autobal and by rockit (``expand=True``) in the
same run.

The problem: Jeffcott rotor (psi = 1, Omega0 = 105 rad/s, chi/m1 = 5 1/s), 40 -> 210 rad/s by a 5 s
deadline with |alpha| <= 40 rad/s^2, then a 3 s hold at 210 rad/s over which the peak counts, never
above 210 rad/s; minimum peak deflection (epigraph at every Radau point).  Both transcribe the same
dimensionless model (the same CasADi Function), Radau collocation of degree 3 on the same mesh
(N control intervals to the deadline, the hold on intervals of the same length), the same IPOPT
options, and start from the same guess: the best profile of autobal's global search, its states
at the interval starts (rockit's ``set_initial`` fills the collocation points with them, so autobal
gets the same crude guess).  Build = transcription and solver construction; solve = one IPOPT
solve (median of ``REPEATS``; rockit re-solves with its built solver).  Each solve is capped at
``WALL`` seconds (IPOPT ``max_wall_time``).  Every optimum is re-simulated with CVODES.

Run: ``python -m benchmarks spinup_ocp``.  Writes benchmarks/results/spinup_ocp.md, .json and a scaling
figure spinup_ocp.png.
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path

import casadi as ca
import numpy as np

from autobal.models.rotor import RotorParams, rotor_model
from autobal.ocp import search
from autobal.ocp import spinup as S

OUT = Path(__file__).resolve().parent / "results"
INTERVALS = (200, 400, 800, 1600)
REPEATS = 1
WALL = 240.0  # s, per solve


def problem() -> S.SpinupOcp:
    return S.SpinupOcp(RotorParams.from_groups(105.0, 5.0, 1.0), 40.0, 210.0, 5.0, 40.0, settling_time=3.0,
                       omega_max=210.0)


def guess(ocp, N):
    """The global search's best profile on N intervals, and its states at the interval starts."""
    best = search.grid_search(ocp, keep=1)
    u = search.controls_on_mesh(ocp, best.params[0], N)
    ms = S.mesh(ocp, N)
    uu = np.concatenate([u, np.zeros(ms.ns)])
    h = np.concatenate([np.full(ms.n, ms.h), np.full(ms.ns, ms.hs)])
    X = np.vstack([np.asarray(ocp.q0)[None, :], S.simulate_profile(ocp, uu, h, [1.0], tol=1e-8)[:, -1, :]])
    return uu, h, X


def timed(fn):
    times, out = [], None
    for _ in range(REPEATS):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def autobal_run(ocp, N, uu, h, X, ref):
    t = time.perf_counter()
    solver = S.Solver(ocp, S.DirectCollocation(N, 3, "radau"), ref, {"max_wall_time": WALL})
    build = time.perf_counter() - t
    w0 = S.initial_guess(ocp, solver.nlp, uu[:N])
    w0[solver.nlp.index["X"]] = X
    w0[solver.nlp.index["Xc"]] = X[:-1, None, :]  # rockit's guess: the interval-start states
    solve, sol = timed(lambda: solver.solve(w0=w0.copy(), raise_on_failure=False))
    tr = S.resimulate(ocp, sol.u, sol.h, "autobal")
    return {"build": build, "solve": solve, "iterations": sol.iterations, "status": sol.status,
            "objective": sol.objective, "resim": tr.peak_delta}


def rockit_run(ocp, N, uu, h, X, ref):
    """The same problem in rockit's declaration API, ``expand=True``."""
    from rockit import DirectCollocation, Ocp

    ms = S.mesh(ocp, N)
    T_end = ocp.tau_h + ocp.tau_s
    t = time.perf_counter()
    r = Ocp(t0=0, T=T_end)
    qs = [r.state() for _ in range(5)]
    q = ca.vertcat(*qs)
    u = r.control()
    s = r.variable()
    f = rotor_model().ode(q, u * ocp.a_max, ocp.params.p)
    for i in range(5):
        r.set_der(qs[i], f[i])
    free = ca.if_else(r.t < ocp.tau_h - 1e-9, 1, 0)  # 0 in the settling window: speed held, no speed bound
    r.subject_to(-free <= (u <= free), grid="control")
    r.subject_to(qs[4] <= ocp.nuf + (1 - free), grid="integrator_roots")
    r.subject_to(r.at_t0(q) == ocp.q0)
    r.subject_to(r.at_tf(qs[4]) == ocp.nuf)
    r.subject_to((qs[0] ** 2 + qs[1] ** 2 - s * ref) / ref <= 0, grid="integrator_roots")
    r.subject_to(s >= 0)
    r.add_objective(s)
    opts = {f"ipopt.{k}": v for k, v in S.IPOPT_OPTIONS.items()} | {
        "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False, "expand": True,
        "ipopt.max_wall_time": WALL}
    r.solver("ipopt", opts)
    r.method(DirectCollocation(N=ms.n + ms.ns, M=1, degree=3, scheme="radau"))
    tg = np.concatenate([[0.0], np.cumsum(h)])
    for i in range(5):  # rockit 0.6's set_initial of a numeric matrix fails for collocation
        r.set_initial(qs[i], ca.interpolant(f"g{i}", "linear", [tg], X[:, i])(r.t))
    r.set_initial(u, uu)
    r.set_initial(s, 1.05 * np.max(X[:, 0] ** 2 + X[:, 1] ** 2) / ref)
    declare = time.perf_counter() - t

    def solve():
        try:
            return r.solve()
        except RuntimeError:  # not converged: rockit raises; its last iterate is still there
            return r.non_converged_solution

    t = time.perf_counter()
    solve()  # transcription + nlpsol construction + first solve
    first = time.perf_counter() - t
    dt, sol = timed(solve)  # re-solves reuse the built solver: the solve time
    st = sol.stats
    _, us = sol.sample(u, grid="control")
    tr = S.resimulate(ocp, np.asarray(us, float)[:len(h)], h, "rockit")
    return {"build": declare + max(first - dt, 0.0), "solve": dt, "iterations": st["iter_count"],
            "status": st["return_status"], "objective": float(np.sqrt(max(sol.value(s), 0) * ref)),
            "resim": tr.peak_delta}


def figure(rows, path):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.subplots()
    for key, label, mk in (("autobal", "autobal solve", "o-"), ("peer", "rockit (expand=True) solve", "s--")):
        pts = [(r["N"], r[key]["solve"]) for r in rows if r.get(key)]
        if pts:
            ax.loglog(*zip(*pts, strict=True), mk, label=label)
    pts = [(r["N"], r["autobal"]["build"]) for r in rows if r.get("autobal")]
    ax.loglog(*zip(*pts, strict=True), "o:", label="autobal build")
    n = np.array([r["N"] for r in rows], float)
    if len(n):
        a0 = rows[0]["autobal"]["solve"]
        ax.loglog(n, a0 * n / n[0], "k:", lw=0.8, label="linear in N")
    ax.set_xlabel("control intervals N to the deadline")
    ax.set_ylabel("time (s)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)


def main(intervals=INTERVALS) -> str:
    from benchmarks.__main__ import machine

    ocp = problem()
    ref = 200.0  # scale of the epigraph level delta^2 (both)
    rows = []
    for N in intervals:
        uu, h, X = guess(ocp, N)
        row = {"N": N}
        for key, fn in (("autobal", autobal_run), ("peer", rockit_run)):
            try:
                row[key] = fn(ocp, N, uu, h, X, ref)
            except Exception as exc:  # report exactly why a side could not run
                row[key], row[f"{key}_error"] = None, f"{type(exc).__name__}: {str(exc)[:200]}"
        rows.append(row)
        print(f"spinup_ocp N={N}: {row}", flush=True)
    cases = []
    for r in rows:
        a, p = r.get("autobal"), r.get("peer")
        cases.append({"case": f"spin-up OCP, a_max 40 rad/s^2, deadline 5 s, hold 3 s, Radau 3, N = {r['N']}",
                      "autobal_s": a["solve"] if a else None, "autobal_build_s": a["build"] if a else None,
                      "peer": "rockit DirectCollocation, expand=True", "peer_s": p["solve"] if p else None,
                      "ratio": p["solve"] / a["solve"] if a and p else None,
                      "autobal_error": r.get("autobal_error") or (None if a and a["status"] == "Solve_Succeeded"
                                                                   else a and a["status"]),
                      "peer_error": r.get("peer_error") or (None if p and p["status"] == "Solve_Succeeded"
                                                             else p and p["status"]),
                      "autobal": a, "rockit": p})
    OUT.mkdir(exist_ok=True)
    (OUT / "spinup_ocp.json").write_text(json.dumps({"name": "spinup_ocp", "machine": machine(), "cases": cases},
                                                    indent=2))
    figure(rows, OUT / "spinup_ocp.png")
    lines = ["# Spin-up OCP: autobal vs rockit (expand=True)", "",
             "Jeffcott rotor, 40 -> 210 rad/s by a 5 s deadline, |alpha| <= 40 rad/s^2, 3 s hold at 210 rad/s, "
             "speed cap 210 rad/s; minimum peak deflection; Radau degree 3; same mesh, same IPOPT options "
             f"(tol {S.IPOPT_OPTIONS['tol']:g}, MUMPS, each solve capped at {WALL:g} s), same initial guess (the "
             "global search's best profile, interval-start states); peaks re-simulated with CVODES (rtol 1e-12).",
             f"Machine: {machine()}.", "",
             "| N | side | build (s) | solve (s) | iterations | status | optimum (e) | re-simulated peak (e) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        for key, label in (("autobal", "autobal"), ("peer", "rockit")):
            v = r.get(key)
            if v is None:
                lines.append(f"| {r['N']} | {label} | not run: {r.get(key + '_error')} | | | | | |")
            else:
                b = f"{v['build']:.2f}"
                lines.append(f"| {r['N']} | {label} | {b} | {v['solve']:.2f} | {v['iterations']} | {v['status']} | "
                             f"{v['objective']:.5f} | {v['resim']:.5f} |")
    lines += ["", "![scaling](spinup_ocp.png)", ""]
    text = "\n".join(lines) + "\n"
    (OUT / "spinup_ocp.md").write_text(text)
    return text


if __name__ == "__main__":
    print(main())
