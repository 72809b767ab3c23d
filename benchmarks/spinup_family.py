"""Benchmark: a family of spin-up problems with independent references (issue 35), and the study's wall time on each.

The family spans what engineers meet: damping ratio 0.005-0.1, 0.5-20 natural periods to cross +-10 % of the
critical speed at the full acceleration, tight and loose deadlines, drive limits without braking (torque, power),
drag, speed caps and a datasheet rotor.  Each problem is a scene (written to a YAML file and loaded as the CLI
loads it).

The reference of each problem is found by a method independent of the study's (its cross-entropy search, its
collocation and CVODES): scipy's differential evolution over four profile families (a leg list: each leg runs at
a rate towards a target speed, the drive's torque, power and drag limits capping the rate at every step), the best
family polished by Nelder-Mead, every candidate judged by the exponential integrator
(:func:`autobal.ocp.search.simulate_steps`) at a step of 0.5 in Omega0 t; the best profile is then judged by
scipy's ``solve_ivp`` (DOP853, rtol 1e-10, atol 1e-12) on the rotor's fixed-frame equations (the model's
``ode_fixed`` Function, one copy of the equation), sampled at 64 points per natural period.  Its deadline, speed
cap and drive limits are checked on the solve_ivp trajectory (the torque from the model's torque Function).

The families: (1) three phases (full rate to w1, a rate u_b for a time d, full rate on); (2) one back-off (full
rate to a1, the lowest allowed rate for d1, then a last leg at a free rate that arrives by the deadline); (3) two
back-offs (the same with a second excursion); (4) four waypoints (free speeds at free instants, linear between
within the limits).

Writes tests/data/spinup_family.json (each problem's scene, its reference peak, the family and parameters that
found it, the check of its limits, how it was computed) and benchmarks/results/spinup_family.json (the study's
peak and wall time on each, beside the reference).  Run: ``python -m benchmarks.spinup_family`` (tens of minutes);
``python -m benchmarks.spinup_family --study`` re-times the study alone; ``--levers NAME ...`` the study's levers side
by side; ``--screening NAME ...`` the coarse screening in one process, on two threads and in two processes.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np
import yaml
from scipy.integrate import solve_ivp
from scipy.optimize import differential_evolution, minimize

from autobal import api
from autobal.analyses.spinup import ocp as spinup_ocp
from autobal.models.rotor import rotor_model
from autobal.ocp import search
from benchmarks._results import case, write

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "spinup_family.json"
DT = 0.5  # step of the search integrator, Omega0 t (its FAST_STEP: the peak within 1e-4 of CVODES)

_ROTOR = {"mass": "1 kg", "stiffness": "10000 N/m", "eccentricity": "0.1 mm"}  # omega_n = 100 rad/s


def _spin(**kw) -> dict:
    return {"objective": "peak_deflection", "segments": 0, **kw}


#: name -> (what it covers, scene without its name and title)
PROBLEMS = {
    "damped_issue35": ("zeta 0.1, 2.0 periods per passage, loose deadline (slack 2.06 s), cap (issue 35)", {
        "rotor": {"mass": "2 kg", "stiffness": "20000 N/m", "damping": "40 N*s/m", "eccentricity": "0.05 mm"},
        "analyses": {"spinup": _spin(start_speed="50 rad/s", final_speed="200 rad/s", horizon="3 s",
                                     settling_time="1 s", max_speed="200 rad/s", max_acceleration="160 rad/s^2")}}),
    "damped_tight": ("zeta 0.1, 2.0 periods per passage, tight deadline (slack 0.06 s)", {
        "rotor": {"mass": "2 kg", "stiffness": "20000 N/m", "damping": "40 N*s/m", "eccentricity": "0.05 mm"},
        "analyses": {"spinup": _spin(start_speed="50 rad/s", final_speed="200 rad/s", horizon="1 s",
                                     settling_time="1 s", max_speed="200 rad/s", max_acceleration="160 rad/s^2")}}),
    "light_fast": ("zeta 0.005, 0.5 periods per passage, slack 0.15 s, cap", {
        "rotor": _ROTOR | {"damping": "1 N*s/m"},
        "analyses": {"spinup": _spin(start_speed="50 rad/s", final_speed="200 rad/s", horizon="0.4 s",
                                     settling_time="0.6 s", max_speed="200 rad/s", max_acceleration="640 rad/s^2")}}),
    "light_slow": ("zeta 0.005, 20 periods per passage, tight deadline (slack 0.6 s)", {
        "rotor": _ROTOR | {"damping": "1 N*s/m"},
        "analyses": {"spinup": _spin(start_speed="50 rad/s", final_speed="200 rad/s", horizon="10 s",
                                     settling_time="1 s", max_speed="200 rad/s", max_acceleration="16 rad/s^2")}}),
    "medium_loose_nocap": ("zeta 0.02, 5.3 periods per passage, loose deadline (slack 1.0 s), no speed cap", {
        "rotor": _ROTOR | {"damping": "4 N*s/m"},
        "analyses": {"spinup": _spin(start_speed="40 rad/s", final_speed="200 rad/s", horizon="3.7 s",
                                     settling_time="1 s", max_acceleration="60 rad/s^2")}}),
    "zeta05": ("zeta 0.05, 3.2 periods per passage, loose deadline (slack 1.5 s), cap", {
        "rotor": _ROTOR | {"damping": "10 N*s/m"},
        "analyses": {"spinup": _spin(start_speed="50 rad/s", final_speed="200 rad/s", horizon="3 s",
                                     settling_time="1 s", max_speed="200 rad/s", max_acceleration="100 rad/s^2")}}),
    "torque_no_brake": ("zeta 0.02, torque limit 0.8 N m, no braking, 3.2 periods per passage", {
        "rotor": _ROTOR | {"damping": "4 N*s/m",
                           "drive": {"polar_inertia": "0.01 kg*m^2", "max_torque": "0.8 N*m",
                                     "max_braking_torque": "0 N*m"}},
        "analyses": {"spinup": _spin(start_speed="40 rad/s", final_speed="200 rad/s", horizon="3 s",
                                     settling_time="1 s", max_speed="200 rad/s", max_acceleration="100 rad/s^2")}}),
    "power_drag_no_brake": ("zeta 0.03, power limit 150 W, drag 1e-3 N m s, no braking", {
        "rotor": _ROTOR | {"damping": "6 N*s/m",
                           "drive": {"polar_inertia": "0.01 kg*m^2", "max_torque": "1.2 N*m", "max_power": "150 W",
                                     "drag": "0.001 N*m*s", "max_braking_torque": "0 N*m"}},
        "analyses": {"spinup": _spin(start_speed="40 rad/s", final_speed="200 rad/s", horizon="3 s",
                                     settling_time="1 s", max_speed="200 rad/s", max_acceleration="120 rad/s^2")}}),
    "datasheet_rotor": ("a 120 kg rotor from its datasheet (2400 rpm, zeta 0.02), 150 N m, 45 kW, no braking", {
        "rotor": {"mass": "120 kg", "critical_speed": "2400 rpm", "damping_ratio": 0.02,
                  "unbalance": {"residual": "6000 g*mm"},
                  "drive": {"polar_inertia": "2.0 kg*m^2", "max_torque": "150 N*m", "max_power": "45 kW",
                            "max_braking_torque": "0 N*m"}},
        "analyses": {"spinup": _spin(start_speed="600 rpm", final_speed="4000 rpm", horizon="8 s",
                                     settling_time="1 s", max_speed="4000 rpm", max_acceleration="60 rad/s^2")}}),
}


def load_problem(name: str, scene: dict):
    """The SpinupOcp and the scene of a family problem (its scene written to a YAML file and loaded)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{name}.yaml"
        path.write_text(yaml.safe_dump({"name": name, "title": name} | scene, sort_keys=False))
        sc = api.load(path)
    return spinup_ocp(sc, sc.analyses.spinup), sc


