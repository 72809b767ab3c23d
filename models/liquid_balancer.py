"""Liquid auto-balancer: a cylindrical chamber partly filled with liquid on a flexible rotor.

Sources: [T] Khomyak, master's thesis,
KhNU 2020, ch. 2 Eqs. (2.4)-(2.15), ch. 3 (3.1)-(3.14), App. В/Г programs; Pashkov, PhD abstract,
Tomsk 2010, ch. 3.  SI units at every argument:
m, m^3, kg, kg/m^3, Pa s, rad/s, 1/s; angles in rad unless a name ends in ``_deg``.

The quasi-static model (the calculation of App. В) is a CasADi SX graph (:func:`quasi_static`):
(omega, omega_cr, n, R, h, V, rho, D0, e_f) -> delta, phi, G, f, r, x_p, D, k_D, alpha0, lambda0.
``e_f`` is the eccentricity that drives the shaft deflection f = G e_f: the App. В code uses
e0 = D0/m_d ("program" deflection), a check uses D0/M_sys ("system").

Where the source's formula for the equilibrium angle is defective, ``variant`` selects it:

* ``"printed"``: (2.13) as printed, alpha0 = pi - arccos(sin^2 d + sqrt((sin^2 d - 1)(sin^2 d - k^2)));
* ``"program"``: the Pascal ``LAMBDA`` of App. В/Г, which squares ``Sin2d`` (sin^4 d in the first term);
* ``"corrected"`` (default): (2.13-corr), the division by k_D restored (a derived correction of the printed (2.13)).

Domain violations are results, never exceptions: CasADi returns NaN for sqrt/arccos of an invalid
argument and :func:`reasons` names the cause ("no equilibrium (k_D < sin delta)", ...).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from autobal.models.params import SIParams, si

VARIANTS = ("printed", "program", "corrected")
DEFLECTIONS = ("program", "system")  # eccentricity in f = G e_f: D0/m_d (App. В code) or D0/M_sys
G_ACCEL = 9.81  # m/s^2, as in [T]
GCM = 1e-5  # 1 g*cm in kg*m

INPUTS = ("omega", "omega_cr", "n", "R", "h", "V", "rho", "D0", "e_f")
OUTPUTS = ("delta", "phi", "G", "G_exact", "zeta_over_ec", "f", "r2", "r", "x_p", "D", "k_D", "sin2d",
            "radicand", "acos_arg", "alpha0", "lambda0")


@dataclass(frozen=True)
class System(SIParams):
    """One liquid auto-balancer system in SI (Khomyak (2020), Table 3.1 symbols).

    Attributes
    ----------
    rotor_mass, chamber_mass, unbalance_mass : float
        M_p, M_k, m_d, kg.
    unbalance_radius : float
        e_d, m (D0 = m_d e_d).
    omega_cr : float
        Critical (resonance) speed omega_p, rad/s.
    n : float
        Damping constant, 1/s (:func:`n_from_decrement`).
    R, h : float
        Chamber radius and height, m.
    V : float
        Liquid volume, m^3.
    rho : float
        Liquid density, kg/m^3.
    speed : float
        Working speed omega, rad/s.
    mu : float or None
        Liquid viscosity, Pa s (viscous zone (2.15) only).
    stiffness : float or None
        Shaft stiffness c, N/m (chapter-3 calculators only).
    inclination : float or None
        Rotor inclination Omega_inc, rad (paraboloid free surface).
    nested_radii, nested_volumes : tuple of float
        Further concentric chambers, outermost first: wall radii (m) and liquid volumes (m^3).
    wall_thickness, hub_radius : float
        Partition thickness and the innermost chamber's inner wall radius, m.
    """

    # the scene's liquid_balancer section is derived from these declarations (autobal/parts/liquid_balancer.py):
    # ``key`` is the field's place in the scene (rotor, chamber, liquid, nested)
    rotor_mass: float = si("kg", kind="mass", key="rotor.mass", doc="M_p, rotor mass")
    chamber_mass: float = si("kg", kind="mass", key="chamber.mass", doc="M_k")
    unbalance_mass: float = si("kg", kind="mass", key="rotor.unbalance_mass", doc="m_d")
    unbalance_radius: float = si("m", kind="length", key="rotor.unbalance_radius", doc="e_d; D0 = m_d e_d")
    omega_cr: float = si("rad/s", kind="angular speed", key="rotor.critical_speed", doc="omega_p (resonance speed)")
    n: float = si("1/s", kind="rate", key="rotor.damping_coefficient", scene_default=None,
                  doc="n; overrides log_decrement")
    R: float = si("m", kind="length", key="chamber.radius", doc="R, inner radius of the (outer) chamber wall")
    h: float = si("m", kind="length", key="chamber.height", doc="h")
    V: float = si("m**3", kind="volume", key="liquid.volume", doc="V")
    rho: float = si("kg/m**3", kind="density", key="liquid.density", doc="rho")
    speed: float = si("rad/s", kind="angular speed", doc="working angular speed omega")
    mu: float | None = si("Pa*s", None, kind="viscosity", key="liquid.viscosity", doc="mu (viscous zone (2.15))")
    stiffness: float | None = si("N/m", None, kind="stiffness", key="rotor.stiffness",
                                 doc="c [N/m], for the chapter-3 / Pashkov calculators only")
    inclination: float | None = si("rad", None, key="", doc="Omega_inc (the scene: chamber.inclination_deg)")
    nested_radii: tuple = ()
    nested_volumes: tuple = ()
    wall_thickness: float = si("m", 0.0, kind="length", key="nested.wall_thickness", scene_default=..., ge=0,
                               doc="t_w, partition thickness")
    hub_radius: float = si("m", 0.0, kind="length", key="nested.hub_radius", ge=0,
                           doc="inner wall of the innermost chamber")

    @property
    def D0(self) -> float:
        """Rotor unbalance D0 = m_d e_d [kg m] (App. В step 2.7 corrected, erratum 15)."""
        return self.unbalance_mass * self.unbalance_radius

    @property
    def m_l(self) -> float:
        return self.rho * self.V

    @property
    def M_sys(self) -> float:
        """M_p + M_k + m_d + m_l (App. В step 2.2)."""
        return self.rotor_mass + self.chamber_mass + self.unbalance_mass + self.m_l

    def e_f(self, deflection: str) -> float:
        """Eccentricity in f = G e_f: D0/m_d (App. В code, "program") or D0/M_sys ("system")."""
        if deflection == "program":
            return self.D0 / self.unbalance_mass
        if deflection == "system":
            return self.D0 / self.M_sys
        raise ValueError(f"deflection is one of {DEFLECTIONS}, not {deflection!r}")

    def inputs(self, deflection: str, **override) -> dict:
        """Inputs of the quasi-static model (:data:`INPUTS`) at the working speed."""
        p = {"omega": self.speed, "omega_cr": self.omega_cr, "n": self.n, "R": self.R, "h": self.h, "V": self.V,
             "rho": self.rho, "D0": self.D0, "e_f": self.e_f(deflection)}
        return p | override


# ---- damping (2.5), erratum 1 -----------------------------------------------------------------

def n_from_decrement(theta: float, omega_cr: float) -> float:
    """Damping constant n [1/s] of x'' + 2n x' + omega_cr^2 x from the log decrement: n = theta omega_cr / (2 pi).

    A correction: the thesis writes 2n = theta omega_cr [T, Eq. (2.5)], but its own Table 3.1
    (theta = 0.826, omega_cr = 59.7, n = 7.85) fits theta omega_cr / (2 pi) = 7.848.
    """
    return theta * omega_cr / (2.0 * math.pi)


def n_from_decrement_literal(theta: float, omega_cr: float) -> float:
    """The thesis's literal 2n = theta omega_cr [T, Eq. (2.5)] (n = 24.66 for Table 3.1); kept for completeness."""
    return theta * omega_cr / 2.0


