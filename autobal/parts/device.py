"""Scene part ``device``: the axial balancing device (Pavlenko (2014), ch. 2), its schema and its adapter to
:class:`autobal.models.device.DeviceParams` (SI).

The schema of ``device.dynamics`` is in :mod:`autobal.parts.device_dynamics`, built only when a scene has
that section (:func:`device_model`).  The physics (:mod:`autobal.models`) never sees a schema object or a
YAML path: :func:`adapt` is where the section becomes plain frozen dataclasses in SI, with the scene's
defaults filled in, and where a missing or inconsistent section is reported with its YAML path.
"""

from __future__ import annotations

import dataclasses
import math
from functools import cache
from typing import Annotated, Literal

from pydantic import Field, create_model, model_validator

from autobal.errors import ScenarioError
from autobal.models import device as dv
from autobal.models.dynamics import DynamicData, squeeze_damping
from autobal.schema import NonNegative, Positive, Strict
from autobal.units import (
    AngularSpeed,
    Area,
    Density,
    Force,
    ForceOrZero,
    Length,
    Pressure,
    PressureOrZero,
    Viscosity,
    VolumeFlow,
)

DESCRIPTION = "the axial balancing device (statics, dynamics, Monte Carlo, fits)"
DYNAMICS_DESCRIPTION = "masses, springs, volumes for the frequency, stability and transient analyses"


def _d(text: str, default=..., **kw):
    """A field with its meaning for the schema reference (units are added by the quantity types)."""
    return Field(default, description=text, **kw)


class Fluid(Strict):
    """The working fluid of the balancing device."""

    density: Density = _d("liquid density, or gas density at normal conditions (rho)")
    viscosity: Viscosity = _d("dynamic viscosity (mu)")
    normal_pressure: Pressure | None = _d("gas only: pressure of the normal conditions of the density, "
                                          "Pavlenko (2014), Eq. (2.128)", None)


class Impeller(Strict):
    """Impeller data for the axial-force ratio b, Pavlenko (2014), Eq. (2.18) and Appendix A."""

    hub_radius: Length = _d("hub radius R0")
    shroud_radius: Length = _d("shroud seal radius R1")
    outer_radius: Length = _d("impeller outer radius R2")
    stages: Annotated[int, Field(ge=1, le=100)] = _d("number of stages, 1 to 100")
    speed: AngularSpeed = _d("rotational speed")


class Operating(Strict):
    """Nominal operating data of the machine; the bases p_B and s_B of the dimensionless groups."""

    nominal_pressure: Pressure = _d("nominal discharge pressure p_n = p_B, the pressure base")
    nominal_thrust: Force = _d("nominal axial thrust T_n; the area base is s_B = T_n / p_n")
    nominal_flow: VolumeFlow | None = _d("nominal flow Q_n of the machine, for Q_e / Q_n", None)
    drain_pressure: PressureOrZero = _d("drain pressure p4 behind the outer seal", 0.0)
    thrust_ratio: Positive | None = _d("b in tau = b psi1, dimensionless; computed from the impeller when "
                                       "omitted", None)
    impeller: Impeller | None = _d("impeller data, to compute thrust_ratio", None)

    @model_validator(mode="after")
    def _b_given(self):
        if self.thrust_ratio is None and self.impeller is None:
            raise ValueError("give thrust_ratio (b) or impeller data to compute it")
        return self


class InnerSeal(Strict):
    """Laminar annular bushing seal, g1 = pi d h^3 / (12 mu l)."""

    diameter: Length = _d("seal diameter d1")
    length: Length = _d("seal length l1")
    clearance: Length = _d("radial clearance h1")


class OuterSeal(Strict):
    """Square-root-law annular seal, zeta = zeta_local + lambda l / (2h)."""

    diameter: Length = _d("seal diameter d3")
    length: Length = _d("seal length l3")
    clearance: Length = _d("radial clearance h3")
    local_loss: NonNegative = _d("local loss coefficient zeta_local, dimensionless", 1.5)
    friction: Positive = _d("friction factor lambda, dimensionless", 0.06)


