"""Nonlinear dynamics of the rotor - balancing device - regulator system (Pavlenko 2014, §2.4, §2.6).

Equations (2.37)-(2.40) (pump) and (2.167) (compressor): rotor axial motion, regulator stem,
chamber compressibility V/E and the displacement flows of the moving disc and membrane, with the
throttle laws of the statics (models/throttles.py).  Two forms of the chamber balances:

* ``"energy"`` (default): one balance per chamber, V_k/E dp_k/dt = inflow - outflow - dV_k/dt,
  with the volume changes that match the forces (a correction of the printed form): dV2/dz = +s_e, dV3/dz = -s_e (the
  disc moves into the cavity behind it when the gap opens), dV_e/dx = -s_m (the membrane force
  s_m (p_e - p1) closes the valve).  For the gas (compressor) the displacement flows are
  converted to normal volume flows with the chamber density, p_k / p_n (the throttle laws give
  normal m^3/s); the source's (2.167) has rho instead and (2.169) drops it.
* ``"chain"``: the printed chain form (2.38)/(2.40), explicit as (2.111) (reconstructed: xi, not
  xi^(3/2), liquid roots for the pump, g3 in the last line).  Kept to reproduce the source; its
  cavity 3 is never squeezed and its barrier chamber has the wrong sign of s_m dx/dt, both of
  which feed energy into the system.

The rotor's damping c_z is the squeeze film of the face throttle, c(z) = 1.5 mu s_T^2 / (pi z^3),
given by its value at the base gap z_B (Pavlenko (2014), App. A).  ``damping_gap`` chooses where the
film is evaluated: ``"instantaneous"`` (the default of the energy form) at the state gap z, c_z (z_B/z)^3
= c_z u^-3, which is the same force for every choice of the normalising base z_B (its linearisation is the
film at the operating gap z0); ``"base"`` (the default of the chain form, the source's) the constant c_z.

A device without a regulator (simplified system of §2.4.2) is the same model without the regulator
block: the barrier pressure is then ideal, psi_e = psi1 + dpsi.

Everything is dimensionless as in the statics: u = z/z_B, xi = x/x_B, psi = p/p_B, flows over
g1 p_B, forces over p_B s_B; time is in seconds.  Velocities are carried as v = t_ref du/dt and
w = t_ref dxi/dt with t_ref = sqrt(m_p/k_pr) so that every state is O(1).  The spring preloads are
Delta = F_pr/k_pr + z0 and Delta_reg = F_reg/k_reg + x0 (the preloads read so), so that the
equilibrium is exactly the static solution.  Inputs are w = (psi1, tau), tau = T/(p_B s_B).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import casadi as ca
import numpy as np

from autobal.models.device import DeviceDesign, groups_by_name, network
from autobal.models.params import BIG, SIParams, si

FORMS = ("energy", "chain")
# where the rotor's squeeze-film damping is evaluated, by default per chamber form: at the state gap z (the
# physical film) or at the base gap z_B (the source's constant c_z, kept with the printed form that reproduces it)
DAMPING_GAPS = {"energy": "instantaneous", "chain": "base"}
# dynamic data, in this order, as the symbolic parameter vector of the model
PARAM_NAMES = ("m_p", "k_pr", "c_z", "E", "V2", "V3", "m0", "k_reg", "c_x", "V_cam", "V_m", "s_c")
@dataclass(frozen=True)
class DynamicData(SIParams):
    """Dynamic data of a device in SI (Pavlenko (2014), App. A and App. B dynamic data).

    Regulator entries (m0, k_reg, c_x, V_cam, V_m, s_c, s_m) are NaN for a device without one.

    Attributes
    ----------
    m_p : float
        Rotor mass, kg.
    k_pr : float
        Push-off spring stiffness, N/m.
    c_z : float
        Rotor damping at the base gap z_B, N s/m (see :func:`squeeze_damping`); the energy form scales it
        to the instantaneous gap as the squeeze film, c_z (z_B/z)^3.
    E : float
        Bulk modulus of the barrier medium, Pa.
    V2, V3 : float
        Chamber before the face throttle and cavity behind the disc, m^3.
    m0 : float
        Regulator stem mass, kg.
    k_reg : float
        Regulator spring stiffness, N/m.
    c_x : float
        Stem damping, N s/m.
    V_cam, V_m : float
        Valve chamber and membrane (barrier) chamber, m^3.
    s_c, s_m : float
        Valve seat area and membrane area, m^2.
    p_n : float
        Gas: pressure of normal conditions, Pa (displacement flows of the energy form).
    forcing_amplitude : float
        delta psi_1a, amplitude of the harmonic discharge pressure, dimensionless.
    omega0 : float
        Operating speed, rad/s.
    """

    # the scene's device.dynamics section is derived from these declarations (autobal/parts/device_dynamics.py):
    # ``key`` is the scene's name, ``regulator.*`` its sub-section (required there, NaN without a regulator)
    m_p: float = si("kg", kind="mass", key="rotor_mass", doc="rotor mass m_p")
    k_pr: float = si("N/m", kind="stiffness", key="pushoff_stiffness",
                     doc="push-off spring stiffness k_pr; preload deflection F_pr/k_pr + z0")
    c_z: float = si("N*s/m", kind="damping", key="rotor_damping", scene_default=None, ge=0,
                    doc="rotor damping c_z at the base gap z_B (0: undamped); the energy-consistent model takes "
                    "it as the face's squeeze film at the instantaneous gap z, c_z (z_B/z)^3; default the "
                    "squeeze film 1.5 mu s_T^2/(pi z_B^3), Pavlenko (2014), App. A")
    E: float = si("Pa", kind="bulk modulus", key="bulk_modulus",
                  doc="bulk modulus E of the barrier medium (gas: the source's 1.42e5 Pa)")
    V2: float = si("m**3", kind="volume", key="disc_chamber_volume", doc="V2, chamber before the face throttle")
    V3: float = si("m**3", kind="volume", key="cavity_volume", doc="V3, cavity behind the disc")
    m0: float = si("kg", math.nan, kind="mass", key="regulator.stem_mass", scene_default=...,
                   doc="regulator stem mass m0")
    k_reg: float = si("N/m", math.nan, kind="stiffness", key="regulator.spring_stiffness", scene_default=...,
                      doc="regulator spring stiffness k_reg")
    c_x: float = si("N*s/m", math.nan, kind="damping", key="regulator.stem_damping", scene_default=0.0, ge=0,
                    doc="stem damping c_x (the source: 0)")
    V_cam: float = si("m**3", math.nan, kind="volume", key="regulator.valve_chamber_volume", scene_default=...,
                      doc="V_cam, valve chamber")
    V_m: float = si("m**3", math.nan, kind="volume", key="regulator.membrane_chamber_volume", scene_default=...,
                    doc="V_m, membrane (barrier) chamber")
    s_c: float = si("m**2", math.nan, kind="area", key="regulator.seat_area",
                    doc="valve seat area s_c; default pi d_c^2 / 4 from regulator.valve.seat_diameter")
    s_m: float = si("m**2", math.nan, kind="area", key="", doc="membrane area s_m (the device's regulator)")
    p_n: float = si("Pa", math.nan, kind="pressure", key="", doc="gas: pressure of normal conditions (the fluid's)")
    forcing_amplitude: float = si("", 0.2, doc="delta psi_1a, amplitude of the harmonic discharge pressure",
                                  gt=0, le=BIG)
    omega0: float = si("rad/s", math.nan, kind="angular speed", key="operating_speed",
                       doc="operating speed omega0; default the impeller speed")

    @property
    def has_regulator(self) -> bool:
        return math.isfinite(self.m0)

    def vector(self) -> np.ndarray:
        return np.array([getattr(self, k) for k in PARAM_NAMES], float)

    def with_(self, **changes) -> DynamicData:
        return replace(self, **changes)


# the dynamic parameters by their descriptive names (the scene's and the reports' names) -> short name
LONG_NAMES = {f.metadata["key"].rpartition(".")[2]: f.name for f in fields(DynamicData) if f.name in PARAM_NAMES}


def squeeze_damping(viscosity: float, face_area: float, gap: float) -> float:
    """Squeeze-film damping of the face throttle at the gap z, c = 1.5 mu s_T^2 / (pi z^3).

    Pavlenko (2014), App. A, evaluates it at the base gap z = z_B (c_z); the energy-consistent model
    carries it to the instantaneous gap as c_z (z_B/z)^3 (see :func:`build`).

    Parameters
    ----------
    viscosity : float
        mu, Pa s.
    face_area : float
        s_T, m^2.
    gap : float
        z, m (z_B for the scene's c_z).

    Returns
    -------
    float
        c, N s/m.
    """
    return 1.5 * viscosity * face_area**2 / (math.pi * gap**3)


@dataclass
class DynamicModel:
    """The nonlinear model as CasADi Functions, built once for one operating point.

    ``ode(x, w, p) -> dx/dt`` (1/s); ``rows(q, qd, qdd, w, p)`` the implicit balances in the
    order and sign convention of (2.43)/(2.101) with each chamber row divided by the coefficient of
    its own pressure (so the thesis's constants can be read off their Jacobians); ``flows(x, w)``
    the throttle flows.  ``x0``, ``w0``: the equilibrium (the static solution); ``p0``: the
    scene's dynamic data in the order of PARAM_NAMES.
    """

    form: str
    regulator: bool
    medium: str
    states: list[str]
    coords: list[str]  # q of the operator form: u, (xi, psi_cam, psi_e), psi2, psi3
    inputs: list[str]
    t_ref: float
    ode: ca.Function
    rows: ca.Function
    flows: ca.Function
    x0: np.ndarray
    w0: np.ndarray
    p0: np.ndarray
    design: DeviceDesign
    data: DynamicData
    point: dict = field(default_factory=dict)
    damping_gap: str = "instantaneous"

    def index(self, name: str) -> int:
        return self.states.index(name)

    def params(self, data: DynamicData | None = None) -> np.ndarray:
        return self.p0 if data is None else data.vector()


def build(dev: DeviceDesign, data: DynamicData, point: dict, form: str = "energy",
          preload: str = "static", symbols=None, values=None, damping_gap: str | None = None) -> DynamicModel:
    """Build the nonlinear model at the static ``point`` (Pavlenko (2014), Eqs. (2.40), (2.111), (2.167)).

    The throttle flows are those of the statics (:func:`autobal.models.device.network`).

    Parameters
    ----------
    dev : DeviceDesign
        The device's groups and SI scales (:func:`autobal.models.device.design`).
    data : DynamicData
        Masses, springs, damping and volumes in SI.
    point : dict
        psi1, dpsi and the static unknowns u, psi2, psi3 (and xi, psi_e, psi_cam with a regulator),
        e.g. ``StaticPoint.values | {"psi1": .., "dpsi": ..}`` (dimensionless).
    form : {"energy", "chain"}
        Chamber balances: energy-consistent (default) or the printed chain form (2.40).
    preload : {"static", "literal"}
        "static": Delta = F_pr/k_pr + z0, Delta_reg = F_reg/k_reg + x0, so the equilibrium is the static
        point; "literal": Delta = F_pr/k_pr as (2.37) reads, the equilibrium moves and is found by a
        Newton solve from the static point (it replaces ``point``).
    symbols : casadi.SX or None
        Design symbols: the groups and scales of ``dev`` (g1, z_B, x_B, s_e, ...) and the membrane area
        ``data.s_m`` may be CasADi expressions of these; every Function then takes them as a last input
        ``d`` (e.g. ``ode(x, w, p, d)``), so a design NLP differentiates the model exactly.  Only with
        ``preload="static"``.
    values : array_like, optional
        With ``symbols``: their nominal values, at which the chamber rows' normalisation (a constant
        per row, which the ODE does not see) is taken as a number; default: symbolic.
    damping_gap : {"instantaneous", "base"} or None
        Where the rotor's squeeze film is evaluated: "instantaneous", at the state gap z, force
        c_z (z_B/z)^3 dz/dt = c_z u^-3 dz/dt (independent of the normalising base z_B); "base", the constant
        c_z of Pavlenko (2014), App. A.  Default: ``DAMPING_GAPS[form]`` (energy: instantaneous, chain: base).

    Returns
    -------
    DynamicModel
        CasADi Functions of the model (time in s) and its equilibrium.
    """
    if form not in FORMS:
        raise ValueError(f"unknown chamber form {form!r}; expected one of {FORMS}")
    damping_gap = DAMPING_GAPS[form] if damping_gap is None else damping_gap
    if damping_gap not in ("instantaneous", "base"):
        raise ValueError(f"unknown damping gap {damping_gap!r}; expected 'instantaneous' or 'base'")
    if symbols is not None and preload != "static":
        raise ValueError("a model with design symbols takes preload='static' only")
    extra, extra_names = ([symbols], ["d"]) if symbols is not None else ([], [])
    g, sc = dev.groups, dev.scales
    reg = g.regulator
    if (reg is not None) != data.has_regulator:
        raise ValueError("dynamic data and device disagree on the regulator")
    gas = g.medium == "gas"
    p_b, s_b, z_b, x_b, g1 = sc["p_B"], sc["s_B"], sc["z_B"], sc["x_B"], sc["g1"]
    s_e = sc["s_e"]
    p_n = data.p_n
    t_ref = math.sqrt(data.m_p / data.k_pr)
    psi10, dpsi = float(point["psi1"]), float(point["dpsi"])
    u0 = float(point["u"])
    u_spring = u0 if preload == "static" else 0.0  # spring force k (Delta - z) = F_pr - k (z - u_spring z_B)

    p = ca.SX.sym("p", len(PARAM_NAMES))
    P = dict(zip(PARAM_NAMES, ca.vertsplit(p), strict=True))
    w = ca.SX.sym("w", 2)
    psi1, tau = w[0], w[1]
    coords = ["u", "xi", "psi_cam", "psi_e", "psi2", "psi3"] if reg else ["u", "psi2", "psi3"]
    n = len(coords)
    q, qd, qdd = ca.SX.sym("q", n), ca.SX.sym("qd", n), ca.SX.sym("qdd", n)
    Q = dict(zip(coords, ca.vertsplit(q), strict=True))
    Qd = dict(zip(coords, ca.vertsplit(qd), strict=True))
    Qdd = dict(zip(coords, ca.vertsplit(qdd), strict=True))
    force = p_b * s_b
    flow_scale = g1 * p_b

    def theta(vol):  # compliance time V / (E g1), s
        return vol / (P["E"] * g1)

    def density(psi):  # displacement flows as normal volume flows (gas, energy form)
        return psi * p_b / p_n if gas and form == "energy" else 1.0

    fl = network(g, groups_by_name(g), psi1, dpsi, Q)  # the flow network of the statics
    # rotor (2.37): m z'' + c z' + k (z - z0) = F - T + F_pr   [over p_B s_B]; c = c_z (z_B/z)^3 or c_z
    c_rotor = P["c_z"] / Q["u"] ** 3 if damping_gap == "instantaneous" else P["c_z"]
    rows = [(P["m_p"] * Qdd["u"] + c_rotor * Qd["u"] + P["k_pr"] * (Q["u"] - u_spring)) * z_b / force
            - (g.sigma * (Q["psi2"] - Q["psi3"]) - tau + g.chi)]
    d_e = s_e * z_b * Qd["u"] / flow_scale  # disc displacement flow s_e dz/dt
    comp = {k: theta(P[v]) * Qd[k] for k, v in (("psi2", "V2"), ("psi3", "V3"))}
    if reg:
        xi0 = float(point["xi"]) if preload == "static" else 0.0
        # stem (2.37): m0 x'' + c_x x' + k_reg (x - x0) = F_reg - s_m (p_e - p1), F_reg = s_m dp
        rows.append((P["m0"] * Qdd["xi"] + P["c_x"] * Qd["xi"] + P["k_reg"] * (Q["xi"] - xi0)) * x_b / force
                    + reg.sigma_m * (Q["psi_e"] - psi1 - dpsi))
        d_c = P["s_c"] * x_b * Qd["xi"] / flow_scale
        d_m = data.s_m * x_b * Qd["xi"] / flow_scale
        comp |= {"psi_cam": theta(P["V_cam"]) * Qd["psi_cam"], "psi_e": theta(P["V_m"]) * Qd["psi_e"]}
        if form == "chain":  # (2.40): every member of the chain equals the previous one
            link_c = fl["valve"] + comp["psi_cam"] + d_c
            link_e = fl["e"] + comp["psi_e"] + d_m
            balances = {"psi_cam": fl["in"] - link_c, "psi_e": link_c - link_e,
                        "psi2": link_e - (fl["1"] + fl["T"] + comp["psi2"] + d_e)}
        else:
            balances = {"psi_cam": fl["in"] - fl["valve"] - d_c * density(Q["psi_cam"]) - comp["psi_cam"],
                        "psi_e": fl["valve"] - fl["e"] + d_m * density(Q["psi_e"]) - comp["psi_e"],
                        "psi2": fl["e"] - fl["1"] - fl["T"] - d_e * density(Q["psi2"]) - comp["psi2"]}
    else:
        if form == "chain":
            balances = {"psi2": fl["e"] - (fl["1"] + fl["T"] + comp["psi2"] + d_e)}
        else:
            balances = {"psi2": fl["e"] - fl["1"] - fl["T"] - d_e * density(Q["psi2"]) - comp["psi2"]}
    if form == "chain":
        balances["psi3"] = (fl["T"] + comp["psi2"] + d_e) - (fl["3"] + comp["psi3"] + d_e)
    else:
        balances["psi3"] = fl["T"] - fl["3"] + d_e * density(Q["psi3"]) - comp["psi3"]
    # chamber rows in the thesis's normalisation: coefficient of the own pressure = +1
    q0 = [float(point[k]) for k in coords]
    w_eq = [psi10, g.b * psi10]
    for k in coords[1 + bool(reg):]:
        own = ca.Function("own", [q, qd, w, p, *extra], [ca.jacobian(balances[k], Q[k])])
        scale = own(q0, [0.0] * n, w_eq, data.vector(), *extra)
        if symbols is not None and values is not None:
            scale = ca.Function("own_d", [symbols], [scale])(values)
        rows.append(balances[k] / (scale if symbols is not None and values is None else float(scale)))

    R = ca.vertcat(*rows)
    rows_f = ca.Function("rows", [q, qd, qdd, w, p, *extra], [R], ["q", "qd", "qdd", "w", "p", *extra_names], ["r"])

    # explicit first-order form: the rows are affine in qdd (mechanics) and qd (chambers)
    vel = ["u", "xi"] if reg else ["u"]
    states = []
    for k in coords:
        states.append(k)
        if k in vel:
            states.append("v" if k == "u" else "w")
    x = ca.SX.sym("x", len(states))
    X = dict(zip(states, ca.vertsplit(x), strict=True))
    q_of_x = ca.vertcat(*[X[k] for k in coords])
    qd_known = {k: X["v" if k == "u" else "w"] / t_ref for k in vel}
    # unknowns: accelerations of the mechanical coords and rates of the pressures
    unk = ca.SX.sym("unk", n)
    qd_x = ca.vertcat(*[qd_known[k] if k in vel else unk[i] for i, k in enumerate(coords)])
    qdd_x = ca.vertcat(*[unk[i] if k in vel else 0 for i, k in enumerate(coords)])
    r_x = rows_f(q_of_x, qd_x, qdd_x, w, p, *extra)
    M = ca.jacobian(r_x, unk)
    sol = -ca.solve(M, ca.substitute(r_x, unk, ca.DM.zeros(n)))  # exact: r is affine in unk
    xdot = []
    for i, k in enumerate(coords):
        if k in vel:
            xdot += [qd_known[k], t_ref * sol[i]]
        else:
            xdot.append(sol[i])
    ode = ca.Function("ode", [x, w, p, *extra], [ca.vertcat(*xdot)], ["x", "w", "p", *extra_names], ["xdot"])
    fl_x = ca.substitute(ca.vertcat(*fl.values()), q, q_of_x)
    flows = ca.Function("flows", [x, w, *extra], [fl_x], ["x", "w", *extra_names], ["q"])

    vals = {"u": u0, "v": 0.0, "w": 0.0, "psi2": point["psi2"], "psi3": point["psi3"]}
    if reg:
        vals |= {"xi": point["xi"], "psi_e": point["psi_e"], "psi_cam": point["psi_cam"]}
    x0 = np.array([vals[k] for k in states], float)
    w0 = np.array([psi10, g.b * psi10], float)
    if preload != "static":  # the equilibrium of (2.37) with the literal preloads
        solver = ca.rootfinder("equilibrium", "newton", ca.Function("f", [x], [ode(x, w0, data.vector())]),
                               {"abstol": 1e-13})
        x0 = np.array(solver(x0)).ravel()
        point = dict(point) | {k: float(v) for k, v in zip(states, x0, strict=True) if k in coords}
    return DynamicModel(form=form, regulator=reg is not None, medium=g.medium, states=states, coords=coords,
                        inputs=["psi1", "tau"], t_ref=t_ref, ode=ode, rows=rows_f, flows=flows, x0=x0, w0=w0,
                        p0=data.vector(), design=dev, data=data, point=dict(point), damping_gap=damping_gap)

