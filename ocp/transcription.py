"""Transcriptions of the declared spin-up problem into an NLP (rockit's ``method`` role).

* :class:`DirectCollocation` (Legendre or Radau points, degree and number of intervals; CasADi SX);
* :class:`MultipleShooting` (CVODES over each interval, the path constraints at the same interior
  instants as the collocation points, so both methods solve the same discrete problem).

The variables are ordered stage by stage (state, collocation states, control), the form a
structure-exploiting solver needs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from autobal.ocp.protocol import SpinupProblem

if TYPE_CHECKING:
    from autobal.ocp.problem import PathConstraint

TV_SMOOTHING = 1e-2  # |Delta u| below which the total-variation penalty is quadratic


@dataclass(frozen=True)
class DirectCollocation:
    """Direct collocation on ``intervals`` equal intervals, ``degree`` Legendre or Radau points each."""

    intervals: int = 200
    degree: int = 3
    scheme: str = "radau"
    # the NLP solver: "ipopt" (MUMPS) on the interval layout of :func:`transcribe`, or "fatrop" (a Riccati
    # recursion over the stages) on the stage form of :func:`transcribe_stages` (Radau only)
    solver: str = "ipopt"

    @property
    def label(self) -> str:
        via = "" if self.solver == "ipopt" else f", {self.solver}"
        return f"direct collocation ({self.scheme}, degree {self.degree}, {self.intervals} intervals{via})"


@dataclass(frozen=True)
class MultipleShooting:
    """Multiple shooting with CVODES; path constraints at the collocation instants of ``scheme``/``degree``."""

    intervals: int = 200
    degree: int = 3
    scheme: str = "radau"
    tol: float = 1e-10
    hessian: str = "limited-memory"  # the exact Hessian through CVODES costs ~5x more per iteration

    @property
    def label(self) -> str:
        return f"multiple shooting (CVODES, {self.intervals} intervals)"


@cache
def collocation_data(degree: int, scheme: str):
    tau = ca.collocation_points(degree, scheme)
    C, D, B = ca.collocation_coeff(tau)
    return list(tau), np.array(C), np.array(D).ravel(), np.array(B).ravel()


def path_fractions(degree: int, scheme: str) -> list[float]:
    """Instants (fractions of an interval) where path constraints are imposed: the collocation
    points, and the interval end when it is not one of them (Legendre)."""
    tau = collocation_data(degree, scheme)[0]
    return tau if abs(tau[-1] - 1) < 1e-12 else [*tau, 1.0]


@cache
def interval_integrator(rhs: ca.Function, fractions: tuple, tol: float, multistep: str = "bdf",
                        max_steps: int = 20000) -> ca.Function:
    """CVODES over one interval in s in [0, 1]: dq/ds = h f(q, a*, p) of the model's equation ``rhs``
    ((q, a*, p) -> dq/dtau, any state dimension), outputs at ``fractions``.  Parameters [a*, h, p].
    ``multistep``: "bdf" (Newton iteration) or "adams" (functional iteration, non-stiff: the re-simulation at
    tight tolerance, benchmarks/spinup_ocp.md "Study time")."""
    q, par = ca.SX.sym("q", rhs.size1_in(0)), ca.SX.sym("par", 2 + rhs.size1_in(2))
    adams = {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"}
    return ca.integrator("spinup_interval", "cvodes", {"x": q, "p": par, "ode": par[1] * rhs(q, par[0], par[2:])},
                         0, list(fractions), {"abstol": tol, "reltol": tol, "max_num_steps": max_steps}
                         | (adams if multistep == "adams" else {}))


def interval_function(ocp: SpinupProblem, d: int, scheme: str, ref: float, continuity: bool = True) -> ca.Function:
    """One collocation interval as an SX Function (x_k (nx), the collocation states (nx d), u_k, x_(k+1) (nx),
    h, v) -> (collocation residuals (nx d) and, with ``continuity``, the continuity residual (nx), one column
    per path constraint (its values at the interval start when it uses the control, then at the path points),
    h sum_j B_j delta^2 (the quadrature of the integrated objective)).  Mapped over the intervals it is the
    whole transcription."""
    tau, C, D, B = collocation_data(d, scheme)
    frac = path_fractions(d, scheme)
    f, nx = ocp.dynamics(), ocp.nx
    x0, xc, u, x1, h = ca.SX.sym("x0", nx), ca.SX.sym("xc", nx * d), ca.SX.sym("u"), ca.SX.sym("x1", nx), ca.SX.sym("h")
    v = ca.SX.sym("v", ocp.n_extra)
    Z = [x0] + [xc[nx * j:nx * j + nx] for j in range(d)]
    res, quad = [], ca.SX(0)
    for j in range(d):
        res.append(sum(C[r, j] * Z[r] for r in range(d + 1)) - f(Z[j + 1], u, h))
        if ocp.objective == "integrated_deflection":
            quad = quad + h * B[j] * ocp.deflection2()(Z[j + 1])
    if continuity:
        res.append(x1 - sum(D[r] * Z[r] for r in range(d + 1)))
    pts = Z[1:] + ([x1] if len(frac) > d else [])
    paths = [ca.vertcat(*[pc.expr(q, u * ocp.a_max, v) for q in ([x0] if pc.uses_control else []) + pts])
             for pc in ocp.path_constraints(ref)]
    return ca.Function("spinup_interval", [x0, xc, u, x1, h, v], [ca.vertcat(*res), *paths, quad])


def jerk_regulariser(ocp: SpinupProblem, du):
    """The objective's jerk terms: ``jerk_penalty`` sum (Delta u)^2 plus ``jerk_variation`` times the total
    variation sum |Delta u|, smoothed as sqrt(Delta u^2 + s^2) - s with s = TV_SMOOTHING (Huber-like: quadratic
    below s, so one-interval pulses cost and the switches stay sharp).

    Parameters
    ----------
    ocp : SpinupProblem
        The problem (its weights, dimensionless, relative to the scaled objective).
    du : SX or MX column
        Changes of u = alpha/alpha_max between consecutive control intervals of the horizon, dimensionless.

    Returns
    -------
    SX or MX
        The regulariser, in units of the scaled objective (0 when both weights are 0).
    """
    reg = 0
    if ocp.jerk_penalty:
        reg = reg + ocp.jerk_penalty * ca.sumsqr(du)
    if ocp.jerk_variation:
        reg = reg + ocp.jerk_variation * ca.sum1(ca.sqrt(du**2 + TV_SMOOTHING**2) - TV_SMOOTHING)
    return reg


@dataclass
class Mesh:
    """Interval lengths (tau): ``n`` control intervals of the horizon, then ``ns`` settling intervals of ``hs``.
    The control intervals are ``h`` each (uniform) or ``h`` times ``grading`` (a graded mesh: ``grading`` sums to
    ``n``, so the intervals still cover the horizon); the settling window stays uniform."""

    n: int
    ns: int
    h: float  # control interval length of the uniform mesh (guess, when the time is free), the graded one's mean
    hs: float
    grading: np.ndarray | None = None  # (n,) each control interval's length over h; None: uniform

    @property
    def control_lengths(self) -> np.ndarray:
        """The n control intervals' lengths, tau (the guess when the time is free)."""
        return np.full(self.n, self.h) if self.grading is None else self.h * self.grading

    @property
    def lengths(self) -> np.ndarray:
        """All n + ns interval lengths, tau."""
        return np.concatenate([self.control_lengths, np.full(self.ns, self.hs)])


