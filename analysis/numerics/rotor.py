"""Analyses of the rotor with a liquid auto-balancer (Pashkov (2010)).

Closed forms of the source beside CasADi/CVODES integration of the one nonlinear model
(:mod:`autobal.models.rotor`), all in the dimensionless variables of Pashkov (2010), Eq. (2) (time tau = Omega0 t,
speed nu = omega/Omega0, deflection over e):

* :func:`steady_state`: Eq. (3) at constant speed; :func:`stationary`: Eq. (9), (10), (7'),
  the stationary curves of Figs 5-6 with their special points (Pashkov (2010));
* :func:`stability`: the 4x4 perturbation matrix of (P) from the exact CasADi Jacobian;
* :func:`step_closed_form`: the residue solution (5)-(7) of a speed step; :func:`simulate` the
  CVODES integration of the same problem;
* :func:`passage`: uniform acceleration through the critical speed, (8')-(9') (Figs 7-9);
  :func:`crossover`: the friction n* at which the peak system unbalance with liquid equals the
  one without (Pashkov (2010));
* :func:`lewis`: the Jeffcott rotor accelerated from rest at constant rate;
* :func:`motor_runup`: run-up driven by a motor characteristic.
"""

from __future__ import annotations

from functools import cache

import casadi as ca
import numpy as np

from autobal.analysis.run import interrupt, solver_options
from autobal.models.rotor import RotorParams, rotor_model

SEGMENT_POINTS = 256  # output samples per CVODES call on long uniform runs (fewer restarts)


# ---- closed forms ----------------------------------------------------------------------------------

def steady_state(p: RotorParams, nu) -> dict:
    """Steady whirl (3) at nu = omega/Omega0: x, y (over e), a = delta/e, phase lag gamma (rad),
    system unbalance d1 = |w/(psi e) + 1| (7), torque M/(m1 e^2 Omega0^2) = 2 zeta0 nu a^2 + b~ nu (8)."""
    nu = np.asarray(nu, float)
    psi, z0, _, bt = p.p
    w = psi * nu**2 / (psi - nu**2 + 2j * z0 * psi * nu)
    a = np.abs(w)
    return {"nu": nu, "x": w.real, "y": w.imag, "a": a, "gamma": -np.angle(w),
            "d": np.abs(w / psi + 1), "M": 2 * z0 * nu * a**2 + bt * nu}


def stationary(mu1: float, n: float, z) -> dict:
    """Eq. (9), (7') at z = (omega/Omega0)^2 with dimensionless n = chi^2/(c m1):
    a/e, d/(m1 e), M/(e^2 c), phase lag gamma, and the ratios (10) to the rotor without liquid."""
    z = np.asarray(z, float)

    def D(mu):
        return (1 - mu * z) ** 2 + n * z

    return {"z": z, "a": z / np.sqrt(D(mu1)), "d": np.sqrt(1 + n * z) / np.sqrt(D(mu1)),
            "M": z**2 * np.sqrt(n * z) / D(mu1), "gamma": np.arctan2(np.sqrt(n * z), 1 - mu1 * z),
            "ratio_a": np.sqrt(D(1.0) / D(mu1)), "ratio_M": D(1.0) / D(mu1)}


