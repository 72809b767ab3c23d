"""Balancing norms: permissible unbalance, unbalance coefficient, two-plane equivalents
(Khomyak (2020), ch. 2; not physics of the liquid auto-balancer itself)."""

from __future__ import annotations

import numpy as np


def permissible_specific_unbalance(n_rpm, kind: str = "general"):
    """Permissible specific unbalance [e_st], micrometres (Khomyak (2020), ch. 2).

    General machinery 2e8/n^2, household appliances 6000/n, with the speed n in rpm.
    """
    n_rpm = np.asarray(n_rpm, float)
    if kind == "general":
        return 2e8 / n_rpm**2
    if kind == "household":
        return 6000.0 / n_rpm
    raise ValueError("kind is 'general' or 'household'")


def unbalance_coefficient(F_c, P_st):
    """k = F_c / P_st, Eq. (2.3); recommended below 1 (0.01-0.5)."""
    return F_c / P_st


def two_plane_unbalances(D_C, L_A, L_B, M_D, couple_sign: int = -1):
    """Equivalent two-plane unbalances (Khomyak (2020), ch. 2): D_A = (D_C L_B + M_D)/L, D_B = (D_C L_A + sign M_D)/L.

    ``couple_sign = -1`` is the reconstruction (the couple enters the planes with opposite signs,
    erratum 21); ``+1`` reproduces the printed pair.
    """
    L = L_A + L_B
    return (D_C * L_B + M_D) / L, (D_C * L_A + couple_sign * M_D) / L
