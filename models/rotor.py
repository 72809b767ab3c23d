"""Planar Jeffcott (Laval) rotor with static unbalance, optionally carrying a liquid auto-balancer
(model M1 of Pashkov (2010), ch. 2).

Physics (SI, Pashkov (2010), Eq. (2) as reconstructed): rotor mass ``m1``, eccentricity ``e``, isotropic
shaft stiffness ``c``, external viscous friction ``chi`` on the absolute velocity of the shaft centre.
The liquid block (a chamber of radius R and height h filled with liquid of density rho, rigidly
co-rotating, free surface centred on the axis) adds only the full-chamber mass
``m2* = rho pi R^2 h`` to the translational inertia, m = m1 + m2*, psi = m1/m (Pashkov (2010)).
A scene without a liquid block has m2* = 0, psi = 1: the plain Jeffcott rotor.

Everything is built in the dimensionless form of Pashkov (2010), Eq. (2) (tau = Omega0 t, nu = beta'/Omega0,
a* = beta''/Omega0^2, w~ = w/e, zeta0 = chi/(2 sqrt(c m1))), rotating frame (x, y along the
unbalance, autonomous in beta):

    w~'' + 2(zeta0 psi + i nu) w~' + [psi - nu^2 + i(a* + 2 zeta0 psi nu)] w~ = psi (nu^2 - i a*),   nu' = a*

and, where useful, in the fixed frame u = w e^{i beta}: u~'' + 2 zeta0 psi u~' + psi u~ = psi (nu^2 - i a*) e^{i beta}.

Drive (a toolkit extension, rotating-frame closure):
M = (J_p + m1 e^2 (1 - psi)) beta'' + b beta' - psi e [c y + chi (y' + beta' x)], dimensionless
M~ = M / (m1 e^2 Omega0^2).  Two drive modes: prescribed angular acceleration (control a*),
or a motor torque (control M~, beta'' solved from the torque equation), e.g. the linear motor
characteristic L(omega) = L_s (1 - omega / omega_nl) (toolkit extension).

The Functions are built once with the groups as parameters ``p = [psi, zeta0, j, b~]``
(j = J_p/(m1 e^2), b~ = b/(m1 e^2 Omega0)) and called for any rotor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import casadi as ca

from autobal.models.params import SIParams, si

STATES = ("x", "y", "vx", "vy", "nu")  # w~ = x + i y, w~' = vx + i vy, nu = omega / Omega0
FIXED_STATES = ("X", "Y", "VX", "VY", "nu", "beta")
NP = 4  # parameters p = [psi, zeta0, j, b~]


@dataclass(frozen=True)
class LiquidLayer(SIParams):
    """Liquid chamber of the auto-balancer (Pashkov (2010), model M1): full-chamber mass rho pi R^2 h.

    Attributes
    ----------
    density : float
        rho, kg/m^3.
    radius : float
        R = r1, chamber wall radius, m.
    height : float
        h, m.
    free_surface_radius : float or None
        r, m (only the sufficiency check needs it).
    """

    # the scene's rotor.liquid section is derived from these declarations (autobal/parts/rotor.py); a scene gives
    # the chamber or the design parameter psi instead, so each is optional there
    density: float = si("kg/m**3", kind="density", scene_default=None, doc="rho, liquid density")
    radius: float = si("m", kind="length", scene_default=None, doc="R = r1, chamber wall radius")
    height: float = si("m", kind="length", scene_default=None, doc="h, chamber height")
    free_surface_radius: float | None = si("m", None, kind="length", doc="r, free-surface radius (only the "
                                           "sufficiency check R - r >= s needs it)")

    @property
    def full_chamber_mass(self) -> float:
        """m2* = rho pi R^2 h (Pashkov (2010)), kg."""
        return self.density * math.pi * self.radius**2 * self.height

    @property
    def liquid_mass(self) -> float | None:
        """Actual liquid mass m2 = rho pi (R^2 - r^2) h, kg (None without a free-surface radius)."""
        r = self.free_surface_radius
        return None if r is None else self.density * math.pi * (self.radius**2 - r**2) * self.height

    def sufficient(self, deflection: float) -> bool:
        """Sufficiency condition R - r >= s (Pashkov (2010), ch. 3) for a shaft deflection s (m)."""
        r = self.free_surface_radius
        return True if r is None else self.radius - r >= deflection


@dataclass(frozen=True)
class RotorParams(SIParams):
    """SI parameters of the Jeffcott rotor, its optional liquid layer and its drive (Pashkov (2010), ch. 3).

    Attributes
    ----------
    m1 : float
        Rotor mass without liquid, kg.
    c : float
        Shaft stiffness, N/m.
    chi : float
        External viscous friction, N s/m.
    e : float
        Eccentricity, m.
    m2_star : float
        Full-chamber liquid mass rho pi R^2 h, kg (0: no liquid block).
    J_p : float
        Polar inertia of the rotor and drive, kg m^2.
    b : float
        Rotational drag of the drive, N m s.
    """

    # the scene's rotor section is derived from these declarations (autobal/parts/rotor.py); a scene may give
    # c, chi and e from a datasheet instead (critical speed, damping ratio, balance grade), so they are optional
    # there; m2_star comes from the liquid section
    m1: float = si("kg", kind="mass", key="mass", doc="m1, without liquid (the modal mass)")
    c: float = si("N/m", kind="stiffness", key="stiffness", scene_default=None, doc="c, shaft stiffness")
    chi: float = si("N*s/m", kind="damping", key="damping", scene_default=None, ge=0,
                    doc="chi, external viscous friction")
    e: float = si("m", kind="length", key="eccentricity", scene_default=None, doc="e, eccentricity")
    m2_star: float = si("kg", 0.0, kind="mass", key="", doc="m2* = rho pi R^2 h (the liquid section)")
    J_p: float = si("kg*m**2", 0.0, kind="moment of inertia", key="drive.polar_inertia", scene_default=...,
                    doc="J_p of rotor and drive")
    b: float = si("N*m*s", 0.0, kind="rotational damping", key="drive.drag", ge=0, doc="b, N m s")

    @classmethod
    def from_groups(cls, Omega0: float, chi_over_m1: float, psi: float = 1.0, e: float = 1.0,
                    m1: float = 1.0, J_p: float = 0.0, b: float = 0.0) -> RotorParams:
        """The source's way of stating a case: Omega0 = sqrt(c/m1), n = chi/m1 (section 3.7), psi."""
        return cls(m1=m1, c=m1 * Omega0**2, chi=chi_over_m1 * m1, e=e, m2_star=m1 * (1.0 / psi - 1.0),
                   J_p=J_p, b=b)

    @property
    def m(self) -> float:
        """Reduced mass m = m1 + m2* (Pashkov (2010))."""
        return self.m1 + self.m2_star

    @property
    def psi(self) -> float:
        """psi = m1/m = 1/(1 + m2*/m1) (Pashkov (2010)); 1 without liquid."""
        return self.m1 / self.m

    @property
    def mu1(self) -> float:
        """mu1 = m/m1 = 1/psi (Pashkov (2010))."""
        return self.m / self.m1

    @property
    def Omega0(self) -> float:
        """Natural frequency of the rotor without liquid sqrt(c/m1), rad/s (Pashkov (2010))."""
        return math.sqrt(self.c / self.m1)

    @property
    def omega_cr(self) -> float:
        """Undamped critical speed with liquid sqrt(c/m) = Omega0 sqrt(psi), rad/s (Pashkov (2010))."""
        return math.sqrt(self.c / self.m)

    @property
    def zeta0(self) -> float:
        """Damping ratio of the rotor without liquid chi / (2 sqrt(c m1))."""
        return self.chi / (2.0 * math.sqrt(self.c * self.m1))

    @property
    def k(self) -> float:
        """k = c psi / m1 = c/m, s^-2 (Pashkov (2010))."""
        return self.c / self.m

    # the source's three meanings of "n" (Pashkov (2010)), as separately named functions
    def n_steady(self) -> float:
        """n of sections 3.4-3.5: chi psi / m1 = chi/m, 1/s (Pashkov (2010))."""
        return self.chi / self.m

    def n_stationary(self) -> float:
        """n of section 3.6, Eq. (9): dimensionless chi^2 / (c m1) = (2 zeta0)^2."""
        return self.chi**2 / (self.c * self.m1)

    def n_passage(self) -> float:
        """n of section 3.7 (uniform acceleration, Fig. 9): chi/m1, 1/s (Pashkov (2010))."""
        return self.chi / self.m1

    @property
    def torque_scale(self) -> float:
        """m1 e^2 Omega0^2 (N m): torques are reported over it inside the toolkit."""
        return self.m1 * self.e**2 * self.Omega0**2

    @property
    def p(self) -> list[float]:
        """The parameter vector [psi, zeta0, j, b~] of the built Functions."""
        j = self.J_p / (self.m1 * self.e**2)
        b = self.b / (self.m1 * self.e**2 * self.Omega0)
        return [self.psi, self.zeta0, j, b]

    def with_liquid(self, layer: LiquidLayer) -> RotorParams:
        return RotorParams(self.m1, self.c, self.chi, self.e, layer.full_chamber_mass, self.J_p, self.b)

    def with_psi(self, psi: float) -> RotorParams:
        return RotorParams(self.m1, self.c, self.chi, self.e, self.m1 * (1.0 / psi - 1.0), self.J_p, self.b)

    def with_chi(self, chi: float) -> RotorParams:
        return RotorParams(self.m1, self.c, chi, self.e, self.m2_star, self.J_p, self.b)

    def scaled(self, critical_speed: float, damping: float, liquid_mass: float) -> RotorParams:
        """The rotor with its critical speed, damping and liquid mass scaled by the factors: c (critical_speed)^2
        (omega_cr = sqrt(c/m) scales by the factor), chi damping, m2* liquid_mass."""
        return RotorParams(self.m1, self.c * float(critical_speed) ** 2, self.chi * float(damping), self.e,
                           self.m2_star * float(liquid_mass), self.J_p, self.b)


