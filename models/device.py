"""Locking-balancing device (balance disc + barrier chamber + pressure-drop regulator).

The static model of Pavlenko (2014), Eqs. (2.17)/(2.19) for the pump and (2.137) for the
compressor, assembled from blocks: the throttles of the flow network, the disc's force
balance and, when the scene has one, the regulator (inlet throttle, valve and membrane).
A device without a regulator has an ideal barrier supply, psi_e = psi1 + dpsi, and no
regulator unknowns.

Everything is dimensionless as in the source: psi = p/p_B, q = Q/(g1 p_B), forces over
p_B s_B.  The mechanical stops are modelled by reactions with complementarity: ``r_contact``
(the pad on the disc: u >= 0, r >= 0, u r = 0) and, for a valve with a travel limit,
``r_valve`` (the stem on its open stop: xi_max - xi >= 0, r >= 0, product 0: the
regulator saturates).  The bounds carry the signs; ``complementarity`` (the sum of the products) is
zero exactly at a physical solution.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from autobal.models import throttles as th
from autobal.models.params import BIG, SIParams, numbers, section, si
from autobal.models.throttles import face_opening, flow, valve_opening

if TYPE_CHECKING:
    from autobal.models.dynamics import DynamicData


# ---- the device in SI: plain parameter objects ------------------------------------------------

@dataclass(frozen=True)
class Fluid(SIParams):
    """The working fluid of the balancing device.

    Attributes
    ----------
    density : float
        Liquid density, or gas density at normal conditions, kg/m^3.
    viscosity : float
        Dynamic viscosity, Pa s.
    normal_pressure : float
        Gas only: pressure of normal conditions (Pavlenko (2014), Eq. (2.128)), Pa; NaN for a liquid.
    """

    density: float = si("kg/m**3", kind="density", doc="liquid density, or gas density at normal conditions (rho)")
    viscosity: float = si("Pa*s", kind="viscosity", doc="dynamic viscosity (mu)")
    normal_pressure: float = si("Pa", math.nan, kind="pressure", doc="gas only: pressure of the normal conditions "
                                "of the density, Pavlenko (2014), Eq. (2.128)")


@dataclass(frozen=True)
class Impeller(SIParams):
    """Last-stage impeller data for the axial-force ratio b (Pavlenko (2014), Eq. (2.18), App. A).

    Attributes
    ----------
    hub_radius, shroud_radius, outer_radius : float
        R0, R1, R2, m.
    stages : int
        Number of stages i.
    speed : float
        Angular speed, rad/s.
    """

    hub_radius: float = si("m", kind="length", doc="hub radius R0")
    shroud_radius: float = si("m", kind="length", doc="shroud seal radius R1")
    outer_radius: float = si("m", kind="length", doc="impeller outer radius R2")
    stages: int = si("", doc="number of stages, 1 to 100", ge=1, le=100)
    speed: float = si("rad/s", kind="angular speed", doc="rotational speed")


@dataclass(frozen=True)
class Operating(SIParams):
    """Nominal operating data of the machine; the bases p_B and s_B of the dimensionless groups.

    Attributes
    ----------
    nominal_pressure : float
        p_n = p_B, Pa.
    nominal_thrust : float
        T_n, N; s_B = T_n / p_B.
    drain_pressure : float
        p4, Pa.
    thrust_ratio : float
        b in tau = b psi1 (dimensionless); NaN: computed from ``impeller``.
    impeller : Impeller or None
        Impeller data for b.
    nominal_flow : float
        Q_n, m^3/s (NaN if unknown; only for reporting Q_e / Q_n).
    """

    nominal_pressure: float = si("Pa", kind="pressure", doc="nominal discharge pressure p_n = p_B, the pressure base")
    nominal_thrust: float = si("N", kind="force", doc="nominal axial thrust T_n; the area base is s_B = T_n / p_n")
    drain_pressure: float = si("Pa", 0.0, kind="pressure", doc="drain pressure p4 behind the outer seal", ge=0)
    thrust_ratio: float = si("", math.nan, doc="b in tau = b psi1, dimensionless; computed from the impeller when "
                             "omitted", gt=0, le=BIG)
    impeller: Impeller | None = section("impeller data, to compute thrust_ratio", None)
    nominal_flow: float = si("m**3/s", math.nan, kind="volume flow", doc="nominal flow Q_n of the machine, for "
                             "Q_e / Q_n")

    def __post_init__(self):
        if numbers(self.thrust_ratio) and math.isnan(self.thrust_ratio) and self.impeller is None:
            raise ValueError("give thrust_ratio (b) or impeller data to compute it")


@dataclass(frozen=True)
class InnerSeal(SIParams):
    """Laminar annular bushing seal, g1 = pi d h^3 / (12 mu l).

    Attributes
    ----------
    diameter, length, clearance : float
        d, l, h, m.
    """

    diameter: float = si("m", kind="length", doc="seal diameter d1")
    length: float = si("m", kind="length", doc="seal length l1")
    clearance: float = si("m", kind="length", doc="radial clearance h1")


@dataclass(frozen=True)
class OuterSeal(SIParams):
    """Square-root-law annular seal, zeta = zeta_local + lambda l / (2h).

    Attributes
    ----------
    diameter, length, clearance : float
        d, l, h, m.
    local_loss : float
        zeta_local, dimensionless.
    friction : float
        lambda, dimensionless.
    """

    diameter: float = si("m", kind="length", doc="seal diameter d3")
    length: float = si("m", kind="length", doc="seal length l3")
    clearance: float = si("m", kind="length", doc="radial clearance h3")
    local_loss: float = si("", 1.5, doc="local loss coefficient zeta_local, dimensionless", ge=0, le=BIG)
    friction: float = si("", 0.06, doc="friction factor lambda, dimensionless", gt=0, le=BIG)


@dataclass(frozen=True)
class Face(SIParams):
    """Face throttle between the disc and the pad; conductance g_TB u^(3/2), u = z/z_B.

    The base gap z_B is the normalising base of the face law, not a second gap: g_TB is proportional to
    z_B^(3/2) (flow area times 1/sqrt(zeta_TB), both set at z_B), so g_TB (z/z_B)^(3/2) is one function of the
    physical gap z whatever z_B is (Pavlenko (2014), App. A).

    Attributes
    ----------
    inner_diameter, outer_diameter : float
        d2, d3, m.
    base_gap : float
        z_B, m: the base of u = z/z_B (and the gap at which the rotor damping c_z is given).
    friction : float
        lambda_T, dimensionless.
    """

    inner_diameter: float = si("m", kind="length", doc="inner diameter of the face annulus")
    outer_diameter: float = si("m", kind="length", doc="outer diameter of the face annulus; larger than "
                               "inner_diameter")
    base_gap: float = si("m", kind="length", doc="base face gap z_B = h_TB: the normalising base of the face "
                         "law g_TB (z/z_B)^(3/2), u = z/z_B; g_TB scales as z_B^(3/2), so changing z_B alone "
                         "changes neither the operating gap z0 nor the leakage. device.dynamics.rotor_damping "
                         "is given at this gap: scale it by (old/new)^3 to keep the device's squeeze film")
    friction: float = si("", 0.06, doc="friction factor lambda of the face gap, dimensionless", gt=0, le=BIG)

    def __post_init__(self):
        if numbers(self.outer_diameter, self.inner_diameter) and self.outer_diameter <= self.inner_diameter:
            raise ValueError("outer_diameter must be larger than inner_diameter")


@dataclass(frozen=True)
class Disc(SIParams):
    """The balancing disc: inner seal, face throttle, outer seal and the push-off spring (preload F_pr, N)."""

    inner_seal: InnerSeal = section("laminar inner seal (throttle 1)")
    face: Face = section("face throttle (throttle T)")
    outer_seal: OuterSeal = section("square-root-law outer seal (throttle 3)")
    pushoff_force: float = si("N", 0.0, kind="force", doc="push-off spring force F_pr", ge=0)

    def __post_init__(self):
        d1, d2 = self.inner_seal.diameter, self.face.inner_diameter
        if numbers(d1, d2) and d1 >= d2:
            raise ValueError("inner_seal.diameter must be smaller than face.inner_diameter")


@dataclass(frozen=True)
class Tube(SIParams):
    """Laminar round tube, g = pi d^4 / (192 mu l) (the source's coefficient): diameter and length, m."""

    diameter: float = si("m", kind="length", doc="bore diameter")
    length: float = si("m", kind="length", doc="tube length")


@dataclass(frozen=True)
class Barrier(SIParams):
    """The barrier chamber fed through a supply throttle at a regulated margin dpsi = (p_e - p1)/p_B above
    discharge."""

    supply_throttle: Tube = section("laminar supply throttle e")
    margin_ratio: float = si("", doc="regulator set-point dpsi = (p_e - p1) / p_B, dimensionless, 0 to 10",
                             gt=0, le=10)


@dataclass(frozen=True)
class Valve(SIParams):
    """The regulator's valve (an orifice).

    Attributes
    ----------
    seat_diameter : float
        d_c, m.
    base_opening : float
        x_B, m.
    discharge_coefficient : float
        phi, dimensionless.
    max_opening : float
        Travel limit, m; inf: unlimited.
    """

    seat_diameter: float = si("m", kind="length", doc="valve seat diameter d_c")
    base_opening: float = si("m", kind="length", doc="base valve opening x_B, the opening base")
    discharge_coefficient: float = si("", 0.54, doc="discharge coefficient, 0 to 1", gt=0, le=1)
    max_opening: float = si("m", math.inf, kind="length", doc="valve travel limit; unlimited when omitted")


@dataclass(frozen=True)
class Regulator(SIParams):
    """Pressure-drop regulator that holds the barrier pressure at a margin above discharge: supply pressure
    p_in (Pa), inlet throttle, valve, membrane area s_m (m^2)."""

    supply_pressure: float = si("Pa", kind="pressure", doc="supply pressure p_in of the regulator")
    inlet_throttle: Tube = section("laminar inlet throttle")
    valve: Valve = section("the valve")
    membrane_area: float = si("m**2", kind="area", doc="membrane area s_m")


@dataclass(frozen=True)
class DeviceParams(SIParams):
    """A locking-balancing device in SI (Pavlenko (2014), Fig. 2.1, App. A/B).

    Attributes
    ----------
    medium : str
        "liquid" (pump) or "gas" (compressor).
    fluid, operating, disc, barrier, regulator
        The parts (see their classes); ``regulator`` None: an ideal barrier supply.
    dynamics : DynamicData or None
        Masses, springs, damping and volumes for the dynamic analyses (models/dynamics.py).
    """

    medium: str = section("working medium: liquid (pump) or gas (compressor)", choices=("liquid", "gas"))
    fluid: Fluid = section("fluid properties")
    operating: Operating = section("nominal operating data and bases")
    disc: Disc = section("the balancing disc")
    barrier: Barrier = section("the barrier chamber")
    regulator: Regulator | None = section("pressure-drop regulator; none: the barrier at a fixed margin", None)
    dynamics: DynamicData | None = None

    def __post_init__(self):
        p_n = self.fluid.normal_pressure
        if self.medium == "gas" and numbers(p_n) and math.isnan(p_n):
            raise ValueError("fluid.normal_pressure is required for a gas (Pa, e.g. '0.1 MPa')")


@dataclass(frozen=True)
class RegulatorGroups:
    """Dimensionless groups of the pressure-drop regulator (2.18)."""

    sigma_m: float  # membrane area / s_B
    psi_in: float  # supply pressure / p_B
    alpha_in1: float  # inlet throttle g_in / g1 (laminar)
    alpha_B1: float  # valve g_B / (g1 sqrt(p_B)) (orifice, liquid law in both media)
    xi_max: float = math.inf  # valve travel limit x_max / x_B


@dataclass(frozen=True)
class DeviceGroups:
    """Dimensionless groups (2.18) of the disc and its flow network."""

    medium: str  # "liquid" (pump, (2.19)) or "gas" (compressor, (2.137))
    sigma: float  # s_e / s_B
    chi: float  # push-off preload F_pr / (p_B s_B)
    b: float  # tau = b psi1, axial force law
    psi4: float  # drain pressure / p_B
    alpha_TB1: float  # face throttle at u = 1
    alpha_31: float  # outer seal
    alpha_e1: float  # barrier supply throttle (laminar)
    regulator: RegulatorGroups | None = None

    @property
    def square_root_law(self) -> str:
        return "turbulent" if self.medium == "liquid" else "gas_turbulent"


def _group_names(cls) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls) if f.name not in ("medium", "regulator", "xi_max"))


