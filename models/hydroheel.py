"""The traditional balance disc (hydro-heel) of Pavlenko (2014), chapter 1.2: statics and seal wear.

A balance disc without barrier supply or regulator: discharge -> inner annular seal (laminar,
g1) -> chamber 2 -> face gap (laminar, g_TB u^3) -> chamber 3 -> outer seal (laminar, g3) ->
drain.  Dimensionless as in the source: psi = p/p_B, tau = T/(p_B s_B), u = z/z_B, and in this
chapter chi = h1/z_B is the dimensionless radial clearance of the inner seal (1.31), which grows
as the seal wears (1.38).

Static model (1.22):  tau = sigma (psi2 - psi3) + chi_pr;  psi1 - psi2 = alpha_T1 u^3 (psi2 - psi3);
psi1 - psi2 = alpha_31 (psi3 - psi4).  Closed forms (1.25)-(1.29) (Pavlenko 2014, ch. 1.2, with the
psi4 terms re-derived), the geometry form (1.30)-(1.35), the failure-free region (1.36) and the
flow characteristic (1.51)-(1.52).  Wear: chi(t) = chi0 + b t (1.38), b a normal wear rate
truncated to b >= 0 (1.39)-(1.41).

The same disc with *turbulent* throttles, Q = g sqrt(dp), is the model of the parameter
estimation of Pavlenko (2014), Sec. 4.4, Eqs. (4.16)-(4.31): :class:`TurbulentDisc`.  Its force
law is (1.28) with alpha_T1 replaced by alpha^2 (alpha = g_TB/g1), so both share
:func:`load_from_gap` and :func:`gap_from_load`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.special import ndtr


def load_from_gap(u, a, tau_max):
    """Force law of the disc without outer throttle or spring: tau = tau_max / (1 + a u^3).

    Pavlenko (2014), Eq. (1.28) (laminar throttles: a = alpha_T1, tau_max = sigma psi1) and
    Eqs. (4.16)-(4.17) (turbulent throttles: a = alpha^2).  Numbers, numpy arrays or CasADi.

    Parameters
    ----------
    u : float or array or casadi.SX
        Face gap over its base value, u = z/z_B (1).
    a : float or casadi.SX
        Face-to-seal conductance term at u = 1 (1).
    tau_max : float or casadi.SX
        Load at which the gap closes, sigma psi1 (1).

    Returns
    -------
    Load tau = T/(p_B s_B) (1).
    """
    return tau_max / (1.0 + a * u**3)


def gap_from_load(tau, a, tau_max):
    """The inverse of :func:`load_from_gap`: u = [(tau_max/tau - 1)/a]^(1/3).

    Pavlenko (2014), Eq. (1.29) (a = alpha_T1) and Eq. (4.18) (a = alpha^2).  NaN (numpy) for
    tau > tau_max, where no gap balances the load.

    Parameters
    ----------
    tau : float or array or casadi.SX
        Load T/(p_B s_B) (1).
    a : float or casadi.SX
        Face-to-seal conductance term at u = 1 (1).
    tau_max : float or casadi.SX
        Load at which the gap closes (1).

    Returns
    -------
    Face gap u = z/z_B (1).
    """
    return ((tau_max / tau - 1.0) / a) ** (1.0 / 3.0)


def seal_shape_factor(r1: float, l1: float, r2: float, r3: float) -> float:
    """k = l1 (r2 + r3) / (2 r1 (r3 - r2)), Eq. (1.32); any consistent length unit."""
    return l1 * (r2 + r3) / (2.0 * r1 * (r3 - r2))


def conductance_ratio(k: float, chi):
    """alpha_T1 = g_TB/g1 = k / chi^3 with chi = h1/z_B, Eqs. (1.30)-(1.31)."""
    return k / np.asarray(chi, float) ** 3


def initial_clearance(k: float, alpha_T1: float) -> float:
    """chi0 = cbrt(k / alpha_T1): the new seal's clearance h1/z_B that gives alpha_T1, from (1.30)."""
    return float(np.cbrt(k / alpha_T1))


def flow_ratio(u, alpha_T1):
    """Flow characteristic q = Q/Q(u = 1) = (1 + alpha_T1) u^3 / (1 + alpha_T1 u^3), Eq. (1.51).

    Parameters
    ----------
    u : float or array or casadi.SX
        Face gap over its base value (1).
    alpha_T1 : float or casadi.SX
        Face-to-seal conductance ratio g_TB/g1 (1.23) (1).

    Returns
    -------
    Leak flow over its value at u = 1 (1).
    """
    u3 = u**3
    return (1.0 + alpha_T1) * u3 / (1.0 + alpha_T1 * u3)


