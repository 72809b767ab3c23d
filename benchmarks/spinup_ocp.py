"""Benchmark: the spin-up OCP of the shipped scene ``spinup_jeffcott_deadline_5s``, solved by autobal and by
rockit (``expand=True``) in the same run, at 200, 400, 800 and 1600 control intervals.

The problem, as a drive is specified: Jeffcott rotor (psi = 1, Omega0 = 105 rad/s, n = 5 1/s),
40 -> 210 rad/s by a 5 s deadline with |alpha| <= 40 rad/s^2, then a 3 s hold at 210 rad/s over which
the peak counts, never above 210 rad/s; minimum peak deflection (epigraph delta^2 <= S at every Radau
point).  Both sides transcribe the same dimensionless model (the rotor model's CasADi Function) by
Radau collocation of degree 3 on the same uniform mesh (N intervals to the deadline, 0.6 N more over the
hold), use the same IPOPT options (autobal's solver options ``spinup``, MUMPS) and start from the same guess:
the best profile of autobal's global search (the first of its starts) on the N intervals, the states
simulated to the interval ends and held over each interval at the collocation points (rockit's
``set_initial`` of interval values; autobal's ``hold_states``; a simulated guess at the collocation
points, or one interpolated linearly, takes autobal to the iteration limit at N = 200), written into both
NLPs' variables (rockit's: into its Opti variables after ``transcribe()``, in one call, because its
``set_initial`` of a profile costs O(N^2)); both initial objectives are recorded as a check.  autobal's NLP
has no separate node states: its last Radau point is the interval end, which starts held like rockit's
last point; rockit's separate node variables start at the simulated values.

A third side, autobal with fatrop (``nlp_solver: fatrop``: the same discrete problem in the stage form of
``transcribe_stages``, a Riccati recursion over the stages instead of MUMPS), starts from the same guess.

Times: build = declaration, transcription and solver construction (rockit: its ``solve()`` call's
wall time minus the IPOPT solve inside it); solve = the wall time of the IPOPT call itself, function
evaluations included (autobal: around the solver call; rockit: CasADi's ``t_wall_total`` of it), one
solve each; the profile splits it into function evaluations (objective, constraints, gradients,
Jacobian, Hessian) and IPOPT's own work (the linear algebra).  Each solve is capped at ``WALL``
seconds (IPOPT ``max_wall_time``).  Every optimum is re-simulated with CVODES (rtol 1e-12, 24 points per interval).

Run: ``python -m benchmarks spinup_ocp`` (all sizes; ``max_wall_time`` is only checked between
iterations: stopped by hand, the sizes done are kept) or ``python -m benchmarks.spinup_ocp 200 400``
(some sizes).  Writes benchmarks/results/spinup_ocp.json and .md, and docs/figures/benchmark_spinup_scaling.png.
"""

from __future__ import annotations

import dataclasses
import re
import sys
import time
import traceback
from pathlib import Path

import casadi as ca
import numpy as np

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.analysis.run import solver_options
from autobal.models.rotor import rotor_model
from autobal.ocp import solve as osolve
from autobal.ocp.simulation import initial_guess, resimulate
from autobal.ocp.transcription import DirectCollocation, mesh
from benchmarks._results import RESULTS, case, write

SCENE = "spinup_jeffcott_deadline_5s"
INTERVALS = (200, 400, 800, 1600)
DEGREE, SCHEME = 3, "radau"
WALL = 300.0  # s, cap of each IPOPT solve
REF = 200.0  # scale of the epigraph level delta^2 (both sides)
FIGURE = Path(__file__).resolve().parent.parent / "docs" / "figures" / "benchmark_spinup_scaling.png"
PEER = "rockit-meco DirectCollocation, expand=True"
EVALS = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
SIDES = ("autobal", "fatrop", "rockit")  # autobal with IPOPT, autobal with fatrop, the peer


def problem():
    """The shipped scene's SpinupOcp (the real problem: deadline, settling window, speed cap) without the
    scene's jerk regulariser (``jerk_variation``): rockit's declaration below has none, so both sides solve
    the minimum-peak problem itself."""
    scene = api.load(SCENE)
    return dataclasses.replace(spinup_ocp(scene, scene.analyses.spinup), jerk_variation=0.0, jerk_penalty=0.0)


