"""The source's closed-form static solutions, beside which the exact (IPOPT) solution is reported.

Pump: Pavlenko (2014) Eqs. (2.22), (2.24)-(2.28), (2.30)-(2.32), (2.36), with the
reconstructions of (2.27), (2.28) and the sign erratum of (2.32).  Compressor: (2.144)-(2.147),
(2.156), (2.159), (2.160) and, as Appendix B does, the pump formulas (2.26), (2.28) for the
regulator.  All functions take :class:`autobal.models.device.DeviceGroups` and numpy arrays.

Every closed form assumes an ideal regulator: the barrier margin p_e - p1 = dpsi p_B is held at every discharge
pressure.  A device without a regulator has exactly that barrier supply (psi_e = psi1 + dpsi); with a regulator
the assumption fails where its valve is on its stop (saturated), and a closed form is then no estimate of the device.
"""

from __future__ import annotations

import numpy as np


def _rel(g, psi1, dpsi):
    ae, a3, at = g.alpha_e1, g.alpha_31, g.alpha_TB1
    c = (g.b * psi1 - g.chi) / g.sigma  # psi2 - psi3, (2.20)
    return ae, a3, at, c


def flow_base(g, dpsi):
    """The source's base flow Q_B/(g1 p_B) of the dimensionless flows q.

    Liquid: Q_B = Q_e = g_e dp/(1 + a_e1), Pavlenko (2014) Eq. (2.29); gas: Eq. (2.156).  Plain
    arithmetic, so it takes numpy arrays and CasADi symbols alike.

    Parameters
    ----------
    g : DeviceGroups or a namespace of its groups (arrays or symbols)
        medium, alpha_e1, alpha_31 and, for the gas, b, chi, sigma.
    dpsi : float, array or symbol
        Barrier margin (p_e - p1)/p_B, dimensionless.

    Returns
    -------
    Q_B / (g1 p_B), dimensionless.
    """
    ae, a3 = g.alpha_e1, g.alpha_31
    if g.medium == "liquid":
        return ae * dpsi / (1 + ae)
    return ae * a3 / (ae + a3) * (1 + dpsi - (g.b - g.chi) / g.sigma)


def regulator(g, psi1, dpsi, psi2=None):
    """psi_cam (2.26) and xi (2.28); with ``psi2`` given, their exact counterparts for that psi2.

    xi is NaN where the valve cannot pass the flow (radicand <= 0: the regulator saturates).
    """
    r = g.regulator
    ae = g.alpha_e1
    psi_e = psi1 + dpsi
    q_e = ae * dpsi / (1 + ae) if psi2 is None else ae * (psi_e - psi2)
    psi_cam = r.psi_in - q_e / r.alpha_in1
    with np.errstate(invalid="ignore", divide="ignore"):
        xi = q_e / (r.alpha_B1 * np.sqrt(psi_cam - psi_e))
    return psi_cam, xi


def pump(g, psi1, dpsi) -> dict:
    """Approximate closed form of the pump (liquid) device, (2.24)-(2.32), (2.36)."""
    psi1 = np.asarray(psi1, float)
    ae, a3, at, c = _rel(g, psi1, dpsi)
    k = ae / (1 + ae)
    psi2 = psi1 + k * dpsi  # (2.24)
    psi3 = psi2 - c  # (2.25)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.cbrt((a3 / at) ** 2 * (psi3 - g.psi4) / c)  # (2.27)
        q_t = (1 + ae) * a3 / ae * np.sqrt(psi3 - g.psi4) / dpsi  # (2.30)
        dpsi_kr = (1 + ae) * a3 / ae * np.sqrt(1 - (g.b - g.chi) / g.sigma)  # (2.31), NaN if b - chi > sigma
    ratio = (at / a3) ** 2 * u**3
    out = {
        "psi_e": psi1 + dpsi, "psi2": psi2, "psi3": psi3, "u": u,
        "q_e": np.ones_like(psi1), "q_T": q_t, "q_1": 1 - q_t,
        "Q_e_over_g1pB": ae * dpsi / (1 + ae) * np.ones_like(psi1),  # Q_e = g_e dp/(1 + a_e1)
        "Q_B_over_g1pB": flow_base(g, dpsi),  # flow base of q, (2.29)
        "kappa_s": 3 * g.sigma / u * (psi1 - g.psi4 + k * dpsi) * ratio / (1 + ratio) ** 2,  # (2.36)
        "dpsi_kr": dpsi_kr,
        "psi1_kr": ((ae * dpsi / (a3 * (1 + ae))) ** 2 - k * dpsi - g.chi / g.sigma)
        / (1 - g.b / g.sigma),  # (2.32), -chi/sigma (the printed sign of chi is an erratum)
    }
    if g.regulator is not None:
        out["psi_cam"], out["xi"] = regulator(g, psi1, dpsi)
    return out