# The dimensionless groups (2.18) by name: every list of groups in the toolkit derives from these.
DEVICE_GROUPS = _group_names(DeviceGroups)  # sigma, chi, b, psi4, alpha_TB1, alpha_31, alpha_e1
REGULATOR_GROUPS = _group_names(RegulatorGroups)  # sigma_m, psi_in, alpha_in1, alpha_B1
# the groups that are boundary pressures (drain, regulator supply), not properties of the device itself
PRESSURE_GROUPS = ("psi4", "psi_in")


def groups_by_name(groups: DeviceGroups) -> dict:
    """Group name -> value of every dimensionless group of the device (DEVICE_GROUPS and, with a
    regulator, REGULATOR_GROUPS)."""
    out = {k: getattr(groups, k) for k in DEVICE_GROUPS}
    if groups.regulator is not None:
        out |= {k: getattr(groups.regulator, k) for k in REGULATOR_GROUPS}
    return out


def network(groups: DeviceGroups, g: dict, psi1, dpsi, v: dict) -> dict:
    """Throttle flows of the device's flow network (Pavlenko (2014), Eqs. (2.15), (2.136)).

    Parameters
    ----------
    groups : DeviceGroups
        The device (medium, regulator present or not).
    g : dict
        Group name -> value (numbers or CasADi symbols): the fields of DeviceGroups and, with a
        regulator, of RegulatorGroups.
    psi1, dpsi
        Discharge pressure p1/p_B and barrier margin (p_e - p1)/p_B (dimensionless).
    v : dict
        The pressures and coordinates: psi2, psi3, u (face gap z/z_B) and, with a regulator,
        psi_e, psi_cam, xi (valve opening x/x_B).

    Returns
    -------
    dict
        Throttle name -> dimensionless flow q = Q/(g1 p_B): "e" (barrier supply, e -> 2), "1" (inner
        seal, 2 -> discharge), "T" (face, 2 -> 3), "3" (outer seal, 3 -> drain) and, with a
        regulator, "in" (inlet, supply -> valve chamber) and "valve" (valve chamber -> e).  The face
        and the valve pass no flow when closed (u <= 0, xi <= 0).
    """
    root = groups.square_root_law
    psi_e = v["psi_e"] if groups.regulator is not None else psi1 + dpsi
    q = {
        "e": flow("laminar", g["alpha_e1"], psi_e, v["psi2"]),
        "1": flow("laminar", 1.0, v["psi2"], psi1),
        "T": face_opening(v["u"]) * flow(root, g["alpha_TB1"], v["psi2"], v["psi3"]),
        "3": flow(root, g["alpha_31"], v["psi3"], g["psi4"]),
    }
    if groups.regulator is not None:
        q["in"] = flow("laminar", g["alpha_in1"], g["psi_in"], v["psi_cam"])
        # valve: liquid orifice law in both media (2.137), App. B
        q["valve"] = valve_opening(v["xi"]) * flow("turbulent", g["alpha_B1"], v["psi_cam"], psi_e)
    return q


