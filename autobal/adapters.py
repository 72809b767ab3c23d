"""The one adapter layer: validated scene parts (pydantic, SI floats) -> the models' parameter objects.

The physics (:mod:`autobal.models`) never sees a schema object or a YAML path; this module is where
a scene's sections become plain frozen dataclasses in SI, with the scene's defaults filled in, and
where a missing or inconsistent section is reported with its YAML path.
"""

from __future__ import annotations

import dataclasses
import math

from autobal.errors import ScenarioError
from autobal.models import device as dv
from autobal.models import ross_rotor as rr
from autobal.models.dynamics import DynamicData, squeeze_damping
from autobal.models.liquid_balancer import System, n_from_decrement
from autobal.models.rotor import LiquidLayer, RotorParams


def _opt(v, default=math.nan) -> float:
    return default if v is None else v


def device(d) -> dv.DeviceParams:
    """The scene's ``device`` section as :class:`autobal.models.device.DeviceParams` (SI).

    Parameters
    ----------
    d : autobal.scenario.Device
        The validated section.

    Returns
    -------
    DeviceParams
        With ``dynamics`` when the section has ``device.dynamics``.
    """
    fl, op, disc = d.fluid, d.operating, d.disc
    imp = op.impeller
    params = dv.DeviceParams(
        medium=d.medium,
        fluid=dv.Fluid(density=fl.density, viscosity=fl.viscosity, normal_pressure=_opt(fl.normal_pressure)),
        operating=dv.Operating(
            nominal_pressure=op.nominal_pressure, nominal_thrust=op.nominal_thrust,
            drain_pressure=op.drain_pressure, thrust_ratio=_opt(op.thrust_ratio),
            impeller=None if imp is None else dv.Impeller(hub_radius=imp.hub_radius, shroud_radius=imp.shroud_radius,
                                                          outer_radius=imp.outer_radius, stages=imp.stages,
                                                          speed=imp.speed),
            nominal_flow=_opt(op.nominal_flow)),
        disc=dv.Disc(inner_seal=dv.InnerSeal(**disc.inner_seal.model_dump()), face=dv.Face(**disc.face.model_dump()),
                     outer_seal=dv.OuterSeal(**disc.outer_seal.model_dump()), pushoff_force=disc.pushoff_force),
        barrier=dv.Barrier(supply_throttle=dv.Tube(**d.barrier.supply_throttle.model_dump()),
                           margin_ratio=d.barrier.margin_ratio),
        regulator=None if d.regulator is None else _regulator(d.regulator),
    )
    if d.dynamics is None:
        return params
    return dataclasses.replace(params, dynamics=dynamic_data(d, params))


def _regulator(r) -> dv.Regulator:
    v = r.valve
    return dv.Regulator(supply_pressure=r.supply_pressure, inlet_throttle=dv.Tube(**r.inlet_throttle.model_dump()),
                        valve=dv.Valve(seat_diameter=v.seat_diameter, base_opening=v.base_opening,
                                       discharge_coefficient=v.discharge_coefficient,
                                       max_opening=_opt(v.max_opening, math.inf)),
                        membrane_area=r.membrane_area)


def dynamic_data(d, params: dv.DeviceParams) -> DynamicData:
    """The ``device.dynamics`` section with its defaults filled in (SI).

    Defaults: rotor damping the face's squeeze film (:func:`autobal.models.dynamics.squeeze_damping`),
    operating speed the impeller's, seat area pi d_c^2 / 4.

    Parameters
    ----------
    d : autobal.scenario.Device
        The validated ``device`` section (with ``dynamics``).
    params : DeviceParams
        The same device as parameters.

    Returns
    -------
    DynamicData
    """
    dyn = d.dynamics
    if dyn is None:
        raise ScenarioError("device.dynamics: the dynamic analyses need a dynamics section")
    if (d.regulator is None) != (dyn.regulator is None):
        raise ScenarioError("device.dynamics.regulator: give it exactly when the device has a regulator "
                            "(stem_mass, spring_stiffness, valve_chamber_volume, membrane_chamber_volume)")
    face = params.disc.face
    c_z = dyn.rotor_damping
    if c_z is None:
        c_z = squeeze_damping(params.fluid.viscosity, dv.face_area(face), face.base_gap)
    omega0 = dyn.operating_speed
    if omega0 is None:
        imp = params.operating.impeller
        omega0 = imp.speed if imp is not None else math.nan
    kw = {}
    if dyn.regulator is not None:
        r, reg = dyn.regulator, params.regulator
        s_c = r.seat_area if r.seat_area is not None else math.pi * reg.valve.seat_diameter**2 / 4
        kw = {"m0": r.stem_mass, "k_reg": r.spring_stiffness, "c_x": r.stem_damping,
              "V_cam": r.valve_chamber_volume, "V_m": r.membrane_chamber_volume, "s_c": s_c,
              "s_m": reg.membrane_area}
    return DynamicData(m_p=dyn.rotor_mass, k_pr=dyn.pushoff_stiffness, c_z=c_z, E=dyn.bulk_modulus,
                       V2=dyn.disc_chamber_volume, V3=dyn.cavity_volume, p_n=params.fluid.normal_pressure,
                       forcing_amplitude=dyn.forcing_amplitude, omega0=omega0, **kw)