# ---- the quasi-static model as CasADi expressions ---------------------------------------------

def jeffcott(omega, omega_cr, n) -> dict:
    """Phase lag and deflection ratio of the damped Jeffcott rotor, Eqs. (2.5)-(2.8).

    delta = atan2(2 n omega, omega_cr^2 - omega^2) in (0, pi) (2.5); sin phi = 2 n omega / omega_cr^2 (2.8);
    G = f/e_c from (2.7) in the form safe at omega = omega_cr [derived],
    G = (sqrt(omega_cr^4 - (2 n omega)^2) - (omega_cr^2 - omega^2)) / sqrt((omega_cr^2 - omega^2)^2 + (2 n omega)^2);
    G_exact = omega^2 / sqrt(...) is the exact Jeffcott deflection ratio that (2.7) approximates;
    zeta_over_ec = zeta / e_c of (2.6).
    """
    a = 2 * n * omega
    b = omega_cr**2 - omega**2
    c = ca.sqrt(a**2 + b**2)
    return {"delta": ca.atan2(a, b), "phi": ca.asin(a / omega_cr**2), "cos_delta": b / c, "sin2d": (a / c) ** 2,
            "G": (ca.sqrt(omega_cr**4 - a**2) - b) / c, "G_exact": omega**2 / c, "zeta_over_ec": omega_cr**2 / c}