class Face(Strict):
    """Face throttle between the disc and the pad; conductance g_TB u^(3/2)."""

    inner_diameter: Length = _d("inner diameter of the face annulus")
    outer_diameter: Length = _d("outer diameter of the face annulus; larger than inner_diameter")
    base_gap: Length = _d("base face gap z_B = h_TB, the gap base")
    friction: Positive = _d("friction factor lambda of the face gap, dimensionless", 0.06)

    @model_validator(mode="after")
    def _annulus(self):
        if self.outer_diameter <= self.inner_diameter:
            raise ValueError("outer_diameter must be larger than inner_diameter")
        return self


class Disc(Strict):
    """The balancing disc: inner seal, face throttle, outer seal and the push-off spring."""

    inner_seal: InnerSeal = _d("laminar inner seal (throttle 1)")
    face: Face = _d("face throttle (throttle T)")
    outer_seal: OuterSeal = _d("square-root-law outer seal (throttle 3)")
    pushoff_force: ForceOrZero = _d("push-off spring force F_pr", 0.0)

    @model_validator(mode="after")
    def _seal_inside_face(self):
        if self.inner_seal.diameter >= self.face.inner_diameter:
            raise ValueError("inner_seal.diameter must be smaller than face.inner_diameter")
        return self


class Tube(Strict):
    """Laminar round tube, g = pi d^4 / (192 mu l) (the source's coefficient)."""

    diameter: Length = _d("bore diameter")
    length: Length = _d("tube length")


class Barrier(Strict):
    """The barrier chamber fed through a supply throttle at a regulated margin above discharge."""

    supply_throttle: Tube = _d("laminar supply throttle e")
    margin_ratio: Annotated[float, Field(gt=0, le=10)] = _d(
        "regulator set-point dpsi = (p_e - p1) / p_B, dimensionless, 0 to 10")


class Valve(Strict):
    """The regulator's valve (an orifice)."""

    seat_diameter: Length = _d("valve seat diameter d_c")
    base_opening: Length = _d("base valve opening x_B, the opening base")
    discharge_coefficient: Annotated[float, Field(gt=0, le=1)] = _d("discharge coefficient, 0 to 1", 0.54)
    max_opening: Length | None = _d("valve travel limit; unlimited when omitted", None)


class Regulator(Strict):
    """Pressure-drop regulator that holds the barrier pressure at a margin above discharge."""

    supply_pressure: Pressure = _d("supply pressure p_in of the regulator")
    inlet_throttle: Tube = _d("laminar inlet throttle")
    valve: Valve = _d("the valve")
    membrane_area: Area = _d("membrane area s_m")


class DeviceParts(Strict):
    """The axial balancing device without its dynamics section (see :func:`device_model`)."""

    medium: Literal["liquid", "gas"] = _d("working medium: liquid (pump) or gas (compressor)")
    fluid: Fluid = _d("fluid properties")
    operating: Operating = _d("nominal operating data and bases")
    disc: Disc = _d("the balancing disc")
    barrier: Barrier = _d("the barrier chamber")
    regulator: Regulator | None = _d("pressure-drop regulator; none: the barrier at a fixed margin", None)

    @model_validator(mode="after")
    def _gas_needs_normal_pressure(self):
        if self.medium == "gas" and self.fluid.normal_pressure is None:
            raise ValueError("fluid.normal_pressure is required for a gas (Pa, e.g. '0.1 MPa')")
        return self


@cache
def device_model(dynamics: bool = True) -> type[DeviceParts]:
    """The ``Device`` model, with the schema of its ``dynamics`` section or (False) without it.

    Parameters
    ----------
    dynamics : bool
        Build the schema of ``device.dynamics`` (imports autobal.parts.device_dynamics).

    Returns
    -------
    type
        A pydantic model named ``Device``.
    """
    schema = None
    if dynamics:
        from autobal.parts.device_dynamics import Dynamics

        schema = Dynamics | None
    return create_model("Device", __base__=DeviceParts, __module__=__name__,
                        __doc__="The axial balancing device, Pavlenko (2014), ch. 2.",
                        dynamics=(schema, _d(DYNAMICS_DESCRIPTION, None)))



def _opt(v, default=math.nan) -> float:
    return default if v is None else v


def adapt(d) -> dv.DeviceParams:
    """The scene's ``device`` section as :class:`autobal.models.device.DeviceParams` (SI).

    Parameters
    ----------
    d : Device
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
    d : Device
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
    return adapt(scn.device)


def design(d) -> dv.DeviceDesign:
    """The dimensionless groups of the scene's ``device`` section (:func:`autobal.models.device.design`)."""
    return dv.design(adapt(d))
