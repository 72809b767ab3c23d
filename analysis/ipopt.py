"""IPOPT options in one place, and a solve call that reports status and keeps the last iterate."""

from __future__ import annotations

import casadi as ca
import numpy as np

from autobal.analysis import interrupt, progress

# Tight tolerances: the statics are small, well-scaled (dimensionless) and solved to
# machine-level residuals; bound_relax_factor = 0 keeps bounds (u >= 0, xi <= xi_max) exact.
COLD = {
    "ipopt.tol": 1e-12,
    "ipopt.constr_viol_tol": 1e-12,
    "ipopt.compl_inf_tol": 1e-12,
    "ipopt.acceptable_iter": 0,
    "ipopt.bound_relax_factor": 0.0,
    "ipopt.max_iter": 300,
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
}
# Continuation: start from the previous solution and its multipliers, close to the bounds.
WARM = COLD | {
    "ipopt.warm_start_init_point": "yes",
    "ipopt.warm_start_bound_push": 1e-10,
    "ipopt.warm_start_mult_bound_push": 1e-10,
    "ipopt.mu_init": 1e-8,
}


def nlpsol(name: str, x, p, f, g, warm: bool = False, hess_lag: ca.Function | None = None,
           **extra) -> ca.Function:
    """An IPOPT solver for min f(x; p) s.t. g(x; p) in [lbg, ubg], x in [lbx, ubx].

    ``hess_lag``: a user Hessian of the Lagrangian, (x, p, lam_f, lam_g) -> its upper triangle,
    e.g. the Gauss-Newton lam_f J'J of a least-squares fit (analysis/least_squares.py).
    """
    opts = (WARM if warm else COLD) | {f"ipopt.{k}": v for k, v in extra.items()}
    if hess_lag is not None:
        opts["hess_lag"] = hess_lag
    return ca.nlpsol(name, "ipopt", {"x": x, "p": p, "f": f, "g": g}, opts)


def solve(solver: ca.Function, **args) -> dict:
    """Call ``solver``; return its outputs as numpy arrays plus status, success, iterations.

    An interrupt (SIGINT, SIGTERM) during the solve raises :class:`autobal.analysis.interrupt.Interrupted`
    instead of coming back as a solver status.
    """
    out = interrupt.call(solver, **args)
    stats = solver.stats()
    res = {k: np.asarray(v).ravel() for k, v in out.items()}
    res["status"] = stats["return_status"]
    res["success"] = bool(stats["success"])
    res["iterations"] = int(stats.get("iter_count", -1))
    progress.tick(note=f"last: {res['iterations']} iterations, {res['status']}")  # a bar counting solves
    return res