def acos_argument(sin2d, k, variant: str):
    """y in alpha0 = pi - arccos(y), i.e. y = -cos(alpha0), for the three variants of (2.13)."""
    if variant == "printed":
        return sin2d + ca.sqrt((sin2d - 1) * (sin2d - k**2))
    if variant == "program":
        return sin2d**2 + ca.sqrt((sin2d - 1) * (sin2d - k**2))
    if variant == "corrected":
        # never above 1 in exact arithmetic (Cauchy-Schwarz); the clamp removes round-off at k_D = 1
        # (if_else, not fmin: fmin(NaN, 1) would be 1 and hide a missing equilibrium)
        y = (sin2d + ca.sqrt((1 - sin2d) * (k**2 - sin2d))) / k
        return ca.if_else(y > 1, 1, y)
    raise ValueError(f"unknown variant {variant!r}; expected one of {VARIANTS}")


def lambda0(k, cos_alpha0):
    """Self-balancing efficiency lambda0 = e0/e_c = k / sqrt(1 + 2 k cos alpha0 + k^2), Eq. (2.14)."""
    return k / ca.sqrt(1 + 2 * k * cos_alpha0 + k**2)


def inverse_lambda0_squared(k, sin2d, variant: str):
    """(e_c/e0)^2 = 1/lambda0^2 = (1 + 2 k cos alpha0 + k^2) / k^2: smooth, zero at complete balancing.

    The optimisation objective (maximising lambda0 is minimising this); for the corrected branch it is
    (|cos delta| - sqrt(k^2 - sin^2 delta))^2 / k^2 [derived].
    """
    if variant == "corrected":
        return (ca.sqrt(1 - sin2d) - ca.sqrt(k**2 - sin2d)) ** 2 / k**2
    return (1 - 2 * k * acos_argument(sin2d, k, variant) + k**2) / k**2


