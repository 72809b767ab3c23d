"""Solver options in one place: every solver's documented defaults, readable and settable for a session.

As python-control's ``config.defaults``: :data:`defaults` is one flat mapping ``"group.option" -> value``
(the options a solver is built with now), :data:`DEFAULTS` the documented values it starts from,
:func:`set_defaults` changes some of a group for the session, :func:`reset_defaults` brings back the documented
ones and :func:`using` changes them within a ``with`` block.  A group is the options of one use of a solver; an
IPOPT group is laid over ``ipopt`` (every IPOPT solve's base), its own options winning::

    autobal.set_solver_defaults("ipopt", max_iter=500)        # every IPOPT solve's base iteration limit
    with autobal.using_solver_defaults("transient", rtol=1e-10, atol=1e-12):
        run = autobal.run(scene)
    autobal.solver_defaults("ipopt")                          # {"tol": 1e-12, ..., "max_iter": 500}
    autobal.reset_solver_defaults()

The front door's names are this module's :func:`get` (``autobal.solver_defaults``), :func:`set_defaults`,
:func:`reset_defaults` and :func:`using` (``autobal.set_solver_defaults``, ...).

An option is read when its solver is built or run (a solver built before a change keeps its options).  A scene's
own setting (``analyses.spinup.max_iterations`` and ``tolerance``, a fit's ``max_iterations``) and a caller's
argument (``Simulator(rtol=...)``) win over the session's default; those settings default to :data:`DEFAULTS`.
Where IPOPT writes (``print_level`` 0, its log into a file of its own: :mod:`autobal.analysis.numerics.ipopt`) is no
option here.  The models' own numerics (models/, a layer below this module: the Newton equilibrium of a dynamic model,
the ROSS rotor's fixed-frame re-simulation tolerance ``RESIM_TOL``) are constants of their modules, which every
caller may override by argument.  Options are of this process: the workers of a dask cluster
(:mod:`autobal.analysis.run.executor`) use the documented ones.
"""

from __future__ import annotations

import contextlib
from types import MappingProxyType