@dataclass(frozen=True)
class RotorModel:
    """CasADi Functions of the dimensionless rotor (built once; see module docstring).

    ``ode(q, a, p) -> q'``: rotating frame, prescribed acceleration a* (Eq. (2) / §3.2).
    ``ode_torque(q, M, p) -> q'``: rotating frame driven by the torque M~ (toolkit extension).
    ``ode_fixed(Q, a, p) -> Q'``: fixed frame, states (X, Y, X', Y', nu, beta).
    ``outputs(q, a, p) -> [delta/e, d, M~]``: deflection (9'), system unbalance d1 (7)/(9'), drive torque.
    ``delta2(q)``, ``unbalance2(q, p)``: the squares, smooth, for epigraph constraints.
    """

    ode: ca.Function
    ode_torque: ca.Function
    ode_fixed: ca.Function
    outputs: ca.Function
    torque: ca.Function
    delta2: ca.Function
    unbalance2: ca.Function


def _rhs(q, a, psi, zeta0):
    x, y, vx, vy, nu = (q[i] for i in range(5))
    A = psi - nu**2
    B = a + 2 * zeta0 * psi * nu
    ax = psi * nu**2 - 2 * zeta0 * psi * vx + 2 * nu * vy - A * x + B * y
    ay = -psi * a - 2 * zeta0 * psi * vy - 2 * nu * vx - A * y - B * x
    return ca.vertcat(vx, vy, ax, ay, a)