def quasi_static(p: dict, variant: str = "corrected") -> dict:
    """The quasi-static model of App. В, steps 2.1-4, on symbols or numbers ``p`` keyed by :data:`INPUTS`.

    r = sqrt(R^2 - V/(pi h)) (step 2.3); f = G e_f (2.7); x_p = r^2 f / (R^2 - r^2) ([T], the
    program's e); D = rho V x_p = rho f (pi h R^2 - V) (step 2.8); k_D = D0/D (2.9); alpha0 by
    ``variant``; lambda0 by (2.14) (derived closed form for the corrected branch, which is the
    same number and exact at k_D = 1).
    """
    j = jeffcott(p["omega"], p["omega_cr"], p["n"])
    f = j["G"] * p["e_f"]
    r2 = p["R"] ** 2 - p["V"] / (ca.pi * p["h"])
    x_p = r2 * f / (p["R"] ** 2 - r2)
    D = p["rho"] * p["V"] * x_p
    k = p["D0"] / D
    s = j["sin2d"]
    y = acos_argument(s, k, variant)
    if variant == "corrected":
        lam = k / ca.fabs(ca.fabs(j["cos_delta"]) - ca.sqrt(k**2 - s))
    else:
        lam = lambda0(k, -y)
    return {"delta": j["delta"], "phi": j["phi"], "G": j["G"], "G_exact": j["G_exact"],
            "zeta_over_ec": j["zeta_over_ec"], "f": f, "r2": r2, "r": ca.sqrt(r2), "x_p": x_p, "D": D,
            "k_D": k, "sin2d": s, "radicand": (1 - s) * (k**2 - s), "acos_arg": y,
            "alpha0": ca.pi - ca.acos(y), "lambda0": lam}


