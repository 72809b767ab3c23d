"""Optimal chamber height and liquid volume of a liquid auto-balancer as IPOPT problems
(Khomyak (2020), App. В OPTIMUM_KAMERA and App. Г OPTIMUM_LIQUID), each checked against a dense grid,
and the liquid volume of the exact wall crescent (toolkit extension).  SI units throughout.
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np

from autobal.analysis.numerics import ipopt
from autobal.errors import SolveError
from autobal.models import liquid_balancer as lb
from autobal.models.liquid_balancer import System

# ---- the optimisation problems (App. В / App. Г as IPOPT problems) ---------------------------

def k_bounds(sin2d: float, variant: str) -> tuple[float, float]:
    """Range of k_D where (2.13) of ``variant`` has an equilibrium: k >= sin delta, and the arccos
    argument <= 1 (printed: k <= 1; program: k^2 <= s + (1 - s)(1 + s)^2; corrected: unbounded)."""
    s = sin2d
    lo = 0.0 if (s >= 1 and variant != "corrected") else math.sqrt(s)
    if variant == "printed":
        hi = 1.0 if s < 1 else math.inf
    elif variant == "program":
        hi = math.sqrt(s + (1 - s) * (1 + s) ** 2) if s < 1 else math.inf
    else:
        hi = math.inf
    return lo, hi


@functools.cache
def _solver(kind: str, variant: str):
    """IPOPT: min (e_c/e0)^2 = 1/lambda0^2 over x = h/R ("height") or x = V/(pi R^2 h) ("volume")."""
    x = ca.SX.sym("x")
    p = {k: ca.SX.sym(k) for k in lb.INPUTS}
    sym = dict(p)
    if kind == "height":
        sym["h"] = x * p["R"]
    else:
        sym["V"] = x * ca.pi * p["R"] ** 2 * p["h"]
    out = lb.quasi_static(sym, variant)
    J = lb.inverse_lambda0_squared(out["k_D"], out["sin2d"], variant)
    return ipopt.nlpsol(f"liquid_{kind}_{variant}", x, ca.vertcat(*[p[k] for k in lb.INPUTS]), J, ca.SX(0, 1))


def optimise(system: System, kind: str, variant: str, deflection: str, lower: float, upper: float,
             grid_points: int, **override) -> dict:
    """Maximise lambda0 over the chamber height (``kind="height"``) or the liquid volume (``"volume"``).

    The bounds combine the geometry (V < pi R^2 h; the given design limits ``lower``/``upper``) with the
    existence of an equilibrium (:func:`k_bounds` turned into the variable through the monotone k_D(h) or
    k_D(V); D = rho f (pi h R^2 - V)).  IPOPT minimises 1/lambda0^2, smooth and zero at complete
    balancing (k_D = 1, where the corrected and printed branches are singular); a dense grid of
    ``grid_points`` over the same bounds, evaluating lambda0 itself, cross-checks it (App. В/Г loops).
    """
    p = system.inputs(deflection, **override)
    R = p["R"]
    j = {k: float(v) for k, v in lb.jeffcott(p["omega"], p["omega_cr"], p["n"]).items()}
    f = j["G"] * p["e_f"]
    k_lo, k_hi = k_bounds(j["sin2d"], variant)
    rf = p["rho"] * f
    with np.errstate(divide="ignore"):
        if kind == "height":
            geo_lo = p["V"] / (math.pi * R**2) * (1 + 1e-9)
            # k = D0 / (rho f (pi R^2 h - V)) falls with h
            lo = max(lower, geo_lo, (p["D0"] / (rf * k_hi) + p["V"]) / (math.pi * R**2) if k_hi < math.inf else 0)
            hi = min(upper, (p["D0"] / (rf * k_lo) + p["V"]) / (math.pi * R**2) if k_lo > 0 else math.inf)
            scale, name = R, "h"
        else:
            vol = math.pi * R**2 * p["h"]
            lo = max(lower, vol - p["D0"] / (rf * k_lo) if k_lo > 0 else 0.0)
            hi = min(upper, vol * (1 - 1e-9), vol - p["D0"] / (rf * k_hi) if k_hi < math.inf else math.inf)
            scale, name = vol, "V"
    res = {"variable": name, "variant": variant, "deflection": deflection, "lower_bound": lower,
           "upper_bound": upper, "feasible_lower": lo, "feasible_upper": hi, "f": f}
    if not (f > 0 and lo < hi):
        return res | {"optimum": math.nan, "lambda0_max": math.nan, "k_D": math.nan, "reason":
                      f"no equilibrium for any {name} in [{lower:.6g}, {upper:.6g}] (k_D range "
                      f"[{k_lo:.4g}, {k_hi:.4g}] of the {variant} (2.13) not reachable)",
                      "grid": {"x": [], "lambda0": []}}
    solver = _solver(kind, variant)
    pv = [p[k] for k in lb.INPUTS]
    x0 = 0.5 * (lo + hi) / scale
    sol = ipopt.solve(solver, x0=x0, lbx=lo / scale, ubx=hi / scale, p=pv, lbg=[], ubg=[])
    if not sol["success"]:
        raise SolveError(f"liquid balancer: optimal {name} not found", sol["status"],
                         {name: float(sol["x"][0] * scale), "objective": float(sol["f"][0])})
    x_opt = float(sol["x"][0]) * scale
    at = lb.evaluate(variant, **(p | {name: x_opt}))
    grid = np.linspace(lo, hi, grid_points)
    g = lb.evaluate(variant, **(p | {name: grid}))
    lam = np.where(np.isfinite(g["lambda0"]), g["lambda0"], -np.inf)
    i = int(np.argmax(lam))
    step = grid[1] - grid[0]
    k_opt = float(at["k_D"])
    singular = variant in ("corrected", "printed") and abs(k_opt - 1) < 1e-6
    # analytic optimum of the singular branches: k_D = 1
    star = ((p["D0"] / rf + p["V"]) / (math.pi * R**2) if kind == "height"
            else math.pi * R**2 * p["h"] - p["D0"] / rf)
    return res | {
        "optimum": x_opt, "optimum_over_R": x_opt / R if kind == "height" else None,
        "lambda0_max": float(at["lambda0"]), "inverse_lambda0_squared": float(sol["f"][0]),
        "k_D": k_opt, "alpha0_deg": math.degrees(float(at["alpha0"])), "singular": singular,
        "k_D_equals_1_at": star, "solver": {"status": sol["status"], "iterations": sol["iterations"]},
        "grid_optimum": float(grid[i]), "grid_lambda0": float(g["lambda0"][i]), "grid_step": float(step),
        "grid_difference": abs(float(grid[i]) - x_opt), "agree": bool(abs(float(grid[i]) - x_opt) <= step),
        "reason": "complete balancing (k_D = 1): lambda0 unbounded, value depends on the grid" if singular else "",
        "grid": {"x": grid[:: max(1, grid_points // 400)], "lambda0": g["lambda0"][:: max(1, grid_points // 400)]},
    }


def crescent_volume(R: float, h: float, f: float, D0: float, rho: float) -> dict:
    """V at which the liquid crescent's unbalance rho V x_p equals D0 (k_D = 1) [toolkit extension]."""
    from scipy.optimize import brentq

    vol = math.pi * R**2 * h

    def excess(V):
        return rho * lb.crescent(R, h, V, f)["D_over_rho"] - D0

    vs = np.linspace(vol * 1e-4, vol * (1 - 1e-6), 400)
    ex = np.array([excess(v) for v in vs])
    cross = np.nonzero((ex[:-1] < 0) & (ex[1:] >= 0))[0]
    if not len(cross):
        return {"V": math.nan, "x_p": math.nan, "sufficient": False}
    V = brentq(excess, vs[cross[0]], vs[cross[0] + 1], xtol=1e-14)
    c = lb.crescent(R, h, V, f)
    return {"V": V, "x_p": c["x_p"], "sufficient": c["sufficient"]}
