"""Statics of the balancing device solved with IPOPT (Pavlenko 2014, (2.17)/(2.19), (2.137)).

IPOPT solves the balances of :func:`autobal.models.device.static_system` as equality
constraints with the physical bounds (pressures >= 0, gap u >= 0, valve 0 <= xi <= xi_max,
stop reactions >= 0) and the stops' complementarity (sum of gap x reaction) as the objective,
which is zero exactly at the physical solution and is checked to be so.  Regulator saturation
(the valve on its open stop) and face contact are part of the solution, reported
through their reactions, never a crash.

Newton's method on the square system of the same balances (stops fixed: each reaction zero or
its coordinate on the stop) is the one batch solver, :class:`ParametricStatics`: the balances
with any groups as parameters, solved for many points at once (CasADi Functions mapped over the
points, generated as C and compiled where a C compiler is found, called through buffers; batched
linear solves), behind :meth:`StaticsSolver.newton` (an independent
cross-check of IPOPT), :meth:`StaticsSolver.fast_sweep`, the Monte Carlo and the estimation.
:meth:`StaticsSolver.sweep` continues over the discharge ratio with warm starts and
:meth:`StaticsSolver.batch` solves a whole sweep as one NLP.

Status: a point counts as solved only when every balance is within :data:`MAX_RELATIVE_RESIDUAL` of its
largest term, whatever IPOPT's return status says; otherwise :meth:`StaticsSolver.solve` raises SolveError
(the statics analysis is a failed solve, exit 3) with the status ``Residual_Above_Tolerance`` and the last
iterate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from autobal.analysis.numerics import closed_form, ipopt
from autobal.analysis.numerics.compiled import compiled_map, compiler
from autobal.analysis.run import interrupt, solver_options
from autobal.errors import SolveError
from autobal.models.device import DeviceDesign, StaticSystem, static_system

REACTION_TOL = 1e-8  # a stop reaction above this (dimensionless force) means the stop is reached
COMPLEMENTARITY_TOL = 1e-10  # sum of gap x reaction accepted as zero
FAST_NEWTON_ITER = 12  # batched Newton evaluations before the points left go to CasADi's rootfinder
RESIDUAL_TOL = 1e-10  # a Newton root is accepted below this largest absolute balance residual
# IPOPT stalls (search direction too small) where a square-root throttle's flow reverses: its derivative is
# ~1e5 there and the balance's own terms vanish.  Such a point is kept when every balance is within this of
# its largest term (absolute error ~1e-12 of the flows), with IPOPT's status beside it.
STALLED_RESIDUAL = 1e-6
# A solved point (IPOPT's status Solve_Succeeded or not) counts only when every balance is within this of its largest
# term: IPOPT's status alone does not make a point a solution.
MAX_RELATIVE_RESIDUAL = STALLED_RESIDUAL
FLOW_FLOOR = 1e-9  # a flow balance's scale is at least this part of the largest flow in the network
# Batches of at least COMPILED_MIN points are evaluated by the point Function mapped over COMPILED_SIZE points and
# compiled to C with the loop inside (one C call per block, the last block padded): 3x CasADi's virtual machine.
COMPILED_SIZE, COMPILED_MIN = 1024, 256


@dataclass
class StaticPoint:
    """One solved static state: unknowns by name, throttle flows q, solver report."""

    psi1: float
    dpsi: float
    x: np.ndarray
    values: dict
    flows: dict
    status: str
    iterations: int
    max_residual: float  # largest balance residual relative to the largest term in it
    lam: dict = field(default_factory=dict, repr=False)

    @property
    def saturated(self) -> bool:
        return self.values.get("r_valve", 0.0) > REACTION_TOL

    @property
    def contact(self) -> bool:
        return self.values["r_contact"] > REACTION_TOL

    @property
    def active(self) -> frozenset:
        """The stops reached: names of the reactions that are not zero."""
        return frozenset(k for k, v in self.values.items() if k.startswith("r_") and v > REACTION_TOL)


def ideal_guess(g, unknowns: list[str], psi1s, dpsi) -> np.ndarray:
    """Rows of ``unknowns`` from the exact ideal-regulator closed form (no stop reached), vectorised
    over ``psi1s`` (and over array-valued groups ``g``, one sample per row); where it has no physical
    value, a crude interior point."""
    psi1s = np.atleast_1d(np.asarray(psi1s, float))
    ex = closed_form.exact_ideal(g, psi1s, dpsi)
    bad = ~(np.isfinite(ex["u"]) & (ex["u"] > 0) & np.isfinite(ex["psi2"]) & np.isfinite(ex["psi3"]))
    c = (g.b * psi1s - g.chi) / g.sigma
    v = {"psi2": np.where(bad, psi1s + 0.5 * dpsi, ex["psi2"]),
         "u": np.where(bad, 1.0, ex["u"]), "psi_e": psi1s + dpsi}
    v["psi3"] = np.where(bad, np.maximum(v["psi2"] - c, 0.05), ex["psi3"])
    if g.regulator is not None:
        cam, xi = closed_form.regulator(g, psi1s, dpsi, psi2=v["psi2"])
        ok = np.isfinite(xi) & (cam > v["psi_e"])
        v["psi_cam"] = np.where(ok, cam, 0.5 * (g.regulator.psi_in + v["psi_e"]))
        v["xi"] = np.where(ok, xi, 1.0)
    zeros = np.zeros(len(psi1s))
    return np.column_stack([np.broadcast_to(v.get(k, zeros), zeros.shape) for k in unknowns])


def call_rows(f: ca.Function, *rows: np.ndarray, out: list | None = None) -> list[np.ndarray]:
    """Call a Function mapped over m points on ``rows`` (m x entries each) through a CasADi buffer:
    a point's entries are contiguous in a C-ordered row, which is CasADi's column-major column, so
    nothing is converted to or from DM.  Returns one array (m x entries) per output (``out``: the
    arrays to fill, C-contiguous)."""
    m = rows[0].shape[0]
    buf, run = f.buffer()
    rows = [np.ascontiguousarray(r, dtype=float) for r in rows]
    outs = out if out is not None else [np.empty((m, f.nnz_out(j) // m)) for j in range(f.n_out())]
    for i, r in enumerate(rows):
        buf.set_arg(i, memoryview(r))
    for j, o in enumerate(outs):
        buf.set_res(j, memoryview(o))
    run()
    return outs


def _solve_each(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """J^-1 r for a stack of square systems (LAPACK LU with partial pivoting, one system after another,
    so a system's solution does not depend on the others); NaN rows where singular (an exact zero
    pivot, which fails the whole stack in numpy: found by the same LU's sign of the determinant)."""
    with np.errstate(all="ignore"):
        try:
            return np.linalg.solve(J, r[..., None])[..., 0]
        except np.linalg.LinAlgError:
            out = np.full(r.shape, np.nan)
            ok = np.linalg.slogdet(J)[0] != 0
            out[ok] = np.linalg.solve(J[ok], r[ok][..., None])[..., 0]
            return out


class ParametricStatics:
    """The device's static balances with some groups as a parameter vector, and their Newton
    solve with the stops fixed, mapped over columns of parameters: the one evaluator behind the
    statics sweep (:meth:`StaticsSolver.fast_sweep`), the Monte Carlo and the estimation.

    The balances are those of :func:`autobal.models.device.static_system` (Pavlenko 2014,
    (2.17)/(2.19), (2.137)) with the groups ``names`` (fields of DeviceGroups/RegulatorGroups)
    as ``theta``; the parameter column of every Function here is ``p = [psi1, dpsi, theta]``.

    Parameters
    ----------
    groups : DeviceGroups
        The device's dimensionless groups; those in ``names`` are replaced by ``theta``.
    names : sequence of str
        The groups that become parameters, in the order of ``theta``.
    """

    def __init__(self, groups, names=()):
        self.names = tuple(names)
        self.system: StaticSystem = static_system(groups, self.names)
        sys_ = self.system
        w, psi1, dpsi = ca.SX.sym("w", len(sys_.unknowns)), ca.SX.sym("psi1"), ca.SX.sym("dpsi")
        theta = ca.SX.sym("theta", len(self.names))
        args = [w, psi1, dpsi] + ([theta] if self.names else [])
        q, psi = sys_.flows(*args)
        #: balances r(w, psi1, dpsi, theta), dimensionless (zero at a solution)
        self.residual = ca.Function("parametric_residual", [w, psi1, dpsi, theta], [sys_.residual(*args)])
        #: throttle flows q(w, psi1, dpsi, theta) in the order of ``system.throttles``
        self.flows = ca.Function("parametric_flows", [w, psi1, dpsi, theta], [q])
        #: pressures (psi_e, psi2, psi3, psi_cam or NaN) of (w, psi1, dpsi, theta)
        self.pressures = ca.Function("parametric_pressures", [w, psi1, dpsi, theta], [psi])
        #: each balance's |residual| over its largest term, (w, psi1, dpsi, theta) -> vector
        self.relative = self._relative(groups, w, psi1, dpsi, theta, q)
        self.lower = np.array(sys_.lower, float)
        self.upper = np.array(sys_.upper, float)
        # the stop sets tried in turn: regulating, then the valve on its open stop
        self.active_sets = [frozenset()] + ([frozenset({"r_valve"})] if "r_valve" in sys_.stops else [])
        self._newton: dict = {}
        self._square: dict = {}
        self._maps: dict = {}
        self._compiled: dict = {}
        self._free: dict = {}
        self.parallel, self.threads = "serial", 2  # map mode of the virtual machine's maps (CasADi map)
        self.chunk = 8192  # points per mapped call on the virtual machine
        #: evaluate batches of COMPILED_MIN points or more by maps compiled to C (:func:`compiled_map`), in
        #: blocks of ``block`` points; default: when a C compiler is found
        self.jit = compiler() is not None
        self.block = COMPILED_SIZE

    def _relative(self, groups, w, psi1, dpsi, theta, q) -> ca.Function:
        """Each balance's |residual| over its scale, the largest absolute term in it (for a flow balance at
        least :data:`FLOW_FLOOR` of the network's largest flow; the groups in ``names`` taken from theta)."""
        sys_ = self.system
        named = dict(zip(self.names, ca.vertsplit(theta), strict=True)) if self.names else {}
        reg = groups.regulator

        def group(name, where):
            return named.get(name, getattr(where, name))

        flows = dict(zip(sys_.throttles, ca.vertsplit(q), strict=True))

        # a flow balance whose own flows both vanish (a closed face, a chamber at its drain's pressure) is scaled
        # by a small part of the network's largest flow, not by its own zero: its residual is then measured, not 0/0
        floor = FLOW_FLOOR * ca.mmax(ca.fabs(q))

        def largest(*names):
            return ca.fmax(ca.mmax(ca.fabs(ca.vertcat(*[flows[k] for k in names]))), floor)

        scale = {
            "disc force": ca.fmax(group("b", groups) * psi1, group("chi", groups)),
            "chamber 2 flow": largest("e", "1", "T"),
            "chamber 3 flow": largest("T", "3"),
            "membrane force": group("sigma_m", reg) * dpsi if reg else 1.0,
            "valve chamber flow": largest("in", "valve") if reg else 1.0,
            "barrier chamber flow": largest("valve", "e") if reg else 1.0,
        }
        r = ca.fabs(self.residual(w, psi1, dpsi, theta))
        return ca.Function("relative_residual", [w, psi1, dpsi, theta],
                           [r / ca.vertcat(*[scale[e] for e in sys_.equations])])

    def free(self, active: frozenset = frozenset()) -> tuple[list[int], dict]:
        """Indices of the unknowns left free when each stop is fixed (in ``active``: coordinate on
        its stop; otherwise reaction 0), and the fixed values by index."""
        if active not in self._free:
            sys_ = self.system
            fixed = {sys_.index(k): v for k, v in sys_.fixed_by_stops(active).items()}
            self._free[active] = ([i for i in range(len(sys_.unknowns)) if i not in fixed], fixed)
        free, fixed = self._free[active]
        return list(free), dict(fixed)

    def newton(self, active: frozenset = frozenset()) -> tuple[ca.Function, list[int], ca.Function]:
        """The square system with the stops fixed as in :meth:`free` as CasADi's Newton rootfinder
        (the implicit function, for exact derivatives of a root with respect to p):
        ``(solver(w_free0, p) -> w_free, free indices, full(w_free) -> w)``.  Roots of many points
        are found by :meth:`roots`, the same Newton iteration driven over all points at once."""
        if active not in self._newton:
            free, fixed = self.free(active)
            wf, p = ca.SX.sym("wf", len(free)), ca.SX.sym("p", 2 + len(self.names))
            full = ca.vertcat(*[wf[free.index(i)] if i in free else fixed[i]
                                for i in range(len(self.system.unknowns))])
            rf = ca.Function("square", [wf, p], [self.residual(full, p[0], p[1], p[2:])], {"cse": True})
            self._square[active] = rf
            solver = ca.rootfinder(f"newton_{'_'.join(sorted(active)) or 'free'}", "newton", rf,
                                   solver_options.rootfinder())
            self._newton[active] = (solver, free, ca.Function("full", [wf], [full]))
        return self._newton[active]

    def sensitivity(self, active: frozenset = frozenset()) -> ca.Function:
        """d(free unknowns)/dp of the rootfinder, (w_free0, p) -> matrix (exact, implicit function)."""
        solver, free, _ = self.newton(active)
        wf, p = ca.MX.sym("wf", len(free)), ca.MX.sym("p", 2 + len(self.names))
        return ca.Function("dW_dp", [wf, p], [ca.jacobian(solver(wf, p), p)])

    def function(self, kind: str, active: frozenset) -> ca.Function:
        """One point's Function: "check" (w, p) -> (largest |r|, largest relative |r|, q, psi, the number
        of bounds w satisfies: 2 x unknowns inside, fewer outside or NaN);
        "relative" (w, p) -> relative |r| per balance; "step" (w_free, p) -> (r, J row by row) of the
        square system with the stops fixed as ``active`` says; "newton" (w_free0, p) -> w_free, its
        root by CasADi's rootfinder."""
        key = (kind, active)
        if key not in self._maps:
            free = self.newton(active)[1]
            if kind in ("check", "relative"):
                w, p = ca.SX.sym("w", len(self.system.unknowns)), ca.SX.sym("p", 2 + len(self.names))
                args = (w, p[0], p[1], p[2:])
                out = [self.relative(*args)] if kind == "relative" else [
                    ca.mmax(ca.fabs(self.residual(*args))), ca.mmax(self.relative(*args)), self.flows(*args),
                    self.pressures(*args), ca.sum1(ca.vertcat(w >= self.lower, w <= self.upper))]
                # cse: the residual, the flows and the scales share their throttle flows (215 -> 111 instructions)
                self._maps[key] = ca.Function(kind, [w, p], out, {"cse": True})
            elif kind == "newton":  # CasADi's rootfinder (with its line search) from w_free
                solver = self.newton(active)[0]
                wf, p = ca.MX.sym("wf", len(free)), ca.MX.sym("p", 2 + len(self.names))
                self._maps[key] = ca.Function("newton", [wf, p], [solver(wf, p)])
            else:  # the square system's residual and its Jacobian (row-major, dense) at w_free
                wf, p = ca.SX.sym("wf", len(free)), ca.SX.sym("p", 2 + len(self.names))
                r = self._square[active](wf, p)
                J = ca.densify(ca.jacobian(r, wf))
                self._maps[key] = ca.Function("newton_system", [wf, p], [r, ca.vec(J.T)], {"cse": True})
        return self._maps[key]

    def mapped(self, kind: str, active: frozenset, m: int) -> ca.Function:
        """:meth:`function` mapped over ``m`` points on CasADi's virtual machine (``parallel``: CasADi's map
        mode), built once per size."""
        key = (kind, active, m, self.parallel)
        if key not in self._maps:
            f = self.function(kind, active)
            self._maps[key] = f.map(m, self.parallel, self.threads) if self.parallel != "serial" else f.map(m)
            sized = [k for k in self._maps if len(k) == 4]
            if len(sized) > 32:  # keep the cache small: sizes of the fallback passes vary
                self._maps.pop(sized[0])
        return self._maps[key]

    def compiled(self, kind: str, active: frozenset) -> ca.Function | None:
        """:meth:`function` mapped over ``block`` points and compiled to C (:func:`compiled_map`, in the map
        mode ``parallel``), built or loaded once; None without a C compiler."""
        key = (kind, active, self.block, self.parallel)
        if key not in self._compiled:
            self._compiled[key] = compiled_map(self.function(kind, active), self.block, self.parallel, self.threads)
        return self._compiled[key]

    def evaluate(self, kind: str, active: frozenset, *rows: np.ndarray) -> list[np.ndarray]:
        """:meth:`function` on every row of ``rows`` (points x entries each) by :func:`call_rows`: batches of
        COMPILED_MIN points or more (with ``jit``) by the compiled map (:meth:`compiled`), block after block,
        the last one padded with copies of its last point; the others on the virtual machine in chunks of at
        most ``chunk`` points: a CasADi map takes time to build in proportion to its size (about 3 us per
        point), so one map of the chunk size is built once and called repeatedly, and a remainder is padded
        to a power of two.  Returns one array (points x entries) per output."""
        m = rows[0].shape[0]
        rows = [np.ascontiguousarray(r, dtype=float) for r in rows]
        f = self.function(kind, active)
        outs = [np.empty((m, f.nnz_out(j))) for j in range(f.n_out())]
        fc = self.compiled(kind, active) if self.jit and kind != "newton" and m >= COMPILED_MIN else None
        block = self.block if fc is not None else self.chunk
        for a in range(0, m, block):
            b = min(a + block, m)
            if fc is not None:
                fm, size = fc, block
            else:
                # the rootfinder's map is cheap to build and each point costs up to 50 iterations: never padded
                size = b - a if b - a == block or kind == "newton" else max(16, 1 << (b - a - 1).bit_length())
                fm = self.mapped(kind, active, size)
            if size == b - a:
                interrupt.call(call_rows, fm, *[r[a:b] for r in rows], out=[o[a:b] for o in outs])
            else:  # a remainder: padded with copies of its last point, so few sizes are built
                pad = [np.concatenate([r[a:b], np.repeat(r[b - 1:b], size - (b - a), axis=0)]) for r in rows]
                for o, v in zip(outs, interrupt.call(call_rows, fm, *pad), strict=True):
                    o[a:b] = v[:b - a]
        return outs

    def roots(self, active: frozenset, W0: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Newton's method on the square system (stops fixed as ``active`` says) at every point.

        Every iteration evaluates the residual and its exact Jacobian (CasADi, mapped) at the points
        still iterating and solves all their Newton systems at once (LAPACK LU with partial pivoting,
        batched), halving a step that does not reduce |r|; a point stops when all its balances
        satisfy |r| <= the ``newton.abstol`` solver option (as CasADi's rootfinder) or when its Jacobian is singular.
        The points still iterating after FAST_NEWTON_ITER evaluations (slow, e.g. a valve on its stop
        with almost no pressure drop) are solved again from their start by CasADi's rootfinder on the
        same system (its line search, at most 50 iterations).  No bounds.

        Parameters
        ----------
        active : frozenset of str
            The stops reached (their coordinates fixed on the stop); the other reactions are zero.
        W0 : ndarray (points x unknowns)
            Starts, full rows of unknowns (the fixed entries are overwritten).
        P : ndarray (points x (2 + len(names)))
            Rows [psi1, dpsi, theta], dimensionless.

        Returns
        -------
        ndarray (points x unknowns)
            The last iterate of every point, full rows, dimensionless.
        """
        free, fixed = self.free(active)
        W = np.array(W0, float)
        W[:, list(fixed)] = list(fixed.values())
        X = np.ascontiguousarray(W[:, free])
        n, k = len(free), len(W)
        norm_prev = np.full(k, np.inf)
        step = np.zeros((k, n))
        alpha = np.ones(k)
        rows = np.arange(k)
        for _ in range(FAST_NEWTON_ITER):
            r, J = self.evaluate("step", active, X[rows], P[rows])
            norm = np.sqrt((r * r).sum(axis=1))
            # backtracking as CasADi's Newton: a trial that does not reduce |r| is halved (down to 1/64)
            worse = ~(norm < norm_prev[rows]) & (alpha[rows] > 1 / 64)
            back = rows[worse]
            alpha[back] *= 0.5
            X[back] += alpha[back, None] * step[back]  # from x_prev - 2a dx to x_prev - a dx
            ahead = ~worse & (np.abs(r).max(axis=1) > solver_options.defaults["newton.abstol"])
            dx = _solve_each(J[ahead].reshape(-1, n, n), r[ahead])
            ok = np.all(np.isfinite(dx), axis=1)  # singular or not finite: the point stops where it is
            ahead[ahead] = ok
            fwd = rows[ahead]
            step[fwd] = dx[ok]
            alpha[fwd], norm_prev[fwd] = 1.0, norm[ahead]
            X[fwd] -= step[fwd]
            rows = np.concatenate([back, fwd])
            if rows.size == 0:
                break
        if rows.size:  # the few slow ones (valve nearly without pressure drop): CasADi's rootfinder, from the start
            X[rows] = self.evaluate("newton", active, W[rows][:, free], P[rows])[0]
        W[:, free] = X
        return W

    def solve(self, P: np.ndarray, attempts, tol: float = RESIDUAL_TOL) -> dict:
        """Roots at every point, trying stop sets in turn.

        Each attempt takes only the points not yet accepted: their start (with the stops fixed as
        the set says) is checked first and, where it is no root, :meth:`roots` runs from it.  A
        point is accepted when finite, inside the bounds and every balance's absolute residual is
        <= ``tol``.

        Parameters
        ----------
        P : ndarray (points x (2 + len(names)))
            Rows [psi1, dpsi, theta]: discharge ratio p1/p_B, margin (p_e - p1)/p_B and the groups
            ``names``, dimensionless.
        attempts : sequence of (frozenset, ndarray)
            (stop set, starts): the stops reached and full rows of unknowns per point.
        tol : float
            Largest absolute balance residual accepted (dimensionless).

        Returns
        -------
        dict
            ``W`` rows of unknowns, ``q`` throttle flows Q/(g1 p_B), ``psi`` pressures (psi_e, psi2,
            psi3, psi_cam), ``residual`` largest |r|, ``relative_residual`` largest |r| over its
            balance's largest term, ``valid`` (bool), ``active`` (index into ``attempts`` of the
            accepting attempt, -1 none); NaN rows where no attempt was accepted.
        """
        sys_ = self.system
        P = np.ascontiguousarray(P, dtype=float)
        n = P.shape[0]
        out = None  # W, q, psi, residual, relative residual: the first pass's arrays, the rejected rows blanked
        which = np.full(n, -1)
        todo = None  # indices of the points not accepted yet (None: all of them)

        def accept(Wk, active, k, tol):
            nonlocal todo, out
            r, rel, qk, pk, inside = self.evaluate("check", active, Wk, P if todo is None else P[todo])
            part = [Wk, qk, pk, r[:, 0], rel[:, 0]]
            ok = (inside[:, 0] == 2 * Wk.shape[1]) & (part[3] <= tol)  # finite, inside every bound, a root
            bad = ~ok
            if todo is None:  # the first pass: take the arrays as they are, blank the rejected points
                out, todo = part, np.flatnonzero(bad)
                if todo.size:
                    for a in out:
                        a[bad] = np.nan
                which[ok] = k
            else:
                idx = todo[ok]
                for a, v in zip(out, part, strict=True):
                    a[idx] = v[ok]
                which[idx] = k
                todo = todo[bad]

        for k, (active, starts) in enumerate(attempts):
            if todo is not None and todo.size == 0:
                break
            fixed = self.free(active)[1]
            start = np.array(starts if todo is None else starts[todo], float)
            start[:, list(fixed)] = list(fixed.values())
            # a start may be a root already (the closed form is exact when no stop is reached): accepted by
            # the Newton method's own first test, |r| <= its abstol, without a step
            accept(start, active, k, min(tol, solver_options.defaults["newton.abstol"]))
            if todo.size:
                accept(self.roots(active, starts[todo], P[todo]), active, k, tol)
        if out is None:  # no attempt
            out = [np.full((n, len(sys_.unknowns)), np.nan), np.full((n, len(sys_.throttles)), np.nan),
                   np.full((n, 4), np.nan), np.full(n, np.nan), np.full(n, np.nan)]
        W, q, psi, resid, relative = out
        return {"W": W, "q": q, "psi": psi, "residual": resid, "relative_residual": relative, "valid": which >= 0,
                "active": which}


class StaticsSolver:
    """IPOPT (and Newton) solvers of one device's static equations, built once, called many times."""

    def __init__(self, dev: DeviceDesign):
        self.design = dev
        self.parametric = ParametricStatics(dev.groups)  # the same balances, for the Newton solves
        self.system: StaticSystem = self.parametric.system
        n = len(self.system.unknowns)
        w = ca.SX.sym("w", n)
        p = ca.SX.sym("p", 2)  # psi1, dpsi
        r = self.system.residual(w, p[0], p[1])
        f = self.system.complementarity(w)
        self._w, self._p, self._r, self._f = w, p, r, f
        self._cold = ipopt.nlpsol("statics", w, p, f, r)
        self._warm = ipopt.nlpsol("statics_warm", w, p, f, r, warm=True)
        self._jacobian = ca.Function("balance_jacobian", [w, p], [ca.jacobian(r, w)])
        self._built: dict = {}  # solvers built on first use, by key

    # ---- single points ---------------------------------------------------------------------
    def ideal_guess(self, psi1s, dpsi: float) -> np.ndarray:
        """Rows of unknowns from the exact ideal-regulator closed form, vectorised over ``psi1s``."""
        return ideal_guess(self.design.groups, self.system.unknowns, psi1s, dpsi)

    def guess(self, psi1: float, dpsi: float) -> np.ndarray:
        """Initial point: the ideal-regulator closed form or, where the valve cannot pass that
        flow, the Newton root with the valve on its open stop; clipped into the bounds."""
        x = self.ideal_guess(psi1, dpsi)[0]
        lo, hi = np.array(self.system.lower, float), np.array(self.system.upper, float)
        if "r_valve" in self.system.stops:
            sat = self.newton(psi1, dpsi, np.clip(x, lo, hi), frozenset({"r_valve"}))
            if np.all(np.isfinite(sat)) and np.all(sat >= lo) and np.all(sat <= hi):
                x = sat
        return np.clip(x, lo + 1e-9, hi - 1e-9)

    def solve(self, psi1: float, dpsi: float, start: StaticPoint | None = None) -> StaticPoint:
        """Solve at discharge ratio ``psi1`` and margin ``dpsi``; warm-start from ``start``.

        Raises SolveError (with the solver status and the last iterate) if IPOPT fails.
        """
        args = self._bounds() | {"p": [psi1, dpsi]}
        if start is not None:
            res, point = self._solved(psi1, dpsi, ipopt.solve(self._warm, **args, x0=start.x, lam_x0=start.lam["x"],
                                                              lam_g0=start.lam["g"]))
            if res["success"] or self._stalled_at_root(point):
                return point
        res, point = self._solved(psi1, dpsi, ipopt.solve(self._cold, **args, x0=self.guess(psi1, dpsi)))
        if self._stalled_at_root(point):
            return point
        c = solver_options.get("continuation")
        if not res["success"] and start is None and psi1 > c["start"]:
            # homotopy in the discharge ratio from a low, regulated pressure, warm-started along the path
            try:
                return self.sweep(np.linspace(c["start"], psi1, c["steps"]), dpsi)[-1]
            except SolveError:
                pass
        if not res["success"]:
            raise SolveError(f"statics at psi1 = {psi1:g}, dpsi = {dpsi:g} did not converge",
                             res["status"], {"psi1": psi1, "dpsi": dpsi, **point.values})
        return point

    def newton(self, psi1: float, dpsi: float, start: np.ndarray | None = None,
               active: frozenset = frozenset()) -> np.ndarray:
        """Root of the same balances by Newton's method, as a square system
        (:meth:`ParametricStatics.roots`).

        Each stop is fixed as inactive (reaction 0) or, if named in ``active``, active
        (coordinate on its stop, reaction free).  No bounds; full vector of unknowns returned.
        """
        x0 = self.guess(psi1, dpsi) if start is None else start
        return self.parametric.roots(active, np.atleast_2d(x0), np.array([[psi1, dpsi]]))[0]

    def fast_sweep(self, psi1s, dpsi: float, tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
        """A sweep in one call: Newton roots of the no-stop system mapped over the grid from the
        vectorised closed-form guess (:meth:`ParametricStatics.solve`).  Points not accepted (not
        converged to ``tol`` relative, outside the bounds, i.e. needing a stop) are re-solved by
        IPOPT, warm-started along the grid.  Returns rows of unknowns and a flag per point: True
        where IPOPT was needed."""
        psi1s = np.asarray(psi1s, float)
        P = np.column_stack([psi1s, np.full(len(psi1s), dpsi)])
        sol = self.parametric.solve(P, [(frozenset(), self.ideal_guess(psi1s, dpsi))], tol=math.inf)
        X = sol["W"]
        with np.errstate(invalid="ignore"):
            ok = sol["valid"] & (sol["relative_residual"] <= tol)
        prev = None
        for i in np.flatnonzero(~ok):
            prev = self.solve(float(psi1s[i]), dpsi, prev if i > 0 and not ok[i - 1] else None)
            X[i] = prev.x
        return X, ~ok

    def sweep(self, psi1s, dpsi: float) -> list[StaticPoint]:
        """Continuation over discharge ratio: each point warm-started from the previous one."""
        points, prev = [], None
        for s in np.asarray(psi1s, float):
            prev = self.solve(float(s), dpsi, prev)
            points.append(prev)
        return points

    def batch(self, psi1s, dpsi: float) -> tuple[np.ndarray, dict]:
        """The whole sweep as one NLP (the point equations mapped over the grid); rows of x."""
        psi1s = np.asarray(psi1s, float)
        m, n = len(psi1s), len(self.system.unknowns)
        if m not in self._built:
            W = ca.SX.sym("W", n, m)
            P = ca.SX.sym("P", m + 1)
            one = ca.Function("point", [self._w, self._p], [self._r])
            g = one.map(m)(W, ca.vertcat(P[:m].T, ca.repmat(P[m], 1, m)))
            f = ca.Function("stops", [self._w], [self._f]).map(m)(W)
            self._built[m] = ipopt.nlpsol("statics_batch", ca.vec(W), P, ca.sum2(f), ca.vec(g))
        b = self._bounds()
        x0 = np.concatenate([self.guess(s, dpsi) for s in psi1s])
        res = self._check(ipopt.solve(self._built[m], x0=x0, p=np.append(psi1s, dpsi),
                                      lbx=np.tile(b["lbx"], m), ubx=np.tile(b["ubx"], m), lbg=0, ubg=0), m)
        if not res["success"]:
            raise SolveError(f"batch statics over {m} points did not converge", res["status"])
        return res["x"].reshape(m, n), res

    # ---- derived quantities ----------------------------------------------------------------
    def stiffness(self, pt: StaticPoint) -> float:
        """Exact static stiffness kappa_s = -d phi/d u at fixed psi1 (2.33), phi = sigma (psi2 - psi3).

        All balances but the disc's force balance are held while u varies, the regulator's stop
        as it stands: the implicit-function derivative of the square system.  NaN in contact.
        """
        if pt.contact:
            return float("nan")
        return float(self.system.stiffness(np.asarray(self._jacobian(pt.x, [pt.psi1, pt.dpsi])), pt.active))

    def force_gap(self, psi1: float, dpsi: float, us) -> np.ndarray:
        """Balancing force phi = sigma (psi2 - psi3) against a prescribed gap u at fixed psi1:
        the static characteristic (2.35) from the exact flow network (disc force balance left
        out), by IPOPT continuation along ``us``; a point counts only if its balances (all but the
        disc force) hold to :data:`MAX_RELATIVE_RESIDUAL` (else SolveError ``Residual_Above_Tolerance``)."""
        sys_ = self.system
        rows = [i for i, e in enumerate(sys_.equations) if e != "disc force"]
        if "force_gap" not in self._built:
            self._built["force_gap"] = ipopt.nlpsol("force_gap", self._w, self._p, self._f, self._r[rows])
        solver, iu = self._built["force_gap"], sys_.index("u")
        x = self.solve(psi1, dpsi).x
        phi = []
        for u in np.asarray(us, float):
            b = self._bounds()
            b["lbx"][iu] = b["ubx"][iu] = u
            x[iu] = u
            res = self._check(ipopt.solve(solver, **b, x0=x, p=[psi1, dpsi]))
            if not res["success"]:
                raise SolveError(f"force-gap characteristic at u = {u:g} did not converge", res["status"])
            worst = float(np.max(self.relative_residual(np.asarray(res["x"], float).ravel(), psi1, dpsi)[rows]))
            if not worst <= MAX_RELATIVE_RESIDUAL:
                raise SolveError(f"force-gap characteristic at u = {u:g}: the balances do not hold",
                                 f"Residual_Above_Tolerance ({worst:.1e} relative, IPOPT said {res['status']})")
            x = res["x"]
            phi.append(self.design.groups.sigma * (x[sys_.index("psi2")] - x[sys_.index("psi3")]))
        return np.array(phi)

    def critical(self, unknown: str, fixed: float, guess: float) -> StaticPoint:
        """Exact state where the inner-seal flow q1 vanishes (onset of flow reversal).

        unknown = "psi1": the critical discharge ratio psi1_kr at margin ``fixed`` (cf. (2.32));
        unknown = "dpsi": the critical margin dpsi_kr at discharge ratio ``fixed`` (cf. (2.31)).
        """
        sys_ = self.system
        s = ca.SX.sym("s")
        psi1, dpsi = (s, fixed) if unknown == "psi1" else (fixed, s)
        q1 = sys_.flows(self._w, psi1, dpsi)[0][sys_.throttles.index("1")]
        g = ca.vertcat(sys_.residual(self._w, psi1, dpsi), q1)
        solver = ipopt.nlpsol("critical", ca.vertcat(self._w, s), ca.SX.sym("none", 0), self._f, g)
        start = (guess, fixed) if unknown == "psi1" else (fixed, guess)
        b = self._bounds()
        res = self._check(ipopt.solve(solver, x0=np.append(self.guess(*start), guess), lbg=0, ubg=0,
                                      lbx=np.append(b["lbx"], 1e-6), ubx=np.append(b["ubx"], np.inf)))
        if not res["success"]:
            raise SolveError(f"critical {unknown} (q1 = 0) did not converge", res["status"])
        value = float(res["x"][-1])
        res |= {"x": res["x"][:-1], "lam_x": res["lam_x"][:-1], "lam_g": res["lam_g"][:-1]}
        point = self._point(*((value, fixed) if unknown == "psi1" else (fixed, value)), res)
        if not point.max_residual <= MAX_RELATIVE_RESIDUAL:
            raise SolveError(f"critical {unknown} (q1 = 0): the balances do not hold", f"Residual_Above_Tolerance "
                             f"({point.max_residual:.1e} relative, IPOPT said {res['status']})")
        return point

    def relative_residual(self, x: np.ndarray, psi1, dpsi: float) -> np.ndarray:
        """Each balance's residual divided by its largest term; rows of ``x`` for arrays of psi1
        (:meth:`ParametricStatics.relative`)."""
        X = np.atleast_2d(x)
        P = np.column_stack([np.broadcast_to(psi1, len(X)), np.full(len(X), dpsi)])
        out = self.parametric.evaluate("relative", frozenset(), X, P)[0]
        return out[0] if np.ndim(x) == 1 else out

    # ---- internals ---------------------------------------------------------------------------
    @staticmethod
    def _stalled_at_root(point: StaticPoint) -> bool:
        """IPOPT stopped for a too small search direction at a root to :data:`STALLED_RESIDUAL`."""
        return point.status == "Search_Direction_Becomes_Too_Small" and point.max_residual <= STALLED_RESIDUAL

    def _bounds(self) -> dict:
        lo, hi = np.array(self.system.lower, float), np.array(self.system.upper, float)
        return {"lbx": lo, "ubx": hi, "lbg": 0, "ubg": 0}

    def _check(self, res: dict, points: int = 1) -> dict:
        """A solve counts only if the stops' complementarity is zero too (per point)."""
        if res["success"] and res["f"][0] > COMPLEMENTARITY_TOL * points:
            res |= {"success": False, "status": f"Stop_Complementarity_Violated ({res['f'][0]:.1e})"}
        return res

    def _solved(self, psi1: float, dpsi: float, res: dict) -> tuple[dict, StaticPoint]:
        """IPOPT's answer checked (:meth:`_check`) and its point; a success whose balances are not satisfied to
        :data:`MAX_RELATIVE_RESIDUAL` is not one (status ``Residual_Above_Tolerance``)."""
        res = self._check(res)
        point = self._point(psi1, dpsi, res)
        if res["success"] and not point.max_residual <= MAX_RELATIVE_RESIDUAL:
            res |= {"success": False, "status": f"Residual_Above_Tolerance ({point.max_residual:.1e} relative, "
                                                f"IPOPT said {res['status']})"}
            point.status = res["status"]
        return res, point

    def _point(self, psi1: float, dpsi: float, res: dict) -> StaticPoint:
        sys_ = self.system
        x = res["x"]
        q, _ = sys_.flows(x, psi1, dpsi)
        vals = dict(zip(sys_.unknowns, map(float, x), strict=True))
        vals.setdefault("psi_e", psi1 + dpsi)
        return StaticPoint(
            psi1=psi1, dpsi=dpsi, x=x, values=vals,
            flows=dict(zip(sys_.throttles, map(float, np.asarray(q).ravel()), strict=True)),
            status=res["status"], iterations=res["iterations"],
            max_residual=float(self.relative_residual(x, psi1, dpsi).max()),
            lam={"x": res["lam_x"], "g": res["lam_g"]},
        )