def guess(ocp, nlp):
    """The common start on the N intervals of ``nlp``: autobal's own (``Solver.solve(u, hold_states=True)``):
    the global search's best profile, the states simulated at the collocation points and interval ends,
    then the collocation states held at the interval-start values.  Returns the start's label, the full
    NLP guess, and its parts for rockit: controls (horizon and hold), interval lengths (tau), states at
    the interval ends (N + Ns + 1, 5) and at the collocation points (N + Ns, d, 5), epigraph level."""
    label, u = osolve.starts(ocp, nlp.mesh.n, multistart=False)[0]
    ms = nlp.mesh
    if abs(ms.hs - ms.h) > 1e-12 * ms.h:
        raise ValueError(f"N = {ms.n}: the hold does not fit whole intervals of the horizon's length")
    w0 = initial_guess(ocp, nlp, u)
    X = w0[nlp.index["X"]]  # simulated nodes (rockit's node variables)
    w0[nlp.index["Xc"]] = X[:-1, None, :]  # autobal's last Radau point, its node, is held like rockit's
    h = np.full(ms.n + ms.ns, ms.h)
    return label, w0, w0[nlp.index["u"]], h, X, w0[nlp.index["Xc"]], float(w0[nlp.index["v"][0]])


def profile(stats: dict, total: float) -> dict:
    """Where the solve's wall time ``total`` went (s): each function evaluation and IPOPT's own work."""
    out = {k: float(stats.get(f"t_wall_{k}", 0.0)) for k in EVALS}
    out["ipopt_internal"] = total - sum(out.values())
    return out


def outcome(ocp, stats, u, h, objective, build, solve, status=None):
    tr = resimulate(ocp, u, h, "optimum")
    it = stats.get("iterations") or {}
    return {"build_s": build, "solve_s": solve,
            "iterations": int(stats["iter_count"]), "status": status or stats["return_status"],
            "success": bool(stats["success"]), "optimum_over_e": objective, "resimulated_peak_over_e": tr.peak_delta,
            "initial_objective": float(it["obj"][0]) if it.get("obj") else None, "profile_s": profile(stats, solve)}


def autobal_run(ocp, N):
    """Build and solve autobal's NLP (IPOPT) from its start; the outcome and the start (for the others)."""
    t = time.perf_counter()
    solver = osolve.Solver(ocp, DirectCollocation(N, DEGREE, SCHEME), REF, {"max_wall_time": WALL})
    build = time.perf_counter() - t
    g = guess(ocp, solver.nlp)
    sol = solver.solve(w0=g[1].copy(), raise_on_failure=False)
    return outcome(ocp, solver.solver.stats(), sol.u, sol.h, sol.objective, build, sol.solve_time_s), g


def fatrop_run(ocp, N, g):
    """The same problem, mesh and guess in autobal's stage form, solved by fatrop (``nlp_solver: fatrop``); its
    node states start simulated and its collocation points held, as rockit's."""
    t = time.perf_counter()
    solver = osolve.Solver(ocp, DirectCollocation(N, DEGREE, SCHEME, "fatrop"), REF)
    build = time.perf_counter() - t
    _, _, uu, _, X, Xc, level = g
    nlp, w0 = solver.nlp, np.zeros(solver.nlp.x.numel())
    w0[nlp.index["X"]], w0[nlp.index["Xc"]], w0[nlp.index["u"]], w0[nlp.index["v"]] = X, Xc, uu, level
    sol = solver.solve(w0=w0, raise_on_failure=False)
    return outcome(ocp, solver.solver.stats(), sol.u, sol.h, sol.objective, build, sol.solve_time_s, sol.status)