def on_uniform(u: np.ndarray, h: np.ndarray, m: int) -> np.ndarray:
    """The piecewise-constant controls u on intervals of lengths h averaged onto m equal intervals of the same span
    (the speed at their edges kept exactly); u itself when the intervals are already equal and m = len(u)."""
    if m == len(u) and np.all(h == h[0]):
        return np.asarray(u)
    cum = np.concatenate([[0.0], np.cumsum(np.asarray(u) * h)])
    edges = np.linspace(0.0, np.sum(h), m + 1)
    return np.diff(np.interp(edges, np.concatenate([[0.0], np.cumsum(h)]), cum)) / np.diff(edges)


def mesh(ocp: SpinupProblem, n: int, grading: np.ndarray | None = None) -> Mesh:
    """The mesh of n control intervals (uniform, or graded by ``grading``, n lengths over tau_h / n summing to n)
    and the settling window's intervals at about the uniform control step."""
    h = ocp.tau_h / n
    ns = int(math.ceil(ocp.tau_s / h - 1e-9)) if ocp.tau_s > 0 else 0
    if grading is not None:
        if ocp.free_time:
            raise ValueError("a graded mesh needs a fixed deadline (the free-time transcription is uniform)")
        grading = np.asarray(grading, float)
        if grading.shape != (n,) or np.any(grading <= 0) or abs(grading.sum() - n) > 1e-9 * n:
            raise ValueError(f"a graded mesh needs {n} positive interval lengths over tau_h/n summing to {n}")
    return Mesh(n, ns, h, ocp.tau_s / ns if ns else 0.0, grading)


@dataclass
class Nlp:
    """A transcribed problem: IPOPT data, the named constraint blocks and how to read a solution."""

    x: ca.SX | ca.MX
    f: ca.SX | ca.MX
    g: ca.SX | ca.MX
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    blocks: list  # (name, rows of g as an index array)
    index: dict  # "X" (n+ns+1, nx), "Xc" (n+ns, d, nx) or None, "u" (n+ns,), "v" list of indices
    mesh: Mesh
    fractions: list
    method: object
    ref: float
    # collocation: the interval Function, its mapped arguments and where each interval's inputs and rows sit
    # in x and g (see :func:`structured_derivatives`); None for multiple shooting
    intervals: dict | None = None
    # the stage form (:func:`transcribe_stages`): fatrop's nx, nu, ng per stage; None for the other layouts
    stages: dict | None = None


@dataclass(frozen=True)
class Layout:
    """Where each variable of a transcription sits in the NLP's vector w.

    Per interval k (K = control + settling intervals) a block of ``per`` variables [X_k (nx), Xc_k (d nx, collocation
    only), u_k], then X_K, then v.  When the last collocation point is the interval end (Radau, ``merged``) it is the
    next node: X_0, then per interval [Xc_k, u_k], then v; the node states and their continuity equations drop out (a
    fifth of the KKT system and most of its zero-diagonal pairs: half the time per IPOPT iteration at N = 200,
    benchmarks/spinup_ocp.md)."""

    K: int
    per: int  # variables per interval block
    first: int  # where the interval blocks start (nx when merged: X_0 leads)
    merged: bool
    X: np.ndarray  # (K+1, nx) the node states
    Xc: np.ndarray | None  # (K, d, nx) the collocation states (None for multiple shooting)
    u: np.ndarray  # (K,) the controls
    v: list  # the extra variables (epigraph level or final time)
    size: int  # len(w)


def layout(nx: int, nv: int, K: int, d: int, collocation: bool, merged: bool) -> Layout:
    """The variable layout (:class:`Layout`) of K intervals of a model with nx states and nv extra variables, with d
    collocation states per interval (``collocation``), the last the next node (``merged``)."""
    per = (0 if merged else nx) + (nx * d if collocation else 0) + 1
    first = nx if merged else 0
    starts = first + per * np.arange(K)
    Xc = (starts[:, None, None] + per - 1 - nx * d + nx * np.arange(d)[:, None] + np.arange(nx)
          if collocation else None)
    X = (np.concatenate([np.arange(nx)[None, :], Xc[:, -1, :]]) if merged else
         np.concatenate([starts[:, None] + np.arange(nx), K * per + np.arange(nx)[None, :]]))
    end = K * per + nx  # the extra variables follow the interval blocks and one node's nx
    return Layout(K, per, first, merged, X, Xc, starts + per - 1, list(range(end, end + nv)), end + nv)


