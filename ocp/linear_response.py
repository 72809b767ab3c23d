"""The Jeffcott rotor's response to a given piecewise-constant speed profile without an ODE solver: the spin-up
explorer's per-change re-simulation (CVODES, :func:`autobal.ocp.simulation.resimulate`, stays the cross-check).

With the speed profile given, the rotor is linear in its state.  In the fixed frame (``ode_fixed`` of
:func:`autobal.models.rotor.rotor_model`, Pashkov (2010), Eq. (2) with u = w e^{i beta}) the shaft centre u = X + iY
obeys (u, u')' = A (u, u') + b f(tau): A constant (stiffness and damping), f the unbalance forcing
f0(nu, a*) e^{i beta}, nu piecewise linear and beta piecewise quadratic along the profile.  Over a step of length d

    (u, u')(t + d) = e^{A d} (u, u')(t) + int_0^d e^{A (d - s)} b f(t + s) ds     (Duhamel, exact),

done in A's modes (A = V diag(lambda) V^-1): each mode a first-order recurrence z+ = e^{lambda d} z + g (a linear
filter over the steps), g the integral by n-point Gauss-Legendre.  Its error per step is at most
d^{2n+1} (n!)^4 / ((2n+1) ((2n)!)^3) max |g^{(2n)}| (Davis & Rabinowitz (1984), Eq. (2.7.12)), the derivative bounded
by Cauchy's estimate on a disc of radius r around the step (the integrand is entire:
|g^{(2n)}| <= (2n)! r^{-2n} max_disc |g|); n and the number of steps per sample are chosen so that the steps' bounds
add up (the modes decay, Re lambda <= 0) to at most ``tol`` in the deflection delta/e.

A, b and f0 are read off the model's CasADi expressions (its Jacobian in the state, its forcing at zero deflection,
checked to be quadratic in (nu, a*) and to turn with beta), so the equation stays in models/ once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import casadi as ca
import numpy as np

from autobal.ocp.problem import SpinupOcp
from autobal.ocp.simulation import Trajectory, trajectory

TOL = 1e-11  # bound on the error of delta/e (absolute) of the response


@dataclass(frozen=True)
class FixedFrame:
    """The fixed-frame model as a linear system: ``A(p)`` (2x2, on (u, u')), the input column ``b(p)`` and the
    forcing at beta = 0, ``f0(nu, a*, p)`` (complex), as CasADi Functions of the model's parameters."""

    A: ca.Function
    b: ca.Function
    f0: ca.Function


@cache
def fixed_frame() -> FixedFrame:
    """The rotor's fixed-frame equation split into A, b and f0 (see the module docstring); raises ValueError when
    the model is not of that form (then the response needs an ODE solver)."""
    from autobal.models.rotor import NP, rotor_model

    ode = rotor_model().ode_fixed
    Q, a, p = ca.SX.sym("Q", 6), ca.SX.sym("a"), ca.SX.sym("p", NP)
    rhs = ode(Q, a, p)
    x, nu, beta = Q[:4], Q[4], Q[5]
    J = ca.jacobian(rhs[:4], x)
    forcing = ca.substitute(rhs[:4], x, ca.DM.zeros(4))
    # the linear part does not depend on the speed or the angle, and X and Y obey the same equation
    for s in (x, nu, beta, a):
        if not ca.jacobian(J, s).is_zero():
            raise ValueError("the fixed-frame model is not linear with constant coefficients in its state")
    iso = ca.Function("iso", [p], [J[[0, 2], [0, 2]] - J[[1, 3], [1, 3]], J[[0, 2], [1, 3]], J[[1, 3], [0, 2]]])
    rng = np.random.default_rng(0)
    pt = rng.uniform(0.2, 1.0, NP)
    if max(float(ca.norm_inf(m)) for m in iso(pt)) > 0 or float(ca.norm_inf(forcing[:2])) != 0:
        raise ValueError("the fixed-frame model is not isotropic with the forcing on the velocities")
    fx, fy = forcing[2], forcing[3]
    grad = ca.jacobian(ca.vertcat(fx, fy), ca.vertcat(nu, a))
    for s in (nu, a):  # quadratic in (nu, a*): the third derivatives vanish
        if not ca.jacobian(ca.jacobian(grad, s), ca.vertcat(nu, a)).is_zero():
            raise ValueError("the rotor's forcing is not quadratic in the speed and the acceleration")
    at0 = ca.Function("f", [nu, a, beta, p], [fx, fy])
    nu_t, a_t = rng.uniform(0.5, 2.0, 2)  # the forcing turns with beta: f(beta) = f(0) e^{i beta}
    f_0, f_q = (complex(*map(float, at0(nu_t, a_t, b_, pt))) for b_ in (0.0, math.pi / 2))
    if abs(f_q - 1j * f_0) > 1e-12 * abs(f_0):
        raise ValueError("the rotor's forcing does not turn with the rotation angle")
    f0 = ca.Function("f0", [nu, a, p], [ca.substitute(ca.vertcat(fx, fy), beta, 0)])
    A = ca.Function("A", [p], [J[[0, 2], [0, 2]]])
    return FixedFrame(A, ca.Function("b", [p], [ca.DM([0, 1])]), f0)


def _coefficients(f0: ca.Function, p) -> np.ndarray:
    """f0 = c0 + c1 nu + c2 a* + c3 nu^2 + c4 nu a* + c5 a*^2 (complex), by its values at six points (exact for a
    quadratic, checked in :func:`fixed_frame`)."""
    pts = np.array([[0, 0], [1, 0], [0, 1], [-1, 0], [1, 1], [0, -1]], float)
    vals = np.array(f0.map(6)(pts[:, 0][None, :], pts[:, 1][None, :], p))
    f = vals[0] + 1j * vals[1]
    M = np.column_stack([np.ones(6), pts[:, 0], pts[:, 1], pts[:, 0] ** 2, pts[:, 0] * pts[:, 1], pts[:, 1] ** 2])
    return np.linalg.solve(M, f)


def modes(ocp: SpinupOcp) -> tuple:
    """A's eigenvalues lambda, eigenvectors V, V^-1 and the input in the modes V^-1 b for the rotor of ``ocp``;
    ValueError for a (nearly) critically damped rotor, whose A has no two independent eigenvectors."""
    ff = fixed_frame()
    lam, V = np.linalg.eig(np.array(ff.A(ocp.p)))
    if abs(lam[0] - lam[1]) < 1e-3 * max(abs(lam[0]), 1.0):  # V ill-conditioned (near critical damping)
        raise ValueError("a critically damped rotor: A has a double eigenvalue")
    Vi = np.linalg.inv(V)
    return lam, V, Vi, Vi @ np.array(ff.b(ocp.p)).ravel()


@cache
def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def gauss_bound(n: int, d: float, lam: float, nu: float, a: float, coef) -> float:
    """Bound on the n-point Gauss-Legendre error of int_0^d e^{lambda (d - s)} f0(nu(s), a*) e^{i beta(s)} ds, both
    parts of the complex value (Re lambda <= 0, |lambda| <= ``lam``, |nu| <= ``nu``, |a*| <= ``a``, f0's
    coefficients ``coef``): the remainder with Cauchy's estimate on a disc of radius r = 2n / (lam + nu), where
    |e^{lambda (d - z)}| <= e^{lam r}, |e^{i beta(z)}| <= e^{nu r + a r^2 / 2} and |nu(z)| <= nu + a r."""
    r = 2 * n / (lam + nu)
    disc = _f0_bound(coef, nu + a * r, a) * math.exp(lam * r + nu * r + a * r * r / 2)
    return (2 * d ** (2 * n + 1) * math.factorial(n) ** 4 / ((2 * n + 1) * math.factorial(2 * n) ** 2)
            * r ** (-2 * n) * disc)


def _f0_bound(coef, nu: float, a: float) -> float:
    """max |f0| over |nu| <= ``nu``, |a*| <= ``a``."""
    return float(np.abs(coef) @ np.array([1, nu, a, nu * nu, nu * a, a * a]))


def response(ocp: SpinupOcp, u, h, points: int, tol: float = TOL) -> tuple[np.ndarray, float]:
    """The states (K, points, nx) of the rotating frame (as :func:`autobal.ocp.simulation.simulate_profile` gives
    them) at the ends of ``points`` equal parts of each interval h (tau) of the piecewise-constant acceleration u
    (over alpha_max), from ``ocp.q0``; and the bound on the error of delta/e its quadrature keeps (<= ``tol``)."""
    lam, V, Vi, c = modes(ocp)
    coef = _coefficients(fixed_frame().f0, ocp.p)
    u, h = np.asarray(u, float), np.asarray(h, float)
    K = len(u)
    a = u * ocp.a_max
    q0 = np.asarray(ocp.q0, float)
    nu_k = q0[4] + np.concatenate([[0.0], np.cumsum(a * h)[:-1]])  # the speed and the angle at each interval's start
    beta_k = np.concatenate([[0.0], np.cumsum(nu_k * h + a * h * h / 2)[:-1]])
    # the quadrature: the fewest nodes and parts of a sample whose bounds add up to tol (in u, through V)
    lam_abs, nu_max, a_abs = float(np.max(np.abs(lam))), float(np.max(np.abs(np.append(nu_k, nu_k + a * h)))), \
        float(np.max(np.abs(a)))
    scale = float(np.abs(V[0]) @ np.abs(c))  # |u| per unit of the modal integrals' error (|e^{lambda t}| <= 1)
    d_max = float(np.max(h)) / points
    parts, n = 1, None
    while n is None:
        steps = K * points * parts
        n = next((k for k in range(2, 9) if steps * scale * gauss_bound(k, d_max / parts, lam_abs, nu_max, a_abs, coef)
                  <= tol), None)
        parts = parts if n is not None else 2 * parts
    bound = steps * scale * gauss_bound(n, d_max / parts, lam_abs, nu_max, a_abs, coef)
    m = points * parts  # steps per interval
    xi, w = _gauss(n)
    d = h / m  # the step length in each interval
    # the nodes from each interval's start, (K, m, n); the forcing there
    s = (np.arange(m)[None, :, None] + (1 + xi[None, None, :]) / 2) * d[:, None, None]
    nu, ak = nu_k[:, None, None] + a[:, None, None] * s, a[:, None, None]
    f = (coef[0] + coef[1] * nu + coef[2] * ak + coef[3] * nu * nu + coef[4] * nu * ak + coef[5] * ak * ak) \
        * np.exp(1j * (beta_k[:, None, None] + (nu_k[:, None, None] + ak * s / 2) * s))
    # the start: u = w e^{i beta}, beta = 0; u' = w' + i nu w
    w0 = q0[0] + 1j * q0[1]
    z = Vi @ np.array([w0, q0[2] + 1j * q0[3] + 1j * q0[4] * w0])
    # each step's integral in the modes: c_j sum_i (d w_i / 2) e^{lambda_j d (1 - xi_i) / 2} f(node i), (2, K, m)
    kern = c[:, None, None] * d[None, :, None] * w / 2 * np.exp(lam[:, None, None] * d[None, :, None] * (1 - xi) / 2)
    g = np.einsum("jkn,kin->jki", kern, f)
    # z+ = e^{lambda d} z + g step by step, within an interval as z_i = e^{lambda i d} (z_0 + sum_{j < i} e^{-lambda
    # j d} g_j) (i = 1 .. m, exact: the steps are equal), the intervals' starts in turn
    grow = np.exp(lam[:, None, None] * d[None, :, None] * np.arange(1, m + 1))  # (2, K, m)
    acc = np.cumsum(g / grow, axis=2)
    z_k = np.empty((2, K), complex)
    for k in range(K):
        z_k[:, k] = z
        z = grow[:, k, -1] * (z + acc[:, k, -1])
    zs = (grow * (z_k[:, :, None] + acc))[:, :, parts - 1::parts].reshape(2, K * points)
    uu = [V[r, 0] * zs[0] + V[r, 1] * zs[1] for r in range(2)]  # (u, u') at the samples
    tk = np.repeat(np.arange(K), points)
    sk = np.tile(np.arange(1, points + 1), K) * np.repeat(h / points, points)
    nu_s = nu_k[tk] + a[tk] * sk
    rot = np.exp(-1j * (beta_k[tk] + nu_k[tk] * sk + a[tk] * sk * sk / 2))
    ws = uu[0] * rot
    dws = uu[1] * rot - 1j * nu_s * ws
    q = np.stack([ws.real, ws.imag, dws.real, dws.imag, nu_s], axis=-1)
    return q.reshape(K, points, 5), bound


#: elementwise numpy functions of CasADi's scalar operations (:func:`vectorised`)
_OPS = {ca.OP_ASSIGN: lambda x: x, ca.OP_ADD: np.add, ca.OP_SUB: np.subtract, ca.OP_MUL: np.multiply,
        ca.OP_DIV: np.divide, ca.OP_NEG: np.negative, ca.OP_SQ: np.square, ca.OP_TWICE: lambda x: 2 * x,
        ca.OP_INV: np.reciprocal, ca.OP_SQRT: np.sqrt, ca.OP_SIN: np.sin, ca.OP_COS: np.cos, ca.OP_EXP: np.exp,
        ca.OP_FABS: np.abs, ca.OP_POW: np.power, ca.OP_CONSTPOW: np.power, ca.OP_HYPOT: np.hypot}


@cache
def vectorised(f: ca.Function):
    """``f`` (an SX Function of dense inputs with one output) evaluated by numpy on arrays of points, instruction by
    instruction (the same operations as CasADi's virtual machine, on whole arrays): ``call(*args)``, each input
    indexable by its entries (an array (rows, points), or a sequence of scalars: broadcast), returns the output's
    rows, shape (rows, points)."""
    if not f.is_a("SXFunction") or f.n_out() != 1 or not all(f.sparsity_in(i).is_dense() for i in range(f.n_in())):
        raise ValueError(f"{f.name()}: not an SX Function of dense inputs with one output")
    prog = [(f.instruction_id(k), f.instruction_input(k), f.instruction_output(k),
             f.instruction_constant(k) if f.instruction_id(k) == ca.OP_CONST else None)
            for k in range(f.n_instructions())]
    if unknown := {op for op, *_ in prog} - set(_OPS) - {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST}:
        raise ValueError(f"{f.name()}: operations {sorted(unknown)} have no numpy function here")
    rows = f.size1_out(0)

    def call(*args):
        work, out = {}, [0.0] * rows
        for op, i, o, const in prog:
            if op == ca.OP_INPUT:
                work[o[0]] = args[i[0]][i[1]]
            elif op == ca.OP_OUTPUT:
                out[o[1]] = work[i[0]]
            elif op == ca.OP_CONST:
                work[o[0]] = const
            else:
                work[o[0]] = _OPS[op](*(work[j] for j in i[:1 if op in _UNARY else 2]))
        return np.array(np.broadcast_arrays(*out))

    return call


_UNARY = {ca.OP_ASSIGN, ca.OP_NEG, ca.OP_SQ, ca.OP_TWICE, ca.OP_INV, ca.OP_SQRT, ca.OP_SIN, ca.OP_COS, ca.OP_EXP,
          ca.OP_FABS}


def torque(q: np.ndarray, a: np.ndarray, p) -> np.ndarray:
    """The model's drive torque M~ (:func:`autobal.models.rotor.rotor_model`'s ``torque``) at the states q (nx, N) and
    accelerations a (1, N), by :func:`vectorised`."""
    from autobal.models.rotor import rotor_model

    return vectorised(rotor_model().torque)(q, a, p)[0]


def resimulate(ocp: SpinupOcp, u, h, label: str, points: int | None = None, tol: float = TOL) -> Trajectory:
    """:func:`autobal.ocp.simulation.resimulate` by :func:`response`: the same samples, the same Trajectory."""
    from autobal.analysis.run import solver_options

    points = solver_options.defaults["resimulation.points"] if points is None else points
    return trajectory(ocp, u, h, label, response(ocp, u, h, points, tol)[0], torque)
