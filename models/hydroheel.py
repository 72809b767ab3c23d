"""The traditional balance disc (hydro-heel) of Pavlenko (2014), chapter 1.2: statics and seal wear.

A balance disc without barrier supply or regulator: discharge -> inner annular seal (laminar,
g1) -> chamber 2 -> face gap (laminar, g_TB u^3) -> chamber 3 -> outer seal (laminar, g3) ->
drain.  Dimensionless as in the source: psi = p/p_B, tau = T/(p_B s_B), u = z/z_B, and in this
chapter chi = h1/z_B is the dimensionless radial clearance of the inner seal (1.31), which grows
as the seal wears (1.38).

Static model (1.22):  tau = sigma (psi2 - psi3) + chi_pr;  psi1 - psi2 = alpha_T1 u^3 (psi2 - psi3);
psi1 - psi2 = alpha_31 (psi3 - psi4).  Closed forms (1.25)-(1.29) (spec reliability §1.2, with the
psi4 terms re-derived), the geometry form (1.30)-(1.35), the failure-free region (1.36) and the
flow characteristic (1.51)-(1.52).  Wear: chi(t) = chi0 + b t (1.38), b a normal wear rate
truncated to b >= 0 (1.39)-(1.41).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.special import ndtr


def seal_shape_factor(r1: float, l1: float, r2: float, r3: float) -> float:
    """k = l1 (r2 + r3) / (2 r1 (r3 - r2)), Eq. (1.32); any consistent length unit."""
    return l1 * (r2 + r3) / (2.0 * r1 * (r3 - r2))


def conductance_ratio(k: float, chi):
    """alpha_T1 = g_TB/g1 = k / chi^3 with chi = h1/z_B, Eqs. (1.30)-(1.31)."""
    return k / np.asarray(chi, float) ** 3


def initial_clearance(k: float, alpha_T1: float) -> float:
    """chi0 = cbrt(k / alpha_T1): the new seal's clearance h1/z_B that gives alpha_T1, from (1.30)."""
    return float(np.cbrt(k / alpha_T1))


def flow_ratio(u, alpha_T1: float):
    """Flow characteristic q = Q/Q(u = 1) = (1 + alpha_T1) u^3 / (1 + alpha_T1 u^3), Eq. (1.51)."""
    u3 = np.asarray(u, float) ** 3
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
        """tau(chi) that gives gap u, Eq. (1.35); the bounds tau1, tau2 of region B (1.36) at u_min, u_max."""
        c3 = np.asarray(chi, float) ** 3
        return self.sigma * self.psi1 * c3 / (c3 + self.k * np.asarray(u, float) ** 3)


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