def variable_bounds(ocp: SpinupProblem, lay: Layout, ms: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of w: the initial state fixed, the control in [u_min, 1] on the horizon and 0 over the settling window
    (the speed held), the speed bounds at the horizon's inner nodes, the extra variable's range."""
    lbx, ubx = np.full(lay.size, -np.inf), np.full(lay.size, np.inf)
    sp = ocp.speed_index
    # speed bounds on the horizon only: at its end omega_final is imposed, and over the settling window
    # the speed is held by the dynamics (a bound there would duplicate an equality: degenerate multipliers)
    # and at the nodes only: with a piecewise-constant acceleration the speed is linear in each interval
    # (exact in any collocation), so a bound at the collocation points would duplicate the node bounds
    # (the last Radau point is the next node): on an arc held at the cap that fails LICQ
    nlo, nhi = ocp.nu_bounds()
    lbx[lay.X[1:ms.n, sp]], ubx[lay.X[1:ms.n, sp]] = nlo, nhi
    lbx[lay.X[0]] = ubx[lay.X[0]] = ocp.q0
    lbx[lay.u[:ms.n]], ubx[lay.u[:ms.n]] = ocp.u_min, 1.0
    lbx[lay.u[ms.n:]] = ubx[lay.u[ms.n:]] = 0.0  # settling window: held speed
    if lay.v:
        lbx[lay.v[0]], ubx[lay.v[0]] = (0.0, 1.0) if ocp.free_time else (0.0, np.inf)
    return lbx, ubx


def control_step(ocp: SpinupProblem, ms: Mesh, v):
    """The length (tau) of a control interval of the horizon: fixed, or v_0 tau_h / n when the time is free."""
    return v[0] * ocp.tau_h / ms.n if ocp.free_time else ms.h


def collocation_rows(ocp: SpinupProblem, method: DirectCollocation, w, v, lay: Layout, ms: Mesh, ref: float
                     ) -> tuple[list, list, object, dict]:
    """The collocation's rows: one SX Function per interval (:func:`interval_function`), mapped over the K intervals
    (C++, no Python loop).  Returns the dynamics rows, each path constraint's rows, the quadrature and the
    interval data (the Function, its mapped arguments, and each interval input's variable (-1: a constant) and
    coefficient, for :func:`structured_derivatives`); ``v`` is w's extra variables."""
    nx, d, K, per = ocp.nx, method.degree, lay.K, lay.per
    W = ca.reshape(w[lay.first:lay.first + K * per], per, K)
    last = W[per - 1 - nx:per - 1, :]  # the last collocation point
    X0 = ca.horzcat(w[:nx], last[:, :-1]) if lay.merged else W[:nx, :]  # each interval's start and end node
    Xn = last if lay.merged else ca.horzcat(W[:nx, 1:], w[K * per:K * per + nx])
    hrow = ca.horzcat(ca.repmat(control_step(ocp, ms, v), 1, ms.n), ca.repmat(ms.hs, 1, ms.ns)) \
        if ms.grading is None else ca.DM(ms.lengths).T
    fi = interval_function(ocp, d, method.scheme, ref, continuity=not lay.merged)
    args = [X0, W[per - 1 - nx * d:per - 1, :], W[per - 1, :], Xn, hrow, v]
    out = fi.map(K)(*args)
    cols = np.full((fi.nnz_in(), K), -1)
    coefs = np.ones((fi.nnz_in(), K))
    ih = 2 * nx + nx * d + 1  # where h sits among the interval's inputs
    cols[:nx] = lay.X[:-1].T
    cols[nx:nx + nx * d] = lay.Xc.reshape(K, -1).T
    cols[nx + nx * d] = lay.u
    cols[nx + nx * d + 1:ih] = lay.X[1:].T
    if ocp.free_time:  # h = v_0 tau_h / n on the horizon
        cols[ih, :ms.n], coefs[ih, :ms.n] = lay.v[0], ocp.tau_h / ms.n
    cols[ih + 1:] = np.array(lay.v, int)[:, None]
    intervals = {"function": fi, "args": args, "cols": cols, "coefs": coefs}
    return [ca.vec(out[0])], [[ca.vec(o)] for o in out[1:-1]], ca.sum2(out[-1]), intervals


def shooting_rows(ocp: SpinupProblem, method: MultipleShooting, w, U, v, lay: Layout, ms: Mesh,
                  paths: list[PathConstraint]) -> tuple[list, list]:
    """Multiple shooting's rows: CVODES over each interval (:func:`interval_integrator`), the continuity of the
    node states and the path constraints at the integrator's outputs (the collocation instants).  Returns the
    dynamics rows and each path constraint's rows; ``U`` and ``v`` are w's controls and extra variables."""
    if ocp.objective == "integrated_deflection":
        raise ValueError("multiple shooting supports the peak and min_time objectives (no quadrature)")
    frac = path_fractions(method.degree, method.scheme)
    nx, per = ocp.nx, lay.per
    X = [w[k * per:k * per + nx] for k in range(lay.K + 1)]  # shooting: [X_k, u_k] per interval
    F = interval_integrator(ocp.rhs(), tuple(frac), method.tol)
    dynamics, path_rows = [], [[] for _ in paths]
    lengths = ms.lengths
    for k in range(lay.K):
        h = control_step(ocp, ms, v) if k < ms.n and ms.grading is None else lengths[k]
        out = F(x0=X[k], p=ca.vertcat(U[k] * ocp.a_max, h, *ocp.p))["xf"]
        dynamics.append(X[k + 1] - out[:, -1])
        for pc, r in zip(paths, path_rows, strict=True):
            r += [pc.expr(qj, U[k] * ocp.a_max, v) for qj in ([X[k]] if pc.uses_control else [])
                  + [out[:, j] for j in range(len(frac))]]
    return dynamics, path_rows


def jerk_rows(ocp: SpinupProblem, U, ms: Mesh, v) -> tuple[list, list]:
    """The changes du of the control between the horizon's intervals (one vector expression, not n scalar ones: the
    MX Hessian of a sum of n scalar nodes costs ~n^2 to build; the study's NLP build at N = 1600: 6.6 s,
    benchmarks/spinup_ocp.md, "Study scaling with N") and the jerk limit's rows du / (the largest change)."""
    du = [U[1:ms.n] - U[:ms.n - 1]] if ms.n > 1 else []
    if ocp.jerk_max is None:
        return du, []
    step = ocp.jerk_max / ocp.alpha_max / ocp.Om * (ocp.tau_h / ms.n if not ocp.free_time else 1.0)
    if ms.grading is not None:  # each pair of intervals its own step: the time between their midpoints
        return du, [d / ca.DM(step * jerk_steps(ms)) for d in du]
    return du, [d / step for d in du] if not ocp.free_time else [d / (step * v[0] * ocp.tau_h / ms.n) for d in du]


def jerk_steps(ms: Mesh) -> np.ndarray:
    """The n - 1 steps over tau_h / n between consecutive control intervals' midpoints (1 on a uniform mesh): the
    jerk limit bounds the change of the acceleration by the limit times this step."""
    g = np.ones(ms.n) if ms.grading is None else ms.grading
    return (g[1:] + g[:-1]) / 2


def stack(rows: dict, bounds: dict) -> tuple[list, np.ndarray, np.ndarray, list]:
    """The constraint blocks in order: each named block's expression, the bounds of g and (name, rows of g)."""
    g, lbg, ubg, blocks, start = [], [], [], [], 0
    for name, r in rows.items():
        if not r:
            continue
        e = ca.vertcat(*r)
        n = e.numel()
        g.append(e)
        lbg.append(np.full(n, bounds[name][0]))
        ubg.append(np.full(n, bounds[name][1]))
        blocks.append((name, np.arange(start, start + n)))
        start += n
    return g, np.concatenate(lbg), np.concatenate(ubg), blocks


# relative tolerance of the drive limits: the check of a re-simulated profile (the NLP keeps the limits at its
# collocation points only; ocp/simulation.py) and the no-braking rows of the settling window
# (:func:`relax_settling_brake`); on torques it is relative to the torque reference (simulation.torque_reference)
DRIVE_TOL = 1e-3


def relax_settling_brake(lbg: np.ndarray, blocks: list, ms: Mesh, tol: float = DRIVE_TOL) -> None:
    """Lower a no-braking limit (torque or braking rows whose lower bound is 0) over the settling window to -``tol``,
    in place (0: left as it is; the coarse screening, ocp/solve.py ``coarse_solver``).  There the control is 0 (the
    speed held), so the drive torque is the unbalance reaction of the residual whirl alone, and M >= 0 at the
    window's points constrains only that whirl's phase where the points fall: on a torque-limited rotor without
    braking the refinement lost its basin to it (torque_no_brake of the family, docs/dev/spinup.md, "Where
    torque_no_brake's basin is lost").  The re-simulation's drive check allows the same tolerance."""
    if not ms.ns:
        return
    for name, r in blocks:
        if name.startswith(("torque limit", "braking limit")):
            settle = r[len(r) // (ms.n + ms.ns) * ms.n:]
            lbg[settle[lbg[settle] == 0.0]] = -tol


def transcribe(ocp: SpinupProblem, method, ref: float, symbolic: str = "SX", ms: Mesh | None = None,
               brake_tol: float = DRIVE_TOL) -> Nlp:
    """The NLP of ``ocp`` by ``method`` (DirectCollocation: :func:`collocation_rows`, or MultipleShooting:
    :func:`shooting_rows`), the variables laid out by :func:`layout`.

    Parameters
    ----------
    ocp : SpinupProblem
        The declared problem (:class:`autobal.ocp.protocol.SpinupProblem`).
    method : DirectCollocation or MultipleShooting
        The transcription.
    ref : float
        Scale of the objective (delta^2 or d^2 for the epigraph, (delta/e)^2 s for the integral).
    symbolic : {"SX", "MX"}
        The collocation NLP's expression graph: "SX" (scalar, each interval's expressions inlined) or "MX"
        (the interval Function mapped over the intervals; its derivatives are maps too, so the solver's
        construction hardly grows with the intervals).  Multiple shooting is always MX.
    ms : Mesh, optional
        The intervals (:func:`mesh`, uniform or graded); the uniform mesh of ``method.intervals`` by default.
    brake_tol : float
        How far below 0 a no-braking limit's rows of the settling window may go (:func:`relax_settling_brake`;
        relative to the row's torque reference); 0: kept as stated.

    Returns
    -------
    Nlp
        Variables, objective, constraints, bounds, the named constraint blocks and the index of each variable.
    """
    collocation = isinstance(method, DirectCollocation)
    ms = mesh(ocp, method.intervals) if ms is None else ms
    merged = collocation and abs(collocation_data(method.degree, method.scheme)[0][-1] - 1) < 1e-12
    lay = layout(ocp.nx, ocp.n_extra, ms.n + ms.ns, method.degree, collocation, merged)
    w = (ca.MX if symbolic == "MX" or not collocation else ca.SX).sym("w", lay.size)
    U, v = w[lay.u.tolist()], w[lay.size - len(lay.v):]
    lbx, ubx = variable_bounds(ocp, lay, ms)

    paths = ocp.path_constraints(ref)
    intervals, quad = None, 0
    if collocation:
        dynamics, path_rows, quad, intervals = collocation_rows(ocp, method, w, v, lay, ms, ref)
    else:
        dynamics, path_rows = shooting_rows(ocp, method, w, U, v, lay, ms, paths)
    final = "final speed omega(T) = omega_final"
    rows = {"dynamics": dynamics} | {pc.name: r for pc, r in zip(paths, path_rows, strict=True)}
    rows[final] = [w[int(lay.X[ms.n, ocp.speed_index])] - ocp.nuf]
    bounds = {pc.name: (pc.lb, pc.ub) for pc in paths} | {"dynamics": (0.0, 0.0), final: (0.0, 0.0)}
    du, jerk = jerk_rows(ocp, U, ms, v)
    if ocp.jerk_max is not None:
        name = f"jerk limit |d alpha/dt| <= {ocp.jerk_max:g} rad/s^3"
        rows[name], bounds[name] = jerk, (-1.0, 1.0)
    g, lbg, ubg, blocks = stack(rows, bounds)
    relax_settling_brake(lbg, blocks, ms, brake_tol)

    obj = v[0] if ocp.objective in ("peak_deflection", "peak_unbalance", "min_time") else quad / ref
    if du:
        obj = obj + jerk_regulariser(ocp, ca.vertcat(*du))
    if intervals is not None:  # g row of each interval output: the dynamics and path blocks come first
        fi = intervals["function"]
        sizes = [fi.nnz_out(i) for i in range(fi.n_out() - 1)]
        first = [r[0] for _, r in blocks[:len(sizes)]]
        intervals["rows"] = np.concatenate([a + n * np.arange(lay.K)[None, :] + np.arange(n)[:, None]
                                            for a, n in zip(first, sizes, strict=True)])
        intervals["tail"] = ca.vertcat(*g[len(sizes):])  # the rows outside the intervals
    index = {"X": lay.X, "Xc": lay.Xc, "u": lay.u, "v": lay.v}
    return Nlp(w, obj, ca.vertcat(*g), lbx, ubx, lbg, ubg, blocks, index, ms,
               path_fractions(method.degree, method.scheme), method, ref, intervals)


def stage_function(ocp: SpinupProblem, d: int, scheme: str, ref: float, jerk: bool) -> ca.Function:
    """One stage of the stage form (:func:`transcribe_stages`) as an SX Function (x_k (nx), the collocation
    states (nx d), u_k, h, v_k, p_k, x_(k+1) (nx), v_(k+1), p_(k+1), h_j) -> (the gap rows x_(k+1) - Z_d,
    v_(k+1) - v_k and, with ``jerk``, p_(k+1) - u_k; the collocation residuals; one column per path constraint; the
    speed of x_k; with a jerk limit (u_k - p_k)/h_j (h_j the step from the previous interval's midpoint); the
    quadrature).  The equations are :func:`interval_function`'s."""
    fi = interval_function(ocp, d, scheme, ref, continuity=False)
    nv, jp, nx = ocp.n_extra, int(jerk), ocp.nx
    x0, xc, u, h, hj = ca.SX.sym("x0", nx), ca.SX.sym("xc", nx * d), ca.SX.sym("u"), ca.SX.sym("h"), ca.SX.sym("hj")
    v, p, x1, v1, p1 = (ca.SX.sym(n, k) for n, k in (("v", nv), ("p", jp), ("x1", nx), ("v1", nv), ("p1", jp)))
    res, *paths, quad = fi(x0, xc, u, xc[-nx:], h, v)
    gap = ca.vertcat(x1 - xc[-nx:], v1 - v, p1 - u if jerk else ca.SX(0, 1))
    rows = [gap, res, *paths, x0[ocp.speed_index]]
    if ocp.jerk_max is not None:
        rows.append((u - p) / (ocp.jerk_max / ocp.alpha_max / ocp.Om * hj))
    return ca.Function("spinup_stage", [x0, xc, u, h, v, p, x1, v1, p1, hj], [*rows, quad])


SPEED_ROWS = "speed: omega <= omega_max on the horizon, final speed omega(T) = omega_final"


def stage_layout(nx: int, nv: int, jp: int, d: int, K: int) -> tuple[int, dict]:
    """The variables of the stage form: stage k < K [X_k (nx), v_k (nv), p_k (jp), u_k, Xc_k (d nx)], then stage K
    [X_K, v_K, p_K].  Returns the variables per stage k < K and the index of each ("X", "Xc", "u", "v", "v_copies"
    (K+1, nv), "p" (K+1,) or None)."""
    nxs = nx + nv + jp  # the states of a stage
    per = nxs + 1 + nx * d
    start = per * np.arange(K + 1)
    idx_vc = start[:, None] + nx + np.arange(nv)
    return per, {"X": start[:, None] + np.arange(nx), "Xc": start[:K, None, None] + nxs + 1 + nx * np.arange(d)[:, None]
                 + np.arange(nx), "u": start[:K] + nxs, "v": list(idx_vc[0]), "v_copies": idx_vc,
                 "p": start + nx + nv if jp else None}


def stage_row_bounds(ocp: SpinupProblem, ms: Mesh, sizes: list, paths: list[PathConstraint],
                     brake_tol: float = DRIVE_TOL) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray]:
    """Bounds of the stage form's rows (the K stages' rows of :func:`stage_function`, ``sizes`` rows per output, in
    stage order): the gaps and collocation residuals 0, the path constraints', the speed bounded on the horizon's
    inner nodes and omega_final at the deadline (when a settling window follows), the jerk limit on the horizon.
    Returns lbg, ubg, the rows of each named block and the rows of each stage (rows per stage, K)."""
    K, n = ms.n + ms.ns, ms.n
    nrow = sum(sizes)
    rows = np.arange(nrow)[:, None] + nrow * np.arange(K)[None, :]  # stage by stage
    names = ["dynamics", "dynamics"] + [pc.name for pc in paths] + [SPEED_ROWS]
    bounds = [(0.0, 0.0), (0.0, 0.0)] + [(pc.lb, pc.ub) for pc in paths] + [(-np.inf, np.inf)]
    if ocp.jerk_max is not None:
        names.append(f"jerk limit |d alpha/dt| <= {ocp.jerk_max:g} rad/s^3")
        bounds.append((-np.inf, np.inf))
    block = np.repeat(np.arange(len(sizes)), sizes)  # the output of each row of a stage
    lo = np.repeat(np.array(bounds)[block, :1], K, axis=1)
    hi = np.repeat(np.array(bounds)[block, 1:], K, axis=1)
    speed = np.flatnonzero(block == names.index(SPEED_ROWS))[0]
    lo[speed, 1:n], hi[speed, 1:n] = ocp.nu_bounds()
    if ocp.jerk_max is not None:
        lo[-1, 1:n], hi[-1, 1:n] = -1.0, 1.0
    lo, hi = lo.ravel(order="F"), hi.ravel(order="F")
    blocks = {name: rows[np.isin(block, [i for i, m in enumerate(names) if m == name])].ravel() for name in names}
    relax_settling_brake(lo, [(name, np.sort(r)) for name, r in blocks.items()], ms, brake_tol)  # in stage order
    if ms.ns:
        lo[rows[speed, n]] = hi[rows[speed, n]] = ocp.nuf
    return lo, hi, blocks, rows


def stage_variable_bounds(ocp: SpinupProblem, size: int, index: dict, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the stage form's variables: X_0 fixed, u in [u_min, 1] on the horizon (as :func:`variable_bounds`)
    and 0 after, the first previous control 0, the extra variable's range (its copies free: the gap rows carry it)."""
    lbx, ubx = np.full(size, -np.inf), np.full(size, np.inf)
    idx_u, idx_vc = index["u"], index["v_copies"]
    lbx[index["X"][0]] = ubx[index["X"][0]] = ocp.q0
    lbx[idx_u[:n]], ubx[idx_u[:n]] = ocp.u_min, 1.0
    lbx[idx_u[n:]] = ubx[idx_u[n:]] = 0.0
    if index["p"] is not None:
        lbx[index["p"][0]] = ubx[index["p"][0]] = 0.0
    if idx_vc.shape[1]:
        lbx[idx_vc[0, 0]], ubx[idx_vc[0, 0]] = (0.0, 1.0) if ocp.free_time else (0.0, np.inf)
    return lbx, ubx


def transcribe_stages(ocp: SpinupProblem, method: DirectCollocation, ref: float, ms: Mesh | None = None,
                      brake_tol: float = DRIVE_TOL) -> Nlp:
    """The collocation NLP of ``ocp`` in the stage form of a structure-exploiting solver (fatrop: Vanroye et
    al. (2023), a Riccati recursion over the stages, linear in their number).

    The same discrete problem as :func:`transcribe` (Radau points): stage k < K has the states
    x_k = [X_k (nx), v_k (the epigraph level or the time scale, one copy per stage), p_k (the previous control,
    when the objective or a limit uses the jerk)] and the controls [u_k, the collocation states (nx d)]; stage 0
    has only controls (X_0 fixed by its bounds); stage K only its states (:func:`stage_layout`).  Each stage's rows
    follow its gap rows (x_(k+1) as the last collocation point, v and p carried): the collocation residuals, the path
    constraints, the speed and the jerk limit (:func:`stage_row_bounds`).  No row or Hessian entry couples two
    stages but through the gap rows, as fatrop requires.

    Parameters
    ----------
    ocp : SpinupProblem
        The declared problem.
    method : DirectCollocation
        Radau collocation (the last point is the interval end, the next stage's state).
    ref : float
        Scale of the objective, as for :func:`transcribe`.
    ms : Mesh, optional
        The intervals, as for :func:`transcribe`.
    brake_tol : float
        As for :func:`transcribe`.

    Returns
    -------
    Nlp
        With ``stages`` (fatrop's N, nx, nu, ng), ``index["v_copies"]`` (K+1, nv) and ``index["p"]`` (K+1,) or
        None; ``index["v"]`` is stage 0's copy.
    """
    if not isinstance(method, DirectCollocation) or abs(collocation_data(method.degree, method.scheme)[0][-1]
                                                        - 1) > 1e-12:
        raise ValueError(f"the stage form (fatrop) needs Radau collocation, got {method.label}")
    ms = mesh(ocp, method.intervals) if ms is None else ms
    K, n, d, nv, nx = ms.n + ms.ns, ms.n, method.degree, ocp.n_extra, ocp.nx
    jerk = n > 1 and bool(ocp.jerk_penalty or ocp.jerk_variation or ocp.jerk_max is not None)
    nxs = nx + nv + int(jerk)  # the states of a stage
    per, index = stage_layout(nx, nv, int(jerk), d, K)
    w = ca.MX.sym("w", K * per + nxs)
    W = ca.reshape(w[:K * per], per, K)
    nxt = ca.horzcat(W[:nxs, 1:], w[K * per:])
    scale = ocp.tau_h / n  # h = v_0 tau_h / n on the horizon when the time is free
    hrow = ca.horzcat(W[nx, :n] * scale if ocp.free_time else ca.repmat(ms.h, 1, n), ca.repmat(ms.hs, 1, ms.ns)) \
        if ms.grading is None else ca.DM(ms.lengths).T
    # the jerk limit's step of stage k: the time between the midpoints of intervals k - 1 and k (h when uniform)
    hjerk = hrow if ms.grading is None else ca.DM(np.concatenate([[1.0], jerk_steps(ms), np.ones(ms.ns)]) * ms.h).T
    fs = stage_function(ocp, d, method.scheme, ref, jerk)
    out = fs.map(K)(W[:nx, :], W[nxs + 1:, :], W[nxs, :], hrow, W[nx:nx + nv, :], W[nx + nv:nxs, :], nxt[:nx, :],
                    nxt[nx:nx + nv, :], nxt[nx + nv:, :], hjerk)
    sizes = [fs.nnz_out(i) for i in range(fs.n_out() - 1)]
    g = ca.vec(ca.vertcat(*out[:-1]))
    lo, hi, blocks, _ = stage_row_bounds(ocp, ms, sizes, ocp.path_constraints(ref), brake_tol)
    if not ms.ns:  # the deadline is the last stage's: its one row
        g = ca.vertcat(g, w[int(index["X"][K, ocp.speed_index])])
        lo, hi = np.append(lo, ocp.nuf), np.append(hi, ocp.nuf)
        blocks[SPEED_ROWS] = np.append(blocks[SPEED_ROWS], g.numel() - 1)
    blocks = [(name, np.sort(r)) for name, r in blocks.items()]
    lbx, ubx = stage_variable_bounds(ocp, w.numel(), index, n)
    obj = w[int(index["v_copies"][0, 0])] if ocp.objective in ("peak_deflection", "peak_unbalance", "min_time") \
        else ca.sum2(out[-1]) / ref
    if jerk:
        obj = obj + jerk_regulariser(ocp, w[index["u"][1:n].tolist()] - w[index["p"][1:n].tolist()])
    stages = {"N": K, "nx": [0] + [nxs] * K, "nu": [nxs + 1 + nx * d] + [1 + nx * d] * (K - 1) + [0],
              "ng": [sum(sizes) - nxs] * K + [0 if ms.ns else 1]}
    return Nlp(w, obj, g, lbx, ubx, lo, hi, blocks, index, ms,
               path_fractions(d, method.scheme), method, ref, None, stages)


def complete_stage_guess(nlp: Nlp, w: np.ndarray) -> np.ndarray:
    """A guess of the stage form with its carried copies filled: every stage's v is stage 0's, p_(k+1) = u_k."""
    w = np.array(w, float)
    if nlp.stages is None:
        return w
    w[nlp.index["v_copies"]] = w[nlp.index["v"]]
    if nlp.index["p"] is not None:
        w[nlp.index["p"][1:]] = w[nlp.index["u"]]
    return w


def _assemble(vals: ca.MX, rows: np.ndarray, cols: np.ndarray, src: np.ndarray, coef: np.ndarray,
              shape: tuple) -> ca.MX:
    """The sparse matrix sum_t coef_t vals[src_t] e_(rows_t) e_(cols_t)' (duplicates summed; a plain
    permutation of ``vals`` when there are none and every coefficient is 1)."""
    key = cols.astype(np.int64) * shape[0] + rows
    uniq, at = np.unique(key, return_inverse=True)
    colind = np.searchsorted(uniq // shape[0], np.arange(shape[1] + 1))
    sp = ca.Sparsity(shape[0], shape[1], colind.tolist(), (uniq % shape[0]).tolist())
    if uniq.size == key.size and np.all(coef == 1):
        order = np.empty_like(at)
        order[at] = np.arange(at.size)
        return ca.MX(sp, vals[src[order].tolist()])
    A = ca.DM.triplet(at.tolist(), src.tolist(), coef.tolist(), uniq.size, vals.numel())
    return ca.MX(sp, ca.mtimes(A, vals))


def structured_derivatives(nlp: Nlp) -> dict:
    """The constraint Jacobian and the Hessian of the Lagrangian of a collocation NLP from the interval
    Function's own SX derivatives, mapped over the intervals and scattered into place by a constant sparse
    matrix; the rows outside the intervals (final speed, jerk) and the objective by MX differentiation.
    Built in about constant time in N and evaluated about as fast as a whole-NLP SX graph (an MX Jacobian
    of the map costs 4-6x more per call; benchmarks/spinup_ocp.md, "Levers").

    Parameters
    ----------
    nlp : Nlp
        A collocation transcription (``nlp.intervals`` set).

    Returns
    -------
    dict
        ``jac_g`` (x, p) -> (g, dg/dx) and ``hess_lag`` (x, p, lam_f, lam_g) -> the upper triangle of the
        Hessian of lam_f f + lam_g' g, for :func:`autobal.analysis.numerics.ipopt.nlpsol`.
    """
    s = nlp.intervals
    fi, args, cols, coefs, rows = s["function"], s["args"], s["cols"], s["coefs"], s["rows"]
    K = cols.shape[1]
    x, f, g, tail = nlp.x, nlp.f, nlp.g, s["tail"]
    nx, ng = x.numel(), g.numel()
    zs = fi.sx_in()
    z = ca.vertcat(*[ca.vec(a) for a in zs])
    y = ca.vertcat(*fi.call(zs)[:-1])  # the interval's g rows (the quadrature output is the objective's)
    k = np.arange(K)[None, :]

    J = ca.jacobian(y, z)
    ji, jj = (np.array(a) for a in J.sparsity().get_triplet())
    # one map gives the interval rows and their Jacobian: jac_g returns g too, without a second pass
    *ys, jv = ca.Function("spinup_interval_jac", zs, [*fi.call(zs)[:-1], ca.vertcat(*J.nonzeros())]).map(K)(*args)
    R, C, CO = rows[ji], cols[jj], coefs[jj]
    src = np.arange(ji.size)[:, None] + ji.size * k
    ok = C >= 0
    jac_head = _assemble(ca.vec(jv), R[ok], C[ok], src[ok], CO[ok], (rows.size, nx))

    mu = ca.SX.sym("mu", y.numel())
    H = ca.hessian(ca.dot(mu, y), z)[0]
    hi, hj = (np.array(a) for a in H.sparsity().get_triplet())
    p, lam_f, lam_g = ca.MX.sym("p", 0), ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
    mus = ca.reshape(lam_g[rows.ravel(order="F").tolist()], y.numel(), K)
    hv = ca.Function("spinup_interval_hess", [*zs, mu], [ca.vertcat(*H.nonzeros())]).map(K)(*args, mus)
    C1, C2, CO = cols[hi], cols[hj], coefs[hi] * coefs[hj]
    src = np.arange(hi.size)[:, None] + hi.size * k
    ok = (C1 >= 0) & (C2 >= 0) & (C1 <= C2)
    hess_head = _assemble(ca.vec(hv), C1[ok], C2[ok], src[ok], CO[ok], (nx, nx))
    nt = tail.numel()
    rest = lam_f * f + (ca.dot(lam_g[rows.size:], tail) if nt else 0)
    hess = hess_head + ca.triu(ca.hessian(rest, x)[0])
    jac = ca.vertcat(jac_head, ca.jacobian(tail, x)) if nt else jac_head
    g = ca.vertcat(*[ca.vec(a) for a in ys], tail)
    return {"jac_g": ca.Function("spinup_jac_g", [x, p], [g, jac]),
            "hess_lag": ca.Function("spinup_hess_l", [x, p, lam_f, lam_g], [hess])}


def point_times(nlp: Nlp) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node times (K+1,), interval lengths (K,) and collocation-point times (K, d) of a collocation NLP, tau."""
    h = nlp.mesh.lengths
    t0 = np.concatenate([[0.0], np.cumsum(h)])
    tau = np.array(collocation_data(nlp.method.degree, nlp.method.scheme)[0])
    return t0, h, t0[:-1, None] + h[:, None] * tau[None, :]


def _lagrange(nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Lagrange basis on ``nodes`` at the points s: (len(s), len(nodes))."""
    L = np.ones((len(s), len(nodes)))
    for r, nr in enumerate(nodes):
        for q, nq in enumerate(nodes):
            if q != r:
                L[:, r] *= (s - nq) / (nr - nq)
    return L


def coarse_interval(coarse: Nlp, t: np.ndarray) -> np.ndarray:
    """The interval of the ``coarse`` mesh each time t (tau) falls in."""
    tc0 = point_times(coarse)[0]
    return np.clip(np.searchsorted(tc0, t, side="right") - 1, 0, len(tc0) - 2)


def interpolate(coarse: Nlp, w: np.ndarray, lam_g: np.ndarray, lam_x: np.ndarray, fine: Nlp
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Primal and dual guess of the ``fine`` collocation NLP from a solution of the ``coarse`` one (same
    problem, a finer mesh): the states by the coarse collocation polynomials, the controls held
    (:func:`interpolate_duals` for the multipliers; None, None for the stage form, which starts from the primal
    guess)."""
    d, scheme = coarse.method.degree, coarse.method.scheme
    tau = collocation_data(d, scheme)[0]
    tc0, hc, _ = point_times(coarse)
    tf0, hf, tfc = point_times(fine)
    Kf = len(hf)
    Xc, Zc = w[coarse.index["X"]], w[coarse.index["Xc"]]
    nx = Xc.shape[1]
    nodes = np.concatenate([[0.0], tau])

    def state_at(t):
        k = coarse_interval(coarse, t)
        Z = np.concatenate([Xc[k][:, None, :], Zc[k]], axis=1)  # (P, d+1, nx)
        return np.einsum("pr,pri->pi", _lagrange(nodes, (t - tc0[k]) / hc[k]), Z)

    wf = np.zeros(fine.x.numel())
    wf[fine.index["X"]] = state_at(tf0)
    wf[fine.index["X"][-1]] = Xc[-1]
    wf[fine.index["Xc"]] = state_at(tfc.ravel()).reshape((Kf, d, nx))
    kc = coarse_interval(coarse, tf0[:-1] + 0.5 * hf)
    wf[fine.index["u"]] = w[coarse.index["u"]][kc]
    wf[fine.index["v"]] = w[coarse.index["v"]]
    if lam_g is None or coarse.stages or fine.stages:  # the stage form (fatrop) starts from the primal guess
        return wf, None, None
    return (wf, *interpolate_duals(coarse, lam_g, lam_x, fine))


def interpolate_duals(coarse: Nlp, lam_g: np.ndarray, lam_x: np.ndarray, fine: Nlp) -> tuple[np.ndarray, np.ndarray]:
    """The multipliers of the ``fine`` NLP from the ``coarse`` one's (:func:`interpolate`).

    The multipliers of the collocation equations are B_j p(t) (quadrature weight times the costate, the
    same on any mesh) and those of the continuity equations p(t): both interpolated in time; the path
    multipliers are a measure (the peak's), each moved to the nearest fine point; the control-bound
    multipliers scale with the interval length.  With them IPOPT starts at a small barrier parameter
    near the coarse optimum: from its own least-squares multipliers (spread evenly over the thousands of
    epigraph points) the barrier's central path lifts the peak level far above the optimum first
    (benchmarks/spinup_ocp.md)."""
    d, scheme = coarse.method.degree, coarse.method.scheme
    B = collocation_data(d, scheme)[3]
    tc0, hc, tcc = point_times(coarse)
    tf0, hf, tfc = point_times(fine)
    Kc, Kf = len(hc), len(hf)
    nx = coarse.index["X"].shape[1]
    kc = coarse_interval(coarse, tf0[:-1] + 0.5 * hf)

    def block(nlp, name):
        return next((r for n, r in nlp.blocks if n == name), None)

    lg = np.zeros(fine.g.numel())
    rows = block(coarse, "dynamics")
    per = rows.size // (nx * Kc)  # d + 1 equations per interval, d when the nodes are the last points (Radau)
    Dc = lam_g[rows].reshape(Kc, per, nx)
    colloc = (Dc[:, :d, :] / np.asarray(B)[None, :, None]).reshape(-1, nx)
    pc = np.stack([np.interp(tfc.ravel(), tcc.ravel(), colloc[:, i]) for i in range(nx)], -1).reshape(Kf, d, nx)
    parts = [pc * np.asarray(B)[None, :, None]]
    if per > d:
        parts.append(np.stack([np.interp(tf0[1:], tc0[1:], Dc[:, d, i]) for i in range(nx)], -1)[:, None, :])
    lg[block(fine, "dynamics")] = np.concatenate(parts, axis=1).ravel()
    npath = len(coarse.fractions)
    tcp = np.concatenate([tcc, tc0[1:, None]], axis=1)[:, :npath].ravel() if npath > d else tcc.ravel()
    tfp = np.concatenate([tfc, tf0[1:, None]], axis=1)[:, :npath].ravel() if npath > d else tfc.ravel()
    for name, rows in coarse.blocks:
        fb = block(fine, name)
        if name == "dynamics" or fb is None:
            continue
        if rows.size == 1 and fb.size == 1:
            lg[fb] = lam_g[rows]
        elif (rows.size == tcp.size or "epigraph" in name) and rows.size % tcp.size == 0 \
                and fb.size == rows.size // tcp.size * tfp.size:
            # a path constraint at the path points (m rows per point: the nodes of a multi-node epigraph)
            m = rows.size // tcp.size
            for i in np.nonzero(lam_g[rows])[0]:
                lg[fb[m * np.argmin(np.abs(tfp - tcp[i // m])) + i % m]] += lam_g[rows[i]]
    lx = np.zeros(fine.x.numel())
    lx[fine.index["X"][0]] = lam_x[coarse.index["X"][0]]
    lx[fine.index["u"]] = lam_x[coarse.index["u"]][kc] * hf / hc[kc]
    return lg, lx