@functools.cache
def quasi_static_function(variant: str = "corrected") -> ca.Function:
    """The quasi-static model as a CasADi Function: named scalar inputs :data:`INPUTS`, outputs :data:`OUTPUTS`."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; expected one of {VARIANTS}")
    sym = {k: ca.SX.sym(k) for k in INPUTS}
    out = quasi_static(sym, variant)
    return ca.Function(f"liquid_balancer_{variant}", [sym[k] for k in INPUTS], [out[k] for k in OUTPUTS],
                       list(INPUTS), list(OUTPUTS))


@functools.lru_cache(maxsize=64)
def _mapped(variant: str, size: int) -> ca.Function:
    return quasi_static_function(variant).map(size)


def evaluate(variant: str = "corrected", **inputs) -> dict:
    """Evaluate the quasi-static model for scalar or array inputs (broadcast); numpy arrays out, with ``reason``.

    Never raises on a domain violation: the outputs are NaN (or inf at complete balancing) and
    ``reason`` says why (see :func:`reasons`).
    """
    missing = [k for k in INPUTS if k not in inputs]
    if missing:
        raise TypeError(f"missing inputs {missing}")
    vals = [np.asarray(inputs[k], float) for k in INPUTS]
    shape = np.broadcast_shapes(*[v.shape for v in vals])
    size = max(int(np.prod(shape)), 1)
    # constant inputs go in as scalars (map repeats them); the others as 1 x size rows
    args = [float(v) if v.ndim == 0 else np.broadcast_to(v, shape).reshape(1, -1) for v in vals]
    res = _mapped(variant, size)(*args)
    out = {name: res[i].full().ravel().reshape(shape) for i, name in enumerate(OUTPUTS)}
    out["reason"] = reasons(out, np.broadcast_to(vals[0], shape), variant)
    bad = (out["reason"] != "") & ~np.isinf(out["lambda0"])
    for name in ("alpha0", "lambda0"):
        out[name] = np.where(bad, np.nan, out[name])
    return out


def reasons(out: dict, omega, variant: str) -> np.ndarray:
    """Reason code of each point: "" (an equilibrium exists) or why lambda0 is NaN / infinite."""
    omega = np.asarray(omega, float)
    code = np.full(np.shape(out["lambda0"]), "", dtype=object)
    s, k, r2, y = out["sin2d"], out["k_D"], out["r2"], out["acos_arg"]
    phi, lam = out["phi"], out["lambda0"]
    with np.errstate(invalid="ignore"):
        checks = [
            (omega <= 0, "zero speed: no deflection, k_D infinite"),
            (~(r2 > 0), "no free surface: liquid volume fills the chamber (r^2 <= 0)"),
            (~np.isfinite(phi), "sin(phi) > 1: 2 n omega > omega_cr^2"),
            ((k**2 < s) & ((s < 1) | (variant == "corrected")), "no equilibrium (k_D < sin delta)"),
            ((y > 1) & (variant != "corrected"), f"no equilibrium: arccos argument > 1 ({variant} (2.13))"),
            (np.isinf(lam), "complete balancing (k_D = 1): lambda0 infinite"),
            (~np.isfinite(lam), "no equilibrium (domain of (2.13)/(2.14))"),
        ]
    for mask, text in checks:
        code[np.asarray(mask, bool) & (code == "")] = text
    return code


# ---- self-consistent closure (toolkit extension) ----------------------------------

def self_consistent(omega, omega_cr, n, R, h, V, rho, M_sys) -> dict:
    """lambda0 with f = G e_c and e_c = (D0/M_sys)/lambda0 closed consistently [derived].

    Q = M_sys / (rho pi h r^2 G), lambda0+- = sqrt(sin^2 d + (|cos d| +- Q)^2) / Q, k_D = Q lambda0.
    The "+" root (k_D > 1) always exists; the "-" root needs Q <= |cos delta| (NaN otherwise).
    A toolkit extension, not the thesis's algorithm.
    """
    omega, omega_cr, n = (np.asarray(x, float) for x in (omega, omega_cr, n))
    a = 2 * n * omega
    b = omega_cr**2 - omega**2
    c = np.hypot(a, b)
    with np.errstate(all="ignore"):
        s = (a / c) ** 2
        cosd = np.abs(b / c)
        G = (np.sqrt(omega_cr**4 - a**2) - b) / c
        r2 = R**2 - V / (np.pi * h)
        Q = M_sys / (rho * np.pi * h * r2 * G)
        plus = np.sqrt(s + (cosd + Q) ** 2) / Q
        minus = np.where(Q <= cosd, np.sqrt(s + (cosd - Q) ** 2) / Q, np.nan)
    return {"Q": Q, "lambda0_plus": plus, "lambda0_minus": minus, "k_D_plus": Q * plus}


# ---- extremum analysis of lambda0(k) at fixed alpha0 ([T], ch. 2) -------------------------------

@functools.cache
def lambda0_of_k_function() -> ca.Function:
    """lambda0(k; alpha0) of (2.14) with its exact first and second k-derivatives (CasADi AD)."""
    k, al = ca.SX.sym("k"), ca.SX.sym("alpha0")
    lam = lambda0(k, ca.cos(al))
    d1 = ca.jacobian(lam, k)
    d2 = ca.jacobian(d1, k)
    return ca.Function("lambda0_k", [k, al], [lam, d1, d2], ["k", "alpha0"], ["lambda0", "d1", "d2"])


def dlambda0_dk(k, alpha0):
    """Eq. [T, ch. 2]: (1 + k cos a) / (1 + 2 k cos a + k^2)^(3/2)."""
    c = np.cos(alpha0)
    return (1 + k * c) / (1 + 2 * k * c + k**2) ** 1.5


def d2lambda0_dk2(k, alpha0, printed: bool = False):
    """Second derivative: the general form [derived], or the printed one [T, ch. 2] (valid at k* only)."""
    c = np.cos(alpha0)
    q = (1 + 2 * k * c + k**2) ** 2.5
    if printed:
        return -k * np.sin(alpha0) ** 2 / q
    return -(2 * c + 3 * k + k * c**2 + 2 * k**2 * c) / q


def extremum(alpha0) -> dict:
    """Stationary point k* = -1/cos alpha0 and maximum lambda0 = 1/|sin alpha0| [T, ch. 2].

    A maximum for k >= 0 needs cos alpha0 < 0; otherwise (and at alpha0 = pi, where lambda0 = k/|1-k|
    is unbounded at k = 1) k* and the maximum are NaN / inf.
    """
    alpha0 = np.asarray(alpha0, float)
    c = np.cos(alpha0)
    with np.errstate(all="ignore"):
        kstar = np.where(c < 0, -1.0 / c, np.nan)
        lmax = np.where(c < 0, 1.0 / np.abs(np.sin(alpha0)), np.nan)
    return {"k_star": kstar, "lambda0_max": lmax}


# ---- viscous liquid: equilibrium zone (2.15) ---------------------------------------------------

def sin_beta_star(mu, R, xi_deg, m_l, omega):
    """Zone boundary sin beta* = 8 pi^2 mu R xi / (180 m omega), xi in degrees [T, ch. 2]."""
    return 8 * math.pi**2 * np.asarray(mu) * R * np.asarray(xi_deg) / (180.0 * m_l * np.asarray(omega))


def sin_beta_star_nu(nu, R, xi_rad, V, omega):
    """The same with mu/m = nu/V and xi in rad: 8 pi nu R xi / (V omega) (program Г reconstructed)."""
    return 8 * math.pi * np.asarray(nu) * R * np.asarray(xi_rad) / (V * np.asarray(omega))


def program_arc(R, h, V, f) -> dict:
    """Program Г's arc angle: z = (r^2 - R^2 - f^2)/(2 R f), xi = 2 pi - arccos(z) [rad] (erratum 18: R^2 for V^2).

    z = -cos(theta*) is defined (|z| <= 1) only when the free surface cuts the wall, f > R - r;
    otherwise z is clipped to -1 (xi = pi) and ``clipped`` is True.
    """
    r2 = R**2 - V / (np.pi * h)
    with np.errstate(all="ignore"):
        z = (r2 - R**2 - np.asarray(f, float) ** 2) / (2 * R * np.asarray(f, float))
    clipped = ~(np.abs(z) <= 1)
    return {"z": z, "xi": 2 * np.pi - np.arccos(np.clip(z, -1, 1)), "clipped": clipped}


def sinus_literal(nu, R, V, h, omega, f):
    """Program Г's SINUS as printed (8 pi nu^2 xi / (V omega)), with only the V^2 -> R^2 fix in z."""
    return 8 * math.pi * nu**2 * program_arc(R, h, V, f)["xi"] / (V * omega)