@dataclass
class StaticSystem:
    """The static equations as CasADi Functions of (w, psi1, dpsi).

    ``residual`` returns the balances (zero at a solution); ``complementarity`` the sum of
    stop gap x reaction (zero at a solution); ``flows`` the throttle flows q in the order of
    ``throttles`` and the pressures (psi_e, psi2, psi3, psi_cam or NaN).  ``stops`` maps each
    reaction to (coordinate, its value on the stop, side): gap = side (coordinate - stop) >= 0.
    """

    groups: DeviceGroups
    unknowns: list[str]
    lower: list[float]
    upper: list[float]
    equations: list[str]
    throttles: list[str]
    residual: ca.Function
    flows: ca.Function
    complementarity: ca.Function
    stops: dict = field(default_factory=dict)

    def index(self, name: str) -> int:
        return self.unknowns.index(name)

    def fixed_by_stops(self, active=frozenset()) -> dict:
        """Unknowns a set of stops fixes: for a stop in ``active`` its coordinate on the stop,
        for every other stop its reaction at zero (name -> value)."""
        return {c if r in active else r: (at if r in active else 0.0) for r, (c, at, _) in self.stops.items()}

    def stiffness(self, J, active=frozenset(), sigma=None):
        """Static stiffness kappa_s = -d phi/du at fixed psi1, phi = sigma (psi2 - psi3), Pavlenko (2014),
        Eq. (2.33): the implicit-function derivative of every balance but the disc's force balance.

        Parameters
        ----------
        J : numpy.ndarray or CasADi matrix
            Jacobian of ``residual`` with respect to the unknowns at a solution.
        active : set of str
            Stops the solution rests on (their coordinates are held); the other reactions are zero.
        sigma : float or CasADi expression, optional
            The disc area ratio s_e/s_B where it is a design symbol; default: the groups' own.

        Returns
        -------
        float or CasADi expression
            kappa_s, dimensionless (force over p_B s_B per unit u = z/z_B).
        """
        eqs = [i for i, e in enumerate(self.equations) if e != "disc force"]
        held = {"u", "r_contact"} | {self.stops[r][0] if r in active else r for r in self.stops if r != "r_contact"}
        cols = [i for i, k in enumerate(self.unknowns) if k not in held]
        iu = self.index("u")
        if isinstance(J, ca.SX | ca.MX | ca.DM):
            dx = -ca.solve(J[eqs, cols], J[eqs, iu])
        else:
            J = np.asarray(J)
            dx = -np.linalg.solve(J[np.ix_(eqs, cols)], J[eqs, iu])
        names = [self.unknowns[i] for i in cols]
        sigma = self.groups.sigma if sigma is None else sigma
        return -sigma * (dx[names.index("psi2")] - dx[names.index("psi3")])