# group -> (what it is for, {option: (documented default, why)}); the reasons are the measurements quoted
GROUPS = {
    "ipopt": ("every IPOPT solve (the statics as they are; the groups below are laid over it)", {
        # the statics are small, well-scaled (dimensionless) and solved to machine-level residuals
        "tol": (1e-12, "convergence tolerance"),
        "constr_viol_tol": (1e-12, "constraint violation accepted"),
        "compl_inf_tol": (1e-12, "complementarity accepted"),
        "acceptable_iter": (0, "no 'acceptable' exit"),
        "bound_relax_factor": (0.0, "bounds kept exact (u >= 0, xi <= xi_max)"),
        "max_iter": (300, "iteration limit"),
    }),
    "ipopt_warm": ("IPOPT warm start along a statics continuation path: from the previous solution and its "
                   "multipliers, close to the bounds", {
        "warm_start_init_point": ("yes", "start from the given point and multipliers"),
        "warm_start_bound_push": (1e-10, "how far the start is pushed off its bounds"),
        "warm_start_mult_bound_push": (1e-10, "how far the multipliers are pushed off zero"),
        "mu_init": (1e-8, "initial barrier parameter"),
    }),
    "continuation": ("statics continuation (the sweep's path and the fallback of a failed cold start)", {
        "start": (0.25, "discharge ratio psi1 a failed cold start's homotopy starts from, -"),
        "steps": (16, "points of that homotopy"),
        "path_nodes": (257, "nodes of a sweep's continuation path across its range"),
        "max_halvings": (6, "halvings of a failed continuation step before the sweep gives up"),
    }),
    "newton": ("CasADi's Newton rootfinder of the statics (the sweep's fast path, Monte Carlo, the explorer)", {
        "abstol": (1e-14, "stops when every balance's |residual| is below this"),
        "max_iter": (50, "iteration limit"),
        "linear_solver": ("qr", "dense QR: 1.8x csparse on these 6-8 unknowns"),
    }),
    # mu_strategy adaptive: the dynamic data the objective does not see (volumes, damping, spring) make the
    # optimum a manifold and the reduced Hessian singular; IPOPT's monotone barrier decrease then stalls near
    # mu ~ 1e-6 and falls into restoration (the pump with the outer-seal clearance or the supply-throttle
    # diameter as variables, 500 iterations); the adaptive rule converges in tens of iterations
    "design": ("IPOPT of the design optimisation: the adaptive barrier (the monotone one stalls near mu ~ 1e-6 "
               "where the optimum is a manifold)", {
        "mu_strategy": ("adaptive", "barrier update"),
        "tol": (1e-8, "convergence tolerance"),
        "constr_viol_tol": (1e-10, "constraint violation accepted"),
        "compl_inf_tol": (1e-8, "complementarity accepted"),
        "acceptable_tol": (1e-6, "'acceptable' tolerance"),
        "acceptable_iter": (5, "iterations at it before an 'acceptable' exit"),
        "max_iter": (500, "iteration limit"),
    }),
    "design_fallback": ("laid over `design` when the adaptive barrier fails (the pump designed for the chain "
                        "model, its stability constraints active)", {
        "mu_strategy": ("monotone", "barrier update"),
        "max_iter": (1000, "iteration limit"),
    }),
    "fit": ("IPOPT of the least-squares fits (estimation, Gauss-Newton)", {
        "max_iter": (300, "iteration limit (a scene's fit.max_iterations wins)"),
    }),
    "gauss_newton": ("the batched projected Gauss-Newton of many small fits (the work-precision study's disc fits)", {
        "block": (8, "Gauss-Newton steps unrolled into one Function"),
        "tol": (1e-10, "a problem has converged when its last step is below this (scaled variables)"),
        "max_blocks": (8, "blocks at most before the unconverged problems are left to IPOPT"),
    }),
    "spinup": ("IPOPT of the spin-up OCPs (collocation, shooting, robust, time-optimal)", {
        "tol": (1e-8, "convergence tolerance (a scene's tolerance wins)"),
        "constr_viol_tol": (1e-8, "constraint violation accepted"),
        "compl_inf_tol": (1e-8, "complementarity accepted"),
        "acceptable_iter": (0, "no 'acceptable' exit"),
        "max_iter": (1000, "iteration limit (a scene's max_iterations wins)"),
        "mu_strategy": ("adaptive", "barrier update"),
        "bound_relax_factor": (1e-10, "bounds relaxed by this"),
        # mumps_permuting_scaling 0: no maximum-weight matching and scaling of the KKT matrix in MUMPS (its
        # ICNTL(6); IPOPT's default 7 lets MUMPS choose).  With it, from 800 collocation intervals on, MUMPS'
        # factorisation of the spin-up KKT system delays so many pivots that it runs out of its estimated workspace
        # (INFO(1) = -9) and one IPOPT iteration takes minutes; without it one takes about a second and N = 800
        # solves in 71 iterations (benchmarks/spinup_ocp.md, "MUMPS levers at N = 800").
        "mumps_permuting_scaling": (0, "no maximum-weight matching in MUMPS"),
        # mumps_pivot_order 6: MUMPS' approximate minimum degree with quasi-dense row detection (QAMD) instead of
        # the automatic choice (METIS here): per IPOPT iteration 5-28 % less CPU at 200-1600 intervals, the same
        # optima (measured before the Radau node states were eliminated; benchmarks/spinup_ocp.md, "Levers").
        "mumps_pivot_order": (6, "MUMPS' QAMD ordering"),
    }),
    # the fine stages of the mesh continuation start from the coarser optimum and its multipliers: the
    # iterate and multipliers are pushed only slightly off their bounds, and the barrier parameter is monotone
    # from 1e-6.  The interpolated start is not feasible on the finer mesh (the coarse collocation polynomials
    # miss the finer collocation equations by up to 0.8 in the states of the liquid balancer, 0.4 of the
    # Jeffcott rotor); from there the adaptive barrier update (which ignores mu_init) drove the liquid
    # balancer's 200-interval stage into the restoration phase at its first iteration and then crept with
    # step sizes of 1e-2-1e-1: 114 + 376 iterations for the 100- and 200-interval stages, 69 + 47 monotone,
    # the same optimum (benchmarks/spinup_ocp.md, "Liquid balancer convergence")
    "spinup_warm": ("laid over `spinup` on the fine stages of the mesh continuation (from the coarser optimum and "
                    "its multipliers; benchmarks/spinup_ocp.md, 'Liquid balancer convergence')", {
        "warm_start_init_point": ("yes", "start from the given point and multipliers"),
        "mu_strategy": ("monotone", "barrier update"),
        "mu_init": (1e-6, "initial barrier parameter"),
        "warm_start_bound_push": (1e-9, "how far the start is pushed off its bounds"),
        "warm_start_slack_bound_push": (1e-9, "how far the slacks are pushed off their bounds"),
        "warm_start_mult_bound_push": (1e-9, "how far the multipliers are pushed off zero"),
    }),
    # a screening, not the answer (benchmarks/spinup_ocp.md, "Study time" and "Liquid balancer convergence")
    "spinup_coarse": ("the coarse stage of the spin-up mesh continuation: a screening of the starts", {
        "max_iter": (200, "iteration limit of a start (the best basins converge in 13-111)"),
    }),
    # IPOPT's MUMPS calls take a lock the threads of a process share: on the coarse screening two threads gained
    # 1.03-1.11x, two processes 1.50-1.84x (analysis/run/forked.py; docs/benchmarks.md, "Spin-up study on a family of
    # problems")
    "parallel": ("work the spin-up study shares with a process forked from this one (Linux): the global search's "
                 "back-off searches, the coarse screening, the ramp baselines", {
        "processes": (2, "processes at once, this one included (at most the cores this process may use; 1: all in "
                         "this process); the results are the same bit for bit"),
    }),
    "fatrop": ("fatrop on the spin-up's stage form (tol and max_iter from `spinup`)", {
        # fatrop on the stage form (transcribe_stages): from the benchmark's guess at 200-800 intervals mu_init
        # 1e-5 takes 28-32 iterations; fatrop's default (1e-2) 145-553, 1e-4 81-153 and 1e-6 34-60
        # (benchmarks/spinup_ocp.md, "fatrop")
        "mu_init": (1e-5, "initial barrier parameter"),
    }),
    "resimulation": ("CVODES (Adams) re-simulation of every spin-up optimum, the peak it reports", {
        # the peak of the 5 s deadline optimum moves by 7e-10 relative from 1e-12, in half the time
        # (benchmarks/spinup_ocp.md, "Study time")
        "tol": (1e-10, "relative and absolute tolerance, -"),
        "points": (24, "samples per control interval"),
    }),
    "rotor": ("CVODES of the Jeffcott rotor's studies (the passage of the critical speed, Lewis' run-up, the motor "
              "run-up: analysis/numerics/rotor.py)", {
        "tol": (1e-10, "relative and absolute tolerance (states are O(1)-O(100)), -"),
        "max_num_steps": (200000, "step attempts between two outputs"),
    }),
    "liquid_balancer_check": ("CVODES of the time-domain Jeffcott rotor that checks the liquid balancer's closed-form "
                              "phase and deflection (analysis/studies/liquid_balancer.py)", {
        "tol": (1e-11, "relative and absolute tolerance, -"),
        "max_num_steps": (200000, "step attempts between two outputs"),
    }),
    "transient": ("the transient study's integrator (CVODES, IDAS; RODAS4 reads rtol, atol, max_num_steps)", {
        "rtol": (1e-9, "relative tolerance, -"),
        "atol": (1e-11, "absolute tolerance (scaled states), -"),
        "max_num_steps": (20000, "step attempts between two outputs"),
    }),
}

