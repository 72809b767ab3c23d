"""A fixed-step, L-stable Rosenbrock integrator (RODAS4) written once as a CasADi Function over its steps, for
measuring what a compiled integrator without step-size logic costs on the stiff transient benchmark.

Method: RODAS4 of Hairer & Wanner (1996), *Solving Ordinary Differential Equations II*, Sect. IV.7
(coefficients of their code rodas.f, METH = 1): six stages, order 4, stiffly accurate and L-stable, with an
embedded order-3 solution whose difference (the last stage) is the local error estimate.  Each stage solves
``(I / (h gamma) - J) g_i = f(x + sum_j a_ij g_j) + sum_j (c_ij / h) g_j`` with the exact Jacobian ``J`` at the
start of the step; the LU factors of that matrix are written out symbolically (no pivoting; the final-error check
of the benchmark is what vouches for it), so the structural zeros of the Jacobian drop out of the code.

Measurement code only: the toolkit's transient analysis integrates with CVODES.
"""

from __future__ import annotations

import casadi as ca

GAMMA = 0.25
# a_ij (stage arguments) and c_ij (stage right-hand sides), rows i = 2..6 of rodas.f's ROCOE (METH = 1)
A = [[],
     [1.544],
     [0.9466785280815826, 0.2557011698983284],
     [3.314825187068521, 2.896124015972201, 0.9986419139977817],
     [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950],
     [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950, 1.0]]
C = [[],
     [-5.6688],
     [-2.430093356833875, -0.2063599157091915],
     [-0.1073529058151375, -9.594562251023355, -20.47028614809616],
     [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160],
     [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136, -6.058818238834054]]


def _lu_solver(W: ca.SX):
    """A solve with the square SX matrix ``W`` through its LU factors, written out once (Doolittle, no pivoting)."""
    n = W.shape[0]
    U = [[W[i, j] for j in range(n)] for i in range(n)]
    L = [[None] * n for _ in range(n)]
    for k in range(n):
        for i in range(k + 1, n):
            L[i][k] = U[i][k] / U[k][k]
            for j in range(k + 1, n):
                U[i][j] = U[i][j] - L[i][k] * U[k][j]

    def solve(b: ca.SX) -> ca.SX:
        y = [b[i] for i in range(n)]
        for i in range(n):
            for k in range(i):
                y[i] = y[i] - L[i][k] * y[k]
        for i in reversed(range(n)):
            for k in range(i + 1, n):
                y[i] = y[i] - U[i][k] * y[k]
            y[i] = y[i] / U[i][i]
        return ca.vertcat(*y)

    return solve


def rodas4_step(rhs: ca.Function) -> ca.Function:
    """One RODAS4 step of the autonomous ODE ``x' = rhs(x)``.

    Parameters
    ----------
    rhs : casadi.Function
        ``x -> dx/dt`` (one dense column input and output, any units; SX-expandable).

    Returns
    -------
    casadi.Function
        ``(x, h) -> (x_next, err)``: the state after a step of ``h`` (units of the time in ``rhs``) and the
        embedded local error estimate, the last stage (a vector, units of ``x``).
    """
    n = rhs.size1_in(0)
    x, h = ca.SX.sym("x", n), ca.SX.sym("h")
    fx = rhs(x)
    solve = _lu_solver(ca.densify(ca.SX.eye(n) / (h * GAMMA) - ca.jacobian(fx, x)))
    g = []
    for i in range(6):
        u = x + sum((a * gj for a, gj in zip(A[i], g, strict=True)), ca.SX.zeros(n))
        coupling = sum((c / h * gj for c, gj in zip(C[i], g, strict=True)), ca.SX.zeros(n))
        g.append(solve((fx if i == 0 else rhs(u)) + coupling))
    return ca.Function("rodas4_step", [x, h], [u + g[5], g[5]], ["x", "h"], ["x_next", "err"])


