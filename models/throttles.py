"""Throttle flow laws and conductances of the balancing device.

Laws are written on dimensionless pressures psi = p / p_B and give a dimensionless
flow q = Q / (g1 p_B), where g1 is the laminar conductance of the inner seal
(Pavlenko 2014, Eqs. (2.15), (2.18), (2.136), (2.137)).  The ratio ``alpha`` of a
law is the conductance ratio of (2.18): alpha = g/g1 (laminar), g/(g1 sqrt(p_B))
(liquid square-root laws), g/g1 (gas square-root laws, whose g is in m^3/(Pa s)).

Conductances (2.16) and Table 2.2 are plain functions of SI geometry and fluid data.
"""

from __future__ import annotations

import math

import casadi as ca

# Half-width of the smoothing of the signed square root, in the dimensionless
# argument of the root.  Relative change of a flow at |dpsi| >= 1e-4: < 1e-12.
SQRT_SMOOTHING = 1e-10

LAWS = ("laminar", "turbulent", "gas_turbulent")


def sqrt(x):
    """Square root of a number (math.sqrt) or of a CasADi expression (casadi.sqrt): the conductances
    below take either, so that the groups of models/device.design stay symbolic in a design NLP."""
    return math.sqrt(x) if isinstance(x, int | float) else ca.sqrt(x)


def signed_sqrt(x, eps: float = SQRT_SMOOTHING):
    """sign(x) sqrt(|x|), made smooth at x = 0: x / (x^2 + eps^2)^(1/4).

    Finite with finite derivatives at and past zero, so a flow reversal through a
    square-root throttle is a result, not a NaN.  The fourth root is written as two square roots:
    the same value to rounding, and in generated C two sqrt instructions instead of a libm pow call
    (a third of the statics check's time, benchmarks/statics_sweep).
    """
    return x / sqrt(sqrt(x * x + eps * eps))


def flow(law: str, alpha, psi_a, psi_b):
    """Dimensionless flow from node a to node b through a throttle with law ``law``.

    laminar: alpha (psi_a - psi_b); turbulent (liquid, (2.15)): alpha sqrt(psi_a - psi_b);
    gas_turbulent ((2.134), (2.136)): alpha sqrt(psi_a^2 - psi_b^2).
    """
    if law == "laminar":
        return alpha * (psi_a - psi_b)
    if law == "turbulent":
        return alpha * signed_sqrt(psi_a - psi_b)
    if law == "gas_turbulent":
        return alpha * signed_sqrt(psi_a * psi_a - psi_b * psi_b)
    raise ValueError(f"unknown throttle law {law!r}; expected one of {LAWS}")


def face_opening(u):
    """Opening factor u^(3/2) of the face throttle, Eq. (2.15); u is clamped at 0."""
    return ca.fmax(u, 0) ** 1.5


def valve_opening(xi):
    """Opening factor of the regulator valve, xi clamped at 0 (Eq. (2.15)): a valve on its seat
    (xi <= 0) passes no flow, in either direction."""
    return ca.fmax(xi, 0)


# ---- conductances, SI in, SI out (Eq. (2.16), Table 2.2, appendices A/B) ----------------

def laminar_annulus(diameter: float, clearance: float, length: float, viscosity: float) -> float:
    """g = pi d h^3 / (12 mu l), m^3/(Pa s): a plain annular bushing seal (Pavlenko (2014), App. A)."""
    return math.pi * diameter * clearance**3 / (12.0 * viscosity * length)


def laminar_tube(diameter: float, length: float, viscosity: float) -> float:
    """g = pi d^4 / (192 mu l), m^3/(Pa s): round tube, with the source's coefficient 192 (2.16).

    Hagen-Poiseuille gives 128; the source (and its appendices) use 192.
    """
    return math.pi * diameter**4 / (192.0 * viscosity * length)


def turbulent(area: float, loss: float, density: float, medium: str, normal_pressure: float) -> float:
    """Square-root-law conductance of a flow section ``area`` with total loss coefficient ``loss``.

    liquid: g = f / sqrt(rho zeta / 2), m^3/(Pa^0.5 s)   (2.16), (2.118);
    gas:    g = f / sqrt(p_n rho_n zeta), m^3/(Pa s)       (2.135) as corrected in App. B.
    """
    if medium == "liquid":
        return area / sqrt(0.5 * density * loss)
    return area / sqrt(normal_pressure * density * loss)


def annulus_loss(local_loss: float, friction: float, length: float, clearance: float) -> float:
    """zeta = zeta_local + lambda l / (2 h) of a cylindrical seal (Pavlenko (2014), App. A)."""
    return local_loss + 0.5 * friction * length / clearance


def face_loss(friction: float, inner_diameter: float, outer_diameter: float, base_gap: float) -> float:
    """zeta_TB = lambda (d3 - d2) / (4 z_B) of the face throttle (Pavlenko (2014), App. A)."""
    return 0.25 * friction * (outer_diameter - inner_diameter) / base_gap


def orifice(discharge_coefficient: float, seat_diameter: float, base_opening: float, density: float) -> float:
    """Valve conductance g_B = phi pi d_c x_B sqrt(2/rho), m^3/(Pa^0.5 s) (2.16)."""
    return discharge_coefficient * math.pi * seat_diameter * base_opening * sqrt(2.0 / density)
