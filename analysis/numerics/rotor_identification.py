"""Synchronous response, dynamic-stiffness identification and the eccentricity-identification error bound.

Proceedings 2017 [P]: (a) the isotropic rotor
with tangential (cross-coupled) stiffness, Romashchenko & Drach, eqs. (1)-(5); (b) the
condition-number bound of the eccentricity identification of a flexible rotor, reconstructed
(the source's formulas (4)-(6) are missing).  SI units: kg, N/m, N s/m, rad/s, kg m.
"""

from __future__ import annotations

import numpy as np


def synchronous_response(M, K, D, lam, K_tau, m_r, Omega, delta=0.0):
    """Amplitude A and phase alpha of z = A e^{i(Omega t + alpha)}, eq. (4) (atan2 for alpha).

    A = m r Omega^2 / |K - M Omega^2 + i (D (1 - lambda) Omega - K_tau)|; alpha = delta + arg of the
    inverse dynamic stiffness.  ``K_tau`` may be a callable of Omega.
    """
    Omega = np.asarray(Omega, float)
    Kt = K_tau(Omega) if callable(K_tau) else K_tau
    stiff = (K - M * Omega**2) + 1j * (D * (1 - lam) * Omega - Kt)
    resp = m_r * Omega**2 * np.exp(1j * delta) / stiff
    return np.abs(resp), np.angle(resp)


def dynamic_stiffness(A, alpha, m_r, Omega, delta=0.0):
    """Direct K - M Omega^2 and quadrature D(1 - lambda) Omega - K_tau from synchronous data.

    Direct = m r Omega^2 cos(delta - alpha)/A; quadrature = m r Omega^2 sin(delta - alpha)/A (sign typo of
    the printed quadrature corrected).
    """
    F = m_r * np.asarray(Omega, float) ** 2 / np.asarray(A, float)
    return F * np.cos(delta - np.asarray(alpha)), F * np.sin(delta - np.asarray(alpha))


def fit_stiffness_mass(Omega, direct):
    """Least-squares K (intercept) and M (minus slope) of the direct dynamic stiffness against Omega^2."""
    X = np.column_stack([np.ones_like(Omega), -np.asarray(Omega, float) ** 2])
    (K, M), *_ = np.linalg.lstsq(X, np.asarray(direct, float), rcond=None)
    return float(K), float(M)


def beam_flexibility(L: float, EI: float, positions) -> np.ndarray:
    """Influence coefficients a_ij [m/N] of a simply supported Euler-Bernoulli beam (deflection at x_i for a
    unit load at x_j): a = b x (L^2 - b^2 - x^2) / (6 EI L), b = L - x_j, for x_i <= x_j (symmetric)."""
    x = np.asarray(positions, float)
    a = np.empty((x.size, x.size))
    for i, xi in enumerate(x):
        for j, xj in enumerate(x):
            lo, hi = min(xi, xj), max(xi, xj)
            b = L - hi
            a[i, j] = b * lo * (L**2 - b**2 - lo**2) / (6 * EI * L)
    return a


def identification_bound(A: np.ndarray, omega: float) -> dict:
    """cond(A), cond(E/omega^2 - A) and their product, the bound of ||de||/||e|| per ||dY||/||Y||.

    Model Y = omega^2 A (Y + e) (A = flexibility times the disc masses), so e = A^-1 (E/omega^2 - A) Y.
    """
    B = np.eye(A.shape[0]) / omega**2 - A
    cA, cB = np.linalg.cond(A), np.linalg.cond(B)
    return {"cond_A": cA, "cond_B": cB, "bound": cA * cB}


def eccentricities(A: np.ndarray, omega: float, Y: np.ndarray) -> np.ndarray:
    """e = A^-1 (E/omega^2 - A) Y."""
    return np.linalg.solve(A, (np.eye(A.shape[0]) / omega**2 - A) @ Y)


def monte_carlo_ratio(A: np.ndarray, omega: float, e: np.ndarray, eps: float, samples: int, seed: int = 0):
    """Observed (||de||/||e||) / (||dY||/||Y||) for random relative measurement errors eps of the deflections."""
    rng = np.random.default_rng(seed)
    n = A.shape[0]
    Y = np.linalg.solve(np.eye(n) / omega**2 - A, A @ e)
    ratios = np.empty(samples)
    for s in range(samples):
        dY = rng.standard_normal(n)
        dY *= eps * np.linalg.norm(Y) / np.linalg.norm(dY)
        de = eccentricities(A, omega, Y + dY) - e
        ratios[s] = (np.linalg.norm(de) / np.linalg.norm(e)) / eps
    return ratios