def rodas4_fixed(rhs: ca.Function, n_steps: int, t_end: float) -> ca.Function:
    """RODAS4 over ``n_steps`` equal steps from 0 to ``t_end`` as one Function (CasADi's ``mapaccum``: a loop in
    the generated code).

    Parameters
    ----------
    rhs : casadi.Function
        ``x -> dx/dt`` of the autonomous ODE.
    n_steps : int
        Number of steps.
    t_end : float
        Final time, units of the time in ``rhs`` (s).

    Returns
    -------
    casadi.Function
        ``x0 -> (xf, est_max, est_sum)``: the final state, the largest and the summed embedded local error
        estimates over the steps (max over the states), units of ``x``.
    """
    n = rhs.size1_in(0)
    x, h = ca.SX.sym("x", n), ca.SX.sym("h")
    x_next, err = rodas4_step(rhs)(x, h)
    step = ca.Function("rodas4_step_max", [x, h], [x_next, ca.mmax(ca.fabs(err))])
    x0 = ca.MX.sym("x0", n)
    xs, errs = step.mapaccum("rodas4_steps", n_steps, [0], [0])(x0, ca.DM.ones(1, n_steps) * (t_end / n_steps))
    return ca.Function(f"rodas4_{n_steps}", [x0], [xs[:, -1], ca.mmax(errs), ca.sum2(errs)], ["x0"],
                       ["xf", "est_max", "est_sum"])


def rodas4_adaptive(rhs: ca.Function, t_end: float, rtol: float, atol: float, attempts: int) -> ca.Function:
    """RODAS4 with step-size control on its embedded error estimate, as one Function of ``attempts`` step attempts
    (``mapaccum``), each skipped once ``t_end`` is reached (CasADi's conditional: a branch in the generated code,
    so spare attempts cost almost nothing); call it again from where it stopped while ``t < t_end``.  Error norm:
    the root mean square of ``err / (atol + rtol max(|x|, |x_next|))``; a step is accepted when it is at most 1;
    the next step is this one times ``min(6, max(0.2, 0.9 norm^(-1/4)))`` (Hairer & Wanner 1996, Sect. IV.8).

    Parameters
    ----------
    rhs : casadi.Function
        ``x -> dx/dt`` of the autonomous ODE.
    t_end : float
        Final time, units of the time in ``rhs`` (s).
    rtol, atol : float
        Relative tolerance (-) and absolute tolerance (units of ``x``).
    attempts : int
        Step attempts (accepted plus rejected) in one call.

    Returns
    -------
    casadi.Function
        ``(x0, t0, h0) -> (xf, t, h, accepted, rejected)``: the state at time ``t`` (``t_end`` unless the attempts
        ran out), the next step size (units of time), and the numbers of accepted and rejected steps.
    """
    n = rhs.size1_in(0)
    step = rodas4_step(rhs)
    z = ca.SX.sym("z", n + 4)  # t, h, accepted, rejected, x
    t, h, x = z[0], z[1], z[4:]
    hu = ca.fmin(h, t_end - t)
    x_next, err = step(x, hu)
    norm = ca.fmax(ca.sqrt(ca.sumsqr(err / (atol + rtol * ca.fmax(ca.fabs(x), ca.fabs(x_next)))) / n), 1e-10)
    ok = norm <= 1
    attempt = ca.Function("attempt", [z], [ca.vertcat(ca.if_else(ok, t + hu, t),
                                                      hu * ca.fmin(6.0, ca.fmax(0.2, 0.9 * norm ** -0.25)),
                                                      z[2] + ok, z[3] + 1 - ok, ca.if_else(ok, x_next, x))])
    zz = ca.SX.sym("z", n + 4)
    skip = ca.Function.conditional("attempt_or_skip", [attempt], ca.Function("skip", [zz], [zz]))
    zm = ca.MX.sym("z", n + 4)
    loop = ca.Function("attempt_loop", [zm], [skip(t_end - zm[0] <= 1e-12 * t_end, zm)]).mapaccum("attempts", attempts)
    x0, t0, h0 = ca.MX.sym("x0", n), ca.MX.sym("t0"), ca.MX.sym("h0")
    zf = loop(ca.vertcat(t0, h0, 0.0, 0.0, x0))[:, -1]
    return ca.Function("rodas4_adaptive", [x0, t0, h0], [zf[4:], zf[0], zf[1], zf[2], zf[3]], ["x0", "t0", "h0"],
                       ["xf", "t", "h", "accepted", "rejected"])