def dynamic_device(scn) -> dv.DeviceParams:
    """The scene's device with its dynamic data, for the frequency, stability and transient analyses.

    Raises
    ------
    ScenarioError
        When the scene has no ``device`` or no ``device.dynamics``.
    """
    if scn.device is None or scn.device.dynamics is None:
        raise ScenarioError(f"{scn.name}: the dynamic analyses need device.dynamics (masses, springs, volumes)")
    return device(scn.device)


def design(d) -> dv.DeviceDesign:
    """The dimensionless groups of the scene's ``device`` section (:func:`autobal.models.device.design`)."""
    return dv.design(device(d))


def rotor(r) -> RotorParams:
    """The scene's ``rotor`` section as :class:`autobal.models.rotor.RotorParams` (SI).

    Parameters
    ----------
    r : autobal.schema_rotor.Rotor
        The validated section; a liquid layer is given by its chamber or by psi = m1/m.  From the datasheet:
        c = m1 Omega_c^2 (Omega_c the undamped critical speed without liquid), chi = 2 zeta sqrt(c m1)
        = 2 zeta m1 Omega_c, e = G/Omega_service (balance quality grade G, ISO 21940-11) or e = U/m1 (residual
        unbalance U).

    Returns
    -------
    RotorParams
    """
    m1 = r.mass
    c = r.stiffness if r.stiffness is not None else m1 * r.critical_speed**2
    chi = r.damping if r.damping is not None else 2 * r.damping_ratio * math.sqrt(c * m1)
    e = r.eccentricity
    if e is None:
        u = r.unbalance
        e = u.grade_m_s / u.service_speed if u.grade is not None else u.residual / m1
    p = RotorParams(m1=m1, c=c, chi=chi, e=e,
                    J_p=r.drive.polar_inertia if r.drive else 0.0, b=r.drive.drag if r.drive else 0.0)
    if r.liquid is None:
        return p
    if r.liquid.psi is not None:
        return p.with_psi(r.liquid.psi)
    return p.with_liquid(LiquidLayer(r.liquid.density, r.liquid.radius, r.liquid.height,
                                     r.liquid.free_surface_radius))


def liquid_balancer(part) -> System:
    """The scene's ``liquid_balancer`` section as :class:`autobal.models.liquid_balancer.System` (SI).

    The damping constant n is the section's ``damping_coefficient`` or, from the log decrement,
    n = theta omega_cr / (2 pi) (:func:`autobal.models.liquid_balancer.n_from_decrement`).
    """
    ro, ch, li = part.rotor, part.chamber, part.liquid
    n = ro.damping_coefficient if ro.damping_coefficient is not None else n_from_decrement(
        ro.log_decrement, ro.critical_speed)
    nest = part.nested
    return System(rotor_mass=ro.mass, chamber_mass=ch.mass, unbalance_mass=ro.unbalance_mass,
                  unbalance_radius=ro.unbalance_radius, omega_cr=ro.critical_speed, n=n, R=ch.radius,
                  h=ch.height, V=li.volume, rho=li.density, speed=part.speed, mu=li.viscosity,
                  stiffness=ro.stiffness,
                  inclination=None if ch.inclination_deg is None else math.radians(ch.inclination_deg),
                  nested_radii=tuple(c.radius for c in nest.chambers) if nest else (),
                  nested_volumes=tuple(c.volume for c in nest.chambers) if nest else (),
                  wall_thickness=nest.wall_thickness if nest else 0.0,
                  hub_radius=nest.hub_radius if nest else 0.0)


def ross_rotor(r):
    """The scene's ``ross_rotor`` section as :class:`autobal.models.ross_rotor.RossRotorSpec` (SI) and its
    unbalances.

    Parameters
    ----------
    r : autobal.schema_ross.RossRotor
        The validated section (phases in degrees).

    Returns
    -------
    (RossRotorSpec, tuple of Unbalance)
        Elements in SI; unbalance m e in kg m, phase in rad.
    """
    ub = tuple(rr.Unbalance(u.node, u.magnitude, math.radians(u.phase)) for u in r.unbalance)
    if r.example is not None:
        return rr.RossRotorSpec(example=r.example), ub
    m = r.material
    shaft = tuple(rr.Shaft(s.length, s.inner_diameter, s.outer_diameter) for s in r.shaft for _ in range(s.count))
    disks = tuple(rr.Disk(d.node, d.mass, d.diametral_inertia, d.polar_inertia) for d in r.disks)
    brgs = tuple(rr.Bearing(b.node, b.kxx, b.kxx if b.kyy is None else b.kyy, b.cxx, b.cxx if b.cyy is None else b.cyy,
                            b.kxy, b.kyx) for b in r.bearings)
    return rr.RossRotorSpec(shaft=shaft, disks=disks, bearings=brgs,
                            material=rr.Material(m.density, m.young_modulus, m.shear_modulus)), ub
