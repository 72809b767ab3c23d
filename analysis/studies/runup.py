"""The rotor identified from a measured run-up or coast-down: critical speed, damping ratio and unbalance fitted to
the 1x vectors by least squares of the transient Jeffcott response driven by the measured speed profile.

Model: the planar Jeffcott rotor of :mod:`autobal.models.rotor` in the fixed frame (``ode_fixed``, Pashkov (2010),
Eq. (2) with psi = 1), written in the time t of the measurement,

    u'' + 2 zeta w_n u' + w_n^2 u = eps (w^2 - i alpha) e^{i phi},   u = x + i y (m),

driven by the measured speed w(t) (piecewise linear through the vectors' speeds), alpha = dw/dt and the shaft angle
phi(t) = integral of w dt (0 at the key-phasor pulse, positive in the direction of rotation).  The unbalance
eps = e e^{i theta} is the mass centre's eccentricity e and its angle theta from the key-phasor mark in the
direction of rotation.  The response is complex-linear in eps: u = eps g(t; w_n, zeta), g the response to a unit
eccentricity at angle 0.  The probes read x = Re u and y = Im u (y 90 degrees from x in the direction of rotation),
and their 1x vectors are taken as from the measurement, over the revolution (key-phasor pulse to pulse) whose middle
is the vector's time (autobal.runup_data's order tracking):

    X_k = (1/pi) int x e^{-i phi} dphi = eps A_k + conj(eps) B_k,   Y_k = -i (eps A_k - conj(eps) B_k),
    A_k = (1/2pi) int g e^{-i phi} dphi,   B_k = (1/2pi) int conj(g) e^{-i phi} dphi

(B is zero in a steady whirl), plus a constant run-out vector per probe when it is fitted.  The model is integrated
by a fixed-step RK4 (built once per speed profile with CasADi ``mapaccum``), so IPOPT gets the exact sensitivities
of the discrete model; the steady whirl that starts it and the steady-state fit come from the same ``ode_fixed`` by
its exact Jacobian ((i nu I - A) Z = F).  Gauss-Newton covariance, Student-t intervals, the conditioning of the
scaled Jacobian and an F test of the residual against the noise of the vectors (the spread of their second
differences) as the adequacy test, as analysis/numerics/adequacy.py does for the device fit with repeated measurements.

The classical readings (the peak's speed as the critical, the half-power damping, the 1x vector at service speed)
are reported beside, with their difference from the transient fit: a run-up fast enough to matter moves the peak
above the critical speed and widens it (Lewis's passage effect), so those readings are biased.

Units: SI inside and in the Result (rad/s, m, kg, kg m); angles in degrees as the analysers give them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cache, cached_property

import casadi as ca
import numpy as np
from scipy import stats

from autobal.analysis.numerics.least_squares import LeastSquares, uncertainty
from autobal.analysis.numerics.standards import API_AF, API_SM, ISO_G
from autobal.analysis.run.fields import Record, TypedResult, declarations, optional, quantity, record
from autobal.analysis.run.figures import Figure
from autobal.analysis.run.quantities import convert
from autobal.analysis.run.result import new_figure, unit_axis
from autobal.models.rotor import rotor_model

#: fixed-step RK4 steps per revolution at the highest speed (and per natural period at the highest w_n searched)
STEPS_PER_REV = 12
#: the critical speeds searched: up to this multiple of the highest measured speed
WN_MAX_FACTOR = 2.0
#: revolutions before the first vector's revolution where the model starts in the steady whirl (0: at its
#: key-phasor pulse, as a run from a hold at the first speed)
LEAD_REVS = 0.0


# ---- the model's response, from models/rotor.py's fixed-frame equations -----------------------------------------

def _rhs_time():
    """dz/dt of z = (x, y, x', y') / e (x' over w_n) from ``ode_fixed``: (z, w, phi, alpha, w_n, zeta)."""
    m = rotor_model()
    z, w, phi, alpha, wn, zeta = (ca.SX.sym(n, k) for n, k in (("z", 4), ("w", 1), ("phi", 1), ("alpha", 1),
                                                                 ("wn", 1), ("zeta", 1)))
    Q = ca.vertcat(z, w / wn, phi)
    dQ = m.ode_fixed(Q, alpha / wn**2, ca.vertcat(1, zeta, 0, 0))
    return ca.Function("runup_rhs", [z, w, phi, alpha, wn, zeta], [wn * dQ[:4]])


def _steady_whirl():
    """The steady whirl of ``ode_fixed`` at constant nu = w/w_n: z(beta) = Re(Z e^{i beta}) with (i nu I - A) Z = F,
    A the exact Jacobian in z, F the forcing's complex amplitude; (nu, zeta) -> Z (re, im), per unit eccentricity."""
    m = rotor_model()
    z, nu, zeta = ca.SX.sym("z", 4), ca.SX.sym("nu"), ca.SX.sym("zeta")
    p = ca.vertcat(1, zeta, 0, 0)

    def f(beta):
        return m.ode_fixed(ca.vertcat(z, nu, beta), 0, p)[:4]

    A = ca.jacobian(f(0), z)
    F0 = ca.substitute(f(0), z, ca.DM.zeros(4))
    F1 = ca.substitute(f(math.pi / 2), z, ca.DM.zeros(4))  # cos(beta) F0 + sin(beta) F1 = Re((F0 - i F1) e^{i beta})
    big = ca.blockcat([[-A, -nu * ca.DM.eye(4)], [nu * ca.DM.eye(4), -A]])  # (i nu I - A) on [re; im]
    Z = ca.solve(big, ca.vertcat(F0, -F1))
    return ca.Function("steady_whirl", [nu, zeta], [Z[:4], Z[4:]])


@cache
def rhs() -> ca.Function:
    """The fixed-frame right-hand side in the measurement's time (built once)."""
    return _rhs_time()


@cache
def steady_whirl() -> ca.Function:
    """The steady whirl Function (built once)."""
    return _steady_whirl()


def steady_response(speed, critical_speed: float, damping_ratio: float) -> np.ndarray:
    """H(w) = the steady 1x vector of probe x per unit eccentricity at angle 0 (complex, 1) at the speeds
    (rad/s): w^2 / (w_n^2 - w^2 + 2 i zeta w_n w), from ``ode_fixed`` (:func:`steady_whirl`)."""
    nu = np.atleast_1d(np.asarray(speed, float)) / critical_speed
    re, im = steady_whirl().map(nu.size)(nu, damping_ratio)
    return np.asarray(re)[0] + 1j * np.asarray(im)[0]


# ---- the speed profile and the revolution windows -----------------------------------------------------------------

@dataclass(frozen=True)
class SpeedProfile:
    """w(t) piecewise linear through the vectors' (time, speed), held at the ends; phi(t) its integral plus
    ``offset`` (rad) and alpha(t) its slope (rad/s^2)."""

    time: np.ndarray
    speed: np.ndarray
    offset: float = 0.0

    def speed_at(self, t):
        return np.interp(t, self.time, self.speed)

    def acceleration_at(self, t):
        t = np.asarray(t, float)
        slope = np.diff(self.speed) / np.diff(self.time)
        i = np.clip(np.searchsorted(self.time, t, side="right") - 1, 0, len(slope) - 1)
        inside = (t >= self.time[0]) & (t < self.time[-1])
        return np.where(inside, slope[i], 0.0)

    @cached_property
    def _phi_nodes(self):
        return np.concatenate([[0.0], np.cumsum(np.diff(self.time) * (self.speed[1:] + self.speed[:-1]) / 2)])

    def angle_at(self, t):
        """phi(t), exact for the piecewise-linear w (rad)."""
        t = np.asarray(t, float)
        tc = np.clip(t, self.time[0], self.time[-1])
        i = np.clip(np.searchsorted(self.time, tc, side="right") - 1, 0, len(self.time) - 2)
        dt = tc - self.time[i]
        slope = (self.speed[i + 1] - self.speed[i]) / (self.time[i + 1] - self.time[i])
        phi = self.offset + self._phi_nodes[i] + self.speed[i] * dt + slope * dt**2 / 2
        return phi + np.where(t < self.time[0], (t - self.time[0]) * self.speed[0], 0.0) \
            + np.where(t > self.time[-1], (t - self.time[-1]) * self.speed[-1], 0.0)

    def time_at(self, phi):
        """t(phi), the inverse of :meth:`angle_at` (bisection on the monotonic angle, vectorised)."""
        phi = np.asarray(phi, float)
        lo = np.full(phi.shape, self.time[0] - 10 * (self.time[-1] - self.time[0]) - 10.0)
        hi = np.full(phi.shape, self.time[-1] + 10 * (self.time[-1] - self.time[0]) + 10.0)
        for _ in range(80):
            mid = (lo + hi) / 2
            below = self.angle_at(mid) < phi
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return (lo + hi) / 2


def _extended(t: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The profile carried on at its end rates for 1 + LEAD_REVS revolutions before and one after (the first and last
    vectors' revolutions reach beyond their times: half a revolution), the speed kept above half its end value."""
    out_t, out_w = [t], [w]
    for end, nxt, side in ((0, 1, -1), (-1, -2, 1)):
        slope = (w[nxt] - w[end]) / (t[nxt] - t[end])
        span = 2 * math.pi * (1 + LEAD_REVS) / w[end]
        we = max(w[end] + side * slope * span, w[end] / 2)
        te = t[end] + side * span
        (out_t.insert(0, [te]), out_w.insert(0, [we])) if side < 0 else (out_t.append([te]), out_w.append([we]))
    return np.concatenate(out_t), np.concatenate(out_w)


def _half_revolution(prof: SpeedProfile, t: np.ndarray) -> np.ndarray:
    """Half the period of the revolution timed at its middle t: phi(t + d) - phi(t - d) = 2 pi (bisection)."""
    lo, hi = np.zeros_like(t), np.full_like(t, 4 * math.pi / max(float(np.min(prof.speed)), 1e-300))
    for _ in range(80):
        mid = (lo + hi) / 2
        short = prof.angle_at(t + mid) - prof.angle_at(t - mid) < 2 * math.pi
        lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
    return (lo + hi) / 2


def _window_weights(grid: np.ndarray, ta: float, tb: float, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices and trapezoid weights of int_{ta}^{tb} v(t) f(t) dt over the samples v(grid) of a uniform grid, v f
    linear between samples (f sampled on the grid: the weights multiply v only)."""
    h = grid[1] - grid[0]
    ia, ib = max(int(np.floor((ta - grid[0]) / h)), 0), int(np.floor((tb - grid[0]) / h))
    idx = np.arange(ia, ib + 2)
    w = np.zeros(idx.size, complex)
    # pieces [grid[j], grid[j+1]] cut to [ta, tb]: the integral of the linear interpolant of v f on each piece
    for k in range(idx.size - 1):
        a, b = max(grid[idx[k]], ta), min(grid[idx[k + 1]], tb)
        if b <= a:
            continue
        sa, sb = (a - grid[idx[k]]) / h, (b - grid[idx[k]]) / h  # positions in the piece, 0..1
        # int of (1 - s) and s over [sa, sb], times h
        w0 = h * ((sb - sa) - (sb**2 - sa**2) / 2)
        w1 = h * (sb**2 - sa**2) / 2
        w[k] += w0 * f[idx[k]]
        w[k + 1] += w1 * f[idx[k + 1]]
    return idx, w


# ---- the transient model of one speed profile ---------------------------------------------------------------------

class TransientModel:
    """The 1x vectors of the Jeffcott rotor driven by one measured speed profile, per unit eccentricity: the CasADi
    Function ``unit(w_n, zeta) -> (A_re, A_im, B_re, B_im)`` (K values each), built once and reused for any data
    measured on that profile.

    Parameters
    ----------
    time, speed : array (K,)
        The vectors' times (s) and speeds (rad/s), strictly monotonic in time.
    wn_max : float
        The highest critical speed the model must resolve (rad/s); the RK4 step resolves it and the highest speed by
        :data:`STEPS_PER_REV` steps per period.
    """

    def __init__(self, time, speed, wn_max: float):
        time = np.asarray(time, float)
        t, w = time, np.asarray(speed, float)
        t, w = _extended(t, w)
        half = _half_revolution(SpeedProfile(t, w), time)
        ta, tb = time - half, time + half
        # the first revolution starts at a key-phasor pulse: phi = 0 there
        self.profile = prof = SpeedProfile(t, w, -float(SpeedProfile(t, w).angle_at(ta[0])))
        fastest = max(float(np.max(w)), wn_max)
        self.step = h = 2 * math.pi / (STEPS_PER_REV * fastest)
        start = min(float(prof.time_at(-2 * math.pi * LEAD_REVS)), float(ta[0]))
        n = int(math.ceil((tb[-1] - start) / h)) + 2
        grid = start + h * np.arange(n + 1)
        self.grid = grid
        # stage data of each step: w, phi, alpha at t, t + h/2, t + h
        ts = np.stack([grid[:-1], grid[:-1] + h / 2, grid[1:]])
        self.stage = np.vstack([prof.speed_at(ts), prof.angle_at(ts), prof.acceleration_at(ts)])  # (9, n)
        c = prof.speed_at(grid) * np.exp(-1j * prof.angle_at(grid)) / (2 * math.pi)  # (1/2pi) w e^{-i phi}
        rows, cols, wr, wi = [], [], [], []
        for k in range(len(time)):
            idx, wk = _window_weights(grid, ta[k], tb[k], c)
            rows += [k] * idx.size
            cols += list(idx)
            wr += list(wk.real)
            wi += list(wk.imag)
        self.Wr = ca.DM.triplet(rows, cols, ca.DM(wr), len(time), n + 1)
        self.Wi = ca.DM.triplet(rows, cols, ca.DM(wi), len(time), n + 1)
        self.start_speed, self.start_angle = float(prof.speed_at(start)), float(prof.angle_at(start))
        self.steps = n
        self.size = len(time)

    @cached_property
    def unit(self) -> ca.Function:
        """(w_n, zeta) -> A_re, A_im, B_re, B_im: the model's 1x vectors per unit eccentricity (see module)."""
        f = rhs()
        z, d, wn, zeta = ca.SX.sym("z", 4), ca.SX.sym("d", 9), ca.SX.sym("wn"), ca.SX.sym("zeta")
        h = self.step
        k1 = f(z, d[0], d[3], d[6], wn, zeta)
        k2 = f(z + h / 2 * k1, d[1], d[4], d[7], wn, zeta)
        k3 = f(z + h / 2 * k2, d[1], d[4], d[7], wn, zeta)
        k4 = f(z + h * k3, d[2], d[5], d[8], wn, zeta)
        step = ca.Function("rk4", [z, d, wn, zeta], [z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
        sim = step.mapaccum("runup_sim", self.steps, [0], [0])
        wn, zeta = ca.MX.sym("wn"), ca.MX.sym("zeta")
        # the steady whirl at the first speed starts it
        re, im = steady_whirl()(self.start_speed / wn, zeta)
        c, s = math.cos(self.start_angle), math.sin(self.start_angle)
        z0 = re * c - im * s
        data = ca.DM(self.stage[[0, 1, 2, 3, 4, 5, 6, 7, 8]])
        traj = sim(z0, data, ca.repmat(wn, 1, self.steps), ca.repmat(zeta, 1, self.steps))
        Z = ca.horzcat(z0, traj)
        gx, gy = Z[0, :].T, Z[1, :].T  # g = gx + i gy on the grid
        A_re = ca.mtimes(self.Wr, gx) - ca.mtimes(self.Wi, gy)
        A_im = ca.mtimes(self.Wr, gy) + ca.mtimes(self.Wi, gx)
        B_re = ca.mtimes(self.Wr, gx) + ca.mtimes(self.Wi, gy)
        B_im = ca.mtimes(self.Wi, gx) - ca.mtimes(self.Wr, gy)
        return ca.Function("runup_unit", [wn, zeta], [A_re, A_im, B_re, B_im], ["wn", "zeta"],
                           ["A_re", "A_im", "B_re", "B_im"])


def _steady_unit(speed: np.ndarray):
    """(w_n, zeta) -> A_re, A_im, B_re, B_im of the steady whirl at the vectors' speeds (B = 0): the steady-state
    fit's model, from ``ode_fixed`` as the transient one."""
    whirl = steady_whirl().map(len(speed))
    w = ca.DM(np.asarray(speed, float)).T

    def unit(wn, zeta):
        re, im = whirl(w / wn, zeta)
        zero = ca.MX.zeros(len(speed), 1)
        return re[0, :].T, im[0, :].T, zero, zero

    return unit


# ---- the fit -------------------------------------------------------------------------------------------------------

#: the names of the fitted parameters, in the order of the estimate
NAMES = ("critical_speed", "damping_ratio", "eps_re", "eps_im", "runout_x_re", "runout_x_im", "runout_y_re",
         "runout_y_im")
SYMBOLS = {"critical_speed": "ω_n", "damping_ratio": "ζ", "eps_re": "Re ε", "eps_im": "Im ε",
           "runout_x_re": "Re r_x", "runout_x_im": "Im r_x", "runout_y_re": "Re r_y", "runout_y_im": "Im r_y"}


@dataclass(frozen=True)
class Fit:
    """One fit of the 1x vectors: the estimate, its linearised uncertainty and the solver's report (SI)."""

    names: tuple[str, ...]
    estimate: np.ndarray
    covariance: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    correlation: np.ndarray
    residual_std: float  # m, the residual's standard deviation per component of a vector
    dof: int
    condition: float  # condition number of the Jacobian scaled by the parameters' magnitudes
    weakest: np.ndarray  # its right singular vector of the smallest singular value (relative changes)
    fitted_x: np.ndarray  # complex (K,)
    fitted_y: np.ndarray | None
    status: str
    success: bool
    iterations: int

    def value(self, name: str) -> float:
        return float(self.estimate[self.names.index(name)])

    def interval(self, name: str) -> tuple[float, float]:
        i = self.names.index(name)
        return float(self.ci_low[i]), float(self.ci_high[i])

    @property
    def eps(self) -> complex:
        return complex(self.value("eps_re"), self.value("eps_im"))

    def eccentricity(self) -> tuple[float, float, float]:
        """e = |eps| (m) and its 95 % interval by the delta method."""
        return self._derived(lambda e: abs(e), lambda e: np.array([e.real, e.imag]) / abs(e))

    def angle(self) -> tuple[float, float, float]:
        """theta = arg eps (rad, from the key-phasor mark in the direction of rotation) and its interval."""
        return self._derived(lambda e: math.atan2(e.imag, e.real),
                             lambda e: np.array([-e.imag, e.real]) / abs(e) ** 2)

    def _derived(self, value, grad) -> tuple[float, float, float]:
        i = [self.names.index("eps_re"), self.names.index("eps_im")]
        g = grad(self.eps)
        se = math.sqrt(max(float(g @ self.covariance[np.ix_(i, i)] @ g), 0.0))
        t = self._t()
        v = value(self.eps)
        return v, v - t * se, v + t * se

    def _t(self) -> float:
        return float(stats.t.ppf(0.975, self.dof)) if self.dof > 0 else math.nan

    def standard_error(self, name: str) -> float:
        i = self.names.index(name)
        return math.sqrt(self.covariance[i, i])


class Fitter:
    """Least squares of the 1x vectors by IPOPT (Gauss-Newton Hessian, exact CasADi sensitivities of the model),
    built once per model and reused for any measured vectors on the same speeds and times.

    Parameters
    ----------
    unit : callable
        (w_n, zeta) -> A_re, A_im, B_re, B_im (CasADi), the model's vectors per unit eccentricity.
    size : int
        K, the number of vectors.
    probes : int
        1 (x) or 2 (x and y).
    runout : bool
        Fit a constant run-out vector per probe.
    """

    def __init__(self, unit, size: int, probes: int, runout: bool):
        self.unit, self.size, self.probes, self.runout = unit, size, probes, runout
        self.names = NAMES[:2 + 2 + (2 * probes if runout else 0)]
        n = len(self.names)
        x, p = ca.MX.sym("x", n), ca.MX.sym("p", 2 * probes * size + n + 1)
        scale, sigma = p[2 * probes * size:-1], p[-1]
        theta = x * scale
        self.model = self._vectors(theta)
        r = (ca.vertcat(*self.model) - p[:2 * probes * size]) / sigma
        self.ls = LeastSquares("runup_fit", x, p, r, ca.MX(0, 1), n, max_iter=200, tol=1e-10)
        self.vectors = ca.Function("runup_vectors", [x, p], [ca.vertcat(*self.model)])

    def _vectors(self, theta):
        Ar, Ai, Br, Bi = self.unit(theta[0], theta[1])
        er, ei = theta[2], theta[3]
        # X = eps A + conj(eps) B (+ r_x)
        xr = er * Ar - ei * Ai + er * Br + ei * Bi
        xi = er * Ai + ei * Ar + er * Bi - ei * Br
        if self.runout:
            xr, xi = xr + theta[4], xi + theta[5]
        out = [xr, xi]
        if self.probes == 2:
            # Y = -i (eps A - conj(eps) B) (+ r_y)
            yr = er * Ai + ei * Ar - er * Bi + ei * Br
            yi = -(er * Ar - ei * Ai - er * Br - ei * Bi)
            if self.runout:
                yr, yi = yr + theta[6], yi + theta[7]
            out += [yr, yi]
        return out

    def linear(self, wn: float, zeta: float, data: np.ndarray) -> tuple[np.ndarray, float]:
        """The eccentricity and run-out that fit best at a given (w_n, zeta) (linear least squares) and the sum of
        squares left."""
        Ar, Ai, Br, Bi = (np.asarray(v, float).ravel() for v in self._numeric_unit(wn, zeta))
        K, cols = self.size, []
        one, zero = np.ones(K), np.zeros(K)
        # columns: d/d eps_re, d/d eps_im, then the run-outs, rows [xr, xi, (yr, yi)]
        cols.append(np.concatenate([Ar + Br, Ai + Bi] + ([Ai - Bi, -(Ar - Br)] if self.probes == 2 else [])))
        cols.append(np.concatenate([-Ai + Bi, Ar - Br] + ([Ar + Br, Ai + Bi] if self.probes == 2 else [])))
        if self.runout:
            for j in range(2 * self.probes):
                cols.append(np.concatenate([one if i == j else zero for i in range(2 * self.probes)]))
        M = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(M, data, rcond=None)
        res = data - M @ coef
        return coef, float(res @ res)

    @cached_property
    def _numeric_unit(self):
        wn, zeta = ca.MX.sym("wn"), ca.MX.sym("zeta")
        return ca.Function("unit", [wn, zeta], list(self.unit(wn, zeta)))

    def solve(self, data: np.ndarray, start: np.ndarray, lower: np.ndarray, upper: np.ndarray, sigma: float) -> Fit:
        """Fit the stacked measured vectors ``data`` ([Re X, Im X, (Re Y, Im Y)], m) from ``start`` (SI)."""
        scale = np.where(np.abs(start) > 0, np.abs(start), 1.0)
        scale[2:] = max(abs(complex(start[2], start[3])), 1e-300)  # eccentricity and run-outs on one scale
        p = np.concatenate([data, scale, [sigma]])
        res = self.ls.solve(start / scale, lower / scale, upper / scale, p)
        est = np.asarray(res["x"], float).ravel() * scale
        r = res["r"] * sigma
        J = res["J"] * sigma / scale  # d r / d theta (SI)
        unc = uncertainty(r, J, est)
        Js = J * np.where(np.abs(est) > 0, np.abs(est), scale)  # relative sensitivities
        _, sv, vt = np.linalg.svd(Js, full_matrices=False)
        fitted = np.asarray(self.vectors(res["x"], p), float).ravel()
        K = self.size
        fx = fitted[:K] + 1j * fitted[K:2 * K]
        fy = fitted[2 * K:3 * K] + 1j * fitted[3 * K:] if self.probes == 2 else None
        stats_ = res.get("stats", {})
        return Fit(self.names, est, unc["covariance"], unc["ci_low"], unc["ci_high"], unc["correlation"],
                   unc["residual_std"], unc["dof"], float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf, vt[-1],
                   fx, fy, str(res.get("status", stats_.get("return_status", ""))), bool(res.get("success")),
                   int(res.get("iterations", 0)))


# ---- an independent synthetic run-up (scipy, not the fitting model's code) ----------------------------------------

class SyntheticRunup:
    """A run-up (or coast-down) of a Jeffcott rotor at a constant rate, simulated independently of the fitting
    model: the fixed-frame equation written again here in its dimensional form and integrated by scipy's DOP853
    (rtol 1e-10), its probe signals sampled ``samples`` times per revolution between key-phasor pulses and each
    revolution's 1x vector taken by its own DFT (order tracking, the trapezoid rule from pulse to pulse); for tests,
    the guide and the shipped measurement.

    u'' + 2 zeta w_n u' + w_n^2 u = eps (w^2 - i alpha) e^{i phi},  w = w0 + alpha t,  phi = w0 t + alpha t^2/2,
    started in the steady whirl at w0; x = Re u + Re(r_x e^{i phi}), y = Im u + Re(r_y e^{i phi}) plus white noise.

    Parameters
    ----------
    critical_speed, damping_ratio : float
        w_n (rad/s), zeta.
    eccentricity, angle : float
        e (m) and theta (rad, from the key-phasor mark in the direction of rotation).
    start_speed, end_speed, duration : float
        The ramp w0 -> w1 (rad/s) in ``duration`` s (w1 < w0: a coast-down).
    runout_x, runout_y : complex
        The probes' run-out 1x vectors (m).
    samples : int
        Samples per revolution of the order tracking.
    """

    def __init__(self, critical_speed: float, damping_ratio: float, eccentricity: float, angle: float,
                 start_speed: float, end_speed: float, duration: float, runout_x: complex = 0j,
                 runout_y: complex = 0j, samples: int = 32):
        from scipy.integrate import solve_ivp

        wn, z, eps = critical_speed, damping_ratio, eccentricity * np.exp(1j * angle)
        w0, alpha = start_speed, (end_speed - start_speed) / duration
        self.truth = {"critical_speed": wn, "damping_ratio": z, "eccentricity": eccentricity, "angle": angle}
        self.alpha, self.w0 = alpha, w0
        revs = int((w0 * duration + alpha * duration**2 / 2) / (2 * math.pi))
        phis = 2 * math.pi * (np.arange(revs * samples + 1) / samples)
        t = self._time(phis)

        def f(tt, s):
            w, phi = w0 + alpha * tt, w0 * tt + alpha * tt**2 / 2
            F = eps * (w**2 - 1j * alpha) * np.exp(1j * phi)
            return [s[2], s[3], F.real - 2 * z * wn * s[2] - wn**2 * s[0], F.imag - 2 * z * wn * s[3] - wn**2 * s[1]]

        u0 = eps * w0**2 / (wn**2 - w0**2 + 2j * z * wn * w0)
        sol = solve_ivp(f, (0, t[-1]), [u0.real, u0.imag, (1j * w0 * u0).real, (1j * w0 * u0).imag],
                        method="DOP853", t_eval=t, rtol=1e-10, atol=1e-10 * eccentricity, dense_output=True)
        self.phi, self.t, self.solution, self.runout = phis, t, sol.sol, (runout_x, runout_y)
        self.clean_x, self.clean_y = self._probes(t, phis)
        self.samples, self.revs = samples, revs

    def _probes(self, t, phi):
        u = self.solution(t)
        e_phi = np.exp(1j * phi)
        return u[0] + (self.runout[0] * e_phi).real, u[1] + (self.runout[1] * e_phi).real

    def _time(self, phi):
        if self.alpha == 0:
            return phi / self.w0
        return (-self.w0 + np.sqrt(self.w0**2 + 2 * self.alpha * phi)) / self.alpha

    def signals(self, rate: float, noise: float = 0.0, rng: np.random.Generator | None = None,
                width: float = 0.3) -> dict:
        """Raw signals sampled at ``rate`` (Hz) over the whole revolutions: time (s), probe x and y (m, with white
        noise ``noise``) and a key-phasor (5 V over ``width`` rad after each pulse at phi = 2 pi k, else 0 V)."""
        rng = rng or np.random.default_rng(0)
        t = np.arange(0.0, self.t[-1], 1.0 / rate)
        phi = self.w0 * t + self.alpha * t**2 / 2
        x, y = self._probes(t, phi)
        if noise:
            x, y = x + noise * rng.standard_normal(t.size), y + noise * rng.standard_normal(t.size)
        return {"time": t, "x": x, "y": y, "keyphasor": np.where(np.mod(phi, 2 * math.pi) < width, 5.0, 0.0)}

    def vectors(self, noise: float = 0.0, rng: np.random.Generator | None = None) -> dict:
        """The 1x vectors of each revolution (pulse to pulse): time (s, its middle), speed (rad/s, 2 pi over its
        period), x and y (complex, m, x(t) = Re(X e^{i phi})); white noise of standard deviation ``noise`` (m) on
        every sample."""
        rng = rng or np.random.default_rng(0)
        n, s = self.revs, self.samples
        x, y = self.clean_x, self.clean_y
        if noise:
            x = x + noise * rng.standard_normal(x.shape)
            y = y + noise * rng.standard_normal(y.shape)
        # each revolution's samples from pulse to pulse, both ends (the trapezoid rule over the revolution)
        rows = np.arange(n)[:, None] * s + np.arange(s + 1)[None, :]
        kernel = np.exp(-1j * 2 * math.pi * np.arange(s + 1) / s) * 2 / s
        kernel[[0, -1]] /= 2
        pulses = self.t[::s]
        return {"time": (pulses[1:] + pulses[:-1]) / 2, "speed": 2 * math.pi / np.diff(pulses), "x": x[rows] @ kernel,
                "y": y[rows] @ kernel}


# ---- identification ------------------------------------------------------------------------------------------------

def noise_level(x: np.ndarray) -> float:
    """The noise of a sequence of 1x vectors (m, per component): 1.4826 MAD of their second differences over
    sqrt(6) (a second difference removes a response that changes smoothly from vector to vector; the median keeps
    the few vectors of a fast passage from counting as noise)."""
    d = np.diff(np.asarray(x), 2)
    parts = np.concatenate([d.real, d.imag])
    return float(1.4826 * np.median(np.abs(parts - np.median(parts))) / math.sqrt(6))


def _smooth(v: np.ndarray, width: int) -> np.ndarray:
    if width < 2:
        return v
    k = np.ones(width) / width
    pad = np.pad(v, (width // 2, width - 1 - width // 2), mode="edge")
    return np.convolve(pad, k, mode="valid")


@dataclass(frozen=True)
class Classical:
    """The classical readings of a run-up's amplitude: the peak's speed as the critical speed, the damping ratio from
    the half-power points (zeta = 1/(2 AF), API 684 (2005) amplification factor), the 1x vector at service speed."""

    peak_speed: float | None
    peak_amplitude: float | None
    damping_ratio: float | None
    lower: float | None
    upper: float | None
    status: str


def classical_readings(speed: np.ndarray, amplitude: np.ndarray) -> Classical:
    """Read the peak and its half-power points off the measured amplitude (lightly smoothed: a running mean over
    1/100 of the vectors), as an engineer reads a Bode plot."""
    from autobal.analysis.numerics.standards import half_power_readings

    order = np.argsort(speed)
    w, a = np.asarray(speed, float)[order], _smooth(np.asarray(amplitude, float)[order], max(1, len(speed) // 100))
    i = int(np.argmax(a))
    if i in (0, len(a) - 1):
        return Classical(None, None, None, None, None, "the amplitude has no peak inside the measured speed range: "
                         "the critical speed is not crossed")
    r = half_power_readings(lambda s: np.interp(s, w, a), [w[i]], high=w[-1], low=w[0], points=max(4001, 4 * len(w)))
    hp = r[0]
    if hp.factor is None:
        return Classical(hp.peak_speed, hp.peak, None, hp.lower, hp.upper, hp.status or "no half-power points")
    return Classical(hp.peak_speed, hp.peak, 1 / (2 * hp.factor), hp.lower, hp.upper, "")


def _stack(x: np.ndarray, y: np.ndarray | None) -> np.ndarray:
    parts = [x.real, x.imag] + ([y.real, y.imag] if y is not None else [])
    return np.concatenate(parts)


@dataclass(frozen=True)
class Identification:
    """What :func:`identify` found (SI): the transient fit (None without time stamps), the steady-state fit, the
    classical readings, the noise of the vectors and the adequacy test."""

    transient: Fit | None
    steady: Fit
    classical: Classical
    noise: float
    adequacy: dict
    max_speed: float
    min_speed: float


def _starts(classical: Classical, w_lo: float, w_hi: float, rising: bool) -> list[tuple[float, float]]:
    """Starting points (w_n, zeta): about the classical readings, the critical speed below the peak of a run-up and
    above that of a coast-down (the passage effect); above the speed range when there is no peak."""
    if classical.peak_speed is not None:
        z0 = classical.damping_ratio or 0.05
        wns = classical.peak_speed * (np.linspace(0.8, 1.08, 8) if rising else np.linspace(0.92, 1.25, 8))
        zs = [min(max(z0 * f, 2e-3), 0.5) for f in (0.4, 1.0, 2.0)]
    else:
        wns = w_hi * np.array([1.05, 1.25, 1.5, 1.9])
        zs = [0.01, 0.05, 0.2]
    return [(float(w), float(z)) for w in wns if w_lo < w < WN_MAX_FACTOR * w_hi for z in zs]


def fit(fitter: Fitter, data: np.ndarray, starts, lower, upper) -> Fit:
    """The best of the starting points by the linear least squares of eccentricity and run-out at each (w_n, zeta),
    then IPOPT on all parameters from it."""
    best = min(((fitter.linear(wn, z, data), wn, z) for wn, z in starts), key=lambda c: c[0][1])
    (coef, ssr), wn, z = best
    start = np.concatenate([[wn, z], coef])
    sigma = math.sqrt(ssr / max(len(data) - len(start), 1)) or 1.0
    return fitter.solve(data, start, lower, upper, sigma)


def adequacy(residual_std: float, dof: int, noise: float, noise_dof: int, significance: float = 0.05) -> dict:
    """F test of the residual variance against the noise variance of the vectors (:func:`noise_level`): adequate
    when F = s^2/sigma^2 <= F_crit(1 - significance; dof, noise_dof), the lack-of-fit test of
    analysis/numerics/adequacy.py with the vectors' own scatter as the pure error; a given noise (``noise_dof``
    infinite) by the chi-square test F_crit = chi2(1 - significance; dof)/dof."""
    if not (noise > 0 and dof > 0 and noise_dof > 0):
        return {"F": None, "F_crit": None, "p_value": None, "adequate": None, "significance": significance,
                "note": "no noise level: the vectors are too few or identical"}
    F = residual_std**2 / noise**2
    if math.isinf(noise_dof):  # a noise given: known, the chi-square test of s^2/sigma^2 on dof
        crit, p = float(stats.chi2.ppf(1 - significance, dof)) / dof, float(stats.chi2.sf(F * dof, dof))
    else:
        crit, p = float(stats.f.ppf(1 - significance, dof, noise_dof)), float(stats.f.sf(F, dof, noise_dof))
    return {"F": float(F), "F_crit": crit, "p_value": p, "adequate": bool(F <= crit), "significance": significance}


def identify(time, speed, x, y=None, *, runout: bool = True, noise: float | None = None,
             model: TransientModel | None = None, fitters: dict | None = None) -> Identification:
    """Identify the Jeffcott rotor from 1x vectors (see the module docstring).

    Parameters
    ----------
    time : array (K,) or None
        s, at each vector; None: no transient fit (the steady-state fit and the classical readings only).
    speed : array (K,)
        rad/s, strictly monotonic.
    x, y : complex arrays (K,)
        The probes' 1x vectors, m (x(t) = Re(X e^{i phi})); y None: one probe.
    runout : bool
        Fit a constant run-out vector per probe (False: it was subtracted, or there is none).
    noise : float, optional
        The vectors' noise (m per component); default :func:`noise_level` of the data.
    model, fitters : optional
        A :class:`TransientModel` of these times and speeds and a cache of its :class:`Fitter`s, to reuse them
        over many data sets on one speed profile.
    """
    speed = np.asarray(speed, float)
    x = np.asarray(x, complex)
    y = None if y is None else np.asarray(y, complex)
    probes = 1 if y is None else 2
    data = _stack(x, y)
    amp = np.abs(x) if y is None else np.sqrt((np.abs(x) ** 2 + np.abs(y) ** 2) / 2)
    classical = classical_readings(speed, amp)
    w_lo, w_hi = float(speed.min()), float(speed.max())
    starts = _starts(classical, w_lo, w_hi, bool(speed[-1] > speed[0]))
    n = 4 + (2 * probes if runout else 0)
    lower = np.concatenate([[0.2 * w_lo if w_lo > 0 else 1e-3 * w_hi, 1e-4], np.full(n - 2, -np.inf)])
    upper = np.concatenate([[WN_MAX_FACTOR * w_hi, 1.0], np.full(n - 2, np.inf)])
    fitters = {} if fitters is None else fitters
    key = ("steady", probes, runout)
    if key not in fitters:
        fitters[key] = Fitter(_steady_unit(speed), len(speed), probes, runout)
    steady = fit(fitters[key], data, starts, lower, upper)
    transient = None
    if time is not None:
        if model is None:
            model = TransientModel(time, speed, WN_MAX_FACTOR * w_hi)
        key = ("transient", probes, runout)
        if key not in fitters:
            fitters[key] = Fitter(model.unit, len(speed), probes, runout)
        transient = fit(fitters[key], data, starts, lower, upper)
    sigma = float(noise) if noise is not None else math.sqrt(
        np.mean([noise_level(v) ** 2 for v in ([x] if y is None else [x, y])]))
    head = transient or steady
    # a given noise is known (infinite degrees of freedom: the chi-square test); an estimated one has the second
    # differences' components
    ad = adequacy(head.residual_std, head.dof, sigma, (len(speed) - 2) * 2 * probes if noise is None else math.inf)
    return Identification(transient, steady, classical, sigma, ad, w_hi, w_lo)


# ---- the typed Result ----------------------------------------------------------------------------------------------

def _speed(description: str, **kw):
    return quantity("rad/s", "ω", description, "rpm", **kw)


def _length(description: str, symbol: str = "e", **kw):
    return quantity("m", symbol, description, "µm", **kw)


def _angle(description: str, symbol: str = "θ", **kw):
    return quantity("deg", symbol, description, **kw)


def _ratio(description: str, symbol: str = "ζ", **kw):
    return quantity("1", symbol, description, **kw)


@record
class Fitted(Record):
    """One fit of the 1x vectors (transient or steady-state): estimates with 95 % Student-t intervals (Gauss-Newton
    covariance), the residual, the conditioning and the solver's report."""

    critical_speed: float = _speed("critical speed ω_n = sqrt(c/m) fitted")
    critical_speed_ci: np.ndarray = _speed("95 % interval of the critical speed")
    damping_ratio: float = _ratio("damping ratio ζ = χ/(2 sqrt(c m)) fitted")
    damping_ratio_ci: np.ndarray = _ratio("95 % interval of the damping ratio")
    eccentricity: float = _length("eccentricity e = |ε| of the mass centre fitted")
    eccentricity_ci: np.ndarray = _length("95 % interval of the eccentricity (delta method)")
    unbalance_angle_deg: float = _angle("unbalance angle θ = arg ε from the key-phasor mark, in the direction of "
                                        "rotation")
    unbalance_angle_ci_deg: np.ndarray = _angle("95 % interval of the unbalance angle")
    residual_std: float = _length("standard deviation of the residual per component of a vector", "s")
    dof: int = quantity("1", "ν", "degrees of freedom of the residual (components - parameters)")
    parameters: list[str]
    correlation: np.ndarray = _ratio("correlation matrix of the parameters (order of parameters)", "ρ")
    condition_number: float = _ratio("condition number of the Jacobian scaled by the parameters' magnitudes",
                                     "κ")
    weakest_direction: np.ndarray = _ratio("right singular vector of the smallest singular value (relative "
                                           "changes of the parameters that change the fit least)", "v_min")
    status: str
    iterations: int = quantity("1", "", "IPOPT iterations")
    runout_x: np.ndarray | None = quantity("m", "r_x", "run-out 1x vector of probe x [Re, Im] (x = Re(r e^{iφ}))",
                                           "µm", optional=True)
    runout_y: np.ndarray | None = quantity("m", "r_y", "run-out 1x vector of probe y [Re, Im]", "µm", optional=True)


@record
class ClassicalReading(Record):
    """The classical readings of the amplitude (slow, steady run-up assumed) and their difference from the transient
    fit (their bias at the run's rate)."""

    peak_speed: float | None = _speed("speed of the amplitude's peak, read as the critical speed", optional=True)
    peak_amplitude: float | None = _length("amplitude at the peak (0-peak)", "A_max", optional=True)
    damping_ratio: float | None = _ratio("damping ratio from the half-power points, 1/(2 AF)", optional=True)
    half_power_speeds: np.ndarray | None = _speed("half-power speeds N_1, N_2 (0.707 of the peak)", optional=True)
    eccentricity: float | None = _length("eccentricity read from the 1x vector at the service speed over the "
                                         "steady response of the classical critical speed and damping",
                                         optional=True)
    service_amplitude: float | None = _length("1x amplitude of probe x at the service speed (0-peak)", "A_s",
                                              optional=True)
    service_lag_deg: float | None = _angle("phase lag of probe x at the service speed", "φ_s", optional=True)
    critical_speed_bias_pct: float | None = quantity("%", "Δω", "peak speed over the transient fit's critical "
                                                     "speed, - 1", optional=True)
    damping_ratio_bias_pct: float | None = quantity("%", "Δζ", "half-power damping over the transient fit's, - 1",
                                                    optional=True)
    status: str = ""


@record
class Adequacy(Record):
    """F test of the residual variance against the noise of the vectors (their second differences' spread)."""

    noise: float = _length("noise of a vector per component (given, or 1.4826 MAD of the second differences / √6)",
                           "σ")
    residual_std: float = _length("residual standard deviation per component", "s")
    significance: float = _ratio("significance of the test", "α")
    F: float | None = _ratio("F = s²/σ²", "F", optional=True)
    F_crit: float | None = _ratio("F_crit at the significance", "F_crit", optional=True)
    p_value: float | None = _ratio("p value of F", "p", optional=True)
    adequate: bool | None = None
    note: str = ""


@record
class Margins(Record):
    """API 684 (2005) amplification factor and separation margin of the identified rotor's steady response."""

    amplification_factor: float | None = _ratio("AF = N_c/(N_2 - N_1) of the identified rotor's steady response",
                                                "AF", source=API_AF, optional=True)
    separation_margin_pct: float | None = quantity("%", "SM", "separation margin from the service speed",
                                                   source=API_SM, optional=True)
    required_separation_margin_pct: float | None = quantity("%", "SM_req", "separation margin required for the AF",
                                                            source=API_SM, optional=True)
    separation_margin_ok: bool | None = None
    words: str = ""


@record
class Series(Record):
    """The measured and fitted 1x vectors, amplitude (0-peak) and phase lag from the key-phasor, per vector."""

    speed: np.ndarray = _speed("shaft speed of each vector")
    x_amplitude: np.ndarray = _length("measured 1x amplitude of probe x (0-peak)", "|X|")
    x_lag_deg: np.ndarray = _angle("measured phase lag of probe x", "φ_x")
    steady_x_amplitude: np.ndarray = _length("fitted 1x amplitude of probe x (steady-state fit)", "|X|")
    steady_x_lag_deg: np.ndarray = _angle("fitted phase lag of probe x (steady-state fit)", "φ_x")
    fit_x_amplitude: np.ndarray | None = _length("fitted 1x amplitude of probe x (transient)", "|X|", optional=True)
    fit_x_lag_deg: np.ndarray | None = _angle("fitted phase lag of probe x (transient)", "φ_x", optional=True)
    time: np.ndarray | None = quantity("s", "t", "time of each vector", optional=True)
    y_amplitude: np.ndarray | None = _length("measured 1x amplitude of probe y (0-peak)", "|Y|", optional=True)
    y_lag_deg: np.ndarray | None = _angle("measured phase lag of probe y", "φ_y", optional=True)
    fit_y_amplitude: np.ndarray | None = _length("fitted 1x amplitude of probe y", "|Y|", optional=True)
    fit_y_lag_deg: np.ndarray | None = _angle("fitted phase lag of probe y", "φ_y", optional=True)


@record
class RunupResult(TypedResult):
    """The rotor identified from a measured run-up or coast-down (see the module docstring)."""

    title: str
    identified: bool
    reason: str
    max_speed: float = _speed("highest measured speed")
    min_speed: float = _speed("lowest measured speed")
    acceleration: float = quantity("rad/s^2", "α", "mean rate of the run (speed range over duration; 0 without time)")
    undetermined: str
    critical_speed: float | None = _speed("critical speed ω_n identified (transient fit)", headline=1,
                                          optional=True)
    damping_ratio: float | None = _ratio("damping ratio ζ identified (transient fit)", headline=2, optional=True)
    eccentricity: float | None = _length("eccentricity e of the mass centre identified", headline=3, optional=True)
    unbalance_angle_deg: float | None = _angle("unbalance angle from the key-phasor mark, in the direction of "
                                               "rotation", headline=4, optional=True)
    mass: float | None = quantity("kg", "m", "modal mass (given, or the given stiffness over ω_n²)", optional=True)
    unbalance: float | None = quantity("kg*m", "U", "unbalance U = m e", "g·mm", headline=5, optional=True)
    unbalance_ci: np.ndarray | None = quantity("kg*m", "U", "95 % interval of the unbalance", "g·mm",
                                               optional=True)
    stiffness: float | None = quantity("N/m", "c", "shaft stiffness c = m ω_n²", "kN/m", optional=True)
    damping: float | None = quantity("N*s/m", "χ", "viscous damping χ = 2 ζ m ω_n", optional=True)
    service_speed: float | None = _speed("service speed (given)", optional=True)
    balance_grade: float | None = quantity("m/s", "G", "balance quality grade G = e Ω at the service speed (G 2.5 "
                                           "is 2.5 mm/s)", "mm/s", source=ISO_G, headline=6, optional=True)
    transient: Fitted | None = optional()
    steady: Fitted | None = optional()
    classical: ClassicalReading | None = optional()
    adequacy: Adequacy | None = optional()
    margins: Margins | None = optional()
    series: Series | None = optional()
    rotor_yaml: str = ""
    notes: list[str] = dataclasses.field(default_factory=list)
    name = "runup"

    def verdict(self) -> tuple[bool | None, str]:
        return self.identified, self.reason

    def summary(self) -> str:
        lines = [f"run-up identification: {'identified' if self.identified else 'NOT identified'} - {self.reason}"]
        for row in self.headline():
            lines.append(f"  {row['quantity']}: {row['value']} {row['unit']}".rstrip()
                         + (f" ({row['beside']})" if row["beside"] else ""))
        c = self.classical
        if c is not None and c.peak_speed is not None:
            q = QUANTITIES.find("classical.peak_speed")
            lines.append(f"  classical: peak at {q.text(c.peak_speed)}"
                         + (f" ({c.critical_speed_bias_pct:+.2f} % from the transient fit)"
                            if c.critical_speed_bias_pct is not None else "")
                         + (f", half-power ζ {c.damping_ratio:.4g}" if c.damping_ratio is not None else "")
                         + (f" ({c.damping_ratio_bias_pct:+.1f} %)" if c.damping_ratio_bias_pct is not None else ""))
        return "\n".join(lines)

    def tables(self) -> dict[str, dict]:
        s = self.series
        if s is None:
            return {}
        cols = {k: v for k, v in s.to_dict().items() if v is not None}
        return {"runup_vectors.csv": QUANTITIES.columns(cols, "series")}

    def write(self, folder):
        """The tables and figures, and the identified rotor as a spin-up scene's ``rotor:`` section."""
        from pathlib import Path

        paths, captions = super().write(folder)
        if self.rotor_yaml:
            p = Path(folder) / "identified_rotor.yaml"
            p.write_text(self.rotor_yaml, encoding="utf-8")
            paths.append(p)
        return paths, captions

    def draw(self, ax) -> None:
        """Bode amplitude of probe x: measured, transient fit, steady-state fit."""
        s = self.series
        f = unit_axis(ax, "1x amplitude |X| (0-peak)", "m", "µm")
        rpm = unit_axis(ax, "speed ω", "rad/s", "rpm", which="x")
        if s.fit_x_amplitude is not None:
            ax.plot(s.speed * rpm, s.fit_x_amplitude * f, "-", lw=1.0, label="transient fit")
        ax.plot(s.speed * rpm, s.steady_x_amplitude * f, "--", lw=1.0, label="steady-state fit")
        ax.plot(s.speed * rpm, s.x_amplitude * f, "o", ms=2.5, mfc="none", color="k", lw=0, label="measured")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)

    def figures(self) -> dict:
        s = self.series
        if s is None:
            return {}
        fig, (a1, a2) = new_figure((7.5, 7.0), 2, 1)
        self.draw(a1)
        rpm = unit_axis(a2, "speed ω", "rad/s", "rpm", which="x")
        if s.fit_x_lag_deg is not None:
            a2.plot(s.speed * rpm, s.fit_x_lag_deg, "-", lw=1.0, label="transient fit")
        a2.plot(s.speed * rpm, s.steady_x_lag_deg, "--", lw=1.0, label="steady-state fit")
        a2.plot(s.speed * rpm, s.x_lag_deg, "o", ms=2.5, mfc="none", color="k", lw=0, label="measured")
        a2.set_ylabel("phase lag φ_x (deg, from the key-phasor)")
        a2.grid(alpha=0.3)
        fig.suptitle(f"{self.title}: Bode plot of probe x", fontsize=9)
        out = {"fig_runup_bode.png": Figure(
            fig, "Bode plot of probe x: the measured 1x vectors (amplitude 0-peak and phase lag from the key-phasor) "
                 "against speed, beside the transient fit driven by the measured speed profile and the steady-state "
                 "fit; the gap between the two fits is the passage effect of the run-up rate")}
        fig2, (b1, b2) = new_figure((10, 4.6), 1, 2)
        f = unit_axis(b1, "Re X", "m", "µm", which="x", other="")  # the chosen length unit
        unit_axis(b1, "Im X", "m", "µm", other="")
        rpm = unit_axis(b2, "speed ω", "rad/s", "rpm", which="x")
        for amp, lag, style, label in ((s.x_amplitude, s.x_lag_deg, ".", "measured"),
                                       (s.fit_x_amplitude, s.fit_x_lag_deg, "-", "transient fit"),
                                       (s.steady_x_amplitude, s.steady_x_lag_deg, "--", "steady-state fit")):
            if amp is None:
                continue
            z = amp * f * np.exp(-1j * np.radians(lag))  # X = |X| e^{-i lag}
            b1.plot(z.real, z.imag, style, ms=3, lw=1, label=label)
        b1.set_aspect("equal", adjustable="datalim")
        b1.set_title("polar plot of probe x (x = Re(X e^{iφ}))", fontsize=8)
        b1.grid(alpha=0.3)
        b1.legend(fontsize=7)
        if s.fit_x_amplitude is not None:
            meas = s.x_amplitude * np.exp(-1j * np.radians(s.x_lag_deg))
            fitx = s.fit_x_amplitude * np.exp(-1j * np.radians(s.fit_x_lag_deg))
            b2.plot(s.speed * rpm, np.abs(meas - fitx) * f, ".", ms=3, label="|measured - transient fit|")
        stx = s.steady_x_amplitude * np.exp(-1j * np.radians(s.steady_x_lag_deg))
        meas = s.x_amplitude * np.exp(-1j * np.radians(s.x_lag_deg))
        b2.plot(s.speed * rpm, np.abs(meas - stx) * f, "x", ms=3, label="|measured - steady-state fit|")
        if self.adequacy is not None:
            b2.axhline(self.adequacy.noise * f * math.sqrt(2), color="k", lw=0.8, ls=":",
                       label="noise √2 σ (a vector's)")
        unit_axis(b2, "residual |ΔX|", "m", "µm", other="")
        b2.grid(alpha=0.3)
        b2.legend(fontsize=7)
        fig2.suptitle(self.title, fontsize=9)
        out["fig_runup_polar_residual.png"] = Figure(
            fig2, "Polar plot of probe x's 1x vectors (measured, transient fit, steady-state fit) and the residual "
                  "|measured − fit| against speed beside the noise of a vector: a residual above the noise where the "
                  "rotor crosses its critical speed is what the steady-state reading misses")
        return out


RunupResult.quantities = QUANTITIES = declarations(RunupResult)


# ---- the study -----------------------------------------------------------------------------------------------------

def _fitted(f: Fit) -> Fitted:
    e, elo, ehi = f.eccentricity()
    th, tlo, thi = f.angle()
    names = list(f.names)
    ro = {k: np.array([f.value(f"runout_{k}_re"), f.value(f"runout_{k}_im")]) if f"runout_{k}_re" in names else None
          for k in ("x", "y")}
    return Fitted(critical_speed=f.value("critical_speed"), critical_speed_ci=np.array(f.interval("critical_speed")),
                  damping_ratio=f.value("damping_ratio"), damping_ratio_ci=np.array(f.interval("damping_ratio")),
                  eccentricity=e, eccentricity_ci=np.array([elo, ehi]), unbalance_angle_deg=math.degrees(th),
                  unbalance_angle_ci_deg=np.degrees([tlo, thi]), residual_std=f.residual_std, dof=f.dof,
                  parameters=names, correlation=f.correlation, condition_number=f.condition,
                  weakest_direction=f.weakest, status=f.status, iterations=f.iterations, runout_x=ro["x"],
                  runout_y=ro["y"])


def _half_width(value: float, ci) -> float:
    return (ci[1] - ci[0]) / 2 / abs(value) if value else math.inf


def _weakest_words(f: Fit) -> str:
    """The smallest singular vector of the scaled Jacobian in words: the relative changes that move the fit least."""
    v = f.weakest * np.sign(f.weakest[np.argmax(np.abs(f.weakest))])
    parts = [f"{SYMBOLS[n]} {c:+.2f}" for n, c in zip(f.names, v, strict=True) if abs(c) >= 0.3]
    return (f"the data determine least the combination of relative changes ({', '.join(parts)}) "
            f"(condition number {f.condition:.3g})")


def _lag(v: np.ndarray) -> np.ndarray:
    """The analyser's phase lag in degrees of x(t) = Re(X e^{i phi}): -angle(X), unwrapped, in (-180, 540]."""
    return np.degrees(np.unwrap(-np.angle(v)))


def rotor_section(mass: float | None, fit: Fitted, unbalance: tuple | None) -> str:
    """The identified rotor as the ``rotor:`` section of a spin-up scene (datasheet form, units written), with
    the 95 % intervals as comments; without a mass the ``mass`` line is left for the engineer to fill in."""
    rpm = convert(1.0, "rad/s", "rpm")
    lo, hi = fit.critical_speed_ci * rpm
    zlo, zhi = fit.damping_ratio_ci
    elo, ehi = fit.eccentricity_ci * 1e6
    lines = ["# the rotor identified from a run-up (autobal analyses.runup, transient fit); 95 % intervals as "
             "comments", "rotor:"]
    lines.append(f"  mass: {mass:.6g} kg" if mass is not None else
                 "  # mass: ... kg        # not identified from vibration alone: give the modal mass")
    lines.append(f"  critical_speed: {fit.critical_speed * rpm:.6g} rpm   # 95 %: {lo:.6g} to {hi:.6g} rpm")
    lines.append(f"  damping_ratio: {fit.damping_ratio:.5g}   # 95 %: {zlo:.4g} to {zhi:.4g}")
    if unbalance is not None:
        u, ulo, uhi = (x * 1e6 for x in unbalance)
        lines.append(f"  unbalance: {{residual: {u:.5g} g*mm}}   # 95 %: {ulo:.4g} to {uhi:.4g} g*mm; e = "
                     f"{fit.eccentricity * 1e6:.4g} um ({elo:.4g} to {ehi:.4g})")
    else:
        lines.append(f"  eccentricity: {fit.eccentricity * 1e6:.5g} um   # 95 %: {elo:.4g} to {ehi:.4g} um")
    lines.append(f"  # unbalance angle {fit.unbalance_angle_deg:.4g} deg from the key-phasor mark in the direction "
                 "of rotation")
    return "\n".join(lines) + "\n"


def run(data, *, title: str = "", mass: float | None = None, stiffness: float | None = None,
        service_speed: float | None = None, runout: bool = True, noise: float | None = None,
        max_relative_interval: float = 0.25, significance: float = 0.05) -> RunupResult:
    """Identify the rotor from one run-up's 1x vectors.

    Parameters
    ----------
    data
        The 1x vectors: an object with ``speed`` (rad/s), ``x``, ``y`` (complex, m, or y None), ``time`` (s or None)
        and ``notes`` (autobal.runup_data.OneX).
    mass, stiffness : float, optional
        The modal mass (kg) or the shaft stiffness (N/m, e.g. a static deflection under a known load): then
        m e (kg m), c and chi are reported; not both.
    service_speed : float, optional
        rad/s: the 1x vector read there, the ISO 21940-11 grade, the API 684 separation margin.
    runout : bool
        Fit a constant run-out vector per probe.
    noise : float, optional
        The vectors' noise, m per component (default: from their second differences).
    max_relative_interval : float
        Identified only when each of w_n, zeta and e has a 95 % interval half-width below this fraction of its value.
    """
    from autobal.analysis.numerics.standards import balance_grade, half_power_readings, margin_check, margin_words
    from autobal.errors import SolveError

    if mass is not None and stiffness is not None:
        raise ValueError("give the modal mass or the stiffness, not both")
    speed, x = np.asarray(data.speed, float), np.asarray(data.x, complex)
    y = None if data.y is None else np.asarray(data.y, complex)
    time = None if data.time is None else np.asarray(data.time, float)
    idn = identify(time, speed, x, y, runout=runout, noise=noise)
    for name, f in (("transient", idn.transient), ("steady-state", idn.steady)):
        if f is not None and not f.success:
            raise SolveError(f"the {name} fit of the run-up did not converge", f.status,
                             {"estimate": dict(zip(f.names, f.estimate.tolist(), strict=True))})
    head = idn.transient or idn.steady
    T = _fitted(head)
    steady = _fitted(idn.steady)
    wn, zeta, ecc = T.critical_speed, T.damping_ratio, T.eccentricity
    # what the data determine
    widths = {"ω_n": _half_width(wn, T.critical_speed_ci), "ζ": _half_width(zeta, T.damping_ratio_ci),
              "e": _half_width(ecc, T.eccentricity_ci)}
    loose = [f"{k} ± {100 * v:.3g} %" if math.isfinite(v) else f"{k} undetermined (singular Jacobian)"
             for k, v in widths.items() if not v <= max_relative_interval]
    weakest = _weakest_words(head)
    rpm = convert(1.0, "rad/s", "rpm")
    lo, hi = (wn, wn) if not np.all(np.isfinite(T.critical_speed_ci)) else T.critical_speed_ci
    crossed = idn.max_speed > hi and idn.min_speed < lo
    reasons = []
    if not crossed:
        below = idn.max_speed <= hi
        at = idn.max_speed if below else idn.min_speed
        band = (f"95 %: {T.critical_speed_ci[0] * rpm:.5g} to {T.critical_speed_ci[1] * rpm:.5g} rpm"
                if np.all(np.isfinite(T.critical_speed_ci)) else "its interval undetermined")
        what = ("below it the response is the unbalance over the stiffness, X ≈ ε ω²/ω_n², so only e/ω_n² is "
                "determined" if below else
                "above it the response tends to X ≈ -ε, which a constant run-out vector imitates, so e is determined "
                "only without run-out (slow-roll subtracted, runout false)")
        reasons.append(f"the run's {'highest' if below else 'lowest'} speed {at * rpm:.5g} rpm is "
                       f"{'below' if below else 'above'} the critical speed (fitted {wn * rpm:.5g} rpm, {band}): "
                       f"{what}; the damping ratio and the critical speed are not")
    if loose:
        reasons.append(f"95 % intervals wider than ±{100 * max_relative_interval:.3g} %: {', '.join(loose)}; "
                       + weakest)
    if time is None:
        reasons.append("the vectors have no time stamps: only the steady-state fit, biased by the run's rate")
    identified = not reasons
    if identified:
        reason = (f"identified from the {'run-up' if speed[-1] > speed[0] else 'coast-down'} as it was run: "
                  f"ω_n {wn * rpm:.5g} rpm ± {100 * widths['ω_n']:.2g} %, ζ {zeta:.4g} ± {100 * widths['ζ']:.2g} %, "
                  f"e {ecc * 1e6:.4g} µm ± {100 * widths['e']:.2g} % (95 %)")
    else:
        reason = "not identifiable from these data: " + "; ".join(reasons)
    ad = idn.adequacy
    adequacy = Adequacy(noise=idn.noise, residual_std=head.residual_std, significance=ad["significance"], F=ad["F"],
                        F_crit=ad["F_crit"], p_value=ad["p_value"], adequate=ad["adequate"], note=ad.get("note", ""))
    if identified and ad["adequate"] is False:
        identified = False
        reason = (f"the Jeffcott rotor does not fit these data within their noise (F = {ad['F']:.3g} > F_crit = "
                  f"{ad['F_crit']:.3g}): a second mode, anisotropic supports or a rub; the numbers are not "
                  "identified")
    # mass, unbalance, grade
    m = mass if mass is not None else (stiffness / wn**2 if stiffness is not None else None)
    unb = None
    if m is not None:
        if mass is not None:
            unb = (m * ecc, m * T.eccentricity_ci[0], m * T.eccentricity_ci[1])
        else:  # U = c e / w_n^2: the interval by the delta method over (w_n, eps)
            i = [head.names.index(k) for k in ("critical_speed", "eps_re", "eps_im")]
            eps = head.eps
            g = np.array([-2 * stiffness * ecc / wn**3, stiffness * eps.real / ecc / wn**2,
                          stiffness * eps.imag / ecc / wn**2])
            se = math.sqrt(float(g @ head.covariance[np.ix_(i, i)] @ g))
            u = stiffness * ecc / wn**2
            unb = (u, u - head._t() * se, u + head._t() * se)
    classical = idn.classical
    cl_e = sa = sl = None
    if service_speed is not None:
        Xs = complex(np.interp(service_speed, speed, x.real), np.interp(service_speed, speed, x.imag)) \
            if speed.min() <= service_speed <= speed.max() else None
        if Xs is not None:
            sa, sl = abs(Xs), math.degrees(-np.angle(Xs))
            if classical.peak_speed is not None and classical.damping_ratio is not None:
                H = steady_response(service_speed, classical.peak_speed, classical.damping_ratio)[0]
                cl_e = abs(Xs) / abs(H)

    def bias(a, b):
        return None if a is None or b is None else 100 * (a / b - 1)

    cr = ClassicalReading(
        peak_speed=classical.peak_speed, peak_amplitude=classical.peak_amplitude,
        damping_ratio=classical.damping_ratio,
        half_power_speeds=None if classical.lower is None else np.array([classical.lower, classical.upper]),
        eccentricity=cl_e, service_amplitude=sa, service_lag_deg=sl,
        critical_speed_bias_pct=bias(classical.peak_speed, wn) if idn.transient else None,
        damping_ratio_bias_pct=bias(classical.damping_ratio, zeta) if idn.transient else None, status=classical.status)
    margins = None
    if identified:
        reading = half_power_readings(lambda w: np.abs(steady_response(w, wn, zeta)), [wn],
                                      high=3 * max(wn, service_speed or 0), points=8001)[0]
        chk = margin_check(reading, service_speed)
        margins = Margins(amplification_factor=chk["amplification_factor"],
                          separation_margin_pct=chk["separation_margin_pct"],
                          required_separation_margin_pct=chk["required_separation_margin_pct"],
                          separation_margin_ok=chk["separation_margin_ok"], words=margin_words(chk))
    # the series
    fx, fy = (idn.transient.fitted_x, idn.transient.fitted_y) if idn.transient else (None, None)
    sx = idn.steady.fitted_x
    series = Series(speed=speed, x_amplitude=np.abs(x), x_lag_deg=_lag(x), steady_x_amplitude=np.abs(sx),
                    steady_x_lag_deg=_lag(sx), time=time, fit_x_amplitude=None if fx is None else np.abs(fx),
                    fit_x_lag_deg=None if fx is None else _lag(fx), y_amplitude=None if y is None else np.abs(y),
                    y_lag_deg=None if y is None else _lag(y), fit_y_amplitude=None if fy is None else np.abs(fy),
                    fit_y_lag_deg=None if fy is None else _lag(fy))
    acc = 0.0 if time is None else float((speed[-1] - speed[0]) / (time[-1] - time[0]))
    ok = identified
    known = ok and m is not None
    return RunupResult(
        title=title, identified=ok, reason=reason, max_speed=idn.max_speed, min_speed=idn.min_speed,
        acceleration=acc, undetermined=weakest,
        critical_speed=wn if ok else None, damping_ratio=zeta if ok else None, eccentricity=ecc if ok else None,
        unbalance_angle_deg=T.unbalance_angle_deg if ok else None, mass=m if known else None,
        unbalance=unb[0] if known else None, unbalance_ci=np.array(unb[1:]) if known else None,
        stiffness=m * wn**2 if known else None, damping=2 * zeta * m * wn if known else None,
        service_speed=service_speed,
        balance_grade=balance_grade(ecc, service_speed) if ok and service_speed else None,
        transient=_fitted(idn.transient) if idn.transient else None, steady=steady, classical=cr,
        adequacy=adequacy, margins=margins, series=series, rotor_yaml=rotor_section(m, T, unb) if ok else "",
        notes=list(getattr(data, "notes", ()) or ()))