def max_gap(q_max: float, alpha_T1: float) -> float:
    """u_max = cbrt(q_max / (1 + alpha_T1 (1 - q_max))), Eq. (1.52): the gap at the largest
    admissible leak q_max.  Infinite when the leak can never reach q_max (q_max >= (1+a)/a)."""
    den = 1.0 + alpha_T1 * (1.0 - q_max)
    return float(np.cbrt(q_max / den)) if den > 0 else math.inf


@dataclass(frozen=True)
class HydroHeel:
    """Dimensionless groups of the traditional disc (1.17)-(1.24).

    ``alpha_31 = inf`` is the disc without an outer throttle (g3 -> inf, psi3 = psi4), the case
    (1.28)-(1.36) and the worked example use.
    """

    sigma: float  # s_e / s_B (1.20)
    alpha_T1: float  # g_TB / g1 (1.23)
    alpha_31: float = math.inf  # g3 / g1 (1.24)
    chi_pr: float = 0.0  # push-off preload F_pr / (p_B s_B) (1.19)
    psi4: float = 0.0  # drain pressure / p_B

    def pressures(self, u, psi1):
        """psi2, psi3 at gap u, Eqs. (1.25)-(1.26) (exact solution of the flow balances of (1.22))."""
        a = self.alpha_T1 * np.asarray(u, float) ** 3
        if math.isinf(self.alpha_31):
            return (psi1 + a * self.psi4) / (1.0 + a), np.full_like(a, self.psi4) + 0 * psi1
        a3 = self.alpha_31
        d = a3 + a * (1.0 + a3)
        return ((a3 + a) * psi1 + a3 * a * self.psi4) / d, (a * psi1 + a3 * (1.0 + a) * self.psi4) / d

    def force(self, u, psi1):
        """Axial force the disc balances at gap u, tau(u) of Eq. (1.27) ((1.28) with no outer throttle)."""
        psi2, psi3 = self.pressures(u, psi1)
        return self.sigma * (psi2 - psi3) + self.chi_pr

    def gap(self, tau, psi1):
        """Equilibrium gap u(tau), the inverse of (1.27); (1.29) with no outer throttle.

        NaN where no gap balances tau (tau - chi_pr outside (0, sigma (psi1 - psi4)])."""
        f = (np.asarray(tau, float) - self.chi_pr) / self.sigma  # psi2 - psi3
        dpsi = psi1 - self.psi4
        with np.errstate(divide="ignore", invalid="ignore"):
            if math.isinf(self.alpha_31):
                u3 = (dpsi - f) / (self.alpha_T1 * f)
            else:
                u3 = (self.alpha_31 * dpsi / f - self.alpha_31) / (self.alpha_T1 * (1.0 + self.alpha_31))
            return np.where((f > 0) & (u3 >= 0), np.cbrt(u3), np.nan)

    def residual(self) -> ca.Function:
        """The static system (1.22) as a CasADi Function r(w = [psi2, psi3, u], psi1, tau).

        The third balance is written as (psi1 - psi2)/alpha_31 = psi3 - psi4 so that the disc
        without an outer throttle (alpha_31 = inf) is the same function with 1/alpha_31 = 0."""
        w = ca.SX.sym("w", 3)
        psi1, tau = ca.SX.sym("psi1"), ca.SX.sym("tau")
        psi2, psi3, u = w[0], w[1], w[2]
        r = ca.vertcat(
            self.sigma * (psi2 - psi3) + self.chi_pr - tau,
            psi1 - psi2 - self.alpha_T1 * u**3 * (psi2 - psi3),
            (psi1 - psi2) / self.alpha_31 - (psi3 - self.psi4),
        )
        return ca.Function("hydroheel_statics", [w, psi1, tau], [r], ["w", "psi1", "tau"], ["r"])