def stationary_points(mu1: float, n: float) -> dict:
    """Special points of (9) (Pashkov (2010)): peak z_kp, a_kp; the speed z = 2/(1+mu1) above which the
    liquid helps; a(inf) = 1/mu1; torque maximum z1 and minimum z2 (None when they do not exist:
    exact condition mu1 > 3n/(6 - 2 sqrt 5)); the largest d/(m1 e) and where it is."""
    out = {"mu1": mu1, "n": n, "z_kp": 2 / (2 * mu1 - n), "a_kp": 2 / np.sqrt(4 * mu1 * n - n**2),
           "z_helps": 2 / (1 + mu1), "a_inf": 1 / mu1, "z1": None, "M1": None, "z2": None, "M2": None}
    disc = (6 * mu1 - 3 * n) ** 2 - 20 * mu1**2
    if disc > 0 and 6 * mu1 - 3 * n > 0:
        for key, sign in (("1", -1), ("2", 1)):
            z = (6 * mu1 - 3 * n + sign * np.sqrt(disc)) / (2 * mu1**2)
            out["z" + key], out["M" + key] = z, float(stationary(mu1, n, z)["M"])
    else:
        why = "the torque has no maximum and minimum: needs mu1 > 3 n / (6 - 2 sqrt 5)"
        out |= {f"{k}_status": why for k in ("z1", "M1", "z2", "M2")}
    # d has one maximum below z_helps: golden-section search on a bracketing grid
    zz = np.linspace(1e-3, 2 / mu1 + 1, 4001)
    i = int(np.argmax(stationary(mu1, n, zz)["d"]))
    from scipy.optimize import minimize_scalar

    r = minimize_scalar(lambda z: -stationary(mu1, n, z)["d"], bracket=(zz[i - 1], zz[i], zz[i + 1]),
                        tol=1e-12)
    out["d_max"], out["z_d_max"] = float(-r.fun), float(r.x)
    return out


def stability(p: RotorParams, nu: float) -> dict:
    """Eigenvalues (over Omega0) of the perturbation equations (P) at speed nu, from the exact
    Jacobian of the model at its steady state, beside the derived roots lambda +- i nu,
    lambda^2 + n lambda + k = 0."""
    m = rotor_model()
    s = steady_state(p, nu)
    q = ca.DM([float(s["x"]), float(s["y"]), 0, 0, nu])
    qs = ca.SX.sym("q", 5)
    J = ca.Function("J", [qs], [ca.jacobian(m.ode(qs, 0, p.p)[:4], qs[:4])])
    A = np.array(J(q))
    ev = np.linalg.eigvals(A)
    psi, z0 = p.psi, p.zeta0
    lam = np.roots([1, 2 * z0 * psi, psi]).astype(complex)
    derived = np.array([la + s_ * 1j * nu for la in lam for s_ in (1, -1)])
    return {"matrix": A, "eigenvalues": ev, "derived": derived,
            "residual": float(np.max(np.min(np.abs(ev[:, None] - derived[None, :]), axis=1))),
            "max_real": float(ev.real.max())}


def step_closed_form(p: RotorParams, nu0: float, nu: float, tau) -> np.ndarray:
    """Complex w(tau)/e after a speed step nu0 -> nu from the steady state at nu0, relative velocity
    zero (4): the residue solution (5) with roots (6) and the reconstructed D, X, Y;
    the stop nu = 0 (double roots) by w = w_C(nu0) f(tau), f'' + n f' + k f = 0."""
    tau = np.asarray(tau, float)
    psi, z0 = p.psi, p.zeta0
    k, n, om = psi, 2 * z0 * psi, nu
    wc0 = complex(steady_state(p, nu0)["x"] + 1j * steady_state(p, nu0)["y"])
    lam = np.roots([1, n, k]).astype(complex)
    if om == 0:
        l1, l2 = lam
        return wc0 * (l2 * np.exp(l1 * tau) - l1 * np.exp(l2 * tau)) / (l2 - l1)
    xi0, eta0 = wc0.real, wc0.imag

    def E1(S):
        return S**2 + n * S + k - om**2

    def E2(S):
        return 2 * S + n

    D0 = (k - om**2) ** 2 + n**2 * om**2
    A = psi * (k - om**2) * om**2 / D0 + 0j * tau
    B = -psi * om**3 * n / D0 + 0j * tau
    for S in (la + s_ * 1j * om for la in lam for s_ in (1, -1)):
        F1 = psi * om**2 + S * ((S + n) * xi0 - 2 * om * eta0)
        F2 = S * ((S + n) * eta0 + 2 * om * xi0)
        X = E1(S) * F1 + om * E2(S) * F2
        Y = E1(S) * F2 - om * E2(S) * F1
        den = S * 2 * E2(S) * (E1(S) + 2 * om**2)  # S_j D'(S_j), D(S_j) = 0
        A = A + X * np.exp(S * tau) / den
        B = B + Y * np.exp(S * tau) / den
    return A.real + 1j * B.real


# ---- integration -----------------------------------------------------------------------------------