def static_system(groups: DeviceGroups, parameters=()) -> StaticSystem:
    """Build the static equations of the device described by ``groups``.

    ``parameters`` names groups (fields of DeviceGroups or RegulatorGroups, e.g. "alpha_TB1",
    "psi_in"; not "medium" or "xi_max") that become a symbolic input ``theta``: then
    ``residual(w, psi1, dpsi, theta)`` and ``flows(w, psi1, dpsi, theta)``, for mapping the
    statics over parameter samples and exact parametric derivatives.
    """
    reg = groups.regulator
    theta = ca.SX.sym("theta", len(parameters))
    g = {f.name: getattr(groups, f.name) for f in dataclasses.fields(DeviceGroups)}
    rg = {f.name: getattr(reg, f.name) for f in dataclasses.fields(RegulatorGroups)} if reg is not None else {}
    for i, name in enumerate(parameters):
        target = rg if name in rg else g
        if name not in target or name in ("medium", "regulator", "xi_max"):
            raise ValueError(f"{name!r} is not a parameter of this device's static model")
        target[name] = theta[i]

    inf = math.inf
    unknowns = {"psi2": (0, inf), "psi3": (0, inf), "u": (0, inf), "r_contact": (0, inf)}
    stops = {"r_contact": ("u", 0.0, 1.0)}  # reaction: (coordinate, stop, side)
    if reg is not None:
        unknowns |= {"psi_e": (0, inf), "psi_cam": (0, inf), "xi": (0, reg.xi_max)}
        if math.isfinite(reg.xi_max):
            unknowns["r_valve"] = (0, inf)
            stops["r_valve"] = ("xi", reg.xi_max, -1.0)
    names = list(unknowns)
    w = ca.SX.sym("w", len(names))
    v = {n: w[i] for i, n in enumerate(names)}
    psi1 = ca.SX.sym("psi1")
    dpsi = ca.SX.sym("dpsi")
    psi_e = v["psi_e"] if reg is not None else psi1 + dpsi
    q = network(groups, g | rg, psi1, dpsi, v)  # (2.15)/(2.136): name -> q
    eqs = {
        "disc force": g["sigma"] * (v["psi2"] - v["psi3"]) + g["chi"] + v["r_contact"] - g["b"] * psi1,
        "chamber 2 flow": q["e"] - q["1"] - q["T"],
        "chamber 3 flow": q["T"] - q["3"],
    }
    if reg is not None:
        eqs["membrane force"] = rg["sigma_m"] * (psi_e - psi1 - dpsi) + v.get("r_valve", 0)
        eqs["valve chamber flow"] = q["in"] - q["valve"]
        eqs["barrier chamber flow"] = q["valve"] - q["e"]

    nan = ca.SX(math.nan)
    outputs = ca.vertcat(psi_e, v["psi2"], v["psi3"], v["psi_cam"] if reg is not None else nan)
    args, arg_names = [w, psi1, dpsi], ["w", "psi1", "dpsi"]
    if parameters:
        args, arg_names = args + [theta], arg_names + ["theta"]
    return StaticSystem(
        groups=groups,
        unknowns=names,
        lower=[float(lo) for lo, _ in unknowns.values()],
        upper=[float(hi) for _, hi in unknowns.values()],
        equations=list(eqs),
        throttles=list(q),
        residual=ca.Function("static_residual", args, [ca.vertcat(*eqs.values())], arg_names, ["r"]),
        flows=ca.Function("static_flows", args, [ca.vertcat(*q.values()), outputs], arg_names, ["q", "psi"]),
        complementarity=ca.Function("stop_complementarity", [w], [sum(
            v[r] * side * (v[coord] - at) for r, (coord, at, side) in stops.items())]),
        stops=stops,
    )