def rockit_run(ocp, N, g):
    """The same problem in rockit's declaration API, ``expand=True`` (a competent rockit user's setting)."""
    from rockit import DirectCollocation as RockitCollocation
    from rockit import Ocp

    _, _, uu, h, X, Xc, level = g
    ms = mesh(ocp, N)
    t = time.perf_counter()
    r = Ocp(t0=0, T=ocp.tau_h + ocp.tau_s)
    qs = [r.state() for _ in range(5)]
    q = ca.vertcat(*qs)
    u = r.control()
    s = r.variable()
    f = rotor_model().ode(q, u * ocp.a_max, ocp.params.p)
    for i in range(5):
        r.set_der(qs[i], f[i])
    free = ca.if_else(r.t < ocp.tau_h - 1e-9, 1, 0)  # 0 over the hold: speed held, no speed bound
    r.subject_to(-free <= (u <= free), grid="control")
    r.subject_to(0 <= (qs[4] <= ocp.nuf + (1 - free)), grid="integrator_roots")
    r.subject_to(r.at_t0(q) == ocp.q0)
    r.subject_to(r.at_tf(qs[4]) == ocp.nuf)  # = omega_final at the deadline: the hold keeps the speed
    r.subject_to((qs[0] ** 2 + qs[1] ** 2 - s * REF) / REF <= 0, grid="integrator_roots")
    r.subject_to(s >= 0)
    r.add_objective(s)
    opts = {f"ipopt.{k}": v for k, v in solver_options.get("spinup").items()} | {
        "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False, "record_time": True, "expand": True,
        "ipopt.max_wall_time": WALL}
    r.solver("ipopt", opts)
    r.method(RockitCollocation(N=ms.n + ms.ns, M=1, degree=DEGREE, scheme=SCHEME))
    r.transcribe()
    # the guess goes straight into rockit's Opti variables, in one call: its set_initial of a profile
    # makes one Opti call per interval, each hashing every variable (O(N^2); minutes at N = 200)
    m = r._method
    m.opti.set_initial(ca.veccat(*m.X, *m.Xc_pure, *m.U, m.eval(r, s)),
                       np.concatenate([X.ravel(), Xc.ravel(), uu, [level]]))
    try:
        sol = r.solve()
    except RuntimeError:  # not converged: rockit raises, its last iterate is kept
        sol = r.non_converged_solution
    end = time.perf_counter()
    stats = sol.stats
    _, us = sol.sample(u, grid="control")
    solve = float(stats["t_wall_total"])  # the IPOPT call inside solve()
    return outcome(ocp, stats, np.asarray(us, float)[:len(h)], h, float(np.sqrt(max(sol.value(s), 0) * REF)),
                   end - t - solve, solve)


def slope(n, y) -> float | None:
    """Least-squares exponent p of y ~ N^p (None with fewer than two points)."""
    ok = [(a, b) for a, b in zip(n, y, strict=True) if b and b > 0]
    if len(ok) < 2:
        return None
    x, z = np.log([a for a, _ in ok]), np.log([b for _, b in ok])
    return float(np.polyfit(x, z, 1)[0])