def force_gap(g, psi1, dpsi, u):
    """Balancing force against gap at fixed pressure, phi(u) of (2.35) (pump, psi2 from (2.24))."""
    ae, a3, at, _ = _rel(g, psi1, dpsi)
    return g.sigma * (psi1 - g.psi4 + ae / (1 + ae) * dpsi) / (1 + (at / a3) ** 2 * np.asarray(u) ** 3)


def pump_quadratic(g, psi1, dpsi) -> dict:
    """Exact solution of the pump's disc subsystem with an ideal regulator: smaller root of (2.21)."""
    psi1 = np.asarray(psi1, float)
    ae, a3, at, c = _rel(g, psi1, dpsi)
    p = (1 + ae) * psi1 + ae * dpsi
    disc = a3**2 + 4 * (1 + ae) * ((1 + ae) * (psi1 - c - g.psi4) + ae * dpsi)
    with np.errstate(invalid="ignore"):
        psi2 = (a3**2 + 2 * (1 + ae) * p - a3 * np.sqrt(disc)) / (2 * (1 + ae) ** 2)  # (2.22)
        psi3 = psi2 - c
        u = np.cbrt((a3 / at) ** 2 * (psi3 - g.psi4) / c)
    return {"psi2": psi2, "psi3": psi3, "u": u}


def compressor_disc(g, psi1, dpsi):
    """psi2 (2.144) with the corrected A, B (2.143) (any psi4; (2.145)/(2.146) at psi4 = 0),
    psi3 = psi2 - c and u (2.147): exact for the gas disc subsystem with an ideal regulator."""
    ae, a3, at, c = _rel(g, psi1, dpsi)
    p = (1 + ae) * psi1 + ae * dpsi
    den = (1 + ae) ** 2 - a3**2
    a = ((1 + ae) * p - a3**2 * c) / den  # (2.143)
    bq = (p**2 - a3**2 * (c**2 - g.psi4**2)) / den
    with np.errstate(invalid="ignore", divide="ignore"):
        psi2 = a - np.sqrt(a**2 - bq)  # (2.144)
        psi3 = psi2 - c
        u = np.cbrt((a3 / at) ** 2 * (psi3**2 - g.psi4**2) / (psi2**2 - psi3**2))  # (2.147)
    return psi2, psi3, u


def compressor(g, psi1, dpsi) -> dict:
    """Closed form of the compressor (gas) device as Appendix B computes it.

    Disc: :func:`compressor_disc`; flows (2.159) with the program's q1 denominator; psi1_kr and
    dpsi_kr (2.160); kappa (2.162) with a central difference of u(psi1); the regulator by the
    pump formulas (2.26), (2.28) (the source's program model).
    """
    psi1 = np.asarray(psi1, float)
    ae, a3, at, c = _rel(g, psi1, dpsi)
    psi2, psi3, u = compressor_disc(g, psi1, dpsi)
    bs, cs = g.b / g.sigma, g.chi / g.sigma
    s1 = 1 - (g.b - g.chi) / g.sigma
    q_e = ((1 - bs) * psi1 + dpsi / a3 + cs) / (s1 + dpsi / a3)  # (2.159)
    q_1 = (ae / a3 * dpsi - (1 - bs) * psi1 - cs) / (ae * (s1 + dpsi))  # (2.159), App. B denominator
    h = 1e-6
    du = (compressor_disc(g, psi1 + h, dpsi)[2] - compressor_disc(g, psi1 - h, dpsi)[2]) / (2 * h)
    out = {
        "psi_e": psi1 + dpsi, "psi2": psi2, "psi3": psi3, "u": u,
        "q_e": q_e, "q_1": q_1, "q_T": q_e - q_1,
        "Q_e_over_g1pB": ae * dpsi / (1 + ae) * np.ones_like(psi1),  # App. B uses the pump Q_e
        "Q_B_over_g1pB": flow_base(g, dpsi),  # (2.156)
        "kappa_s": np.full_like(psi1, np.nan),  # no fixed-pressure closed form for the gas device
        "kappa_u_2_162": -g.b / du,  # (2.162): slope along the pressure sweep, not at fixed psi1
        "dpsi_kr": a3 / ae * s1,  # (2.160) at psi1_kr = 1
        "psi1_kr": (ae / a3 * dpsi - cs) / (1 - bs),  # (2.160), App. B L3616
    }
    if g.regulator is not None:
        out["psi_cam"], out["xi"] = regulator(g, psi1, dpsi)
    return out


def for_medium(g, psi1, dpsi) -> dict:
    """The source's closed form for this device's medium."""
    return pump(g, psi1, dpsi) if g.medium == "liquid" else compressor(g, psi1, dpsi)


def exact_ideal(g, psi1, dpsi) -> dict:
    """Exact disc subsystem with an ideal regulator (psi_e = psi1 + dpsi): (2.22) or (2.144)."""
    if g.medium == "liquid":
        return pump_quadratic(g, psi1, dpsi)
    psi2, psi3, u = compressor_disc(g, np.asarray(psi1, float), dpsi)
    return {"psi2": psi2, "psi3": psi3, "u": u}