@dataclass(frozen=True)
class DeviceDesign:
    """A device's dimensionless groups with the SI scales and conductances they came from.

    ``scales``: p_B (Pa), s_B (m^2), z_B (m), x_B (m), g1 (m^3/(Pa s)), Q_scale = g1 p_B
    (m^3/s), s_e (m^2), Q_n (m^3/s or NaN).  ``conductances``: g1, g3, g_TB, g_e, g_in, g_B
    in their SI units (see models/throttles.py).
    """

    groups: DeviceGroups
    dpsi: float  # barrier margin (p_e - p1)/p_B, the regulator set-point
    scales: dict
    conductances: dict
    extra: dict


def axial_force_ratio(density: float, impeller: Impeller, nominal_pressure: float) -> float:
    """Axial-force ratio b of the impeller (Pavlenko (2014), App. A).

    b = 1 - rho w^2 R2^2 i / (8 p_n) (1 - (R1^2 + R0^2) / (2 R2^2)).

    Parameters
    ----------
    density : float
        kg/m^3.
    impeller : Impeller
        Radii (m), stages, speed (rad/s).
    nominal_pressure : float
        p_n, Pa.

    Returns
    -------
    float
        b, dimensionless.
    """
    r0, r1, r2 = impeller.hub_radius, impeller.shroud_radius, impeller.outer_radius
    head = density * impeller.speed**2 * r2**2 * impeller.stages / (8.0 * nominal_pressure)
    return 1.0 - head * (1.0 - (r1**2 + r0**2) / (2.0 * r2**2))