def _torque(q, a, psi, zeta0, j, bt):
    """M~ = (j + 1 - psi) a* + b~ nu - psi [y + 2 zeta0 (y' + nu x)] (toolkit extension, over m1 e^2 Omega0^2)."""
    x, y, vy, nu = q[0], q[1], q[3], q[4]
    return (j + 1 - psi) * a + bt * nu - psi * (y + 2 * zeta0 * (vy + nu * x))


@cache
def rotor_model() -> RotorModel:
    """Build (once) the CasADi SX Functions of the rotor with optional liquid layer."""
    q = ca.SX.sym("q", 5)
    a = ca.SX.sym("a")
    M = ca.SX.sym("M")
    p = ca.SX.sym("p", NP)
    psi, zeta0, j, bt = p[0], p[1], p[2], p[3]
    ode = ca.Function("rotor_ode", [q, a, p], [_rhs(q, a, psi, zeta0)], ["q", "a", "p"], ["dq"])
    # torque drive: solve the torque equation for a* (needs j + 1 - psi > 0, i.e. some polar inertia)
    a_of_M = (M - bt * q[4] + psi * (q[1] + 2 * zeta0 * (q[3] + q[4] * q[0]))) / (j + 1 - psi)
    ode_torque = ca.Function("rotor_ode_torque", [q, M, p], [_rhs(q, a_of_M, psi, zeta0)], ["q", "M", "p"], ["dq"])
    Q = ca.SX.sym("Q", 6)
    X, Y, VX, VY, nu, beta = (Q[i] for i in range(6))
    fx = -2 * zeta0 * psi * VX - psi * X + psi * (nu**2 * ca.cos(beta) + a * ca.sin(beta))
    fy = -2 * zeta0 * psi * VY - psi * Y + psi * (nu**2 * ca.sin(beta) - a * ca.cos(beta))
    ode_fixed = ca.Function("rotor_ode_fixed", [Q, a, p], [ca.vertcat(VX, VY, fx, fy, a, nu)],
                            ["Q", "a", "p"], ["dQ"])
    d2 = q[0] ** 2 + q[1] ** 2
    u2 = (q[0] / psi + 1) ** 2 + (q[1] / psi) ** 2
    tq = _torque(q, a, psi, zeta0, j, bt)
    outputs = ca.Function("rotor_outputs", [q, a, p], [ca.sqrt(d2), ca.sqrt(u2), tq], ["q", "a", "p"],
                          ["delta", "d", "M"])
    return RotorModel(
        ode=ode, ode_torque=ode_torque, ode_fixed=ode_fixed, outputs=outputs,
        torque=ca.Function("rotor_torque", [q, a, p], [tq]),
        delta2=ca.Function("rotor_delta2", [q], [d2]),
        unbalance2=ca.Function("rotor_unbalance2", [q, p], [u2]),
    )


def motor_characteristic(omega, stall_torque: float, no_load_speed: float):
    """Linear DC-motor characteristic L(omega) = L_s (1 - omega/omega_nl), N m (toolkit extension)."""
    return stall_torque * (1 - omega / no_load_speed)