MARGIN = 1e-3  # relative: the torque the legs leave for the unbalance reaction, which the caps do not model


def rate_caps(ocp, omega: np.ndarray) -> tuple[np.ndarray, float]:
    """(largest acceleration over alpha_max the drive gives at ``omega``, lowest control u_min): alpha_max and the
    torque and power limits (less MARGIN) after the drag b omega, over the drive's inertia."""
    top = np.full_like(omega, ocp.alpha_max)
    if ocp.inertia > 0:
        lim = [np.full_like(omega, ocp.torque_max)] if ocp.torque_max else []
        if ocp.power_max:
            lim.append(ocp.power_max / np.maximum(omega, 1e-9))
        for m in lim:
            top = np.minimum(top, (m * (1 - MARGIN) - ocp.drag * omega) / ocp.inertia)
    lo = ocp.u_min
    if ocp.braking_torque_max is not None and ocp.inertia > 0:  # braking torque limit, drag helps
        lo = max(lo, -(ocp.braking_torque_max + ocp.drag * omega.min()) / (ocp.inertia * ocp.alpha_max))
    return top / ocp.alpha_max, lo


def execute(ocp, legs: list[tuple], steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The controls (C, steps) over alpha_max of leg lists run step by step at DT: each leg (target speed (C,),
    rate (C,) over alpha_max, >0, and optionally a duration (C,), s) runs towards its target at that rate, capped by
    the drive (:func:`rate_caps`) and u_min going down, until it reaches the target or its duration ends; after the
    last, full rate to omega_final and hold.  Also the speed at the deadline (C,)."""
    C = len(legs[0][0])
    legs = [leg if len(leg) == 3 else (*leg, np.full(C, np.inf)) for leg in legs]
    legs.append((np.full(C, float(ocp.omega_final)), np.ones(C), np.full(C, np.inf)))
    targets, rates, durs = (np.column_stack([leg[i] for leg in legs]) for i in range(3))
    da = ocp.alpha_max * DT / ocp.Om  # speed change of a full-rate step, rad/s
    dts = DT / ocp.Om
    w = np.full(C, float(ocp.omega_start))
    k, spent = np.zeros(C, int), np.zeros(C)
    u = np.zeros((C, steps))
    h_steps = int(round(ocp.tau_h / DT))
    rows, last = np.arange(C), targets.shape[1] - 1
    for j in range(steps):
        for _ in range(3):  # legs reached or timed out move on
            done = ((np.abs(targets[rows, k] - w) < 1e-9) | (spent >= durs[rows, k] - 1e-12)) & (k < last)
            k, spent = k + done, np.where(done, 0.0, spent)
        tgt = targets[rows, k] if j < h_steps else np.full(C, float(ocp.omega_final))
        top, lo = rate_caps(ocp, w + da)  # at the highest speed the step may end at: the power limit kept at its end
        up, down = np.minimum(rates[rows, k], top), np.maximum(-rates[rows, k], lo)
        frac = np.clip((durs[rows, k] - spent) / dts, 0, 1)  # a timed leg ending inside the step
        step = np.clip(tgt - w, down * da * frac, up * da * frac)
        u[:, j] = step / da
        w, spent = w + step, spent + dts
    return u, ocp.omega_start + np.sum(u[:, :h_steps], axis=1) * da


def family_legs(ocp, family: str, x: np.ndarray) -> list:
    """The legs (:func:`execute`) of a family's profiles for the points x (C, dim) of the unit box."""
    top = ocp.omega_final if ocp.omega_max is None else ocp.omega_max
    lo_w, span, C = ocp.omega_start, top - ocp.omega_start, len(x)
    back = max(-ocp.u_min, 0.0)
    if family == "three_phase":  # full rate to w1, then a rate rb (-1 brakes, 0 holds) for d, then full rate
        rb = -1 + 1.5 * x[:, 1]
        return [(lo_w + x[:, 0] * span, np.ones(C)),
                (np.where(rb < 0, 0.0, top), np.maximum(np.abs(rb), 1e-9), x[:, 2] * ocp.horizon)]
    if family in ("backoff1", "backoff2"):
        legs, w = [], np.full(C, float(lo_w))
        for i in range(1 if family == "backoff1" else 2):
            ak = w + x[:, 2 * i] * (top - w)
            bk = ak - x[:, 2 * i + 1] * (ak - lo_w)
            legs += [(ak, np.ones(C)), (bk, np.full(C, back), x[:, 2 * i + 1] * ocp.horizon)] if back > 0 else \
                [(ak, np.ones(C)), (np.full(C, top), np.full(C, 1e-9), x[:, 2 * i + 1] * ocp.horizon / 2)]  # a hold
            w = bk if back > 0 else ak
        return legs + [(np.full(C, float(ocp.omega_final)), 0.05 + 0.95 * x[:, -1])]
    return [(lo_w + x[:, 2 * i] * span, 0.02 + 0.98 * x[:, 2 * i + 1]) for i in range(4)]  # waypoints


DIMS = {"three_phase": 3, "backoff1": 3, "backoff2": 5, "waypoints": 8}


def controls(ocp, family: str, x: np.ndarray, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Controls (C, steps) and deadline speeds of a family's profiles."""
    x = np.clip(np.atleast_2d(x), 0, 1)
    return execute(ocp, family_legs(ocp, family, x), steps)


def cost(ocp, family: str, rotor, steps: int):
    def f(x):
        u, wd = controls(ocp, family, x, steps)
        pk = search.simulate_steps(ocp, u, DT, rotor)
        short = np.maximum(ocp.omega_final - wd, 0) / ocp.omega_final
        return np.where(short > 1e-6, 1e3 * (1 + short), pk)
    return f


def judge(ocp, u: np.ndarray) -> dict:
    """solve_ivp (DOP853, rtol 1e-10) of the fixed-frame model with the step controls u (DT each): the peak
    delta/e sampled at 64 points per natural period, the speed at the deadline, the largest speed and the drive's
    largest torque and power and smallest torque."""
    m, P = rotor_model(), ocp.params
    p = ca.DM(P.p)
    f = m.ode_fixed
    x, y, vx, vy, nu0 = ocp.q0
    z = np.array([x, y, vx - nu0 * y, vy + nu0 * x, nu0, 0.0])
    # merge equal controls into runs
    edges = [0]
    for j in range(1, len(u)):
        if abs(u[j] - u[j - 1]) > 1e-12:
            edges.append(j)
    edges.append(len(u))
    per = 2 * np.pi / (P.omega_cr / ocp.Om)
    peak, t_all, Z = 0.0, [], []
    for s, e in zip(edges[:-1], edges[1:], strict=True):
        a = float(u[s]) * ocp.a_max
        t0, t1 = s * DT, e * DT
        sol = solve_ivp(lambda t, q, a=a: np.array(f(q, a, p)).ravel(), (t0, t1), z, method="DOP853", rtol=1e-10,
                        atol=1e-12, dense_output=True)
        tt = np.linspace(t0, t1, max(int(np.ceil((t1 - t0) / per * 64)), 2) + 1)
        q = sol.sol(tt)
        peak = max(peak, float(np.hypot(q[0], q[1]).max()))
        t_all.append(tt)
        Z.append(q)
        z = sol.y[:, -1]
    Q = np.concatenate(Z, axis=1)
    T = np.concatenate(t_all)
    # the torque of the model (rotating-frame states from the fixed-frame ones)
    nu, beta = Q[4], Q[5]
    c, s_ = np.cos(beta), np.sin(beta)
    X, Y, VX, VY = Q[0], Q[1], Q[2], Q[3]
    xr, yr = c * X + s_ * Y, -s_ * X + c * Y
    vxr, vyr = c * VX + s_ * VY + nu * yr, -s_ * VX + c * VY - nu * xr
    k = np.clip((T / DT).astype(int), 0, len(u) - 1)
    acc = u[k] * ocp.a_max
    q_rot = np.vstack([xr, yr, vxr, vyr, nu])
    torque = np.array(m.torque.map(q_rot.shape[1])(q_rot, acc[None, :], ca.repmat(p, 1, q_rot.shape[1]))).ravel() \
        * P.torque_scale
    h = int(round(ocp.tau_h / DT))
    return {"peak_over_e": peak, "deadline_speed_rad_s": float(ocp.omega_start + np.sum(u[:h]) * ocp.alpha_max * DT
                                                                 / ocp.Om),
            "max_speed_rad_s": float(nu.max() * ocp.Om), "max_torque_N_m": float(torque.max()),
            "min_torque_N_m": float(torque.min()), "max_power_W": float((torque * nu * ocp.Om).max())}


def reference(name: str, scene: dict, seed: int = 1) -> dict:
    ocp, _ = load_problem(name, scene)
    rotor = search.FixedFrameModes.of(ocp)
    steps = int(np.ceil((ocp.tau_h + ocp.tau_s) / DT))
    found = {}
    t0 = time.perf_counter()
    for fam, dim in DIMS.items():
        f = cost(ocp, fam, rotor, steps)
        r = differential_evolution(lambda X, f=f: f(X.T), [(0, 1)] * dim, seed=seed, vectorized=True,
                                   updating="deferred", popsize=max(6, 30 // dim), maxiter=40, tol=1e-9,
                                   polish=False)
        found[fam] = (float(r.fun), np.clip(r.x, 0, 1))
        print(f"  {name} {fam}: {found[fam][0]:.5f}", flush=True)
    fam = min(found, key=lambda k: found[k][0])
    f = cost(ocp, fam, rotor, steps)
    p = minimize(lambda v: float(f(np.clip(v, 0, 1)[None])[0]), found[fam][1], method="Nelder-Mead",
                 options={"maxfev": 300, "xatol": 1e-6, "fatol": 1e-8})
    if p.fun < found[fam][0]:
        found[fam] = (float(p.fun), np.clip(p.x, 0, 1))
    fam = min(found, key=lambda k: found[k][0])
    u, _ = controls(ocp, fam, found[fam][1][None], steps)
    j = judge(ocp, u[0])
    j["integrator_peak_over_e"] = found[fam][0]
    return {"reference_peak_over_e": j["peak_over_e"], "family": fam, "x": list(map(float, found[fam][1])),
            "families": {k: v[0] for k, v in found.items()}, "check": j, "search_s": time.perf_counter() - t0}


#: what a study process runs: load the scene, run the spin-up study as `autobal run` does (without writing files),
#: print its re-simulated peak and where its time went (s): the imports, the scene's loading, the study and the
#: study's own split (``time_split``) as one JSON line
SNIPPET = """import time
t0 = time.perf_counter()
import json, sys
from autobal import api
from autobal.analyses.spinup import ocp
from autobal.ocp import spinup_study
t1 = time.perf_counter()
sc = api.load(sys.argv[1]); s = sc.analyses.spinup
t2 = time.perf_counter()
res = spinup_study.run(ocp(sc, s), spinup_study.method_of(s), sc.title, s.multistart, None, s.segments)
t3 = time.perf_counter()
print(json.dumps({"peak": res.peak_deflection, "import_s": t1 - t0, "load_s": t2 - t1, "run_s": t3 - t2,
                  "split": res.time_split}))
"""


def study(name: str, scene: dict, python: str = sys.executable) -> dict:
    """The study on one problem in a new process of ``python`` (the process start-up included): its re-simulated
    peak (delta/e) and wall time (s)."""
    import subprocess

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{name}.yaml"
        path.write_text(yaml.safe_dump({"name": name, "title": name} | scene, sort_keys=False))
        t0 = time.perf_counter()
        out = subprocess.run([python, "-c", SNIPPET, str(path)], capture_output=True, text=True,
                             cwd=tmp)  # not the worktree: its autobal/ would shadow the python's own
        dt = time.perf_counter() - t0
        if out.returncode:  # a failed study: no peak, its last line
            return {"study_peak_over_e": None, "study_s": dt, "failure": (out.stderr.strip().splitlines() or ["?"])[-1]}
        got = json.loads(out.stdout.splitlines()[-1])
        return {"study_peak_over_e": got["peak"], "study_s": dt, "parts": parts(got, dt)}


def parts(got: dict, wall: float) -> dict:
    """Where a study process's wall time went (s), from its SNIPPET line ``got``: the interpreter's start and exit (what
    the imports, the loading and the study leave of ``wall``), the imports, the scene's loading, and the study's own
    parts (its ``time_split``): the global search, the coarse screening, the refinement (its NLP builds, guesses and
    IPOPT solves; the coarse NLP's build too), the CVODES re-simulations, and the rest (the baselines, computed
    alongside, are in it where they were waited for)."""
    split = {k.removesuffix("_time_s"): v for k, v in got["split"].items()}
    own = {"global_search_s": split["global_search"], "screening_s": split["screening"],
           "refinement_s": split["build"] + split["solve"] + split["guesses"], "resimulation_s": split["resimulation"]}
    return {"start_exit_s": wall - got["import_s"] - got["load_s"] - got["run_s"], "imports_s": got["import_s"],
            "loading_s": got["load_s"], **own, "rest_s": got["run_s"] - sum(own.values())}


def levers(names: list[str]) -> None:
    """The study's levers side by side on some problems, in this process, back to back (ratios to the study as it
    is; the load of the shared machine stretches the times alike): the regulariser in the coarse screening too (as
    before issue 35), the lean start list (the one-back-off searches and the hold ramp: no three-phase grid, no
    two-back-off search, no constant ramps), the start list without the three-phase grid's two, one refinement of
    the coarse optima instead of up to three, the coarse screening to IPOPT tolerance 1e-4, and the coarse ranking
    by the exponential integrator alone (no CVODES for near ties), the global search and the screening in one
    process (two as is: analysis/run/forked.py), and the screening on two threads of one process; LEVERS=name,name
    (environment) runs a subset
    beside "as is"."""
    import dataclasses
    from types import SimpleNamespace
    from unittest import mock

    from autobal.ocp import solve

    screen = solve.coarse_solver

    def regularised_screen(ocp, method, ref, options):  # the coarse stage with the regulariser (before)
        if not isinstance(method, solve.DirectCollocation) or ocp.free_time:
            return None
        n = solve.coarse_intervals(method.intervals)
        return None if n == method.intervals else solve.Solver(ocp, dataclasses.replace(method, intervals=n), ref,
                                                               solve.coarse_options(options), brake_tol=0.0)

    def lean(ocp, n, multistart=True):
        out = [s for s in full(ocp, n, multistart) if "2 back-offs" not in s[0] and not s[0].startswith("global")
               and "ramp" not in s[0] or s[0].startswith("ramp, hold")]
        return out

    def nogrid(ocp, n, multistart=True):  # the back-off searches' starts and the hold, without the grid's two
        return [s for s in full(ocp, n, multistart) if not s[0].startswith("global")]

    def loose(options):  # the coarse screening to IPOPT tolerance 1e-4 (1e-8 as is)
        return coarse(options) | {"tol": 1e-4, "constr_viol_tol": 1e-6, "compl_inf_tol": 1e-6}

    def serial(fn, n, helper_fn=None):  # the global search and the screening in this process alone
        return [fn(i) for i in range(n)]

    full, coarse = solve.starts, solve.coarse_options
    variants = {"as is": {}, "one refinement (before)": {"REFINED": 1},
                "regulariser in the screening": {"coarse_solver": regularised_screen},
                "lean starts": {"starts": lean}, "no three-phase grid": {"starts": nogrid},
                "coarse tolerance 1e-4": {"coarse_options": loose},
                "coarse ranking by the exponential integrator alone": {"RANK_TIE": 0.0},
                "all in one process": {"forked": SimpleNamespace(shared=serial)},
                "coarse screening on two threads": {"screen": threaded_screen}}
    keep = [v for v in os.environ.get("LEVERS", "").split(",") if v]  # a subset of the variants, by name
    variants = {k: v for k, v in variants.items() if not keep or k in keep or k == "as is"}
    cases = []
    for i, name in enumerate(names):
        ocp, sc = load_problem(name, PROBLEMS[name][1])
        method = spinup_method(sc)
        if i == 0:  # untimed: the first study in a process pays the solvers' loading (2 s on zeta05)
            solve.optimize(ocp, method)
        for label, patch in variants.items():
            with mock.patch.multiple(solve, **patch) if patch else mock.patch.object(solve, "coarse_solver", screen):
                t0 = time.perf_counter()
                opt = solve.optimize(ocp, method)
                dt = time.perf_counter() - t0
            ref = json.loads(DATA.read_text())["problems"][name]["reference_peak_over_e"]
            cases.append(case(f"{name}: {label}", dt, opt.build_time_s, None, None, 100 * (opt.score / ref - 1),
                              variant=label, problem=name, peak_over_e=opt.score,
                              starts=sum(1 for r in opt.starts if "coarse" in str(r.get("stage"))),
                              load_average=os.getloadavg()[0]))
            print(cases[-1], flush=True)
    write("spinup_family_levers", "Spin-up study levers on problems of the issue-35 family (optimize, in one process)",
          cases, notes=["autobal (s): the wall time of autobal.ocp.solve.optimize (starts, NLP builds and solves, "
                        "re-simulations) with each variant, back to back; autobal error: its peak against the "
                        "reference, % (negative: below)"])


def spinup_method(sc):
    from autobal.ocp.spinup_study import method_of

    return method_of(sc.analyses.spinup)


def threaded_screen(ocp, solver, profiles, twin):
    """The coarse screening on two threads of this process, each with its own NLP (the round before the forked
    process: IPOPT's MUMPS calls take a lock the threads share)."""
    import threading

    from autobal.ocp import solve

    nc, todo, lock = solver.nlp.mesh.n, iter(range(len(profiles))), threading.Lock()
    out = [None] * len(profiles)

    def lane(s):
        while True:
            with lock:
                i = next(todo, None)
            if i is None:
                return
            out[i] = s.solve(solve.on_coarse(profiles[i], nc), raise_on_failure=False, hold_states=ocp.hold_states)

    other = threading.Thread(target=lane, args=(twin(),))
    other.start()
    lane(solver)
    other.join()
    return out


def screening(names: list[str], rounds: int = 6) -> None:
    """The coarse screening of each problem's starts (the study's own starts and coarse NLP) one after another in this
    process, on two threads of it, shared with a forked process (as the study does), and that with CasADi's OpenBLAS
    on two threads (as before it was set to one), in turn ``rounds`` times: the median wall time of each, and its
    speed-up over the first (ratio)."""
    cases = [c for name in names for c in screening_of(name, rounds)]
    write("spinup_screening", "The spin-up study's coarse screening: one process, two threads, two processes",
          cases, notes=[f"autobal (s): the median wall time of the screening over {rounds} rounds, the variants in "
                        "turn; ratio: the one-process time over it; same_solutions: every variant's coarse optima "
                        "equal the one-process ones bit for bit"])


def screening_of(name: str, rounds: int) -> list[dict]:
    """:func:`screening`'s rows of one problem."""
    import ctypes

    import autobal
    from autobal.analysis.numerics import ipopt
    from autobal.ocp import solve

    ocp, sc = load_problem(name, PROBLEMS[name][1])
    method = spinup_method(sc)
    ref = ocp.reference_level()
    profiles = [u for _, u in solve.starts(ocp, method.intervals)]
    coarse = solve.coarse_solver(ocp, method, ref, None)

    def twin():
        return solve.coarse_solver(ocp, method, ref, None)

    def serial():
        with autobal.using_solver_defaults("parallel", processes=1):
            return solve.screen(ocp, coarse, profiles, twin)

    def blas_two():  # CasADi's OpenBLAS on two threads, as before it was set to one (analysis/numerics/ipopt.py)
        blas = ctypes.CDLL(ipopt.OPENBLAS, mode=os.RTLD_NOLOAD | os.RTLD_LAZY)
        blas.openblas_set_num_threads(2)
        try:
            return solve.screen(ocp, coarse, profiles, twin)
        finally:
            blas.openblas_set_num_threads(1)

    one = "one after another in one process"
    variants = {one: serial, "two threads of one process": lambda: threaded_screen(ocp, coarse, profiles, twin),
                "two processes (the study)": lambda: solve.screen(ocp, coarse, profiles, twin),
                "two processes, CasADi's OpenBLAS on two threads": blas_two}
    times, first = {k: [] for k in variants}, {}
    for _ in range(rounds):
        for label, run in variants.items():
            t0 = time.perf_counter()
            out = run()
            times[label].append(time.perf_counter() - t0)
            first.setdefault(label, [r.w for r in out])
    same = all(np.array_equal(a, b) for k in first for a, b in zip(first[k], first[one], strict=True))
    base = float(np.median(times[one]))
    cases = [case(f"{name}: {label}", float(np.median(t)), None, one, base, problem=name, variant=label,
                  starts=len(profiles), rounds=[round(x, 3) for x in t], same_solutions=same,
                  load_average=os.getloadavg()[0]) for label, t in times.items()]
    for c in cases:
        print(c, flush=True)
    return cases


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    names = [a for a in argv if not a.startswith("-")] or list(PROBLEMS)
    if "--levers" in argv:
        return levers(names)
    if "--screening" in argv:
        return screening(names)
    data = json.loads(DATA.read_text()) if DATA.exists() else {"problems": {}}
    if "--study" not in argv:  # the references (--refs: only they)
        for name in names:
            what, scene = PROBLEMS[name]
            ref = reference(name, scene)
            data["problems"][name] = {"covers": what, "scene": scene, **ref}
            print(name, ref["reference_peak_over_e"], ref["family"], flush=True)
            data["how"] = ("scipy differential_evolution (seed 1) over four profile families, the best polished "
                           "by Nelder-Mead, on the exponential integrator at step 0.5 in Omega0 t; the best judged by "
                           "scipy solve_ivp DOP853 rtol 1e-10 atol 1e-12 on the model's ode_fixed "
                           "(python -m benchmarks.spinup_family --refs)")
            DATA.write_text(json.dumps(data, indent=1) + "\n")
    if "--refs" in argv:
        return
    option = {a.split("=", 1)[0]: a.split("=", 1)[1] for a in argv if a.startswith("--") and "=" in a}
    base = option.get("--base")  # the python of the code to compare with, "before"
    label = option.get("--base-label", "the study before issue 35")
    repeat = int(option.get("--repeat", 1))  # each study this many times, before and after in turn: the median
    cases = []
    for name in names:
        ref = data["problems"][name]["reference_peak_over_e"]
        tries = {"before": [], "after": []}
        for _ in range(repeat):
            for key, python in (("before", base), ("after", sys.executable)):
                if python:
                    tries[key].append(study(name, PROBLEMS[name][1], python))
        runs = {k: sorted(v, key=lambda r: r["study_s"])[len(v) // 2] for k, v in tries.items() if v}
        gap = {k: None if r["study_peak_over_e"] is None else 100 * (r["study_peak_over_e"] / ref - 1)
               for k, r in runs.items()}
        b = runs.get("before", {})
        cases.append(case(name, runs["after"]["study_s"], None, label if b else None,
                          b.get("study_s"), gap["after"], gap.get("before"), reference_peak_over_e=ref,
                          peak_over_e=runs["after"]["study_peak_over_e"], before_peak_over_e=b.get("study_peak_over_e"),
                          failure=runs["after"].get("failure"), before_failure=b.get("failure"),
                          parts=runs["after"].get("parts"), before_parts=b.get("parts"),
                          load_average=os.getloadavg()[0]))
        print(cases[-1], flush=True)
    old = Path(__file__).parent / "results" / "spinup_family.json"  # the rows of problems not re-run are kept
    kept = {c["case"]: c for c in json.loads(old.read_text())["cases"]} if old.exists() else {}
    for c in cases:  # without --base the rows keep their measured "before"
        prev = kept.get(c["case"], {})
        keep = {k: prev.get(k) for k in ("peer", "peer_s", "peer_error", "before_peak_over_e", "before_failure",
                                         "before_parts")
                if c.get(k) is None and prev.get(k) is not None}
        kept[c["case"]] = c | keep | ({"ratio": keep["peer_s"] / c["autobal_s"]} if "peer_s" in keep else {})
    cases = [kept[n] for n in PROBLEMS if n in kept]
    med = {k: float(np.median([c[k] for c in cases if c[k] is not None] or [np.nan])) for k in ("autobal_s", "peer_s")}
    write("spinup_family", "Spin-up study on the issue-35 family: peak against the independent reference, wall time",
          cases, notes=["autobal (s): the study's wall time in a new process (start-up included), this branch; peer "
                        f"(s): {label} (its python given by --base=); each the median of {repeat} (before and after in "
                        "turn); errors: the study's peak against the reference, % (negative: below it)",
                        f"median wall time: {med['autobal_s']:.2f} s after, {med['peer_s']:.2f} s before"])
    doc = json.loads(old.read_text())  # the medians beside the cases, for the docs' placeholders
    old.write_text(json.dumps(doc | {"median_after_s": med["autobal_s"], "median_before_s": med["peer_s"]}
                              | to_goal(cases), indent=1, allow_nan=False) + "\n")


GOAL_S = 1.5  # issue 35: the study's median wall time over the family, process start-up included


def to_goal(cases: list[dict]) -> dict:
    """How far the family's median is from GOAL_S: each part's median over the problems (s), the median fixed part
    (the interpreter's start and exit, the imports, the scene's loading: what any study process pays), and how many
    times faster the median problem's study itself (its wall time less the fixed part) would have to be."""
    split = [c["parts"] for c in cases if c.get("parts")]
    if not split:
        return {}
    fixed = float(np.median([p["start_exit_s"] + p["imports_s"] + p["loading_s"] for p in split]))
    study = float(np.median([c["autobal_s"] for c in cases if c.get("parts")])) - fixed
    return {"median_parts": {k: float(np.median([p[k] for p in split])) for k in split[0]}, "median_fixed_s": fixed,
            "median_study_s": study, "goal_s": GOAL_S, "study_speedup_needed": study / (GOAL_S - fixed)}


if __name__ == "__main__":
    main()