def face_area(face: Face) -> float:
    """Face throttle area s_T = pi (r3^2 - r2^2), m^2 (Pavlenko (2014), Eq. (2.5))."""
    return math.pi * ((face.outer_diameter / 2) ** 2 - (face.inner_diameter / 2) ** 2)


def design(device: DeviceParams) -> DeviceDesign:
    """Dimensionless groups of a device (Pavlenko (2014), Eqs. (2.16), (2.18), (2.135), (2.137)).

    The one place the groups and the scales are computed from the SI parameters, numerically and
    symbolically: the geometry and loss fields of the throttles (clearances, lengths, diameters, loss
    coefficients, the face base gap z_B, the valve base opening x_B), the margin, the supply pressure
    and the membrane area may be CasADi expressions, and so are then the groups and the scales they
    enter (g1, z_B, x_B, s_e, Q_scale; a design NLP gets their exact derivatives).  The pressure and
    force scales p_B, s_B (and the axial-force ratio b) must stay numbers.

    Parameters
    ----------
    device : DeviceParams
        The device in SI (numbers, or CasADi expressions as above).

    Returns
    -------
    DeviceDesign
        Groups, barrier margin dpsi, SI scales (p_B Pa, s_B m^2, z_B m, x_B m, g1 m^3/(Pa s),
        Q_scale m^3/s, s_e m^2, Q_n m^3/s) and conductances in SI.
    """
    fl, op, disc, medium = device.fluid, device.operating, device.disc, device.medium
    p_n = fl.normal_pressure
    p_b = op.nominal_pressure
    s_b = op.nominal_thrust / p_b
    inner, face, outer = disc.inner_seal, disc.face, disc.outer_seal
    r_u1, r2 = inner.diameter / 2, face.inner_diameter / 2
    s_t = face_area(face)
    s_e = math.pi * (r2**2 - r_u1**2) + 0.5 * s_t  # (2.5)

    g1 = th.laminar_annulus(inner.diameter, inner.clearance, inner.length, fl.viscosity)
    zeta3 = th.annulus_loss(outer.local_loss, outer.friction, outer.length, outer.clearance)
    g3 = th.turbulent(math.pi * outer.diameter * outer.clearance, zeta3, fl.density, medium, p_n)
    zeta_tb = th.face_loss(face.friction, face.inner_diameter, face.outer_diameter, face.base_gap)
    f_tb = 0.5 * math.pi * (face.inner_diameter + face.outer_diameter) * face.base_gap
    g_tb = th.turbulent(f_tb, zeta_tb, fl.density, medium, p_n)
    sup = device.barrier.supply_throttle
    g_e = th.laminar_tube(sup.diameter, sup.length, fl.viscosity)
    # liquid square-root conductances carry sqrt(p_B) in their ratio, gas ones do not (2.18), (2.137)
    root_scale = math.sqrt(p_b) if medium == "liquid" else 1.0

    b_computed = (axial_force_ratio(fl.density, op.impeller, p_b) if op.impeller is not None else math.nan)
    b = op.thrust_ratio if math.isfinite(op.thrust_ratio) else b_computed
    cond = {"g1": g1, "g3": g3, "g_TB": g_tb, "g_e": g_e}
    extra = {"zeta_u3": zeta3, "zeta_TB": zeta_tb, "f_TB": f_tb, "s_T": s_t, "s_e": s_e,
             "b_from_impeller": b_computed}
    x_b = math.nan
    reg_groups = None
    if device.regulator is not None:
        reg = device.regulator
        g_in = th.laminar_tube(reg.inlet_throttle.diameter, reg.inlet_throttle.length, fl.viscosity)
        v = reg.valve
        g_b = th.orifice(v.discharge_coefficient, v.seat_diameter, v.base_opening, fl.density)
        x_b = v.base_opening
        cond |= {"g_in": g_in, "g_B": g_b}
        reg_groups = RegulatorGroups(
            sigma_m=reg.membrane_area / s_b,
            psi_in=reg.supply_pressure / p_b,
            alpha_in1=g_in / g1,
            alpha_B1=g_b / (g1 * math.sqrt(p_b)),  # valve: liquid orifice law in both media (2.137)
            xi_max=v.max_opening / x_b,
        )
    groups = DeviceGroups(
        medium=medium,
        sigma=s_e / s_b,
        chi=disc.pushoff_force / (p_b * s_b),
        b=b,
        psi4=op.drain_pressure / p_b,
        alpha_TB1=g_tb / (g1 * root_scale),
        alpha_31=g3 / (g1 * root_scale),
        alpha_e1=g_e / g1,
        regulator=reg_groups,
    )
    scales = {"p_B": p_b, "s_B": s_b, "z_B": face.base_gap, "x_B": x_b, "g1": g1, "Q_scale": g1 * p_b,
              "s_e": s_e, "Q_n": op.nominal_flow}
    return DeviceDesign(groups=groups, dpsi=device.barrier.margin_ratio, scales=scales,
                        conductances=cond, extra=extra)