def zone_half_width(q, sin_beta):
    """Half-width Delta* of the viscous equilibrium zone in Delta = alpha - delta - phi_c [derived].

    With x_p = q f (q = r^2/(R^2 - r^2)), (2.9) is tan beta = sin Delta / (q + cos Delta) [derived], and
    (2.15) |tan beta| <= tan beta* gives |Delta| <= Delta* = atan t + asin(t q / sqrt(1 + t^2)),
    t = tan beta*.  NaN when t q / sqrt(1 + t^2) > 1: every angle is an equilibrium (no balancing).
    """
    sb = np.asarray(sin_beta, float)
    t = sb / np.sqrt(1 - sb**2)
    with np.errstate(invalid="ignore"):
        return np.arctan(t) + np.arcsin(t * np.asarray(q, float) / np.sqrt(1 + t**2))


def tan_beta(delta_dev, q):
    """(2.9) in a clean form [derived]: tan beta = sin Delta / (q + cos Delta), q = x_p/f."""
    return np.sin(delta_dev) / (q + np.cos(delta_dev))


def lambda0_corrected(k, delta):
    """lambda0 on the corrected branch, k / | |cos d| - sqrt(k^2 - sin^2 d) | [derived]; NaN if k < |sin d|."""
    k, delta = np.asarray(k, float), np.asarray(delta, float)
    with np.errstate(all="ignore"):
        return k / np.abs(np.abs(np.cos(delta)) - np.sqrt(k**2 - np.sin(delta) ** 2))


# ---- free surface as a paraboloid [derived] ---------------------------------------