@dataclass(frozen=True)
class TurbulentDisc:
    """The traditional disc of Pavlenko (2014), Sec. 4.4: no outer throttle, both throttles
    turbulent (Q1 = g1 sqrt(p1 - p2), Q_T = g_TB u^1.5 sqrt(p2)), Eqs. (4.16)-(4.31).

    The two parameters the source estimates: ``alpha`` = g_TB/g1, the face-to-seal conductance
    ratio at u = 1 (1), and ``tau_max`` = sigma psi1, the load at which the gap closes (4.17) (1).
    Fields may be numbers, numpy arrays or CasADi symbols (the fits use symbols).
    """

    alpha: float
    tau_max: float

    def load(self, u):
        """tau(u) = tau_max/(1 + alpha^2 u^3), Eq. (4.16): (1.28) with alpha_T1 = alpha^2."""
        return load_from_gap(u, self.alpha**2, self.tau_max)

    def gap(self, tau):
        """Static characteristic u(tau) = cbrt[(tau_max/tau - 1)/alpha^2], Eq. (4.18)."""
        return gap_from_load(tau, self.alpha**2, self.tau_max)

    def stiffness(self, tau):
        """Axial stiffness of the disc kappa = -d tau/du = 3 alpha^2 u^2 tau^2/tau_max at the load tau (1: load over
        p_B s_B per unit gap u = h/h_TB), the derivative of (4.16) at u(tau) of (4.18); c = kappa p_B s_B/h_TB, N/m."""
        return 3.0 * self.alpha**2 * self.gap(tau) ** 2 * tau**2 / self.tau_max

    def flow_at_gap(self, u):
        """q = Q/Q_B = sqrt[(1 + alpha^2) u^3/(1 + alpha^2 u^3)], Eq. (4.30): the square root of
        the laminar characteristic (1.51) with alpha_T1 = alpha^2."""
        return flow_ratio(u, self.alpha**2) ** 0.5

    def flow(self, tau):
        """Flow characteristic q(tau) = sqrt[(1 + alpha^2)/alpha^2 (1 - tau/tau_max)], Eq. (4.31)."""
        return ((1.0 + self.alpha**2) / self.alpha**2 * (1.0 - tau / self.tau_max)) ** 0.5


def base_flow(g1: float, g_tb: float, p1: float) -> float:
    """Base flow of the turbulent disc, the flow at u = 1: Q_B = sqrt[g1^2 g_TB^2 p1/(g1^2 + g_TB^2)],
    Pavlenko (2014), Eq. (4.28) (the printed g_c is g1).

    Parameters
    ----------
    g1, g_tb : float
        Turbulent conductances of the inner seal and of the face at u = 1, m^3/(s Pa^0.5).
    p1 : float
        Discharge pressure over the drain, Pa.

    Returns
    -------
    Q_B, m^3/s.
    """
    return math.sqrt(g1**2 * g_tb**2 * p1 / (g1**2 + g_tb**2))