DEFAULTS = MappingProxyType({f"{g}.{k}": v[0] for g, (_, opts) in GROUPS.items() for k, v in opts.items()})
defaults: dict = dict(DEFAULTS)  # the options in force in this session


def get(group: str | None = None) -> dict:
    """The options of ``group`` in force now, option -> value (an IPOPT group without the ``ipopt`` base); with
    no group, every option, ``"group.option"`` -> value (a copy: change them with :func:`set_defaults`)."""
    if group is None:
        return dict(defaults)
    if group not in GROUPS:
        raise ValueError(f"unknown solver option group {group!r}; known: {', '.join(GROUPS)}")
    return {k: defaults[f"{group}.{k}"] for k in GROUPS[group][1]}


def set_defaults(group: str, **options) -> None:
    """Set options of ``group`` for the session, e.g. ``set_defaults("ipopt", max_iter=500)``; an unknown group
    or option, a value of another type than the documented default or a negative number is a one-line
    ``ValueError`` (and nothing is set)."""
    get(group)
    for name, value in options.items():
        key = f"{group}.{name}"
        if key not in DEFAULTS:
            raise ValueError(f"unknown solver option {key!r}; {group} has {', '.join(GROUPS[group][1])}")
        want = type(DEFAULTS[key])
        ok = isinstance(value, want) or (want is float and isinstance(value, int))
        if not ok or isinstance(value, bool) != (want is bool):
            raise ValueError(f"solver option {key!r} takes a value of type {want.__name__}, got {value!r}")
        if want in (int, float) and not value >= 0:
            raise ValueError(f"solver option {key!r} must be >= 0, got {value!r}")
    defaults.update({f"{group}.{k}": v for k, v in options.items()})


def reset_defaults() -> None:
    """Bring back every documented default (:data:`DEFAULTS`)."""
    defaults.clear()
    defaults.update(DEFAULTS)


@contextlib.contextmanager
def using(group: str, **options):
    """Within the block, ``group`` has ``options`` (:func:`set_defaults`); after it, what it had before."""
    before = dict(defaults)
    set_defaults(group, **options)
    try:
        yield
    finally:
        defaults.clear()
        defaults.update(before)


def ipopt_options(max_iterations: int | None = None, tolerance: float | None = None) -> dict:
    """A scene's ``max_iterations`` and ``tolerance`` as IPOPT options (tol, constraint violation and
    complementarity at the same tolerance), laid over a group's; None: the group's."""
    its = {} if max_iterations is None else {"max_iter": int(max_iterations)}
    return its | ({} if tolerance is None else {"tol": tolerance, "constr_viol_tol": tolerance,
                                                 "compl_inf_tol": tolerance})


def rootfinder() -> dict:
    """CasADi's Newton rootfinder options: the ``newton`` group, a failure returned (not raised), no warnings."""
    return get("newton") | {"error_on_fail": False, "show_eval_warnings": False}


def markdown_table() -> str:
    """The documented defaults as a Markdown table (docs/api.md holds it; a test checks it is this)."""
    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    rows = ["| option | default | what |", "|---|---|---|"]
    for g, (what, opts) in GROUPS.items():
        rows.append(f"| **`{g}`** | | {cell(what)} |")
        rows += [f"| `{g}.{k}` | `{v!r}` | {cell(why)} |" for k, (v, why) in opts.items()]
    return "\n".join(rows)