def paraboloid(R, h, V, omega, inclination) -> dict:
    """Free surface z(rho) = z* + a rho^2, a = omega^2/(2 g sin Omega_inc), z* = h/2 - a (R^2 - V/(pi h)).

    ``valid`` when the surface spans the chamber height inside the wall: z* <= 0 and rho_s(h) <= R,
    where the cylinder formulas for r and D are exact (mean of rho_s^2 over the height = r^2).
    Horizontal rotor (inclination 0): a = inf, the cylinder itself.
    """
    s = math.sin(inclination)
    if s <= 0:
        return {"a": math.inf, "z_star": -math.inf, "rho_bottom": math.sqrt(R**2 - V / (math.pi * h)),
                "rho_top": math.sqrt(R**2 - V / (math.pi * h)), "valid": True}
    a = omega**2 / (2 * G_ACCEL * s)
    zs = h / 2 - a * (R**2 - V / (math.pi * h))
    rb = math.sqrt(-zs / a) if zs <= 0 else math.nan
    rt2 = (h - zs) / a
    return {"a": a, "z_star": zs, "rho_bottom": rb, "rho_top": math.sqrt(rt2),
            "valid": bool(zs <= 0 and rt2 <= R**2)}


def paraboloid_volume(R, h, a, z_star) -> float:
    """Liquid volume of the paraboloid surface, pi h R^2 - (pi/a)(h^2/2 - z* h) [derived]."""
    return math.pi * h * R**2 - math.pi / a * (h**2 / 2 - z_star * h)


# ---- insufficient liquid: the crescent at the wall (toolkit extension) --------------

def _lens(R, r, d):
    """Area and first moment (about O, along O->O1) of disc(O,R) intersected with disc(O1,r), |OO1| = d."""
    if d <= abs(R - r):
        if r <= R:
            return math.pi * r**2, d * math.pi * r**2
        return math.pi * R**2, 0.0
    if d >= R + r:
        return 0.0, 0.0
    xc = (d**2 + R**2 - r**2) / (2 * d)
    tR = math.acos(max(-1.0, min(1.0, xc / R)))
    tr = math.acos(max(-1.0, min(1.0, (d - xc) / r)))
    aR = R**2 * (tR - math.sin(tR) * math.cos(tR))
    ar = r**2 * (tr - math.sin(tr) * math.cos(tr))
    mom = 2.0 / 3.0 * R**3 * math.sin(tR) ** 3 + d * ar - 2.0 / 3.0 * r**3 * math.sin(tr) ** 3
    return aR + ar, mom


def crescent(R, h, V, f) -> dict:
    """Liquid between the wall circle (O, R) and the free-surface circle (O1, r), |OO1| = f, exactly.

    Solves the cross-section area pi R^2 - lens = V/h for r and returns r, the centroid offset x_p
    (from O, away from the rotation axis) and D/rho = V x_p.  Equals the thesis's x_p = r^2 f/(R^2 - r^2)
    while R - r >= f (sufficient liquid); beyond it the liquid is a crescent at the wall with
    x_p -> R (toolkit extension).
    """
    from scipy.optimize import brentq

    A = V / h
    if not 0 < A < math.pi * R**2:
        return {"r": math.nan, "x_p": math.nan, "D_over_rho": math.nan, "sufficient": False}
    if f <= 0:
        r = math.sqrt(R**2 - A / math.pi)
        return {"r": r, "x_p": 0.0, "D_over_rho": 0.0, "sufficient": True}

    def area(r):
        return math.pi * R**2 - _lens(R, r, f)[0] - A

    r = brentq(area, 0.0, R + f, xtol=1e-15, rtol=1e-14, maxiter=200)
    la, lm = _lens(R, r, f)
    x_p = lm / (math.pi * R**2 - la)  # liquid moment = -lens moment: the centroid lies away from O1
    return {"r": r, "x_p": x_p, "D_over_rho": V * x_p, "sufficient": bool(R - r >= f)}


# ---- chapter 3: simplified supercritical model and several chambers ---------------------------