@cache
def _integrator(points: int, tol: float, max_num_steps: int) -> ca.Function:
    """CVODES over one segment in normalized time s in [0, 1], dq/ds = h f(q, a*, p); outputs at
    s = 1/points, ..., 1.  Parameters [a*, h, p]."""
    m = rotor_model()
    q = ca.SX.sym("q", 5)
    par = ca.SX.sym("par", 2 + 4)
    ode = par[1] * m.ode(q, par[0], par[2:])
    grid = np.linspace(0, 1, points + 1)[1:].tolist()
    return ca.integrator(f"rotor_seg_{points}", "cvodes", {"x": q, "p": par, "ode": ode}, 0, grid,
                         {"abstol": tol, "reltol": tol, "max_num_steps": max_num_steps})


def simulate(p: RotorParams, q0, a_seg, h_seg, points: int = 16, tol: float | None = None) -> dict:
    """Integrate the rotating-frame model with piecewise-constant a* (segment k has a_seg[k] over the
    dimensionless duration h_seg[k]) from q0 = (x, y, x', y', nu); states at ``points`` instants
    per segment (CVODES, the solver options' group ``rotor``; ``tol`` overrides its tolerance).  Returns tau
    (with 0) and q (5 x len(tau))."""
    opts = solver_options.get("rotor")
    F = _integrator(points, opts["tol"] if tol is None else tol, opts["max_num_steps"])
    a_seg, h_seg = np.atleast_1d(a_seg).astype(float), np.atleast_1d(h_seg).astype(float)
    pv = list(p.p)
    qs, taus, q, t0 = [np.asarray(q0, float)[:, None]], [np.zeros(1)], np.asarray(q0, float), 0.0
    for a, h in zip(a_seg, h_seg, strict=True):
        out = np.array(interrupt.call(F, x0=q, p=[a, h, *pv])["xf"])
        qs.append(out)
        taus.append(t0 + h * np.linspace(0, 1, points + 1)[1:])
        q, t0 = out[:, -1], t0 + h
    return {"tau": np.concatenate(taus), "q": np.hstack(qs)}


def peak(t, v) -> tuple[float, float]:
    """Largest value of a sampled smooth curve and where it is (parabola through the top 3 samples)."""
    v = np.asarray(v, float)
    i = int(np.argmax(v))
    if 0 < i < len(v) - 1:
        y0, y1, y2 = v[i - 1], v[i], v[i + 1]
        den = y0 - 2 * y1 + y2
        if den < 0:
            s = 0.5 * (y0 - y2) / den
            return float(y1 - 0.25 * (y0 - y2) * s), float(t[i] + s * (t[i + 1] - t[i]))
    return float(v[i]), float(t[i])


def deflection(q) -> np.ndarray:
    return np.hypot(q[0], q[1])


def unbalance(q, psi: float) -> np.ndarray:
    return np.hypot(q[0] / psi + 1, q[1] / psi)


def steady_q(p: RotorParams, nu: float) -> list[float]:
    s = steady_state(p, nu)
    return [float(s["x"]), float(s["y"]), 0.0, 0.0, float(nu)]


def _segments(duration: float, dt: float) -> tuple[np.ndarray, int]:
    k = max(1, int(np.ceil(duration / dt)))
    return np.full(k, duration / k), k


def passage(p: RotorParams, nu0: float, a_star: float, nu_end: float, q0=None, per_unit: float = 24.0,
            tol: float | None = None) -> dict:
    """Uniform acceleration nu = nu0 + a* tau (the source's omega = omega0 + 2 eps t) from the steady
    state (8') at nu0 (or q0) to nu_end: delta/e and d (9') on a dense grid, and their peaks
    (max, nu at the max).  ``per_unit`` samples per unit of tau (a whirl period is 2 pi / (nu + 1))."""
    q0 = steady_q(p, nu0) if q0 is None else q0
    h, k = _segments((nu_end - nu0) / a_star, SEGMENT_POINTS / per_unit)
    sim = simulate(p, q0, np.full(k, a_star), h, points=SEGMENT_POINTS, tol=tol)
    q, tau = sim["q"], sim["tau"]
    delta, d = deflection(q), unbalance(q, p.psi)
    nu = q[4]
    dmax, t1 = peak(tau, delta)
    umax, t2 = peak(tau, d)
    return {"tau": tau, "nu": nu, "delta": delta, "d": d, "delta_max": dmax, "nu_delta_max": nu0 + a_star * t1,
            "d_max": umax, "nu_d_max": nu0 + a_star * t2}