def figure(rows, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 3.4), layout="constrained")
    ax_t, ax_i = fig.subplots(1, 2)
    n = np.array([r["N"] for r in rows], float)
    for side, label, mk, c in (("autobal", "autobal (IPOPT)", "o-", "C0"), ("fatrop", "autobal (fatrop)", "^-", "C2"),
                               ("rockit", "rockit (expand=True)", "s--", "C3")):
        pts = [(r["N"], r[side]) for r in rows if r.get(side)]
        if not pts:
            continue
        N_, v = zip(*pts, strict=True)
        ax_t.loglog(N_, [x["solve_s"] for x in v], mk, color=c, label=f"{label} solve")
        ax_t.loglog(N_, [x["build_s"] for x in v], mk.replace("-", ":").replace("::", ":"), color=c, alpha=0.5,
                    mfc="none", label=f"{label} build")
        ax_i.loglog(N_, [x["iterations"] for x in v], mk, color=c, label=label)
        for x_, x in zip(N_, v, strict=True):
            if not x["success"]:
                ax_t.annotate(x["status"].replace("_", " "), (x_, x["solve_s"]), fontsize=6)
    missing = [int(r["N"]) for r in rows if not (r.get("autobal") and r.get("rockit"))]
    for ax, key in ((ax_t, "solve_s"), (ax_i, "iterations")):
        if len(n) and rows[0].get("autobal"):
            y0 = rows[0]["autobal"][key]
            ax.loglog(n, y0 * n / n[0], "k:", lw=0.8, label="$\\propto N$")
        ax.set_xticks(n, [str(int(x)) for x in n])
        ax.minorticks_off()
        if missing:
            ax.set_title(f"not finished: N = {', '.join(map(str, missing))}", fontsize=7)
        ax.set_xlabel("control intervals N to the deadline")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    ax_t.set_ylabel("wall time (s)")
    ax_i.set_ylabel("solver iterations")
    fig.suptitle("Spin-up OCP (deadline 5 s, hold 3 s, Radau 3): autobal and rockit, same mesh and guess",
                 fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def report(ocp, rows, start_label) -> list[dict]:
    """One case per size and autobal solver (IPOPT, fatrop), each against rockit's solve of the same size."""
    cases = []
    for r, mine in ((r, mine) for r in rows for mine in ("autobal", "fatrop")):
        a, p = r.get(mine), r.get("rockit")
        err = {}
        for side, x in ((mine, a), ("peer", p)):
            err[side] = r.get(f"{side}_error") or (None if x and x["success"] else x and x["status"])
        via = "IPOPT" if mine == "autobal" else "fatrop"
        row = case(f"N = {r['N']} (+{r['Ns']} hold), autobal {via}", a["solve_s"] if a else np.nan,
                   a["build_s"] if a else None,
                   PEER, p["solve_s"] if p else np.nan,
                   autobal_iterations=a and a["iterations"], peer_iterations=p and p["iterations"],
                   autobal_status=a and a["status"], peer_status=p and p["status"],
                   autobal_optimum=a and a["optimum_over_e"], peer_optimum=p and p["optimum_over_e"],
                   autobal_resimulated_peak=a and a["resimulated_peak_over_e"],
                   peer_resimulated_peak=p and p["resimulated_peak_over_e"],
                   peer_build_s=p and p["build_s"], autobal=a, rockit=p)
        row["autobal_error"], row["peer_error"] = err[mine], err["peer"]
        cases.append(row)
    return cases


def _sides(rows):
    """(row, side, outcome or None) for each size and side, in table order."""
    return [(r, side, r.get(side)) for r in rows for side in SIDES]


def markdown(rows, exps) -> list[str]:
    t = ["| N | side | build (s) | solve (s) | iterations | solve / iteration (ms) | status | optimum (e) "
         "| re-simulated peak (e) | initial objective |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r, side, v in _sides(rows):
        if v is None:
            why = r.get(("peer" if side == "rockit" else side) + "_error") or "not reached"
            t.append(f"| {r['N']} | {side} | not run: {why} | | | | | | | |")
        else:
            t.append(f"| {r['N']} | {side} | {v['build_s']:.2f} | {v['solve_s']:.2f} | {v['iterations']} | "
                     f"{1e3 * v['solve_s'] / max(v['iterations'], 1):.1f} | {v['status']} | "
                     f"{v['optimum_over_e']:.5f} | {v['resimulated_peak_over_e']:.5f} | "
                     f"{'-' if v['initial_objective'] is None else format(v['initial_objective'], '.6g')} |")
    p = ["| N | side | objective + constraints (s) | gradient + Jacobian (s) | Hessian (s) | the solver's own work "
         "(s) | share in the solver |", "|---|---|---|---|---|---|---|"]
    for r, side, v in _sides(rows):
        if v is not None:
            pr, own = v["profile_s"], v["profile_s"]["ipopt_internal"]
            p.append(f"| {r['N']} | {side} | {pr['nlp_f'] + pr['nlp_g']:.3f} | "
                     f"{pr['nlp_grad_f'] + pr['nlp_jac_g']:.3f} | {pr['nlp_hess_l']:.3f} | {own:.2f} | "
                     f"{100 * own / max(v['solve_s'], 1e-12):.0f} % |")
    e = ["| exponent p of y ~ N^p (least squares over the sizes run) | autobal (IPOPT) | autobal (fatrop) | rockit |",
         "|---|---|---|---|"]
    for key, label in (("solve_s", "solve time"), ("iterations", "solver iterations"),
                       ("per_iteration", "solve time per iteration"), ("build_s", "build time")):
        e.append(f"| {label} | " + " | ".join(_f(exps[side].get(key)) for side in SIDES) + " |")
    return ["Per side:\n\n" + "\n".join(t), "Where the solve time goes (CasADi's timers):\n\n" + "\n".join(p),
            "Scaling with the number of intervals:\n\n" + "\n".join(e)]


def _f(x):
    return "-" if x is None else f"{x:.2f}"


def exponents(rows) -> dict:
    out = {}
    for side in SIDES:
        pts = [(r["N"], r[side]) for r in rows if r.get(side) and r[side]["success"]]
        n = [a for a, _ in pts]
        out[side] = {k: slope(n, [v[k] for _, v in pts]) for k in ("solve_s", "iterations", "build_s")}
        out[side]["per_iteration"] = slope(n, [v["solve_s"] / max(v["iterations"], 1) for _, v in pts])
    return out


def main(intervals=INTERVALS) -> list[dict]:
    ocp = problem()
    rows, start_label = [], None
    for N in intervals:
        row = {"N": N, "Ns": mesh(ocp, N).ns}
        rows.append(row)
        g = None
        for side, key in (("autobal", "autobal"), ("fatrop", "fatrop"), ("rockit", "peer")):
            t = time.perf_counter()
            try:
                if side == "autobal":
                    row[side], g = autobal_run(ocp, N)
                    start_label = g[0]
                elif side == "fatrop":
                    row[side] = fatrop_run(ocp, N, g)
                else:
                    row[side] = rockit_run(ocp, N, g)
            except KeyboardInterrupt:  # stopped by hand: the sizes done so far and this one's wall time are kept
                row[side], row[f"{key}_error"] = None, f"interrupted after {time.perf_counter() - t:.0f} s"
                save(ocp, rows, start_label)
                raise
            except Exception as exc:  # report exactly why a side could not run
                traceback.print_exc()
                row[side], row[f"{key}_error"] = None, f"{type(exc).__name__}: {str(exc)[:200]}"
            print(f"spinup_ocp N={N} {side}: {row[side]}", flush=True)
        save(ocp, rows, start_label)
    return save(ocp, rows, start_label)


def save(ocp, rows, start_label) -> list[dict]:
    cases = report(ocp, rows, start_label)
    exps = exponents(rows)
    ratios = {via: [c["ratio"] for c in cases if c["case"].endswith(via) and c["ratio"]] for via in ("IPOPT", "fatrop")}
    best = [max(x, y) for x, y in zip(ratios["IPOPT"], ratios["fatrop"], strict=False)]
    goal = ("Goal (issue 14): >= 3x faster than rockit expand=True on the same problem, mesh and guess: "
            f"{'met' if best and min(best) >= 3 else 'missed'} (peer / autobal solve "
            + "; ".join(f"with {via} {', '.join(f'{x:.2f}' for x in r)}" for via, r in ratios.items())
            + " at the sizes run); the solve-time split below shows where the time goes.")
    notes = [goal,
             f"Scene {SCENE}: Jeffcott rotor (psi = 1, Omega0 = 105 rad/s, n = 5 1/s), 40 -> 210 rad/s by a 5 s "
             "deadline, |alpha| <= 40 rad/s^2, 3 s hold at 210 rad/s over which the peak counts, speed cap 210 rad/s; "
             f"minimum peak deflection (epigraph at every Radau point). Radau collocation degree {DEGREE} on the same "
             "uniform mesh (N intervals to the deadline, 0.6 N over the hold); the same IPOPT options "
             f"(tol {solver_options.defaults['spinup.tol']:g}, adaptive barrier, MUMPS, each solve capped at "
             f"{WALL:g} s); the "
             f"same guess: autobal's global-search start ({start_label}), states simulated to the interval ends "
             "and held over each interval at the collocation points (autobal's last Radau point is the node "
             "itself, held like rockit's; rockit's node variables start simulated).",
             "autobal (fatrop): the same discrete problem in autobal's stage form (nlp_solver: fatrop; the node "
             f"states and the collocation points start as rockit's), fatrop with mu_init "
             f"{solver_options.defaults['fatrop.mu_init']:g} and tol {solver_options.defaults['spinup.tol']:g}; its "
             "build includes "
             "CasADi's SX expansion and fatrop's setup.",
             "Solve = wall time of the one solver call, function evaluations included (rockit: CasADi's "
             "t_wall_total); build = declaration, transcription and solver construction (rockit: its solve() "
             "call minus the IPOPT solve in it), not in the ratio. Errors: the solver status when not "
             "Solve_Succeeded. Optima and peaks in delta/e; the re-simulated peak is CVODES at rtol 1e-12 with "
             "the optimal controls.",
             "Exponents: " + "; ".join(f"{label} solve ~ N^{_f(exps[side]['solve_s'])}, iterations ~ N^"
                                       f"{_f(exps[side]['iterations'])}" for side, label in
                                       (("autobal", "autobal (IPOPT)"), ("fatrop", "autobal (fatrop)"),
                                        ("rockit", "rockit"))) + " (successful solves only)."]
    md = RESULTS / "spinup_ocp.md"
    old = md.read_text() if md.exists() else ""
    kept = next((old[m.start():] for m in re.finditer(r"^#+ .*lever", old, re.I | re.M)), "")
    write("spinup_ocp", "Spin-up OCP (deadline 5 s, hold 3 s): autobal vs rockit expand=True, 200-1600 intervals",
          cases, notes, tables=markdown(rows, exps))
    if kept:  # a section on the levers another study appended: kept below the generated table
        md.write_text(md.read_text() + "\n" + kept)
    figure(rows, FIGURE)
    return cases


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or INTERVALS)