@dataclass(frozen=True)
class WornDisc:
    """The disc of (1.33)-(1.36): no outer throttle, no spring, gap set by the seal clearance chi.

    ``k`` is the seal shape factor (1.32); the face/seal conductance ratio is k/chi^3, so the gap
    at load tau is u = chi cbrt((sigma psi1 - tau)/(k tau)) (1.33).
    """

    sigma: float
    k: float
    psi1: float = 1.0

    def gap(self, chi, tau):
        """u(chi, tau), Eq. (1.33)."""
        tau = np.asarray(tau, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(chi, float) * np.cbrt((self.sigma * self.psi1 - tau) / (self.k * tau))

    def clearance(self, u, tau):
        """chi(tau) that gives gap u at load tau, Eq. (1.34); infinite at tau = sigma psi1."""
        tau = np.asarray(tau, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(u, float) * np.cbrt(self.k * tau / (self.sigma * self.psi1 - tau))

    def load(self, chi, u):
        """tau(chi) that gives gap u, Eq. (1.35): the force law (1.28) with alpha_T1 = k/chi^3 (1.30);
        the bounds tau1, tau2 of region B (1.36) at u_min, u_max."""
        return load_from_gap(np.asarray(u, float), self.k / np.asarray(chi, float) ** 3, self.sigma * self.psi1)


@dataclass(frozen=True)
class WearModel:
    """Linear wear chi(t) = chi0 + b t (1.38) with a truncated normal wear rate b (1.39)-(1.41).

    b_mean, b_std in 1/s (dimensionless clearance per second); the truncation to b >= 0 is exact:
    the normaliser a_b = 1/Phi(b_mean/b_std) (1.40).
    """

    chi0: float
    b_mean: float
    b_std: float

    @property
    def a_b(self) -> float:
        """Normalising factor of the truncated density, Eq. (1.40)."""
        return float(1.0 / ndtr(self.b_mean / self.b_std)) if self.b_std > 0 else 1.0

    def rate_cdf(self, b):
        """P(wear rate <= b) of the truncated normal (1.41); 0 below b = 0."""
        b = np.asarray(b, float)
        if self.b_std == 0:
            return (b >= self.b_mean).astype(float)
        lo = ndtr(-self.b_mean / self.b_std)
        return np.clip((ndtr((b - self.b_mean) / self.b_std) - lo) * self.a_b, 0.0, 1.0)

    def clearance_cdf(self, chi, t):
        """F_chi(chi, t) = P(chi(t) <= chi), Eq. (1.44) with (1.42)-(1.43) (broadcasting in chi, t).

        chi(t) = chi0 + b t with b truncated normal: at t = 0 a step at chi0."""
        chi, t = np.broadcast_arrays(np.asarray(chi, float), np.asarray(t, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            at_t = self.rate_cdf((chi - self.chi0) / t)
        return np.where(t > 0, at_t, (chi >= self.chi0).astype(float))

    def clearance_mean_std(self, t):
        """Mean and standard deviation of chi(t) of the untruncated law, Eq. (1.43)."""
        t = np.asarray(t, float)
        return self.chi0 + self.b_mean * t, self.b_std * t

    def wear_probability(self, depth_ratio: float, t):
        """P(wear chi(t) - chi0 <= depth_ratio) (wear in units of z_B): Fig. 1.27."""
        with np.errstate(divide="ignore"):
            return self.rate_cdf(depth_ratio / np.asarray(t, float))


LOSS_NAMES = ("zeta1", "lambda1", "zeta2", "lambda2")


@dataclass(frozen=True)
class DiscLosses:
    """Geometry and loss coefficients of the turbulent disc's two throttles, for the conductance
    ratio (4.38) of Pavlenko (2014), Sec. 4.4, with the conductance ratio written without the
    printed square root (g_TB/g1 is a ratio of conductances).

    Lengths in m; loss coefficients dimensionless.  ``friction_factor`` f: 0.5 for
    zeta + lambda l/(2h) as in (2.11) and the parameter derivation of Sec. 4.3.3; 1.0 for
    (4.38) as printed.
    """

    face_mean_diameter: float  # d_m = r2 + r3, m
    seal_diameter: float  # d_u (d1) of the annular seal, m
    base_gap: float  # h_TB, m
    seal_clearance: float  # h1, m
    seal_length: float  # l1, m
    face_length: float  # l2 = r3 - r2, m
    zeta1: float = 1.5  # annular seal: local loss
    lambda1: float = 0.06  # annular seal: friction
    zeta2: float = 1.5  # face throttle: local (inlet) loss
    lambda2: float = 0.06  # face throttle: friction
    friction_factor: float = 0.5

    def _geometry(self) -> float:
        return (self.face_mean_diameter / self.seal_diameter) * (self.base_gap / self.seal_clearance)

    def conductance_ratio(self) -> float:
        """alpha = (d_m/d_u)(h_TB/h1) sqrt[(zeta1 + f lambda1 l1/h1)/(zeta2 + f lambda2 l2/h_TB)], Eq. (4.38) (1)."""
        f = self.friction_factor
        num = self.zeta1 + f * self.lambda1 * self.seal_length / self.seal_clearance
        den = self.zeta2 + f * self.lambda2 * self.face_length / self.base_gap
        return self._geometry() * math.sqrt(num / den)

    def solve(self, unknown: str, alpha: float) -> float:
        """The loss coefficient ``unknown`` (one of zeta1, lambda1, zeta2, lambda2) that gives the
        conductance ratio ``alpha`` in (4.38), the others fixed; closed form (1)."""
        f = self.friction_factor
        k = (alpha / self._geometry()) ** 2
        seal = self.seal_length / self.seal_clearance
        face = self.face_length / self.base_gap
        num = self.zeta1 + f * self.lambda1 * seal
        den = self.zeta2 + f * self.lambda2 * face
        return {"zeta1": k * den - f * self.lambda1 * seal,
                "lambda1": (k * den - self.zeta1) / (f * seal),
                "zeta2": num / k - f * self.lambda2 * face,
                "lambda2": (num / k - self.zeta2) / (f * face)}[unknown]