def full_liquid_mass(rho, h, radii) -> float:
    """rho pi h sum R_i^2: the 'fictitious' mass of liquid filling every chamber's full disc (3.2), (3.12)."""
    return rho * math.pi * h * float(np.sum(np.square(radii)))


def nested_liquid_mass(rho, h, radii, wall_thickness, hub_radius=0.0) -> float:
    """rho pi h sum [R_i^2 - (R_{i+1} + t_w)^2] (innermost: R_N^2 - hub^2): first-moment mass of nested
    chambers (the alternative to the printed sum R_i^2)."""
    radii = list(radii)
    inner = [R + wall_thickness for R in radii[1:]] + [hub_radius]
    return rho * math.pi * h * sum(R**2 - ri**2 for R, ri in zip(radii, inner, strict=True))


def deflection(e0, m, omega, c, m_liquid_full, kappa=1.0):
    """Shaft deflection s = e0 m omega^2 / (c - (m + kappa rho pi h sum R_i^2) omega^2), (3.2)/(3.5)/(3.12).

    (3.2) with the missing h restored (erratum 8); (3.12) as (3.2) with sum R_i^2 (erratum 13: the
    printed denominator sign is flipped).  Negative above the critical speed (deflection opposite e0).
    """
    omega = np.asarray(omega, float)
    with np.errstate(divide="ignore"):
        return e0 * m * omega**2 / (c - (m + kappa * m_liquid_full) * omega**2)


def critical_speed(c, m, m_liquid_full, kappa=1.0):
    """omega_k = sqrt(c / (m + kappa rho pi h sum R_i^2)), (3.3)/(3.6)/(3.13)."""
    return math.sqrt(c / (m + kappa * m_liquid_full))


def eccentricity_37(e0, m, s, m_p, s_p):
    """System eccentricity about the chamber axis e = (e0 m + m_p (s_p - s)) / (m + m_p), (3.7)."""
    return (e0 * m + m_p * (s_p - s)) / (m + m_p)


def eccentricity_38(e0, m, m_liquid_full):
    """High-speed limit e = e0 m / (m + rho pi h R^2), (3.8)."""
    return e0 * m / (m + m_liquid_full)


def efficiency(m, m_liquid_full, kappa=1.0):
    """E_e = E_s = (m + kappa rho pi h sum R_i^2) / m, (3.9)/(3.14); Pashkov's E_e = mu1 = 1/psi."""
    return (m + kappa * m_liquid_full) / m


def limit_mass(s, rho, h, R):
    """Limit liquid mass m_0 = 2 s rho pi h R (erratum 9: s, not s_p) below which the liquid is insufficient."""
    return 2 * abs(s) * rho * math.pi * h * R


def sufficiency(radii, volumes, h, s, wall_thickness=0.0, hub_radius=0.0) -> dict:
    """Sufficiency margins (3.4)/(3.11): R_i - r_i - |s| >= 0 and r_i - (R_{i+1} + t_w) - |s| >= 0 [m].

    Chambers nested from the outside in; r_i = sqrt(R_i^2 - V_i/(pi h)).  The innermost chamber's inner
    wall is the hub (radius ``hub_radius``).
    """
    radii, volumes = list(radii), list(volumes)
    inner = [R + wall_thickness for R in radii[1:]] + [hub_radius]
    s = abs(float(s))
    r, outer_margin, inner_margin = [], [], []
    for R, V, ri in zip(radii, volumes, inner, strict=True):
        r2 = R**2 - V / (math.pi * h)
        rr = math.sqrt(r2) if r2 > 0 else math.nan
        r.append(rr)
        outer_margin.append(R - rr - s)
        inner_margin.append(rr - ri - s)
    ok = [bool(a >= 0 and b >= 0) for a, b in zip(outer_margin, inner_margin, strict=True)]
    return {"r": r, "wall_margin": outer_margin, "partition_margin": inner_margin, "ok": ok, "all_ok": all(ok)}
