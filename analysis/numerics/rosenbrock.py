"""RODAS4, an L-stable Rosenbrock method, written once as CasADi Functions: one step, a fixed-step run and an
adaptive run on an output grid whose loop of step attempts can be compiled to C (analysis/numerics/compiled.py).

Method: RODAS4 of Hairer & Wanner (1996), *Solving Ordinary Differential Equations II*, Sect. IV.7
(coefficients of their code rodas.f, METH = 1): six stages, order 4, stiffly accurate and L-stable, with an
embedded order-3 solution whose difference (the last stage) is the local error estimate.  Each stage solves
``(I / (h gamma) - J) g_i = F(z + sum_j a_ij g_j) + sum_j (c_ij / h) g_j`` with the exact Jacobian ``J`` at the
start of the step; a non-autonomous ``x' = f(t, x, p)`` is integrated as the autonomous system of ``z = (x, t)``,
``t' = 1`` (Hairer & Wanner 1996, Sect. IV.7, the autonomous form from which Eq. (7.4') follows), so the time
derivative of ``f`` enters through the Jacobian.  The matrix is factored once a step, written out
symbolically so that the structural zeros of the Jacobian drop out of the code: by LU without pivoting
(default) with its growth factor max |U_ij| / max |W_ij| as a check (partial pivoting keeps it near 1;
above ``GROWTH_MAX``, or not finite, the adaptive loop rejects the step, and a smaller step makes the matrix
diagonally dominant, where no pivoting is needed), or by Householder QR (CasADi's ``qr_sparse``: stable
without pivoting, 1.4x the instructions; on the pump's 8-state model 141 compiled steps take 0.137 ms against
0.094 ms with LU).  Step-size control: Hairer & Wanner (1996), Sect. IV.8, Eq. (8.21)
with the error norm of Sect. II.4, Eq. (4.11).
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
# RODASP of Steinebach (1995), "Order-reduction of ROW-methods for DAEs and method of lines applications",
# Preprint 1741, TH Darmstadt: the same structure and gamma, coefficients chosen against the order reduction of a
# stiff component driven by a time-dependent input (tests: order 3 against RODAS4's 1 on the Prothero-Robinson
# problem, order 4 against 2-3 on the pump driven by a harmonic pressure)
A_P = [[],
       [3.0],
       [1.831036793486759, 0.4955183967433795],
       [2.304376582692669, -0.05249275245743001, -1.176798761832782],
       [-7.170454962423024, -4.741636671481785, -16.31002631330971, -1.062004044111401],
       [-7.170454962423024, -4.741636671481785, -16.31002631330971, -1.062004044111401, 1.0]]
C_P = [[],
       [-12.0],
       [-8.791795173947035, -2.207865586973518],
       [10.81793056857153, 6.780270611428266, 19.53485944642410],
       [34.19095006749676, 15.49671153725963, 54.74760875964130, 14.16005392148534],
       [34.62605830930532, 15.30084976114473, 56.99955578662667, 18.40807009793095, -5.714285714285717]]
TABLEAUS = {"rodas4": (A, C), "rodas4p": (A_P, C_P)}
FAC_MIN, FAC_MAX, SAFETY = 0.2, 6.0, 0.9  # step-size controller of rodas.f (Hairer & Wanner 1996, Sect. IV.8)
GROWTH_MAX = 1e4  # largest LU growth factor accepted (no pivoting); a larger one rejects the step: h shrinks
H_MIN = 1e-14  # relative to the time reached: smaller step sizes are an underflow (a failure)
STATUS = {1: "step size underflow", 2: "step budget of an output interval exhausted"}


def _qr_solver(W: ca.SX):
    """A solve with the square SX matrix ``W`` through its Householder QR factors (CasADi's ``qr_sparse``),
    factored once and written out symbolically."""
    v, r, beta, prinv, pc = ca.qr_sparse(W)
    return (lambda b: ca.qr_solve(b, v, r, beta, prinv, pc)), ca.SX(0)


def _lu_solver(W: ca.SX):
    """A solve with the square SX matrix ``W`` through its LU factors written out once (Doolittle, no pivoting;
    the structural zeros drop out), and the growth factor max |U_ij| / max |W_ij| as a check: partial pivoting
    bounds it by 2^(n-1) and keeps it near 1 in practice, so a large one (or a non-finite one: a zero pivot)
    flags a factorisation that needed pivoting."""
    n = W.shape[0]
    U = [[W[i, j] for j in range(n)] for i in range(n)]
    L = [[None] * n for _ in range(n)]
    for k in range(n):
        for i in range(k + 1, n):
            L[i][k] = U[i][k] / U[k][k]
            for j in range(k + 1, n):
                U[i][j] = U[i][j] - L[i][k] * U[k][j]
    u_max = ca.mmax(ca.fabs(ca.vertcat(*[U[i][j] for i in range(n) for j in range(i, n)])))
    growth = u_max / ca.mmax(ca.fabs(W))

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

    return solve, growth


def rodas4_step(rhs: ca.Function, linear_solver: str = "lu", method: str = "rodas4") -> ca.Function:
    """One RODAS4 step of ``x' = f(t, x, p)`` (Hairer & Wanner (1996), Sect. IV.7), or one RODASP step
    (Steinebach 1995).

    Parameters
    ----------
    rhs : casadi.Function
        ``(t, x, p) -> dx/dt`` (dense columns; ``p`` may be empty; SX-expandable), any units.
    linear_solver : {"lu", "qr"}
        The factorisation of ``I / (h gamma) - J``: LU without pivoting (its growth factor returned as a
        check) or Householder QR (stable without pivoting; the check output is then 0).
    method : {"rodas4", "rodas4p"}
        The coefficients: RODAS4 of rodas.f, or RODASP (``TABLEAUS``).

    Returns
    -------
    casadi.Function
        ``(t, x, p, h) -> (x_next, err, growth)``: the state after a step of ``h`` from time ``t`` (units of
        the time in ``rhs``), the embedded local error estimate, the last stage (units of ``x``), and the
        growth factor of the LU factorisation (-).
    """
    n, m = rhs.size1_in(1), rhs.size1_in(2)
    t, x, p, h = ca.SX.sym("t"), ca.SX.sym("x", n), ca.SX.sym("p", m), ca.SX.sym("h")
    z = ca.vertcat(x, t)

    def F(z):
        return ca.vertcat(rhs(z[n], z[:n], p), 1.0)

    Fz = F(z)
    W = ca.densify(ca.SX.eye(n + 1) / (h * GAMMA) - ca.jacobian(Fz, z))
    solve, growth = {"lu": _lu_solver, "qr": _qr_solver}[linear_solver](W)
    a_, c_ = TABLEAUS[method]
    g, u = [], z
    for i in range(6):
        u = z + sum((a * gj for a, gj in zip(a_[i], g, strict=True)), ca.SX.zeros(n + 1))
        coupling = sum((c / h * gj for c, gj in zip(c_[i], g, strict=True)), ca.SX.zeros(n + 1))
        g.append(solve((Fz if i == 0 else F(u)) + coupling))
    return ca.Function("rodas4_step", [t, x, p, h], [u[:n] + g[5][:n], g[5][:n], growth], ["t", "x", "p", "h"],
                       ["x_next", "err", "growth"])


def rodas4_fixed(rhs: ca.Function, n_steps: int, t_end: float, linear_solver: str = "lu",
                 method: str = "rodas4") -> ca.Function:
    """RODAS4 over ``n_steps`` equal steps from 0 to ``t_end`` as one Function (CasADi's ``mapaccum``: a loop
    in generated code).

    Parameters
    ----------
    rhs : casadi.Function
        ``(t, x, p) -> dx/dt``.
    n_steps : int
        Number of steps.
    t_end : float
        Final time, units of the time in ``rhs`` (s).
    linear_solver, method : str
        As in :func:`rodas4_step`.

    Returns
    -------
    casadi.Function
        ``(x0, p) -> (xf, est_max, est_sum)``: the final state, the largest and the summed embedded local
        error estimates over the steps (max over the states), units of ``x``.
    """
    n, m = rhs.size1_in(1), rhs.size1_in(2)
    step = rodas4_step(rhs, linear_solver, method)
    zt, p = ca.SX.sym("z", n + 1), ca.SX.sym("p", m)
    h = t_end / n_steps
    x_next, err, _ = step(zt[n], zt[:n], p, h)
    advance = ca.Function("rodas4_fixed_step", [zt, p], [ca.vertcat(x_next, zt[n] + h), ca.mmax(ca.fabs(err))])
    x0, pm = ca.MX.sym("x0", n), ca.MX.sym("p", m)
    zs, errs = advance.mapaccum("rodas4_steps", n_steps, [0], [0])(ca.vertcat(x0, 0.0), ca.repmat(pm, 1, n_steps))
    return ca.Function(f"rodas4_{n_steps}", [x0, pm], [zs[:n, -1], ca.mmax(errs), ca.sum2(errs)], ["x0", "p"],
                       ["xf", "est_max", "est_sum"])


def rodas4_grid(rhs: ca.Function, attempts: int, linear_solver: str = "lu", method: str = "rodas4") -> ca.Function:
    """RODAS4 with step-size control towards the points of a uniform output grid, as one Function of
    ``attempts`` step attempts (``mapaccum``: a loop in generated code).

    Every step is clipped to the next output time ``t_k = k dt`` (so the outputs are states of the method, not
    interpolants), and the controller's step size survives the clipping.  Error norm (Hairer & Wanner (1996),
    Sect. II.4, Eq. (4.11)): the root mean square of ``err / (atol + rtol max(|x|, |x_next|))``; a step is
    accepted when the norm is at most 1 (a non-finite one is not) and the LU growth factor at most
    ``GROWTH_MAX``; the next step size is the step times ``min(6, max(0.2, 0.9 norm^(-1/4)))`` (Sect. IV.8,
    the factors of rodas.f).  Once the output ``k_end`` is reached, or on a failure, the remaining attempts are
    skipped (CasADi's conditional: a branch in the generated code).  Tolerances are inputs, so one compiled
    library serves every tolerance.

    Parameters
    ----------
    rhs : casadi.Function
        ``(t, x, p) -> dx/dt``.
    attempts : int
        Step attempts (accepted plus rejected) in one call.
    linear_solver, method : str
        As in :func:`rodas4_step`.

    Returns
    -------
    casadi.Function
        ``(w, dt, k_end, tol, p) -> W``: from ``w = (t, h, k, landed, accepted, rejected, tries, status, x)``
        (time, next step size, index of the last output reached, counters, state), grid spacing ``dt`` (units
        of time), towards the output ``k_end``, with ``tol = (rtol, atol, max_steps)`` (``max_steps``: attempts
        allowed between two outputs); ``W`` holds ``w`` after each attempt, one column an attempt (the last
        one continues a later call): ``landed`` is 1 where the attempt reached an output time (``x`` is then
        the output ``k``), ``tries`` counts the attempts since the last output, ``status`` is 0 (running or
        done), 1 (step size underflow) or 2 (step budget of an output interval exhausted).
    """
    n, m = rhs.size1_in(1), rhs.size1_in(2)
    step = rodas4_step(rhs, linear_solver, method)
    w, dt, k_end, tol, p = ca.SX.sym("w", 8 + n), ca.SX.sym("dt"), ca.SX.sym("k_end"), ca.SX.sym("tol", 3), \
        ca.SX.sym("p", m)
    t, h, k, acc, rej, tries, x = w[0], w[1], w[2], w[4], w[5], w[6], w[8:]
    t_next = (k + 1) * dt
    clip = t + 1.01 * h >= t_next  # within 1 % of the output time: land on it
    hu = ca.if_else(clip, t_next - t, h)
    x_next, err, growth = step(t, x, p, hu)
    norm = ca.sqrt(ca.sumsqr(err / (tol[1] + tol[0] * ca.fmax(ca.fabs(x), ca.fabs(x_next)))) / n)
    ok = ca.logic_and(norm <= 1, growth <= GROWTH_MAX)  # False for a NaN norm (a non-finite step)
    fac = ca.fmin(FAC_MAX, ca.fmax(FAC_MIN, SAFETY * ca.fmax(norm, 1e-10) ** -0.25))
    fac = ca.if_else(ca.logic_or(ok, norm > 1), fac, FAC_MIN)  # non-finite or growth: shrink by FAC_MIN
    landed = ca.logic_and(ok, clip)
    h_new = ca.if_else(landed, ca.fmax(h, hu * fac), hu * fac)
    tries_new = ca.if_else(landed, 0, tries + 1)
    status = ca.if_else(h_new < H_MIN * ca.fmax(ca.fabs(t), dt), 1, ca.if_else(tries_new >= tol[2], 2, 0))
    attempt = ca.Function("attempt", [w, dt, k_end, tol, p], [ca.vertcat(
        ca.if_else(ok, ca.if_else(clip, t_next, t + hu), t), h_new, k + landed, landed, acc + ok, rej + 1 - ok,
        tries_new, status, ca.if_else(ok, x_next, x))])
    idle = ca.Function("idle", [w, dt, k_end, tol, p], [ca.vertcat(w[:3], 0, w[4:])])
    choose = ca.Function.conditional("attempt_or_idle", [attempt], idle)
    args = [ca.MX.sym("w", 8 + n), ca.MX.sym("dt"), ca.MX.sym("k_end"), ca.MX.sym("tol", 3), ca.MX.sym("p", m)]
    done = ca.logic_or(args[0][2] >= args[2], args[0][7] != 0)  # 0: attempt (choice 0), 1: idle (the default)
    body = ca.Function("attempt_loop", args, [choose(done, *args)])
    return ca.Function("rodas4_grid", args, [body.mapaccum("attempts", attempts, [0], [0])(*args)],
                       ["w", "dt", "k_end", "tol", "p"], ["W"])