def crossover(Omega0: float, psi: float, omega0: float, alpha: float, nu_end: float = 2.0,
              bracket=(0.5, 30.0), xtol: float = 1e-3) -> float:
    """n* = chi/m1 (1/s) at which max d with liquid (psi) equals max d without (psi = 1) in the
    uniform passage (5.30 for psi = 0.5 at 20 s^-2 [derived])."""

    def gap(n):
        r1 = passage(RotorParams.from_groups(Omega0, n, psi), omega0 / Omega0, alpha / Omega0**2, nu_end)
        r0 = passage(RotorParams.from_groups(Omega0, n, 1.0), omega0 / Omega0, alpha / Omega0**2, nu_end)
        return r1["d_max"] - r0["d_max"]

    from scipy.optimize import brentq  # heavy (0.45 s to import): only this study needs it

    return float(brentq(gap, *bracket, xtol=xtol))


def lewis_end(a_star: float) -> float:
    """The speed nu = omega/Omega where :func:`lewis` stops: past the asymptotic peak speed 1 + 2.1574 sqrt(a*)."""
    return 1 + 2.1574 * np.sqrt(a_star) + max(0.15, 5 * np.sqrt(a_star))


def lewis(zeta: float, a_star: float, per_unit: float = 12.0, tol: float | None = None) -> dict:
    """Lewis (1932) problem: Jeffcott rotor (psi = 1) from rest, u = u' = 0,
    nu(0) = 0, constant a* = alpha/Omega^2.  |u| = |w|, so the rotating frame is used; it runs
    past the asymptotic peak speed 1 + 2.1574 sqrt(a*).  Returns the peak |u|/e and nu there."""
    p = RotorParams(m1=1.0, c=1.0, chi=2 * zeta, e=1.0)
    r = passage(p, 0.0, a_star, lewis_end(a_star), q0=[0, 0, 0, 0, 0], per_unit=per_unit, tol=tol)
    return {"zeta": zeta, "a_star": a_star, "peak": r["delta_max"], "nu_peak": r["nu_delta_max"],
            "asymptote": 1.4672 / np.sqrt(a_star), "nu_asymptote": 1 + 2.1574 * np.sqrt(a_star)}


def motor_runup(p: RotorParams, stall: float, no_load: float, tau_end: float, q0=None,
                points: int = 4000) -> dict:
    """Run-up driven by the linear motor characteristic L = L_s (1 - nu/nu_nl) (dimensionless torque
    over m1 e^2 Omega0^2): the speed is a state, the torque equation gives beta''.
    Needs polar inertia (j + 1 - psi > 0).  Reports the final speed and whether the rotor passed
    its critical speed sqrt(psi) (Sommerfeld capture otherwise)."""
    m = rotor_model()
    q = ca.SX.sym("q", 5)
    L = stall * (1 - q[4] / no_load)
    grid = np.linspace(0, tau_end, points + 1)[1:].tolist()
    opts = solver_options.get("rotor")
    F = ca.integrator("motor", "cvodes", {"x": q, "ode": m.ode_torque(q, L, p.p)}, 0, grid,
                      {"abstol": opts["tol"], "reltol": opts["tol"], "max_num_steps": opts["max_num_steps"]})
    q0 = [0, 0, 0, 0, 0] if q0 is None else q0
    qq = np.hstack([np.asarray(q0, float)[:, None], np.array(interrupt.call(F, x0=q0)["xf"])])
    tau = np.concatenate([[0.0], grid])
    nu_cr = np.sqrt(p.psi)
    return {"tau": tau, "nu": qq[4], "delta": deflection(qq), "nu_final": float(qq[4, -1]),
            "passed": bool(qq[4, -1] > nu_cr), "nu_cr": float(nu_cr)}
